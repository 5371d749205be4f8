//! Robust hard shadows for large views (Stingl 2011): z-partitioning split schemes, the warp
//! parameters of PSM / LiSPSM / reparametrised LiSPSM, the focusing fit and the perspective-aliasing
//! error metric. Everything here is CPU maths, shared by the `cascaded` technique, the analysis
//! command and (later) the cascaded soft shadow maps.

use glam::{Mat4, Vec2, Vec3, Vec4};

use crate::bounds::Aabb;
use crate::camera::View;
use crate::convex::ConvexBody;
use crate::light::{Light, LightKind};
use crate::lightspace::ShadowView;

/// The split distances `C_0..=C_m` of z-partitioning (Stingl 2011, Eqs. 3.6–3.8 and 4.1).
///
/// `lambda` blends uniform (0) and logarithmic (1) splits (the practical scheme of PSSM, Zhang et
/// al. 2006). `pseudo_near` and `pseudo_far` (distances, `near ≤ pseudo_near < pseudo_far ≤ far`)
/// replace near and far in the inner splits (Eq. 4.1, Lloyd's pseudo-near plane and Stingl's
/// pseudo-far plane); `C_0` and `C_m` stay at the real near and far planes.
pub fn split_distances(near: f32, far: f32, m: usize, lambda: f32, pseudo_near: f32, pseudo_far: f32) -> Vec<f32> {
    let m = m.max(1);
    let (n, f) = (pseudo_near.max(near), pseudo_far.min(far).max(pseudo_near.max(near) * (1.0 + 1e-6)));
    let mut c: Vec<f32> = (0..=m)
        .map(|i| {
            let t = i as f32 / m as f32;
            let uniform = n + (f - n) * t;
            let log = n * (f / n).powf(t);
            (1.0 - lambda) * uniform + lambda * log
        })
        .collect();
    c[0] = near;
    c[m] = far;
    c
}

/// Replaces the inner splits `C_1..C_{m−1}` by `fixed[i − 1]` where that is positive: splits placed
/// by hand, as Azri 2020 §3.2.1 does per scene ("partitioned arbitrarily", NOTES-003 §1.6). The
/// result stays a partition of the view depth range: every split is clamped into `(near, far)`
/// and at least its predecessor.
pub fn fix_splits(splits: &mut [f32], fixed: &[f32]) {
    let m = splits.len().saturating_sub(1);
    if m < 2 {
        return;
    }
    let (near, far) = (splits[0], splits[m]);
    for i in 1..m {
        if let Some(&d) = fixed.get(i - 1).filter(|d| d.is_finite() && **d > 0.0) {
            splits[i] = d.clamp(near, far);
        }
        splits[i] = splits[i].max(splits[i - 1]).min(far);
    }
}

/// The split scheme's λ: `uniform` 0, `log` 1, `practical` the given λ.
pub fn scheme_lambda(scheme: &str, lambda: f32) -> f32 {
    match scheme {
        "uniform" => 0.0,
        "log" => 1.0,
        _ => lambda,
    }
}

/// LiSPSM's optimal warp distance (Wimmer & Scherzer 2006, as in Stingl 2011 Eq. 3.2):
/// `n_opt = d / (√(z1/z0) − 1)`, where d is the warp frustum's depth in light space and z0, z1 the
/// eye-space depths its near and far planes span. Equal perspective error (m_z) at z0 and z1.
/// Infinite (uniform shadow mapping) when z1 ≤ z0 (light along the view: the duelling frusta).
pub fn n_opt(d: f32, z0: f32, z1: f32) -> f32 {
    let r = (z1 / z0.max(1e-9)).sqrt() - 1.0;
    if r <= 1e-6 { f32::INFINITY } else { d / r }
}

/// The pseudo-plane form of n_opt (Stingl 2011, Eq. 4.2, in its dimensionally consistent form, see
/// NOTES-004 §1.7): equal error at the pseudo-near depth `z0 + pn·(z1 − z0)` and the pseudo-far
/// depth `z1 − pf·(z1 − z0)` (pn, pf ∈ [0, 1)); reduces to [`n_opt`] for pn = pf = 0.
pub fn n_opt_pseudo(d: f32, z0: f32, z1: f32, pn: f32, pf: f32) -> f32 {
    let span = z1 - z0;
    if span <= 1e-9 {
        return f32::INFINITY;
    }
    let a = z0 + pn * span;
    let b = z1 - pf * span;
    d * (z0 + (a * b).max(0.0).sqrt()) / span
}

/// η(γ) of the reparametrised LiSPSM (Lloyd et al., as in Stingl 2011 Eq. 3.3): −1 (uniform) while
/// the light is within Θ/3 of the view direction, rising to 0 (n_opt) by Θ + 0.3·(90° − Θ).
/// `gamma` is the angle between the view and light directions, `theta` half the field of view
/// (radians).
pub fn eta(gamma: f32, theta: f32) -> f32 {
    let right = std::f32::consts::FRAC_PI_2;
    let (ga, gb, gc) = (theta / 3.0, theta, theta + 0.3 * (right - theta));
    let (eb, ec) = (-0.2, 0.0);
    if gamma <= ga {
        -1.0
    } else if gamma <= gb {
        -1.0 + (eb + 1.0) * (gamma - ga) / (gb - ga)
    } else if gamma <= gc {
        eb + (ec - eb) * (right * (gamma - gb) / (gc - gb)).sin()
    } else {
        ec
    }
}

/// The reparametrised warp distance n_repar(η) (Stingl 2011 Eq. 3.4 with the corrected η ≥ 0 branch
/// `(1 + √α)/(η√α + 1)`, NOTES-004 §1.4): η = −1 uniform (∞), 0 LiSPSM's n_opt, 1 PSM.
/// `w` is the warp frustum's depth in light space, α = z1/z0.
pub fn n_repar(w: f32, z0: f32, z1: f32, eta: f32) -> f32 {
    let alpha = z1 / z0.max(1e-9);
    if alpha <= 1.0 + 1e-6 {
        return f32::INFINITY;
    }
    let s = alpha.sqrt();
    let base = w / (alpha - 1.0);
    if eta <= -1.0 {
        f32::INFINITY
    } else if eta < 0.0 {
        base * (1.0 + s - eta * (alpha - 1.0)) / (eta + 1.0)
    } else {
        base * (1.0 + s) / (eta * s + 1.0)
    }
}

/// W_lz of Stingl 2011 Eq. 3.5: the view frustum's extent along the warp axis for an overhead
/// light, from γ, Θ, the near and far distances and the near plane's width `w_e`.
pub fn w_lz(gamma: f32, theta: f32, near: f32, far: f32, w_e: f32) -> f32 {
    let w_s = (far - near) / theta.cos();
    let w_n = w_e * gamma.cos();
    let w_s1 = w_s * (1.0 - (theta - gamma).cos());
    let w_s2 = w_s * (theta + gamma).sin();
    w_n + w_s2 + if gamma <= theta { w_s1 } else { 0.0 }
}

/// The orthographic fit of Stingl 2011 Eq. 3.1, in reversed Z: maps the box `min..max` (in the
/// space the points were transformed to) onto x, y ∈ [−1, 1] and depth ∈ [0, 1] with `max.z` (the
/// side towards the light, in a right-handed light view looking down −z) at depth 1.
pub fn fit_matrix(min: Vec3, max: Vec3) -> Mat4 {
    let e = (max - min).max(Vec3::splat(1e-9));
    Mat4::from_cols(
        Vec4::new(2.0 / e.x, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 2.0 / e.y, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 1.0 / e.z, 0.0),
        Vec4::new(-(max.x + min.x) / e.x, -(max.y + min.y) / e.y, -min.z / e.z, 1.0),
    )
}

/// The light-space perspective warp of LiSPSM, in a light view space whose +y is the warp axis
/// (the view direction projected onto the shadow-map plane): projection centre `c` (behind the
/// body's near face by `n` along +y), with `y_near` the body's near face. It keeps light rays (lines
/// along z) straight and parallel, so a shadow map can still be rendered orthographically after it.
pub fn warp_matrix(c: Vec3, n: f32, d: f32) -> Mat4 {
    // w' = y − c.y; x' = x − c.x; z' = z − c.z; y' = A·w' + B maps w' ∈ [n, n + d] to [0, 1].
    let a = (n + d) / d;
    let b = -n * (n + d) / d;
    Mat4::from_cols(
        Vec4::new(1.0, 0.0, 0.0, 0.0),
        Vec4::new(0.0, a, 0.0, 1.0),
        Vec4::new(0.0, 0.0, 1.0, 0.0),
        Vec4::new(-c.x, -a * c.y + b, -c.z, -c.y),
    )
}

