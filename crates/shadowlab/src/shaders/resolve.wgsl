// The bindings every visibility-resolve compute shader shares (group 0), and the surface at a
// pixel. Technique-specific bindings go in group 1.

// #include "common.wgsl"
// #include "lights.wgsl"

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var depth_texture: texture_2d<f32>;
@group(0) @binding(2) var normal_texture: texture_2d<f32>;
@group(0) @binding(3) var<uniform> light: Light;
@group(0) @binding(4) var visibility_out: texture_storage_2d<r32float, write>;

struct Surface {
    p: vec3<f32>,
    n: vec3<f32>,
    // The pixel shows geometry and the light may reach it (DESIGN.md §3).
    relevant: bool,
};

fn load_surface(pixel: vec2<u32>) -> Surface {
    var s: Surface;
    let depth = textureLoad(depth_texture, vec2<i32>(pixel), 0).r;
    if (is_background(camera, depth)) {
        s.relevant = false;
        return s;
    }
    s.p = world_from_depth(camera, pixel, depth);
    s.n = normalize(textureLoad(normal_texture, vec2<i32>(pixel), 0).xyz);
    s.relevant = light_relevant(light, s.p, s.n);
    return s;
}

fn in_frame(pixel: vec2<u32>) -> bool {
    return f32(pixel.x) < camera.size.x && f32(pixel.y) < camera.size.y;
}
