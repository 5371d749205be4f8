//! The technique contract (DESIGN.md §5): the trait, its errors and statistics, and what a technique
//! sees of a frame. The registry of techniques lives above them (`registry.rs`); the GPU context they
//! share below them (`context.rs`).
//!
//! A technique is created per (light, technique) pair. Each frame it gets [`ShadowTechnique::prepare`]
//! (render maps, volumes, ...) and then [`ShadowTechnique::resolve`], which must write the light's
//! visibility V for every pixel into a [`VisibilityLayer`]. That layer is the whole interface to the
//! rest of the renderer, which is what makes techniques comparable, composable per light and
//! replaceable.

use shadowlab_core::cascades::VisibleDepths;
use shadowlab_core::params::{ParamDef, ParamError, ParamSet};
use shadowlab_core::{Light, LightId, Scene};

use crate::context::Shared;
use crate::frame::{SurfaceInputs, VisibilityLayer};
use crate::gpu::Gpu;
use crate::gpu_scene::GpuScene;
use crate::light_map::LightMap;
use crate::live::scheduler::{Budget, CostModel, UnitKind, UnitSize, count_units};
use crate::live::{InstanceId, LiveScene, ShadowCache};
use crate::timing::GpuTimer;

/// A technique could not be set up or run.
#[derive(Debug, thiserror::Error)]
pub enum TechniqueError {
    #[error("unknown technique '{id}' (known: {known})")]
    Unknown { id: String, known: String },
    #[error("technique '{id}': {source}")]
    Param {
        id: String,
        #[source]
        source: ParamError,
    },
    #[error("technique '{id}' does not support {light_type} light '{light}'")]
    Unsupported { id: String, light: String, light_type: &'static str },
    #[error("technique '{id}': {message}")]
    Failed { id: String, message: String },
}

/// Resources and counts a technique reports.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TechniqueStats {
    /// Bytes of GPU memory the technique holds (maps, buffers), not counting shared resources.
    pub memory_bytes: u64,
    /// Render and compute passes per frame.
    pub passes: u32,
    /// Draw calls per frame.
    pub draws: u32,
    /// Triangles rasterised per frame for shadows.
    pub triangles: u64,
    /// Technique-specific figures for the reports (`auto_near_latency_frames`, ...).
    pub extra: Vec<(String, f64)>,
}

/// Everything a technique may use during a frame.
pub struct FrameContext<'a> {
    pub gpu: &'a Gpu,
    pub shared: &'a Shared,
    pub encoder: &'a mut wgpu::CommandEncoder,
    pub scene: &'a Scene,
    pub gpu_scene: &'a GpuScene,
    pub surface: &'a SurfaceInputs,
    pub light: &'a Light,
    pub light_id: LightId,
    /// The light's `LightUniform`.
    pub light_buffer: &'a wgpu::Buffer,
    pub timer: &'a mut GpuTimer,
    /// Frames rendered before this one (for techniques that cache or spread work over frames).
    pub frame_index: u64,
    /// The scene's ids and versions (what cached items are checked against).
    pub live: &'a LiveScene,
    /// The one store of cached items, and this frame's work counts.
    pub cache: &'a mut ShadowCache,
    /// The technique instance's owner id in the cache.
    pub owner: u32,
    /// What this frame may still spend on cache fills (unlimited unless a target frame time is set).
    pub budget: &'a mut Budget,
    /// Predicted costs of units of work.
    pub costs: &'a CostModel,
    /// Set only for a technique that [resolves per pixel](ShadowTechnique::resolves_per_pixel):
    /// the pixels whose surface may have changed since it last resolved into this same layer
    /// with the same prepared data (a dragged object's footprint, old and new). Its resolve may
    /// keep to them: every other pixel of the layer still holds its right value.
    pub region: Option<ResolveRegion<'a>>,
    /// The light's turn at the start or end of a drag under a target frame time (the frame's
    /// budget is spent on it): what its new state cannot be shown without is charged to the
    /// budget, not asked of it ([`FrameContext::take_needed_units`]).
    pub turn: bool,
    /// For `resolve`: the layer it writes holds this technique's last resolve over the same
    /// surface, light and instances, from the same camera; only what its `prepare`s changed since
    /// differs. A technique may keep what they did not change (`lightmaps`: the pixels off its
    /// receivers, when only the light maps changed).
    pub kept: bool,
}

