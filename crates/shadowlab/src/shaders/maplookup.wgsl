// Lookups into a light's shadow map array (group 1 of map-based resolve shaders), with the
// receiver-side biases: an offset along the normal scaled to the texel size (normal-offset
// shadows, Holbert 2011) and a constant offset towards the light.

// #include "shadowmap.wgsl"

struct MapParams {
    // x: normal offset in texels; y: constant offset in world units; z: map size; w: 1 for cube maps.
    bias: vec4<f32>,
    // x: 1 for bilinear comparison taps, 0 for nearest.
    mode: vec4<f32>,
};

// #ifdef FRAGMENT
// No storage buffers without compute (WebGL2): a uniform array (`shadowmap::UNIFORM_VIEWS`).
@group(1) @binding(2) var<uniform> shadow_views: array<ShadowView, 16>;
// #else
@group(1) @binding(2) var<storage, read> shadow_views: array<ShadowView>;
// #endif
@group(1) @binding(3) var<uniform> map_params: MapParams;

struct MapPoint {
    uvz: vec3<f32>,
    // The view (index into `shadow_views`) the point falls in; its texture layer is `view_layer`.
    layer: u32,
    // World size of a texel at the point.
    texel: f32,
    on_map: bool,
};

// The texture layer that holds view `view`'s map.
fn view_layer(view: u32) -> i32 {
    return i32(shadow_views[view].range.z + 0.5);
}

// The view of `views_base + face` that covers p.
fn map_layer(p: vec3<f32>, views_base: u32) -> u32 {
    if (map_params.bias.w > 0.5) {
        return views_base + cube_face(p - shadow_views[views_base].eye.xyz);
    }
    return views_base;
}

// Where the biased receiver point of p (normal n, towards the light l) falls on the map.
fn map_point(p: vec3<f32>, n: vec3<f32>, l: vec3<f32>, views_base: u32) -> MapPoint {
    var mp: MapPoint;
    let first = map_layer(p, views_base);
    mp.texel = shadow_texel_size(shadow_views[first], p, map_params.bias.z);
    let q = p + n * (map_params.bias.x * mp.texel) + l * map_params.bias.y;
    mp.layer = map_layer(q, views_base);
    mp.uvz = shadow_project(shadow_views[mp.layer], q);
    mp.on_map = shadow_on_map(mp.uvz);
    return mp;
}

// #ifdef HARDWARE_COMPARE
// The hardware comparison sampler: nearest, or bilinear (2 × 2 PCF in one tap), by the sampler bound.
@group(1) @binding(0) var shadow_maps: texture_depth_2d_array;
@group(1) @binding(1) var shadow_sampler: sampler_comparison;

// One comparison of depth `z` at an offset of `offset` texels in view `layer`'s map; 1 = lit.
fn map_tap_z(mp: MapPoint, offset: vec2<f32>, layer: u32, z: f32) -> f32 {
    let uv = mp.uvz.xy + offset / map_params.bias.z;
    return textureSampleCompareLevel(shadow_maps, shadow_sampler, uv, view_layer(layer), z);
}

fn stored_depth(t: vec2<i32>, layer: u32) -> f32 {
    return textureLoad(shadow_maps, t, view_layer(layer), 0);
}

// `map_tap_z` with the bilinear ramp between texels narrowed to `ramp` texels: the comparison
// sampler's weights follow the point's fraction past the texel centre, so the point is moved
// within its 2 × 2 cell to where the plain weights are the narrowed ones.
fn map_tap_sharp(mp: MapPoint, offset: vec2<f32>, layer: u32, z: f32, ramp: f32) -> f32 {
    if (map_params.mode.x < 0.5 || ramp >= 1.0) {
        return map_tap_z(mp, offset, layer, z);
    }
    let s = mp.uvz.xy * map_params.bias.z + offset - vec2<f32>(0.5);
    let f = clamp((fract(s) - vec2<f32>(0.5)) / ramp + vec2<f32>(0.5), vec2<f32>(0.0), vec2<f32>(1.0));
    let uv = (floor(s) + f + vec2<f32>(0.5)) / map_params.bias.z;
    return textureSampleCompareLevel(shadow_maps, shadow_sampler, uv, view_layer(layer), z);
}
// #else
// Where comparison samplers of texture arrays do not work (wgpu's GL backend), the depths are read
// and compared in the shader, with the same nearest or bilinear weighting.
@group(1) @binding(0) var shadow_maps: texture_2d_array<f32>;

// 1 when the receiver depth `z` is at least as close to the light as the stored depth (reversed Z).
fn map_compare(texel: vec2<i32>, layer: u32, z: f32) -> f32 {
    let last = i32(map_params.bias.z) - 1;
    let t = clamp(texel, vec2<i32>(0), vec2<i32>(last));
    return select(0.0, 1.0, z >= stored_depth(t, layer));
}

// One comparison of depth `z` at an offset of `offset` texels in view `layer`'s map; 1 = lit.
fn map_tap_z(mp: MapPoint, offset: vec2<f32>, layer: u32, z: f32) -> f32 {
    return map_tap_sharp(mp, offset, layer, z, 1.0);
}

