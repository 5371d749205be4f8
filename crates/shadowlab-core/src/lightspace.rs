//! Light-space maths: the views a shadow map is rendered from.
//!
//! All projections here use **reversed Z** with depth in [0, 1]: the near plane maps to 1 and the far
//! plane to 0. With a floating-point depth buffer this spreads precision evenly over the whole range
//! (the float's dense values near 0 meet the projection's crowding at the far end), which is what
//! long light frusta need. A stored depth is *closer to the light* when it is *larger*.

use glam::{Mat4, Vec2, Vec3, Vec4};

use crate::bounds::Aabb;
use crate::light::{Light, LightKind};
use crate::sampling::orthonormal_basis;

/// Reversed-Z perspective projection (right-handed view space looking down −Z).
pub fn perspective_reversed(fov_y: f32, aspect: f32, near: f32, far: f32) -> Mat4 {
    let f = 1.0 / (0.5 * fov_y).tan();
    let a = near / (far - near);
    let b = near * far / (far - near);
    Mat4::from_cols(
        Vec4::new(f / aspect, 0.0, 0.0, 0.0),
        Vec4::new(0.0, f, 0.0, 0.0),
        Vec4::new(0.0, 0.0, a, -1.0),
        Vec4::new(0.0, 0.0, b, 0.0),
    )
}

/// Reversed-Z orthographic projection of the view-space box `[l, r] × [b, t]` between distances
/// `near` and `far` in front of the eye.
pub fn orthographic_reversed(l: f32, r: f32, b: f32, t: f32, near: f32, far: f32) -> Mat4 {
    let (w, h, d) = (r - l, t - b, far - near);
    Mat4::from_cols(
        Vec4::new(2.0 / w, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 2.0 / h, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 1.0 / d, 0.0),
        Vec4::new(-(r + l) / w, -(t + b) / h, far / d, 1.0),
    )
}

/// Reversed-Z perspective projection of the off-axis window `[l, r] × [b, t]` (tangents: view-space
/// x/−z and y/−z) between distances `near` and `far`: `perspective_reversed` with its image window
/// moved off the axis (OpenGL's `glFrustum`, in tangent units).
pub fn off_axis_reversed(l: f32, r: f32, b: f32, t: f32, near: f32, far: f32) -> Mat4 {
    let a = near / (far - near);
    let c = near * far / (far - near);
    Mat4::from_cols(
        Vec4::new(2.0 / (r - l), 0.0, 0.0, 0.0),
        Vec4::new(0.0, 2.0 / (t - b), 0.0, 0.0),
        Vec4::new((r + l) / (r - l), (t + b) / (t - b), a, -1.0),
        Vec4::new(0.0, 0.0, c, 0.0),
    )
}

/// A right-handed view matrix at `eye` looking along unit `dir`, with an up vector that is never
/// parallel to it.
pub fn look_along(eye: Vec3, dir: Vec3) -> Mat4 {
    let up = if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
    glam::camera::rh::view::look_at_mat4(eye, eye + dir, up)
}

/// One rendered view of a shadow map (a cube face, a cascade, a frustum).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowView {
    pub view: Mat4,
    pub projection: Mat4,
    pub view_projection: Mat4,
    /// The eye (perspective) or a point on the near plane's axis (orthographic).
    pub eye: Vec3,
    /// Unit viewing direction.
    pub axis: Vec3,
    pub orthographic: bool,
    pub near: f32,
    pub far: f32,
    /// World size of one texel: for orthographic views that size; for perspective views the size per
    /// unit of distance along `axis` (so the size at p is `texel_scale × (p − eye)·axis`).
    pub texel_scale: f32,
    /// Warped maps (LiSPSM, PSM): the stored reversed-Z depth as an affine function of the world
    /// position, `d = row · (p, 1)`, instead of the projective depth. A warp's projective depth
    /// `z/w` packs the far half of a kilometre view into a sliver of the depth range (w runs from
    /// the warp's near distance n to n + d, a ratio of thousands for PSM), below a float's step,
    /// and lit ground then shadows itself in rows (issue 19 item 1). Light-space depth along the
    /// light is affine in the world, so it interpolates exactly as a perspective-correct varying.
    pub linear_depth: Option<Vec4>,
}

