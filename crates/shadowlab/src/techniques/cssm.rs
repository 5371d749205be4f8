//! `cssm`: cascaded soft shadow maps (Azri 2020, NOTES-003 §4). The view frustum is split into
//! cascades by eye depth (the practical split scheme of PSSM, Zhang et al. 2006); each cascade
//! approximates the area light by its own number of point samples with hard maps of its own size,
//! so that near penumbrae, large on screen, get many samples and fine maps, and far ones few samples
//! and coarse maps (Azri: 16 @ 1024², 9 @ 512², 4 @ 128²; 25/16/4 for the Dragon scene). Each
//! sample's view is fitted to the cascade's slice of the view frustum (clipped to the scene); a
//! pixel is shaded by the cascade of its eye depth, as the average of the cascade's samples with a
//! 3 × 3 PCF each (Azri Eq. 3.8).
//!
//! The splits follow PSSM's practical scheme (`lambda`) unless placed by hand (`split1`…): Azri
//! places them per scene so that each object falls in the cascade meant for it (NOTES-003 §1.6).
//!
//! Beyond the paper:
//! - `band`: Azri switches cascades hard, which shows as a seam where sample counts change; a band
//!   at the far end of each cascade (a fraction of its depth range) blends it into the next (each
//!   cascade's sums weighted by the band's ramp, so in proportion to its sample count too).
//! - `sizes=auto`: each cascade's map size is the smallest power of two with two texels per pixel at
//!   the cascade's near depth over the slice's width across the light
//!   ([`shadowlab_core::cascades::map_size_for`]), from 128 up to the largest `sizeN`: Azri's
//!   hand-shrunk far maps suit wide penumbrae but blur sharp ones (the sun).
//! - `stabilize`: the fitted views jitter as the camera moves their slices, which shows as flicker;
//!   stabilised views look along quantised directions through texel-snapped off-axis windows of
//!   quantised width ([`shadowlab_core::lightspace::focused_perspective_stable`]).
//! - Cascades whose samples cannot be fitted to their slice (a light inside or beside it, as room
//!   lamps are) fall back to `sampled`'s whole-scene views at the largest cascade size, and their
//!   samples take turns in the same layers: memory stays at one sample's views.
//! - `counts=auto`: the samples per axis of cascade c are k = ⌈W_c / 3 px⌉ clamped to 2…5, where W_c
//!   is the widest penumbra the light can cast in the scene
//!   ([`shadowlab_core::cascades::widest_penumbra`]) in pixels at the cascade's near depth
//!   ([`shadowlab_core::cascades::samples_per_axis`]): k copies of a hard edge split a penumbra
//!   into k steps, invisible under the PCF while about 3 pixels wide.

use shadowlab_core::cascades::{
    adjusted_depth_range, fix_splits, map_size_for, pixel_size, samples_per_axis, split_distances, widest_penumbra,
    width_across,
};
use shadowlab_core::convex::ConvexBody;
use shadowlab_core::lightspace::{
    LightFrusta, focused_directional, focused_directional_stable, focused_perspective, focused_perspective_stable,
};
use shadowlab_core::params::ParamDef;
use shadowlab_core::sampling::{EmitterPoint, EmitterSample, SamplePattern, emitter_points_with};
use shadowlab_core::{Aabb, Light, ParamSet, View};

use super::sampled::{PATTERN, sample_frusta, sample_pipelines};
use crate::context::Shared;
use crate::frame::VisibilityLayer;
use crate::sample_maps::{self, SET_FIRST, SET_PCF, SampleMaps, SetConfig, SetUniform};
use crate::shadowmap::{CONSTANT_BIAS, FACES, FaceMode, NORMAL_OFFSET, Raster, SLOPE_BIAS};
use crate::technique::{FrameContext, ShadowTechnique, TechniqueError, TechniqueInfo, TechniqueStats};

/// Most cascades.
const MAX_CASCADES: usize = 4;

/// The smallest map `sizes=auto` makes (Azri's far cascades).
const AUTO_MIN_SIZE: u32 = 128;

