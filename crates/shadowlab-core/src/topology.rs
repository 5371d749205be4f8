//! Mesh topology: position welding, the edge → faces map with multiplicity, closedness.
//!
//! Shadow volumes and smoothies need silhouettes, and silhouettes need to know, for every edge, which
//! faces share it. Meshes as loaded split vertices at creases and seams (one position, several
//! normals), so the edge map works on *welded* positions. Edges with one face (boundaries of open
//! meshes) and more than two faces (non-manifold junctions) are kept with their multiplicity: the
//! silhouette code decides what to do with them (Hasselgren §3.2, NOTES-001).

use glam::{IVec3, Vec3};
use rustc_hash::FxHashMap;

use crate::mesh::{Mesh, canonical_bits};

/// Merges positions that are equal (`tolerance == 0`) or closer than `tolerance`.
/// Returns, per input position, the index of its representative, and the representatives.
pub fn weld_positions(positions: &[Vec3], tolerance: f32) -> (Vec<u32>, Vec<Vec3>) {
    let mut reps: Vec<Vec3> = Vec::new();
    let mut map = Vec::with_capacity(positions.len());
    if tolerance <= 0.0 || !tolerance.is_finite() {
        let mut exact: FxHashMap<[u32; 3], u32> = FxHashMap::default();
        for &p in positions {
            let next = reps.len() as u32;
            map.push(*exact.entry(p.to_array().map(canonical_bits)).or_insert_with(|| {
                reps.push(p);
                next
            }));
        }
        return (map, reps);
    }
    // Grid of cells of size `tolerance`: a neighbour within tolerance is in one of the 27 cells
    // around the point's own.
    let cell = |p: Vec3| (p / tolerance).floor().as_ivec3();
    let mut grid: FxHashMap<IVec3, Vec<u32>> = FxHashMap::default();
    let t2 = tolerance * tolerance;
    for &p in positions {
        let c = cell(p);
        let mut found = None;
        'search: for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if let Some(list) = grid.get(&(c + IVec3::new(dx, dy, dz)))
                        && let Some(&r) = list.iter().find(|&&r| reps[r as usize].distance_squared(p) <= t2)
                    {
                        found = Some(r);
                        break 'search;
                    }
                }
            }
        }
        let r = found.unwrap_or_else(|| {
            reps.push(p);
            let r = reps.len() as u32 - 1;
            grid.entry(c).or_default().push(r);
            r
        });
        map.push(r);
    }
    (map, reps)
}

/// One use of an edge by a face.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EdgeUse {
    /// The face (triangle index in the mesh).
    pub face: u32,
    /// True when the face's counter-clockwise order runs from `v[0]` to `v[1]`.
    pub forward: bool,
}

/// An undirected edge between two welded vertices, `v[0] < v[1]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Edge {
    pub v: [u32; 2],
    first_use: u32,
    use_count: u32,
}

impl Edge {
    /// Number of faces that share the edge: 1 on a boundary, 2 on a manifold, more at a junction.
    pub fn multiplicity(&self) -> usize {
        self.use_count as usize
    }
}

/// The connectivity of a mesh over welded positions.
#[derive(Debug, Clone)]
pub struct Topology {
    /// Welded vertex of each mesh vertex.
    pub vertex_weld: Vec<u32>,
    /// Position of each welded vertex.
    pub positions: Vec<Vec3>,
    /// The mesh's triangles over welded vertices (degenerate ones included, so indices match).
    pub triangles: Vec<[u32; 3]>,
    /// Triangles whose corners weld together (zero area by construction); they have no edges.
    pub degenerate: Vec<bool>,
    pub edges: Vec<Edge>,
    uses: Vec<EdgeUse>,
    /// For each triangle, its three edges (corner k to k+1); `u32::MAX` for degenerate triangles.
    pub face_edges: Vec<[u32; 3]>,
}

