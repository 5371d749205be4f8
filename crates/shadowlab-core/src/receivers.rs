//! Large planar receivers: the flat parts of floors, walls and ceilings that receiver light maps
//! cover (Toromanoff 2005 §F–H, NOTES-000: a visibility texture per light in the receiver's own
//! plane, at "object resolution").
//!
//! A receiver's world-space triangles are grouped by plane (same unit normal, same offset); every
//! group of at least a given area becomes a [`Patch`]: the rectangle of that plane that covers the
//! group, with an orthonormal frame along whichever of the group's edge directions gives the
//! smallest rectangle, so that boxes and walls get tight rectangles.

use glam::Vec3;

use crate::scene::{Instance, Role, Scene};

/// A flat, rectangular part of a receiver: its plane, frame and extent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Patch {
    /// Index of the instance in `Scene::instances`.
    pub instance: usize,
    /// Unit normal of the receiving side (the side the triangles face).
    pub normal: Vec3,
    /// `normal · p` of the plane's points.
    pub offset: f32,
    /// The rectangle's corner: it spans `origin + u·axis_u + v·axis_v` for u in [0, width], v in
    /// [0, height].
    pub origin: Vec3,
    pub axis_u: Vec3,
    pub axis_v: Vec3,
    pub width: f32,
    pub height: f32,
    /// Area of the triangles in the patch.
    pub area: f32,
}

impl Patch {
    /// The world position of rectangle coordinates `(u, v)`.
    pub fn point(&self, u: f32, v: f32) -> Vec3 {
        self.origin + self.axis_u * u + self.axis_v * v
    }

    /// The rectangle's four corners.
    pub fn corners(&self) -> [Vec3; 4] {
        [
            self.point(0.0, 0.0),
            self.point(self.width, 0.0),
            self.point(0.0, self.height),
            self.point(self.width, self.height),
        ]
    }
}

/// Whether an instance receives light maps: its role says it is a receiver, or its mesh is flat
/// (one plane) and at least `min_area` large. Decided without the instance's translation (about
/// its own origin), so that moving an instance never changes it ([`PatchCache`] keeps it through
/// a drag).
pub fn is_receiver(scene: &Scene, inst: &Instance, min_area: f32) -> bool {
    if !inst.receives_shadows {
        return false;
    }
    if inst.role == Some(Role::Receiver) {
        return true;
    }
    let about_origin = glam::Affine3A { matrix3: inst.transform.matrix3, translation: glam::Vec3A::ZERO };
    let patches = patches_under(scene, inst, &about_origin, 0, 0.0);
    patches.len() == 1 && patches[0].area >= min_area && {
        let mesh = scene.mesh(inst.mesh);
        let total: f32 = (0..mesh.triangle_count())
            .map(|t| {
                let [a, b, c] = mesh.corners(t).map(|p| about_origin.transform_point3(p));
                0.5 * (b - a).cross(c - a).length()
            })
            .sum();
        patches[0].area >= 0.99 * total
    }
}

/// The patches of every receiver of the scene, planes of at least `min_area` m² each.
pub fn planar_patches(scene: &Scene, min_area: f32) -> Vec<Patch> {
    scene
        .instances
        .iter()
        .enumerate()
        .filter(|(_, inst)| is_receiver(scene, inst, min_area))
        .flat_map(|(i, inst)| instance_patches(scene, inst, i, min_area))
        .collect()
}

/// [`planar_patches`] kept per instance across calls: an instance's patches are found again only
/// when what they depend on changed (its mesh, transform, role, whether it receives shadows) or
/// `min_area` did. A drag moves one object; the others' patches stay (finding them walks every
/// triangle, for every light, in every frame the scene changed).
#[derive(Debug, Clone, Default)]
pub struct PatchCache {
    min_area: f32,
    /// Per instance index: what the patches were found for, whether it is a receiver, and the
    /// patches (`instance` fields are rewritten on the way out, so an index shift after a removal
    /// only costs a recompute).
    entries: Vec<Option<(PatchKey, bool, Vec<Patch>)>>,
}

