//! Temporary (dragged) objects (Toromanoff 2005 §3.3, his option 5): while an instance is
//! temporary, every cached item leaves it out, so dragging invalidates nothing; it casts through a
//! pass of its own each frame instead: a small map per light fitted to the object ([`map_size`])
//! (one frustum, or six faces when the light is inside its bounds; an orthographic box for
//! directional lights), looked up after the lights' techniques have written their visibility,
//! which is multiplied by the object's hard shadow, every light in one dispatch. On release the object becomes permanent again and the items it reaches
//! are rebuilt once (the validity table).
//!
//! Receivers beyond a map's far plane compare at depth 0 (everything stored is closer to the
//! light): the object's shadow reaches as far as the light does.

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec4};
use shadowlab_core::convex::{ConvexBody, box_misses_view};
use shadowlab_core::lightspace::{ShadowView, cube_faces_meeting, directional_frustum, light_frusta, point_frusta};
use shadowlab_core::{Aabb, Light, LightId, LightKind, Mobility};

use super::edits::InstanceId;
use super::scene::LiveScene;
use super::scheduler::{UnitKind, count_units};
use crate::context::{RegionUniform, Shared, UNFILTERED, storage_entry, texture_entry};
use crate::frame::{CameraUniform, Footprint, LightUniform, SurfaceInputs, VISIBILITY_FORMAT, VisibilityLayer};
use crate::gbuffer::GBuffer;
use crate::gpu_scene::GpuScene;
use crate::shadowmap::{BiasUniform, FaceMode, Raster, ShadowMapArray, lookup_group, lookup_layout};
use crate::technique::FrameContext;
use crate::timing::{GpuTimer, PassKind};

/// Texels per side of a temporary object's map (the object alone fills it) for an output of
/// `width × height`: twice the output's larger side, as a power of two within 256..=1024. The
/// object's shadow covers at most the screen, so more texels than about two per pixel across it
/// buy nothing, and a drag frame on a small output should not pay for a 1024² map per light.
pub fn map_size(width: u32, height: u32) -> u32 {
    (2 * width.max(height)).next_power_of_two().clamp(256, 1024)
}

/// The fewest texels a side of a dragged object's tile in the atlas.
const MIN_TILE: u32 = 64;

/// Texels a side of the dragged objects' tiles for lights whose lookups' footprints are at most
/// `widest` pixels across ([`widest`]): two texels per pixel across them, the density
/// [`map_size`] gives across the whole output, and at most `full` (its size). A tile holds one
/// object as its light sees it, and its shadow and its own pixels are what the light's lookup
/// covers: a chair whose shadow spans a third of the screen needs no more texels than that
/// (on a CPU adapter the atlas pass costs by the texel: `room` at 160 × 120, 512² tiles, 2.0 ms;
/// 256², 0.8 ms).
fn tile_for(widest: u32, full: u32) -> u32 {
    (2 * widest).next_power_of_two().clamp(MIN_TILE.min(full), full)
}

/// The larger side of the largest of `rects` (x, y, width, height).
fn widest(rects: impl IntoIterator<Item = [u32; 4]>) -> u32 {
    rects.into_iter().map(|[_, _, w, h]| w.max(h)).max().unwrap_or(0)
}

/// Part boxes (`LiveScene::instance_parts`, all instances together) up to which the dragged
/// objects' shadow silhouettes are cut by each box (a clipped body each, per view and light,
/// every drag step), not by the whole scene's box.
const MAX_RECEIVER_BOXES: usize = 256;

/// The bias of `hard`'s defaults (texels along the normal; slope-scaled raster bias).
const NORMAL_OFFSET: f32 = 0.3;
const SLOPE_BIAS: f32 = 1.5;

/// How the pass's maps (the dragged objects' and the whole scene's) are drawn: `hard`'s raster.
const RASTER: Raster =
    Raster { faces: FaceMode::Back, slope_bias: SLOPE_BIAS, linear_depth: false, only_masked: false };

/// The permanent instances alone, seen by the application's camera, while objects are dragged:
/// the surface the lights' techniques shadow then. Their layers depend on nothing a drag changes,
/// so a drag step resolves nothing again (the dragged objects' pass alone runs); pixels that show
/// a dragged object take the permanent casters' hard shadow instead ([`TemporaryShadows::add`]).
/// Drawn again when the camera, the permanent scene or the set of dragged objects changes.
pub struct PermanentSurface {
    gbuffer: GBuffer,
    pub inputs: SurfaceInputs,
    /// The application surface's generation, the permanent epoch and the dragged instances it was
    /// drawn for.
    drawn: Option<(u64, u64, Vec<InstanceId>)>,
}

impl PermanentSurface {
    /// Brings `slot` up to date with `surface` (drawing it when anything it shows changed).
    /// Returns whether it was drawn.
    pub fn update(
        slot: &mut Option<Self>,
        shared: &Shared,
        encoder: &mut wgpu::CommandEncoder,
        gpu_scene: &GpuScene,
        live: &LiveScene,
        surface: &SurfaceInputs,
        timer: &mut GpuTimer,
    ) -> bool {
        let device = &shared.gpu.device;
        let (width, height) = (surface.width, surface.height);
        if slot.as_ref().is_none_or(|p| p.gbuffer.size() != (width, height)) {
            let gbuffer = GBuffer::new(device, width, height);
            let inputs = gbuffer.surface(device, surface.camera);
            *slot = Some(Self { gbuffer, inputs, drawn: None });
        }
        let p = slot.as_mut().expect("made above");
        let dragged: Vec<InstanceId> = live
            .scene()
            .instances
            .iter()
            .zip(live.instances())
            .filter(|(i, _)| i.mobility == Mobility::Temporary)
            .map(|(_, s)| s.id)
            .collect();
        let key = (surface.generation(), live.permanent_epoch(), dragged);
        if p.drawn.as_ref() != Some(&key) {
            // A new camera (or anything else): the layers over the old surface no longer hold.
            p.inputs.set_camera(&shared.gpu.queue, surface.camera);
            let timestamps = timer.render_pass(device, PassKind::Gbuffer);
            let camera = &p.inputs.camera_buffer;
            p.gbuffer.draw(shared, encoder, gpu_scene, camera, timestamps, |g| g.mobility != Mobility::Temporary);
            p.drawn = Some(key);
            return true;
        }
        false
    }

    pub fn bytes(&self) -> u64 {
        self.gbuffer.bytes()
    }
}

/// The dragged objects' shadows for every light, rebuilt each frame while any object is dragged:
/// one atlas of the dragged objects' maps drawn in one pass, and one lookup for all lights, so a
/// drag step costs a pass and a dispatch however many lights there are, and each pixel's surface
/// is read once (on a CPU adapter a pass, a dispatch and a surface read each cost about as much as
/// a light's own work).
pub struct TemporaryShadows {
    /// The lights' own layers under the pass, and what it writes (`None` while nothing casts).
    layers: Option<Layers>,
    /// Bumped whenever `layers` is made again: a light's layer in it was resolved under one
    /// generation and holds only while that is current.
    generation: u64,
    /// Every pending light's views of the whole scene (the permanent casters' shadow on the dragged
    /// objects, kept while the drag goes on).
    maps: Option<(ShadowMapArray, wgpu::BindGroup)>,
    /// The temporary objects' views of this frame, every light's, as tiles of an atlas.
    atlas: Option<Atlas>,
    /// The slots of each light's views of the whole scene in `maps`.
    permanent: Vec<PermanentViews>,
    /// The first slot no light's whole-scene views hold.
    next_slot: u32,
    bias: wgpu::Buffer,
    /// The lights of this frame's lookups (`Batch`, and their uniforms: `array<Light>`), and the
    /// lookups' workgroups (`Work`): over the lights' shadows, and over the pixels that may show a
    /// dragged object.
    batch: wgpu::Buffer,
    lights: wgpu::Buffer,
    work: wgpu::Buffer,
    dragged_work: wgpu::Buffer,
    /// Group 0's region (unused: the work lists say which pixels are looked up).
    region: wgpu::Buffer,
    /// The lights [`TemporaryShadows::add`] queued for this frame's lookup.
    pending: Vec<Pending>,
}

/// The lights' layers while objects are dragged: one array layer per light, in the engine's
/// light order.
struct Layers {
    /// What each light's technique wrote over the permanent surface (views of one layer each).
    raw: Vec<VisibilityLayer>,
    raw_texture: wgpu::Texture,
    /// Written by the lookup; its rectangles are copied into the lights' own layers.
    out_texture: wgpu::Texture,
    out_view: wgpu::TextureView,
    lights: Vec<LightId>,
}

