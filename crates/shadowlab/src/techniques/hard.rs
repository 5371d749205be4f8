//! `hard`: standard shadow mapping (Williams 1978), the baseline every other technique is measured
//! against. Perspective maps for spot lights, six cube faces (or one frustum, when the scene fits
//! in one) for point and rectangle lights, an orthographic map fitted to the scene bounds for
//! directional lights; Depth32Float with reversed Z.
//!
//! Bias (Stingl 2011, §2.2, recommends slope-scaled bias with back faces): back faces of closed
//! meshes go into the map (`faces=back`), a slope-scaled raster bias (`slope_bias`), a lookup offset
//! along the normal scaled to the texel size (`normal_offset`, in texels) and a constant offset
//! towards the light (`constant_bias`, world units). Open and double-sided meshes are rendered with
//! both faces.

use shadowlab_core::{Light, ParamSet};

use crate::frame::VisibilityLayer;
use crate::shadowmap::{LightMap, lookup_layout};
use crate::technique::{
    FrameContext, MapAnalysis, ShadowTechnique, Shared, TechniqueError, TechniqueInfo, TechniqueStats, dispatch_resolve,
};

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "hard",
    summary: "standard shadow mapping, one nearest comparison per pixel",
    source: "Williams 1978; Stingl 2011 §2.1-2.2 (bias)",
    params: crate::map_params!(),
    light_types: super::ALL_LIGHTS,
    create,
};

struct Hard {
    params: ParamSet,
    map: Option<LightMap>,
    pipeline: wgpu::ComputePipeline,
    triangles: u64,
}

fn create(shared: &Shared, params: &ParamSet, _light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let pipeline = shared.resolve_pipeline("hard", include_str!("hard.wgsl"), "main", &[&lookup_layout(shared)], &[]);
    Ok(Box::new(Hard { params: params.clone(), map: None, pipeline, triangles: 0 }))
}

impl ShadowTechnique for Hard {
    fn id(&self) -> &'static str {
        INFO.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        let map = self
            .map
            .get_or_insert_with(|| LightMap::new(ctx.shared, ctx.light, &ctx.gpu_scene.bounds, &self.params, false));
        map.render(ctx);
        self.triangles = ctx.gpu_scene.triangles;
        Ok(())
    }

    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let Some(map) = &self.map else { return };
        let group0 = ctx.shared.resolve_bind_group(ctx.surface, ctx.light_buffer, out);
        dispatch_resolve(ctx, "hard", &self.pipeline, &[&group0, &map.group]);
    }

    fn stats(&self) -> TechniqueStats {
        match &self.map {
            Some(m) => {
                let (passes, draws, triangles) = m.counts(self.triangles);
                TechniqueStats { memory_bytes: m.bytes(), passes: passes + 1, draws, triangles, extra: Vec::new() }
            }
            None => TechniqueStats::default(),
        }
    }

    fn analysis(&self) -> Option<MapAnalysis<'_>> {
        self.map.as_ref().map(|m| MapAnalysis { lookup: &m.group, selection: &m.selection })
    }
}
