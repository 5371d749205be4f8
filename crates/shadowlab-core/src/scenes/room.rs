//! `room`: the furnished interior that the semi-static work targets (Toromanoff 2005, §I–II: an
//! interior planner with a ceiling light, secondary "atmosphere" lights and the sun through a
//! window). Fine shadow detail (chair slats, a cup handle), one dynamic chair, every light type.
//!
//! Interior: x ∈ [−2.5, 2.5], z ∈ [−2, 2], y ∈ [0, 2.6] m; the window is in the east wall (+x).

use glam::{Affine3A, Quat, Vec2, Vec3};

use super::{Builder, at, combine};
use crate::camera::View;
use crate::light::{Light, LightKind};
use crate::material::Material;
use crate::mesh::Mesh;
use crate::params::{ParamDef, ParamSet};
use crate::primitives::{beam, cuboid, cuboid_between, cylinder, lathe, rounded_box, slab_with_hole, sphere, torus};
use crate::sampling::Rng;
use crate::scene::{Instance, Role, Scene};

pub const SUMMARY: &str =
    "furnished 5 × 4 × 2.6 m room: ceiling lamp, reading spot, coloured point light, sun through a window";

pub static OPTIONS: &[ParamDef] = &[];

const HALF_X: f32 = 2.5;
const HALF_Z: f32 = 2.0;
const HEIGHT: f32 = 2.6;
const WALL: f32 = 0.12;
/// Window opening in the east wall: z range and y range.
const WINDOW_Z: (f32, f32) = (-0.8, 0.8);
const WINDOW_Y: (f32, f32) = (0.9, 2.1);
const TABLE_CENTRE: Vec3 = Vec3::new(-0.4, 0.0, 0.1);
const TABLE_TOP: f32 = 0.75;

pub fn build(_options: &ParamSet) -> Scene {
    let mut b = Builder::new("room");
    shell(&mut b);
    table_and_chairs(&mut b);
    cup(&mut b);
    shelf(&mut b);
    sofa(&mut b);
    lamps(&mut b);
    let mut scene = b.finish();
    scene.ambient = Vec3::splat(0.04);
    lights(&mut scene);
    scene.views = vec![
        View::new("default", Vec3::new(-2.2, 1.75, 1.75), Vec3::new(0.3, 0.45, -0.4), 0.05, 20.0)
            .with_fov_degrees(68.0),
        View::new(
            "table",
            TABLE_CENTRE + Vec3::new(0.55, TABLE_TOP + 0.3, 0.5),
            TABLE_CENTRE + Vec3::new(0.15, TABLE_TOP + 0.04, 0.0),
            0.02,
            10.0,
        )
        .with_fov_degrees(45.0),
        View::new("window", Vec3::new(-1.9, 1.5, -1.4), Vec3::new(1.2, 0.3, 0.5), 0.05, 20.0).with_fov_degrees(65.0),
        View::new("sofa", Vec3::new(0.9, 1.35, -0.9), Vec3::new(-2.0, 0.5, 0.9), 0.05, 20.0).with_fov_degrees(62.0),
        // Under the table, in the ceiling lamp's shadow of the table top: the near plane cuts
        // shadow volumes (z-pass fails here; Toromanoff 2005 Fig. 35).
        View::new(
            "under_table",
            TABLE_CENTRE + Vec3::new(-0.1, 0.4, 0.1),
            TABLE_CENTRE + Vec3::new(2.0, 0.25, 1.1),
            0.05,
            20.0,
        )
        .with_fov_degrees(70.0),
    ];
    scene
}