/// Texels per screen pixel that `sizes=auto` asks for at a cascade's near depth. Two, because the
/// 3 × 3 PCF and the normal offset (1.5 texels) spread each texel over its neighbours, and grazing
/// receivers stretch it: on `room`'s sun (128²) one texel per pixel left RMSE 0.048, two 0.034
/// (hard 0.036; Azri's fixed 1024/512/128 0.068).
const AUTO_TEXELS_PER_PIXEL: f32 = 2.0;

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "cssm",
    summary: "cascaded soft shadow maps: per-cascade sample counts and map sizes",
    source: "Azri 2020 §4 (NOTES-003)",
    params: &[
        ParamDef::int("cascades", 3, 1, MAX_CASCADES as i64, "cascades (view depth splits)"),
        ParamDef::float("lambda", 0.5, 0.0, 1.0, "split scheme: 0 uniform … 1 logarithmic"),
        ParamDef::float("split1", 0.0, 0.0, 1.0e6, "eye depth where cascade 1 starts (0: from lambda)"),
        ParamDef::float("split2", 0.0, 0.0, 1.0e6, "eye depth where cascade 2 starts (0: from lambda)"),
        ParamDef::float("split3", 0.0, 0.0, 1.0e6, "eye depth where cascade 3 starts (0: from lambda)"),
        ParamDef::choice(
            "counts",
            "fixed",
            &["fixed", "auto"],
            "sample counts: the samplesN parameters, or from the penumbra's size on screen",
        ),
        ParamDef::int("samples0", 16, 1, 256, "samples of cascade 0 (nearest)"),
        ParamDef::int("samples1", 9, 1, 256, "samples of cascade 1"),
        ParamDef::int("samples2", 4, 1, 256, "samples of cascade 2"),
        ParamDef::int("samples3", 4, 1, 256, "samples of cascade 3"),
        ParamDef::choice(
            "sizes",
            "fixed",
            &["fixed", "auto"],
            "map sizes: the sizeN parameters, or texels matched to pixels (at most the largest sizeN)",
        ),
        ParamDef::int("size0", 1024, 16, 8192, "map size of cascade 0"),
        ParamDef::int("size1", 512, 16, 8192, "map size of cascade 1"),
        ParamDef::int("size2", 128, 16, 8192, "map size of cascade 2"),
        ParamDef::int("size3", 128, 16, 8192, "map size of cascade 3"),
        ParamDef::float(
            "band",
            0.0,
            0.0,
            0.5,
            "blend band at each cascade's far end, fraction of its depth range (0: hard switch); the cascades blend in proportion to weight × samples",
        ),
        ParamDef::bool("pcf", true, "3×3 PCF on every sample's map (Azri 2020 Eq. 3.8)"),
        ParamDef::bool(
            "stabilize",
            false,
            "texel-snapped sample views with quantised widths and directions, against flicker",
        ),
        PATTERN,
        FACES,
        SLOPE_BIAS,
        NORMAL_OFFSET,
        CONSTANT_BIAS,
    ],
    light_types: super::ALL_LIGHTS,
    create,
    compose: None,
    fragment: false,
};

struct Cssm {
    params: ParamSet,
    accumulate: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    accum: Option<(wgpu::Buffer, u32, u32)>,
    cascades: Vec<CascadeMaps>,
    raster: Raster,
    draws: u32,
    triangles: u64,
    /// Eye-depth split distances of the last frame.
    splits: Vec<f32>,
}

/// One cascade's samples and maps, kept while its layout (sample count, views per sample, map size,
/// array or shared layers) holds.
struct CascadeMaps {
    set: SampleMaps,
    size: u32,
}

impl CascadeMaps {
    /// The lookup dispatches of the cascade: one over the whole array, or one per sample when the
    /// samples share their layers.
    fn dispatches(&self) -> u32 {
        if self.set.array { 1 } else { self.set.samples }
    }
}

