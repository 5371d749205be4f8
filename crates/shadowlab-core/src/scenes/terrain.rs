//! `terrain`: Stingl-style outdoor scene (Stingl 2011, §2 and §5: a large terrain with trees and
//! buildings under a directional light, seen from the ground over a long view distance). It is
//! where uniform shadow maps fail: perspective aliasing near the viewer, wasted texels far away,
//! and the duelling-frusta view that looks into the light.
//!
//! An 800 × 800 m heightfield, ~1500 instanced trees, 100 instanced cabins (a village and scattered
//! ones) and a 60 m lattice tower.

use glam::{Affine3A, Quat, Vec2, Vec3};

use crate::camera::View;
use crate::light::{Light, LightKind};
use crate::material::Material;
use crate::params::{ParamDef, ParamSet};
use crate::primitives::{beam, cone, cuboid_between, cylinder, heightfield, prism};
use crate::sampling::Rng;
use crate::scene::{Instance, MeshId, Role, Scene};

use super::{Builder, combine};

pub const SUMMARY: &str = "800 m terrain with 1500 trees, 100 cabins and a lattice tower under a directional light";

pub static OPTIONS: &[ParamDef] = &[
    ParamDef::float("sun", 0.0, 0.0, 5.0, "angular radius of the sun in degrees (0: hard shadows; the real sun: 0.27)"),
    ParamDef::int("trees", 1500, 0, 20_000, "number of trees"),
    ParamDef::int("grid", 256, 16, 1024, "heightfield quads per side (2·grid² triangles)"),
];

const SIZE: f32 = 800.0;
const VILLAGE: Vec2 = Vec2::new(60.0, 40.0);
const VILLAGE_RADIUS: f32 = 70.0;
const TOWER: Vec2 = Vec2::new(-120.0, -60.0);
/// Direction the sunlight travels: from the south-west-ish, 30° above the horizon.
const SUN_ELEVATION_DEG: f32 = 30.0;
const SUN_AZIMUTH: Vec2 = Vec2::new(0.866, 0.5);

/// The heightfield: smooth fractal noise, flattened around the village.
struct Ground {
    n: u32,
    heights: Vec<f32>,
}

impl Ground {
    fn new(n: u32) -> Self {
        let mut heights = Vec::with_capacity(((n + 1) * (n + 1)) as usize);
        for k in 0..=n {
            for i in 0..=n {
                let (x, z) = (SIZE * (i as f32 / n as f32 - 0.5), SIZE * (k as f32 / n as f32 - 0.5));
                heights.push(analytic_height(x, z));
            }
        }
        Self { n, heights }
    }

    /// Height of the triangulated surface itself (not the smooth function), so that objects and
    /// cameras sit exactly on what is drawn. Matches the diagonal of [`heightfield`].
    fn height(&self, x: f32, z: f32) -> f32 {
        let cell = SIZE / self.n as f32;
        let fx = ((x + 0.5 * SIZE) / cell).clamp(0.0, self.n as f32 - 1e-3);
        let fz = ((z + 0.5 * SIZE) / cell).clamp(0.0, self.n as f32 - 1e-3);
        let (i, k) = (fx.floor() as u32, fz.floor() as u32);
        let (u, v) = (fx - i as f32, fz - k as f32);
        let h = |di: u32, dk: u32| self.heights[((k + dk) * (self.n + 1) + i + di) as usize];
        let (ha, hb, hc, hd) = (h(0, 0), h(1, 0), h(1, 1), h(0, 1));
        if u >= v { ha + (hb - ha) * u + (hc - hb) * v } else { ha + (hd - ha) * v + (hc - hd) * u }
    }
}

fn analytic_height(x: f32, z: f32) -> f32 {
    let mut h = 0.0;
    let (mut amp, mut freq) = (30.0, 1.0 / 260.0);
    for octave in 0..5 {
        h += amp * (2.0 * value_noise(x * freq, z * freq, octave) - 1.0);
        amp *= 0.45;
        freq *= 2.1;
    }
    // Flatten the village site towards a level plateau.
    let d = Vec2::new(x, z).distance(VILLAGE) / VILLAGE_RADIUS;
    let w = (1.0 - d).clamp(0.0, 1.0);
    let w = w * w * (3.0 - 2.0 * w);
    h * (1.0 - w) + 4.0 * w
}

