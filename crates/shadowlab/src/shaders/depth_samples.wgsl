// The visible samples of the depth buffer for sample distribution shadow maps (Lauritzen, Salvi
// and Lefohn 2011, §4): the min and max view depth over covered pixels (as depth_range.wgsl) and,
// per bin of view depth (log-spaced over the range in `bins.range`), the box the samples take in
// the light's frame (xy of `bins.light_view`). Reduced per workgroup in shared memory, then with
// atomics on u32s that order like the floats they encode (`ordered`).

// #include "common.wgsl"

// Must equal shadowlab_core::cascades::DEPTH_BINS (checked by a test of depth_range.rs).
const BINS: u32 = 64u;

struct Bins {
    light_view: mat4x4<f32>,
    // x: near edge of bin 0, y: BINS / ln(far / near).
    range: vec4<f32>,
};

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var depth_texture: texture_2d<f32>;
// [0], [1]: min and max view depth (bits of positive floats); then per bin, ordered encodings of
// min x, min y, max x, max y.
@group(0) @binding(2) var<storage, read_write> samples: array<atomic<u32>>;
@group(0) @binding(3) var<uniform> bins: Bins;

var<workgroup> group_min: atomic<u32>;
var<workgroup> group_max: atomic<u32>;
var<workgroup> group_bins: array<atomic<u32>, 256>;

// A float's bits mapped so that unsigned order is the floats' order (negatives flipped whole,
// positives with the sign bit set).
fn ordered(f: f32) -> u32 {
    let b = bitcast<u32>(f);
    if ((b & 0x80000000u) != 0u) {
        return ~b;
    }
    return b | 0x80000000u;
}

// The empty value of word k of a bin: the largest code for minima, the smallest for maxima.
fn empty_word(k: u32) -> u32 {
    return select(0u, 0xffffffffu, k < 2u);
}

@compute @workgroup_size(16, 16)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    if (local == 0u) {
        atomicStore(&group_min, 0x7f7fffffu);
        atomicStore(&group_max, 0u);
    }
    // 256 invocations, 4 words for each of the 64 bins: one word each.
    atomicStore(&group_bins[local], empty_word(local % 4u));
    workgroupBarrier();
    if (f32(id.x) < camera.size.x && f32(id.y) < camera.size.y) {
        let depth = textureLoad(depth_texture, vec2<i32>(id.xy), 0).r;
        if (!is_background(camera, depth)) {
            let p = world_from_depth(camera, id.xy, depth);
            let d = view_depth(camera, p);
            if (d > 0.0) {
                atomicMin(&group_min, bitcast<u32>(d));
                atomicMax(&group_max, bitcast<u32>(d));
                let t = log(d / bins.range.x) * bins.range.y;
                let bin = u32(clamp(floor(t), 0.0, f32(BINS - 1u)));
                let xy = (bins.light_view * vec4<f32>(p, 1.0)).xy;
                atomicMin(&group_bins[bin * 4u], ordered(xy.x));
                atomicMin(&group_bins[bin * 4u + 1u], ordered(xy.y));
                atomicMax(&group_bins[bin * 4u + 2u], ordered(xy.x));
                atomicMax(&group_bins[bin * 4u + 3u], ordered(xy.y));
            }
        }
    }
    workgroupBarrier();
    if (local == 0u) {
        atomicMin(&samples[0], atomicLoad(&group_min));
        atomicMax(&samples[1], atomicLoad(&group_max));
    }
    let word = atomicLoad(&group_bins[local]);
    if (word != empty_word(local % 4u)) {
        if (local % 4u < 2u) {
            atomicMin(&samples[2u + local], word);
        } else {
            atomicMax(&samples[2u + local], word);
        }
    }
}