struct PermanentViews {
    light: LightId,
    first: u32,
    count: u32,
    /// The views of slots `first..first + count` (empty until they are set) and which of them
    /// are drawn.
    views: Vec<ShadowView>,
    drawn: Vec<bool>,
}

/// A light's part of the frame's lookup.
struct Pending {
    light: LightId,
    /// Its layer in [`Layers`].
    layer: u32,
    uniform: LightUniform,
    /// The pixels its shadows may fall on, as blocks of `GROUP`² ([`Blocks::indices`]), and their
    /// bounds.
    blocks: Vec<u32>,
    rect: [u32; 4],
    /// The blocks that may show a dragged object (among `blocks`).
    objects: Option<Vec<u32>>,
    /// The temporary objects' views, and the whole scene's, with those the dragged objects reach
    /// now (the others may wait for a frame with time to spare).
    views: Vec<ShadowView>,
    whole: Vec<ShadowView>,
    needed: Vec<bool>,
    redraw: bool,
    /// The light and the boxes of its dragged objects that cast: `run` makes `views` again for
    /// the frame's tile.
    source: Light,
    casters: Vec<Aabb>,
}

/// One light of a lookup (`temporary.wgsl`, `struct Entry`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct Entry {
    rect: [u32; 4],
    /// x: the first temporary view, y: how many; z: the first view of the whole scene, w: how many.
    views: [u32; 4],
    /// x: 1 when the whole scene's views are a cube's six faces; y: the light's layer; w: the
    /// light's index in the lights' array.
    flags: [u32; 4],
}

/// Pixels a side of a lookup's workgroup.
const GROUP: u32 = 8;

impl TemporaryShadows {
    pub fn new(shared: &Shared) -> Self {
        let device = &shared.gpu.device;
        Self {
            layers: None,
            generation: 0,
            maps: None,
            atlas: None,
            permanent: Vec::new(),
            next_slot: 0,
            bias: crate::util::uniform_buffer(device, "temporary bias", bytemuck::bytes_of(&bias(1))),
            batch: batch_buffer(device, 1),
            work: work_buffer(device, 1),
            dragged_work: work_buffer(device, 1),
            lights: lights_buffer(device, 1),
            region: crate::util::uniform_buffer(
                device,
                "temporary region",
                bytemuck::bytes_of(&RegionUniform::whole()),
            ),
            pending: Vec::new(),
        }
    }

    /// Compiles what a drag's first frames would (the lookups, the maps' depth passes for closed
    /// and open meshes): with the engine, not in the frame a light first joins a drag, where on a
    /// CPU adapter it took 19.5 ms of recording (`room`, 128 × 96), 17 × a drag step's.
    pub fn warm(shared: &Shared) {
        if !shared.compute {
            return;
        }
        for dragged in [false, true] {
            lookup_pipeline(shared, dragged);
        }
        for cull in [Some(wgpu::Face::Front), None] {
            crate::shadowmap::depth_pipeline(shared, cull, false, false, &RASTER);
        }
    }

