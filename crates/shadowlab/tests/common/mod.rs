//! Helpers for GPU tests: render a technique, trace the reference on the same surface.

#![allow(dead_code)]

use shadowlab::{BackendChoice, Gpu, Renderer, TechniqueSpec};
use shadowlab_core::{LightId, Scene, SurfaceBuffer, View, load_scene};
use shadowlab_reference::temporal::{FlickerStats, FrameSample, flicker};
use shadowlab_reference::{ReferenceSettings, SceneBvh, Selection, light_visibility};

/// The test GPU: whatever wgpu finds (on CI machines Mesa's lavapipe, Vulkan on the CPU).
pub fn gpu() -> Gpu {
    Gpu::new(BackendChoice::Auto)
        .expect("no GPU adapter: install Mesa's Vulkan driver (apt-get install mesa-vulkan-drivers)")
}

/// A scene file of the repository's `scenes/` folder (`bunny-plane.toml`).
pub fn scene_file(name: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes").join(name);
    load_scene(path.to_str().expect("a UTF-8 path")).unwrap_or_else(|e| panic!("scenes/{name}: {e}")).scene
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

/// The width of the shadow boundary on the ground along +x (|z| < 0.1 m), from V's profile:
/// 4 ∫ min(V, 1 − V) dx, which is the width of a linear ramp and robust to noise.
pub fn boundary_width(run: &Run, v: &[f32]) -> f32 {
    // 2.4 cm bins: over a pixel (1.6 cm on the ground in the 256² top view).
    let bins = 40;
    // From the top view the occluder hides the ground inside x = 0.625.
    let (x0, x1) = (0.63f32, 1.6f32);
    let mut sum = vec![0.0f32; bins];
    let mut count = vec![0u32; bins];
    for (i, &x) in v.iter().enumerate() {
        let p = run.surface.positions[i];
        if x.is_nan() || !run.surface.covered[i] || p.y > 0.01 || p.z.abs() > 0.1 || p.x < x0 || p.x >= x1 {
            continue;
        }
        let b = (((p.x - x0) / (x1 - x0)) * bins as f32) as usize;
        sum[b] += x;
        count[b] += 1;
    }
    let dx = (x1 - x0) / bins as f32;
    let mut width = 0.0;
    for b in 0..bins {
        assert!(count[b] > 0, "bin {b} empty: the image is too small for the profile");
        let m = sum[b] / count[b] as f32;
        width += 4.0 * m.min(1.0 - m) * dx;
    }
    width
}

/// Flicker of light 0 along the camera path `path` of `scene` at `width` × `height`: each
/// technique against the same per-frame references (the truth on each frame's surface).
pub fn path_flicker(scene: &str, path: &str, width: u32, height: u32, specs: &[&str]) -> Vec<FlickerStats> {
    let gpu = gpu();
    let scene = load_scene(scene).unwrap().scene;
    let views = scene.path(path).unwrap().views();
    let renderer = |spec: &str| {
        let mut r = Renderer::new(&gpu, scene.clone(), &views[0], width, height);
        let none = TechniqueSpec::parse("none", &[]).unwrap();
        for i in 1..scene.lights.len() as u32 {
            r.set_technique(LightId(i), &none).unwrap();
        }
        r.set_technique(LightId(0), &TechniqueSpec::parse(spec, &[]).unwrap()).unwrap();
        r
    };
    let mut base = renderer("none");
    let mut frames = Vec::new();
    for v in &views {
        base.set_view(v);
        base.render().unwrap();
        let surface = base.read_surface().unwrap();
        let r = reference(&scene, &surface, LightId(0), 1);
        frames.push((surface, r));
    }
    specs
        .iter()
        .map(|spec| {
            let mut r = renderer(spec);
            let mut stats = FlickerStats::default();
            let mut prev: Option<Vec<f32>> = None;
            for (t, v) in views.iter().enumerate() {
                r.set_view(v);
                r.render().unwrap();
                let value = r.read_visibility(LightId(0)).unwrap().unwrap();
                if let Some(p) = &prev {
                    let a = FrameSample {
                        view: &views[t - 1],
                        surface: &frames[t - 1].0,
                        value: p,
                        reference: &frames[t - 1].1,
                    };
                    let b = FrameSample { view: v, surface: &frames[t].0, value: &value, reference: &frames[t].1 };
                    stats.add(&flicker(&a, &b));
                }
                prev = Some(value);
            }
            stats
        })
        .collect()
}
