//! `hard` and `pcf` against the ray-traced truth, and the two classic failures of shadow maps made
//! visible: acne and peter-panning.

mod common;

use glam::{Affine3A, Vec3};
use shadowlab_core::lightspace::light_frusta;
use shadowlab_core::{Instance, Light, LightId, LightKind, Material, Scene, View, load_scene, primitives};
use shadowlab_reference::visibility::near_hard_boundary;
use shadowlab_reference::{SceneBvh, Selection};

use common::{gpu, reference, render};

/// Wrong pixels (|Δ| > 0.1) among the relevant ones, leaving out pixels within one shadow-map
/// texel of a shadow boundary (see `near_hard_boundary`: the reference traced at ±1 texel
/// perpendicular to the light ray disagrees there), which a map of that resolution cannot decide.
fn wrong_frac_away_from_edges(scene: &Scene, run: &common::Run, light: LightId, map_size: u32) -> (f64, usize) {
    let v = run.visibility(light);
    let r = reference(scene, &run.surface, light, 1);
    let l = &scene.lights[light.index()];
    let frusta = light_frusta(l, &scene.bounds(), map_size);
    let bvh = SceneBvh::build(scene, Selection::Casters);
    let edge = near_hard_boundary(&bvh, &run.surface, l, &|p| frusta.view_for(p).texel_size_at(p));
    let (mut n, mut wrong) = (0usize, 0usize);
    for i in 0..v.len() {
        if r[i].is_nan() || edge[i] {
            continue;
        }
        n += 1;
        wrong += ((v[i] - r[i]).abs() > 0.1) as usize;
    }
    let relevant = r.iter().filter(|x| !x.is_nan()).count();
    let edges = edge.iter().filter(|&&e| e).count();
    println!("  relevant {relevant}, near an edge {edges}");
    (wrong as f64 / n.max(1) as f64, n)
}

#[test]
fn hard_matches_the_reference_for_point_spot_and_directional_lights() {
    let gpu = gpu();
    let mut scene = load_scene("room").unwrap().scene;
    scene.scale_emitters(0.0);
    // Each light from views where it lights much of the image.
    let cases = [
        ("default", "ceiling lamp"),
        ("window", "ceiling lamp"),
        ("sofa", "reading lamp"),
        ("default", "sun"),
        ("window", "sun"),
    ];
    for (view, name) in cases {
        let v = scene.view(view).unwrap().clone();
        {
            let light = scene.find_light(name).unwrap();
            let run = render(&gpu, &scene, &v, 160, "hard", &[light]);
            let (wrong, n) = wrong_frac_away_from_edges(&scene, &run, light, 2048);
            println!("room/{view} {name}: wrong_frac {:.4}% of {n} pixels", 100.0 * wrong);
            // The bound: below 1% (measured at most 0.09%, the reading lamp on the sofa).
            assert!(n > 1000, "{view}/{name}: too few relevant pixels ({n})");
            assert!(wrong < 0.01, "{view}/{name}: wrong_frac {wrong}");
        }
    }
}

fn plane_scene(light: Light) -> Scene {
    let mut s = Scene::new("plane");
    let m = s.add_material(Material::default());
    let plane = s.add_mesh(primitives::plane(40.0, 40.0, 1, 1));
    s.add_instance(Instance::new("ground", plane, m, Affine3A::IDENTITY));
    s.add_light(light);
    s.views.push(View::new("v", Vec3::new(0.0, 6.0, 8.0), Vec3::new(0.0, 0.0, -2.0), 0.1, 100.0));
    s
}

/// Fraction of relevant pixels with V > 0.5 (there is nothing to cast a shadow: all should be lit).
fn lit_fraction(spec: &str, light: Light) -> f64 {
    let gpu = gpu();
    let scene = plane_scene(light);
    let run = render(&gpu, &scene, &scene.views[0], 128, spec, &[LightId(0)]);
    let v = run.visibility(LightId(0));
    let relevance = run.surface.relevance(&scene.lights[0]);
    let (mut n, mut lit) = (0, 0);
    for (x, r) in v.iter().zip(&relevance) {
        if *r {
            n += 1;
            lit += (*x > 0.5) as usize;
        }
    }
    assert!(n > 5000, "{n} relevant pixels");
    lit as f64 / n as f64
}

#[test]
fn no_acne_on_a_plane_lit_at_80_degrees() {
    // 80° from the normal: elevation 10°.
    let e = 10f32.to_radians();
    let sun = Light::new(
        "sun",
        LightKind::Directional { direction: Vec3::new(e.cos(), -e.sin(), 0.0), angular_radius: 0.0 },
        Vec3::ONE,
        1.0,
    );
    // A spot whose axis meets the plane at 80° from the normal where it lands.
    let spot = Light::new(
        "spot",
        LightKind::Spot {
            position: Vec3::new(-17.0, 3.0, 0.0),
            direction: Vec3::new(e.cos(), -e.sin(), 0.0),
            inner_angle: 0.2,
            outer_angle: 0.35,
            radius: 0.0,
        },
        Vec3::ONE,
        100.0,
    );
    for (name, light) in [("sun", sun), ("spot", spot)] {
        let with_defaults = lit_fraction("hard", light.clone());
        let unbiased = lit_fraction("hard:slope_bias=0,normal_offset=0,map_size=1024", light);
        println!("{name}: lit {:.4}% with default bias, {:.4}% without", 100.0 * with_defaults, 100.0 * unbiased);
        // The bound: fully lit on at least 99.9% of relevant pixels (measured 100%).
        assert!(with_defaults >= 0.999, "{name}: acne with the defaults: {with_defaults}");
        // And the failure is visible without bias: measured 50% lit; require under 99%.
        assert!(unbiased < 0.99, "{name}: no acne even without bias ({unbiased}): the test could not fail");
    }
}