/// Floor, ceiling and four walls, each a closed slab; the east wall has the window.
fn shell(b: &mut Builder) {
    let floor = b.material(Material::diffuse("oak floor", Vec3::new(0.42, 0.29, 0.18)).with_specular(0.15, 40.0));
    let walls = b.material(Material::diffuse("wall paint", Vec3::new(0.78, 0.76, 0.72)));
    let ceiling = b.material(Material::diffuse("ceiling paint", Vec3::splat(0.85)));
    let (ox, oz) = (HALF_X + WALL, HALF_Z + WALL);
    b.object("floor", cuboid_between(Vec3::new(-ox, -WALL, -oz), Vec3::new(ox, 0.0, oz)), floor, Affine3A::IDENTITY)
        .with_role(Role::Receiver);
    b.object(
        "ceiling",
        cuboid_between(Vec3::new(-ox, HEIGHT, -oz), Vec3::new(ox, HEIGHT + WALL, oz)),
        ceiling,
        Affine3A::IDENTITY,
    )
    .with_role(Role::Receiver);
    // Walls reach a little into floor and ceiling so that no light leaks along the joints; they
    // overlap rather than share corners, which keeps every mesh 2-manifold.
    let (y0, y1) = (-0.5 * WALL, HEIGHT + 0.5 * WALL);
    let west = cuboid_between(Vec3::new(-ox, y0, -oz), Vec3::new(-HALF_X, y1, oz));
    let north = cuboid_between(Vec3::new(-ox + 0.01, y0, -oz), Vec3::new(ox - 0.01, y1, -HALF_Z));
    let south = cuboid_between(Vec3::new(-ox + 0.01, y0, HALF_Z), Vec3::new(ox - 0.01, y1, oz));
    b.object(
        "walls",
        combine([(west, Affine3A::IDENTITY), (north, Affine3A::IDENTITY), (south, Affine3A::IDENTITY)]),
        walls,
        Affine3A::IDENTITY,
    )
    .with_role(Role::Receiver);
    // East wall: a slab with a hole, built in its own frame (width along x, thickness along z) and
    // turned +90° about y, which sends local x to world −z and local z to world +x.
    let width = 2.0 * oz;
    let slab = slab_with_hole(
        width,
        y1 - y0,
        WALL,
        Vec2::new(WINDOW_Z.0 + oz, WINDOW_Y.0 - y0),
        Vec2::new(WINDOW_Z.1 + oz, WINDOW_Y.1 - y0),
    );
    let turn = Affine3A::from_rotation_translation(
        Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
        Vec3::new(HALF_X, y0, oz),
    );
    b.object(
        "east wall",
        {
            let mut m = Mesh::new("east wall");
            m.append(&slab, &turn);
            m
        },
        walls,
        Affine3A::IDENTITY,
    )
    .with_role(Role::Receiver);
    // A sill under the window, protruding into the room: a ledge the sun shines over.
    let sill = b.material(Material::diffuse("sill", Vec3::splat(0.9)).with_specular(0.3, 60.0));
    b.object(
        "sill",
        cuboid_between(
            Vec3::new(HALF_X - 0.08, WINDOW_Y.0 - 0.03, WINDOW_Z.0 - 0.05),
            Vec3::new(HALF_X + 0.02, WINDOW_Y.0 + 0.005, WINDOW_Z.1 + 0.05),
        ),
        sill,
        Affine3A::IDENTITY,
    );
}

