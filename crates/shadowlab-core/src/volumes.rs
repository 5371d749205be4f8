//! Shadow volumes on the CPU: silhouettes from mesh topology and the volume geometry extruded to
//! infinity (Crow 1977; Hasselgren 2003 §2.3, §3.3.2; Toromanoff 2005 alg. B). This is the reference
//! the GPU compute implementation is tested against, and it documents the rules:
//!
//! - **Occluding faces.** A closed mesh occludes with the faces that face the light (their dark
//!   side is hidden inside the solid). An open mesh, or a double-sided one, occludes with *every*
//!   face, each turned to face the light: a sheet of paper casts a shadow whichever side is lit.
//! - **Silhouettes by counting.** Each occluding face walks its edges in its (turned) winding. An
//!   edge's *net* count is the number of walks a→b minus the walks b→a; the edge gets |net| side
//!   quads, oriented by the sign. Edges between two lit faces cancel (not silhouettes); edges of one
//!   lit face, including every boundary edge of an open mesh, are silhouettes; edges shared by more
//!   than two faces contribute per face pair, so non-manifold junctions stay correct.
//! - **Caps.** Z-fail and ZP+ need closed volumes: the occluding faces themselves (light cap) and
//!   the same faces at infinity, reversed (dark cap).
//! - **Infinity.** Extruded vertices have w = 0: the direction away from the light (from the light
//!   position for point lights, the light's direction for directional ones).
//!
//! The result, counted with the signed crossing rule (front faces −1, back faces +1 along a ray
//! towards the viewer, Haines 1994), is positive exactly inside the shadow.

use glam::{Affine3A, Mat4, Vec3, Vec4};

use crate::topology::Topology;

/// Where the light is, for extrusion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightSource {
    Point(Vec3),
    /// The direction the light travels.
    Directional(Vec3),
}

impl LightSource {
    /// Unit direction from `p` towards the light.
    pub fn towards(&self, p: Vec3) -> Vec3 {
        match *self {
            Self::Point(l) => (l - p).normalize_or(Vec3::Y),
            Self::Directional(d) => -d.normalize(),
        }
    }

    /// The homogeneous point at infinity that `p` extrudes to.
    pub fn extrude(&self, p: Vec3) -> Vec4 {
        match *self {
            Self::Point(l) => (p - l).extend(0.0),
            Self::Directional(d) => d.extend(0.0),
        }
    }
}

/// For each face: +1 occludes with its own winding, −1 occludes turned over, 0 does not occlude.
/// Degenerate faces never occlude. `mirrored`: the world positions come from a transform with a
/// negative determinant, which turns every face's winding over.
pub fn face_signs(topo: &Topology, world: &[Vec3], light: &LightSource, two_sided: bool, mirrored: bool) -> Vec<i8> {
    let orientation = if mirrored { -1.0 } else { 1.0 };
    topo.triangles
        .iter()
        .zip(&topo.degenerate)
        .map(|(t, &degenerate)| {
            if degenerate {
                return 0;
            }
            let [a, b, c] = t.map(|i| world[i as usize]);
            let n = (b - a).cross(c - a);
            let facing = orientation * n.dot(light.towards((a + b + c) / 3.0));
            if facing > 0.0 {
                1
            } else if two_sided && facing < 0.0 {
                -1
            } else {
                0
            }
        })
        .collect()
}

/// Whether a point light lies inside the closed mesh `topo` placed at `world` (ray parity, with the
/// watertight test of [`crate::bvh::PreparedRay`]). A one-sided closed caster around the light (a
/// bulb in a box, a lamp in a closed shade) faces away from it everywhere, so by the facing rule it
/// would occlude with no face and cast nothing; its shadow is everything outside it, which the
/// caster's volume gets when it occludes with every face turned towards the light, as open meshes
/// do.
pub fn encloses_light(topo: &Topology, world: &[Vec3], light: &LightSource) -> bool {
    let LightSource::Point(l) = *light else { return false };
    let bounds = crate::Aabb::from_points(world.iter().copied());
    if bounds.is_empty() || !bounds.contains(l) {
        return false;
    }
    // An arbitrary direction unlikely to run along the mesh's edges or faces.
    let dir = Vec3::new(0.5773, 0.5781, 0.5766).normalize();
    let ray = crate::bvh::PreparedRay::new(l, dir, 0.0, f32::INFINITY);
    let hits = topo
        .triangles
        .iter()
        .zip(&topo.degenerate)
        .filter(|(_, d)| !**d)
        .filter(|(t, _)| ray.intersect(&t.map(|i| glam::Vec3A::from(world[i as usize]))).is_some())
        .count();
    hits % 2 == 1
}

/// Silhouette edges as `(a, b, count)`: `count` side quads along the directed welded edge a→b.
pub fn silhouette(topo: &Topology, signs: &[i8]) -> Vec<(u32, u32, u32)> {
    let mut out = Vec::new();
    for (e, edge) in topo.edges.iter().enumerate() {
        let net: i32 = topo
            .edge_uses(e)
            .iter()
            .map(|u| {
                let s = i32::from(signs[u.face as usize]);
                if u.forward { s } else { -s }
            })
            .sum();
        if net > 0 {
            out.push((edge.v[0], edge.v[1], net as u32));
        } else if net < 0 {
            out.push((edge.v[1], edge.v[0], (-net) as u32));
        }
    }
    out
}

