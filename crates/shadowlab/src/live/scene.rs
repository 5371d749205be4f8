//! The scene of a live engine: the [`Scene`] itself, stable ids for its instances and lights, and
//! the version counters that cached items record. Every change goes through [`LiveScene::apply`],
//! so nothing can change without its versions moving.

use shadowlab_core::{Aabb, Instance, Light, LightId, Mobility, Scene};

use super::edits::{Edit, EditError, EditKind, InstanceId, LightChange, check_transform};

/// Splits of a mesh into parts for [`LiveScene::instance_parts`]: at most 2³ boxes.
const MESH_PART_DEPTH: u32 = 3;

/// Per instance: its stable id, the version of its transform and its world bounds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InstanceState {
    pub id: InstanceId,
    /// Changes whenever the transform does (and is unique: a new instance never repeats one).
    pub version: u64,
    pub bounds: Aabb,
}

/// Per light: its stable id and the versions of its emitter (shape, placement, range: what shadows
/// depend on) and of its colour and intensity (what they do not).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LightState {
    pub id: LightId,
    pub emitter_version: u64,
    pub colour_version: u64,
}

/// What one applied edit did: its kind and what it concerned, with the instance's bounds before
/// and after (for the validity table's region tests).
#[derive(Debug, Clone, PartialEq)]
pub struct Applied {
    pub kind: EditKind,
    pub instance: Option<InstanceId>,
    pub light: Option<LightId>,
    pub bounds_before: Option<Aabb>,
    pub bounds_after: Option<Aabb>,
}

/// A scene that changes between frames.
#[derive(Debug, Clone)]
pub struct LiveScene {
    scene: Scene,
    instances: Vec<InstanceState>,
    lights: Vec<LightState>,
    /// The last version handed out (versions are unique across the engine's life).
    counter: u64,
    next_instance: u32,
    next_light: u32,
    /// Bumped by every applied edit.
    epoch: u64,
    /// Bumped by every edit of an instance (what the surface of the next frame may show).
    instances_epoch: u64,
    /// Bumped by every edit of an instance but a temporary one's move: a visibility layer
    /// resolved at the same value differs from a fresh one only in dragged objects' footprints.
    permanent_epoch: u64,
    /// Bounds of every instance but temporary ones: what light views are fitted to.
    fit_bounds: Aabb,
    fit_caster_bounds: Aabb,
    /// Per mesh, boxes around its parts in its own space ([`Mesh::part_bounds`]; meshes never
    /// change after the scene is taken over).
    mesh_parts: Vec<Vec<Aabb>>,
    /// The last pick-ups (an instance made temporary) and releases (made permanent again): the
    /// permanent epoch each one brought, whether it was a pick-up, and the instance's bounds in
    /// the permanent scene (where it was picked up, where it was released;
    /// [`LiveScene::picked_up_since`], [`LiveScene::released_since`]).
    switches: Vec<(u64, bool, InstanceId, Aabb)>,
}

/// Pick-ups and releases [`LiveScene`] remembers (a light waits at most a frame per light for its turn).
const SWITCHES_KEPT: usize = 64;