fn table_and_chairs(b: &mut Builder) {
    let wood = b.material(Material::diffuse("walnut", Vec3::new(0.36, 0.22, 0.13)).with_specular(0.25, 50.0));
    let (tw, td) = (1.4, 0.8);
    let mut parts = vec![(cuboid(Vec3::new(tw, 0.04, td)), at(0.0, TABLE_TOP - 0.02, 0.0))];
    for (sx, sz) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        // Legs end inside the top so that they do not share its faces.
        parts.push((cylinder(0.03, TABLE_TOP - 0.025, 32), at(sx * (0.5 * tw - 0.09), 0.0, sz * (0.5 * td - 0.09))));
    }
    b.object("table", combine(parts), wood, Affine3A::from_translation(TABLE_CENTRE)).with_role(Role::Occluder);

    let chair_wood = b.material(Material::diffuse("beech", Vec3::new(0.55, 0.4, 0.26)).with_specular(0.2, 40.0));
    let chair = chair_mesh();
    let c = TABLE_CENTRE;
    let placements = [
        ("chair north-west", Vec3::new(c.x - 0.32, 0.0, c.z - 0.62), 0.0),
        ("chair north-east", Vec3::new(c.x + 0.32, 0.0, c.z - 0.62), 0.0),
        ("chair south", Vec3::new(c.x, 0.0, c.z + 0.62), 180.0),
    ];
    for (name, p, yaw) in placements {
        let t = Affine3A::from_rotation_translation(Quat::from_rotation_y(f32::to_radians(yaw)), p);
        let mesh = b.scene.add_mesh(Mesh { name: name.to_owned(), ..chair.clone() });
        b.scene.add_instance(Instance::new(name, mesh, chair_wood, t)).with_role(Role::Occluder);
    }
    // The dynamic chair stands at the east end, pulled out and turned, its slatted back to the
    // window: the sun draws the slats on the floor.
    let t = Affine3A::from_rotation_translation(
        Quat::from_rotation_y(f32::to_radians(-75.0)),
        Vec3::new(c.x + 1.05, 0.0, c.z + 0.1),
    );
    let mesh = b.scene.add_mesh(Mesh { name: "chair east".to_owned(), ..chair });
    b.scene.add_instance(Instance::new("chair east", mesh, chair_wood, t)).with_role(Role::Occluder).dynamic();
}

/// A chair facing +z (the sitter looks towards +z; the back is at −z): seat, four legs, two back
/// posts, a top rail and five vertical slats.
fn chair_mesh() -> Mesh {
    let (sw, sd, sh) = (0.44, 0.42, 0.46);
    let leg = 0.035;
    let mut parts = vec![(cuboid(Vec3::new(sw, 0.035, sd)), at(0.0, sh, 0.0))];
    for (sx, sz) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        let (x, z) = (sx * (0.5 * sw - 0.03), sz * (0.5 * sd - 0.03));
        let top = if sz < 0.0 { 0.98 } else { sh - 0.005 };
        // Back legs continue up as the back posts.
        parts.push((cuboid(Vec3::new(leg, top, leg)), at(x, 0.5 * top, z)));
    }
    let back_z = -(0.5 * sd - 0.03);
    parts.push((cuboid(Vec3::new(sw - 0.04, 0.07, 0.025)), at(0.0, 0.93, back_z)));
    for k in 0..5 {
        let x = (k as f32 - 2.0) * 0.075;
        parts.push((cuboid(Vec3::new(0.035, 0.44, 0.015)), at(x, 0.69, back_z)));
    }
    combine(parts)
}