/// A 1 m box standing on a plane, the sun from +x at 45°: its shadow must touch the box.
fn contact_gap(spec: &str, map_size: u32) -> (f32, f32) {
    let gpu = gpu();
    let mut s = Scene::new("box");
    let m = s.add_material(Material::default());
    let plane = s.add_mesh(primitives::plane(10.0, 10.0, 1, 1));
    let cube = s.add_mesh(primitives::cuboid(Vec3::ONE));
    s.add_instance(Instance::new("ground", plane, m, Affine3A::IDENTITY));
    s.add_instance(Instance::new("box", cube, m, Affine3A::from_translation(Vec3::new(0.0, 0.5, 0.0))));
    let d = Vec3::new(-1.0, -1.0, 0.0).normalize();
    s.add_light(Light::new("sun", LightKind::Directional { direction: d, angular_radius: 0.0 }, Vec3::ONE, 1.0));
    let view = View::new("contact", Vec3::new(-1.3, 0.9, 0.5), Vec3::new(-0.6, 0.0, 0.0), 0.05, 20.0);
    let run = render(&gpu, &s, &view, 256, spec, &[LightId(0)]);
    let v = run.visibility(LightId(0));
    let r = reference(&s, &run.surface, LightId(0), 1);
    // Floor points on the shadow side, along the middle of the face (away from its side edges):
    // the widest lit strip inside the true shadow, measured from the box's face at x = −0.5.
    let mut gap = 0.0f32;
    let mut shadow_seen = 0;
    for i in 0..v.len() {
        let p = run.surface.positions[i];
        if !run.surface.covered[i] || r[i].is_nan() || p.y.abs() > 1e-3 || p.z.abs() > 0.3 || p.x > -0.5 || p.x < -1.2 {
            continue;
        }
        if r[i] == 0.0 {
            shadow_seen += 1;
            if v[i] > 0.5 {
                gap = gap.max(-0.5 - p.x);
            }
        }
    }
    let covered = run.surface.covered.iter().filter(|&&c| c).count();
    assert!(shadow_seen > 1000, "the view shows the shadow: {shadow_seen} of {covered} covered");
    let texel = light_frusta(&s.lights[0], &s.bounds(), map_size).views[0].texel_scale;
    (gap, texel)
}

#[test]
fn no_peter_panning_at_a_contact_line() {
    let (gap, texel) = contact_gap("hard:map_size=512", 512);
    println!("lit gap at the contact line: {gap:.4} m, one texel = {texel:.4} m");
    // The bound: at most one shadow-map texel (measured 0.016 m with 0.020 m texels).
    assert!(gap <= texel, "gap {gap} > texel {texel}");
    // A large constant bias detaches the shadow, and the test sees it.
    let (bad, _) = contact_gap("hard:map_size=512,constant_bias=0.15", 512);
    assert!(bad > 2.0 * texel, "peter-panning not detected: {bad}");
}

#[test]
fn pcf_is_monotone_across_an_edge_and_puts_it_where_the_reference_does() {
    let gpu = gpu();
    let mut scene = load_scene("penumbra").unwrap().scene;
    scene.scale_emitters(0.0);
    let view = scene.view("top").unwrap().clone();
    let (size, map, radius) = (256u32, 256u32, 2.0f32);
    let run = render(
        &gpu,
        &scene,
        &view,
        size,
        &format!("pcf:kernel=box,taps=9,radius={radius},map_size={map}"),
        &[LightId(0)],
    );
    let v = run.visibility(LightId(0));
    let row = (size / 2) as usize;
    // From the centre of the card's shadow towards +x: V must rise monotonically.
    // Ground pixels only (the card's lit top is seen from above, in the middle).
    let line: Vec<(f32, f32)> = (size as usize / 2..size as usize)
        .map(|x| row * size as usize + x)
        .filter(|&i| run.surface.covered[i] && run.surface.positions[i].y.abs() < 1e-3)
        .map(|i| (run.surface.positions[i].x, v[i]))
        .collect();
    for w in line.windows(2) {
        assert!(w[1].1 >= w[0].1 - 1e-4, "not monotone: {:?} then {:?}", w[0], w[1]);
    }
    let cross = line.iter().find(|(_, v)| *v >= 0.5).expect("the edge is in view").0;
    // The hard edge: the light at 3 m, the card's edge x = 0.5 at 1 m → 0.75 on the ground.
    let edge = 0.75;
    let frusta = light_frusta(&scene.lights[0], &scene.bounds(), map);
    let texel = frusta.views[0].texel_size_at(Vec3::new(edge, 0.0, 0.0));
    let pixel = line[1].0 - line[0].0;
    println!("pcf 50% crossing at x = {cross:.4} (edge {edge}, texel {texel:.4}, pixel {pixel:.4})");
    // Within the kernel radius (plus the bilinear tap's texel and one pixel of sampling): measured
    // 0.014 from the edge against a bound of 0.116.
    assert!((cross - edge).abs() <= (radius + 1.0) * texel + pixel, "{cross} vs {edge}");
}
