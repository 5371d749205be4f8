//! The ground truth V_l(p) of DESIGN.md §3, by ray tracing.
//!
//! Hard lights (zero-size emitters) cast one ray per pixel. Area emitters are integrated with N
//! stratified samples per pixel (a jittered grid on the unit square, mapped onto the rectangle, the
//! disk or the cone by [`shadowlab_core::sampling`]), each pixel with its own random stream derived
//! from `(seed, light, pixel)`: the same input gives bit-identical output on any number of threads.
//!
//! **Ray origins** (DESIGN.md §3). A shadow ray starts at `p + ε·N_g`: along the *geometric* normal,
//! which is what separates the point from the triangle it lies on (the shading normal may point
//! into the surface at grazing angles, and a ray started behind its own triangle hits it). ε is
//! [`ray_epsilon`]: the larger of [`EPSILON_SCALE`] × the scene's diagonal and [`EPSILON_ULPS`] float
//! steps of the largest coordinate of p. The first term covers G-buffer positions, which carry
//! float error of about 1e-6 of their distance to the camera: 1e-5 of the scene size leaves a margin
//! of ten (0.07 mm in `room`, 1 cm over the 800 m `terrain`). The second keeps the offset above the
//! coordinates' own rounding far from the origin; scenes are traced in their local frame
//! ([`shadowlab_core::Scene::recentre`]), where it rarely binds, so that a scene and its translated
//! copy have the same truth.
//!
//! **Samples below the horizon.** An emitter sample behind the surface's tangent plane (n·ω ≤ 0) is
//! hidden by the surface itself and counts as occluded: a point sees no light through the body it
//! lies on.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use shadowlab_core::sampling::{EmitterSample, EmitterSampler, Rng, jittered_grid};
use shadowlab_core::{Light, SurfaceBuffer};

use crate::bvh::{PreparedRay, SceneBvh};

pub use shadowlab_core::bvh::{EPSILON_SCALE, EPSILON_ULPS, ray_epsilon};

/// How the reference integrates area emitters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceSettings {
    /// Emitter samples per pixel for area lights (hard lights always use one ray).
    pub samples: u32,
    pub seed: u64,
}

impl Default for ReferenceSettings {
    fn default() -> Self {
        Self { samples: 256, seed: 1 }
    }
}

/// One light's reference visibility over a surface buffer.
#[derive(Debug, Clone)]
pub struct Visibility {
    pub width: u32,
    pub height: u32,
    /// V in [0, 1] for relevant pixels, NaN for the others (background, back-facing, out of range
    /// or outside a spot's cone).
    pub values: Vec<f32>,
    pub relevant_pixels: usize,
    /// Shadow rays traced.
    pub rays: u64,
    pub seconds: f64,
}

impl Visibility {
    pub fn is_relevant(&self, i: usize) -> bool {
        !self.values[i].is_nan()
    }

    /// Shadow rays per second of wall time.
    pub fn rays_per_second(&self) -> f64 {
        self.rays as f64 / self.seconds.max(1e-9)
    }
}

/// Progress callback: `(pixels done, pixels total)`; called from worker threads.
pub type Progress<'a> = &'a (dyn Fn(usize, usize) + Sync);

