//! `volumes` against the ray-traced truth: exact hard shadows for point, spot and directional
//! lights, with the camera inside volumes, with open and non-manifold casters, with the light in
//! the near plane; and the GPU extraction against the CPU reference of `shadowlab_core::volumes`.

mod common;

use glam::{Affine3A, Quat, Vec3};
use shadowlab_core::volumes::{LightSource, shadow_volume};
use shadowlab_core::{
    Instance, Light, LightId, LightKind, Material, Mesh, Scene, Topology, View, load_scene, primitives,
};
use shadowlab_reference::visibility::near_boundary_in_image;
use shadowlab_reference::{SceneBvh, Selection};

use common::{Run, gpu, reference, render};

const SIZE: u32 = 160;

/// Wrong pixels (|Δ| > 0.5) among the relevant ones, leaving out only the pixels whose centre lies
/// within half a pixel of the true shadow boundary (`near_boundary_in_image`: on a circle of radius
/// 0.5 pixel around the centre, the reference or the geometric facing of the mesh disagrees with
/// the centre).
fn wrong_frac(scene: &Scene, run: &Run, light: LightId, view: &View) -> (f64, usize) {
    let v = run.visibility(light);
    let r = reference(scene, &run.surface, light, 1);
    let casters = SceneBvh::build(scene, Selection::Casters);
    let all = SceneBvh::build(scene, Selection::All);
    let edge = near_boundary_in_image(&casters, &all, &run.surface, &scene.lights[light.index()], view);
    let (mut n, mut wrong, mut excepted) = (0usize, 0usize, 0usize);
    for i in 0..v.len() {
        if r[i].is_nan() {
            continue;
        }
        if edge[i] {
            excepted += 1;
            continue;
        }
        n += 1;
        wrong += ((v[i] - r[i]).abs() > 0.5) as usize;
    }
    println!("  {excepted} relevant pixels within half a pixel of a boundary excepted, {n} compared");
    (wrong as f64 / n.max(1) as f64, n)
}

fn all_lights(scene: &Scene) -> Vec<LightId> {
    (0..scene.lights.len() as u32).map(LightId).collect()
}

/// The extra statistic `key` of light `name` (`"lamp 1: zfail_fallbacks"`).
fn hard_scene(name: &str) -> Scene {
    let mut scene = load_scene(name).unwrap().scene;
    scene.scale_emitters(0.0);
    scene
}

/// The bound: at most 0.1% of relevant pixels differ, edge pixels excepted.
const EXACT: f64 = 0.001;

#[test]
fn volumes_match_the_reference_for_point_spot_and_directional_lights() {
    let gpu = gpu();
    // (scene, view, lights checked there): point, spot and directional lights.
    let cases: [(&str, &str, &[&str]); 5] = [
        ("room", "default", &["ceiling lamp", "accent", "sun"]),
        ("room", "sofa", &["reading lamp"]),
        ("room", "window", &["ceiling lamp", "sun"]),
        ("columns", "hall", &["lamp 0", "lamp 1"]),
        ("columns", "doorway", &["lamp 1", "lamp 2", "lamp 3"]),
    ];
    for (scene_name, view, lights) in cases {
        let scene = hard_scene(scene_name);
        let v = scene.view(view).unwrap().clone();
        for spec in ["volumes", "volumes:mode=zfail"] {
            let run = render(&gpu, &scene, &v, SIZE, spec, &all_lights(&scene));
            for name in lights {
                let light = scene.find_light(name).unwrap();
                let (wrong, n) = wrong_frac(&scene, &run, light, &v);
                println!("{scene_name}/{view} {name} {spec}: {:.4}% of {n} pixels wrong", 100.0 * wrong);
                assert!(n > 1000, "{scene_name}/{view}/{name}: too few relevant pixels ({n})");
                // Measured at most 0.0064% (one pixel, the sun through the window with z-fail).
                assert!(wrong <= EXACT, "{scene_name}/{view}/{name} {spec}: wrong_frac {wrong}");
            }
        }
    }
}

