//! Light meshes: the static geometry cut along a static light's static shadow boundaries, lit pieces
//! only (Hasselgren 2003 §3.2, NOTES-001 §1.6–1.7).
//!
//! For a light that never moves, the shadows static casters throw on static receivers never change.
//! Hasselgren precomputes them exactly: the receivers are cut by the side planes of the static
//! casters' shadow volumes, so that every piece is entirely lit or entirely shadowed, and one ray
//! from a piece's midpoint to the light decides which (Code 3, `computeLitPolys`). What is lit is the
//! light's *light mesh*; at run time the static shadows cost nothing but drawing it.
//!
//! Rules, as built here:
//! - **Receivers**: the triangles of static instances that face the light (a double-sided material's
//!   triangle facing away is turned over) and come within its range (§1.7.4: back faces and faces
//!   out of range are dark anyway, DESIGN.md §3's relevance). Instances that receive no shadows
//!   keep every such triangle, uncut.
//! - **Cut planes**: one per side quad of the static casters' shadow volumes, from their silhouettes
//!   by net edge counting ([`crate::volumes::silhouette`]: open and non-manifold meshes work). A
//!   receiver polygon is cut by a quad's plane only where it actually meets the quad (the crossing
//!   segment tested against the quad's three edges), which keeps the piece count down (§1.7.2: "cut
//!   only when polygons actually intersect").
//! - **Clipper** ([`clip`]): shared cut vertices and no T-junctions.
//! - **Cut by caps too**: where a receiver passes through a caster (a pillar standing in a floor slab),
//!   the boundary of its shadowed part is the caster's surface, which no side quad contains. The
//!   receivers are also cut by the occluding faces (the volumes' light caps) they meet, so every
//!   piece lies inside or outside the closed volume: the thesis assumes no interpenetration.
//! - **Classification**: the centroid's shadow ray against the static casters ([`SceneBvh`]), offset
//!   along the piece's normal by the truth's epsilon ([`ray_epsilon`]).
//! - Area lights are cut and classified from their centre: the light mesh gives hard shadows.
//!
//! [`file`] stores light meshes with a hash of the scene's static part, so a stale file is refused.

pub mod clip;
pub mod file;

use web_time::Instant;

use glam::{Vec3, Vec4};
use rustc_hash::FxHashMap;

use self::clip::PolygonMesh;
use crate::bvh::{PreparedRay, SceneBvh, ray_epsilon};
use crate::mesh::canonical_bits;
use crate::topology::Topology;
use crate::volumes::{LightSource, face_signs, silhouette};
use crate::{Aabb, Instance, Light, Mobility, Scene};

/// A static light's light mesh.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LightMesh {
    /// Index of the light in `Scene::lights`.
    pub light: u32,
    /// World-space vertices.
    pub positions: Vec<Vec3>,
    /// The lit pieces, fanned into triangles (front faces towards the light).
    pub triangles: Vec<[u32; 3]>,
    /// The scene instance each triangle comes from.
    pub instances: Vec<u32>,
    /// Fake soft shadows (§3.4): the light's visibility at each vertex, interpolated across the
    /// triangles. Empty for hard light meshes (1 everywhere).
    pub visibility: Vec<f32>,
}

impl LightMesh {
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The triangle's corners.
    pub fn corners(&self, t: usize) -> [Vec3; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }

    /// Total area of the lit triangles.
    pub fn area(&self) -> f64 {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                f64::from((b - a).cross(c - a).length()) / 2.0
            })
            .sum()
    }
}

/// What a light mesh took and holds.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LightMeshStats {
    /// Static receiver triangles facing the light within its range: the input.
    pub receiver_triangles: usize,
    /// Side quads of the static casters' volumes (the cut planes).
    pub cut_planes: usize,
    /// Occluding faces receivers were also cut by where they pass through a caster.
    pub cap_faces: usize,
    /// Convex pieces after cutting.
    pub pieces: usize,
    /// Of which lit.
    pub lit_pieces: usize,
    /// Triangles of the light mesh.
    pub triangles: usize,
    pub seconds: f64,
}

/// Whether an instance belongs to the static part a light mesh is made of.
pub fn is_static(inst: &Instance) -> bool {
    inst.mobility == Mobility::Static
}

/// Whether a light can have a light mesh: a static light (its mobility) with a centre or a direction.
pub fn is_static_light(light: &Light) -> bool {
    light.mobility == Mobility::Static
}

