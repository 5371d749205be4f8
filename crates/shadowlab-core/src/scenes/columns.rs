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
use crate::sampling::Rng;
use crate::scene::{Instance, Role, Scene};

pub const SUMMARY: &str = "three 8 m rooms with pillars and doorways, four point lights, dynamic spheres and door";

pub static OPTIONS: &[ParamDef] = &[
    ParamDef::float("door_angle", 35.0, 0.0, 100.0, "how far the dynamic door is open (degrees)"),
    ParamDef::bool(
        "dynamic",
        true,
        "the balls and the door are dynamic (false: static, so that only movers move; Hasselgren's 0-object benchmark)",
    ),
    ParamDef::int(
        "movers",
        0,
        0,
        MAX_MOVERS as i64,
        "dynamic boxes and balls 'mover 1'..'mover N' (0.4-0.5 m) on the open floor of the three rooms",
    ),
];

const HALF_X: f32 = 12.0;
const HALF_Z: f32 = 4.0;
const HEIGHT: f32 = 4.0;
const WALL: f32 = 0.2;
/// Doorways: (wall x, z range), both 2.2 m high.
const DOORWAYS: [(f32, (f32, f32)); 2] = [(-4.0, (-0.6, 0.6)), (4.0, (1.2, 2.4))];
const DOOR_HEIGHT: f32 = 2.2;
/// Round pillars (radius [`ROUND_PILLAR_RADIUS`]) in the outer rooms: (x, z) of their axes.
const ROUND_PILLARS: [(f32, f32); 8] =
    [(-10.0, -2.0), (-10.0, 2.0), (-6.0, -2.0), (-6.0, 2.0), (6.0, -2.2), (6.0, 2.2), (10.0, -2.2), (10.0, 2.2)];
const ROUND_PILLAR_RADIUS: f32 = 0.3;
/// Square pillars (side [`SQUARE_PILLAR_SIDE`]) in the middle room: (x, z) of their centres.
const SQUARE_PILLARS: [(f32, f32); 2] = [(-1.5, -2.0), (1.5, 2.2)];
const SQUARE_PILLAR_SIDE: f32 = 0.6;
/// The dynamic balls: name, (x, z) on the floor; radius [`BALL_RADIUS`].
const BALLS: [(&str, f32, f32); 2] = [("ball west", -9.0, -0.9), ("ball east", 8.3, 0.8)];
const BALL_RADIUS: f32 = 0.5;
/// The most movers `columns:movers=N` places.
const MAX_MOVERS: usize = 64;

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
    let dynamic = options.bool("dynamic");
    let door = b.object("door", door, wood, Affine3A::from_rotation_translation(Quat::from_rotation_y(angle), hinge));
    door.with_role(Role::Occluder);
    if dynamic {
        door.dynamic();
    }

    // Pillars: round in the outer rooms, square in the middle one; they reach into floor and
    // ceiling slabs so no light passes at their ends.
    let round = cylinder(ROUND_PILLAR_RADIUS, HEIGHT + 0.1, 48);
    let mut pillars = Vec::new();
    for (x, z) in ROUND_PILLARS {
        pillars.push((round.clone(), at(x, -0.05, z)));
    }
    for (x, z) in SQUARE_PILLARS {
        let side = SQUARE_PILLAR_SIDE;
        pillars.push((cuboid(Vec3::new(side, HEIGHT + 0.1, side)), at(x, 0.5 * HEIGHT, z)));
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
    for ((name, x, z), material) in BALLS.into_iter().zip([red, green]) {
        let ball = b.object(name, sphere(BALL_RADIUS, 48, 24), material, at(x, BALL_RADIUS, z));
        ball.with_role(Role::Occluder);
        if dynamic {
            ball.dynamic();
        }
    }
    movers(&mut b, options.int("movers").clamp(0, MAX_MOVERS as i64) as usize);

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
    scene.views = views();
    scene
}

fn views() -> Vec<View> {
    vec![
        View::new("hall", Vec3::new(-11.4, 1.7, -3.3), Vec3::new(2.0, 1.0, 1.6), 0.05, 60.0).with_fov_degrees(70.0),
        View::new("pillars", Vec3::new(11.5, 2.2, 3.5), Vec3::new(6.0, 0.4, -1.0), 0.05, 60.0).with_fov_degrees(70.0),
        View::new("doorway", Vec3::new(1.2, 1.7, -2.6), Vec3::new(4.5, 0.9, 1.9), 0.05, 60.0).with_fov_degrees(65.0),
        // In the shadow that the middle room's square pillar casts from lamp 1: the near plane
        // cuts its volume.
        View::new("pillar_shadow", Vec3::new(-2.6, 1.0, -2.8), Vec3::new(1.5, 0.3, 0.5), 0.05, 60.0)
            .with_fov_degrees(70.0),
    ]
}

