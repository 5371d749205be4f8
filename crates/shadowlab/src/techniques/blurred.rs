//! `blurred`: blurred projected texture shadows (Toromanoff 2005, algorithm C / Algorithm 5): the
//! hard shadow averaged over N × N copies shifted on a regular grid (N = 6: 36 copies), one
//! constant kernel for every pixel whatever the distances between light, occluder and receiver.
//! Toromanoff blurs the receiver's projected shadow texture once; without separate receivers the
//! same average is taken per pixel over the N × N comparison taps. The cheapest soft look and
//! "totally false approximations of the shadows" (the thesis): contact shadows are as wide as
//! distant ones. Kept as a point on the quality/time curve.
//!
//! The offset step and the blur radius are not stated in the thesis (NOTES-000 §C); here the copies
//! are centred on the pixel, spanning `±radius` texels.

use shadowlab_core::params::ParamDef;
use shadowlab_core::{Light, ParamSet};

use crate::frame::VisibilityLayer;
use crate::kernel;
use crate::shadowmap::{LightMap, lookup_layout};
use crate::technique::{
    FrameContext, MapAnalysis, ShadowTechnique, Shared, TechniqueError, TechniqueInfo, TechniqueStats, dispatch_resolve,
};

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "blurred",
    summary: "hard map blurred with one constant N×N kernel (the cheapest soft look)",
    source: "Toromanoff 2005 alg. C (Algorithm 5)",
    params: crate::map_params!(
        ParamDef::int("n", 6, 1, 8, "copies per side (N × N taps; Toromanoff: 6)"),
        ParamDef::float("radius", 12.0, 0.0, 64.0, "half the span of the copies (texels)"),
    ),
    light_types: super::ALL_LIGHTS,
    create,
};

struct Blurred {
    params: ParamSet,
    map: Option<LightMap>,
    pipeline: wgpu::ComputePipeline,
    kernel_group: wgpu::BindGroup,
    kernel_bytes: u64,
    triangles: u64,
}

fn create(shared: &Shared, params: &ParamSet, _light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let n = params.int("n") as usize;
    let k = kernel::kernel_uniform("box", n * n, params.float("radius") as f32, false);
    let (kernel_group, kernel_bytes) = kernel::bind_group(shared, &k);
    let pipeline = shared.resolve_pipeline(
        "blurred",
        include_str!("blurred.wgsl"),
        "main",
        &[&lookup_layout(shared), &kernel::layout(shared)],
        &[],
    );
    Ok(Box::new(Blurred { params: params.clone(), map: None, pipeline, kernel_group, kernel_bytes, triangles: 0 }))
}

impl ShadowTechnique for Blurred {
    fn id(&self) -> &'static str {
        INFO.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        let map = self
            .map
            .get_or_insert_with(|| LightMap::new(ctx.shared, ctx.light, &ctx.gpu_scene.bounds, &self.params, true));
        map.render(ctx);
        self.triangles = ctx.gpu_scene.triangles;
        Ok(())
    }

    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let Some(map) = &self.map else { return };
        let group0 = ctx.shared.resolve_bind_group(ctx.surface, ctx.light_buffer, out);
        dispatch_resolve(ctx, "blurred", &self.pipeline, &[&group0, &map.group, &self.kernel_group]);
    }

    fn stats(&self) -> TechniqueStats {
        match &self.map {
            Some(m) => {
                let (passes, draws, triangles) = m.counts(self.triangles);
                TechniqueStats {
                    memory_bytes: m.bytes() + self.kernel_bytes,
                    passes: passes + 1,
                    draws,
                    triangles,
                    extra: Vec::new(),
                }
            }
            None => TechniqueStats::default(),
        }
    }

    fn analysis(&self) -> Option<MapAnalysis<'_>> {
        self.map.as_ref().map(|m| MapAnalysis { lookup: &m.group, selection: &m.selection })
    }
}
