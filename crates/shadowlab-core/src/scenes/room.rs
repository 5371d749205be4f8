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

pub static OPTIONS: &[ParamDef] = &[ParamDef::int(
    "lamps",
    0,
    0,
    MAX_LAMPS as i64,
    "point lamps 'lamp 1'..'lamp N' (4.5 cm, range 2.5-5 m) around the furniture, plus the sun, \
     instead of the usual four lights (0: those)",
)];

const HALF_X: f32 = 2.5;
const HALF_Z: f32 = 2.0;
const HEIGHT: f32 = 2.6;
const WALL: f32 = 0.12;
/// Window opening in the east wall: z range and y range.
const WINDOW_Z: (f32, f32) = (-0.8, 0.8);
const WINDOW_Y: (f32, f32) = (0.9, 2.1);
const TABLE_CENTRE: Vec3 = Vec3::new(-0.4, 0.0, 0.1);
const TABLE_TOP: f32 = 0.75;

pub fn build(options: &ParamSet) -> Scene {
    let mut b = Builder::new("room");
    shell(&mut b);
    table_and_chairs(&mut b);
    cup(&mut b);
    shelf(&mut b);
    sofa(&mut b);
    lamps(&mut b);
    let mut scene = b.finish();
    scene.ambient = Vec3::splat(0.04);
    match options.int("lamps").clamp(0, MAX_LAMPS as i64) as usize {
        0 => lights(&mut scene),
        n => many_lamps(&mut scene, n),
    }
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
    scene.add_light(sun());
}

/// The sun comes in through the east window from the east, down at about 40°.
fn sun() -> Light {
    Light::new(
        "sun",
        LightKind::Directional {
            direction: Vec3::new(-0.72, -0.62, 0.3).normalize(),
            angular_radius: 0.27f32.to_radians(),
        },
        Vec3::new(1.0, 0.95, 0.85),
        4.0,
    )
}

/// The most lamps `room:lamps=N` places.
const MAX_LAMPS: usize = LAMPS.len();
/// Emitter radius of the `lamps` option's point lamps (m).
const LAMP_RADIUS: f32 = 0.045;

/// One point lamp of the `lamps` option.
struct Lamp {
    position: Vec3,
    /// Distance beyond which the lamp has no effect (m): a few metres, so that most lamps miss some
    /// corners of the room.
    range: f32,
    /// Chosen so that intensity / distance² stays under 6 on the nearest wall, floor or ceiling
    /// (about 1.5 in HDR units there): bright, never blown out.
    intensity: f32,
}

const fn lamp(x: f32, y: f32, z: f32, range: f32, intensity: f32) -> Lamp {
    Lamp { position: Vec3::new(x, y, z), range, intensity }
}

