//! The mesh clipper of the light-mesh precomputation (Hasselgren 2003 §3.2.2, NOTES-001 §1.7.2):
//! convex planar polygons over shared vertices, cut by planes one polygon at a time, with no
//! T-junctions left at the end.
//!
//! - **Cutting** (Code 1, `cutPolyByPlane`): a convex polygon with vertices strictly on both sides of
//!   a plane becomes two convex, planar polygons. Vertices within `eps` of the plane belong to both
//!   halves (the thesis leaves this case open; putting them in one half only would give slivers).
//! - **Shared cut vertices.** Every edge lies on a *segment*: an original edge, or the dividing edge
//!   a cut created. A cut vertex is the intersection of its segment's line with the plane, computed
//!   from the segment's two ends and cached per (segment, plane): a neighbour cut by the same plane
//!   gets the very same vertex, not a copy a rounding error away (the thesis's "edge cache").
//! - **T-junctions** (Figure 13): a polygon's neighbour may be cut where the polygon is not. Every
//!   segment records the vertices created on it, and [`PolygonMesh::remove_t_junctions`] inserts, into
//!   each polygon edge, those lying strictly between its ends. The polygon stays convex and planar
//!   (the new vertices are collinear with the edge), and rasterising the result leaves no gaps.

use glam::{Vec3, Vec4};
use rustc_hash::FxHashMap;

/// A convex planar polygon over [`PolygonMesh::positions`], counter-clockwise seen from its front.
#[derive(Debug, Clone, PartialEq)]
pub struct Polygon {
    pub vertices: Vec<u32>,
    /// What the polygon was cut from (an input triangle, for instance); halves inherit it.
    pub source: u32,
}

/// A straight piece of edge shared by the polygons along it, and the vertices cuts made on it.
#[derive(Debug, Clone)]
struct Segment {
    origin: Vec3,
    dir: Vec3,
    inner: Vec<u32>,
}

impl Segment {
    fn param(&self, p: Vec3) -> f32 {
        (p - self.origin).dot(self.dir) / self.dir.length_squared().max(f32::MIN_POSITIVE)
    }
}

/// Which side of a plane a vertex lies on, within `eps`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    Back,
    On,
    Front,
}

/// Convex polygons over shared vertices, cut by planes (see the module docs).
#[derive(Debug, Clone)]
pub struct PolygonMesh {
    pub positions: Vec<Vec3>,
    /// `None`: a polygon replaced by its two halves.
    polygons: Vec<Option<Polygon>>,
    segments: Vec<Segment>,
    /// Undirected edge (smaller vertex first) → its segment.
    edge_segment: FxHashMap<(u32, u32), u32>,
    /// (segment, plane id) → the cut vertex.
    cuts: FxHashMap<(u32, u32), u32>,
    /// Distance within which a vertex counts as on a plane.
    pub eps: f32,
}

impl PolygonMesh {
    pub fn new(positions: Vec<Vec3>, eps: f32) -> Self {
        Self {
            positions,
            polygons: Vec::new(),
            segments: Vec::new(),
            edge_segment: FxHashMap::default(),
            cuts: FxHashMap::default(),
            eps,
        }
    }

    /// Adds a polygon (vertex indices into `positions`) and returns its id.
    pub fn add(&mut self, vertices: Vec<u32>, source: u32) -> u32 {
        self.polygons.push(Some(Polygon { vertices, source }));
        self.polygons.len() as u32 - 1
    }

    /// The polygon `id`, or `None` if it was cut.
    pub fn polygon(&self, id: u32) -> Option<&Polygon> {
        self.polygons.get(id as usize).and_then(Option::as_ref)
    }

    /// Every polygon still in the mesh, with its id.
    pub fn polygons(&self) -> impl Iterator<Item = (u32, &Polygon)> {
        self.polygons.iter().enumerate().filter_map(|(i, p)| p.as_ref().map(|p| (i as u32, p)))
    }

    pub fn side(&self, plane: Vec4, v: u32) -> Side {
        let d = plane.dot(self.positions[v as usize].extend(1.0));
        if d > self.eps {
            Side::Front
        } else if d < -self.eps {
            Side::Back
        } else {
            Side::On
        }
    }

