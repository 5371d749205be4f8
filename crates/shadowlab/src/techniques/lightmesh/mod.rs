//! `lightmesh`: static lights with precomputed light meshes (Hasselgren 2003, NOTES-001 §1.6–1.9).
//!
//! Hasselgren's Table 1 splits every (light, caster, receiver) case by mobility. For a static light:
//! - **static casters on static receivers**: precomputed. The static receivers, cut along the static
//!   shadow boundaries with the shadowed pieces removed (the *light mesh*,
//!   [`shadowlab_core::lightmesh`]), are drawn from the camera (`mesh.wgsl`): a pixel they cover is
//!   lit by the static casters, any other static pixel is in their shadow. No map, no bias, no
//!   volume: exact and nearly free.
//! - **dynamic casters on everything**: their shadow volumes (`volumes` over the dynamic casters).
//! - **static casters on dynamic receivers**: the static casters' volumes, drawn only over the
//!   dynamic objects' screen rectangle within the light's (§3.3.1.1 scissor, merged per light as
//!   §3.3.1.3 chooses), with the casters culled against the frustum through it (§3.3.1.2).
//!
//! A dynamic light falls back to `volumes` over every caster (Table 1's last four rows). The light
//! mesh comes from a file (`shadowlab precompute`, [`crate::Shadows::provide_light_meshes`]) or is
//! built on the CPU when the technique first runs, and is a cached item of the live engine
//! ([`ItemKind::LightMesh`]): rebuilt when the validity table says an edit touched it (a static
//! instance within the light's range moved, came or went, or the light itself changed). The stencil
//! methods are those of `volumes` (`mode`), not Hasselgren's invert-stencil depth pass over
//! light-mesh volumes.
//! Area lights get hard shadows from their centre.

use bytemuck::{Pod, Zeroable};
use shadowlab_core::lightmesh::{self, LightMesh, LightMeshStats};
use shadowlab_core::params::ParamDef;
use shadowlab_core::{Light, Mobility, ParamSet};

mod mesh_volumes;

use glam::Vec4;
use shadowlab_core::volumes::{LightSource, SphereRect, VolumeCamera};

use super::volumes::{self, CasterSet, Volumes};
use crate::context::{Shared, UNFILTERED, texture_entry, uniform_entry};
use crate::frame::VisibilityLayer;
use crate::live::validity::{lightmesh_region, lightmesh_signature};
use crate::live::{ItemKey, ItemKind};
use crate::technique::{
    FrameContext, ShadowTechnique, TechniqueError, TechniqueInfo, TechniqueStats, dispatch_resolve,
};
use crate::timing::PassKind;

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "lightmesh",
    summary: "static lights: precomputed light meshes for static shadows, shadow volumes for what moves (hard)",
    source: "Hasselgren 2003 §3.1–3.3 (Table 1, light meshes, focused static volumes)",
    params: &[
        ParamDef::choice(
            "mode",
            "auto",
            &["auto", "zpass", "zfail", "zpplus"],
            "stencil counting of the volumes (as `volumes`)",
        ),
        ParamDef::bool(
            "focus",
            true,
            "static casters' volumes only over the dynamic objects' screen rectangle (false: everywhere)",
        ),
        ParamDef::choice(
            "static_volumes",
            "auto",
            &["auto", "mesh", "casters"],
            "static casters' shadows on dynamic objects: volumes on the light mesh's edges (Hasselgren's robust depth pass; needs depth clamping), the casters' own volumes, or mesh where the adapter clamps depth",
        ),
        ParamDef::bool(
            "soft",
            false,
            "fake soft static shadows: receivers cut by penumbra wedges from the emitter's size, visibility per vertex (Hasselgren §3.4)",
        ),
        ParamDef::choice(
            "penumbra",
            "auto",
            &["auto", "half", "full"],
            "with soft: the outer half only (dynamic hard shadows fit, no leak), both halves, or half when anything is dynamic",
        ),
    ],
    light_types: super::ALL_LIGHTS,
    create,
    compose: None,
    fragment: false,
};

