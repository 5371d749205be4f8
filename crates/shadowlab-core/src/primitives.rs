//! Procedural meshes: the building blocks of the built-in scenes and of the TOML `primitive` key.
//!
//! Every solid here is closed and 2-manifold after position welding (shadow volumes need that), with
//! counter-clockwise, outward-facing triangles. The only open primitive is [`plane`].

use glam::{Affine3A, Vec2, Vec3};
use rustc_hash::FxHashMap;

use crate::mesh::{Mesh, canonical_bits};

/// Crease angle below which neighbouring faces are smoothed: keeps boxes flat, cylinders round.
const CREASE_DEGREES: f32 = 50.0;

/// Axis-aligned box of the given full size, centred on the origin.
pub fn cuboid(size: Vec3) -> Mesh {
    let h = 0.5 * size;
    let p: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 != 0 { h.x } else { -h.x },
                if i & 2 != 0 { h.y } else { -h.y },
                if i & 4 != 0 { h.z } else { -h.z },
            )
        })
        .collect();
    // Corner i has x = bit 0, y = bit 1, z = bit 2. Each face: two CCW triangles seen from outside.
    let quads: [[u32; 4]; 6] = [
        [1, 3, 7, 5], // +x
        [0, 4, 6, 2], // -x
        [2, 6, 7, 3], // +y
        [0, 1, 5, 4], // -y
        [4, 5, 7, 6], // +z
        [0, 2, 3, 1], // -z
    ];
    let tris: Vec<[u32; 3]> = quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
    Mesh::with_computed_normals("box", &p, &tris, CREASE_DEGREES)
}

/// Box spanning `min..max`.
pub fn cuboid_between(min: Vec3, max: Vec3) -> Mesh {
    let mut m = Mesh::new("box");
    m.append(&cuboid(max - min), &Affine3A::from_translation(0.5 * (min + max)));
    m
}

/// A flat, open, single-sided rectangle in the XZ plane facing +Y, centred on the origin, split
/// into `nx × nz` quads.
pub fn plane(width: f32, depth: f32, nx: u32, nz: u32) -> Mesh {
    heightfield(width, depth, nx, nz, |_, _| 0.0)
}

/// An open grid in XZ with heights `h(x, z)`, facing +Y, centred on the origin.
pub fn heightfield(width: f32, depth: f32, nx: u32, nz: u32, h: impl Fn(f32, f32) -> f32) -> Mesh {
    let (nx, nz) = (nx.max(1), nz.max(1));
    let mut positions = Vec::with_capacity(((nx + 1) * (nz + 1)) as usize);
    for k in 0..=nz {
        for i in 0..=nx {
            let x = width * (i as f32 / nx as f32 - 0.5);
            let z = depth * (k as f32 / nz as f32 - 0.5);
            positions.push(Vec3::new(x, h(x, z), z));
        }
    }
    let row = nx + 1;
    let mut tris = Vec::with_capacity((2 * nx * nz) as usize);
    for k in 0..nz {
        for i in 0..nx {
            let a = k * row + i;
            let (b, c, d) = (a + 1, a + row + 1, a + row);
            // Seen from +Y (x right, z towards the viewer), a → d → c is counter-clockwise.
            tris.push([a, d, c]);
            tris.push([a, c, b]);
        }
    }
    // 180°: a terrain is one smooth surface.
    Mesh::with_computed_normals("grid", &positions, &tris, 180.0)
}

/// A surface of revolution around +Y of a profile of `(radius, height)` points.
///
/// With `closed_loop == false` the profile must start and end on the axis (radius 0), which makes a
/// solid (sphere, cylinder, cup); with `closed_loop == true` the profile is a loop away from the axis
/// (a torus). Points on the axis become single pole vertices, so the result is closed and
/// 2-manifold. The winding is made outward whatever the profile's direction.
pub fn lathe(profile: &[Vec2], closed_loop: bool, segments: u32) -> Mesh {
    let segments = segments.max(3);
    let mut weld: FxHashMap<[u32; 3], u32> = FxHashMap::default();
    let mut positions: Vec<Vec3> = Vec::new();
    let mut grid: Vec<Vec<u32>> = Vec::with_capacity(profile.len());
    for q in profile {
        let mut ring = Vec::with_capacity(segments as usize);
        for j in 0..segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            let p =
                if q.x == 0.0 { Vec3::new(0.0, q.y, 0.0) } else { Vec3::new(q.x * phi.cos(), q.y, q.x * phi.sin()) };
            let key = p.to_array().map(canonical_bits);
            let next = positions.len() as u32;
            ring.push(*weld.entry(key).or_insert_with(|| {
                positions.push(p);
                next
            }));
        }
        grid.push(ring);
    }
    let rows = if closed_loop { profile.len() } else { profile.len().saturating_sub(1) };
    let mut tris = Vec::new();
    for k in 0..rows {
        let (r0, r1) = (&grid[k], &grid[(k + 1) % profile.len()]);
        for j in 0..segments as usize {
            let jn = (j + 1) % segments as usize;
            for t in [[r0[j], r1[j], r1[jn]], [r0[j], r1[jn], r0[jn]]] {
                if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                    tris.push(t);
                }
            }
        }
    }
    orient_outward(&positions, &mut tris);
    Mesh::with_computed_normals("lathe", &positions, &tris, CREASE_DEGREES)
}

