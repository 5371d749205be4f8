//! Acne: lit pixels that a technique darkens. On a real model under a grazing light
//! (`scenes/dragon-grazing.toml`: the Stanford dragon, a sun 11° above the horizon), the pixels the
//! truth sees fully lit (V_ref = 1) and a technique puts below 0.98 (`lit_darkened_frac`).

mod common;

use shadowlab_core::{LightId, load_scene};
use shadowlab_reference::metrics::ErrorStats;

use common::{gpu, reference, render};

#[test]
fn filtered_maps_leave_lit_slopes_lit_under_a_grazing_light() {
    let gpu = gpu();
    let scene = common::scene_file("dragon-grazing.toml");
    let view = scene.view("default").unwrap().clone();
    let sun = LightId(0);
    // Measured at 96² against 64 reference samples, with each filter tap compared with the
    // receiver's plane there (and, in brackets, with the centre's depth, as before): hard 0, pcf
    // 0.0031 (0.0105), pcss 0.0014, cascaded 0, blurred 0.041 (0.70); since the crease bias and
    // the grazing fall-back pcf 0.0025, blurred 0.0258. Bounds: about twice the first figures.
    let cases = [("hard", 0.001), ("pcf", 0.006), ("pcss", 0.004), ("cascaded", 0.001), ("blurred", 0.08)];
    let mut truth = None;
    for (spec, bound) in cases {
        let run = render(&gpu, &scene, &view, 96, spec, &[sun]);
        let r = truth.get_or_insert_with(|| reference(&scene, &run.surface, sun, 64));
        let stats = ErrorStats::compare(&run.visibility(sun), r);
        let darkened = stats.lit_darkened_frac();
        println!("{spec}: {:.4} of lit pixels darkened, RMSE {:.4}", darkened, stats.rmse());
        assert!(darkened <= bound, "{spec}: {darkened} of lit pixels darkened (bound {bound})");
    }
}

/// Facets that the light grazes: on the Sibenik cathedral under its default sun, chamfer strips
/// under a ledge (their facets' N·L about 0.0094, 0.55° from edge-on) are thinner than a texel in
/// the map, so a filter's taps read the ledge over them. The filters give way to the point's own
/// texel there (`filter_weight`, footprint.wgsl), as `hard` reads it.
#[test]
fn filters_leave_facets_the_light_grazes_to_their_own_texel() {
    let gpu = gpu();
    let dir = std::env::var_os("SHADOWLAB_ASSETS")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/assets"));
    let path = dir.join("sibenik/sibenik.obj");
    assert!(path.is_file(), "{} not found (set SHADOWLAB_ASSETS)", path.display());
    let scene = load_scene(path.to_str().unwrap()).unwrap().scene;
    let view = scene.views[0].clone();
    let sun = LightId(0);
    let to_light = match scene.lights[0].kind {
        shadowlab_core::LightKind::Directional { direction, .. } => -direction,
        ref other => panic!("the OBJ's default light is a sun, not {other:?}"),
    };
    let mut truth = None;
    let mut hard = None;
    // Measured at 128² against 64 reference samples: lit pixels on facets within 1.1° of edge-on
    // (|N_g·L| < 0.02, the band where the filters are dropped) darkened below 0.98, of 28: hard 1,
    // pcf 1, pcss 1, cascaded 3 (before the fall-back: pcf 18, pcss 28, cascaded 3). Bounds: no
    // more than `hard` reading the same map; `cascaded` reads its own split maps, whose single
    // texels already miss 3 (the fall-back changed none of them), and may not miss more.
    for (spec, own) in [("hard", None), ("pcf", None), ("pcss", None), ("cascaded", Some(3))] {
        let run = render(&gpu, &scene, &view, 128, spec, &[sun]);
        let r = truth.get_or_insert_with(|| reference(&scene, &run.surface, sun, 64));
        let v = run.visibility(sun);
        let s = &run.surface;
        let grazed: Vec<usize> = (0..v.len())
            .filter(|&i| s.covered[i] && r[i] >= 1.0 && s.geometric_normals[i].dot(to_light).abs() < 0.02)
            .collect();
        let darkened = grazed.iter().filter(|&&i| v[i] < 0.98).count();
        println!("{spec}: {darkened} of {} lit pixels on grazed facets darkened", grazed.len());
        // The case must be present for the test to mean anything (measured: 28 such pixels).
        assert!(
            grazed.len() >= 10,
            "only {} lit pixels on grazed facets: the view no longer shows the chamfers",
            grazed.len()
        );
        let bound = own.unwrap_or(*hard.get_or_insert(darkened));
        assert!(
            darkened <= bound,
            "{spec}: {darkened} of {} lit pixels on grazed facets darkened (bound {bound})",
            grazed.len()
        );
    }
}