/// The part of a layer a resolve has to redo ([`FrameContext::region`]).
#[derive(Debug, Clone, Copy)]
pub struct ResolveRegion<'a> {
    /// x, y, width, height in pixels; never empty.
    pub rect: [u32; 4],
    /// The rectangle as a `RegionUniform` (binding 5 of the resolve group).
    pub buffer: &'a wgpu::Buffer,
}

/// The overlap of two pixel rectangles (x, y, width, height); `None` when empty.
pub fn intersect_rects(a: [u32; 4], b: [u32; 4]) -> Option<[u32; 4]> {
    let (x0, y0) = (a[0].max(b[0]), a[1].max(b[1]));
    let x1 = (u64::from(a[0]) + u64::from(a[2])).min(u64::from(b[0]) + u64::from(b[2]));
    let y1 = (u64::from(a[1]) + u64::from(a[3])).min(u64::from(b[1]) + u64::from(b[3]));
    (x1 > u64::from(x0) && y1 > u64::from(y0))
        .then(|| [x0, y0, (x1 - u64::from(x0)) as u32, (y1 - u64::from(y0)) as u32])
}

impl FrameContext<'_> {
    /// The pixels this resolve covers: the region, or the whole surface.
    pub fn resolve_rect(&self) -> [u32; 4] {
        self.region.map_or([0, 0, self.surface.width, self.surface.height], |r| r.rect)
    }

    /// The group 0 of a resolve shader writing `out` over [`FrameContext::resolve_rect`]: with it,
    /// dispatch through [`dispatch_resolve_in`] and take pixels from `region_pixel`.
    pub fn resolve_group(&self, out: &VisibilityLayer) -> wgpu::BindGroup {
        match &self.region {
            Some(r) => self.shared.resolve_bind_group_in(self.surface, self.light_buffer, out, r.buffer),
            None => self.shared.resolve_bind_group(self.surface, self.light_buffer, out),
        }
    }

    /// The region's rectangle, if the resolve has one (for [`scissor_to`]).
    pub fn region_rect(&self) -> Option<[u32; 4]> {
        self.region.map(|r| r.rect)
    }

    /// Units the light's new state cannot be shown without (an object's volumes: Toromanoff alg.
    /// 14 shows a light's volumes only when all its objects' are in): in the light's
    /// [turn](FrameContext::turn) they run and are charged, whatever the budget; otherwise as
    /// [`FrameContext::take_units`].
    pub fn take_needed_units(&mut self, kind: UnitKind, size: UnitSize, count: u32) -> bool {
        if self.turn {
            count_units(&mut self.cache.units, kind, size, count);
            return true;
        }
        self.take_units(kind, size, count)
    }

    /// Charges `count` units of `kind`, each of `size` (texels, faces), to the frame's budget:
    /// false when they do not fit (the work is left for a later frame). Units that run are
    /// counted for the cost model, which learns each kind and size's cost from the frame's time.
    pub fn take_units(&mut self, kind: UnitKind, size: UnitSize, count: u32) -> bool {
        if !self.budget.take(self.costs.predict(kind, size) * f64::from(count)) {
            return false;
        }
        count_units(&mut self.cache.units, kind, size, count);
        true
    }
}

