//! Convex bodies as polygon soups, clipped by planes: the intersection body B of focused shadow
//! mapping (Stingl 2011, §3.1.1, after Wimmer & Scherzer 2006).

use glam::{Mat4, Vec3};

use crate::bounds::Aabb;

/// A plane `n·p + d = 0`; the kept half-space is `n·p + d ≥ 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    pub n: Vec3,
    pub d: f32,
}

impl Plane {
    pub fn new(n: Vec3, point: Vec3) -> Self {
        Self { n, d: -n.dot(point) }
    }

    pub fn distance(&self, p: Vec3) -> f32 {
        self.n.dot(p) + self.d
    }
}

/// A convex polyhedron as its faces (convex polygons, any winding).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ConvexBody {
    pub faces: Vec<Vec<Vec3>>,
}

impl ConvexBody {
    /// The box's six faces.
    pub fn from_aabb(b: &Aabb) -> Self {
        Self::from_corners(&b.corners())
    }

    /// A hexahedron from 8 corners indexed like [`Aabb::corners`] (bit 0: x, bit 1: y, bit 2: z).
    pub fn from_corners(c: &[Vec3; 8]) -> Self {
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        Self { faces: quads.iter().map(|q| q.iter().map(|&i| c[i]).collect()).collect() }
    }

    /// The frustum whose clip space (D3D-style, depth in [0, 1]) is mapped by `view_proj`.
    pub fn from_frustum(view_proj: &Mat4) -> Self {
        let inv = view_proj.inverse();
        let mut c = [Vec3::ZERO; 8];
        for (i, corner) in c.iter_mut().enumerate() {
            let ndc = Vec3::new(
                if i & 1 != 0 { 1.0 } else { -1.0 },
                if i & 2 != 0 { 1.0 } else { -1.0 },
                if i & 4 != 0 { 1.0 } else { 0.0 },
            );
            *corner = inv.project_point3(ndc);
        }
        Self::from_corners(&c)
    }

    pub fn is_empty(&self) -> bool {
        self.faces.is_empty()
    }

    /// All vertices (with repeats).
    pub fn points(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.faces.iter().flatten().copied()
    }

    /// Keeps the part on the positive side of `plane`, closing the cut with a new face.
    pub fn clip(&self, plane: &Plane) -> Self {
        // Wholly on one side (the common case when a body is tested against many planes): the
        // body itself, or nothing, as the cut below would give, without its allocations.
        let (mut inside, mut outside) = (false, false);
        for p in self.points() {
            if plane.distance(p) >= 0.0 {
                inside = true;
            } else {
                outside = true;
            }
        }
        if !outside {
            return Self { faces: self.faces.iter().filter(|f| f.len() >= 3).cloned().collect() };
        }
        if !inside {
            return Self::default();
        }
        let mut faces = Vec::with_capacity(self.faces.len() + 1);
        let mut cut: Vec<Vec3> = Vec::new();
        for face in &self.faces {
            let mut out = Vec::with_capacity(face.len() + 2);
            for k in 0..face.len() {
                let (a, b) = (face[k], face[(k + 1) % face.len()]);
                let (da, db) = (plane.distance(a), plane.distance(b));
                if da >= 0.0 {
                    out.push(a);
                }
                if (da >= 0.0) != (db >= 0.0) {
                    let p = a + (b - a) * (da / (da - db));
                    out.push(p);
                    cut.push(p);
                }
            }
            if out.len() >= 3 {
                faces.push(out);
            }
        }
        if cut.len() >= 3 {
            // Order the cut points around their centre in the plane.
            let centre = cut.iter().copied().sum::<Vec3>() / cut.len() as f32;
            let (u, v) = crate::sampling::orthonormal_basis(plane.n.normalize());
            cut.sort_by(|a, b| {
                let (pa, pb) = (*a - centre, *b - centre);
                pseudo_angle(pa.dot(u), pa.dot(v)).total_cmp(&pseudo_angle(pb.dot(u), pb.dot(v)))
            });
            cut.dedup_by(|a, b| a.distance_squared(*b) < 1e-12);
            if cut.len() >= 3 {
                faces.push(cut);
            }
        }
        Self { faces }
    }

    /// The part inside the box.
    pub fn clip_to_aabb(&self, b: &Aabb) -> Self {
        let planes = [
            Plane { n: Vec3::X, d: -b.min.x },
            Plane { n: Vec3::NEG_X, d: b.max.x },
            Plane { n: Vec3::Y, d: -b.min.y },
            Plane { n: Vec3::NEG_Y, d: b.max.y },
            Plane { n: Vec3::Z, d: -b.min.z },
            Plane { n: Vec3::NEG_Z, d: b.max.z },
        ];
        planes.iter().fold(self.clone(), |body, p| if body.is_empty() { body } else { body.clip(p) })
    }

