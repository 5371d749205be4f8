// `ssm`'s passes after `classify` (ssm.wgsl): the indirect dispatch of the listed pixels, and the
// pull-push reconstruction of the pixels left out by screen-space adaptive sampling (Guennebaud et
// al. 2007 §5.2, after Gortler et al. 1996): pull averages (visibility × weight, weight) down a
// pyramid through a tent filter until every texel has data; push fills each level's gaps from the
// one below, bilinearly; computed pixels (weight 1) are never changed. The last push writes the
// layer.

// #include "resolve.wgsl"

struct Work {
    count: atomic<u32>,
    heavy: atomic<u32>,
};

// The head of ssm.wgsl's uniform (its fifth vec4, `extra`: w, the front's pixels per invocation).
struct SsmHead {
    vectors: array<vec4<f32>, 5>,
};

struct Level {
    // x: offset, y: width, z: height of the level written; w: unused.
    dst: vec4<u32>,
    // The same for the level read.
    src: vec4<u32>,
};

@group(2) @binding(0) var<uniform> ssm_head: SsmHead;
@group(2) @binding(2) var<storage, read_write> vbuf: array<vec2<f32>>;
@group(2) @binding(3) var<storage, read_write> work: Work;
@group(3) @binding(0) var<uniform> level: Level;
@group(3) @binding(1) var<storage, read_write> args: array<u32>;

// The indirect dispatches of ssm.wgsl's `visibility` (the front of the list, `extra.w` pixels to
// an invocation) and `heavy` (the back, one each), 64 invocations to a workgroup and at most
// 65 535 workgroups (the least `max_compute_workgroups_per_dimension` wgpu allows).
@compute @workgroup_size(1)
fn dispatch_args() {
    let per = 64u * max(u32(ssm_head.vectors[4].w), 1u);
    args[0] = min((atomicLoad(&work.count) + per - 1u) / per, 65535u);
    args[1] = 1u;
    args[2] = 1u;
    args[3] = min((atomicLoad(&work.heavy) + 63u) / 64u, 65535u);
    args[4] = 1u;
    args[5] = 1u;
}

fn at(l: vec4<u32>, x: u32, y: u32) -> vec2<f32> {
    return vbuf[l.x + min(y, l.z - 1u) * l.y + min(x, l.y - 1u)];
}

// Level k + 1 from level k (Gortler et al. 1996 §3.4.2, the pull): over the 4 × 4 fine texels
// around a coarse texel's centre, a tent filter (1, 3, 3, 1)/8 along each axis weights each fine
// texel by its distance to that centre, so a lone sample off the centre counts less there than one
// on it; the weight is that sum times 4 (the tent's unnormalised sum, 2 per axis: one sample in
// every 2 × 2 gives a complete level), at most 1; visibility is the weighted mean. With a 2 × 2
// box instead, a coarse texel holding one sample took its value whole, shifted by up to half the
// texel: a penumbra's ramp moved outwards level by level (s_min = 4 on `penumbra`'s 1 m light:
// 0.081 penumbra RMSE, 0.025 computed in full).
@compute @workgroup_size(8, 8)
fn pull(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= level.dst.y || id.y >= level.dst.z) {
        return;
    }
    let tent = array<f32, 4>(0.125, 0.375, 0.375, 0.125);
    var sum = 0.0;
    var weight = 0.0;
    // The tent's own sum over the fine texels that exist (less at the level's border).
    var support = 0.0;
    for (var dy = 0; dy < 4; dy = dy + 1) {
        for (var dx = 0; dx < 4; dx = dx + 1) {
            let x = 2 * i32(id.x) + dx - 1;
            let y = 2 * i32(id.y) + dy - 1;
            if (x >= 0 && y >= 0 && x < i32(level.src.y) && y < i32(level.src.z)) {
                let c = vbuf[level.src.x + u32(y) * level.src.y + u32(x)];
                let h = tent[dx] * tent[dy];
                sum = sum + h * c.y * c.x;
                weight = weight + h * c.y;
                support = support + h;
            }
        }
    }
    var v = 0.0;
    if (weight > 0.0) {
        v = sum / weight;
    }
    vbuf[level.dst.x + id.y * level.dst.y + id.x] = vec2<f32>(v, min(4.0 * weight / max(support, 1.0e-6), 1.0));
}

// Level k's value at texel (x, y) with its gaps filled from level k + 1 (`level.src`), bilinearly.
fn pushed(x: u32, y: u32) -> f32 {
    let c = vbuf[level.dst.x + y * level.dst.y + x];
    if (c.y >= 1.0 || level.src.y == 0u) {
        return c.x;
    }
    // Texel centres of the coarse level sit at fine coordinates 2i + 1.
    let f = (vec2<f32>(f32(x), f32(y)) + vec2<f32>(0.5)) * 0.5 - vec2<f32>(0.5);
    let base = vec2<i32>(floor(f));
    let t = f - floor(f);
    let x0 = u32(max(base.x, 0));
    let y0 = u32(max(base.y, 0));
    let x1 = u32(max(base.x + 1, 0));
    let y1 = u32(max(base.y + 1, 0));
    let coarse = mix(
        mix(at(level.src, x0, y0).x, at(level.src, x1, y0).x, t.x),
        mix(at(level.src, x0, y1).x, at(level.src, x1, y1).x, t.x),
        t.y,
    );
    return c.y * c.x + (1.0 - c.y) * coarse;
}

@compute @workgroup_size(8, 8)
fn push(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= level.dst.y || id.y >= level.dst.z) {
        return;
    }
    vbuf[level.dst.x + id.y * level.dst.y + id.x] = vec2<f32>(pushed(id.x, id.y), 1.0);
}

// The full-resolution level: filled, and written to the visibility layer.
@compute @workgroup_size(8, 8)
fn finish(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= level.dst.y || id.y >= level.dst.z) {
        return;
    }
    textureStore(visibility_out, id.xy, vec4<f32>(pushed(id.x, id.y)));
}