/// Sphere of `radius` centred on the origin (UV sphere with single-vertex poles).
pub fn sphere(radius: f32, segments: u32, rings: u32) -> Mesh {
    let rings = rings.max(2);
    let profile: Vec<Vec2> = (0..=rings)
        .map(|i| {
            let theta = std::f32::consts::PI * i as f32 / rings as f32;
            if i == 0 || i == rings {
                // Exactly on the axis, so the poles weld to single vertices.
                Vec2::new(0.0, if i == 0 { radius } else { -radius })
            } else {
                Vec2::new(radius * theta.sin(), radius * theta.cos())
            }
        })
        .collect();
    let mut m = lathe(&profile, false, segments);
    // A sphere is smooth everywhere: recompute without creases.
    m = Mesh::with_computed_normals("sphere", &m.positions, &m.triangles, 180.0);
    m.name = "sphere".to_owned();
    m
}

/// Closed cylinder of `radius` standing on the origin, from y = 0 to y = `height`.
pub fn cylinder(radius: f32, height: f32, segments: u32) -> Mesh {
    let mut m = lathe(
        &[Vec2::new(0.0, 0.0), Vec2::new(radius, 0.0), Vec2::new(radius, height), Vec2::new(0.0, height)],
        false,
        segments,
    );
    m.name = "cylinder".to_owned();
    m
}

/// Closed cone of base `radius` standing on the origin, apex at y = `height`.
pub fn cone(radius: f32, height: f32, segments: u32) -> Mesh {
    let mut m = lathe(&[Vec2::new(0.0, 0.0), Vec2::new(radius, 0.0), Vec2::new(0.0, height)], false, segments);
    m.name = "cone".to_owned();
    m
}

/// Torus around +Y: tube of radius `minor` around a circle of radius `major`.
pub fn torus(major: f32, minor: f32, segments: u32, tube_segments: u32) -> Mesh {
    let n = tube_segments.max(3);
    let profile: Vec<Vec2> = (0..n)
        .map(|i| {
            let a = std::f32::consts::TAU * i as f32 / n as f32;
            Vec2::new(major + minor * a.cos(), minor * a.sin())
        })
        .collect();
    let mut m = lathe(&profile, true, segments);
    m = Mesh::with_computed_normals("torus", &m.positions, &m.triangles, 180.0);
    m.name = "torus".to_owned();
    m
}

/// A zero-thickness rectangle in the XZ plane that is closed: two back-to-back faces sharing the
/// four corners, split along different diagonals so that every edge has exactly two faces. It casts
/// the shadow of an infinitely thin card (what analytic oracles assume) and still works with
/// back-face shadow maps and shadow volumes, which need closed meshes.
pub fn card(width: f32, depth: f32) -> Mesh {
    let (hx, hz) = (0.5 * width, 0.5 * depth);
    let p = vec![Vec3::new(-hx, 0.0, -hz), Vec3::new(hx, 0.0, -hz), Vec3::new(hx, 0.0, hz), Vec3::new(-hx, 0.0, hz)];
    // Top (+Y) along diagonal 0-2, bottom (−Y) along diagonal 1-3.
    let tris = vec![[0, 3, 2], [0, 2, 1], [1, 2, 3], [1, 3, 0]];
    let mut m = Mesh::with_computed_normals("card", &p, &tris, CREASE_DEGREES);
    m.name = "card".to_owned();
    m
}