/// Computes V for every relevant pixel of `surface` and `light` (`light_index` keys the random
/// streams, so lights get independent samples).
pub fn light_visibility(
    bvh: &SceneBvh,
    surface: &SurfaceBuffer,
    light: &Light,
    light_index: u32,
    settings: &ReferenceSettings,
    progress: Option<Progress<'_>>,
) -> Visibility {
    let start = Instant::now();
    let samples = samples_for(light, settings.samples);
    let width = surface.width as usize;
    let total = surface.len();
    let done = AtomicUsize::new(0);
    let rays = std::sync::atomic::AtomicU64::new(0);
    let mut values = vec![f32::NAN; total];
    // The emitter's own constants (a cone's cosine and frame), once for all samples.
    let sampler = EmitterSampler::new(light);
    let rows = Rows { bvh, surface, light, sampler, samples, light_index, seed: settings.seed, width };
    values.par_chunks_mut(width.max(1)).enumerate().for_each(|(row, out)| {
        let row_rays = rows.trace(row, out);
        rays.fetch_add(row_rays, Ordering::Relaxed);
        let d = done.fetch_add(out.len(), Ordering::Relaxed) + out.len();
        if let Some(progress) = progress {
            progress(d, total);
        }
    });
    let relevant_pixels = values.iter().filter(|v| !v.is_nan()).count();
    Visibility {
        width: surface.width,
        height: surface.height,
        values,
        relevant_pixels,
        rays: rays.into_inner(),
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// What tracing one row of one light's visibility needs.
struct Rows<'a> {
    bvh: &'a SceneBvh,
    surface: &'a SurfaceBuffer,
    light: &'a Light,
    sampler: EmitterSampler,
    samples: u32,
    light_index: u32,
    seed: u64,
    width: usize,
}

impl Rows<'_> {
    /// Writes V for the relevant pixels of row `row` into `out`; returns the rays traced.
    fn trace(&self, row: usize, out: &mut [f32]) -> u64 {
        #[cfg(target_arch = "x86_64")]
        if shadowlab_core::bvh::has_modern_isa() {
            // SAFETY: the CPU has every feature `trace_modern` is compiled for.
            return unsafe { self.trace_modern(row, out) };
        }
        self.trace_in(row, out)
    }

    /// [`Self::trace_in`] compiled for the x86-64 of the last decade, as the BVH's traversal is
    /// ([`shadowlab_core::bvh::has_modern_isa`]): the sampling arithmetic and the random streams
    /// too. The same operations in the same order: the same bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
    unsafe fn trace_modern(&self, row: usize, out: &mut [f32]) -> u64 {
        self.trace_in(row, out)
    }

    #[inline(always)]
    fn trace_in(&self, row: usize, out: &mut [f32]) -> u64 {
        let (bvh, surface, light, samples) = (self.bvh, self.surface, self.light, self.samples);
        let mut pattern = Vec::with_capacity(samples as usize);
        let mut batch = Vec::with_capacity(samples as usize);
        let mut row_rays = 0u64;
        for (x, v) in out.iter_mut().enumerate() {
            let i = row * self.width + x;
            if !surface.is_relevant(i, light) {
                continue;
            }
            let (p, n) = (surface.positions[i], surface.geometric_normals[i]);
            let eps = ray_epsilon(p, bvh.scene_diagonal);
            let origin = p + n * eps;
            if samples == 1 && light.is_hard() {
                row_rays += 1;
                let visible = match sample_ray(&self.sampler, origin, n, Vec2::splat(0.5), eps) {
                    SampleRay::Trace(ray) => bvh.unoccluded(&ray),
                    SampleRay::Visible => true,
                    SampleRay::Hidden => false,
                };
                *v = if visible { 1.0 } else { 0.0 };
                continue;
            }
            let stream = (u64::from(self.light_index) << 40) ^ i as u64;
            let mut rng = Rng::for_stream(self.seed, stream);
            jittered_grid(samples, &mut rng, &mut pattern);
            // All of the pixel's rays are prepared first, then traced: the sampling arithmetic
            // (square roots, divisions, the cone's sines) runs in a loop of its own, where
            // independent samples overlap, instead of between traversals. Only the count of
            // visible samples is kept, which the order of tracing cannot change.
            batch.clear();
            let mut visible = 0usize;
            for &u in &pattern {
                match sample_ray(&self.sampler, origin, n, u, eps) {
                    SampleRay::Trace(ray) => batch.push(ray),
                    SampleRay::Visible => visible += 1,
                    SampleRay::Hidden => {}
                }
            }
            visible += batch.iter().filter(|ray| bvh.unoccluded(ray)).count();
            row_rays += samples as u64;
            *v = visible as f32 / samples as f32;
        }
        row_rays
    }
}

/// Emitter samples per pixel the truth takes for `light` when `samples` are asked: one ray for a
/// hard light (a point, a single direction: DESIGN.md §3's V ∈ {0, 1}), whatever was asked.
pub fn samples_for(light: &Light, samples: u32) -> u32 {
    if light.is_hard() { 1 } else { samples.max(1) }
}

