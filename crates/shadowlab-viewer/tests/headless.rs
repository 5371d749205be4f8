//! Headless runs of the viewer: the window's pixels, overlays, a scripted drag against the truth,
//! and the windowed viewer under Xvfb.

use glam::Vec3;
use shadowlab::{BackendChoice, Gpu, Renderer, TechniqueSpec};
use shadowlab_core::LightId;
use shadowlab_reference::metrics::ErrorStats;
use shadowlab_reference::{ReferenceSettings, SceneBvh, Selection, light_visibility};
use shadowlab_viewer::headless::Headless;
use shadowlab_viewer::script::Script;
use shadowlab_viewer::ui::PANEL_WIDTH;
use shadowlab_viewer::{Overlay, Setup};

fn gpu() -> Gpu {
    Gpu::new(BackendChoice::Auto)
        .expect("no GPU adapter: install Mesa's Vulkan driver (apt-get install mesa-vulkan-drivers)")
}

fn setup(technique: &str, width: u32, height: u32) -> Setup {
    Setup { scene: "room".into(), view: None, width, height, technique: technique.into() }
}

/// The scene area of a screenshot (right of the panel), RGB.
fn scene_area(shot: &image::RgbaImage, width: u32, height: u32) -> Vec<u8> {
    let mut out = Vec::with_capacity((width * height * 3) as usize);
    for y in 0..height {
        for x in 0..width {
            out.extend_from_slice(&shot.get_pixel(PANEL_WIDTH + x, y).0[..3]);
        }
    }
    out
}

/// The window shows the engine's image exactly: the scene area equals what `shadowlab render`
/// (the same `Renderer` with the same view and technique on every light) writes.
#[test]
fn the_scene_area_equals_the_render_of_the_same_view() {
    let (w, h) = (128, 96);
    let mut viewer = Headless::new(gpu(), setup("pcf", w, h)).unwrap();
    viewer.frame(Vec::new()).unwrap();
    let shot = viewer.screenshot().unwrap();
    assert_eq!(shot.dimensions(), (w + PANEL_WIDTH, h));
    let shown = scene_area(&shot, w, h);

    let scene = viewer.viewer.scene().clone();
    let view = viewer.viewer.camera.view();
    let mut r = Renderer::new(&gpu(), scene.clone(), &view, w, h);
    let spec = TechniqueSpec::parse("pcf", &[]).unwrap();
    for i in 0..scene.lights.len() as u32 {
        r.set_technique(LightId(i), &spec).unwrap();
    }
    r.render().unwrap();
    let rendered = r.read_image().unwrap();
    let differing = shown.iter().zip(&rendered).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "{differing} of {} channel values differ", rendered.len());
    // The panel is drawn (not the scene, not black): the UI is in the picture too.
    let panel_lit = (0..h).flat_map(|y| (0..PANEL_WIDTH).map(move |x| (x, y))).filter(|&(x, y)| {
        let p = shot.get_pixel(x, y).0;
        p[0] > 120 && p[1] > 120 && p[2] > 120
    });
    let panel_lit = panel_lit.count();
    println!("panel pixels lit: {panel_lit}");
    // Measured 998 bright text pixels in the 300 × 96 panel; 200 is a fifth of that.
    assert!(panel_lit > 200, "the panel's text is missing");
}