    /// Runs a drag's own passes once, over nothing, in the engine's first frame. A CPU adapter
    /// (lavapipe) compiles a pipeline's shader for the state it is used with at its first draw or
    /// dispatch, not when the pipeline is made ([`TemporaryShadows::warm`] makes them): in `room` at
    /// 160 × 120 the first draw of a light's whole-scene view took 12.3 ms of GPU time against 2.8
    /// ms in a second drag, and the lookups 3.5 against 0.8 ms, all in the frame the first light
    /// joined the first drag. Here every caster is drawn into a scratch map with each depth
    /// pipeline it needs, and both lookups are dispatched over no block, with textures of the
    /// shapes a drag binds (a texture's power-of-two sides are part of the compiled state; the
    /// atlas is square with a power-of-two tile, its side a power of two or not). Nothing here
    /// outlives the call, and no work is counted.
    pub fn rehearse(&mut self, ctx: &mut FrameContext<'_>) {
        if !ctx.shared.compute {
            return;
        }
        let shared = ctx.shared;
        let device = &shared.gpu.device;
        let (width, height) = (ctx.surface.width, ctx.surface.height);
        let size = map_size(width, height);
        let whole = light_frusta(ctx.light, &padded(&ctx.live.fit_bounds()), size).views;
        let Some(view) = whole.first() else { return };
        let mut maps = ShadowMapArray::new(shared, size, 1, 1);
        maps.set_views(&ctx.gpu.queue, 0, std::slice::from_ref(view));
        maps.draw_everything_in(0);
        let every = [Mobility::Static, Mobility::Dynamic, Mobility::Temporary];
        maps.render_casters(ctx, 0, 0, &RASTER, &every, true);
        // Buffers of its own: a write to the pass's would land before this frame's real lookups.
        let params = crate::util::uniform_buffer(device, "temporary bias (rehearsal)", bytemuck::bytes_of(&bias(size)));
        let group = lookup_group(shared, &maps, &params, false);
        // No block: every workgroup returns at once.
        let work = work_buffer(device, 1);
        let layers = Layers::new(shared, width, height, &[ctx.light_id]);
        // Group 0's output stands for a light's own layer: a texture of its own.
        let own_layer = Layers::new(shared, width, height, &[ctx.light_id]);
        let group0 = shared.resolve_bind_group_in(ctx.surface, ctx.light_buffer, &own_layer.raw[0], &self.region);
        let own = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("temporary (rehearsal)"),
            layout: &layout(shared),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&layers.raw_view()) },
                wgpu::BindGroupEntry { binding: 1, resource: self.batch.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&ctx.surface.depth) },
                wgpu::BindGroupEntry { binding: 3, resource: self.lights.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&layers.out_view) },
                wgpu::BindGroupEntry { binding: 5, resource: work.as_entire_binding() },
            ],
        });
        let max = device.limits().max_texture_dimension_2d;
        // One tile (its side a power of two), and eight (three to a side: not one).
        let atlases = [Atlas::new(shared, MIN_TILE, 1, max), Atlas::new(shared, MIN_TILE, 8, max)];
        let mut pass = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("temporary (rehearsal)"),
            timestamp_writes: None,
        });
        for dragged in [false, true] {
            pass.set_pipeline(&lookup_pipeline(shared, dragged).1);
            for atlas in &atlases {
                for (i, g) in [&group0, &group, &own, &atlas.group].into_iter().enumerate() {
                    pass.set_bind_group(i as u32, Some(g), &[]);
                }
                pass.dispatch_workgroups(1, 1, 1);
            }
        }
    }

    /// Whether any instance is temporary: the techniques then shadow the permanent surface and this
    /// pass runs, for the shadows the dragged objects cast and those they receive.
    pub fn active(live: &LiveScene) -> bool {
        live.scene().instances.iter().any(|i| i.mobility == Mobility::Temporary)
    }

    /// Makes the lights' layers for a frame of `width × height` shadowing `lights` (in the
    /// engine's order) where they are missing or of another shape. Returns their generation.
    pub fn begin(&mut self, shared: &Shared, width: u32, height: u32, lights: &[LightId]) -> u64 {
        self.pending.clear();
        let fits = self
            .layers
            .as_ref()
            .is_some_and(|l| l.lights == lights && (l.raw_texture.width(), l.raw_texture.height()) == (width, height));
        if !fits {
            self.layers = Some(Layers::new(shared, width, height, lights));
            self.generation += 1;
        }
        self.generation
    }

    /// The layer the `k`-th light's technique writes into while temporary objects exist (the pass
    /// multiplies it into the light's own layer). After [`TemporaryShadows::begin`].
    pub fn raw_layer(&self, k: usize) -> &VisibilityLayer {
        &self.layers.as_ref().expect("begin comes first").raw[k]
    }

    /// Starts the `k`-th light's raw layer as a copy of `from` (its layer before a pick-up, for a
    /// resolve of the pixels the pick-up changed). After [`TemporaryShadows::begin`].
    pub fn seed_raw(&self, encoder: &mut wgpu::CommandEncoder, k: usize, from: &VisibilityLayer) {
        let raw = &self.layers.as_ref().expect("begin comes first").raw_texture;
        encoder.copy_texture_to_texture(
            from.texture.as_image_copy(),
            layer_copy(raw, k as u32, [0, 0]),
            from.texture.size(),
        );
    }

    /// The generation of the `k`-th light's raw layer, while the layers made for the last drag
    /// are kept after it ([`TemporaryShadows::end_drag`]) and `k` is still `light`.
    pub fn kept_raw(&self, k: usize, light: LightId) -> Option<u64> {
        self.layers.as_ref().filter(|l| l.lights.get(k) == Some(&light)).map(|_| self.generation)
    }

    /// Copies the `k`-th light's raw layer into `to` (its own layer, at a release: the light's
    /// technique over the permanent surface, before the released objects' pixels are resolved).
    pub fn seed_from_raw(&self, encoder: &mut wgpu::CommandEncoder, k: usize, to: &VisibilityLayer) {
        let raw = &self.layers.as_ref().expect("kept_raw comes first").raw_texture;
        encoder.copy_texture_to_texture(
            layer_copy(raw, k as u32, [0, 0]),
            to.texture.as_image_copy(),
            to.texture.size(),
        );
    }

    /// The frame of a release: the dragged objects' maps are freed, the lights' raw layers kept
    /// until every light has left the pass ([`TemporaryShadows::release`]): a light whose turn
    /// comes copies its own and resolves only where the released objects are seen or shadowed.
    pub fn end_drag(&mut self) {
        (self.maps, self.atlas, self.next_slot) = (None, None, 0);
        self.permanent.clear();
        self.pending.clear();
    }

    /// The engine's index of the first light [`TemporaryShadows::add`] queued this frame.
    pub fn first_pending(&self) -> Option<usize> {
        self.pending.first().map(|p| p.layer as usize)
    }

    /// Frees the layers and maps once nothing is dragged and every light has left the pass: a drag
    /// holds them, a still scene does not.
    pub fn release(&mut self) {
        self.end_drag();
        self.layers = None;
    }

    /// Texels a side of each dragged object's map in the last drag step (`None` once the drag
    /// ended).
    pub fn tile(&self) -> Option<u32> {
        self.atlas.as_ref().map(|a| a.tile)
    }

    pub fn bytes(&self) -> u64 {
        let layers = self.layers.as_ref().map_or(0, |l| {
            let s = l.raw_texture.size();
            2 * u64::from(s.width) * u64::from(s.height) * u64::from(s.depth_or_array_layers) * 4
        });
        layers + self.maps.as_ref().map_or(0, |m| m.0.bytes()) + self.atlas.as_ref().map_or(0, |a| a.maps.bytes())
    }

    /// Queues the `k`-th light (the context's) for this frame's lookup, which writes into `out`
    /// the light's raw layer × the temporary objects' shadows, where the raw layer is the light's
    /// technique over the permanent surface (what the eye would see without the dragged objects).
    /// Where the eye sees a dragged object instead, the permanent casters' hard shadow stands in
    /// for the raw layer, from maps of the whole scene drawn once (`redraw`: the light or the
    /// permanent scene changed) and kept while the drag goes on. Only the pixels the objects cover
    /// and those their shadows may fall on ([`shadow_silhouette`]) are looked up; the others are
    /// copied from the raw layer now.
    pub fn add(&mut self, ctx: &mut FrameContext<'_>, k: usize, out: &VisibilityLayer, redraw: bool) {
        if redraw {
            // Before any early return: maps drawn for the layer's old state must not outlive it.
            if let Some(p) = self.permanent.iter_mut().find(|p| p.light == ctx.light_id) {
                p.views.clear();
            }
        }
        let size = map_size(ctx.surface.width, ctx.surface.height);
        // The footprints are found with the views of the smallest tile, which hold those of any
        // larger one (their windows are padded by two texels), so the frame's tile, chosen from
        // them, depends on the scene and the camera alone, as a fresh engine's does.
        let tile = MIN_TILE.min(size);
        let mut views: Vec<ShadowView> = Vec::new();
        let mut casters: Vec<Aabb> = Vec::new();
        let mut receivers = ctx.live.fit_bounds();
        // The pixels that show a dragged object (they take the permanent casters' shadow): the
        // silhouettes of its parts' boxes (a chair's seat, back and legs, not its box); then
        // those its shadow may fall on.
        let whole_frame = [0, 0, ctx.surface.width, ctx.surface.height];
        let mut objects = Blocks::new(ctx.surface.width, ctx.surface.height);
        for (i, (inst, state)) in ctx.live.scene().instances.iter().zip(ctx.live.instances()).enumerate() {
            if inst.mobility == Mobility::Temporary {
                receivers = receivers.union(&state.bounds);
                for part in ctx.live.instance_parts(i).filter(|b| !b.is_empty()) {
                    match ctx.surface.camera.pixels_of_body(&ConvexBody::from_aabb(&padded(&part))) {
                        None => objects.add_rect(whole_frame),
                        Some(points) if points.is_empty() => {}
                        Some(points) => objects.add_hull(&points),
                    }
                }
                if inst.casts_shadows {
                    casters.push(padded(&state.bounds));
                    views.extend(light_frusta(ctx.light, &padded(&state.bounds), tile).views);
                }
            }
        }
        let objects = objects.bounds().map(|_| objects.indices());
        let mut blocks = Blocks::new(ctx.surface.width, ctx.surface.height);
        blocks.take(objects.iter().flatten().copied());
        // Every surface lies in one of its instance's part boxes, so a shadow falls only where
        // the body through the object meets one of them: the body clipped by each box is a slab
        // where it crosses the floor or a wall, where the whole scene's box also held the air
        // before them. Past `MAX_RECEIVER_BOXES` boxes, the scene's box (each costs a clipping
        // per view and light, every drag step).
        let instances = ctx.live.instances();
        let mut boxes: Vec<Aabb> = (0..instances.len())
            .flat_map(|i| ctx.live.instance_parts(i))
            .filter(|b| !b.is_empty())
            .map(|b| padded(&b))
            .collect();
        if boxes.len() > MAX_RECEIVER_BOXES {
            boxes = vec![padded(&receivers)];
        }
        'views: for view in &views {
            // Boxes beyond the body through the whole scene's box meet nothing.
            let reach = Aabb::from_points(view_body(view, tile, &padded(&receivers)).points());
            for b in boxes.iter().filter(|b| b.min.cmple(reach.max).all() && reach.min.cmple(b.max).all()) {
                match shadow_silhouette(&ctx.surface.camera, view, tile, b) {
                    Silhouette::Nothing => {}
                    Silhouette::Anywhere => {
                        blocks.add_rect(whole_frame);
                        break 'views;
                    }
                    Silhouette::Hull(points) => blocks.add_hull(&points),
                }
            }
        }
        let rect = blocks.bounds();
        if rect != Some(whole_frame) {
            let raw = &self.layers.as_ref().expect("begin comes first").raw[k];
            let extent = out.texture.size();
            ctx.encoder.copy_texture_to_texture(
                layer_copy(&raw.texture, k as u32, [0, 0]),
                out.texture.as_image_copy(),
                extent,
            );
        }
        let Some(rect) = rect else { return };
        // The whole scene's box, which dragging does not change: the permanent views stay put.
        let whole = light_frusta(ctx.light, &padded(&ctx.live.fit_bounds()), size);
        // A cube's faces are read only for the points they hold: those of the faces no dragged
        // object reaches now are drawn when a frame has time to spare (or when one does), not all
        // in the frame the light joins the drag (a point lamp's six faces of the whole room are
        // 5 ms at 128 × 96 on a CPU adapter).
        let needed = match (whole.cube, ctx.light.position()) {
            (true, Some(eye)) => {
                let mut needed = vec![false; whole.views.len()];
                for (i, inst) in ctx.live.scene().instances.iter().enumerate() {
                    if inst.mobility == Mobility::Temporary {
                        for part in ctx.live.instance_parts(i).filter(|b| !b.is_empty()) {
                            let faces = cube_faces_meeting(eye, &padded(&part));
                            needed.iter_mut().zip(faces).for_each(|(n, f)| *n |= f);
                        }
                    }
                }
                needed
            }
            _ => vec![true; whole.views.len()],
        };
        let whole = whole.views;
        self.pending.push(Pending {
            light: ctx.light_id,
            layer: k as u32,
            uniform: LightUniform::new(ctx.light),
            rect,
            blocks: blocks.indices(),
            objects,
            views,
            whole,
            needed,
            redraw,
            source: ctx.light.clone(),
            casters,
        });
    }

    /// Draws the queued lights' maps and runs their lookup, one dispatch over every light's
    /// footprint, then copies each light's footprint into its layer (`outs[k]`: the `k`-th
    /// light's). `permanent`: the surface the raw layers were resolved over.
    pub fn run(&mut self, ctx: &mut FrameContext<'_>, permanent: &SurfaceInputs, outs: &[&VisibilityLayer]) {
        if self.pending.is_empty() {
            return;
        }
        let shared = ctx.shared;
        let size = map_size(ctx.surface.width, ctx.surface.height);
        // Slots for the lights' views of the whole scene: kept from frame to frame, new ones
        // after the last.
        for p in &self.pending {
            let fits = self.permanent.iter().any(|v| v.light == p.light && v.count == p.whole.len() as u32);
            if !fits {
                self.permanent.retain(|v| v.light != p.light);
                let count = p.whole.len() as u32;
                self.permanent.push(PermanentViews {
                    light: p.light,
                    first: self.next_slot,
                    count,
                    views: Vec::new(),
                    drawn: Vec::new(),
                });
                self.next_slot += count;
            }
        }
        let needed = self.next_slot;
        if self.maps.as_ref().is_none_or(|(m, _)| m.layers < needed || m.size != size) {
            // Room for a power of two of views: a 1024² layer is 4 MiB, and a drag that grows
            // from one view to six reallocates once.
            let capacity = needed.max(1).next_power_of_two();
            let mut maps = ShadowMapArray::new(shared, size, capacity, capacity);
            ctx.gpu.queue.write_buffer(&self.bias, 0, bytemuck::bytes_of(&bias(size)));
            let group = lookup_group(shared, &maps, &self.bias, false);
            // Views drawn at the same size are copied, not drawn again: lights join a drag one a
            // frame under a target, and each growth redrew every light before (`room`'s fourth
            // light's frame drew 15 views of the whole scene, 14 ms at 128 × 96, not 6).
            let old = self.maps.take().filter(|(m, _)| m.size == size);
            for v in &mut self.permanent {
                match &old {
                    Some((old, _)) if !v.views.is_empty() => {
                        for (layer, _) in (v.first..).zip(&v.drawn).filter(|(_, drawn)| **drawn) {
                            ctx.encoder.copy_texture_to_texture(
                                layer_copy(&old.texture, layer, [0, 0]),
                                layer_copy(&maps.texture, layer, [0, 0]),
                                wgpu::Extent3d { width: size, height: size, depth_or_array_layers: 1 },
                            );
                        }
                        maps.set_views(&ctx.gpu.queue, v.first, &v.views);
                    }
                    _ => v.views.clear(),
                }
            }
            self.maps = Some((maps, group));
        }
        let (maps, group) = self.maps.as_mut().expect("made above");
        // The tile the lookups' footprints need, and the views made again for it.
        let tile = tile_for(widest(self.pending.iter().map(|p| p.rect)), size);
        for p in &mut self.pending {
            p.views = p.casters.iter().flat_map(|b| light_frusta(&p.source, b, tile).views).collect();
        }
        let temporary: u32 = self.pending.iter().map(|p| p.views.len() as u32).sum();
        let max = shared.gpu.device.limits().max_texture_dimension_2d;
        if self.atlas.as_ref().is_none_or(|a| a.capacity() < temporary || a.tile != tile) {
            self.atlas = Some(Atlas::new(shared, tile, temporary.max(1).next_power_of_two(), max));
        }
        let atlas = self.atlas.as_mut().expect("made above");
        let mut entries = Vec::with_capacity(self.pending.len());
        // Per block, the entries that look it up, and those whose dragged objects' pixels it holds.
        let (mut work, mut dragged) = (LightsOfBlocks::default(), LightsOfBlocks::default());
        let mut next = 0;
        for (i, p) in self.pending.iter().enumerate() {
            let slots = self.permanent.iter_mut().find(|v| v.light == p.light).expect("given above");
            if p.redraw || slots.views.is_empty() {
                maps.set_views(&ctx.gpu.queue, slots.first, &p.whole);
                slots.views.clone_from(&p.whole);
                slots.drawn = vec![false; p.whole.len()];
            }
            // Views the dragged objects reach are drawn now; the others in a frame whose budget
            // has room (under a target), or now (without one).
            let texels = u64::from(size) * u64::from(size);
            for (j, drawn) in slots.drawn.iter_mut().enumerate() {
                if *drawn {
                    continue;
                }
                if p.needed[j] || ctx.budget.is_unlimited() {
                    count_units(&mut ctx.cache.units, UnitKind::MapView, texels, 1);
                } else if !ctx.take_units(UnitKind::MapView, texels, 1) {
                    continue;
                }
                let slot = slots.first + j as u32;
                maps.render(ctx, slot, slot, &RASTER);
                ctx.cache.work.temporary_views += 1;
                *drawn = true;
            }
            let n = p.views.len() as u32;
            let layers: Vec<u32> = (next..next + n).map(|t| atlas.place(t).0).collect();
            atlas.maps.set_views_in(&ctx.gpu.queue, next, &p.views, &layers);
            ctx.cache.work.temporary_views += n;
            let cube = u32::from(slots.count == 6);
            let views = [next, n, slots.first, slots.count];
            let e = i as u32;
            entries.push(Entry { rect: p.rect, views, flags: [cube, p.layer, 0, e] });
            work.add(e, &p.blocks);
            if let Some(objects) = &p.objects {
                dragged.add(e, objects);
            }
            next += n;
        }
        let per_row = ctx.surface.width.div_ceil(GROUP);
        let (work, dragged) = (work.items(per_row), dragged.items(per_row));
        // Every light's views of the dragged objects, a pass per atlas layer (one in general).
        for layer in 0..atlas.maps.layers {
            let tiles: Vec<(u32, Option<[u32; 4]>)> = (0..temporary)
                .map(|t| (t, atlas.place(t)))
                .filter(|(_, (l, _))| *l == layer)
                .map(|(t, (_, rect))| (t, Some(rect)))
                .collect();
            if !tiles.is_empty() {
                atlas.maps.render_tiles(ctx, layer, &tiles, &RASTER, &[Mobility::Temporary], true);
            }
        }
        let device = &shared.gpu.device;
        let count = entries.len() as u64;
        if self.batch.size() < batch_bytes(count) {
            self.batch = batch_buffer(device, count.next_power_of_two());
            self.lights = lights_buffer(device, count.next_power_of_two());
        }
        for (buffer, items) in [(&mut self.work, &work), (&mut self.dragged_work, &dragged)] {
            if buffer.size() < work_bytes(items.len() as u64) {
                *buffer = work_buffer(device, (items.len() as u64).next_power_of_two());
            }
        }
        let queue = &ctx.gpu.queue;
        queue.write_buffer(&self.batch, 0, bytemuck::bytes_of(&[entries.len() as u32, 0, 0, 0]));
        queue.write_buffer(&self.batch, 16, bytemuck::cast_slice(&entries));
        for (buffer, items) in [(&self.work, &work), (&self.dragged_work, &dragged)] {
            queue.write_buffer(buffer, 0, bytemuck::bytes_of(&[items.len() as u32, 0, 0, 0]));
            queue.write_buffer(buffer, 16, bytemuck::cast_slice(items));
        }
        let uniforms: Vec<LightUniform> = self.pending.iter().map(|p| p.uniform).collect();
        queue.write_buffer(&self.lights, 0, bytemuck::cast_slice(&uniforms));
        let layers = self.layers.as_ref().expect("begin comes first");
        let own = |work: &wgpu::Buffer| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("temporary"),
                layout: &layout(shared),
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(&layers.raw_view()),
                    },
                    wgpu::BindGroupEntry { binding: 1, resource: self.batch.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&permanent.depth) },
                    wgpu::BindGroupEntry { binding: 3, resource: self.lights.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&layers.out_view) },
                    wgpu::BindGroupEntry { binding: 5, resource: work.as_entire_binding() },
                ],
            })
        };
        // Group 0's light and output are the first light's: the lookups read their lights from
        // group 2 and write the array.
        let first = self.pending[0].layer as usize;
        let group0 = shared.resolve_bind_group_in(ctx.surface, ctx.light_buffer, outs[first], &self.region);
        // Every light's shadow footprint, then the pixels that show a dragged object again, with
        // the permanent casters' shadow (a separate pipeline: a CPU adapter runs every branch of
        // a shader, taken or not, so the common case must not carry the rare one).
        // Pixels of a light's footprint outside its blocks keep the technique's visibility.
        for p in &self.pending {
            let [x, y, w, h] = p.rect;
            ctx.encoder.copy_texture_to_texture(
                layer_copy(&layers.raw_texture, p.layer, [x, y]),
                layer_copy(&layers.out_texture, p.layer, [x, y]),
                wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            );
        }
        // Both lookups in one pass (on a CPU adapter a pass costs about what a dispatch over a
        // few dozen blocks does).
        let lookups: Vec<(u32, wgpu::BindGroup, wgpu::ComputePipeline)> =
            [(&self.work, work.len(), false), (&self.dragged_work, dragged.len(), true)]
                .into_iter()
                .filter(|(_, blocks, _)| *blocks > 0)
                .map(|(items, blocks, dragged)| (blocks as u32, own(items), lookup_pipeline(shared, dragged).1))
                .collect();
        if !lookups.is_empty() {
            let timestamps = ctx.timer.compute_pass(device, PassKind::Visibility);
            let mut pass = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("temporary"),
                timestamp_writes: timestamps,
            });
            let wide = device.limits().max_compute_workgroups_per_dimension;
            for (blocks, own, pipeline) in &lookups {
                pass.set_pipeline(pipeline);
                for (i, g) in [&group0, group, own, &atlas.group].into_iter().enumerate() {
                    pass.set_bind_group(i as u32, Some(g), &[]);
                }
                pass.dispatch_workgroups((*blocks).min(wide), blocks.div_ceil(wide), 1);
            }
        }
        for p in &self.pending {
            let [x, y, w, h] = p.rect;
            ctx.encoder.copy_texture_to_texture(
                layer_copy(&layers.out_texture, p.layer, [x, y]),
                wgpu::TexelCopyTextureInfo {
                    texture: &outs[p.layer as usize].texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d { x, y, z: 0 },
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            );
        }
        self.pending.clear();
    }
}