#[test]
fn camera_inside_volumes_breaks_zpass_but_not_auto_zfail_or_zp_plus() {
    let gpu = gpu();
    // Under the table (ceiling lamp), in a pillar's shadow (lamp 1), and in the sun's shadow
    // (the room's default view: the sun enters only through the window).
    let cases =
        [("room", "under_table", "ceiling lamp"), ("columns", "pillar_shadow", "lamp 1"), ("room", "default", "sun")];
    for (scene_name, view, name) in cases {
        let scene = hard_scene(scene_name);
        let v = scene.view(view).unwrap().clone();
        let light = scene.find_light(name).unwrap();
        let zpass = render(&gpu, &scene, &v, SIZE, "volumes:mode=zpass", &[light]);
        let (wrong, _) = wrong_frac(&scene, &zpass, light, &v);
        println!("{scene_name}/{view} {name} zpass: {:.2}% wrong", 100.0 * wrong);
        // Measured 40% (table), 7% (pillar), 60% (sun): the near plane cuts the volumes.
        assert!(wrong > 0.02, "{scene_name}/{view}: z-pass should fail here, wrong_frac {wrong}");
        for spec in ["volumes", "volumes:mode=zfail", "volumes:mode=zpplus"] {
            let run = render(&gpu, &scene, &v, SIZE, spec, &[light]);
            let (wrong, n) = wrong_frac(&scene, &run, light, &v);
            println!("{scene_name}/{view} {name} {spec}: {:.4}% of {n} wrong", 100.0 * wrong);
            assert!(wrong <= EXACT, "{scene_name}/{view} {spec}: wrong_frac {wrong}");
        }
        let auto = render(&gpu, &scene, &v, SIZE, "volumes", &[light]);
        assert_eq!(auto.stat(name, "method_zpplus"), 1.0, "auto starts the count with ZP+ inside a volume");
    }
}

#[test]
fn auto_takes_zpass_when_the_camera_is_provably_outside() {
    let gpu = gpu();
    let scene = hard_scene("penumbra");
    let v = scene.view("default").unwrap().clone();
    let run = render(&gpu, &scene, &v, SIZE, "volumes", &[LightId(0)]);
    let name = scene.lights[0].name.clone();
    assert_eq!(run.stat(&name, "method_zpass"), 1.0);
    let (wrong, n) = wrong_frac(&scene, &run, LightId(0), &v);
    assert!(n > 1000 && wrong <= EXACT, "penumbra: wrong_frac {wrong} of {n}");
}

#[test]
fn light_in_the_near_plane_falls_back_to_zfail() {
    let gpu = gpu();
    let mut scene = hard_scene("columns");
    let v = scene.view("pillar_shadow").unwrap().clone();
    let (right, _, forward) = v.basis();
    // Exactly in the near plane, 0.7 m to the right of the view axis: the ZP+ frustum is flat.
    let in_plane = v.position + forward * v.near + right * 0.7;
    let light = scene.find_light("lamp 1").unwrap();
    let LightKind::Point { position, .. } = &mut scene.lights[light.index()].kind else { panic!("a point light") };
    *position = in_plane;
    for spec in ["volumes:mode=zpplus", "volumes"] {
        let run = render(&gpu, &scene, &v, SIZE, spec, &[light]);
        assert_eq!(run.stat("lamp 1", "zfail_fallbacks"), 1.0, "{spec}: the flat ZP+ frustum is detected");
        assert_eq!(run.stat("lamp 1", "method_zfail"), 1.0);
        let (wrong, n) = wrong_frac(&scene, &run, light, &v);
        println!("light in the near plane, {spec}: {:.4}% of {n} wrong", 100.0 * wrong);
        assert!(n > 1000 && wrong <= EXACT, "{spec}: wrong_frac {wrong}");
    }
}