/// The overlays are `shadowlab::analysis`'s pictures (those of `render --overlay`) over the eye's
/// image, exactly; the visibility overlay is the light's V in grey; and a technique that shades
/// from no single map says so instead of failing.
#[test]
fn overlays_show_the_analysis_pictures() {
    use shadowlab::analysis::{MapPicture, compose_fill, compose_maps};
    let (w, h) = (96, 72);
    let mut viewer = Headless::new(gpu(), setup("hard", w, h)).unwrap();
    viewer.frame(Vec::new()).unwrap();
    let plain = scene_area(&viewer.screenshot().unwrap(), w, h);
    let changed = |a: &[u8], b: &[u8]| a.chunks_exact(3).zip(b.chunks_exact(3)).filter(|(p, q)| p != q).count();
    viewer.viewer.overlay = Overlay::Visibility;
    viewer.frame(Vec::new()).unwrap();
    let visibility = scene_area(&viewer.screenshot().unwrap(), w, h);
    let id = viewer.viewer.light_id(viewer.viewer.selected_light).unwrap();
    let v = viewer.viewer.renderer.read_visibility(id).unwrap().unwrap();
    let grey: Vec<u8> = v.iter().flat_map(|&x| [(x.clamp(0.0, 1.0) * 255.0).round() as u8; 3]).collect();
    assert_eq!(visibility, grey, "the visibility overlay is V in grey");
    let dark = visibility.chunks_exact(3).filter(|p| p[0] < 128).count();
    assert!(dark > 0 && dark < (w * h) as usize, "the light's shadow shows ({dark} dark pixels)");
    for (overlay, picture) in [
        (Overlay::Splits, MapPicture::Splits),
        (Overlay::Texels, MapPicture::Texels),
        (Overlay::Sampling, MapPicture::Sampling),
    ] {
        viewer.viewer.overlay = overlay;
        viewer.frame(Vec::new()).unwrap();
        let shown = scene_area(&viewer.screenshot().unwrap(), w, h);
        let r = &viewer.viewer.renderer;
        let o = r.map_overlay(id, viewer.viewer.grid).unwrap().expect("hard has maps");
        assert_eq!(shown, compose_maps(&r.read_image().unwrap(), &o, picture), "{overlay:?}");
        assert!(changed(&plain, &shown) > 0, "{overlay:?} draws something");
    }
    viewer.viewer.set_technique(0, "volumes").unwrap();
    viewer.viewer.overlay = Overlay::Fill;
    viewer.frame(Vec::new()).unwrap();
    assert_eq!(viewer.viewer.overlay, Overlay::Fill, "{}", viewer.viewer.status);
    let fill = scene_area(&viewer.screenshot().unwrap(), w, h);
    let r = &viewer.viewer.renderer;
    let lights: Vec<LightId> = r.shadows.live().lights().iter().map(|s| s.id).collect();
    let counts = r.fill_counts(&lights).unwrap().expect("volumes count fragments");
    assert_eq!(fill, compose_fill(&r.read_image().unwrap(), &counts));
    assert!(changed(&plain, &fill) > 0, "volume fragments cover part of the view");
    viewer.viewer.overlay = Overlay::Texels;
    viewer.viewer.set_technique(0, "none").unwrap();
    viewer.frame(Vec::new()).unwrap();
    assert_eq!(viewer.viewer.overlay, Overlay::None, "an overlay the technique cannot show is turned off");
    assert!(viewer.viewer.status.contains("texel grid"), "and the user is told: {}", viewer.viewer.status);
}