/// The lookup's pipeline: over the lights' shadow footprints, or (`dragged`) over the pixels that
/// may show a dragged object.
fn lookup_pipeline(shared: &Shared, dragged: bool) -> (&'static str, wgpu::ComputePipeline) {
    let key = if dragged { "temporary (dragged objects)" } else { "temporary" };
    let pipeline = shared.resolve_pipeline_with(
        key,
        include_str!("temporary.wgsl"),
        "main",
        &[&lookup_layout(shared), &layout(shared), &lookup_layout(shared)],
        &[],
        if dragged { &["DRAGGED"] } else { &[] },
    );
    (key, pipeline)
}

/// The dragged objects' maps of every light: tiles of `tile`² texels, `per_side` to a side in
/// each layer of an array (one layer unless the device's largest texture is too small).
struct Atlas {
    maps: ShadowMapArray,
    group: wgpu::BindGroup,
    tile: u32,
    per_side: u32,
}

impl Atlas {
    /// Room for `capacity` tiles of `tile`² in layers of at most `max` texels a side, with the
    /// lookup's parameters (its tile and layout) in a buffer of its own.
    fn new(shared: &Shared, tile: u32, capacity: u32, max: u32) -> Self {
        let (per_side, layers) = atlas_shape(tile, capacity, max);
        // A view slot for every tile: `capacity` below counts them.
        let maps = ShadowMapArray::new(shared, per_side * tile, layers, layers * per_side * per_side);
        let values = Vec4::new(NORMAL_OFFSET, 0.0, tile as f32, per_side as f32);
        let params = BiasUniform { values, mode: Vec4::ZERO };
        let bias = crate::util::uniform_buffer(&shared.gpu.device, "temporary atlas bias", bytemuck::bytes_of(&params));
        let group = lookup_group(shared, &maps, &bias, false);
        Self { maps, group, tile, per_side }
    }