/// `struct Combine` of `resolve.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct CombineUniform {
    focus: [u32; 4],
    flags: [u32; 4],
}

/// The light mesh's marks: r the static visibility, g 1 where the light mesh is the visible surface.
/// (32-bit: a hard mesh's 1, interpolated across a triangle, must stay 1.)
const MASK_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;

/// The light mesh on the GPU.
struct GpuMesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    stats: LightMeshStats,
}

/// A light mesh being built in the background, for the state `signature` describes.
struct Job {
    signature: crate::live::Signature,
    result: std::sync::mpsc::Receiver<Result<(LightMesh, LightMeshStats), lightmesh::LightMeshError>>,
}

/// Screen-sized targets.
struct State {
    size: (u32, u32),
    mask: wgpu::TextureView,
    uniform: wgpu::Buffer,
    /// The light-mesh volumes' stencil and shadow mask, and their fill counters (the total, then
    /// one per pixel).
    stencil: wgpu::TextureView,
    shadow: wgpu::TextureView,
    fill: wgpu::Buffer,
}

struct LightMeshTechnique {
    params: ParamSet,
    /// A light mesh is drawn (a static light); otherwise `statics` holds every caster's volumes.
    precomputed: bool,
    focus: bool,
    soft: bool,
    /// `penumbra`: `None` for auto.
    penumbra: Option<lightmesh::Penumbra>,
    /// Volumes of the dynamic casters (none for a dynamic light).
    dynamic: Option<Volumes>,
    /// Volumes of the static casters, focused on dynamic receivers (of every caster, for a dynamic
    /// light); `None` when the light mesh's own volumes stand in (`mesh_volumes`).
    statics: Option<Volumes>,
    /// The static shadows on dynamic objects from volumes on the light mesh's edges.
    use_mesh_volumes: bool,
    mesh_volumes: Option<mesh_volumes::MeshVolumes>,
    /// Whether the light-mesh volumes' fill was counted (their first frame).
    fill_measured: bool,
    mesh: Option<GpuMesh>,
    /// The mesh came from a file (`Shadows::provide_light_meshes`), not built here.
    from_file: bool,
    /// A rebuild on a worker thread (under a frame-time target, when a mesh is already shown).
    job: Option<Job>,
    /// Its cache set (the mesh's record in the [`crate::live::ShadowCache`]).
    set: Option<u32>,
    state: Option<State>,
    /// Whether the last frame drew the dynamic and the static volumes.
    drew: (bool, bool),
    focus_rect: [u32; 4],
    rebuilds: u32,
}

