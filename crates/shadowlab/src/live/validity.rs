//! What each edit invalidates: the one table of validity rules (Toromanoff 2005 §3.2, extended;
//! Hasselgren 2003 §1.6 Table 1: light × caster × receiver, static or dynamic), and the
//! [`Signature`]s by which the cache applies it.
//!
//! A cached item records the signature it was built from: its light's emitter version, a hash of
//! its view (matrix, raster state, size), the casters whose bounds meet its region (with their
//! transform versions), the object it belongs to. It is valid exactly while the signature computed
//! from the current state equals the recorded one, so no edit can be missed: the table
//! ([`rule`]) says which edits change which part, and the tests check that signatures change
//! exactly as the table says.

use std::hash::{Hash, Hasher};

use glam::{Mat4, Vec3, Vec4};
use shadowlab_core::lightspace::ShadowView;
use shadowlab_core::{Aabb, Light, Mobility};

use super::edits::{EditKind, InstanceId};
use super::scene::LiveScene;

/// The kinds of cached items (DESIGN.md §11).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ItemKind {
    /// A light view's map of the static casters (a cube face, a cone, a cascade, an emitter
    /// sample's view), kept across frames.
    StaticView,
    /// A copy of a static view with the dynamic casters that reach it drawn over it.
    CompositeView,
    /// A receiver's light map for one light (view-independent visibility in the receiver's plane).
    LightMap,
    /// One object's silhouettes and volume geometry for one light (`volumes`).
    VolumeObject,
    /// Screen-sized buffers: visibility layers, per-pixel sums, stencil buffers.
    ScreenBuffer,
}

impl ItemKind {
    pub const ALL: [ItemKind; 5] =
        [Self::StaticView, Self::CompositeView, Self::LightMap, Self::VolumeObject, Self::ScreenBuffer];

    pub fn name(self) -> &'static str {
        match self {
            Self::StaticView => "static map view",
            Self::CompositeView => "composite map view",
            Self::LightMap => "receiver light map",
            Self::VolumeObject => "object volume",
            Self::ScreenBuffer => "screen buffer",
        }
    }

    /// The casters an item of this kind holds: static ones only, or every permanent one.
    pub fn caster_classes(self) -> &'static [Mobility] {
        match self {
            Self::StaticView => &[Mobility::Static],
            Self::CompositeView | Self::LightMap => &[Mobility::Static, Mobility::Dynamic],
            Self::VolumeObject | Self::ScreenBuffer => &[],
        }
    }
}

/// When an edit invalidates an item: one cell of the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rule {
    Never,
    /// Every item of the kind, of every light.
    Always,
    /// The items of the light concerned.
    SameLight,
    /// Items whose region (view frustum within the light's range, light map receiver) meets the
    /// instance's bounds before or after the edit.
    Region,
    /// The item of the instance concerned (its own volume or light map).
    SameObject,
    /// Views fitted to the camera (cascades, `cssm`), unless stabilised and still snapped alike.
    CameraFitted,
}

impl Rule {
    pub fn name(self) -> &'static str {
        match self {
            Self::Never => "–",
            Self::Always => "all",
            Self::SameLight => "that light's",
            Self::Region => "those it reaches",
            Self::SameObject => "its own",
            Self::CameraFitted => "camera-fitted",
        }
    }
}

/// The table: which items an edit invalidates. Beyond it, any edit that changes the fitted scene
/// bounds (a permanent instance added, removed or moved past the scene's extent) refits every
/// light's whole-scene views, and an item whose GPU memory was lost or reallocated is rebuilt.
pub fn rule(edit: EditKind, item: ItemKind) -> Rule {
    use ItemKind as I;
    use Mobility::{Dynamic as D, Static as S, Temporary as T};
    match (edit, item) {
        // Output buffers follow the output size, nothing else.
        (EditKind::Resize, I::ScreenBuffer) => Rule::Always,
        (EditKind::Resize, _) | (_, I::ScreenBuffer) => Rule::Never,
        // Visibility is colour-free (DESIGN.md §3).
        (EditKind::LightColour, _) => Rule::Never,
        (EditKind::LightEmitter | EditKind::RemoveLight, _) => Rule::SameLight,
        // A new light's items are new; nothing else changes.
        (EditKind::AddLight, _) => Rule::Never,
        (EditKind::Camera, I::StaticView | I::CompositeView) => Rule::CameraFitted,
        (EditKind::Camera, _) => Rule::Never,
        // Temporary (dragged) instances are in no cached item (Toromanoff §3.3).
        (EditKind::MoveInstance(T) | EditKind::AddInstance(T) | EditKind::RemoveInstance(T), _) => Rule::Never,
        (EditKind::MoveInstance(S), I::StaticView | I::CompositeView | I::LightMap) => Rule::Region,
        (EditKind::MoveInstance(D), I::CompositeView | I::LightMap) => Rule::Region,
        (EditKind::MoveInstance(_), I::VolumeObject) => Rule::SameObject,
        (EditKind::MoveInstance(_), I::StaticView) => Rule::Never,
        (EditKind::AddInstance(S) | EditKind::RemoveInstance(S), I::StaticView | I::CompositeView | I::LightMap) => {
            Rule::Region
        }
        (EditKind::AddInstance(D) | EditKind::RemoveInstance(D), I::CompositeView | I::LightMap) => Rule::Region,
        (EditKind::AddInstance(_) | EditKind::RemoveInstance(_), I::StaticView) => Rule::Never,
        // An added instance's volume is a new item; a removed one's goes with it.
        (EditKind::AddInstance(_), I::VolumeObject) => Rule::Never,
        (EditKind::RemoveInstance(_), I::VolumeObject) => Rule::SameObject,
        (EditKind::ChangeMobility { from, to }, kind) => {
            let held = |m: Mobility| kind.caster_classes().contains(&m);
            match kind {
                I::VolumeObject if from == T || to == T => Rule::SameObject,
                I::VolumeObject => Rule::Never,
                _ if held(from) != held(to) => Rule::Region,
                // Static → dynamic moves a caster from the static map to the composite copy.
                I::CompositeView if from != T && to != T => Rule::Region,
                _ => Rule::Never,
            }
        }
    }
}

