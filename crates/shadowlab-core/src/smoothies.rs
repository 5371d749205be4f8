//! Smoothies: fake soft shadows from the silhouette (Chan & Durand, "Rendering Fake Soft Shadows
//! with Smoothies", EGSR 2003; Toromanoff 2005, algorithm E / Algorithm 7).
//!
//! Each silhouette edge of a caster, seen from the light's centre, gets a quad (a "smoothie")
//! extruded outward, perpendicular to both the edge and the light ray (Toromanoff E step 2:
//! `d = normalize(edge × lightVector)`), and triangles close the gaps at convex silhouette corners
//! (step 5). Every vertex carries its distance from the silhouette along the quad (`offset`, world
//! units): 0 on the edge, the quad's width on the outer border. Seen from the light, a receiver
//! behind a smoothie at blocker distance b reads the offset there and divides it by the outer
//! penumbra's width at that distance, `R·(1 − b/r)` for a receiver at r (Toromanoff's
//! `R·D/(d + D)` with d = b, D = r − b), which ramps visibility from the hard edge outwards. The
//! umbra stays that of the hard map: smoothies only ever add shadow outside it, which is why they
//! "always have an umbra" and are too dark for large lights.

use glam::{Affine3A, Vec3};

use crate::topology::Topology;
use crate::volumes::{LightSource, face_signs, silhouette};

/// A smoothie vertex: world position and distance from the silhouette (world units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SmoothieVertex {
    pub position: Vec3,
    pub offset: f32,
}

/// The smoothies of one caster: triangles, three vertices each. `width(p)` is the smoothie's width
/// at silhouette point p (the widest outer penumbra any receiver can need there).
pub fn smoothies(
    topo: &Topology,
    transform: &Affine3A,
    light: &LightSource,
    two_sided: bool,
    width: impl Fn(Vec3) -> f32,
) -> Vec<[SmoothieVertex; 3]> {
    let world: Vec<Vec3> = topo.positions.iter().map(|&p| transform.transform_point3(p)).collect();
    let mirror = transform.matrix3.determinant() < 0.0;
    let signs = face_signs(topo, &world, light, two_sided, mirror);
    let edges: Vec<(u32, u32)> =
        silhouette(topo, &signs).into_iter().map(|(a, b, _)| if mirror { (b, a) } else { (a, b) }).collect();
    // The lit side is on the left of a→b seen from the light, so outward is (b − a) × towards-light.
    let outward = |a: u32, b: u32, at: u32| -> Option<Vec3> {
        let p = world[at as usize];
        (world[b as usize] - world[a as usize]).cross(light.towards(p)).try_normalize()
    };
    let vertex = |i: u32, dir: Vec3| -> (SmoothieVertex, SmoothieVertex) {
        let p = world[i as usize];
        let w = width(p).max(0.0);
        (SmoothieVertex { position: p, offset: 0.0 }, SmoothieVertex { position: p + dir * w, offset: w })
    };
    let mut out = Vec::with_capacity(edges.len() * 4);
    // Outward directions of the edges arriving at and leaving each vertex, for the corners.
    let mut arriving: std::collections::HashMap<u32, Vec<Vec3>> = std::collections::HashMap::new();
    let mut leaving: std::collections::HashMap<u32, Vec<Vec3>> = std::collections::HashMap::new();
    for &(a, b) in &edges {
        let (Some(da), Some(db)) = (outward(a, b, a), outward(a, b, b)) else { continue };
        let (a0, a1) = vertex(a, da);
        let (b0, b1) = vertex(b, db);
        out.push([a0, b0, b1]);
        out.push([a0, b1, a1]);
        leaving.entry(a).or_default().push(da);
        arriving.entry(b).or_default().push(db);
    }
    for (v, ins) in &arriving {
        let Some(outs) = leaving.get(v) else { continue };
        for &d_in in ins {
            for &d_out in outs {
                // Where consecutive quads leave a wedge between them (a convex corner seen from
                // the light), a triangle fills it; at concave corners they overlap instead.
                let turn = d_in.cross(d_out).dot(light.towards(world[*v as usize]));
                if d_in.dot(d_out) < 0.9999 && turn > 0.0 {
                    let (c, e_in) = vertex(*v, d_in);
                    let (_, e_out) = vertex(*v, d_out);
                    out.push([c, e_in, e_out]);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;
    use crate::primitives;

    fn card_smoothies(w: f32) -> (Vec<[SmoothieVertex; 3]>, Vec3) {
        let mesh: Mesh = primitives::card(1.0, 1.0);
        let topo = Topology::build(&mesh);
        let t = Affine3A::from_translation(Vec3::new(0.0, 1.0, 0.0));
        let light = LightSource::Point(Vec3::new(0.1, 3.0, 0.2));
        (smoothies(&topo, &t, &light, true, |_| w), Vec3::new(0.0, 1.0, 0.0))
    }

    #[test]
    fn card_smoothies_point_outward_and_close_the_corners() {
        let (tris, centre) = card_smoothies(0.2);
        // 4 edges × 2 triangles + 4 convex corners.
        assert_eq!(tris.len(), 12);
        for t in &tris {
            for v in t {
                assert!(v.offset == 0.0 || (v.offset - 0.2).abs() < 1e-6);
                let lateral = Vec3::new(v.position.x - centre.x, 0.0, v.position.z - centre.z);
                if v.offset > 0.0 {
                    // Outer vertices lie outside the card's square (half side 0.5), in its plane
                    // or near it, and never farther than the corner plus the width.
                    assert!(lateral.x.abs() > 0.5 - 1e-4 || lateral.z.abs() > 0.5 - 1e-4, "{v:?}");
                    assert!(lateral.length() <= 0.5f32.hypot(0.5) + 0.2 + 1e-4);
                }
            }
        }
        // No gaps: points just outside the card, all around it, are covered by some smoothie
        // (seen from above, since the light is nearly overhead).
        let cover = |p: Vec3| {
            tris.iter().any(|t| {
                let [a, b, c] = t.map(|v| glam::Vec2::new(v.position.x, v.position.z));
                let q = glam::Vec2::new(p.x, p.z);
                let s = |u: glam::Vec2, v: glam::Vec2| (v - u).perp_dot(q - u);
                let (d1, d2, d3) = (s(a, b), s(b, c), s(c, a));
                !((d1 < 0.0 || d2 < 0.0 || d3 < 0.0) && (d1 > 0.0 || d2 > 0.0 || d3 > 0.0))
            })
        };
        for k in 0..72 {
            let a = (k as f32 * 5.0).to_radians();
            // The square's boundary pushed out by 0.05 along the direction.
            let dir = Vec3::new(a.cos(), 0.0, a.sin());
            let t = 0.5 / dir.x.abs().max(dir.z.abs());
            assert!(cover(centre + dir * (t + 0.05)), "gap at {k}×5°");
        }
    }

    #[test]
    fn mirrored_casters_still_extrude_outward() {
        let mesh: Mesh = primitives::card(1.0, 1.0);
        let topo = Topology::build(&mesh);
        let t = Affine3A::from_scale(Vec3::new(-1.0, 1.0, 1.0)) * Affine3A::from_translation(Vec3::Y);
        let light = LightSource::Directional(Vec3::NEG_Y);
        let tris = smoothies(&topo, &t, &light, true, |_| 0.1);
        assert!(!tris.is_empty());
        for v in tris.iter().flatten().filter(|v| v.offset > 0.0) {
            assert!(v.position.x.abs().max(v.position.z.abs()) > 0.5 - 1e-4, "{v:?}");
        }
    }
}