fn create(shared: &Shared, params: &ParamSet, light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let mut inner = ParamSet::new(volumes::INFO.params);
    inner
        .set("mode", params.choice("mode"))
        .map_err(|e| TechniqueError::Failed { id: INFO.id.into(), message: e.to_string() })?;
    let precomputed = light.mobility == Mobility::Static;
    let focus = params.bool("focus");
    let soft = params.bool("soft");
    let penumbra = match params.choice("penumbra") {
        "half" => Some(lightmesh::Penumbra::Half),
        "full" => Some(lightmesh::Penumbra::Full),
        _ => None,
    };
    let clamp = shared.gpu.device.features().contains(wgpu::Features::DEPTH_CLIP_CONTROL);
    let use_mesh_volumes = precomputed
        && match params.choice("static_volumes") {
            "mesh" if !clamp => {
                return Err(TechniqueError::Failed {
                    id: INFO.id.into(),
                    message: "static_volumes=mesh counts from the eye with depth clamping, which this adapter lacks \
                              (DEPTH_CLIP_CONTROL); use static_volumes=casters"
                        .into(),
                });
            }
            "mesh" => true,
            "casters" => false,
            _ => clamp,
        };
    let (mut dynamic, mut statics) = match (precomputed, use_mesh_volumes) {
        (true, true) => (Some(Volumes::new(shared, &inner, light, CasterSet::Dynamic, false)?), None),
        (true, false) => (
            Some(Volumes::new(shared, &inner, light, CasterSet::Dynamic, false)?),
            Some(Volumes::new(shared, &inner, light, CasterSet::Static, focus)?),
        ),
        (false, _) => (None, Some(Volumes::new(shared, &inner, light, CasterSet::All, false)?)),
    };
    // One sample (the centre), no cropping: the masks always suffice.
    let masks =
        dynamic.as_mut().is_none_or(Volumes::stop_at_mask) && statics.as_mut().is_none_or(Volumes::stop_at_mask);
    debug_assert!(masks, "lightmesh's volumes have one sample");
    Ok(Box::new(LightMeshTechnique {
        params: params.clone(),
        precomputed,
        focus,
        soft,
        penumbra,
        dynamic,
        statics,
        use_mesh_volumes,
        mesh_volumes: None,
        fill_measured: false,
        mesh: None,
        job: None,
        from_file: false,
        set: None,
        state: None,
        drew: (false, false),
        focus_rect: [0; 4],
        rebuilds: 0,
    }))
}

fn mesh_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("lightmesh draw", || {
        let vf = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("lightmesh draw"),
            entries: &[
                uniform_entry(0, vf),
                texture_entry(1, wgpu::ShaderStages::FRAGMENT, UNFILTERED, wgpu::TextureViewDimension::D2),
            ],
        })
    })
}

fn combine_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("lightmesh combine", || {
        let c = wgpu::ShaderStages::COMPUTE;
        let d2 = wgpu::TextureViewDimension::D2;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("lightmesh combine"),
            entries: &[
                texture_entry(0, c, UNFILTERED, d2),
                texture_entry(1, c, UNFILTERED, d2),
                texture_entry(2, c, UNFILTERED, d2),
                uniform_entry(3, c),
            ],
        })
    })
}

fn mesh_pipeline(shared: &Shared) -> wgpu::RenderPipeline {
    shared.render_pipeline("lightmesh draw", || {
        let device = &shared.gpu.device;
        let module = crate::shader::module(device, "lightmesh draw", include_str!("mesh.wgsl"));
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("lightmesh draw"),
            bind_group_layouts: &[Some(&mesh_layout(shared))],
            immediate_size: 0,
        });
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("lightmesh draw"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("mesh_vs"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: 16,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32],
                })],
            },
            // Both faces: a double-sided receiver's piece may be wound either way.
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("mesh_fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: MASK_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::RED | wgpu::ColorWrites::GREEN,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    })
}

fn upload(device: &wgpu::Device, mesh: &LightMesh, stats: LightMeshStats) -> GpuMesh {
    use wgpu::util::DeviceExt;
    // Buffers may not be empty: a light mesh with nothing lit keeps one unused vertex.
    // Position and visibility (1 for hard light meshes).
    let mut positions: Vec<[f32; 4]> = mesh
        .positions
        .iter()
        .enumerate()
        .map(|(i, p)| p.extend(mesh.visibility.get(i).copied().unwrap_or(1.0)).to_array())
        .collect();
    positions.resize(positions.len().max(1), [0.0; 4]);
    let mut indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let index_count = indices.len() as u32;
    indices.resize(indices.len().max(3), 0);
    GpuMesh {
        vertices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("light mesh vertices"),
            contents: bytemuck::cast_slice(&positions),
            usage: wgpu::BufferUsages::VERTEX,
        }),
        indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("light mesh indices"),
            contents: bytemuck::cast_slice(&indices),
            usage: wgpu::BufferUsages::INDEX,
        }),
        index_count,
        stats,
    }
}

