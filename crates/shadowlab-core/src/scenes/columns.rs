//! `columns`: an interior in the manner of Hasselgren 2003 (§3, the "interactive environments" of
//! his test scenes): three rooms joined by doorways, pillars, four static point lights, and dynamic
//! objects (two spheres, a door in its frame) that force shadows to be recomputed. Every mesh is
//! closed, so shadow volumes apply everywhere.
//!
//! Rooms are 8 × 8 × 4 m side by side along x: x ∈ [−12, 12], z ∈ [−4, 4], y ∈ [0, 4].

use glam::{Affine3A, Quat, Vec2, Vec3};

use super::{Builder, at, combine};
use crate::camera::View;
use crate::light::{Light, LightKind};
use crate::material::Material;
use crate::mesh::Mesh;
use crate::params::{ParamDef, ParamSet};
use crate::primitives::{cuboid, cuboid_between, cylinder, slab_with_hole, sphere};
use crate::scene::{Role, Scene};

pub const SUMMARY: &str = "three 8 m rooms with pillars and doorways, four point lights, dynamic spheres and door";

pub static OPTIONS: &[ParamDef] =
    &[ParamDef::float("door_angle", 35.0, 0.0, 100.0, "how far the dynamic door is open (degrees)")];

const HALF_X: f32 = 12.0;
const HALF_Z: f32 = 4.0;
const HEIGHT: f32 = 4.0;
const WALL: f32 = 0.2;
/// Doorways: (wall x, z range), both 2.2 m high.
const DOORWAYS: [(f32, (f32, f32)); 2] = [(-4.0, (-0.6, 0.6)), (4.0, (1.2, 2.4))];
const DOOR_HEIGHT: f32 = 2.2;

