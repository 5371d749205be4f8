//! Soft shadow mapping by back-projection (Guennebaud, Barthe, Paulin, "High-Quality Adaptive Soft
//! Shadow Mapping", Eurographics 2007): the CPU reference of the per-pixel maths. The WGSL shader mirrors
//! these functions one for one.
//!
//! A receiver p is shadowed by the shadow-map samples that are nearer the light than p is. Back-projecting
//! every such sample as a little quad leaves gaps and overlaps. This method instead takes the *contour* of
//! the occluding samples, back-projects it onto the light and integrates the occluded area radially from
//! the light's centre. The pieces, in the order a pixel meets them:
//!
//! 1. **Kernel**: [`kernel_half_width`] (Guennebaud et al. 2007, §3, Eq. 1) is the square of the map that
//!    can hold an occluder of p at all.
//! 2. **Level**: [`continuous_level`] and [`lod_blend`] (§5.1) pick the min/max pyramid level that keeps
//!    the kernel a few texels wide, and blend across integer levels as trilinear filtering does.
//! 3. **Contour**: [`block_edges`] (§4.1) runs marching squares over every 2×2 block of occluder flags.
//!    Each endpoint slides with `t` along an occluder→background segment and takes its depth from that
//!    occluder, its *holder*. Neighbouring blocks therefore agree, and the contour is closed in 3D.
//! 4. **Light centre**: [`centre_inside`] (§4.2, Fig. 5) gives the hard shadow of the centre from the
//!    same contour.
//! 5. **Integration**: [`Emitter`] and [`visible_fraction`] (§4.2) start from the whole light if its
//!    centre is visible and from nothing otherwise. For each back-projected edge they then add or remove
//!    the part of the light beyond it, seen from the centre. Only edges near p matter, because the centre
//!    test accounts for everything else.
//! 6. **Screen-space selection**: [`penumbra_object_size`], [`penumbra_screen_size`] and [`selected`]
//!    (§5.2, Eq. 4–6) compute only a dithered subset of pixels where the penumbra is wide on screen.
//!    Pull-push fills in the rest.
//!
//! Conventions: `cross(a, b) = a.x·b.y − a.y·b.x` ([`Vec2::perp_dot`]). Every contour edge has the
//! occluder on its left, so closed occluder outlines run counter-clockwise. Nothing here panics, and no
//! input produces a NaN: out-of-range and NaN inputs are clamped to some in-range answer.

use std::cmp::Ordering;
use std::f32::consts::PI;

use glam::Vec2;

/// Endpoints closer than this are one point (texels of the current level).
const MIN_EDGE: f32 = 1e-6;

/// `x` if it is positive, else 0 (NaN included).
fn nonneg(x: f32) -> f32 {
    if x > 0.0 { x } else { 0.0 }
}

/// `x` clamped to [0, 1], NaN → 0.
fn unit(x: f32) -> f32 {
    if x > 0.0 { x.min(1.0) } else { 0.0 }
}

// ---------------------------------------------------------------------------------------------------------
// §4.1: contour of a 2×2 block

/// Centre of block sample `i` (taken mod 4) in the block frame: texels of the current level, origin at the
/// block centre, counter-clockwise from the lower left. `i` and `i + 2` are diagonal, and
/// `sample_centre(i + 2) == -sample_centre(i)`.
pub const fn sample_centre(i: u8) -> Vec2 {
    match i & 3 {
        0 => Vec2::new(-0.5, -0.5),
        1 => Vec2::new(0.5, -0.5),
        2 => Vec2::new(0.5, 0.5),
        _ => Vec2::new(-0.5, 0.5),
    }
}

/// One oriented contour edge in the block frame, with the block samples (0..4) whose depths its endpoints
/// take. The occluder is on the left of a→b.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContourEdge {
    pub a: Vec2,
    pub b: Vec2,
    pub holder_a: u8,
    pub holder_b: u8,
}

impl ContourEdge {
    const NONE: Self = Self { a: Vec2::ZERO, b: Vec2::ZERO, holder_a: 0, holder_b: 0 };
}

/// The first edge of each mask as `[occluder_a, background_a, occluder_b, background_b]`. Endpoint a lies on
/// the segment between samples occluder_a and background_a and is held by occluder_a; likewise for b. Read
/// the rows walking counter-clockwise round the block: a is where an occluder is followed by background,
/// and b is where background is followed by an occluder. The saddles (0x5, 0xA) store the corner of
/// their lower occluder; the other corner is the central symmetry (every index + 2).
const EDGE_RULES: [[u8; 4]; 16] = [
    [0, 0, 0, 0], // 0x0  none
    [0, 1, 0, 3], // 0x1  single 0
    [1, 2, 1, 0], // 0x2  single 1
    [1, 2, 0, 3], // 0x3  pair 0, 1
    [2, 3, 2, 1], // 0x4  single 2
    [0, 1, 0, 3], // 0x5  diagonal 0, 2: single 0, then single 2
    [2, 3, 1, 0], // 0x6  pair 1, 2
    [2, 3, 0, 3], // 0x7  three, background 3
    [3, 0, 3, 2], // 0x8  single 3
    [0, 1, 3, 2], // 0x9  pair 3, 0
    [1, 2, 1, 0], // 0xA  diagonal 1, 3: single 1, then single 3
    [1, 2, 3, 2], // 0xB  three, background 2
    [3, 0, 2, 1], // 0xC  pair 2, 3
    [0, 1, 2, 1], // 0xD  three, background 1
    [3, 0, 1, 0], // 0xE  three, background 0
    [0, 0, 0, 0], // 0xF  all
];

/// The contour edges of a 2×2 block (Guennebaud et al. 2007, §4.1), occluder on the left of a→b.
///
/// Bit i of `mask` is set when sample i occludes (higher bits are ignored). Endpoints lie on the segment
/// from an occluder o to a 4-adjacent background sample b, at `c_o + (1 − t)/2·(c_b − c_o)`, and o holds
/// them. So t = 0 follows the texel borders, t = 1 joins occluder centres (erosion, used at coarse levels,
/// §5.1) and t = −1 joins background centres. `t` is clamped to [−1, 1], and NaN counts as 0. Returns the
/// edges and how many of them are valid.
///
/// An edge is dropped only when it is one point in 3D, i.e. both ends at the same place with the same
/// holder. That happens to the single and diagonal corners at t = 1. At t = −1 a three-occluder edge also
/// shrinks to the background centre, but its ends keep the depths of two different occluders, so it still
/// spans a segment on the light and is kept.
pub fn block_edges(mask: u8, t: f32) -> ([ContourEdge; 2], usize) {
    layer_block_edges(mask, 0, t)
}

/// [`block_edges`] of one occluder layer (`ssm`'s `layers`, ours): bit i of `cut` is set when sample i
/// would occlude but lies in another layer. Towards such a sample the endpoint sits on the border (t = 0)
/// whatever `t` is, since the other layer's contour has the same edge the other way round: with `t` on
/// both sides (t = 1 at coarse levels) each layer would shrink away from the cut and leave a band between
/// them that neither covers. Only a block that also holds background keeps a gap (at most half of it,
/// where marching squares' cases for the layers differ from the union's; `layer_contours_tile_across_the_cut`).
pub fn layer_block_edges(mask: u8, cut: u8, t: f32) -> ([ContourEdge; 2], usize) {
    coarse_block_edges(mask, cut, 0, t)
}