    /// The part a reversed-Z projection `clip_from` sees (wgpu clip space: −w ≤ x, y ≤ w, the near
    /// plane at z = w; no far plane): its four sides widened by `widen` × w and its near plane
    /// moved `near_margin` × w towards the eye, so that round-off never cuts what it sees.
    pub fn clip_to_view(&self, clip_from: &Mat4, widen: f32, near_margin: f32) -> Self {
        let planes = view_planes(clip_from, widen, near_margin);
        // Wholly in view: no plane cuts, and the clips below would each copy the body (dropping
        // faces of fewer than three points).
        if self.points().all(|p| planes.iter().all(|plane| plane.distance(p) >= 0.0)) {
            return Self { faces: self.faces.iter().filter(|f| f.len() >= 3).cloned().collect() };
        }
        planes.iter().fold(self.clone(), |body, plane| if body.is_empty() { body } else { body.clip(plane) })
    }
}

/// A number that grows with the angle of `(x, y)` from the +x axis as `atan2(y, x)` does, in
/// (−2, 2], without its cost (clipping sorts every cut by it).
fn pseudo_angle(x: f32, y: f32) -> f32 {
    let p = x / (x.abs() + y.abs());
    if !p.is_finite() {
        // The centre itself: atan2(0, 0) is 0, as for the +x axis.
        return 0.0;
    }
    if y < 0.0 { p - 1.0 } else { 1.0 - p }
}

/// The planes [`ConvexBody::clip_to_view`] cuts by, keeping their positive sides.
pub fn view_planes(clip_from: &Mat4, widen: f32, near_margin: f32) -> [Plane; 5] {
    let m = clip_from.transpose();
    let (x, y, z, w) = (m.x_axis, m.y_axis, m.z_axis, m.w_axis);
    let wide = w * (1.0 + widen);
    let near = w * (1.0 + near_margin) - z;
    [wide + x, wide - x, wide + y, wide - y, near].map(|row| Plane { n: row.truncate(), d: row.w })
}

/// Whether a box wholly outside one of [`ConvexBody::clip_to_view`]'s planes, so that the box's
/// body clipped to the view is empty (tested on its corners, as the clip does), without building
/// the body: a caller testing many boxes against a view skips most of them here.
pub fn box_misses_view(b: &Aabb, clip_from: &Mat4, widen: f32, near_margin: f32) -> bool {
    let corners = b.corners();
    view_planes(clip_from, widen, near_margin).iter().any(|plane| corners.iter().all(|&c| plane.distance(c) < 0.0))
}

/// The point where the ray from `p` (inside `b`) along `dir` leaves the box.
pub fn exit_point(b: &Aabb, p: Vec3, dir: Vec3) -> Vec3 {
    let mut t = f32::INFINITY;
    for axis in 0..3 {
        if dir[axis] > 1e-12 {
            t = t.min((b.max[axis] - p[axis]) / dir[axis]);
        } else if dir[axis] < -1e-12 {
            t = t.min((b.min[axis] - p[axis]) / dir[axis]);
        }
    }
    if t.is_finite() { p + dir * t.max(0.0) } else { p }
}