/// The BVH of the static casters, which classify the pieces.
pub fn static_casters(scene: &Scene) -> SceneBvh {
    SceneBvh::build_filtered(scene, |i| is_static(i) && i.casts_shadows)
}

/// A face of a shadow volume that receivers are cut by: its plane and the three half-spaces bounding
/// it within the plane, all `n·p + d ≥ 0`. A side quad is bounded by its silhouette edge and the rays
/// from the edge's ends; a light-cap triangle (an occluding face) by its edges.
#[derive(Debug, Clone, Copy)]
struct Cutter {
    plane: Vec4,
    bounds: [Vec4; 3],
}

impl Cutter {
    /// The side quad of silhouette edge a → b.
    fn quad(a: Vec3, b: Vec3, light: &LightSource) -> Option<Self> {
        let (ea, eb) = (light.extrude(a).truncate(), light.extrude(b).truncate());
        let n = (b - a).cross(ea).normalize_or_zero();
        if n == Vec3::ZERO || !n.is_finite() {
            return None;
        }
        let half = |m: Vec3, towards: Vec3, through: Vec3| {
            let m = m.normalize_or_zero();
            let m = if m.dot(towards) < 0.0 { -m } else { m };
            m.extend(-m.dot(through))
        };
        Some(Self {
            plane: n.extend(-n.dot(a)),
            bounds: [half(n.cross(b - a), ea, a), half(n.cross(ea), b - a, a), half(n.cross(eb), a - b, b)],
        })
    }

    /// An occluding face: where a receiver passes through a caster (a pillar standing in a floor
    /// slab), the shadow's boundary on it is the caster's surface, not a side quad.
    fn triangle(a: Vec3, b: Vec3, c: Vec3) -> Option<Self> {
        let n = (b - a).cross(c - a).normalize_or_zero();
        if n == Vec3::ZERO || !n.is_finite() {
            return None;
        }
        let inward = |u: Vec3, v: Vec3, w: Vec3| {
            let m = n.cross(v - u).normalize_or_zero();
            let m = if m.dot(w - u) < 0.0 { -m } else { m };
            m.extend(-m.dot(u))
        };
        Some(Self { plane: n.extend(-n.dot(a)), bounds: [inward(a, b, c), inward(b, c, a), inward(c, a, b)] })
    }

    /// Whether the segment p → q (in the cutter's plane) meets the quad, within `eps`.
    fn meets_segment(&self, p: Vec3, q: Vec3, eps: f32) -> bool {
        let (mut lo, mut hi) = (0.0f32, 1.0f32);
        for h in &self.bounds {
            let (dp, dq) = (h.dot(p.extend(1.0)) + eps, h.dot(q.extend(1.0)) + eps);
            if dp < 0.0 && dq < 0.0 {
                return false;
            }
            if dp < 0.0 {
                lo = lo.max(dp / (dp - dq));
            } else if dq < 0.0 {
                hi = hi.min(dp / (dp - dq));
            }
        }
        lo <= hi
    }

    /// Whether the box may meet the quad (conservative).
    fn may_meet_box(&self, b: &Aabb, eps: f32) -> bool {
        let (c, e) = (b.center(), b.extent() * 0.5);
        let reach = |h: &Vec4| h.truncate().abs().dot(e);
        if self.plane.dot(c.extend(1.0)).abs() > reach(&self.plane) + eps {
            return false;
        }
        self.bounds.iter().all(|h| h.dot(c.extend(1.0)) + reach(h) >= -eps)
    }
}

/// A penumbra wedge of one silhouette edge a → b (Hasselgren 2003 §3.4 after Akenine-Möller &
/// Assarsson 2002): bounded by the surface swept from the edge away from the emitter point that
/// leaves the light fully visible (`out`: V = 1) and the one where it is fully hidden (`inn`: V = 0;
/// for [`Penumbra::Half`] the hard shadow's edge, swept from the centre), closed at each end by the
/// triangle between the two directions there. Directions are per vertex, from the silhouette's
/// outward normal at the vertex, so neighbouring wedges share their end triangles and leave no gap.
#[derive(Debug, Clone, Copy)]
struct Wedge {
    a: Vec3,
    b: Vec3,
    out_a: Vec3,
    out_b: Vec3,
    in_a: Vec3,
    in_b: Vec3,
    /// The direction away from the light's centre at a (a directional light's travel direction).
    hard_a: Vec3,
    /// The end triangles' planes, `≥ 0` inside.
    side_a: Vec4,
    side_b: Vec4,
    /// A directional light (the emitter points are directions).
    directional: bool,
    /// The light's centre (`None`: directional).
    light: Option<Vec3>,
    /// Within the scene (the sweeps cut at `reach`).
    bounds: Aabb,
}