/// Perspective aliasing along the view direction for an overhead directional light (Lloyd et al.
/// 2006, as in Stingl 2011 Eqs. 2.3–2.8), without the resolution ratios: `m_x(z)` and `m_z(z)` for
/// eye depth z in a frustum `near..far`, half field of view `theta`, warp distance `n_warp`
/// (∞: uniform). Multiply by image/shadow-map resolution ratios for texels per pixel.
pub fn perspective_error(z: f32, near: f32, far: f32, theta: f32, n_warp: f32) -> (f32, f32) {
    let k = (far - near) / (2.0 * theta.tan());
    if !n_warp.is_finite() {
        return (far / z, k / z);
    }
    let np = n_warp;
    let mx = far * (np + z - near) / (z * (np + far - near));
    let mz = k * (np + z - near).powi(2) / (z * np * (np + far - near));
    (mx, mz)
}

/// The predicted perspective aliasing error of each split along the view direction (above 1: a
/// texel spans more than a pixel): `steps + 1` samples `(z, m_x, m_z)` per split, at eye depths spaced geometrically over it
/// ([`perspective_error`] times the image/map resolution ratios of a `width × height` image and
/// `map_size`² maps; `focused` is the same frame with focusing on, whose texel size scales the
/// unfocused prediction to the maps actually used). `shadowlab analyze` writes them; the viewer
/// draws them live.
pub fn aliasing_curves(
    frame: &CascadeFrame,
    focused: &CascadeFrame,
    fov_y: f32,
    (width, height): (u32, u32),
    map_size: u32,
    steps: usize,
) -> Vec<Vec<(f32, f32, f32)>> {
    let theta = 0.5 * fov_y;
    let size = map_size.max(1) as f32;
    frame
        .cascades
        .iter()
        .zip(&focused.cascades)
        .map(|(c, f)| {
            let scale = c.view.texel_scale / f.view.texel_scale.max(1e-12);
            let (rx, ry) = (width as f32 / size * scale, height as f32 / size * scale);
            (0..=steps)
                .map(|k| {
                    let z = c.near * (c.far / c.near).powf(k as f32 / steps.max(1) as f32);
                    let (mx, mz) = perspective_error(z, c.near, c.far, theta, c.warp_n);
                    (z, rx * mx, ry * mz)
                })
                .collect()
        })
        .collect()
}

/// Stingl's sampling-frequency colour map (Listing A.3): shadow-map texels per screen pixel →
/// dark red (heavy undersampling) … green (1) … dark blue (heavy oversampling).
pub fn sampling_colour(area: f32) -> Vec3 {
    const BOUNDS: [f32; 7] = [0.0, 1.0 / 7.75, 1.0 / 3.25, 1.0, 3.25, 7.75, 10.0];
    const COLOURS: [Vec3; 7] = [
        Vec3::new(0.2, 0.0, 0.0),
        Vec3::new(1.0, 0.2, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.3, 0.8, 1.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.0, 0.0, 0.4),
    ];
    for i in 0..6 {
        if area >= BOUNDS[i] && area < BOUNDS[i + 1] {
            let t = (area - BOUNDS[i]) / (BOUNDS[i + 1] - BOUNDS[i]);
            return COLOURS[i].lerp(COLOURS[i + 1], t);
        }
    }
    if area.is_nan() { Vec3::ZERO } else { COLOURS[6] }
}

/// Split colours of the overlay (Stingl 2011 Eq. 5.1): red, yellow, green, blue for i mod 4.
pub fn split_colour(i: usize) -> Vec3 {
    [Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, 1.0)][i % 4]
}

/// How the shadow map is warped (Stingl 2011, §3.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Warp {
    /// Uniform (light-space aligned) shadow mapping.
    None,
    /// Perspective shadow maps (Stamminger & Drettakis 2002): warp distance = the near plane.
    Psm,
    /// Light-space perspective shadow maps with n_opt (Wimmer et al. 2004; Wimmer & Scherzer 2006).
    Lispsm,
    /// LiSPSM with n_repar(η(γ)) (Lloyd et al. 2008), robust when the light is near the view direction.
    Repar,
    /// n_repar(η) with a user η ∈ [−1, 1]: −1 uniform, 0 LiSPSM, 1 PSM.
    Arbitrary(f32),
}

impl Warp {
    pub fn parse(name: &str, strength: f32) -> Option<Self> {
        Some(match name {
            "none" => Self::None,
            "psm" => Self::Psm,
            "lispsm" => Self::Lispsm,
            "repar" => Self::Repar,
            "arbitrary" => Self::Arbitrary(strength.clamp(-1.0, 1.0)),
            _ => return None,
        })
    }
}

/// The configuration of a cascaded (focused, warped, partitioned) shadow map.
#[derive(Debug, Clone, PartialEq)]
pub struct CascadeSettings {
    pub focus: bool,
    pub warp: Warp,
    pub splits: usize,
    /// Uniform (0) to logarithmic (1) split blend.
    pub lambda: f32,
    /// Pseudo-near and pseudo-far planes as fractions of the depth range from each end (0: off).
    pub pseudo_near: f32,
    pub pseudo_far: f32,
    /// Quantised scale and texel-snapped offsets (only without warping).
    pub stabilize: bool,
    /// Focused unwarped maps without `stabilize`: the focus box quantised (`quantised_box`).
    pub quantize: bool,
    /// Texels per side of each split's map.
    pub map_size: u32,
    /// A measured visible depth range (the automatic near plane) replacing the adjusted one.
    pub depth_range: Option<(f32, f32)>,
    /// The nearest visible depth measured on the GPU (a frame late), for PSM's warp: PSM puts the
    /// warp's centre at the near plane (n' = n), and the camera's near plane (0.5 m at street
    /// level, where the nearest ground is 3 m away) makes it so strong that far texels cover
    /// metres and thin lit objects shadow themselves. With the true near it is "very good"
    /// (Stingl 2011 §4.3, Fig. 4.3); without one, PSM is held at LiSPSM's strength.
    pub visible_near: Option<f32>,
    /// `scheme=auto` (SDSM, Lauritzen, Salvi and Lefohn 2011): with a measured `depth_range`, the
    /// splits are logarithmic over that tight range, and each directional unwarped split is fitted
    /// to the light-space box of the `samples` it holds. Without a measurement yet (the first
    /// frame), the practical scheme with `lambda` over the adjusted range.
    pub auto: bool,
    /// The visible samples measured on the GPU (a frame or two late), for `auto`.
    pub samples: Option<DepthSamples>,
}

/// Bins of eye depth the GPU sorts the visible samples into, each keeping the light-space box of
/// its samples (`DepthSamples`). Log-spaced over the view's depth range clipped to the scene: over
/// a street view's 0.5 m … 1 km a bin spans 13% of its depth, so a split's box takes in samples at
/// most that much beyond its ends. `shaders/depth_samples.wgsl` holds the same number.
pub const DEPTH_BINS: usize = 64;

/// The eye depths of the `DEPTH_BINS + 1` bin edges over `[near, far]`, logarithmic.
pub fn depth_bin_edges(near: f32, far: f32) -> Vec<f32> {
    let (n, f) = depth_bin_range(near, far);
    (0..=DEPTH_BINS).map(|i| n * (f / n).powf(i as f32 / DEPTH_BINS as f32)).collect()
}

/// `[near, far]` made a valid range for bins (positive, not empty); what the GPU bins over.
pub fn depth_bin_range(near: f32, far: f32) -> (f32, f32) {
    let n = if near.is_finite() { near.max(1e-6) } else { 1e-6 };
    let f = if far.is_finite() { far } else { n * 2.0 };
    (n, f.max(n * (1.0 + 1e-4)))
}

/// The float an order-preserving u32 code stands for (the inverse of `depth_samples.wgsl`'s
/// `ordered`: positive floats with the sign bit set, negative ones with all bits flipped).
pub fn from_ordered(code: u32) -> f32 {
    f32::from_bits(if code & 0x8000_0000 != 0 { code & 0x7fff_ffff } else { !code })
}

/// The order-preserving u32 code of a float (`from_ordered`'s inverse).
pub fn to_ordered(f: f32) -> u32 {
    let b = f.to_bits();
    if b & 0x8000_0000 != 0 { !b } else { b | 0x8000_0000 }
}

/// What a frame's visible samples tell about the splits of a later frame (SDSM's per-partition
/// bounds, Lauritzen et al. 2011 §4): per bin of eye depth, the xy box the samples take in the
/// light's unwarped frame (`light_frame`), and the camera they were seen from.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthSamples {
    /// The light frame the boxes are in; they apply only while a split uses the same one.
    pub light_view: Mat4,
    /// Eye position and unit viewing direction of the frame measured.
    pub eye: Vec3,
    pub forward: Vec3,
    /// `(near, far, min, max)` of each bin that holds samples.
    pub bins: Vec<(f32, f32, Vec2, Vec2)>,
}

