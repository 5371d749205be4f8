// Shadow volumes → visibility. Area lights are sampled: one stencil pass per sample, averaged here
// as `sampled` averages its maps. With receiver cropping (CROP; Toromanoff 2005 alg. 12),
// receivers take their visibility from a shadow map instead. With MASKED, the alpha-masked
// casters, which have no volumes, shadow through a map of their own (mod.rs: the fallback).

// #include "resolve.wgsl"

struct VolumeSample {
    // xyz: the sample point (w = 0) or the unit direction towards it (w = 1).
    position: vec4<f32>,
    // xyz: sphere normal at the sample; w: 1 when the sample is weighted by projected area.
    normal: vec4<f32>,
    // x: sample index.
    index: vec4<u32>,
};

// The stencil, turned into a mask by stencil-tested draws (stencil.wgsl: mask_fs): 1 shadow,
// 0 lit, 0.5 a cropped receiver. (wgpu's GL backend cannot read stencil textures.)
// #ifdef MAPPED
// #include "maplookup.wgsl"
@group(2) @binding(0) var mask_texture: texture_2d<f32>;
@group(2) @binding(1) var<storage, read_write> accum: array<vec2<f32>>;
@group(2) @binding(2) var<uniform> sample: VolumeSample;
// #else
@group(1) @binding(0) var mask_texture: texture_2d<f32>;
@group(1) @binding(1) var<storage, read_write> accum: array<vec2<f32>>;
@group(1) @binding(2) var<uniform> sample: VolumeSample;
// #endif

// #ifdef MAPPED
// Whether the map (the receivers' or the masked casters') shadows this point.
fn map_shadows(s: Surface) -> bool {
    let mp = map_point(s.p, s.n, light_vector(light, s.p).xyz, 0u);
    return mp.on_map && map_tap(mp, vec2<f32>(0.0), mp.layer) < 0.5;
}
// #endif

fn in_shadow(s: Surface, pixel: vec2<u32>) -> bool {
    let m = textureLoad(mask_texture, vec2<i32>(pixel), 0).r;
// #ifdef CROP
    if (m > 0.25 && m < 0.75) {
        // A receiver: the shadow map decides.
        return map_shadows(s);
    }
// #endif
// #ifdef MASKED
    if (m < 0.75) {
        // Lit by the volumes: the alpha-masked casters' map may still shadow it.
        return map_shadows(s);
    }
// #endif
    return m > 0.75;
}

// This sample's visibility and weight at a relevant surface point.
fn sample_visibility(s: Surface, pixel: vec2<u32>) -> vec2<f32> {
    var to_sample = sample.position.xyz;
    if (sample.position.w < 0.5) {
        to_sample = sample.position.xyz - s.p;
    }
    var w = 1.0;
    if (sample.normal.w > 0.5) {
        w = max(dot(sample.normal.xyz, normalize(s.p - light.position.xyz)), 0.0);
    }
    // A sample behind the surface's tangent plane is hidden by the surface itself.
    let lit = w > 0.0 && dot(s.n, normalize(to_sample)) > 0.0 && !in_shadow(s, pixel);
    return vec2<f32>(select(0.0, w, lit), w);
}

// One sample: V directly.
@compute @workgroup_size(8, 8)
fn single(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = region_pixel(id);
    if (!in_frame(pixel)) {
        return;
    }
    let s = load_surface(pixel);
    var v = 1.0;
    if (s.relevant) {
        let a = sample_visibility(s, pixel);
        v = select(0.0, a.x / a.y, a.y > 0.0);
    }
    textureStore(visibility_out, pixel, vec4<f32>(v));
}

// Adds one sample (the first overwrites).
@compute @workgroup_size(8, 8)
fn accumulate(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = region_pixel(id);
    if (!in_frame(pixel)) {
        return;
    }
    let i = pixel.y * u32(camera.size.x) + pixel.x;
    var sum = vec2<f32>(0.0);
    if (sample.index.x > 0u) {
        sum = accum[i];
    }
    let s = load_surface(pixel);
    if (s.relevant) {
        sum = sum + sample_visibility(s, pixel);
    }
    accum[i] = sum;
}

@compute @workgroup_size(8, 8)
fn finish(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = region_pixel(id);
    if (!in_frame(pixel)) {
        return;
    }
    let i = pixel.y * u32(camera.size.x) + pixel.x;
    let s = load_surface(pixel);
    var v = 1.0;
    if (s.relevant) {
        let a = accum[i];
        v = select(0.0, a.x / a.y, a.y > 0.0);
    }
    textureStore(visibility_out, pixel, vec4<f32>(v));
}