impl LiveScene {
    /// Takes the scene over; instance and light ids start as their indices.
    pub fn new(scene: Scene) -> Self {
        let mut counter = 0;
        let mut next = || {
            counter += 1;
            counter
        };
        let mesh_bounds: Vec<Aabb> = scene.meshes.iter().map(|m| m.bounds()).collect();
        let mesh_parts: Vec<Vec<Aabb>> = scene.meshes.iter().map(|m| m.part_bounds(MESH_PART_DEPTH)).collect();
        let instances = scene
            .instances
            .iter()
            .enumerate()
            .map(|(i, inst)| InstanceState {
                id: InstanceId(i as u32),
                version: next(),
                bounds: mesh_bounds.get(inst.mesh.index()).map_or(Aabb::EMPTY, |b| b.transformed(&inst.transform)),
            })
            .collect();
        let lights = (0..scene.lights.len())
            .map(|i| LightState { id: LightId(i as u32), emitter_version: next(), colour_version: next() })
            .collect();
        let (next_instance, next_light) = (scene.instances.len() as u32, scene.lights.len() as u32);
        let mut live = Self {
            scene,
            instances,
            lights,
            counter,
            next_instance,
            next_light,
            epoch: 0,
            instances_epoch: 0,
            permanent_epoch: 0,
            fit_bounds: Aabb::EMPTY,
            fit_caster_bounds: Aabb::EMPTY,
            mesh_parts,
            switches: Vec::new(),
        };
        live.refit();
        live
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Changes with every applied edit: items checked at this epoch need no new check.
    pub fn epoch(&self) -> u64 {
        self.epoch
    }

    /// Changes with every edit of an instance (moved, added, removed, mobility): the surface a camera
    /// sees may have changed.
    pub fn instances_epoch(&self) -> u64 {
        self.instances_epoch
    }

    /// Changes with every instance edit but a temporary (dragged) instance's move.
    pub fn permanent_epoch(&self) -> u64 {
        self.permanent_epoch
    }

    /// When every edit of the permanent scene since permanent epoch `epoch` was a pick-up (an
    /// instance made temporary): the bounds the picked-up instances had then (none: nothing
    /// changed). A visibility layer resolved at `epoch` differs from one of the permanent
    /// instances now only where those bounds were seen or shadowed. `None` when anything else
    /// changed, or too long ago to tell.
    pub fn picked_up_since(&self, epoch: u64) -> Option<Vec<Aabb>> {
        self.switched_since(epoch, true).map(|s| s.into_iter().map(|(_, b)| b).collect())
    }

    /// When every edit of the permanent scene since permanent epoch `epoch` was a release (a
    /// temporary instance made permanent): the released instances and their bounds (none: nothing
    /// changed). A visibility layer resolved at `epoch` differs from one of the permanent
    /// instances now only where those bounds are seen or shadowed. `None` otherwise, as
    /// [`LiveScene::picked_up_since`].
    pub fn released_since(&self, epoch: u64) -> Option<Vec<(InstanceId, Aabb)>> {
        self.switched_since(epoch, false)
    }

    fn switched_since(&self, epoch: u64, pick_up: bool) -> Option<Vec<(InstanceId, Aabb)>> {
        let edits = self.permanent_epoch.checked_sub(epoch)?;
        let since: Vec<(InstanceId, Aabb)> =
            self.switches.iter().filter(|s| s.0 > epoch && s.1 == pick_up).map(|s| (s.2, s.3)).collect();
        (since.len() as u64 == edits).then_some(since)
    }

    /// Whether some dynamic instance casts shadows (map views may then need composite copies).
    pub fn has_dynamic_casters(&self) -> bool {
        self.scene.instances.iter().any(|i| i.mobility == Mobility::Dynamic && i.casts_shadows)
    }

    /// The temporary (dragged) instances, in scene order: their states (id, version, bounds).
    pub fn temporary_states(&self) -> Vec<InstanceState> {
        self.scene
            .instances
            .iter()
            .zip(&self.instances)
            .filter(|(i, _)| i.mobility == Mobility::Temporary)
            .map(|(_, s)| *s)
            .collect()
    }

    pub fn instances(&self) -> &[InstanceState] {
        &self.instances
    }

    pub fn lights(&self) -> &[LightState] {
        &self.lights
    }

    /// Index in `scene().instances` of an instance id.
    pub fn instance_index(&self, id: InstanceId) -> Option<usize> {
        self.instances.iter().position(|s| s.id == id)
    }

    /// The id of the first instance named `name`.
    pub fn find_instance(&self, name: &str) -> Option<InstanceId> {
        self.scene.instances.iter().position(|i| i.name == name).map(|i| self.instances[i].id)
    }

    pub fn instance(&self, id: InstanceId) -> Option<&Instance> {
        self.instance_index(id).map(|i| &self.scene.instances[i])
    }

    /// Index in `scene().lights` of a light id.
    pub fn light_index(&self, id: LightId) -> Option<usize> {
        self.lights.iter().position(|s| s.id == id)
    }

    pub fn light(&self, id: LightId) -> Option<&Light> {
        self.light_index(id).map(|i| &self.scene.lights[i])
    }

    pub fn light_state(&self, id: LightId) -> Option<&LightState> {
        self.lights.iter().find(|s| s.id == id)
    }

    /// The id of the first light named `name`, or the light at that decimal index.
    pub fn find_light(&self, name_or_index: &str) -> Option<LightId> {
        self.scene.find_light(name_or_index).map(|l| self.lights[l.index()].id)
    }

    /// Bounds of every instance but temporary ones: light views are fitted to them, so that dragging
    /// an object never refits a light.
    pub fn fit_bounds(&self) -> Aabb {
        self.fit_bounds
    }

    /// World boxes around the parts of the `index`-th instance (in the scene's order): together
    /// they hold all its triangles, and they are often much smaller than its bounds (three walls in
    /// one mesh get three slabs, not the room).
    pub fn instance_parts(&self, index: usize) -> impl Iterator<Item = Aabb> + '_ {
        self.scene.instances.get(index).into_iter().flat_map(move |inst| {
            let parts = self.mesh_parts.get(inst.mesh.index()).map_or(&[][..], Vec::as_slice);
            parts.iter().map(move |b| b.transformed(&inst.transform))
        })
    }

