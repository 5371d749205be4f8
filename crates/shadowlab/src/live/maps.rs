//! Cached map views: the one mechanism by which every map-based technique keeps its shadow maps
//! across frames (Filament's `ShadowMapManager` and Unity HDRP's mixed cached shadow maps are the
//! models).
//!
//! Each view (a cube face, a cone, a cascade, an emitter sample's view) has a **static layer**
//! holding the static casters, kept while its [`Signature`] holds (the light's emitter, the view
//! itself, the static casters that reach it and their versions). When dynamic casters reach the
//! view, a **composite layer** holds a copy of the static layer with those casters drawn over it,
//! kept while they stand still; views no dynamic caster reaches are looked up in their static layer
//! directly. Layers come from one pool per set (the array grows by a quarter of its views at a time,
//! its layers copied over), so only views that dynamic casters reach cost memory twice; where the
//! device cannot hold more layers, static and dynamic casters share the static layer and its
//! signature names both.
//!
//! **Spread over frames** ([`super::scheduler`]): with an unlimited [`Budget`](super::scheduler::Budget) every stale view is
//! rendered in place in the frame that made it stale. With a limited one, each stale view is a unit
//! rendered into layers of its own while the budget allows; the set keeps showing its previous
//! complete state until every stale view has been rendered for the current state, then all switch
//! at once (Toromanoff's all-or-nothing rule), and the replaced layers return to the pool.
//!
//! With caching disabled ([`super::ShadowCache::set_enabled`]) every view is rendered every frame
//! with all permanent casters in one pass: the uncached engine the cached one is checked against.
//! Temporary (dragged) casters are in no layer: they have a pass of their own
//! ([`super::temporary`]).

use shadowlab_core::Mobility;
use shadowlab_core::lightspace::ShadowView;

use super::cache::ItemKey;
use super::scheduler::UnitKind;
use super::validity::{ItemKind, Region, Signature, view_hash, view_signatures};
use crate::context::Shared;
use crate::shadowmap::{PERMANENT, Raster, ShadowMapArray};
use crate::technique::{FrameContext, TechniqueError};

/// What a view was last checked against: when none of it changed, the view is valid without
/// testing its casters again (a still frame costs nothing).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Checked {
    epoch: u64,
    view: u64,
    cache_generation: u64,
}

/// The layers of one view's state, and what they hold.
#[derive(Debug, Clone, PartialEq)]
struct Layers {
    /// The view they were rendered from (what lookups must project with).
    view: ShadowView,
    static_layer: u32,
    /// With dynamic casters: the copy with them drawn over (else lookups read the static layer).
    composite_layer: Option<u32>,
    static_sig: Signature,
    composite_sig: Option<Signature>,
    /// Static and dynamic casters in the static layer (no room for a composite copy).
    merged: bool,
}

impl Layers {
    /// The layer lookups read.
    fn shown(&self) -> u32 {
        self.composite_layer.unwrap_or(self.static_layer)
    }
}

/// A light's views with their cached layers.
pub struct MapViews {
    pub maps: ShadowMapArray,
    /// Views looked up (and rendered) by this set.
    count: u32,
    /// This allocation's set id in the cache's keys.
    set: u32,
    views: Vec<ShadowView>,
    /// Per view: the layers shown, once the set has been complete.
    front: Vec<Option<Layers>>,
    /// Per view: layers rendered for a state not yet shown (an update spread over frames).
    back: Vec<Option<Layers>>,
    /// Per view: the view and texture layer written into its lookup uniform.
    written: Vec<Option<(ShadowView, u32)>>,
    checked: Vec<Option<Checked>>,
    /// Layers the array has, and those not in use.
    allocated: u32,
    free: Vec<u32>,
    /// Bumped when the texture is reallocated: bind groups over it must be made again.
    generation: u32,
    /// Whether the layers shown hold the current state.
    current: bool,
    /// Bumped whenever what the lookups read changes (a layer shown, re-rendered or swapped), for
    /// what is derived from the maps (`ssm`'s depth pyramid).
    shown_version: u64,
    /// Draws issued by the last update.
    pub draws: u32,
}

impl MapViews {
    /// `count` views of `size`² texels, with a new set id from the cache.
    pub fn new(shared: &Shared, cache: &mut super::ShadowCache, size: u32, count: u32) -> Self {
        let count = count.max(1);
        Self {
            maps: ShadowMapArray::new(shared, size, count, count),
            count,
            set: cache.new_set(),
            views: Vec::new(),
            front: vec![None; count as usize],
            back: vec![None; count as usize],
            written: vec![None; count as usize],
            checked: vec![None; count as usize],
            allocated: count,
            free: (0..count).rev().collect(),
            generation: 0,
            current: false,
            shown_version: 0,
            draws: 0,
        }
    }