impl DepthSamples {
    /// The samples from the words the GPU wrote (`depth_samples.wgsl`): `[min depth, max depth]`
    /// then per bin the ordered codes of min x, min y, max x, max y, binned over `depth_bin_edges
    /// (near, far)`. The first and last bins also hold the samples beyond the edges (the shader
    /// clamps), so their outer edges are widened to the measured range. `None` when the words are
    /// too few or hold no sample.
    pub fn from_words(words: &[u32], light_view: Mat4, near: f32, far: f32, eye: Vec3, forward: Vec3) -> Option<Self> {
        if words.len() < 2 + 4 * DEPTH_BINS {
            return None;
        }
        let (lo, hi) = (f32::from_bits(words[0]), f32::from_bits(words[1]));
        if !(lo <= hi && lo.is_finite() && hi.is_finite()) {
            return None;
        }
        let edges = depth_bin_edges(near, far);
        let mut bins = Vec::new();
        for i in 0..DEPTH_BINS {
            let w = &words[2 + 4 * i..6 + 4 * i];
            let (min, max) =
                (Vec2::new(from_ordered(w[0]), from_ordered(w[1])), Vec2::new(from_ordered(w[2]), from_ordered(w[3])));
            if !(min.is_finite() && max.is_finite() && min.cmple(max).all()) {
                continue;
            }
            let n = if i == 0 { edges[0].min(lo) } else { edges[i] };
            let f = if i + 1 == DEPTH_BINS { edges[i + 1].max(hi) } else { edges[i + 1] };
            bins.push((n, f, min, max));
        }
        (!bins.is_empty()).then_some(Self { light_view, eye, forward, bins })
    }

    /// The union of the boxes of the bins that overlap eye depths `[near, far]` (a bin partly
    /// inside counts whole: the box is never smaller than the split's samples'). `None` when no
    /// sample lies there.
    pub fn box_between(&self, near: f32, far: f32) -> Option<(Vec2, Vec2)> {
        self.bins.iter().filter(|b| b.1 >= near && b.0 <= far).fold(None, |acc, b| match acc {
            None => Some((b.2, b.3)),
            Some((lo, hi)) => Some((lo.min(b.2), hi.max(b.3))),
        })
    }

    /// How far (world units) a sample seen at depth up to `far` may have moved on screen since the
    /// measurement: the eye's displacement plus the turn of the view times the depth. The guard
    /// band of a frame-late fit (0 while the camera stands still).
    pub fn drift(&self, eye: Vec3, forward: Vec3, far: f32) -> f32 {
        let turn = self.forward.dot(forward).clamp(-1.0, 1.0).acos();
        let d = (eye - self.eye).length() + turn * far.max(0.0);
        if d.is_finite() { d } else { f32::INFINITY }
    }
}

/// What the GPU measured of the visible depths, a frame or more before it is used: the tight range
/// (`CascadeSettings::depth_range`, PSM's `visible_near`), the frame it was measured in, and the
/// binned samples of `scheme=auto`. A fresh engine adopts a live engine's, so both fit their maps
/// to the same measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct VisibleDepths {
    pub range: (f32, f32),
    pub frame: u64,
    pub samples: Option<DepthSamples>,
}

/// The unwarped frame of a directional light's maps: looking along `light_dir` from outside the
/// scene's bounding sphere, +y world up (+z when the light is vertical), so that the texel grid does
/// not turn with the camera (a precondition of stabilisation, and what `DepthSamples` are measured in).
pub fn light_frame(light_dir: Vec3, scene: &Aabb) -> Mat4 {
    let up = if light_dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
    light_frame_up(light_dir, scene, up)
}

fn light_frame_up(light_dir: Vec3, scene: &Aabb, up: Vec3) -> Mat4 {
    let radius = 0.5 * scene.diagonal().max(1e-3);
    let eye = scene.center() - light_dir * (radius * 1.5);
    glam::camera::rh::view::look_at_mat4(eye, eye + light_dir, up)
}

/// One split's map.
#[derive(Debug, Clone, PartialEq)]
pub struct Cascade {
    pub view: ShadowView,
    /// Eye-depth range of the split.
    pub near: f32,
    pub far: f32,
    /// The warp distance used (∞: not warped).
    pub warp_n: f32,
    /// PSM had no measured near plane and was held at LiSPSM's strength (`visible_near`).
    pub psm_limited: bool,
    /// The split's frustum does not meet the scene (its map is empty).
    pub empty: bool,
}

/// The cascades of one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct CascadeFrame {
    pub cascades: Vec<Cascade>,
    /// The view depth range after adjustment to V ∩ S (and the measured range).
    pub near: f32,
    pub far: f32,
    /// Angle between the view direction and the light direction, in [0, π/2].
    pub gamma: f32,
}

impl CascadeFrame {
    pub fn split_distances(&self) -> Vec<f32> {
        let mut d: Vec<f32> = self.cascades.iter().map(|c| c.near).collect();
        d.push(self.cascades.last().map_or(self.far, |c| c.far));
        d
    }
}

/// The widest penumbra (world units) that `light` can cast from the occluders in `occluders` onto
/// the scene `scene`: occluder edges as near the light as the occluders' box comes, receivers as far
/// as the scene reaches (for the sun: the scene's depth along the light). The estimate behind
/// `cssm`'s automatic sample counts.
pub fn widest_penumbra(light: &Light, occluders: &Aabb, scene: &Aabb) -> f32 {
    if occluders.is_empty() || light.is_hard() {
        return 0.0;
    }
    match light.position() {
        Some(p) => {
            let nearest = p.clamp(occluders.min, occluders.max).distance(p);
            let far = scene.corners().iter().map(|c| c.distance(p)).fold(0.0f32, f32::max);
            // An occluder closer than 5% of the scene's reach would make every penumbra "infinite":
            // such blockers shade little of what the camera sees.
            2.0 * light.penumbra_half_width(nearest.max(0.05 * far), far)
        }
        None => {
            let dir = light.direction().unwrap_or(Vec3::NEG_Y).normalize_or(Vec3::NEG_Y);
            let depth = scene.extent().abs().dot(dir.abs());
            2.0 * light.penumbra_half_width(0.0, depth)
        }
    }
}

/// `cssm`'s automatic sample count per axis for a cascade whose penumbrae are `width_px` pixels wide
/// on screen: k hard-edge copies split a penumbra into k steps, which stay invisible (under the 3 × 3
/// PCF) while at most `step_px` pixels wide: k = ⌈width/step⌉, clamped to 2…5 (Azri 2020's counts
/// are k = 4, 3, 2; 5 is the 25 of its Dragon scene).
pub fn samples_per_axis(width_px: f32, step_px: f32) -> u32 {
    let k = (width_px / step_px.max(1e-3)).ceil();
    if k.is_nan() { 2 } else { (k as u32).clamp(2, 5) }
}

/// The width of `points` seen along `axis` (unit): the largest distance between two of them in the
/// plane perpendicular to it. A map fitted to the points spans about this much.
pub fn width_across(points: &[Vec3], axis: Vec3) -> f32 {
    let axis = axis.normalize_or(Vec3::NEG_Y);
    let flat: Vec<Vec3> = points.iter().map(|&p| p - axis * p.dot(axis)).collect();
    let mut widest = 0.0f32;
    for (i, a) in flat.iter().enumerate() {
        for b in &flat[i + 1..] {
            widest = widest.max(a.distance(*b));
        }
    }
    if widest.is_finite() { widest } else { 0.0 }
}

/// `cssm`'s automatic map size for a cascade: the smallest power of two whose texels, over a map
/// `width` world units wide, are no larger than `texel` (a fraction of a screen pixel at the
/// cascade's near depth: the texel-to-pixel match of cascaded shadow maps, Dimitrov 2007), clamped
/// to `min..=max`. Azri 2020 shrinks far maps by hand (1024/512/128), which suits wide penumbrae
/// but blurs sharp ones (the sun).
pub fn map_size_for(width: f32, texel: f32, min: u32, max: u32) -> u32 {
    let (min, max) = (min.max(1), max.max(min.max(1)));
    let texels = width / texel;
    if !texels.is_finite() || texels <= min as f32 {
        return if texels.is_finite() { min } else { max };
    }
    (texels.ceil() as u32).checked_next_power_of_two().unwrap_or(max).clamp(min, max)
}

/// World size of one pixel at eye depth `depth` for a vertical field of view `fov_y` over `height`
/// pixels.
pub fn pixel_size(depth: f32, fov_y: f32, height: u32) -> f32 {
    2.0 * depth.max(0.0) * (0.5 * fov_y).tan() / height.max(1) as f32
}

/// The view's depth range clipped to the scene: the min and max view-axis distance over the vertices
/// of V ∩ S (Stingl 2011, §3.3.1, after Zhang et al. 2007). `None` when the view misses the scene.
pub fn adjusted_depth_range(view: &View, aspect: f32, scene: &Aabb) -> Option<(f32, f32)> {
    let v = ConvexBody::from_frustum(&(view.projection(aspect) * view.view_matrix()));
    let h = v.clip_to_aabb(scene);
    let f = view.forward();
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for p in h.points() {
        let z = (p - view.position).dot(f);
        lo = lo.min(z);
        hi = hi.max(z);
    }
    (lo <= hi).then(|| (lo.max(view.near), hi.min(view.far).max(lo.max(view.near) * (1.0 + 1e-4))))
}