/// A scripted drag moves the chair's shadow, and the shadow after the drag is as right against
/// the ray-traced truth as that of a fresh engine with the chair resting there.
#[test]
fn a_scripted_drag_moves_the_shadow_and_matches_the_truth() {
    let (w, h) = (96, 72);
    let mut viewer = Headless::new(gpu(), setup("hard", w, h)).unwrap();
    let light = viewer.viewer.find_light("ceiling lamp").unwrap();
    viewer.frame(Vec::new()).unwrap();
    let before = viewer.viewer.renderer.read_visibility(LightId(light as u32)).unwrap().unwrap();
    let script = Script::parse("[[step]]\ndrag = \"chair east\"\nby = [-0.6, 0.0, 0.4]\nframes = 5\n").unwrap();
    viewer.run_script(&script).unwrap();
    assert_eq!(viewer.viewer.dragging(), None, "released after the drag");
    let r = &viewer.viewer.renderer;
    let after = r.read_visibility(LightId(light as u32)).unwrap().unwrap();
    let moved = before.iter().zip(&after).filter(|(a, b)| (*a - *b).abs() > 0.5).count();
    // The chair and its shadow cover a few hundred of the 6912 pixels (measured 410); at least 50.
    assert!(moved > 50, "the shadow moved: {moved} pixels changed");

    let truth = |r: &Renderer| {
        let surface = r.read_surface().unwrap();
        let bvh = SceneBvh::build(r.scene(), Selection::Casters);
        let lamp = &r.scene().lights[light];
        let settings = ReferenceSettings { samples: 16, seed: 1 };
        let t = light_visibility(&bvh, &surface, lamp, light as u32, &settings, None).values;
        let v = r.read_visibility(LightId(light as u32)).unwrap().unwrap();
        ErrorStats::compare(&v, &t).wrong_frac()
    };
    let dragged = truth(r);
    let scene = r.scene().clone();
    let mut fresh = Renderer::new(&gpu(), scene.clone(), &viewer.viewer.camera.view(), w, h);
    let spec = TechniqueSpec::parse("hard", &[]).unwrap();
    for i in 0..scene.lights.len() as u32 {
        fresh.set_technique(LightId(i), &spec).unwrap();
    }
    fresh.render().unwrap();
    let resting = truth(&fresh);
    println!("wrong_frac vs truth: after the drag {dragged:.5}, fresh engine {resting:.5}");
    // The live engine after a drag and release equals a fresh one (tests/live.rs); here through
    // the viewer's edits. Margin: 0.1 points for a re-fitted map's texel alignment.
    assert!(dragged <= resting + 0.001, "after the drag {dragged} vs fresh {resting}");
}

/// The mouse picks what is under it (a ray on the scene's BVH) and drags it on the horizontal
/// plane through the picked point: temporary while held, its old mobility back on release.
#[test]
fn the_mouse_picks_and_drags_an_object() {
    let (w, h) = (96, 72);
    let mut viewer = Headless::new(gpu(), setup("hard", w, h)).unwrap();
    viewer.frame(Vec::new()).unwrap();
    let v = &mut viewer.viewer;
    // The chair east's centre, projected.
    let live = v.renderer.shadows.live();
    let id = live.find_instance("chair east").unwrap();
    let centre = live.instances()[live.instance_index(id).unwrap()].bounds.center();
    let cam = shadowlab::CameraUniform::from_view(&v.camera.view(), w, h);
    let shadowlab::frame::Footprint::Rect([x, y, rw, rh]) = cam.footprint_of([centre]) else { panic!("on screen") };
    let (px, py) = (x as f32 + 0.5 * rw as f32, y as f32 + 0.5 * rh as f32);
    let (index, point) = v.pick(px, py).expect("something is under the chair's centre");
    let bounds = v.renderer.shadows.live().instances()[index].bounds;
    let slack = Vec3::splat(1e-3);
    assert!(
        shadowlab_core::Aabb::new(bounds.min - slack, bounds.max + slack).contains(point),
        "the hit lies on the picked object"
    );
    let name = v.scene().instances[index].name.clone();
    let mobility = v.scene().instances[index].mobility;
    assert!(v.begin_drag(px, py).unwrap());
    assert_eq!(v.dragging(), Some(name.as_str()));
    assert_eq!(v.scene().instances[index].mobility, shadowlab_core::Mobility::Temporary);
    v.drag_to(px + 12.0, py + 4.0).unwrap();
    viewer.frame(Vec::new()).unwrap();
    let v = &mut viewer.viewer;
    v.end_drag().unwrap();
    let after = v.renderer.shadows.live().instances()[index].bounds;
    assert!(after.center().distance(bounds.center()) > 1e-3, "the object moved");
    assert!((after.min.y - bounds.min.y).abs() < 1e-4, "on its plane");
    assert_eq!(v.scene().instances[index].mobility, mobility, "its mobility is back");
    assert!(v.pick(-5.0, 3.0).is_none(), "off the image: nothing");
    assert!(!v.begin_drag(f32::NAN, 3.0).unwrap(), "a NaN position picks nothing");
}

