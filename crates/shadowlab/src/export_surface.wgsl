// Reads the surface back for the CPU reference: the same world positions the techniques
// reconstruct, the normals they use, and the geometric normals (relevance and ray offsets).

// #include "common.wgsl"

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var depth_texture: texture_2d<f32>;
@group(0) @binding(2) var normal_texture: texture_2d<f32>;
@group(0) @binding(3) var<storage, read_write> positions: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> normals: array<vec4<f32>>;
@group(0) @binding(5) var geometric_normal_texture: texture_2d<f32>;
@group(0) @binding(6) var<storage, read_write> geometric_normals: array<vec4<f32>>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (f32(id.x) >= camera.size.x || f32(id.y) >= camera.size.y) {
        return;
    }
    let i = id.y * u32(camera.size.x) + id.x;
    let depth = textureLoad(depth_texture, vec2<i32>(id.xy), 0).r;
    if (is_background(camera, depth)) {
        positions[i] = vec4<f32>(0.0);
        normals[i] = vec4<f32>(0.0);
        geometric_normals[i] = vec4<f32>(0.0);
        return;
    }
    positions[i] = vec4<f32>(world_from_depth(camera, id.xy, depth), 1.0);
    normals[i] = vec4<f32>(normalize(textureLoad(normal_texture, vec2<i32>(id.xy), 0).xyz), 0.0);
    geometric_normals[i] = vec4<f32>(textureLoad(geometric_normal_texture, vec2<i32>(id.xy), 0).xyz, 0.0);
}