#[derive(Debug, Clone, PartialEq)]
struct PatchKey {
    mesh: crate::scene::MeshId,
    transform: glam::Affine3A,
    role: Option<Role>,
    receives_shadows: bool,
}

impl PatchCache {
    /// The same patches as `planar_patches(scene, min_area)`, in the same order.
    pub fn patches(&mut self, scene: &Scene, min_area: f32) -> Vec<Patch> {
        if self.min_area.to_bits() != min_area.to_bits() {
            self.entries.clear();
            self.min_area = min_area;
        }
        self.entries.resize(scene.instances.len(), None);
        let mut out = Vec::new();
        for (i, inst) in scene.instances.iter().enumerate() {
            let key = PatchKey {
                mesh: inst.mesh,
                transform: inst.transform,
                role: inst.role,
                receives_shadows: inst.receives_shadows,
            };
            let entry = &mut self.entries[i];
            if entry.as_ref().is_none_or(|(k, _, _)| *k != key) {
                // A move alone (a drag step) keeps whether it is a receiver: a dragged chair,
                // which is none, costs nothing here.
                let receiver = match entry {
                    Some((k, receiver, _))
                        if (k.mesh, k.transform.matrix3, k.role, k.receives_shadows)
                            == (key.mesh, key.transform.matrix3, key.role, key.receives_shadows) =>
                    {
                        *receiver
                    }
                    _ => is_receiver(scene, inst, min_area),
                };
                let patches = if receiver { instance_patches(scene, inst, i, min_area) } else { Vec::new() };
                *entry = Some((key, receiver, patches));
            }
            let (_, _, patches) = entry.as_ref().expect("filled above");
            out.extend(patches.iter().map(|p| Patch { instance: i, ..*p }));
        }
        out
    }
}

/// The planes of one instance with at least `min_area` of triangles.
pub fn instance_patches(scene: &Scene, inst: &Instance, index: usize, min_area: f32) -> Vec<Patch> {
    patches_under(scene, inst, &inst.transform, index, min_area)
}