    /// [`LiveScene::fit_bounds`] of the shadow casters.
    pub fn fit_caster_bounds(&self) -> Aabb {
        self.fit_caster_bounds
    }

    fn version(&mut self) -> u64 {
        self.counter += 1;
        self.counter
    }

    fn refit(&mut self) {
        let (mut all, mut casters) = (Aabb::EMPTY, Aabb::EMPTY);
        for (inst, s) in self.scene.instances.iter().zip(&self.instances) {
            if inst.mobility == Mobility::Temporary {
                continue;
            }
            all = all.union(&s.bounds);
            if inst.casts_shadows {
                casters = casters.union(&s.bounds);
            }
        }
        self.fit_bounds = all;
        self.fit_caster_bounds = casters;
    }

    /// Refuses bounds that would make the scene's extent infinite, as a scene file's may not be
    /// (`Scene::validate`): with the other instances (all but `skip`), the box's diagonal must
    /// be finite. A move to 3e38 m passed the transform's own check and then overflowed the
    /// truth's BVH build.
    fn check_extent(&self, skip: Option<usize>, bounds: &Aabb) -> Result<(), String> {
        let others = self.instances.iter().enumerate().filter(|(k, _)| Some(*k) != skip);
        let all = others.fold(*bounds, |all, (_, s)| all.union(&s.bounds));
        if !bounds.is_empty() && !all.diagonal().is_finite() {
            let reach = bounds.min.abs().max(bounds.max.abs()).max_element();
            return Err(format!("the scene's extent would become infinite (the instance would reach {reach:.3e} m)"));
        }
        Ok(())
    }

    fn bounds_of(&self, inst: &Instance) -> Aabb {
        self.scene.meshes.get(inst.mesh.index()).map_or(Aabb::EMPTY, |m| m.bounds().transformed(&inst.transform))
    }