/// Traces the shadow ray of one emitter sample `u` from `origin` (already offset along the
/// geometric normal `n`, whose tangent plane hides samples behind it).
#[inline]
fn sample_visible(bvh: &SceneBvh, light: &Light, origin: Vec3, n: Vec3, u: Vec2, eps: f32) -> bool {
    match sample_ray(&EmitterSampler::new(light), origin, n, u, eps) {
        SampleRay::Trace(ray) => bvh.unoccluded(&ray),
        SampleRay::Visible => true,
        SampleRay::Hidden => false,
    }
}

/// What an emitter sample needs: a shadow ray, or nothing because its answer is already known.
enum SampleRay {
    Trace(PreparedRay),
    /// The sample lies within ε of the origin: nothing can hide it.
    Visible,
    /// Behind the tangent plane: the surface itself hides the sample.
    Hidden,
}

/// The shadow ray of emitter sample `u` seen from `origin` (see [`sample_visible`]).
#[inline(always)]
fn sample_ray(sampler: &EmitterSampler, origin: Vec3, n: Vec3, u: Vec2, eps: f32) -> SampleRay {
    let (dir, tmax) = match sampler.sample(origin, u) {
        EmitterSample::Point(q) => {
            let d = q - origin;
            let len = d.length();
            if len <= eps {
                return SampleRay::Visible;
            }
            (d / len, len - eps)
        }
        EmitterSample::Direction(d) => (d, f32::INFINITY),
    };
    if n.dot(dir) <= 0.0 {
        return SampleRay::Hidden; // behind the tangent plane: the surface itself hides the sample
    }
    SampleRay::Trace(PreparedRay::new(origin, dir, 0.0, tmax))
}

/// Reference visibility of several lights, with their total timing.
#[derive(Debug, Clone)]
pub struct ReferenceResult {
    /// In the order of the `lights` argument.
    pub lights: Vec<Visibility>,
    pub seconds: f64,
    pub rays: u64,
    pub bvh_build: Duration,
}

impl ReferenceResult {
    pub fn rays_per_second(&self) -> f64 {
        self.rays as f64 / self.seconds.max(1e-9)
    }
}

/// Computes the reference for `lights` (pairs of scene index and light) over one surface buffer.
/// `progress` sees the pixels of all lights together.
pub fn reference(
    bvh: &SceneBvh,
    surface: &SurfaceBuffer,
    lights: &[(u32, &Light)],
    settings: &ReferenceSettings,
    progress: Option<Progress<'_>>,
) -> ReferenceResult {
    let start = Instant::now();
    let per_light = surface.len();
    let total = per_light * lights.len();
    let mut out = Vec::with_capacity(lights.len());
    for (k, &(index, light)) in lights.iter().enumerate() {
        let offset = k * per_light;
        let wrapped = progress.map(|p| move |d: usize, _t: usize| p(offset + d, total));
        let v = match &wrapped {
            Some(f) => light_visibility(bvh, surface, light, index, settings, Some(f)),
            None => light_visibility(bvh, surface, light, index, settings, None),
        };
        out.push(v);
    }
    let rays = out.iter().map(|v| v.rays).sum();
    ReferenceResult { lights: out, seconds: start.elapsed().as_secs_f64(), rays, bvh_build: bvh.build_time }
}

/// Marks the pixels whose surface point lies within `radius(p)` of a hard shadow boundary, measured
/// perpendicular to the light ray: the reference is traced from 8 points around p (offsets of r
/// along two axes perpendicular to the direction to the light, and the diagonals, each slid along
/// the light ray onto p's tangent plane: the footprint of a shadow-map texel on the receiver), and
/// a pixel is marked when any of them disagrees with p itself. Tests use it with r = one shadow-map texel to exclude the
/// pixels a map of that resolution cannot decide. The light's emitter size is ignored (its centre
/// is used).
pub fn near_hard_boundary(
    bvh: &SceneBvh,
    surface: &SurfaceBuffer,
    light: &Light,
    radius: &(dyn Fn(Vec3) -> f32 + Sync),
) -> Vec<bool> {
    let mut centre = light.clone();
    centre.scale_emitter(0.0);
    let visible = |p: Vec3, n: Vec3| {
        let eps = ray_epsilon(p, bvh.scene_diagonal);
        sample_visible(bvh, &centre, p + n * eps, n, Vec2::splat(0.5), eps)
    };
    (0..surface.len())
        .into_par_iter()
        .map(|i| {
            if !surface.is_relevant(i, light) {
                return false;
            }
            let (p, n) = (surface.positions[i], surface.geometric_normals[i]);
            let here = visible(p, n);
            let (l, _) = light.to_light(p);
            let (t, b) = shadowlab_core::sampling::orthonormal_basis(l);
            let r = radius(p);
            let d = std::f32::consts::FRAC_1_SQRT_2;
            let n_dot_l = n.dot(l).max(1e-3);
            [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0), (d, d), (-d, d), (d, -d), (-d, -d)].iter().any(
                |&(x, y)| {
                    let o = r * (x * t + y * b);
                    visible(p + o - l * (n.dot(o) / n_dot_l), n) != here
                },
            )
        })
        .collect()
}

