//! Deterministic random numbers and the sample patterns on emitters (DESIGN.md §3).
//!
//! The CPU reference jitters these patterns per pixel; GPU techniques that sample an area light with
//! N shadow maps (`sampled`) use their un-jittered centres. Both map the unit square onto the emitter
//! the same way, so a technique and the reference sample the same measure.

use glam::{Vec2, Vec3};

use crate::light::{Light, LightKind};

/// SplitMix64 (Steele, Lea & Flood 2014): tiny, fast, and good enough to seed per-pixel streams.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// A generator for one item of a stream: the same `(seed, stream)` always gives the same numbers,
    /// whatever order or thread the items run in.
    #[inline]
    pub fn for_stream(seed: u64, stream: u64) -> Self {
        Self(mix64(seed ^ mix64(stream.wrapping_add(0x9E37_79B9_7F4A_7C15))))
    }

    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        mix64(self.0)
    }

    /// Uniform in [0, 1), 24 bits.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    /// Uniform in `lo..hi`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }
}

fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The most square `(columns, rows)` with `columns × rows == n`: 1024 → 32 × 32, 64 → 8 × 8,
/// 12 → 3 × 4. A prime n gives 1 × n strips, still stratified along one axis.
pub fn grid_dims(n: u32) -> (u32, u32) {
    let n = n.max(1);
    let mut cols = (n as f64).sqrt() as u32;
    while cols > 1 && !n.is_multiple_of(cols) {
        cols -= 1;
    }
    (cols.max(1), n / cols.max(1))
}

/// The centres of a `grid_dims(n)` grid on the unit square (no randomness): the k×k pattern of
/// Azri §3 and Guennebaud Fig. 1.
pub fn grid_centres(n: u32) -> Vec<Vec2> {
    let (cols, rows) = grid_dims(n);
    (0..rows)
        .flat_map(|r| (0..cols).map(move |c| Vec2::new((c as f32 + 0.5) / cols as f32, (r as f32 + 0.5) / rows as f32)))
        .collect()
}

/// `n` jittered-grid samples on the unit square: one uniform sample in each cell of a
/// `grid_dims(n)` grid.
#[inline]
pub fn jittered_grid(n: u32, rng: &mut Rng, out: &mut Vec<Vec2>) {
    let (cols, rows) = grid_dims(n);
    out.clear();
    for r in 0..rows {
        for c in 0..cols {
            out.push(Vec2::new((c as f32 + rng.next_f32()) / cols as f32, (r as f32 + rng.next_f32()) / rows as f32));
        }
    }
}

