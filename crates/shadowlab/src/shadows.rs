//! [`Shadows`]: the part of shadowlab an application embeds. It owns the scene (through the live
//! engine's [`LiveScene`]), uploads it once, shadows each light with its technique into a visibility
//! layer per light, and keeps what it can across frames in one [`ShadowCache`].
//!
//! State and lifecycle: the scene changes only through [`Shadows::apply`] (typed edits, checked
//! before anything changes), the output size only through [`Shadows::resize`]; each
//! [`Shadows::record`] brings the GPU copy of the instances up to date, rewrites the uniforms of
//! lights whose colour or emitter changed, and lets every technique re-render only the items whose
//! signatures changed (DESIGN.md §11).

use std::collections::{HashMap, HashSet};
use std::hash::{Hash, Hasher};

use shadowlab_core::{LightId, Scene};

use crate::auto::Preference;
use crate::context::{RegionUniform, Shared};
use crate::frame::{CameraUniform, Footprint, LightUniform, SurfaceInputs, VisibilityLayer};
use crate::gpu::Gpu;
use crate::gpu_scene::GpuScene;
use crate::live::cache::MAP_TEXEL_BYTES;
use crate::live::scheduler::{Adaptation, Budget, CostModel, Step, UnitCounts, screen_share};
use crate::live::temporary::{PermanentSurface, TemporaryShadows, map_size, pick_up_footprint};
use crate::live::validity::screen_signature;
use crate::live::{Applied, Edit, EditError, EditKind, InstanceState, LiveScene, ShadowCache, Signature, Work};
use crate::registry::TechniqueSpec;
use crate::technique::{FrameContext, ResolveRegion, ShadowTechnique, TechniqueError, TechniqueStats};
use crate::timing::GpuTimer;
use crate::util;

/// The share of the target frame time kept free of fills (Toromanoff's alg. 15 leaves the margin
/// open): a tenth, against the prediction's errors.
const BUDGET_MARGIN: f64 = 0.1;

/// The default shadow-map memory budget (`Shadows::set_map_budget`): 1 GiB, a fraction of
/// any desktop GPU's memory and of what WebGPU devices commonly give.
pub const DEFAULT_MAP_BUDGET: u64 = 1 << 30;

/// The map-memory budget's shares (bytes) by (light, rung), with the key of the demands they
/// were planned for.
type MapPlan = (u64, HashMap<(LightId, usize), u64>);

/// One rung of a light's quality ladder: a technique with its own caches.
pub(crate) struct Rung {
    pub spec: TechniqueSpec,
    pub technique: Box<dyn ShadowTechnique>,
    /// The technique's owner id in the cache.
    owner: u32,
}

/// One light's shadowing: its ladder of techniques and its visibility layer.
pub(crate) struct LightShadow {
    pub light: LightId,
    /// From the cheapest to the best; with one rung, the light's technique.
    pub rungs: Vec<Rung>,
    /// The rung shown in the last frame (`None`: unshadowed).
    pub shown: Option<usize>,
    pub layer: VisibilityLayer,
    pub light_buffer: wgpu::Buffer,
    /// The light's colour version its uniform was written from (emitter edits bump it too).
    uniform_version: u64,
    /// What the layer was last resolved from: with it unchanged and nothing re-rendered, the layer
    /// still holds (a still frame costs no lookup), and with only dragged objects moved, all of it
    /// but their footprints.
    resolved: Option<Resolved>,
    /// The region uniform of this light's resolves limited to a footprint.
    region_buffer: wgpu::Buffer,
    /// What the light shows while its technique has nothing complete: no shadow.
    unshadowed: Box<dyn ShadowTechnique>,
    /// The quality level shown in the last frame: 0 no shadow, 1 the technique's base, higher its
    /// upgrades (see [`ShadowTechnique::progress`]); and the emitter samples behind it.
    level: u32,
    samples: u32,
    /// While a drag that began or ended under a frame-time target has not reached this light:
    /// the permanent epoch it waits under (it keeps the layer it showed before; a later edit ends
    /// the wait).
    held: Option<u64>,
    /// A pick-up's turn taken in two frames: the light's layer over the permanent surface was
    /// resolved (into its raw layer) under this state, and the light waits one more frame to
    /// join the dragged objects' pass.
    staged: Option<Staged>,
}

/// What a light's raw layer was resolved from in the first frame of a staged turn.
#[derive(Debug, Clone)]
struct Staged {
    key: (Signature, usize, Option<u64>),
    camera: CameraUniform,
    raw: u64,
}

/// What a light's layer was resolved from.
#[derive(Debug, Clone)]
struct Resolved {
    /// [`screen_signature`] (the light, the surface, every instance edit but dragged objects'
    /// moves), the rung shown and its [`ShadowTechnique::shown_version`].
    key: (Signature, usize, Option<u64>),
    /// The dragged objects then (ids, versions, bounds).
    temporaries: Vec<InstanceState>,
    /// Whether some of them cast (then the technique wrote the light's layer before dragging
    /// and the temporary pass multiplied their shadows in).
    casting: bool,
    /// The camera it was seen from.
    camera: CameraUniform,
    /// While they cast: the generation of the layers the technique wrote into
    /// ([`TemporaryShadows::begin`]); 0 otherwise.
    raw: u64,
}

/// What of a light's layer must be resolved again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Redo {
    Nothing,
    Region([u32; 4]),
    Whole,
}

/// The pixels dragged objects covered (`before`) or cover (`now`): the footprints of the objects
/// that moved; any object picked up or released: every pixel.
fn moved_footprint(camera: &CameraUniform, before: &[InstanceState], now: &[InstanceState]) -> Footprint {
    if before.len() != now.len() || before.iter().zip(now).any(|(a, b)| a.id != b.id) {
        return Footprint::Whole;
    }
    before
        .iter()
        .zip(now)
        .filter(|(a, b)| a.version != b.version)
        .fold(Footprint::Nothing, |f, (a, b)| f.union(camera.footprint(&a.bounds)).union(camera.footprint(&b.bounds)))
}