/// Computes the split maps of a directional or spot light for `view` (Stingl 2011, §3.4): adjust the
/// depth range, split it, then per split focus on B_i, warp (directional lights) and fit.
pub fn compute_cascades(light: &Light, scene: &Aabb, view: &View, aspect: f32, s: &CascadeSettings) -> CascadeFrame {
    let (mut near, mut far) = adjusted_depth_range(view, aspect, scene).unwrap_or((view.near, view.far));
    let mut lambda = s.lambda;
    if let Some((lo, hi)) = s.depth_range {
        // The measured range is what the camera sees; it never widens the adjusted one. The auto
        // scheme's is a frame or more old: a guard band of 10% on each side (a camera walking
        // towards a wall gets nearer than it was by less than that in a frame).
        let (lo, hi) = if s.auto { (lo * 0.9, hi * 1.1) } else { (lo, hi) };
        near = lo.max(near).min(far);
        far = hi.min(far).max(near * (1.0 + 1e-4));
        if s.auto {
            // Lauritzen et al. 2011 §3: logarithmic partitions over the tight range are close to
            // the best fixed ones for any view (the log scheme's fault is only the near plane).
            lambda = 1.0;
        }
    }
    let forward = view.forward();
    let m = s.splits.max(1);
    let span = far - near;
    let (pn, pf) = (near + s.pseudo_near.clamp(0.0, 0.99) * span, far - s.pseudo_far.clamp(0.0, 0.99) * span);
    let distances = split_distances(near, far, m, lambda, pn, pf.max(pn * (1.0 + 1e-4)));
    let light_dir = light.direction().unwrap_or(Vec3::NEG_Y).normalize();
    let gamma = forward.dot(-light_dir).abs().min(1.0).acos();
    let mut cascades = Vec::with_capacity(m);
    for i in 0..m {
        let (cn, cf) = (distances[i], distances[i + 1]);
        let split_view = View { near: cn, far: cf.max(cn * (1.0 + 1e-5)), ..view.clone() };
        let body = ConvexBody::from_frustum(&(split_view.projection(aspect) * split_view.view_matrix()));
        let cascade = match light.kind {
            LightKind::Spot { position, direction, outer_angle, .. } => {
                spot_cascade(position, direction, outer_angle, scene, &body, s, cn, cf)
            }
            _ => {
                let (pn_i, pf_i) =
                    (if i == 0 { s.pseudo_near } else { 0.0 }, if i + 1 == m { s.pseudo_far } else { 0.0 });
                directional_cascade(light_dir, scene, view, &body, s, cn, cf, gamma, (pn_i, pf_i))
            }
        };
        cascades.push(cascade);
    }
    CascadeFrame { cascades, near, far, gamma }
}

#[allow(clippy::too_many_arguments)]
fn directional_cascade(
    light_dir: Vec3,
    scene: &Aabb,
    view: &View,
    body: &ConvexBody,
    s: &CascadeSettings,
    near: f32,
    far: f32,
    gamma: f32,
    (pn, pf): (f32, f32),
) -> Cascade {
    let forward = view.forward();
    // The light frame: +y along the view direction projected onto the shadow-map plane when warping
    // (LiSPSM's light space), a fixed frame otherwise (so the texel grid does not turn with the
    // camera: a precondition of stabilisation).
    let projected = forward - light_dir * forward.dot(light_dir);
    let warping = s.warp != Warp::None && projected.length() > 1e-3;
    let light_view =
        if warping { light_frame_up(light_dir, scene, projected.normalize()) } else { light_frame(light_dir, scene) };
    let eye = light_view.inverse().transform_point3(Vec3::ZERO);
    let mut points: Vec<Vec3> = if s.focus {
        crate::convex::directional_focus_points(body, scene, light_dir)
    } else {
        scene.corners().to_vec()
    };
    let empty = points.is_empty();
    if empty {
        // The split misses the scene: a tiny map at the scene centre, which no pixel will use.
        points = vec![scene.center(), scene.center() + Vec3::splat(1e-3)];
    }
    let ls: Vec<Vec3> = points.iter().map(|&p| light_view.transform_point3(p)).collect();
    let mut bounds = Aabb::from_points(ls.iter().copied());
    let fitted = if warping || empty || !s.auto || !s.focus { None } else { s.samples.as_ref() };
    // The same frame up to rounding (its translation is of the scene's size).
    let same_frame = |m: &Mat4| m.abs_diff_eq(light_view, 1e-5 * (1.0 + light_view.w_axis.truncate().length()));
    if let Some(samples) = fitted.filter(|d| same_frame(&d.light_view)) {
        // SDSM's per-partition bounds (Lauritzen et al. 2011 §4): the focus box cut down to the
        // samples the split held when measured, grown by a guard band (2% of the box, and how far
        // the view has moved since, which also widens the depths taken). Where they no longer
        // overlap, the focus box stays.
        let drift = samples.drift(view.position, forward, far);
        if let Some((lo, hi)) = samples.box_between(near - drift, far + drift) {
            let pad = 0.02 * (hi - lo).max_element() + drift;
            let (lo, hi) = (lo - Vec2::splat(pad), hi + Vec2::splat(pad));
            let (cut_lo, cut_hi) = (bounds.min.truncate().max(lo), bounds.max.truncate().min(hi));
            if cut_lo.cmplt(cut_hi).all() {
                bounds.min = cut_lo.extend(bounds.min.z);
                bounds.max = cut_hi.extend(bounds.max.z);
            }
        }
    }
    // Depth covers the whole scene along the light (casters anywhere above the body).
    let scene_ls = Aabb::from_points(scene.corners().iter().map(|&c| light_view.transform_point3(c)));
    let (z_min, z_max) = (scene_ls.min.z.min(bounds.min.z), scene_ls.max.z.max(bounds.max.z));

    let mut warp_n = f32::INFINITY;
    let mut psm_limited = false;
    let mut warp = Mat4::IDENTITY;
    if warping && !empty {
        let d = (bounds.max.y - bounds.min.y).max(1e-4);
        // The projection centre moves continuously with the camera (Stingl 2011, §4.1): the light-space
        // x (and z) of the point s on the view vector at the split's near distance.
        let s_ls = light_view.transform_point3(view.position + forward * near);
        let c_start = Vec3::new(s_ls.x, bounds.min.y, s_ls.z);
        let inv = light_view.inverse();
        let depth_of = |p_ls: Vec3| (inv.transform_point3(p_ls) - view.position).dot(forward);
        let z0 = depth_of(c_start).max(near).max(1e-4);
        let z1 = depth_of(c_start + Vec3::Y * d).max(z0 * (1.0 + 1e-4));
        let theta = 0.5 * view.fov_y;
        warp_n = match s.warp {
            Warp::None => f32::INFINITY,
            Warp::Psm => match s.visible_near {
                // n' = n with the nearest depth the split really shows.
                Some(v) if z1 > v.max(z0) * (1.0 + 1e-4) => d * v.max(z0) / (z1 - v.max(z0)),
                Some(_) => f32::INFINITY,
                None => {
                    let (psm, lispsm) = (d * z0 / (z1 - z0), n_opt(d, z0, z1));
                    psm_limited = psm < lispsm;
                    psm.max(lispsm)
                }
            },
            Warp::Lispsm if pn > 0.0 || pf > 0.0 => n_opt_pseudo(d, z0, z1, pn, pf),
            Warp::Lispsm => n_opt(d, z0, z1),
            Warp::Repar => n_repar(d, z0, z1, eta(gamma, theta)),
            Warp::Arbitrary(e) => n_repar(d, z0, z1, e),
        };
        if warp_n.is_finite() && warp_n > 0.0 {
            let c = Vec3::new(c_start.x, c_start.y - warp_n, c_start.z);
            warp = warp_matrix(c, warp_n, d);
        } else {
            warp_n = f32::INFINITY;
        }
    }
    let size = s.map_size.max(1) as f32;
    let (min, max) = if warp_n.is_finite() {
        let w: Vec<Vec3> = ls.iter().map(|&p| warp.project_point3(p)).collect();
        let b = Aabb::from_points(w.iter().copied());
        // Depth range of the whole scene column, through the warp: extend z by the scene's extent.
        let zc: Vec<f32> = ls
            .iter()
            .flat_map(|&p| {
                [warp.project_point3(Vec3::new(p.x, p.y, z_min)).z, warp.project_point3(Vec3::new(p.x, p.y, z_max)).z]
            })
            .collect();
        let (lo, hi) =
            (zc.iter().copied().fold(f32::INFINITY, f32::min), zc.iter().copied().fold(f32::NEG_INFINITY, f32::max));
        (Vec3::new(b.min.x, b.min.y, lo), Vec3::new(b.max.x, b.max.y, hi))
    } else if s.stabilize {
        stabilized_box(&bounds, &scene_ls, size, s.auto)
    } else if s.quantize && s.focus && !warping && !empty {
        let (lo, hi) = quantised_box(&bounds, size);
        (Vec3::new(lo.x, lo.y, z_min), Vec3::new(hi.x, hi.y, z_max))
    } else {
        (Vec3::new(bounds.min.x, bounds.min.y, z_min), Vec3::new(bounds.max.x, bounds.max.y, z_max))
    };
    // A texel of margin on each side for filter kernels at the border.
    let pad = (max - min) / size;
    let (min, max) = (
        Vec3::new(min.x - pad.x, min.y - pad.y, min.z - 0.01 * (max.z - min.z)),
        Vec3::new(max.x + pad.x, max.y + pad.y, max.z + 0.01 * (max.z - min.z)),
    );
    let fit = fit_matrix(min, max);
    let projection = fit * warp;
    let texel_scale = if warp_n.is_finite() {
        (bounds.max.x - bounds.min.x).max(bounds.max.y - bounds.min.y) / size
    } else {
        (max.x - min.x).max(max.y - min.y) / size
    };
    // A warped map stores the light-space depth over the scene's column, not the warp's z/w (see
    // `ShadowView::linear_depth`): reversed, 1 at the side towards the light. The splits of a warped
    // technique that end up unwarped (the light along the view) store the same thing: their
    // orthographic depth, which is affine already.
    let view_projection = projection * light_view;
    let (linear_depth, far_distance) = if warp_n.is_finite() {
        let (lo, hi) = (z_min - 0.01 * (z_max - z_min), z_max + 0.01 * (z_max - z_min));
        let row = (light_view.row(2) - Vec4::new(0.0, 0.0, 0.0, lo)) / (hi - lo).max(1e-9);
        (Some(row), hi - lo)
    } else if s.warp != Warp::None {
        (Some(view_projection.row(2)), z_max - z_min)
    } else {
        (None, z_max - z_min)
    };
    Cascade {
        view: ShadowView {
            view: light_view,
            projection,
            view_projection,
            eye,
            axis: light_dir,
            orthographic: true,
            near: 0.0,
            far: far_distance,
            texel_scale,
            linear_depth,
        },
        near,
        far,
        warp_n,
        psm_limited,
        empty,
    }
}