/// A slab in the XY plane (x in `0..width`, y in `0..height`, z in `0..thickness`) with a
/// rectangular hole through it from `hole_min` to `hole_max` (in x, y): a wall with a window or a
/// doorway, closed and 2-manifold (genus 1). The hole must lie strictly inside the slab.
pub fn slab_with_hole(width: f32, height: f32, thickness: f32, hole_min: Vec2, hole_max: Vec2) -> Mesh {
    let outer = [Vec2::new(0.0, 0.0), Vec2::new(width, 0.0), Vec2::new(width, height), Vec2::new(0.0, height)];
    let inner = [hole_min, Vec2::new(hole_max.x, hole_min.y), hole_max, Vec2::new(hole_min.x, hole_max.y)];
    // Vertex index: outer k at z=0 → k, at z=t → 4+k; inner k at z=0 → 8+k, at z=t → 12+k.
    let mut p = Vec::with_capacity(16);
    for ring in [&outer, &inner] {
        for z in [0.0, thickness] {
            p.extend(ring.iter().map(|q| Vec3::new(q.x, q.y, z)));
        }
    }
    let (o0, o1, i0, i1) = (0u32, 4u32, 8u32, 12u32);
    let mut quads: Vec<[u32; 4]> = Vec::new();
    for k in 0..4u32 {
        let n = (k + 1) % 4;
        quads.push([o1 + k, o1 + n, i1 + n, i1 + k]); // front face ring (z = t)
        quads.push([o0 + n, o0 + k, i0 + k, i0 + n]); // back face ring (z = 0)
        quads.push([o0 + k, o0 + n, o1 + n, o1 + k]); // outer rim
        quads.push([i0 + n, i0 + k, i1 + k, i1 + n]); // hole sides
    }
    let mut tris: Vec<[u32; 3]> = quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
    orient_outward(&p, &mut tris);
    Mesh::with_computed_normals("slab", &p, &tris, CREASE_DEGREES)
}

