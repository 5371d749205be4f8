//! Emissive panels as lights: an instance whose material emits (an OBJ's `Ke`, a glTF's emissive
//! factor, a scene file's `emissive`) and whose mesh is one planar rectangle becomes a `rect` light
//! over it, facing the way its triangles face, so that the Cornell box is lit by its ceiling panel
//! rather than by a default sun. The panel then casts no shadow: it is the light.

use glam::Vec3;

use crate::light::{Light, LightKind};
use crate::scene::Scene;

/// Relative tolerance for "planar" and "rectangular" (of the panel's size).
const TOLERANCE: f32 = 1e-3;

/// Turns every emissive rectangle of `scene` into a rect light; returns warnings for emissive
/// instances that are not one rectangle (left as they are). A second call adds nothing.
pub fn lights_from_emissive(scene: &mut Scene) -> Vec<String> {
    let mut warnings = Vec::new();
    for i in 0..scene.instances.len() {
        let inst = &scene.instances[i];
        let Some(material) = scene.materials.get(inst.material.index()) else { continue };
        let emissive = material.emissive;
        let peak = emissive.max_element();
        if peak.is_nan() || peak <= 0.0 {
            continue;
        }
        let name = format!("{} (emissive)", inst.name);
        if scene.lights.iter().any(|l| l.name == name) {
            continue;
        }
        let Some(mesh) = scene.meshes.get(inst.mesh.index()) else { continue };
        // The distinct corners, by position: loaders split vertices where normals or UVs differ.
        // Only two triangles can make a rectangle: a larger emitter is not searched (the search
        // is quadratic in its vertices: a 1024-segment emissive sphere took minutes).
        let mut corners: Vec<Vec3> = Vec::new();
        let two = if mesh.triangles.len() == 2 { &mesh.triangles[..] } else { &[] };
        for &v in two.iter().flatten() {
            let Some(&p) = mesh.positions.get(v as usize) else { continue };
            let p = inst.transform.transform_point3(p);
            if !corners.iter().any(|c| (*c - p).length_squared() <= 1e-12 * (1.0 + p.length_squared())) {
                corners.push(p);
            }
        }
        let Some((centre, normal, tangent, width, height)) =
            rectangle(&corners, &mesh.triangles, &mesh.positions, inst.transform)
        else {
            warnings.push(format!(
                "'{}' emits light but is not one planar rectangle ({} triangles): not made a light",
                inst.name,
                mesh.triangles.len()
            ));
            continue;
        };
        // Radiance × area: the panel's intensity on its axis (the lights' inverse-square falloff).
        let light = Light::new(
            name,
            LightKind::Rect { position: centre, direction: normal, tangent, width, height },
            emissive / peak,
            peak * width * height,
        );
        scene.add_light(light);
        scene.instances[i].casts_shadows = false;
    }
    warnings
}

/// The rectangle spanned by four corners (centre, facing normal from the first triangle's winding,
/// tangent along one side, width and height), if they are one.
fn rectangle(
    corners: &[Vec3],
    triangles: &[[u32; 3]],
    positions: &[Vec3],
    transform: glam::Affine3A,
) -> Option<(Vec3, Vec3, Vec3, f32, f32)> {
    if corners.len() != 4 || triangles.len() != 2 {
        return None;
    }
    let [a, b, c] = triangles[0].map(|v| positions.get(v as usize).map(|&p| transform.transform_point3(p)));
    let (a, b, c) = (a?, b?, c?);
    let normal = (b - a).cross(c - a).normalize_or_zero();
    let centre = corners.iter().copied().sum::<Vec3>() / 4.0;
    let size = corners.iter().map(|p| (*p - centre).length()).fold(0.0f32, f32::max);
    if normal == Vec3::ZERO
        || size.is_nan()
        || size <= 0.0
        || corners.iter().any(|p| (*p - centre).dot(normal).abs() > TOLERANCE * size)
    {
        return None;
    }
    // The corners in turn around the centre, then two sides from the first.
    let u = (corners[0] - centre).normalize();
    let v = normal.cross(u);
    let mut sorted = corners.to_vec();
    sorted.sort_by(|p, q| {
        let angle = |x: &Vec3| (*x - centre).dot(v).atan2((*x - centre).dot(u));
        angle(p).total_cmp(&angle(q))
    });
    let (e1, e2) = (sorted[1] - sorted[0], sorted[3] - sorted[0]);
    let (w, h) = (e1.length(), e2.length());
    let square = e1.dot(e2).abs() <= TOLERANCE * w * h;
    let closes = (sorted[0] + e1 + e2 - sorted[2]).length() <= TOLERANCE * size;
    if !(w > 0.0 && h > 0.0 && square && closes) {
        return None;
    }
    Some((centre, normal, e1 / w, w, h))
}

