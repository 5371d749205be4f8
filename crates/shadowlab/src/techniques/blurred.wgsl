// `blurred`: Toromanoff 2005's blurred projected shadows (algorithm C): the hard shadow averaged
// over an N × N grid of shifted copies, the same kernel everywhere.

// #include "resolve.wgsl"
// #include "pcfkernel.wgsl"
// #include "horizon.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = region_pixel(id);
    if (!in_frame(pixel)) {
        return;
    }
    let s = load_surface(pixel);
    var v = 1.0;
    if (s.relevant) {
        let mp = map_point(s.p, s.n, light_vector(light, s.p).xyz, 0u);
        if (mp.on_map) {
            v = pcf_filter(mp, mp.layer, kernel.params.y, pixel, receiver_plane(mp, s.p, s.n), 0.0);
        }
        // A soft shadow's part the map cannot see: the receiver hiding the emitter (horizon.wgsl).
        v = min(v, light_horizon(light, s.p, geometric_normal(pixel, s.n)));
    }
    textureStore(visibility_out, pixel, vec4<f32>(v));
}
