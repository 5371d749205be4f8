// The hierarchical shadow map of `ssm` (Guennebaud et al. 2006, 2007 §3): a pyramid over each
// view's map whose texels hold the nearest and the farthest stored depth they cover (reversed Z:
// the largest and the smallest). Level 1 is reduced from the map, each further level from the last.

// #include "resolve.wgsl"
// #include "maplookup.wgsl"

struct Reduce {
    // x: level written (≥ 1); y: its offset in a view's block; z: its side; w: texels per view.
    dst: vec4<u32>,
    // x: level read; y: its offset (levels ≥ 1); z: its side.
    src: vec4<u32>,
};

@group(2) @binding(0) var<uniform> reduce: Reduce;
@group(2) @binding(1) var<storage, read_write> hsm: array<vec2<f32>>;
// #ifdef HARDWARE_COMPARE
@group(2) @binding(2) var block_sampler: sampler;
// #endif

// #ifdef HARDWARE_COMPARE
// A texel's 2 × 2 block in one gather (on a CPU adapter, a quarter of four loads' addressing and
// bounds checks); the block's order is no matter to a nearest and a farthest. Its corner is sampled
// exactly, so the block is t…t + 1, the last texel repeated past an odd side (clamped sampler).
fn map_block(t: vec2<i32>, layer: i32) -> vec4<f32> {
    let size = vec2<f32>(textureDimensions(shadow_maps));
    return textureGather(shadow_maps, block_sampler, (vec2<f32>(t) + 1.0) / size, layer);
}
// #else
fn map_block(t: vec2<i32>, layer: i32) -> vec4<f32> {
    let last = vec2<i32>(textureDimensions(shadow_maps)) - 1;
    return vec4<f32>(
        textureLoad(shadow_maps, t, layer, 0).r,
        textureLoad(shadow_maps, min(t + vec2<i32>(1, 0), last), layer, 0).r,
        textureLoad(shadow_maps, min(t + vec2<i32>(0, 1), last), layer, 0).r,
        textureLoad(shadow_maps, min(t + vec2<i32>(1, 1), last), layer, 0).r,
    );
}
// #endif

fn store(view: u32, id: vec2<u32>, a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, d: vec2<f32>) {
    let nearest = max(max(a.x, b.x), max(c.x, d.x));
    let farthest = min(min(a.y, b.y), min(c.y, d.y));
    hsm[view * reduce.dst.w + reduce.dst.y + id.y * reduce.dst.z + id.x] = vec2<f32>(nearest, farthest);
}

// Level 1 from the map. Each entry point reads its four texels with no branch on the level: a
// CPU adapter would run both sides of one (ssm.wgsl, `DISK`). A texel past an odd side repeats the
// last, which neither bound changes.
@compute @workgroup_size(8, 8)
fn from_map(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= reduce.dst.z || id.y >= reduce.dst.z) {
        return;
    }
    let q = map_block(vec2<i32>(2u * id.xy), view_layer(id.z));
    store(id.z, id.xy, q.xx, q.yy, q.zz, q.ww);
}

// Each further level from the last.
@compute @workgroup_size(8, 8)
fn from_level(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= reduce.dst.z || id.y >= reduce.dst.z) {
        return;
    }
    let base = id.z * reduce.dst.w + reduce.src.y;
    let side = reduce.src.z;
    let t = 2u * id.xy;
    let u = min(t + vec2<u32>(1u), vec2<u32>(side - 1u));
    let a = hsm[base + t.y * side + t.x];
    let b = hsm[base + t.y * side + u.x];
    let c = hsm[base + u.y * side + t.x];
    let d = hsm[base + u.y * side + u.x];
    store(id.z, id.xy, a, b, c, d);
}