fn create(shared: &Shared, params: &ParamSet, _light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let (accumulate, finish) = sample_pipelines(shared, "cssm", include_str!("cssm.wgsl"));
    let raster = Raster {
        faces: FaceMode::parse(params.choice("faces")),
        slope_bias: params.float("slope_bias") as f32,
        linear_depth: false,
        only_masked: false,
    };
    Ok(Box::new(Cssm {
        params: params.clone(),
        accumulate,
        finish,
        accum: None,
        cascades: Vec::new(),
        raster,
        draws: 0,
        triangles: 0,
        splits: Vec::new(),
    }))
}

/// The corners of a cascade's slice of the view frustum clipped to the scene (a tiny box at the
/// scene's centre when the slice misses the scene: no pixel will use that cascade).
fn slice_points(view: &View, aspect: f32, near: f32, far: f32, scene: &Aabb) -> Vec<glam::Vec3> {
    let slice = View { near, far: far.max(near * (1.0 + 1e-5)), ..view.clone() };
    let body = ConvexBody::from_frustum(&(slice.projection(aspect) * slice.view_matrix())).clip_to_aabb(scene);
    let points: Vec<glam::Vec3> = body.points().collect();
    if points.is_empty() {
        let c = scene.center();
        let e = glam::Vec3::splat(1e-3 * scene.diagonal().max(1e-3));
        return vec![c - e, c + e];
    }
    points
}

/// Every sample's view fitted to the slice (`true`), or (if any sample cannot be fitted: inside
/// it, or seeing it too wide) the whole-scene views of `sampled` for all of them (`false`).
fn cascade_frusta(
    light: &Light,
    points: &[EmitterPoint],
    scene: &Aabb,
    slice: &[glam::Vec3],
    size: u32,
    stable: bool,
) -> (Vec<LightFrusta>, bool) {
    let fitted: Option<Vec<LightFrusta>> = points
        .iter()
        .map(|p| {
            let view = match (p.sample, stable) {
                (EmitterSample::Point(q), false) => focused_perspective(q, slice, scene, size),
                (EmitterSample::Point(q), true) => focused_perspective_stable(q, slice, scene, size),
                (EmitterSample::Direction(d), false) => Some(focused_directional(-d, scene, slice, size)),
                (EmitterSample::Direction(d), true) => Some(focused_directional_stable(-d, scene, slice, size)),
            };
            view.map(|v| LightFrusta { views: vec![v], cube: false })
        })
        .collect();
    match fitted {
        Some(views) => (views, true),
        None => {
            let samples: Vec<EmitterSample> = points.iter().map(|p| p.sample).collect();
            (sample_frusta(light, &samples, scene, size), false)
        }
    }
}

impl Cssm {
    /// Sample counts per cascade for this frame.
    fn counts(&self, ctx: &FrameContext<'_>, view: &View, splits: &[f32]) -> Vec<u32> {
        let m = splits.len() - 1;
        if self.params.choice("counts") == "auto" {
            let widest = widest_penumbra(ctx.light, &ctx.scene.occluder_bounds(), &ctx.gpu_scene.bounds);
            (0..m)
                .map(|c| {
                    let px = widest / pixel_size(splits[c], view.fov_y, ctx.surface.height).max(1e-9);
                    samples_per_axis(px, 3.0).pow(2)
                })
                .collect()
        } else {
            (0..m).map(|c| self.params.int(&format!("samples{c}")) as u32).collect()
        }
    }

    /// The set uniforms of cascade c (its depth range and blend bands): one for `samples` maps
    /// looked up together, or one per sample for maps that share their layers.
    fn set_uniforms(&self, c: usize, splits: &[f32], samples: u32, faces: u32, array: bool) -> Vec<SetUniform> {
        let first = self.set_uniform(c, splits, faces);
        if array {
            return vec![SetUniform { index: [0, samples, faces, first.index[3]], ..first }];
        }
        (0..samples)
            .map(|i| {
                let flags = first.index[3];
                let flags = if i == 0 { flags } else { flags & !SET_FIRST };
                SetUniform { index: [i, 1, faces, flags], ..first }
            })
            .collect()
    }