/// Counts that say whether a mesh is closed and 2-manifold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TopologyReport {
    pub welded_vertices: usize,
    pub triangles: usize,
    pub degenerate_triangles: usize,
    pub edges: usize,
    /// Edges used by one face.
    pub boundary_edges: usize,
    /// Edges used by exactly two faces.
    pub manifold_edges: usize,
    /// Edges used by three or more faces.
    pub nonmanifold_edges: usize,
    /// Two-face edges whose faces run the same way along them (inconsistent winding).
    pub orientation_conflicts: usize,
    pub consistently_oriented: bool,
    /// V − E + F (2 for a closed sphere-like mesh).
    pub euler_characteristic: i64,
}

impl TopologyReport {
    pub fn is_closed(&self) -> bool {
        self.boundary_edges == 0
    }

    /// Every edge has exactly two faces and the winding agrees across each one.
    pub fn is_closed_manifold(&self) -> bool {
        self.boundary_edges == 0 && self.nonmanifold_edges == 0 && self.orientation_conflicts == 0
    }

    /// `closed`, `open`, `non-manifold`, `closed (inconsistent winding)`.
    pub fn summary(&self) -> &'static str {
        match (self.boundary_edges > 0, self.nonmanifold_edges > 0, self.orientation_conflicts > 0) {
            (_, true, _) => "non-manifold",
            (true, false, _) => "open",
            (false, false, true) => "closed (inconsistent winding)",
            (false, false, false) => "closed",
        }
    }
}

impl Topology {
    /// Connectivity over exactly equal positions.
    pub fn build(mesh: &Mesh) -> Self {
        Self::build_with_tolerance(mesh, 0.0)
    }

    /// Connectivity over positions welded within `tolerance`.
    pub fn build_with_tolerance(mesh: &Mesh, tolerance: f32) -> Self {
        let (vertex_weld, positions) = weld_positions(&mesh.positions, tolerance);
        let triangles: Vec<[u32; 3]> = mesh
            .triangles
            .iter()
            .map(|t| t.map(|i| vertex_weld.get(i as usize).copied().unwrap_or(u32::MAX)))
            .collect();
        let degenerate: Vec<bool> = triangles
            .iter()
            .map(|&[a, b, c]| a == b || b == c || a == c || a == u32::MAX || b == u32::MAX || c == u32::MAX)
            .collect();

        // Pass 1: name every edge and count its uses.
        let mut edge_of: FxHashMap<u64, u32> = FxHashMap::default();
        edge_of.reserve(triangles.len() * 3 / 2);
        let mut edges: Vec<Edge> = Vec::with_capacity(triangles.len() * 3 / 2);
        let mut face_edges = vec![[u32::MAX; 3]; triangles.len()];
        for (f, t) in triangles.iter().enumerate() {
            if degenerate[f] {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let v = [a.min(b), a.max(b)];
                let key = (u64::from(v[0]) << 32) | u64::from(v[1]);
                let next = edges.len() as u32;
                let e = *edge_of.entry(key).or_insert_with(|| {
                    edges.push(Edge { v, first_use: 0, use_count: 0 });
                    next
                });
                edges[e as usize].use_count += 1;
                face_edges[f][k] = e;
            }
        }
        // Pass 2: lay the uses out contiguously per edge.
        let mut offset = 0u32;
        for e in &mut edges {
            e.first_use = offset;
            offset += e.use_count;
        }
        let mut fill = vec![0u32; edges.len()];
        let mut uses = vec![EdgeUse { face: 0, forward: false }; offset as usize];
        for (f, t) in triangles.iter().enumerate() {
            if degenerate[f] {
                continue;
            }
            for k in 0..3 {
                let e = face_edges[f][k] as usize;
                let slot = edges[e].first_use + fill[e];
                fill[e] += 1;
                uses[slot as usize] = EdgeUse { face: f as u32, forward: t[k] == edges[e].v[0] };
            }
        }
        Self { vertex_weld, positions, triangles, degenerate, edges, uses, face_edges }
    }

    /// The faces that use edge `e`, with their direction along it.
    pub fn edge_uses(&self, e: usize) -> &[EdgeUse] {
        let edge = &self.edges[e];
        &self.uses[edge.first_use as usize..(edge.first_use + edge.use_count) as usize]
    }