/// Half the footprint of a mover: a 0.4 m box turned about y reaches 0.28 m from its centre, a
/// ball has radius 0.25 m.
const MOVER_REACH: f32 = 0.3;
/// Free space kept between a mover's footprint and the obstacles (the grid keeps 1 m from walls).
const MOVER_GAP: f32 = 0.2;

/// Floor obstacles as circles (x, z, radius) that cover them from above: pillars, crates, balls,
/// the door's whole swing (0°–100° about its hinge), the first doorway's passage and the ground
/// under each view's camera.
fn obstacles() -> Vec<(f32, f32, f32)> {
    let mut v: Vec<(f32, f32, f32)> = ROUND_PILLARS.iter().map(|&(x, z)| (x, z, ROUND_PILLAR_RADIUS)).collect();
    v.extend(SQUARE_PILLARS.iter().map(|&(x, z)| (x, z, SQUARE_PILLAR_SIDE * std::f32::consts::FRAC_1_SQRT_2)));
    // The crate stack (0.8 m and 0.6 m boxes) and the long crate (1.2 × 0.7 m).
    v.extend([(-2.6, 2.6, 0.6), (2.4, -2.6, 0.7)]);
    v.extend(BALLS.iter().map(|&(_, x, z)| (x, z, BALL_RADIUS)));
    let (dx, (dz0, dz1)) = DOORWAYS[1];
    v.push((dx, dz0, dz1 - dz0 + 0.05));
    let (wx, (wz0, wz1)) = DOORWAYS[0];
    v.push((wx, 0.5 * (wz0 + wz1), 0.5 * (wz1 - wz0) + 0.5));
    // The cameras' feet: no mover right in front of a view.
    v.extend(views().iter().map(|view| (view.position.x, view.position.z, 1.0)));
    v
}

/// Where movers may stand: a 1 m grid in each room (7 × 7 points, 1 m from its walls) without the
/// points too close to an obstacle, shuffled with a fixed seed so that any first N spread over the
/// three rooms. Points 1 m apart keep 0.4 m between neighbouring movers.
fn mover_spots() -> Vec<Vec2> {
    let obstacles = obstacles();
    let mut spots = Vec::new();
    for room_x in [-8.0f32, 0.0, 8.0] {
        for i in -3..=3 {
            for k in -3..=3 {
                let p = Vec2::new(room_x + i as f32, k as f32);
                let clear =
                    obstacles.iter().all(|&(x, z, r)| p.distance(Vec2::new(x, z)) >= r + MOVER_REACH + MOVER_GAP);
                if clear {
                    spots.push(p);
                }
            }
        }
    }
    let mut rng = Rng::new(0x0B5E_55ED);
    for i in (1..spots.len()).rev() {
        let j = (rng.next_u64() % (i as u64 + 1)) as usize;
        spots.swap(i, j);
    }
    spots
}