/// [`layer_block_edges`] at a coarse pyramid level (ours): bit i of `full` is set when sample i occludes
/// with all the finer texels it covers (its farthest depth occludes too, not only its nearest). Where
/// such a sample meets background the occluder's edge is the texel border itself, so the endpoint sits
/// there (t = 0); `t` (t = 1 at coarse levels, §5.1) places only the edges of partly occluding samples,
/// whose occluder ends somewhere inside them. Without it an occluder's border that falls on a coarse
/// texel's border is eroded by half that texel (`full_coarse_samples_keep_their_border`).
pub fn coarse_block_edges(mask: u8, cut: u8, full: u8, t: f32) -> ([ContourEdge; 2], usize) {
    let mask = mask & 0xF;
    let mut edges = [ContourEdge::NONE; 2];
    if mask == 0x0 || mask == 0xF {
        return (edges, 0);
    }
    let f = (1.0 - if t.is_nan() { 0.0 } else { t.clamp(-1.0, 1.0) }) * 0.5;
    let endpoint = |o: u8, b: u8| {
        let f = if cut >> (b & 3) & 1 == 1 || full >> (o & 3) & 1 == 1 { 0.5 } else { f };
        sample_centre(o) + f * (sample_centre(b) - sample_centre(o))
    };
    let [oa, ba, ob, bb] = EDGE_RULES[mask as usize];
    let corners = if mask == 0x5 || mask == 0xA { 2 } else { 1 };
    let mut n = 0;
    // Rotating every index by 2 negates every coordinate: the saddle's second corner.
    for r in (0..corners).map(|k| 2 * k) {
        let (holder_a, holder_b) = ((oa + r) & 3, (ob + r) & 3);
        let e = ContourEdge { a: endpoint(oa + r, ba + r), b: endpoint(ob + r, bb + r), holder_a, holder_b };
        if holder_a != holder_b || e.a.distance(e.b) >= MIN_EDGE {
            edges[n] = e;
            n += 1;
        }
    }
    (edges, n)
}

/// Whether block point `x` lies inside the occluder contour: the hard shadow of the light centre when `x`
/// is the receiver's own map position (Guennebaud et al. 2007, §4.2, Fig. 5). This follows the contour,
/// not the texel grid, so hard boundaries come out smooth. Inside means left of any edge, which for a
/// saddle is either corner. A block whose contour has shrunk to a point is inside exactly when occluders
/// are the majority: 0xF, or three occluders at t = −1.
pub fn centre_inside(mask: u8, t: f32, x: Vec2) -> bool {
    let (edges, n) = block_edges(mask, t);
    let mut extended = false;
    let mut left = false;
    for e in &edges[..n] {
        let d = e.b - e.a;
        if d.length() >= MIN_EDGE {
            extended = true;
            left |= d.perp_dot(x - e.a) > 0.0;
        }
    }
    if extended { left } else { (mask & 0xF).count_ones() > 2 }
}

// ---------------------------------------------------------------------------------------------------------
// §4.2: radial integration over the emitter

/// An emitter's shape in normalised light coordinates, centred on the origin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Emitter {
    /// [−1, 1]². A rectangle light normalised per axis, which is affine, so fractions of area survive.
    Square,
    /// The unit disk. A sphere light's disk facing the point, or the sun's cone in gnomonic projection.
    Disk,
}

impl Emitter {
    /// Area of the normalised domain.
    pub fn area(self) -> f32 {
        match self {
            Emitter::Square => 4.0,
            Emitter::Disk => PI,
        }
    }

    /// The part of segment a→b inside the domain, in the same direction. None if that part is empty,
    /// shorter than 1e-9, or the input is not finite.
    pub fn clip(self, a: Vec2, b: Vec2) -> Option<(Vec2, Vec2)> {
        if !(a.is_finite() && b.is_finite()) {
            return None;
        }
        let d = b - a;
        let (mut s0, mut s1) = (0.0f32, 1.0f32);
        match self {
            Emitter::Square => {
                // Liang–Barsky: a + s·d stays within each slab −1 ≤ x, x ≤ 1, −1 ≤ y, y ≤ 1.
                for (p, q) in [(-d.x, a.x + 1.0), (d.x, 1.0 - a.x), (-d.y, a.y + 1.0), (d.y, 1.0 - a.y)] {
                    if p == 0.0 {
                        if q < 0.0 {
                            return None;
                        }
                    } else if p < 0.0 {
                        s0 = s0.max(q / p);
                    } else {
                        s1 = s1.min(q / p);
                    }
                }
            }
            Emitter::Disk => {
                // |a + s·d|² = 1. The root without cancellation first, then the other from the product.
                let (qa, qb, qc) = (d.dot(d), a.dot(d), a.dot(a) - 1.0);
                let disc = qb * qb - qa * qc;
                if !(disc > 0.0 && qa > 0.0) {
                    return None;
                }
                let q = -(qb + disc.sqrt().copysign(qb));
                let (r0, r1) = (q / qa, qc / q);
                s0 = s0.max(r0.min(r1));
                s1 = s1.min(r0.max(r1));
            }
        }
        let (a1, b1) = (a + s0 * d, a + s1 * d);
        (s0 < s1 && a1.is_finite() && b1.is_finite() && a1.distance(b1) >= 1e-9).then_some((a1, b1))
    }

    /// Area of the domain inside the angular wedge from the origin between the directions of `a` and `b`
    /// (the wedge narrower than π; exactly opposite directions give half the domain). Symmetric in a and b.
    /// Non-finite input gives 0.
    pub fn sector_area(self, a: Vec2, b: Vec2) -> f32 {
        if !(a.is_finite() && b.is_finite()) {
            return 0.0;
        }
        let cross = a.perp_dot(b);
        match self {
            // nonneg: a cross product that overflows to NaN gives 0, not NaN.
            Emitter::Disk => nonneg(0.5 * cross.abs().atan2(a.dot(b))),
            Emitter::Square => {
                let (a, b) = if cross < 0.0 { (b, a) } else { (a, b) };
                let to_border = |u: Vec2| {
                    let m = u.x.abs().max(u.y.abs());
                    if m > 0.0 { u / m } else { Vec2::ZERO }
                };
                // Fan from the origin: border under a, the corners strictly inside the wedge, border under b.
                // A wedge narrower than π holds at most two corners.
                let mut fan = [to_border(a), Vec2::ZERO, Vec2::ZERO, Vec2::ZERO];
                let mut n = 1;
                for c in [Vec2::new(1.0, 1.0), Vec2::new(-1.0, 1.0), Vec2::new(-1.0, -1.0), Vec2::new(1.0, -1.0)] {
                    if n < 3 && a.perp_dot(c) > 0.0 && c.perp_dot(b) > 0.0 {
                        fan[n] = c;
                        n += 1;
                    }
                }
                if n == 3 && fan[1].perp_dot(fan[2]) < 0.0 {
                    fan.swap(1, 2);
                }
                fan[n] = to_border(b);
                fan[..=n].windows(2).map(|w| 0.5 * w[0].perp_dot(w[1]).abs()).sum()
            }
        }
    }

    /// For a clipped edge a→b, the part of the domain beyond it as seen from the centre: the sector minus
    /// the triangle (origin, a, b). For the disk this is the circular segment cut off by the chord. ≥ 0.
    pub fn beyond(self, a: Vec2, b: Vec2) -> f32 {
        nonneg(self.sector_area(a, b) - 0.5 * a.perp_dot(b).abs())
    }
}

/// Visible fraction of the emitter (Guennebaud et al. 2007, §4.2) from its back-projected contour edges,
/// given in normalised light coordinates with the occluder on the left.
///
/// Each clipped edge a′→b′ adds or removes the area beyond it:
/// V = c·A − Σ s_e·beyond(e′), with c = 1 if the centre is visible. Going outward from the centre, a
/// clockwise edge (cross(a′, b′) < 0) has its occluder beyond it, so the occluder starts there and
/// s = +1. A counter-clockwise edge has its occluder towards the centre, so the occluder ends there and
/// s = −1. Edges that miss the emitter contribute nothing, and the centre's state supplies what they
/// would have. Radial edges (through the centre) sweep no area. Returns V / A clamped to [0, 1].
pub fn visible_fraction(emitter: Emitter, centre_visible: bool, edges: impl IntoIterator<Item = (Vec2, Vec2)>) -> f32 {
    let area = emitter.area();
    let mut visible = if centre_visible { area } else { 0.0 };
    for (a, b) in edges {
        let Some((a, b)) = emitter.clip(a, b) else { continue };
        let cross = a.perp_dot(b);
        if cross.abs() >= 1e-12 {
            visible += cross.signum() * emitter.beyond(a, b);
        }
    }
    unit(visible / area)
}

// ---------------------------------------------------------------------------------------------------------
// §5.1: light-space level of detail

/// Continuous pyramid level λ = log2(w̃_k / t_k) (Guennebaud et al. 2007, §5.1, Eq. 3): the level at which a
/// kernel `kernel_texels` wide at level 0 measures `t_k` texels. Both inputs are floored at 1e-6.
pub fn continuous_level(kernel_texels: f32, t_k: f32) -> f32 {
    (kernel_texels.max(1e-6) / t_k.max(1e-6)).log2()
}