/// Open and non-manifold casters over a ground plane: a card (an open plane), a box with its top
/// missing, three faces on one edge, a mirrored box, a mesh with a degenerate triangle.
fn open_scene(light: Light) -> Scene {
    let mut s = Scene::new("open casters");
    let m = s.add_material(Material::default());
    let ground = s.add_mesh(primitives::cuboid_between(Vec3::new(-4.0, -0.1, -4.0), Vec3::new(4.0, 0.0, 4.0)));
    s.add_instance(Instance::new("ground", ground, m, Affine3A::IDENTITY));
    let card = s.add_mesh(primitives::plane(0.8, 0.6, 2, 2));
    s.add_instance(Instance::new(
        "card",
        card,
        m,
        Affine3A::from_rotation_translation(Quat::from_rotation_z(0.3), Vec3::new(-1.6, 1.0, -0.8)),
    ));
    let mut open_box = primitives::cuboid(Vec3::new(0.7, 0.5, 0.7));
    // Drop the two triangles facing +y (the lid).
    let up: Vec<usize> = open_box
        .triangles
        .iter()
        .enumerate()
        .filter(|(_, t)| {
            let [a, b, c] = t.map(|i| open_box.positions[i as usize]);
            (b - a).cross(c - a).normalize().y > 0.9
        })
        .map(|(i, _)| i)
        .collect();
    assert_eq!(up.len(), 2);
    for i in up.into_iter().rev() {
        open_box.triangles.remove(i);
    }
    let open_box = s.add_mesh(open_box);
    s.add_instance(Instance::new("open box", open_box, m, Affine3A::from_translation(Vec3::new(1.2, 0.9, -0.6))));
    let mut fan = Mesh::new("fan");
    fan.positions = vec![
        Vec3::new(-0.4, 0.0, 0.0),
        Vec3::new(0.4, 0.0, 0.0),
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::new(0.0, 0.0, 0.5),
        Vec3::new(0.0, -0.45, 0.2),
        // A degenerate triangle (three collinear points).
        Vec3::new(0.6, 0.0, 0.0),
    ];
    fan.normals = vec![Vec3::Y; 6];
    fan.triangles = vec![[0, 1, 2], [1, 0, 3], [0, 1, 4], [0, 1, 5]];
    let fan = s.add_mesh(fan);
    s.add_instance(Instance::new("fan", fan, m, Affine3A::from_translation(Vec3::new(0.2, 1.3, 1.0))));
    let cube = s.add_mesh(primitives::cuboid(Vec3::new(0.6, 0.4, 0.3)));
    s.add_instance(Instance::new(
        "mirrored box",
        cube,
        m,
        Affine3A::from_scale_rotation_translation(
            Vec3::new(-1.0, 1.0, 1.0),
            Quat::from_rotation_y(0.5),
            Vec3::new(-1.0, 0.7, 1.4),
        ),
    ));
    s.add_light(light);
    s.views.push(View::new("v", Vec3::new(0.5, 4.5, 5.0), Vec3::new(0.0, 0.0, 0.0), 0.1, 40.0).with_fov_degrees(55.0));
    s
}

#[test]
fn open_and_non_manifold_casters_shadow_correctly() {
    let gpu = gpu();
    let point =
        Light::new("point", LightKind::Point { position: Vec3::new(0.3, 4.0, 0.2), radius: 0.0 }, Vec3::ONE, 30.0);
    let sun = Light::new(
        "sun",
        LightKind::Directional { direction: Vec3::new(0.35, -1.0, -0.25).normalize(), angular_radius: 0.0 },
        Vec3::ONE,
        2.0,
    );
    for light in [point, sun] {
        let scene = open_scene(light);
        let v = scene.views[0].clone();
        for spec in ["volumes", "volumes:mode=zfail", "volumes:mode=zpplus"] {
            let run = render(&gpu, &scene, &v, SIZE, spec, &[LightId(0)]);
            let (wrong, n) = wrong_frac(&scene, &run, LightId(0), &v);
            println!("open casters, {} {spec}: {:.4}% of {n} wrong", scene.lights[0].name, 100.0 * wrong);
            assert!(n > 5000 && wrong <= EXACT, "{spec}: wrong_frac {wrong}");
            // Something is shadowed: the test sees the casters.
            let shadowed = run.visibility(LightId(0)).iter().filter(|&&x| x < 0.5).count();
            assert!(shadowed > 500, "{spec}: only {shadowed} shadowed pixels");
        }
    }
}

