//! `cascaded` on the long-view terrain: focusing, warping and partitioning lower the error against the
//! ray-traced truth, the sampling overlay shows perspective aliasing where it should, stabilisation
//! lowers flicker, and the automatic near plane arrives one frame late.

mod common;

use shadowlab_core::{LightId, Scene, load_scene};
use shadowlab_reference::metrics::ErrorStats;
use shadowlab_reference::temporal::FlickerStats;

use common::{gpu, reference, render};

const SIZE: u32 = 160;

fn wrong_frac(scene: &Scene, view: &str, spec: &str) -> f64 {
    let gpu = gpu();
    let v = scene.view(view).unwrap().clone();
    let run = render(&gpu, scene, &v, SIZE, spec, &[LightId(0)]);
    let r = reference(scene, &run.surface, LightId(0), 1);
    ErrorStats::compare(&run.visibility(LightId(0)), &r).wrong_frac()
}

#[test]
fn focusing_warping_and_splitting_lower_the_error() {
    let scene = load_scene("terrain").unwrap().scene;
    // Equal texel budgets: one 2048² map, or four 1024² splits.
    let steps = [
        "hard",
        "cascaded",
        "cascaded:warp=lispsm",
        "cascaded:splits=4,map_size=1024",
        "cascaded:splits=4,map_size=1024,warp=lispsm,scheme=log",
    ];
    for view in ["ground", "duel"] {
        let w: Vec<f64> = steps.iter().map(|s| wrong_frac(&scene, view, s)).collect();
        println!(
            "terrain/{view}: {}",
            steps.iter().zip(&w).map(|(s, x)| format!("{s} {:.3}%", 100.0 * x)).collect::<Vec<_>>().join(", ")
        );
        // Focusing beats the unfocused map, LiSPSM beats focusing, and the full combination beats
        // the plain map by far (measured at 160²: ground 0.72 → 0.57 → 0.22 → 0.18 → 0.13%, duel
        // 11.4 → 8.4 → 0.36 → 2.5 → 0.51%; see the README for why PSSM alone loses in the duel view).
        assert!(w[1] < w[0], "{view}: focusing {} vs hard {}", w[1], w[0]);
        assert!(w[2] < w[1], "{view}: LiSPSM {} vs focused {}", w[2], w[1]);
        assert!(w[4] < 0.5 * w[0], "{view}: PSSM(4)+LiSPSM {} vs hard {}", w[4], w[0]);
    }
}

#[test]
fn uniform_sampling_is_red_near_the_viewer_and_blue_far_away() {
    use shadowlab_core::cascades::sampling_colour;
    let gpu = gpu();
    let scene = load_scene("terrain").unwrap().scene;
    let view = scene.view("ground").unwrap().clone();
    let run = render(&gpu, &scene, &view, 128, "hard", &[LightId(0)]);
    let o = run.renderer.map_overlay(LightId(0), 4).unwrap().unwrap();
    let median_of_rows = |rows: std::ops::Range<u32>| {
        let mut v: Vec<f32> = rows
            .flat_map(|y| (0..128).map(move |x| (y * 128 + x) as usize))
            .filter(|&i| o.map[i] >= 0 && o.on_map[i])
            .map(|i| o.texels_per_pixel[i])
            .collect();
        v.sort_by(f32::total_cmp);
        v[v.len() / 2]
    };
    // The ground near the viewer (bottom rows) and far away (just under the horizon).
    let first_ground_row =
        (0..128).find(|&y| (0..128).filter(|&x| o.map[(y * 128 + x) as usize] >= 0).count() > 100).unwrap();
    let (near, far) = (median_of_rows(118..128), median_of_rows(first_ground_row..first_ground_row + 6));
    let (cn, cf) = (sampling_colour(near), sampling_colour(far));
    println!("texels per pixel: near {near:.3} {cn}, far {far:.3} {cf}");
    // Measured near 0.011 (dark red: < 1/7.75) and far 12.9 (dark blue: > 10).
    assert!(near < 1.0 / 3.25 && cn.x > cn.z, "near the viewer: {near}");
    assert!(far > 3.25 && cf.z > cf.x, "far away: {far}");
}

/// Flicker along the terrain's slow walk at 128², every technique against the same references.
fn walk_flicker(specs: &[&str]) -> Vec<FlickerStats> {
    common::path_flicker("terrain", "walk", 128, 128, specs)
}

#[test]
fn stabilised_cascades_flicker_less() {
    let s = walk_flicker(&[
        "cascaded:splits=4,map_size=1024,quantize=false",
        "cascaded:splits=4,map_size=1024",
        "cascaded:splits=4,map_size=1024,stabilize=true",
    ]);
    println!(
        "flicker: free focus {:.4}%, quantised {:.4}%, stabilised {:.4}%",
        100.0 * s[0].fraction(),
        100.0 * s[1].fraction(),
        100.0 * s[2].fraction()
    );
    assert!(s.iter().all(|f| f.pixels > 100_000));
    // Measured at 128² with the default scheme=auto: free 0.073%, quantised (the default) 0.065%,
    // stabilised 0.072% (with the practical scheme, before auto: 0.097%, 0.077%, 0.085%).
    assert!(s[1].fraction() < s[0].fraction(), "quantised {:?} vs free {:?}", s[1], s[0]);
    assert!(s[2].fraction() < s[0].fraction(), "stabilised {:?} vs free {:?}", s[2], s[0]);
}