/// The lamps of `room:lamps=N`, the first N of them. Each sits at least 0.3 m from walls, floor and
/// ceiling and 0.15 m outside every piece of furniture's bounds, where the furniture between it and
/// the floor or walls casts shadows the views see. The first eight spread over the room, and for
/// each corner of the floor one of them does not reach it; the rest add light at other heights.
const LAMPS: [Lamp; 16] = [
    // 1: over the table, 0.75 m above its top: the table, the chairs' seats and slats on the
    // floor, the cup and the fruit on the table top.
    lamp(-0.4, 1.5, 0.1, 3.5, 1.6),
    // 2: beside the bookcase (west of it, in front): its side panel and the books on the shelves
    // and back panel, the north-east and east chairs on the floor.
    lamp(0.6, 1.3, -1.35, 3.0, 1.0),
    // 3: near the sofa, east of it above the seat: cushions and arm on the sofa and the west wall,
    // the table's west end and the south chair on the floor.
    lamp(-1.3, 1.2, 0.75, 3.0, 1.6),
    // 4: high towards the south-east corner: the table and the east chair towards the north-west.
    lamp(1.9, 1.9, 1.35, 4.0, 2.0),
    // 5: at chair height south of the table: long shadows of table and chair legs northwards over
    // the floor onto the bookcase and the north wall.
    lamp(0.15, 0.55, 1.35, 3.0, 1.2),
    // 6: low in the north-west, between the reading lamp and the north-west chair: chair and table
    // legs south-eastwards over the floor, the reading lamp's pole towards the sofa.
    lamp(-1.2, 0.6, -1.5, 2.5, 0.8),
    // 7: high over the east chair: its slats on the floor.
    lamp(1.1, 2.0, 0.5, 3.5, 2.0),
    // 8: low by the east wall, north of the window: the east chair and the table legs westwards
    // over the floor, the bookcase's end along the north wall.
    lamp(2.1, 0.45, -0.9, 3.5, 0.9),
    // 9: high by the north wall behind the north chairs: their slats on the table and the floor.
    lamp(-0.6, 2.0, -1.55, 3.0, 1.2),
    // 10: high by the south wall between the sofa and the south chair: the chair's slats and the
    // sofa's south arm.
    lamp(-1.2, 1.8, 1.55, 3.0, 1.2),
    // 11: under table height between the sofa and the table: table and chair legs eastwards.
    lamp(-1.35, 0.35, -0.35, 3.0, 0.6),
    // 12: above the bookcase: shelves on the books.
    lamp(1.5, 2.25, -1.5, 2.5, 0.7),
    // 13: behind the south chair's back, by the south wall: its slats under the table.
    lamp(-0.5, 1.1, 1.6, 3.0, 0.9),
    // 14: just above the table top at its east end: cup, saucer and fruit across the top.
    lamp(0.55, 1.0, -0.35, 2.5, 0.6),
    // 15: low in the north-east corner, in front of the bookcase: the east chair westwards.
    lamp(2.15, 0.5, -1.35, 2.5, 0.6),
    // 16: half a metre under the ceiling, mid-room, with the longest reach.
    lamp(0.3, 2.1, -0.4, 5.0, 1.4),
];

/// Warm lamp colours (linear RGB), used in turn.
const LAMP_COLOURS: [Vec3; 4] =
    [Vec3::new(1.0, 0.85, 0.65), Vec3::new(1.0, 0.78, 0.55), Vec3::new(1.0, 0.9, 0.75), Vec3::new(1.0, 0.72, 0.45)];

