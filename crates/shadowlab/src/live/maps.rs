//! Cached map views: the one mechanism by which every map-based technique keeps its shadow maps
//! across frames (Filament's `ShadowMapManager` and Unity HDRP's mixed cached shadow maps are the
//! models).
//!
//! Each view (a cube face, a cone, a cascade, an emitter sample's view) has a **static layer**
//! holding the static casters, kept while its [`Signature`] holds (the light's emitter, the view
//! itself, the static casters that reach it and their versions). When dynamic casters reach the
//! view, a **composite layer** holds a copy of the static layer with those casters drawn over it,
//! kept while they stand still; views no dynamic caster reaches are looked up in their static layer
//! directly. A view gets its composite layer the first time a dynamic caster reaches it (the array
//! grows by a quarter of its views at a time, its layers copied over, so only views that dynamic
//! casters reach cost memory twice); where the device cannot hold more layers, static and dynamic
//! casters share the static layer and its signature names both.
//!
//! With caching disabled ([`super::ShadowCache::set_enabled`]) every view is rendered every frame
//! with all permanent casters in one pass: the uncached engine the cached one is checked against.
//! Temporary (dragged) casters are in no layer: they have a pass of their own
//! ([`super::temporary`]).

use shadowlab_core::Mobility;
use shadowlab_core::lightspace::ShadowView;

use super::cache::ItemKey;
use super::validity::{ItemKind, Region, view_hash, view_signatures};
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
    layer: u32,
}

/// A light's views with their cached layers.
pub struct MapViews {
    pub maps: ShadowMapArray,
    /// Views looked up (and rendered) by this set.
    count: u32,
    /// This allocation's set id in the cache's keys.
    set: u32,
    views: Vec<ShadowView>,
    /// Per view: the texture layer lookups read this frame.
    layers: Vec<u32>,
    checked: Vec<Option<Checked>>,
    /// Per view: its composite layer, once a dynamic caster has reached it.
    composite_layer: Vec<Option<u32>>,
    /// Layers the array has (the static layers `0..count`, then composite ones).
    allocated: u32,
    /// The next composite layer to hand out.
    next_composite: u32,
    /// Bumped when the texture is reallocated: bind groups over it must be made again.
    generation: u32,
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
            layers: vec![u32::MAX; count as usize],
            checked: vec![None; count as usize],
            composite_layer: vec![None; count as usize],
            allocated: count,
            next_composite: count,
            generation: 0,
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

    fn key(&self, ctx: &FrameContext<'_>, kind: ItemKind, i: u32) -> ItemKey {
        ItemKey { light: ctx.light_id, owner: ctx.owner, set: self.set, kind, index: i }
    }

    /// The composite layers a growth adds.
    fn growth(&self) -> u32 {
        (self.count / 4).max(1)
    }

    /// Whether view `i` has, or can get, a composite layer.
    fn composite_fits(&self, shared: &Shared, i: u32) -> bool {
        self.composite_layer[i as usize].is_some()
            || self.next_composite < self.allocated
            || self.allocated + self.growth() <= shared.gpu.device.limits().max_texture_array_layers
    }