impl Wedge {
    fn far(&self, reach: f32) -> [Vec3; 4] {
        let f = |p: Vec3, d: Vec3| p + d * (reach / d.length().max(1e-12));
        [f(self.a, self.out_a), f(self.b, self.out_b), f(self.a, self.in_a), f(self.b, self.in_b)]
    }

    /// The receivers are cut along both sweeps (two triangles each: they need not be planar) and
    /// the two end triangles.
    fn cutters(&self, reach: f32) -> Vec<Cutter> {
        let [oa, ob, ia, ib] = self.far(reach);
        let (a, b) = (self.a, self.b);
        [(a, b, ob), (a, ob, oa), (a, b, ib), (a, ib, ia), (a, oa, ia), (b, ob, ib)]
            .into_iter()
            .filter_map(|(p, q, r)| Cutter::triangle(p, q, r))
            .collect()
    }

    /// V at `p` if `p` lies in the wedge: 1 − t, where the surface through the edge swept along
    /// `out + t (in − out)` (directions blended along the edge at p's position) passes through p;
    /// with the unit direction and distance from `p` to the emitter point it still sees past the edge.
    fn visibility(&self, p: Vec3, eps: f32) -> Option<(f32, Vec3, f32)> {
        // Where along the edge p lies, seen from the light: p projected onto the hard quad's plane,
        // then along the light's rays onto the edge's line. Only points whose ray meets the edge
        // itself, beyond it, can be in its wedge.
        let e = self.b - self.a;
        let (s, beyond) = match self.light {
            Some(l) => {
                let n = (self.a - l).cross(self.b - l);
                let pp = p - n * ((p - l).dot(n) / n.length_squared().max(1e-30));
                let (u, w) = (pp - l, self.a - l);
                let eu = e.cross(u);
                let s = -w.cross(u).dot(eu) / eu.length_squared().max(1e-30);
                (s, (pp - self.a.lerp(self.b, s)).dot(u) > 0.0)
            }
            None => {
                let d = self.hard_a;
                let n = e.cross(d);
                let pp = p - n * ((p - self.a).dot(n) / n.length_squared().max(1e-30));
                let ed = e.cross(d);
                let s = (pp - self.a).cross(d).dot(ed) / ed.length_squared().max(1e-30);
                (s, (pp - self.a.lerp(self.b, s)).dot(d) > 0.0)
            }
        };
        let slack = eps / e.length().max(1e-30);
        if !beyond || !(-slack..=1.0 + slack).contains(&s) {
            return None;
        }
        let s = s.clamp(0.0, 1.0);
        let out = self.out_a.lerp(self.out_b, s);
        let inn = self.in_a.lerp(self.in_b, s);
        let f0 = (p - self.a).dot(e.cross(out));
        let f1 = (p - self.a).dot(e.cross(inn - out));
        if f1.abs() <= f32::MIN_POSITIVE {
            return None;
        }
        let t = -f0 / f1;
        // Points on the sweeps themselves (t 0 or 1 up to rounding) belong to the wedge.
        const SLACK: f32 = 1e-4;
        if !(-SLACK..=1.0 + SLACK).contains(&t) {
            return None;
        }
        // The emitter point the inner sweep comes from (the edge point minus its direction): the
        // part of the light a point in the penumbra still sees past this edge.
        let (dir, dist) = if self.directional {
            (-inn.normalize_or_zero(), f32::INFINITY)
        } else {
            let edge_point = self.a.lerp(self.b, s);
            let to = (edge_point - inn) - p;
            (to.normalize_or_zero(), to.length())
        };
        Some((1.0 - t.clamp(0.0, 1.0), dir, dist))
    }
}

