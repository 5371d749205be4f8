//! `city`: a generated city 2 km across under a hard sun, seen from street level: the kilometre-scale
//! outdoor case of Stingl 2011 (§1: "large terrains with long view distances") and of Lauritzen,
//! Salvi and Lefohn 2011 (sample distribution shadow maps), where the visible depths run from half a
//! metre to two kilometres and a texel of a whole-city map is metres wide at the eye.
//!
//! A 20 × 20 grid of 80 m blocks, each holding four closed buildings 5–135 m tall (taller towards
//! the centre), cut by 20 m cross streets and a 30 m main street along +x, lined on both sides by lamp
//! posts 8–30 m tall and 0.3 m thick (thin casters: thinner than a texel of most maps).

use glam::{Affine3A, Vec2, Vec3};

use crate::camera::{CameraPath, View};
use crate::light::{Light, LightKind};
use crate::material::Material;
use crate::params::{ParamDef, ParamSet};
use crate::primitives::{cuboid_between, cylinder, plane};
use crate::sampling::Rng;
use crate::scene::{Instance, Role, Scene};

use super::{Builder, at, combine};

pub const SUMMARY: &str = "2 km generated city, 1600 buildings and 134 lamp posts, a hard sun, street-level views";

pub static OPTIONS: &[ParamDef] = &[
    ParamDef::float("elevation", 35.0, 2.0, 90.0, "sun elevation above the horizon in degrees (8: a low sun)"),
    ParamDef::float(
        "azimuth",
        60.0,
        -180.0,
        180.0,
        "direction the sunlight travels, degrees from the main street (+x) towards +z",
    ),
    ParamDef::float("sun", 0.0, 0.0, 5.0, "angular radius of the sun in degrees (0: hard shadows)"),
];

/// Half the city's extent (m).
const HALF: f32 = 1000.0;
/// Block pitch: an 80 m block and a 20 m street.
const CELL: f32 = 100.0;
/// Half the main street's width (m), centred on z = 0.
const MAIN_HALF: f32 = 15.0;
/// Lamp posts along the main street: every 30 m on both sidewalks, heights taking turns.
const POLE_STEP: f32 = 30.0;
const POLE_HEIGHTS: [f32; 4] = [8.0, 12.0, 20.0, 30.0];

/// The direction the sunlight travels for an elevation and an azimuth in degrees.
pub fn sun_direction(elevation_deg: f32, azimuth_deg: f32) -> Vec3 {
    let (e, a) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
    Vec3::new(a.cos() * e.cos(), -e.sin(), a.sin() * e.cos()).normalize()
}

