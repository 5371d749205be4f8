//! Temporary (dragged) objects (Toromanoff 2005 §3.3, his option 5): while an instance is
//! temporary, every cached item leaves it out, so dragging invalidates nothing; it casts through a
//! pass of its own each frame instead: a small map per light fitted to the object ([`map_size`]) (one frustum, or
//! six faces when the light is inside its bounds; an orthographic box for directional lights),
//! looked up after the light's technique has written its visibility, which is multiplied by the
//! object's hard shadow. On release the object becomes permanent again and the items it reaches
//! are rebuilt once (the validity table).
//!
//! Receivers beyond a map's far plane compare at depth 0 (everything stored is closer to the
//! light): the object's shadow reaches as far as the light does.

use bytemuck::{Pod, Zeroable};
use glam::Vec4;
use shadowlab_core::convex::ConvexBody;
use shadowlab_core::lightspace::{ShadowView, light_frusta};
use shadowlab_core::{Aabb, Mobility};

use super::edits::InstanceId;
use super::scene::LiveScene;
use crate::context::{RegionUniform, Shared, UNFILTERED, storage_entry, texture_entry};
use crate::frame::{CameraUniform, Footprint, SurfaceInputs, VisibilityLayer};
use crate::gbuffer::GBuffer;
use crate::gpu_scene::GpuScene;
use crate::shadowmap::{BiasUniform, FaceMode, Raster, ShadowMapArray, lookup_group, lookup_layout};
use crate::technique::{FrameContext, dispatch_resolve_rect};
use crate::timing::{GpuTimer, PassKind};

/// Texels per side of a temporary object's map (the object alone fills it) for an output of
/// `width × height`: twice the output's larger side, as a power of two within 256..=1024. The
/// object's shadow covers at most the screen, so more texels than about two per pixel across it
/// buy nothing, and a drag frame on a small output should not pay for a 1024² map per light.
pub fn map_size(width: u32, height: u32) -> u32 {
    (2 * width.max(height)).next_power_of_two().clamp(256, 1024)
}

/// The bias of `hard`'s defaults (texels along the normal; slope-scaled raster bias).
const NORMAL_OFFSET: f32 = 0.3;
const SLOPE_BIAS: f32 = 1.5;

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct TemporaryUniform {
    /// x: the temporary objects' views; y: the permanent views before them; z: 1 when those are
    /// a cube's six faces.
    counts: [u32; 4],
}

/// The permanent instances alone, seen by the application's camera, while objects are dragged:
/// the surface the lights' techniques shadow then. Their layers depend on nothing a drag changes,
/// so a drag step resolves nothing again (the dragged objects' pass alone runs); pixels that show
/// a dragged object take the permanent casters' hard shadow instead ([`TemporaryShadows::apply`]).
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
    pub fn update<'s>(
        slot: &'s mut Option<Self>,
        shared: &Shared,
        encoder: &mut wgpu::CommandEncoder,
        gpu_scene: &GpuScene,
        live: &LiveScene,
        surface: &SurfaceInputs,
        timer: &mut GpuTimer,
    ) -> &'s SurfaceInputs {
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
        }
        &p.inputs
    }

    pub fn bytes(&self) -> u64 {
        self.gbuffer.bytes()
    }
}

/// The temporary objects' shadows of one light, rebuilt each frame while any object is dragged.
pub struct TemporaryShadows {
    raw: Option<VisibilityLayer>,
    /// The permanent casters' views (layers from 0: they shadow the dragged objects) and then the
    /// temporary objects' own.
    maps: Option<(ShadowMapArray, wgpu::BindGroup)>,
    /// Permanent views drawn in `maps` and still valid (0: none).
    permanent: u32,
    bias: wgpu::Buffer,
    counts: wgpu::Buffer,
    /// The `RegionUniform` of the pixels the objects' shadows may fall on.
    region: wgpu::Buffer,
}

impl TemporaryShadows {
    pub fn new(shared: &Shared) -> Self {
        let device = &shared.gpu.device;
        let bias = BiasUniform { values: Vec4::new(NORMAL_OFFSET, 0.0, 0.0, 0.0), mode: Vec4::ZERO };
        Self {
            raw: None,
            maps: None,
            permanent: 0,
            bias: crate::util::uniform_buffer(device, "temporary bias", bytemuck::bytes_of(&bias)),
            counts: crate::util::branch_buffer(
                device,
                "temporary counts",
                bytemuck::bytes_of(&TemporaryUniform { counts: [0; 4] }),
            ),
            region: crate::util::uniform_buffer(
                device,
                "temporary region",
                bytemuck::bytes_of(&RegionUniform::whole()),
            ),
        }
    }