/// The fraction of the emitter's normalised domain where `k.x + k.y·u + k.z·v > 0`: the part above a
/// receiver's tangent plane. The rest is hidden by the receiver itself (the attached shadow near a
/// terminator), which the truth's rays see and a depth map does not: its own samples are not occluders.
/// `shaders/horizon.wgsl` (`emitter_above`) mirrors this; `ssm` combines it with the contour's fraction
/// by the minimum, `pcss`, `blurred` and `smoothies` with their filtered fractions. A non-finite `k` hides nothing.
pub fn fraction_above(emitter: Emitter, k: glam::Vec3) -> f32 {
    if !k.is_finite() {
        // No plane to speak of (a NaN normal): it hides nothing.
        return 1.0;
    }
    let slope = Vec2::new(k.y, k.z);
    let l = slope.length();
    if l < 1e-12 {
        return if k.x > 0.0 { 1.0 } else { 0.0 };
    }
    match emitter {
        Emitter::Disk => {
            // The centre's signed distance to the line; the circular segment beyond it is hidden.
            let d = (k.x / l).clamp(-1.0, 1.0);
            ((PI - (d.acos() - d * (1.0 - d * d).max(0.0).sqrt())) / PI).clamp(0.0, 1.0)
        }
        Emitter::Square => {
            // One Sutherland–Hodgman step against the half-plane, then the shoelace formula.
            let corners = [Vec2::new(-1.0, -1.0), Vec2::new(1.0, -1.0), Vec2::new(1.0, 1.0), Vec2::new(-1.0, 1.0)];
            let f = |p: Vec2| k.x + slope.dot(p);
            let mut kept: Vec<Vec2> = Vec::with_capacity(5);
            for i in 0..4 {
                let (a, b) = (corners[i], corners[(i + 1) % 4]);
                let (fa, fb) = (f(a), f(b));
                if fa >= 0.0 {
                    kept.push(a);
                }
                if (fa >= 0.0) != (fb >= 0.0) {
                    kept.push(a + (b - a) * (fa / (fa - fb)));
                }
            }
            let twice: f32 = (0..kept.len()).map(|i| kept[i].perp_dot(kept[(i + 1) % kept.len()])).sum();
            (0.5 * twice / 4.0).clamp(0.0, 1.0)
        }
    }
}

/// Which levels to evaluate, and how to blend them, for continuous level `lambda` (Guennebaud et al. 2007,
/// §5.1). Returns `(lod, other, w)` meaning v = (1 − w)·vis(lod) + w·vis(other).
///
/// Within a band β of an integer level the two neighbouring levels are mixed, reaching ½–½ at the integer,
/// so v does not jump when λ crosses it. The upper band uses (1 − (1 − d)/β)/2, the weight that makes this
/// work (the paper prints (d/β)/2). Levels stay within [0, top], with no blending past either end.
/// `beta` is capped at ½ so the bands cannot overlap; β ≤ 0 or NaN means no blending. Non-finite λ
/// gives (0, 0, 0).
pub fn lod_blend(lambda: f32, beta: f32, top: u32) -> (u32, u32, f32) {
    if !lambda.is_finite() {
        return (0, 0, 0.0);
    }
    let level = lambda.floor();
    if level < 0.0 {
        return (0, 0, 0.0);
    }
    if level > top as f32 {
        return (top, top, 0.0);
    }
    let lod = (level as u32).min(top);
    let beta = if beta > 0.0 { beta.min(0.5) } else { 0.0 };
    let d = lambda - level;
    if d < beta && lod > 0 {
        (lod, lod - 1, 0.5 * (1.0 - d / beta))
    } else if 1.0 - d < beta && lod < top {
        (lod, lod + 1, 0.5 * (1.0 - (1.0 - d) / beta))
    } else {
        (lod, lod, 0.0)
    }
}

// ---------------------------------------------------------------------------------------------------------
// §3: kernel bound

/// Half-width, in level-0 texels, of the square of the map around p's own map position that can hold an
/// occluder of p. The occluder must be no nearer than `z_min`, and the emitter of radius R is centred on
/// the view's eye. This is Guennebaud et al. 2007, §3, Eq. 1, generalised to off-axis receivers and to
/// the sun. Returns 0 when `z_p ≤ z_min`.
///
/// *Perspective* (`radius_over_texel = R/texel_scale`, a texel at axis distance z spanning
/// `texel_scale·z`). Put the eye at the origin looking down +z and p = z_p·(u, v, 1). The occluder
/// x = p + s·(e − p) sits at axis distance z on the way to an emitter point e. By similar triangles
/// s = (z_p − z)/(z_p − e_z), and the p terms cancel because p lies on its own ray (u, v, 1):
///
/// `map(x) − map(p) = (z_p − z)/z · (e_xy − (u, v)·e_z)/(z_p − e_z) / texel_scale`.
///
/// For a planar emitter (e_z = 0) this is `(1/z − 1/z_p)·e_xy`. It is largest at z = z_min, and
/// |e_x| ≤ R, which gives Eq. 1: `R/texel_scale·(1/z_min − 1/z_p)`. An emitter with depth extent adds
/// u·e_z, and |e_x| + |u·e_z| ≤ R·√(1 + u²) ≤ R·(1 + off_axis). `off_axis` = max(|u|, |v|) is 0 on the
/// axis and at most 1 on a cube face; negative or NaN counts as 0. Emitter points in front of the eye
/// (e_z > 0) also shorten z_p − e_z. For a spherical emitter, pass `radius_over_texel·z_p/(z_p − R)`
/// (needs z_p > R) to stay conservative. Without that factor the bound falls short by up to
/// 1/√(1 − (R/z_p)²) on the axis. `z_min` is floored at 1e-6, so the result stays finite as it → 0.
///
/// *Orthographic* (sun, `radius_over_texel = tanθ/texel_world`). A ray towards the sun tilted by α ≤ θ
/// moves sideways (z_p − z)·tan α, so the half-width is `tanθ/texel_world·(z_p − z_min)`.
pub fn kernel_half_width(radius_over_texel: f32, z_min: f32, z_p: f32, off_axis: f32, orthographic: bool) -> f32 {
    // Also bails out on NaN depths.
    let Some(Ordering::Greater) = z_p.partial_cmp(&z_min) else { return 0.0 };
    let r = nonneg(radius_over_texel);
    if orthographic {
        nonneg(r * (z_p - z_min))
    } else {
        nonneg(r * (1.0 / z_min.max(1e-6) - 1.0 / z_p) * (1.0 + nonneg(off_axis)))
    }
}

/// The inverse of [`kernel_half_width`] in the occluder's depth: the axis distance at which an occluder's
/// kernel is `half` texels. Occluders farther from the light (nearer p) have smaller kernels, so
/// `z ≥ kernel_depth(…)` ⟺ `kernel_half_width(…, z, …) ≤ half` for z < z_p. It cuts the occluders into
/// [`occluder_layers`]. A zero-size emitter (every kernel 0) gives 0 (perspective) or −∞ (orthographic):
/// every occluder; `half ≤ 0` or NaN gives z_p.
pub fn kernel_depth(radius_over_texel: f32, half: f32, z_p: f32, off_axis: f32, orthographic: bool) -> f32 {
    let (r, h) = (nonneg(radius_over_texel), nonneg(half));
    if orthographic {
        if r == 0.0 { f32::NEG_INFINITY } else { z_p - h / r }
    } else {
        let c = r * (1.0 + nonneg(off_axis));
        if c == 0.0 { 0.0 } else { 1.0 / (h / c + 1.0 / z_p) }
    }
}

/// How many occluder layers a pixel traces (beyond the paper, whose one level per pixel, §5.1, loses
/// the small shadows of occluders near the receiver beside the wide penumbra of one near the light).
/// Layer 0 holds the occluders nearer the light than [`kernel_depth`] of the kernel's `half / 2^finer`
/// and is traced at the pixel's levels (`lod`, `other`); layer j holds those whose own kernel is at most
/// `half / 2^(j·finer)` (and more than the next layer's bound), traced over that kernel at levels
/// `j·finer` finer: as many samples as layer 0, so each layer costs about the same. The last layer takes
/// every occluder down to p. At most `most` (at least 1), and only as many as the levels allow, so that
/// no layer's level is below 0. The layers' visible fractions multiply (their occluders taken as
/// independent).
pub fn occluder_layers(lod: u32, other: u32, most: u32, finer: u32) -> u32 {
    if finer == 0 {
        return 1;
    }
    most.clamp(1, 1 + lod.min(other) / finer)
}