/// An open single-sided card facing down, seen from above: the G-buffer culls its back faces, so
/// the eye looks through it at the ground in its shadow and enters its volume through the light
/// cap (Sibenik's open mesh: `volumes` lit 1.25% of the pixels in shadow at 128 × 96, `hard`
/// 0.33%). Counting in front of the surface (z-pass, ZP+) must draw that cap; z-fail always did.
#[test]
fn the_eye_looking_through_an_open_face_sees_its_shadow() {
    let gpu = gpu();
    let sun = Light::new(
        "sun",
        LightKind::Directional { direction: Vec3::new(0.2, -1.0, 0.1).normalize(), angular_radius: 0.0 },
        Vec3::ONE,
        2.0,
    );
    let point =
        Light::new("point", LightKind::Point { position: Vec3::new(-0.3, 5.0, 0.2), radius: 0.0 }, Vec3::ONE, 40.0);
    for light in [sun, point] {
        let mut s = Scene::new("card seen from behind");
        let m = s.add_material(Material::default());
        let ground = s.add_mesh(primitives::cuboid_between(Vec3::new(-4.0, -0.1, -4.0), Vec3::new(4.0, 0.0, 4.0)));
        s.add_instance(Instance::new("ground", ground, m, Affine3A::IDENTITY));
        let card = s.add_mesh(primitives::plane(1.6, 1.2, 2, 2));
        // Turned over: it faces the ground, its back the eye and the light.
        let turn = Affine3A::from_rotation_translation(Quat::from_rotation_x(std::f32::consts::PI), Vec3::Y * 1.2);
        s.add_instance(Instance::new("card", card, m, turn));
        s.add_light(light);
        s.views.push(View::new("v", Vec3::new(0.6, 4.0, 2.5), Vec3::ZERO, 0.1, 40.0).with_fov_degrees(50.0));
        let v = s.views[0].clone();
        for spec in ["volumes", "volumes:mode=zpass", "volumes:mode=zpplus", "volumes:mode=zfail"] {
            let run = render(&gpu, &s, &v, SIZE, spec, &[LightId(0)]);
            let (wrong, n) = wrong_frac(&s, &run, LightId(0), &v);
            let shadowed = run.visibility(LightId(0)).iter().filter(|&&x| x < 0.5).count();
            println!(
                "card seen from behind, {} {spec}: {:.4}% of {n} wrong, {shadowed} pixels shadowed",
                s.lights[0].name,
                100.0 * wrong
            );
            // The card's shadow is on screen under it: the test sees what it is about (measured
            // 2257 shadowed pixels under the sun, 3653 under the point light; bound about half).
            assert!(shadowed > 1000, "{spec}: only {shadowed} shadowed pixels");
            // Measured 25 283 and 25 229 pixels compared (bound 5000, a fifth); 0% wrong in every
            // mode, 1.40% with z-pass before the see-through light caps (bound EXACT, the issue's).
            assert!(n > 5000 && wrong <= EXACT, "{spec}: wrong_frac {wrong}");
        }
    }
}

#[test]
fn gpu_extraction_matches_the_cpu_reference() {
    let gpu = gpu();
    let scene = hard_scene("room");
    let v = scene.view("default").unwrap().clone();
    let light = scene.find_light("ceiling lamp").unwrap();
    let mut run = render(&gpu, &scene, &v, 64, "volumes:mode=zfail,cull=false,scissor=false", &[light]);
    // The first frame's counters are read at the next one.
    run.renderer.render().unwrap();
    let gpu_triangles = run.renderer.shadows.stats().triangles;
    let source = LightSource::of(&scene.lights[light.index()]);
    let mut cpu_triangles = 0;
    for inst in scene.instances.iter().filter(|i| i.casts_shadows) {
        let mesh = scene.mesh(inst.mesh);
        let topo = Topology::build(mesh);
        let two_sided = !topo.report().is_closed() || scene.material(inst.material).double_sided;
        cpu_triangles += shadow_volume(&topo, &inst.transform, &source, two_sided, true).triangles().count() as u64;
    }
    println!("volume triangles: GPU {gpu_triangles}, CPU {cpu_triangles}");
    assert!(cpu_triangles > 1000);
    assert_eq!(gpu_triangles, cpu_triangles, "the GPU builds the same volumes as the CPU reference");
    assert!(run.stat("ceiling lamp", "fill_fragments") > 0.0, "the fill is measured");
}