// `map_tap_z` with the bilinear ramp between texels narrowed to `ramp` texels (1: plain).
fn map_tap_sharp(mp: MapPoint, offset: vec2<f32>, layer: u32, z: f32, ramp: f32) -> f32 {
    let st = (mp.uvz.xy * map_params.bias.z) + offset;
    if (map_params.mode.x < 0.5) {
        return map_compare(vec2<i32>(floor(st)), layer, z);
    }
    let s = st - vec2<f32>(0.5);
    let base = vec2<i32>(floor(s));
    let f = clamp((s - floor(s) - vec2<f32>(0.5)) / max(ramp, 1.0e-3) + vec2<f32>(0.5), vec2<f32>(0.0), vec2<f32>(1.0));
    let c00 = map_compare(base, layer, z);
    let c10 = map_compare(base + vec2<i32>(1, 0), layer, z);
    let c01 = map_compare(base + vec2<i32>(0, 1), layer, z);
    let c11 = map_compare(base + vec2<i32>(1, 1), layer, z);
    return mix(mix(c00, c10, f.x), mix(c01, c11, f.x), f.y);
}

fn stored_depth(t: vec2<i32>, layer: u32) -> f32 {
// #ifdef FRAGMENT
    // Through the nearest sampler (resolve.wgsl): WebGL2 reads 0 from a depth texture without one.
    let size = vec2<f32>(textureDimensions(shadow_maps));
    return textureSampleLevel(shadow_maps, nearest_sampler, (vec2<f32>(t) + 0.5) / size, view_layer(layer), 0.0).r;
// #else
    return textureLoad(shadow_maps, t, view_layer(layer), 0).r;
// #endif
}
// #endif

// The stored depth at an offset of `offset` texels, nearest texel (PCSS's blocker search).
fn map_depth(mp: MapPoint, offset: vec2<f32>, layer: u32) -> f32 {
    let last = i32(map_params.bias.z) - 1;
    let t = clamp(vec2<i32>(floor(mp.uvz.xy * map_params.bias.z + offset)), vec2<i32>(0), vec2<i32>(last));
    return stored_depth(t, layer);
}

// One comparison tap at an offset of `offset` texels in view `layer`'s map; 1 = lit.
fn map_tap(mp: MapPoint, offset: vec2<f32>, layer: u32) -> f32 {
    return map_tap_z(mp, offset, layer, mp.uvz.z);
}

// Receiver-plane depth bias (Isidoro 2006, "Shadow Mapping: GPU-based Tips and Techniques", GDC):
// the change of the receiver's map depth per texel of offset, from two points of its tangent plane
// (p, n: the surface point and normal). Wide kernels compare each tap with the receiver's own depth
// there instead of the centre's, so planes do not shadow themselves. Zero where the plane is seen
// edge-on from the light.
fn receiver_plane_gradient(mp: MapPoint, p: vec3<f32>, n: vec3<f32>) -> vec2<f32> {
    let view = shadow_views[mp.layer];
    var t = cross(n, vec3<f32>(0.0, 1.0, 0.0));
    if (dot(t, t) < 1.0e-6) {
        t = cross(n, vec3<f32>(1.0, 0.0, 0.0));
    }
    t = normalize(t);
    let b = cross(n, t);
    let o = shadow_project(view, p);
    let a = (shadow_project(view, p + t * mp.texel) - o) * vec3<f32>(map_params.bias.z, map_params.bias.z, 1.0);
    let c = (shadow_project(view, p + b * mp.texel) - o) * vec3<f32>(map_params.bias.z, map_params.bias.z, 1.0);
    // Texel offset d = a.xy·k.x + c.xy·k.y changes depth by a.z·k.x + c.z·k.y: g = M⁻ᵀ (a.z, c.z).
    let det = a.x * c.y - c.x * a.y;
    if (abs(det) < 1.0e-3) {
        return vec2<f32>(0.0);
    }
    return vec2<f32>(c.y * a.z - a.y * c.z, a.x * c.z - c.x * a.z) / det;
}

// The receiver's plane for a filter: xy its depth change per texel of offset
// (`receiver_plane_gradient`), z the slope of the crease bias (`crease_slope`).
fn receiver_plane(mp: MapPoint, p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let g = receiver_plane_gradient(mp, p, n);
    return vec3<f32>(g, crease_slope(mp, p, g));
}

// The depth a filter tap must allow per texel of reach so that a concave crease stays lit: where
// the receiver's plane meets a perpendicular one (the ground at a wall's foot), a tap r texels
// away reads that other surface, closer to the light than the receiver's extrapolated plane by up
// to (tan α + cot α)·r texel widths, α the receiver's tilt from the map plane (2.1 under a 35°
// sun, 7.3 under 8°). Receiver-plane bias alone (Isidoro 2006) accounts for tan α only. `g`: the
// receiver-plane gradient, |g| = tan α texel widths of depth per texel; the tilt is taken as at
// most 83° (cot α ≥ 1/8) so that an edge-on plane does not bias without bound.
fn crease_slope(mp: MapPoint, p: vec3<f32>, g: vec2<f32>) -> f32 {
    let view = shadow_views[mp.layer];
    var ray = view.axis.xyz;
    if (view.eye.w < 0.5) {
        ray = normalize(p - view.eye.xyz);
    }
    // The depth of one texel width along the light's ray.
    let k = abs(shadow_project(view, p + ray * mp.texel).z - shadow_project(view, p).z);
    // (Written so that a degenerate step, zero or not a number, gives no bias rather than NaN.)
    if (!(k > 0.0)) {
        return 0.0;
    }
    let s = min(length(g), 8.0 * k);
    return s + k * k / max(s, k / 8.0);
}