/// `columns:movers=N`: N dynamic occluders on the floor, boxes and balls in turn, each its own
/// instance (boxes share one mesh, balls another).
fn movers(b: &mut Builder, n: usize) {
    if n == 0 {
        return;
    }
    let orange = b.material(Material::diffuse("mover orange", Vec3::new(0.75, 0.4, 0.12)).with_specular(0.3, 60.0));
    let blue = b.material(Material::diffuse("mover blue", Vec3::new(0.15, 0.3, 0.65)).with_specular(0.3, 60.0));
    let box_mesh = b.scene.add_mesh(Mesh { name: "mover box".to_owned(), ..cuboid(Vec3::splat(0.4)) });
    let ball_mesh = b.scene.add_mesh(Mesh { name: "mover ball".to_owned(), ..sphere(0.25, 32, 16) });
    for (i, p) in mover_spots().into_iter().take(n).enumerate() {
        let (mesh, material, transform) = if i % 2 == 0 {
            // Turned by a different angle each, so their shadows differ.
            let yaw = 0.37 * i as f32;
            (
                box_mesh,
                orange,
                Affine3A::from_rotation_translation(Quat::from_rotation_y(yaw), Vec3::new(p.x, 0.2, p.y)),
            )
        } else {
            (ball_mesh, blue, at(p.x, 0.25, p.y))
        };
        b.scene
            .add_instance(Instance::new(format!("mover {}", i + 1), mesh, material, transform))
            .with_role(Role::Occluder)
            .dynamic();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bounds::Aabb;
    use crate::scene::Mobility;

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

    fn columns(spec: &str) -> Scene {
        let s = super::super::build(spec).unwrap();
        s.validate().unwrap_or_else(|e| panic!("{spec}: {e}"));
        s
    }

    fn dynamic(s: &Scene) -> Vec<&crate::scene::Instance> {
        s.instances.iter().filter(|i| i.mobility == Mobility::Dynamic).collect()
    }

    fn overlap(a: &Aabb, b: &Aabb) -> bool {
        a.min.cmplt(b.max).all() && b.min.cmplt(a.max).all()
    }

    /// The bounds of each pillar, floor to ceiling.
    fn pillar_bounds() -> Vec<Aabb> {
        ROUND_PILLARS
            .iter()
            .map(|&(x, z)| (x, z, ROUND_PILLAR_RADIUS))
            .chain(SQUARE_PILLARS.iter().map(|&(x, z)| (x, z, 0.5 * SQUARE_PILLAR_SIDE)))
            .map(|(x, z, r)| Aabb::new(Vec3::new(x - r, 0.0, z - r), Vec3::new(x + r, HEIGHT, z + r)))
            .collect()
    }

    #[test]
    fn movers_are_extra_dynamic_objects_clear_of_the_pillars() {
        let plain = columns("columns");
        let s = columns("columns:movers=4");
        assert_eq!(dynamic(&s).len(), dynamic(&plain).len() + 4);
        assert_eq!(s, columns("columns:movers=4"), "deterministic");
        // The default scene's objects come first and unchanged.
        assert_eq!(s.instances[..plain.instances.len()], plain.instances[..]);
        let pillars = pillar_bounds();
        for (k, m) in s.instances[plain.instances.len()..].iter().enumerate() {
            assert_eq!(m.name, format!("mover {}", k + 1));
            assert_eq!((m.mobility, m.role), (Mobility::Dynamic, Some(Role::Occluder)));
            let b = s.mesh(m.mesh).bounds().transformed(&m.transform);
            // On the floor: the bottom at y = 0, to 1 mm.
            assert!(b.min.y.abs() < 1e-3, "{}: {b:?}", m.name);
            for p in &pillars {
                assert!(!overlap(&b, p), "{} {b:?} overlaps a pillar {p:?}", m.name);
            }
        }
    }

    #[test]
    fn all_movers_stand_clear_of_each_other_and_of_everything_else() {
        // The door swung fully open (100°) sweeps the most floor.
        let s = columns(&format!("columns:movers={MAX_MOVERS},door_angle=100"));
        let first = s.instances.len() - MAX_MOVERS;
        // At least 5 cm of free space around each mover's box (they are placed 0.2 m from the
        // circles that cover the obstacles; the closest, by the west ball, keeps 0.24 m).
        let clearance = 0.05;
        let movers: Vec<(&str, Aabb)> = s.instances[first..]
            .iter()
            .map(|m| {
                let b = s.mesh(m.mesh).bounds().transformed(&m.transform);
                (m.name.as_str(), Aabb::new(b.min - clearance, b.max + clearance))
            })
            .collect();
        // Every triangle of every other object but floor and ceiling (pillars, crates, balls, door
        // and frame, inner and outer walls), by its bounds: a mover cutting a surface touches that
        // triangle's box; one inside a crate touches the crate's bottom, on the floor like its own.
        for inst in s.instances[..first].iter().filter(|i| !matches!(i.name.as_str(), "floor" | "ceiling")) {
            let mesh = s.mesh(inst.mesh);
            for t in 0..mesh.triangle_count() {
                let tri = Aabb::from_points(mesh.corners(t).map(|c| inst.transform.transform_point3(c)));
                for (name, b) in &movers {
                    assert!(!overlap(b, &tri), "{name} {b:?} touches {} (triangle {t}, {tri:?})", inst.name);
                }
            }
        }
        for (i, (a, ba)) in movers.iter().enumerate() {
            for (b, bb) in &movers[i + 1..] {
                assert!(!overlap(ba, bb), "{a} and {b} overlap");
            }
            for p in pillar_bounds() {
                assert!(!overlap(ba, &p), "{a} {ba:?} overlaps a pillar {p:?}");
            }
        }
        // Spread over the three rooms: each holds at least 12 of the 64 (the seed gives 24, 17
        // and 23 from west to east).
        for room_x in [-8.0, 0.0, 8.0] {
            // Rooms are 8 m wide along x.
            let here = movers.iter().filter(|(_, b)| (b.center().x - room_x).abs() < 4.0).count();
            assert!(here >= 12, "{here} movers in the room at x = {room_x}");
        }
        // Enough free spots for the largest option value (there are 95).
        assert!(mover_spots().len() >= MAX_MOVERS, "{} spots", mover_spots().len());
    }
}
