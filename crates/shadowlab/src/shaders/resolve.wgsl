// The bindings every visibility-resolve compute shader shares (group 0), and the surface at a
// pixel. Technique-specific bindings go in group 1.

// #include "common.wgsl"
// #include "lights.wgsl"

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var depth_texture: texture_2d<f32>;
@group(0) @binding(2) var normal_texture: texture_2d<f32>;
@group(0) @binding(3) var<uniform> light: Light;
@group(0) @binding(4) var visibility_out: texture_storage_2d<r32float, write>;

// The pixels this dispatch covers: x, y the first; z, w width and height (the whole layer: 0, 0
// and unbounded). A resolve limited to a region (`FrameContext::region`) dispatches its size and
// takes pixels from `region_pixel`.
struct Region {
    rect: vec4<u32>,
};
@group(0) @binding(5) var<uniform> region: Region;
// The facets' own normals (the shading normals where the application gave none).
@group(0) @binding(6) var geometric_normal_texture: texture_2d<f32>;

fn region_pixel(id: vec3<u32>) -> vec2<u32> {
    return id.xy + region.rect.xy;
}

struct Surface {
    p: vec3<f32>,
    // The shading normal, facing the camera (the facet's own: `geometric_normal`).
    n: vec3<f32>,
    // The depth-buffer value.
    depth: f32,
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
    s.depth = depth;
    s.p = world_from_depth(camera, pixel, depth);
    s.n = normalize(textureLoad(normal_texture, vec2<i32>(pixel), 0).xyz);
    s.relevant = light_relevant(light, s.p, s.n);
    return s;
}

// The facet's own normal at a pixel, facing the camera: the plane the truth's rays leave from
// (DESIGN.md §3). The shading normal where it is missing.
fn geometric_normal(pixel: vec2<u32>, shading: vec3<f32>) -> vec3<f32> {
    let g = textureLoad(geometric_normal_texture, vec2<i32>(pixel), 0).xyz;
    if (!(dot(g, g) > 1.0e-12)) {
        return shading;
    }
    return normalize(g);
}

fn in_frame(pixel: vec2<u32>) -> bool {
    // Pixels come from `region_pixel`, so `pixel - origin` cannot wrap.
    let local = pixel - region.rect.xy;
    return f32(pixel.x) < camera.size.x && f32(pixel.y) < camera.size.y && local.x < region.rect.z
        && local.y < region.rect.w;
}