impl ShadowView {
    pub fn perspective(eye: Vec3, axis: Vec3, fov: f32, near: f32, far: f32, map_size: u32) -> Self {
        let t = (0.5 * fov).tan();
        Self::perspective_with(eye, axis, perspective_reversed(fov, 1.0, near, far), near, far, 2.0 * t, map_size)
    }

    /// A perspective view whose square image window `[l, r] × [b, t]` (tangents) lies off the axis
    /// ([`off_axis_reversed`]).
    pub fn off_axis(eye: Vec3, axis: Vec3, window: [f32; 4], near: f32, far: f32, map_size: u32) -> Self {
        let [l, r, b, t] = window;
        Self::perspective_with(eye, axis, off_axis_reversed(l, r, b, t, near, far), near, far, r - l, map_size)
    }

    /// `width`: the image window's width in tangent units (texels per unit of distance × size).
    fn perspective_with(
        eye: Vec3,
        axis: Vec3,
        projection: Mat4,
        near: f32,
        far: f32,
        width: f32,
        map_size: u32,
    ) -> Self {
        let view = look_along(eye, axis);
        Self {
            view,
            projection,
            view_projection: projection * view,
            eye,
            axis,
            orthographic: false,
            near,
            far,
            texel_scale: width / map_size.max(1) as f32,
            linear_depth: None,
        }
    }

    /// World size of a texel at `p`.
    pub fn texel_size_at(&self, p: Vec3) -> f32 {
        if self.orthographic { self.texel_scale } else { self.texel_scale * (p - self.eye).dot(self.axis).max(0.0) }
    }

    /// Map coordinates `(u, v)` in [0, 1]² (v down) and reversed-Z depth of `p`.
    pub fn project(&self, p: Vec3) -> Vec3 {
        let c = self.view_projection * p.extend(1.0);
        let ndc = c.truncate() / c.w;
        let z = self.linear_depth.map_or(ndc.z, |row| row.dot(p.extend(1.0)));
        Vec3::new(0.5 * ndc.x + 0.5, 0.5 - 0.5 * ndc.y, z)
    }
}

/// Extra field of view on cube faces so that a filter kernel near a face's edge still reads texels
/// of that face: `margin` texels on each side.
fn cube_face_fov(map_size: u32, margin_texels: f32) -> f32 {
    let s = map_size.max(8) as f32;
    2.0 * (1.0 + 2.0 * margin_texels / s).atan()
}

/// The cube face directions in the order of their layers: +X, −X, +Y, −Y, +Z, −Z. A point goes to
/// the face of the largest component of its direction from the light.
pub const CUBE_FACES: [Vec3; 6] = [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];

/// The cube face of direction `d` (see [`CUBE_FACES`]).
pub fn cube_face(d: Vec3) -> usize {
    let a = d.abs();
    if a.x >= a.y && a.x >= a.z {
        if d.x >= 0.0 { 0 } else { 1 }
    } else if a.y >= a.z {
        if d.y >= 0.0 { 2 } else { 3 }
    } else if d.z >= 0.0 {
        4
    } else {
        5
    }
}

/// The cube faces [`cube_face`] gives to some point of the box `b` seen from `eye` (indexed as
/// [`CUBE_FACES`]): a face's map is read only for points it holds, so a box's points need no
/// other. A face holds a direction `d` when its axis component, with the face's sign, is at
/// least both others' magnitudes; over a box each component ranges independently, so the face
/// holds some point when the largest signed component reaches the least magnitudes of the
/// other two. Ties count for every face they touch (conservative). An empty box meets none.
pub fn cube_faces_meeting(eye: Vec3, b: &Aabb) -> [bool; 6] {
    let (lo, hi) = (b.min - eye, b.max - eye);
    if !(lo.cmple(hi).all()) {
        return [false; 6];
    }
    let least = |a: usize| if lo[a] <= 0.0 && hi[a] >= 0.0 { 0.0 } else { lo[a].abs().min(hi[a].abs()) };
    let mut faces = [false; 6];
    for axis in 0..3 {
        let others = (0..3).filter(|&o| o != axis).map(least).fold(0.0f32, f32::max);
        faces[2 * axis] = hi[axis] >= others;
        faces[2 * axis + 1] = -lo[axis] >= others;
    }
    faces
}