pub fn build(options: &ParamSet) -> Scene {
    let mut b = Builder::new("columns");
    let stone = b.material(Material::diffuse("stone floor", Vec3::new(0.5, 0.49, 0.46)).with_specular(0.1, 30.0));
    let plaster = b.material(Material::diffuse("plaster", Vec3::new(0.76, 0.73, 0.68)));
    let ceiling = b.material(Material::diffuse("ceiling", Vec3::splat(0.8)));
    let column = b.material(Material::diffuse("column stone", Vec3::new(0.66, 0.62, 0.56)).with_specular(0.15, 40.0));
    let wood = b.material(Material::diffuse("door wood", Vec3::new(0.45, 0.3, 0.19)).with_specular(0.2, 40.0));
    let frame_mat = b.material(Material::diffuse("door frame", Vec3::new(0.3, 0.2, 0.13)));

    let (ox, oz) = (HALF_X + WALL, HALF_Z + WALL);
    b.object("floor", cuboid_between(Vec3::new(-ox, -WALL, -oz), Vec3::new(ox, 0.0, oz)), stone, Affine3A::IDENTITY)
        .with_role(Role::Receiver);
    b.object(
        "ceiling",
        cuboid_between(Vec3::new(-ox, HEIGHT, -oz), Vec3::new(ox, HEIGHT + WALL, oz)),
        ceiling,
        Affine3A::IDENTITY,
    )
    .with_role(Role::Receiver);
    let (y0, y1) = (-0.5 * WALL, HEIGHT + 0.5 * WALL);
    let outer = combine([
        (cuboid_between(Vec3::new(-ox, y0, -oz), Vec3::new(-HALF_X, y1, oz)), Affine3A::IDENTITY),
        (cuboid_between(Vec3::new(HALF_X, y0, -oz), Vec3::new(ox, y1, oz)), Affine3A::IDENTITY),
        (cuboid_between(Vec3::new(-ox + 0.01, y0, -oz), Vec3::new(ox - 0.01, y1, -HALF_Z)), Affine3A::IDENTITY),
        (cuboid_between(Vec3::new(-ox + 0.01, y0, HALF_Z), Vec3::new(ox - 0.01, y1, oz)), Affine3A::IDENTITY),
    ]);
    b.object("outer walls", outer, plaster, Affine3A::IDENTITY).with_role(Role::Receiver);

    // Inner walls: slabs with a doorway hole, built with width along local x and thickness along
    // local z, turned −90° about y (local x → world z, local z → world −x).
    let (wy0, wy1) = (-0.15, HEIGHT + 0.05);
    let wall_len = 2.0 * HALF_Z + 0.1;
    let turn = Quat::from_rotation_y(-std::f32::consts::FRAC_PI_2);
    let mut inner = Mesh::new("inner walls");
    for (x, (z0, z1)) in DOORWAYS {
        // The hole starts 5 cm under the floor so its sill face hides in the floor slab.
        let hole = (Vec2::new(z0 + 0.5 * wall_len, -0.05 - wy0), Vec2::new(z1 + 0.5 * wall_len, DOOR_HEIGHT - wy0));
        let slab = slab_with_hole(wall_len, wy1 - wy0, WALL, hole.0, hole.1);
        inner
            .append(&slab, &Affine3A::from_rotation_translation(turn, Vec3::new(x + 0.5 * WALL, wy0, -0.5 * wall_len)));
    }
    b.object("inner walls", inner, plaster, Affine3A::IDENTITY).with_role(Role::Receiver);

    // A frame around the second doorway, deeper than the wall, and its dynamic door.
    let (dx, (dz0, dz1)) = DOORWAYS[1];
    let (fw, fd) = (0.1, WALL + 0.1);
    let frame = slab_with_hole(
        dz1 - dz0 + 2.0 * fw,
        DOOR_HEIGHT + fw + 0.1,
        fd,
        Vec2::new(fw, 0.05),
        Vec2::new(fw + dz1 - dz0, 0.1 + DOOR_HEIGHT),
    );
    b.object(
        "door frame",
        {
            let mut m = Mesh::new("door frame");
            m.append(&frame, &Affine3A::from_rotation_translation(turn, Vec3::new(dx + 0.5 * fd, -0.1, dz0 - fw)));
            m
        },
        frame_mat,
        Affine3A::IDENTITY,
    );
    let angle = (options.float("door_angle") as f32).to_radians();
    let door_w = dz1 - dz0 - 0.03;
    // Hinged on the doorway's low-z side, swinging into the third room (+x).
    let hinge = Vec3::new(dx, 0.0, dz0 + 0.015);
    let door = cuboid_between(Vec3::new(-0.02, 0.01, 0.0), Vec3::new(0.02, DOOR_HEIGHT - 0.03, door_w));
    b.object("door", door, wood, Affine3A::from_rotation_translation(Quat::from_rotation_y(angle), hinge))
        .with_role(Role::Occluder)
        .dynamic();

    // Pillars: round in the outer rooms, square in the middle one; they reach into floor and
    // ceiling slabs so no light passes at their ends.
    let round = cylinder(0.3, HEIGHT + 0.1, 48);
    let mut pillars = Vec::new();
    for (x, z) in
        [(-10.0, -2.0), (-10.0, 2.0), (-6.0, -2.0), (-6.0, 2.0), (6.0, -2.2), (6.0, 2.2), (10.0, -2.2), (10.0, 2.2)]
    {
        pillars.push((round.clone(), at(x, -0.05, z)));
    }
    for (x, z) in [(-1.5, -2.0), (1.5, 2.2)] {
        pillars.push((cuboid(Vec3::new(0.6, HEIGHT + 0.1, 0.6)), at(x, 0.5 * HEIGHT, z)));
    }
    b.object("pillars", combine(pillars), column, Affine3A::IDENTITY).with_role(Role::Occluder);

    let crate_mat = b.material(Material::diffuse("crates", Vec3::new(0.55, 0.45, 0.3)));
    b.object(
        "crates",
        combine([
            (cuboid(Vec3::new(0.8, 0.8, 0.8)), at(-2.6, 0.4, 2.6)),
            (
                cuboid(Vec3::new(0.6, 0.6, 0.6)),
                Affine3A::from_rotation_translation(Quat::from_rotation_y(0.4), Vec3::new(-2.5, 1.105, 2.55)),
            ),
            (
                cuboid(Vec3::new(1.2, 0.5, 0.7)),
                Affine3A::from_rotation_translation(Quat::from_rotation_y(-0.3), Vec3::new(2.4, 0.25, -2.6)),
            ),
        ]),
        crate_mat,
        Affine3A::IDENTITY,
    )
    .with_role(Role::Occluder);

    let red = b.material(Material::diffuse("red ball", Vec3::new(0.7, 0.18, 0.12)).with_specular(0.5, 80.0));
    let green = b.material(Material::diffuse("green ball", Vec3::new(0.2, 0.5, 0.28)).with_specular(0.5, 80.0));
    b.object("ball west", sphere(0.5, 48, 24), red, at(-9.0, 0.5, -0.9)).with_role(Role::Occluder).dynamic();
    b.object("ball east", sphere(0.5, 48, 24), green, at(8.3, 0.5, 0.8)).with_role(Role::Occluder).dynamic();

    let mut scene = b.finish();
    scene.ambient = Vec3::splat(0.03);
    let warm = Vec3::new(1.0, 0.88, 0.7);
    for (i, (p, c)) in [
        (Vec3::new(-8.0, 3.3, 0.4), warm),
        (Vec3::new(0.0, 3.3, -1.0), warm),
        (Vec3::new(6.8, 3.2, 0.3), Vec3::new(0.85, 0.9, 1.0)),
        (Vec3::new(10.2, 2.8, -2.9), Vec3::new(1.0, 0.75, 0.5)),
    ]
    .into_iter()
    .enumerate()
    {
        scene.add_light(
            Light::new(format!("lamp {i}"), LightKind::Point { position: p, radius: 0.1 }, c, 14.0).with_range(16.0),
        );
    }
    scene.views = vec![
        View::new("hall", Vec3::new(-11.4, 1.7, -3.3), Vec3::new(2.0, 1.0, 1.6), 0.05, 60.0).with_fov_degrees(70.0),
        View::new("pillars", Vec3::new(11.5, 2.2, 3.5), Vec3::new(6.0, 0.4, -1.0), 0.05, 60.0).with_fov_degrees(70.0),
        View::new("doorway", Vec3::new(1.2, 1.7, -2.6), Vec3::new(4.5, 0.9, 1.9), 0.05, 60.0).with_fov_degrees(65.0),
        // In the shadow that the middle room's square pillar casts from lamp 1: the near plane
        // cuts its volume.
        View::new("pillar_shadow", Vec3::new(-2.6, 1.0, -2.8), Vec3::new(1.5, 0.3, 0.5), 0.05, 60.0)
            .with_fov_degrees(70.0),
    ];
    scene
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout() {
        let s = build(&ParamSet::new(OPTIONS));
        assert_eq!(s.lights.len(), 4);
        assert!(s.lights.iter().all(|l| matches!(l.kind, LightKind::Point { radius, .. } if radius == 0.1)));
        let dynamic: Vec<&str> = s
            .instances
            .iter()
            .filter(|i| i.mobility == crate::scene::Mobility::Dynamic)
            .map(|i| i.name.as_str())
            .collect();
        assert_eq!(dynamic, ["door", "ball west", "ball east"]);
        let b = s.bounds();
        assert!((b.extent().x - 24.4).abs() < 0.01 && (b.extent().z - 8.4).abs() < 0.01, "{b:?}");
    }
}