/// A cup with a handle on the table: a thick-walled lathe plus a torus half sunk into its wall.
fn cup(b: &mut Builder) {
    let porcelain = b.material(Material::diffuse("porcelain", Vec3::splat(0.92)).with_specular(0.6, 120.0));
    let (r, h, t) = (0.04, 0.09, 0.004);
    let body = lathe(
        &[
            Vec2::new(0.0, 0.0),
            Vec2::new(r - 0.006, 0.0),
            Vec2::new(r, 0.006),
            Vec2::new(r, h),
            Vec2::new(r - t, h),
            Vec2::new(r - t, 0.008),
            Vec2::new(0.0, 0.008),
        ],
        false,
        64,
    );
    // Torus around +Y turned to stand in the x-y plane, centred on the wall at +x.
    let handle = torus(0.024, 0.0055, 48, 16);
    let handle_t = Affine3A::from_rotation_translation(
        Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
        Vec3::new(r + 0.012, 0.5 * h, 0.0),
    );
    let saucer = lathe(
        &[
            Vec2::new(0.0, 0.0),
            Vec2::new(0.05, 0.0),
            Vec2::new(0.075, 0.012),
            Vec2::new(0.07, 0.014),
            Vec2::new(0.0, 0.006),
        ],
        false,
        64,
    );
    let place = TABLE_CENTRE + Vec3::new(0.25, TABLE_TOP, 0.05);
    let rot = Quat::from_rotation_y(f32::to_radians(-30.0));
    b.object("saucer", saucer, porcelain, Affine3A::from_rotation_translation(rot, place)).with_role(Role::Occluder);
    b.object(
        "cup",
        combine([(body, Affine3A::IDENTITY), (handle, handle_t)]),
        porcelain,
        Affine3A::from_rotation_translation(rot, place + Vec3::new(0.0, 0.0065, 0.0)),
    )
    .with_role(Role::Occluder);
    // A bowl of fruit at the other end: smooth round shapes for smooth shadows.
    let bowl_mat = b.material(Material::diffuse("ceramic", Vec3::new(0.25, 0.42, 0.55)).with_specular(0.4, 80.0));
    let bowl = lathe(
        &[
            Vec2::new(0.0, 0.0),
            Vec2::new(0.06, 0.0),
            Vec2::new(0.13, 0.07),
            Vec2::new(0.124, 0.072),
            Vec2::new(0.056, 0.008),
            Vec2::new(0.0, 0.008),
        ],
        false,
        64,
    );
    let bowl_at = TABLE_CENTRE + Vec3::new(-0.35, TABLE_TOP, -0.1);
    b.object("bowl", bowl, bowl_mat, Affine3A::from_translation(bowl_at)).with_role(Role::Occluder);
    let fruit_mat = b.material(Material::diffuse("apples", Vec3::new(0.62, 0.12, 0.08)).with_specular(0.4, 60.0));
    let fruit = combine(
        [(-0.045, 0.035, 0.0), (0.05, 0.04, 0.02), (0.0, 0.035, -0.055), (0.005, 0.095, 0.0)]
            .into_iter()
            .map(|(x, y, z)| (sphere(0.037, 32, 16), at(x, y + 0.01, z))),
    );
    b.object("fruit", fruit, fruit_mat, Affine3A::from_translation(bowl_at)).with_role(Role::Occluder);
}

/// A bookcase against the north wall with rows of books.
fn shelf(b: &mut Builder) {
    let board = b.material(Material::diffuse("painted board", Vec3::new(0.88, 0.86, 0.8)));
    let (w, h, d) = (1.2, 1.9, 0.32);
    let (x0, z0) = (0.9, -HALF_Z + 0.01);
    let mut parts = vec![
        (cuboid_between(Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.02, h, d)), Affine3A::IDENTITY),
        (cuboid_between(Vec3::new(w - 0.02, 0.0, 0.0), Vec3::new(w, h, d)), Affine3A::IDENTITY),
        (cuboid_between(Vec3::new(0.015, 0.02, 0.0), Vec3::new(w - 0.015, h - 0.02, 0.012)), Affine3A::IDENTITY),
    ];
    let levels = [0.05, 0.5, 0.95, 1.4, 1.88];
    for &y in &levels {
        parts.push((
            cuboid_between(Vec3::new(0.015, y - 0.02, 0.008), Vec3::new(w - 0.015, y, d - 0.005)),
            Affine3A::IDENTITY,
        ));
    }
    let origin = Affine3A::from_translation(Vec3::new(x0, 0.0, z0));
    b.object("bookcase", combine(parts), board, origin).with_role(Role::Occluder);

    // Books in four colours, deterministic sizes; one leans on its neighbour.
    let colours =
        [Vec3::new(0.55, 0.1, 0.1), Vec3::new(0.1, 0.25, 0.45), Vec3::new(0.15, 0.4, 0.2), Vec3::new(0.75, 0.6, 0.25)];
    let mut per_colour: Vec<Vec<(Mesh, Affine3A)>> = vec![Vec::new(); colours.len()];
    let mut rng = Rng::new(0x5EED_B00C);
    for (row, &y) in levels[..3].iter().enumerate() {
        let mut x = 0.04;
        let mut k = 0usize;
        while x < w - 0.12 - if row == 1 { 0.4 } else { 0.0 } {
            let thick = rng.range(0.022, 0.05);
            let tall = rng.range(0.2, 0.3);
            let deep = rng.range(0.15, 0.22);
            let lean = if k == 6 { 0.28f32 } else { 0.0 };
            let t = Affine3A::from_translation(Vec3::new(
                x + 0.5 * thick + lean * 0.5 * tall,
                y + 0.001,
                0.03 + 0.5 * deep,
            )) * Affine3A::from_rotation_z(-lean)
                * Affine3A::from_translation(Vec3::new(0.0, 0.5 * tall, 0.0));
            per_colour[(k * 7 + row * 3) % colours.len()].push((cuboid(Vec3::new(thick, tall, deep)), t));
            x += thick + if lean > 0.0 { 0.5 * tall * lean.sin() + 0.01 } else { 0.002 };
            k += 1;
        }
    }
    for (i, (parts, colour)) in per_colour.into_iter().zip(colours).enumerate() {
        let m = b.material(Material::diffuse(format!("book cloth {i}"), colour).with_specular(0.1, 20.0));
        b.object(&format!("books {i}"), combine(parts), m, origin).with_role(Role::Occluder);
    }
}