/// `room:lamps=N`: the first `n` of [`LAMPS`], then the sun. Beyond eight lamps every lamp is
/// dimmed by 8/N, so that sixteen light the room about as brightly as eight.
fn many_lamps(scene: &mut Scene, n: usize) {
    let dim = (8.0 / n as f32).min(1.0);
    for (i, l) in LAMPS.iter().take(n).enumerate() {
        scene.add_light(
            Light::new(
                format!("lamp {}", i + 1),
                LightKind::Point { position: l.position, radius: LAMP_RADIUS },
                LAMP_COLOURS[i % LAMP_COLOURS.len()],
                l.intensity * dim,
            )
            .with_range(l.range),
        );
    }
    scene.add_light(sun());
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bounds::Aabb;

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

    fn room(spec: &str) -> Scene {
        let s = super::super::build(spec).unwrap();
        s.validate().unwrap_or_else(|e| panic!("{spec}: {e}"));
        s
    }

    /// The world bounds of every instance but the shell (floor, ceiling, walls: their boxes
    /// enclose the whole room).
    fn furniture(s: &Scene) -> Vec<(&str, Aabb)> {
        s.instances
            .iter()
            .filter(|i| i.role != Some(Role::Receiver))
            .map(|i| (i.name.as_str(), s.mesh(i.mesh).bounds().transformed(&i.transform)))
            .collect()
    }

    fn distance_to_box(p: Vec3, b: &Aabb) -> f32 {
        (b.min - p).max(p - b.max).max(Vec3::ZERO).length()
    }

    #[test]
    fn without_lamps_the_room_keeps_its_four_lights() {
        let s = room("room");
        assert_eq!(s, room("room:lamps=0"));
        // 23 objects: the shell (5 with the sill), 8 pieces of furniture, 4 rows of books, cup,
        // saucer, bowl, fruit and the two lamp fixtures.
        assert_eq!(s.instances.len(), 23);
        let lights: Vec<_> = s.lights.iter().map(|l| (l.name.as_str(), l.type_name(), l.position())).collect();
        assert_eq!(
            lights,
            [
                ("ceiling lamp", "point", Some(CEILING_LAMP)),
                ("reading lamp", "spot", Some(READING_LAMP)),
                ("accent", "point", Some(ACCENT_LAMP)),
                ("sun", "directional", None),
            ]
        );
    }

    #[test]
    fn lamps_replace_the_local_lights_and_stand_clear_of_the_furniture() {
        let plain = room("room");
        for n in [1, 8, 16] {
            let s = room(&format!("room:lamps={n}"));
            // The same objects and views: only the lights differ.
            assert_eq!(
                (&s.instances, &s.meshes, &s.materials, &s.views),
                (&plain.instances, &plain.meshes, &plain.materials, &plain.views)
            );
            assert_eq!(s.lights.len(), n + 1);
            assert_eq!(s.lights[n], plain.lights[3], "the sun stays, last");
            let furniture = furniture(&s);
            for (i, l) in s.lights[..n].iter().enumerate() {
                assert_eq!(l.name, format!("lamp {}", i + 1));
                let LightKind::Point { position: p, radius } = l.kind else { panic!("{}: {:?}", l.name, l.kind) };
                // Small spheres: 4 to 5 cm.
                assert!((0.04..=0.05).contains(&radius), "{}: radius {radius}", l.name);
                // A range of a few metres (the lamps have 2.5 to 5 m).
                let range = l.range.unwrap_or(f32::INFINITY);
                assert!((2.0..=5.0).contains(&range), "{}: range {range}", l.name);
                // Inside the room, at least 0.3 m from walls, floor and ceiling (the closest, lamps 11,
                // 12 and 15 by floor, ceiling and east wall, are 0.35 m away).
                let inner = Aabb::new(Vec3::new(-HALF_X, 0.0, -HALF_Z) + 0.3, Vec3::new(HALF_X, HEIGHT, HALF_Z) - 0.3);
                assert!(inner.contains(p), "{}: {p} is not in the room", l.name);
                // Outside every piece of furniture's box, by at least 0.15 m (the closest, lamp 11
                // between sofa and table, is 0.20 m from the sofa): no lamp inside a closed caster.
                for (name, b) in &furniture {
                    let d = distance_to_box(p, b);
                    assert!(d >= 0.15, "{} at {p} is {d} m from {name}'s bounds {b:?}", l.name);
                }
                // Within range of the floor under it.
                let below = Vec3::new(p.x, 0.0, p.z);
                assert!(l.is_relevant(below, Vec3::Y) && l.attenuation(below) > 0.0, "{} misses the floor", l.name);
                // No hot spot on the shell: intensity × attenuation at the nearest wall, floor or
                // ceiling point at most 8 (the brightest, lamp 8 by the east wall, gives 5.6; times
                // the wall's albedo/π, 0.25, that is 1.4, below the tone curve's shoulder).
                let gaps = [p.x + HALF_X, HALF_X - p.x, p.y, HEIGHT - p.y, p.z + HALF_Z, HALF_Z - p.z];
                let nearest = gaps.into_iter().fold(f32::INFINITY, f32::min);
                let hot = l.intensity / (nearest * nearest);
                assert!(hot <= 8.0, "{}: {hot} at {nearest} m", l.name);
            }
        }
    }

    #[test]
    fn lamp_ranges_leave_out_every_corner_for_some_lamp() {
        let s = room("room:lamps=8");
        // Each of the eight lamps misses at least one corner of the floor.
        let corners = [(-HALF_X, -HALF_Z), (HALF_X, -HALF_Z), (HALF_X, HALF_Z), (-HALF_X, HALF_Z)];
        for l in &s.lights[..8] {
            let (p, range) = (l.position().unwrap(), l.range.unwrap());
            let missed = corners.iter().filter(|&&(x, z)| p.distance(Vec3::new(x, 0.0, z)) >= range).count();
            assert!(missed >= 1, "{} reaches every corner", l.name);
        }
        // A chair (0.98 m high, 0.61 m across its diagonal) pushed into any corner of the floor stays
        // inside that corner's 1 m cube; for each corner some lamp's range does not reach the cube,
        // so that lamp need not redraw anything when the chair moves there.
        for (cx, cz) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let corner = Vec3::new(cx * HALF_X, 0.0, cz * HALF_Z);
            let cube = Aabb::from_points([corner, corner - Vec3::new(cx, -1.0, cz)]);
            let missing: Vec<&str> = s
                .lights
                .iter()
                .filter(|l| {
                    let (Some(p), Some(range)) = (l.position(), l.range) else { return false };
                    distance_to_box(p, &cube) >= range
                })
                .map(|l| l.name.as_str())
                .collect();
            assert!(!missing.is_empty(), "every lamp reaches the corner {corner}");
        }
    }

    /// World triangles of each piece of furniture, with their bounds.
    fn furniture_triangles(s: &Scene) -> Vec<(Aabb, Vec<[Vec3; 3]>)> {
        s.instances
            .iter()
            .filter(|i| i.role != Some(Role::Receiver))
            .map(|i| {
                let m = s.mesh(i.mesh);
                let tris: Vec<[Vec3; 3]> =
                    (0..m.triangle_count()).map(|t| m.corners(t).map(|c| i.transform.transform_point3(c))).collect();
                (m.bounds().transformed(&i.transform), tris)
            })
            .collect()
    }

    /// Whether the segment `p → q` crosses a triangle (Möller & Trumbore 1997).
    fn blocked(casters: &[(Aabb, Vec<[Vec3; 3]>)], p: Vec3, q: Vec3) -> bool {
        let d = q - p;
        let segment = Aabb::from_points([p, q]);
        casters.iter().any(|(b, tris)| {
            let overlaps = segment.min.cmple(b.max).all() && b.min.cmple(segment.max).all();
            overlaps
                && tris.iter().any(|&[a, b, c]| {
                    let (e1, e2) = (b - a, c - a);
                    let h = d.cross(e2);
                    let det = e1.dot(h);
                    if det.abs() < 1e-12 {
                        return false;
                    }
                    let s = p - a;
                    let u = s.dot(h) / det;
                    let qv = s.cross(e1);
                    let v = d.dot(qv) / det;
                    let t = e2.dot(qv) / det;
                    u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 1e-4 && t < 1.0 - 1e-4
                })
        })
    }

    #[test]
    fn every_lamp_casts_furniture_shadows_on_floor_and_walls() {
        let s = room("room:lamps=16");
        let casters = furniture_triangles(&s);
        // Points 10 cm apart on the floor and the four walls (not in the window), with their
        // normals into the room.
        let step = 0.1;
        let grid = |a: f32, b: f32| (0..((b - a) / step) as usize).map(move |k| a + (k as f32 + 0.5) * step);
        let mut points = Vec::new();
        for x in grid(-HALF_X, HALF_X) {
            for z in grid(-HALF_Z, HALF_Z) {
                points.push((Vec3::new(x, 0.0, z), Vec3::Y));
            }
            for y in grid(0.0, HEIGHT) {
                points.push((Vec3::new(x, y, -HALF_Z), Vec3::Z));
                points.push((Vec3::new(x, y, HALF_Z), -Vec3::Z));
            }
        }
        for z in grid(-HALF_Z, HALF_Z) {
            for y in grid(0.0, HEIGHT) {
                points.push((Vec3::new(-HALF_X, y, z), Vec3::X));
                let window = (WINDOW_Z.0..=WINDOW_Z.1).contains(&z) && (WINDOW_Y.0..=WINDOW_Y.1).contains(&y);
                if !window {
                    points.push((Vec3::new(HALF_X, y, z), -Vec3::X));
                }
            }
        }
        for l in &s.lights[..16] {
            let p = l.position().unwrap();
            let lit: Vec<Vec3> = points.iter().filter(|(q, n)| l.is_relevant(*q, *n)).map(|(q, _)| *q).collect();
            let shadowed = lit.iter().filter(|&&q| blocked(&casters, q, p)).count();
            let fraction = shadowed as f32 / lit.len() as f32;
            // Each lamp's furniture shadows cover at least 10% of the floor and wall points it
            // reaches (the least, lamp 5 at chair height south of the table, has 12.8%; lamps 1-3
            // have about 25%).
            assert!(fraction >= 0.1, "{}: {shadowed} of {} points in its range are shadowed", l.name, lit.len());
        }
    }
}