    /// Where polygon `id` crosses `plane`: the ends of the crossing segment, when it has vertices
    /// strictly on both sides (otherwise a cut would change nothing).
    pub fn crossing(&self, id: u32, plane: Vec4) -> Option<(Vec3, Vec3)> {
        let poly = self.polygon(id)?;
        let sides: Vec<Side> = poly.vertices.iter().map(|&v| self.side(plane, v)).collect();
        if !sides.contains(&Side::Front) || !sides.contains(&Side::Back) {
            return None;
        }
        let mut points = Vec::with_capacity(2);
        let n = poly.vertices.len();
        for i in 0..n {
            let (v, w) = (poly.vertices[i], poly.vertices[(i + 1) % n]);
            let (p, q) = (self.positions[v as usize], self.positions[w as usize]);
            match (sides[i], sides[(i + 1) % n]) {
                (Side::On, _) => points.push(p),
                (Side::Front, Side::Back) | (Side::Back, Side::Front) => {
                    let (dp, dq) = (plane.dot(p.extend(1.0)), plane.dot(q.extend(1.0)));
                    points.push(p + (q - p) * (dp / (dp - dq)));
                }
                _ => {}
            }
        }
        Some((*points.first()?, *points.last()?))
    }

    /// The segment edge (a, b) lies on, created when the edge is new.
    fn segment_of(&mut self, a: u32, b: u32) -> u32 {
        let key = (a.min(b), a.max(b));
        if let Some(&s) = self.edge_segment.get(&key) {
            return s;
        }
        let (pa, pb) = (self.positions[key.0 as usize], self.positions[key.1 as usize]);
        self.segments.push(Segment { origin: pa, dir: pb - pa, inner: Vec::new() });
        let s = self.segments.len() as u32 - 1;
        self.edge_segment.insert(key, s);
        s
    }

    /// The vertex where edge (a, b) meets plane `plane_id`: shared by every edge on the same segment.
    fn cut_vertex(&mut self, a: u32, b: u32, plane_id: u32, plane: Vec4) -> u32 {
        let s = self.segment_of(a, b);
        let w = match self.cuts.get(&(s, plane_id)) {
            Some(&w) => w,
            None => {
                let seg = &self.segments[s as usize];
                let da = plane.dot(seg.origin.extend(1.0));
                let db = plane.dot((seg.origin + seg.dir).extend(1.0));
                let t = if da != db { da / (da - db) } else { 0.5 };
                // The ends of (a, b) lie strictly on both sides, so the point lies between them; the
                // clamp only guards against rounding in the segment's parameter.
                let (ta, tb) = (seg.param(self.positions[a as usize]), seg.param(self.positions[b as usize]));
                let t = t.clamp(ta.min(tb), ta.max(tb));
                let p = seg.origin + seg.dir * t;
                self.positions.push(p);
                let w = self.positions.len() as u32 - 1;
                self.segments[s as usize].inner.push(w);
                self.cuts.insert((s, plane_id), w);
                w
            }
        };
        self.edge_segment.insert((a.min(w), a.max(w)), s);
        self.edge_segment.insert((w.min(b), w.max(b)), s);
        w
    }

