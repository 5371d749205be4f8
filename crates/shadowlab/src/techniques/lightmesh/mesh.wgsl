// `lightmesh`: the light mesh drawn from the camera marks the pixels it lights (Hasselgren 2003
// §3.1: "render lighting on the static geometry, i.e. the light mesh"). No depth buffer: a fragment
// counts where its piece is the visible surface of its pixel.

// #include "common.wgsl"

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var depth_texture: texture_2d<f32>;

// The light mesh's pieces lie in the planes of the triangles the G-buffer drew but are tessellated
// differently: a piece marks a pixel when its point on the pixel's view ray is the visible surface,
// within this fraction of the distance to the eye (depth-buffer round-off is ~1e-6 of it; contact
// creases closer than this may be marked lit).
const SAME_SURFACE: f32 = 2e-4;

struct MeshOut {
    @builtin(position) clip: vec4<f32>,
    // Position relative to the eye (precision far from the origin).
    @location(0) rel: vec3<f32>,
    // The light's visibility (fake soft shadows: per vertex, interpolated; 1 when hard).
    @location(1) v: f32,
};

@vertex
fn mesh_vs(@location(0) p: vec3<f32>, @location(1) v: f32) -> MeshOut {
    var out: MeshOut;
    out.clip = camera.view_proj * vec4<f32>(p, 1.0);
    out.rel = p - camera.position.xyz;
    out.v = v;
    return out;
}

@fragment
fn mesh_fs(v: MeshOut) -> @location(0) vec4<f32> {
    let pixel = vec2<u32>(v.clip.xy);
    let d = textureLoad(depth_texture, vec2<i32>(pixel), 0).r;
    if (is_background(camera, d)) {
        discard;
    }
    let surface = world_from_depth(camera, pixel, d) - camera.position.xyz;
    if (distance(surface, v.rel) > SAME_SURFACE * length(surface)) {
        discard;
    }
    // r: the visibility, g: marked (a visibility of 0 on the umbra's edge is still the light mesh).
    return vec4<f32>(clamp(v.v, 0.0, 1.0), 1.0, 0.0, 0.0);
}