    pub fn report(&self) -> TopologyReport {
        let mut r = TopologyReport {
            welded_vertices: self.positions.len(),
            triangles: self.triangles.len(),
            degenerate_triangles: self.degenerate.iter().filter(|&&d| d).count(),
            edges: self.edges.len(),
            ..TopologyReport::default()
        };
        for (e, edge) in self.edges.iter().enumerate() {
            match edge.multiplicity() {
                1 => r.boundary_edges += 1,
                2 => {
                    r.manifold_edges += 1;
                    let u = self.edge_uses(e);
                    if u[0].forward == u[1].forward {
                        r.orientation_conflicts += 1;
                    }
                }
                _ => r.nonmanifold_edges += 1,
            }
        }
        r.consistently_oriented = r.orientation_conflicts == 0;
        let used_vertices = {
            let mut used = vec![false; self.positions.len()];
            for (t, d) in self.triangles.iter().zip(&self.degenerate) {
                if !d {
                    for &i in t {
                        used[i as usize] = true;
                    }
                }
            }
            used.iter().filter(|&&u| u).count()
        };
        r.euler_characteristic = used_vertices as i64 - r.edges as i64 + (r.triangles - r.degenerate_triangles) as i64;
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::primitives;

    #[test]
    fn cube_is_closed_with_18_edges() {
        let m = primitives::cuboid(Vec3::ONE);
        assert_eq!(m.vertex_count(), 24, "corners are split for flat normals");
        let t = Topology::build(&m);
        let r = t.report();
        assert_eq!(r.welded_vertices, 8);
        assert_eq!(r.edges, 18);
        assert_eq!(r.manifold_edges, 18);
        assert_eq!(r.boundary_edges, 0);
        assert_eq!(r.nonmanifold_edges, 0);
        assert!(r.consistently_oriented);
        assert!(r.is_closed_manifold());
        assert_eq!(r.euler_characteristic, 2);
        assert_eq!(r.summary(), "closed");
        for e in 0..t.edges.len() {
            let u = t.edge_uses(e);
            assert_eq!(u.len(), 2);
            assert_ne!(u[0].forward, u[1].forward);
        }
    }

    #[test]
    fn plane_is_open() {
        let r = Topology::build(&primitives::plane(1.0, 1.0, 1, 1)).report();
        assert_eq!(r.edges, 5);
        assert_eq!(r.boundary_edges, 4);
        assert_eq!(r.manifold_edges, 1);
        assert!(!r.is_closed());
        assert_eq!(r.summary(), "open");
    }

    #[test]
    fn three_faces_on_one_edge_are_non_manifold() {
        let mut m = Mesh::new("fan");
        m.positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, -Vec3::Y];
        m.normals = vec![Vec3::Y; 5];
        m.triangles = vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]];
        let t = Topology::build(&m);
        let r = t.report();
        assert_eq!(r.nonmanifold_edges, 1);
        assert_eq!(r.boundary_edges, 6);
        assert_eq!(r.summary(), "non-manifold");
        let shared = t.edges.iter().position(|e| e.v == [0, 1]).unwrap();
        assert_eq!(t.edge_uses(shared).len(), 3);
    }

    #[test]
    fn flipped_face_is_an_orientation_conflict() {
        let mut m = primitives::cuboid(Vec3::ONE);
        m.triangles[0].swap(1, 2);
        let r = Topology::build(&m).report();
        assert!(r.is_closed());
        assert_eq!(r.orientation_conflicts, 3);
        assert!(!r.is_closed_manifold());
    }

    #[test]
    fn tolerance_welding_closes_near_seams() {
        let mut m = primitives::cuboid(Vec3::ONE);
        // Nudge one split copy of a corner by 1e-6: exact welding opens the cube, tolerant does not.
        let p = m.positions[0];
        let twin = m.positions.iter().skip(1).position(|&q| q == p).unwrap() + 1;
        m.positions[twin] += Vec3::splat(1e-6);
        assert!(!Topology::build(&m).report().is_closed());
        assert!(Topology::build_with_tolerance(&m, 1e-5).report().is_closed_manifold());
    }

    #[test]
    fn degenerate_triangles_are_skipped() {
        let mut m = primitives::cuboid(Vec3::ONE);
        m.triangles.push([0, 0, 1]);
        let r = Topology::build(&m).report();
        assert_eq!(r.degenerate_triangles, 1);
        assert!(r.is_closed_manifold());
    }
}