/// [`instance_patches`] with the instance's mesh placed by `transform`.
fn patches_under(
    scene: &Scene,
    inst: &Instance,
    transform: &glam::Affine3A,
    index: usize,
    min_area: f32,
) -> Vec<Patch> {
    let Some(mesh) = scene.meshes.get(inst.mesh.index()) else { return Vec::new() };
    let bounds = mesh.bounds().transformed(transform);
    let tolerance = 1e-5 * bounds.diagonal().max(1e-3);
    struct Group {
        normal: Vec3,
        offset: f32,
        area: f32,
        points: Vec<Vec3>,
        /// Distinct edge directions (up to a few hundred), candidates for the rectangle's axis.
        edges: Vec<Vec3>,
    }
    let mut groups: Vec<Group> = Vec::new();
    let mut planes: std::collections::HashMap<(i32, i32, i32, i64), usize> = std::collections::HashMap::new();
    for t in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.corners(t).map(|p| transform.transform_point3(p));
        let cross = (b - a).cross(c - a);
        let area = 0.5 * cross.length();
        if area.is_nan() || area <= 0.0 || !area.is_finite() {
            continue;
        }
        let mut normal = cross.normalize();
        if transform.matrix3.determinant() < 0.0 {
            normal = -normal;
        }
        let offset = normal.dot(a);
        // Planes are found by their quantised normal and offset (a hash, so that curved meshes with
        // a plane per triangle stay linear in time).
        let key = (
            (normal.x * 1e4).round() as i32,
            (normal.y * 1e4).round() as i32,
            (normal.z * 1e4).round() as i32,
            (offset / (4.0 * tolerance)).round() as i64,
        );
        let k = *planes.entry(key).or_insert_with(|| {
            groups.push(Group { normal, offset, area: 0.0, points: Vec::new(), edges: Vec::new() });
            groups.len() - 1
        });
        let g = &mut groups[k];
        g.area += area;
        g.points.extend([a, b, c]);
        for e in [b - a, c - b, a - c] {
            let e = (e - g.normal * e.dot(g.normal)).normalize_or_zero();
            if e != Vec3::ZERO && g.edges.len() < 256 && !g.edges.iter().any(|d| d.dot(e).abs() > 1.0 - 1e-5) {
                g.edges.push(e);
            }
        }
    }
    groups
        .into_iter()
        .filter(|g| g.area >= min_area && g.area > 0.0)
        .map(|g| {
            let extent = |axis_u: Vec3| {
                let axis_v = g.normal.cross(axis_u);
                let (mut lo, mut hi) = ((f32::MAX, f32::MAX), (f32::MIN, f32::MIN));
                for p in &g.points {
                    let (u, v) = (p.dot(axis_u), p.dot(axis_v));
                    lo = (lo.0.min(u), lo.1.min(v));
                    hi = (hi.0.max(u), hi.1.max(v));
                }
                (axis_u, axis_v, lo, hi)
            };
            let area = |e: &(Vec3, Vec3, (f32, f32), (f32, f32))| (e.3.0 - e.2.0) * (e.3.1 - e.2.1);
            let candidates = if g.edges.is_empty() { vec![g.normal.any_orthonormal_vector()] } else { g.edges.clone() };
            let (axis_u, axis_v, lo, hi) = candidates
                .into_iter()
                .map(extent)
                .min_by(|x, y| area(x).total_cmp(&area(y)))
                .expect("at least one candidate");
            let origin = g.normal * g.offset + axis_u * lo.0 + axis_v * lo.1;
            Patch {
                instance: index,
                normal: g.normal,
                offset: g.offset,
                origin,
                axis_u,
                axis_v,
                width: hi.0 - lo.0,
                height: hi.1 - lo.1,
                area: g.area,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Quat};

    use super::*;
    use crate::{Material, primitives};

    /// The cache gives what `planar_patches` gives, after moves, a role change, a removal and a
    /// new `min_area`, and recomputes nothing when nothing changed.
    #[test]
    fn cached_patches_equal_fresh_ones_after_every_change() {
        let mut scene = crate::load_scene("room").expect("room").scene;
        let mut cache = PatchCache::default();
        let check = |cache: &mut PatchCache, scene: &Scene, min_area: f32, what: &str| {
            assert_eq!(cache.patches(scene, min_area), planar_patches(scene, min_area), "after {what}");
        };
        check(&mut cache, &scene, 1.0, "the first call");
        let floor = scene.instances.iter().position(|i| i.role == Some(Role::Receiver)).expect("a receiver");
        scene.instances[floor].transform =
            Affine3A::from_translation(Vec3::new(0.3, 0.0, -0.2)) * scene.instances[floor].transform;
        check(&mut cache, &scene, 1.0, "moving a receiver");
        scene.instances[floor].role = None;
        check(&mut cache, &scene, 1.0, "a role change");
        scene.instances[floor].receives_shadows = false;
        check(&mut cache, &scene, 1.0, "no longer receiving");
        scene.instances.remove(0);
        check(&mut cache, &scene, 1.0, "a removal");
        check(&mut cache, &scene, 0.25, "a smaller minimum area");
        // Unchanged: every entry is kept as it is.
        let before = cache.entries.clone();
        let _ = cache.patches(&scene, 0.25);
        assert_eq!(format!("{:?}", cache.entries), format!("{before:?}"));
    }

    /// A move keeps whether an instance is a receiver (a drag step decides nothing again), and
    /// what changes it is still seen: a tile scaled past the minimum area becomes one, and one
    /// moved far from the origin stays one.
    #[test]
    fn only_a_change_of_shape_decides_again_whether_an_instance_receives() {
        let mut s = Scene::new("t");
        let tile = s.add_mesh(primitives::plane(0.5, 0.5, 1, 1));
        let mat = s.add_material(Material::default());
        s.add_instance(Instance::new("tile", tile, mat, Affine3A::IDENTITY));
        let ball = s.add_mesh(primitives::sphere(1.0, 16, 8));
        s.add_instance(Instance::new("ball", ball, mat, Affine3A::IDENTITY));
        let mut cache = PatchCache::default();
        let mut check = |s: &Scene, receivers: usize, what: &str| {
            let patches = cache.patches(s, 1.0);
            assert_eq!(patches, planar_patches(s, 1.0), "after {what}");
            assert_eq!(patches.len(), receivers, "after {what}: {patches:?}");
        };
        check(&s, 0, "the first call (0.25 m² is too small, a ball is not flat)");
        s.instances[1].transform = Affine3A::from_translation(Vec3::new(2.0, 0.0, 1.0));
        check(&s, 0, "moving the ball");
        s.instances[0].transform = Affine3A::from_scale(Vec3::new(3.0, 1.0, 3.0));
        check(&s, 1, "scaling the tile to 2.25 m²");
        s.instances[0].transform = Affine3A::from_translation(Vec3::new(1e4, 3.0, -2e4)) * s.instances[0].transform;
        check(&s, 1, "moving the tile 22 km away");
        s.instances[0].transform = Affine3A::from_translation(Vec3::new(1e4, 3.0, -2e4));
        check(&s, 0, "scaling it back");
    }

    #[test]
    fn a_box_floor_has_its_large_faces_as_patches() {
        let mut s = Scene::new("t");
        let m = s.add_mesh(primitives::cuboid_between(Vec3::new(-2.0, -0.1, -1.5), Vec3::new(2.0, 0.0, 1.5)));
        let mat = s.add_material(Material::default());
        s.add_instance(Instance::new("floor", m, mat, Affine3A::IDENTITY)).with_role(Role::Receiver);
        let patches = planar_patches(&s, 1.0);
        // Top and bottom (4 × 3 m²); the sides are 0.4 m² and 0.3 m².
        assert_eq!(patches.len(), 2, "{patches:?}");
        let top = patches.iter().find(|p| p.normal.y > 0.5).expect("the top");
        assert!((top.offset - 0.0).abs() < 1e-6 && (top.area - 12.0).abs() < 1e-4);
        assert!((top.width * top.height - 12.0).abs() < 1e-3, "a tight rectangle: {top:?}");
        for c in top.corners() {
            assert!(c.y.abs() < 1e-6 && c.x.abs() <= 2.0 + 1e-5 && c.z.abs() <= 1.5 + 1e-5, "{c}");
        }
    }

    #[test]
    fn a_turned_card_is_a_receiver_by_being_flat_and_large() {
        let mut s = Scene::new("t");
        let m = s.add_mesh(primitives::plane(2.0, 1.0, 4, 2));
        let mat = s.add_material(Material::default());
        let t = Affine3A::from_rotation_translation(Quat::from_rotation_x(0.7), Vec3::new(1.0, 2.0, 3.0));
        s.add_instance(Instance::new("card", m, mat, t));
        let small = s.add_mesh(primitives::plane(0.5, 0.5, 1, 1));
        s.add_instance(Instance::new("tile", small, mat, Affine3A::IDENTITY));
        let ball = s.add_mesh(primitives::sphere(1.0, 16, 8));
        s.add_instance(Instance::new("ball", ball, mat, Affine3A::IDENTITY));
        let patches = planar_patches(&s, 1.0);
        assert_eq!(patches.len(), 1, "the card only (the tile is 0.25 m², the ball not flat)");
        let p = patches[0];
        assert!((p.area - 2.0).abs() < 1e-4 && (p.width * p.height - 2.0).abs() < 1e-3, "{p:?}");
        assert!((p.normal - t.transform_vector3(Vec3::Y)).length() < 1e-5);
    }
}
