//! The third-person view (Stingl 2011 §5): the scene seen from a second camera, with the eye's
//! frustum and the selected light's map frusta (cube faces, cascade splits) drawn in, and the eye's
//! own image as a minimap. The frusta are those the eye's techniques used for the frame shown.

use glam::{Mat4, Vec3, Vec4};
use shadowlab::{Gpu, Renderer, TechniqueSpec};
use shadowlab_core::lightspace::ShadowView;
use shadowlab_core::{LightId, Scene, View};

use crate::camera::FlyCamera;
use crate::viewer::ViewerError;

/// A world-space line segment and its colour (RGB).
pub type Segment = ([Vec3; 2], [u8; 3]);

/// The eye's frustum colour and the focus body's.
pub const EYE_COLOUR: [u8; 3] = [255, 255, 255];
pub const FOCUS_COLOUR: [u8; 3] = [255, 236, 0];
pub const LIGHT_COLOUR: [u8; 3] = [255, 128, 0];

/// Map view `k`'s colour: the splits overlay's (`cascades::split_colour`).
pub fn view_colour(k: usize) -> [u8; 3] {
    shadowlab_core::cascades::split_colour(k).to_array().map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
}

/// The second camera's renderer, rebuilt from the live scene whenever an edit or a technique change
/// made it stale.
pub struct ThirdPerson {
    pub renderer: Renderer,
    pub camera: FlyCamera,
    /// A light view being looked through (`light_view_camera`), until the camera is moved.
    pub fixed: Option<View>,
    /// The scene epoch and the techniques' version it was built for.
    built: (u64, u64),
}

impl ThirdPerson {
    /// Starts behind and above `eye`, looking at where the eye looks, inside the scene's box.
    pub fn new(
        gpu: &Gpu,
        scene: &Scene,
        specs: &[TechniqueSpec],
        eye: &FlyCamera,
        size: (u32, u32),
        built: (u64, u64),
    ) -> Result<Self, ViewerError> {
        let bounds = scene.bounds();
        let diagonal = bounds.diagonal().max(1e-3);
        let inner = shrink(&bounds, 0.05);
        let back = eye.position - eye.forward() * 0.35 * diagonal + Vec3::Y * 0.25 * diagonal;
        let position = back.clamp(inner.min, inner.max);
        let target = eye.position + eye.forward() * 0.1 * diagonal;
        let view = View {
            name: "third person".into(),
            position,
            target: if target.distance(position) > 1e-4 { target } else { position + eye.forward() },
            up: Vec3::Y,
            fov_y: 70f32.to_radians(),
            near: eye.near,
            far: eye.far.max(4.0 * diagonal),
        };
        let camera = FlyCamera::from_view(&view, diagonal);
        let renderer = build(gpu, scene, specs, &view, size)?;
        Ok(Self { renderer, camera, fixed: None, built })
    }

    /// The view rendered: the light view looked through, or the free camera's.
    pub fn view(&self) -> View {
        self.fixed.clone().unwrap_or_else(|| self.camera.view())
    }

    /// Renders from the third-person camera, rebuilding first when `built` moved on.
    pub fn render(
        &mut self,
        gpu: &Gpu,
        scene: &Scene,
        specs: &[TechniqueSpec],
        size: (u32, u32),
        built: (u64, u64),
    ) -> Result<(), ViewerError> {
        let view = self.view();
        if built != self.built || (self.renderer.width, self.renderer.height) != size {
            self.renderer = build(gpu, scene, specs, &view, size)?;
            self.built = built;
        }
        self.renderer.set_view(&view);
        self.renderer.render()?;
        Ok(())
    }
}

/// A camera looking as map view `view` does (Stingl 2011 §5's light views): from its eye along its
/// axis with its field of view and its up; an orthographic view (a directional light's) is
/// approached by a camera far back along its axis, aimed at its window's centre, with the field of
/// view that spans the window's height.
pub fn light_view_camera(view: &ShadowView, scene_diagonal: f32) -> View {
    let inverse = view.view_projection.inverse();
    // The map's own up (its view matrix's y axis in the world), so that its window's height is the
    // camera's.
    let up = view.view.inverse().transform_vector3(Vec3::Y).normalize_or(Vec3::Y);
    // The window's centre line and half height, on the near plane (reversed Z: depth 1).
    let at = |x: f32, y: f32| inverse.project_point3(Vec3::new(x, y, 1.0));
    if view.orthographic {
        let half = 0.5 * at(0.0, 1.0).distance(at(0.0, -1.0));
        // Far enough that the perspective shrinks the window's depth by well under a percent.
        let back = 200.0 * scene_diagonal.max(1e-3);
        let centre = at(0.0, 0.0);
        View {
            name: "light view".into(),
            position: centre - view.axis * back,
            target: centre,
            up,
            fov_y: 2.0 * (half / back).atan(),
            near: back * 0.5,
            far: back + 2.0 * (view.far - view.near).abs().max(scene_diagonal),
        }
    } else {
        let half = 1.0 / view.projection.y_axis.y.abs().max(1e-6);
        View {
            name: "light view".into(),
            position: view.eye,
            target: view.eye + view.axis,
            up,
            fov_y: 2.0 * half.atan(),
            near: view.near.max(1e-4),
            far: view.far.max(view.near * 2.0),
        }
    }
}

