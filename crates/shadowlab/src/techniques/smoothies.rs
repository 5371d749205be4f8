//! `smoothies`: fake soft shadows with an umbra and an outer penumbra (Chan & Durand, "Rendering
//! Fake Soft Shadows with Smoothies", EGSR 2003; Toromanoff 2005, algorithm E). Each frame:
//!
//! 1. the hard map from the light's centre (the umbra);
//! 2. on the CPU, the casters' silhouettes from the light's centre and their smoothies: quads
//!    extruded outward from every silhouette edge, joined by triangles at convex corners so that
//!    the ring has no gaps ([`shadowlab_core::smoothies`]);
//! 3. the smoothies rendered from the same views into a smoothie buffer that keeps, per texel, the
//!    nearest smoothie's distance from the silhouette and its depth;
//! 4. per pixel: the hard map's verdict; outside the umbra, the smoothie in front of the receiver (if
//!    any) gives V = offset / (R·(1 − b/r)), Toromanoff's `R·D/(d + D)` evaluated per receiver.
//!
//! Smoothies only add shadow outside the hard shadow: the umbra never shrinks, so shadows of large
//! lights are too dark and too wide (the heatmaps show it as a band inside every penumbra). R is
//! the emitter's radius ([`shadowlab_core::Light::emitter_extent`]).

use std::sync::Arc;

use glam::Vec3;
use shadowlab_core::smoothies::{SmoothieVertex, smoothies};
use shadowlab_core::volumes::LightSource;
use shadowlab_core::{EmitterExtent, Light, ParamSet, Scene, Topology};

use crate::context::{Shared, uniform_entry};
use crate::frame::VisibilityLayer;
use crate::light_map::LightMap;
use crate::shadowmap::{SHADOW_FORMAT, lookup_layout, matrices_layout};
use crate::technique::{
    FrameContext, MapAnalysis, ShadowTechnique, TechniqueError, TechniqueInfo, TechniqueStats, dispatch_resolve,
};
use crate::timing::PassKind;

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "smoothies",
    summary: "hard umbra plus smoothie quads at the silhouette for an outer penumbra (fake soft shadows)",
    source: "Chan & Durand 2003; Toromanoff 2005 alg. E (Algorithm 7)",
    params: crate::map_params!(),
    light_types: super::ALL_LIGHTS,
    create,
    compose: None,
    fragment: false,
};

/// The smoothie buffer's texels: two f32 bit patterns in unsigned integers, because 32-bit float
/// colour targets are not renderable on every backend (wgpu's GL backend refuses Rg32Float), while
/// Rg32Uint is, and loses nothing.
const BUFFER_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Uint;

/// The welded topology of every mesh, shared by every light's smoothies.
pub(super) struct MeshTopologies(Vec<Topology>);

/// The scene's mesh topologies (built once, shared).
pub(super) fn topologies(shared: &Shared, scene: &Scene) -> Arc<MeshTopologies> {
    shared.resource("mesh topologies", || MeshTopologies(scene.meshes.iter().map(Topology::build).collect()))
}

struct SmoothieState {
    buffer: wgpu::Texture,
    color_layers: Vec<wgpu::TextureView>,
    depth: wgpu::Texture,
    depth_layers: Vec<wgpu::TextureView>,
    matrices: wgpu::Buffer,
    matrices_group: wgpu::BindGroup,
    stride: u64,
    group: wgpu::BindGroup,
    vertices: Option<wgpu::Buffer>,
    vertex_count: u32,
}

struct Smoothies {
    params: ParamSet,
    emitter: f32,
    map: Option<LightMap>,
    state: Option<SmoothieState>,
    resolve: wgpu::ComputePipeline,
    uniform: wgpu::Buffer,
    triangles: u64,
    smoothie_triangles: u64,
}

fn layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("smoothies", || {
        let c = wgpu::ShaderStages::COMPUTE;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("smoothies"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: c,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Uint,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
                uniform_entry(1, c),
            ],
        })
    })
}

fn render_pipeline(shared: &Shared) -> wgpu::RenderPipeline {
    shared.render_pipeline("smoothie buffer", || {
        let device = &shared.gpu.device;
        let module = crate::shader::module(device, "smoothie buffer", include_str!("smoothie_buffer.wgsl"));
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("smoothie buffer"),
            bind_group_layouts: &[Some(&matrices_layout(shared))],
            immediate_size: 0,
        });
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("smoothie buffer"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: 16,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32],
                })],
            },
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: SHADOW_FORMAT,
                depth_write_enabled: Some(true),
                // Reversed Z: the smoothie nearest the light wins.
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: BUFFER_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    })
}