/// The maps a technique looks up, for the analysis overlays (`shadowlab render --overlay`).
pub struct MapAnalysis<'a> {
    /// Group 1 of `shaders/maplookup.wgsl`.
    pub lookup: &'a wgpu::BindGroup,
    /// Group 3 of `shaders/selection.wgsl`.
    pub selection: &'a wgpu::BindGroup,
    /// The map views (cube faces, cascade splits) on the CPU, for drawing their frusta.
    pub views: &'a [shadowlab_core::lightspace::ShadowView],
}

/// The technique contract of DESIGN.md §5.
pub trait ShadowTechnique: Send {
    /// The stable id used by the CLI and the reports.
    fn id(&self) -> &'static str;
    fn params(&self) -> &ParamSet;
    /// Renders whatever the technique needs before resolving (shadow maps, volumes).
    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError>;
    /// Writes V for every pixel of the surface into `out` (with [`FrameContext::region`]: at least
    /// every pixel of the region).
    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer);
    fn stats(&self) -> TechniqueStats;
    /// Whether each pixel's V depends only on that pixel's surface and what `prepare` left (no
    /// screen-space filtering, no neighbours): then a frame in which only some pixels' surface
    /// changed may resolve just those ([`FrameContext::region`]), the rest of the layer kept.
    fn resolves_per_pixel(&self) -> bool {
        false
    }
    /// Whether, beyond [`ShadowTechnique::resolves_per_pixel`], a caster that leaves the scene's
    /// permanent casters (a pick-up) or joins them (a release) changes what `resolve` writes only
    /// where the caster is seen or where its shadow, from any point of the emitter, may fall,
    /// what `prepare` filled being otherwise the same (or, at a release, only the caster's own
    /// data: [`ShadowTechnique::filled_only`]): then a light's turn at a pick-up or a release
    /// resolves only those pixels again (the rest copied from its layer before, or at a release
    /// from its layer over the permanent surface). A technique may still drop the region it is given
    /// (`ctx.region = None`) and resolve every pixel: `volumes` does when the caster's leaving
    /// changed how it counts (its methods or start values).
    fn resolves_locally(&self) -> bool {
        false
    }
    /// The instances whose data alone the last `prepare` changed in what the technique shows
    /// (`volumes`: those objects' volumes; none: it changed nothing), or `None` when it changed
    /// anything else (a map, a light map) or cannot tell. For a technique that
    /// [resolves locally](ShadowTechnique::resolves_locally), a layer resolved before that
    /// `prepare` then still holds wherever those instances are not seen and their shadows cannot
    /// fall: a light's turn at a release, which fills the released objects' volumes, resolves
    /// only there.
    fn filled_only(&self) -> Option<&[InstanceId]> {
        None
    }
    /// The shadow maps the technique asks for on `light` in a scene of `bounds` (their size and
    /// how many; `dynamic`: dynamic casters may need composite copies), for the map-memory budget
    /// (`Shadows::set_map_budget`), which may grant a smaller size. `None`: no maps under it.
    fn map_demand(&self, _light: &Light, _bounds: &shadowlab_core::Aabb, _dynamic: bool) -> Option<(u32, u32)> {
        None
    }
    /// Whether the technique has a complete state to show (its maps, volumes and light maps all
    /// filled for some state of the scene). While filling is spread over frames from nothing, it
    /// has not, and the light is shown unshadowed (Toromanoff's all-or-nothing rule).
    fn shown(&self) -> bool {
        true
    }

    /// Whether what it shows is the current state (no fill pending).
    fn current(&self) -> bool {
        true
    }

    /// A number that changes whenever what [`ShadowTechnique::resolve`] reads changes (maps,
    /// volumes or light maps written where its lookups see them). A fill spread over frames into
    /// layers out of sight leaves it as it is, so the light's visibility is not resolved again
    /// until the fill is shown. `None` (the default): not tracked, and any fill in `prepare`
    /// counts as a change.
    fn shown_version(&self) -> Option<u64> {
        None
    }

    /// The rung it shows on its own quality ladder (1: its base; higher: upgrades, as light maps
    /// with more samples) and the emitter samples behind it (0 where that means nothing).
    fn progress(&self) -> (u32, u32) {
        (1, 0)
    }

    /// The maps behind the last frame, for techniques that shade each pixel from one map (hard,
    /// pcf, cascaded); `None` for the others.
    fn analysis(&self) -> Option<MapAnalysis<'_>> {
        None
    }

    /// Every map view behind the last frame (cube faces, cascade splits, emitter samples' views),
    /// for drawing their frusta (the viewer's third-person view). By default those of
    /// [`ShadowTechnique::analysis`].
    fn map_views(&self) -> Vec<shadowlab_core::lightspace::ShadowView> {
        self.analysis().map_or_else(Vec::new, |a| a.views.to_vec())
    }

    /// Shadow-volume fill of the first frame: buffers of u32 counters, the total then one per pixel
    /// (row by row), for `render --overlay fill` (Hasselgren 2003 Fig. 8). Empty for techniques
    /// without volumes.
    fn fill_counts(&self) -> Vec<&wgpu::Buffer> {
        Vec::new()
    }

    /// What the technique measured on the GPU and steers by a frame or more later (`cascaded`'s
    /// visible depths): a readback that a fresh engine, rendering one frame, cannot have. Default:
    /// none.
    fn measured(&self) -> Option<VisibleDepths> {
        None
    }

    /// Takes a live engine's measurement ([`ShadowTechnique::measured`]) as its own, so that a
    /// fresh engine compared with it draws from the same state (`Shadows::fresh`). Default: ignored.
    fn adopt_measured(&mut self, _measured: VisibleDepths) {}

    /// Gives up the caches a successor on the same light could keep ([`Handover`]). Default: none.
    fn hand_over(&mut self) -> Option<Handover> {
        None
    }

    /// Takes over a predecessor's caches, or gives them back when they do not fit its parameters.
    fn take_over(&mut self, _shared: &Shared, handover: Handover) -> Result<(), Handover> {
        Err(handover)
    }
}