/// How a light's shadow map covers the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct LightFrusta {
    pub views: Vec<ShadowView>,
    /// Six views indexed by [`cube_face`]; otherwise one view.
    pub cube: bool,
}

impl LightFrusta {
    /// The view that covers `p`.
    pub fn view_for(&self, p: Vec3) -> &ShadowView {
        if self.cube { &self.views[cube_face(p - self.views[0].eye)] } else { &self.views[0] }
    }
}

/// Near plane of local light views, as a fraction of the scene diagonal: small enough for casters
/// close to the light (a lamp's own cord), large enough for depth precision with reversed-Z floats.
pub const NEAR_FRACTION: f32 = 1.0e-3;

/// Views from a point `eye` that see everything in `bounds` (optionally only within a cone): one
/// perspective frustum when the bounds or the cone fit in 120°, six cube faces otherwise.
pub fn point_frusta(eye: Vec3, bounds: &Aabb, cone: Option<(Vec3, f32)>, map_size: u32) -> LightFrusta {
    point_frusta_with(eye, bounds, cone, map_size, false)
}

/// [`point_frusta`], optionally forced to six cube faces (so that the samples of an area light all
/// use the same layout).
pub fn point_frusta_with(
    eye: Vec3,
    bounds: &Aabb,
    cone: Option<(Vec3, f32)>,
    map_size: u32,
    force_cube: bool,
) -> LightFrusta {
    let diag = bounds.diagonal().max(1e-3);
    let far = bounds.corners().iter().map(|c| c.distance(eye)).fold(0.0f32, f32::max).max(diag * 1e-2) * 1.01;
    let near = (NEAR_FRACTION * diag).min(0.5 * far);
    let max_half = 60f32.to_radians();
    // The cone from the eye around the box (when the eye is outside it): a cone narrower than a
    // hemisphere that holds the 8 corners holds their convex hull, the box.
    let to_box = (!bounds.contains(eye)).then(|| {
        let axis = (bounds.center() - eye).normalize_or(Vec3::NEG_Y);
        let half = bounds
            .corners()
            .iter()
            .map(|&c| axis.dot((c - eye).normalize_or(axis)).clamp(-1.0, 1.0).acos())
            .fold(0.0f32, f32::max);
        (axis, half)
    });
    // One frustum: aimed at the scene's box when that is the narrower target, else
    // along the spot's cone; either covers everything the light can shadow.
    let fits = |half: f32| half <= max_half;
    let (single, at_box) = match (cone, to_box) {
        _ if force_cube => (None, false),
        (Some((_, half)), Some((to_c, s))) if s < half && fits(s) => (Some((to_c, s)), true),
        (Some((axis, half)), _) if fits(half) => (Some((axis, half)), false),
        (None, Some((to_c, s))) if fits(s) => (Some((to_c, s)), true),
        _ => (None, false),
    };
    if let Some((axis, half)) = single {
        // One texel of margin around the cone for filter kernels.
        let fov = 2.0 * (half.tan() * (1.0 + 2.0 / map_size.max(8) as f32)).atan();
        // Depth along the axis is linear, so over the box it is smallest at a corner.
        let box_near = bounds.corners().iter().map(|&c| (c - eye).dot(axis)).fold(f32::INFINITY, f32::min);
        let near = if at_box { (0.99 * box_near).max(near) } else { near };
        return LightFrusta { views: vec![ShadowView::perspective(eye, axis, fov, near, far, map_size)], cube: false };
    }
    let fov = cube_face_fov(map_size, 4.0);
    LightFrusta {
        views: CUBE_FACES.iter().map(|&axis| ShadowView::perspective(eye, axis, fov, near, far, map_size)).collect(),
        cube: true,
    }
}