/// The table as Markdown, for the README (a test keeps the two the same).
pub fn table_markdown() -> String {
    let mut s = String::from("| edit |");
    for k in ItemKind::ALL {
        s += &format!(" {} |", k.name());
    }
    s += "\n| --- |";
    for _ in ItemKind::ALL {
        s += " --- |";
    }
    s += "\n";
    for e in EditKind::all() {
        s += &format!("| {} |", e.describe());
        for k in ItemKind::ALL {
            s += &format!(" {} |", rule(e, k).name());
        }
        s += "\n";
    }
    s
}

/// The part of space whose casters can change an item: a view's frustum, within the light's range.
#[derive(Debug, Clone, Copy)]
pub struct Region {
    /// Half-spaces `n·p + d ≥ 0` of the frustum (wgpu clip space, either depth direction).
    planes: [Vec4; 6],
    /// The light's range: a caster entirely outside it cannot shadow a point the light reaches.
    ball: Option<(Vec3, f32)>,
}

impl Region {
    /// The frustum of a clip-space matrix, within the light's range.
    pub fn of_view(view_projection: &Mat4, light: &Light) -> Self {
        let m = view_projection.transpose();
        let (x, y, z, w) = (m.x_axis, m.y_axis, m.z_axis, m.w_axis);
        let planes = [w + x, w - x, w + y, w - y, z, w - z];
        let ball = match (light.position(), light.range) {
            (Some(p), Some(r)) => Some((p, r)),
            _ => None,
        };
        Self { planes, ball }
    }

    /// A box's region (light maps: the receiver's surroundings), within the light's range.
    pub fn of_box(b: &Aabb, light: &Light) -> Self {
        let planes = [
            Vec4::new(1.0, 0.0, 0.0, -b.min.x),
            Vec4::new(-1.0, 0.0, 0.0, b.max.x),
            Vec4::new(0.0, 1.0, 0.0, -b.min.y),
            Vec4::new(0.0, -1.0, 0.0, b.max.y),
            Vec4::new(0.0, 0.0, 1.0, -b.min.z),
            Vec4::new(0.0, 0.0, -1.0, b.max.z),
        ];
        let ball = match (light.position(), light.range) {
            (Some(p), Some(r)) => Some((p, r)),
            _ => None,
        };
        Self { planes, ball }
    }

    /// Whether a box may meet the region (conservative: a box outside every plane's side is out).
    pub fn meets(&self, b: &Aabb) -> bool {
        if b.is_empty() {
            return false;
        }
        for p in &self.planes {
            let n = p.truncate();
            // The box corner farthest along the plane's normal.
            let c = Vec3::select(n.cmpge(Vec3::ZERO), b.max, b.min);
            if n.dot(c) + p.w < 0.0 {
                return false;
            }
        }
        if let Some((centre, r)) = self.ball {
            let nearest = centre.clamp(b.min, b.max);
            if nearest.distance_squared(centre) > r * r {
                return false;
            }
        }
        true
    }
}

/// What an item was built from; equal signatures mean the item is still right.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Signature {
    /// The emitter version of the item's light.
    pub emitter: u64,
    /// A hash of the item's own inputs: its view, raster state, size, technique parameters.
    pub view: u64,
    /// Casters of the item's classes whose bounds meet its region, with their versions.
    pub casters: Vec<(InstanceId, u64)>,
    /// The version of the object the item belongs to (volumes, light-map receivers); 0 otherwise.
    pub object: u64,
}

/// The casters of `classes` whose bounds meet `region`, with their versions, in id order.
pub fn casters_in(live: &LiveScene, region: &Region, classes: &[Mobility]) -> Vec<(InstanceId, u64)> {
    let mut out: Vec<(InstanceId, u64)> = live
        .scene()
        .instances
        .iter()
        .zip(live.instances())
        .filter(|(inst, s)| inst.casts_shadows && classes.contains(&inst.mobility) && region.meets(&s.bounds))
        .map(|(_, s)| (s.id, s.version))
        .collect();
    out.sort_unstable();
    out
}

/// Whether any caster of `classes` meets `region`.
pub fn any_caster_in(live: &LiveScene, region: &Region, classes: &[Mobility]) -> bool {
    live.scene()
        .instances
        .iter()
        .zip(live.instances())
        .any(|(inst, s)| inst.casts_shadows && classes.contains(&inst.mobility) && region.meets(&s.bounds))
}

/// A hash of a shadow view and whatever else decides what an item holds (raster state, size).
pub fn view_hash(view: &ShadowView, extra: &[u64]) -> u64 {
    let mut h = std::hash::DefaultHasher::new();
    for m in [view.view, view.projection] {
        for v in m.to_cols_array() {
            v.to_bits().hash(&mut h);
        }
    }
    for v in [view.near, view.far, view.texel_scale] {
        v.to_bits().hash(&mut h);
    }
    view.orthographic.hash(&mut h);
    extra.hash(&mut h);
    h.finish()
}

/// A hash of plain numbers (parameters that decide an item's contents).
pub fn hash_values(values: &[f64]) -> u64 {
    let mut h = std::hash::DefaultHasher::new();
    for v in values {
        v.to_bits().hash(&mut h);
    }
    h.finish()
}
