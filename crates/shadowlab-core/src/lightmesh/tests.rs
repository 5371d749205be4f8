use glam::{Affine3A, Vec3};

use super::file::{self, LightMeshFileError};
use super::*;
use crate::light::LightKind;
use crate::material::Material;
use crate::primitives::{cuboid, plane, sphere};
use crate::sampling::Rng;

/// A floor, a box and a low sphere over it, one point light: small enough for brute-force checks.
fn small_scene() -> Scene {
    let mut s = Scene::new("light mesh test");
    let m = s.add_material(Material::default());
    let floor = s.add_mesh(plane(6.0, 6.0, 3, 3));
    let cube = s.add_mesh(cuboid(Vec3::ONE));
    let ball = s.add_mesh(sphere(0.4, 10, 6));
    s.add_instance(Instance::new("floor", floor, m, Affine3A::IDENTITY));
    s.add_instance(Instance::new("box", cube, m, Affine3A::from_translation(Vec3::new(0.3, 0.5, -0.2))));
    s.add_instance(Instance::new("ball", ball, m, Affine3A::from_translation(Vec3::new(-1.2, 1.5, 0.9))));
    s.add_light(Light::new(
        "lamp",
        LightKind::Point { position: Vec3::new(0.7, 3.0, 0.4), radius: 0.0 },
        Vec3::ONE,
        10.0,
    ));
    s
}

fn point_in_triangle(p: Vec3, [a, b, c]: [Vec3; 3]) -> bool {
    let n = (b - a).cross(c - a);
    if n.length_squared() == 0.0 || ((p - a).dot(n) / n.length()).abs() > 1e-4 {
        return false;
    }
    [(a, b), (b, c), (c, a)].iter().all(|&(u, v)| (v - u).cross(p - u).dot(n) >= 0.0)
}

/// Random points on the static receivers facing the light, with their normals.
fn receiver_samples(scene: &Scene, light: &Light, count: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut tris = Vec::new();
    for inst in scene.instances.iter().filter(|i| is_static(i)) {
        let mesh = scene.mesh(inst.mesh);
        for t in 0..mesh.triangle_count() {
            let c = mesh.corners(t).map(|p| inst.transform.transform_point3(p));
            let n = (c[1] - c[0]).cross(c[2] - c[0]);
            if light.is_relevant(c.iter().sum::<Vec3>() / 3.0, n.normalize_or_zero()) {
                tris.push((c, n.length()));
            }
        }
    }
    let total: f32 = tris.iter().map(|t| t.1).sum();
    let mut rng = Rng::new(seed);
    (0..count)
        .map(|_| {
            let mut x = rng.next_f32() * total;
            let (c, _) = tris
                .iter()
                .find(|t| {
                    x -= t.1;
                    x <= 0.0
                })
                .copied()
                .unwrap_or(tris[tris.len() - 1]);
            let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            (c[0] + (c[1] - c[0]) * u + (c[2] - c[0]) * v, (c[1] - c[0]).cross(c[2] - c[0]).normalize())
        })
        .collect()
}

