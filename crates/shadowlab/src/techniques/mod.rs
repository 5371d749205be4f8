//! The shadow techniques, one module each with its WGSL beside it.

mod blurred;
mod cascaded;
mod cssm;
mod hard;
mod lightmaps;
mod lightmesh;
mod map_lookup;
mod none;
mod pcf;
mod pcss;
mod sampled;
mod smoothies;
mod ssm;
mod volumes;

use crate::technique::TechniqueInfo;

pub use cascaded::cascade_settings;

/// Every light type.
pub(crate) const ALL_LIGHTS: &[&str] = &["point", "spot", "directional", "rect"];

pub(crate) static REGISTRY: &[TechniqueInfo] = &[
    none::INFO,
    hard::INFO,
    pcf::INFO,
    sampled::INFO,
    cascaded::INFO,
    volumes::INFO,
    pcss::INFO,
    blurred::INFO,
    cssm::INFO,
    smoothies::INFO,
    lightmaps::INFO,
    ssm::INFO,
    lightmesh::INFO,
];