pub fn build(options: &ParamSet) -> Scene {
    let mut b = Builder::new("city");
    let asphalt = b.material(Material::diffuse("asphalt", Vec3::new(0.22, 0.22, 0.23)));
    let facades = [
        b.material(Material::diffuse("concrete", Vec3::new(0.62, 0.6, 0.56))),
        b.material(Material::diffuse("brick", Vec3::new(0.55, 0.33, 0.26))),
        b.material(Material::diffuse("glass", Vec3::new(0.35, 0.42, 0.5)).with_specular(0.5, 80.0)),
    ];
    let steel = b.material(Material::diffuse("steel", Vec3::new(0.4, 0.41, 0.43)).with_specular(0.4, 60.0));

    b.object("ground", plane(2.0 * HALF, 2.0 * HALF, 20, 20), asphalt, Affine3A::IDENTITY).with_role(Role::Receiver);

    // Buildings, merged into one mesh per district of 4 × 4 blocks and facade material (disjoint closed
    // boxes stay a closed mesh; a few hundred draws would cost more than the triangles).
    let mut rng = Rng::new(0xC17E_0001);
    let cells = (2.0 * HALF / CELL) as i32;
    let mut districts: Vec<Vec<(crate::mesh::Mesh, Affine3A)>> = vec![Vec::new(); 25 * facades.len()];
    for ci in 0..cells {
        for ck in 0..cells {
            let (x0, z0) = (-HALF + ci as f32 * CELL, -HALF + ck as f32 * CELL);
            let (mut lo, mut hi) = (Vec2::new(x0 + 10.0, z0 + 10.0), Vec2::new(x0 + 90.0, z0 + 90.0));
            // The main street is wider than the cross streets.
            if z0 + CELL <= 0.0 + 1e-3 && z0 + CELL >= -1e-3 {
                hi.y = -MAIN_HALF;
            }
            if z0.abs() < 1e-3 {
                lo.y = MAIN_HALF;
            }
            let centre = 0.5 * (lo + hi);
            // Towers downtown, low houses at the edge.
            let r = (centre.length() / HALF).min(1.0);
            let tallest = 15.0 + 135.0 * (1.0 - r) * (1.0 - r);
            let district = (ci / 4 * 5 + ck / 4) as usize;
            for lot in 0..4 {
                let (u, v) = ((lot % 2) as f32, (lot / 2) as f32);
                let size = hi - lo;
                let l0 = lo + Vec2::new(u, v) * 0.5 * size + Vec2::splat(2.0);
                let l1 = lo + Vec2::new(u + 1.0, v + 1.0) * 0.5 * size - Vec2::splat(2.0);
                // Set back from the lot's edges by up to 4 m, a different amount on each side.
                let inset = |rng: &mut Rng| rng.range(0.0, 4.0);
                let (a, c) = (
                    Vec2::new(l0.x + inset(&mut rng), l0.y + inset(&mut rng)),
                    Vec2::new(l1.x - inset(&mut rng), l1.y - inset(&mut rng)),
                );
                let height = 5.0 + rng.next_f32().powf(1.5) * (tallest - 5.0);
                let material = (rng.next_f32() * facades.len() as f32) as usize % facades.len();
                let mesh = cuboid_between(Vec3::new(a.x, 0.0, a.y), Vec3::new(c.x, height, c.y));
                districts[district * facades.len() + material].push((mesh, Affine3A::IDENTITY));
            }
        }
    }
    for (i, parts) in districts.into_iter().enumerate() {
        if parts.is_empty() {
            continue;
        }
        let (district, material) = (i / facades.len(), i % facades.len());
        let mut mesh = combine(parts);
        mesh.name = format!("district {district} {}", ["concrete", "brick", "glass"][material]);
        let id = b.scene.add_mesh(mesh);
        let name = format!("buildings {district}.{material}");
        b.scene.add_instance(Instance::new(name, id, facades[material], Affine3A::IDENTITY)).with_role(Role::Occluder);
    }

    // Lamp posts: thin closed cylinders on both sidewalks of the main street.
    let poles: Vec<_> = POLE_HEIGHTS
        .iter()
        .map(|&h| {
            let mut m = cylinder(0.15, h, 8);
            m.name = format!("pole {h} m");
            b.scene.add_mesh(m)
        })
        .collect();
    let count = (2.0 * (HALF - 10.0) / POLE_STEP) as i32 + 1;
    for k in 0..count {
        let x = -(HALF - 10.0) + k as f32 * POLE_STEP;
        for (side, z) in [(0, -MAIN_HALF + 2.0), (1, MAIN_HALF - 2.0)] {
            let mesh = poles[(k as usize + 2 * side) % poles.len()];
            b.scene
                .add_instance(Instance::new(format!("pole {k}.{side}"), mesh, steel, at(x, 0.0, z)))
                .with_role(Role::Occluder);
        }
    }

    let mut scene = b.finish();
    scene.ambient = Vec3::new(0.05, 0.06, 0.08);
    let direction = sun_direction(options.float("elevation") as f32, options.float("azimuth") as f32);
    scene.add_light(Light::new(
        "sun",
        LightKind::Directional { direction, angular_radius: (options.float("sun") as f32).to_radians() },
        Vec3::new(1.0, 0.95, 0.86),
        3.0,
    ));

    // Street level: a pedestrian's eye (1.7 m) on the main street looking down it, tilted 1° down so
    // that the road starts a hundred metres ahead; near 0.5 m, far 2 km.
    let eye = Vec3::new(-900.0, 1.7, 5.0);
    let street = View::new("street", eye, eye + Vec3::new(100.0, -1.75, 0.0), 0.5, 2000.0).with_fov_degrees(60.0);
    // A 60-frame walk down the street at 1.5 m/s (30 frames a second).
    let walked = View { position: eye + Vec3::X * 3.0, target: street.target + Vec3::X * 3.0, ..street.clone() };
    scene.paths.push(CameraPath { name: "walk".into(), keys: vec![street.clone(), walked], frames: 60 });
    let rooftop = Vec3::new(-420.0, 60.0, -180.0);
    scene.views = vec![
        street,
        View::new("rooftop", rooftop, Vec3::new(150.0, 0.0, 120.0), 1.0, 2000.0).with_fov_degrees(60.0),
        View::new("overhead", Vec3::new(0.0, 1400.0, 0.0), Vec3::ZERO, 10.0, 3000.0)
            .with_fov_degrees(60.0)
            .with_up(-Vec3::Z),
    ];
    scene
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_heights_and_extent() {
        let s = build(&ParamSet::new(OPTIONS));
        let poles = s.instances.iter().filter(|i| i.name.starts_with("pole")).count();
        assert_eq!(poles, 134);
        let e = s.bounds().extent();
        assert!((e.x - 2000.0).abs() < 1.0 && (e.z - 2000.0).abs() < 1.0, "{e}");
        // Buildings 5-135 m: the tallest downtown reaches over 100 m (measured 123.7 m).
        assert!(e.y > 100.0 && e.y <= 150.0, "{e}");
        let triangles = s.stats().triangles;
        assert!((20_000..100_000).contains(&triangles), "{triangles}");
        // The street view looks along the main street, across the light.
        let street = s.view("street").unwrap();
        let d = sun_direction(35.0, 60.0);
        assert!(street.forward().dot(Vec3::X) > 0.99);
        assert!(street.forward().dot(-d).abs() < 0.5);
    }

    #[test]
    fn the_main_street_is_free_of_buildings() {
        let s = build(&ParamSet::new(OPTIONS));
        for inst in s.instances.iter().filter(|i| i.name.starts_with("buildings")) {
            for p in &s.mesh(inst.mesh).positions {
                assert!(p.z.abs() >= MAIN_HALF - 1e-3, "{}: {p}", inst.name);
            }
        }
    }
}
