// `sampled`: the area light as N point samples, one hard shadow map each, V = the (weighted)
// average. A pass looks up one sample (accumulation over passes) or all of them (a texture array).

// #include "samples.wgsl"

@compute @workgroup_size(8, 8)
fn accumulate(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_frame(id.xy)) {
        return;
    }
    let s = load_surface(id.xy);
    var sums = vec2<f32>(0.0);
    if (s.relevant) {
        sums = set_sums(s);
    }
    accumulate_sums(id.xy, sums);
}

@compute @workgroup_size(8, 8)
fn finish(@builtin(global_invocation_id) id: vec3<u32>) {
    sample_set_finish(id.xy);
}