/// A shadow volume: homogeneous world-space triangles, outward-facing (w = 0 vertices at infinity).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ShadowVolume {
    pub sides: Vec<[Vec4; 3]>,
    /// Light caps (the occluding faces) and dark caps (them at infinity, reversed).
    pub caps: Vec<[Vec4; 3]>,
}

impl ShadowVolume {
    pub fn triangles(&self) -> impl Iterator<Item = &[Vec4; 3]> {
        self.sides.iter().chain(&self.caps)
    }
}

/// The shadow volume of `mesh` placed by `transform`, for `light`. `two_sided`: the mesh is open or
/// its material double-sided (see the module docs).
pub fn shadow_volume(
    topo: &Topology,
    transform: &Affine3A,
    light: &LightSource,
    two_sided: bool,
    caps: bool,
) -> ShadowVolume {
    let world: Vec<Vec3> = topo.positions.iter().map(|&p| transform.transform_point3(p)).collect();
    // A mirroring transform turns every face over: signs and walks stay in object-space winding,
    // and the world-space geometry built from them is turned back.
    let mirror = transform.matrix3.determinant() < 0.0;
    let two_sided = two_sided || encloses_light(topo, &world, light);
    let signs = face_signs(topo, &world, light, two_sided, mirror);
    let mut v = ShadowVolume::default();
    let fin = |i: u32| world[i as usize].extend(1.0);
    let inf = |i: u32| light.extrude(world[i as usize]);
    for (a, b, count) in silhouette(topo, &signs) {
        let (a, b) = if mirror { (b, a) } else { (a, b) };
        for _ in 0..count {
            // The lit face is on the left of a→b seen from the light; the side faces outward to the
            // right and away from the light: (b, a, a∞) and (b, a∞, b∞).
            v.sides.push([fin(b), fin(a), inf(a)]);
            v.sides.push([fin(b), inf(a), inf(b)]);
        }
    }
    if caps {
        for (f, t) in topo.triangles.iter().enumerate() {
            let s = signs[f] * if mirror { -1 } else { 1 };
            if s == 0 {
                continue;
            }
            let [a, b, c] = if s > 0 { *t } else { [t[0], t[2], t[1]] };
            // The light cap faces the light: outward from the volume means towards the light.
            v.caps.push([fin(a), fin(b), fin(c)]);
            v.caps.push([inf(a), inf(c), inf(b)]);
        }
    }
    v
}

/// Signed crossings of the volume by the ray from `p` towards `dir` (Haines 1994): +1 for every
/// back face crossed, −1 for every front face, so the total is how many volumes enclose `p`. Points
/// at infinity are replaced by points at `far` along their direction (tests use a far bound
/// larger than the scene).
pub fn enclosure_count(volume: &ShadowVolume, p: Vec3, dir: Vec3, far: f32) -> i32 {
    let finite = |v: Vec4| if v.w == 0.0 { v.truncate().normalize() * far } else { v.truncate() / v.w };
    let mut count = 0;
    for t in volume.triangles() {
        let [a, b, c] = t.map(finite);
        let n = (b - a).cross(c - a);
        let denom = n.dot(dir);
        if denom.abs() < 1e-12 {
            continue;
        }
        let s = n.dot(a - p) / denom;
        if s <= 0.0 {
            continue;
        }
        let q = p + dir * s;
        let (e0, e1, e2) = ((b - a).cross(q - a), (c - b).cross(q - b), (a - c).cross(q - c));
        if e0.dot(n) >= 0.0 && e1.dot(n) >= 0.0 && e2.dot(n) >= 0.0 {
            // Leaving through a face whose normal points along the ray: we were inside.
            count += if denom > 0.0 { 1 } else { -1 };
        }
    }
    count
}

impl LightSource {
    /// The source of a light's centre (area lights: their centre; the sun: its direction).
    pub fn of(light: &crate::Light) -> Self {
        match light.kind {
            crate::LightKind::Directional { direction, .. } => Self::Directional(direction),
            _ => Self::Point(light.position().unwrap_or(Vec3::ZERO)),
        }
    }

    /// The source of one emitter sample.
    pub fn of_sample(sample: crate::sampling::EmitterSample) -> Self {
        match sample {
            crate::sampling::EmitterSample::Point(p) => Self::Point(p),
            crate::sampling::EmitterSample::Direction(towards) => Self::Directional(-towards),
        }
    }

    /// `xyz`: position or direction of travel; `w`: 1 for a point, 0 for a direction (as shaders
    /// take it).
    pub fn to_vec4(&self) -> Vec4 {
        match *self {
            Self::Point(p) => p.extend(1.0),
            Self::Directional(d) => d.normalize_or(Vec3::NEG_Y).extend(0.0),
        }
    }
}