/// Caches a technique hands to its successor on the same light when only its parameters change
/// (a slider in the viewer) or it is replaced by one built on the same maps (`hard` → `pcf`): the
/// successor keeps the memory, and the cache's signatures (which hash every parameter that changes
/// what a map holds) decide what is re-rendered, so nothing kept can be stale.
pub enum Handover {
    /// A light's hard map ([`LightMap`]).
    Map(Box<LightMap>),
}

/// How to make a technique.
pub type Constructor = fn(&Shared, &ParamSet, &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError>;

/// A registry entry: what the technique is, where it comes from, what it takes.
#[derive(Debug)]
pub struct TechniqueInfo {
    pub id: &'static str,
    pub summary: &'static str,
    /// The source document and section it implements.
    pub source: &'static str,
    pub params: &'static [ParamDef],
    /// Light types it shadows (`point`, `spot`, `directional`, `rect`).
    pub light_types: &'static [&'static str],
    pub create: Constructor,
    /// For a technique that shadows some pixels itself and hands the others to another technique
    /// (`lightmaps`: receivers from light maps, the rest by `volumes`), how it wraps that one.
    pub compose: Option<Compose>,
    /// It has a fragment-shader path: it runs on devices without compute shaders (WebGL2), where
    /// the others cannot ([`crate::gpu::runs_compute`]).
    pub fragment: bool,
}

/// How a technique wraps another: the parameter naming the other technique (created by the
/// registry, so techniques need not know each other), and the constructor that takes it.
#[derive(Debug)]
pub struct Compose {
    pub param: &'static str,
    pub create: ComposeConstructor,
}

/// How to make a technique around another one.
pub type ComposeConstructor =
    fn(&Shared, &ParamSet, &Light, Box<dyn ShadowTechnique>) -> Result<Box<dyn ShadowTechnique>, TechniqueError>;

impl TechniqueInfo {
    pub fn supports(&self, light: &Light) -> bool {
        self.light_types.contains(&light.type_name())
    }
}