    /// Views in the set.
    pub fn len(&self) -> u32 {
        self.count
    }

    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    pub fn size(&self) -> u32 {
        self.maps.size
    }

    /// Changes when the texture was reallocated (bind groups over `maps` must be made again).
    pub fn generation(&self) -> u32 {
        self.generation
    }

    /// The views of the last update.
    pub fn views(&self) -> &[ShadowView] {
        &self.views
    }

    pub fn bytes(&self) -> u64 {
        self.maps.bytes()
    }

    /// Whether every view shows a complete state (the current one, or the last complete one while
    /// an update is spread over frames). Before the first complete state nothing may be looked up.
    pub fn shown(&self) -> bool {
        self.front.iter().all(Option::is_some)
    }

    /// Whether the layers shown hold the current state (nothing pending).
    pub fn current(&self) -> bool {
        self.current
    }

    /// Changes whenever what the lookups read changes: derived data (a depth pyramid) made for
    /// another version is stale.
    pub fn shown_version(&self) -> u64 {
        self.shown_version
    }

    /// The view that view `i`'s lookups read (the last complete state while an update is spread
    /// over frames); `None` before its first.
    pub fn shown_view(&self, i: u32) -> Option<&ShadowView> {
        self.written.get(i as usize)?.as_ref().map(|w| &w.0)
    }

    fn key(&self, ctx: &FrameContext<'_>, kind: ItemKind, i: u32) -> ItemKey {
        ItemKey { light: ctx.light_id, owner: ctx.owner, set: self.set, kind, index: i }
    }

    /// The layers added each time the pool runs out.
    fn growth(&self) -> u32 {
        (self.count / 4).max(1)
    }

    /// A free layer, growing the array when the pool is empty; `None` past the device's limit.
    fn take_layer(&mut self, ctx: &mut FrameContext<'_>) -> Option<u32> {
        if self.free.is_empty() {
            let grown = self.allocated + self.growth();
            if grown > ctx.shared.gpu.device.limits().max_texture_array_layers {
                return None;
            }
            let placeholder = ShadowMapArray::new(ctx.shared, 1, 1, 1);
            let old = std::mem::replace(&mut self.maps, placeholder);
            // Every layer is copied over, so every record stays true.
            self.maps = old.grown(ctx.shared, ctx.encoder, grown);
            self.free.extend((self.allocated..grown).rev());
            self.allocated = grown;
            self.generation += 1;
        }
        self.free.pop()
    }