/// Signed count of the occluding faces of one caster that the segment from `p` to the light
/// crosses: the number of its shadow volumes that contain `p` (each occluding face's own volume,
/// the infinite frustum behind it, contains exactly the points whose light segment crosses it; the
/// silhouette volume is their sum with the inner sides cancelled). This is the stencil start value
/// at the eye for the robust depth pass (Hasselgren 2003 §3.3.2, NOTES-001 §1.9: "the viewpoint is
/// in shadow if a ray from the viewpoint to the light intersects any polygon").
pub fn crossings(topo: &Topology, transform: &Affine3A, light: &LightSource, two_sided: bool, p: Vec3) -> u32 {
    let world: Vec<Vec3> = topo.positions.iter().map(|&q| transform.transform_point3(q)).collect();
    let mirror = transform.matrix3.determinant() < 0.0;
    let two_sided = two_sided || encloses_light(topo, &world, light);
    let signs = face_signs(topo, &world, light, two_sided, mirror);
    let (dir, len) = match *light {
        LightSource::Point(l) => ((l - p).normalize_or(Vec3::Y), p.distance(l)),
        LightSource::Directional(d) => (-d.normalize_or(Vec3::NEG_Y), f32::INFINITY),
    };
    let mut count = 0;
    for (t, &s) in topo.triangles.iter().zip(&signs) {
        if s == 0 {
            continue;
        }
        let [a, b, c] = t.map(|i| world[i as usize]);
        let (e1, e2) = (b - a, c - a);
        let h = dir.cross(e2);
        let det = e1.dot(h);
        if det.abs() < 1e-12 {
            continue;
        }
        let o = p - a;
        let u = o.dot(h) / det;
        let q = o.cross(e1);
        let v = dir.dot(q) / det;
        let dist = e2.dot(q) / det;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && dist > 0.0 && dist < len {
            count += 1;
        }
    }
    count
}

/// The camera as shadow volumes see it: its view-projection (any perspective projection wgpu
/// accepts, reversed or standard depth, finite or infinite far plane) and the NDC depth of its
/// near plane (1 with reversed Z, 0 with standard Z).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VolumeCamera {
    pub view_proj: Mat4,
    pub eye: Vec3,
    pub near_ndc_depth: f32,
}

/// Volumes are drawn with their own depth mapping, z_ndc = ε + (1 − ε)·w_near / w_clip: reversed,
/// with an infinite far plane at ε instead of 0, so that vertices at infinity (w = 0) rasterise
/// inside the depth range even without depth clamping (Everitt & Kilgard 2002's infinite
/// projection; NOTES-001 §1.4). The surface's depth is converted to the same mapping.
pub const INFINITY_DEPTH: f32 = 1.0 / 1_048_576.0;

impl VolumeCamera {
    /// The clip-space `w` of points on the near plane (the near distance for a standard projection).
    pub fn near_w(&self) -> f32 {
        let corner = self.near_corners()[0];
        self.view_proj.row(3).dot(corner.extend(1.0))
    }

