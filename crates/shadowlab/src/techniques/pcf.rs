//! `pcf`: percentage-closer filtering (Reeves, Salesin & Cook, SIGGRAPH 1987) on the maps of `hard`.
//! Each tap is a bilinear comparison (a 2 × 2 PCF of its own, the hardware comparison sampler where
//! the backend has it). Kernels: a box of N × N taps (Azri 2020 §3 uses 3 × 3: `kernel=box,taps=9`),
//! a Poisson disk of N taps, or the same disk rotated per pixel (interleaved gradient noise, Jimenez
//! 2014), which trades banding for noise. The radius is in texels or in world units at the receiver.

use shadowlab_core::{Light, ParamSet};

use crate::frame::VisibilityLayer;
use crate::kernel;
use crate::shadowmap::{LightMap, lookup_layout};
use crate::technique::{
    FrameContext, MapAnalysis, ShadowTechnique, Shared, TechniqueError, TechniqueInfo, TechniqueStats, dispatch_resolve,
};

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "pcf",
    summary: "percentage-closer filtering: box, Poisson or rotated Poisson kernels",
    source: "Reeves et al. 1987; Azri 2020 §3 (3×3 PCF); Stingl 2011 §2.3",
    params: crate::map_params!(kernel::KERNEL, kernel::TAPS, kernel::RADIUS, kernel::RADIUS_UNIT),
    light_types: super::ALL_LIGHTS,
    create,
};

struct Pcf {
    params: ParamSet,
    map: Option<LightMap>,
    pipeline: wgpu::ComputePipeline,
    kernel_group: wgpu::BindGroup,
    kernel_bytes: u64,
    triangles: u64,
}

fn create(shared: &Shared, params: &ParamSet, _light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let (kernel_group, kernel_bytes) = kernel::bind_group(shared, &kernel::from_params(params));
    let pipeline = shared.resolve_pipeline(
        "pcf",
        include_str!("pcf.wgsl"),
        "main",
        &[&lookup_layout(shared), &kernel::layout(shared)],
        &[],
    );
    Ok(Box::new(Pcf { params: params.clone(), map: None, pipeline, kernel_group, kernel_bytes, triangles: 0 }))
}

impl ShadowTechnique for Pcf {
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
        dispatch_resolve(ctx, "pcf", &self.pipeline, &[&group0, &map.group, &self.kernel_group]);
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