/// The wedges of a caster's silhouette edges (welded indices into `world`), for an emitter of
/// radius (or angular tangent) `size`.
fn wedges_of(
    edges: &[(u32, u32)],
    world: &[Vec3],
    source: &LightSource,
    size: f32,
    penumbra: Penumbra,
    reach: f32,
) -> (Vec<Wedge>, Vec<(u32, u32)>) {
    // The silhouette's outward normal per edge (perpendicular to the edge and the light direction,
    // away from the occluding face: the edge runs along its winding, the face on its left), summed
    // at each vertex.
    let mut normal: FxHashMap<u32, Vec3> = FxHashMap::default();
    for &(a, b) in edges {
        let (pa, pb) = (world[a as usize], world[b as usize]);
        let towards = source.towards((pa + pb) * 0.5);
        let m = (pb - pa).cross(towards).normalize_or_zero();
        *normal.entry(a).or_default() += m;
        *normal.entry(b).or_default() += m;
    }
    // Directions at a vertex: away from the centre, and from the emitter points on either side.
    let dirs = |v: u32| -> Option<(Vec3, Vec3, Vec3)> {
        let p = world[v as usize];
        let hard = source.extrude(p).truncate();
        let u = hard.normalize_or_zero();
        let m = normal.get(&v).copied().unwrap_or_default();
        let m = (m - u * m.dot(u)).normalize_or_zero();
        if m == Vec3::ZERO || u == Vec3::ZERO {
            return None;
        }
        Some(match source {
            // From L ∓ r·m through p: (p − L) ± r·m.
            LightSource::Point(_) => (hard + m * size, hard - m * size, hard),
            // Travel directions tilted by the angle: d ± tan θ·m.
            LightSource::Directional(_) => (u + m * size, u - m * size, u),
        })
    };
    let mut out = Vec::with_capacity(edges.len());
    // Edges without a wedge (the light along the silhouette's normal): cut by their hard quad.
    let mut hard = Vec::new();
    for &(a, b) in edges {
        let (Some((out_a, in_a, hard_a)), Some((out_b, in_b, hard_b))) = (dirs(a), dirs(b)) else {
            hard.push((a, b));
            continue;
        };
        // Linear wedges assume a light small against its distance to the edge (Hasselgren: "errors
        // grow with the light radius"). Beyond a half-angle of MAX_TAN (a cord just above a bulb)
        // the wedge would sweep half the room: such an edge keeps its hard quad.
        const MAX_TAN: f32 = 0.25;
        let tan = |o: Vec3, h: Vec3| (o - h).length() / h.length().max(1e-12);
        if !matches!(source, LightSource::Directional(_))
            && (tan(out_a, hard_a) > MAX_TAN || tan(out_b, hard_b) > MAX_TAN)
        {
            hard.push((a, b));
            continue;
        }
        let (in_a, in_b) = match penumbra {
            Penumbra::Full => (in_a, in_b),
            Penumbra::Half => (hard_a, hard_b),
        };
        let (pa, pb) = (world[a as usize], world[b as usize]);
        let side = |p: Vec3, o: Vec3, i: Vec3, towards: Vec3| {
            let n = o.cross(i).normalize_or_zero();
            let n = if n.dot(towards) < 0.0 { -n } else { n };
            n.extend(-n.dot(p))
        };
        let mut w = Wedge {
            a: pa,
            b: pb,
            out_a,
            out_b,
            in_a,
            in_b,
            hard_a,
            side_a: side(pa, out_a, in_a, pb - pa),
            side_b: side(pb, out_b, in_b, pa - pb),
            directional: matches!(source, LightSource::Directional(_)),
            light: match source {
                LightSource::Point(l) => Some(*l),
                LightSource::Directional(_) => None,
            },
            bounds: Aabb::default(),
        };
        if w.side_a.truncate() == Vec3::ZERO || w.side_b.truncate() == Vec3::ZERO {
            hard.push((a, b));
            continue;
        }
        w.bounds = Aabb::from_points([pa, pb].into_iter().chain(w.far(reach)));
        out.push(w);
    }
    (out, hard)
}

/// A bounding-box tree over the receiver triangles, for finding the ones a quad may meet.
struct BoxTree {
    nodes: Vec<BoxNode>,
    order: Vec<u32>,
}

struct BoxNode {
    bounds: Aabb,
    /// Leaf: first and count in `order`; inner: (left child, 0), the right child follows the left's subtree.
    first: u32,
    count: u32,
    right: u32,
}

impl BoxTree {
    fn build(boxes: &[Aabb]) -> Self {
        let mut tree = Self { nodes: Vec::new(), order: (0..boxes.len() as u32).collect() };
        if !boxes.is_empty() {
            let n = boxes.len();
            tree.split(boxes, 0, n);
        }
        tree
    }

