// `ssm`: soft shadow mapping by back-projection (Guennebaud, Barthe, Paulin 2007, "High-Quality
// Adaptive Soft Shadow Mapping"; NOTES-002). Per pixel: the contour of the map's occluding samples
// inside the search kernel (§4.1), back-projected from the receiver onto the emitter and integrated
// radially from its centre (§4.2), at a level of the min/max depth pyramid chosen from the kernel's
// size and blended with the next (§5.1). Penumbra pixels are computed on a sparse pattern where the
// penumbra is wide on screen and filled in by pull-push (§5.2). The CPU reference of the same
// rules, with their tests, is shadowlab_core::backprojection.
//
// Entry points, in the order the technique runs them: `edges` (the discontinuity buffer),
// `classify` (lit, umbra or penumbra; penumbra pixels to compute are appended to a list), `args`
// (the indirect dispatch of the list), `visibility` (one invocation per listed pixel), then
// pullpush.wgsl fills the gaps and writes the visibility layer.

// #include "resolve.wgsl"
// #include "maplookup.wgsl"
// #include "horizon.wgsl"

struct Ssm {
    // x: contour parameter t at the finest level; y: t at coarser levels; z: t_k, the widest kernel
    // (texels of the level used); w: β, the band of λ over which two levels are blended.
    contour: vec4<f32>,
    // x: 1 with light-space LOD; y: 1 with screen-space adaptive sampling; z: s_min (pixels);
    // w: width h of the selection pattern.
    adapt: vec4<f32>,
    // x: kernel-tightening iterations; y: widest kernel without LOD (texels); z: top level of the
    // pyramid; w: texels of one view's pyramid (levels ≥ 1).
    limits: vec4<f32>,
    // x: relative depth step and y: cosine of the normal angle that make a discontinuity; z: how far
    // (pixels) discontinuities force exact computation; w: what to show (0: visibility, 1: the
    // class, 2: the level, 3: the kernel's width, 4: the contour's fraction, 5: the horizon's).
    screen: vec4<f32>,
    // x: the most loop iterations of a pixel listed at the front (`loop_budget`); y: how far
    // (level-0 texels) the receiver's plane is extrapolated; z: the adapter's loop budget per
    // invocation (0: none); w: the front's pixels per invocation.
    extra: vec4<f32>,
    // x: the most occluder layers (`layers`); y: how many levels finer each layer is traced than
    // the one nearer the light.
    layers: vec4<f32>,
    // Per pyramid level ≥ 1: x: offset in a view's block, y: side (texels).
    levels: array<vec4<u32>, 16>,
    // Inverse view-projection of each view the lookups read.
    inv: array<mat4x4<f32>, 6>,
};

struct Work {
    // Penumbra pixels `classify` listed at the front of the list (those within `extra.x` loop
    // iterations), and from its back (`heavy`: the others, where the adapter has a loop budget).
    count: atomic<u32>,
    heavy: atomic<u32>,
};

@group(2) @binding(0) var<uniform> ssm: Ssm;
// Per view, levels ≥ 1 of the hierarchical shadow map: (nearest, farthest) stored depth (reversed
// Z: larger is nearer the light).
@group(2) @binding(1) var<storage, read> hsm: array<vec2<f32>>;
// (visibility, weight) per pixel, then the coarser levels of pull-push.
@group(2) @binding(2) var<storage, read_write> vbuf: array<vec2<f32>>;
@group(2) @binding(3) var<storage, read_write> work: Work;
@group(2) @binding(4) var<storage, read_write> list: array<u32>;
// 1 where the camera's depth or normal is discontinuous.
@group(2) @binding(5) var<storage, read_write> flags: array<u32>;

// The emitter's shape, fixed per pipeline (`ssm::EmitterShape`): a rectangle light's square, one-
// sided, or the disk of a sphere light or the sun. Constant so that the shader holds one shape's
// code: CPU adapters run both branches of a varying `if` (lavapipe: 12 % of the bunny's time).
// #ifdef SQUARE_EMITTER
const DISK: bool = false;
// #else
const DISK: bool = true;
// #endif

const LIT: u32 = 0u;
const UMBRA: u32 = 1u;
const PENUMBRA: u32 = 2u;

// ---- the hierarchical shadow map (§3) ----

fn level_side(level: u32) -> i32 {
    if (level == 0u) {
        return i32(map_params.bias.z);
    }
    return i32(ssm.levels[level].y);
}

// (nearest, farthest) stored depth of texel t of `level` in view `view`. Off a single view's map
// nothing occludes; past a cube face's edge the edge texels extend (as the comparison sampler's
// clamp reads them for the other map techniques): the neighbouring face continues the occluders
// there, and reading nothing lit the umbra along the seam.
fn hsm_texel(view: u32, level: u32, t_in: vec2<i32>) -> vec2<f32> {
    let side = level_side(level);
    var t = t_in;
    if (any(t < vec2<i32>(0)) || any(t >= vec2<i32>(side))) {
        if (map_params.bias.w < 0.5) {
            return vec2<f32>(0.0);
        }
        t = clamp(t, vec2<i32>(0), vec2<i32>(side - 1));
    }
    if (level == 0u) {
        let d = stored_depth(t, view);
        return vec2<f32>(d, d);
    }
    let block = view * u32(ssm.limits.w) + ssm.levels[level].x;
    return hsm[block + u32(t.y) * u32(side) + u32(t.x)];
}

struct Bounds {
    nearest: f32,
    farthest: f32,
    // The mean stored depth of the texels read that occlude the receiver (0: none).
    occluder: f32,
};

// Depth bounds of the map over the square [lo, hi] (level-0 texels), from the coarsest level
// whose texels are at least as wide as the square (at most 2 × 2 texels read). Texels nearer than
// `occluding` count towards the occluder depth.
fn hsm_bounds(view: u32, lo: vec2<f32>, hi: vec2<f32>, occluding: f32) -> Bounds {
    let top = u32(ssm.limits.z);
    let width = max(max(hi.x - lo.x, hi.y - lo.y), 1.0);
    let level = min(u32(ceil(log2(width))), top);
    let scale = f32(1u << level);
    let a = vec2<i32>(floor(lo / scale));
    let b = vec2<i32>(floor(hi / scale));
    var out = Bounds(0.0, 1.0, 0.0);
    var sum = 0.0;
    var n = 0.0;
    for (var y = a.y; y <= b.y; y = y + 1) {
        for (var x = a.x; x <= b.x; x = x + 1) {
            let d = hsm_texel(view, level, vec2<i32>(x, y));
            out.nearest = max(out.nearest, d.x);
            out.farthest = min(out.farthest, d.y);
            if (d.x > occluding) {
                sum = sum + d.x;
                n = n + 1.0;
            }
        }
    }
    if (n > 0.0) {
        out.occluder = sum / n;
    }
    return out;
}

// The map's depth bounds over the square [st − half, st + half] (level-0 texels) for receiver px,
// counting towards `nearest` and `occluder` only the texels that may hold an occluder of px: a
// sample hides part of the emitter only if it is nearer the light than the receiver and lies
// within its own kernel of the receiver (`kernel_half` from its depth is exactly how far from the
// receiver, on the map, a sample at that depth back-projects inside the emitter: Eq. 1 read per
// texel), so a texel whose nearest depth is no nearer than the receiver, or whose closest point is
// beyond the kernel of that depth, is left out, and so is one wholly behind a rectangle light's
// plane. The pyramid level is the one whose texels are at least a quarter of the square wide (at
// most 5 × 5 texels read: with 3 × 3 of half its width the kernels came out wider, bunny `azri`
// penumbra RMSE 0.124 against 0.116, and no cheaper). `half` of the result: how far from the
// receiver the texels counted can matter (the square's half at most). Eq. 1 on the nearest depth
// of the 2 × 2 coarse texels that covered the square let one occluder near the light anywhere in
// them (the board over the room's accent lamp) spread every kernel around it.
struct Kernel {
    half: f32,
    bounds: Bounds,
};

