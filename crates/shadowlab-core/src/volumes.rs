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

use glam::{Affine3A, Vec3, Vec4};

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
}