    /// The near-plane rectangle's corners: NDC (−1, −1), (1, −1), (1, 1), (−1, 1).
    pub fn near_corners(&self) -> [Vec3; 4] {
        let inv = self.view_proj.as_dmat4().inverse();
        [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .map(|(x, y)| inv.project_point3(glam::DVec3::new(x, y, f64::from(self.near_ndc_depth))).as_vec3())
    }

    /// The near-plane corners of the NDC rectangle `rect` = [x0, y0, x1, y1] (a part of the image).
    pub fn near_rect(&self, rect: [f32; 4]) -> [Vec3; 4] {
        let inv = self.view_proj.as_dmat4().inverse();
        [(rect[0], rect[1]), (rect[2], rect[1]), (rect[2], rect[3]), (rect[0], rect[3])].map(|(x, y)| {
            let ndc = glam::DVec3::new(f64::from(x), f64::from(y), f64::from(self.near_ndc_depth));
            inv.project_point3(ndc).as_vec3()
        })
    }

    /// Unit normal of the near plane, pointing away from the eye.
    pub fn forward(&self) -> Vec3 {
        self.view_proj.row(3).truncate().normalize_or(Vec3::NEG_Z)
    }

    /// World → clip for volumes: the camera's x, y and w rows, with depth replaced by the infinite
    /// reversed mapping of [`INFINITY_DEPTH`].
    pub fn volume_matrix(&self) -> Mat4 {
        let m = self.view_proj;
        let (r0, r1, r3) = (m.row(0), m.row(1), m.row(3));
        let r2 = INFINITY_DEPTH * r3 + (1.0 - INFINITY_DEPTH) * self.near_w() * Vec4::W;
        Mat4::from_cols(r0, r1, r2, r3).transpose()
    }

    /// The planes (homogeneous, `plane · (x, w) ≥ 0` inside) of the frustum through the NDC
    /// rectangle `rect` = [x0, y0, x1, y1], and the near plane: polygons outside one of them draw
    /// nothing (Hasselgren 2003 §3.3.1.2, NOTES-001 §1.8.2).
    pub fn planes(&self, rect: [f32; 4]) -> [Vec4; 5] {
        let m = self.volume_matrix();
        let (r0, r1, r2, r3) = (m.row(0), m.row(1), m.row(2), m.row(3));
        [r0 - rect[0] * r3, rect[2] * r3 - r0, r1 - rect[1] * r3, rect[3] * r3 - r1, r3 - r2]
    }

    /// A sphere around the pyramid of the eye and the near-plane rectangle (Toromanoff 2005 §VI.2.a:
    /// z-pass fails only where this pyramid meets a volume).
    pub fn near_pyramid_sphere(&self) -> (Vec3, f32) {
        let corners = self.near_corners();
        let centre = (corners.iter().copied().sum::<Vec3>() + self.eye) / 5.0;
        let radius = corners.iter().chain([&self.eye]).map(|c| c.distance(centre)).fold(0.0, f32::max);
        (centre, radius * 1.001 + 1e-6)
    }

    /// Where a sphere lands on screen: the NDC rectangle [x0, y0, x1, y1] that bounds it, or the
    /// whole screen when it reaches the eye's plane, or nothing when it lies behind the near plane
    /// or off screen. The bounds are exact for the whole sphere: NDC x = (r0·p)/(r3·p) over the
    /// ball is extreme where the plane r0·p − x·r3·p = 0 touches it, a quadratic in x (in the
    /// spirit of Mara & McGuire 2013's projected-sphere bounds).
    pub fn sphere_rect(&self, centre: Vec3, radius: f32) -> SphereRect {
        let m = self.view_proj.as_dmat4();
        let (c, r) = (centre.as_dvec3().extend(1.0), f64::from(radius));
        let w = m.row(3);
        let (b, bl) = (w.dot(c), w.truncate().length());
        if b + r * bl <= f64::from(self.near_w()) {
            return SphereRect::Outside;
        }
        // The sphere reaches the eye's plane (w = 0): its image is unbounded.
        if b - r * bl <= 0.0 {
            return SphereRect::Full;
        }
        let bounds = |row: glam::DVec4| {
            let (a, av) = (row.dot(c), row.truncate());
            let bv = w.truncate();
            // (A − tB)² = r²|a − t b|²  →  t²(B² − r²|b|²) − 2t(AB − r² a·b) + (A² − r²|a|²) = 0.
            let qa = b * b - r * r * bv.length_squared();
            let qb = a * b - r * r * av.dot(bv);
            let qc = a * a - r * r * av.length_squared();
            let root = (qb * qb - qa * qc).max(0.0).sqrt();
            ((qb - root) / qa, (qb + root) / qa)
        };
        let (x0, x1) = bounds(m.row(0));
        let (y0, y1) = bounds(m.row(1));
        if x0 >= 1.0 || y0 >= 1.0 || x1 <= -1.0 || y1 <= -1.0 {
            return SphereRect::Outside;
        }
        let clamp = |v: f64| v.clamp(-1.0, 1.0) as f32;
        SphereRect::Rect([clamp(x0), clamp(y0), clamp(x1), clamp(y1)])
    }

    /// Hornus et al. 2005's ZP+ (Toromanoff 2005 alg. 10, NOTES-000 §I): a projection from the
    /// light whose far plane is the camera's near plane and whose image is the camera's image of
    /// that plane, pixel for pixel. Rendering the occluders' light caps with it counts, for every
    /// pixel, the volumes that contain the pixel's point on the near plane: the stencil start value
    /// for z-pass. `None` when the light lies in (or too close to) the near plane, where the
    /// frustum is flat (the known failure: fall back to z-fail). `bounds` holds every occluder.
    pub fn zp_plus(&self, light: &LightSource, bounds: &crate::Aabb) -> Option<ZpPlus> {
        use glam::{DMat4, DVec3, DVec4};
        let corners = self.near_corners().map(|c| c.as_dvec3());
        let centre = corners.iter().copied().sum::<DVec3>() / 4.0;
        let m = self.view_proj.as_dmat4();
        let f = m.row(3).truncate().normalize_or(DVec3::NEG_Z);
        let near_w = m.row(3).dot(corners[0].extend(1.0));
        let (r0, r1) = (m.row(0) / near_w, m.row(1) / near_w);
        // Distance of the eye from the near plane: the length scale for "too close".
        let scale = (centre - self.eye.as_dvec3()).dot(f).abs().max(1e-9);
        let tolerance = f64::from(ZP_PLUS_TOLERANCE);
        match *light {
            LightSource::Point(l) => {
                let l = l.as_dvec3();
                let n_dist = f.dot(centre - l);
                if n_dist.abs() <= tolerance * scale {
                    return None;
                }
                // Relative to the light, x' = x − L: σ = f·x'/n_dist is 0 at the light and 1 on
                // the near plane, and x is seen on the plane at q = L + x'/σ, so σ·ndc(q) is linear
                // in x'.
                let sigma = (f / n_dist).extend(0.0);
                let row = |r: DVec4| r.dot(l.extend(1.0)) * sigma + r.truncate().extend(0.0);
                // Depth (1/σ − 1)·δ/(1 − δ): 0 on the near plane, 1 at σ = δ (just off the light),
                // clipped beyond both. Zero at the plane keeps the clip exact where it matters.
                let delta = 1e-6;
                let z = (DVec4::W - sigma) * (delta / (1.0 - delta));
                let matrix = DMat4::from_cols(row(r0), row(r1), z, sigma).transpose();
                Some(ZpPlus { matrix: matrix.as_mat4(), origin: l.as_vec3() })
            }
            LightSource::Directional(d) => {
                let d = d.as_dvec3().normalize_or(DVec3::NEG_Y);
                let fd = f.dot(d);
                if fd.abs() <= tolerance {
                    return None;
                }
                // Relative to the plane's centre, x' = x − c: x lies t = −f·x'/(f·d) upstream of
                // the plane along the light, and is seen on it at q = x + t·d.
                let t = (-f / fd).extend(0.0);
                let far =
                    bounds.corners().iter().map(|p| t.dot((p.as_dvec3() - centre).extend(1.0))).fold(0.0f64, f64::max)
                        * 1.01
                        + 1e-3;
                let row = |r: DVec4| r.truncate().extend(r.dot(centre.extend(1.0))) + r.truncate().dot(d) * t;
                // Depth t/far: 0 on the near plane, clipped beyond it.
                let z = t / far;
                let matrix = DMat4::from_cols(row(r0), row(r1), z, DVec4::W).transpose();
                Some(ZpPlus { matrix: matrix.as_mat4(), origin: centre.as_vec3() })
            }
        }
    }
}

/// The ZP+ projection: clip = `matrix` · (x − `origin`, 1). Relative coordinates keep the
/// f32 arithmetic of the shader away from cancellation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZpPlus {
    pub matrix: Mat4,
    pub origin: Vec3,
}