fn occluder_bounds(px: Pixel, half: f32, occluding: f32) -> Kernel {
    let view = shadow_views[px.view];
    let top = u32(ssm.limits.z);
    let lo = px.st - vec2<f32>(half);
    let hi = px.st + vec2<f32>(half);
    let level = min(u32(ceil(log2(max(0.5 * half, 1.0)))), top);
    let scale = f32(1u << level);
    let a = vec2<i32>(floor(lo / scale));
    let b = vec2<i32>(floor(hi / scale));
    var out = Kernel(0.0, Bounds(0.0, 1.0, 0.0));
    var sum = 0.0;
    var n = 0.0;
    for (var y = a.y; y <= b.y; y = y + 1) {
        for (var x = a.x; x <= b.x; x = x + 1) {
            let d = hsm_texel(px.view, level, vec2<i32>(x, y));
            out.bounds.farthest = min(out.bounds.farthest, d.y);
            // The texel's offsets from the receiver, per axis: nearest and farthest.
            let t0 = vec2<f32>(f32(x), f32(y)) * scale - px.st;
            let t1 = t0 + vec2<f32>(scale);
            let near = max(max(t0, -t1), vec2<f32>(0.0));
            let far = max(abs(t0), abs(t1));
            let kh = kernel_half(px, shadow_distance(view, d.x));
            if (d.x <= px.z || max(near.x, near.y) > kh) {
                continue;
            }
            // A texel wholly behind a rectangle light's plane (a plane through the map's eye, so
            // its corners' directions decide, at any depth): the ceiling beside the light.
            let c0 = vec2<f32>(f32(x), f32(y)) * scale;
            if (behind_emitter(px, c0, d.x) && behind_emitter(px, c0 + vec2<f32>(scale, 0.0), d.x)
                && behind_emitter(px, c0 + vec2<f32>(0.0, scale), d.x) && behind_emitter(px, c0 + vec2<f32>(scale), d.x)) {
                continue;
            }
            out.half = max(out.half, min(kh, max(far.x, far.y)));
            out.bounds.nearest = max(out.bounds.nearest, d.x);
            if (d.x > occluding) {
                sum = sum + d.x;
                n = n + 1.0;
            }
        }
    }
    out.half = min(out.half, half);
    if (n > 0.0) {
        out.bounds.occluder = sum / n;
    }
    return out;
}

// ---- the emitter, seen from the receiver ----

struct Pixel {
    p: vec3<f32>,
    n: vec3<f32>,
    view: u32,
    // The receiver's biased point on the map (level-0 texels) and stored-depth scale depth.
    st: vec2<f32>,
    // The receiver itself on the map (level-0 texels): the emitter's centre's hard test.
    sc: vec2<f32>,
    z: f32,
    // Receiver-plane depth gradient per texel (Isidoro 2006), and |g|₁.
    g: vec2<f32>,
    g1: f32,
    // Distance of the receiver along the view's axis.
    zd: f32,
    // Kernel half-width (level-0 texels).
    half: f32,
    // Back-projection onto the emitter's normalised domain: coords(q) = base + k / (m·(q − p)) ×
    // (T·(q − p), B·(q − p)) (evaluated through `rt`, `rb`, `rm`).
    base: vec2<f32>,
    k: f32,
    m: vec3<f32>,
    t: vec3<f32>,
    b: vec3<f32>,
    // +1 when the map's texel axes keep their orientation on the emitter, −1 when mirrored.
    flip: f32,
    // A zero-size emitter: the contour's hard shadow.
    hard: bool,
    // emitter_at's rows.
    rt: vec4<f32>,
    rb: vec4<f32>,
    rm: vec4<f32>,
    // A rectangle light's plane: (X, W) = rows · (st, depth, 1) give m·(q − c) = X / W for the point
    // q stored there (c the emitter's centre). Nothing on or behind that plane (X / W ≥ 0) can
    // hide any part of a one-sided emitter (the square, `DISK` false) from a receiver it lights.
    plane_row: vec4<f32>,
    w_row: vec4<f32>,
    // The occluder layer traced: samples whose stored depth d has cut_lo < d ≤ cut_hi (all of
    // them: −1, 2).
    cut_lo: f32,
    cut_hi: f32,
};

fn basis_u(m: vec3<f32>) -> vec3<f32> {
    var u = cross(m, vec3<f32>(0.0, 1.0, 0.0));
    if (dot(u, u) < 1.0e-6) {
        u = cross(m, vec3<f32>(1.0, 0.0, 0.0));
    }
    return normalize(u);
}

// The emitter's extent as the kernel bound sees it: a radius for local lights (a rectangle's half
// diagonal), the tangent of the angular radius for the sun.
fn emitter_radius() -> f32 {
    let kind = light_kind(light);
    if (kind == LIGHT_RECT) {
        return 0.5 * length(light.cone.zw);
    }
    if (kind == LIGHT_DIRECTIONAL) {
        return tan(light.color.w);
    }
    return light.color.w;
}

// Sets up the back-projection of receiver p onto the emitter (DESIGN.md §3's emitter measures):
// a rectangle in its own plane, a sphere light as its disk facing p, the sun as its cone of
// directions in gnomonic projection (a disk of radius tan θ).
fn set_emitter(px: ptr<function, Pixel>) {
    let kind = light_kind(light);
    let p = (*px).p;
    (*px).hard = emitter_radius() <= 0.0;
    (*px).base = vec2<f32>(0.0);
    if (kind == LIGHT_RECT) {
        let c = light.position.xyz;
        let half = max(0.5 * light.cone.zw, vec2<f32>(1.0e-9));
        let tangent = normalize(light.tangent.xyz);
        let bitangent = normalize(cross(light.direction.xyz, tangent));
        (*px).m = -light.direction.xyz;
        (*px).t = tangent / half.x;
        (*px).b = bitangent / half.y;
        (*px).k = dot(c - p, (*px).m);
        (*px).base = vec2<f32>(dot(p - c, (*px).t), dot(p - c, (*px).b));
        (*px).hard = (*px).hard || min(light.cone.z, light.cone.w) <= 0.0;
        return;
    }
    var r = max(emitter_radius(), 1.0e-9);
    if (kind == LIGHT_DIRECTIONAL) {
        (*px).m = -light.direction.xyz;
        (*px).k = 1.0;
    } else {
        let d = light.position.xyz - p;
        (*px).m = normalize(d);
        (*px).k = length(d);
    }
    let u = basis_u((*px).m);
    (*px).t = u / r;
    (*px).b = cross((*px).m, u) / r;
}

// The emitter coordinates of the point stored at level-0 texel position st with stored depth `depth`,
// seen from the receiver. Unprojection and back-projection folded into three rows per pixel:
// (X, Y, Z) = rows · (st, depth, 1) are (T·(q − p), B·(q − p), m·(q − p)) up to the unprojection's
// common w, which cancels in X / Z and Y / Z.
fn emitter_at(px: Pixel, st: vec2<f32>, depth: f32) -> vec2<f32> {
    let s = vec4<f32>(st, depth, 1.0);
    let x = dot(px.rt, s);
    let y = dot(px.rb, s);
    let z = max(dot(px.rm, s), 1.0e-9 * (abs(x) + abs(y)) + 1.0e-30);
    return px.base + (px.k / z) * vec2<f32>(x, y);
}

// The row of `emitter_at` for direction a: a · (q − p) as a function of (st, depth, 1), q the
// unprojection (inverse view-projection `inv`) of map texel position st at stored depth `depth`.
fn emitter_row(inv: mat4x4<f32>, p: vec3<f32>, a: vec3<f32>) -> vec4<f32> {
    // Over NDC: aᵀ·q_h.xyz − (a·p)·q_h.w; then NDC x = 2 st.x / S − 1, y = 1 − 2 st.y / S.
    let r = transpose(inv) * vec4<f32>(a, -dot(p, a));
    let k = 2.0 / map_params.bias.z;
    return vec4<f32>(r.x * k, -r.y * k, r.z, r.w - r.x + r.y);
}