/// The light mesh covers exactly the lit receiver points: every point of a light-mesh triangle at
/// least `edge` from its sides (its centre, and points towards its corners) sees the light, and every sampled receiver
/// point that sees the light lies in the light mesh, except within `edge` of a shadow boundary.
fn check_against_rays(scene: &Scene, index: usize, samples: usize, edge: f32) -> (usize, usize) {
    let casters = static_casters(scene);
    let light = &scene.lights[index];
    let (lm, stats) = build(scene, index, &casters).unwrap();
    assert_eq!(stats.triangles, lm.triangle_count());
    let diagonal = scene.bounds().diagonal();
    for t in 0..lm.triangle_count() {
        let c = lm.corners(t);
        let n = (c[1] - c[0]).cross(c[2] - c[0]).normalize();
        let centre = (c[0] + c[1] + c[2]) / 3.0;
        let from_sides = |p: Vec3| {
            [(c[0], c[1]), (c[1], c[2]), (c[2], c[0])]
                .iter()
                .map(|&(a, b)| (p - a).cross((b - a).normalize()).length())
                .fold(f32::INFINITY, f32::min)
        };
        let points = c.iter().flat_map(|&q| [0.5, 0.9, 0.99].map(|k| centre + (q - centre) * k)).chain([centre]);
        for p in points.filter(|&p| from_sides(p) >= edge) {
            assert!(point_lit(p, n, light, &casters, diagonal), "light-mesh triangle {t} has a shadowed point {p}");
        }
    }
    let mut lit = 0;
    let mut missed = 0;
    for (p, n) in receiver_samples(scene, light, samples, 7) {
        if !point_lit(p, n, light, &casters, diagonal) {
            continue;
        }
        lit += 1;
        let covered = (0..lm.triangle_count()).any(|t| point_in_triangle(p, lm.corners(t)));
        // A miss is allowed only next to a shadow boundary: some point within `edge` is dark.
        if !covered {
            let near_edge = [Vec3::X, -Vec3::X, Vec3::Z, -Vec3::Z, Vec3::Y, -Vec3::Y]
                .iter()
                .map(|d| (*d - n * d.dot(n)).normalize_or_zero())
                .any(|d| !point_lit(p + d * edge, n, light, &casters, diagonal));
            assert!(near_edge, "lit point {p} is not in the light mesh");
            missed += 1;
        }
    }
    (lit, missed)
}

#[test]
fn small_scene_light_mesh_is_exactly_the_lit_part() {
    let scene = small_scene();
    let (lit, missed) = check_against_rays(&scene, 0, 3000, 1e-3);
    assert!(lit > 1000, "the test must see lit points: {lit}");
    // Misses only at boundaries (each checked above); 3000 random points land within 1 mm of an
    // edge with probability ~1e-3 each.
    assert!(missed <= 5, "{missed} lit points outside the light mesh");
}

#[test]
fn columns_light_meshes_match_the_rays() {
    let scene = crate::scenes::build("columns").unwrap();
    for index in 0..scene.lights.len() {
        let (lit, missed) = check_against_rays(&scene, index, 400, 2e-3);
        // Measured: 142, 138, 112, 82 lit samples of 400 and no miss on the four lamps. Bounds: at
        // least 50 lit (the test must see light), at most 2 misses (each already checked to lie
        // within 2 mm of a shadow edge).
        assert!(lit > 50, "light {index}: {lit} lit samples");
        assert!(missed <= 2, "light {index}: {missed} lit points outside the light mesh");
    }
}

#[test]
fn cutting_preserves_area_and_leaves_no_t_junctions() {
    let scene = small_scene();
    let light = &scene.lights[0];
    let casters = static_casters(&scene);
    let (lm, stats) = build(&scene, 0, &casters).unwrap();
    assert!(stats.pieces > stats.receiver_triangles, "the box and ball cut the floor: {stats:?}");
    assert!(stats.lit_pieces < stats.pieces, "some pieces are shadowed");
    // The lit area equals the relevant receiver area minus the shadowed part; estimated by the
    // fraction of random receiver points that see the light (3000 samples: ±2 % at 1σ ≈ 0.9 %).
    let samples = receiver_samples(&scene, light, 3000, 11);
    let diagonal = scene.bounds().diagonal();
    let lit_frac = samples.iter().filter(|(p, n)| point_lit(*p, *n, light, &casters, diagonal)).count() as f64 / 3000.0;
    let relevant: f64 = scene
        .instances
        .iter()
        .flat_map(|inst| {
            let mesh = scene.mesh(inst.mesh);
            (0..mesh.triangle_count()).map(move |t| mesh.corners(t).map(|p| inst.transform.transform_point3(p)))
        })
        .filter(|c| {
            let n = (c[1] - c[0]).cross(c[2] - c[0]);
            light.is_relevant(c.iter().sum::<Vec3>() / 3.0, n.normalize_or_zero())
        })
        .map(|c| f64::from((c[1] - c[0]).cross(c[2] - c[0]).length()) / 2.0)
        .sum();
    let ratio = lm.area() / (relevant * lit_frac);
    assert!((ratio - 1.0).abs() < 0.03, "light-mesh area / sampled lit area = {ratio}");

    // No T-junctions: no vertex of an instance's light-mesh triangles lies strictly inside an edge
    // of another (objects that merely touch, a box on the floor, are not one mesh).
    let mut bad = 0;
    for t in 0..lm.triangle_count() {
        let c = lm.corners(t);
        let own: Vec<Vec3> = (0..lm.triangle_count())
            .filter(|&u| lm.instances[u] == lm.instances[t])
            .flat_map(|u| lm.corners(u))
            .collect();
        for (a, b) in [(c[0], c[1]), (c[1], c[2]), (c[2], c[0])] {
            for &p in &own {
                let s = (p - a).dot(b - a) / (b - a).length_squared();
                if s > 1e-4 && s < 1.0 - 1e-4 && (a + (b - a) * s).distance(p) < 1e-6 {
                    bad += 1;
                }
            }
        }
    }
    assert_eq!(bad, 0, "T-junctions in the light mesh");
}