/// Marks the pixels whose centre lies within half a pixel of a hard shadow boundary in the image:
/// the tolerance of an exact technique (shadow volumes), which may decide such a pixel either way
/// by round-off. Two kinds of boundary are looked for at 8 points on the circle of radius 0.5 pixel
/// around the pixel centre:
///
/// - **cast shadows**: the reference, traced at each point's camera ray where it meets the pixel's
///   tangent plane, disagrees with the centre;
/// - **the geometric terminator**: the triangle that each point's camera ray hits in `all` (a BVH of
///   everything drawn) faces the light at some points and not at others: a pixel straddling the
///   mesh's silhouette edge from the light, which an exact technique may give to either side.
///
/// Grazing pixels (the tangent plane nearly along the ray) are marked too. The light's centre is
/// used, whatever its emitter size.
pub fn near_boundary_in_image(
    casters: &SceneBvh,
    all: &SceneBvh,
    surface: &SurfaceBuffer,
    light: &Light,
    view: &shadowlab_core::View,
) -> Vec<bool> {
    let mut centre = light.clone();
    centre.scale_emitter(0.0);
    let visible = |p: Vec3, n: Vec3| {
        let eps = ray_epsilon(p, casters.scene_diagonal);
        sample_visible(casters, &centre, p + n * eps, n, Vec2::splat(0.5), eps)
    };
    // Whether the triangle seen along a camera ray faces the light (None: background).
    let faces_light = |o: Vec3, dir: Vec3| {
        let hit = all.closest(&PreparedRay::new(o, dir, 0.0, f32::INFINITY), |_, _| true)?;
        let t = &all.triangles()[hit.index as usize];
        let mut n = Vec3::from((t.v[1] - t.v[0]).cross(t.v[2] - t.v[0]));
        if n.dot(dir) > 0.0 {
            n = -n;
        }
        let (l, _) = centre.to_light(o + dir * hit.t);
        Some(n.dot(l) > 0.0)
    };
    let (w, h) = (surface.width, surface.height);
    let d = 0.5 * std::f32::consts::FRAC_1_SQRT_2;
    let offsets = [(0.5, 0.0), (-0.5, 0.0), (0.0, 0.5), (0.0, -0.5), (d, d), (-d, d), (d, -d), (-d, -d)];
    (0..surface.len())
        .into_par_iter()
        .map(|i| {
            if !surface.is_relevant(i, light) {
                return false;
            }
            let (p, n) = (surface.positions[i], surface.geometric_normals[i]);
            let here = visible(p, n);
            let (x, y) = ((i as u32 % w) as f32 + 0.5, (i as u32 / w) as f32 + 0.5);
            let (o, dir) = view.image_ray(x, y, w, h);
            let facing = faces_light(o, dir);
            offsets.iter().any(|&(dx, dy)| {
                let (o, dir) = view.image_ray(x + dx, y + dy, w, h);
                let denom = n.dot(dir);
                if denom.abs() < 1e-4 {
                    return true;
                }
                let q = o + dir * (n.dot(p - o) / denom);
                if visible(q, n) != here {
                    return true;
                }
                matches!((facing, faces_light(o, dir)), (Some(a), Some(b)) if a != b)
            })
        })
        .collect()
}