/// How close to the near plane the light may come before ZP+ gives up, as a fraction of the near
/// distance (point lights), or as the cosine between the sun and the plane (directional lights).
pub const ZP_PLUS_TOLERANCE: f32 = 1e-2;

/// Where a sphere lands on screen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SphereRect {
    Full,
    Outside,
    /// NDC [x0, y0, x1, y1].
    Rect([f32; 4]),
}

/// Toromanoff's conservative skip test (2005 §VI.2.a, NOTES-000 §I): may the shadow volume of a
/// caster inside the sphere (`centre`, `radius`) touch the sphere (`q`, `rho`)? The volume lies
/// in the cone from a point light tangent to the caster's sphere (a half-cylinder for the sun).
pub fn sphere_volume_touches(light: &LightSource, centre: Vec3, radius: f32, q: Vec3, rho: f32) -> bool {
    if centre.distance(q) <= radius + rho {
        return true;
    }
    match *light {
        LightSource::Point(l) => {
            let axis = centre - l;
            let dist = axis.length();
            if dist <= radius {
                return true;
            }
            let to_q = q - l;
            let dq = to_q.length();
            if dq <= rho {
                return true;
            }
            // The volume starts beyond the caster's near side.
            if to_q.dot(axis / dist) < dist - radius - rho {
                return false;
            }
            let half = (radius / dist).clamp(-1.0, 1.0).asin() + (rho / dq).clamp(-1.0, 1.0).asin();
            let angle = (axis.dot(to_q) / (dist * dq)).clamp(-1.0, 1.0).acos();
            angle <= half
        }
        LightSource::Directional(d) => {
            let d = d.normalize_or(Vec3::NEG_Y);
            let along = (q - centre).dot(d);
            if along < -(radius + rho) {
                return false;
            }
            let across = (q - centre - d * along).length();
            across <= radius + rho
        }
    }
}

/// A tighter skip test for casters whose bounding sphere is a poor fit (walls, floors): may the
/// shadow volume of a caster inside the box `bounds` touch the sphere (`q`, `rho`)? A point x of
/// the sphere is in the volume only if its segment to the light crosses the box; every point of
/// that segment lies within `rho` of the segment from `q` to the light, so the test is whether
/// that segment meets the box grown by `rho`. Conservative, like [`sphere_volume_touches`].
pub fn box_volume_touches(light: &LightSource, bounds: &crate::Aabb, q: Vec3, rho: f32) -> bool {
    let (min, max) = (bounds.min - Vec3::splat(rho), bounds.max + Vec3::splat(rho));
    let (dir, len) = match *light {
        LightSource::Point(l) => (l - q, 1.0),
        LightSource::Directional(d) => (-d.normalize_or(Vec3::NEG_Y), f32::INFINITY),
    };
    // Slab test of q + t·dir, t ∈ [0, len].
    let (mut t0, mut t1) = (0.0f32, len);
    for axis in 0..3 {
        let (o, d) = (q[axis], dir[axis]);
        if d.abs() < 1e-12 {
            if o < min[axis] || o > max[axis] {
                return false;
            }
            continue;
        }
        let (a, b) = ((min[axis] - o) / d, (max[axis] - o) / d);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
        if t0 > t1 {
            return false;
        }
    }
    true
}