/// A sofa against the west wall, from rounded boxes.
fn sofa(b: &mut Builder) {
    let fabric = b.material(Material::diffuse("sofa fabric", Vec3::new(0.22, 0.3, 0.42)));
    let cushion = b.material(Material::diffuse("cushion fabric", Vec3::new(0.3, 0.4, 0.52)));
    let x = -HALF_X + 0.5;
    let n = 14;
    let frame = combine([
        (rounded_box(Vec3::new(0.9, 0.38, 2.1), 0.04, n), at(0.0, 0.21, 0.0)),
        (rounded_box(Vec3::new(0.22, 0.62, 2.1), 0.06, n), at(-0.36, 0.5, 0.0)),
        (rounded_box(Vec3::new(0.9, 0.6, 0.2), 0.07, n), at(0.0, 0.32, -1.0)),
        (rounded_box(Vec3::new(0.9, 0.6, 0.2), 0.07, n), at(0.0, 0.32, 1.0)),
    ]);
    b.object("sofa", frame, fabric, at(x, 0.0, 0.1)).with_role(Role::Occluder);
    let cushions = combine([
        (rounded_box(Vec3::new(0.66, 0.16, 0.88), 0.06, n), at(0.08, 0.47, -0.45)),
        (rounded_box(Vec3::new(0.66, 0.16, 0.88), 0.06, n), at(0.08, 0.47, 0.45)),
        (rounded_box(Vec3::new(0.18, 0.42, 0.86), 0.07, n), at(-0.2, 0.76, -0.45)),
        (rounded_box(Vec3::new(0.18, 0.42, 0.86), 0.07, n), at(-0.2, 0.76, 0.45)),
    ]);
    b.object("cushions", cushions, cushion, at(x, 0.0, 0.1)).with_role(Role::Occluder);
}