#[test]
fn scissor_and_culling_change_the_cost_not_the_image() {
    let gpu = gpu();
    let scene = hard_scene("columns");
    let v = scene.view("hall").unwrap().clone();
    let lights = all_lights(&scene);
    let plain = render(&gpu, &scene, &v, SIZE, "volumes:scissor=false,cull=false", &lights);
    let mut fast = render(&gpu, &scene, &v, SIZE, "volumes", &lights);
    fast.renderer.render().unwrap();
    let mut plain = plain;
    plain.renderer.render().unwrap();
    for &l in &lights {
        let (a, b) = (plain.visibility(l), fast.visibility(l));
        let differ = a.iter().zip(&b).filter(|(x, y)| (*x - *y).abs() > 0.5).count();
        // Measured 0: culling only drops polygons that draw nothing.
        assert!(differ <= 2, "light {}: {differ} pixels change with scissor and culling", l.0);
    }
    let fill = |run: &Run| scene.lights.iter().map(|l| run.stat(&l.name, "fill_fragments")).sum::<f64>();
    let tris = |run: &Run| run.renderer.shadows.stats().triangles;
    println!("fill: {} → {}; triangles {} → {}", fill(&plain), fill(&fast), tris(&plain), tris(&fast));
    // Measured 6362 → 6178 triangles (casters culled whole: extraction is shared by every camera,
    // so the rasteriser clips the polygons outside) and 1.064 M → 0.996 M fragments (lamp 3's
    // range covers 89% of the screen).
    assert!(tris(&fast) < tris(&plain), "culling drops casters' volumes");
    assert!(fill(&fast) < fill(&plain), "the scissor saves fill");
}

#[test]
fn robust_depth_pass_with_invert_counts_from_the_eye() {
    // One convex caster over a ground that casts nothing: volumes never overlap where it matters.
    let gpu = gpu();
    let mut s = Scene::new("one box");
    let m = s.add_material(Material::default());
    let ground = s.add_mesh(primitives::plane(12.0, 12.0, 1, 1));
    s.add_instance(Instance::new("ground", ground, m, Affine3A::IDENTITY)).no_shadow();
    let cube = s.add_mesh(primitives::cuboid(Vec3::new(1.0, 0.6, 1.0)));
    s.add_instance(Instance::new("box", cube, m, Affine3A::from_translation(Vec3::new(0.0, 1.5, 0.0))));
    s.add_light(Light::new(
        "point",
        LightKind::Point { position: Vec3::new(0.0, 4.0, 0.0), radius: 0.0 },
        Vec3::ONE,
        30.0,
    ));
    // The eye under the box, in its shadow, looking across the lit ground.
    let v = View::new("inside", Vec3::new(0.1, 0.6, 0.1), Vec3::new(3.0, 0.0, 2.0), 0.1, 40.0).with_fov_degrees(70.0);
    let run = render(&gpu, &s, &v, SIZE, "volumes:stencil=invert,mode=zpass", &[LightId(0)]);
    let (wrong, n) = wrong_frac(&s, &run, LightId(0), &v);
    println!("robust depth pass from inside: {:.4}% of {n} wrong", 100.0 * wrong);
    assert!(n > 5000 && wrong <= EXACT, "wrong_frac {wrong}");
    let plain = render(&gpu, &s, &v, SIZE, "volumes:mode=zpass", &[LightId(0)]);
    let (wrong, _) = wrong_frac(&s, &plain, LightId(0), &v);
    assert!(wrong > 0.02, "plain z-pass fails from inside the volume: {wrong}");
}