/// The points of the focus body of a directional light (Stingl 2011, §3.1.1): H = V ∩ S, and each
/// point of H extruded towards the light (against `light_dir`, the direction the light travels) to
/// where it leaves S. Their convex hull contains every caster that can shadow a visible point, and
/// lies inside S. Empty when the view does not meet the scene.
pub fn directional_focus_points(view_body: &ConvexBody, scene: &Aabb, light_dir: Vec3) -> Vec<Vec3> {
    let h = view_body.clip_to_aabb(scene);
    let mut pts: Vec<Vec3> = h.points().collect();
    let toward_light = -light_dir.normalize();
    let extruded: Vec<Vec3> = pts.iter().map(|&p| exit_point(scene, p, toward_light)).collect();
    pts.extend(extruded);
    pts
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With the identity as projection (w = 1) the view is |x|, |y| ≤ 1 and z ≤ 1 (the near plane,
    /// reversed Z); the margins widen it.
    #[test]
    fn clipping_to_a_view_keeps_what_it_sees() {
        let body = ConvexBody::from_aabb(&Aabb::new(Vec3::splat(-3.0), Vec3::splat(3.0)));
        let seen = body.clip_to_view(&Mat4::IDENTITY, 0.0, 0.0);
        let b = seen.points().fold(Aabb::EMPTY, |b, p| b.union(&Aabb::new(p, p)));
        assert!((b.min - Vec3::new(-1.0, -1.0, -3.0)).abs().max_element() < 1e-6, "{b:?}");
        assert!((b.max - Vec3::new(1.0, 1.0, 1.0)).abs().max_element() < 1e-6, "{b:?}");
        let wider = body.clip_to_view(&Mat4::IDENTITY, 0.5, 0.25);
        let b = wider.points().fold(Aabb::EMPTY, |b, p| b.union(&Aabb::new(p, p)));
        assert!((b.max - Vec3::new(1.5, 1.5, 1.25)).abs().max_element() < 1e-6, "{b:?}");
        // Wholly behind the near plane: nothing.
        let behind = ConvexBody::from_aabb(&Aabb::new(Vec3::new(0.0, 0.0, 2.0), Vec3::splat(3.0)));
        assert!(behind.clip_to_view(&Mat4::IDENTITY, 0.0, 0.0).is_empty());
    }
    use crate::camera::View;

    /// `pseudo_angle` orders directions as `atan2` does (the cut faces' order), and a box said to
    /// miss a view clips to nothing there, while one that reaches it is not said to miss: checked
    /// on random directions, boxes and perspective views.
    #[test]
    fn the_cheap_tests_agree_with_what_they_stand_for() {
        let mut seed = 7u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        let mut directions: Vec<(f32, f32)> = (0..500).map(|_| (next(), next())).collect();
        directions.extend([(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0), (-1.0, 1e-7), (-1.0, -1e-7)]);
        for &(x0, y0) in &directions {
            for &(x1, y1) in &directions {
                let (a, b) = (y0.atan2(x0), y1.atan2(x1));
                if (a - b).abs() > 1e-5 {
                    assert_eq!(a < b, pseudo_angle(x0, y0) < pseudo_angle(x1, y1), "({x0}, {y0}) and ({x1}, {y1})");
                }
            }
        }
        let (mut missed, mut met) = (0, 0);
        for _ in 0..200 {
            let eye = Vec3::new(next(), next(), next()) * 2.0;
            let target = Vec3::new(next(), next(), next());
            let view = crate::lightspace::perspective_reversed(0.3 + next().abs(), 1.0, 0.1, 10.0)
                * crate::lightspace::look_along(eye, (target - eye).normalize_or(Vec3::Z));
            let c = Vec3::new(next(), next(), next()) * 4.0;
            let e = Vec3::new(next().abs(), next().abs(), next().abs()) * 0.5 + Vec3::splat(0.01);
            let b = Aabb::new(c - e, c + e);
            let clipped = ConvexBody::from_aabb(&b).clip_to_view(&view, 0.05, 1e-4);
            if box_misses_view(&b, &view, 0.05, 1e-4) {
                missed += 1;
                assert!(clipped.is_empty(), "{b:?} is said to miss the view but clips to {clipped:?}");
            } else if !clipped.is_empty() {
                met += 1;
            }
        }
        // Both cases occur (measured 160 missed and 39 met of 200 with this seed; at least 20 each).
        assert!(missed >= 20 && met >= 20, "{missed} missed, {met} met");
    }

    fn inside_convex_hull_of_box(p: Vec3, b: &Aabb) -> bool {
        let e = 1e-3;
        p.cmpge(b.min - Vec3::splat(e)).all() && p.cmple(b.max + Vec3::splat(e)).all()
    }

    #[test]
    fn clipping_a_cube_by_a_diagonal_plane_keeps_half() {
        let body = ConvexBody::from_aabb(&Aabb::new(Vec3::ZERO, Vec3::ONE));
        let half = body.clip(&Plane::new(Vec3::X, Vec3::splat(0.5)));
        let pts: Vec<Vec3> = half.points().collect();
        assert!(pts.iter().all(|p| p.x >= 0.5 - 1e-6));
        assert_eq!(half.faces.len(), 6, "five cut faces and the cap");
        let b = Aabb::from_points(pts);
        assert!((b.min.x - 0.5).abs() < 1e-6 && (b.max.x - 1.0).abs() < 1e-6);
    }

    #[test]
    fn focus_body_contains_view_in_scene_and_stays_in_scene() {
        let scene = Aabb::new(Vec3::new(-50.0, 0.0, -50.0), Vec3::new(50.0, 20.0, 50.0));
        let view = View::new("v", Vec3::new(0.0, 2.0, 40.0), Vec3::new(0.0, 1.0, 0.0), 0.5, 200.0);
        let vp = view.view_projection(16, 9);
        // Our projections are reversed Z: near maps to 1. from_frustum expects D3D-style [0, 1]
        // either way: the 8 corners are the same set.
        let v = ConvexBody::from_frustum(&vp);
        let light = Vec3::new(0.6, -0.7, 0.2).normalize();
        let pts = directional_focus_points(&v, &scene, light);
        assert!(!pts.is_empty());
        // B lies inside S.
        assert!(pts.iter().all(|&p| inside_convex_hull_of_box(p, &scene)));
        // Every point of V ∩ S is inside the AABB of B (a conservative check of containment).
        let bb = Aabb::from_points(pts.iter().copied());
        let h = v.clip_to_aabb(&scene);
        assert!(h.points().all(|p| inside_convex_hull_of_box(p, &bb)));
        // The extrusion reaches S's boundary towards the light (the top face here).
        assert!(pts.iter().any(|p| (p.y - 20.0).abs() < 1e-3));
        // H's points are within the view frustum's depth range.
        assert!(h.points().all(|p| (p - view.position).dot(view.forward()) <= 200.0 + 1e-2));
    }

    #[test]
    fn view_outside_scene_gives_empty_focus() {
        let scene = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let view = View::new("v", Vec3::new(0.0, 0.0, 10.0), Vec3::new(0.0, 0.0, 20.0), 0.1, 5.0);
        let v = ConvexBody::from_frustum(&view.view_projection(1, 1));
        assert!(directional_focus_points(&v, &scene, -Vec3::Y).is_empty());
    }
}
