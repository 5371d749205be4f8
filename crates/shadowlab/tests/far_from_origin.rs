//! Issue 17 item 2: shadows do not depend on where the scene lies. Every technique renders `room`
//! and its copy 100 km away ((1e5, 0, 1e5) m, each coordinate rounded to `f32` as a file would place
//! it); both are recentred into their local frames (`Scene::recentre`), and each one's error
//! against its own truth must agree. (In world coordinates at 1e5 m a float's step is 8 mm: `hard`
//! lost whole shadows and spot and sun maps got acne, 0.29% → 3.6% wrong.)

mod common;

use glam::Vec3;
use shadowlab::registry;
use shadowlab_core::{LightId, Scene, load_scene};

use common::{gpu, reference, render};

/// The scene moved by `t` the way a file would place it: every coordinate rounded to `f32`.
fn translated(scene: &Scene, t: Vec3) -> Scene {
    let mut s = scene.clone();
    s.translate(t);
    s
}

/// Pooled wrong fraction (|Δ| > 0.1) of `spec` over the lights it supports.
fn wrong_frac(gpu: &shadowlab::Gpu, scene: &Scene, spec: &str) -> Option<f64> {
    let info = shadowlab::registry::find(spec).unwrap();
    let lights: Vec<LightId> =
        (0..scene.lights.len() as u32).map(LightId).filter(|l| info.supports(&scene.lights[l.index()])).collect();
    if lights.is_empty() {
        return None;
    }
    let run = render(gpu, scene, scene.view("default").unwrap(), 96, spec, &lights);
    let (mut n, mut wrong) = (0usize, 0usize);
    for &l in &lights {
        let v = run.visibility(l);
        let r = reference(scene, &run.surface, l, 64);
        for (a, b) in v.iter().zip(&r) {
            if !b.is_nan() {
                n += 1;
                wrong += ((a - b).abs() > 0.1) as usize;
            }
        }
    }
    Some(wrong as f64 / n.max(1) as f64)
}

#[test]
fn every_technique_is_as_right_far_from_the_origin_as_near_it() {
    let gpu = gpu();
    let near = load_scene("room").unwrap().scene;
    let mut far = translated(&near, Vec3::new(1.0e5, 0.0, 1.0e5));
    far.recentre();
    for info in registry().iter().filter(|t| t.id != "none") {
        let (Some(a), Some(b)) = (wrong_frac(&gpu, &near, info.id), wrong_frac(&gpu, &far, info.id)) else {
            continue;
        };
        println!("{:<10} wrong_frac near {:.4}%  far {:.4}%", info.id, 100.0 * a, 100.0 * b);
        // Measured differences up to 0.17 percentage points (`sampled`; the others ≤ 0.06): objects,
        // camera and lights shift by up to 4 mm against each other when rounded at 1e5 m, which
        // moves edge pixels. The failure this guards against was 3.3 points and more (issue 17).
        // Bound: 0.4 points.
        assert!((a - b).abs() < 0.004, "{}: near {a}, far {b}", info.id);
    }
}