    fn capacity(&self) -> u32 {
        self.maps.capacity
    }

    /// The layer and viewport of tile `t`.
    fn place(&self, t: u32) -> (u32, [u32; 4]) {
        tile_place(t, self.tile, self.per_side)
    }
}

/// Tiles to a side and layers of an atlas of `capacity` tiles of `tile`² texels whose layers are
/// at most `max` texels a side: square layers, as few as fit.
fn atlas_shape(tile: u32, capacity: u32, max: u32) -> (u32, u32) {
    let fit = (max / tile.max(1)).max(1);
    let mut per_side = 1;
    while per_side * per_side < capacity && per_side < fit {
        per_side += 1;
    }
    (per_side, capacity.max(1).div_ceil(per_side * per_side))
}

/// The layer and viewport of tile `t` in an atlas of `per_side` tiles of `tile`² to a side: row by
/// row, then the next layer (`temporary.wgsl`'s `atlas_depth`).
fn tile_place(t: u32, tile: u32, per_side: u32) -> (u32, [u32; 4]) {
    let per_layer = per_side * per_side;
    let i = t % per_layer;
    ((t / per_layer), [(i % per_side) * tile, (i / per_side) * tile, tile, tile])
}

impl Layers {
    fn new(shared: &Shared, width: u32, height: u32, lights: &[LightId]) -> Self {
        let device = &shared.gpu.device;
        let array = |label, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width, height, depth_or_array_layers: lights.len().max(1) as u32 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: VISIBILITY_FORMAT,
                usage: usage
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            })
        };
        let raw_texture = array("visibility before dragging", wgpu::TextureUsages::STORAGE_BINDING);
        let out_texture = array("visibility with dragged objects", wgpu::TextureUsages::STORAGE_BINDING);
        let raw = (0..lights.len() as u32)
            .map(|k| VisibilityLayer {
                texture: raw_texture.clone(),
                view: raw_texture.create_view(&wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: k,
                    array_layer_count: Some(1),
                    ..Default::default()
                }),
            })
            .collect();
        let out_view = out_texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        Self { raw, raw_texture, out_texture, out_view, lights: lights.to_vec() }
    }

    fn raw_view(&self) -> wgpu::TextureView {
        self.raw_texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        })
    }
}

/// Layer `layer` of an array texture at `origin`, for a copy.
fn layer_copy(texture: &wgpu::Texture, layer: u32, origin: [u32; 2]) -> wgpu::TexelCopyTextureInfo<'_> {
    wgpu::TexelCopyTextureInfo {
        texture,
        mip_level: 0,
        origin: wgpu::Origin3d { x: origin[0], y: origin[1], z: layer },
        aspect: wgpu::TextureAspect::All,
    }
}

/// The lookups' bias for maps of `size` texels: `hard`'s normal offset.
fn bias(size: u32) -> BiasUniform {
    BiasUniform { values: Vec4::new(NORMAL_OFFSET, 0.0, size as f32, 0.0), mode: Vec4::ZERO }
}

/// Bytes of a `Work` list of `count` workgroups: its count, then the workgroups.
fn work_bytes(count: u64) -> u64 {
    16 + count * 16
}

/// The lights (entries of a lookup) each 8 × 8 block is looked up for: one workgroup per block
/// and 32 entries, which reads each pixel's surface once for all of them.
#[derive(Default)]
struct LightsOfBlocks {
    /// Block index → a bit per entry, 32 to a word.
    masks: std::collections::BTreeMap<u32, Vec<u32>>,
}

impl LightsOfBlocks {
    fn add(&mut self, entry: u32, blocks: &[u32]) {
        let (word, bit) = ((entry / 32) as usize, 1u32 << (entry % 32));
        for &b in blocks {
            let words = self.masks.entry(b).or_default();
            if words.len() <= word {
                words.resize(word + 1, 0);
            }
            words[word] |= bit;
        }
    }

    /// The workgroups (`temporary.wgsl`, `struct Work`): the entries' bits, the block's position
    /// (x | y << 16, in blocks), the first entry of the bits; in block order.
    fn items(&self, per_row: u32) -> Vec<[u32; 4]> {
        let mut items = Vec::with_capacity(self.masks.len());
        for (&b, words) in &self.masks {
            for (w, &mask) in words.iter().enumerate().filter(|(_, m)| **m != 0) {
                items.push([mask, (b % per_row) | ((b / per_row) << 16), 32 * w as u32, 0]);
            }
        }
        items
    }
}