/// Stabilised focus (Stingl 2011, §3.5, Zhang et al. 2009's approximated solution): the square
/// extent quantised to 64 levels of the scene's extent, the centre snapped to whole texels, the
/// depth range that of the whole scene. Small camera motions then move no texel boundary.
/// `octaves` (`scheme=auto`, whose boxes follow the visible samples and so change size every frame
/// of a walk): the extent a power-of-two fraction of the scene's (down to 1/4096), so the texel size
/// changes only when the samples' box crosses an octave, at the cost of up to half the resolution.
fn stabilized_box(bounds: &Aabb, scene_ls: &Aabb, size: f32, octaves: bool) -> (Vec3, Vec3) {
    const LEVELS: f32 = 64.0;
    let full = (scene_ls.max.x - scene_ls.min.x).max(scene_ls.max.y - scene_ls.min.y).max(1e-6);
    let want = (bounds.max.x - bounds.min.x).max(bounds.max.y - bounds.min.y) * (1.0 + 4.0 / size);
    let fraction = if octaves {
        let f = (want / full).max(1.0 / 4096.0).log2().ceil().exp2();
        if f.is_finite() { f.clamp(1.0 / 4096.0, 1.0) } else { 1.0 }
    } else {
        ((want / full * LEVELS).ceil() / LEVELS).clamp(1.0 / LEVELS, 1.0)
    };
    let extent = fraction * full;
    let texel = extent / size;
    let c = bounds.center();
    let (cx, cy) = ((c.x / texel).round() * texel, (c.y / texel).round() * texel);
    (
        Vec3::new(cx - 0.5 * extent, cy - 0.5 * extent, scene_ls.min.z),
        Vec3::new(cx + 0.5 * extent, cy + 0.5 * extent, scene_ls.max.z),
    )
}

/// Quantised focus, for unwarped focused maps without `stabilize`: each side of the focus box
/// rounded up to a level of a geometric ladder (eight to an octave: at most 9% of resolution lost)
/// and its centre snapped to whole texels, so that while the camera walks the texel grid stays put
/// and a static edge does not crawl from frame to frame (issue 19 item 4: focused maps shimmered
/// 6× as much as `hard` along the city's street). Unlike `stabilized_box`, the box is not square
/// and not a fraction of the scene, so a small split keeps its small texels.
fn quantised_box(bounds: &Aabb, size: f32) -> (Vec2, Vec2) {
    const PER_OCTAVE: f32 = 8.0;
    let level = |extent: f32| -> f32 {
        let want = (extent * (1.0 + 4.0 / size)).max(1e-4);
        ((want.log2() * PER_OCTAVE).ceil() / PER_OCTAVE).exp2()
    };
    let extent = Vec2::new(level(bounds.max.x - bounds.min.x), level(bounds.max.y - bounds.min.y));
    let texel = extent / size;
    let c = bounds.center().truncate();
    let c = (c / texel).round() * texel;
    (c - 0.5 * extent, c + 0.5 * extent)
}

