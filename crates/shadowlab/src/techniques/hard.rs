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

use super::map_lookup::MapLookup;
use crate::context::Shared;
use crate::shadowmap::lookup_layout;
use crate::technique::{ShadowTechnique, TechniqueError, TechniqueInfo};

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "hard",
    summary: "standard shadow mapping, one nearest comparison per pixel",
    source: "Williams 1978; Stingl 2011 §2.1-2.2 (bias)",
    params: crate::map_params!(),
    light_types: super::ALL_LIGHTS,
    create,
    compose: None,
    fragment: true,
};

fn create(shared: &Shared, params: &ParamSet, _light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let pipeline = shared.resolve_program("hard", include_str!("hard.wgsl"), "main", &[&lookup_layout(shared)], &[]);
    Ok(MapLookup::boxed(INFO.id, params, false, pipeline, None))
}