    /// The set uniform of cascade c: its depth range and blend bands.
    fn set_uniform(&self, c: usize, splits: &[f32], faces: u32) -> SetUniform {
        let m = splits.len() - 1;
        let band = self.params.float("band") as f32;
        let pcf = if self.params.bool("pcf") { SET_PCF } else { 0 };
        let flags = pcf | if c == 0 { SET_FIRST } else { 0 };
        let (lo, hi) = (splits[c], splits[c + 1]);
        let mut u = SetUniform::all(0, 0, faces, flags);
        u.range[0] = if c == 0 { -f32::MAX } else { lo };
        u.range[1] = if c + 1 == m { f32::MAX } else { hi };
        u.range[2] = if c + 1 == m || band <= 0.0 { f32::MAX } else { hi - band * (hi - lo) };
        // Without a band the previous set's band is empty: it starts where this set does.
        u.range[3] = match c {
            0 => -f32::MAX,
            _ if band <= 0.0 => lo,
            _ => lo - band * (lo - splits[c - 1]),
        };
        u
    }
}

impl ShadowTechnique for Cssm {
    fn map_views(&self) -> Vec<shadowlab_core::lightspace::ShadowView> {
        self.cascades.iter().flat_map(|c| c.set.views().iter().copied()).collect()
    }

