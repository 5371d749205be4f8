//! `pcf`: percentage-closer filtering (Reeves, Salesin & Cook, SIGGRAPH 1987) on the maps of `hard`.
//! Each tap is a bilinear comparison (a 2 × 2 PCF of its own, the hardware comparison sampler where
//! the backend has it). Kernels: a box of N × N taps (Azri 2020 §3 uses 3 × 3: `kernel=box,taps=9`),
//! a Poisson disk of N taps, or the same disk rotated per pixel (interleaved gradient noise, Jimenez
//! 2014), which trades banding for noise. The radius is in texels or in world units at the receiver.

use shadowlab_core::{Light, ParamSet};

use super::map_lookup::MapLookup;
use crate::context::Shared;
use crate::kernel;
use crate::shadowmap::lookup_layout;
use crate::technique::{ShadowTechnique, TechniqueError, TechniqueInfo};

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "pcf",
    summary: "percentage-closer filtering: box, Poisson or rotated Poisson kernels",
    source: "Reeves et al. 1987; Azri 2020 §3 (3×3 PCF); Stingl 2011 §2.3",
    params: crate::map_params!(kernel::KERNEL, kernel::TAPS, kernel::RADIUS, kernel::RADIUS_UNIT, kernel::MAX_BLUR),
    light_types: super::ALL_LIGHTS,
    create,
    compose: None,
    fragment: true,
};

fn create(shared: &Shared, params: &ParamSet, _light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let own = kernel::bind_group(shared, &kernel::from_params(params));
    let pipeline = shared.resolve_program(
        "pcf",
        include_str!("pcf.wgsl"),
        "main",
        &[&lookup_layout(shared), &kernel::layout(shared)],
        &[],
    );
    Ok(MapLookup::boxed(INFO.id, params, true, pipeline, Some(own)))
}