// ---------------------------------------------------------------------------------------------------------
// §5.2: screen-space selection

/// 1-based rank of pixel (i, j) in the h×h ordered-dither (Bayer) matrix, for h ∈ {1, 2, 4, 8}. Any
/// other h is treated as 1, so every pixel has rank 1. Consecutive ranks are spread as far apart as the
/// tile allows, so any prefix of the ranks samples the tile evenly.
pub fn pattern_rank(h: u32, i: u32, j: u32) -> u32 {
    let bits = match h {
        2 => 1,
        4 => 2,
        8 => 3,
        _ => return 1,
    };
    // M_2n = 4·M_n(low bits) + M_2(high bit) with M_2 = [[0, 2], [3, 1]], so the lowest bit is the most
    // significant base-4 digit.
    (0..bits).fold(0, |rank, k| {
        let (x, y) = ((i >> k) & 1, (j >> k) & 1);
        4 * rank + 2 * (x ^ y) + y
    }) + 1
}

/// Whether pixel (i, j) gets its visibility computed (Guennebaud et al. 2007, §5.2, Eq. 6):
/// `s_scr < s_min·√(h²/rank)`, so a fraction of about (s_min/s_scr)² of the pixels is computed. The
/// rank-1 pixel of every h×h tile is always computed, so pull-push has data everywhere. A NaN size or
/// threshold selects the pixel.
pub fn selected(s_scr: f32, s_min: f32, h: u32, i: u32, j: u32) -> bool {
    let rank = pattern_rank(h, i, j);
    let h = if matches!(h, 1 | 2 | 4 | 8) { h } else { 1 };
    let threshold = s_min * ((h * h) as f32 / rank as f32).sqrt();
    rank == 1 || matches!(s_scr.partial_cmp(&threshold), Some(Ordering::Less) | None)
}

/// Object-space penumbra width behind an occluder at light distance `z_occ` (Guennebaud et al. 2007, §5.2,
/// Eq. 4) for an emitter of diameter w_l = 2·`radius`: 2R·(z_p − z_occ)/z_occ. It is ≥ 0 and finite,
/// with `z_occ` floored at 1e-6.
pub fn penumbra_object_size(radius: f32, z_p: f32, z_occ: f32) -> f32 {
    let Some(Ordering::Greater) = z_p.partial_cmp(&z_occ) else { return 0.0 };
    let z_occ = z_occ.max(1e-6);
    nonneg(2.0 * radius * (z_p - z_occ) / z_occ).min(f32::MAX)
}