    fn split(&mut self, boxes: &[Aabb], first: usize, end: usize) -> u32 {
        let bounds = self.order[first..end].iter().fold(Aabb::default(), |acc, &i| acc.union(&boxes[i as usize]));
        let me = self.nodes.len() as u32;
        self.nodes.push(BoxNode { bounds, first: first as u32, count: (end - first) as u32, right: 0 });
        if end - first <= 4 {
            return me;
        }
        let centres = Aabb::from_points(self.order[first..end].iter().map(|&i| boxes[i as usize].center()));
        let axis = centres.extent().max_position();
        let mid = (first + end) / 2;
        self.order[first..end].select_nth_unstable_by(mid - first, |&x, &y| {
            boxes[x as usize].center()[axis].total_cmp(&boxes[y as usize].center()[axis])
        });
        self.split(boxes, first, mid);
        let right = self.split(boxes, mid, end);
        let node = &mut self.nodes[me as usize];
        node.count = 0;
        node.right = right;
        me
    }

    fn query(&self, hit: impl Fn(&Aabb) -> bool, mut visit: impl FnMut(u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = vec![0u32];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            if !hit(&node.bounds) {
                continue;
            }
            if node.count > 0 {
                for &i in &self.order[node.first as usize..(node.first + node.count) as usize] {
                    visit(i);
                }
            } else {
                stack.push(n + 1);
                stack.push(node.right);
            }
        }
    }
}

/// Errors of building light meshes.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LightMeshError {
    #[error("the scene has no light {0}")]
    NoSuchLight(usize),
    #[error("light {index} '{name}' is not static: light meshes are for lights that never move")]
    NotStatic { index: usize, name: String },
}

/// The static receivers of a light cut along its static shadow boundaries, before classification.
pub struct Pieces {
    pub mesh: PolygonMesh,
    /// Per input triangle (a polygon's `source`): its instance, and whether it was cut (it receives shadows).
    pub receivers: Vec<(u32, bool)>,
    pub cut_planes: usize,
    pub cap_faces: usize,
    /// The penumbra wedges (soft light meshes only).
    wedges: Vec<Wedge>,
    wedge_tree: BoxTree,
}

impl Pieces {
    /// The light's visibility at `p` from the wedges containing it (the least), or `None` when `p`
    /// lies in no wedge. A wedge's value holds only where its silhouette edge is what `p` sees of
    /// the light's edge: `sees(p, direction, distance)` tests the segment from `p` to the emitter
    /// point a penumbra point still sees past the edge, and a blocked one counts 0 (another occluder is in the way:
    /// the wedges of a room's outer walls reach inside it).
    pub fn wedge_visibility(&self, p: Vec3, sees: impl Fn(Vec3, Vec3, f32) -> bool) -> Option<f32> {
        let mut v: Option<f32> = None;
        self.wedge_tree.query(
            |b| b.contains(p),
            |w| {
                if let Some((x, dir, dist)) = self.wedges[w as usize].visibility(p, self.mesh.eps) {
                    let x = if sees(p, dir, dist) { x } else { 0.0 };
                    v = Some(v.map_or(x, |v| v.min(x)));
                }
            },
        );
        v
    }
}

/// Hard light meshes, or fake soft ones from penumbra wedges (Hasselgren 2003 §3.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    Hard,
    Soft(Penumbra),
}

/// Which part of the penumbra a soft light mesh has (NOTES-001 §1.11).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Penumbra {
    /// From the fully lit boundary to the umbra's: both sides of the hard shadow's edge.
    Full,
    /// From the fully lit boundary to the hard shadow's edge only: the static umbra is the hard
    /// shadow, so dynamic objects' hard volumes fit it and a closed dynamic door in a static frame
    /// leaks no light (§3.4's mixing with hard dynamic shadows; the penumbra is half as wide).
    Half,
}

/// Builds light `index`'s light mesh; `casters` is [`static_casters`] of the same scene.
pub fn build(scene: &Scene, index: usize, casters: &SceneBvh) -> Result<(LightMesh, LightMeshStats), LightMeshError> {
    build_with(scene, index, casters, Mode::Hard)
}