#[test]
fn sampled_volumes_soften_towards_the_reference() {
    let gpu = gpu();
    let scene = load_scene("penumbra").unwrap().scene;
    let v = scene.view("default").unwrap().clone();
    let mut errors = Vec::new();
    for samples in [4, 16, 64] {
        let run = render(&gpu, &scene, &v, 96, &format!("volumes:samples={samples}"), &[LightId(0)]);
        let vis = run.visibility(LightId(0));
        assert!(vis.iter().all(|x| (0.0..=1.0).contains(x)), "V in [0, 1]");
        let r = reference(&scene, &run.surface, LightId(0), 256);
        let (mut sum, mut n) = (0.0f64, 0usize);
        for (a, b) in vis.iter().zip(&r) {
            if !b.is_nan() {
                sum += f64::from(a - b).powi(2);
                n += 1;
            }
        }
        errors.push((sum / n as f64).sqrt());
    }
    println!("RMSE with 4, 16, 64 samples: {errors:?}");
    // The rectangle is sampled on a k×k grid: RMSE falls as k grows (measured 0.041, 0.020,
    // 0.010); the bound for 64 samples is that measure with a margin of two.
    assert!(errors[0] > errors[1] && errors[1] > errors[2], "{errors:?}");
    assert!(errors[2] < 0.02, "64 samples: RMSE {}", errors[2]);
}

#[test]
fn cropped_receivers_take_the_map_and_occluders_the_volumes() {
    // Toromanoff 2005 alg. 12: receivers never see the stencil; here they see `hard`'s map.
    let gpu = gpu();
    let scene = hard_scene("room");
    let v = scene.view("default").unwrap().clone();
    let light = scene.find_light("ceiling lamp").unwrap();
    let cropped = render(&gpu, &scene, &v, SIZE, "volumes:crop=true", &[light]).visibility(light);
    let map = render(&gpu, &scene, &v, SIZE, "hard", &[light]).visibility(light);
    let volumes = render(&gpu, &scene, &v, SIZE, "volumes", &[light]).visibility(light);
    let all = SceneBvh::build(&scene, Selection::All);
    let (mut receivers, mut others, mut receiver_diff, mut other_diff) = (0, 0, 0, 0);
    for i in 0..cropped.len() {
        let (x, y) = ((i as u32 % SIZE) as f32 + 0.5, (i as u32 / SIZE) as f32 + 0.5);
        let (o, dir) = v.image_ray(x, y, SIZE, SIZE);
        let ray = shadowlab_reference::bvh::PreparedRay::new(o, dir, 0.0, f32::INFINITY);
        let Some(hit) = all.closest(&ray, |_, _| true) else { continue };
        let inst = &scene.instances[all.triangles()[hit.index as usize].instance as usize];
        if inst.role == Some(shadowlab_core::Role::Receiver) {
            receivers += 1;
            receiver_diff += ((cropped[i] - map[i]).abs() > 0.5) as usize;
        } else {
            others += 1;
            other_diff += ((cropped[i] - volumes[i]).abs() > 0.5) as usize;
        }
    }
    println!(
        "crop: {receiver_diff} of {receivers} receiver pixels differ from hard, {other_diff} of {others} others from volumes"
    );
    assert!(receivers > 5000 && others > 5000);
    // Pixel-centre ray casts and the rasteriser disagree on which object a pixel shows only along
    // object outlines: measured 0 pixels; allowed 0.5%.
    assert!(receiver_diff as f64 <= 0.005 * receivers as f64, "receivers follow the map");
    assert!(other_diff as f64 <= 0.005 * others as f64, "occluders follow the volumes");
    // And the two sources differ somewhere, or the test could not tell them apart.
    let differ = map.iter().zip(&volumes).filter(|(a, b)| (*a - *b).abs() > 0.5).count();
    assert!(differ > 20, "hard and volumes differ on {differ} pixels only");
}