#[test]
fn automatic_near_plane_arrives_one_frame_late() {
    let gpu = gpu();
    let scene = load_scene("terrain").unwrap().scene;
    let view = scene.view("ground").unwrap().clone();
    let mut run = render(&gpu, &scene, &view, 96, "cascaded:auto_near=true", &[LightId(0)]);
    run.renderer.render().unwrap();
    let stats = run.renderer.shadows.stats();
    let get = |k: &str| stats.extra.iter().find(|(n, _)| n.ends_with(k)).map(|(_, v)| *v);
    assert_eq!(get("auto_near_latency_frames"), Some(1.0));
    // The view's near plane is 0.5 m; the nearest visible ground is metres away.
    let near = get(": near").unwrap();
    assert!(near > 1.0, "near {near}");
    assert!(get(": far").unwrap() < 1000.0);
}

/// Issue 19 item 2: four `scheme=auto` splits (SDSM: log splits over the visible depths of a
/// frame before, each fitted to its samples' light-space box) on the terrain's ground view, at the
/// texel budget of one 2048² map: the first frame falls back to the practical scheme, the second is
/// fitted, and it is no worse than one focused map (the default `cascaded`) or four practical splits.
#[test]
fn auto_splits_fit_the_visible_depths() {
    let gpu = gpu();
    let scene = load_scene("terrain").unwrap().scene;
    let view = scene.view("ground").unwrap().clone();
    let mut run = render(&gpu, &scene, &view, SIZE, "cascaded:splits=4,map_size=1024,scheme=auto", &[LightId(0)]);
    assert_eq!(run.stat("sun", "auto_fitted"), 0.0, "nothing measured before the first frame");
    run.renderer.render().unwrap();
    assert_eq!(run.stat("sun", "auto_fitted"), 1.0, "the first frame's samples read back by the second");
    assert_eq!(run.stat("sun", "auto_near_latency_frames"), 1.0);
    let truth = reference(&scene, &run.surface, LightId(0), 1);
    let auto = ErrorStats::compare(&run.visibility(LightId(0)), &truth).wrong_frac();
    let one = wrong_frac(&scene, "ground", "cascaded");
    let practical = wrong_frac(&scene, "ground", "cascaded:splits=4,map_size=1024");
    println!(
        "terrain/ground: auto(4) {:.3}%, cascaded {:.3}%, practical(4) {:.3}%",
        100.0 * auto,
        100.0 * one,
        100.0 * practical
    );
    // The bound: no worse than today's default `cascaded`, nothing added. Measured at 160²
    // (llvmpipe): auto(4) 0.108%, one focused map 0.624%, four practical splits 0.173%.
    assert!(auto <= one, "auto {auto} vs cascaded {one}");
    assert!(auto <= practical, "auto {auto} vs practical {practical}");
}

#[test]
fn bad_cascade_configurations_are_refused() {
    let gpu = gpu();
    let scene = load_scene("terrain").unwrap().scene;
    let spec = shadowlab::TechniqueSpec::parse("cascaded:warp=lispsm,stabilize=true", &[]).unwrap();
    let mut r = shadowlab::Renderer::new(&gpu, scene.clone(), &scene.views[0], 16, 16);
    let e = r.set_technique(LightId(0), &spec).unwrap_err().to_string();
    assert!(e.contains("stabilize cannot apply to warped maps"), "{e}");
    let room = load_scene("room").unwrap().scene;
    let lamp = room.find_light("ceiling lamp").unwrap();
    let mut r = shadowlab::Renderer::new(&gpu, room.clone(), &room.views[0], 16, 16);
    let e = r.set_technique(lamp, &shadowlab::TechniqueSpec::parse("cascaded", &[]).unwrap()).unwrap_err().to_string();
    assert!(e.contains("does not support point light"), "{e}");
}

/// The visible depths change only with the surface: once a measurement of the current view is
/// read back, still frames record no depth reduction (a still frame stays the G-buffer and the
/// lighting), and a camera move measures again. The maps stay fitted throughout.
#[test]
fn still_frames_measure_the_visible_depths_once() {
    let gpu = gpu();
    let scene = load_scene("terrain").unwrap().scene;
    let view = scene.view("ground").unwrap().clone();
    let mut run = render(&gpu, &scene, &view, 64, "cascaded:splits=2,map_size=512", &[LightId(0)]);
    run.renderer.render().unwrap();
    let measured = run.stat("sun", "depth_passes");
    assert!(measured >= 1.0, "the first frames measure: {measured}");
    for _ in 0..4 {
        let work = run.renderer.render().unwrap().work;
        assert_eq!((work.map_views, work.resolves), (0, 0), "a still frame re-does nothing: {work:?}");
    }
    assert_eq!(run.stat("sun", "depth_passes"), measured, "still frames measure nothing");
    assert_eq!(run.stat("sun", "auto_fitted"), 1.0);
    let mut moved = view.clone();
    moved.position += glam::Vec3::new(2.0, 0.0, 1.0);
    run.renderer.set_view(&moved);
    run.renderer.render().unwrap();
    assert_eq!(run.stat("sun", "depth_passes"), measured + 1.0, "a camera move measures again");
}