/// [`build`], hard or with fake soft shadows.
pub fn build_with(
    scene: &Scene,
    index: usize,
    casters: &SceneBvh,
    mode: Mode,
) -> Result<(LightMesh, LightMeshStats), LightMeshError> {
    let start = Instant::now();
    let pieces = cut_with(scene, index, mode)?;
    let light = &scene.lights[index];
    let diagonal = scene.bounds().diagonal().max(1e-6);
    // Classification: a piece in a penumbra wedge is kept (its vertices carry the visibility), any
    // other by one shadow ray from its centroid (lit or umbra).
    let sees = |p: Vec3, dir: Vec3, dist: f32| {
        let eps = ray_epsilon(p, diagonal);
        casters.unoccluded(&PreparedRay::new(p, dir, eps, dist - eps))
    };
    let ids: Vec<u32> = pieces.mesh.polygons().map(|(id, _)| id).collect();
    let lit: Vec<bool> = ids
        .iter()
        .map(|&id| {
            let source_tri = &pieces.receivers[pieces.mesh.polygon(id).map_or(0, |p| p.source as usize)];
            !source_tri.1
                || pieces.wedge_visibility(pieces.mesh.centroid(id), sees).is_some_and(|v| v > 0.0)
                || piece_lit(&pieces.mesh, id, light, casters, diagonal)
        })
        .collect();
    let mesh = &pieces.mesh;
    let receivers = &pieces.receivers;
    let (cut_planes, cap_faces) = (pieces.cut_planes, pieces.cap_faces);

    let mut out = LightMesh { light: index as u32, ..LightMesh::default() };
    let mut remap: FxHashMap<u32, u32> = FxHashMap::default();
    for (&id, _) in ids.iter().zip(&lit).filter(|(_, l)| **l) {
        let Some(poly) = mesh.polygon(id) else { continue };
        let instance = receivers[poly.source as usize].0;
        let v: Vec<u32> = poly
            .vertices
            .iter()
            .map(|&v| {
                *remap.entry(v).or_insert_with(|| {
                    out.positions.push(mesh.positions[v as usize]);
                    out.positions.len() as u32 - 1
                })
            })
            .collect();
        for tri in fan(&mut out.positions, &v) {
            out.triangles.push(tri);
            out.instances.push(instance);
        }
    }
    if mode != Mode::Hard {
        // Per vertex (shared vertices agree, so the interpolation is continuous): the least of the
        // wedges containing it, 1 outside them (§3.4).
        out.visibility = out.positions.iter().map(|&p| pieces.wedge_visibility(p, sees).unwrap_or(1.0)).collect();
    }
    let stats = LightMeshStats {
        receiver_triangles: receivers.len(),
        cut_planes,
        cap_faces,
        pieces: ids.len(),
        lit_pieces: lit.iter().filter(|&&l| l).count(),
        triangles: out.triangles.len(),
        seconds: start.elapsed().as_secs_f64(),
    };
    Ok((out, stats))
}

/// Cuts light `index`'s static receivers by its static casters' volumes (the module docs' rules).
pub fn cut(scene: &Scene, index: usize) -> Result<Pieces, LightMeshError> {
    cut_with(scene, index, Mode::Hard)
}

