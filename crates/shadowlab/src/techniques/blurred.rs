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

use super::map_lookup::MapLookup;
use crate::context::Shared;
use crate::kernel;
use crate::shadowmap::lookup_layout;
use crate::technique::{ShadowTechnique, TechniqueError, TechniqueInfo};

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
    compose: None,
    fragment: false,
};

fn create(shared: &Shared, params: &ParamSet, _light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let n = params.int("n") as usize;
    let k = kernel::kernel_uniform("box", n * n, params.float("radius") as f32, false, 0.0);
    let own = kernel::bind_group(shared, &k);
    let pipeline = crate::context::ResolveProgram::Compute(shared.resolve_pipeline(
        "blurred",
        include_str!("blurred.wgsl"),
        "main",
        &[&lookup_layout(shared), &kernel::layout(shared)],
        &[],
    ));
    Ok(MapLookup::boxed(INFO.id, params, true, pipeline, Some(own)))
}