    /// Sets this frame's views (`views.len()` must be [`MapViews::len`]) and renders the layers
    /// that are not valid, within the frame's budget. `extra` is hashed into every view's
    /// signature: whatever else decides what the maps hold (the technique's map parameters).
    /// Returns the views rendered.
    pub fn update(
        &mut self,
        ctx: &mut FrameContext<'_>,
        views: &[ShadowView],
        raster: &Raster,
        extra: u64,
    ) -> Result<u32, TechniqueError> {
        if views.len() != self.count as usize {
            return Err(TechniqueError::Failed {
                id: "maps".into(),
                message: format!("{} views for a set of {}", views.len(), self.count),
            });
        }
        let queue = ctx.gpu.queue.clone();
        if self.views != views {
            // Passes render the current views; lookups keep the views of the layers they read.
            self.views = views.to_vec();
            self.maps.set_render_views(&queue, 0, views);
        }
        let raster_hash = raster_hash(raster, self.maps.size, extra);
        self.draws = 0;
        let mut rendered = 0;
        if !ctx.cache.enabled() {
            for i in 0..self.count {
                let layer = match &self.front[i as usize] {
                    Some(f) => f.static_layer,
                    None => self.take_layer(ctx).unwrap_or(i),
                };
                self.draws += self.maps.render_casters(ctx, layer, i, raster, PERMANENT, true);
                self.front[i as usize] = Some(Layers {
                    view: self.views[i as usize],
                    static_layer: layer,
                    composite_layer: None,
                    static_sig: Signature::default(),
                    composite_sig: None,
                    merged: true,
                });
                ctx.cache.work.map_views += 1;
                rendered += 1;
            }
            self.current = true;
            self.shown_version += 1;
            self.write_layers(&queue);
            return Ok(rendered);
        }
        let (epoch, generation) = (ctx.live.epoch(), ctx.cache.generation());
        // Which views are stale, with the signatures of their current state.
        let mut stale: Vec<(u32, Signature, Option<Signature>, bool)> = Vec::new();
        for i in 0..self.count {
            let view = self.views[i as usize];
            let vh = view_hash(&view, &[raster_hash]);
            let quick = Checked { epoch, view: vh, cache_generation: generation };
            if self.checked[i as usize] == Some(quick) && self.back[i as usize].is_none() {
                ctx.cache.work.reused += 1;
                continue;
            }
            let region = Region::of_view(&view.view_projection, ctx.light);
            let (static_sig, composite_sig, has_dynamic) = view_signatures(ctx.live, ctx.light_id, &region, vh);
            let composite_sig = has_dynamic.then_some(composite_sig);
            let valid = |s: &Self, ctx: &FrameContext<'_>| {
                let front = s.front[i as usize].as_ref();
                let static_ok = ctx.cache.is_valid(&s.key(ctx, ItemKind::StaticView, i), &static_sig)
                    && front.is_some_and(|f| !f.merged);
                let merged_ok = front.is_some_and(|f| f.merged)
                    && composite_sig
                        .as_ref()
                        .is_some_and(|c| ctx.cache.is_valid(&s.key(ctx, ItemKind::StaticView, i), c));
                let composite_ok = match &composite_sig {
                    // No dynamic caster left: the shown layers must not be a composite copy.
                    None => front.is_some_and(|f| f.composite_layer.is_none()),
                    Some(c) => {
                        front.is_some_and(|f| f.composite_layer.is_some())
                            && ctx.cache.is_valid(&s.key(ctx, ItemKind::CompositeView, i), c)
                    }
                };
                (static_ok && composite_ok) || merged_ok
            };
            if valid(self, ctx) {
                ctx.cache.work.reused += 1;
                if let Some(old) = self.back[i as usize].take() {
                    give_back(&mut self.free, &old, self.front[i as usize].as_ref());
                }
                self.checked[i as usize] = Some(quick);
            } else {
                stale.push((i, static_sig, composite_sig, false));
            }
        }
        let in_place = ctx.budget.is_unlimited();
        let mut done = true;
        for (i, static_sig, composite_sig, _) in &stale {
            let i = *i;
            if let Some(back) = &self.back[i as usize]
                && back.static_sig == *static_sig
                && (back.composite_sig == *composite_sig || back.merged)
            {
                continue; // rendered in an earlier frame for this very state
            }
            let units = 1 + u32::from(composite_sig.is_some());
            let texels = u64::from(self.maps.size).pow(2);
            if !ctx.take_units(UnitKind::MapView, texels, units) {
                done = false;
                continue;
            }
            let before = ctx.cache.work.map_views;
            let layers = self.render_view(ctx, i, raster, static_sig.clone(), composite_sig.clone(), in_place);
            if layers.is_some() && ctx.cache.work.map_views == before {
                // A composite copy given up, nothing rendered: still new data for the lookups, so
                // the light is resolved again (a technique without a shown version is resolved
                // when its `prepare` fills anything).
                ctx.cache.work.shown_views += 1;
            }
            rendered += units;
            match layers {
                Some(l) if in_place => {
                    self.commit(ctx, i, l);
                }
                Some(l) => {
                    if let Some(old) = self.back[i as usize].take() {
                        give_back(&mut self.free, &old, self.front[i as usize].as_ref());
                    }
                    self.back[i as usize] = Some(l);
                }
                None => done = false,
            }
        }
        if !in_place && done {
            // Every stale view has its layers for the current state: show them all at once.
            for (i, ..) in &stale {
                if let Some(l) = self.back[*i as usize].take() {
                    self.commit(ctx, *i, l);
                }
            }
        }
        self.current = done;
        if done {
            for (i, ..) in &stale {
                let vh = view_hash(&self.views[*i as usize], &[raster_hash]);
                self.checked[*i as usize] = Some(Checked { epoch, view: vh, cache_generation: ctx.cache.generation() });
            }
        }
        self.write_layers(&queue);
        Ok(rendered)
    }

    /// Makes `layers` view `i`'s shown state: records its signatures, frees the layers replaced.
    fn commit(&mut self, ctx: &mut FrameContext<'_>, i: u32, layers: Layers) {
        let static_key = self.key(ctx, ItemKind::StaticView, i);
        let composite_key = self.key(ctx, ItemKind::CompositeView, i);
        if layers.merged {
            ctx.cache.commit(static_key, layers.composite_sig.clone().unwrap_or_else(|| layers.static_sig.clone()));
            ctx.cache.forget(&composite_key);
        } else {
            ctx.cache.commit(static_key, layers.static_sig.clone());
            match &layers.composite_sig {
                Some(c) => ctx.cache.commit(composite_key, c.clone()),
                None => ctx.cache.forget(&composite_key),
            }
        }
        if let Some(old) = self.front[i as usize].take() {
            give_back(&mut self.free, &old, Some(&layers));
        }
        self.front[i as usize] = Some(layers);
        self.shown_version += 1;
    }

    /// Renders view `i` for the state of `static_sig` / `composite_sig`: in its shown layers
    /// (`in_place`), or in layers of its own. Returns its layers, `None` when no layer was free.
    fn render_view(
        &mut self,
        ctx: &mut FrameContext<'_>,
        i: u32,
        raster: &Raster,
        static_sig: Signature,
        composite_sig: Option<Signature>,
        in_place: bool,
    ) -> Option<Layers> {
        let front = self.front[i as usize].clone();
        let static_key = self.key(ctx, ItemKind::StaticView, i);
        let static_valid = front.as_ref().is_some_and(|f| !f.merged) && ctx.cache.is_valid(&static_key, &static_sig);
        // The static layer: kept when still valid, else rendered (in place, or into a new layer).
        let static_layer = match (&front, static_valid, in_place) {
            (Some(f), true, _) => f.static_layer,
            (Some(f), false, true) => f.static_layer,
            _ => self.take_layer(ctx)?,
        };
        if !static_valid {
            // With dynamic casters and no room for a composite copy, both go in the static layer.
            let merged = composite_sig.is_some()
                && front.as_ref().and_then(|f| f.composite_layer).is_none()
                && self.free.is_empty()
                && self.allocated + self.growth() > ctx.shared.gpu.device.limits().max_texture_array_layers;
            let classes: &[Mobility] = if merged { PERMANENT } else { &[Mobility::Static] };
            self.draws += self.maps.render_casters(ctx, static_layer, i, raster, classes, true);
            ctx.cache.work.map_views += 1;
            if merged {
                let view = self.views[i as usize];
                return Some(Layers {
                    view,
                    static_layer,
                    composite_layer: None,
                    static_sig,
                    composite_sig,
                    merged: true,
                });
            }
        }
        let composite_layer = match &composite_sig {
            None => None,
            Some(_) => {
                let layer = match (&front, in_place) {
                    (Some(f), true) if f.composite_layer.is_some() => f.composite_layer.expect("checked"),
                    _ => self.take_layer(ctx)?,
                };
                self.maps.copy_layer(ctx.encoder, static_layer, layer);
                self.draws += self.maps.render_casters(ctx, layer, i, raster, &[Mobility::Dynamic], false);
                ctx.cache.work.map_views += 1;
                ctx.cache.work.composite_views += 1;
                Some(layer)
            }
        };
        Some(Layers {
            view: self.views[i as usize],
            static_layer,
            composite_layer,
            static_sig,
            composite_sig,
            merged: false,
        })
    }

    /// Writes each view's lookup uniform with the view and layer it shows (where they changed).
    fn write_layers(&mut self, queue: &wgpu::Queue) {
        for i in 0..self.count as usize {
            let shown = self.front[i].as_ref().map(|f| (f.view, f.shown()));
            if let Some((view, layer)) = shown
                && self.written[i] != shown
            {
                self.maps.set_view_layer(queue, i as u32, &view, layer);
                self.written[i] = shown;
                self.shown_version += 1;
            }
        }
    }

    /// Drops this set's records from the cache (its memory is about to be freed or replaced).
    pub fn forget_items(&self, ctx: &mut FrameContext<'_>) {
        for i in 0..self.count {
            for kind in [ItemKind::StaticView, ItemKind::CompositeView] {
                let key = self.key(ctx, kind, i);
                ctx.cache.forget(&key);
            }
        }
    }
}

/// Returns the layers of `layers` to the pool, but those `keep` still uses.
fn give_back(free: &mut Vec<u32>, layers: &Layers, keep: Option<&Layers>) {
    let kept = |l: u32| keep.is_some_and(|k| k.static_layer == l || k.composite_layer == Some(l));
    for l in std::iter::once(layers.static_layer).chain(layers.composite_layer) {
        if !kept(l) && !free.contains(&l) {
            free.push(l);
        }
    }
}

/// A hash of the raster state and map size (what, beside the view, decides a map's depths).
fn raster_hash(raster: &Raster, size: u32, extra: u64) -> u64 {
    let faces = match raster.faces {
        crate::shadowmap::FaceMode::Back => 0u64,
        crate::shadowmap::FaceMode::Front => 1,
        crate::shadowmap::FaceMode::Both => 2,
    };
    let masked = u64::from(raster.only_masked) << 63;
    faces ^ masked ^ (u64::from(raster.slope_bias.to_bits()) << 2) ^ (u64::from(size) << 34) ^ extra.rotate_left(17)
}