/// [`cut`] by side quads (hard) or by penumbra wedges (soft).
pub fn cut_with(scene: &Scene, index: usize, mode: Mode) -> Result<Pieces, LightMeshError> {
    let light = scene.lights.get(index).ok_or(LightMeshError::NoSuchLight(index))?;
    if !is_static_light(light) {
        return Err(LightMeshError::NotStatic { index, name: light.name.clone() });
    }
    let source = LightSource::of(light);
    let diagonal = scene.bounds().diagonal().max(1e-6);
    // Vertices this close to a plane are on it: well above float noise at the scene's scale, well
    // below any feature (1e-6 of the diagonal is 1 µm in a 1 km scene).
    let eps = 1e-6 * diagonal;
    let in_range = |b: &Aabb| match (light.range, light.position()) {
        (Some(range), Some(l)) => l.clamp(b.min, b.max).distance(l) < range,
        _ => true,
    };

    // Receivers, over positions shared between instances (exact welding), facing the light.
    let mut positions: Vec<Vec3> = Vec::new();
    let mut weld: FxHashMap<[u32; 3], u32> = FxHashMap::default();
    let mut vertex = |p: Vec3, positions: &mut Vec<Vec3>| {
        *weld.entry(p.to_array().map(canonical_bits)).or_insert_with(|| {
            positions.push(p);
            positions.len() as u32 - 1
        })
    };
    // (corners, instance, cut): `cut` false for instances that receive no shadows.
    let mut receivers: Vec<([u32; 3], u32, bool)> = Vec::new();
    for (i, inst) in scene.instances.iter().enumerate() {
        if !is_static(inst) {
            continue;
        }
        let mesh = scene.mesh(inst.mesh);
        let double_sided = scene.material(inst.material).double_sided;
        let mirrored = inst.transform.matrix3.determinant() < 0.0;
        let world: Vec<Vec3> = mesh.positions.iter().map(|&p| inst.transform.transform_point3(p)).collect();
        for tri in &mesh.triangles {
            let Some(mut c) = tri.map(|k| world.get(k as usize).copied()).into_iter().collect::<Option<Vec<Vec3>>>()
            else {
                continue;
            };
            if mirrored {
                c.swap(1, 2);
            }
            let n = (c[1] - c[0]).cross(c[2] - c[0]);
            let facing = n.dot(light.to_light((c[0] + c[1] + c[2]) / 3.0).0);
            if !n.is_finite() || n == Vec3::ZERO || facing == 0.0 || (facing < 0.0 && !double_sided) {
                continue;
            }
            if facing < 0.0 {
                c.swap(1, 2);
            }
            if !in_range(&Aabb::from_points(c.iter().copied())) {
                continue;
            }
            let ids = [0, 1, 2].map(|k| vertex(c[k], &mut positions));
            if ids[0] != ids[1] && ids[1] != ids[2] && ids[0] != ids[2] {
                receivers.push((ids, i as u32, inst.receives_shadows));
            }
        }
    }

    // Cut planes: side quads of the static casters' silhouettes (within range).
    let mut topologies: FxHashMap<u32, Topology> = FxHashMap::default();
    let mut quads = Vec::new();
    let mut caps = Vec::new();
    let mut wedges = Vec::new();
    // The emitter's size for wedges: a radius, or the tangent of a directional light's angle.
    let emitter = match light.emitter_extent() {
        crate::light::EmitterExtent::Radius(r) if r > 0.0 => Some(r),
        crate::light::EmitterExtent::Angle(t) if t > 0.0 => Some(t),
        _ => None,
    };
    for inst in scene.instances.iter().filter(|i| is_static(i) && i.casts_shadows) {
        let mesh = scene.mesh(inst.mesh);
        let topo = topologies.entry(inst.mesh.0).or_insert_with(|| Topology::build(mesh));
        let world: Vec<Vec3> = topo.positions.iter().map(|&p| inst.transform.transform_point3(p)).collect();
        if !in_range(&Aabb::from_points(world.iter().copied())) {
            continue;
        }
        let closed = topo.report().is_closed();
        let two_sided = !closed
            || scene.material(inst.material).double_sided
            || crate::volumes::encloses_light(topo, &world, &source);
        let mirrored = inst.transform.matrix3.determinant() < 0.0;
        let signs = face_signs(topo, &world, &source, two_sided, mirrored);
        let edges: Vec<(u32, u32)> = silhouette(topo, &signs)
            .into_iter()
            .filter(|&(a, b, _)| in_range(&Aabb::from_points([world[a as usize], world[b as usize]])))
            .map(|(a, b, _)| (a, b))
            .collect();
        match (mode, emitter) {
            (Mode::Soft(penumbra), Some(emitter)) => {
                let (made, hard) = wedges_of(&edges, &world, &source, emitter, penumbra, 4.0 * diagonal);
                for w in made {
                    quads.extend(w.cutters(4.0 * diagonal));
                    wedges.push(w);
                }
                let quad = |&(a, b): &(u32, u32)| Cutter::quad(world[a as usize], world[b as usize], &source);
                quads.extend(hard.iter().filter_map(quad));
            }
            _ => quads
                .extend(edges.iter().filter_map(|&(a, b)| Cutter::quad(world[a as usize], world[b as usize], &source))),
        }
        for (t, _) in signs.iter().enumerate().filter(|(_, s)| **s != 0) {
            let [a, b, c] = topo.triangles[t].map(|v| world[v as usize]);
            if in_range(&Aabb::from_points([a, b, c]))
                && let Some(cap) = Cutter::triangle(a, b, c)
            {
                caps.push(cap);
            }
        }
    }

    let mut mesh = PolygonMesh::new(positions, eps);
    let cut_planes = quads.len();
    let mut cutters = quads;
    cutters.extend(caps);
    let mut boxes = Vec::with_capacity(receivers.len());
    for &(ids, _, cut) in &receivers {
        // Uncut receivers get an empty box no cutter meets.
        boxes.push(if cut { Aabb::from_points(ids.map(|v| mesh.positions[v as usize])) } else { Aabb::default() });
    }
    // Each receiver triangle's cutters, in one order for all (the cut-vertex cache names planes by it).
    let tree = BoxTree::build(&boxes);
    let mut cutters_of: Vec<Vec<u32>> = vec![Vec::new(); receivers.len()];
    for (k, cutter) in cutters.iter().enumerate() {
        tree.query(|b| !b.is_empty() && cutter.may_meet_box(b, eps), |t| cutters_of[t as usize].push(k as u32));
    }
    for (t, &(ids, _, _)) in receivers.iter().enumerate() {
        let id = mesh.add(ids.to_vec(), t as u32);
        // Each piece carries the cutters that may still meet it: halves keep only those that may
        // meet their own box, so a receiver cut into thousands of pieces is not tested against
        // every cutter for every piece.
        let mut work = vec![(id, std::mem::take(&mut cutters_of[t]))];
        while let Some((id, list)) = work.pop() {
            let hit = list.iter().position(|&k| {
                let c = &cutters[k as usize];
                mesh.crossing(id, c.plane).is_some_and(|(p, q)| c.meets_segment(p, q, eps))
            });
            let Some(i) = hit else { continue };
            let k = list[i];
            let Some(halves) = mesh.cut(id, k, cutters[k as usize].plane) else {
                work.push((id, list[i + 1..].to_vec()));
                continue;
            };
            for half in halves {
                let b = piece_box(&mesh, half);
                let rest: Vec<u32> =
                    list[i + 1..].iter().copied().filter(|&j| cutters[j as usize].may_meet_box(&b, eps)).collect();
                work.push((half, rest));
            }
        }
    }
    mesh.remove_t_junctions();
    let wedge_tree = BoxTree::build(&wedges.iter().map(|w| w.bounds).collect::<Vec<_>>());
    Ok(Pieces {
        mesh,
        receivers: receivers.iter().map(|r| (r.1, r.2)).collect(),
        cut_planes,
        cap_faces: cutters.len() - cut_planes,
        wedges,
        wedge_tree,
    })
}