    /// Whether any instance is temporary: the techniques then shadow the permanent surface and this
    /// pass runs, for the shadows the dragged objects cast and those they receive.
    pub fn active(live: &LiveScene) -> bool {
        live.scene().instances.iter().any(|i| i.mobility == Mobility::Temporary)
    }

    /// The layer techniques write into while temporary objects exist (the pass multiplies it into
    /// the light's own layer).
    pub fn raw_layer(&mut self, shared: &Shared, width: u32, height: u32) -> &VisibilityLayer {
        let stale = self.raw.as_ref().is_none_or(|r| (r.texture.width(), r.texture.height()) != (width, height));
        if stale {
            self.raw = Some(VisibilityLayer::new(&shared.gpu.device, width, height, "visibility before dragging"));
        }
        self.raw.as_ref().expect("made above")
    }

    /// Frees the layer and maps once nothing is dragged: a drag holds them, a still scene does not.
    pub fn release(&mut self) {
        (self.raw, self.maps, self.permanent) = (None, None, 0);
    }

    pub fn bytes(&self) -> u64 {
        self.raw.as_ref().map_or(0, VisibilityLayer::bytes) + self.maps.as_ref().map_or(0, |m| m.0.bytes())
    }

    /// Renders the temporary objects' maps for the context's light and writes `out` = the raw
    /// layer × their shadows, where the raw layer is the light's technique over the permanent
    /// surface (`permanent`: what the eye would see without the dragged objects). Where the eye
    /// sees a dragged object instead, the permanent casters' hard shadow stands in for the raw
    /// layer, from maps of the whole scene drawn once (`redraw`: the light or the permanent
    /// scene changed) and kept while the drag goes on. Only the pixels the objects cover and those their shadows
    /// may fall on ([`shadow_footprint`]) are looked up; the others are copied from the raw layer.
    pub fn apply(
        &mut self,
        ctx: &mut FrameContext<'_>,
        out: &VisibilityLayer,
        permanent: &SurfaceInputs,
        redraw: bool,
    ) {
        if redraw {
            // Before any early return: maps drawn for the layer's old state must not outlive it.
            self.permanent = 0;
        }
        let shared = ctx.shared;
        let size = map_size(ctx.surface.width, ctx.surface.height);
        let mut views: Vec<ShadowView> = Vec::new();
        let mut receivers = ctx.live.fit_bounds();
        // The pixels that show a dragged object (they take the permanent casters' shadow), then
        // those its shadow may fall on.
        let mut footprint = Footprint::Nothing;
        for (inst, state) in ctx.live.scene().instances.iter().zip(ctx.live.instances()) {
            if inst.mobility == Mobility::Temporary {
                receivers = receivers.union(&state.bounds);
                footprint = footprint.union(ctx.surface.camera.footprint(&padded(&state.bounds)));
                if inst.casts_shadows {
                    views.extend(light_frusta(ctx.light, &padded(&state.bounds), size).views);
                }
            }
        }
        let footprint = views
            .iter()
            .fold(footprint, |f, v| f.union(shadow_footprint(&ctx.surface.camera, v, size, &padded(&receivers))));
        let raw = self.raw.as_ref().expect("raw_layer comes first");
        let rect = match footprint {
            Footprint::Whole => [0, 0, ctx.surface.width, ctx.surface.height],
            Footprint::Nothing | Footprint::Rect(_) => {
                let extent = raw.texture.size();
                ctx.encoder.copy_texture_to_texture(raw.texture.as_image_copy(), out.texture.as_image_copy(), extent);
                match footprint {
                    Footprint::Rect(rect) => rect,
                    _ => return,
                }
            }
        };
        // The whole scene's box, which dragging does not change: the permanent views stay put.
        let whole = light_frusta(ctx.light, &padded(&ctx.live.fit_bounds()), size).views;
        let (p, n) = (whole.len() as u32, views.len() as u32);
        if self.maps.as_ref().is_none_or(|(m, _)| m.layers < p + n || m.size != size) {
            // Room for a power of two of views: a 1024² layer is 4 MiB, so no spare layers for one
            // object's single frustum, yet a drag that grows from one view to six reallocates once.
            let capacity = (p + n).max(1).next_power_of_two();
            self.permanent = 0;
            let maps = ShadowMapArray::new(shared, size, capacity, capacity);
            let bias = BiasUniform { values: Vec4::new(NORMAL_OFFSET, 0.0, size as f32, 0.0), mode: Vec4::ZERO };
            ctx.gpu.queue.write_buffer(&self.bias, 0, bytemuck::bytes_of(&bias));
            let group = lookup_group(shared, &maps, &self.bias, false);
            self.maps = Some((maps, group));
        }
        let (maps, group) = self.maps.as_mut().expect("made above");
        let raster = Raster { faces: FaceMode::Back, slope_bias: SLOPE_BIAS, linear_depth: false, only_masked: false };
        if self.permanent != p {
            maps.set_views(&ctx.gpu.queue, 0, &whole);
            for i in 0..p {
                maps.render(ctx, i, i, &raster);
            }
            ctx.cache.work.temporary_views += p;
            self.permanent = p;
        }
        maps.set_views(&ctx.gpu.queue, p, &views);
        for i in p..p + n {
            maps.render_casters(ctx, i, i, &raster, &[Mobility::Temporary], true);
        }
        ctx.cache.work.temporary_views += n;
        let cube = u32::from(p == 6);
        ctx.gpu.queue.write_buffer(&self.counts, 0, bytemuck::bytes_of(&TemporaryUniform { counts: [n, p, cube, 0] }));
        ctx.gpu.queue.write_buffer(&self.region, 0, bytemuck::bytes_of(&RegionUniform { rect }));
        let device = &shared.gpu.device;
        let own = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("temporary"),
            layout: &layout(shared),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&raw.view) },
                wgpu::BindGroupEntry { binding: 1, resource: self.counts.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&permanent.depth) },
            ],
        });
        let pipeline = shared.resolve_pipeline(
            "temporary",
            include_str!("temporary.wgsl"),
            "main",
            &[&lookup_layout(shared), &layout(shared)],
            &[],
        );
        let group0 = shared.resolve_bind_group_in(ctx.surface, ctx.light_buffer, out, &self.region);
        dispatch_resolve_rect(ctx, "temporary objects", &pipeline, &[&group0, group, &own], rect);
    }
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
/// 1.93 → 1.83 and 1.81, one run each alternated).
fn shadow_footprint(camera: &CameraUniform, view: &ShadowView, size: u32, receivers: &Aabb) -> Footprint {
    // Two texels wider than the window; the near plane a hair beyond for round-off (reversed Z).
    let body = ConvexBody::from_aabb(receivers).clip_to_view(&view.view_projection, 4.0 / size as f32, 1e-4);
    if body.is_empty() {
        return Footprint::Nothing;
    }
    camera.footprint_of_body(&body)
}

/// An object's bounds with a little room, so that its silhouette never touches the map's border.
fn padded(b: &Aabb) -> Aabb {
    let e = glam::Vec3::splat(0.02 * b.diagonal().max(1e-4));
    Aabb::new(b.min - e, b.max + e)
}

fn layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("temporary", || {
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("temporary"),
            entries: &[
                texture_entry(0, wgpu::ShaderStages::COMPUTE, UNFILTERED, wgpu::TextureViewDimension::D2),
                storage_entry(1, wgpu::ShaderStages::COMPUTE, true),
                texture_entry(2, wgpu::ShaderStages::COMPUTE, UNFILTERED, wgpu::TextureViewDimension::D2),
            ],
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
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
        let Footprint::Rect(rect) = shadow_footprint(&cam, &views[0], size, &receivers) else {
            panic!("the shadow is on screen");
        };
        let pixel = |p: Vec3| match cam.footprint_of([p]) {
            Footprint::Rect(r) => (r[0] + r[2] / 2, r[1] + r[3] / 2),
            other => panic!("{p} is on screen: {other:?}"),
        };
        let inside =
            |(x, y): (u32, u32)| x >= rect[0] && x < rect[0] + rect[2] && y >= rect[1] && y < rect[1] + rect[3];
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