// The row of the unprojection's w: q_h.w as a function of (st, depth, 1), as `emitter_row`.
fn unprojected_w(inv: mat4x4<f32>) -> vec4<f32> {
    let r = transpose(inv) * vec4<f32>(0.0, 0.0, 0.0, 1.0);
    let k = 2.0 / map_params.bias.z;
    return vec4<f32>(r.x * k, -r.y * k, r.z, r.w - r.x + r.y);
}

// Whether the point stored at level-0 texel position st with stored depth `depth` lies on or
// behind a rectangle light's plane (`Pixel::plane_row`).
fn behind_emitter(px: Pixel, st: vec2<f32>, depth: f32) -> bool {
    if (DISK) {
        return false;
    }
    let s = vec4<f32>(st, depth, 1.0);
    return dot(px.plane_row, s) * sign(dot(px.w_row, s)) >= 0.0;
}

// ---- the normalised emitter domain: [−1, 1]² or the unit disk (cross2, square_corner: horizon.wgsl) ----

// The parameter range (t0, t1) of segment a + s(b − a) inside the domain; empty when t0 ≥ t1.
fn clip_range(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    let d = b - a;
    if (DISK) {
        let qa = dot(d, d);
        let qb = dot(a, d);
        let qc = dot(a, a) - 1.0;
        let disc = qb * qb - qa * qc;
        if (qa <= 0.0 || disc <= 0.0) {
            return vec2<f32>(1.0, 0.0);
        }
        let r = sqrt(disc);
        return vec2<f32>(max((-qb - r) / qa, 0.0), min((-qb + r) / qa, 1.0));
    }
    // Liang–Barsky against the four sides (unrolled: a CPU driver keeps indexed local arrays in
    // memory, zeroed on every invocation).
    var r = vec2<f32>(0.0, 1.0);
    r = clip_side(r, -d.x, a.x + 1.0);
    r = clip_side(r, d.x, 1.0 - a.x);
    r = clip_side(r, -d.y, a.y + 1.0);
    r = clip_side(r, d.y, 1.0 - a.y);
    return r;
}

// One Liang–Barsky side p·s ≤ q applied to the parameter range r (empty: r.x > r.y).
fn clip_side(r: vec2<f32>, p: f32, q: f32) -> vec2<f32> {
    if (p == 0.0) {
        return select(r, vec2<f32>(1.0, 0.0), q < 0.0);
    }
    let t = q / p;
    if (p < 0.0) {
        return vec2<f32>(max(r.x, t), r.y);
    }
    return vec2<f32>(r.x, min(r.y, t));
}

// The square's boundary point in direction u.
fn square_rim(u: vec2<f32>) -> vec2<f32> {
    return u / max(max(abs(u.x), abs(u.y)), 1.0e-30);
}

// Corner i of the square, when it lies strictly inside the wedge from a to b: the first such
// corner, then the second.
fn take_corner(i: i32, a: vec2<f32>, b: vec2<f32>, first: ptr<function, i32>, second: ptr<function, i32>) {
    let c = square_corner(i);
    if (cross2(a, c) > 0.0 && cross2(c, b) > 0.0) {
        if (*first < 0) {
            *first = i;
        } else {
            *second = i;
        }
    }
}

// Area of the domain inside the wedge from the centre between the directions of a and b (< π).
fn sector_area(a_in: vec2<f32>, b_in: vec2<f32>) -> f32 {
    var a = a_in;
    var b = b_in;
    if (cross2(a, b) < 0.0) {
        a = b_in;
        b = a_in;
    }
    if (DISK) {
        return 0.5 * atan2(abs(cross2(a, b)), dot(a, b));
    }
    // A fan over the rim: a's rim point, the corners inside the wedge in turn, b's rim point.
    // (Four tests written out: loops count against CPU adapters' budget, `loop_budget`.)
    var first = -1;
    var second = -1;
    take_corner(0, a, b, &first, &second);
    take_corner(1, a, b, &first, &second);
    take_corner(2, a, b, &first, &second);
    take_corner(3, a, b, &first, &second);
    // Corners 3 and 0 are in turn the other way round.
    if (first == 0 && second == 3) {
        first = 3;
        second = 0;
    }
    var prev = square_rim(a);
    var area = 0.0;
    if (first >= 0) {
        area = area + cross2(prev, square_corner(first));
        prev = square_corner(first);
    }
    if (second >= 0) {
        area = area + cross2(prev, square_corner(second));
        prev = square_corner(second);
    }
    area = area + cross2(prev, square_rim(b));
    return 0.5 * area;
}

fn domain_area() -> f32 {
    return select(4.0, 3.14159265, DISK);
}

// The signed part of the emitter an edge a → b (occluder on its left) hides or reveals beyond
// itself, seen from the centre (§4.2, as penumbra wedges integrate; NOTES-002 "self-consistent
// formulation"): + where the occluder ends there (the edge turns counter-clockwise about the
// centre), − where it begins.
fn edge_area(a: vec2<f32>, b: vec2<f32>) -> f32 {
    let r = clip_range(a, b);
    if (r.y - r.x <= 1.0e-7) {
        return 0.0;
    }
    let a2 = a + r.x * (b - a);
    let b2 = a + r.y * (b - a);
    let c = cross2(a2, b2);
    if (abs(c) < 1.0e-12) {
        return 0.0;
    }
    let beyond = max(sector_area(a2, b2) - 0.5 * abs(c), 0.0);
    return sign(c) * beyond;
}

// ---- smooth contour detection (§4.1) ----

// Sample i's centre in a 2 × 2 block's frame: 0 (−½, −½), 1 (½, −½), 2 (½, ½), 3 (−½, ½).
fn sample_centre(i: u32) -> vec2<f32> {
    let k = i & 3u;
    return vec2<f32>(select(-0.5, 0.5, k == 1u || k == 2u), select(-0.5, 0.5, k >= 2u));
}

// Where the contour crosses the segment from occluder sample o to background sample b: its border
// for t = 0, o's centre for t = 1, b's for t = −1.
fn crossing(o: u32, b: u32, t: f32) -> vec2<f32> {
    let co = sample_centre(o);
    return co + 0.5 * (1.0 - t) * (sample_centre(b) - co);
}

struct BlockEdges {
    a0: vec2<f32>,
    b0: vec2<f32>,
    a1: vec2<f32>,
    b1: vec2<f32>,
    // The samples whose depths the endpoints take.
    ha0: u32,
    hb0: u32,
    ha1: u32,
    hb1: u32,
    count: u32,
};

// A block's single edge: from the crossing between occluder `ha` and sample `a_to` to the one
// between occluder `hb` and sample `b_to`, its ends holding those occluders' depths.
fn one_edge(ha: u32, a_to: u32, hb: u32, b_to: u32, t: f32, cut: u32) -> BlockEdges {
    var e: BlockEdges;
    e.a0 = crossing(ha, a_to, crossing_t(ha, a_to, t, cut));
    e.b0 = crossing(hb, b_to, crossing_t(hb, b_to, t, cut));
    e.ha0 = ha;
    e.hb0 = hb;
    e.count = 1u;
    return e;
}

// The contour's t from occluder o towards sample b: t, or 0 (the border) where b occludes too but
// lies in another occluder layer (bit b of `cut`): that layer's contour has the same edge the other
// way round, and both at the border leave neither a gap nor an overlap between them. Also 0 where
// o is a coarse sample that occludes with every finer texel it holds (bit 4 + o of `cut`): its
// occluder ends on its border, which erosion (t = 1) would move in by half the texel.
fn crossing_t(o: u32, b: u32, t: f32, cut: u32) -> f32 {
    return select(t, 0.0, ((cut >> b) & 1u) != 0u || ((cut >> (4u + o)) & 1u) != 0u);
}