#[test]
fn directional_and_dynamic_lights() {
    let mut scene = small_scene();
    scene.lights[0].kind =
        LightKind::Directional { direction: Vec3::new(0.3, -1.0, 0.2).normalize(), angular_radius: 0.0 };
    let (lit, missed) = check_against_rays(&scene, 0, 2000, 1e-3);
    // At least 500 of 2000 samples lit so that the test sees light; misses only next to edges
    // (each checked above), at most 4 (~1e-3 per sample within 1 mm of an edge).
    assert!(lit > 500 && missed <= 4, "{lit} lit, {missed} missed");
    scene.lights[0].mobility = Mobility::Dynamic;
    let casters = static_casters(&scene);
    assert!(matches!(build(&scene, 0, &casters), Err(LightMeshError::NotStatic { .. })));
    assert_eq!(build(&scene, 3, &casters).unwrap_err(), LightMeshError::NoSuchLight(3));
}

#[test]
fn dynamic_objects_are_neither_cut_nor_casting() {
    let mut scene = small_scene();
    let casters = static_casters(&scene);
    let (all_static, _) = build(&scene, 0, &casters).unwrap();
    scene.instances[1].mobility = Mobility::Dynamic;
    let casters = static_casters(&scene);
    let (lm, _) = build(&scene, 0, &casters).unwrap();
    assert!(lm.instances.iter().all(|&i| i != 1), "the dynamic box is not a receiver");
    assert!(lm.area() > all_static.area(), "without the box's shadow more of the floor is lit");
}

#[test]
fn file_round_trips_and_refuses_stale_or_damaged_files() {
    let scene = small_scene();
    let casters = static_casters(&scene);
    let (lm, _) = build(&scene, 0, &casters).unwrap();
    let bytes = file::encode(&scene, std::slice::from_ref(&lm));
    let back = file::decode(&bytes, &scene).unwrap();
    assert_eq!(back.meshes, vec![lm.clone()]);
    assert!(back.stale.is_empty());

    // Every single flipped byte is caught (magic, version, hash or checksum).
    for at in (0..bytes.len()).step_by(97).chain([8, bytes.len() - 1]) {
        let mut bad = bytes.clone();
        bad[at] ^= 0x5a;
        assert!(file::decode(&bad, &scene).is_err(), "flipped byte {at} accepted");
    }
    // Truncated.
    assert!(matches!(file::decode(&bytes[..bytes.len() / 2], &scene), Err(LightMeshFileError::Corrupt(_))));
    assert!(matches!(file::decode(b"glTF", &scene), Err(LightMeshFileError::NotALightMeshFile)));
    // Another version (with a valid checksum, so the version is what is refused).
    let mut old = bytes[..bytes.len() - 8].to_vec();
    old[8..12].copy_from_slice(&0u32.to_le_bytes());
    let mut h = file::Fnv::default();
    h.bytes(&old);
    old.extend_from_slice(&h.finish().to_le_bytes());
    assert!(matches!(file::decode(&old, &scene), Err(LightMeshFileError::Version { found: 0, .. })));
    // Another scene: the static part moved.
    let mut moved = scene.clone();
    moved.instances[1].transform = Affine3A::from_translation(Vec3::new(0.4, 0.5, -0.2));
    assert!(matches!(file::decode(&bytes, &moved), Err(LightMeshFileError::OtherScene)));
    // A dynamic object moving does not make it stale; the light moving does (for that light).
    let mut edited = scene.clone();
    edited.instances[2].mobility = Mobility::Dynamic;
    assert!(
        matches!(file::decode(&bytes, &edited), Err(LightMeshFileError::OtherScene)),
        "mobility is part of the static part"
    );
    let mut lamp = scene.clone();
    lamp.lights[0].translate(|p| p + Vec3::X);
    let d = file::decode(&bytes, &lamp).unwrap();
    assert!(d.meshes.is_empty());
    assert_eq!(d.stale, vec![0]);
    // Colour and intensity are not part of a light mesh.
    // A soft light mesh round-trips with its visibility.
    let (soft, _) = build_with(&scene, 0, &casters, Mode::Soft(Penumbra::Half)).unwrap();
    let back = file::decode(&file::encode(&scene, std::slice::from_ref(&soft)), &scene).unwrap();
    assert_eq!(back.meshes, vec![soft]);
    let mut tinted = scene.clone();
    tinted.lights[0].color = Vec3::new(1.0, 0.5, 0.2);
    assert_eq!(file::decode(&bytes, &tinted).unwrap().meshes.len(), 1);
}

