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
use shadowlab_core::{Aabb, Light, LightId, Mobility};

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
    /// A light's visibility layer (and the screen-sized buffers behind it), kept across still
    /// frames.
    ScreenBuffer,
    /// A static light's light mesh: its static receivers cut along the static shadows, lit pieces
    /// only (Hasselgren 2003 §3.2; `lightmesh`).
    LightMesh,
}

impl ItemKind {
    pub const ALL: [ItemKind; 6] = [
        Self::StaticView,
        Self::CompositeView,
        Self::LightMap,
        Self::VolumeObject,
        Self::ScreenBuffer,
        Self::LightMesh,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Self::StaticView => "static map view",
            Self::CompositeView => "composite map view",
            Self::LightMap => "receiver light map",
            Self::VolumeObject => "object volume",
            Self::ScreenBuffer => "visibility layer",
            Self::LightMesh => "light mesh",
        }
    }

    /// The casters an item of this kind holds: static ones only, or every permanent one.
    pub fn caster_classes(self) -> &'static [Mobility] {
        match self {
            // A light mesh holds the static instances, receivers as much as casters.
            Self::StaticView | Self::LightMesh => &[Mobility::Static],
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
    /// The pixels the instance covered or covers on screen (its bounds before and after,
    /// projected): a technique that resolves per pixel redoes only those. Only on devices without
    /// compute, where dragged objects cast nothing: elsewhere the layers are of the permanent
    /// surface (`live::temporary::PermanentSurface`), which a drag leaves alone.
    Footprint,
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
            Self::Footprint => "its footprint, without compute",
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
        // A removed light's items go with it.
        (EditKind::RemoveLight, _) => Rule::SameLight,
        // Visibility is colour-free (DESIGN.md §3).
        (EditKind::LightColour, _) => Rule::Never,
        // A light's visibility layer holds while its light, the scene's instances and the surface
        // (camera, size) do.
        (EditKind::LightEmitter, I::ScreenBuffer) => Rule::SameLight,
        (EditKind::AddLight, I::ScreenBuffer) => Rule::Never,
        // A dragged object is in no shadow data: only the pixels it covered or covers changed.
        (EditKind::MoveInstance(T), I::ScreenBuffer) => Rule::Footprint,
        (_, I::ScreenBuffer) => Rule::Always,
        (EditKind::Resize, _) => Rule::Never,
        (EditKind::LightEmitter, _) => Rule::SameLight,
        // A new light's items are new; nothing else changes.
        (EditKind::AddLight, _) => Rule::Never,
        (EditKind::Camera, I::StaticView | I::CompositeView) => Rule::CameraFitted,
        (EditKind::Camera, _) => Rule::Never,
        // A light mesh is the static part seen from the light (Hasselgren's Table 1: static light,
        // static caster, static receiver): only static instances within the light's range count.
        (EditKind::MoveInstance(S) | EditKind::AddInstance(S) | EditKind::RemoveInstance(S), I::LightMesh) => {
            Rule::Region
        }
        (EditKind::MoveInstance(_) | EditKind::AddInstance(_) | EditKind::RemoveInstance(_), I::LightMesh) => {
            Rule::Never
        }
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
                // Static ↔ dynamic takes a caster out of (or into) the static maps; a composite
                // copy or a light map holds every permanent caster either way.
                _ if held(from) != held(to) => Rule::Region,
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

/// The signatures of a map view's static layer (static casters) and of its composite copy (every
/// permanent caster), and whether any dynamic caster reaches it (so that it needs the copy).
pub fn view_signatures(live: &LiveScene, light: LightId, region: &Region, view: u64) -> (Signature, Signature, bool) {
    let emitter = live.light_state(light).map_or(0, |s| s.emitter_version);
    let statics = casters_in(live, region, &[Mobility::Static]);
    let dynamics = casters_in(live, region, &[Mobility::Dynamic]);
    let has_dynamic = !dynamics.is_empty();
    let mut all = statics.clone();
    all.extend(dynamics);
    all.sort_unstable();
    (
        Signature { emitter, view, casters: statics, object: 0 },
        Signature { emitter, view, casters: all, object: 0 },
        has_dynamic,
    )
}

/// The signature of a receiver's light map: the light's emitter, the patch (`view`), every
/// permanent caster in `region` but the receiver itself, and the receiver's transform.
pub fn lightmap_signature(live: &LiveScene, light: LightId, region: &Region, view: u64, receiver: usize) -> Signature {
    let emitter = live.light_state(light).map_or(0, |s| s.emitter_version);
    let receiver = live.instances()[receiver];
    let mut casters = casters_in(live, region, &[Mobility::Static, Mobility::Dynamic]);
    casters.retain(|(id, _)| *id != receiver.id);
    Signature { emitter, view, casters, object: receiver.version }
}

/// The signature of one object's volume geometry for one light sample (`view`: the sample).
pub fn volume_signature(live: &LiveScene, light: LightId, view: u64, object: usize) -> Signature {
    let emitter = live.light_state(light).map_or(0, |s| s.emitter_version);
    Signature { emitter, view, casters: Vec::new(), object: live.instances()[object].version }
}

/// The signature of a light's visibility layer: its emitter, the surface (`surface`: its
/// generation, which changes with the camera and the size) and every instance edit but a dragged
/// object's move ([`Rule::Footprint`]: `Shadows::record` compares the dragged objects' bounds).
pub fn screen_signature(live: &LiveScene, light: LightId, surface: u64) -> Signature {
    let emitter = live.light_state(light).map_or(0, |s| s.emitter_version);
    Signature { emitter, view: surface, casters: Vec::new(), object: live.permanent_epoch() }
}

/// The region a light mesh depends on: the scene's fitted bounds, within the light's range.
pub fn lightmesh_region(live: &LiveScene, light: &Light) -> Region {
    Region::of_box(&live.fit_bounds(), light)
}

/// The signature of a light's light mesh: its emitter and every static instance in `region` (casting
/// or only receiving), with their versions.
pub fn lightmesh_signature(live: &LiveScene, light: LightId, region: &Region) -> Signature {
    let emitter = live.light_state(light).map_or(0, |s| s.emitter_version);
    let mut statics: Vec<(InstanceId, u64)> = live
        .scene()
        .instances
        .iter()
        .zip(live.instances())
        .filter(|(inst, s)| inst.mobility == Mobility::Static && region.meets(&s.bounds))
        .map(|(_, s)| (s.id, s.version))
        .collect();
    statics.sort_unstable();
    Signature { emitter, view: 0, casters: statics, object: 0 }
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

/// `size` rounded up to a multiple of `align` (dynamic uniform offsets).
pub fn aligned(size: u64, align: u64) -> u64 {
    size.div_ceil(align.max(1)) * align.max(1)
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use glam::{Affine3A, Vec3};
    use shadowlab_core::lightspace::light_frusta;
    use shadowlab_core::receivers::planar_patches;
    use shadowlab_core::{LightKind, load_scene};

    use super::*;
    use crate::live::{Edit, InstanceId, LightChange};

    /// An item of the table test: its kind, its light, its region, what it belongs to.
    #[derive(Debug, Clone)]
    struct Item {
        kind: ItemKind,
        light: LightId,
        region: Option<Region>,
        object: Option<InstanceId>,
    }

    /// Every item of every kind, as the engine would hold them, with their signatures.
    fn items(live: &LiveScene, output: (u32, u32)) -> BTreeMap<(ItemKind, u32, u32, u32), (Item, Signature)> {
        let mut out = BTreeMap::new();
        let patches = planar_patches(live.scene(), 1.0);
        for (li, state) in live.lights().iter().enumerate() {
            let light = &live.scene().lights[li];
            for (v, view) in light_frusta(light, &live.fit_bounds(), 256).views.iter().enumerate() {
                let region = Region::of_view(&view.view_projection, light);
                let (s, c, _) = view_signatures(live, state.id, &region, view_hash(view, &[]));
                for (kind, sig) in [(ItemKind::StaticView, s), (ItemKind::CompositeView, c)] {
                    let item = Item { kind, light: state.id, region: Some(region), object: None };
                    out.insert((kind, state.id.0, v as u32, 0), (item, sig));
                }
            }
            for (k, p) in patches.iter().enumerate() {
                let b = Aabb::from_points(p.corners().into_iter().chain(light.position()));
                let region = Region::of_box(&b, light);
                let sig = lightmap_signature(live, state.id, &region, k as u64, p.instance);
                let item = Item {
                    kind: ItemKind::LightMap,
                    light: state.id,
                    region: Some(region),
                    object: Some(live.instances()[p.instance].id),
                };
                out.insert((ItemKind::LightMap, state.id.0, live.instances()[p.instance].id.0, k as u32), (item, sig));
            }
            for (o, (inst, s)) in live.scene().instances.iter().zip(live.instances()).enumerate() {
                if inst.casts_shadows && inst.mobility != Mobility::Temporary {
                    let item = Item { kind: ItemKind::VolumeObject, light: state.id, region: None, object: Some(s.id) };
                    out.insert(
                        (ItemKind::VolumeObject, state.id.0, s.id.0, 0),
                        (item, volume_signature(live, state.id, 0, o)),
                    );
                }
            }
            let region = lightmesh_region(live, light);
            let item = Item { kind: ItemKind::LightMesh, light: state.id, region: Some(region), object: None };
            out.insert((ItemKind::LightMesh, state.id.0, 0, 0), (item, lightmesh_signature(live, state.id, &region)));
            let item = Item { kind: ItemKind::ScreenBuffer, light: state.id, region: None, object: None };
            let sig = screen_signature(live, state.id, u64::from(output.0) << 32 | u64::from(output.1));
            out.insert((ItemKind::ScreenBuffer, state.id.0, 0, 0), (item, sig));
        }
        out
    }

    /// The room with the dynamic chair and a dragged copy of a chair, ready for every edit.
    fn base() -> (LiveScene, InstanceId, InstanceId, InstanceId) {
        let mut live = LiveScene::new(load_scene("room").unwrap().scene);
        let static_chair = live.find_instance("chair north-west").unwrap();
        let dynamic_chair = live.find_instance("chair east").unwrap();
        let mut dragged = live.instance(live.find_instance("chair south").unwrap()).unwrap().clone();
        dragged.name = "dragged".into();
        dragged.mobility = Mobility::Temporary;
        dragged.transform = Affine3A::from_translation(Vec3::new(0.0, 0.0, 0.3)) * dragged.transform;
        let temporary = live.apply(Edit::AddInstance(Box::new(dragged))).unwrap().instance.unwrap();
        (live, static_chair, dynamic_chair, temporary)
    }

    /// Applies `edit` and checks that exactly the items the table names changed their signature.
    fn check(name: &str, edit: impl FnOnce(&mut LiveScene, &mut (u32, u32)) -> crate::live::Applied) {
        let (mut live, ..) = base();
        let mut output = (160, 120);
        let before = items(&live, output);
        let fit = live.fit_bounds();
        let applied = edit(&mut live, &mut output);
        assert_eq!(live.fit_bounds(), fit, "{name}: the edit must not refit the lights (a case of its own)");
        let after = items(&live, output);
        for (key, (item, sig)) in &before {
            let changed = after.get(key).is_none_or(|(_, s)| s != sig);
            let meets = |b: Option<Aabb>| b.is_some_and(|b| item.region.is_some_and(|r| r.meets(&b)));
            let expected = match rule(applied.kind, item.kind) {
                // A footprint is compared by bounds, outside the signature.
                Rule::Never | Rule::CameraFitted | Rule::Footprint => false,
                Rule::Always => true,
                Rule::SameLight => applied.light == Some(item.light),
                Rule::Region => meets(applied.bounds_before) || meets(applied.bounds_after),
                Rule::SameObject => applied.instance.is_some() && applied.instance == item.object,
            };
            assert_eq!(
                changed,
                expected,
                "{name} ({:?}): {} of light {:?} (object {:?}): signature {} but the table says {:?}",
                applied.kind,
                item.kind.name(),
                item.light,
                item.object,
                if changed { "changed" } else { "held" },
                rule(applied.kind, item.kind)
            );
        }
    }

    fn nudge(live: &LiveScene, id: InstanceId) -> Affine3A {
        Affine3A::from_translation(Vec3::new(0.08, 0.0, -0.05)) * live.instance(id).unwrap().transform
    }

    /// Every edit kind → exactly the items of the table (Toromanoff §3.2 extended), by signature.
    #[test]
    fn signatures_change_exactly_as_the_table_says() {
        let (_, s, d, t) = base();
        let cup_copy = |m: Mobility| {
            move |live: &mut LiveScene, _: &mut (u32, u32)| {
                let mut cup = live.instance(live.find_instance("cup").unwrap()).unwrap().clone();
                cup.mobility = m;
                cup.transform = Affine3A::from_translation(Vec3::new(0.2, 0.0, 0.1)) * cup.transform;
                live.apply(Edit::AddInstance(Box::new(cup))).unwrap()
            }
        };
        for (name, id) in [("static", s), ("dynamic", d), ("temporary", t)] {
            check(&format!("move the {name} chair"), |live, _| {
                let to = nudge(live, id);
                live.apply(Edit::Transform { instance: id, transform: to }).unwrap()
            });
            check(&format!("remove the {name} chair"), |live, _| live.apply(Edit::RemoveInstance(id)).unwrap());
            for to in [Mobility::Static, Mobility::Dynamic, Mobility::Temporary] {
                check(&format!("the {name} chair becomes {}", to.name()), |live, _| {
                    live.apply(Edit::Mobility { instance: id, mobility: to }).unwrap()
                });
            }
        }
        for m in [Mobility::Static, Mobility::Dynamic, Mobility::Temporary] {
            check(&format!("add a {} cup", m.name()), cup_copy(m));
        }
        check("colour", |live, _| {
            live.apply(Edit::Light { light: LightId(0), change: LightChange::Color(Vec3::new(1.0, 0.0, 0.0)) }).unwrap()
        });
        check("intensity", |live, _| {
            live.apply(Edit::Light { light: LightId(2), change: LightChange::Intensity(0.1) }).unwrap()
        });
        check("lamp moved", |live, _| {
            let p = live.scene().lights[0].position().unwrap();
            live.apply(Edit::Light { light: LightId(0), change: LightChange::Position(p + Vec3::X * 0.2) }).unwrap()
        });
        check("lamp resized", |live, _| {
            live.apply(Edit::Light { light: LightId(1), change: LightChange::Radius(0.08) }).unwrap()
        });
        check("light added", |live, _| {
            let lamp = Light::new(
                "new",
                LightKind::Point { position: Vec3::new(0.5, 2.0, 0.5), radius: 0.05 },
                Vec3::ONE,
                1.0,
            );
            live.apply(Edit::AddLight(Box::new(lamp))).unwrap()
        });
        check("light removed", |live, _| live.apply(Edit::RemoveLight(LightId(1))).unwrap());
        check("resize", |_, output| {
            *output = (80, 60);
            crate::live::Applied {
                kind: EditKind::Resize,
                instance: None,
                light: None,
                bounds_before: None,
                bounds_after: None,
            }
        });
    }

    /// Moving a static object past the scene's extent refits every light's whole-scene views (their
    /// matrices change, so their signatures do): the one case outside the table.
    #[test]
    fn growing_the_scene_refits_every_view() {
        let (mut live, s, ..) = base();
        let hashes = |live: &LiveScene| -> Vec<u64> {
            live.scene()
                .lights
                .iter()
                .flat_map(|l| {
                    light_frusta(l, &live.fit_bounds(), 256).views.iter().map(|v| view_hash(v, &[])).collect::<Vec<_>>()
                })
                .collect()
        };
        let before = hashes(&live);
        live.apply(Edit::Transform { instance: s, transform: Affine3A::from_translation(Vec3::new(40.0, 0.0, 0.0)) })
            .unwrap();
        let after = hashes(&live);
        assert_eq!(before.len(), after.len());
        for (i, (a, b)) in before.iter().zip(&after).enumerate() {
            assert_ne!(a, b, "view {i} kept its fit");
        }
    }

    #[test]
    fn the_readme_shows_the_table() {
        let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../README.md")).unwrap();
        assert!(
            readme.contains(&table_markdown()),
            "README.md's validity table differs from the code's:\n{}",
            table_markdown()
        );
    }

    #[test]
    fn colour_never_invalidates_shadow_data() {
        for k in ItemKind::ALL {
            assert_eq!(rule(EditKind::LightColour, k), Rule::Never, "{}", k.name());
        }
    }
}