// The marching-squares rule of a block with occluder mask `mask` (bit i: sample i occludes): up to
// two edges, the occluder on their left. shadowlab_core::backprojection::coarse_block_edges is the same
// table (`code`: bits 0–3 the mask, 4–7 the samples in another layer, 8–11 those occluding in full).
fn block_edges(code: u32, t: f32) -> BlockEdges {
    let mask = code & 15u;
    let cut = code >> 4u;
    var e: BlockEdges;
    e.count = 0u;
    if (mask == 0u || mask == 15u) {
        return e;
    }
    // The rotation i that brings the mask to one of the cases below (the first of 0…3 that
    // does), two bits per mask; looked up rather than searched, since loops count against CPU
    // adapters' budget (`loop_budget`).
    let i = (0x069fd210u >> (2u * mask)) & 3u;
    // Bit k of r: sample i + k occludes.
    let r = ((mask >> i) | (mask << (4u - i))) & 15u;
    let i1 = (i + 1u) & 3u;
    let i2 = (i + 2u) & 3u;
    let i3 = (i + 3u) & 3u;
    if (r == 1u || r == 5u) {
        // One occluder at i (and its diagonal twin for 0x5, 0xA).
        e = one_edge(i, i1, i, i3, t, cut);
        if (r == 5u) {
            e.a1 = crossing(i2, i3, crossing_t(i2, i3, t, cut));
            e.b1 = crossing(i2, i1, crossing_t(i2, i1, t, cut));
            e.ha1 = i2;
            e.hb1 = i2;
            e.count = 2u;
        }
    } else if (r == 3u) {
        // Occluders i and i + 1.
        e = one_edge(i1, i2, i, i3, t, cut);
    } else if (r == 14u) {
        // Background at i only.
        e = one_edge(i3, i, i1, i, t, cut);
    }
    // A single occluder's corner (and a diagonal pair's) collapses to a point at t = 1. The
    // three-occluder edge at t = −1 is a point on the map too, but its ends hold two depths: it
    // stays, a segment on the emitter. A saddle's corners collapse apart where one occludes in
    // full (t = 0 there): the other's edge then stays, first.
    let second = e.count == 2u && (length(e.b1 - e.a1) >= 1.0e-6 || e.ha1 != e.hb1);
    if (length(e.b0 - e.a0) < 1.0e-6 && e.ha0 == e.hb0) {
        e.a0 = e.a1;
        e.b0 = e.b1;
        e.ha0 = e.ha1;
        e.hb0 = e.hb1;
        e.count = select(0u, 1u, second);
    } else if (!second) {
        e.count = min(e.count, 1u);
    }
    return e;
}

fn left_of(a: vec2<f32>, b: vec2<f32>, x: vec2<f32>) -> bool {
    return cross2(b - a, x - a) > 0.0;
}

// Whether point x of a block (its frame) is inside the occluders' contour: the hard test of the
// emitter's centre that matches the contour (§4.2, Fig. 5).
fn centre_inside(code: u32, t: f32, x: vec2<f32>) -> bool {
    let mask = code & 15u;
    let e = block_edges(code, t);
    var extended = false;
    var left = false;
    if (e.count >= 1u && length(e.b0 - e.a0) >= 1.0e-6) {
        extended = true;
        left = left_of(e.a0, e.b0, x);
    }
    if (e.count == 2u && length(e.b1 - e.a1) >= 1.0e-6) {
        extended = true;
        left = left || left_of(e.a1, e.b1, x);
    }
    // No edge with length in the block: inside when most of its samples occlude.
    return select(countOneBits(mask) > 2u, left, extended);
}

// ---- visibility at one level ----

// What a pass over one level reads, looked up once: its scale, side, where its texels are.
struct Level {
    level: u32,
    scale: f32,
    side: i32,
    // The view's texture layer (level 0) or its block's offset in the pyramid (coarser levels).
    layer: i32,
    base: u32,
    // Half the level's texel in level-0 texels, between the centres of the finer texels it covers
    // (a coarse texel holds the nearest depth of them all).
    half_extent: f32,
};

fn level_of(px: Pixel, level: u32) -> Level {
    var l: Level;
    l.level = level;
    l.scale = f32(1u << level);
    l.side = level_side(level);
    l.layer = view_layer(px.view);
    l.base = px.view * u32(ssm.limits.w) + ssm.levels[level].x;
    l.half_extent = 0.5 * (l.scale - 1.0);
    return l;
}

// #ifdef HARDWARE_COMPARE
fn map_texel(t: vec2<i32>, layer: i32) -> f32 {
    return textureLoad(shadow_maps, t, layer, 0);
}
// #else
fn map_texel(t: vec2<i32>, layer: i32) -> f32 {
    return textureLoad(shadow_maps, t, layer, 0).r;
}
// #endif

// The (nearest, farthest) stored depth of sample s of the level (off the map as `hsm_texel`: nothing
// occludes there, but past a cube face's edge its edge texels extend).
fn depths_at(l: Level, s_in: vec2<i32>) -> vec2<f32> {
    var s = s_in;
    if (any(s < vec2<i32>(0)) || any(s >= vec2<i32>(l.side))) {
        if (map_params.bias.w < 0.5) {
            return vec2<f32>(0.0);
        }
        s = clamp(s, vec2<i32>(0), vec2<i32>(l.side - 1));
    }
    if (l.level == 0u) {
        let d = map_texel(s, l.layer);
        return vec2<f32>(d, d);
    }
    return hsm[l.base + u32(s.y) * u32(l.side) + u32(s.x)];
}

// Whether sample s occludes the receiver: nearer the light than the receiver's plane there.
fn threshold(px: Pixel, l: Level, s: vec2<i32>) -> f32 {
    let o = (vec2<f32>(s) + vec2<f32>(0.5)) * l.scale - px.st;
    // The receiver's plane holds near it only: beyond `plane_reach` texels (per axis) a curved
    // receiver leaves its tangent plane, and extrapolating it would hide real occluders. A coarse
    // sample holds the nearest of its finer texels, so it is compared with the highest the
    // (clamped) plane gets over them: per axis at the texel's side the plane rises towards, which
    // is the plane's rise over half the texel near the receiver and nothing beyond `plane_reach`
    // (where the plane is flat), so that a steep receiver does not lift the threshold above real
    // occluders far from it.
    let reach = ssm.extra.y;
    let side = sign(px.g) * l.half_extent;
    // Nor can anything farther from the light than the receiver itself hide it from any point of
    // the emitter, however its plane falls away: where the plane recedes (a crease, as the ceiling
    // meets a wall that faces the light), the other surface, beside the receiver at its depth,
    // would otherwise count as an occluder at the receiver's depth, whose back-projection covers
    // the whole emitter.
    return max(px.z + dot(px.g, clamp(o + side, vec2<f32>(-reach), vec2<f32>(reach))), px.z);
}

// (stored depth, 1 if it occludes, 16 if it would but lies in another occluder layer) of sample s;
// 257 (1 + 256) where a coarse sample occludes with its farthest depth too, every finer texel it
// holds (`crossing_t`).
fn occludes(px: Pixel, l: Level, s: vec2<i32>) -> vec2<f32> {
    let d = depths_at(l, s);
    let in_layer = d.x > px.cut_lo && d.x <= px.cut_hi;
    let th = threshold(px, l, s);
    let blocks = d.x > th && !behind_emitter(px, (vec2<f32>(s) + vec2<f32>(0.5)) * l.scale, d.x);
    let full = l.level > 0u && d.y > max(th, px.cut_lo);
    return vec2<f32>(d.x, select(0.0, select(16.0, select(1.0, 257.0, full), in_layer), blocks));
}

// Four samples' `occludes` as `block_edges` takes them: bit i, sample i occludes; bit 4 + i, it
// lies in another layer; bit 8 + i, it occludes in full.
fn block_code(o0: f32, o1: f32, o2: f32, o3: f32) -> u32 {
    return u32(o0) | (u32(o1) << 1u) | (u32(o2) << 2u) | (u32(o3) << 3u);
}

fn mask_at(px: Pixel, l: Level, c: vec2<i32>) -> u32 {
    let o0 = occludes(px, l, c).y;
    let o1 = occludes(px, l, c + vec2<i32>(1, 0)).y;
    let o2 = occludes(px, l, c + vec2<i32>(1, 1)).y;
    let o3 = occludes(px, l, c + vec2<i32>(0, 1)).y;
    return block_code(o0, o1, o2, o3);
}

