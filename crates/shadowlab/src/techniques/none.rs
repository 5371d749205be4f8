//! `none`: no shadows, V = 1 everywhere. The floor of every cost and the ceiling of every error.

use shadowlab_core::{Light, ParamSet};

use crate::context::{ResolveProgram, Shared};
use crate::frame::VisibilityLayer;
use crate::technique::{
    FrameContext, ShadowTechnique, TechniqueError, TechniqueInfo, TechniqueStats, dispatch_program_in,
};

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "none",
    summary: "no shadows (V = 1): the cost floor and error ceiling",
    source: "—",
    params: &[],
    light_types: super::ALL_LIGHTS,
    create,
    compose: None,
    fragment: true,
};

struct NoShadows {
    params: ParamSet,
    pipeline: ResolveProgram,
}

fn create(shared: &Shared, params: &ParamSet, _light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let pipeline = shared.resolve_program("none", include_str!("none.wgsl"), "main", &[], &[]);
    Ok(Box::new(NoShadows { params: params.clone(), pipeline }))
}

impl ShadowTechnique for NoShadows {
    fn id(&self) -> &'static str {
        INFO.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    fn prepare(&mut self, _ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        Ok(())
    }

    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let group = ctx.resolve_group(out);
        dispatch_program_in(ctx, "none", &self.pipeline, &[&group], out);
    }

    fn stats(&self) -> TechniqueStats {
        TechniqueStats { passes: 1, ..Default::default() }
    }
}