fn create(shared: &Shared, params: &ParamSet, light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let emitter = emitter_size(light);
    let uniform =
        crate::util::uniform_buffer(&shared.gpu.device, "smoothies", bytemuck::cast_slice(&[emitter, 0.0, 0.0, 0.0]));
    let resolve = shared.resolve_pipeline(
        "smoothies",
        include_str!("smoothies.wgsl"),
        "main",
        &[&lookup_layout(shared), &layout(shared)],
        &[],
    );
    Ok(Box::new(Smoothies {
        params: params.clone(),
        emitter,
        map: None,
        state: None,
        resolve,
        uniform,
        triangles: 0,
        smoothie_triangles: 0,
    }))
}

/// The emitter's radius (local lights) or the tangent of its angular radius (the sun).
pub(super) fn emitter_size(light: &Light) -> f32 {
    match light.emitter_extent() {
        EmitterExtent::Radius(r) | EmitterExtent::Angle(r) => r,
    }
}

/// The smoothies of every permanent caster for `light`, per instance (its index in the scene) as a
/// flat vertex list (position, offset); `emitter` is the light's radius or the tangent of its
/// angular radius. Shared with `lightmaps`' smoothie fill.
pub(super) fn instance_smoothies(
    scene: &Scene,
    topologies: &MeshTopologies,
    light: &Light,
    emitter: f32,
) -> Vec<(usize, Vec<[f32; 4]>)> {
    let source = LightSource::of(light);
    let bounds = scene.bounds();
    let corners = bounds.corners();
    // The widest outer penumbra a receiver can need at silhouette point p, at the blocker's
    // distance: R·(1 − b/r_max) for local lights, tan θ·(r_max − b) for the sun.
    let width = |p: Vec3| -> f32 {
        match source {
            LightSource::Point(l) => {
                let far = corners.iter().map(|c| c.distance(l)).fold(0.0f32, f32::max);
                emitter * (1.0 - p.distance(l) / far.max(1e-6)).max(0.0)
            }
            LightSource::Directional(d) => {
                let d = d.normalize_or(Vec3::NEG_Y);
                emitter * corners.iter().map(|c| (*c - p).dot(d)).fold(0.0f32, f32::max)
            }
        }
    };
    let mut out = Vec::new();
    // Temporary (dragged) objects have a pass of their own.
    let permanent = |i: &shadowlab_core::Instance| i.casts_shadows && i.mobility != shadowlab_core::Mobility::Temporary;
    for (index, inst) in scene.instances.iter().enumerate().filter(|(_, i)| permanent(i)) {
        let topo = &topologies.0[inst.mesh.index()];
        if topo.triangles.is_empty() {
            continue;
        }
        let two_sided = !topo.report().is_closed() || scene.material(inst.material).double_sided;
        let vertices: Vec<[f32; 4]> = smoothies(topo, &inst.transform, &source, two_sided, width)
            .iter()
            .flat_map(|t| t.map(|v: SmoothieVertex| [v.position.x, v.position.y, v.position.z, v.offset]))
            .collect();
        out.push((index, vertices));
    }
    out
}

impl Smoothies {
    fn build(&self, shared: &Shared, map: &LightMap) -> SmoothieState {
        let device = &shared.gpu.device;
        let size = map.maps.as_ref().map_or(1, |m| m.size());
        let layers = map.frusta.views.len().max(1) as u32;
        let make = |label: &str, format| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: size,
                    height: size,
                    depth_or_array_layers: crate::shadowmap::padded_layers(layers, shared.gpu.adapter.backend == "gl"),
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
        };
        let layer_views = |t: &wgpu::Texture| -> Vec<wgpu::TextureView> {
            (0..layers)
                .map(|l| {
                    t.create_view(&wgpu::TextureViewDescriptor {
                        dimension: Some(wgpu::TextureViewDimension::D2),
                        base_array_layer: l,
                        array_layer_count: Some(1),
                        ..Default::default()
                    })
                })
                .collect()
        };
        let buffer = make("smoothie buffer", BUFFER_FORMAT);
        let depth = make("smoothie depth", SHADOW_FORMAT);
        let stride = u64::from(device.limits().min_uniform_buffer_offset_alignment).max(64);
        let matrices = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("smoothie matrices"),
            size: stride * u64::from(layers),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let matrices_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("smoothie matrices"),
            layout: &matrices_layout(shared),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &matrices,
                    offset: 0,
                    size: std::num::NonZeroU64::new(64),
                }),
            }],
        });
        let array = buffer.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("smoothies"),
            layout: &layout(shared),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&array) },
                wgpu::BindGroupEntry { binding: 1, resource: self.uniform.as_entire_binding() },
            ],
        });
        SmoothieState {
            color_layers: layer_views(&buffer),
            depth_layers: layer_views(&depth),
            buffer,
            depth,
            matrices,
            matrices_group,
            stride,
            group,
            vertices: None,
            vertex_count: 0,
        }
    }
}