fn holder_depth(h: u32, d: vec4<f32>) -> f32 {
    return select(select(d.w, d.z, h == 2u), select(d.y, d.x, h == 0u), h < 2u);
}

// The part of emitter-domain area an edge between block points a, b (sample coordinates) with
// stored depths da, db hides or reveals.
fn edge_term(px: Pixel, l: Level, a: vec2<f32>, da: f32, b: vec2<f32>, db: f32) -> f32 {
    let la = emitter_at(px, (a + vec2<f32>(0.5)) * l.scale, da);
    let lb = emitter_at(px, (b + vec2<f32>(0.5)) * l.scale, db);
    // The ends swapped where the map mirrors the emitter: selected, not branched, since a CPU
    // adapter would run `edge_area` on both branches (`DISK`).
    let mirrored = px.flip <= 0.0;
    return edge_area(select(la, lb, mirrored), select(lb, la, mirrored));
}

// The edges' terms of the blocks with lower-left sample (i, j), i in [i0, i1], in row j.
fn row_terms(px: Pixel, l: Level, t: f32, i0: i32, i1: i32, j: i32) -> f32 {
    var sum = 0.0;
    // Samples slide along the row: (i, j), (i, j + 1) are the last block's right column.
    var s0 = occludes(px, l, vec2<i32>(i0, j));
    var s3 = occludes(px, l, vec2<i32>(i0, j + 1));
    for (var i = i0; i <= i1; i = i + 1) {
        let s1 = occludes(px, l, vec2<i32>(i + 1, j));
        let s2 = occludes(px, l, vec2<i32>(i + 1, j + 1));
        let code = block_code(s0.y, s1.y, s2.y, s3.y);
        let mask = code & 15u;
        if (mask != 0u && mask != 15u) {
            let e = block_edges(code, t);
            let centre = vec2<f32>(f32(i) + 0.5, f32(j) + 0.5);
            let depths = vec4<f32>(s0.x, s1.x, s2.x, s3.x);
            if (e.count >= 1u) {
                sum = sum + edge_term(px, l, centre + e.a0, holder_depth(e.ha0, depths), centre + e.b0, holder_depth(e.hb0, depths));
            }
            if (e.count == 2u) {
                sum = sum + edge_term(px, l, centre + e.a1, holder_depth(e.ha1, depths), centre + e.b1, holder_depth(e.hb1, depths));
            }
        }
        s0 = s1;
        s3 = s2;
    }
    return sum;
}

// Whether the samples [lo, hi] of level l are all on one side of the receiver's plane, from the
// pyramid two levels up (whose texels cover 4 × 4 samples): then their blocks have no edge.
fn uniform_samples(px: Pixel, l: Level, lo: vec2<i32>, hi: vec2<i32>) -> bool {
    let coarse = l.level + 2u;
    if (coarse > u32(ssm.limits.z)) {
        return false;
    }
    let c = level_of(px, coarse);
    let a = lo >> vec2<u32>(2u);
    let b = hi >> vec2<u32>(2u);
    var nearest = 0.0;
    var farthest = 1.0;
    for (var y = a.y; y <= b.y; y = y + 1) {
        for (var x = a.x; x <= b.x; x = x + 1) {
            let t = vec2<i32>(x, y);
            var d = vec2<f32>(0.0);
            if (all(t >= vec2<i32>(0)) && all(t < vec2<i32>(c.side))) {
                d = hsm[c.base + u32(y) * u32(c.side) + u32(x)];
            }
            nearest = max(nearest, d.x);
            farthest = min(farthest, d.y);
        }
    }
    // The receiver's plane over the samples rises at most |g| per texel, out to `plane_reach`.
    let a0 = (vec2<f32>(lo) + vec2<f32>(0.5)) * l.scale - px.st;
    let a1 = (vec2<f32>(hi) + vec2<f32>(0.5)) * l.scale - px.st;
    let far = min(max(abs(a0), abs(a1)) + vec2<f32>(l.half_extent), vec2<f32>(ssm.extra.y));
    let e = dot(abs(px.g), far);
    let low = px.z - e;
    let high = px.z + e;
    // None occludes (below the plane, or outside the layer), or all do.
    let none = nearest <= max(low, px.cut_lo) || farthest > px.cut_hi;
    let all_in = farthest > max(high, px.cut_lo) && nearest <= px.cut_hi;
    return none || all_in;
}

// Whether no sample `visibility_at(px, l)` reads, for l up to `level`, can occlude: one look at the
// pyramid over them all (a superset of their level-0 texels) finds them all below the receiver's
// plane or all outside the layer (nearer the light than `cut_hi`). A layer near the receiver is
// often empty (every occluder at one depth): it then costs this look alone.
fn layer_empty(px: Pixel, level: u32) -> bool {
    let scale = f32(1u << level);
    // The blocks meeting the kernel, one sample of the level beyond it on each side.
    let reach = px.half + 2.0 * scale;
    let b = hsm_bounds(px.view, px.st - vec2<f32>(reach), px.st + vec2<f32>(reach), 1.0);
    // The receiver's plane (as `threshold` holds it) is at least this low over them.
    let low = px.z - px.g1 * min(reach + 0.5 * scale, ssm.extra.y);
    return b.nearest <= max(low, px.cut_lo) || b.farthest > px.cut_hi;
}

// The fraction of the emitter visible from the receiver, from the contour at `level`.
fn visibility_at(px: Pixel, level: u32) -> f32 {
    let l = level_of(px, level);
    let t = select(ssm.contour.y, ssm.contour.x, level == 0u);
    // The receiver in sample coordinates of the level (sample (i, j) at (i, j)); a zero-size
    // emitter's hard test is the map lookup's, at the biased point (as `hard`).
    let q = select(px.sc, px.st, px.hard) / l.scale - vec2<f32>(0.5);
    // The light's centre: inside or outside the contour of the block around q.
    let cell = vec2<i32>(floor(q));
    let inside = centre_inside(mask_at(px, l, cell), t, q - (vec2<f32>(cell) + vec2<f32>(0.5)));
    let area = domain_area();
    var v = select(area, 0.0, inside);
    if (px.hard) {
        return v / area;
    }
    // Every block (samples (i, j) … (i + 1, j + 1)) that meets the kernel, in tiles of 4 × 4
    // blocks aligned to the pyramid two levels up; tiles on one side of the receiver are skipped.
    let hk = px.half / l.scale;
    let lo = vec2<i32>(ceil(q - vec2<f32>(hk + 1.0)));
    let hi = vec2<i32>(floor(q + vec2<f32>(hk)));
    for (var tj = lo.y >> 2u; tj <= hi.y >> 2u; tj = tj + 1) {
        let j0 = max(lo.y, tj * 4);
        let j1 = min(hi.y, tj * 4 + 3);
        for (var ti = lo.x >> 2u; ti <= hi.x >> 2u; ti = ti + 1) {
            let i0 = max(lo.x, ti * 4);
            let i1 = min(hi.x, ti * 4 + 3);
            if (uniform_samples(px, l, vec2<i32>(i0, j0), vec2<i32>(i1 + 1, j1 + 1))) {
                continue;
            }
            for (var j = j0; j <= j1; j = j + 1) {
                v = v + row_terms(px, l, t, i0, i1, j);
            }
        }
    }
    return clamp(v / area, 0.0, 1.0);
}

// ---- the loop budget of CPU adapters ----

// llvmpipe (lavapipe, the CPU rasterisers of Mesa) ends every loop of an invocation once the
// invocations running together have made 65 535 loop iterations in all, counting every loop of the
// shader (Mesa gallivm, LP_MAX_TGSI_LOOP_ITERATIONS); loops with a constant count are unrolled and
// do not count. Past it the contour is cut short without a word. So where the uniform carries a
// budget, a pixel's count is bounded from above (`pixel_loops`), levels are
// raised where one pixel alone would exceed it, and `classify` lists the pixels within `extra.x`
// at the front of the list, which `visibility` computes `extra.w` to an invocation (a share of the
// budget each: an invocation's fixed cost is large on a CPU), and the others at its back, which
// `heavy` computes one to an invocation.
fn loop_budget() -> u32 {
    return u32(ssm.extra.z);
}