/// A plate (1 × 3 m) 1 m above a floor under a sphere light of radius 0.3 m, 3 m up: a straight
/// shadow edge along z near x = 0.75 with a penumbra 0.3 m wide (similar triangles:
/// 2·r·(d_receiver − d_plate)/d_plate = 0.6·1/2).
fn plate_scene() -> Scene {
    let mut s = Scene::new("plate");
    let m = s.add_material(Material::default());
    let floor = s.add_mesh(plane(8.0, 8.0, 8, 8));
    let plate = s.add_mesh(cuboid(Vec3::new(1.0, 0.02, 3.0)));
    s.add_instance(Instance::new("floor", floor, m, Affine3A::IDENTITY));
    s.add_instance(Instance::new("plate", plate, m, Affine3A::from_translation(Vec3::new(0.0, 1.0, 0.0))));
    s.add_light(Light::new(
        "bulb",
        LightKind::Point { position: Vec3::new(0.0, 3.0, 0.0), radius: 0.3 },
        Vec3::ONE,
        10.0,
    ));
    s
}

/// V of the light mesh at floor point `p` (barycentric over the triangle containing it), or 0 off it.
fn mesh_visibility(lm: &LightMesh, p: Vec3) -> f32 {
    for t in 0..lm.triangle_count() {
        let c = lm.corners(t);
        if point_in_triangle(p, c) {
            let n = (c[1] - c[0]).cross(c[2] - c[0]);
            let w = [(c[1] - p).cross(c[2] - p), (c[2] - p).cross(c[0] - p), (c[0] - p).cross(c[1] - p)]
                .map(|x| x.dot(n) / n.length_squared());
            let v = lm.triangles[t].map(|i| if lm.visibility.is_empty() { 1.0 } else { lm.visibility[i as usize] });
            return w[0] * v[0] + w[1] * v[1] + w[2] * v[2];
        }
    }
    0.0
}

/// The truth at `p` for a sphere light: the fraction of its disk facing `p` that `p` sees
/// (DESIGN.md §3), on a 24 × 24 polar grid.
fn disk_visibility(p: Vec3, light: Vec3, r: f32, casters: &SceneBvh, diagonal: f32) -> f32 {
    let w = (light - p).normalize();
    let u = w.any_orthonormal_vector();
    let v = w.cross(u);
    let (mut seen, n) = (0, 24);
    for i in 0..n {
        for j in 0..n {
            let rho = r * ((i as f32 + 0.5) / n as f32).sqrt();
            let phi = std::f32::consts::TAU * (j as f32 + 0.5) / n as f32;
            let q = light + (u * phi.cos() + v * phi.sin()) * rho;
            let origin = p + Vec3::Y * crate::bvh::ray_epsilon(p, diagonal);
            let d = q - origin;
            let ray = PreparedRay::new(origin, d.normalize(), 0.0, d.length());
            seen += usize::from(casters.unoccluded(&ray));
        }
    }
    seen as f32 / (n * n) as f32
}

