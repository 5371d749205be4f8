//! Indexed triangle meshes.

use glam::{Affine3A, Vec2, Vec3};
use rustc_hash::FxHashMap;

use crate::bounds::Aabb;

/// Triangles above which [`Mesh::part_bounds`] keeps one box (a sort per axis and level).
pub const PART_BOUNDS_MAX_TRIANGLES: usize = 4096;

/// An indexed triangle mesh in its own (object) space.
///
/// Triangles are counter-clockwise when seen from the front (the side their normals point to), as in
/// glTF and OBJ. `normals` has one entry per position; `uvs`, when present, too.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Option<Vec<Vec2>>,
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn new(name: impl Into<String>) -> Self {
        Self { name: name.into(), ..Self::default() }
    }

    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Bounds of the vertices that triangles use (unreferenced vertices, common in scans, do not count).
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for t in &self.triangles {
            for &i in t {
                if let Some(&p) = self.positions.get(i as usize) {
                    b.grow(p);
                }
            }
        }
        b
    }

    /// Boxes that together hold every triangle: the triangles split in two, `depth` times, where
    /// the boxes' surfaces weighed by their triangles add up least (the surface area heuristic of
    /// bounding volume hierarchies; each axis tried, the triangles in the order
    /// of their centroids), so at most 2^depth boxes. A mesh of several parts, such as three walls
    /// in one mesh, gets a box around each instead of one around the room. Meshes of more than
    /// [`PART_BOUNDS_MAX_TRIANGLES`] triangles (scanned models, compact anyway) keep one box.
    /// Triangles with a vertex out of range are left out, as [`Mesh::bounds`] leaves the vertex out.
    pub fn part_bounds(&self, depth: u32) -> Vec<Aabb> {
        let valid = |t: &[u32; 3]| t.iter().all(|&i| (i as usize) < self.positions.len());
        let tris: Vec<usize> = (0..self.triangles.len()).filter(|&t| valid(&self.triangles[t])).collect();
        if tris.len() > PART_BOUNDS_MAX_TRIANGLES {
            return vec![self.bounds()];
        }
        let mut parts = Vec::new();
        self.split_parts(tris, depth, &mut parts);
        parts
    }

    fn split_parts(&self, mut tris: Vec<usize>, depth: u32, parts: &mut Vec<Aabb>) {
        let boxed = |t: usize| {
            let mut b = Aabb::EMPTY;
            for p in self.corners(t) {
                b.grow(p);
            }
            b
        };
        // Surface area, not volume: a flat box (the tops of three walls) has no volume but spans
        // the room.
        let area = |b: &Aabb| {
            let e = b.extent();
            e.x * e.y + e.y * e.z + e.z * e.x
        };
        if tris.is_empty() {
            return;
        }
        if depth == 0 || tris.len() < 2 {
            parts.push(tris.iter().fold(Aabb::EMPTY, |b, &t| b.union(&boxed(t))));
            return;
        }
        // The best cut: (cost, axis, triangles before it).
        let mut best = (f32::INFINITY, 0, tris.len() / 2);
        for axis in 0..3 {
            let centroid = |t: usize| (self.corners(t).iter().copied().sum::<Vec3>() / 3.0)[axis];
            tris.sort_by(|&a, &b| centroid(a).total_cmp(&centroid(b)));
            // Suffix boxes, then a sweep of prefix boxes.
            let mut after = vec![Aabb::EMPTY; tris.len() + 1];
            for i in (0..tris.len()).rev() {
                after[i] = after[i + 1].union(&boxed(tris[i]));
            }
            let mut before = Aabb::EMPTY;
            for i in 1..tris.len() {
                before = before.union(&boxed(tris[i - 1]));
                let v = area(&before) * i as f32 + area(&after[i]) * (tris.len() - i) as f32;
                if v < best.0 {
                    best = (v, axis, i);
                }
            }
        }
        let (_, axis, cut) = best;
        let centroid = |t: usize| (self.corners(t).iter().copied().sum::<Vec3>() / 3.0)[axis];
        tris.sort_by(|&a, &b| centroid(a).total_cmp(&centroid(b)));
        let rest = tris.split_off(cut);
        self.split_parts(tris, depth - 1, parts);
        self.split_parts(rest, depth - 1, parts);
    }

    /// The triangle's three corner positions.
    pub fn corners(&self, t: usize) -> [Vec3; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }

    /// Unnormalised face normal (twice the area, pointing to the front side).
    pub fn face_normal_area(&self, t: usize) -> Vec3 {
        let [a, b, c] = self.corners(t);
        (b - a).cross(c - a)
    }

    /// Appends `other` (transformed by `transform`) to this mesh. Normals follow the inverse
    /// transpose; a mirroring transform flips the winding so that fronts stay fronts.
    pub fn append(&mut self, other: &Mesh, transform: &Affine3A) {
        let base = self.positions.len() as u32;
        let normal_matrix = transform.matrix3.inverse().transpose();
        let mirror = transform.matrix3.determinant() < 0.0;
        self.positions.extend(other.positions.iter().map(|&p| transform.transform_point3(p)));
        self.normals.extend(other.normals.iter().map(|&n| (normal_matrix * n).normalize_or(Vec3::Y)));
        match (&mut self.uvs, &other.uvs) {
            (Some(a), Some(b)) => a.extend_from_slice(b),
            (Some(a), None) => a.extend(std::iter::repeat_n(Vec2::ZERO, other.positions.len())),
            (None, Some(b)) if base == 0 => self.uvs = Some(b.clone()),
            (None, Some(b)) => {
                let mut uvs = vec![Vec2::ZERO; base as usize];
                uvs.extend_from_slice(b);
                self.uvs = Some(uvs);
            }
            (None, None) => {}
        }
        self.triangles.extend(
            other
                .triangles
                .iter()
                .map(|&[a, b, c]| if mirror { [a + base, c + base, b + base] } else { [a + base, b + base, c + base] }),
        );
    }

    /// Checks the invariants every consumer relies on. Returns a message naming the first problem.
    ///
    /// Rejected: no triangles, NaN or infinite positions/normals/uvs, index out of range, array
    /// lengths that disagree. Degenerate (zero-area) triangles are allowed: scans have them.
    pub fn check(&self) -> Result<(), String> {
        if self.triangles.is_empty() {
            return Err(format!("mesh '{}' is empty (no triangles)", self.name));
        }
        if self.normals.len() != self.positions.len() {
            return Err(format!(
                "mesh '{}' has {} normals for {} positions",
                self.name,
                self.normals.len(),
                self.positions.len()
            ));
        }
        if let Some(uvs) = &self.uvs
            && uvs.len() != self.positions.len()
        {
            return Err(format!("mesh '{}' has {} uvs for {} positions", self.name, uvs.len(), self.positions.len()));
        }
        if let Some(i) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(format!("mesh '{}': position {i} is not finite: {}", self.name, self.positions[i]));
        }
        if let Some(i) = self.normals.iter().position(|n| !n.is_finite()) {
            return Err(format!("mesh '{}': normal {i} is not finite: {}", self.name, self.normals[i]));
        }
        if let Some(uvs) = &self.uvs
            && let Some(i) = uvs.iter().position(|t| !t.is_finite())
        {
            return Err(format!("mesh '{}': uv {i} is not finite: {}", self.name, uvs[i]));
        }
        let n = self.positions.len() as u32;
        if let Some((t, tri)) = self.triangles.iter().enumerate().find(|(_, t)| t.iter().any(|&i| i >= n)) {
            return Err(format!(
                "mesh '{}': triangle {t} has index {:?} out of range (the mesh has {n} vertices)",
                self.name, tri
            ));
        }
        Ok(())
    }

    /// Replaces normals that are zero, not finite or not unit length: normalises those that can be,
    /// and gives the rest the area-weighted normal of the faces around the vertex.
    pub fn repair_normals(&mut self) {
        self.normals.resize(self.positions.len(), Vec3::ZERO);
        let mut bad = false;
        for n in &mut self.normals {
            let len = n.length();
            if len.is_finite() && len > 1e-12 {
                *n /= len;
            } else {
                *n = Vec3::ZERO;
                bad = true;
            }
        }
        if !bad {
            return;
        }
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for (t, tri) in self.triangles.iter().enumerate() {
            let fa = self.face_normal_area(t);
            for &i in tri {
                acc[i as usize] += fa;
            }
        }
        for (n, a) in self.normals.iter_mut().zip(acc) {
            if *n == Vec3::ZERO {
                *n = a.normalize_or(Vec3::Y);
            }
        }
    }

    /// Builds a mesh from positions and triangles alone, computing normals: faces meeting at a shared
    /// position are smoothed together when their normals differ by less than `crease_degrees`, and
    /// split (the vertex duplicated) otherwise. 0° gives flat shading; 180° smooths everything.
    /// Positions are shared by exact equality, so a mesh whose corners are already split still
    /// smooths across the split.
    pub fn with_computed_normals(
        name: impl Into<String>,
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        crease_degrees: f32,
    ) -> Mesh {
        Self::with_computed_normals_and_uvs(name, positions, None, triangles, crease_degrees)
    }

    /// [`Mesh::with_computed_normals`], carrying per-position texture coordinates along.
    pub fn with_computed_normals_and_uvs(
        name: impl Into<String>,
        positions: &[Vec3],
        uvs: Option<&[Vec2]>,
        triangles: &[[u32; 3]],
        crease_degrees: f32,
    ) -> Mesh {
        let cos_crease = crease_degrees.clamp(0.0, 180.0).to_radians().cos();
        // Weld by exact position so that smoothing sees across split vertices.
        let mut weld: FxHashMap<[u32; 3], u32> = FxHashMap::default();
        let welded: Vec<u32> = positions
            .iter()
            .map(|p| {
                let key = p.to_array().map(canonical_bits);
                let next = weld.len() as u32;
                *weld.entry(key).or_insert(next)
            })
            .collect();
        let face_normals: Vec<Vec3> = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                (b - a).cross(c - a)
            })
            .collect();
        // Faces around each welded position.
        let mut around: Vec<Vec<u32>> = vec![Vec::new(); weld.len()];
        for (f, t) in triangles.iter().enumerate() {
            for &i in t {
                let w = welded[i as usize] as usize;
                if around[w].last() != Some(&(f as u32)) {
                    around[w].push(f as u32);
                }
            }
        }
        let mut mesh = Mesh::new(name);
        let mut out_uvs = uvs.map(|_| Vec::new());
        // A corner's vertex is identified by (original index, smoothed normal bits).
        let mut vertex_of: FxHashMap<(u32, [u32; 3]), u32> = FxHashMap::default();
        for (f, t) in triangles.iter().enumerate() {
            let nf = face_normals[f].normalize_or_zero();
            let mut out = [0u32; 3];
            for (k, &i) in t.iter().enumerate() {
                let w = welded[i as usize] as usize;
                let mut n = Vec3::ZERO;
                for &g in &around[w] {
                    let ng = face_normals[g as usize];
                    if g as usize == f || nf.dot(ng.normalize_or_zero()) >= cos_crease {
                        // Area weighting: larger faces dominate, slivers barely count.
                        n += ng;
                    }
                }
                let n = n.normalize_or(if nf == Vec3::ZERO { Vec3::Y } else { nf });
                let key = (i, n.to_array().map(canonical_bits));
                let next = mesh.positions.len() as u32;
                out[k] = *vertex_of.entry(key).or_insert_with(|| {
                    mesh.positions.push(positions[i as usize]);
                    mesh.normals.push(n);
                    if let (Some(out), Some(src)) = (&mut out_uvs, uvs) {
                        out.push(src.get(i as usize).copied().unwrap_or(Vec2::ZERO));
                    }
                    next
                });
            }
            mesh.triangles.push(out);
        }
        mesh.uvs = out_uvs;
        mesh
    }
}