impl ShadowTechnique for Smoothies {
    fn id(&self) -> &'static str {
        INFO.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        let shared = ctx.shared;
        let map = self.map.get_or_insert_with(|| LightMap::new(shared, &self.params, true));
        map.update(ctx)?;
        let emitter = emitter_size(ctx.light);
        if emitter != self.emitter {
            self.emitter = emitter;
            shared.gpu.queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&emitter));
        }
        let layers = map.frusta.views.len();
        // The layers or the size (the memory budget's grant) changed: the maps were reallocated.
        let size = map.granted_size();
        if self.state.as_ref().is_none_or(|s| s.color_layers.len() != layers || s.buffer.width() != size) {
            let state = self.build(shared, self.map.as_ref().expect("made above"));
            self.state = Some(state);
        }
        let state = self.state.as_mut().expect("built above");
        let map = self.map.as_ref().expect("made above");
        for (i, v) in map.frusta.views.iter().enumerate() {
            shared.gpu.queue.write_buffer(
                &state.matrices,
                i as u64 * state.stride,
                bytemuck::bytes_of(&v.view_projection),
            );
        }
        let topologies = topologies(shared, ctx.scene);
        let vertices: Vec<[f32; 4]> = instance_smoothies(ctx.scene, &topologies, ctx.light, self.emitter)
            .into_iter()
            .flat_map(|(_, v)| v)
            .collect();
        let bytes: &[u8] = bytemuck::cast_slice(&vertices);
        if state.vertices.as_ref().is_none_or(|b| b.size() < bytes.len() as u64) && !bytes.is_empty() {
            state.vertices = Some(shared.gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("smoothies"),
                size: (bytes.len() as u64).next_power_of_two(),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        if let Some(b) = &state.vertices {
            shared.gpu.queue.write_buffer(b, 0, bytes);
        }
        state.vertex_count = vertices.len() as u32;
        self.smoothie_triangles = u64::from(state.vertex_count / 3);
        let pipeline = render_pipeline(shared);
        for layer in 0..state.color_layers.len() {
            let timestamps = ctx.timer.render_pass(&ctx.gpu.device, PassKind::Shadow);
            let mut pass = ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("smoothie buffer"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &state.color_layers[layer],
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &state.depth_layers[layer],
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                timestamp_writes: timestamps,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if let (Some(b), true) = (&state.vertices, state.vertex_count > 0) {
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, Some(&state.matrices_group), &[(layer as u64 * state.stride) as u32]);
                pass.set_vertex_buffer(0, b.slice(..));
                pass.draw(0..state.vertex_count, 0..1);
            }
        }
        self.triangles = ctx.gpu_scene.triangles;
        Ok(())
    }

    fn map_demand(&self, light: &Light, bounds: &shadowlab_core::Aabb, dynamic: bool) -> Option<(u32, u32)> {
        Some(LightMap::demand(&self.params, light, bounds, dynamic))
    }

    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let (Some(group), Some(state)) = (self.map.as_ref().and_then(LightMap::group), &self.state) else { return };
        let group0 = ctx.shared.resolve_bind_group(ctx.surface, ctx.light_buffer, out);
        dispatch_resolve(ctx, "smoothies", &self.resolve, &[&group0, group, &state.group]);
    }

    fn stats(&self) -> TechniqueStats {
        let (Some(m), Some(s)) = (&self.map, &self.state) else { return TechniqueStats::default() };
        let (passes, draws, triangles) = m.counts(self.triangles);
        let layers = s.color_layers.len() as u32;
        let texture_bytes = |t: &wgpu::Texture, texel: u64| {
            u64::from(t.width()) * u64::from(t.height()) * u64::from(t.depth_or_array_layers()) * texel
        };
        TechniqueStats {
            memory_bytes: m.bytes()
                + texture_bytes(&s.buffer, 8)
                + texture_bytes(&s.depth, 4)
                + s.matrices.size()
                + s.vertices.as_ref().map_or(0, wgpu::Buffer::size)
                + self.uniform.size(),
            passes: passes + layers + 1,
            draws: draws + layers,
            triangles: triangles + self.smoothie_triangles * u64::from(layers),
            extra: vec![("smoothie_triangles".into(), self.smoothie_triangles as f64)],
        }
    }

    fn shown(&self) -> bool {
        self.map.as_ref().is_some_and(LightMap::shown)
    }

    fn current(&self) -> bool {
        self.map.as_ref().is_some_and(LightMap::current)
    }

    fn analysis(&self) -> Option<MapAnalysis<'_>> {
        let m = self.map.as_ref()?;
        Some(MapAnalysis { lookup: m.group()?, selection: &m.selection, views: &m.frusta.views })
    }
}