impl LightMeshTechnique {
    /// Rebuilds the light mesh when the validity table says an edit touched it (a static instance
    /// within the light's range, or the light itself: [`ItemKind::LightMesh`]).
    fn refresh_mesh(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        let set = *self.set.get_or_insert_with(|| ctx.cache.new_set());
        let key = ItemKey { light: ctx.light_id, owner: ctx.owner, set, kind: ItemKind::LightMesh, index: 0 };
        let region = lightmesh_region(ctx.live, ctx.light);
        let signature = lightmesh_signature(ctx.live, ctx.light_id, &region);
        if self.mesh.is_some() && ctx.cache.is_valid(&key, &signature) {
            // (An edit undone: what is shown holds again, and a rebuild under way is not needed.)
            self.job = None;
            ctx.cache.work.reused += 1;
            return Ok(());
        }
        // A background rebuild for this very state may have finished.
        if let Some(job) = &self.job {
            if job.signature == signature {
                match job.result.try_recv() {
                    Ok(Ok((mesh, stats))) => {
                        self.job = None;
                        self.install(ctx, key, signature, &mesh, stats, false);
                        ctx.cache.work.light_meshes += 1;
                        return Ok(());
                    }
                    Err(std::sync::mpsc::TryRecvError::Empty) => {
                        ctx.budget.deferred += 1;
                        return Ok(());
                    }
                    // The worker failed: build here, and report its error if it fails again.
                    Ok(Err(_)) | Err(std::sync::mpsc::TryRecvError::Disconnected) => self.job = None,
                }
            } else {
                // Made for a state that no longer is: dropped (the worker's send fails quietly).
                self.job = None;
            }
        }
        let preloaded = ctx
            .cache
            .preloaded_light_meshes
            .iter()
            .find(|(light, s, mesh)| {
                *light == ctx.light_id && *s == signature && mesh.visibility.is_empty() != self.soft
            })
            .map(|(_, _, mesh)| std::sync::Arc::clone(mesh));
        if let Some(mesh) = preloaded {
            let stats = LightMeshStats { triangles: mesh.triangle_count(), ..LightMeshStats::default() };
            self.install(ctx, key, signature, &mesh, stats, true);
            ctx.cache.work.reused += 1;
            return Ok(());
        }
        let failed = |message: String| TechniqueError::Failed { id: INFO.id.into(), message };
        let index = ctx
            .live
            .lights()
            .iter()
            .position(|s| s.id == ctx.light_id)
            .ok_or_else(|| failed("the light is not in the live scene".into()))?;
        let mode = if self.soft {
            // Auto: the half penumbra as soon as anything casts a dynamic shadow (§3.4: no leak).
            let dynamic = ctx.scene.instances.iter().any(|i| i.casts_shadows && i.mobility != Mobility::Static);
            let half = if dynamic { lightmesh::Penumbra::Half } else { lightmesh::Penumbra::Full };
            lightmesh::Mode::Soft(self.penumbra.unwrap_or(half))
        } else {
            lightmesh::Mode::Hard
        };
        // Under a frame-time target, with a mesh to show meanwhile: rebuilt on a worker thread
        // while the last complete mesh stays (Toromanoff's all-or-nothing rule, as maps do; the
        // technique reports `current() == false` until it lands).
        if self.mesh.is_some() && !ctx.budget.is_unlimited() && cfg!(not(target_arch = "wasm32")) {
            let scene = ctx.scene.clone();
            let (send, result) = std::sync::mpsc::channel();
            let spawned = std::thread::Builder::new().name("light mesh".into()).spawn(move || {
                let casters = lightmesh::static_casters(&scene);
                let _ = send.send(lightmesh::build_with(&scene, index, &casters, mode));
            });
            if spawned.is_ok() {
                self.job = Some(Job { signature, result });
                ctx.budget.deferred += 1;
                return Ok(());
            }
        }
        let casters = lightmesh::static_casters(ctx.scene);
        let (mesh, stats) =
            lightmesh::build_with(ctx.scene, index, &casters, mode).map_err(|e| failed(e.to_string()))?;
        self.install(ctx, key, signature, &mesh, stats, false);
        ctx.cache.work.light_meshes += 1;
        Ok(())
    }