/// Light fixtures: the ceiling lamp's cord and canopy, and the reading lamp beside the sofa.
fn lamps(b: &mut Builder) {
    let metal = b.material(Material::diffuse("brushed metal", Vec3::splat(0.3)).with_specular(0.7, 90.0));
    let (cx, cz) = (CEILING_LAMP.x, CEILING_LAMP.z);
    // The cord stops above the bulb's emitter (radius 0.1) so it never sits inside it.
    let cord_bottom = CEILING_LAMP.y + 0.13;
    b.object(
        "pendant",
        combine([
            (cylinder(0.006, HEIGHT - cord_bottom + 0.01, 12), at(cx, cord_bottom, cz)),
            (cylinder(0.06, 0.04, 32), at(cx, HEIGHT - 0.035, cz)),
        ]),
        metal,
        Affine3A::IDENTITY,
    );
    // Reading lamp: a base, a pole, an arm and a shade opening downwards above the emitter.
    let shade = lathe(
        &[
            Vec2::new(0.0, 0.16),
            Vec2::new(0.05, 0.16),
            Vec2::new(0.13, 0.0),
            Vec2::new(0.122, 0.0),
            Vec2::new(0.044, 0.152),
            Vec2::new(0.0, 0.152),
        ],
        false,
        48,
    );
    let s = READING_LAMP;
    let (px, pz) = READING_LAMP_POLE;
    b.object(
        "reading lamp",
        combine([
            (cylinder(0.16, 0.025, 40), at(px, 0.0, pz)),
            (cylinder(0.014, s.y + 0.2, 16), at(px, 0.02, pz)),
            (beam(Vec3::new(px, s.y + 0.2, pz), Vec3::new(s.x, s.y + 0.17, s.z), 0.018), Affine3A::IDENTITY),
            // Shade rim at y = s.y + 0.045: above the top of the 4 cm emitter.
            (shade, at(s.x, s.y + 0.045, s.z)),
        ]),
        metal,
        Affine3A::IDENTITY,
    );
}

const CEILING_LAMP: Vec3 = Vec3::new(-0.3, 2.2, 0.1);
/// Above the north end of the sofa; its pole stands north of the sofa.
const READING_LAMP: Vec3 = Vec3::new(-1.6, 1.5, -0.7);
const READING_LAMP_POLE: (f32, f32) = (-1.95, -1.35);
/// On the bookcase's second shelf, right of the books.
const ACCENT_LAMP: Vec3 = Vec3::new(1.85, 0.62, -HALF_Z + 0.22);

fn lights(scene: &mut Scene) {
    scene.add_light(
        Light::new(
            "ceiling lamp",
            LightKind::Point { position: CEILING_LAMP, radius: 0.1 },
            Vec3::new(1.0, 0.82, 0.6),
            6.0,
        )
        .with_range(12.0),
    );
    scene.add_light(
        Light::new(
            "reading lamp",
            LightKind::Spot {
                position: READING_LAMP,
                direction: Vec3::new(-0.25, -1.0, 0.25).normalize(),
                inner_angle: 28f32.to_radians(),
                outer_angle: 42f32.to_radians(),
                radius: 0.04,
            },
            Vec3::new(1.0, 0.9, 0.75),
            5.0,
        )
        .with_range(8.0),
    );
    // A small blue accent light on the bookcase's middle shelf, between the books.
    scene.add_light(
        Light::new("accent", LightKind::Point { position: ACCENT_LAMP, radius: 0.02 }, Vec3::new(0.35, 0.55, 1.0), 0.6)
            .with_range(4.0),
    );
    // The sun comes in through the east window from the east, down at about 40°.
    scene.add_light(Light::new(
        "sun",
        LightKind::Directional {
            direction: Vec3::new(-0.72, -0.62, 0.3).normalize(),
            angular_radius: 0.27f32.to_radians(),
        },
        Vec3::new(1.0, 0.95, 0.85),
        4.0,
    ));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_and_roles() {
        let s = build(&ParamSet::new(OPTIONS));
        let stats = s.stats();
        assert!((20_000..=60_000).contains(&stats.triangles), "{} triangles", stats.triangles);
        let b = s.bounds();
        assert!((b.extent().x - 5.24).abs() < 0.01 && (b.extent().y - 2.84).abs() < 0.01, "{b:?}");
        let receivers = s.instances.iter().filter(|i| i.role == Some(Role::Receiver)).count();
        assert!(receivers >= 4);
        let dynamic: Vec<_> = s.instances.iter().filter(|i| i.mobility == crate::scene::Mobility::Dynamic).collect();
        assert_eq!(dynamic.len(), 1);
        assert!(dynamic[0].name.contains("chair"));
        let kinds: Vec<_> = s.lights.iter().map(|l| l.type_name()).collect();
        assert_eq!(kinds, ["point", "spot", "point", "directional"]);
    }
}