/// Bad input is an error, not a panic: unknown scene, view, light, technique, parameter value,
/// instance; a bad script step leaves the viewer running.
#[test]
fn bad_input_is_an_error() {
    let gpu = gpu();
    assert!(Headless::new(gpu.clone(), Setup { scene: "nowhere.toml".into(), ..setup("hard", 64, 48) }).is_err());
    assert!(Headless::new(gpu.clone(), Setup { view: Some("nope".into()), ..setup("hard", 64, 48) }).is_err());
    assert!(Headless::new(gpu.clone(), setup("no-such-technique", 64, 48)).is_err());
    assert!(Headless::new(gpu.clone(), setup("hard", 0, 48)).is_err());
    let mut viewer = Headless::new(gpu, setup("hard", 64, 48)).unwrap();
    viewer.frame(Vec::new()).unwrap();
    let v = &mut viewer.viewer;
    assert!(v.find_light("no lamp").is_err());
    assert!(v.set_param(0, "map_size", "-3").is_err());
    assert!(v.set_param(0, "no_param", "1").is_err());
    assert!(v.set_technique(0, "pcf:kernel=nan").is_err());
    assert_eq!(v.spec(0).unwrap().info.id, "hard", "a refused change keeps the technique");
    for bad in [
        "[[step]]\ndrag = \"no such thing\"\nby = [1, 0, 0]\n",
        "[[step]]\noverlay = \"x\"\n",
        "[[step]]\nview = \"x\"\n",
    ] {
        let script = Script::parse(bad).unwrap();
        assert!(viewer.run_script(&script).is_err(), "{bad}");
    }
    viewer.frame(Vec::new()).unwrap();
}

/// Truth in the loop: tracing runs on a background thread while frames keep coming, and its
/// metrics are those of the reference traced directly on the same surface.
#[cfg(feature = "truth")]
#[test]
fn the_truth_is_traced_while_frames_keep_coming() {
    let (w, h) = (96, 72);
    let mut viewer = Headless::new(gpu(), setup("pcf", w, h)).unwrap();
    viewer.frame(Vec::new()).unwrap();
    let light = viewer.viewer.find_light("ceiling lamp").unwrap();
    viewer.viewer.selected_light = light;
    // 256 samples on 6912 pixels: seconds of tracing on two cores, many frames.
    let samples = 256;
    viewer.viewer.start_truth(samples).unwrap();
    assert!(viewer.viewer.start_truth(samples).is_err(), "one trace at a time");
    let start = std::time::Instant::now();
    let mut frames_while_tracing = 0;
    while viewer.viewer.truth_job.is_some() {
        viewer.frame(Vec::new()).unwrap();
        frames_while_tracing += 1;
        assert!(start.elapsed().as_secs() < 300, "the trace ends");
    }
    println!("{frames_while_tracing} frames while tracing");
    // The trace runs apart from the frames: several frames are drawn while it runs (measured 13 and
    // 25 in two runs at 96 × 72 on two cores); a trace on the frame's thread would allow one.
    assert!(frames_while_tracing >= 3, "only {frames_while_tracing} frames while tracing");
    let truth = viewer.viewer.current_truth().expect("the truth of the frame shown");
    assert_eq!(viewer.viewer.overlay, Overlay::Error, "the error is shown when the truth lands");

    // The same numbers as the reference traced here, on the same surface.
    let r = &viewer.viewer.renderer;
    let surface = r.read_surface().unwrap();
    let bvh = SceneBvh::build(r.scene(), Selection::Casters);
    let settings = ReferenceSettings { samples, seed: 1 };
    let reference = light_visibility(&bvh, &surface, &r.scene().lights[light], light as u32, &settings, None).values;
    let v = r.read_visibility(LightId(light as u32)).unwrap().unwrap();
    let direct = ErrorStats::compare(&v, &reference);
    assert_eq!(truth.stats, direct, "the viewer's metrics are compare's");
    // The heatmap is in the picture.
    let shot = viewer.screenshot().unwrap();
    let shown = scene_area(&shot, w, h);
    let heat = shadowlab_reference::images::error_heatmap(&v, &reference);
    assert_eq!(shown, heat, "the error overlay shows the heatmap");
    // A new size makes it stale (its heatmap no longer fits the image).
    viewer.viewer.renderer.resize(w + 8, h).unwrap();
    viewer.frame(Vec::new()).unwrap();
    assert!(viewer.viewer.current_truth().is_none(), "stale after a resize");
    assert_eq!(viewer.viewer.overlay, Overlay::None, "the error overlay is turned off, with a message");
    viewer.viewer.renderer.resize(w, h).unwrap();
    viewer.frame(Vec::new()).unwrap();
    viewer.viewer.start_truth(4).unwrap();
    while viewer.viewer.truth_job.is_some() {
        viewer.frame(Vec::new()).unwrap();
    }
    assert!(viewer.viewer.current_truth().is_some());
    // Moving the camera makes it stale.
    viewer.viewer.camera.turn(20.0, 0.0, 0.01);
    viewer.frame(Vec::new()).unwrap();
    assert!(viewer.viewer.current_truth().is_none(), "stale after the camera moved");
    assert_eq!(viewer.viewer.overlay, Overlay::None, "and the overlay is turned off, with a message");
}