    /// Checks `edit` completely, then applies it. On error nothing has changed.
    pub fn apply(&mut self, edit: Edit) -> Result<Applied, EditError> {
        let applied = self.apply_checked(edit)?;
        self.epoch += 1;
        if applied.instance.is_some() {
            self.instances_epoch += 1;
            if applied.kind != EditKind::MoveInstance(Mobility::Temporary) {
                self.permanent_epoch += 1;
                // A pick-up, where the instance was; a release, where it is.
                let switch = match (applied.kind, applied.instance) {
                    (EditKind::ChangeMobility { from, to: Mobility::Temporary }, Some(id))
                        if from != Mobility::Temporary =>
                    {
                        applied.bounds_before.map(|b| (true, id, b))
                    }
                    (EditKind::ChangeMobility { from: Mobility::Temporary, to }, Some(id))
                        if to != Mobility::Temporary =>
                    {
                        self.instance_index(id).map(|i| (false, id, self.instances[i].bounds))
                    }
                    _ => None,
                };
                if let Some((pick_up, id, b)) = switch {
                    if self.switches.len() == SWITCHES_KEPT {
                        self.switches.remove(0);
                    }
                    self.switches.push((self.permanent_epoch, pick_up, id, b));
                }
            }
        }
        self.refit();
        Ok(applied)
    }

    fn apply_checked(&mut self, edit: Edit) -> Result<Applied, EditError> {
        let instance_at = |live: &Self, id: InstanceId| live.instance_index(id).ok_or(EditError::UnknownInstance(id));
        let light_at = |live: &Self, id: LightId| live.light_index(id).ok_or(EditError::UnknownLight(id));
        match edit {
            Edit::Transform { instance, transform } => {
                let i = instance_at(self, instance)?;
                let inst = &self.scene.instances[i];
                check_transform(&transform)
                    .map_err(|message| EditError::BadInstance { name: inst.name.clone(), message })?;
                let mobility = inst.mobility;
                let before = self.instances[i].bounds;
                let after = self.bounds_of(&Instance { transform, ..inst.clone() });
                self.check_extent(Some(i), &after)
                    .map_err(|message| EditError::BadInstance { name: inst.name.clone(), message })?;
                self.scene.instances[i].transform = transform;
                let version = self.version();
                self.instances[i].version = version;
                self.instances[i].bounds = after;
                Ok(Applied {
                    kind: EditKind::MoveInstance(mobility),
                    instance: Some(instance),
                    light: None,
                    bounds_before: Some(before),
                    bounds_after: Some(after),
                })
            }
            Edit::AddInstance(inst) => {
                let bad = |message: String| EditError::BadInstance { name: inst.name.clone(), message };
                if inst.mesh.index() >= self.scene.meshes.len() {
                    return Err(bad(format!("mesh index {} out of range", inst.mesh.0)));
                }
                if inst.material.index() >= self.scene.materials.len() {
                    return Err(bad(format!("material index {} out of range", inst.material.0)));
                }
                check_transform(&inst.transform).map_err(bad)?;
                let bounds = self.bounds_of(&inst);
                self.check_extent(None, &bounds).map_err(bad)?;
                let id = InstanceId(self.next_instance);
                self.next_instance += 1;
                let version = self.version();
                let mobility = inst.mobility;
                self.scene.instances.push(*inst);
                self.instances.push(InstanceState { id, version, bounds });
                Ok(Applied {
                    kind: EditKind::AddInstance(mobility),
                    instance: Some(id),
                    light: None,
                    bounds_before: None,
                    bounds_after: Some(bounds),
                })
            }
            Edit::RemoveInstance(instance) => {
                let i = instance_at(self, instance)?;
                if self.scene.instances.len() == 1 {
                    return Err(EditError::LastInstance(self.scene.instances[i].name.clone()));
                }
                let inst = self.scene.instances.remove(i);
                let state = self.instances.remove(i);
                Ok(Applied {
                    kind: EditKind::RemoveInstance(inst.mobility),
                    instance: Some(instance),
                    light: None,
                    bounds_before: Some(state.bounds),
                    bounds_after: None,
                })
            }
            Edit::Mobility { instance, mobility } => {
                let i = instance_at(self, instance)?;
                let from = self.scene.instances[i].mobility;
                self.scene.instances[i].mobility = mobility;
                let b = self.instances[i].bounds;
                Ok(Applied {
                    kind: EditKind::ChangeMobility { from, to: mobility },
                    instance: Some(instance),
                    light: None,
                    bounds_before: Some(b),
                    bounds_after: Some(b),
                })
            }
            Edit::Light { light, change } => {
                let i = light_at(self, light)?;
                let colour_only = change.is_colour_only();
                let updated = changed_light(&self.scene.lights[i], change)?;
                self.scene.lights[i] = updated;
                let version = self.version();
                if colour_only {
                    self.lights[i].colour_version = version;
                } else {
                    self.lights[i].emitter_version = version;
                    self.lights[i].colour_version = version;
                }
                let kind = if colour_only { EditKind::LightColour } else { EditKind::LightEmitter };
                Ok(Applied { kind, instance: None, light: Some(light), bounds_before: None, bounds_after: None })
            }
            Edit::AddLight(light) => {
                light.check().map_err(|message| EditError::BadLight { name: light.name.clone(), message })?;
                let id = LightId(self.next_light);
                self.next_light += 1;
                let (emitter_version, colour_version) = (self.version(), self.version());
                self.scene.lights.push(*light);
                self.lights.push(LightState { id, emitter_version, colour_version });
                Ok(Applied {
                    kind: EditKind::AddLight,
                    instance: None,
                    light: Some(id),
                    bounds_before: None,
                    bounds_after: None,
                })
            }
            Edit::RemoveLight(light) => {
                let i = light_at(self, light)?;
                self.scene.lights.remove(i);
                self.lights.remove(i);
                Ok(Applied {
                    kind: EditKind::RemoveLight,
                    instance: None,
                    light: Some(light),
                    bounds_before: None,
                    bounds_after: None,
                })
            }
        }
    }
}