// An upper bound on the loop iterations of `setup`: its kernel-tightening steps and, for each and
// three more, `occluder_bounds`' ≤ 5 × 5 texels (36 with the loops' exits); the level raising (17).
fn setup_loops() -> u32 {
    return 36u * (u32(ssm.limits.x) + 3u) + 20u;
}

// A pixel's share of loops outside `setup` and `visibility_at`: the pass's own loop, and the
// layers' (at most 4 and its exit) with their `layer_empty` looks (9 each, 3 layers) among them.
const ROUND_LOOPS: u32 = 40u;

// An upper bound on the loop iterations of `visibility_at(px, level)` for a kernel of half-width
// `half` (level-0 texels): tiles of 4 × 4 blocks per axis, each counting at most 35 (its own
// iteration, `uniform_samples`' ≤ 2 × 2 texels with their loops' exits: 9, ≤ 4 rows: 5, their
// ≤ 4 blocks each: 20), and each row of tiles 2 more.
fn level_loops(half: f32, level: u32) -> u32 {
    let hk = half / f32(1u << level);
    let tiles = u32(min((2.0 * hk + 2.0) / 4.0, 4096.0)) + 2u;
    return tiles * (tiles * 35u + 2u) + 2u;
}

// An upper bound on the loop iterations of a listed pixel's `visibility_at` calls.
fn pixel_loops(s: Setup) -> u32 {
    var sum = 0u;
    for (var j = 0u; j < s.layers; j = j + 1u) {
        let half = s.px.half / f32(1u << (j * s.finer));
        sum = sum + level_loops(half, s.lod - j * s.finer);
        sum = sum + select(0u, level_loops(half, s.other - j * s.finer), s.w > 0.0);
    }
    return sum;
}

// ---- per pixel: kernel, level, class ----

// Half-width (level-0 texels) of the map region that can hold an occluder of a receiver at axis
// distance zd, for occluders no nearer than zn (Eq. 1 of §3, generalised: the emitter's depth
// extent seen off the view's axis widens it by (1 + off-axis tangent); see
// shadowlab_core::backprojection::kernel_half_width).
fn kernel_half(px: Pixel, zn: f32) -> f32 {
    if (zn >= px.zd || emitter_radius() <= 0.0) {
        return 0.0;
    }
    let rate = kernel_rate(px);
    if (shadow_views[px.view].eye.w > 0.5) {
        return rate * (px.zd - zn);
    }
    return rate * (1.0 / max(zn, 1.0e-6) - 1.0 / px.zd);
}

// How fast the kernel grows as the occluder nears the light: `kernel_half` is rate · (z_d − z_n)
// for the sun, rate · (1/z_n − 1/z_d) for local lights.
fn kernel_rate(px: Pixel) -> f32 {
    let view = shadow_views[px.view];
    let r = emitter_radius();
    if (view.eye.w > 0.5) {
        return r / view.axis.w;
    }
    let side = map_params.bias.z;
    let off_axis = 0.5 * side * view.axis.w * max(abs(2.0 * px.st.x / side - 1.0), abs(2.0 * px.st.y / side - 1.0));
    // Emitter points nearer the light's centre than its plane (a sphere's front half) see the
    // kernel widened by z_p / (z_p − R) (shadowlab_core::backprojection::kernel_half_width).
    let depth = px.zd / max(px.zd - r, 1.0e-6 * px.zd);
    return (r * depth / view.axis.w) * (1.0 + off_axis);
}

// The distance along the view's axis at which an occluder's kernel (`kernel_half`) is `h` texels:
// occluders farther from the light have smaller ones (shadowlab_core::backprojection::kernel_depth).
fn kernel_depth(px: Pixel, h: f32) -> f32 {
    let rate = max(kernel_rate(px), 1.0e-12);
    if (shadow_views[px.view].eye.w > 0.5) {
        return px.zd - h / rate;
    }
    return 1.0 / (h / rate + 1.0 / px.zd);
}

// The stored depth of distance `d` along the view's axis (the inverse of `shadow_distance`).
fn stored_depth_at(v: ShadowView, d: f32) -> f32 {
    let n = v.range.x;
    let f = v.range.y;
    if (v.eye.w > 0.5) {
        return (f - d) / (f - n);
    }
    return (n * f / max(d, 1.0e-20) - n) / (f - n);
}

struct Setup {
    px: Pixel,
    kind: u32,
    // The levels blended and the weight of the second (§5.1).
    lod: u32,
    other: u32,
    w: f32,
    // The occluders' distance along the view's axis (for the penumbra's size).
    z_occ: f32,
    // The part of the emitter above the receiver's tangent plane.
    horizon: f32,
    // Occluder layers (`layers`): layer j holds the occluders whose own kernel is at most the
    // pixel's / 2^(j·finer), traced j·finer levels finer than the levels above.
    layers: u32,
    finer: u32,
};

fn lod_blend(lambda: f32, beta: f32, top: u32) -> vec3<f32> {
    if (lambda < 0.0 || lambda != lambda) {
        return vec3<f32>(0.0, 0.0, 0.0);
    }
    let lod = min(u32(floor(lambda)), top);
    let d = lambda - floor(lambda);
    if (d < beta && lod > 0u) {
        return vec3<f32>(f32(lod), f32(lod - 1u), 0.5 * (1.0 - d / beta));
    }
    if (1.0 - d < beta && lod < top) {
        return vec3<f32>(f32(lod), f32(lod + 1u), 0.5 * (1.0 - (1.0 - d) / beta));
    }
    return vec3<f32>(f32(lod), f32(lod), 0.0);
}

// The receiver at `pixel` on the map, with its emitter's frame (no loops): false where the pixel
// shows nothing relevant or falls off the map.
fn receiver(pixel: vec2<u32>, out: ptr<function, Pixel>) -> bool {
    let s = load_surface(pixel);
    if (!s.relevant) {
        return false;
    }
    let mp = map_point(s.p, s.n, light_vector(light, s.p).xyz, 0u);
    if (!mp.on_map) {
        return false;
    }
    var px: Pixel;
    px.p = s.p;
    px.n = s.n;
    px.view = mp.layer;
    px.st = mp.uvz.xy * map_params.bias.z;
    // The hard test of the emitter's centre (`centre_inside`) is made where the receiver itself
    // projects, not its biased point: the back-projected edges are seen from the receiver, and a
    // contour passing between the two points would count half the emitter twice or not at all
    // (V 0.5 read as 0 or 1).
    px.sc = shadow_project(shadow_views[mp.layer], s.p).xy * map_params.bias.z;
    px.z = mp.uvz.z;
    px.g = receiver_plane_gradient(mp, s.p, geometric_normal(pixel, s.n));
    px.g1 = abs(px.g.x) + abs(px.g.y);
    let view = shadow_views[px.view];
    px.zd = shadow_distance(view, px.z);
    set_emitter(&px);
    let inv = ssm.inv[px.view];
    px.rt = emitter_row(inv, px.p, px.t);
    px.rb = emitter_row(inv, px.p, px.b);
    px.rm = emitter_row(inv, px.p, px.m);
    px.plane_row = emitter_row(inv, light.position.xyz, px.m);
    px.w_row = unprojected_w(inv);
    px.cut_lo = -1.0;
    px.cut_hi = 2.0;
    *out = px;
    return true;
}