/// The panel's other controls, through the viewer's methods: named views, camera paths, a light
/// moved and resized through the live engine (its shadow follows), caching off.
#[test]
fn views_paths_and_light_edits_reach_the_image() {
    let (w, h) = (64, 48);
    let mut viewer = Headless::new(gpu(), setup("hard", w, h)).unwrap();
    viewer.frame(Vec::new()).unwrap();
    let first = viewer.screenshot().unwrap();
    viewer.viewer.go_to_view("table").unwrap();
    viewer.frame(Vec::new()).unwrap();
    let table = viewer.screenshot().unwrap();
    assert_ne!(scene_area(&first, w, h), scene_area(&table, w, h), "another view");
    assert!(viewer.viewer.go_to_view("attic").is_err());
    assert!(viewer.viewer.play_path("nowhere").is_err());
    let v = &mut viewer.viewer;
    let lamp = v.find_light("ceiling lamp").unwrap();
    let id = v.light_id(lamp).unwrap();
    let before = v.renderer.read_visibility(id).unwrap().unwrap();
    let p = v.scene().lights[lamp].position().unwrap();
    v.edit_light(lamp, shadowlab::LightChange::Position(p + Vec3::new(0.8, 0.0, 0.0))).unwrap();
    assert!(v.edit_light(lamp, shadowlab::LightChange::Radius(-1.0)).is_err(), "a negative radius is refused");
    viewer.frame(Vec::new()).unwrap();
    let after = viewer.viewer.renderer.read_visibility(id).unwrap().unwrap();
    let moved = before.iter().zip(&after).filter(|(a, b)| (*a - *b).abs() > 0.5).count();
    println!("pixels changed by the lamp's move: {moved}");
    // Measured 73 of 3072 pixels at 64 × 48; 20 leaves room for the map's texel alignment.
    assert!(moved > 20, "the lamp's shadows moved with it ({moved} pixels)");
    viewer.viewer.renderer.shadows.set_caching(false);
    viewer.frame(Vec::new()).unwrap();
    let uncached = viewer.viewer.renderer.read_visibility(id).unwrap().unwrap();
    assert_eq!(after, uncached, "the cached frame equals the rebuilt one");
}