/// An orthographic view along `direction` fitted to `bounds` (the light-space box of its corners).
pub fn directional_frustum(direction: Vec3, bounds: &Aabb, map_size: u32) -> LightFrusta {
    let dir = direction.normalize();
    let radius = 0.5 * bounds.diagonal().max(1e-3);
    let eye = bounds.center() - dir * (radius * 1.1);
    let view = look_along(eye, dir);
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for c in bounds.corners() {
        let v = view.transform_point3(c);
        lo = lo.min(v);
        hi = hi.max(v);
    }
    // View space looks down −Z: distances are −z.
    let (near, far) = ((-hi.z - 0.01 * radius).max(0.0), -lo.z + 0.01 * radius);
    let pad = 2.0 * (hi.x - lo.x).max(hi.y - lo.y) / map_size.max(8) as f32;
    let (l, r, b, t) = (lo.x - pad, hi.x + pad, lo.y - pad, hi.y + pad);
    let projection = orthographic_reversed(l, r, b, t, near, far);
    LightFrusta {
        views: vec![ShadowView {
            view,
            projection,
            view_projection: projection * view,
            eye,
            axis: dir,
            orthographic: true,
            near,
            far,
            texel_scale: (r - l).max(t - b) / map_size.max(1) as f32,
            linear_depth: None,
        }],
        cube: false,
    }
}

/// A perspective view from `eye` that holds `points` (the corners of a cascade's slice of the view
/// frustum clipped to the scene, as cascaded soft shadow maps fit each sample's view: Azri 2020 §4)
/// and every caster between the eye and them: the narrowest cone around their centroid. `None` when
/// that cone is wider than 120° (the eye inside or beside the slice; wide perspective views waste
/// their texels at the edges): then the whole-scene views of
/// [`point_frusta_with`] fit better.
pub fn focused_perspective(eye: Vec3, points: &[Vec3], scene: &Aabb, map_size: u32) -> Option<ShadowView> {
    if points.is_empty() {
        return None;
    }
    let centroid = points.iter().copied().sum::<Vec3>() / points.len() as f32;
    let axis = (centroid - eye).try_normalize()?;
    let mut tan_half = 0.0f32;
    let mut far = 0.0f32;
    for &p in points {
        let d = p - eye;
        let along = d.dot(axis);
        let across = (d - axis * along).length();
        if along <= 1e-6 * (1.0 + across) {
            return None;
        }
        tan_half = tan_half.max(across / along);
        far = far.max(along);
    }
    if tan_half.is_nan() || tan_half > 60f32.to_radians().tan() {
        return None;
    }
    // One texel of margin around the cone for filter kernels.
    let fov = 2.0 * (tan_half.max(1e-6) * (1.0 + 2.0 / map_size.max(8) as f32)).atan();
    let far = far * 1.01;
    let diag = scene.diagonal().max(1e-3);
    let box_near = scene.corners().iter().map(|&c| (c - eye).dot(axis)).fold(f32::INFINITY, f32::min);
    let near = (0.99 * box_near).max(NEAR_FRACTION * diag).min(0.5 * far);
    Some(ShadowView::perspective(eye, axis, fov, near, far, map_size))
}

/// A square window holding `[lo, hi]` on a fixed image plane, stabilised against camera motion (the
/// approach of Stingl 2011 §3.5 for cascades, here on each sample's image plane): its width rounded
/// up to eighths of an octave (with two texels of margin a side), its centre snapped to whole
/// texels. Static geometry then keeps its texels while the fitted points move, until the width
/// steps. Returns `(l, r, b, t)`.
pub fn stable_window(lo: Vec2, hi: Vec2, map_size: u32) -> (f32, f32, f32, f32) {
    let size = map_size.max(8) as f32;
    let want = (hi.x - lo.x).max(hi.y - lo.y).max(1e-6) * (1.0 + 4.0 / size);
    let width = ((want.log2() * 8.0).ceil() / 8.0).exp2();
    let texel = width / size;
    let centre = (0.5 * (lo + hi) / texel).round() * texel;
    (centre.x - 0.5 * width, centre.x + 0.5 * width, centre.y - 0.5 * width, centre.y + 0.5 * width)
}