fn setup(pixel: vec2<u32>) -> Setup {
    var out: Setup;
    out.kind = LIT;
    out.horizon = 1.0;
    out.layers = 1u;
    out.finer = 0u;
    var px: Pixel;
    if (!receiver(pixel, &px)) {
        return out;
    }
    let view = shadow_views[px.view];
    if (!px.hard) {
        // The receiver's own horizon, on its facet (horizon.wgsl).
        out.horizon = light_horizon(light, px.p, geometric_normal(pixel, px.n));
    }
    // The kernel from the nearest depth of the whole map, then tightened by the nearest depth
    // inside it (§3).
    let top = u32(ssm.limits.z);
    let global = hsm_texel(px.view, top, vec2<i32>(0));
    var half = min(kernel_half(px, shadow_distance(view, global.x)), map_params.bias.z);
    var b = Bounds(global.x, global.y, 0.0);
    let iterations = u32(ssm.limits.x);
    for (var i = 0u; i < iterations; i = i + 1u) {
        // Texels nearer than the receiver's plane anywhere in the kernel count towards the
        // occluders' mean depth (the plane held out to `plane_reach`, as `threshold` holds it).
        let rise = px.g1 * (min(half, ssm.extra.y) + 1.0);
        let k = occluder_bounds(px, half, px.z + rise);
        b = k.bounds;
        if (k.half >= half * 0.999) {
            break;
        }
        half = k.half;
    }
    // The occluders' depth for λ and the penumbra's size: the mean of the occluding texels read
    // (continuous where the occluder is, unlike the kernel's min).
    var z_occ = shadow_distance(view, max(b.occluder, b.nearest));
    if (b.occluder > 0.0) {
        z_occ = shadow_distance(view, b.occluder);
    }
    let smooth_half = kernel_half(px, z_occ);
    var lod = 0u;
    var other = 0u;
    var w = 0.0;
    let t_k = ssm.contour.z;
    if (ssm.adapt.x > 0.5 && half > 0.0) {
        // §5.1, Eq. 3; never a kernel wider than 4 t_k texels at the level used (cost bound where
        // the occluders' mean is far behind the nearest).
        let lambda = max(log2(max(2.0 * smooth_half, 1.0e-6) / t_k), log2(2.0 * half / (4.0 * t_k)));
        let l = lod_blend(lambda, ssm.contour.w, top);
        lod = u32(l.x);
        other = u32(l.y);
        w = l.z;
    } else {
        half = min(half, 0.5 * ssm.limits.y);
    }
    px.half = half;
    // Occluder layers (shadowlab_core::backprojection::occluder_layers): one level per pixel
    // (§5.1) loses the small shadows of occluders near the receiver beside the wide penumbra of
    // one near the light. Where the level is `finer` or more above the finest, the occluders
    // whose own kernel is at most half / 2^finer (those farther from the light than
    // `kernel_depth`) are traced `finer` levels finer, over that smaller kernel (as many samples
    // of their level), and so on down. The layers' visible fractions multiply.
    let finer = u32(ssm.layers.y);
    if (ssm.adapt.x > 0.5 && !px.hard && finer > 0u) {
        out.finer = finer;
        out.layers = clamp(u32(ssm.layers.x), 1u, 1u + min(lod, other) / finer);
    }
    let layers = out.layers;
    let budget = loop_budget();
    if (budget > 0u) {
        // An adapter that ends loops past a budget (`loop_budget`) would cut this pixel's contour
        // short; coarser levels, whose kernels hold fewer samples, are used where it would.
        let room = budget - min(budget, setup_loops() + ROUND_LOOPS);
        for (var k = 0u; k < 16u; k = k + 1u) {
            if (layers * (level_loops(half, lod) + select(0u, level_loops(half, other), w > 0.0)) <= room || min(lod, other) >= top) {
                break;
            }
            lod = min(lod + 1u, top);
            other = min(other + 1u, top);
        }
    }
    // Lit or umbra over the kernel grown by a texel of the coarser level used (its blocks).
    let margin = f32(1u << max(lod, other));
    let reach = half + margin;
    let cb = occluder_bounds(px, reach, 1.0).bounds;
    let rise = px.g1 * (reach + 0.5 * f32(1u << max(lod, other)));
    out.px = px;
    out.z_occ = z_occ;
    out.lod = lod;
    out.other = other;
    out.w = w;
    if (cb.nearest <= px.z - rise) {
        out.kind = LIT;
    } else if (cb.farthest > px.z + rise) {
        out.kind = UMBRA;
    } else {
        out.kind = PENUMBRA;
    }
    return out;
}

// The emitter's orientation on the map: three points between the light and the receiver.
fn orientation(px: Pixel) -> f32 {
    let mid = 0.5 * (px.z + 1.0);
    let c0 = emitter_at(px, px.st, mid);
    let c1 = emitter_at(px, px.st + vec2<f32>(1.0, 0.0), mid);
    let c2 = emitter_at(px, px.st + vec2<f32>(0.0, 1.0), mid);
    return select(-1.0, 1.0, cross2(c1 - c0, c2 - c0) >= 0.0);
}

// The penumbra's width on screen in pixels: Eq. 4 in the world (the emitter's diameter for w_l), Eq. 5
// projected at the receiver.
fn screen_penumbra(s: Setup) -> f32 {
    let px = s.px;
    let r = emitter_radius();
    var s_obj = 2.0 * r * max(px.zd - s.z_occ, 0.0);
    if (shadow_views[px.view].eye.w < 0.5) {
        s_obj = s_obj / max(s.z_occ, 1.0e-6);
    }
    let across = basis_u(normalize(px.p - camera.position.xyz));
    let a = camera.view_proj * vec4<f32>(px.p, 1.0);
    let c = camera.view_proj * vec4<f32>(px.p + across * s_obj, 1.0);
    let shift = (c.xy / c.w - a.xy / a.w) * 0.5 * camera.size.xy;
    return length(shift) * abs(dot(px.n, normalize(camera.position.xyz - px.p)));
}

fn pixel_index(pixel: vec2<u32>) -> u32 {
    return pixel.y * u32(camera.size.x) + pixel.x;
}

// ---- passes ----

fn surface_depth(pixel: vec2<i32>) -> f32 {
    let last = vec2<i32>(camera.size.xy) - vec2<i32>(1);
    let q = clamp(pixel, vec2<i32>(0), last);
    let depth = textureLoad(depth_texture, q, 0).r;
    if (is_background(camera, depth)) {
        return -1.0;
    }
    return length(world_from_depth(camera, vec2<u32>(q), depth) - camera.position.xyz);
}

// The discontinuity buffer (§5.2): a step in the camera's depth or normal to a 4-neighbour (one of
// them background, a relative depth step, or a turn of the normal).
@compute @workgroup_size(8, 8)
fn edges(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_frame(id.xy)) {
        return;
    }
    let p = vec2<i32>(id.xy);
    let d = surface_depth(p);
    let n = textureLoad(normal_texture, p, 0).xyz;
    let last = vec2<i32>(camera.size.xy) - vec2<i32>(1);
    var edge = 0u;
    for (var k = 0; k < 4; k = k + 1) {
        let axis = select(vec2<i32>(0, 1), vec2<i32>(1, 0), k < 2);
        let q = clamp(p + select(-axis, axis, (k & 1) == 0), vec2<i32>(0), last);
        let dq = surface_depth(q);
        let m = textureLoad(normal_texture, q, 0).xyz;
        let background = (d < 0.0) != (dq < 0.0);
        let depth_step = abs(dq - d) > ssm.screen.x * min(d, dq);
        // Unnormalised: n·m < cos θ |n||m|.
        let turn = dot(n, m) < ssm.screen.y * sqrt(dot(n, n) * dot(m, m));
        edge = edge | select(0u, 1u, background || (d >= 0.0 && (depth_step || turn)));
    }
    flags[pixel_index(id.xy)] = edge;
}

// The selection pattern (§5.2, Eq. 6): a pixel's rank (1-based) in an ordered-dither tile.
fn pattern_rank(h: u32, x: u32, y: u32) -> u32 {
    // Bayer matrices by bit interleaving, M_2n = 4 M_2(low bits) + M_n(high bits).
    var levels = 0u;
    if (h >= 8u) {
        levels = 3u;
    } else if (h >= 4u) {
        levels = 2u;
    } else if (h >= 2u) {
        levels = 1u;
    }
    let xx = x ^ y;
    var r = 0u;
    for (var k = 0u; k < levels; k = k + 1u) {
        // From the least significant bit of the coordinates to the most significant of the rank.
        r = (r << 2u) | (((xx >> k) & 1u) << 1u) | ((y >> k) & 1u);
    }
    return r + 1u;
}

