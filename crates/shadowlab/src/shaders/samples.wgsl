// Multi-map soft shadows (group 2): an area light as point samples with one hard shadow map each
// (`sampled`, and each cascade of `cssm`). A set of samples is looked up in one pass; the weighted
// sums (w·V, w) accumulate per pixel in `accum` and `sample_set_finish` divides.

// #include "resolve.wgsl"
// #include "maplookup.wgsl"

struct SampleInfo {
    // xyz: the sample point (w = 0) or the unit direction towards it (w = 1).
    position: vec4<f32>,
    // xyz: sphere normal at the sample; w: 1 when the sample is weighted by projected area.
    normal: vec4<f32>,
};

const SET_PCF: u32 = 1u;
const SET_FIRST: u32 = 4u;

struct SampleSet {
    // x: first sample; y: samples; z: views per sample (1 or 6); w: SET_* flags (3 × 3 PCF per
    // sample; the first set of the frame, which overwrites the sums).
    index: vec4<u32>,
    // The eye-depth weight of the set (cssm's cascades; see `set_weight`): x, y: the depth range;
    // z: where the blend band at its far end starts; w: where the previous set's band starts.
    range: vec4<f32>,
};

@group(2) @binding(0) var<storage, read> samples: array<SampleInfo>;
@group(2) @binding(1) var<storage, read_write> accum: array<vec2<f32>>;
@group(2) @binding(2) var<uniform> sample_set: SampleSet;

// Sample i's weighted hard visibility at s: (w·V, w).
fn sample_contribution(s: Surface, i: u32) -> vec2<f32> {
    let sample = samples[i];
    var to_sample = sample.position.xyz;
    if (sample.position.w < 0.5) {
        to_sample = sample.position.xyz - s.p;
    }
    let l = normalize(to_sample);
    var w = 1.0;
    if (sample.normal.w > 0.5) {
        w = max(dot(sample.normal.xyz, normalize(s.p - light.position.xyz)), 0.0);
    }
    // A sample behind the surface's tangent plane is hidden by the surface itself.
    if (w <= 0.0 || dot(s.n, l) <= 0.0) {
        return vec2<f32>(0.0, w);
    }
    let base = i * sample_set.index.z;
    let mp = map_point(s.p, s.n, l, base);
    if (!mp.on_map) {
        return vec2<f32>(w, w);
    }
    // Samples that take turns in the same layers have those layers in their views' `range.z`.
    let layer = mp.layer;
    var v = 0.0;
    if ((sample_set.index.w & SET_PCF) != 0u) {
        // Azri 2020 Eq. 3.8: a 3 × 3 PCF with one-texel offsets on every sample's map.
        for (var dy = -1; dy <= 1; dy = dy + 1) {
            for (var dx = -1; dx <= 1; dx = dx + 1) {
                v = v + map_tap(mp, vec2<f32>(f32(dx), f32(dy)), layer);
            }
        }
        v = v / 9.0;
    } else {
        v = map_tap(mp, vec2<f32>(0.0), layer);
    }
    return vec2<f32>(w * v, w);
}

// The weighted sums over the set's samples.
fn set_sums(s: Surface) -> vec2<f32> {
    var sum = vec2<f32>(0.0);
    let end = sample_set.index.x + sample_set.index.y;
    for (var i = sample_set.index.x; i < end; i = i + 1u) {
        sum = sum + sample_contribution(s, i);
    }
    return sum;
}

// The weight of the set at eye depth `depth`: 1 inside its range, ramping down over the band at
// its far end and up over the previous set's band (Azri 2020 switches hard: bands of zero width).
fn set_weight(depth: f32) -> f32 {
    let r = sample_set.range;
    if (depth >= r.x && depth < r.y) {
        if (depth > r.z) {
            return 1.0 - (depth - r.z) / max(r.y - r.z, 1.0e-9);
        }
        return 1.0;
    }
    if (depth < r.x && depth > r.w) {
        return (depth - r.w) / max(r.x - r.w, 1.0e-9);
    }
    return 0.0;
}

// Adds `sums` to the pixel's running sums (the first set of the frame overwrites them).
fn accumulate_sums(pixel: vec2<u32>, sums: vec2<f32>) {
    let i = pixel.y * u32(camera.size.x) + pixel.x;
    var total = sums;
    if ((sample_set.index.w & SET_FIRST) == 0u) {
        total = total + accum[i];
    }
    accum[i] = total;
}

// Writes V = Σ w·V / Σ w.
fn sample_set_finish(pixel: vec2<u32>) {
    if (!in_frame(pixel)) {
        return;
    }
    let a = accum[pixel.y * u32(camera.size.x) + pixel.x];
    let s = load_surface(pixel);
    var v = 1.0;
    if (s.relevant) {
        v = select(0.0, a.x / a.y, a.y > 0.0);
    }
    textureStore(visibility_out, pixel, vec4<f32>(clamp(v, 0.0, 1.0)));
}