/// Triangles of the convex polygon `v` over `positions`. Vertices inserted on edges (T-junction
/// removal) are collinear with their edge's ends; a fan from a corner would give zero-area triangles
/// over them and leave them out, so their neighbours' vertices would sit in the middle of an edge
/// again. Such polygons are fanned from an added centre vertex instead: every triangle has area and
/// every boundary vertex is used.
fn fan(positions: &mut Vec<Vec3>, v: &[u32]) -> Vec<[u32; 3]> {
    let n = v.len();
    let p = |i: usize| positions[v[i % n] as usize];
    let straight = (0..n).any(|i| {
        let (a, b, c) = (p(i), p(i + 1), p(i + 2));
        // sin of the turn ≤ 1e-4: the float noise of a vertex inserted on a short edge.
        (b - a).cross(c - b).length() <= 1e-4 * (b - a).length() * (c - b).length()
    });
    if !straight {
        return (1..n - 1).map(|i| [v[0], v[i], v[i + 1]]).collect();
    }
    let centre = v.iter().map(|&i| positions[i as usize]).sum::<Vec3>() / n as f32;
    positions.push(centre);
    let c = positions.len() as u32 - 1;
    (0..n).map(|i| [c, v[i], v[(i + 1) % n]]).collect()
}

fn piece_box(mesh: &PolygonMesh, id: u32) -> Aabb {
    let mut b = Aabb::default();
    if let Some(poly) = mesh.polygon(id) {
        for &v in &poly.vertices {
            b.grow(mesh.positions[v as usize]);
        }
    }
    b
}

/// Whether the point `p` on a surface with normal `n` (facing the light) sees the light's centre.
pub fn point_lit(p: Vec3, n: Vec3, light: &Light, casters: &SceneBvh, diagonal: f32) -> bool {
    let origin = p + n * ray_epsilon(p, diagonal);
    let (dir, dist) = light.to_light(origin);
    let ray = PreparedRay::new(origin, dir, 0.0, dist);
    casters.unoccluded(&ray)
}

fn piece_lit(mesh: &PolygonMesh, id: u32, light: &Light, casters: &SceneBvh, diagonal: f32) -> bool {
    let n = mesh.vector_area(id).normalize_or_zero();
    point_lit(mesh.centroid(id), n, light, casters, diagonal)
}

#[cfg(test)]
mod tests;