impl LightShadow {
    /// The light's best rung (its technique, with one rung).
    pub fn top(&self) -> &Rung {
        self.rungs.last().expect("a ladder has a rung")
    }

    /// The technique shown in the last frame (the best rung before the first frame).
    pub fn shown_technique(&self) -> &dyn ShadowTechnique {
        self.rungs[self.shown.unwrap_or(self.rungs.len() - 1)].technique.as_ref()
    }
}

/// Shadows for every light of a scene over one surface: what an application embeds.
pub struct Shadows {
    shared: Shared,
    live: LiveScene,
    gpu_scene: GpuScene,
    pub(crate) lights: Vec<LightShadow>,
    cache: ShadowCache,
    /// Predicted costs of units of work, from measured frames.
    costs: CostModel,
    /// The frame time the scheduler keeps to (`None`: every fill in the frame that needs it).
    target_ms: Option<f64>,
    /// Quality or speed: scales the target (issue 12: a run-time input beside it).
    preference: Preference,
    /// The units of work the last frame ran, by kind and size (what [`Shadows::observe`] shares
    /// the frame's measured time among).
    last_units: UnitCounts,
    /// Predicted render time of a frame without fills (ms): the part of the target work cannot use.
    render_ms: Option<f64>,
    /// Costs and render time are scripted: measurements leave them.
    scripted: bool,
    /// The rungs every light may use (frame-rate adaptation lowers it under a target).
    cap: usize,
    adaptation: Adaptation,
    frame_index: u64,
    /// Instances changed since the GPU copy was written.
    instances_dirty: bool,
    size: (u32, u32),
    /// Bytes the lights' shadow maps may take together (`None`: no limit).
    map_budget: Option<u64>,
    /// The shares of the budget by (light, rung), and the key of the demands they were made for.
    map_plan: Option<MapPlan>,
    /// What the lights' techniques shadow while objects are dragged (`None` otherwise).
    permanent: Option<PermanentSurface>,
    /// The dragged objects' shadows, every light's in one pass.
    temporary: TemporaryShadows,
    /// Whether the dragged objects' passes were run once over nothing
    /// ([`TemporaryShadows::rehearse`]).
    rehearsed: bool,
}

impl Shadows {
    /// Uploads the scene. No light is shadowed until [`Shadows::set_technique`].
    pub fn new(gpu: &Gpu, scene: Scene) -> Self {
        let shared = Shared::new(gpu);
        let gpu_scene = GpuScene::new(&gpu.device, &gpu.queue, &scene);
        let temporary = TemporaryShadows::new(&shared);
        TemporaryShadows::warm(&shared);
        Self {
            shared,
            live: LiveScene::new(scene),
            gpu_scene,
            lights: Vec::new(),
            cache: ShadowCache::default(),
            costs: CostModel::default(),
            target_ms: None,
            preference: Preference::Balanced,
            last_units: UnitCounts::new(),
            render_ms: None,
            scripted: false,
            cap: usize::MAX,
            adaptation: Adaptation::default(),
            frame_index: 0,
            instances_dirty: false,
            size: (0, 0),
            map_budget: Some(DEFAULT_MAP_BUDGET),
            map_plan: None,
            permanent: None,
            temporary,
            rehearsed: false,
        }
    }

    /// The scene as it is now (after every applied edit).
    pub fn scene(&self) -> &Scene {
        self.live.scene()
    }

    /// The scene with its stable ids and versions.
    pub fn live(&self) -> &LiveScene {
        &self.live
    }

    /// Hands over light meshes made for the scene as it is now (`shadowlab precompute`, read with
    /// `shadowlab_core::lightmesh::file::read`, which refuses other scenes): `lightmesh` takes them
    /// instead of building its own, until an edit touches them (the validity table). Returns how
    /// many were taken; meshes of lights not in the scene are left out.
    pub fn provide_light_meshes(&mut self, meshes: Vec<shadowlab_core::lightmesh::LightMesh>) -> usize {
        let mut taken = 0;
        for mesh in meshes {
            let Some(state) = self.live.lights().get(mesh.light as usize) else { continue };
            let light = &self.live.scene().lights[mesh.light as usize];
            let region = crate::live::validity::lightmesh_region(&self.live, light);
            let signature = crate::live::validity::lightmesh_signature(&self.live, state.id, &region);
            let id = state.id;
            self.cache.preloaded_light_meshes.retain(|(l, _, _)| *l != id);
            self.cache.preloaded_light_meshes.push((id, signature, std::sync::Arc::new(mesh)));
            taken += 1;
        }
        taken
    }

    /// The scene's GPU buffers (an application drawing its own G-buffer binds them).
    pub fn gpu_scene(&self) -> &GpuScene {
        &self.gpu_scene
    }

    pub fn shared(&self) -> &Shared {
        &self.shared
    }