    fn id(&self) -> &'static str {
        INFO.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        let shared = ctx.shared;
        let (w, h) = (ctx.surface.width, ctx.surface.height);
        if self.accum.as_ref().is_none_or(|a| (a.1, a.2) != (w, h)) {
            self.accum = Some((sample_maps::accumulation_buffer(shared, INFO.id, w, h)?, w, h));
            self.cascades.clear();
        }
        let view = ctx.surface.camera.view();
        let aspect = ctx.surface.camera.aspect();
        let bounds = ctx.gpu_scene.bounds;
        let (near, far) = adjusted_depth_range(&view, aspect, &bounds).unwrap_or((view.near, view.far));
        let m = (self.params.int("cascades") as usize).clamp(1, MAX_CASCADES);
        let mut splits = split_distances(near, far, m, self.params.float("lambda") as f32, near, far);
        let fixed: Vec<f32> = (1..MAX_CASCADES).map(|i| self.params.float(&format!("split{i}")) as f32).collect();
        fix_splits(&mut splits, &fixed);
        let counts = self.counts(ctx, &view, &splits);
        let pattern = SamplePattern::parse(self.params.choice("pattern")).unwrap_or(SamplePattern::Grid);
        let accum = &self.accum.as_ref().expect("made above").0;
        let largest = (0..m).map(|c| self.params.int(&format!("size{c}")) as u32).max().unwrap_or(1);
        for c in 0..m {
            let points = emitter_points_with(ctx.light, counts[c], pattern);
            let slice = slice_points(&view, aspect, splits[c], splits[c + 1], &bounds);
            let mut size = self.params.int(&format!("size{c}")) as u32;
            if self.params.choice("sizes") == "auto" {
                let centroid = slice.iter().copied().sum::<glam::Vec3>() / slice.len().max(1) as f32;
                let axis = match ctx.light.position() {
                    Some(p) => centroid - p,
                    None => ctx.light.direction().unwrap_or(glam::Vec3::NEG_Y),
                };
                let texel = pixel_size(splits[c], view.fov_y, ctx.surface.height) / AUTO_TEXELS_PER_PIXEL;
                size = map_size_for(width_across(&slice, axis), texel, AUTO_MIN_SIZE, largest);
            }
            let stable = self.params.bool("stabilize");
            let (mut frusta, fitted) = cascade_frusta(ctx.light, &points, &bounds, &slice, size, stable);
            // Whole-scene views (a light inside or beside the slice: room lamps) spread each map
            // over everything, where Azri's smaller far maps assume views fitted to their slice:
            // those keep the largest cascade size, and their samples take turns in the same
            // layers (accumulated pass by pass, as `sampled` does), so that memory stays at one
            // sample's views (up to six cube faces) whatever the count.
            if !fitted && size < largest {
                size = largest;
                frusta = cascade_frusta(ctx.light, &points, &bounds, &slice, size, stable).0;
            }
            let array = fitted;
            let n = points.len() as u32;
            let faces = frusta[0].views.len() as u32;
            let sets = self.set_uniforms(c, &splits, n, faces, array);
            let keep = self
                .cascades
                .get(c)
                .is_some_and(|k| k.size == size && k.set.samples == n && k.set.faces == faces && k.set.array == array);
            if keep {
                let k = &mut self.cascades[c];
                k.set.set_points(&shared.gpu.queue, &points);
                k.set.set_views(&shared.gpu.queue, &frusta);
                for (i, set) in sets.iter().enumerate() {
                    k.set.write_set(&shared.gpu.queue, i, set);
                }
            } else {
                if let Some(old) = self.cascades.get(c) {
                    old.set.forget_items(ctx);
                }
                let config = SetConfig {
                    size,
                    array,
                    normal_offset: self.params.float("normal_offset") as f32,
                    constant_bias: self.params.float("constant_bias") as f32,
                };
                let maps = SampleMaps::new(shared, ctx.cache, INFO.id, &points, &frusta, config, accum, &sets)?;
                let made = CascadeMaps { set: maps, size };
                if c < self.cascades.len() {
                    self.cascades[c] = made;
                } else {
                    self.cascades.push(made);
                }
            }
        }
        for old in self.cascades.iter().skip(m) {
            old.set.forget_items(ctx);
        }
        self.cascades.truncate(m);
        // Fitted cascades keep their samples' maps while their views hold (a still camera).
        self.draws = 0;
        for k in &mut self.cascades {
            k.set.update(ctx, &self.raster)?;
            if let crate::sample_maps::SampleStorage::Cached(maps) = &k.set.storage {
                self.draws += maps.draws;
            }
        }
        self.splits = splits;
        self.triangles = ctx.gpu_scene.triangles;
        Ok(())
    }

    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        if self.cascades.is_empty() {
            return;
        }
        let group0 = ctx.shared.resolve_bind_group(ctx.surface, ctx.light_buffer, out);
        // Array cascades (maps rendered in prepare): one lookup. Shared layers: each sample's maps,
        // then its lookup, in turn. Cascade 0's first lookup starts the sums.
        for k in &self.cascades {
            if k.set.array {
                k.set.dispatch(ctx, "cssm cascade", &self.accumulate, &group0, 0);
            } else {
                for i in 0..k.set.samples {
                    self.draws += k.set.render_sample(ctx, i, &self.raster);
                    k.set.dispatch(ctx, "cssm cascade sample", &self.accumulate, &group0, i as usize);
                }
            }
        }
        self.cascades[0].set.dispatch(ctx, "cssm finish", &self.finish, &group0, 0);
    }

    fn shown(&self) -> bool {
        !self.cascades.is_empty() && self.cascades.iter().all(|k| k.set.shown())
    }

    fn current(&self) -> bool {
        self.cascades.iter().all(|k| k.set.current())
    }

    fn stats(&self) -> TechniqueStats {
        if self.cascades.is_empty() {
            return TechniqueStats::default();
        }
        let views: u32 = self.cascades.iter().map(|k| k.set.samples * k.set.faces).sum();
        let mut extra = Vec::new();
        for (c, k) in self.cascades.iter().enumerate() {
            extra.push((format!("cascade{c}_samples"), f64::from(k.set.samples)));
            extra.push((format!("cascade{c}_map_size"), f64::from(k.size)));
            extra.push((format!("cascade{c}_views_per_sample"), f64::from(k.set.faces)));
            extra.push((format!("cascade{c}_fitted"), if k.set.array { 1.0 } else { 0.0 }));
        }
        for (i, d) in self.splits.iter().enumerate() {
            extra.push((format!("split{i}"), f64::from(*d)));
        }
        TechniqueStats {
            memory_bytes: self.cascades.iter().map(|k| k.set.bytes()).sum::<u64>()
                + self.accum.as_ref().map_or(0, |a| a.0.size()),
            passes: views + self.cascades.iter().map(CascadeMaps::dispatches).sum::<u32>() + 1,
            draws: self.draws,
            triangles: self.triangles * u64::from(views),
            extra,
        }
    }
}