/// Float bits with -0.0 folded onto 0.0, for hashing positions by exact value.
pub(crate) fn canonical_bits(x: f32) -> u32 {
    if x == 0.0 { 0 } else { x.to_bits() }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        (vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, -1.0), Vec3::new(0.0, 0.0, -1.0)], vec![[0, 1, 2], [0, 2, 3]])
    }

    /// Every triangle lies in one of the boxes, the boxes lie in the mesh's bounds, there are at
    /// most 2^depth of them, and three separate walls get three thin boxes, not the room.
    #[test]
    fn part_bounds_hold_every_triangle() {
        use crate::primitives::cuboid_between;
        let walls = [
            cuboid_between(Vec3::new(-2.6, 0.0, -2.1), Vec3::new(-2.5, 2.6, 2.1)),
            cuboid_between(Vec3::new(-2.5, 0.0, -2.1), Vec3::new(2.5, 2.6, -2.0)),
            cuboid_between(Vec3::new(-2.5, 0.0, 2.0), Vec3::new(2.5, 2.6, 2.1)),
        ];
        let (mut positions, mut triangles) = (Vec::new(), Vec::new());
        for w in &walls {
            let base = positions.len() as u32;
            positions.extend(&w.positions);
            triangles.extend(w.triangles.iter().map(|t| t.map(|i| i + base)));
        }
        let mesh = Mesh::with_computed_normals("walls", &positions, &triangles, 30.0);
        let whole = mesh.bounds();
        for depth in 0..5 {
            let parts = mesh.part_bounds(depth);
            assert!(!parts.is_empty() && parts.len() <= 1 << depth, "depth {depth}: {} parts", parts.len());
            for b in &parts {
                assert!(whole.contains(b.min) && whole.contains(b.max), "depth {depth}: {b:?} outside {whole:?}");
            }
            for t in 0..mesh.triangle_count() {
                let inside = |b: &Aabb| mesh.corners(t).iter().all(|&p| b.contains(p));
                assert!(parts.iter().any(inside), "depth {depth}: triangle {t} in no box");
            }
            let volume = |b: &Aabb| b.extent().x * b.extent().y * b.extent().z;
            let total: f32 = parts.iter().map(volume).sum();
            if depth >= 3 {
                // The walls' own volume is 0.1 × 2.6 × (4.2 + 5 + 5) m³ = 3.7 m³, the room's box
                // 56.8 m³: the boxes must stay near the walls.
                assert!(total < 0.25 * volume(&whole), "depth {depth}: {total} m³ of boxes");
            }
        }
        assert!(Mesh::with_computed_normals("none", &[], &[], 30.0).part_bounds(3).is_empty());
    }

    #[test]
    fn computed_normals_face_the_front() {
        let (p, t) = quad();
        let m = Mesh::with_computed_normals("q", &p, &t, 30.0);
        assert_eq!(m.positions.len(), 4);
        for n in &m.normals {
            assert!((*n - Vec3::Y).length() < 1e-6, "{n}");
        }
        m.check().unwrap();
    }

    #[test]
    fn crease_splits_a_folded_edge() {
        // Two faces folded at 90 degrees along the x axis.
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.0, -1.0, 0.0)];
        let t = vec![[0, 1, 2], [0, 3, 1]];
        let flat = Mesh::with_computed_normals("f", &p, &t, 30.0);
        assert_eq!(flat.positions.len(), 6, "shared edge vertices are split");
        let smooth = Mesh::with_computed_normals("s", &p, &t, 120.0);
        assert_eq!(smooth.positions.len(), 4, "shared edge vertices are smoothed");
    }

    #[test]
    fn check_rejects_bad_meshes() {
        let (p, t) = quad();
        let mut m = Mesh::with_computed_normals("q", &p, &t, 30.0);
        m.positions[1].y = f32::NAN;
        assert!(m.check().unwrap_err().contains("not finite"));
        let mut m = Mesh::with_computed_normals("q", &p, &t, 30.0);
        m.triangles[1][2] = 9;
        assert!(m.check().unwrap_err().contains("out of range"));
        let m = Mesh::new("empty");
        assert!(m.check().unwrap_err().contains("empty"));
    }

    #[test]
    fn append_mirrors_winding() {
        let (p, t) = quad();
        let q = Mesh::with_computed_normals("q", &p, &t, 30.0);
        let mut m = Mesh::new("m");
        m.append(&q, &Affine3A::from_scale(Vec3::new(1.0, -1.0, 1.0)));
        // After mirroring in y the face normal points down, and so does the stored normal.
        assert!(m.face_normal_area(0).y < 0.0);
        assert!(m.normals[0].y < 0.0);
    }

    #[test]
    fn repair_normals_fills_zeros() {
        let (p, t) = quad();
        let mut m = Mesh::with_computed_normals("q", &p, &t, 30.0);
        m.normals[0] = Vec3::ZERO;
        m.normals[1] = Vec3::new(0.0, 3.0, 0.0);
        m.repair_normals();
        assert!((m.normals[0] - Vec3::Y).length() < 1e-6);
        assert!((m.normals[1] - Vec3::Y).length() < 1e-6);
    }
}