/// A camera path plays one view per frame, then stops where it ends.
#[test]
fn a_camera_path_plays_one_view_per_frame() {
    let mut viewer = Headless::new(gpu(), Setup { scene: "terrain".into(), ..setup("hard", 48, 32) }).unwrap();
    viewer.frame(Vec::new()).unwrap();
    let views = viewer.viewer.scene().paths[0].views();
    viewer.viewer.play_path("walk").unwrap();
    let mut seen = Vec::new();
    while viewer.viewer.path_progress().is_some() {
        viewer.frame(Vec::new()).unwrap();
        seen.push(viewer.viewer.camera.position);
        assert!(seen.len() <= views.len() + 1, "the path ends");
    }
    assert_eq!(seen.len(), views.len() + 1, "every view, then the frame that ends it");
    for (p, v) in seen.iter().zip(&views) {
        assert!(p.abs_diff_eq(v.position, 1e-5), "{p} vs {}", v.position);
    }
}

/// The third-person view shows another camera's image with the eye's frustum (white) and the
/// selected light's map frusta (their colours) drawn in, and the eye's image in a corner; the keys
/// then move that camera, not the eye.
#[test]
fn the_third_person_view_draws_the_frusta() {
    let (w, h) = (160, 120);
    let mut viewer = Headless::new(gpu(), setup("hard", w, h)).unwrap();
    viewer.viewer.selected_light = viewer.viewer.find_light("ceiling lamp").unwrap();
    viewer.frame(Vec::new()).unwrap();
    let eye_image = scene_area(&viewer.screenshot().unwrap(), w, h);
    viewer.viewer.set_third_person(true).unwrap();
    viewer.frame(Vec::new()).unwrap();
    let third = scene_area(&viewer.screenshot().unwrap(), w, h);
    let differing = eye_image.chunks_exact(3).zip(third.chunks_exact(3)).filter(|(a, b)| a != b).count();
    println!("third person: {differing} pixels differ from the eye's image");
    // Measured 19165 of 19200 pixels: another viewpoint changes nearly all; half is the margin.
    assert!(differing > (w * h / 2) as usize, "another camera's image ({differing} pixels differ)");
    let frusta = viewer.viewer.frusta();
    // The eye's 12 edges, the focus body's (at least a hexahedron's 24 face edges), and 12 per cube
    // face of the ceiling lamp (a point light inside the room).
    let count = |c: [u8; 3]| frusta.iter().filter(|s| s.1 == c).count();
    assert_eq!(count(shadowlab_viewer::third_person::EYE_COLOUR), 12);
    assert!(count(shadowlab_viewer::third_person::FOCUS_COLOUR) >= 24);
    // A point light: a cross where it is, no extrusion (that is for directional lights).
    assert_eq!(count(shadowlab_viewer::third_person::LIGHT_COLOUR), 3);
    let faces = frusta.len()
        - 12
        - count(shadowlab_viewer::third_person::FOCUS_COLOUR)
        - count(shadowlab_viewer::third_person::LIGHT_COLOUR);
    assert_eq!(faces, 6 * 12, "{faces} map-view segments");
    let colour_count =
        |c: [u8; 3]| third.chunks_exact(3).filter(|p| p.iter().zip(c).all(|(a, b)| a.abs_diff(b) < 24)).count();
    println!(
        "frustum pixels: eye {}, focus {}",
        colour_count([255, 255, 255]),
        colour_count(shadowlab_viewer::third_person::FOCUS_COLOUR)
    );
    // Measured 361 (eye) and 1061 (focus body) pixels of their colours; 20 is a line's worth.
    assert!(colour_count([255, 255, 255]) > 20, "the eye's frustum is drawn");
    assert!(colour_count(shadowlab_viewer::third_person::FOCUS_COLOUR) > 20, "the focus body is drawn");
    let drawn = (0..6).map(shadowlab_viewer::third_person::view_colour).filter(|&c| colour_count(c) > 5).count();
    println!("face colours seen: {drawn}");
    // Measured 5 of the 6 face colours on screen (more than 5 pixels each); at least 2.
    assert!(drawn >= 2, "the lamp's faces are drawn ({drawn} colours seen)");
    // Looking through a cube face of the lamp: from the lamp, along the face's axis.
    let face = viewer.viewer.renderer.light_views(LightId(viewer.viewer.selected_light as u32))[3];
    viewer.viewer.look_from_light_view(3).unwrap();
    assert!(viewer.viewer.look_from_light_view(99).is_err(), "no view 99");
    viewer.frame(Vec::new()).unwrap();
    let looked = viewer.viewer.third_person.as_ref().unwrap().view();
    assert!(looked.position.abs_diff_eq(face.eye, 1e-5), "{} vs {}", looked.position, face.eye);
    let through = scene_area(&viewer.screenshot().unwrap(), w, h);
    assert_ne!(through, third, "the light's view is another picture");
    let eye = viewer.viewer.camera.clone();
    viewer.viewer.active_camera().travel(Vec3::new(0.0, 0.0, 1.0), 0.5);
    assert!(viewer.viewer.third_person.as_ref().unwrap().fixed.is_none(), "moving leaves the light view");
    assert_eq!(viewer.viewer.camera, eye, "the keys move the third person, not the eye");
    // A sampled light's frusta: one view per emitter sample and cube face.
    let lamp = viewer.viewer.selected_light;
    viewer.viewer.set_technique(lamp, "sampled:samples=4").unwrap();
    viewer.frame(Vec::new()).unwrap();
    let sample_views = viewer.viewer.renderer.light_views(LightId(lamp as u32)).len();
    assert_eq!(sample_views, 4 * 6, "4 samples × 6 faces");
    viewer.viewer.set_technique(lamp, "hard").unwrap();
    viewer.viewer.set_third_person(false).unwrap();
    viewer.frame(Vec::new()).unwrap();
    assert_eq!(scene_area(&viewer.screenshot().unwrap(), w, h), eye_image, "back to the eye's image");
}

