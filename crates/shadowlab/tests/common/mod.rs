//! Helpers for GPU tests: render a technique, trace the reference on the same surface.

#![allow(dead_code)]

use shadowlab::{BackendChoice, Gpu, Renderer, TechniqueSpec};
use shadowlab_core::{LightId, Scene, SurfaceBuffer, View};
use shadowlab_reference::{ReferenceSettings, SceneBvh, Selection, light_visibility};

/// The test GPU: whatever wgpu finds (on CI machines Mesa's lavapipe, Vulkan on the CPU).
pub fn gpu() -> Gpu {
    Gpu::new(BackendChoice::Auto)
        .expect("no GPU adapter: install Mesa's Vulkan driver (apt-get install mesa-vulkan-drivers)")
}

pub struct Run {
    pub renderer: Renderer,
    pub surface: SurfaceBuffer,
}

/// Renders `spec` on `lights` (the others unshadowed) and reads the surface back.
pub fn render(gpu: &Gpu, scene: &Scene, view: &View, size: u32, spec: &str, lights: &[LightId]) -> Run {
    let spec = TechniqueSpec::parse(spec, &[]).unwrap();
    let none = TechniqueSpec::parse("none", &[]).unwrap();
    let mut renderer = Renderer::new(gpu, scene.clone(), view, size, size);
    for i in 0..scene.lights.len() as u32 {
        let id = LightId(i);
        renderer.set_technique(id, if lights.contains(&id) { &spec } else { &none }).unwrap();
    }
    renderer.render().unwrap();
    let surface = renderer.read_surface().unwrap();
    Run { renderer, surface }
}

impl Run {
    pub fn visibility(&self, light: LightId) -> Vec<f32> {
        self.renderer.read_visibility(light).unwrap().unwrap()
    }

    /// The technique statistic `key` of the light named `light` (`TechniqueStats::extra`).
    pub fn stat(&self, light: &str, key: &str) -> f64 {
        let stats = self.renderer.shadows.stats();
        let full = format!("{light}: {key}");
        stats.extra.iter().find(|(k, _)| *k == full).map(|(_, v)| *v).unwrap_or_else(|| panic!("no stat {full}"))
    }
}

/// The reference on `surface` for one light.
pub fn reference(scene: &Scene, surface: &SurfaceBuffer, light: LightId, samples: u32) -> Vec<f32> {
    let bvh = SceneBvh::build(scene, Selection::Casters);
    light_visibility(
        &bvh,
        surface,
        &scene.lights[light.index()],
        light.0,
        &ReferenceSettings { samples, seed: 1 },
        None,
    )
    .values
}