/// Shirley & Chiu's concentric map (1997) from the unit square to the unit disk: area-preserving and
/// low-distortion, so a stratified square stays stratified on the disk.
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let a = 2.0 * u - Vec2::ONE;
    if a == Vec2::ZERO {
        return Vec2::ZERO;
    }
    use std::f32::consts::FRAC_PI_4;
    let (r, theta) = if a.x.abs() > a.y.abs() {
        (a.x, FRAC_PI_4 * (a.y / a.x))
    } else {
        (a.y, 2.0 * FRAC_PI_4 - FRAC_PI_4 * (a.x / a.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// A unit direction in the cone of half-angle `acos(cos_max)` around `axis`, uniform in solid angle
/// when `u` is uniform: the concentric disk point is lifted onto the spherical cap so that equal
/// areas stay equal (radius² ∝ 1 − cos θ).
pub fn cone_direction(axis: Vec3, cos_max: f32, u: Vec2) -> Vec3 {
    cone_direction_in(axis, cos_max, orthonormal_basis(axis), u)
}

/// [`cone_direction`] with the axis's [`orthonormal_basis`] `(t, b)` given.
#[inline]
fn cone_direction_in(axis: Vec3, cos_max: f32, (t, b): (Vec3, Vec3), u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let r2 = d.length_squared();
    let cos_t = 1.0 - r2 * (1.0 - cos_max);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let dir = if r2 > 0.0 { d / r2.sqrt() } else { Vec2::X };
    (axis * cos_t + (t * dir.x + b * dir.y) * sin_t).normalize()
}

/// Two unit vectors completing `n` (unit) to a right-handed orthonormal frame, without branches
/// that jump: Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 6(1), 2017.
#[inline]
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// Where a shadow ray from a surface point goes for one emitter sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EmitterSample {
    /// A point on the emitter: test the segment to it.
    Point(Vec3),
    /// A direction towards an infinitely far emitter: test the ray.
    Direction(Vec3),
}

/// Maps `u` in the unit square to a sample of `light`'s emitter as seen from `p`, uniform in the
/// emitter's area measure of DESIGN.md §3:
/// - sphere light: the disk of radius r through the centre, perpendicular to the direction from `p`;
/// - rectangle: the rectangle itself;
/// - directional light: the cone of directions within the angular radius;
/// - hard lights: the centre or the single direction, whatever `u`.
pub fn sample_emitter(light: &Light, p: Vec3, u: Vec2) -> EmitterSample {
    EmitterSampler::new(light).sample(p, u)
}

/// [`sample_emitter`] for many samples of one light: what depends on the light alone (a
/// rectangle's second axis; a cone's cosine and frame) is computed once, here, instead of per
/// sample. The samples are the same, bit for bit: `sample_emitter` is this.
#[derive(Debug, Clone, Copy)]
pub struct EmitterSampler {
    kind: Prepared,
}

#[derive(Debug, Clone, Copy)]
enum Prepared {
    Fixed(EmitterSample),
    Sphere { position: Vec3, radius: f32 },
    Rect { position: Vec3, tangent: Vec3, bitangent: Vec3, width: f32, height: f32 },
    Cone { axis: Vec3, cos_max: f32, basis: (Vec3, Vec3) },
}

impl EmitterSampler {
    pub fn new(light: &Light) -> Self {
        let kind = match light.kind {
            LightKind::Point { position, radius } | LightKind::Spot { position, radius, .. } => {
                if radius <= 0.0 {
                    Prepared::Fixed(EmitterSample::Point(position))
                } else {
                    Prepared::Sphere { position, radius }
                }
            }
            LightKind::Rect { position, direction, tangent, width, height } => {
                Prepared::Rect { position, tangent, bitangent: direction.cross(tangent), width, height }
            }
            LightKind::Directional { direction, angular_radius } => {
                if angular_radius <= 0.0 {
                    Prepared::Fixed(EmitterSample::Direction(-direction))
                } else {
                    let axis = -direction;
                    Prepared::Cone { axis, cos_max: angular_radius.cos(), basis: orthonormal_basis(axis) }
                }
            }
        };
        Self { kind }
    }

    /// The sample of `u` seen from `p` (see [`sample_emitter`]).
    #[inline]
    pub fn sample(&self, p: Vec3, u: Vec2) -> EmitterSample {
        match self.kind {
            Prepared::Fixed(sample) => sample,
            Prepared::Sphere { position, radius } => {
                let axis = (position - p).normalize_or(Vec3::Y);
                let (t, b) = orthonormal_basis(axis);
                let d = radius * concentric_disk(u);
                EmitterSample::Point(position + t * d.x + b * d.y)
            }
            Prepared::Rect { position, tangent, bitangent, width, height } => {
                EmitterSample::Point(position + (u.x - 0.5) * width * tangent + (u.y - 0.5) * height * bitangent)
            }
            Prepared::Cone { axis, cos_max, basis } => {
                EmitterSample::Direction(cone_direction_in(axis, cos_max, basis, u))
            }
        }
    }
}

/// A fixed point sample of an emitter, for techniques that render one shadow map per sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmitterPoint {
    pub sample: EmitterSample,
    /// For sphere lights: the outward unit normal of the sphere at the sample. A receiver at p then
    /// weighs the sample by `max(0, normal · (p − centre)/|p − centre|)`, its projected area seen
    /// from p, which makes the weighted samples uniform over the disk that DESIGN.md §3 integrates
    /// (Lambert's cosine over the sphere = uniform over its silhouette).
    pub sphere_normal: Option<Vec3>,
}

/// `n` fixed, stratified samples of `light`'s emitter (centres of a `grid_dims(n)` grid mapped onto
/// the emitter): the k×k grid on rectangles (Azri 2020 §3), cone directions for the sun, and
/// equal-area points on the whole sphere for sphere lights (Archimedes' cylindrical map, weighted
/// per receiver: see [`EmitterPoint::sphere_normal`]). A hard light gives one sample.
pub fn emitter_points(light: &Light, n: u32) -> Vec<EmitterPoint> {
    if light.is_hard() {
        let sample = match light.kind {
            LightKind::Directional { direction, .. } => EmitterSample::Direction(-direction),
            _ => EmitterSample::Point(light.position().unwrap_or(Vec3::ZERO)),
        };
        return vec![EmitterPoint { sample, sphere_normal: None }];
    }
    grid_centres(n)
        .into_iter()
        .map(|u| match light.kind {
            LightKind::Point { position, radius } | LightKind::Spot { position, radius, .. } => {
                let normal = sphere_point(u);
                EmitterPoint { sample: EmitterSample::Point(position + radius * normal), sphere_normal: Some(normal) }
            }
            _ => EmitterPoint { sample: sample_emitter(light, Vec3::ZERO, u), sphere_normal: None },
        })
        .collect()
}

/// How the fixed emitter samples of a multi-map technique are placed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SamplePattern {
    /// Cell centres of a k × k grid ([`emitter_points`]).
    Grid,
    /// One jittered point per grid cell (fixed seed): stratified, without the grid's aligned steps.
    Stratified,
    /// Toromanoff 2005 (algorithm D, Fig. 23): concentric rings on a disk of the light's radius
    /// perpendicular to an axis (the spot's axis, straight down for point lights, the cone for the
    /// sun). The ring layout is not stated in the thesis; here a centre sample and rings of 6, 12,
    /// 18, … samples at equal-area radii (N = 19 is Toromanoff's ≈ 20), each ring turned by half a
    /// step against the previous one. On rectangles the rings go through the inverse concentric map
    /// (nested squares of equal area).
    Rings,
}

