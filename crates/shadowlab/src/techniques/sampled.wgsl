// `sampled`: the area light as N point samples, one hard shadow map each, visibility = the
// (weighted) average. The maps are rendered one sample at a time into the same layers, and each
// sample's hard visibility is accumulated per pixel here.

// #include "resolve.wgsl"
// #include "maplookup.wgsl"

struct SampleInfo {
    // xyz: the sample point (w = 0) or the unit direction towards it (w = 1).
    position: vec4<f32>,
    // xyz: sphere normal at the sample; w: 1 when the sample is weighted by projected area.
    normal: vec4<f32>,
};

struct Step {
    // x: sample index; y: first view of the sample; z: views per sample (1 or 6).
    index: vec4<u32>,
};

@group(2) @binding(0) var<storage, read> samples: array<SampleInfo>;
@group(2) @binding(1) var<storage, read_write> accum: array<vec2<f32>>;
@group(2) @binding(2) var<uniform> step: Step;

// Adds one sample's weighted hard visibility (the first sample overwrites).
@compute @workgroup_size(8, 8)
fn accumulate(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_frame(id.xy)) {
        return;
    }
    let i = id.y * u32(camera.size.x) + id.x;
    var sum = vec2<f32>(0.0);
    if (step.index.x > 0u) {
        sum = accum[i];
    }
    let s = load_surface(id.xy);
    if (s.relevant) {
        let sample = samples[step.index.x];
        var to_sample = sample.position.xyz;
        if (sample.position.w < 0.5) {
            to_sample = sample.position.xyz - s.p;
        }
        let l = normalize(to_sample);
        var w = 1.0;
        if (sample.normal.w > 0.5) {
            w = max(dot(sample.normal.xyz, normalize(s.p - light.position.xyz)), 0.0);
        }
        var v = 0.0;
        // A sample behind the surface's tangent plane is hidden by the surface itself.
        if (w > 0.0 && dot(s.n, l) > 0.0) {
            let mp = map_point(s.p, s.n, l, step.index.y);
            v = 1.0;
            if (mp.on_map) {
                v = map_tap(mp, vec2<f32>(0.0), mp.layer - step.index.y);
            }
        }
        sum = sum + vec2<f32>(w * v, w);
    }
    accum[i] = sum;
}

@compute @workgroup_size(8, 8)
fn finish(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_frame(id.xy)) {
        return;
    }
    let i = id.y * u32(camera.size.x) + id.x;
    let s = load_surface(id.xy);
    var v = 1.0;
    if (s.relevant) {
        let a = accum[i];
        v = select(0.0, a.x / a.y, a.y > 0.0);
    }
    textureStore(visibility_out, id.xy, vec4<f32>(v));
}
