// The bindings every visibility-resolve shader shares (group 0), and the surface at a pixel.
// Technique-specific bindings go in group 1. Compute shaders write the layer (binding 4); with
// FRAGMENT (devices without compute: WebGL2) the layer is the render target instead, drawn by one
// triangle from `resolve_vs` (`per_pixel.wgsl` has both entry points).

// #include "common.wgsl"
// #include "lights.wgsl"

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var depth_texture: texture_2d<f32>;
@group(0) @binding(2) var normal_texture: texture_2d<f32>;
// The light: storage where compute runs (`util::branch_buffer`).
// #ifdef FRAGMENT
@group(0) @binding(3) var<uniform> light: Light;
// #else
@group(0) @binding(3) var<storage, read> light: Light;
// #endif
// #ifdef FRAGMENT
// Depths through a nearest sampler: WebGL2 reads 0 from a depth texture without one (context.rs:
// `Shared::nearest`).
@group(0) @binding(7) var nearest_sampler: sampler;

fn read_depth(pixel: vec2<u32>) -> f32 {
    let size = vec2<f32>(textureDimensions(depth_texture));
    return textureSampleLevel(depth_texture, nearest_sampler, (vec2<f32>(pixel) + 0.5) / size, 0.0).r;
}

// One triangle over the whole target; the render pass's scissor keeps to the region.
@vertex
fn resolve_vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}
// #else
@group(0) @binding(4) var visibility_out: texture_storage_2d<r32float, write>;

fn read_depth(pixel: vec2<u32>) -> f32 {
    return textureLoad(depth_texture, vec2<i32>(pixel), 0).r;
}
// #endif

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
    let depth = read_depth(pixel);
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