/// May the shadow volume of a caster inside the sphere (`centre`, `radius`) reach the inside of
/// a homogeneous plane (`plane · (x, 1) ≥ 0`)? False only when both the sphere and every direction
/// of extrusion lie outside: used to cull whole casters against the view frustum (Policarpo 2001,
/// NOTES-001 §1.5: "cull the SV of each object's bounding volume against the view frustum").
pub fn sphere_volume_reaches_plane(light: &LightSource, centre: Vec3, radius: f32, plane: Vec4) -> bool {
    let n = plane.truncate();
    let len = n.length();
    if len == 0.0 {
        return plane.w >= 0.0;
    }
    if plane.dot(centre.extend(1.0)) >= -radius * len {
        return true;
    }
    match *light {
        LightSource::Point(l) => n.dot(centre - l) + radius * len > 0.0,
        LightSource::Directional(d) => n.dot(d) > 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;
    use crate::primitives;
    use crate::sampling::Rng;

    /// Brute-force truth: does the segment from p to the light hit any triangle of the mesh?
    fn occluded(mesh: &Mesh, t: &Affine3A, light: &LightSource, p: Vec3) -> bool {
        let (dir, len) = match *light {
            LightSource::Point(l) => ((l - p).normalize(), p.distance(l)),
            LightSource::Directional(d) => (-d.normalize(), 1e6),
        };
        mesh.triangles.iter().any(|tri| {
            let [a, b, c] = tri.map(|i| t.transform_point3(mesh.positions[i as usize]));
            let (e1, e2) = (b - a, c - a);
            let h = dir.cross(e2);
            let det = e1.dot(h);
            if det.abs() < 1e-9 {
                return false;
            }
            let s = p - a;
            let u = s.dot(h) / det;
            let q = s.cross(e1);
            let v = dir.dot(q) / det;
            let dist = e2.dot(q) / det;
            u >= 0.0 && v >= 0.0 && u + v <= 1.0 && dist > 1e-4 && dist < len
        })
    }

    /// Random points: the volume's enclosure count says "shadow" exactly where a ray to the light is
    /// blocked, with caps (closed volume) and without (counted from a far-away viewer).
    fn check_against_rays(mesh: &Mesh, t: Affine3A, light: LightSource, two_sided: bool) {
        let topo = Topology::build(mesh);
        let vol = shadow_volume(&topo, &t, &light, two_sided, true);
        let mut rng = Rng::new(42);
        let mut shadowed = 0;
        for i in 0..400 {
            // Half uniform, half just behind the mesh as seen from the light (where shadows are).
            let p = if i % 2 == 0 {
                Vec3::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.5), rng.range(-3.0, 3.0))
            } else {
                let tri =
                    mesh.triangles[(rng.next_f32() * mesh.triangles.len() as f32) as usize % mesh.triangles.len()];
                let [a, b, c] = tri.map(|k| t.transform_point3(mesh.positions[k as usize]));
                let (u, v) = (rng.next_f32(), rng.next_f32());
                let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
                let on = a + (b - a) * u + (c - a) * v;
                let jitter = Vec3::new(rng.range(-0.2, 0.2), rng.range(-0.2, 0.2), rng.range(-0.2, 0.2));
                on - light.towards(on) * rng.range(0.05, 2.5) + jitter
            };
            let truth = occluded(mesh, &t, &light, p);
            // Any ray direction works for a closed volume; pick an irregular one.
            let count = enclosure_count(&vol, p, Vec3::new(0.31, 0.52, -0.79).normalize(), 1e4);
            assert_eq!(count > 0, truth, "point {p}: count {count}, truth {truth}");
            assert!(count >= 0, "negative count {count} at {p}");
            shadowed += truth as usize;
        }
        assert!(shadowed > 20, "the test shadows something: {shadowed}");
    }

    #[test]
    fn cube_volume_matches_rays_for_point_and_directional_lights() {
        let cube = primitives::cuboid(Vec3::ONE);
        let t = Affine3A::from_translation(Vec3::new(0.2, 1.0, -0.1));
        check_against_rays(&cube, t, LightSource::Point(Vec3::new(0.5, 4.0, 0.3)), false);
        check_against_rays(&cube, t, LightSource::Directional(Vec3::new(0.3, -1.0, 0.2)), false);
    }

    #[test]
    fn concave_mesh_volume_self_intersects_but_counts_right() {
        // A torus lying flat: seen from above, overlapping concavities (Hasselgren Fig. 4).
        let torus = primitives::torus(1.0, 0.35, 32, 16);
        let t = Affine3A::from_rotation_translation(glam::Quat::from_rotation_x(0.5), Vec3::new(0.0, 1.2, 0.0));
        check_against_rays(&torus, t, LightSource::Point(Vec3::new(0.3, 5.0, 0.2)), false);
    }

    #[test]
    fn open_and_non_manifold_meshes() {
        // An open plane lit from below still shadows (two-sided occluders).
        let plane = primitives::plane(1.5, 1.5, 3, 3);
        let t = Affine3A::from_translation(Vec3::new(0.0, 1.0, 0.0));
        check_against_rays(&plane, t, LightSource::Point(Vec3::new(0.1, -4.0, 0.2)), true);
        check_against_rays(&plane, t, LightSource::Point(Vec3::new(0.1, 4.0, 0.2)), true);
        // A box with one face missing.
        let mut open_box = primitives::cuboid(Vec3::ONE);
        open_box.triangles.truncate(10);
        check_against_rays(&open_box, t, LightSource::Point(Vec3::new(0.3, 4.0, 0.1)), true);
        // Three faces on one edge.
        let mut fan = Mesh::new("fan");
        fan.positions = vec![
            Vec3::new(-0.5, 0.0, 0.0),
            Vec3::new(0.5, 0.0, 0.0),
            Vec3::new(0.0, 0.8, 0.0),
            Vec3::new(0.0, 0.0, 0.8),
            Vec3::new(0.0, -0.8, 0.3),
        ];
        fan.normals = vec![Vec3::Y; 5];
        fan.triangles = vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]];
        check_against_rays(
            &fan,
            Affine3A::from_translation(Vec3::new(0.0, 1.0, 0.0)),
            LightSource::Point(Vec3::new(0.2, 4.0, 0.9)),
            true,
        );
    }

    #[test]
    fn mirrored_instances_keep_their_volumes() {
        let cube = primitives::cuboid(Vec3::new(1.0, 0.5, 0.7));
        let t = Affine3A::from_scale_rotation_translation(
            Vec3::new(-1.0, 1.0, 1.0),
            glam::Quat::from_rotation_y(0.3),
            Vec3::new(0.0, 1.0, 0.0),
        );
        check_against_rays(&cube, t, LightSource::Point(Vec3::new(0.5, 4.0, 0.3)), false);
    }

    #[test]
    fn cube_silhouettes() {
        let cube = primitives::cuboid(Vec3::ONE);
        let topo = Topology::build(&cube);
        let sil = |l: Vec3| {
            let world: Vec<Vec3> = topo.positions.clone();
            let signs = face_signs(&topo, &world, &LightSource::Point(l), false, false);
            silhouette(&topo, &signs).len()
        };
        assert_eq!(sil(Vec3::new(0.0, 5.0, 0.0)), 4, "straight above: the top square");
        assert_eq!(sil(Vec3::new(5.0, 5.0, 5.0)), 6, "above a corner: a hexagon");
    }

    fn camera() -> VolumeCamera {
        let view = crate::View::new("v", Vec3::new(0.3, 1.2, 4.0), Vec3::new(0.0, 0.5, 0.0), 0.05, 30.0)
            .with_fov_degrees(60.0);
        VolumeCamera { view_proj: view.projection(1.5) * view.view_matrix(), eye: view.position, near_ndc_depth: 1.0 }
    }

    #[test]
    fn volume_matrix_keeps_the_image_and_maps_depth_to_near_and_infinity() {
        let cam = camera();
        let m = cam.volume_matrix();
        for c in cam.near_corners() {
            let a = cam.view_proj * c.extend(1.0);
            let b = m * c.extend(1.0);
            assert!((a.truncate().truncate() / a.w - b.truncate().truncate() / b.w).length() < 1e-4);
            // Measured error 1e-7; margin for f32 round-off of the inverse.
            assert!((b.z / b.w - 1.0).abs() < 1e-4, "near plane at depth 1: {}", b.z / b.w);
        }
        let inf = m * Vec4::new(-0.1, -0.2, -1.0, 0.0);
        assert!((inf.z / inf.w - INFINITY_DEPTH).abs() < 1e-9);
        let near_w = cam.near_w();
        assert!((near_w - 0.05).abs() < 1e-4, "near w is the near distance: {near_w}");
    }

    #[test]
    fn zp_plus_projects_through_the_near_plane_pixel_for_pixel() {
        let cam = camera();
        let bounds = crate::Aabb::new(Vec3::splat(-20.0), Vec3::splat(20.0));
        let corners = cam.near_corners();
        let mut rng = Rng::new(3);
        let ndc = |m: Mat4, p: Vec3| {
            let c = m * p.extend(1.0);
            (Vec3::new(c.x, c.y, c.z) / c.w, c.w)
        };
        for light in [
            LightSource::Point(Vec3::new(1.0, 3.0, -1.0)),
            LightSource::Point(Vec3::new(0.5, 1.8, 5.0)),
            LightSource::Directional(Vec3::new(0.3, -1.0, -0.4)),
            LightSource::Directional(Vec3::new(0.1, -0.3, 0.9)),
        ] {
            let zp = cam.zp_plus(&light, &bounds).expect("light off the near plane");
            for _ in 0..200 {
                let (u, v) = (rng.next_f32(), rng.next_f32());
                let q = corners[0] + (corners[1] - corners[0]) * u + (corners[3] - corners[0]) * v;
                let (at_q, _) = ndc(cam.view_proj, q);
                let before = match light {
                    // Not too close to the light: there, f32 round-off of the point itself is magnified
                    // by the projection onto the plane (as it is for the volume's sides).
                    LightSource::Point(l) => l + (q - l) * rng.range(0.2, 0.99),
                    LightSource::Directional(d) => q - d.normalize() * rng.range(0.01, 8.0),
                };
                let (p, w) = ndc(zp.matrix, before - zp.origin);
                assert!(w > 0.0, "in front of the light");
                // Measured below 1e-5 NDC (f32 round-off); 1e-4 NDC is 0.013 pixel at 256 pixels.
                assert!((p.truncate() - at_q.truncate()).length() < 1e-4, "{light:?}: {p} vs {at_q}");
                assert!((0.0..=1.0).contains(&p.z), "between the light and the plane: depth {}", p.z);
                let beyond = match light {
                    LightSource::Point(l) => l + (q - l) * 1.05,
                    LightSource::Directional(d) => q + d.normalize() * 0.05,
                };
                let (p, _) = ndc(zp.matrix, beyond - zp.origin);
                assert!(p.z < 0.0, "beyond the near plane is clipped: {}", p.z);
            }
        }
        // The light in the near plane: the known failure, detected.
        let in_plane = (corners[0] + corners[2]) / 2.0 + (corners[1] - corners[0]) * 3.0;
        assert!(cam.zp_plus(&LightSource::Point(in_plane), &bounds).is_none());
        let along = corners[1] - corners[0];
        assert!(cam.zp_plus(&LightSource::Directional(along), &bounds).is_none());
    }

    #[test]
    fn crossings_count_the_volumes_around_a_point() {
        let torus = primitives::torus(1.0, 0.35, 24, 12);
        let t = Affine3A::from_rotation_translation(glam::Quat::from_rotation_x(0.5), Vec3::new(0.0, 1.2, 0.0));
        let topo = Topology::build(&torus);
        let light = LightSource::Point(Vec3::new(0.3, 5.0, 0.2));
        let vol = shadow_volume(&topo, &t, &light, false, true);
        let mut rng = Rng::new(9);
        let mut inside = 0;
        for _ in 0..300 {
            let p = Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 1.0), rng.range(-2.0, 2.0));
            let count = enclosure_count(&vol, p, Vec3::new(0.31, 0.52, -0.79).normalize(), 1e4);
            assert_eq!(crossings(&topo, &t, &light, false, p) as i32, count, "at {p}");
            inside += (count > 0) as usize;
        }
        assert!(inside > 30, "points inside volumes were tested: {inside}");
    }

    #[test]
    fn skip_test_is_conservative() {
        let cube = primitives::cuboid(Vec3::ONE);
        let topo = Topology::build(&cube);
        let t = Affine3A::from_translation(Vec3::new(0.0, 1.0, 0.0));
        let (centre, radius) = (Vec3::new(0.0, 1.0, 0.0), 3f32.sqrt() * 0.5);
        let mut rng = Rng::new(5);
        let (mut touched, mut skipped, mut box_skipped) = (0, 0, 0);
        for light in [LightSource::Point(Vec3::new(0.4, 4.0, 0.2)), LightSource::Directional(Vec3::new(0.3, -1.0, 0.1))]
        {
            for _ in 0..300 {
                let q = Vec3::new(rng.range(-4.0, 4.0), rng.range(-3.0, 3.0), rng.range(-4.0, 4.0));
                let rho = rng.range(0.05, 0.6);
                let hit = (0..40).any(|_| {
                    let o = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
                    crossings(&topo, &t, &light, false, q + o.clamp_length_max(1.0) * rho) > 0
                });
                let test = sphere_volume_touches(&light, centre, radius, q, rho);
                assert!(!hit || test, "{light:?}: a sphere at {q} ({rho}) touches the volume but the test skips it");
                let boxed = box_volume_touches(
                    &light,
                    &crate::Aabb::new(Vec3::new(-0.5, 0.5, -0.5), Vec3::new(0.5, 1.5, 0.5)),
                    q,
                    rho,
                );
                assert!(!hit || boxed, "{light:?}: the box test skips a sphere at {q} ({rho}) that touches the volume");
                box_skipped += (!boxed) as usize;
                touched += hit as usize;
                skipped += (!test) as usize;
            }
        }
        assert!(touched > 20 && skipped > 100, "both outcomes occur: {touched} touched, {skipped} skipped");
        assert!(box_skipped > 100, "the box test skips too: {box_skipped}");
    }

    #[test]
    fn sphere_rect_bounds_the_sphere() {
        let cam = camera();
        let mut rng = Rng::new(2);
        let centre = Vec3::new(0.5, 0.3, -1.0);
        let SphereRect::Rect(r) = cam.sphere_rect(centre, 0.4) else { panic!("a sphere in view") };
        for _ in 0..200 {
            let p = centre
                + Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).clamp_length_max(1.0)
                    * 0.4;
            let c = cam.view_proj * p.extend(1.0);
            let (x, y) = (c.x / c.w, c.y / c.w);
            assert!(
                x >= r[0] - 1e-5 && x <= r[2] + 1e-5 && y >= r[1] - 1e-5 && y <= r[3] + 1e-5
                    || x.abs() > 1.0
                    || y.abs() > 1.0
            );
        }
        // Tight: the extreme points found by sampling come within 1% of the rectangle's sides.
        let mut seen = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
        for _ in 0..20000 {
            let d = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).normalize();
            let c = cam.view_proj * (centre + d * 0.4).extend(1.0);
            seen = [seen[0].min(c.x / c.w), seen[1].min(c.y / c.w), seen[2].max(c.x / c.w), seen[3].max(c.y / c.w)];
        }
        for k in 0..4 {
            assert!((seen[k] - r[k]).abs() < 0.01 * (r[2] - r[0]), "side {k}: seen {} vs {}", seen[k], r[k]);
        }
        assert_eq!(cam.sphere_rect(cam.eye, 0.5), SphereRect::Full);
        assert_eq!(cam.sphere_rect(cam.eye - cam.forward() * 10.0, 0.5), SphereRect::Outside);
    }
}
