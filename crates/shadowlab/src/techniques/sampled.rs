//! `sampled`: the documents' own ground truth on the GPU. The area light is replaced by N point
//! samples with one hard shadow map each, and V is their average (Guennebaud et al. 2007, Fig. 1:
//! 1024 maps; Azri 2020 §3: k × k samples; Toromanoff 2005, algorithm D). It doubles as a check of
//! the CPU reference.
//!
//! - `pattern`: the k × k grid (Azri), one jittered point per grid cell (`stratified`), or
//!   Toromanoff's concentric rings (`rings`, [`shadowlab_core::sampling::SamplePattern::Rings`]).
//!   Grid and stratified samples of sphere lights cover the whole sphere at equal area and are
//!   weighted per receiver by their projected area, so that they cover the light's disk uniformly
//!   ([`shadowlab_core::sampling::emitter_points`]).
//! - `pcf`: a 3 × 3 PCF on every sample's map (Azri 2020 Eq. 3.8), which hides the steps between
//!   the samples' hard edges with few samples.
//! - `mode`: `accumulate` renders the samples one after the other into the same layers and adds each
//!   to per-pixel sums (memory of one map, whatever N); `array` renders every sample into its own
//!   layer of one texture array and looks them all up in a single pass (Azri 2020 §3: about 10%
//!   faster; memory grows with N, and N × views must fit the device's array layers).

use shadowlab_core::lightspace::{LightFrusta, directional_frustum, point_frusta_with};
use shadowlab_core::params::ParamDef;
use shadowlab_core::sampling::{EmitterPoint, EmitterSample, SamplePattern, emitter_points_with};
use shadowlab_core::{Light, LightKind, ParamSet};