/// A second renderer of the live scene as it is now, each light with its spec (the third-person
/// view's, the A/B split's).
pub(crate) fn build(
    gpu: &Gpu,
    scene: &Scene,
    specs: &[TechniqueSpec],
    view: &View,
    size: (u32, u32),
) -> Result<Renderer, ViewerError> {
    let mut r = Renderer::new(gpu, scene.clone(), view, size.0, size.1);
    for (i, spec) in specs.iter().enumerate() {
        r.set_technique(LightId(i as u32), spec)?;
    }
    Ok(r)
}

fn shrink(b: &shadowlab_core::Aabb, fraction: f32) -> shadowlab_core::Aabb {
    let e = (b.max - b.min) * fraction;
    shadowlab_core::Aabb::new(b.min + e, b.max - e)
}

/// The eye's frustum, from its near plane to `reach` (the far plane is often kilometres away).
pub fn eye_frustum(eye: &View, aspect: f32, reach: f32) -> Vec<Segment> {
    let f = (eye.target - eye.position).normalize_or(Vec3::NEG_Z);
    let r = f.cross(eye.up).normalize_or(Vec3::X);
    let u = r.cross(f);
    let t = (0.5 * eye.fov_y).tan();
    let ring = |d: f32| {
        [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .map(|(x, y): (f32, f32)| eye.position + f * d + r * (x * d * t * aspect) + u * (y * d * t))
    };
    box_segments(ring(eye.near), ring(eye.far.min(reach).max(eye.near)), EYE_COLOUR)
}

/// The edges of H = V ∩ S, the part of the scene's box the eye sees (Stingl 2011 §3.1: the body the
/// focused and cascaded maps are fitted around, before its extrusion towards the light).
pub fn focus_body(eye: &View, aspect: f32, scene: &shadowlab_core::Aabb) -> Vec<Segment> {
    // Reversed Z swaps which corners are near and far; the body is the same.
    let body = shadowlab_core::convex::ConvexBody::from_frustum(&(eye.projection(aspect) * eye.view_matrix()));
    body.clip_to_aabb(scene)
        .faces
        .iter()
        .flat_map(|f| (0..f.len()).map(move |k| ([f[k], f[(k + 1) % f.len()]], FOCUS_COLOUR)))
        .filter(|([a, b], _)| a.is_finite() && b.is_finite() && a.distance(*b) > 0.0)
        .collect()
}

/// For a directional light, the focus body B's extrusion (Stingl 2011 §3.1.1): from each vertex of
/// H towards the light to where it leaves the scene's box.
pub fn focus_extrusion(h: &[Segment], scene: &shadowlab_core::Aabb, light: &shadowlab_core::Light) -> Vec<Segment> {
    let Some(direction) = light.direction().filter(|_| light.position().is_none()) else { return Vec::new() };
    let toward = -direction.normalize_or(Vec3::NEG_Y);
    let mut points: Vec<Vec3> = h.iter().flat_map(|(ends, _)| *ends).collect();
    points.dedup_by(|a, b| a.distance(*b) < 1e-5);
    points
        .into_iter()
        .map(|p| ([p, shadowlab_core::convex::exit_point(scene, p, toward)], FOCUS_COLOUR))
        .filter(|([a, b], _)| a.distance(*b) > 1e-5)
        .collect()
}

/// Where the light is and where it shines: a cross at a positioned light and a line along a spot's
/// or a rect light's axis; for a directional light, an arrow through the scene's centre along the
/// direction the light travels.
pub fn light_marker(light: &shadowlab_core::Light, scene: &shadowlab_core::Aabb) -> Vec<Segment> {
    let d = 0.05 * scene.diagonal().max(1e-3);
    let c = LIGHT_COLOUR;
    match (light.position(), light.direction()) {
        (Some(p), direction) => {
            let mut s: Vec<Segment> =
                [Vec3::X, Vec3::Y, Vec3::Z].iter().map(|&a| ([p - a * d, p + a * d], c)).collect();
            if let Some(dir) = direction {
                s.push(([p, p + dir.normalize_or(Vec3::NEG_Y) * 4.0 * d], c));
            }
            s
        }
        (None, Some(dir)) => {
            let dir = dir.normalize_or(Vec3::NEG_Y);
            let (tip, tail) = (scene.center(), scene.center() - dir * 6.0 * d);
            let side = dir.cross(if dir.cross(Vec3::Y).length() < 1e-3 { Vec3::X } else { Vec3::Y }).normalize();
            vec![([tail, tip], c), ([tip, tip - dir * d + side * d], c), ([tip, tip - dir * d - side * d], c)]
        }
        (None, None) => Vec::new(),
    }
}

/// A map view's frustum: its near and far rectangles and the edges between them.
pub fn view_frustum(view: &ShadowView, colour: [u8; 3]) -> Vec<Segment> {
    let inverse = view.view_projection.inverse();
    // Reversed Z: depth 1 at the near plane, 0 at the far one.
    let ring = |z: f32| {
        [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].map(|(x, y)| inverse.project_point3(Vec3::new(x, y, z)))
    };
    box_segments(ring(1.0), ring(0.0), colour)
}

fn box_segments(near: [Vec3; 4], far: [Vec3; 4], colour: [u8; 3]) -> Vec<Segment> {
    let mut s = Vec::with_capacity(12);
    for k in 0..4 {
        s.push(([near[k], near[(k + 1) % 4]], colour));
        s.push(([far[k], far[(k + 1) % 4]], colour));
        s.push(([near[k], far[k]], colour));
    }
    s.retain(|([a, b], _)| a.is_finite() && b.is_finite());
    s
}

/// `segment` in the pixels of a `width × height` image seen through `view_proj`: clipped to the
/// part in front of the camera (w above a small positive bound), `None` when nothing is.
pub fn project_segment(view_proj: &Mat4, [a, b]: [Vec3; 2], width: u32, height: u32) -> Option<[glam::Vec2; 2]> {
    let (mut ca, mut cb) = (*view_proj * a.extend(1.0), *view_proj * b.extend(1.0));
    const MIN_W: f32 = 1e-4;
    if ca.w < MIN_W && cb.w < MIN_W {
        return None;
    }
    let cut = |p: Vec4, q: Vec4| p + (q - p) * ((MIN_W - p.w) / (q.w - p.w));
    if ca.w < MIN_W {
        ca = cut(ca, cb);
    } else if cb.w < MIN_W {
        cb = cut(cb, ca);
    }
    let pixel =
        |c: Vec4| glam::Vec2::new((c.x / c.w * 0.5 + 0.5) * width as f32, (0.5 - c.y / c.w * 0.5) * height as f32);
    let (pa, pb) = (pixel(ca), pixel(cb));
    (pa.is_finite() && pb.is_finite()).then_some([pa, pb])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_project_to_pixels_and_are_cut_at_the_camera() {
        let view = View::new("v", Vec3::ZERO, Vec3::NEG_Z, 0.1, 100.0);
        let m = view.view_projection(100, 100);
        // A point straight ahead lands in the middle.
        let [p, q] = project_segment(&m, [Vec3::new(0.0, 0.0, -5.0), Vec3::new(1.0, 0.0, -5.0)], 100, 100).unwrap();
        assert!((p - glam::Vec2::splat(50.0)).length() < 1e-3, "{p}");
        assert!(q.x > p.x && (q.y - p.y).abs() < 1e-3, "right is right: {q}");
        // Entirely behind: nothing; crossing the eye's plane: cut, finite.
        assert!(project_segment(&m, [Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 2.0)], 100, 100).is_none());
        let cut = project_segment(&m, [Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.5, 0.0, -2.0)], 100, 100).unwrap();
        assert!(cut.iter().all(|c| c.is_finite()));
    }

    /// A light-view camera sees what its map view sees: the top and bottom of the map window's
    /// centre line project to the top and bottom of the image's centre column, for a cube face and
    /// for a directional light's window.
    #[test]
    fn light_view_cameras_see_their_map_window() {
        let face = ShadowView::perspective(Vec3::new(0.0, 3.0, 0.0), Vec3::X, 1.2, 0.1, 8.0, 256);
        let sun = shadowlab_core::lightspace::light_frusta(
            &shadowlab_core::Light::new(
                "sun",
                shadowlab_core::LightKind::Directional { direction: Vec3::new(0.3, -1.0, 0.2), angular_radius: 0.0 },
                Vec3::ONE,
                1.0,
            ),
            &shadowlab_core::Aabb::new(Vec3::splat(-3.0), Vec3::splat(3.0)),
            256,
        )
        .views[0];
        for v in [face, sun] {
            let cam = light_view_camera(&v, 10.0);
            let m = cam.view_projection(100, 100);
            let inverse = v.view_projection.inverse();
            for (y, expected) in [(1.0, 0.0), (-1.0, 100.0)] {
                // A point of the window halfway between near and far.
                let p = inverse.project_point3(Vec3::new(0.0, y, 0.5));
                let q = project_segment(&m, [p, p], 100, 100).unwrap()[0];
                assert!(
                    (q.x - 50.0).abs() < 0.5 && (q.y - expected).abs() < 0.5,
                    "{q} (orthographic {})",
                    v.orthographic
                );
            }
        }
    }

    /// B's extrusion runs from H's vertices towards a directional light to the scene's box; other
    /// lights get none. The sun's marker is an arrow along the direction the light travels.
    #[test]
    fn the_focus_body_extrudes_towards_the_sun() {
        let scene = shadowlab_core::Aabb::new(Vec3::new(-5.0, 0.0, -5.0), Vec3::new(5.0, 4.0, 5.0));
        let eye = View::new("e", Vec3::new(0.0, 1.0, 4.0), Vec3::new(0.0, 1.0, 0.0), 0.1, 100.0);
        let h = focus_body(&eye, 1.5, &scene);
        let dir = Vec3::new(0.4, -1.0, 0.1).normalize();
        let sun = shadowlab_core::Light::new(
            "sun",
            shadowlab_core::LightKind::Directional { direction: dir, angular_radius: 0.0 },
            Vec3::ONE,
            1.0,
        );
        let e = focus_extrusion(&h, &scene, &sun);
        assert!(!e.is_empty());
        for ([a, b], _) in &e {
            assert!((*b - *a).normalize().abs_diff_eq(-dir, 1e-3), "towards the light");
            let on_face = (0..3).any(|i| (b[i] - scene.min[i]).abs() < 1e-3 || (b[i] - scene.max[i]).abs() < 1e-3);
            assert!(on_face, "{b} ends on the box");
        }
        let lamp = shadowlab_core::Light::new(
            "lamp",
            shadowlab_core::LightKind::Point { position: Vec3::new(0.0, 3.0, 0.0), radius: 0.1 },
            Vec3::ONE,
            1.0,
        );
        assert!(focus_extrusion(&h, &scene, &lamp).is_empty());
        let arrow = light_marker(&sun, &scene);
        assert_eq!(arrow.len(), 3);
        assert!((arrow[0].0[1] - arrow[0].0[0]).normalize().abs_diff_eq(dir, 1e-4), "along the light's travel");
        assert_eq!(light_marker(&lamp, &scene).len(), 3, "a cross at the lamp");
    }

    #[test]
    fn a_map_frustum_has_twelve_edges_through_its_eye() {
        let v = ShadowView::perspective(Vec3::new(0.0, 3.0, 0.0), Vec3::NEG_Y, 1.0, 0.5, 4.0, 256);
        let s = view_frustum(&v, [1, 2, 3]);
        assert_eq!(s.len(), 12);
        // The side edges run along rays from the light.
        for ([a, b], _) in s.iter().filter(|([a, b], _)| (a.y - b.y).abs() > 1.0) {
            let (da, db) = ((*a - v.eye).normalize(), (*b - v.eye).normalize());
            assert!(da.abs_diff_eq(db, 1e-3), "{a} {b}");
        }
        let eye = View::new("e", Vec3::ZERO, Vec3::NEG_Z, 0.1, 1000.0);
        let e = eye_frustum(&eye, 1.5, 10.0);
        assert_eq!(e.len(), 12);
        assert!(e.iter().all(|([a, b], _)| a.length() <= 20.0 && b.length() <= 20.0), "cut at the reach");
        // The focus body lies in the scene's box and in the eye's frustum.
        let scene = shadowlab_core::Aabb::new(Vec3::new(-2.0, -1.0, -6.0), Vec3::new(2.0, 1.0, -1.0));
        let h = focus_body(&eye, 1.5, &scene);
        // A box cut by a frustum keeps at least a hexahedron's 6 faces of 4 edges (faces share
        // their edges, each listed twice): 24.
        assert!(h.len() >= 24, "{} edges", h.len());
        for ([a, b], _) in &h {
            for p in [a, b] {
                assert!(p.cmpge(scene.min - 1e-4).all() && p.cmple(scene.max + 1e-4).all(), "{p} in the box");
                assert!(p.z <= -0.1 + 1e-4 && p.x.abs() <= -p.z * 1.5 * (0.5 * eye.fov_y).tan() + 1e-3, "{p} seen");
            }
        }
    }
}