impl SamplePattern {
    pub const NAMES: &'static [&'static str] = &["grid", "stratified", "rings"];

    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "grid" => Some(Self::Grid),
            "stratified" => Some(Self::Stratified),
            "rings" => Some(Self::Rings),
            _ => None,
        }
    }
}

/// Points of the unit disk on concentric rings of 1, 6, 12, 18, … samples (the last ring takes the
/// remainder), each at the radius that halves its share of the disk's area, so that every sample
/// stands for the same area.
pub fn ring_points(n: u32) -> Vec<Vec2> {
    let n = n.max(1);
    let mut counts = vec![1u32];
    while counts.iter().sum::<u32>() < n {
        let total: u32 = counts.iter().sum();
        counts.push((6 * counts.len() as u32).min(n - total));
    }
    let mut out = Vec::with_capacity(n as usize);
    let mut before = 0u32;
    for (ring, &count) in counts.iter().enumerate() {
        let radius = if ring == 0 { 0.0 } else { ((before as f32 + 0.5 * count as f32) / n as f32).sqrt() };
        let turn = if ring % 2 == 0 { 0.5 } else { 0.0 };
        for k in 0..count {
            let phi = std::f32::consts::TAU * (k as f32 + turn) / count as f32;
            out.push(radius * Vec2::new(phi.cos(), phi.sin()));
        }
        before += count;
    }
    out
}

/// [`emitter_points`] with a choice of pattern.
pub fn emitter_points_with(light: &Light, n: u32, pattern: SamplePattern) -> Vec<EmitterPoint> {
    if light.is_hard() {
        return emitter_points(light, 1);
    }
    match (pattern, light.kind) {
        (SamplePattern::Grid, _) => emitter_points(light, n),
        (SamplePattern::Rings, LightKind::Point { position, radius } | LightKind::Spot { position, radius, .. }) => {
            let axis = match light.kind {
                LightKind::Spot { direction, .. } => direction.normalize_or(Vec3::NEG_Y),
                _ => Vec3::NEG_Y,
            };
            let (t, b) = orthonormal_basis(axis);
            ring_points(n)
                .into_iter()
                .map(|d| EmitterPoint {
                    sample: EmitterSample::Point(position + radius * (t * d.x + b * d.y)),
                    sphere_normal: None,
                })
                .collect()
        }
        (SamplePattern::Rings, LightKind::Directional { .. } | LightKind::Rect { .. }) => ring_points(n)
            .into_iter()
            .map(|d| {
                // Through the inverse concentric map: equal areas of the disk stay equal on the
                // cone of directions and on the rectangle (rings become nested squares there).
                let u = disk_to_square(d);
                EmitterPoint { sample: sample_emitter(light, Vec3::ZERO, u), sphere_normal: None }
            })
            .collect(),
        (SamplePattern::Stratified, _) => {
            let mut rng = Rng::new(0x5EED_0F1A);
            let mut cells = Vec::new();
            jittered_grid(n, &mut rng, &mut cells);
            match light.kind {
                LightKind::Point { position, radius } | LightKind::Spot { position, radius, .. } => cells
                    .into_iter()
                    .map(|u| {
                        let normal = sphere_point(u);
                        EmitterPoint {
                            sample: EmitterSample::Point(position + radius * normal),
                            sphere_normal: Some(normal),
                        }
                    })
                    .collect(),
                _ => cells
                    .into_iter()
                    .map(|u| EmitterPoint { sample: sample_emitter(light, Vec3::ZERO, u), sphere_normal: None })
                    .collect(),
            }
        }
    }
}