/// A box of `size` centred on the origin with edges rounded by `radius`, built from a cube whose
/// faces are split `n × n` and pushed onto the rounded shape. Corners of the lattice are shared
/// exactly between faces, so the mesh is closed.
pub fn rounded_box(size: Vec3, radius: f32, n: u32) -> Mesh {
    let n = n.max(2) as i32;
    let half = 0.5 * size;
    let r = radius.clamp(0.0, half.min_element());
    let inner = half - Vec3::splat(r);
    let mut index: FxHashMap<[i32; 3], u32> = FxHashMap::default();
    let mut positions: Vec<Vec3> = Vec::new();
    let mut tris: Vec<[u32; 3]> = Vec::new();
    let mut vertex = |l: [i32; 3]| -> u32 {
        let next = positions.len() as u32;
        *index.entry(l).or_insert_with(|| {
            // Lattice point on the unit cube → point on the rounded box.
            let q = Vec3::new(l[0] as f32, l[1] as f32, l[2] as f32) / n as f32 * 2.0 - Vec3::ONE;
            let c = (q * half).clamp(-inner, inner);
            let d = q * half - c;
            positions.push(c + if d.length_squared() > 0.0 { d.normalize() * r } else { Vec3::ZERO });
            next
        })
    };
    // Each face: axis `a` fixed at 0 or n, the other two (u, v) run over the grid.
    for a in 0..3usize {
        for side in [0, n] {
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            for i in 0..n {
                for j in 0..n {
                    let corner = |di: i32, dj: i32| {
                        let mut l = [0i32; 3];
                        l[a] = side;
                        l[u] = i + di;
                        l[v] = j + dj;
                        l
                    };
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)].map(&mut vertex);
                    // (u, v, a) is right-handed: counter-clockwise seen from +a; flip for the low side.
                    if side == n {
                        tris.push([q[0], q[1], q[2]]);
                        tris.push([q[0], q[2], q[3]]);
                    } else {
                        tris.push([q[0], q[2], q[1]]);
                        tris.push([q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    let mut m = Mesh::with_computed_normals("rounded box", &positions, &tris, CREASE_DEGREES);
    m.name = "rounded box".to_owned();
    m
}

/// A box of square cross-section `thickness` running from `a` to `b`: beams, braces, slats.
pub fn beam(a: Vec3, b: Vec3, thickness: f32) -> Mesh {
    let axis = b - a;
    let len = axis.length().max(1e-6);
    let rot = glam::Quat::from_rotation_arc(Vec3::Y, axis / len);
    let mut m = Mesh::new("beam");
    m.append(&cuboid(Vec3::new(thickness, len, thickness)), &Affine3A::from_rotation_translation(rot, 0.5 * (a + b)));
    m
}

/// A gable-roof prism: triangular cross-section of `width` (x) and `height` (y), `depth` long (z),
/// standing on the origin.
pub fn prism(width: f32, height: f32, depth: f32) -> Mesh {
    let (hx, hz) = (0.5 * width, 0.5 * depth);
    let p = vec![
        Vec3::new(-hx, 0.0, -hz),
        Vec3::new(hx, 0.0, -hz),
        Vec3::new(0.0, height, -hz),
        Vec3::new(-hx, 0.0, hz),
        Vec3::new(hx, 0.0, hz),
        Vec3::new(0.0, height, hz),
    ];
    let mut tris = vec![[0, 2, 1], [3, 4, 5], [0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4], [2, 0, 3], [2, 3, 5]];
    orient_outward(&p, &mut tris);
    let mut m = Mesh::with_computed_normals("prism", &p, &tris, CREASE_DEGREES);
    m.name = "prism".to_owned();
    m
}

/// Six times the signed volume enclosed by the triangles (positive when they face outward).
pub fn signed_volume6(positions: &[Vec3], tris: &[[u32; 3]]) -> f32 {
    // Relative to the centroid, for precision far from the origin.
    let c = positions.iter().copied().sum::<Vec3>() / positions.len().max(1) as f32;
    tris.iter()
        .map(|t| {
            let [a, b, d] = t.map(|i| positions[i as usize] - c);
            a.dot(b.cross(d))
        })
        .sum()
}

/// Flips all triangles when they enclose a negative volume.
fn orient_outward(positions: &[Vec3], tris: &mut [[u32; 3]]) {
    if signed_volume6(positions, tris) < 0.0 {
        for t in tris {
            t.swap(1, 2);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::Topology;

    fn assert_closed_outward(m: &Mesh, expected_volume: f32, tolerance: f32) {
        m.check().unwrap();
        let topo = Topology::build(m);
        let r = topo.report();
        assert!(r.is_closed_manifold(), "{}: {r:?}", m.name);
        assert!(r.consistently_oriented, "{}", m.name);
        let v = signed_volume6(&m.positions, &m.triangles) / 6.0;
        assert!((v - expected_volume).abs() <= tolerance * expected_volume, "{}: {v} vs {expected_volume}", m.name);
        // Stored normals agree with the winding.
        for t in 0..m.triangle_count() {
            let fa = m.face_normal_area(t);
            let n: Vec3 = m.triangles[t].iter().map(|&i| m.normals[i as usize]).sum();
            assert!(fa.dot(n) >= 0.0, "{}: triangle {t} normal disagrees with winding", m.name);
        }
    }

    #[test]
    fn solids_are_closed_and_outward() {
        use std::f32::consts::PI;
        assert_closed_outward(&cuboid(Vec3::new(1.0, 2.0, 3.0)), 6.0, 1e-5);
        assert_closed_outward(&sphere(1.0, 64, 32), 4.0 / 3.0 * PI, 0.01);
        assert_closed_outward(&cylinder(0.5, 2.0, 64), PI * 0.25 * 2.0, 0.01);
        assert_closed_outward(&cone(1.0, 3.0, 64), PI * 1.0 / 3.0 * 3.0, 0.01);
        assert_closed_outward(&torus(2.0, 0.5, 64, 32), 2.0 * PI * PI * 2.0 * 0.25, 0.01);
        assert_closed_outward(
            &slab_with_hole(4.0, 3.0, 0.2, Vec2::new(1.0, 1.0), Vec2::new(2.0, 2.5)),
            0.2 * (12.0 - 1.5),
            1e-5,
        );
        assert_closed_outward(&rounded_box(Vec3::new(2.0, 1.0, 1.0), 0.0, 4), 2.0, 1e-5);
        assert_closed_outward(&beam(Vec3::ZERO, Vec3::new(1.0, 2.0, 2.0), 0.1), 0.03, 1e-4);
        assert_closed_outward(&prism(2.0, 1.0, 3.0), 3.0, 1e-5);
        // Inner box a×b×c grown by r: V = abc + 2r(ab + bc + ca) + πr²(a + b + c) + 4/3 πr³.
        let r = 0.25f32;
        let (a, b, c) = (2.0 - 2.0 * r, 1.0 - 2.0 * r, 1.0 - 2.0 * r);
        let v = a * b * c + 2.0 * r * (a * b + b * c + c * a) + PI * r * r * (a + b + c) + 4.0 / 3.0 * PI * r.powi(3);
        assert_closed_outward(&rounded_box(Vec3::new(2.0, 1.0, 1.0), r, 16), v, 0.01);
        assert_eq!(cuboid(Vec3::ONE).triangle_count(), 12);
        assert_eq!(cuboid(Vec3::ONE).vertex_count(), 24, "flat faces split their corners");
    }

    #[test]
    fn card_is_closed_with_zero_volume() {
        let m = card(1.0, 1.0);
        let r = Topology::build(&m).report();
        assert!(r.is_closed_manifold(), "{r:?}");
        assert_eq!((r.welded_vertices, r.edges, r.triangles), (4, 6, 4));
        assert!(signed_volume6(&m.positions, &m.triangles).abs() < 1e-6);
        assert!(m.face_normal_area(0).y > 0.0 && m.face_normal_area(2).y < 0.0);
    }

    #[test]
    fn plane_is_open_and_faces_up() {
        let m = plane(4.0, 4.0, 2, 2);
        assert_eq!(m.triangle_count(), 8);
        for t in 0..m.triangle_count() {
            assert!(m.face_normal_area(t).y > 0.0);
        }
        assert!(!Topology::build(&m).report().is_closed_manifold());
    }
}