/// Value noise on the integer lattice with quintic smoothing (Perlin 2002's fade curve).
fn value_noise(x: f32, z: f32, octave: u32) -> f32 {
    let (xi, zi) = (x.floor(), z.floor());
    let (fx, fz) = (x - xi, z - zi);
    let fade = |t: f32| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let lattice = |a: f32, b: f32| {
        let mut r = Rng::for_stream(
            u64::from(octave) + 0x007E_44A1,
            ((a as i64 as u64) << 32) ^ (b as i64 as u64 & 0xFFFF_FFFF),
        );
        r.next_f32()
    };
    let (u, v) = (fade(fx), fade(fz));
    let a = lattice(xi, zi) + (lattice(xi + 1.0, zi) - lattice(xi, zi)) * u;
    let b = lattice(xi, zi + 1.0) + (lattice(xi + 1.0, zi + 1.0) - lattice(xi, zi + 1.0)) * u;
    a + (b - a) * v
}

pub fn sun_direction() -> Vec3 {
    let e = SUN_ELEVATION_DEG.to_radians();
    let h = SUN_AZIMUTH.normalize() * e.cos();
    Vec3::new(h.x, -e.sin(), h.y).normalize()
}

pub fn build(options: &ParamSet) -> Scene {
    let n = options.int("grid") as u32;
    let ground = Ground::new(n);
    let mut b = Builder::new("terrain");
    let grass = b.material(Material::diffuse("grass", Vec3::new(0.3, 0.42, 0.18)));
    let bark = b.material(Material::diffuse("bark", Vec3::new(0.33, 0.23, 0.14)));
    let needles = b.material(Material::diffuse("needles", Vec3::new(0.12, 0.3, 0.12)));
    let timber = b.material(Material::diffuse("timber", Vec3::new(0.55, 0.4, 0.28)));
    let roof = b.material(Material::diffuse("roof", Vec3::new(0.45, 0.17, 0.12)).with_specular(0.1, 20.0));
    let steel = b.material(Material::diffuse("steel", Vec3::new(0.42, 0.43, 0.45)).with_specular(0.4, 60.0));

    // Same grid formula as `Ground::new`, so mesh vertices and `Ground::height` agree exactly.
    let terrain = heightfield(SIZE, SIZE, n, n, analytic_height);
    b.object("terrain", terrain, grass, Affine3A::IDENTITY).with_role(Role::Receiver);

    // Cabins: walls sunk 1 m into the ground (slopes), a gable roof overlapping the walls' top.
    let walls =
        b.scene.add_mesh(named(cuboid_between(Vec3::new(-3.0, -1.0, -2.25), Vec3::new(3.0, 3.0, 2.25)), "cabin walls"));
    let roof_mesh = b.scene.add_mesh(named(
        {
            let mut m = crate::mesh::Mesh::new("roof");
            m.append(&prism(6.6, 2.2, 5.0), &Affine3A::from_translation(Vec3::new(0.0, 2.95, 0.0)));
            m
        },
        "cabin roof",
    ));
    let mut rng = Rng::new(0x007E_22A1_u64);
    let mut cabins: Vec<Vec2> = Vec::new();
    let mut tries = 0;
    while cabins.len() < 100 && tries < 100_000 {
        tries += 1;
        let in_village = cabins.len() < 60;
        let p = if in_village {
            let a = rng.range(0.0, std::f32::consts::TAU);
            VILLAGE + Vec2::new(a.cos(), a.sin()) * VILLAGE_RADIUS * 0.8 * rng.next_f32().sqrt()
        } else {
            Vec2::new(rng.range(-380.0, 380.0), rng.range(-380.0, 380.0))
        };
        // A cabin's half-diagonal is 3.75 m: 9 m apart they never touch, whatever their turn.
        let spacing = if in_village { 9.0 } else { 40.0 };
        if cabins.iter().any(|c| c.distance(p) < spacing) || p.distance(TOWER) < 25.0 {
            continue;
        }
        cabins.push(p);
    }
    for (i, p) in cabins.iter().enumerate() {
        let t = Affine3A::from_rotation_translation(
            Quat::from_rotation_y(rng.range(0.0, std::f32::consts::TAU)),
            Vec3::new(p.x, ground.height(p.x, p.y), p.y),
        );
        instance(&mut b.scene, &format!("cabin {i}"), walls, timber, t);
        instance(&mut b.scene, &format!("cabin {i} roof"), roof_mesh, roof, t);
    }

    // Trees: trunk and crown, away from cabins, the village square and the tower.
    let trunk = b.scene.add_mesh(named(cylinder(0.25, 3.5, 10), "trunk"));
    let crown = b.scene.add_mesh(named(
        {
            let mut m = crate::mesh::Mesh::new("crown");
            m.append(&cone(2.2, 8.0, 14), &Affine3A::from_translation(Vec3::new(0.0, 2.5, 0.0)));
            m
        },
        "crown",
    ));
    let want = options.int("trees") as usize;
    let mut placed = 0;
    let mut tries = 0;
    while placed < want && tries < want * 50 + 100 {
        tries += 1;
        let p = Vec2::new(rng.range(-395.0, 395.0), rng.range(-395.0, 395.0));
        if p.distance(VILLAGE) < 25.0 || p.distance(TOWER) < 15.0 || cabins.iter().any(|c| c.distance(p) < 7.0) {
            continue;
        }
        let s = rng.range(0.7, 1.4);
        let t = Affine3A::from_scale_rotation_translation(
            Vec3::splat(s),
            Quat::from_rotation_y(rng.range(0.0, std::f32::consts::TAU)),
            Vec3::new(p.x, ground.height(p.x, p.y) - 0.3, p.y),
        );
        instance(&mut b.scene, &format!("tree {placed}"), trunk, bark, t);
        instance(&mut b.scene, &format!("tree {placed} crown"), crown, needles, t);
        placed += 1;
    }

    // A 60 m lattice tower: four posts, a ring of beams and X-braces on every face each 4 m.
    let base = Vec3::new(TOWER.x, ground.height(TOWER.x, TOWER.y) - 1.0, TOWER.y);
    let (half, top) = (3.0, 61.0);
    let corner = |k: usize, y: f32| {
        let (sx, sz) = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)][k];
        // The posts lean in: 3 m half-width at the base, 1.5 m at the top.
        let w = half * (1.0 - 0.5 * y / top);
        Vec3::new(sx * w, y, sz * w)
    };
    let mut parts = Vec::new();
    for k in 0..4 {
        parts.push((beam(corner(k, 0.0), corner(k, top), 0.35), Affine3A::IDENTITY));
    }
    let levels = 15;
    for l in 0..levels {
        let (y0, y1) = (1.0 + 4.0 * l as f32, 1.0 + 4.0 * (l + 1) as f32);
        for k in 0..4 {
            let n = (k + 1) % 4;
            parts.push((beam(corner(k, y1), corner(n, y1), 0.18), Affine3A::IDENTITY));
            parts.push((beam(corner(k, y0), corner(n, y1), 0.12), Affine3A::IDENTITY));
            parts.push((beam(corner(n, y0), corner(k, y1), 0.12), Affine3A::IDENTITY));
        }
    }
    b.object("tower", combine(parts), steel, Affine3A::from_translation(base)).with_role(Role::Occluder);

    let mut scene = b.finish();
    scene.ambient = Vec3::new(0.05, 0.06, 0.08);
    let sun_radius = (options.float("sun") as f32).to_radians();
    scene.add_light(Light::new(
        "sun",
        LightKind::Directional { direction: sun_direction(), angular_radius: sun_radius },
        Vec3::new(1.0, 0.95, 0.86),
        3.0,
    ));

    let eye = |x: f32, z: f32, above: f32| Vec3::new(x, ground.height(x, z) + above, z);
    // Standing on the ground looking across the terrain, tilted down so that the ground starts a few
    // metres away: perspective aliasing is worst right there.
    let ground_from = eye(-170.0, 330.0, 1.8);
    let ahead = Vec2::new(90.0 + 170.0, -330.0 - 330.0).normalize();
    let near_ground = Vec2::new(-170.0, 330.0) + ahead * 40.0;
    let ground_to = Vec3::new(near_ground.x, ground.height(near_ground.x, near_ground.y) - 4.0, near_ground.y);
    let duel_from = eye(250.0, 180.0, 2.0);
    let to_sun = -Vec2::new(sun_direction().x, sun_direction().z).normalize();
    let duel_to_xz = Vec2::new(duel_from.x, duel_from.z) + to_sun * 600.0;
    let duel_to = Vec3::new(duel_to_xz.x, ground.height(duel_to_xz.x, duel_to_xz.y) + 10.0, duel_to_xz.y);
    // A slow walk (5 cm and 0.05° of turn per frame) along the ground view: what flickers here is
    // the shadow map's rasterisation, not the scene.
    let ground_view = View::new("ground", ground_from, ground_to, 0.5, 1000.0).with_fov_degrees(60.0);
    let walk_end = {
        let step = (ground_to - ground_from).with_y(0.0).normalize() * 1.5;
        let turn = glam::Quat::from_rotation_y(1.5f32.to_radians());
        let to = ground_from + step + turn * (ground_to - ground_from);
        View { position: ground_from + step, target: to, ..ground_view.clone() }
    };
    scene.paths.push(crate::camera::CameraPath { name: "walk".into(), keys: vec![ground_view, walk_end], frames: 30 });
    scene.views = vec![
        View::new("ground", ground_from, ground_to, 0.5, 1000.0).with_fov_degrees(60.0),
        View::new("overhead", Vec3::new(0.0, 700.0, 0.0), Vec3::ZERO, 1.0, 2000.0)
            .with_fov_degrees(60.0)
            .with_up(-Vec3::Z),
        View::new("duel", duel_from, duel_to, 0.5, 1000.0).with_fov_degrees(60.0),
    ];
    scene
}

