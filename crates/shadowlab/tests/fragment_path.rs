//! The fragment path (devices without compute shaders or storage buffers: WebGL2), run on this
//! machine's adapter opened with WebGL2's limits (`Gpu::new_without_compute`): `none`, `hard`,
//! `pcf`, `pcss` and `cascaded` resolve in render passes (`technique::dispatch_program_in`, the same WGSL as
//! their compute resolves through `shaders/per_pixel.wgsl`) and give the same visibility; the
//! techniques without that path are refused in words, not with a device error.

mod common;

use shadowlab::{BackendChoice, Gpu, Renderer, TechniqueSpec};
use shadowlab_core::{LightId, load_scene};

#[test]
fn fragment_resolves_match_compute_resolves() {
    let compute = common::gpu();
    let fragment = Gpu::new_without_compute(BackendChoice::Auto).expect("an adapter");
    assert!(shadowlab::gpu::runs_compute(&compute.device));
    assert!(!shadowlab::gpu::runs_compute(&fragment.device), "opened with WebGL2's limits: no compute");
    for (scene_name, view_name) in [("penumbra", "default"), ("room", "default")] {
        let scene = load_scene(scene_name).unwrap().scene;
        let view = scene.view(view_name).unwrap().clone();
        for spec in ["none", "hard", "pcf", "pcss", "cascaded:scheme=practical,splits=3"] {
            let a = visibility(&compute, &scene, &view, spec);
            let b = visibility(&fragment, &scene, &view, spec);
            assert!(fragment.take_error().is_none(), "{scene_name} {spec}: a device error on the fragment path");
            let (mut differ, mut max, mut shadowed) = (0usize, 0f32, 0usize);
            for (va, vb) in a.iter().zip(&b) {
                for (x, y) in va.iter().zip(vb) {
                    let d = (x - y).abs();
                    if d.is_nan() {
                        continue;
                    }
                    max = max.max(d);
                    differ += usize::from(d > 1e-3);
                    shadowed += usize::from(*y < 0.5);
                }
            }
            println!("{scene_name} {spec}: {differ} pixels differ by more than 1e-3 (max {max}), {shadowed} shadowed");
            // Measured 0 pixels differing (max |Δ| 0) for every case on lavapipe: the same WGSL on the
            // same adapter, so bound: none differ (a fragment path shifted by one pixel fails here).
            assert_eq!(differ, 0, "{scene_name} {spec}: the fragment path differs (max {max})");
            if spec != "none" && a.iter().any(|v| !v.is_empty()) {
                // Shadows are there (a path that wrote 1 everywhere would match `none`): measured 422
                // to 424 shadowed pixels on `penumbra`, 3 878 to 8 441 in the room; bound 100.
                assert!(shadowed > 100, "{scene_name} {spec}: {shadowed} shadowed pixels");
            }
        }
    }
}

/// Every light's visibility with `spec` on all lights, 96 × 96 (read back by copies: the
/// surface export of `common::render` is a compute pass).
fn visibility(gpu: &Gpu, scene: &shadowlab_core::Scene, view: &shadowlab_core::View, spec: &str) -> Vec<Vec<f32>> {
    let mut renderer = Renderer::new(gpu, scene.clone(), view, 96, 96);
    let spec = TechniqueSpec::parse(spec, &[]).unwrap();
    let lights: Vec<LightId> = (0..scene.lights.len()).map(|i| LightId(i as u32)).collect();
    for &l in &lights {
        // (A light the technique does not take stays unshadowed on both devices.)
        if spec.info.supports(&scene.lights[l.index()]) {
            renderer.set_technique(l, &spec).unwrap();
        }
    }
    renderer.render().unwrap();
    // (An unshadowed light has no layer: an empty list.)
    lights.iter().map(|&l| renderer.read_visibility(l).unwrap().unwrap_or_default()).collect()
}