    /// Shows `mesh` from now on and records it in the cache.
    fn install(
        &mut self,
        ctx: &mut FrameContext<'_>,
        key: ItemKey,
        signature: crate::live::Signature,
        mesh: &LightMesh,
        stats: LightMeshStats,
        from_file: bool,
    ) {
        self.mesh = Some(upload(&ctx.gpu.device, mesh, stats));
        if self.use_mesh_volumes {
            self.mesh_volumes = Some(mesh_volumes::MeshVolumes::new(&ctx.gpu.device, mesh, LightSource::of(ctx.light)));
        }
        self.from_file = from_file;
        if !from_file {
            self.rebuilds += 1;
        }
        ctx.cache.commit(key, signature);
    }

    fn build_state(&self, ctx: &FrameContext<'_>) -> State {
        let device = &ctx.gpu.device;
        let size = (ctx.surface.width, ctx.surface.height);
        let mask = crate::util::texture_2d(
            device,
            "light mesh lit mask",
            MASK_FORMAT,
            size,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        )
        .create_view(&Default::default());
        State {
            size,
            mask,
            stencil: mesh_volumes::stencil_target(device, size),
            fill: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("light mesh volumes fill"),
                size: 16 + 4 * u64::from(size.0) * u64::from(size.1),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            shadow: crate::util::texture_2d(
                device,
                "light mesh volumes shadow",
                mesh_volumes::SHADOW_FORMAT,
                size,
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            )
            .create_view(&Default::default()),
            uniform: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("lightmesh combine"),
                size: std::mem::size_of::<CombineUniform>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        }
    }
}