/// Restricts a render pass to a resolve's `region` ([`FrameContext::region_rect`]), within
/// `within` when given (a technique's own scissor); false when nothing is left to draw.
pub fn scissor_to(pass: &mut wgpu::RenderPass<'_>, region: Option<[u32; 4]>, within: Option<[u32; 4]>) -> bool {
    let rect = match (region, within) {
        (Some(r), Some(w)) => intersect_rects(r, w),
        (r, w) => r.or(w),
    };
    match rect {
        Some([x, y, w, h]) => {
            pass.set_scissor_rect(x, y, w, h);
            true
        }
        None => region.is_none() && within.is_none(),
    }
}

/// Dispatches a resolve shader over [`FrameContext::resolve_rect`] (8 × 8 workgroups); its group
/// 0 must be [`FrameContext::resolve_group`] and its pixels `region_pixel`'s.
pub fn dispatch_resolve_in(
    ctx: &mut FrameContext<'_>,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
) {
    let rect = ctx.resolve_rect();
    dispatch_resolve_rect(ctx, label, pipeline, groups, rect);
}

/// Dispatches a resolve shader over `rect` (x, y, width, height); its group 0 must hold that
/// rectangle's `RegionUniform` and its pixels be `region_pixel`'s.
pub fn dispatch_resolve_rect(
    ctx: &mut FrameContext<'_>,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
    rect: [u32; 4],
) {
    let timestamps = ctx.timer.compute_pass(&ctx.gpu.device, crate::timing::PassKind::Visibility);
    let mut pass = ctx
        .encoder
        .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: timestamps });
    pass.set_pipeline(pipeline);
    for (i, g) in groups.iter().enumerate() {
        pass.set_bind_group(i as u32, Some(*g), &[]);
    }
    pass.dispatch_workgroups(crate::util::groups(rect[2], 8), crate::util::groups(rect[3], 8), 1);
}

/// Runs a resolve program ([`crate::context::Shared::resolve_program`]) over
/// [`FrameContext::resolve_rect`] into `out`: a compute dispatch as [`dispatch_resolve_in`], or,
/// for a fragment program, one triangle drawn into `out` as a render target, scissored to the
/// rectangle (the pixels outside keep what they held). Its group 0 must be
/// [`FrameContext::resolve_group`]`(out)`.
pub fn dispatch_program_in(
    ctx: &mut FrameContext<'_>,
    label: &str,
    program: &crate::context::ResolveProgram,
    groups: &[&wgpu::BindGroup],
    out: &VisibilityLayer,
) {
    let pipeline = match program {
        crate::context::ResolveProgram::Compute(pipeline) => return dispatch_resolve_in(ctx, label, pipeline, groups),
        crate::context::ResolveProgram::Fragment(pipeline) => pipeline,
    };
    let [x, y, w, h] = ctx.resolve_rect();
    let (x, y) = (x.min(ctx.surface.width), y.min(ctx.surface.height));
    let (w, h) = (w.min(ctx.surface.width - x), h.min(ctx.surface.height - y));
    if w == 0 || h == 0 {
        return;
    }
    let timestamps = ctx.timer.render_pass(&ctx.gpu.device, crate::timing::PassKind::Visibility);
    let mut pass = ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: &out.view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: timestamps,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_scissor_rect(x, y, w, h);
    pass.set_pipeline(pipeline);
    for (i, g) in groups.iter().enumerate() {
        pass.set_bind_group(i as u32, Some(*g), &[]);
    }
    pass.draw(0..3, 0..1);
}

/// Dispatches a resolve shader over the whole surface (8 × 8 workgroups).
pub fn dispatch_resolve(
    ctx: &mut FrameContext<'_>,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
) {
    let rect = [0, 0, ctx.surface.width, ctx.surface.height];
    dispatch_resolve_rect(ctx, label, pipeline, groups, rect);
}
