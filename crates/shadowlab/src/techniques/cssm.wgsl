// `cssm`: cascaded soft shadow maps (Azri 2020). One pass per cascade: the pixels whose eye depth
// falls in the cascade (or its blend bands) average the cascade's samples and add the result,
// weighted, to their sums.

// #include "samples.wgsl"

@compute @workgroup_size(8, 8)
fn accumulate(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_frame(id.xy)) {
        return;
    }
    let s = load_surface(id.xy);
    var sums = vec2<f32>(0.0);
    if (s.relevant) {
        let weight = set_weight(view_depth(camera, s.p));
        if (weight > 0.0) {
            let set_sum = set_sums(s);
            sums = vec2<f32>(weight * select(0.0, set_sum.x / set_sum.y, set_sum.y > 0.0), weight);
        }
    }
    accumulate_sums(id.xy, sums);
}

@compute @workgroup_size(8, 8)
fn finish(@builtin(global_invocation_id) id: vec3<u32>) {
    sample_set_finish(id.xy);
}
