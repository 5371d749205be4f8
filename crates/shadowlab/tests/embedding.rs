//! The embedding path: an application's own device, standard-Z depth and normal buffers (the
//! `embed` example) gives the same shadows as shadowlab's own renderer (reversed Z).

mod common;
#[path = "../examples/embed.rs"]
mod embed;

use shadowlab_core::load_scene;

#[test]
fn embedded_shadows_match_the_renderer() {
    let gpu = common::gpu();
    let mut scene = load_scene("room").unwrap().scene;
    scene.scale_emitters(0.0);
    let view = scene.view("window").unwrap().clone();
    let sun = scene.find_light("sun").unwrap();
    let size = 96;
    let embedded = embed::embedded_visibility(&gpu, scene.clone(), &view, sun, "hard", (size, size));
    let run = common::render(&gpu, &scene, &view, size, "hard", &[sun]);
    let own = run.visibility(sun);
    let relevance = run.surface.relevance(&scene.lights[sun.index()]);
    let relevant = relevance.iter().filter(|&&r| r).count();
    let differ = (0..own.len()).filter(|&i| relevance[i] && (own[i] - embedded[i]).abs() > 0.5).count();
    println!("embedded vs renderer: {differ} of {relevant} relevant pixels differ");
    // The two depth conventions reconstruct positions a few ulps apart; only pixels on a shadow
    // edge may flip (measured 0 of 6030). Bound: 0.5%.
    assert!(relevant > 2000);
    assert!((differ as f64) < 0.005 * relevant as f64, "{differ} of {relevant}");
}

#[test]
fn camera_uniform_recovers_the_view() {
    use shadowlab::CameraUniform;
    let view =
        shadowlab_core::View::new("v", glam::Vec3::new(1.0, 2.0, 3.0), glam::Vec3::new(-4.0, 0.5, -2.0), 0.25, 700.0)
            .with_fov_degrees(55.0);
    for reversed in [true, false] {
        let projection = if reversed {
            view.projection(1.5)
        } else {
            glam::camera::rh::proj::directx::perspective(view.fov_y, 1.5, view.near, view.far)
        };
        let v = CameraUniform::new(view.view_matrix(), projection, 300, 200, reversed).view();
        assert!((v.position - view.position).length() < 1e-4);
        assert!(v.forward().dot(view.forward()) > 1.0 - 1e-5);
        assert!((v.fov_y - view.fov_y).abs() < 1e-4, "{} vs {}", v.fov_y, view.fov_y);
        assert!((v.near - view.near).abs() < 1e-3 * view.near);
        // The far plane from a float inverse is approximate; 2%.
        assert!((v.far - view.far).abs() < 0.02 * view.far, "{} vs {}", v.far, view.far);
    }
}

/// The web's frame path (`Renderer::frame`: record and submit, no wait, no readback) draws what the
/// blocking `render` draws: after the same frames, every light's visibility and the image are
/// equal, and a frame keeps its work counts (the second still frame re-does nothing).
#[test]
fn a_frame_that_does_not_wait_draws_what_render_draws() {
    let gpu = common::gpu();
    let scene = load_scene("room").unwrap().scene;
    let view = scene.view("default").unwrap().clone();
    let spec = shadowlab::TechniqueSpec::parse("pcf:map_size=512", &[]).unwrap();
    let make = || {
        let mut r = shadowlab::Renderer::new(&gpu, scene.clone(), &view, 64, 48);
        for i in 0..scene.lights.len() {
            r.set_technique(shadowlab_core::LightId(i as u32), &spec).unwrap();
        }
        r
    };
    let (mut waiting, mut free) = (make(), make());
    waiting.render().unwrap();
    let first = free.frame().unwrap();
    assert!(first.map_views > 0, "the first frame renders the maps: {first:?}");
    waiting.render().unwrap();
    let second = free.frame().unwrap();
    free.observe(&second, 1.0);
    assert_eq!((second.map_views, second.resolves), (0, 0), "a still frame re-does nothing: {second:?}");
    // Readbacks wait for the submitted frames (native only).
    assert_eq!(waiting.live_visibility().unwrap(), free.live_visibility().unwrap());
    assert_eq!(waiting.read_image().unwrap(), free.read_image().unwrap());
}