fn near_discontinuity(pixel: vec2<u32>) -> bool {
    let reach = i32(ssm.screen.z);
    let last = vec2<i32>(camera.size.xy) - vec2<i32>(1);
    for (var y = -reach; y <= reach; y = y + 1) {
        for (var x = -reach; x <= reach; x = x + 1) {
            let q = clamp(vec2<i32>(pixel) + vec2<i32>(x, y), vec2<i32>(0), last);
            if (flags[u32(q.y) * u32(camera.size.x) + u32(q.x)] != 0u) {
                return true;
            }
        }
    }
    return false;
}

@compute @workgroup_size(8, 8)
fn classify(@builtin(global_invocation_id) id: vec3<u32>) {
    if (!in_frame(id.xy)) {
        return;
    }
    let i = pixel_index(id.xy);
    let s = setup(id.xy);
    if (s.kind == LIT) {
        vbuf[i] = vec2<f32>(select(s.horizon, 1.0, ssm.screen.w == 1.0), 1.0);
        return;
    }
    if (s.kind == UMBRA) {
        vbuf[i] = vec2<f32>(0.0, 1.0);
        return;
    }
    if (ssm.screen.w == 1.0) {
        // Analysis: penumbra pixels at ½.
        vbuf[i] = vec2<f32>(0.5, 1.0);
        return;
    }
    var selected = true;
    if (ssm.adapt.y > 0.5) {
        let h = max(u32(ssm.adapt.w), 1u);
        let rank = pattern_rank(h, id.x % h, id.y % h);
        // Eq. 6 with pattern = h² / rank: the rank-1 pixel of every tile always, the others while
        // the penumbra is narrow enough on screen; always next to a discontinuity.
        let pattern = f32(h * h) / f32(rank);
        selected = rank == 1u || !(screen_penumbra(s) >= ssm.adapt.z * sqrt(pattern)) || near_discontinuity(id.xy);
    }
    if (selected) {
        vbuf[i] = vec2<f32>(0.0, 1.0);
        record(i, s);
        if (loop_budget() > 0u && pixel_loops(s) > u32(ssm.extra.x)) {
            list[last_slot() - atomicAdd(&work.heavy, 1u)] = i;
        } else {
            list[atomicAdd(&work.count, 1u)] = i;
        }
    } else {
        vbuf[i] = vec2<f32>(0.0, 0.0);
    }
}

// #ifdef UNRECORDED
// Outputs whose list with the setups would outgrow a storage binding (`ssm::Screen::recorded`):
// `visibility` sets each listed pixel up again, as `classify` did.
fn record(i: u32, s: Setup) {}

fn listed_setup(i: u32) -> Setup {
    return setup(pixel_at(i));
}
// #else
// Behind the list's slots (one per pixel), four words per pixel (by pixel index): what
// `classify`'s `setup` found for a listed pixel, so that `visibility` does not search its kernel
// again: the kernel's half-width, the levels and layers, the blend weight, the horizon. (In the
// list's buffer: a binding of its own would pass WebGPU's 8 storage buffers per stage.)
fn record(i: u32, s: Setup) {
    let at = last_slot() + 1u + 4u * i;
    list[at] = bitcast<u32>(s.px.half);
    list[at + 1u] = s.lod | (s.other << 8u) | (s.layers << 16u) | (s.finer << 24u);
    list[at + 2u] = bitcast<u32>(s.w);
    list[at + 3u] = bitcast<u32>(s.horizon);
}

// The setup of listed pixel `i` at `pixel`: its receiver again (no loops), the rest as `classify`
// recorded it.
fn restored(pixel: vec2<u32>, i: u32) -> Setup {
    var out: Setup;
    let at = last_slot() + 1u + 4u * i;
    let r = vec4<u32>(list[at], list[at + 1u], list[at + 2u], list[at + 3u]);
    out.kind = PENUMBRA;
    var px: Pixel;
    _ = receiver(pixel, &px);
    px.half = bitcast<f32>(r.x);
    out.px = px;
    out.lod = r.y & 255u;
    out.other = (r.y >> 8u) & 255u;
    out.layers = (r.y >> 16u) & 255u;
    out.finer = r.y >> 24u;
    out.w = bitcast<f32>(r.z);
    out.horizon = bitcast<f32>(r.w);
    return out;
}

fn listed_setup(i: u32) -> Setup {
    return restored(pixel_at(i), i);
}
// #endif

fn pixel_at(i: u32) -> vec2<u32> {
    let width = u32(camera.size.x);
    return vec2<u32>(i % width, i / width);
}

// Listed pixel `i`, set up as `setup_in`.
fn listed(setup_in: Setup, i: u32) {
    var s = setup_in;
    s.px.flip = orientation(s.px);
    if (ssm.screen.w == 2.0) {
        // Analysis: the continuous level used, an eighth per level.
        vbuf[i] = vec2<f32>(min((f32(s.lod) + s.w * (f32(s.other) - f32(s.lod))) / 8.0, 1.0), 1.0);
        return;
    }
    if (ssm.screen.w == 3.0) {
        // Analysis: the kernel's width in level-0 texels, 1 at 256.
        vbuf[i] = vec2<f32>(min(s.px.half / 128.0, 1.0), 1.0);
        return;
    }
    var v = 1.0;
    var layer = s.px;
    let view = shadow_views[s.px.view];
    for (var j = 0u; j < s.layers; j = j + 1u) {
        let shift = j * s.finer;
        layer.half = s.px.half / f32(1u << shift);
        layer.cut_hi = layer.cut_lo;
        if (j == 0u) {
            layer.cut_hi = 2.0;
        }
        layer.cut_lo = -1.0;
        if (j + 1u < s.layers) {
            layer.cut_lo = stored_depth_at(view, kernel_depth(s.px, layer.half / f32(1u << s.finer)));
        }
        if (j > 0u && layer_empty(layer, max(s.lod, s.other) - shift)) {
            continue;
        }
        var vj = visibility_at(layer, s.lod - shift);
        if (s.w > 0.0) {
            vj = mix(vj, visibility_at(layer, s.other - shift), s.w);
        }
        v = v * vj;
    }
    // The receiver's horizon and the occluders' contour, combined by the minimum (exact when one
    // hides a part of the emitter the other does too).
    // Analysis: the contour's fraction alone, the horizon's alone.
    if (ssm.screen.w == 4.0) {
        vbuf[i] = vec2<f32>(v, 1.0);
        return;
    }
    if (ssm.screen.w == 5.0) {
        vbuf[i] = vec2<f32>(s.horizon, 1.0);
        return;
    }
    vbuf[i] = vec2<f32>(min(v, s.horizon), 1.0);
}

// The list's last slot (it has one per pixel; `heavy` pixels are listed from there down).
fn last_slot() -> u32 {
    return u32(camera.size.x) * u32(camera.size.y) - 1u;
}

// The pixels listed at the front (an indirect dispatch, fill.wgsl's `dispatch_args`): on CPU
// adapters `extra.w` to an invocation, as many as the loop budget holds; on GPUs one, or more
// where the list outgrows the most workgroups a dispatch may have (65 535).
@compute @workgroup_size(64)
fn visibility(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let count = atomicLoad(&work.count);
    let stride = groups.x * 64u;
    // (A CPU adapter's output of over 65 535 × 64 × extra.w pixels, 37 million at the defaults,
    // would leave some uncomputed.)
    let per = select(0xffffffffu, max(u32(ssm.extra.w), 1u), loop_budget() > 0u);
    var j = 0u;
    for (var k = id.x; k < count && j < per; k = k + stride) {
        let i = list[k];
        listed(listed_setup(i), i);
        j = j + 1u;
    }
}

// The pixels listed at the back (CPU adapters: more loops than `extra.x`), one to an invocation.
@compute @workgroup_size(64)
fn heavy(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x < atomicLoad(&work.heavy)) {
        let i = list[last_slot() - id.x];
        listed(listed_setup(i), i);
    }
}