fn named(mut m: crate::mesh::Mesh, name: &str) -> crate::mesh::Mesh {
    m.name = name.to_owned();
    m
}

fn instance(scene: &mut Scene, name: &str, mesh: MeshId, material: crate::scene::MaterialId, t: Affine3A) {
    scene.add_instance(Instance::new(name, mesh, material, t)).with_role(Role::Occluder);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_extent() {
        let s = build(&ParamSet::new(OPTIONS));
        let stats = s.stats();
        let trees = s.instances.iter().filter(|i| i.name.starts_with("tree") && !i.name.ends_with("crown")).count();
        let cabins = s.instances.iter().filter(|i| i.name.starts_with("cabin") && !i.name.ends_with("roof")).count();
        assert_eq!(trees, 1500);
        assert_eq!(cabins, 100);
        assert_eq!(s.meshes.iter().find(|m| m.name == "terrain").unwrap().triangle_count(), 2 * 256 * 256);
        let e = s.bounds().extent();
        assert!((e.x - 800.0).abs() < 1.0 && (e.z - 800.0).abs() < 1.0, "{e}");
        assert!(stats.triangles > 200_000, "{}", stats.triangles);
        // The duel view looks towards the light.
        let duel = s.view("duel").unwrap();
        assert!(duel.forward().dot(-sun_direction()) > 0.8);
        let ground = s.view("ground").unwrap();
        assert!(ground.forward().dot(-sun_direction()).abs() < 0.5, "ground view looks across the light");
    }

    #[test]
    fn sun_option_sets_the_angular_radius() {
        let mut o = ParamSet::new(OPTIONS);
        o.set("sun", "0.27").unwrap();
        o.set("trees", "10").unwrap();
        o.set("grid", "16").unwrap();
        let s = build(&o);
        assert!(!s.lights[0].is_hard());
    }

    #[test]
    fn ground_height_matches_the_mesh() {
        let g = Ground::new(32);
        let cell = SIZE / 32.0;
        // At grid points the surface height is the stored value.
        let (x, z) = (-0.5 * SIZE + 3.0 * cell, -0.5 * SIZE + 5.0 * cell);
        assert!((g.height(x, z) - analytic_height(x, z)).abs() < 1e-3);
    }
}