    /// Cuts polygon `id` by `plane` (Hasselgren's `cutPolyByPlane`): returns the ids of its back and
    /// front halves, or `None` when the plane does not pass strictly through it. `plane_id` names
    /// the plane for the cut-vertex cache: the same id must always mean the same plane.
    pub fn cut(&mut self, id: u32, plane_id: u32, plane: Vec4) -> Option<[u32; 2]> {
        let poly = self.polygon(id)?.clone();
        let sides: Vec<Side> = poly.vertices.iter().map(|&v| self.side(plane, v)).collect();
        if !sides.contains(&Side::Front) || !sides.contains(&Side::Back) {
            return None;
        }
        let n = poly.vertices.len();
        let (mut back, mut front) = (Vec::with_capacity(n + 1), Vec::with_capacity(n + 1));
        let mut on_cut = Vec::with_capacity(2);
        for i in 0..n {
            let (v, w) = (poly.vertices[i], poly.vertices[(i + 1) % n]);
            let (sv, sw) = (sides[i], sides[(i + 1) % n]);
            match sv {
                Side::Front => front.push(v),
                Side::Back => back.push(v),
                Side::On => {
                    front.push(v);
                    back.push(v);
                    on_cut.push(v);
                }
            }
            if matches!((sv, sw), (Side::Front, Side::Back) | (Side::Back, Side::Front)) {
                let c = self.cut_vertex(v, w, plane_id, plane);
                front.push(c);
                back.push(c);
                on_cut.push(c);
            }
        }
        if back.len() < 3 || front.len() < 3 {
            return None;
        }
        // The dividing edge is shared by both halves: one segment for both.
        if let [a, b] = on_cut[..] {
            self.segment_of(a, b);
        }
        self.polygons[id as usize] = None;
        let b = self.add(back, poly.source);
        let f = self.add(front, poly.source);
        Some([b, f])
    }

    /// Inserts into every polygon edge the vertices other cuts made strictly inside it (module docs).
    pub fn remove_t_junctions(&mut self) {
        for slot in 0..self.polygons.len() {
            let Some(poly) = &self.polygons[slot] else { continue };
            let n = poly.vertices.len();
            let mut out = Vec::with_capacity(n);
            for i in 0..n {
                let (a, b) = (poly.vertices[i], poly.vertices[(i + 1) % n]);
                out.push(a);
                let Some(&s) = self.edge_segment.get(&(a.min(b), a.max(b))) else { continue };
                let seg = &self.segments[s as usize];
                let (ta, tb) = (seg.param(self.positions[a as usize]), seg.param(self.positions[b as usize]));
                let mut between: Vec<(f32, u32)> = seg
                    .inner
                    .iter()
                    .filter(|&&v| v != a && v != b)
                    .map(|&v| (seg.param(self.positions[v as usize]), v))
                    .filter(|&(t, _)| (t - ta) * (t - tb) < 0.0)
                    .collect();
                // In order from a to b.
                between.sort_by(|x, y| ((x.0 - ta).abs()).total_cmp(&(y.0 - ta).abs()));
                out.extend(between.into_iter().map(|(_, v)| v));
            }
            if let Some(poly) = &mut self.polygons[slot] {
                poly.vertices = out;
            }
        }
    }

    /// Twice the vector area of polygon `id` (its normal times twice its area).
    pub fn vector_area(&self, id: u32) -> Vec3 {
        let Some(poly) = self.polygon(id) else { return Vec3::ZERO };
        let p = |i: usize| self.positions[poly.vertices[i] as usize];
        (1..poly.vertices.len().saturating_sub(1)).map(|i| (p(i) - p(0)).cross(p(i + 1) - p(0))).sum()
    }