#[test]
fn techniques_without_a_fragment_path_are_refused_in_words() {
    let gpu = Gpu::new_without_compute(BackendChoice::Auto).expect("an adapter");
    // Terrain's light is a sun, which every technique takes (the refusal is then the device's).
    let scene = load_scene("terrain:grid=40").unwrap().scene;
    let view = scene.views[0].clone();
    let mut renderer = Renderer::new(&gpu, scene, &view, 32, 32);
    let needs_compute =
        ["volumes", "sampled", "smoothies", "ssm", "lightmaps", "cssm", "blurred", "cascaded:auto_near=true"];
    for spec in needs_compute {
        let err = renderer.set_technique(LightId(0), &TechniqueSpec::parse(spec, &[]).unwrap()).unwrap_err();
        assert!(err.to_string().contains("compute"), "{spec}: {err}");
    }
    renderer.set_technique(LightId(0), &TechniqueSpec::parse("hard", &[]).unwrap()).unwrap();
    renderer.render().unwrap();
    assert!(gpu.take_error().is_none());
}

/// The caches on the fragment path: after each kind of edit (a static object moved, made dynamic
/// and moved, dragged, released; a light moved; a colour changed) the live engine on a device
/// without compute equals a fresh engine on the same state, pixel for pixel, for the map
/// techniques that run there. A dragged object casts nothing there (no compute for its pass), in
/// the live engine and the fresh one alike.
#[test]
fn the_fragment_path_stays_equal_to_a_fresh_engine_after_edits() {
    use glam::{Vec3, Vec3A};
    use shadowlab::live::{Edit, LightChange};
    use shadowlab_core::Mobility;
    let gpu = Gpu::new_without_compute(BackendChoice::Auto).expect("an adapter");
    let scene = load_scene("room").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    for spec in ["hard", "pcf", "pcss", "cascaded:scheme=practical,splits=2"] {
        let mut renderer = Renderer::new(&gpu, scene.clone(), &view, 64, 64);
        let parsed = TechniqueSpec::parse(spec, &[]).unwrap();
        for (i, light) in scene.lights.iter().enumerate() {
            if parsed.info.supports(light) {
                renderer.set_technique(LightId(i as u32), &parsed).unwrap();
            }
        }
        let table = renderer.shadows.live().find_instance("table").expect("the room has a table");
        let lamp = renderer.shadows.live().find_light("ceiling lamp").expect("the room has a ceiling lamp");
        let check = |renderer: &mut Renderer, what: &str| {
            renderer.render().unwrap();
            assert!(gpu.take_error().is_none(), "{spec}: {what}: a device error");
            let live = renderer.live_visibility().unwrap();
            let fresh = renderer.fresh_visibility().unwrap();
            assert_eq!(live.len(), fresh.len());
            for ((_, l), (_, f)) in live.iter().zip(&fresh) {
                let max = l.iter().zip(f).map(|(a, b)| (a - b).abs()).filter(|d| !d.is_nan()).fold(0.0, f32::max);
                // Hard and filtered maps are exact against a fresh engine (as on compute: tests/live.rs).
                assert_eq!(max, 0.0, "{spec}: {what}: live differs from fresh by {max}");
            }
        };
        let step = |renderer: &mut Renderer, by: Vec3, what: &str| {
            let mut t = renderer.shadows.live().instance(table).unwrap().transform;
            t.translation += Vec3A::from(by);
            renderer.apply(Edit::Transform { instance: table, transform: t }).unwrap();
            check(renderer, what);
        };
        check(&mut renderer, "first frame");
        step(&mut renderer, Vec3::new(0.2, 0.0, 0.0), "static table moved");
        renderer.apply(Edit::Mobility { instance: table, mobility: Mobility::Dynamic }).unwrap();
        step(&mut renderer, Vec3::new(0.0, 0.0, 0.2), "dynamic table moved");
        renderer.apply(Edit::Mobility { instance: table, mobility: Mobility::Temporary }).unwrap();
        step(&mut renderer, Vec3::new(-0.2, 0.0, 0.0), "table dragged");
        renderer.apply(Edit::Mobility { instance: table, mobility: Mobility::Static }).unwrap();
        check(&mut renderer, "table released");
        let position = match renderer.shadows.live().light(lamp).unwrap().kind {
            shadowlab_core::LightKind::Point { position, .. } => position,
            _ => panic!("the ceiling lamp is a point light"),
        };
        renderer
            .apply(Edit::Light { light: lamp, change: LightChange::Position(position + Vec3::new(0.3, 0.0, 0.0)) })
            .unwrap();
        check(&mut renderer, "lamp moved");
        renderer.apply(Edit::Light { light: lamp, change: LightChange::Color(Vec3::new(1.0, 0.5, 0.5)) }).unwrap();
        check(&mut renderer, "lamp recoloured");
    }
}
