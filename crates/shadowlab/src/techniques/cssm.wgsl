// `cssm`: cascaded soft shadow maps (Azri 2020). One pass per cascade (or per sample, where the
// cascade's samples share their layers): the pixels whose eye depth falls in the cascade (or its
// blend bands) add the samples' sums (w·V, w), times the cascade's weight there, to their own; V
// is their ratio. Within a cascade that is the weighted average of its samples; across a band the
// cascades blend in proportion to weight × samples.

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
            sums = weight * set_sums(s);
        }
    }
    accumulate_sums(id.xy, sums);
}

@compute @workgroup_size(8, 8)
fn finish(@builtin(global_invocation_id) id: vec3<u32>) {
    sample_set_finish(id.xy);
}