    /// The average of polygon `id`'s vertices: inside it, since it is convex.
    pub fn centroid(&self, id: u32) -> Vec3 {
        let Some(poly) = self.polygon(id) else { return Vec3::ZERO };
        poly.vertices.iter().map(|&v| self.positions[v as usize]).sum::<Vec3>() / poly.vertices.len().max(1) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> PolygonMesh {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let mut m = PolygonMesh::new(p, 1e-6);
        m.add(vec![0, 1, 2, 3], 0);
        m
    }

    fn is_convex_planar(m: &PolygonMesh, id: u32) -> bool {
        let poly = m.polygon(id).unwrap();
        let n = m.vector_area(id).normalize();
        let k = poly.vertices.len();
        (0..k).all(|i| {
            let [a, b, c] = [0, 1, 2].map(|j| m.positions[poly.vertices[(i + j) % k] as usize]);
            (b - a).cross(c - b).dot(n) >= -1e-6 && (a - m.positions[poly.vertices[0] as usize]).dot(n).abs() < 1e-6
        })
    }

    #[test]
    fn a_cut_gives_two_convex_planar_halves_sharing_their_cut_vertices_and_the_area() {
        let mut m = square();
        let plane = Vec4::new(1.0, 0.2, 0.0, -0.55);
        let [b, f] = m.cut(0, 0, plane).expect("the plane crosses the square");
        assert!(m.polygon(0).is_none(), "the cut polygon is replaced");
        for id in [b, f] {
            assert!(is_convex_planar(&m, id));
        }
        let shared: Vec<u32> = m
            .polygon(b)
            .unwrap()
            .vertices
            .iter()
            .copied()
            .filter(|v| m.polygon(f).unwrap().vertices.contains(v))
            .collect();
        assert_eq!(shared.len(), 2, "the halves share exactly the two cut vertices (same ids)");
        for &v in &shared {
            assert!(plane.dot(m.positions[v as usize].extend(1.0)).abs() < 1e-6);
        }
        // Areas add up to the square's (1) to float precision.
        let total = m.vector_area(b).length() / 2.0 + m.vector_area(f).length() / 2.0;
        assert!((total - 1.0).abs() < 1e-6, "{total}");
        // Sides: every vertex of the back half is behind or on the plane.
        for &v in &m.polygon(b).unwrap().vertices {
            assert_ne!(m.side(plane, v), Side::Front);
        }
    }

    #[test]
    fn planes_touching_or_missing_do_not_cut() {
        let mut m = square();
        // Through the corner (1, 1) only, the rest in front: touching.
        assert!(m.cut(0, 0, Vec4::new(-1.0, -1.0, 0.0, 2.0)).is_none());
        // Along an edge.
        assert!(m.cut(0, 1, Vec4::new(0.0, 1.0, 0.0, 0.0)).is_none());
        // Disjoint.
        assert!(m.cut(0, 2, Vec4::new(1.0, 0.0, 0.0, -3.0)).is_none());
        // Through two opposite corners: a cut, with no new vertex.
        let before = m.positions.len();
        let [b, f] = m.cut(0, 3, Vec4::new(1.0, -1.0, 0.0, 0.0)).unwrap();
        assert_eq!(m.positions.len(), before);
        assert_eq!(m.polygon(b).unwrap().vertices.len(), 3);
        assert_eq!(m.polygon(f).unwrap().vertices.len(), 3);
    }

    #[test]
    fn neighbours_share_cut_vertices_and_t_junctions_are_removed() {
        // Two triangles sharing the edge 1–2 (x = 1); a plane y = 0.5 cuts only the left one.
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::new(2.0, 0.5, 0.0)];
        let mut m = PolygonMesh::new(p, 1e-6);
        let left = m.add(vec![0, 1, 2], 0);
        let right = m.add(vec![1, 3, 2], 1);
        m.cut(left, 0, Vec4::new(0.0, 1.0, 0.0, -0.5)).unwrap();
        let right_before = m.polygon(right).unwrap().vertices.len();
        m.remove_t_junctions();
        let right_after = &m.polygon(right).unwrap().vertices;
        assert_eq!(right_after.len(), right_before + 1, "the cut vertex on the shared edge is inserted");
        // No vertex lies strictly inside any polygon edge.
        assert_eq!(t_junctions(&m), 0);
        // The same plane cutting the right triangle later reuses the vertex on the shared edge.
        let before = m.positions.len();
        let mut m2 = m.clone();
        m2.cut(right, 0, Vec4::new(0.0, 1.0, 0.0, -0.5));
        assert_eq!(
            m2.positions.len(),
            before,
            "(1, 0.5) is shared, and the plane meets the right triangle at its corner (2, 0.5)"
        );
    }

    /// Vertices strictly inside some polygon edge (brute force).
    pub(crate) fn t_junctions(m: &PolygonMesh) -> usize {
        let mut count = 0;
        for (_, poly) in m.polygons() {
            let n = poly.vertices.len();
            for i in 0..n {
                let (a, b) = (m.positions[poly.vertices[i] as usize], m.positions[poly.vertices[(i + 1) % n] as usize]);
                for (_, other) in m.polygons() {
                    for &v in &other.vertices {
                        let p = m.positions[v as usize];
                        let t = (p - a).dot(b - a) / (b - a).length_squared();
                        if t > 1e-4 && t < 1.0 - 1e-4 && (a + (b - a) * t).distance(p) < 1e-5 {
                            count += 1;
                        }
                    }
                }
            }
        }
        count
    }
}
