//! The one store of cached shadow items, shared by every technique of a live engine.
//!
//! An item is keyed by its light, its owner (one technique instance: a light's technique, or a
//! shared resource) and its kind and index there; the store keeps the [`Signature`] it was built
//! from. A technique asks [`ShadowCache::is_valid`] before rendering an item, renders it only when
//! not, and records the new signature with [`ShadowCache::commit`]. Owners that drop or reallocate
//! their GPU memory drop their records ([`ShadowCache::forget_owner`]), so the store never outgrows
//! what is alive.

use std::collections::HashMap;
use std::sync::Arc;

use shadowlab_core::LightId;
use shadowlab_core::lightmesh::LightMesh;

use super::scheduler::UnitCounts;
use super::validity::{ItemKind, Signature};

/// A cached item's address.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ItemKey {
    pub light: LightId,
    /// The technique instance (or shared resource) that holds the item's memory.
    pub owner: u32,
    /// The set of items within the owner (one allocation: a map array): never reused, so a new
    /// allocation cannot inherit the records of one it replaced.
    pub set: u32,
    pub kind: ItemKind,
    pub index: u32,
}

/// Work done in one frame, by what was (re)built: the `work` of `timeline.json`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Work {
    /// Map views rendered (static layers, composite layers, uncached views).
    pub map_views: u32,
    /// Map views shown anew without rendering anything (a composite copy given up for the static
    /// layer when no dynamic caster reaches the view any more): what the lookups read changed.
    pub shown_views: u32,
    /// Of those, composite layers (a static copy with the dynamic casters drawn over it).
    pub composite_views: u32,
    /// Emitter samples rendered into receiver light maps.
    pub lightmap_samples: u32,
    /// Texels those samples covered, each counted once a sample (a refill after a caster's edit
    /// covers only the texels the caster can change; saturates).
    pub lightmap_texels: u32,
    /// Objects whose silhouettes and volumes were extracted for a light.
    pub volume_objects: u32,
    /// Views rendered for temporary (dragged) objects: every frame while they are dragged.
    pub temporary_views: u32,
    /// Light meshes rebuilt on the CPU (`lightmesh`: a static object or the light moved).
    pub light_meshes: u32,
    /// Items found valid and reused.
    pub reused: u32,
    /// Visibility layers written (a light whose maps, scene and surface did not change keeps its
    /// layer of the last frame).
    pub resolves: u32,
    /// Of those, resolves limited to dragged objects' footprints (the rest of the layer kept).
    pub region_resolves: u32,
    /// Units left for later frames by the budget.
    pub deferred: u32,
    /// Lights that kept the layer they showed before a drag began or ended, waiting for their turn
    /// (under a target frame time, one light at a time moves to or from the dragged objects' pass:
    /// a frame each, or at a pick-up under a budget below the render time two, the light held
    /// during the first).
    pub held_lights: u32,
    /// The frame's budget for fills (infinite without a target frame time) and what it planned.
    pub budget_ms: f64,
    pub planned_ms: f64,
}

impl Work {
    /// `(name, count)` of every counter, for reports.
    pub fn counts(&self) -> [(&'static str, u32); 13] {
        [
            ("map_views", self.map_views),
            ("shown_views", self.shown_views),
            ("composite_views", self.composite_views),
            ("lightmap_samples", self.lightmap_samples),
            ("lightmap_texels", self.lightmap_texels),
            ("volume_objects", self.volume_objects),
            ("temporary_views", self.temporary_views),
            ("reused", self.reused),
            ("resolves", self.resolves),
            ("region_resolves", self.region_resolves),
            ("deferred", self.deferred),
            ("light_meshes", self.light_meshes),
            ("held_lights", self.held_lights),
        ]
    }

    /// Whether anything was rebuilt (reuse does not count).
    pub fn rebuilt_anything(&self) -> bool {
        self.fills().iter().any(|&n| n > 0)
    }

    /// The counters of work that renders shadow data (maps, composites, light-map samples, volume
    /// objects, temporary views, light meshes) or shows other data (views switched to their static
    /// layer): when they moved between two points, something was filled in between.
    pub fn fills(&self) -> [u32; 7] {
        [
            self.shown_views,
            self.map_views,
            self.composite_views,
            self.lightmap_samples,
            self.volume_objects,
            self.temporary_views,
            self.light_meshes,
        ]
    }
}

/// The store.
#[derive(Debug)]
pub struct ShadowCache {
    records: HashMap<ItemKey, Signature>,
    enabled: bool,
    next_owner: u32,
    /// Bumped whenever records are dropped, so that quick checks made earlier do not outlive them.
    generation: u64,
    /// This frame's work so far.
    pub work: Work,
    /// This frame's units of work by kind and size, for the cost model.
    pub units: UnitCounts,
    /// Light meshes read from a file (`shadowlab precompute`), each with the signature of the state
    /// it was made for: `lightmesh` takes one instead of building it while the signatures agree.
    pub preloaded_light_meshes: Vec<(LightId, Signature, Arc<LightMesh>)>,
    /// Shadow-map memory shares by technique owner (bytes), set by `Shadows` when the lights'
    /// demands exceed the memory budget; an owner without one takes the size it asks for.
    pub map_shares: HashMap<u32, u64>,
    /// Map sizes granted below the asked ones, by (light, owner): (asked, granted).
    pub map_reductions: HashMap<(LightId, u32), (u32, u32)>,
}

impl Default for ShadowCache {
    fn default() -> Self {
        Self {
            records: HashMap::new(),
            enabled: true,
            next_owner: 1,
            generation: 0,
            work: Work::default(),
            units: UnitCounts::new(),
            preloaded_light_meshes: Vec::new(),
            map_shares: HashMap::new(),
            map_reductions: HashMap::new(),
        }
    }
}

/// Bytes of one depth texel of a shadow map (`Depth32Float`).
pub const MAP_TEXEL_BYTES: u64 = 4;

/// The largest map size that is `asked` halved zero or more times, at least 16 (the smallest
/// `map_size`), with `layers` maps of it within `share` bytes.
pub fn fit_map_size(asked: u32, layers: u32, share: u64) -> u32 {
    let mut size = asked.max(16);
    while size > 16 && u64::from(layers) * u64::from(size) * u64::from(size) * MAP_TEXEL_BYTES > share {
        size = (size / 2).max(16);
    }
    size
}

impl ShadowCache {
    /// The map size a technique instance (`owner`, shadowing `light`) may allocate for `layers`
    /// maps of `asked`² texels: within its share of the memory budget, if it has one.
    pub fn grant_map_size(&mut self, light: LightId, owner: u32, asked: u32, layers: u32) -> u32 {
        let granted = self.map_shares.get(&owner).map_or(asked, |&share| fit_map_size(asked, layers, share));
        if granted < asked {
            self.map_reductions.insert((light, owner), (asked, granted));
        } else {
            self.map_reductions.remove(&(light, owner));
        }
        granted
    }
    /// Whether items are kept across frames. Disabled, every item is rebuilt every frame (the
    /// uncached engine the cached one is measured and checked against).
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    pub fn set_enabled(&mut self, on: bool) {
        self.enabled = on;
        self.clear();
    }