    /// The lights with a technique, in id order.
    pub fn shadowed_lights(&self) -> impl Iterator<Item = LightId> + '_ {
        self.lights.iter().map(|s| s.light)
    }

    /// The visibility layer of a shadowed light.
    pub fn layer(&self, light: LightId) -> Option<&VisibilityLayer> {
        self.lights.iter().find(|s| s.light == light).map(|s| &s.layer)
    }

    /// The technique spec of a shadowed light, as given (its best rung's).
    pub fn spec(&self, light: LightId) -> Option<&TechniqueSpec> {
        self.lights.iter().find(|s| s.light == light).map(|s| &s.top().spec)
    }

    /// The specs of a light's quality ladder, from the cheapest to the best.
    pub fn ladder(&self, light: LightId) -> Vec<&TechniqueSpec> {
        self.lights.iter().filter(|s| s.light == light).flat_map(|s| s.rungs.iter().map(|r| &r.spec)).collect()
    }

    /// Shadows `light` with the technique of `spec` (replacing its previous one), writing a layer
    /// of `width × height`.
    pub fn set_technique(
        &mut self,
        light: LightId,
        spec: &TechniqueSpec,
        width: u32,
        height: u32,
    ) -> Result<(), TechniqueError> {
        self.set_ladder(light, std::slice::from_ref(spec), width, height)
    }

    /// Shadows `light` with a quality ladder (Toromanoff 2005 §VII.2: hard, then smoothies, then
    /// sampled): from the cheapest technique to the best. Every rung keeps its own caches; the
    /// light shows the best rung that is complete (and allowed by the frame-rate adaptation), so
    /// that with a target frame time a cheap shadow shows at once and better ones replace it as
    /// their fills finish.
    pub fn set_ladder(
        &mut self,
        light: LightId,
        specs: &[TechniqueSpec],
        width: u32,
        height: u32,
    ) -> Result<(), TechniqueError> {
        let l = self.live.light(light).ok_or_else(|| TechniqueError::Failed {
            id: specs.first().map_or("ladder", |s| s.info.id).to_owned(),
            message: format!("no light {}", light.0),
        })?;
        if specs.is_empty() {
            return Err(TechniqueError::Failed { id: "ladder".into(), message: "a ladder needs a technique".into() });
        }
        let mut rungs = Vec::with_capacity(specs.len());
        for spec in specs {
            let technique = spec.create(&self.shared, l)?;
            rungs.push((spec.clone(), technique));
        }
        let device = &self.shared.gpu.device;
        let light_buffer = util::branch_buffer(device, &l.name, bytemuck::bytes_of(&LightUniform::new(l)));
        let layer = VisibilityLayer::new(device, width, height, &format!("visibility {}", l.name));
        let uniform_version = self.live.light_state(light).map_or(0, |s| s.colour_version);
        let unshadowed = TechniqueSpec::parse("none", &[])
            .and_then(|none| none.create(&self.shared, l))
            .expect("`none` supports every light");
        // A new rung takes over the caches of the old rung at its place when they fit (a changed
        // parameter, `hard` → `pcf`): it keeps the old owner id, so the records still name its
        // memory, and the signatures decide what is re-rendered. The other old records are dropped.
        let mut old_rungs = match self.lights.iter().position(|s| s.light == light) {
            Some(k) => self.lights.remove(k).rungs,
            None => Vec::new(),
        };
        let mut kept = Vec::with_capacity(rungs.len());
        for (i, (_, technique)) in rungs.iter_mut().enumerate() {
            let handed = old_rungs.get_mut(i).and_then(|old| Some((old.owner, old.technique.hand_over()?)));
            kept.push(handed.and_then(|(owner, h)| technique.take_over(&self.shared, h).ok().map(|()| owner)));
        }
        for old in &old_rungs {
            if !kept.contains(&Some(old.owner)) {
                self.cache.forget_owner(old.owner);
            }
        }
        let rungs = rungs
            .into_iter()
            .zip(kept)
            .map(|((spec, technique), owner)| Rung {
                spec,
                technique,
                owner: owner.unwrap_or_else(|| self.cache.new_owner()),
            })
            .collect();
        self.lights.push(LightShadow {
            light,
            rungs,
            shown: None,
            layer,
            light_buffer,
            uniform_version,
            resolved: None,
            region_buffer: util::uniform_buffer(
                &self.shared.gpu.device,
                "resolve region",
                bytemuck::bytes_of(&RegionUniform::whole()),
            ),
            unshadowed,
            held: None,
            staged: None,
            level: 0,
            samples: 0,
        });
        self.lights.sort_by_key(|s| s.light);
        self.size = (width, height);
        Ok(())
    }

    /// Applies a scene edit between frames. A bad edit is an error and changes nothing.
    pub fn apply(&mut self, edit: Edit) -> Result<Applied, EditError> {
        let applied = self.live.apply(edit)?;
        match applied.kind {
            EditKind::RemoveLight => {
                if let Some(light) = applied.light {
                    self.lights.retain(|s| s.light != light);
                    self.cache.forget_light(light);
                }
            }
            EditKind::LightColour | EditKind::LightEmitter | EditKind::AddLight => {}
            _ => self.instances_dirty = true,
        }
        Ok(applied)
    }

    /// Resizes every visibility layer (the techniques adapt their screen-sized buffers).
    pub fn resize(&mut self, width: u32, height: u32) -> Result<(), EditError> {
        let max = self.shared.gpu.device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(EditError::BadSize { width, height, message: format!("each side must be in 1..={max}") });
        }
        let device = &self.shared.gpu.device;
        for s in &mut self.lights {
            let name = self.live.light(s.light).map_or("light", |l| l.name.as_str());
            s.layer = VisibilityLayer::new(device, width, height, &format!("visibility {name}"));
            s.resolved = None;
        }
        self.size = (width, height);
        Ok(())
    }

    /// Spreads cache fills over frames so that a frame keeps to `target_ms` (Toromanoff alg. 13–15):
    /// each frame's fills get the target minus the predicted render time minus a margin, and a light
    /// shows its last complete state until its new one is complete (unshadowed until the first).
    /// `None` (the default) fills everything in the frame that needs it.
    pub fn set_target_ms(&mut self, target_ms: Option<f64>) {
        self.target_ms = target_ms.filter(|t| t.is_finite() && *t > 0.0);
    }

    /// The target as set (before the preference).
    pub fn target_ms(&self) -> Option<f64> {
        self.target_ms
    }

    /// Quality or speed, at run time: the frame time kept to is the target × 2 (`Quality`: slower
    /// frames, fills and upgrades sooner), × 1 (`Balanced`, the default) or × ½ (`Speed`).
    pub fn set_preference(&mut self, preference: Preference) {
        self.preference = preference;
    }

    pub fn preference(&self) -> Preference {
        self.preference
    }

    /// The frame time kept to: the target scaled by the preference.
    pub fn frame_target_ms(&self) -> Option<f64> {
        self.target_ms.map(|t| t * self.preference.budget_factor())
    }

    /// Takes in a rendered frame's GPU times and work (what [`Shadows::record`] returned): the
    /// cost model behind the budget learns from them. `fill_ms` is the time of the fills (the
    /// shadow passes), `render_ms` that of the rest of the frame.
    pub fn observe(&mut self, work: &Work, fill_ms: f64, render_ms: f64) {
        // The units behind `work`, by kind and size, as the last `record` counted them.
        if work.rebuilt_anything() && !self.last_units.is_empty() {
            self.costs.observe_frame(&self.last_units, fill_ms);
        }
        if render_ms.is_finite() && render_ms >= 0.0 && !self.scripted {
            let r = self.render_ms.get_or_insert(render_ms);
            *r += 0.25 * (render_ms - *r);
        }
        // Frame-rate adaptation (alg. 15): with a target, the rungs every light may use follow the
        // measured frame time, with hysteresis.
        let frame = if fill_ms.is_finite() { fill_ms + render_ms } else { render_ms };
        let most = self.lights.iter().map(|s| s.rungs.len()).max().unwrap_or(1);
        if let Some(target) = self.frame_target_ms()
            && most > 1
            && frame.is_finite()
        {
            let cap = self.cap.min(most);
            self.cap = match self.adaptation.step(frame, target) {
                Step::Down => cap.saturating_sub(1).max(1),
                Step::Up => (cap + 1).min(most),
                Step::Stay => cap,
            };
        }
    }

    /// The rungs every light may use now (frame-rate adaptation lowers it under a target).
    pub fn quality_cap(&self) -> usize {
        self.cap
    }

    /// [`Shadows::observe`] for measurements the engine took itself (the renderer's timestamps):
    /// ignored under a scripted clock, where only explicit observations count.
    pub fn observe_measured(&mut self, work: &Work, fill_ms: f64, render_ms: f64) {
        if !self.scripted {
            self.observe(work, fill_ms, render_ms);
        }
    }

    /// The costs the scheduler predicts with.
    pub fn costs(&self) -> &CostModel {
        &self.costs
    }

    /// Replaces the cost model and the predicted render time: a scripted clock, under which the
    /// renderer's own measurements change neither costs nor levels (only explicit
    /// [`Shadows::observe`] calls do).
    pub fn script_costs(&mut self, costs: CostModel, render_ms: f64) {
        self.costs = costs;
        self.render_ms = Some(render_ms);
        self.scripted = true;
    }

    /// Each shadowed light's level in the last frame: 0 unshadowed (nothing complete yet), 1 its
    /// technique's base, higher its upgrades; whether that shows the current state; and the emitter
    /// samples behind it (0 where that means nothing).
    pub fn levels(&self) -> Vec<(LightId, u32, bool, u32)> {
        self.lights
            .iter()
            .map(|s| {
                let top = s.shown == Some(s.rungs.len() - 1);
                (s.light, s.level, top && s.held.is_none() && s.shown_technique().current(), s.samples)
            })
            .collect()
    }

    /// Keeps shadow items across frames (the default), or rebuilds every item every frame.
    pub fn set_caching(&mut self, on: bool) {
        self.cache.set_enabled(on);
    }

    pub fn caching(&self) -> bool {
        self.cache.enabled()
    }

    /// The cache's records (items kept).
    pub fn cached_items(&self) -> usize {
        self.cache.len()
    }

    /// Forgets every cached item, as if the GPU memory had been lost: the next frame rebuilds all.
    pub fn invalidate_all(&mut self) {
        self.cache.clear();
    }

    /// A new engine on the same state (scene, lights' techniques, output size) that caches
    /// nothing: what the live engine is checked against. Its light ids are the lights' indices.
    pub fn fresh(&self) -> Result<Shadows, TechniqueError> {
        let mut fresh = Shadows::new(&self.shared.gpu, self.scene().clone());
        fresh.set_caching(false);
        fresh.cap = self.cap;
        // The same grants: the plan is kept while the lights' demands are the same.
        fresh.map_budget = self.map_budget;
        fresh.map_plan = self.map_plan.clone();
        for s in &self.lights {
            let index = self.live.light_index(s.light).expect("shadowed lights exist");
            let specs: Vec<TechniqueSpec> = s.rungs.iter().map(|r| r.spec.clone()).collect();
            fresh.set_ladder(LightId(index as u32), &specs, s.layer.texture.width(), s.layer.texture.height())?;
            // What the live rungs measured frames ago (cascaded's visible depths) is part of
            // their state: the fresh rungs take it, so both fit their maps to the same samples.
            if let Some(f) = fresh.lights.iter_mut().find(|f| f.light == LightId(index as u32)) {
                for (fr, lr) in f.rungs.iter_mut().zip(&s.rungs) {
                    if let Some(m) = lr.technique.measured() {
                        fr.technique.adopt_measured(m);
                    }
                }
            }
        }
        Ok(fresh)
    }

    /// Bytes the lights' shadow maps may take together (`None`: no limit; default
    /// [`DEFAULT_MAP_BUDGET`]). When the maps the lights' techniques ask for exceed it, each light
    /// gets a share weighted by its screen importance (a quarter plus its share of the screen, as
    /// the scheduler rates it; Godot's and Unity's shadow atlases share theirs likewise) and its
    /// map size is halved until its maps fit its share (at least 16²). Shares are planned when
    /// the lights or their demands change, with the camera of that frame, not at every camera
    /// move (which would re-render maps). Covers `hard`, `pcf`, `pcss`, `blurred`, `smoothies`
    /// and `lightmaps` over them.
    pub fn set_map_budget(&mut self, bytes: Option<u64>) {
        if bytes != self.map_budget {
            self.map_budget = bytes;
            self.map_plan = None;
        }
    }

    pub fn map_budget(&self) -> Option<u64> {
        self.map_budget
    }

    /// The lights whose maps the budget made smaller: (light, size asked, size granted), after
    /// the last frame.
    pub fn map_reductions(&self) -> Vec<(LightId, u32, u32)> {
        let mut out: Vec<(LightId, u32, u32)> =
            self.cache.map_reductions.iter().map(|(&(light, _), &(asked, granted))| (light, asked, granted)).collect();
        out.sort_unstable_by_key(|r| r.0);
        out
    }

    /// Plans the budget's shares (when the demands changed) and hands them to the cache by owner.
    fn plan_map_memory(&mut self, camera: &CameraUniform) {
        let bounds = self.gpu_scene.bounds;
        let dynamic = self.live.has_dynamic_casters();
        let mut demands: Vec<(LightId, usize, u64)> = Vec::new();
        let mut key = std::hash::DefaultHasher::new();
        self.map_budget.hash(&mut key);
        for s in &self.lights {
            let Some(light) = self.live.light(s.light) else { continue };
            for (r, rung) in s.rungs.iter().enumerate() {
                if let Some((size, layers)) = rung.technique.map_demand(light, &bounds, dynamic) {
                    demands.push((s.light, r, u64::from(layers) * u64::from(size).pow(2) * MAP_TEXEL_BYTES));
                    (s.light, r, size, layers).hash(&mut key);
                    light.position().map(|p| p.to_array().map(f32::to_bits)).hash(&mut key);
                    light.range.map(f32::to_bits).hash(&mut key);
                }
            }
        }
        let key = key.finish();
        if self.map_plan.as_ref().is_none_or(|p| p.0 != key) {
            let total: u64 = demands.iter().map(|d| d.2).sum();
            let mut shares = HashMap::new();
            if let Some(budget) = self.map_budget.filter(|&b| total > b) {
                let view = camera.view();
                let forward = (view.target - view.position).normalize_or(glam::Vec3::NEG_Z);
                let weight = |id: LightId| {
                    let l = self.live.light(id).expect("demands come from live lights");
                    0.25 + f64::from(screen_share(l, view.position, forward, view.fov_y, camera.aspect()))
                };
                let mut lights: Vec<LightId> = demands.iter().map(|d| d.0).collect();
                lights.dedup();
                let sum: f64 = lights.iter().map(|&l| weight(l)).sum();
                for &l in &lights {
                    let share = budget as f64 * weight(l) / sum;
                    let of_light: u64 = demands.iter().filter(|d| d.0 == l).map(|d| d.2).sum();
                    for d in demands.iter().filter(|d| d.0 == l) {
                        shares.insert((l, d.1), (share * d.2 as f64 / of_light.max(1) as f64) as u64);
                    }
                }
            }
            self.map_plan = Some((key, shares));
        }
        let plan = &self.map_plan.as_ref().expect("made above").1;
        self.cache.map_shares = self
            .lights
            .iter()
            .flat_map(|s| s.rungs.iter().enumerate().map(move |(r, rung)| (s.light, r, rung.owner)))
            .filter_map(|(l, r, owner)| plan.get(&(l, r)).map(|&share| (owner, share)))
            .collect();
    }

    /// Brings the GPU copy of the instances up to date with the edits applied since the last frame
    /// (done by [`Shadows::record`] too; an application that draws its own G-buffer from
    /// [`Shadows::gpu_scene`] calls it before drawing).
    pub fn sync(&mut self) {
        if self.instances_dirty {
            let gpu = &self.shared.gpu;
            self.gpu_scene.sync(&gpu.device, &gpu.queue, self.live.scene());
            self.instances_dirty = false;
        }
    }

    /// Records every light's prepare and resolve into `encoder`; returns what was re-rendered.
    /// The order in which lights take the frame's budget (Toromanoff alg. 13; issue 12's priority):
    /// lights showing no shadow yet first (their receivers lack any), then the largest share of
    /// the screen ([`screen_share`]), then the nearest to the eye (a directional light reaches
    /// every pixel: distance 0), ties in id order. Lights whose fills fit the budget all run
    /// whatever the order; it decides who waits when they do not.
    fn fill_order(&self, camera: &CameraUniform) -> Vec<usize> {
        let view = camera.view();
        let (eye, forward) = (view.position, (view.target - view.position).normalize_or(glam::Vec3::NEG_Z));
        let finite = |x: f32| if x.is_finite() { x } else { f32::MAX };
        let key = |s: &LightShadow| match self.live.light(s.light) {
            Some(l) => {
                let share = screen_share(l, eye, forward, view.fov_y, camera.aspect());
                let distance = l.position().map_or(0.0, |p| p.distance(eye));
                (s.shown.is_some(), -share, finite(distance))
            }
            None => (s.shown.is_some(), 0.0, f32::MAX),
        };
        let mut order: Vec<usize> = (0..self.lights.len()).collect();
        order.sort_by(|&a, &b| {
            let (ka, kb) = (key(&self.lights[a]), key(&self.lights[b]));
            ka.0.cmp(&kb.0).then(ka.1.total_cmp(&kb.1)).then(ka.2.total_cmp(&kb.2))
        });
        order
    }

    pub fn record(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        surface: &SurfaceInputs,
        timer: &mut GpuTimer,
    ) -> Result<Work, TechniqueError> {
        let gpu = self.shared.gpu.clone();
        self.sync();
        self.plan_map_memory(&surface.camera);
        for s in &mut self.lights {
            let Some(state) = self.live.light_state(s.light) else { continue };
            if state.colour_version != s.uniform_version {
                let light = self.live.light(s.light).expect("state implies light");
                gpu.queue.write_buffer(&s.light_buffer, 0, bytemuck::bytes_of(&LightUniform::new(light)));
                s.uniform_version = state.colour_version;
            }
        }
        // Dragged objects cast through a compute lookup (`live/temporary.rs`): without compute
        // (WebGL2) they cast no shadow while dragged, and every cache still leaves them out.
        // While they cast, the techniques shadow the permanent surface, which a drag leaves alone.
        let casting = self.shared.compute && TemporaryShadows::active(&self.live);
        let new_surface = casting
            && PermanentSurface::update(
                &mut self.permanent,
                &self.shared,
                encoder,
                &self.gpu_scene,
                &self.live,
                surface,
                timer,
            );
        if !casting {
            self.permanent = None;
        }
        let shadowed = match (&self.permanent, casting) {
            (Some(p), true) => &p.inputs,
            _ => surface,
        };
        let mut budget = match self.frame_target_ms() {
            Some(target) => Budget::for_frame(target, self.render_ms.unwrap_or(0.0), BUDGET_MARGIN),
            None => Budget::unlimited(),
        };
        let order = self.fill_order(&surface.camera);
        let temporaries = self.live.temporary_states();
        // A drag that begins or ends under a target (Toromanoff alg. 13 applied to temporary
        // objects: no frame takes every light's work at once): one light at a time, in fill order,
        // moves to the permanent surface and the dragged objects' pass, or back; each other light
        // keeps the layer it showed before (the dragged objects where they were picked up or
        // released: its last complete state) until its turn, or until the camera, the light or
        // another instance changes.
        let epoch = self.live.permanent_epoch();
        let holds: Vec<bool> = self
            .lights
            .iter()
            .map(|s| {
                let before_switch = s.resolved.as_ref().is_some_and(|r| {
                    r.casting != casting
                        && bytemuck::bytes_of(&r.camera) == bytemuck::bytes_of(&surface.camera)
                        && self.live.light_state(s.light).map(|l| l.emitter_version) == Some(r.key.0.emitter)
                });
                self.cache.enabled() && !budget.is_unlimited() && before_switch && s.held.is_none_or(|e| e == epoch)
            })
            .collect();
        // A pick-up under a budget smaller than the frame's own rendering is cut finer: each of
        // its pieces costs about a pass over the screen (the permanent surface's G-buffer, a
        // light's layer over it, the light's maps of the whole scene and its lookup: 2–5 ms each
        // at 128 × 96 on a CPU adapter, against 4.5 ms for a still frame), and such a budget holds
        // none of them beside another. The frame that draws the permanent surface turns no light,
        // and a light's turn takes two frames: its layer over the permanent surface first (it
        // still shows its old one), the dragged objects' pass the next.
        let fine = casting && !budget.is_unlimited() && budget.limit_ms() < self.render_ms.unwrap_or(0.0);
        let turn = match fine && new_surface {
            true => None,
            false => order.iter().copied().find(|&k| holds[k]),
        };
        // The light whose turn it is joins the dragged objects' pass, or leaves it: that is this
        // frame's unit of work, and fills wait for the next frame (a light-map sample over a
        // pick-up's refill alone is 3 ms at 128 × 96 on a CPU adapter, 1.1 ms at a release's). The
        // lights show their old data until those are done, but for what the turned light's new
        // state cannot be shown without: the released objects' volumes, which its turn charges
        // (`FrameContext::turn`).
        if turn.is_some() || (new_surface && fine && holds.contains(&true)) {
            budget.exhaust();
        }
        // Rung by rung across the lights (Toromanoff alg. 13: every light's cheap shadow before
        // anyone's upgrade), each rung's fills within the frame's budget, lights in priority order.
        let rungs = self.lights.iter().map(|s| s.rungs.len()).max().unwrap_or(0).min(self.cap.max(1));
        // The (light, rung) pairs whose `prepare` filled anything.
        let mut rebuilt: HashSet<(usize, usize)> = HashSet::new();
        for r in 0..rungs {
            for &k in &order {
                let s = &mut self.lights[k];
                let Some(rung) = s.rungs.get_mut(r) else { continue };
                let Some(light) = self.live.light(s.light) else { continue };
                let mut ctx = FrameContext {
                    gpu: &gpu,
                    shared: &self.shared,
                    encoder,
                    scene: self.live.scene(),
                    gpu_scene: &self.gpu_scene,
                    surface: shadowed,
                    light,
                    light_id: s.light,
                    light_buffer: &s.light_buffer,
                    timer,
                    frame_index: self.frame_index,
                    live: &self.live,
                    cache: &mut self.cache,
                    owner: rung.owner,
                    budget: &mut budget,
                    costs: &self.costs,
                    region: None,
                    turn: turn == Some(k),
                    kept: false,
                };
                let before = ctx.cache.work.fills();
                rung.technique.prepare(&mut ctx)?;
                if ctx.cache.work.fills() != before {
                    rebuilt.insert((k, r));
                }
            }
        }
        // The layers the techniques write into while objects cast: a light's holds while their
        // generation is the one it was resolved under.
        let raw = if casting {
            let ids: Vec<LightId> = self.lights.iter().map(|s| s.light).collect();
            self.temporary.begin(&self.shared, surface.width, surface.height, &ids)
        } else {
            self.temporary.end_drag();
            0
        };
        for (k, s) in self.lights.iter_mut().enumerate() {
            if holds[k] && turn != Some(k) {
                s.held.get_or_insert(epoch);
                self.cache.work.held_lights += 1;
                continue;
            }
            s.held = None;
            let staged = s.staged.take();
            let Some(light) = self.live.light(s.light) else { continue };
            // The best allowed rung with something complete to show; none: unshadowed.
            let shown = (0..s.rungs.len().min(rungs)).rev().find(|&r| s.rungs[r].technique.shown());
            // What the shown rung's resolve reads: its version where it tracks one (fills out of
            // sight then change nothing), otherwise whether it filled anything this frame.
            let version = shown.and_then(|r| s.rungs[r].technique.shown_version());
            let refilled = shown.is_some_and(|r| version.is_none() && rebuilt.contains(&(k, r)));
            let key =
                (screen_signature(&self.live, s.light, shadowed.generation()), shown.unwrap_or(usize::MAX), version);
            let (per_pixel, local) = match shown {
                Some(r) => (s.rungs[r].technique.resolves_per_pixel(), s.rungs[r].technique.resolves_locally()),
                None => (s.unshadowed.resolves_per_pixel(), s.unshadowed.resolves_locally()),
            };
            // A pick-up or a release (the light's turn, or every light at once without a target):
            // when the light's layer was resolved over the whole surface from this camera and
            // nothing else changed since (the emitter, the rung and what it shows, every other
            // instance), only the pixels the objects covered or shadowed (at a pick-up), or cover
            // and shadow (at a release), change, for a technique that resolves locally: its layer
            // (at a release, the one over the permanent surface, kept for it) is copied and those
            // are resolved again.
            // What the technique filled this frame must be the same, or (at a release) only the
            // released objects' own data: their volumes, which their footprint holds too.
            let filled_only = match shown {
                Some(r) => s.rungs[r].technique.filled_only(),
                None => s.unshadowed.filled_only(),
            };
            let picked_up = match &s.resolved {
                Some(r)
                    if self.cache.enabled()
                        && casting != r.casting
                        && (casting || self.temporary.kept_raw(k, s.light) == Some(r.raw))
                        && per_pixel
                        && local
                        && (r.key.0.emitter, r.key.1) == (key.0.emitter, key.1)
                        && bytemuck::bytes_of(&r.camera) == bytemuck::bytes_of(&surface.camera) =>
                {
                    let same_data = !refilled && r.key.2 == key.2;
                    let boxes = match casting {
                        true => self.live.picked_up_since(r.key.0.object).filter(|_| same_data),
                        false => self
                            .live
                            .released_since(r.key.0.object)
                            .filter(|released| {
                                same_data
                                    || filled_only
                                        .is_some_and(|ids| ids.iter().all(|i| released.iter().any(|(o, _)| o == i)))
                            })
                            .map(|released| released.into_iter().map(|(_, b)| b).collect()),
                    };
                    boxes.map(|boxes| {
                        let scene =
                            self.live.instances().iter().fold(shadowlab_core::Aabb::EMPTY, |a, i| a.union(&i.bounds));
                        let size = map_size(surface.width, surface.height);
                        pick_up_footprint(&surface.camera, light, &boxes, &scene, size)
                    })
                }
                _ => None,
            };
            // Only dragged objects moved since the layer was resolved: over the permanent surface
            // every pixel holds (they cast), or every pixel but their footprints (the validity
            // table's `Footprint`: they do not); the dragged objects' own shadows are redone
            // whenever they moved.
            // The dragged objects' maps of the permanent casters depend on the light and the
            // permanent scene alone: drawn again when those changed, not when a fill is shown.
            let same_scene =
                self.cache.enabled() && s.resolved.as_ref().is_some_and(|r| r.key.0 == key.0 && r.casting == casting);
            let (redo, moved) = match &s.resolved {
                Some(r)
                    if self.cache.enabled() && !refilled && r.key == key && r.casting == casting && r.raw == raw =>
                {
                    let redo = if casting {
                        Redo::Nothing
                    } else {
                        match moved_footprint(&surface.camera, &r.temporaries, &temporaries) {
                            Footprint::Nothing => Redo::Nothing,
                            Footprint::Rect(rect) if per_pixel => Redo::Region(rect),
                            _ => Redo::Whole,
                        }
                    };
                    (redo, r.temporaries != temporaries)
                }
                _ => match picked_up {
                    Some(Footprint::Rect(rect)) => (Redo::Region(rect), true),
                    _ => (Redo::Whole, true),
                },
            };
            let mut seed = picked_up.is_some() && matches!(redo, Redo::Region(_));
            // A staged turn's first frame resolves the raw layer and holds the light; its second
            // joins the pass over that layer when nothing it was resolved from changed (once: a
            // change meanwhile makes the turn whole, so that turns never stall).
            let first_stage = fine && turn == Some(k) && staged.is_none();
            let (mut redo, mut moved) = (redo, moved);
            if turn == Some(k)
                && staged.as_ref().is_some_and(|st| {
                    st.key == key
                        && st.raw == raw
                        && !refilled
                        && bytemuck::bytes_of(&st.camera) == bytemuck::bytes_of(&surface.camera)
                })
            {
                (redo, moved, seed) = (Redo::Nothing, true, false);
            }
            if redo == Redo::Nothing && !(casting && moved) {
                continue;
            }
            if redo != Redo::Nothing {
                self.cache.work.resolves += 1;
            }
            // The layer written holds the last resolve of this rung over the same surface (only
            // its data changed: a fill shown).
            let kept = self.cache.enabled()
                && !matches!(redo, Redo::Region(_))
                && s.resolved.as_ref().is_some_and(|r| {
                    (&r.key.0, r.key.1, r.casting, r.raw) == (&key.0, key.1, casting, raw)
                        && bytemuck::bytes_of(&r.camera) == bytemuck::bytes_of(&surface.camera)
                });
            if first_stage {
                s.held = Some(epoch);
                s.staged = Some(Staged { key: key.clone(), camera: surface.camera, raw });
                self.cache.work.held_lights += 1;
            } else {
                s.shown = shown;
                let (level, samples) = match shown {
                    Some(r) => {
                        let (p, samples) = s.rungs[r].technique.progress();
                        (r as u32 + p, samples)
                    }
                    None => (0, 0),
                };
                (s.level, s.samples) = (level, samples);
                // Unshadowed too (nothing complete yet): that layer holds until a rung is shown.
                s.resolved =
                    Some(Resolved { key, temporaries: temporaries.clone(), casting, camera: surface.camera, raw });
            }
            let owner = shown.map_or(0, |r| s.rungs[r].owner);
            let region = match redo {
                Redo::Region(rect) => {
                    gpu.queue.write_buffer(&s.region_buffer, 0, bytemuck::bytes_of(&RegionUniform { rect }));
                    Some(ResolveRegion { rect, buffer: &s.region_buffer })
                }
                _ => None,
            };
            let mut ctx = FrameContext {
                gpu: &gpu,
                shared: &self.shared,
                encoder,
                scene: self.live.scene(),
                gpu_scene: &self.gpu_scene,
                surface: shadowed,
                light,
                light_id: s.light,
                light_buffer: &s.light_buffer,
                timer,
                frame_index: self.frame_index,
                live: &self.live,
                cache: &mut self.cache,
                owner,
                budget: &mut budget,
                costs: &self.costs,
                region,
                turn: false,
                kept,
            };
            let technique: &mut dyn ShadowTechnique = match shown {
                Some(r) => s.rungs[r].technique.as_mut(),
                None => s.unshadowed.as_mut(),
            };
            if casting {
                // The technique's own layer is kept apart (dragged objects in none of its data);
                // the dragged objects' shadows are multiplied in each time they move.
                if seed {
                    self.temporary.seed_raw(ctx.encoder, k, &s.layer);
                }
                if redo != Redo::Nothing {
                    technique.resolve(&mut ctx, self.temporary.raw_layer(k));
                }
                // (A technique may have given the region up and resolved every pixel.)
                ctx.cache.work.region_resolves += u32::from(ctx.region.is_some());
                if first_stage {
                    continue;
                }
                ctx.region = None;
                ctx.surface = surface;
                self.temporary.add(&mut ctx, k, &s.layer, !same_scene);
            } else {
                if seed {
                    self.temporary.seed_from_raw(ctx.encoder, k, &s.layer);
                }
                technique.resolve(&mut ctx, &s.layer);
                ctx.cache.work.region_resolves += u32::from(ctx.region.is_some());
            }
        }
        // The raw layers outlive a drag until every light has left the pass (see `end_drag`).
        if !casting && self.lights.iter().all(|s| s.resolved.as_ref().is_none_or(|r| !r.casting)) {
            self.temporary.release();
        }
        // Every light's dragged-object shadows in one lookup; and in the first frame with a light,
        // that pass once over nothing, so that what a drag's first frames would compile is compiled
        // now (`TemporaryShadows::rehearse`). Either runs under one light's context (the lookup's
        // first, or any).
        let pending = self.temporary.first_pending();
        let rehearse = !self.rehearsed;
        if let Some((first, light)) = pending.or_else(|| order.first().copied().filter(|_| rehearse)).and_then(|k| {
            let s = &self.lights[k];
            self.live.light(s.light).map(|l| (s, l))
        }) {
            let mut ctx = FrameContext {
                gpu: &gpu,
                shared: &self.shared,
                encoder,
                scene: self.live.scene(),
                gpu_scene: &self.gpu_scene,
                surface,
                light,
                light_id: first.light,
                light_buffer: &first.light_buffer,
                timer,
                frame_index: self.frame_index,
                live: &self.live,
                cache: &mut self.cache,
                owner: 0,
                budget: &mut budget,
                costs: &self.costs,
                region: None,
                turn: false,
                kept: false,
            };
            if pending.is_some() {
                let outs: Vec<&VisibilityLayer> = self.lights.iter().map(|s| &s.layer).collect();
                self.temporary.run(&mut ctx, shadowed, &outs);
            }
            if rehearse {
                self.temporary.rehearse(&mut ctx);
                self.rehearsed = true;
            }
        }
        let mut work = self.cache.begin_frame();
        self.last_units = self.cache.take_units();
        work.deferred = budget.deferred;
        work.budget_ms = if budget.is_unlimited() { f64::INFINITY } else { budget.limit_ms() };
        work.planned_ms = budget.spent_ms();
        self.frame_index += 1;
        Ok(work)
    }

    /// Memory, passes and draws of all techniques together.
    pub fn stats(&self) -> TechniqueStats {
        self.lights.iter().flat_map(|s| s.rungs.iter().map(move |r| (s, r))).fold(
            TechniqueStats::default(),
            |a, (s, r)| {
                let t = r.technique.stats();
                let light = self.live.light(s.light).map_or("?", |l| l.name.as_str());
                let mut extra = a.extra;
                extra.extend(t.extra.into_iter().map(|(k, v)| (format!("{light}: {k}"), v)));
                TechniqueStats {
                    memory_bytes: a.memory_bytes + t.memory_bytes + s.layer.bytes(),
                    passes: a.passes + t.passes,
                    draws: a.draws + t.draws,
                    triangles: a.triangles + t.triangles,
                    extra,
                }
            },
        )
    }

    /// Texels a side of each dragged object's own map in the last frame of a drag (two per pixel
    /// across the widest of the lights' footprints of it, at most the output's map size), `None`
    /// while nothing is dragged: how finely the dragged objects cast.
    pub fn dragged_map_size(&self) -> Option<u32> {
        self.temporary.tile()
    }

    /// GPU bytes held for shadows: every technique's maps and buffers, the visibility layers and
    /// the temporary objects' maps.
    pub fn memory_bytes(&self) -> u64 {
        self.stats().memory_bytes + self.temporary.bytes() + self.permanent.as_ref().map_or(0, PermanentSurface::bytes)
    }

    /// What to say after the device ran out of memory: how much the shadows ask for and which
    /// light's technique asks for most (a map size or sample count past what the device holds
    /// allocates without a validation error, and the device's own message names no resource).
    pub fn out_of_memory_hint(&self) -> String {
        let largest = self
            .lights
            .iter()
            .flat_map(|s| s.rungs.iter().map(move |r| (s, r)))
            .map(|(s, r)| (r.technique.stats().memory_bytes, s, r))
            .max_by_key(|(bytes, ..)| *bytes);
        let mut hint = format!("the shadows ask for {} of GPU memory", format_bytes(self.memory_bytes()));
        if let Some((bytes, s, r)) = largest.filter(|(bytes, ..)| *bytes > 0) {
            let light = self.live.light(s.light).map_or("?", |l| l.name.as_str());
            hint += &format!(
                ", {} of it `{}` on light `{light}`: lower its map sizes or sample counts",
                format_bytes(bytes),
                r.spec.spec
            );
        }
        hint
    }
}

/// Bytes in the largest binary unit that keeps them above 1 (`4.0 GiB`, `12 MiB`).
fn format_bytes(bytes: u64) -> String {
    const UNITS: [&str; 4] = ["B", "KiB", "MiB", "GiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 { format!("{bytes} B") } else { format!("{value:.1} {}", UNITS[unit]) }
}