#[test]
fn volumes_extracted_once_serve_every_camera_and_method() {
    // Extraction is camera-independent: after the first frame, views that take z-pass, ZP+ or
    // z-fail draw the same cached volumes (only the regions drawn differ), extract nothing, and
    // stay exact.
    let gpu = gpu();
    let scene = hard_scene("penumbra");
    let light = LightId(0);
    let name = scene.lights[0].name.clone();
    // From outside every volume (z-pass), from under the card, inside its shadow (ZP+), and from
    // above.
    let under =
        View::new("under", Vec3::new(0.05, 0.25, 0.05), Vec3::new(2.0, 0.0, 1.5), 0.05, 30.0).with_fov_degrees(60.0);
    let views = [scene.view("default").unwrap().clone(), under, scene.view("top").unwrap().clone()];
    let mut methods = Vec::new();
    for spec in ["volumes", "volumes:mode=zfail"] {
        let mut run = render(&gpu, &scene, &views[0], SIZE, spec, &[light]);
        for (k, v) in views.iter().enumerate() {
            if k > 0 {
                run.renderer.set_view(v);
                let work = run.renderer.render().unwrap().work;
                assert_eq!(work.volume_objects, 0, "{spec} {}: a camera move extracts {work:?}", v.name);
                run.surface = run.renderer.read_surface().unwrap();
            }
            let method = ["zpass", "zfail", "zpplus", "skip"]
                .into_iter()
                .find(|m| run.stat(&name, &format!("method_{m}")) > 0.0)
                .unwrap();
            methods.push(method);
            let (wrong, n) = wrong_frac(&scene, &run, light, v);
            println!("{spec} {} {method}: {:.4}% of {n} wrong", v.name, 100.0 * wrong);
            // Measured 0 wrong of 9563, 12319 and 23488 pixels.
            assert!(n > 1000 && wrong <= EXACT, "{spec} {}: wrong_frac {wrong} of {n}", v.name);
        }
    }
    assert_eq!(methods, ["zpass", "zpplus", "zpass", "zfail", "zfail", "zfail"]);
}

/// A light inside a closed, one-sided caster (a bulb in a box): the caster faces away from the light
/// everywhere, yet its shadow is everything outside it (issue 17 item 5: 16 052 of 16 052 relevant
/// pixels were wrong before, in every mode).
#[test]
fn a_light_inside_a_closed_caster_shadows_everything_outside_it() {
    let gpu = gpu();
    let mut s = Scene::new("bulb in a box");
    let m = s.add_material(Material::default());
    let floor = s.add_mesh(primitives::plane(8.0, 8.0, 4, 4));
    s.add_instance(Instance::new("floor", floor, m, Affine3A::IDENTITY));
    let cube = s.add_mesh(primitives::cuboid(Vec3::splat(0.8)));
    s.add_instance(Instance::new("box", cube, m, Affine3A::from_translation(Vec3::new(0.0, 1.0, 0.0))));
    s.add_light(Light::new(
        "bulb",
        LightKind::Point { position: Vec3::new(0.1, 1.05, -0.1), radius: 0.0 },
        Vec3::ONE,
        5.0,
    ));
    let view = View::new("v", Vec3::new(2.5, 3.0, 3.5), Vec3::new(0.0, 0.3, 0.0), 0.1, 40.0).with_fov_degrees(60.0);
    s.views.push(view.clone());
    for spec in ["volumes", "volumes:mode=zfail", "volumes:mode=zpplus"] {
        let run = render(&gpu, &s, &view, SIZE, spec, &[LightId(0)]);
        let v = run.visibility(LightId(0));
        let truth = reference(&s, &run.surface, LightId(0), 1);
        let relevant: Vec<usize> = (0..v.len()).filter(|&i| !truth[i].is_nan()).collect();
        let dark = relevant.iter().filter(|&&i| truth[i] < 0.5).count();
        assert!(dark * 10 > relevant.len() * 9 && relevant.len() > 1000, "the truth: the floor is dark");
        let wrong = relevant.iter().filter(|&&i| (v[i] - truth[i]).abs() > 0.5).count();
        println!("bulb in a box, {spec}: {wrong} of {} relevant pixels wrong", relevant.len());
        // Measured 0 in every mode; the bound is the exact techniques' (EXACT).
        assert!(wrong as f64 <= EXACT * relevant.len() as f64, "{spec}: {wrong} wrong");
    }
    // The CPU reference agrees: the enclosing box's volume holds a floor point.
    let topo = Topology::build(&primitives::cuboid(Vec3::splat(0.8)));
    let transform = Affine3A::from_translation(Vec3::new(0.0, 1.0, 0.0));
    let source = LightSource::Point(Vec3::new(0.1, 1.05, -0.1));
    let volume = shadow_volume(&topo, &transform, &source, false, true);
    let p = Vec3::new(2.0, 0.0, 1.0);
    assert!(shadowlab_core::volumes::enclosure_count(&volume, p, Vec3::Y, 1e4) > 0, "outside the box is shadow");
}