use crate::context::Shared;
use crate::frame::VisibilityLayer;
use crate::sample_maps::{self, SET_FIRST, SET_PCF, SampleMaps, SetConfig, SetUniform, uniform_layout};
use crate::shadowmap::{CONSTANT_BIAS, FACES, FaceMode, NORMAL_OFFSET, Raster, SLOPE_BIAS, lookup_layout};
use crate::technique::{FrameContext, ShadowTechnique, TechniqueError, TechniqueInfo, TechniqueStats};

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "sampled",
    summary: "area light as N point samples with one hard shadow map each, averaged",
    source: "Guennebaud et al. 2007 Fig. 1; Azri 2020 §3; Toromanoff 2005 alg. D",
    params: &[
        ParamDef::int("samples", 64, 1, 4096, "emitter samples (one shadow map each)"),
        ParamDef::int("map_size", 512, 16, 8192, "shadow map resolution of each sample"),
        PATTERN,
        ParamDef::bool("pcf", false, "3×3 PCF on every sample's map (Azri 2020)"),
        ParamDef::choice(
            "mode",
            "accumulate",
            &["accumulate", "array"],
            "accumulate over passes, or one texture array looked up in one pass",
        ),
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

/// The sample pattern parameter, shared with `cssm`.
pub const PATTERN: ParamDef =
    ParamDef::choice("pattern", "grid", SamplePattern::NAMES, "emitter samples: k×k grid, jittered grid or rings");

struct Sampled {
    params: ParamSet,
    state: Option<State>,
    accumulate: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    triangles: u64,
}

/// Built on the first frame, when the scene bounds and the surface size are known; rebuilt when
/// the surface size or the layout of the samples' views changes.
struct State {
    set: SampleMaps,
    raster: Raster,
    accum_bytes: u64,
    size: (u32, u32),
    draws: u32,
}

/// The pipelines of a `samples.wgsl` technique: `accumulate` and `finish` of `source`.
pub(crate) fn sample_pipelines(
    shared: &Shared,
    key: &str,
    source: &str,
) -> (wgpu::ComputePipeline, wgpu::ComputePipeline) {
    let extra = [&lookup_layout(shared), &sample_maps::layout(shared)];
    (
        shared.resolve_pipeline(&format!("{key} accumulate"), source, "accumulate", &extra, &[]),
        shared.resolve_pipeline(&format!("{key} finish"), source, "finish", &extra, &[]),
    )
}

fn create(shared: &Shared, params: &ParamSet, _light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let (accumulate, finish) = sample_pipelines(shared, "sampled", include_str!("sampled.wgsl"));
    Ok(Box::new(Sampled { params: params.clone(), state: None, accumulate, finish, triangles: 0 }))
}

/// The whole-scene views of every sample, all with the same layout (all cube or all single).
pub(crate) fn sample_frusta(
    light: &Light,
    samples: &[EmitterSample],
    bounds: &shadowlab_core::Aabb,
    size: u32,
) -> Vec<LightFrusta> {
    let cone = match light.kind {
        LightKind::Spot { direction, outer_angle, .. } => Some((direction, outer_angle)),
        LightKind::Rect { direction, .. } => Some((direction, std::f32::consts::FRAC_PI_2)),
        _ => None,
    };
    uniform_layout(|force_cube| {
        samples
            .iter()
            .map(|s| match *s {
                EmitterSample::Point(p) => point_frusta_with(p, bounds, cone, size, force_cube),
                EmitterSample::Direction(d) => directional_frustum(-d, bounds, size),
            })
            .collect()
    })
}

impl Sampled {
    /// The samples and their views as the light and the scene are now.
    fn layout(&self, ctx: &FrameContext<'_>) -> (Vec<EmitterPoint>, Vec<LightFrusta>) {
        let size = self.params.int("map_size") as u32;
        let pattern = SamplePattern::parse(self.params.choice("pattern")).unwrap_or(SamplePattern::Grid);
        let points = emitter_points_with(ctx.light, self.params.int("samples") as u32, pattern);
        let samples: Vec<EmitterSample> = points.iter().map(|p| p.sample).collect();
        let frusta = sample_frusta(ctx.light, &samples, &ctx.gpu_scene.bounds, size);
        (points, frusta)
    }

    fn build(
        &self,
        ctx: &mut FrameContext<'_>,
        points: &[EmitterPoint],
        frusta: &[LightFrusta],
    ) -> Result<State, TechniqueError> {
        let shared = ctx.shared;
        let size = self.params.int("map_size") as u32;
        let faces = frusta[0].views.len() as u32;
        let n = points.len() as u32;
        let array = self.params.choice("mode") == "array";
        let pcf = if self.params.bool("pcf") { SET_PCF } else { 0 };
        let sets: Vec<SetUniform> = if array {
            vec![SetUniform::all(0, n, faces, pcf | SET_FIRST)]
        } else {
            (0..n).map(|i| SetUniform::all(i, 1, faces, pcf | if i == 0 { SET_FIRST } else { 0 })).collect()
        };
        let (w, h) = (ctx.surface.width, ctx.surface.height);
        let accum = sample_maps::accumulation_buffer(shared, INFO.id, w, h)?;
        let config = SetConfig {
            size,
            array,
            normal_offset: self.params.float("normal_offset") as f32,
            constant_bias: self.params.float("constant_bias") as f32,
        };
        let set = SampleMaps::new(shared, ctx.cache, INFO.id, points, frusta, config, &accum, &sets)?;
        Ok(State {
            set,
            raster: Raster {
                faces: FaceMode::parse(self.params.choice("faces")),
                slope_bias: self.params.float("slope_bias") as f32,
                linear_depth: false,
                only_masked: false,
            },
            accum_bytes: accum.size(),
            size: (w, h),
            draws: 0,
        })
    }
}

impl ShadowTechnique for Sampled {
    fn map_views(&self) -> Vec<shadowlab_core::lightspace::ShadowView> {
        self.state.as_ref().map_or_else(Vec::new, |s| s.set.views().to_vec())
    }

    fn id(&self) -> &'static str {
        INFO.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    /// Array mode: renders the samples' views that are not valid (cached across frames).
    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        let (points, frusta) = self.layout(ctx);
        let size = (ctx.surface.width, ctx.surface.height);
        let faces = frusta[0].views.len() as u32;
        let keep = self
            .state
            .as_ref()
            .is_some_and(|s| s.size == size && s.set.samples == points.len() as u32 && s.set.faces == faces);
        if keep {
            let state = self.state.as_mut().expect("checked");
            state.set.set_points(&ctx.gpu.queue, &points);
            state.set.set_views(&ctx.gpu.queue, &frusta);
        } else {
            if let Some(old) = &self.state {
                old.set.forget_items(ctx);
            }
            self.state = Some(self.build(ctx, &points, &frusta)?);
        }
        let state = self.state.as_mut().expect("made above");
        state.set.update(ctx, &state.raster)?;
        state.draws = match &state.set.storage {
            crate::sample_maps::SampleStorage::Cached(m) => m.draws,
            crate::sample_maps::SampleStorage::Shared(_) => 0,
        };
        self.triangles = ctx.gpu_scene.triangles;
        Ok(())
    }

    /// Array mode: one lookup pass over the cached maps. Accumulation: renders and looks up the
    /// samples one after the other (nothing is kept). Then writes V.
    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let Some(state) = &mut self.state else { return };
        let group0 = ctx.shared.resolve_bind_group(ctx.surface, ctx.light_buffer, out);
        let set = &state.set;
        if set.array {
            set.dispatch(ctx, "sampled lookup", &self.accumulate, &group0, 0);
        } else {
            for i in 0..set.samples {
                state.draws += set.render_sample(ctx, i, &state.raster);
                set.dispatch(ctx, "sampled accumulate", &self.accumulate, &group0, i as usize);
            }
        }
        set.dispatch(ctx, "sampled finish", &self.finish, &group0, 0);
    }

    fn shown(&self) -> bool {
        self.state.as_ref().is_some_and(|s| s.set.shown())
    }

    fn current(&self) -> bool {
        self.state.as_ref().is_some_and(|s| s.set.current())
    }

    fn stats(&self) -> TechniqueStats {
        match &self.state {
            Some(s) => {
                let lookups = if s.set.array { 1 } else { s.set.samples };
                let rendered = if s.set.array { s.set.rendered } else { s.set.samples * s.set.faces };
                TechniqueStats {
                    memory_bytes: s.set.bytes() + s.accum_bytes,
                    passes: rendered + lookups + 1,
                    draws: s.draws,
                    triangles: self.triangles * u64::from(rendered),
                    extra: vec![
                        ("samples".into(), f64::from(s.set.samples)),
                        ("views_per_sample".into(), f64::from(s.set.faces)),
                    ],
                }
            }
            None => TechniqueStats::default(),
        }
    }
}