/// Archimedes' equal-area map from the unit square onto the unit sphere.
fn sphere_point(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * u.y;
    Vec3::new(r * phi.cos(), z, r * phi.sin())
}

/// The inverse of [`concentric_disk`]: the unit-square point that maps to disk point `d`.
pub fn disk_to_square(d: Vec2) -> Vec2 {
    let r = d.length();
    if r == 0.0 {
        return Vec2::splat(0.5);
    }
    use std::f32::consts::{FRAC_PI_4, PI};
    let mut phi = d.y.atan2(d.x);
    if phi < -FRAC_PI_4 {
        phi += 2.0 * PI;
    }
    let a = if phi < FRAC_PI_4 {
        Vec2::new(r, r * phi / FRAC_PI_4)
    } else if phi < 3.0 * FRAC_PI_4 {
        Vec2::new(-r * (phi - 2.0 * FRAC_PI_4) / FRAC_PI_4, r)
    } else if phi < 5.0 * FRAC_PI_4 {
        Vec2::new(-r, -r * (phi - 4.0 * FRAC_PI_4) / FRAC_PI_4)
    } else {
        Vec2::new(r * (phi - 6.0 * FRAC_PI_4) / FRAC_PI_4, -r)
    };
    (a + Vec2::ONE) * 0.5
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_dims_are_exact_and_square() {
        assert_eq!(grid_dims(1024), (32, 32));
        assert_eq!(grid_dims(64), (8, 8));
        assert_eq!(grid_dims(12), (3, 4));
        assert_eq!(grid_dims(7), (1, 7));
        assert_eq!(grid_dims(0), (1, 1));
        assert_eq!(grid_centres(9).len(), 9);
    }

    #[test]
    fn rng_streams_are_reproducible_and_distinct() {
        let a: Vec<u64> = (0..4).map(|_| Rng::for_stream(1, 7).next_u64()).collect();
        assert!(a.windows(2).all(|w| w[0] == w[1]));
        assert_ne!(Rng::for_stream(1, 7).next_u64(), Rng::for_stream(1, 8).next_u64());
        assert_ne!(Rng::for_stream(1, 7).next_u64(), Rng::for_stream(2, 7).next_u64());
        let mut r = Rng::new(3);
        let mean = (0..10_000).map(|_| r.next_f32()).sum::<f32>() / 10_000.0;
        // Mean of 10⁴ uniforms: standard error 0.0029; 0.01 is over 3 sigma.
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
    }

    #[test]
    fn concentric_disk_preserves_area() {
        // The ring 0.5 < r < 1 has 3/4 of the disk's area: 3/4 of uniform square samples land there.
        let mut rng = Rng::new(5);
        let mut pts = Vec::new();
        jittered_grid(4096, &mut rng, &mut pts);
        let outer = pts.iter().filter(|&&u| concentric_disk(u).length() > 0.5).count();
        assert!((outer as f32 / 4096.0 - 0.75).abs() < 0.005, "{outer}");
        assert!(pts.iter().all(|&u| concentric_disk(u).length() <= 1.0 + 1e-6));
    }

    #[test]
    fn cone_directions_stay_in_the_cone() {
        let axis = Vec3::new(0.3, 0.9, -0.2).normalize();
        let cos_max = 5f32.to_radians().cos();
        let mut rng = Rng::new(9);
        let mut pts = Vec::new();
        jittered_grid(256, &mut rng, &mut pts);
        let mut mean_cos = 0.0;
        for &u in &pts {
            let d = cone_direction(axis, cos_max, u);
            assert!((d.length() - 1.0).abs() < 1e-5);
            assert!(d.dot(axis) >= cos_max - 1e-6);
            mean_cos += d.dot(axis) / pts.len() as f32;
        }
        // Uniform in solid angle: the mean cosine is the middle of [cos_max, 1]. One sample's cosine
        // has a standard deviation of (1 − cos_max)/√12 = 1.1e-3, so 256 independent samples would
        // err by 7e-5; stratified ones err less (measured 1.6e-5). Threshold 5e-5.
        assert!((mean_cos - 0.5 * (1.0 + cos_max)).abs() < 5e-5, "{mean_cos}");
    }

    #[test]
    fn sphere_points_weighted_are_uniform_on_the_disk() {
        use crate::light::Light;
        let light = Light::new("s", LightKind::Point { position: Vec3::ZERO, radius: 1.0 }, Vec3::ONE, 1.0);
        let pts = emitter_points(&light, 4096);
        assert_eq!(pts.len(), 4096);
        // Seen from far along +x, project each sample on the y-z disk with weight n·x̂: the weighted
        // fraction inside radius ½ must be the area fraction ¼.
        let (mut inside, mut total) = (0.0, 0.0);
        for p in &pts {
            let n = p.sphere_normal.unwrap();
            let w = n.x.max(0.0);
            total += w;
            if n.y * n.y + n.z * n.z < 0.25 {
                inside += w;
            }
        }
        // The fixed grid (64 × 64 in height and angle) leaves a structured error: measured 0.2444
        // from +x; threshold 0.01 (4% of the value).
        assert!((inside / total - 0.25).abs() < 0.01, "{}", inside / total);
        let hard = Light::new("h", LightKind::Point { position: Vec3::ONE, radius: 0.0 }, Vec3::ONE, 1.0);
        assert_eq!(emitter_points(&hard, 64).len(), 1);
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(1.0, 2.0, -3.0).normalize()] {
            let (t, b) = orthonormal_basis(n);
            assert!(t.dot(b).abs() < 1e-6 && t.dot(n).abs() < 1e-6 && b.dot(n).abs() < 1e-6);
            assert!((t.length() - 1.0).abs() < 1e-6 && (b.length() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn rings_are_equal_area_and_inverse_map_round_trips() {
        let p = ring_points(19);
        assert_eq!(p.len(), 19);
        assert_eq!(p[0], Vec2::ZERO);
        // 1 + 6 + 12: the second ring at √(4/19), the third at √(13/19).
        assert!((p[1].length() - (4.0f32 / 19.0).sqrt()).abs() < 1e-6);
        assert!((p[18].length() - (13.0f32 / 19.0).sqrt()).abs() < 1e-6);
        assert_eq!(ring_points(20).len(), 20);
        assert!(ring_points(64).iter().all(|q| q.length() < 1.0));
        // Equal area: the mean squared radius of a uniform disk is ½ (64 ring samples: 0.4999).
        let m = ring_points(64).iter().map(|q| q.length_squared()).sum::<f32>() / 64.0;
        assert!((m - 0.5).abs() < 0.01, "{m}");
        for u in [Vec2::new(0.1, 0.7), Vec2::new(0.9, 0.2), Vec2::new(0.5, 0.95), Vec2::new(0.3, 0.3)] {
            let back = disk_to_square(concentric_disk(u));
            assert!(back.distance(u) < 1e-5, "{u} {back}");
        }
    }

    #[test]
    fn patterns_give_n_points_on_the_emitter() {
        use crate::light::Light;
        let sphere = Light::new("s", LightKind::Point { position: Vec3::Y, radius: 0.5 }, Vec3::ONE, 1.0);
        for pattern in [SamplePattern::Grid, SamplePattern::Stratified, SamplePattern::Rings] {
            let pts = emitter_points_with(&sphere, 16, pattern);
            assert_eq!(pts.len(), 16, "{pattern:?}");
            for p in &pts {
                let EmitterSample::Point(q) = p.sample else { panic!() };
                assert!(q.distance(Vec3::Y) <= 0.5 + 1e-5);
            }
        }
        let sun =
            Light::new("d", LightKind::Directional { direction: Vec3::NEG_Y, angular_radius: 0.1 }, Vec3::ONE, 1.0);
        for p in emitter_points_with(&sun, 19, SamplePattern::Rings) {
            let EmitterSample::Direction(d) = p.sample else { panic!() };
            assert!(d.dot(Vec3::Y) >= 0.1f32.cos() - 1e-5);
        }
    }
}