/// "copy command" writes a `--camera` that `shadowlab render` reads back as the viewer's camera.
#[test]
fn the_copied_command_reproduces_the_camera() {
    let mut viewer = Headless::new(gpu(), setup("pcf", 64, 48)).unwrap();
    viewer.viewer.camera.turn(35.0, -12.0, 0.01);
    viewer.viewer.camera.travel(Vec3::new(0.3, 0.1, 0.5), 1.0);
    let command = viewer.viewer.cli_command();
    let camera = command.split("--camera ").nth(1).and_then(|rest| rest.split(' ').next()).expect("a --camera");
    let base = viewer.viewer.scene().views[0].clone();
    let view = shadowlab_core::View::with_camera_text(&base, camera).unwrap();
    let mine = viewer.viewer.camera.view();
    // Three decimals: a millimetre in a 5 m room.
    assert!(view.position.abs_diff_eq(mine.position, 1e-3), "{} vs {}", view.position, mine.position);
    let (d, e) = ((view.target - view.position).normalize(), (mine.target - mine.position).normalize());
    assert!(d.abs_diff_eq(e, 2e-3), "{d} vs {e}");
    assert!((view.fov_y - mine.fov_y).abs() < 1e-3);
    assert!(command.contains("--technique 'pcf'") && command.contains("--size 64x48"), "{command}");
    assert!(!command.contains('#'), "one technique everywhere: the command reproduces it all: {command}");
    // A light with another technique: said, since `render` takes one.
    let reading = viewer.viewer.find_light("reading lamp").unwrap();
    viewer.viewer.set_technique(reading, "pcss").unwrap();
    let command = viewer.viewer.cli_command();
    assert!(command.ends_with("# not reproduced: 'reading lamp' pcss"), "{command}");
}