/// [`focused_perspective`] stabilised: the view looks along the direction to the points' centroid
/// rounded to a grid of directions (components in sixteenths, about 4°), so it turns only in rare
/// steps, and the points' window on that fixed image plane is off-axis and texel-snapped
/// ([`stable_window`]). `None` when a point lies beside or behind the eye, or the window reaches
/// more than 60° off the axis (as [`focused_perspective`]'s cone may not).
pub fn focused_perspective_stable(eye: Vec3, points: &[Vec3], scene: &Aabb, map_size: u32) -> Option<ShadowView> {
    if points.is_empty() {
        return None;
    }
    let centroid = points.iter().copied().sum::<Vec3>() / points.len() as f32;
    let axis = ((centroid - eye).try_normalize()? * 16.0).round().try_normalize()?;
    let view = look_along(eye, axis);
    let (mut lo, mut hi, mut far) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY), 0.0f32);
    for &p in points {
        let v = view.transform_point3(p);
        let depth = -v.z;
        if depth <= 1e-6 * (1.0 + v.truncate().length()) {
            return None;
        }
        let s = v.truncate() / depth;
        lo = lo.min(s);
        hi = hi.max(s);
        far = far.max(depth);
    }
    let (l, r, b, t) = stable_window(lo, hi, map_size);
    let reach = l.abs().max(r.abs()).max(b.abs()).max(t.abs());
    if reach.is_nan() || reach > 60f32.to_radians().tan() {
        return None;
    }
    let far = far * 1.01;
    let diag = scene.diagonal().max(1e-3);
    let box_near = scene.corners().iter().map(|&c| (c - eye).dot(axis)).fold(f32::INFINITY, f32::min);
    let near = (0.99 * box_near).max(NEAR_FRACTION * diag).min(0.5 * far);
    Some(ShadowView::off_axis(eye, axis, [l, r, b, t], near, far, map_size))
}

/// An orthographic view along `direction` whose map covers `points` across the light and the whole
/// scene along it (casters anywhere up the light's path).
pub fn focused_directional(direction: Vec3, scene: &Aabb, points: &[Vec3], map_size: u32) -> ShadowView {
    focused_directional_with(direction, scene, points, map_size, false)
}

/// [`focused_directional`] with the window stabilised ([`stable_window`]): the view's frame is
/// fixed by the scene and the direction, so only the window moves, by whole texels.
pub fn focused_directional_stable(direction: Vec3, scene: &Aabb, points: &[Vec3], map_size: u32) -> ShadowView {
    focused_directional_with(direction, scene, points, map_size, true)
}

fn focused_directional_with(direction: Vec3, scene: &Aabb, points: &[Vec3], map_size: u32, stable: bool) -> ShadowView {
    let dir = direction.normalize_or(Vec3::NEG_Y);
    let scene_radius = 0.5 * scene.diagonal().max(1e-3);
    let eye = scene.center() - dir * (scene_radius * 1.1);
    let view = look_along(eye, dir);
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in points.iter().copied().chain(scene.corners()) {
        let v = view.transform_point3(p);
        lo = lo.min(v);
        hi = hi.max(v);
    }
    let (mut across_lo, mut across_hi) = (lo, hi);
    if !points.is_empty() {
        across_lo = Vec3::splat(f32::INFINITY);
        across_hi = Vec3::splat(f32::NEG_INFINITY);
        for &p in points {
            let v = view.transform_point3(p);
            across_lo = across_lo.min(v);
            across_hi = across_hi.max(v);
        }
    }
    let (near, far) = ((-hi.z - 0.01 * scene_radius).max(0.0), -lo.z + 0.01 * scene_radius);
    let side = (across_hi.x - across_lo.x).max(across_hi.y - across_lo.y).max(1e-4);
    let pad = 2.0 * side / map_size.max(8) as f32;
    let (l, r, b, t) = if stable {
        stable_window(across_lo.truncate(), across_hi.truncate(), map_size)
    } else {
        (across_lo.x - pad, across_hi.x + pad, across_lo.y - pad, across_hi.y + pad)
    };
    let projection = orthographic_reversed(l, r, b, t, near, far);
    ShadowView {
        view,
        projection,
        view_projection: projection * view,
        eye,
        axis: dir,
        orthographic: true,
        near,
        far,
        texel_scale: (r - l).max(t - b) / map_size.max(1) as f32,
        linear_depth: None,
    }
}