fn work_buffer(device: &wgpu::Device, count: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("temporary work"),
        size: work_bytes(count.max(1)),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Bytes of a `Batch` of `count` lights: its count, then the entries.
fn batch_bytes(count: u64) -> u64 {
    16 + count * std::mem::size_of::<Entry>() as u64
}

fn batch_buffer(device: &wgpu::Device, count: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("temporary batch"),
        size: batch_bytes(count),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

fn lights_buffer(device: &wgpu::Device, count: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("temporary lights"),
        size: count * std::mem::size_of::<LightUniform>() as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Where on screen a temporary object's map `view` (of `size` texels) may darken something.
#[derive(Debug)]
enum Silhouette {
    Nothing,
    Anywhere,
    /// Pixel positions whose convex hull it is.
    Hull(Vec<Vec2>),
}

/// The pixels a temporary object's map `view` (of `size` texels) may darken: the receivers' box
/// (every instance's bounds) cut by the view's side planes, two texels wider than the window
/// (the lookup's normal offset moves points by 0.3 texels), and by its near plane, projected. A
/// pixel outside sees a point the lookup skips (outside the window) or finds lit: a point
/// nearer the light than the near plane (fitted just before the object, `light_frusta`) has
/// depth above 1, clamped to 1, as close as anything stored (reversed Z). So the raw
/// visibility stands there, and the space between the light and the object, often a large
/// part of the screen, is not looked up. What is left is cut by the eye's frustum before it is
/// projected: the sun's prism through a chair in `room` runs past the camera, and its corners
/// behind the eye made the whole screen the footprint (at 640 × 480 that light's lookup fell from
/// 307 200 pixels to 161 759, the drag frame ÷ still frame from 2.15 to 1.97; 128 × 96: 1.89 and
/// 1.93 → 1.83 and 1.81, one run each alternated). The silhouette, not its bounding rectangle,
/// is what [`Blocks`] covers: a shadow's wedge across the floor fills a fraction of its box.
fn shadow_silhouette(camera: &CameraUniform, view: &ShadowView, size: u32, receivers: &Aabb) -> Silhouette {
    let body = view_body(view, size, receivers);
    if body.is_empty() {
        return Silhouette::Nothing;
    }
    match camera.pixels_of_body(&body) {
        None => Silhouette::Anywhere,
        Some(points) if points.is_empty() => Silhouette::Nothing,
        Some(points) => Silhouette::Hull(points),
    }
}

/// The pixels whose visibility from `light` may change when the objects with bounds `boxes` leave
/// the permanent scene (a pick-up), for a technique that [`resolves_locally`]: those the objects
/// covered, and those their shadow may fall on within `scene` (every instance's bounds) from any
/// point of the emitter. A point shadowed from an emitter point `e` within `r` of the emitter's
/// centre `c` is `p = e + t (b − e)` with `b` in the box and `t ≥ 1`, which is `c + t (b' − c)`
/// with `b' = b − (1 − 1/t)(e − c)`, within `r` of the box: so the shadow of the box grown by
/// `r` from the centre holds it (the sun's disk: grown by the scene's diagonal × tan of its
/// angular radius). A spot's or a rect light's cone is not taken: a technique may write
/// beyond where its light reaches. `size`: the views' texels, which widen them by two.
///
/// [`resolves_locally`]: crate::technique::ShadowTechnique::resolves_locally
pub fn pick_up_footprint(camera: &CameraUniform, light: &Light, boxes: &[Aabb], scene: &Aabb, size: u32) -> Footprint {
    let reach = padded(scene);
    let grow = match light.kind {
        LightKind::Point { radius, .. } | LightKind::Spot { radius, .. } => radius,
        LightKind::Rect { width, height, .. } => 0.5 * width.hypot(height),
        LightKind::Directional { angular_radius, .. } => scene.diagonal() * angular_radius.min(1.5).tan(),
    };
    let mut footprint = Footprint::Nothing;
    for b in boxes.iter().filter(|b| !b.is_empty()) {
        footprint = footprint.union(camera.footprint(&padded(b)));
        let grown = padded(&Aabb::new(b.min - glam::Vec3::splat(grow), b.max + glam::Vec3::splat(grow)));
        let frusta = match (light.kind, light.position()) {
            (LightKind::Directional { direction, .. }, _) => directional_frustum(direction, &grown, size),
            (_, Some(position)) => point_frusta(position, &grown, None, size),
            (_, None) => return Footprint::Whole,
        };
        for view in &frusta.views {
            let body = view_body(view, size, &reach);
            if !body.is_empty() {
                footprint = footprint.union(camera.footprint_of_body(&body));
            }
        }
        if footprint == Footprint::Whole {
            break;
        }
    }
    footprint
}

/// The box `b` cut by the side planes of a temporary object's map `view` (of `size` texels), two
/// texels wider than its window, and by its near plane a hair beyond for round-off (reversed Z).
fn view_body(view: &ShadowView, size: u32, b: &Aabb) -> ConvexBody {
    let (widen, near) = (4.0 / size as f32, 1e-4);
    if box_misses_view(b, &view.view_projection, widen, near) {
        return ConvexBody::default();
    }
    ConvexBody::from_aabb(b).clip_to_view(&view.view_projection, widen, near)
}

/// The blocks of `GROUP`² pixels of an output a light's lookup covers (a workgroup each).
struct Blocks {
    width: u32,
    height: u32,
    per_row: u32,
    taken: Vec<bool>,
}

/// Pixels by which a block is widened before it is tested against a silhouette: the projected
/// corners' round-off, and the rasteriser's (as `CameraUniform::footprint`'s pixel).
const SILHOUETTE_MARGIN: f32 = 1.5;

impl Blocks {
    fn new(width: u32, height: u32) -> Self {
        let per_row = width.div_ceil(GROUP);
        Self { width, height, per_row, taken: vec![false; (per_row * height.div_ceil(GROUP)) as usize] }
    }

    /// Takes the blocks of these indices ([`Blocks::indices`] of an output of the same size).
    fn take(&mut self, indices: impl IntoIterator<Item = u32>) {
        for i in indices {
            if let Some(t) = self.taken.get_mut(i as usize) {
                *t = true;
            }
        }
    }

    /// Every block that holds a pixel of `rect` (x, y, width, height).
    fn add_rect(&mut self, rect: [u32; 4]) {
        let [x, y, w, h] = rect;
        let (x1, y1) = ((x + w).min(self.width), (y + h).min(self.height));
        if x1 <= x || y1 <= y {
            return;
        }
        for by in y / GROUP..y1.div_ceil(GROUP) {
            for bx in x / GROUP..x1.div_ceil(GROUP) {
                self.taken[(by * self.per_row + bx) as usize] = true;
            }
        }
    }

    /// Every block that meets the convex hull of `points` (pixel positions), widened by
    /// [`SILHOUETTE_MARGIN`].
    fn add_hull(&mut self, points: &[Vec2]) {
        let hull = convex_hull(points);
        let m = SILHOUETTE_MARGIN;
        let (lo, hi) = hull
            .iter()
            .fold((Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let (w, h) = (self.width as f32, self.height as f32);
        let (x0, y0) = ((lo.x - m).clamp(0.0, w), (lo.y - m).clamp(0.0, h));
        let (x1, y1) = ((hi.x + m).clamp(0.0, w), (hi.y + m).clamp(0.0, h));
        if x1 <= x0 || y1 <= y0 {
            return;
        }
        let g = GROUP as f32;
        for by in (y0 / g) as u32..((y1 / g).ceil() as u32).min(self.height.div_ceil(GROUP)) {
            for bx in (x0 / g) as u32..((x1 / g).ceil() as u32).min(self.per_row) {
                let lo = Vec2::new(bx as f32 * g - m, by as f32 * g - m);
                let hi = lo + Vec2::splat(g + 2.0 * m);
                if square_meets_hull(lo, hi, &hull) {
                    self.taken[(by * self.per_row + bx) as usize] = true;
                }
            }
        }
    }

    /// The blocks taken, as `bx + by · per_row`, in order.
    fn indices(&self) -> Vec<u32> {
        (0..self.taken.len() as u32).filter(|&i| self.taken[i as usize]).collect()
    }

    /// The pixels of the blocks taken, bounded (`None`: none), within the output.
    fn bounds(&self) -> Option<[u32; 4]> {
        let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
        for i in self.indices() {
            let (bx, by) = (i % self.per_row, i / self.per_row);
            (x0, y0) = (x0.min(bx * GROUP), y0.min(by * GROUP));
            (x1, y1) = (x1.max((bx + 1) * GROUP), y1.max((by + 1) * GROUP));
        }
        let (x1, y1) = (x1.min(self.width), y1.min(self.height));
        (x1 > x0 && y1 > y0).then(|| [x0, y0, x1 - x0, y1 - y0])
    }
}

/// The convex hull of `points` (Andrew's monotone chain), counter-clockwise in a y-up frame; a
/// point or a segment where they are collinear.
fn convex_hull(points: &[Vec2]) -> Vec<Vec2> {
    let mut p: Vec<Vec2> = points.iter().copied().filter(|q| q.is_finite()).collect();
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<Vec2> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &Vec2>> =
            if pass == 0 { Box::new(p.iter()) } else { Box::new(p.iter().rev()) };
        for &q in iter {
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0 {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull
}

/// Whether the axis-aligned square `lo..hi` meets the convex polygon `hull` (from
/// [`convex_hull`], or the point or segment it gives). Separating axes: the square's (the hull's
/// bounds) and each hull edge's normal.
fn square_meets_hull(lo: Vec2, hi: Vec2, hull: &[Vec2]) -> bool {
    let (hlo, hhi) = hull
        .iter()
        .fold((Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)), |(a, b), p| (a.min(*p), b.max(*p)));
    if hhi.x < lo.x || hlo.x > hi.x || hhi.y < lo.y || hlo.y > hi.y {
        return false;
    }
    let corners = [lo, Vec2::new(hi.x, lo.y), hi, Vec2::new(lo.x, hi.y)];
    if hull.len() < 3 {
        // A point (the bounds said it all) or a segment: the corners not all on one side.
        return hull.len() < 2 || {
            let (a, b) = (hull[0], hull[1]);
            let sides = corners.map(|c| (b - a).perp_dot(c - a));
            !(sides.iter().all(|&d| d > 0.0) || sides.iter().all(|&d| d < 0.0))
        };
    }
    (0..hull.len()).all(|i| {
        let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
        // Counter-clockwise: the inside is on the left of each edge.
        corners.iter().any(|&c| (b - a).perp_dot(c - a) >= 0.0)
    })
}

/// An object's bounds with a little room, so that its silhouette never touches the map's border.
fn padded(b: &Aabb) -> Aabb {
    let e = glam::Vec3::splat(0.02 * b.diagonal().max(1e-4));
    Aabb::new(b.min - e, b.max + e)
}

fn layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("temporary", || {
        let compute = wgpu::ShaderStages::COMPUTE;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("temporary"),
            entries: &[
                texture_entry(0, compute, UNFILTERED, wgpu::TextureViewDimension::D2Array),
                storage_entry(1, compute, true),
                texture_entry(2, compute, UNFILTERED, wgpu::TextureViewDimension::D2),
                storage_entry(3, compute, true),
                storage_entry(5, compute, true),
                wgpu::BindGroupLayoutEntry {
                    binding: 4,
                    visibility: compute,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: VISIBILITY_FORMAT,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                    },
                    count: None,
                },
            ],
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Footprint;
    use glam::Vec3;
    use shadowlab_core::{Light, LightKind, View};

    fn camera() -> CameraUniform {
        // Looking down the -z axis at a 10 m floor strip from the side.
        let view = View {
            name: "side".into(),
            position: Vec3::new(0.0, 2.0, 12.0),
            target: Vec3::new(0.0, 2.0, 0.0),
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
            near: 0.1,
            far: 100.0,
        };
        CameraUniform::from_view(&view, 200, 200)
    }

    /// A lamp high on the left, a small object below and right of it: the object's shadow falls
    /// further right and down. The footprint covers where the shadow falls and leaves out the
    /// space between the lamp and the object, which the side planes alone keep.
    /// The blocks a silhouette takes hold every pixel whose square meets it (brute force over
    /// random convex polygons, some off screen), and none farther than a block and the margin.
    #[test]
    fn blocks_cover_exactly_the_pixels_a_silhouette_meets() {
        let (width, height) = (100, 60);
        // Nothing taken: no bounds (and no underflow computing them).
        assert_eq!(Blocks::new(width, height).bounds(), None);
        let mut seed = 7u64;
        let mut random = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        for case in 0..300 {
            let centre = Vec2::new(random() * 140.0 - 20.0, random() * 100.0 - 20.0);
            let n = 1 + (random() * 9.0) as usize;
            let points: Vec<Vec2> = (0..n)
                .map(|_| centre + Vec2::new(random() - 0.5, random() - 0.5) * Vec2::new(80.0, 50.0) * random())
                .collect();
            let hull = convex_hull(&points);
            let mut blocks = Blocks::new(width, height);
            blocks.add_hull(&points);
            // The distance from a point to the hull (0 inside).
            let distance = |q: Vec2| -> f32 {
                if hull.len() >= 3
                    && (0..hull.len()).all(|i| (hull[(i + 1) % hull.len()] - hull[i]).perp_dot(q - hull[i]) >= 0.0)
                {
                    return 0.0;
                }
                (0..hull.len())
                    .map(|i| {
                        let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
                        let t = ((q - a).dot(b - a) / (b - a).length_squared().max(1e-12)).clamp(0.0, 1.0);
                        q.distance(a + (b - a) * t)
                    })
                    .fold(f32::INFINITY, f32::min)
            };
            for y in 0..height {
                for x in 0..width {
                    let taken = blocks.taken[((y / GROUP) * blocks.per_row + x / GROUP) as usize];
                    let centre = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                    // A pixel's square meets the hull where its centre is within half a diagonal.
                    if distance(centre) <= 0.5 {
                        assert!(taken, "case {case}: pixel ({x}, {y}) meets {hull:?} but its block is not taken");
                    }
                }
            }
            for by in 0..height.div_ceil(GROUP) {
                for bx in 0..blocks.per_row {
                    let centre = Vec2::new((bx * GROUP) as f32 + 4.0, (by * GROUP) as f32 + 4.0);
                    // A block's centre is within 4√2 of its pixels; the margin widens it.
                    if distance(centre) > 4.0 * std::f32::consts::SQRT_2 + SILHOUETTE_MARGIN * 1.5 {
                        let i = (by * blocks.per_row + bx) as usize;
                        assert!(!blocks.taken[i], "case {case}: block ({bx}, {by}) is far from {hull:?}");
                    }
                }
            }
        }
    }

    /// Every (block, light) pair given is in exactly one workgroup, at the block's position, and
    /// no other: lights past the 32nd in workgroups of their own word.
    #[test]
    fn each_block_and_light_is_looked_up_once() {
        let mut lights = LightsOfBlocks::default();
        let per_row = 7;
        let mut given = std::collections::BTreeSet::new();
        for entry in 0..70u32 {
            let blocks: Vec<u32> = (0..40).filter(|b| (b * 7 + entry * 3) % 5 < 2).collect();
            lights.add(entry, &blocks);
            given.extend(blocks.iter().map(|&b| (b, entry)));
        }
        let mut found = std::collections::BTreeSet::new();
        for [mask, position, first, _] in lights.items(per_row) {
            assert!(mask != 0 && first % 32 == 0);
            let b = (position & 0xffff) + (position >> 16) * per_row;
            for bit in (0..32).filter(|bit| mask & (1 << bit) != 0) {
                assert!(found.insert((b, first + bit)), "block {b}, light {} twice", first + bit);
            }
        }
        assert_eq!(found, given);
    }

    /// The blocks taken for a box's silhouette (`pixels_of_body`, as for a dragged object's
    /// parts) hold every pixel a point inside the box projects to: random boxes in front of the
    /// eye, beside it, straddling its plane and behind it.
    #[test]
    fn a_box_silhouette_holds_every_pixel_its_points_reach() {
        let c = camera();
        let (width, height) = (200u32, 200u32);
        let mut seed = 11u64;
        let mut random = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let to_clip = c.inv_view_proj_rel.inverse();
        let eye = c.position.truncate();
        let (mut seen, mut empty) = (0, 0);
        for case in 0..400 {
            // Centres from 6 m behind the eye (z = 12) to 18 m ahead of it.
            let centre = Vec3::new(random() * 16.0 - 8.0, random() * 8.0 - 2.0, random() * 24.0 - 6.0);
            let half = Vec3::new(random(), random(), random()) * 2.0 + Vec3::splat(0.01);
            let b = Aabb::new(centre - half, centre + half);
            let mut blocks = Blocks::new(width, height);
            match c.pixels_of_body(&ConvexBody::from_aabb(&b)) {
                None => blocks.add_rect([0, 0, width, height]),
                Some(points) if points.is_empty() => empty += 1,
                Some(points) => blocks.add_hull(&points),
            }
            let taken = blocks.indices();
            for _ in 0..200 {
                let p = b.min + (b.max - b.min) * Vec3::new(random(), random(), random());
                let clip = to_clip * (p - eye).extend(1.0);
                if clip.w <= 0.01 {
                    continue;
                }
                let ndc = Vec2::new(clip.x, clip.y) / clip.w;
                let pixel = Vec2::new((ndc.x + 1.0) * 0.5 * width as f32, (1.0 - ndc.y) * 0.5 * height as f32);
                if pixel.x < 0.0 || pixel.y < 0.0 || pixel.x >= width as f32 || pixel.y >= height as f32 {
                    continue;
                }
                seen += 1;
                let block = (pixel.x as u32 / GROUP) + (pixel.y as u32 / GROUP) * width.div_ceil(GROUP);
                assert!(taken.contains(&block), "case {case}: {p} at pixel {pixel} is in no block of {b:?}");
            }
        }
        // The test says something: many points on screen, and some boxes wholly out of sight.
        // Measured: 37 631 points seen, 163 boxes out of sight; bounds about a quarter and an
        // eighth of those.
        assert!(seen > 10_000 && empty > 20, "{seen} points seen, {empty} boxes out of sight");
    }

    /// A pick-up's footprint holds every pixel that sees a point of the scene which the box
    /// shadows from some point of an area emitter (a 1 m sphere, a 2 × 1 m rect, a 6° sun), or the
    /// box itself: random boxes, emitter points, points of the box and distances behind it. Fails
    /// with the box not grown by the emitter (points of the penumbra outside), and with the shadow
    /// left out.
    #[test]
    fn a_pick_up_footprint_holds_every_pixel_an_area_lights_shadow_reaches() {
        let c = camera();
        let (width, height) = (200u32, 200u32);
        let scene = Aabb::new(Vec3::new(-10.0, 0.0, -12.0), Vec3::new(10.0, 6.0, 4.0));
        let mut seed = 5u64;
        let mut random = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let lights = [
            Light::new(
                "sphere",
                LightKind::Point { position: Vec3::new(-3.0, 5.0, -3.0), radius: 1.0 },
                Vec3::ONE,
                1.0,
            ),
            Light::new(
                "rect",
                LightKind::Rect {
                    position: Vec3::new(2.0, 5.5, -4.0),
                    direction: Vec3::NEG_Y,
                    tangent: Vec3::X,
                    width: 2.0,
                    height: 1.0,
                },
                Vec3::ONE,
                1.0,
            ),
            Light::new(
                "sun",
                LightKind::Directional { direction: Vec3::new(0.4, -1.0, -0.2).normalize(), angular_radius: 0.05 },
                Vec3::ONE,
                1.0,
            ),
        ];
        let to_clip = c.inv_view_proj_rel.inverse();
        let eye = c.position.truncate();
        let pixel_of = |p: Vec3| {
            let clip = to_clip * (p - eye).extend(1.0);
            if clip.w <= 0.01 {
                return None;
            }
            let ndc = Vec2::new(clip.x, clip.y) / clip.w;
            let px = Vec2::new((ndc.x + 1.0) * 0.5 * width as f32, (1.0 - ndc.y) * 0.5 * height as f32);
            (px.x >= 0.0 && px.y >= 0.0 && px.x < width as f32 && px.y < height as f32).then_some(px)
        };
        let (mut seen, mut rects) = (0, 0);
        for case in 0..300 {
            let light = &lights[case % lights.len()];
            let centre = Vec3::new(random() * 12.0 - 6.0, random() * 2.5 + 0.3, random() * 10.0 - 9.0);
            let half = Vec3::new(random(), random(), random()) * 0.4 + Vec3::splat(0.05);
            let b = Aabb::new(centre - half, centre + half);
            let footprint = pick_up_footprint(&c, light, &[b], &scene, 256);
            let inside = |px: Vec2| match footprint {
                Footprint::Whole => true,
                Footprint::Nothing => false,
                Footprint::Rect([x, y, w, h]) => {
                    px.x >= x as f32 && px.y >= y as f32 && px.x < (x + w) as f32 && px.y < (y + h) as f32
                }
            };
            rects += usize::from(matches!(footprint, Footprint::Rect(_)));
            for _ in 0..300 {
                let on_box = b.min + (b.max - b.min) * Vec3::new(random(), random(), random());
                let p = match light.kind {
                    LightKind::Point { position, radius } => {
                        let u = Vec3::new(random() - 0.5, random() - 0.5, random() - 0.5).normalize_or(Vec3::X);
                        let e = position + u * radius * random().cbrt();
                        e + (on_box - e) * (1.0 + 8.0 * random())
                    }
                    LightKind::Rect { position, tangent, width, height, direction } => {
                        let e = position
                            + tangent * (random() - 0.5) * width
                            + direction.cross(tangent) * (random() - 0.5) * height;
                        e + (on_box - e) * (1.0 + 8.0 * random())
                    }
                    LightKind::Directional { direction, angular_radius } => {
                        let (u, v) = shadowlab_core::lightspace::frame(direction);
                        let a = random() * std::f32::consts::TAU;
                        let tilt = angular_radius * random().sqrt();
                        let d = (direction + (u * a.cos() + v * a.sin()) * tilt.tan()).normalize();
                        on_box + d * 20.0 * random()
                    }
                    LightKind::Spot { .. } => unreachable!(),
                };
                for q in [on_box, p] {
                    if !scene.contains(q) {
                        continue;
                    }
                    if let Some(px) = pixel_of(q) {
                        seen += 1;
                        assert!(inside(px), "case {case} ({}): {q} at {px} outside {footprint:?}", light.name);
                    }
                }
            }
        }
        // The test says something: many points on screen, and most footprints short of the whole
        // frame. Measured: 95 820 points, 300 rectangles of 300; bounds about a fifth and a third.
        assert!(seen > 20_000 && rects > 100, "{seen} points seen, {rects} rectangles");
    }

    /// A tile gives at least two texels per pixel across the widest footprint, at most twice
    /// that (a power of two), never below `MIN_TILE` or above the output's own size.
    #[test]
    fn a_tile_follows_the_widest_footprint() {
        for full in [256, 512, 1024] {
            for w in 0..1200 {
                let rects = [[3, 5, w / 3, w / 2], [0, 0, w, w / 4], [9, 9, 0, 0]];
                assert_eq!(widest(rects), w);
                let t = tile_for(w, full);
                assert!(t.is_power_of_two() && (MIN_TILE..=full).contains(&t), "{t} for {w} px, {full}");
                assert!(t >= (2 * w).min(full), "{t} texels for {w} px");
                assert!(t == MIN_TILE || t < 4 * w, "{t} texels for {w} px: a smaller tile holds two a pixel");
            }
        }
        // The chair's shadows in `room` at 160 × 120 (88–112 px wide over the `drag` timeline,
        // measured): 256², not the output's 512².
        assert_eq!(tile_for(112, map_size(160, 120)), 256);
        assert_eq!(tile_for(0, 1024), MIN_TILE);
        assert_eq!(tile_for(600, 1024), 1024);
        assert_eq!(widest(std::iter::empty()), 0);
    }

    /// Tiles never overlap, stay within their layer, and the layers are as few as the largest
    /// texture allows.
    #[test]
    fn atlas_tiles_are_disjoint_and_within_their_layer() {
        for (tile, capacity, max) in
            [(256, 1, 8192), (256, 4, 8192), (256, 8, 8192), (1024, 64, 8192), (1024, 48, 2048)]
        {
            let (per_side, layers) = atlas_shape(tile, capacity, max);
            assert!(per_side * tile <= max.max(tile), "{per_side} tiles of {tile} exceed {max}");
            assert!(layers * per_side * per_side >= capacity, "room for {capacity}");
            let fewest = capacity.div_ceil((max / tile).pow(2));
            assert_eq!(layers, fewest.max(1), "layers for {capacity} tiles of {tile} within {max}");
            let mut taken = std::collections::HashSet::new();
            for t in 0..capacity {
                let (layer, [x, y, w, h]) = tile_place(t, tile, per_side);
                assert!(layer < layers && x + w <= per_side * tile && y + h <= per_side * tile);
                assert!(taken.insert((layer, x, y)), "tile {t} overlaps another");
            }
        }
        // Four lights' single views at 128 × 96: one 512² layer.
        assert_eq!(atlas_shape(256, 4, 8192), (2, 1));
    }

    #[test]
    fn the_footprint_leaves_out_the_space_between_light_and_object() {
        let kind = LightKind::Point { position: Vec3::new(-4.0, 6.0, 0.0), radius: 0.0 };
        let light = Light::new("lamp", kind, Vec3::ONE, 1.0);
        let object = Aabb::new(Vec3::new(-1.2, 2.8, -0.2), Vec3::new(-0.8, 3.2, 0.2));
        let receivers = Aabb::new(Vec3::new(-6.0, 0.0, -1.0), Vec3::new(6.0, 7.0, 1.0));
        let size = 256;
        let views = light_frusta(&light, &object, size).views;
        assert_eq!(views.len(), 1, "a small object far from the lamp: one frustum");
        let cam = camera();
        let Silhouette::Hull(hull) = shadow_silhouette(&cam, &views[0], size, &receivers) else {
            panic!("the shadow is on screen");
        };
        let mut blocks = Blocks::new(200, 200);
        blocks.add_hull(&hull);
        let rect = blocks.bounds().expect("blocks taken");
        let pixel = |p: Vec3| match cam.footprint_of([p]) {
            Footprint::Rect(r) => (r[0] + r[2] / 2, r[1] + r[3] / 2),
            other => panic!("{p} is on screen: {other:?}"),
        };
        let inside = |(x, y): (u32, u32)| blocks.taken[((y / GROUP) * blocks.per_row + x / GROUP) as usize];
        // Beyond the object along the light's rays (the shadow) and the object itself: covered.
        let lamp = Vec3::new(-4.0, 6.0, 0.0);
        for t in [1.0, 1.3, 1.6] {
            let p = lamp + (object.center() - lamp) * t;
            assert!(inside(pixel(p)), "{p} (t = {t}) is in the shadow's footprint {rect:?}");
        }
        // Between the lamp and the object: left out (it was inside before the near plane cut).
        for t in [0.2, 0.5] {
            let p = lamp + (object.center() - lamp) * t;
            assert!(!inside(pixel(p)), "{p} (t = {t}) lies before the object: {rect:?}");
        }
    }
}
