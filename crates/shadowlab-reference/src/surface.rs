//! Primary rays on the CPU: a [`SurfaceBuffer`] for a camera view without any GPU.
//!
//! It follows the rasteriser's conventions (`shadowlab_core::camera`): the ray through each pixel
//! centre, back faces of single-sided materials culled (a rasteriser does not draw them), mirrored
//! instances with their winding fixed. A double-sided surface seen from behind turns both its
//! normals by the *facet's* facing (N_g · view direction), as the rasteriser's `front_facing` does,
//! never by the shading normal alone (DESIGN.md §3): at grazing angles the interpolated normal may
//! face the camera while the triangle does not.

use glam::{Affine3A, Mat3, Vec3};
use rayon::prelude::*;
use shadowlab_core::{Scene, SurfaceBuffer, View};

use crate::bvh::{PreparedRay, SceneBvh};

/// Traces the visible surface of every pixel. `bvh` must hold all drawn instances
/// ([`crate::bvh::Selection::All`]).
pub fn trace_surface(bvh: &SceneBvh, scene: &Scene, view: &View, width: u32, height: u32) -> SurfaceBuffer {
    let normal_matrices: Vec<(Mat3, bool)> = scene
        .instances
        .iter()
        .map(|i| {
            let t: Affine3A = i.transform;
            (Mat3::from(t.matrix3).inverse().transpose(), scene.material(i.material).double_sided)
        })
        .collect();
    let mut buf = SurfaceBuffer::new(width, height);
    let w = width as usize;
    type Row = (Vec<Vec3>, Vec<Vec3>, Vec<Vec3>, Vec<bool>);
    let rows: Vec<Row> = (0..height)
        .into_par_iter()
        .map(|y| {
            let mut row: Row = (vec![Vec3::ZERO; w], vec![Vec3::Y; w], vec![Vec3::Y; w], vec![false; w]);
            for x in 0..width {
                let (o, d) = view.pixel_ray(x, y, width, height);
                // The near and far planes clip like the rasteriser's depth range (along the axis).
                let cos = d.dot(view.forward()).max(1e-6);
                let ray = PreparedRay::new(o, d, view.near / cos, view.far / cos);
                let hit = bvh.closest(&ray, |tri, front| front || normal_matrices[tri.instance as usize].1);
                if let Some(hit) = hit {
                    let tri = &bvh.triangles()[hit.index as usize];
                    let inst = &scene.instances[tri.instance as usize];
                    let mesh = scene.mesh(inst.mesh);
                    let corners = mesh.triangles[tri.triangle as usize];
                    let b = hit.barycentric;
                    let local = b.x * mesh.normals[corners[0] as usize]
                        + b.y * mesh.normals[corners[1] as usize]
                        + b.z * mesh.normals[corners[2] as usize];
                    let mut n = (normal_matrices[tri.instance as usize].0 * local).normalize_or(Vec3::Y);
                    let [a, b, c] = tri.v.map(Vec3::from);
                    let mut ng = (b - a).cross(c - a).normalize_or(n);
                    if ng.dot(d) > 0.0 {
                        // The facet faces away: the back of a double-sided surface (single-sided
                        // backs are culled above; mirrored corners are already swapped).
                        ng = -ng;
                        n = -n;
                    }
                    row.0[x as usize] = o + d * hit.t;
                    row.1[x as usize] = n;
                    row.2[x as usize] = ng;
                    row.3[x as usize] = true;
                }
            }
            row
        })
        .collect();
    for (y, (p, n, ng, c)) in rows.into_iter().enumerate() {
        buf.positions[y * w..(y + 1) * w].copy_from_slice(&p);
        buf.normals[y * w..(y + 1) * w].copy_from_slice(&n);
        buf.geometric_normals[y * w..(y + 1) * w].copy_from_slice(&ng);
        buf.covered[y * w..(y + 1) * w].copy_from_slice(&c);
    }
    buf
}
