//! `pcss`: percentage-closer soft shadows (R. Fernando, "Percentage-Closer Soft Shadows", SIGGRAPH
//! 2005 sketch), the soft shadows of Bevy, Filament, Babylon and PlayCanvas and the baseline the
//! other soft techniques are measured against. One hard map from the light's centre; per pixel:
//!
//! 1. **blocker search** over the region of the map where a blocker could hide part of the light
//!    (the cone from the receiver to the emitter, as seen through the light's centre);
//! 2. **penumbra estimate** `w = R·(z_r − z_b)/z_b` from the average blocker distance `z_b` (for the
//!    sun `tan θ·(z_r − z_b)`), R the emitter's radius ([`shadowlab_core::Light::emitter_extent`]);
//! 3. **PCF** over a disk of radius w.
//!
//! Taps are a progressive Poisson disk, optionally rotated per pixel (interleaved gradient noise),
//! which trades banding for noise. Its known faults, visible in the error maps: one average blocker
//! depth per pixel (overlapping blockers at different depths are wrong), blockers missed by a sparse
//! search, and a penumbra that grows outward and inward from the hard edge alike.

use shadowlab_core::params::ParamDef;
use shadowlab_core::{EmitterExtent, Light, ParamSet};

use super::map_lookup::MapLookup;
use crate::context::{Shared, uniform_entry};
use crate::kernel;
use crate::shadowmap::lookup_layout;
use crate::technique::{ShadowTechnique, TechniqueError, TechniqueInfo};

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "pcss",
    summary: "percentage-closer soft shadows: blocker search, penumbra estimate, variable PCF",
    source: "Fernando 2005 (SIGGRAPH sketch)",
    params: crate::map_params!(
        ParamDef::int("search_taps", 16, 1, 64, "taps of the blocker search"),
        ParamDef::int("filter_taps", 32, 1, 64, "taps of the PCF filter"),
        ParamDef::bool("rotate", true, "rotate the Poisson disk per pixel (noise instead of banding)"),
        ParamDef::float("max_search", 48.0, 1.0, 512.0, "largest blocker-search radius (texels)"),
        ParamDef::float("max_filter", 48.0, 0.5, 512.0, "largest filter radius (texels)"),
        ParamDef::float("min_filter", 1.0, 0.0, 16.0, "smallest filter radius (texels; at most a pixel's footprint)"),
    ),
    light_types: super::ALL_LIGHTS,
    create,
    compose: None,
    fragment: true,
};

/// `Pcss` in `pcss.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct PcssUniform {
    params: [f32; 4],
    limits: [f32; 4],
    taps: [[f32; 4]; kernel::MAX_TAPS],
}

fn layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("pcss", || {
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("pcss"),
            entries: &[uniform_entry(0, shared.resolve_stage())],
        })
    })
}

fn create(shared: &Shared, params: &ParamSet, light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let (size, nearest) = emitter_terms(light);
    let search = params.int("search_taps") as usize;
    let filter = params.int("filter_taps") as usize;
    let disk = kernel::poisson_disk(search.max(filter).min(kernel::MAX_TAPS));
    let mut u = PcssUniform {
        params: [search as f32, filter as f32, if params.bool("rotate") { 1.0 } else { 0.0 }, size],
        limits: [
            params.float("max_search") as f32,
            params.float("max_filter") as f32,
            params.float("min_filter") as f32,
            nearest,
        ],
        taps: [[0.0; 4]; kernel::MAX_TAPS],
    };
    for (t, p) in u.taps.iter_mut().zip(&disk) {
        *t = [p.x, p.y, 0.0, 0.0];
    }
    let buffer = crate::util::uniform_buffer(&shared.gpu.device, "pcss", bytemuck::bytes_of(&u));
    let group = shared.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("pcss"),
        layout: &layout(shared),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() }],
    });
    let pipeline = shared.resolve_program(
        "pcss",
        include_str!("pcss.wgsl"),
        "main",
        &[&lookup_layout(shared), &layout(shared)],
        &[],
    );
    let bytes = buffer.size();
    Ok(MapLookup::boxed_with_light(INFO.id, params, true, pipeline, (group, bytes), write_emitter, buffer))
}

/// The emitter's size and nearest-blocker bound (`params.w`, `limits.w`), from the light as it is.
fn emitter_terms(light: &Light) -> (f32, f32) {
    match light.emitter_extent() {
        EmitterExtent::Radius(r) => (r, r),
        EmitterExtent::Angle(t) => (t, 0.0),
    }
}

fn write_emitter(light: &Light, queue: &wgpu::Queue, buffer: &wgpu::Buffer) {
    let (size, nearest) = emitter_terms(light);
    queue.write_buffer(buffer, 12, bytemuck::bytes_of(&size));
    queue.write_buffer(buffer, 28, bytemuck::bytes_of(&nearest));
}