    /// Changes whenever records are dropped.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// A fresh owner id (never reused, so a replaced technique's records cannot be mistaken for
    /// its successor's).
    pub fn new_owner(&mut self) -> u32 {
        self.next_owner += 1;
        self.next_owner
    }

    /// A fresh set id for [`ItemKey::set`].
    pub fn new_set(&mut self) -> u32 {
        self.next_owner += 1;
        self.next_owner
    }

    /// Whether `key` holds what `signature` describes.
    pub fn is_valid(&self, key: &ItemKey, signature: &Signature) -> bool {
        self.enabled && self.records.get(key) == Some(signature)
    }

    /// Whether `key` holds something the cache vouches for (valid or not for the present state): a
    /// refill may then keep what an edit cannot have changed.
    pub fn holds(&self, key: &ItemKey) -> bool {
        self.enabled && self.records.contains_key(key)
    }

    /// Records that `key` now holds what `signature` describes.
    pub fn commit(&mut self, key: ItemKey, signature: Signature) {
        if self.enabled {
            self.records.insert(key, signature);
        }
    }

    /// Forgets one item (its memory was overwritten by something else).
    pub fn forget(&mut self, key: &ItemKey) {
        if self.records.remove(key).is_some() {
            self.generation += 1;
        }
    }

    /// Forgets every item of an owner (its memory was freed or reallocated).
    pub fn forget_owner(&mut self, owner: u32) {
        self.records.retain(|k, _| k.owner != owner);
        self.map_reductions.retain(|k, _| k.1 != owner);
        self.generation += 1;
    }

    /// Forgets every item of a light.
    pub fn forget_light(&mut self, light: LightId) {
        self.records.retain(|k, _| k.light != light);
        self.map_reductions.retain(|k, _| k.0 != light);
        self.generation += 1;
    }

    /// Forgets everything (device memory lost).
    pub fn clear(&mut self) {
        self.records.clear();
        self.generation += 1;
    }

    /// Items recorded.
    pub fn len(&self) -> usize {
        self.records.len()
    }

    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Starts a frame's work counts.
    pub fn begin_frame(&mut self) -> Work {
        std::mem::take(&mut self.work)
    }

    /// The frame's units by kind and size (cleared).
    pub fn take_units(&mut self) -> UnitCounts {
        std::mem::take(&mut self.units)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_sizes_halve_until_they_fit_their_share() {
        // Six 2048² faces are 96 MiB: a 16 MiB share holds six 512² ones (6 MiB), not 1024² (24 MiB).
        assert_eq!(fit_map_size(2048, 6, 16 << 20), 512);
        assert_eq!(fit_map_size(2048, 6, 96 << 20), 2048, "a share that holds the asked size keeps it");
        assert_eq!(fit_map_size(2048, 6, 0), 16, "never below the smallest map size");
        assert_eq!(fit_map_size(1000, 1, 1 << 20), 500, "sizes that are not powers of two halve too");
    }

    #[test]
    fn grants_follow_shares_and_are_reported() {
        let mut cache = ShadowCache::default();
        let light = LightId(3);
        assert_eq!(cache.grant_map_size(light, 7, 2048, 6), 2048, "no share: the asked size");
        cache.map_shares.insert(7, 16 << 20);
        assert_eq!(cache.grant_map_size(light, 7, 2048, 6), 512);
        assert_eq!(cache.map_reductions.get(&(light, 7)), Some(&(2048, 512)));
        cache.forget_owner(7);
        assert!(cache.map_reductions.is_empty(), "a forgotten owner's reduction goes with it");
    }
}