/// The penumbra's width across the plate's edge at x = 0.5 (z = 0.2): 4 ∫ min(V, 1 − V) dx, the
/// width of a linear ramp.
fn penumbra_width(v: impl Fn(Vec3) -> f32) -> f32 {
    let (x0, x1, n) = (0.5f32, 1.6f32, 440);
    let dx = (x1 - x0) / n as f32;
    (0..n).map(|i| v(Vec3::new(x0 + (i as f32 + 0.5) * dx, 0.0, 0.2))).map(|v| v.min(1.0 - v).max(0.0)).sum::<f32>()
        * 4.0
        * dx
}

#[test]
fn fake_soft_shadows_are_bounded_and_their_penumbrae_measured() {
    let scene = plate_scene();
    let casters = static_casters(&scene);
    let diagonal = scene.bounds().diagonal();
    let light = Vec3::new(0.0, 3.0, 0.0);
    let truth = penumbra_width(|p| disk_visibility(p, light, 0.3, &casters, diagonal));
    let (full, _) = build_with(&scene, 0, &casters, Mode::Soft(Penumbra::Full)).unwrap();
    let (half, _) = build_with(&scene, 0, &casters, Mode::Soft(Penumbra::Half)).unwrap();
    let (hard, _) = build(&scene, 0, &casters).unwrap();
    for lm in [&full, &half] {
        assert_eq!(lm.visibility.len(), lm.positions.len());
        assert!(lm.visibility.iter().all(|v| (0.0..=1.0).contains(v)), "V in [0, 1]");
        assert!(lm.visibility.iter().any(|&v| v > 0.05 && v < 0.95), "a penumbra exists");
    }
    let w_full = penumbra_width(|p| mesh_visibility(&full, p));
    let w_half = penumbra_width(|p| mesh_visibility(&half, p));
    println!("penumbra width: truth {truth:.4} m, full wedges {w_full:.4} m, half {w_half:.4} m");
    // The geometric 0.3 m, measured on a disk's S-shaped profile (steeper than a ramp in its middle):
    // 0.268 m; bound ±0.02 m.
    assert!((truth - 0.268).abs() < 0.02, "truth {truth}");
    // Linear wedges, their light points perpendicular to the light's direction at the silhouette:
    // measured full/truth 0.89 and half/truth 0.48 (Hasselgren: "the penumbrae are half the size");
    // bounds 0.75–1.05 and 0.4–0.6.
    let (full_ratio, half_ratio) = (w_full / truth, w_half / truth);
    assert!((0.75..=1.05).contains(&full_ratio), "full wedges {w_full} vs truth {truth}");
    assert!((0.4..=0.6).contains(&half_ratio), "half wedges {w_half} vs truth {truth}");

    // Outside the wedges V is 1 wherever the point sees the light's centre; the half penumbra lies
    // outside the hard shadow, so it never lights a point the hard light mesh leaves dark.
    let mut rng = Rng::new(5);
    let mut checked = 0;
    for _ in 0..3000 {
        let p = Vec3::new(rng.next_f32() * 8.0 - 4.0, 0.0, rng.next_f32() * 8.0 - 4.0);
        let (vh, vs) = (mesh_visibility(&hard, p), mesh_visibility(&half, p));
        assert!(vs <= vh + 1e-4, "half penumbra lights {p} ({vs}) where the hard mesh is dark ({vh})");
        if disk_visibility(p, light, 0.3, &casters, diagonal) == 1.0 && vh == 1.0 {
            checked += 1;
            let vf = mesh_visibility(&full, p);
            assert!(vf > 0.999 || vs > 0.999, "fully lit {p}: full {vf}, half {vs}");
        }
    }
    // Most of the 8 × 8 m floor is fully lit (the plate's shadow covers ~3 m²): the check must see
    // more than a third of its 3000 samples.
    assert!(checked > 1000, "{checked} fully lit samples");
}