#[cfg(test)]
mod tests {
    use glam::Affine3A;

    use super::*;
    use crate::material::Material;
    use crate::mesh::Mesh;
    use crate::scene::Instance;

    fn scene_with(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>, emissive: Vec3) -> Scene {
        let mut scene = Scene::new("t");
        // Flat normals split every corner per face: the panel is still found by its positions.
        let mesh = scene.add_mesh(Mesh::with_computed_normals("panel", &positions, &triangles, 0.0));
        let material = scene.add_material(Material { emissive, ..Material::default() });
        scene.add_instance(Instance::new(
            "panel",
            mesh,
            material,
            Affine3A::from_translation(Vec3::new(0.0, 2.0, 0.0)),
        ));
        scene
    }

    #[test]
    fn an_emissive_quad_becomes_a_rect_light_facing_its_front() {
        // Wound so that the front faces −y (a ceiling panel), 0.4 × 0.2 m.
        let quad = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.2),
            Vec3::new(0.4, 0.0, 0.2),
            Vec3::new(0.4, 0.0, 0.0),
        ];
        let mut scene = scene_with(quad.clone(), vec![[0, 2, 1], [0, 3, 2]], Vec3::new(10.0, 5.0, 0.0));
        assert!(lights_from_emissive(&mut scene).is_empty());
        assert_eq!(scene.lights.len(), 1);
        let l = &scene.lights[0];
        match l.kind {
            LightKind::Rect { position, direction, width, height, .. } => {
                // Exact but for f32 round-off of sums of metre-sized coordinates (1e-5: ~100 ulps).
                assert!((position - Vec3::new(0.2, 2.0, 0.1)).length() < 1e-5, "{position}");
                assert!((direction - Vec3::NEG_Y).length() < 1e-5, "{direction}");
                let (a, b) = (width.max(height), width.min(height));
                assert!((a - 0.4).abs() < 1e-5 && (b - 0.2).abs() < 1e-5, "{width} × {height}");
            }
            ref k => panic!("{k:?}"),
        }
        assert_eq!(l.color, Vec3::new(1.0, 0.5, 0.0));
        // Radiance 10 over 0.08 m².
        assert!((l.intensity - 0.8).abs() < 1e-5, "{}", l.intensity);
        assert!(!scene.instances[0].casts_shadows, "the panel is the light");
        scene.validate().unwrap();
        // Idempotent.
        assert!(lights_from_emissive(&mut scene).is_empty());
        assert_eq!(scene.lights.len(), 1);
        // Not emissive, not a rectangle, not planar: no light.
        let mut dark = scene_with(quad.clone(), vec![[0, 2, 1], [0, 3, 2]], Vec3::ZERO);
        lights_from_emissive(&mut dark);
        assert!(dark.lights.is_empty());
        let kite = vec![Vec3::ZERO, Vec3::new(0.1, 0.0, 0.3), Vec3::new(0.4, 0.0, 0.2), Vec3::new(0.4, 0.0, 0.0)];
        let mut odd = scene_with(kite, vec![[0, 2, 1], [0, 3, 2]], Vec3::ONE);
        assert_eq!(lights_from_emissive(&mut odd).len(), 1, "warned");
        assert!(odd.lights.is_empty());
        let bent = vec![Vec3::ZERO, Vec3::new(0.0, 0.0, 0.2), Vec3::new(0.4, 0.1, 0.2), Vec3::new(0.4, 0.0, 0.0)];
        let mut bent = scene_with(bent, vec![[0, 2, 1], [0, 3, 2]], Vec3::ONE);
        assert_eq!(lights_from_emissive(&mut bent).len(), 1);
        assert!(bent.lights.is_empty() && bent.instances[0].casts_shadows);
    }
}