/// Screen-space penumbra width in pixels (Guennebaud et al. 2007, §5.2, Eq. 5): η·s_obj/z·|n·v|, where η is
/// `pixels_per_unit_at_1m` (H/(2·tan(fov_y/2)) for a perspective camera). The |n·v| factor measures the
/// foreshortened width, which raises the sampling density at grazing angles. It is ≥ 0 and finite, with
/// `view_depth` floored at 1e-6.
pub fn penumbra_screen_size(s_obj: f32, pixels_per_unit_at_1m: f32, view_depth: f32, n_dot_v: f32) -> f32 {
    nonneg(pixels_per_unit_at_1m * s_obj / view_depth.max(1e-6) * n_dot_v.abs()).min(f32::MAX)
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;
    use std::f64::consts::{PI, TAU};

    use super::*;

    /// xorshift64*: deterministic and dependency-free.
    struct Rng(u64);

    impl Rng {
        fn unit(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
        }
        fn range(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * self.unit()
        }
    }

    const TS: [f32; 5] = [-1.0, -0.5, 0.0, 0.5, 1.0];

    fn occludes(mask: u8, i: u8) -> bool {
        mask >> (i & 3) & 1 == 1
    }

    #[test]
    fn edge_table_orientation_holders_and_endpoints() {
        for (mask, t) in (0..16u8).flat_map(|m| TS.map(|t| (m, t))) {
            let (edges, n) = block_edges(mask, t);
            let corners = mask.count_ones() == 1 || mask == 0x5 || mask == 0xA;
            let expected = match mask {
                0x0 | 0xF => 0,
                _ if corners && t == 1.0 => 0,
                0x5 | 0xA => 2,
                _ => 1,
            };
            assert_eq!(n, expected, "mask {mask:#x} t {t}");
            for e in &edges[..n] {
                // Held by an occluder, on its segment to a 4-adjacent background sample, at (1 − t)/2.
                for (p, h) in [(e.a, e.holder_a), (e.b, e.holder_b)] {
                    let (co, on) = (sample_centre(h), |g: u8| sample_centre(g) - sample_centre(h));
                    let on_segment = [h + 1, h + 3]
                        .into_iter()
                        .any(|g| !occludes(mask, g) && p.distance(co + (1.0 - t) * 0.5 * on(g)) < 1e-6);
                    assert!(occludes(mask, h) && on_segment, "mask {mask:#x} t {t}: {p} held by {h}");
                }
                let d = e.b - e.a;
                if d.length() < MIN_EDGE {
                    // Only the three-occluder edge at t = −1 shrinks to a point, and it spans two depths.
                    assert!(mask.count_ones() == 3 && t == -1.0 && e.holder_a != e.holder_b);
                    continue;
                }
                // Holders on the left, every background sample on the right; holders touch the line at t = 1,
                // background samples at t = −1. (A "nearest sample beside the midpoint" probe would not do:
                // at t = 0 the three-occluder edge cuts the background corner inside that sample's Voronoi
                // cell.)
                let side = |i: u8| d.perp_dot(sample_centre(i) - e.a);
                for h in [e.holder_a, e.holder_b] {
                    assert!(side(h) > if t < 1.0 { 0.0 } else { -1e-6 }, "mask {mask:#x} t {t}: {e:?}");
                }
                for g in (0..4).filter(|&g| !occludes(mask, g)) {
                    assert!(side(g) < if t > -1.0 { 0.0 } else { 1e-6 }, "mask {mask:#x} t {t}: {e:?}");
                }
            }
        }
        // By hand: single 0 at t = 0 runs (0, −½) → (−½, 0).
        let (e, _) = block_edges(0x1, 0.0);
        assert_eq!((e[0].a, e[0].b), (Vec2::new(0.0, -0.5), Vec2::new(-0.5, 0.0)));
        // NaN t behaves as t = 0; out-of-range t and high mask bits are clamped away.
        assert_eq!(block_edges(0x3, f32::NAN), block_edges(0x3, 0.0));
        assert_eq!(block_edges(0x3, 7.0), block_edges(0x3, 1.0));
        assert_eq!(block_edges(0xF3, 0.0), block_edges(0x3, 0.0));
    }

    #[test]
    fn edge_table_complement_and_saddle_symmetry() {
        let extended = |(edges, n): ([ContourEdge; 2], usize)| -> Vec<ContourEdge> {
            edges.into_iter().take(n).filter(|e| e.a.distance(e.b) >= MIN_EDGE).collect()
        };
        for (mask, t) in (1..15u8).flat_map(|m| TS.map(|t| (m, t))) {
            let (edges, n) = block_edges(mask, t);
            if mask == 0x5 || mask == 0xA {
                // A saddle is its two corners as the single-occluder masks give them, the second being the
                // first negated with holders + 2.
                let (low, high) = (block_edges(mask & 0x3, t), block_edges(mask & 0xC, t));
                assert_eq!(&edges[..n], [&low.0[..low.1], &high.0[..high.1]].concat().as_slice());
                if n == 2 {
                    assert_eq!(
                        (edges[1].a, edges[1].b, edges[1].holder_a),
                        (-edges[0].a, -edges[0].b, edges[0].holder_a + 2)
                    );
                }
                continue;
            }
            // Swapping occluders and background, and t for −t, gives the same 2D curve reversed. (A single corner
            // at t = 1 is dropped while its complement at t = −1 keeps a one-point edge between two depths.)
            let (fwd, rev) = (extended((edges, n)), extended(block_edges(!mask & 0xF, -t)));
            assert_eq!(fwd.len(), rev.len(), "mask {mask:#x} t {t}");
            for (e, r) in fwd.iter().zip(&rev) {
                assert!(e.a.distance(r.b) < 1e-6 && e.b.distance(r.a) < 1e-6, "mask {mask:#x} t {t}");
            }
        }
    }

    const OFFSETS: [(usize, usize); 4] = [(0, 0), (1, 0), (1, 1), (0, 1)];
    const G: usize = 12;

    fn cell_mask(g: &[[bool; G]; G], x: usize, y: usize) -> u8 {
        OFFSETS.iter().enumerate().fold(0, |m, (i, &(dx, dy))| m | (g[y + dy][x + dx] as u8) << i)
    }

    fn segment_distance(q: Vec2, a: Vec2, b: Vec2) -> f32 {
        let d = b - a;
        q.distance(a + d * ((q - a).dot(d) / d.length_squared().max(1e-12)).clamp(0.0, 1.0))
    }

    #[test]
    fn contours_are_watertight_and_winding_matches_centre_test() {
        let mut rng = Rng(0x5EED_0000_0000_0001);
        let key = |p: Vec2| ((p.x * 1e4).round() as i32, (p.y * 1e4).round() as i32);
        let mut checked = [0usize; 2];
        for _ in 0..20 {
            // Sample (x, y) sits at (x, y); cell (x, y) holds samples (x, y), (x+1, y), (x+1, y+1), (x, y+1).
            let mut g = [[false; G]; G];
            for (x, y) in (1..G - 1).flat_map(|x| (1..G - 1).map(move |y| (x, y))) {
                g[y][x] = rng.unit() < 0.45;
            }
            for t in TS {
                let mut edges = Vec::new();
                for (x, y) in (0..G - 1).flat_map(|x| (0..G - 1).map(move |y| (x, y))) {
                    let (cell, n) = block_edges(cell_mask(&g, x, y), t);
                    let centre = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                    let holder = |h: u8| (x + OFFSETS[h as usize].0, y + OFFSETS[h as usize].1);
                    edges.extend(
                        cell[..n].iter().map(|e| (e.a + centre, e.b + centre, holder(e.holder_a), holder(e.holder_b))),
                    );
                }
                // Every endpoint is left as often as reached, with the same holder, so the same 3D point. Where a
                // position names one segment (|t| < 1) it has one holder, whichever cell emits it.
                let (mut balance, mut holder_at) = (HashMap::new(), HashMap::new());
                for &(a, b, ha, hb) in &edges {
                    *balance.entry((key(a), ha)).or_insert(0) += 1;
                    *balance.entry((key(b), hb)).or_insert(0) -= 1;
                    for (p, h) in [(a, ha), (b, hb)].into_iter().filter(|_| t.abs() < 1.0) {
                        assert_eq!(*holder_at.entry(key(p)).or_insert(h), h, "t {t}: {p}");
                    }
                }
                assert!(!edges.is_empty() && balance.values().all(|&c| c == 0), "t {t}: open contour");
                // Winding number by crossing counts against the per-cell centre test, away from the contour.
                for _ in 0..if t.abs() == 1.0 || t == 0.0 { 600 } else { 0 } {
                    let q = Vec2::new(rng.range(0.0, 11.0) as f32, rng.range(0.0, 11.0) as f32);
                    if edges.iter().any(|&(a, b, ..)| segment_distance(q, a, b) < 1e-3) {
                        continue;
                    }
                    let crossing = |&(a, b, ..): &(Vec2, Vec2, _, _)| match (a.y <= q.y, b.y <= q.y) {
                        (true, false) if (b - a).perp_dot(q - a) > 0.0 => 1,
                        (false, true) if (b - a).perp_dot(q - a) < 0.0 => -1,
                        _ => 0,
                    };
                    let winding: i32 = edges.iter().map(crossing).sum();
                    let (x, y) = (q.x as usize, q.y as usize);
                    let inside = centre_inside(cell_mask(&g, x, y), t, q - Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                    assert_eq!(winding, inside as i32, "t {t} at {q}");
                    checked[inside as usize] += 1;
                }
            }
        }
        assert!(checked[0] > 1000 && checked[1] > 1000, "{checked:?}");
    }

    /// Two occluder layers that meet: each layer's contour, with the other's samples as `cut`, covers its
    /// side of the border, so the two cover the block together wherever no background sample is in it,
    /// whatever `t` (but a checkerboard of the two); elsewhere they never overlap and leave at most half
    /// the block. Without the cut rule, at t = 1 (coarse levels) both shrink to their centres and leave
    /// the whole block uncovered.
    #[test]
    fn layer_contours_tile_across_the_cut() {
        // The fraction of the block inside a layer's contour, from a 64² grid of points and the same rule
        // as `centre_inside` (left of an edge; a contour shrunk to a point: most samples occlude).
        let cover = |mask: u8, cut: u8, t: f32| {
            let (edges, n) = layer_block_edges(mask, cut, t);
            let mut inside = 0;
            const N: usize = 64;
            for (i, j) in (0..N).flat_map(|i| (0..N).map(move |j| (i, j))) {
                let x = Vec2::new((i as f32 + 0.5) / N as f32 - 0.5, (j as f32 + 0.5) / N as f32 - 0.5);
                let left = edges[..n].iter().any(|e| (e.b - e.a).perp_dot(x - e.a) > 0.0);
                let hit =
                    if edges[..n].iter().any(|e| e.a.distance(e.b) >= MIN_EDGE) { left } else { mask.count_ones() > 2 };
                inside += hit as usize;
            }
            inside as f32 / (N * N) as f32
        };
        for (a, b) in (1..16u8).flat_map(|a| (1..16u8).map(move |b| (a, b))).filter(|(a, b)| a & b == 0) {
            let background = 0xF & !(a | b);
            for t in TS {
                let both = cover(a, b, t) + cover(b, a, t);
                if background == 0 && a != 0x5 && a != 0xA {
                    // 1/64: grid rounding.
                    assert!((both - 1.0).abs() <= 1.0 / 64.0, "layers {a:#x} {b:#x}, t {t}: {both}");
                } else {
                    // Where background meets both layers, or the layers alternate as a checkerboard
                    // (0x5 with 0xA: two saddles), marching squares' cases differ from the union's: the
                    // layers never overlap, and leave at most half the block (measured 0.5 at 0x4 with 0x8,
                    // t = −1, and at the checkerboard) of what the union covers; 1/64: grid rounding.
                    let union = cover(a | b, 0, t);
                    assert!(both <= union + 1.0 / 64.0, "layers {a:#x} {b:#x}, t {t}: {both} over {union}");
                    assert!(both >= union - 0.5 - 1.0 / 64.0, "layers {a:#x} {b:#x}, t {t}: {both} of {union}");
                }
            }
            if background == 0 && a.count_ones() == 2 && (a == 0x3 || a == 0x6 || a == 0x9 || a == 0xC) {
                assert!(cover(a, 0, 1.0) + cover(b, 0, 1.0) < 1e-6, "without the rule {a:#x}");
            }
        }
    }

    #[test]
    fn full_coarse_samples_keep_their_border() {
        // One row of a level-2 pyramid (a coarse texel covers 4 fine ones) over an occluder that covers
        // the first n fine texels: the contour between the last occluding coarse sample and the first
        // free one, at t = 1, against the finest level's border at n (fine texels).
        const FINE: usize = 4;
        let error = |n: usize, rule: bool| {
            let k = (n - 1) / FINE; // the last coarse texel holding an occluding fine texel
            let full = if rule && n.is_multiple_of(FINE) { 0b1001 } else { 0 };
            // Samples 0 and 3 (the left column, coarse texel k) occlude; 1 and 2 (k + 1) do not.
            let (edges, count) = coarse_block_edges(0b1001, 0, full, 1.0);
            assert_eq!(count, 1);
            assert!((edges[0].a.x - edges[0].b.x).abs() < 1e-6, "a vertical edge");
            // Block frame: the samples' centres at x = ∓½, i.e. fine positions FINE·(k + ½) and FINE·(k + 1½).
            let x = FINE as f32 * (k as f32 + 1.0 + edges[0].a.x);
            (x - n as f32).abs()
        };
        // A saddle whose one corner occludes in full keeps that corner's edge (on the border) while
        // the other's collapses at t = 1: one edge, held by the full sample.
        for (mask, full) in [(0x5u8, 0b0001u8), (0x5, 0b0100), (0xA, 0b0010), (0xA, 0b1000)] {
            let (edges, count) = coarse_block_edges(mask, 0, full, 1.0);
            assert_eq!(count, 1, "saddle {mask:#x}, full {full:#b}");
            assert_eq!(1 << edges[0].holder_a, full, "saddle {mask:#x}: the full corner's edge");
        }
        let ns = 1..=8 * FINE;
        let (mut with, mut without) = (0.0, 0.0);
        for n in ns.clone() {
            let (e, e0) = (error(n, true), error(n, false));
            // Within half a coarse texel of the border either way; on it where the occluder ends on a
            // coarse border.
            assert!(e <= 0.5 * FINE as f32 + 1e-5, "n {n}: {e}");
            if n.is_multiple_of(FINE) {
                assert!(e < 1e-5, "n {n}: {e} (without the rule {e0})");
            }
            with += e;
            without += e0;
        }
        let count = ns.count() as f32;
        // Mean error over the occluder's 4 phases: ½ fine texel with the rule, 1 without (exact: the
        // partial phases are 1, 0, 1 off and the full one 0 with it, 2 without).
        assert!((with / count - 0.5).abs() < 1e-5 && (without / count - 1.0).abs() < 1e-5, "{with} {without}");
    }

    type Poly = Vec<[f64; 2]>;

    /// Counter-clockwise, star-shaped about `c`: 3–8 vertices at radii in [lo, hi] with angular gaps < π
    /// (so convex when lo == hi).
    fn star(rng: &mut Rng, c: [f64; 2], lo: f64, hi: f64) -> Poly {
        let n = 3 + (rng.unit() * 6.0) as usize;
        let r = rng.range(lo, hi);
        let radius = |rng: &mut Rng| if lo == hi { r } else { rng.range(lo, hi) };
        let mut vertex = |k: usize| {
            let (angle, r) = ((k as f64 + 0.4 * rng.unit()) * TAU / n as f64, radius(rng));
            [c[0] + r * angle.cos(), c[1] + r * angle.sin()]
        };
        (0..n).map(&mut vertex).collect()
    }

    /// `case` picks convex or not, the size (up to 4× the domain), the position (near the origin or anywhere)
    /// and, every fifth case, a second polygon 2 away whose radius (≤ 0.9) keeps it disjoint from the first (≤ 1).
    fn random_occluder(rng: &mut Rng, case: usize) -> Vec<Poly> {
        let scale = if case % 5 == 4 { 1.0 } else { [0.3, 0.8, 1.5, 4.0][case % 4] };
        let spread = if case.is_multiple_of(3) { 0.3 } else { 1.5 };
        let c = [rng.range(-spread, spread), rng.range(-spread, spread)];
        let r = rng.range(0.5, 1.0) * scale;
        let mut polys =
            vec![if case.is_multiple_of(2) { star(rng, c, r, r) } else { star(rng, c, 0.25 * scale, scale) }];
        if case % 5 == 4 {
            let angle = rng.range(0.0, TAU);
            polys.push(star(rng, [c[0] + 2.0 * angle.cos(), c[1] + 2.0 * angle.sin()], 0.3, 0.9));
        }
        polys
    }

    fn ring(poly: &[[f64; 2]]) -> impl Iterator<Item = ([f64; 2], [f64; 2])> + '_ {
        poly.iter().zip(poly.iter().cycle().skip(1)).map(|(&p, &q)| (p, q))
    }

    fn signed_area(poly: &[[f64; 2]]) -> f64 {
        ring(poly).map(|(p, q)| p[0] * q[1] - p[1] * q[0]).sum::<f64>() / 2.0
    }

    /// Sorted x of the polygons' boundary crossings of the row y (even–odd pairs enclose the inside).
    fn row_crossings(polys: &[Poly], y: f64) -> Vec<f64> {
        let edges = polys.iter().flat_map(|poly| ring(poly)).filter(|(p, q)| (p[1] > y) != (q[1] > y));
        let mut xs: Vec<f64> = edges.map(|(p, q)| p[0] + (y - p[1]) * (q[0] - p[0]) / (q[1] - p[1])).collect();
        xs.sort_by(f64::total_cmp);
        xs
    }

    /// Sutherland–Hodgman against [−1, 1]². The window is convex, so the area is exact even for non-convex
    /// subjects (which may gain zero-area bridges).
    fn clip_to_square(poly: &[[f64; 2]]) -> Poly {
        let mut out = poly.to_vec();
        for (axis, sign) in [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)] {
            let (input, inside) = (std::mem::take(&mut out), |p: [f64; 2]| sign * p[axis] <= 1.0);
            for (p, q) in ring(&input) {
                out.extend(inside(p).then_some(p));
                if inside(p) != inside(q) {
                    let s = (1.0 - sign * p[axis]) / (sign * (q[axis] - p[axis]));
                    out.push([p[0] + s * (q[0] - p[0]), p[1] + s * (q[1] - p[1])]);
                }
            }
        }
        out
    }

    /// Area of the polygons inside the unit disk: midpoint rule over `rows` rows, exact chords along each.
    fn disk_cover(polys: &[Poly], rows: usize) -> f64 {
        let h = 2.0 / rows as f64;
        let row = |y: f64, half: f64| {
            let chord = |x: &[f64]| (x[1].min(half) - x[0].max(-half)).max(0.0);
            row_crossings(polys, y).chunks(2).map(chord).sum::<f64>() * h
        };
        (0..rows).map(|r| -1.0 + (r as f64 + 0.5) * h).map(|y| row(y, (1.0 - y * y).sqrt())).sum()
    }

    #[test]
    fn radial_integration_matches_covered_area() {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let (mut worst, mut centre_hidden) = ([0.0f64; 2], 0);
        for case in 0..400 {
            let polys = random_occluder(&mut rng, case);
            assert!(polys.iter().all(|p| signed_area(p) > 0.0));
            let hidden = row_crossings(&polys, 0.0).iter().filter(|&&x| x < 0.0).count() % 2 == 1;
            centre_hidden += hidden as usize;
            let edges = polys
                .iter()
                .flat_map(|poly| ring(poly))
                .map(|(p, q)| (Vec2::new(p[0] as f32, p[1] as f32), Vec2::new(q[0] as f32, q[1] as f32)))
                .collect::<Vec<_>>();
            let square = 1.0 - polys.iter().map(|p| signed_area(&clip_to_square(p))).sum::<f64>() / 4.0;
            let got = visible_fraction(Emitter::Square, !hidden, edges.iter().copied()) as f64;
            worst[0] = worst[0].max((got - square).abs());
            if case % 2 == 0 {
                let disk = 1.0 - disk_cover(&polys, 4000) / PI;
                worst[1] =
                    worst[1].max((visible_fraction(Emitter::Disk, !hidden, edges.iter().copied()) as f64 - disk).abs());
            }
        }
        // Both initialisations are exercised.
        assert!((50..350).contains(&centre_hidden), "{centre_hidden}");
        // Square, against the exact clipped area: measured worst 1.3e-7 (f32 fans of area ≤ 4), so 1e-4 leaves
        // a 700× margin. Disk, against the 4000-row rule, whose own error comes mostly from the rows that meet
        // the circle's top and bottom, where the chord grows like a square root: about h^1.5 ≈ 1e-5 of area for
        // h = 5e-4. Measured worst 1.2e-6, so 1e-4 leaves an 80× margin.
        assert!(worst[0] < 1e-4 && worst[1] < 1e-4, "{worst:?}");
    }

    #[test]
    fn visible_fraction_limits_and_garbage() {
        let nan = Vec2::splat(f32::NAN);
        let junk =
            [(nan, Vec2::ONE), (Vec2::new(-1e30, 0.3), Vec2::new(1e30, 0.2)), (Vec2::X, Vec2::X), (Vec2::ONE, nan)];
        // Counter-clockwise square around the whole domain: every edge clips away.
        let cover = [(-3.0, -3.0), (3.0, -3.0), (3.0, 3.0), (-3.0, 3.0)].map(|(x, y)| Vec2::new(x, y));
        let cover: Vec<_> = (0..4).map(|k| (cover[k], cover[(k + 1) % 4])).collect();
        for emitter in [Emitter::Square, Emitter::Disk] {
            assert_eq!(visible_fraction(emitter, true, []), 1.0);
            assert_eq!(visible_fraction(emitter, false, []), 0.0);
            assert_eq!(visible_fraction(emitter, false, cover.iter().copied()), 0.0);
            for c in [true, false] {
                assert!((0.0..=1.0).contains(&visible_fraction(emitter, c, junk)));
            }
            // A quadrant, either way round (1e-6: f32 rounding of π/4).
            assert!((emitter.sector_area(Vec2::X, Vec2::Y) - emitter.area() / 4.0).abs() < 1e-6);
            assert_eq!(emitter.sector_area(Vec2::X, Vec2::Y), emitter.sector_area(Vec2::Y, Vec2::X));
            assert_eq!(emitter.sector_area(nan, Vec2::Y), 0.0);
            // Clipping keeps the direction (1e-6: a few ulps at 1).
            let (a, b) = emitter.clip(Vec2::new(-3.0, 0.0), Vec2::new(3.0, 0.0)).unwrap();
            assert!(a.distance(Vec2::new(-1.0, 0.0)) < 1e-6 && b.distance(Vec2::new(1.0, 0.0)) < 1e-6);
            assert_eq!(emitter.clip(Vec2::new(3.0, 0.0), Vec2::new(3.0, 1.0)), None);
        }
        // A square sector just under π holds two corners: half the square less a sliver of about 1e-4.
        let s = Emitter::Square.sector_area(Vec2::new(1.0, -0.5), Vec2::new(-1.0, 0.5 + 1e-4));
        assert!((s - 2.0).abs() < 1e-3, "{s}");
    }

    #[test]
    fn lod_blend_continuity_band_and_range() {
        let f = |l: u32| (l * l + 3) as f32;
        let v = |lambda: f32| {
            let (lod, other, w) = lod_blend(lambda, 0.05, 6);
            (1.0 - w) * f(lod) + w * f(other)
        };
        for k in 1..=6u32 {
            // Relative to a level step the jump would be 1 without blending. With blending, v moves by
            // ε/β = 2e-3 over ±ε (measured 2.0e-3), so 1e-2 is a 5× margin.
            let jump = (v(k as f32 + 1e-4) - v(k as f32 - 1e-4)).abs() / (f(k) - f(k - 1));
            assert!(jump < 1e-2, "k {k}: jump {jump}");
            assert_eq!(lod_blend(k as f32, 0.05, 6), (k, k - 1, 0.5));
        }
        for lambda in [0.2, 1.06, 2.5, 3.94, 5.5] {
            assert_eq!(lod_blend(lambda, 0.05, 6), (lambda as u32, lambda as u32, 0.0), "{lambda}");
        }
        // w = (1 − 0.02/0.05)/2 = 0.3; f32 λ = 2.98 is off by ~1e-7, which moves w by ~1e-6.
        let (lod, other, w) = lod_blend(2.98, 0.05, 6);
        assert!((lod, other) == (2, 3) && (w - 0.3).abs() < 1e-4, "{w}");
        for (lambda, l) in [(-0.3, 0), (0.01, 0), (6.99, 6), (9.02, 6), (f32::NAN, 0), (f32::INFINITY, 0)] {
            assert_eq!(lod_blend(lambda, 0.05, 6), (l, l, 0.0), "{lambda}");
        }
        assert_eq!(lod_blend(3.01, f32::NAN, 6), (3, 3, 0.0));
        assert_eq!(continuous_level(64.0, 4.0), 4.0);
        assert!(continuous_level(0.0, 4.0).is_finite() && continuous_level(f32::NAN, 0.0).is_finite());
    }

    /// Largest per-axis map offset (texels, through the plane z = 1) from p of occluders x = p + s·(e − p)
    /// with z ≥ z_min: the farthest one allowed and seven random ones.
    fn worst_offset(p: [f64; 3], e: [f64; 3], z_min: f64, texel: f64, rng: &mut Rng) -> f64 {
        let s_max = ((p[2] - z_min) / (p[2] - e[2])).min(1.0);
        let offset = |s: f64| {
            let x: [f64; 3] = std::array::from_fn(|i| p[i] + s * (e[i] - p[i]));
            (0..2).map(|i| (x[i] / x[2] - p[i] / p[2]).abs() / texel).fold(0.0, f64::max)
        };
        (0..8).map(|k| offset(if k == 0 { s_max } else { s_max * rng.unit() })).fold(0.0, f64::max)
    }

    #[test]
    fn kernel_bound_is_conservative_by_brute_force() {
        let mut rng = Rng(0x4B45_524E_454C);
        let texel = 2.0 / 1024.0;
        let mut tightest = [0.0f64; 2];
        // The bound is evaluated in f32, a few ulps off, so each check allows 1e-5 relative (a > 10× margin).
        for _ in 0..4000 {
            let (z_p, u, v) = (rng.range(1.0, 10.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
            let (p, z_min) = ([u * z_p, v * z_p, z_p], rng.range(0.2, z_p));
            let (r, phi, cos) = (rng.range(0.01, 0.9) * z_min, rng.range(0.0, TAU), rng.range(-1.0f64, 1.0));
            let half = |radius_over_texel: f64| {
                kernel_half_width(
                    radius_over_texel as f32,
                    z_min as f32,
                    z_p as f32,
                    u.abs().max(v.abs()) as f32,
                    false,
                )
            };
            // Planar disk in z = 0, its rim (the worst case) half the time: Eq. 1 as it stands.
            let rho = if rng.unit() < 0.5 { r } else { r * rng.unit().sqrt() };
            let d = worst_offset(p, [rho * phi.cos(), rho * phi.sin(), 0.0], z_min, texel, &mut rng);
            let bound = half(r / texel) as f64;
            assert!(d <= bound * (1.0 + 1e-5), "planar: {d} > {bound}");
            tightest[0] = tightest[0].max(d / bound);
            // Anywhere in the ball |e| ≤ R (sphere light, or its facing disk), with the z_p/(z_p − R) factor.
            let (rho, sin) = (if rng.unit() < 0.5 { r } else { r * rng.unit().cbrt() }, (1.0 - cos * cos).sqrt());
            let d = worst_offset(p, [rho * sin * phi.cos(), rho * sin * phi.sin(), rho * cos], z_min, texel, &mut rng);
            let bound = half(r / texel * z_p / (z_p - r)) as f64;
            assert!(d <= bound * (1.0 + 1e-5), "sphere: {d} > {bound}");
            tightest[1] = tightest[1].max(d / bound);
            // Sun: a ray tilted by α ≤ θ, followed up to depth z_min.
            let (theta, alpha) = (rng.range(0.001, 0.3), rng.unit().sqrt());
            let bound = kernel_half_width((theta.tan() / texel) as f32, z_min as f32, z_p as f32, 0.7, true) as f64;
            let drift = (theta * alpha).tan() * (z_p - z_min) * if rng.unit() < 0.5 { 1.0 } else { rng.unit() } / texel;
            assert!(drift * phi.cos().abs().max(phi.sin().abs()) <= bound * (1.0 + 1e-5));
        }
        // The samples come close to the bounds, so neither is slack: measured 0.96 of the planar one (Eq. 1 is
        // tight on the axis at the rim) and 0.79 of the sphere's (its depth factor is only an upper bound).
        assert!(tightest[0] > 0.9 && tightest[1] > 0.7, "{tightest:?}");
        // Without the factor a sphere breaks Eq. 1: on the axis with R/z_p = ½, the emitter point at height
        // R²/z_p lands 1/√(1 − ¼) = 1.155 times as far (1e-4: f32 bound against f64 geometry).
        let (r, z_p, z_min, texel) = (1.0, 2.0, 1.5, 1e-3);
        let d = worst_offset([0.0, 0.0, z_p], [0.75f64.sqrt(), 0.0, 0.5], z_min, texel, &mut Rng(1));
        let plain = kernel_half_width((r / texel) as f32, z_min as f32, z_p as f32, 0.0, false) as f64;
        assert!((d / plain - 1.0 / 0.75f64.sqrt()).abs() < 1e-4, "{}", d / plain);
        assert!(d <= kernel_half_width((r / texel * z_p / (z_p - r)) as f32, 1.5, 2.0, 0.0, false) as f64);
    }

    /// `kernel_depth` inverts `kernel_half_width` in the occluder's depth, so the layers' cut puts an
    /// occluder in the finer layer exactly when its own kernel fits the finer layer's; the layer
    /// count never sends a level below 0.
    #[test]
    fn occluder_layers_cut_by_their_own_kernels() {
        let mut rng = Rng(0x5EED_0000_0000_0007);
        let mut f = |lo: f32, hi: f32| rng.range(lo as f64, hi as f64) as f32;
        for _ in 0..2000 {
            let (r, z_p, off) = (f(1.0, 5000.0), f(0.5, 50.0), f(0.0, 1.0));
            let ortho = f(0.0, 1.0) < 0.5;
            let r = if ortho { r / 100.0 } else { r };
            let half = f(0.5, 300.0);
            let cut = kernel_depth(r, half, z_p, off, ortho);
            assert!(cut < z_p, "{cut} {z_p}");
            let back = kernel_half_width(r, cut.max(1e-6), z_p, off, ortho);
            if cut > 1e-3 {
                assert!((back - half).abs() <= 1e-3 * half, "r {r} z_p {z_p} half {half}: {back}");
            }
            for _ in 0..4 {
                let z = f(0.01, z_p);
                let k = kernel_half_width(r, z, z_p, off, ortho);
                // Away from the cut (float rounding), the kernel fits the layer iff z ≥ cut.
                if (z - cut).abs() > 1e-3 * z_p {
                    assert_eq!(k <= half, z >= cut, "z {z} cut {cut} kernel {k} half {half}");
                }
            }
        }
        assert_eq!(kernel_depth(0.0, 10.0, 2.0, 0.0, false), 0.0);
        assert_eq!(kernel_depth(0.0, 10.0, 2.0, 0.0, true), f32::NEG_INFINITY);
        assert_eq!(kernel_depth(10.0, f32::NAN, 2.0, 0.0, false), 2.0);
        assert_eq!(kernel_depth(10.0, 0.0, 2.0, 0.0, true), 2.0);
        for lod in 0..12u32 {
            for other in [lod.saturating_sub(1), lod, lod + 1] {
                for most in 0..5 {
                    for finer in 0..4 {
                        let n = occluder_layers(lod, other, most, finer);
                        assert!(n >= 1 && n <= most.max(1));
                        assert!((n - 1) * finer <= lod.min(other), "{lod} {other} {most} {finer}: {n}");
                    }
                }
            }
        }
        assert_eq!(occluder_layers(5, 5, 3, 2), 3);
        assert_eq!(occluder_layers(3, 2, 3, 2), 2);
        assert_eq!(occluder_layers(1, 1, 3, 2), 1);
    }

    #[test]
    fn kernel_and_penumbra_sizes_at_the_limits() {
        assert_eq!(kernel_half_width(100.0, 1.0, 2.0, 0.0, false), 50.0);
        assert_eq!(kernel_half_width(100.0, 1.0, 2.0, 1.0, false), 100.0);
        assert_eq!(kernel_half_width(10.0, 1.0, 3.0, 1.0, true), 20.0);
        assert_eq!(kernel_half_width(100.0, 2.0, 2.0, 0.0, false), 0.0);
        assert_eq!(kernel_half_width(100.0, 3.0, 2.0, 0.0, true), 0.0);
        assert!(kernel_half_width(100.0, 0.0, 2.0, 0.0, false).is_finite());
        assert_eq!(kernel_half_width(f32::NAN, 1.0, 2.0, f32::NAN, false), 0.0);
        assert_eq!(kernel_half_width(1.0, f32::NAN, 2.0, 0.0, false), 0.0);
        assert_eq!(penumbra_object_size(0.5, 3.0, 1.0), 2.0);
        assert_eq!(penumbra_object_size(0.5, 1.0, 3.0), 0.0);
        assert!(penumbra_object_size(0.5, 3.0, 0.0).is_finite());
        assert_eq!(penumbra_object_size(f32::NAN, 3.0, 1.0), 0.0);
        assert_eq!(penumbra_object_size(f32::MAX, 3.0, 1.0), f32::MAX);
        assert_eq!(penumbra_screen_size(2.0, 1000.0, 10.0, -0.5), 100.0);
        assert!(penumbra_screen_size(2.0, 1000.0, 0.0, 1.0).is_finite());
        assert_eq!(penumbra_screen_size(f32::NAN, 1000.0, 10.0, 1.0), 0.0);
    }

    #[test]
    fn selection_pattern_keeps_one_pixel_per_tile_and_thins_as_inverse_square() {
        let bayer4 = [[0, 8, 2, 10], [12, 4, 14, 6], [3, 11, 1, 9], [15, 7, 13, 5]];
        for (j, i) in (0..4).flat_map(|j| (0..4).map(move |i| (j, i))) {
            assert_eq!(pattern_rank(4, i as u32 + 4, j as u32 + 8), bayer4[j][i] + 1);
        }
        assert_eq!(pattern_rank(3, 1, 2), 1);
        let tile = |h: u32| (0..h).flat_map(move |i| (0..h).map(move |j| (i, j)));
        for h in [1, 2, 4, 8] {
            let mut ranks: Vec<u32> = tile(h).map(|(i, j)| pattern_rank(h, i, j)).collect();
            ranks.sort_unstable();
            assert_eq!(ranks, (1..=h * h).collect::<Vec<_>>());
            for (i, j) in tile(32) {
                for s in [0.0, 1e3, f32::MAX, f32::INFINITY, f32::NAN] {
                    assert!(pattern_rank(h, i, j) != 1 || selected(s, 16.0, h, i, j));
                    assert!(!s.is_finite() || selected(s, f32::INFINITY, h, i, j));
                }
                assert!(selected(f32::NAN, 16.0, h, i, j));
            }
        }
        // Eq. 6 is strict: at s_scr = s_min·k a tile computes the ranks below h²/k², and rank 1 always. Just
        // under it, it computes the ranks up to h²/k², a fraction 1/k².
        for (h, k) in [4u32, 8].into_iter().flat_map(|h| [1.0f32, 2.0, 4.0].map(|k| (h, k))) {
            let count = |s: f32| tile(h).filter(|&(i, j)| selected(s, 16.0, h, i, j)).count();
            let limit = (h * h) as f32 / (k * k);
            assert_eq!(count(16.0 * k), (1..=h * h).filter(|&r| (r as f32) < limit).count().max(1), "h {h} k {k}");
            assert_eq!(count(16.0 * k * (1.0 - 1e-6)), limit as usize, "h {h} k {k}");
        }
    }

    #[test]
    fn fraction_above_a_tangent_plane_matches_a_fine_grid() {
        let mut rng = Rng(0x5eed_cafe);
        let n = 400;
        for case in 0..60 {
            let k =
                glam::Vec3::new(rng.range(-1.5, 1.5) as f32, rng.range(-1.0, 1.0) as f32, rng.range(-1.0, 1.0) as f32);
            for emitter in [Emitter::Square, Emitter::Disk] {
                let (mut inside, mut above) = (0u32, 0u32);
                for j in 0..n {
                    for i in 0..n {
                        let p = Vec2::new(
                            -1.0 + (i as f32 + 0.5) * 2.0 / n as f32,
                            -1.0 + (j as f32 + 0.5) * 2.0 / n as f32,
                        );
                        if emitter == Emitter::Disk && p.length_squared() > 1.0 {
                            continue;
                        }
                        inside += 1;
                        above += u32::from(k.x + k.y * p.x + k.z * p.y > 0.0);
                    }
                }
                let grid = above as f32 / inside as f32;
                let exact = fraction_above(emitter, k);
                // A 400² grid of cell centres: the line crosses about 2·400 cells, each off by at most
                // half its share, so the grid is within ~1/400 of the truth; measured worst 1.3e-3.
                assert!((exact - grid).abs() < 4e-3, "case {case} {emitter:?} {k}: {exact} vs grid {grid}");
            }
        }
        // Limits: the whole emitter above, below, and a plane through its centre.
        for emitter in [Emitter::Square, Emitter::Disk] {
            assert_eq!(fraction_above(emitter, glam::Vec3::new(5.0, 1.0, 1.0)), 1.0);
            assert_eq!(fraction_above(emitter, glam::Vec3::new(-5.0, 1.0, 1.0)), 0.0);
            assert!((fraction_above(emitter, glam::Vec3::new(0.0, 0.3, -0.7)) - 0.5).abs() < 1e-5);
            assert!((0.0..=1.0).contains(&fraction_above(emitter, glam::Vec3::new(f32::NAN, 1.0, 0.0))));
        }
    }
}