/// A spot light's split map: its perspective frustum focused (in post-perspective space) on the
/// split's visible part of the scene. Warping does not apply.
#[allow(clippy::too_many_arguments)]
fn spot_cascade(
    position: Vec3,
    direction: Vec3,
    outer: f32,
    scene: &Aabb,
    body: &ConvexBody,
    s: &CascadeSettings,
    near: f32,
    far: f32,
) -> Cascade {
    let base = crate::lightspace::point_frusta(position, scene, Some((direction, outer)), s.map_size).views[0];
    let h = body.clip_to_aabb(scene);
    let pts: Vec<Vec3> = if s.focus { h.points().collect() } else { Vec::new() };
    let empty = s.focus && pts.is_empty();
    let (min, max) = if s.focus && !empty {
        // x, y: where the visible points fall on the light's image (clamped to it); depth: from the
        // light's near plane (casters may sit anywhere in front) to the farthest visible point.
        let ndc: Vec<Vec3> = pts.iter().map(|&p| base.view_projection.project_point3(p)).collect();
        let b = Aabb::from_points(ndc.iter().map(|p| p.clamp(Vec3::new(-1.0, -1.0, 0.0), Vec3::ONE)));
        (Vec3::new(b.min.x, b.min.y, b.min.z), Vec3::new(b.max.x, b.max.y, 1.0))
    } else {
        (Vec3::new(-1.0, -1.0, 0.0), Vec3::ONE)
    };
    let pad = (max - min) / s.map_size.max(1) as f32;
    let fit =
        fit_matrix(Vec3::new(min.x - pad.x, min.y - pad.y, min.z), Vec3::new(max.x + pad.x, max.y + pad.y, max.z));
    let projection = fit * base.projection;
    let shrink = ((max.x - min.x).max(max.y - min.y) * 0.5).max(1e-6);
    Cascade {
        view: ShadowView {
            projection,
            view_projection: projection * base.view,
            texel_scale: base.texel_scale * shrink,
            ..base
        },
        near,
        far,
        warp_n: f32::INFINITY,
        psm_limited: false,
        empty,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_splits_replace_the_scheme_and_stay_ordered() {
        let mut c = split_distances(0.1, 10.0, 3, 0.5, 0.1, 10.0);
        let auto = c.clone();
        fix_splits(&mut c, &[2.0, 0.0]);
        assert_eq!((c[0], c[1], c[2], c[3]), (0.1, 2.0, auto[2], 10.0));
        // Out of range, unordered, NaN: clamped into a partition.
        let mut c = auto.clone();
        fix_splits(&mut c, &[50.0, 1.0, f32::NAN]);
        assert_eq!(c, vec![0.1, 10.0, 10.0, 10.0]);
        let mut c = auto.clone();
        fix_splits(&mut c, &[f32::NAN, -1.0]);
        assert_eq!(c, auto);
        assert!(c.windows(2).all(|w| w[0] <= w[1]));
    }

    fn close(a: &[f32], b: &[f32], tol: f32) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol * y.abs().max(1.0))
    }

    #[test]
    fn split_schemes_match_the_documents_values() {
        // NOTES-004 §6.4 (derived from Eqs. 3.6-3.8): n = 1, f = 1000, m = 4.
        let s = |l| split_distances(1.0, 1000.0, 4, l, 1.0, 1000.0);
        assert!(close(&s(0.0), &[1.0, 250.75, 500.5, 750.25, 1000.0], 1e-5), "{:?}", s(0.0));
        assert!(close(&s(1.0), &[1.0, 5.623, 31.623, 177.828, 1000.0], 1e-4), "{:?}", s(1.0));
        assert!(close(&s(0.5), &[1.0, 128.187, 266.061, 464.039, 1000.0], 1e-4), "{:?}", s(0.5));
        let p = split_distances(1.0, 300.0, 4, 0.5, 1.0, 300.0);
        assert!(close(&p, &[1.0, 39.956, 83.910, 148.667, 300.0], 1e-4), "{p:?}");
        // C_0 = n and C_m = f whatever λ and the pseudo planes.
        let q = split_distances(2.0, 500.0, 3, 0.7, 20.0, 300.0);
        assert_eq!((q[0], q[3]), (2.0, 500.0));
        assert_eq!(split_distances(1.0, 10.0, 1, 0.5, 1.0, 10.0), vec![1.0, 10.0]);
    }

    #[test]
    fn n_opt_balances_the_z_error() {
        // n = 1, f = 40, d = f − n: n_opt = 7.32456 and m_z equal at both ends (0.158114 without
        // the resolution factors and the (f − n)/(2 tan Θ) scale).
        let n = n_opt(39.0, 1.0, 40.0);
        assert!((n - 7.32456).abs() < 1e-4, "{n}");
        let theta = 30f32.to_radians();
        let (_, a) = perspective_error(1.0, 1.0, 40.0, theta, n);
        let (_, b) = perspective_error(40.0, 1.0, 40.0, theta, n);
        assert!((a - b).abs() < 1e-4 * a, "{a} vs {b}");
        let k = 39.0 / (2.0 * theta.tan());
        assert!((a / k - 0.158114).abs() < 1e-5, "{}", a / k);
        assert!(n_opt(10.0, 5.0, 5.0).is_infinite(), "duelling frusta → uniform");
        assert!((n_opt_pseudo(39.0, 1.0, 40.0, 0.0, 0.0) - n).abs() < 1e-4);
    }

    #[test]
    fn error_metric_limits() {
        let theta = 30f32.to_radians();
        let (n, f) = (1.0, 40.0);
        for z in [1.0, 5.0, 40.0] {
            // PSM (n' = n): m_x constant 1, m_z ∝ z/(n f).
            let (mx, mz) = perspective_error(z, n, f, theta, n);
            assert!((mx - 1.0).abs() < 1e-5);
            let k = (f - n) / (2.0 * theta.tan());
            assert!((mz - k * z / (n * f)).abs() < 1e-4 * mz);
            // Uniform as the limit of large n'.
            let (ux, uz) = perspective_error(z, n, f, theta, f32::INFINITY);
            let (lx, lz) = perspective_error(z, n, f, theta, 1.0e7);
            assert!((ux - lx).abs() < 1e-3 * ux && (uz - lz).abs() < 1e-3 * uz);
        }
        // At z = f, m_x = 1 for every n'.
        for np in [1.0, 7.3, 100.0] {
            assert!((perspective_error(f, n, f, theta, np).0 - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn n_repar_is_continuous_and_has_its_limits() {
        let (w, z0, z1) = (39.0, 1.0, 40.0);
        assert!(n_repar(w, z0, z1, -1.0).is_infinite(), "η = −1: uniform");
        assert!((n_repar(w, z0, z1, 0.0) - n_opt(w, z0, z1)).abs() < 1e-4, "η = 0: n_opt");
        assert!((n_repar(w, z0, z1, 1.0) - 1.0).abs() < 1e-5, "η = 1: PSM, n' = n");
        // Continuous at η = 0 from both sides.
        assert!((n_repar(w, z0, z1, -1e-4) - n_repar(w, z0, z1, 1e-4)).abs() < 1e-2);
        // η(γ) is continuous at γ_a, γ_b, γ_c: −1 → −0.2 → 0.
        let theta = 30f32.to_radians();
        let right = std::f32::consts::FRAC_PI_2;
        let (ga, gb, gc) = (theta / 3.0, theta, theta + 0.3 * (right - theta));
        let e = 1e-5;
        for (g, want) in [(ga, -1.0), (gb, -0.2), (gc, 0.0)] {
            assert!((eta(g - e, theta) - want).abs() < 1e-3 && (eta(g + e, theta) - want).abs() < 1e-3, "γ = {g}");
        }
        // W_lz at γ = 90° is f − n.
        assert!((w_lz(right, theta, 1.0, 40.0, 1.15) - 39.0).abs() < 1e-3);
    }

    #[test]
    fn fit_maps_the_box_to_the_clip_cube() {
        let (min, max) = (Vec3::new(-3.0, 2.0, -40.0), Vec3::new(5.0, 6.0, -10.0));
        let m = fit_matrix(min, max);
        assert!((m.transform_point3(min) - Vec3::new(-1.0, -1.0, 0.0)).length() < 1e-5);
        assert!((m.transform_point3(max) - Vec3::new(1.0, 1.0, 1.0)).length() < 1e-5);
    }

    #[test]
    fn warp_keeps_light_rays_parallel_and_maps_near_far() {
        let c = Vec3::new(1.0, -5.0, 2.0);
        let (n, d) = (5.0, 20.0);
        let w = warp_matrix(c, n, d);
        // A light ray: fixed x, y, varying z.
        let a = w.project_point3(Vec3::new(3.0, 4.0, -1.0));
        let b = w.project_point3(Vec3::new(3.0, 4.0, -9.0));
        assert!((a.x - b.x).abs() < 1e-6 && (a.y - b.y).abs() < 1e-6 && a.z > b.z);
        // The near face (y = c.y + n) maps to 0, the far face to 1.
        assert!(w.project_point3(Vec3::new(0.0, c.y + n, 0.0)).y.abs() < 1e-6);
        assert!((w.project_point3(Vec3::new(0.0, c.y + n + d, 0.0)).y - 1.0).abs() < 1e-6);
    }

    fn settings(warp: Warp, splits: usize) -> CascadeSettings {
        CascadeSettings {
            focus: true,
            warp,
            splits,
            lambda: 0.5,
            pseudo_near: 0.0,
            pseudo_far: 0.0,
            stabilize: false,
            quantize: true,
            map_size: 1024,
            depth_range: None,
            visible_near: None,
            auto: false,
            samples: None,
        }
    }

    #[test]
    fn psm_takes_the_visible_near_plane_or_lispsm_strength() {
        let (light, scene, view) = terrain_like();
        let aspect = 4.0 / 3.0;
        let lispsm = compute_cascades(&light, &scene, &view, aspect, &settings(Warp::Lispsm, 1));
        // Without a measured near plane PSM (n' = n = 0.5 m) would be far stronger than LiSPSM: held there.
        let held = compute_cascades(&light, &scene, &view, aspect, &settings(Warp::Psm, 1));
        assert!(held.cascades[0].psm_limited);
        assert_eq!(held.cascades[0].warp_n, lispsm.cascades[0].warp_n);
        // With the nearest visible depth (6 m) PSM's own n' = d·z0/(z1 − z0): stronger than LiSPSM
        // and weaker than with the camera's near plane.
        let measured = compute_cascades(
            &light,
            &scene,
            &view,
            aspect,
            &CascadeSettings { visible_near: Some(6.0), ..settings(Warp::Psm, 1) },
        );
        let c = &measured.cascades[0];
        assert!(!c.psm_limited);
        assert!(c.warp_n < lispsm.cascades[0].warp_n, "{} vs {}", c.warp_n, lispsm.cascades[0].warp_n);
        let unclamped = compute_cascades(
            &light,
            &scene,
            &view,
            aspect,
            &CascadeSettings { visible_near: Some(0.0), ..settings(Warp::Psm, 1) },
        );
        assert!(unclamped.cascades[0].warp_n < c.warp_n);
    }

    #[test]
    fn warped_maps_store_linear_depth_that_keeps_far_receivers_apart() {
        let (light, scene, view) = terrain_like();
        let frame = compute_cascades(
            &light,
            &scene,
            &view,
            4.0 / 3.0,
            &CascadeSettings { visible_near: Some(0.0), ..settings(Warp::Psm, 1) },
        );
        let v = &frame.cascades[0].view;
        assert!(v.linear_depth.is_some());
        // Two points on one light ray 1 m apart, 900 m from the eye: their stored depths differ by
        // 1 m over the scene's column (about 1/700 here), not by that divided by the warp's w.
        let far = view.position + view.forward() * 900.0;
        let (a, b) = (v.project(far), v.project(far + light.direction().unwrap()));
        assert!((a.x - b.x).abs() < 1e-4 && (a.y - b.y).abs() < 1e-4, "{a} {b}");
        assert!(a.z - b.z > 1e-3, "{} {}", a.z, b.z);
        // Unwarped maps keep their projective (affine already) depth.
        let plain = compute_cascades(&light, &scene, &view, 4.0 / 3.0, &settings(Warp::None, 1));
        assert!(plain.cascades[0].view.linear_depth.is_none());
    }

    fn terrain_like() -> (Light, Aabb, View) {
        let scene = Aabb::new(Vec3::new(-400.0, -30.0, -400.0), Vec3::new(400.0, 60.0, 400.0));
        let light = Light::new(
            "sun",
            LightKind::Directional { direction: Vec3::new(0.7, -0.5, 0.4).normalize(), angular_radius: 0.0 },
            Vec3::ONE,
            1.0,
        );
        let view = View::new("ground", Vec3::new(-150.0, 5.0, 300.0), Vec3::new(80.0, 0.0, -300.0), 0.5, 1000.0);
        (light, scene, view)
    }

    /// Every point of each split's V_i ∩ S lands inside that split's map.
    fn assert_splits_cover(frame: &CascadeFrame, view: &View, scene: &Aabb) {
        let d = frame.split_distances();
        assert!(d.windows(2).all(|w| w[1] >= w[0]), "{d:?}");
        for c in &frame.cascades {
            let v = View { near: c.near, far: c.far, ..view.clone() };
            let h = ConvexBody::from_frustum(&(v.projection(1.5) * v.view_matrix())).clip_to_aabb(scene);
            for p in h.points() {
                let uvz = c.view.project(p);
                let e = 1e-3;
                assert!(
                    uvz.x > -e && uvz.x < 1.0 + e && uvz.y > -e && uvz.y < 1.0 + e,
                    "{p} → {uvz} (warp n {})",
                    c.warp_n
                );
                assert!(uvz.z > -e && uvz.z < 1.0 + e, "{p} → {uvz}");
            }
        }
    }

    #[test]
    fn cascades_cover_their_splits() {
        let (light, scene, view) = terrain_like();
        for warp in [Warp::None, Warp::Lispsm, Warp::Repar, Warp::Psm] {
            for splits in [1, 4] {
                let f = compute_cascades(&light, &scene, &view, 1.5, &settings(warp, splits));
                assert_eq!(f.cascades.len(), splits);
                assert!(f.near >= view.near && f.far <= view.far);
                if warp == Warp::Lispsm {
                    assert!(
                        f.cascades.iter().all(|c| c.warp_n.is_finite()),
                        "LiSPSM warps when the light crosses the view"
                    );
                }
                assert_splits_cover(&f, &view, &scene);
            }
        }
    }

    #[test]
    fn ordered_codes_keep_the_order_of_floats() {
        let values = [f32::NEG_INFINITY, -1e30, -2.5, -1e-30, -0.0, 0.0, 1e-30, 2.5, 1e30, f32::INFINITY];
        for w in values.windows(2) {
            assert!(to_ordered(w[0]) <= to_ordered(w[1]), "{} {}", w[0], w[1]);
        }
        for v in values {
            assert_eq!(from_ordered(to_ordered(v)).to_bits(), v.to_bits());
        }
        // The shader's empty words decode to no box: NaN minima and maxima.
        assert!(from_ordered(u32::MAX).is_nan() && from_ordered(0).is_nan());
    }

    /// The visible ground (y = 0) of `view` on a `n` × `n` grid of screen points, as the GPU's
    /// depth buffer would hold it.
    fn ground_samples(view: &View, aspect: f32, scene: &Aabb, n: usize) -> Vec<Vec3> {
        let inv = (view.projection(aspect) * view.view_matrix()).inverse();
        let mut out = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let ndc = Vec2::new((i as f32 + 0.5) / n as f32 * 2.0 - 1.0, (j as f32 + 0.5) / n as f32 * 2.0 - 1.0);
                let far = inv.project_point3(ndc.extend(0.5));
                let dir = (far - view.position).normalize();
                if dir.y >= -1e-4 {
                    continue;
                }
                let p = view.position + dir * (-view.position.y / dir.y);
                let d = (p - view.position).dot(view.forward());
                if scene.contains(p) && d > view.near && d < view.far {
                    out.push(p);
                }
            }
        }
        out
    }

    /// The words `depth_samples.wgsl` writes for `points` (the same binning, on the CPU).
    fn sample_words(points: &[Vec3], view: &View, light_view: Mat4, near: f32, far: f32) -> Vec<u32> {
        let (n, f) = depth_bin_range(near, far);
        let mut w = vec![0x7f7f_ffff, 0];
        for _ in 0..DEPTH_BINS {
            w.extend([u32::MAX, u32::MAX, 0, 0]);
        }
        for &p in points {
            let d = (p - view.position).dot(view.forward());
            w[0] = w[0].min(d.to_bits());
            w[1] = w[1].max(d.to_bits());
            let t = (d / n).ln() * DEPTH_BINS as f32 / (f / n).ln();
            let b = t.floor().clamp(0.0, DEPTH_BINS as f32 - 1.0) as usize;
            let xy = light_view.transform_point3(p);
            let k = 2 + 4 * b;
            w[k] = w[k].min(to_ordered(xy.x));
            w[k + 1] = w[k + 1].min(to_ordered(xy.y));
            w[k + 2] = w[k + 2].max(to_ordered(xy.x));
            w[k + 3] = w[k + 3].max(to_ordered(xy.y));
        }
        w
    }

    #[test]
    fn auto_splits_fit_the_visible_samples() {
        let (light, scene, view) = terrain_like();
        let aspect = 1.5;
        let points = ground_samples(&view, aspect, &scene, 96);
        // Enough ground under the view to fill every split (measured 4608 samples; bound a quarter).
        assert!(points.len() > 1000, "{}", points.len());
        let light_view = light_frame(light.direction().unwrap(), &scene);
        let (near, far) = adjusted_depth_range(&view, aspect, &scene).unwrap();
        let words = sample_words(&points, &view, light_view, near, far);
        let samples = DepthSamples::from_words(&words, light_view, near, far, view.position, view.forward()).unwrap();
        let range = (f32::from_bits(words[0]), f32::from_bits(words[1]));
        let auto = CascadeSettings { auto: true, ..settings(Warp::None, 4) };
        // No measurement yet: the practical scheme over the adjusted range, as without `auto`.
        let first = compute_cascades(&light, &scene, &view, aspect, &auto);
        assert_eq!(
            first.split_distances(),
            compute_cascades(&light, &scene, &view, aspect, &settings(Warp::None, 4)).split_distances()
        );
        // Measured: log splits over the tight range with its 10% guard band.
        let ranged = CascadeSettings { depth_range: Some(range), ..auto.clone() };
        let unfitted = compute_cascades(&light, &scene, &view, aspect, &ranged);
        let d = unfitted.split_distances();
        assert!(
            (d[0] - 0.9 * range.0).abs() < 1e-3 * range.0 && (d[4] - 1.1 * range.1).abs() < 1e-3 * range.1,
            "{d:?} {range:?}"
        );
        assert!(((d[1] / d[0]) / (d[4] / d[3]) - 1.0).abs() < 1e-3, "log: equal ratios {d:?}");
        let fitted = compute_cascades(
            &light,
            &scene,
            &view,
            aspect,
            &CascadeSettings { samples: Some(samples.clone()), ..ranged.clone() },
        );
        assert_eq!(fitted.split_distances(), d);
        // Every sample lands inside its split's fitted map.
        for &p in &points {
            let depth = (p - view.position).dot(view.forward());
            let i = d.windows(2).position(|w| depth >= w[0] && depth < w[1]).unwrap();
            let uv = fitted.cascades[i].view.project(p);
            assert!(uv.x > 0.0 && uv.x < 1.0 && uv.y > 0.0 && uv.y < 1.0, "split {i}: {p} → {uv}");
        }
        // The samples' boxes are smaller than the frusta's: the near split's texels shrink
        // (measured 0.55 of the unfitted texel; bound 0.8, well clear of a 9% ladder step).
        let (a, b) = (unfitted.cascades[0].view.texel_scale, fitted.cascades[0].view.texel_scale);
        assert!(b < 0.8 * a, "split 0 texel {b} fitted vs {a}");
        assert!(
            fitted
                .cascades
                .iter()
                .zip(&unfitted.cascades)
                .all(|(f, u)| f.view.texel_scale <= u.view.texel_scale * 1.0001)
        );
        // Samples of another light frame are ignored; a camera moved by 5 m widens the boxes.
        let other = DepthSamples { light_view: Mat4::IDENTITY, ..samples.clone() };
        let ignored = compute_cascades(
            &light,
            &scene,
            &view,
            aspect,
            &CascadeSettings { samples: Some(other), ..ranged.clone() },
        );
        assert_eq!(ignored.cascades[0].view.texel_scale, a);
        let moved = DepthSamples { eye: view.position + Vec3::X * 5.0, ..samples.clone() };
        let guarded = compute_cascades(
            &light,
            &scene,
            &view,
            aspect,
            &CascadeSettings { samples: Some(moved), ..ranged.clone() },
        );
        assert!(guarded.cascades[0].view.texel_scale > b);
        // Stabilised on top: each split's square extent a power-of-two fraction of the scene's
        // (a fitted box changes size every frame), still holding its samples.
        let stable = CascadeSettings { stabilize: true, samples: Some(samples), ..ranged };
        let f = compute_cascades(&light, &scene, &view, aspect, &stable);
        let scene_ls = Aabb::from_points(scene.corners().iter().map(|&c| light_view.transform_point3(c)));
        let full = (scene_ls.max.x - scene_ls.min.x).max(scene_ls.max.y - scene_ls.min.y);
        let size = stable.map_size as f32;
        for c in &f.cascades {
            // The texel of an extent e padded by a texel each side: e (1 + 2 / size) / size.
            let octave = (c.view.texel_scale * size / (1.0 + 2.0 / size) / full).log2();
            assert!((octave - octave.round()).abs() < 1e-3, "extent 2^{octave} of the scene's");
        }
        // Still finer than the unfitted split, octaves and all (measured 0.0334 against 0.0406;
        // deterministic, so no margin).
        assert!(f.cascades[0].view.texel_scale < a, "{} vs unfitted {a}", f.cascades[0].view.texel_scale);
        for &p in &points {
            let depth = (p - view.position).dot(view.forward());
            let i = d.windows(2).position(|w| depth >= w[0] && depth < w[1]).unwrap();
            let uv = f.cascades[i].view.project(p);
            assert!(uv.x > 0.0 && uv.x < 1.0 && uv.y > 0.0 && uv.y < 1.0, "stabilised split {i}: {p} → {uv}");
        }
    }

    #[test]
    fn stabilised_maps_move_by_whole_texels() {
        let (light, scene, view) = terrain_like();
        let mut s = settings(Warp::None, 1);
        s.stabilize = true;
        let a = compute_cascades(&light, &scene, &view, 1.5, &s);
        let moved = View {
            position: view.position + Vec3::new(0.013, 0.0, -0.021),
            target: view.target + Vec3::new(0.013, 0.0, -0.021),
            ..view.clone()
        };
        let b = compute_cascades(&light, &scene, &moved, 1.5, &s);
        // A fixed world point lands a whole number of texels apart (here: the same texel).
        let p = Vec3::new(10.0, 0.0, 20.0);
        let (ua, ub) = (a.cascades[0].view.project(p), b.cascades[0].view.project(p));
        let shift = (ub - ua) * 1024.0;
        assert!((shift.x - shift.x.round()).abs() < 1e-2 && (shift.y - shift.y.round()).abs() < 1e-2, "{shift}");
        assert!((a.cascades[0].view.texel_scale - b.cascades[0].view.texel_scale).abs() < 1e-6);
        // A quantised focus (the default) keeps its grid too; a free one shifts it by a fraction of
        // a texel.
        let shift_of = |s: &CascadeSettings| {
            let (c, d) =
                (compute_cascades(&light, &scene, &view, 1.5, s), compute_cascades(&light, &scene, &moved, 1.5, s));
            (d.cascades[0].view.project(p) - c.cascades[0].view.project(p)) * 1024.0
        };
        let whole = |v: Vec3| (v.x - v.x.round()).abs() < 1e-2 && (v.y - v.y.round()).abs() < 1e-2;
        let quantised = shift_of(&settings(Warp::None, 1));
        assert!(whole(quantised), "{quantised}");
        let scale =
            |v: &View| compute_cascades(&light, &scene, v, 1.5, &settings(Warp::None, 1)).cascades[0].view.texel_scale;
        assert_eq!(scale(&view), scale(&moved), "a quantised focus keeps its texel size");
        let free = shift_of(&CascadeSettings { quantize: false, ..settings(Warp::None, 1) });
        assert!((free.x - free.x.round()).abs() > 1e-3 || (free.y - free.y.round()).abs() > 1e-3, "{free}");
    }

    #[test]
    fn warped_maps_move_continuously_with_the_camera() {
        // Stingl 2011 §4.1: the projection centre follows the view vector, so a small camera move
        // gives a small change of every split's map (no jumps as B's nearest vertex changes).
        let (light, scene, view) = terrain_like();
        let s = settings(Warp::Lispsm, 4);
        let probe = [Vec3::new(-140.0, 2.0, 290.0), Vec3::new(-100.0, 0.0, 150.0), Vec3::new(0.0, 5.0, -100.0)];
        let mut prev: Option<CascadeFrame> = None;
        let mut worst = 0.0f32;
        for k in 0..40 {
            let step = Vec3::new(0.02, 0.0, -0.05) * k as f32;
            let v = View { position: view.position + step, target: view.target + step, ..view.clone() };
            let f = compute_cascades(&light, &scene, &v, 1.5, &s);
            if let Some(p) = &prev {
                for (a, b) in p.cascades.iter().zip(&f.cascades) {
                    for q in probe {
                        let d = (a.view.project(q) - b.view.project(q)).truncate().length();
                        // A 5 cm step moves a point by at most a few texels of a 1024² map
                        // (measured at most 1.2e-3 of the map, 1.3 texels); a jump would be far more.
                        assert!(d < 0.01, "step {k}: point {q} moved {d} on the map");
                        worst = worst.max(d);
                    }
                }
            }
            prev = Some(f);
        }
        println!("largest move on a map: {worst}");
    }

    #[test]
    fn duelling_frusta_fall_back_to_uniform() {
        let (mut light, scene, view) = terrain_like();
        light.kind = LightKind::Directional { direction: -view.forward(), angular_radius: 0.0 };
        let f = compute_cascades(&light, &scene, &view, 1.5, &settings(Warp::Lispsm, 1));
        assert!(f.gamma < 1e-3);
        assert!(f.cascades[0].warp_n.is_infinite());
        let r = compute_cascades(&light, &scene, &view, 1.5, &settings(Warp::Repar, 1));
        assert!(r.cascades[0].warp_n.is_infinite(), "η = −1 at γ = 0");
    }

    #[test]
    fn sampling_colours_match_the_listing() {
        assert_eq!(sampling_colour(1.0), Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(sampling_colour(10.0), Vec3::new(0.0, 0.0, 0.4));
        assert!((sampling_colour(1.0 / 7.75) - Vec3::new(1.0, 0.2, 0.0)).length() < 1e-5);
        assert!((sampling_colour(3.25) - Vec3::new(0.3, 0.8, 1.0)).length() < 1e-5);
        assert!((sampling_colour(7.75) - Vec3::new(0.0, 0.0, 1.0)).length() < 1e-5);
        assert_eq!(split_colour(5), Vec3::new(1.0, 1.0, 0.0));
    }

    #[test]
    fn cssm_auto_counts_follow_the_screen_penumbra() {
        use crate::light::{Light, LightKind};
        assert_eq!(samples_per_axis(0.0, 3.0), 2);
        assert_eq!(samples_per_axis(10.0, 3.0), 4);
        assert_eq!(samples_per_axis(100.0, 3.0), 5);
        assert_eq!(samples_per_axis(f32::NAN, 3.0), 2);
        let scene = Aabb::new(Vec3::new(-2.0, 0.0, -2.0), Vec3::new(2.0, 3.0, 2.0));
        let occ = Aabb::new(Vec3::new(-0.5, 0.9, -0.5), Vec3::new(0.5, 1.0, 0.5));
        let light =
            Light::new("l", LightKind::Point { position: Vec3::new(0.0, 3.0, 0.0), radius: 0.25 }, Vec3::ONE, 1.0);
        // Nearest occluder point 2 m below the light, farthest scene corner √(4+4+9) away.
        let far = 17f32.sqrt();
        let w = widest_penumbra(&light, &occ, &scene);
        assert!((w - 2.0 * 0.25 * (far - 2.0) / 2.0).abs() < 1e-5, "{w}");
        assert_eq!(widest_penumbra(&light, &Aabb::EMPTY, &scene), 0.0);
        assert!((pixel_size(2.0, std::f32::consts::FRAC_PI_2, 100) - 0.04).abs() < 1e-6);
    }

    #[test]
    fn automatic_map_sizes_match_texels_to_pixels() {
        // 6 m across at 2.5 cm pixels: 240 texels → 256².
        assert_eq!(map_size_for(6.0, 0.025, 128, 1024), 256);
        assert_eq!(map_size_for(6.0, 0.001, 128, 1024), 1024, "capped");
        assert_eq!(map_size_for(0.1, 0.025, 128, 1024), 128, "floored");
        assert_eq!(map_size_for(6.0, 0.0, 128, 1024), 1024, "a zero texel asks for the most");
        assert_eq!(map_size_for(f32::NAN, 0.01, 128, 1024), 1024);
        assert_eq!(map_size_for(1.0, 0.01, 128, 100), 128, "max below min");
        // A unit square seen from above is sqrt(2) across; seen edge-on, 1.
        let square = [Vec3::ZERO, Vec3::X, Vec3::Z, Vec3::new(1.0, 0.0, 1.0)];
        assert!((width_across(&square, Vec3::NEG_Y) - 2f32.sqrt()).abs() < 1e-6);
        assert!((width_across(&square, Vec3::X) - 1.0).abs() < 1e-6);
        assert_eq!(width_across(&[], Vec3::Y), 0.0);
    }
}