impl ShadowTechnique for LightMeshTechnique {
    fn id(&self) -> &'static str {
        INFO.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        if self.precomputed {
            self.refresh_mesh(ctx)?;
        }
        if self.state.as_ref().is_none_or(|s| s.size != (ctx.surface.width, ctx.surface.height)) {
            self.state = Some(self.build_state(ctx));
            self.fill_measured = false;
        }
        if let Some(d) = &mut self.dynamic {
            d.prepare(ctx)?;
        }
        if let Some(s) = &mut self.statics {
            s.prepare(ctx)?;
        }
        Ok(())
    }

    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let Some(state) = &self.state else { return };
        let draw_dynamic = self.dynamic.as_ref().is_some_and(Volumes::has_casters);
        let full = [0, 0, state.size.0, state.size.1];
        let mut draw_static = false;
        // The volumes stop at their shadow masks (`stop_at_mask`): `out` is not written.
        if let (Some(d), true) = (&mut self.dynamic, draw_dynamic) {
            d.resolve(ctx, out);
        }
        if let Some(statics) = &mut self.statics {
            self.focus_rect = match (self.precomputed, self.focus) {
                (true, true) => statics.focus_rect().unwrap_or(full),
                _ => full,
            };
            draw_static = statics.has_casters() && self.focus_rect[2] > 0 && self.focus_rect[3] > 0;
            if draw_static {
                statics.resolve(ctx, out);
            }
        } else if let Some(mv) = &mut self.mesh_volumes {
            let cam = &ctx.surface.camera;
            let camera = VolumeCamera {
                view_proj: cam.view_proj,
                eye: cam.position.truncate(),
                near_ndc_depth: if cam.depth.x == 0.0 { 1.0 } else { 0.0 },
            };
            let spheres = if self.focus { volumes::focus_spheres(ctx.live) } else { Vec::new() };
            let light_ndc = match (ctx.light.position(), ctx.light.range) {
                (Some(p), Some(r)) => match camera.sphere_rect(p, r) {
                    SphereRect::Rect(ndc) => Some(ndc),
                    SphereRect::Full => Some([-1.0, -1.0, 1.0, 1.0]),
                    SphereRect::Outside => None,
                },
                _ => Some([-1.0, -1.0, 1.0, 1.0]),
            };
            let ndc =
                if self.focus { light_ndc.and_then(|l| volumes::focus_ndc(&camera, &spheres, l)) } else { light_ndc };
            let rect = ndc.and_then(|n| volumes::pixel_rect(n, state.size.0, state.size.1).map(|px| (n, px)));
            self.focus_rect = rect.map_or([0; 4], |(_, px)| px);
            if let Some((ndc, px)) = rect {
                // The frustum through the rectangle, its four sides only: depth clamping keeps what
                // lies in front of the near plane, and Hasselgren's far plane at the farthest dynamic
                // point (§3.3.1.2) would be wrong here, where the static pixels of the rectangle that
                // the light mesh leaves dark take the count too.
                let planes: Vec<Vec4> = camera.planes(ndc)[..4].to_vec();
                let focus = mesh_volumes::Focus { planes, eye: camera.eye };
                mv.plan(&ctx.gpu.queue, &focus);
                let group = ctx.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("light mesh volumes"),
                    layout: &mesh_volumes::layout(ctx.shared),
                    entries: &[
                        wgpu::BindGroupEntry { binding: 0, resource: ctx.surface.camera_buffer.as_entire_binding() },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: wgpu::BindingResource::TextureView(&ctx.surface.depth),
                        },
                    ],
                });
                // The first frame counts the quads' fill (`render --overlay fill`), as `volumes` does.
                let fill = (!self.fill_measured).then(|| {
                    ctx.encoder.clear_buffer(&state.fill, 0, None);
                    ctx.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("light mesh volumes fill"),
                        layout: &mesh_volumes::fill_layout(ctx.shared),
                        entries: &[wgpu::BindGroupEntry { binding: 0, resource: state.fill.as_entire_binding() }],
                    })
                });
                self.fill_measured = true;
                let timestamps = ctx.timer.render_pass(&ctx.gpu.device, PassKind::Shadow);
                mv.record(
                    ctx.shared,
                    ctx.encoder,
                    &group,
                    &state.stencil,
                    &state.shadow,
                    px,
                    timestamps,
                    fill.as_ref(),
                );
                draw_static = true;
            }
        }
        self.drew = (draw_dynamic, draw_static);
        let shared = ctx.shared;
        let device = &ctx.gpu.device;
        if let Some(mesh) = &self.mesh {
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("lightmesh draw"),
                layout: &mesh_layout(shared),
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: ctx.surface.camera_buffer.as_entire_binding() },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&ctx.surface.depth),
                    },
                ],
            });
            let timestamps = ctx.timer.render_pass(device, PassKind::Shadow);
            let mut pass = ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("light mesh"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &state.mask,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: timestamps,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if mesh.index_count > 0 {
                pass.set_pipeline(&mesh_pipeline(shared));
                pass.set_bind_group(0, Some(&group), &[]);
                pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..mesh.index_count, 0, 0..1);
            }
        }
        let flags = [u32::from(draw_dynamic), u32::from(self.precomputed), u32::from(draw_static), 0];
        let uniform = CombineUniform { focus: self.focus_rect, flags };
        ctx.gpu.queue.write_buffer(&state.uniform, 0, bytemuck::bytes_of(&uniform));
        let dynamic_mask = self.dynamic.as_ref().and_then(Volumes::mask).filter(|_| draw_dynamic);
        let static_mask = match &self.statics {
            Some(statics) => statics.mask(),
            None => Some(&state.shadow),
        }
        .filter(|_| draw_static);
        let combine = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("lightmesh combine"),
            layout: &combine_layout(shared),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&state.mask) },
                // Masks not drawn this frame are not read (`flags`): any texture binds.
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(dynamic_mask.unwrap_or(&state.mask)),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(static_mask.unwrap_or(&state.mask)),
                },
                wgpu::BindGroupEntry { binding: 3, resource: state.uniform.as_entire_binding() },
            ],
        });
        let group0 = shared.resolve_bind_group(ctx.surface, ctx.light_buffer, out);
        let pipeline = shared.resolve_pipeline(
            "lightmesh resolve",
            include_str!("resolve.wgsl"),
            "resolve",
            &[&combine_layout(shared)],
            &[],
        );
        dispatch_resolve(ctx, "lightmesh resolve", &pipeline, &[&group0, &combine]);
    }

    fn shown(&self) -> bool {
        self.dynamic.as_ref().is_none_or(|d| d.shown()) && self.statics.as_ref().is_none_or(|s| s.shown())
    }

    fn current(&self) -> bool {
        self.job.is_none()
            && self.dynamic.as_ref().is_none_or(|d| d.current())
            && self.statics.as_ref().is_none_or(|s| s.current())
    }

    fn fill_counts(&self) -> Vec<&wgpu::Buffer> {
        let mut out = Vec::new();
        if let (Some(d), true) = (&self.dynamic, self.drew.0) {
            out.extend(d.fill_counts());
        }
        if let (Some(s), true) = (&self.statics, self.drew.1) {
            out.extend(s.fill_counts());
        }
        if let (Some(state), true) = (&self.state, self.fill_measured) {
            out.push(&state.fill);
        }
        out
    }

    fn stats(&self) -> TechniqueStats {
        let inner = [self.dynamic.as_ref().map(Volumes::stats), self.statics.as_ref().map(Volumes::stats)];
        let drawn = [self.drew.0, self.drew.1];
        let mut stats = TechniqueStats::default();
        for (s, drawn) in inner.into_iter().zip(drawn) {
            let Some(s) = s else { continue };
            stats.memory_bytes += s.memory_bytes;
            if drawn {
                stats.passes += s.passes;
                stats.draws += s.draws;
                stats.triangles += s.triangles;
            }
        }
        if let Some(state) = &self.state {
            let pixels = u64::from(state.size.0) * u64::from(state.size.1);
            stats.memory_bytes += pixels;
            let [_, _, w, h] = self.focus_rect;
            stats.extra.push(("focus_fraction".into(), f64::from(w) * f64::from(h) / pixels.max(1) as f64));
        }
        stats.passes += 2;
        if let Some(mesh) = &self.mesh {
            stats.memory_bytes += mesh.vertices.size() + mesh.indices.size();
            stats.draws += 1;
            stats.triangles += u64::from(mesh.index_count / 3);
            let s = &mesh.stats;
            stats.extra.extend([
                ("lightmesh_triangles".into(), s.triangles as f64),
                ("lightmesh_receiver_triangles".into(), s.receiver_triangles as f64),
                ("lightmesh_pieces".into(), s.pieces as f64),
                ("lightmesh_build_ms".into(), s.seconds * 1e3),
                ("lightmesh_rebuilds".into(), f64::from(self.rebuilds)),
                ("lightmesh_from_file".into(), f64::from(u8::from(self.from_file))),
            ]);
        }
        if let Some(mv) = &self.mesh_volumes {
            stats.memory_bytes += mv.bytes();
            stats.extra.push(("mesh_volume_quads".into(), mv.quads() as f64));
            stats.extra.push(("mesh_volume_quads_drawn".into(), f64::from(mv.drawn / 6)));
            stats.extra.push(("mesh_volume_eye_in_shadow".into(), f64::from(mv.start)));
            if self.drew.1 {
                stats.passes += 1;
                stats.draws += 2;
                stats.triangles += u64::from(mv.drawn / 3);
            }
        }
        stats.extra.push(("dynamic_volumes".into(), f64::from(u8::from(self.drew.0))));
        stats.extra.push(("static_volumes".into(), f64::from(u8::from(self.drew.1))));
        stats
    }
}