    /// Sets this frame's views (`views.len()` must be [`MapViews::len`]) and renders the layers
    /// that are not valid. `extra` is hashed into every view's signature: whatever else decides
    /// what the maps hold (the technique's map parameters). Returns the views rendered.
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
            self.maps.set_views_in(
                &queue,
                0,
                views,
                &self.layers.iter().map(|&l| l.min(self.count)).collect::<Vec<_>>(),
            );
            self.views = views.to_vec();
            // Force the layers to be written below.
            self.layers.iter_mut().for_each(|l| *l = u32::MAX);
        }
        let raster_hash = raster_hash(raster, self.maps.size, extra);
        let (epoch, generation) = (ctx.live.epoch(), ctx.cache.generation());
        self.draws = 0;
        let mut rendered = 0;
        for i in 0..self.count {
            let view = self.views[i as usize];
            let vh = view_hash(&view, &[raster_hash]);
            let layer = if !ctx.cache.enabled() {
                self.draws += self.maps.render_casters(ctx, i, i, raster, PERMANENT, true);
                ctx.cache.work.map_views += 1;
                rendered += 1;
                i
            } else if let Some(c) = self.checked[i as usize]
                && c.epoch == epoch
                && c.view == vh
                && c.cache_generation == generation
            {
                ctx.cache.work.reused += 1;
                c.layer
            } else {
                let layer = self.update_view(ctx, i, &view, vh, raster, &mut rendered)?;
                self.checked[i as usize] =
                    Some(Checked { epoch, view: vh, cache_generation: ctx.cache.generation(), layer });
                layer
            };
            if self.layers[i as usize] != layer {
                self.maps.set_view_layer(&queue, i, &view, layer);
                self.layers[i as usize] = layer;
            }
        }
        Ok(rendered)
    }

    /// Checks view `i` against the cache and renders what is stale; returns the layer to read.
    fn update_view(
        &mut self,
        ctx: &mut FrameContext<'_>,
        i: u32,
        view: &ShadowView,
        vh: u64,
        raster: &Raster,
        rendered: &mut u32,
    ) -> Result<u32, TechniqueError> {
        let region = Region::of_view(&view.view_projection, ctx.light);
        let (static_sig, composite_sig, has_dynamic) = view_signatures(ctx.live, ctx.light_id, &region, vh);
        let static_key = self.key(ctx, ItemKind::StaticView, i);
        if has_dynamic && !self.composite_fits(ctx.shared, i) {
            // No room for composite copies: both classes share the static layer.
            let sig = composite_sig;
            if ctx.cache.is_valid(&static_key, &sig) {
                ctx.cache.work.reused += 1;
            } else {
                self.draws += self.maps.render_casters(ctx, i, i, raster, PERMANENT, true);
                ctx.cache.commit(static_key, sig);
                ctx.cache.work.map_views += 1;
                *rendered += 1;
            }
            return Ok(i);
        }
        let static_fresh = ctx.cache.is_valid(&static_key, &static_sig);
        if static_fresh {
            ctx.cache.work.reused += 1;
        } else {
            self.draws += self.maps.render_casters(ctx, i, i, raster, &[Mobility::Static], true);
            ctx.cache.commit(static_key, static_sig);
            ctx.cache.work.map_views += 1;
            *rendered += 1;
        }
        if !has_dynamic {
            return Ok(i);
        }
        let target = match self.composite_layer[i as usize] {
            Some(layer) => layer,
            None => {
                if self.next_composite == self.allocated {
                    self.grow(ctx);
                }
                self.next_composite += 1;
                self.composite_layer[i as usize] = Some(self.next_composite - 1);
                self.next_composite - 1
            }
        };
        let composite_key = self.key(ctx, ItemKind::CompositeView, i);
        if ctx.cache.is_valid(&composite_key, &composite_sig) {
            ctx.cache.work.reused += 1;
        } else {
            self.maps.copy_layer(ctx.encoder, i, target);
            self.draws += self.maps.render_casters(ctx, target, i, raster, &[Mobility::Dynamic], false);
            ctx.cache.commit(composite_key, composite_sig);
            ctx.cache.work.map_views += 1;
            ctx.cache.work.composite_views += 1;
            *rendered += 1;
        }
        Ok(target)
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

    /// Adds room for composite layers: a new array, every layer copied over (so every record
    /// stays true: each view keeps its layers).
    fn grow(&mut self, ctx: &mut FrameContext<'_>) {
        let placeholder = ShadowMapArray::new(ctx.shared, 1, 1, 1);
        let old = std::mem::replace(&mut self.maps, placeholder);
        self.allocated += self.growth();
        self.maps = old.grown(ctx.shared, ctx.encoder, self.allocated);
        self.generation += 1;
    }
}

/// A hash of the raster state and map size (what, beside the view, decides a map's depths).
fn raster_hash(raster: &Raster, size: u32, extra: u64) -> u64 {
    let faces = match raster.faces {
        crate::shadowmap::FaceMode::Back => 0u64,
        crate::shadowmap::FaceMode::Front => 1,
        crate::shadowmap::FaceMode::Both => 2,
    };
    faces ^ (u64::from(raster.slope_bias.to_bits()) << 2) ^ (u64::from(size) << 34) ^ extra.rotate_left(17)
}