/// `light` with `change` applied, checked as a whole (`Light::check`).
fn changed_light(light: &Light, change: LightChange) -> Result<Light, EditError> {
    use shadowlab_core::LightKind as K;
    let bad = |message: String| EditError::BadLight { name: light.name.clone(), message };
    let mut l = light.clone();
    match change {
        LightChange::Color(c) => l.color = c,
        LightChange::Intensity(v) => l.intensity = v,
        LightChange::Position(p) => match &mut l.kind {
            K::Point { position, .. } | K::Spot { position, .. } | K::Rect { position, .. } => *position = p,
            K::Directional { .. } => return Err(bad("a directional light has no position".into())),
        },
        LightChange::Direction(d) => {
            let d = d.normalize_or_zero();
            if d == glam::Vec3::ZERO {
                return Err(bad("the direction must be a non-zero finite vector".into()));
            }
            match &mut l.kind {
                K::Spot { direction, .. } | K::Directional { direction, .. } => *direction = d,
                K::Rect { direction, tangent, .. } => {
                    // Keep the tangent perpendicular to the new normal, as close to the old one as can be.
                    let t = (*tangent - d * tangent.dot(d)).normalize_or(d.any_orthonormal_vector());
                    *direction = d;
                    *tangent = t;
                }
                K::Point { .. } => return Err(bad("a point light has no direction".into())),
            }
        }
        LightChange::Radius(r) => match &mut l.kind {
            K::Point { radius, .. } | K::Spot { radius, .. } => *radius = r,
            K::Directional { angular_radius, .. } => *angular_radius = r,
            K::Rect { width, height, .. } => {
                *width = r;
                *height = r;
            }
        },
        LightChange::Size(w, h) => match &mut l.kind {
            K::Rect { width, height, .. } => {
                *width = w;
                *height = h;
            }
            _ => return Err(bad("only a rect light has a width and height (use a radius)".into())),
        },
        LightChange::Range(r) => l.range = r,
        LightChange::Replace(new) => l = new,
    }
    if matches!(l.kind, K::Rect { width, height, .. } if !(width > 0.0 && height > 0.0)) {
        return Err(bad("a rect light's width and height must be > 0".into()));
    }
    l.check().map_err(bad)?;
    Ok(l)
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};
    use shadowlab_core::{LightKind, load_scene};

    use super::*;

    fn room() -> LiveScene {
        LiveScene::new(load_scene("room").unwrap().scene)
    }

    #[test]
    fn bad_edits_are_errors_and_change_nothing() {
        let mut live = room();
        let before = (live.scene().clone(), live.instances().to_vec(), live.lights().to_vec(), live.epoch());
        let chair = live.find_instance(&live.scene().instances[3].name.clone()).unwrap();
        let lamp = LightId(0);
        let nan = Affine3A::from_translation(Vec3::new(f32::NAN, 0.0, 0.0));
        let flat = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
        let bad: Vec<Edit> = vec![
            Edit::Transform { instance: InstanceId(9999), transform: Affine3A::IDENTITY },
            Edit::Transform { instance: chair, transform: nan },
            Edit::Transform { instance: chair, transform: flat },
            Edit::RemoveInstance(InstanceId(9999)),
            Edit::Mobility { instance: InstanceId(9999), mobility: Mobility::Dynamic },
            Edit::Light { light: LightId(99), change: LightChange::Intensity(1.0) },
            Edit::Light { light: lamp, change: LightChange::Intensity(f32::NAN) },
            Edit::Light { light: lamp, change: LightChange::Intensity(-1.0) },
            Edit::Light { light: lamp, change: LightChange::Radius(-0.1) },
            Edit::Light { light: lamp, change: LightChange::Color(Vec3::new(1.0, f32::INFINITY, 0.0)) },
            Edit::Light { light: lamp, change: LightChange::Position(Vec3::NAN) },
            Edit::Light { light: lamp, change: LightChange::Direction(Vec3::ZERO) },
            Edit::Light { light: lamp, change: LightChange::Size(1.0, 1.0) },
            Edit::Light { light: lamp, change: LightChange::Range(Some(0.0)) },
            Edit::AddLight(Box::new(Light::new(
                "bad",
                LightKind::Point { position: Vec3::ZERO, radius: -1.0 },
                Vec3::ONE,
                1.0,
            ))),
            Edit::RemoveLight(LightId(77)),
            Edit::AddInstance(Box::new(Instance::new(
                "ghost",
                shadowlab_core::MeshId(9999),
                shadowlab_core::MaterialId(0),
                Affine3A::IDENTITY,
            ))),
        ];
        for e in bad {
            let err = live.apply(e.clone());
            assert!(err.is_err(), "{e:?} was accepted");
            let after = (live.scene().clone(), live.instances().to_vec(), live.lights().to_vec(), live.epoch());
            assert!(after == before, "{e:?} changed the scene");
        }
    }

    #[test]
    fn ids_stay_stable_and_versions_move_only_with_what_changed() {
        let mut live = room();
        let first = live.instances()[0].id;
        let last = live.instances().last().unwrap().id;
        let v_last = live.instances().last().unwrap().version;
        live.apply(Edit::RemoveInstance(first)).unwrap();
        assert_eq!(live.instance_index(first), None);
        assert_eq!(live.instances().last().unwrap().id, last, "other ids survive a removal");
        assert_eq!(live.instances().last().unwrap().version, v_last);
        let moved = live.apply(Edit::Transform { instance: last, transform: Affine3A::from_translation(Vec3::X) });
        assert!(live.instances().last().unwrap().version > v_last, "{moved:?}");
        let e0 = live.lights()[0];
        live.apply(Edit::Light { light: e0.id, change: LightChange::Color(Vec3::new(1.0, 0.0, 0.0)) }).unwrap();
        assert_eq!(live.lights()[0].emitter_version, e0.emitter_version, "colour is not the emitter");
        assert!(live.lights()[0].colour_version > e0.colour_version);
        let added = live.apply(Edit::AddLight(Box::new(live.scene().lights[0].clone()))).unwrap();
        let new = added.light.unwrap();
        assert!(new.0 as usize >= live.lights().len() - 1 && live.light(new).is_some());
        live.apply(Edit::RemoveLight(LightId(0))).unwrap();
        assert!(live.light(LightId(0)).is_none() && live.light(new).is_some(), "ids are not indices");
    }

    #[test]
    fn temporary_instances_do_not_move_the_fitted_bounds() {
        let mut live = room();
        let fit = live.fit_bounds();
        let chair = live.instances()[3].id;
        live.apply(Edit::Mobility { instance: chair, mobility: Mobility::Temporary }).unwrap();
        live.apply(Edit::Transform { instance: chair, transform: Affine3A::from_translation(Vec3::splat(50.0)) })
            .unwrap();
        assert!(live.fit_bounds().max.x <= fit.max.x, "a dragged chair does not refit the lights");
        live.apply(Edit::Mobility { instance: chair, mobility: Mobility::Static }).unwrap();
        assert!(live.fit_bounds().max.x >= 50.0, "released, it counts again");
    }

    /// Pick-ups (releases) since an epoch are told with the bounds they had (have); any other edit of the permanent
    /// scene (a release, a move, a mobility set again) makes it unknown.
    #[test]
    fn pick_ups_and_releases_since_an_epoch_are_told_and_nothing_else_is() {
        let mut live = room();
        let (chair, table) = (live.instances()[3].id, live.instances()[5].id);
        let start = live.permanent_epoch();
        assert_eq!(live.picked_up_since(start), Some(Vec::new()), "nothing changed");
        let at = live.instance(chair).unwrap().transform;
        let bounds = live.instances().iter().find(|s| s.id == chair).unwrap().bounds;
        live.apply(Edit::Mobility { instance: chair, mobility: Mobility::Temporary }).unwrap();
        // Dragging moves nothing permanent.
        let moved = Affine3A::from_translation(Vec3::X) * at;
        live.apply(Edit::Transform { instance: chair, transform: moved }).unwrap();
        assert_eq!(live.picked_up_since(start), Some(vec![bounds]), "the chair where it was picked up");
        let after = live.permanent_epoch();
        live.apply(Edit::Mobility { instance: table, mobility: Mobility::Temporary }).unwrap();
        assert_eq!(live.picked_up_since(start).map(|b| b.len()), Some(2));
        assert_eq!(live.picked_up_since(after).map(|b| b.len()), Some(1));
        // Set temporary again: not a pick-up, and it ends what can be told.
        live.apply(Edit::Mobility { instance: table, mobility: Mobility::Temporary }).unwrap();
        assert_eq!(live.picked_up_since(start), None);
        let now = live.permanent_epoch();
        live.apply(Edit::Mobility { instance: chair, mobility: Mobility::Static }).unwrap();
        assert_eq!(live.picked_up_since(now), None, "a release");
        assert_eq!(live.picked_up_since(live.permanent_epoch() + 1), None, "an epoch not reached");
        // The release is told where the chair is now, and only as a release.
        let landed = live.instances().iter().find(|s| s.id == chair).unwrap().bounds;
        assert_ne!(landed, bounds);
        assert_eq!(live.released_since(now), Some(vec![(chair, landed)]), "the chair where it was released");
        assert_eq!(live.released_since(start), None, "pick-ups since");
        let later = live.permanent_epoch();
        live.apply(Edit::Mobility { instance: table, mobility: Mobility::Static }).unwrap();
        assert_eq!(live.released_since(now).map(|b| b.len()), Some(2));
        assert_eq!(live.released_since(later).map(|b| b.len()), Some(1));
        live.apply(Edit::Transform { instance: table, transform: Affine3A::IDENTITY }).unwrap();
        assert_eq!(live.released_since(now), None, "a move");
    }
}