/// The A/B split shows the selected light with another technique on the right half: the left half
/// is the eye's image, the right half that of a renderer with the other technique, and the same
/// technique on both sides shows one picture.
#[test]
fn the_ab_split_shows_two_techniques_side_by_side() {
    let (w, h) = (128, 96);
    let mut viewer = Headless::new(gpu(), setup("hard", w, h)).unwrap();
    let lamp = viewer.viewer.find_light("ceiling lamp").unwrap();
    viewer.viewer.selected_light = lamp;
    viewer.frame(Vec::new()).unwrap();
    let a = scene_area(&viewer.screenshot().unwrap(), w, h);
    let column = |img: &[u8], x: u32| (0..h).map(|y| img[3 * (y * w + x) as usize..][..3].to_vec()).collect::<Vec<_>>();
    viewer.viewer.set_ab(Some("hard")).unwrap();
    viewer.frame(Vec::new()).unwrap();
    let same = scene_area(&viewer.screenshot().unwrap(), w, h);
    for x in (0..w).filter(|&x| x < w / 2 || x > w / 2 + 1) {
        assert_eq!(column(&same, x), column(&a, x), "column {x}: the same technique on both sides");
    }
    assert!(column(&same, w / 2).iter().all(|p| p == &vec![255u8; 3]), "the divider");
    viewer.viewer.set_ab(Some("pcss")).unwrap();
    viewer.frame(Vec::new()).unwrap();
    let split = scene_area(&viewer.screenshot().unwrap(), w, h);
    let left_same = (0..w / 2).all(|x| column(&split, x) == column(&a, x));
    let right_changed = (w / 2 + 2..w).filter(|&x| column(&split, x) != column(&a, x)).count();
    assert!(left_same, "the left half stays the eye's technique");
    println!("A/B: {right_changed} columns of the right half differ");
    // Measured 39 of the 62 right-half columns (the lamp's shadows soften where they fall); 10 is
    // the margin for views where fewer shadows cross.
    assert!(right_changed > 10, "pcss's softer shadows on the right ({right_changed} columns differ)");
    assert!(viewer.viewer.set_ab(Some("cascaded")).is_err(), "not for a point light");
    viewer.viewer.set_ab(None).unwrap();
    viewer.frame(Vec::new()).unwrap();
    assert_eq!(scene_area(&viewer.screenshot().unwrap(), w, h), a, "off again");
}

/// The live perspective-error graph of `cascaded` (analyze's curves for the camera now): finite,
/// one curve per split, and more splits lower the worst undersampling (PSSM's point).
#[test]
fn the_perspective_error_follows_the_cascades() {
    let mut viewer = Headless::new(gpu(), Setup { scene: "terrain".into(), ..setup("hard", 96, 64) }).unwrap();
    let sun = viewer.viewer.scene().lights.iter().position(|l| l.type_name() == "directional").expect("a sun");
    viewer.viewer.selected_light = sun;
    assert!(viewer.viewer.aliasing_curves().is_none(), "none for hard");
    let worst = |v: &mut Headless, splits: u32| {
        v.viewer.set_technique(sun, &format!("cascaded:splits={splits}")).unwrap();
        let curves = v.viewer.aliasing_curves().expect("curves for cascaded");
        assert_eq!(curves.len(), splits as usize);
        assert!(curves.iter().flatten().all(|&(z, mx, mz)| z > 0.0
            && mx > 0.0
            && mz > 0.0
            && mx.is_finite()
            && mz.is_finite()));
        // m is the perspective aliasing error, screen pixels per texel (Lloyd et al.): the worst is
        // the largest.
        curves.iter().flatten().map(|p| p.1.max(p.2)).fold(0.0, f32::max)
    };
    let (one, four) = (worst(&mut viewer, 1), worst(&mut viewer, 4));
    println!("largest aliasing error: 1 split {one:.2}, 4 splits {four:.2}");
    assert!(four < one, "four splits lower the worst aliasing: {four} vs {one}");
    viewer.frame(Vec::new()).unwrap();
}
