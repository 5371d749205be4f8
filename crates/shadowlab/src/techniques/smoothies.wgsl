// `smoothies`: the hard map's umbra, and outside it the smoothie buffer's ramp (Chan & Durand 2003;
// Toromanoff 2005, algorithm E).

// #include "resolve.wgsl"
// #include "maplookup.wgsl"
// #include "horizon.wgsl"

struct Smoothies {
    // x: the emitter's radius (perspective views) or tan of its angular radius (orthographic).
    params: vec4<f32>,
};

// Texels: the f32 bits of (distance from the silhouette, reversed-Z depth); cleared to zeros.
@group(2) @binding(0) var smoothie_buffer: texture_2d_array<u32>;
@group(2) @binding(1) var<uniform> smoothies: Smoothies;

// The smoothie's visibility at mp: its distance from the silhouette over the outer penumbra's
// width at its distance b for a receiver at r: R·(1 − b/r), or tan θ·(r − b) for the sun.
fn smoothie_visibility(mp: MapPoint) -> f32 {
    let size = i32(map_params.bias.z);
    let t = clamp(vec2<i32>(floor(mp.uvz.xy * map_params.bias.z)), vec2<i32>(0), vec2<i32>(size - 1));
    let s = bitcast<vec2<f32>>(textureLoad(smoothie_buffer, t, i32(mp.layer), 0).xy);
    // Reversed Z: no smoothie (depth 0), or one at or behind the receiver.
    if (s.y <= mp.uvz.z) {
        return 1.0;
    }
    let view = shadow_views[mp.layer];
    let b = shadow_distance(view, s.y);
    let r = shadow_distance(view, mp.uvz.z);
    var width = smoothies.params.x * max(r - b, 0.0);
    if (view.eye.w < 0.5) {
        width = width / max(r, 1.0e-9);
    }
    return clamp(s.x / max(width, 1.0e-9), 0.0, 1.0);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_frame(id.xy)) {
        return;
    }
    let s = load_surface(id.xy);
    var v = 1.0;
    if (s.relevant) {
        let mp = map_point(s.p, s.n, light_vector(light, s.p).xyz, 0u);
        if (mp.on_map) {
            v = map_tap(mp, vec2<f32>(0.0), mp.layer);
            if (v >= 1.0) {
                v = smoothie_visibility(mp);
            }
        }
        // A soft shadow's part the map cannot see: the receiver hiding the emitter (horizon.wgsl).
        v = min(v, light_horizon(light, s.p, geometric_normal(id.xy, s.n)));
    }
    textureStore(visibility_out, id.xy, vec4<f32>(v));
}
