//! The shadow techniques, one module each with its WGSL beside it.

mod cascaded;
mod hard;
mod none;
mod pcf;
mod sampled;
mod volumes;

use crate::technique::TechniqueInfo;

pub use cascaded::{cascade_settings, selection_layout};

/// Every light type.
pub(crate) const ALL_LIGHTS: &[&str] = &["point", "spot", "directional", "rect"];

pub(crate) static REGISTRY: &[TechniqueInfo] =
    &[none::INFO, hard::INFO, pcf::INFO, sampled::INFO, cascaded::INFO, volumes::INFO];