/// The hard-shadow views of a light's centre (its emitter size ignored): spot lights by their cone,
/// point and rectangle lights by the scene, directional lights fitted to the scene bounds.
pub fn light_frusta(light: &Light, bounds: &Aabb, map_size: u32) -> LightFrusta {
    match light.kind {
        LightKind::Directional { direction, .. } => directional_frustum(direction, bounds, map_size),
        LightKind::Spot { position, direction, outer_angle, .. } => {
            point_frusta(position, bounds, Some((direction, outer_angle)), map_size)
        }
        LightKind::Point { position, .. } => point_frusta(position, bounds, None, map_size),
        LightKind::Rect { position, direction, .. } => {
            // A one-sided emitter lights a hemisphere.
            point_frusta(position, bounds, Some((direction, std::f32::consts::FRAC_PI_2)), map_size)
        }
    }
}

/// A frame around a unit vector, for placing samples around a light's axis.
pub fn frame(axis: Vec3) -> (Vec3, Vec3) {
    orthonormal_basis(axis)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every point of 500 random boxes (a grid of 9³ over each, corners and the light's own
    /// coordinate planes among them) goes to a face the box is said to meet; a box within one
    /// face's pyramid meets that face alone, and the faces claimed for a box straddling the light
    /// are all six. Fails with a face's own component taken at the wrong end of the box, or with
    /// the other axes' largest magnitudes in place of their least.
    #[test]
    fn cube_faces_meeting_holds_every_face_a_boxs_points_take() {
        let mut rng = crate::sampling::Rng::new(7);
        let mut f = || rng.next_f32() * 4.0 - 2.0;
        for _ in 0..500 {
            let eye = Vec3::new(f(), f(), f());
            let (a, b) = (Vec3::new(f(), f(), f()), Vec3::new(f(), f(), f()));
            let bx = Aabb::new(a.min(b), a.max(b));
            let faces = cube_faces_meeting(eye, &bx);
            let mut taken = [false; 6];
            for i in 0..9 {
                for j in 0..9 {
                    for k in 0..9 {
                        let t = Vec3::new(i as f32, j as f32, k as f32) / 8.0;
                        let mut p = bx.min + (bx.max - bx.min) * t;
                        // The light's own coordinates where the box spans them (the point nearest
                        // an axis).
                        for c in 0..3 {
                            if i + j + k == 0 && bx.min[c] <= eye[c] && eye[c] <= bx.max[c] {
                                p[c] = eye[c];
                            }
                        }
                        taken[cube_face(p - eye)] = true;
                    }
                }
            }
            for face in 0..6 {
                assert!(!taken[face] || faces[face], "face {face} taken by a point of {bx:?} from {eye:?}: {faces:?}");
            }
        }
        // Wholly in +X's pyramid, away from its edges.
        let one = Aabb::new(Vec3::new(2.0, -0.5, -0.5), Vec3::new(3.0, 0.5, 0.5));
        assert_eq!(cube_faces_meeting(Vec3::ZERO, &one), [true, false, false, false, false, false]);
        // Below the light, reaching towards +Z but not past the diagonal.
        let below = Aabb::new(Vec3::new(-0.5, -3.0, -0.5), Vec3::new(0.5, -2.0, 1.5));
        assert_eq!(cube_faces_meeting(Vec3::ZERO, &below), [false, false, false, true, false, false]);
        let around = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        assert_eq!(cube_faces_meeting(Vec3::ZERO, &around), [true; 6]);
        assert_eq!(cube_faces_meeting(Vec3::ZERO, &Aabb::EMPTY), [false; 6]);
    }

    #[test]
    fn a_centred_off_axis_window_is_the_symmetric_perspective() {
        let t = 0.7f32;
        let a = off_axis_reversed(-t, t, -t, t, 0.1, 20.0);
        let b = perspective_reversed(2.0 * t.atan(), 1.0, 0.1, 20.0);
        assert!(a.abs_diff_eq(b, 1e-6), "{a:?} vs {b:?}");
    }

    /// Stabilised fitted views move by whole texels and keep their width while the fitted points
    /// move a little: a static point keeps its position within its texel.
    #[test]
    fn stabilised_fitted_views_move_by_whole_texels() {
        let scene = Aabb::new(Vec3::new(-3.0, 0.0, -3.0), Vec3::new(3.0, 2.0, 3.0));
        let slice = |dx: f32| -> Vec<Vec3> {
            [(-1.0, -0.5), (1.2, -0.4), (1.1, 1.3), (-0.9, 1.0)]
                .iter()
                .flat_map(|&(x, z)| [Vec3::new(x + dx, 0.0, z), Vec3::new(x + dx, 1.0, z)])
                .collect()
        };
        let size = 512;
        let stat = Vec3::new(0.3, 0.2, 0.4);
        let eye = Vec3::new(0.5, 3.5, 0.2);
        let views = |dx: f32| {
            (
                focused_perspective_stable(eye, &slice(dx), &scene, size).expect("fits"),
                focused_directional_stable(Vec3::new(0.3, -1.0, 0.2), &scene, &slice(dx), size),
            )
        };
        let (p0, d0) = views(0.0);
        for k in 1..20 {
            let (p, d) = views(0.002 * k as f32);
            for (a, b) in [(&p0, &p), (&d0, &d)] {
                assert_eq!(a.texel_scale, b.texel_scale, "step {k}: the width holds");
                let shift = (b.project(stat) - a.project(stat)).truncate() * size as f32;
                // Whole texels up to f32 round-off of the projection (texel coordinates near 256
                // carry about 3e-5); 2e-3 leaves room, far below the sliding view's > 1e-2 below.
                assert!((shift - shift.round()).abs().max_element() < 2e-3, "step {k}: {shift}");
            }
            // Every fitted point stays on the map.
            for q in slice(0.002 * k as f32) {
                for v in [&p, &d] {
                    let uvz = v.project(q);
                    assert!(uvz.x > 0.0 && uvz.x < 1.0 && uvz.y > 0.0 && uvz.y < 1.0, "{q} → {uvz}");
                }
            }
        }
        // The unstabilised view follows the points continuously: the static point slides.
        let (a, b) = (
            focused_perspective(eye, &slice(0.0), &scene, size).unwrap(),
            focused_perspective(eye, &slice(0.01), &scene, size).unwrap(),
        );
        let shift = (b.project(stat) - a.project(stat)).truncate() * size as f32;
        assert!((shift - shift.round()).abs().max_element() > 1e-2, "{shift}");
    }

    #[test]
    fn reversed_z_maps_near_to_one_far_to_zero() {
        let p = perspective_reversed(1.0, 1.0, 0.5, 100.0);
        let z = |d: f32| {
            let c = p * Vec4::new(0.0, 0.0, -d, 1.0);
            c.z / c.w
        };
        assert!((z(0.5) - 1.0).abs() < 1e-6);
        assert!(z(100.0).abs() < 1e-6);
        assert!(z(1.0) > z(2.0), "closer is larger");
        let o = orthographic_reversed(-1.0, 1.0, -1.0, 1.0, 2.0, 10.0);
        let zo = |d: f32| (o * Vec4::new(0.0, 0.0, -d, 1.0)).z;
        assert!((zo(2.0) - 1.0).abs() < 1e-6 && zo(10.0).abs() < 1e-6);
    }

    #[test]
    fn cube_faces_cover_their_directions() {
        let b = Aabb::new(Vec3::splat(-5.0), Vec3::splat(5.0));
        let f = point_frusta(Vec3::ZERO, &b, None, 512);
        assert!(f.cube && f.views.len() == 6);
        for d in [Vec3::new(1.0, 0.99, -0.99), Vec3::new(-0.2, -3.0, 2.9), Vec3::new(0.1, 0.2, 4.0)] {
            let uvz = f.view_for(d).project(d);
            assert!(uvz.x > 0.0 && uvz.x < 1.0 && uvz.y > 0.0 && uvz.y < 1.0, "{d} → {uvz}");
            assert!(uvz.z > 0.0 && uvz.z < 1.0);
        }
    }

    #[test]
    fn outside_light_gets_one_frustum_covering_the_bounds() {
        let b = Aabb::new(Vec3::new(-2.0, 0.0, -2.0), Vec3::new(2.0, 1.0, 2.0));
        // On the axis and off it: the near plane must not cut the box's corners (depth along the
        // tilted axis can be smaller than the distance to the box).
        for eye in [Vec3::new(0.0, 3.0, 0.0), Vec3::new(0.22, 3.0, 0.22), Vec3::new(0.5, 4.0, -0.3)] {
            let f = point_frusta(eye, &b, Some((-Vec3::Y, std::f32::consts::FRAC_PI_2)), 1024);
            assert!(!f.cube);
            for c in b.corners() {
                let uvz = f.views[0].project(c);
                assert!((0.0..=1.0).contains(&uvz.x) && (0.0..=1.0).contains(&uvz.y), "{eye}: {c} → {uvz}");
                assert!(uvz.z >= 0.0 && uvz.z <= 1.0, "{eye}: {c} → {uvz}");
            }
        }
    }

    #[test]
    fn directional_fit_contains_the_bounds() {
        let b = Aabb::new(Vec3::new(-400.0, -30.0, -400.0), Vec3::new(400.0, 80.0, 400.0));
        let f = directional_frustum(Vec3::new(0.8, -0.5, 0.4), &b, 2048);
        let v = &f.views[0];
        for c in b.corners() {
            let uvz = v.project(c);
            assert!(
                (0.0..=1.0).contains(&uvz.x) && (0.0..=1.0).contains(&uvz.y) && (0.0..=1.0).contains(&uvz.z),
                "{uvz}"
            );
        }
        // A point further along the light direction is deeper (smaller reversed depth).
        let p = Vec3::ZERO;
        assert!(v.project(p).z > v.project(p + 10.0 * Vec3::new(0.8, -0.5, 0.4).normalize()).z);
        assert!((v.texel_size_at(p) - v.texel_scale).abs() < 1e-6);
    }

    #[test]
    fn spot_cone_is_used_when_narrower_than_the_scene() {
        let b = Aabb::new(Vec3::splat(-5.0), Vec3::splat(5.0));
        let f = point_frusta(Vec3::new(0.0, 4.0, 0.0), &b, Some((-Vec3::Y, 0.5)), 256);
        assert!(!f.cube);
        assert!((f.views[0].axis - -Vec3::Y).length() < 1e-6);
        // Texel size grows with distance along the axis.
        let v = &f.views[0];
        assert!(v.texel_size_at(Vec3::new(0.0, -4.0, 0.0)) > 1.9 * v.texel_size_at(Vec3::ZERO));
    }

    #[test]
    fn focused_views_hold_their_points() {
        let scene = Aabb { min: Vec3::new(-5.0, 0.0, -5.0), max: Vec3::new(5.0, 3.0, 5.0) };
        let (centre, radius) = (Vec3::new(1.0, 0.5, -1.0), 1.2);
        let points: Vec<Vec3> = (0..64)
            .map(|k| {
                let a = k as f32 * 0.7;
                centre + radius * Vec3::new(a.cos() * (0.3 * a).cos(), (0.3 * a).sin(), a.sin() * (0.3 * a).cos())
            })
            .collect();
        let eye = Vec3::new(0.2, 2.9, 0.3);
        let v = focused_perspective(eye, &points, &scene, 256).unwrap();
        let dir = Vec3::new(0.3, -1.0, 0.2).normalize();
        let o = focused_directional(dir, &scene, &points, 256);
        for &q in &points {
            for view in [&v, &o] {
                let m = view.project(q);
                assert!(m.x >= 0.0 && m.x <= 1.0 && m.y >= 0.0 && m.y <= 1.0 && m.z >= 0.0 && m.z <= 1.0, "{m}");
            }
        }
        // A caster between the eye and the points is inside the depth range.
        let m = v.project(eye + (centre - eye) * 0.05);
        assert!(m.z <= 1.0 && m.z >= 0.0, "{m}");
        // The sun's view keeps the whole scene along the light: a point above the slice.
        assert!(o.project(centre - dir * 2.0).z <= 1.0);
        // Among the points there is no focused perspective view.
        assert!(focused_perspective(centre, &points, &scene, 256).is_none());
    }
}
