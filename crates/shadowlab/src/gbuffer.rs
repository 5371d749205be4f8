//! The G-buffer: what the renderer draws from the camera before shadows and lighting (DESIGN.md
//! §6), and what the live engine draws of the permanent instances alone while objects are dragged
//! (`live::temporary`). One pipeline for both, so that the two depth buffers agree exactly
//! wherever they show the same surface.

use crate::context::Shared;
use crate::frame::{CameraUniform, SurfaceInputs};
use crate::gpu_scene::{DrawGroup, GpuScene, INSTANCE_LAYOUT, Sidedness, VERTEX_LAYOUT};
use crate::util;

pub const NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const ALBEDO_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
pub const EMISSIVE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Half floats (full ones are not renderable on downlevel adapters): N_g · L keeps its sign except
/// within about 1e-3 of grazing, where relevance is a coin toss for any convention.
pub const GEOMETRIC_NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A render target that passes can also read.
pub(crate) fn target(
    device: &wgpu::Device,
    label: &str,
    format: wgpu::TextureFormat,
    w: u32,
    h: u32,
    extra: wgpu::TextureUsages,
) -> wgpu::Texture {
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING | extra;
    util::texture_2d(device, label, format, (w, h), usage)
}

/// Depth, normals, albedo and emission of one size.
pub struct GBuffer {
    pub depth: wgpu::Texture,
    pub normal: wgpu::Texture,
    pub albedo: wgpu::Texture,
    pub emissive: wgpu::Texture,
    pub geometric_normal: wgpu::Texture,
}

impl GBuffer {
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Self {
        let none = wgpu::TextureUsages::empty();
        Self {
            depth: target(device, "depth", DEPTH_FORMAT, width, height, none),
            normal: target(device, "normal", NORMAL_FORMAT, width, height, none),
            albedo: target(device, "albedo", ALBEDO_FORMAT, width, height, none),
            emissive: target(device, "emissive", EMISSIVE_FORMAT, width, height, none),
            geometric_normal: target(device, "geometric normal", GEOMETRIC_NORMAL_FORMAT, width, height, none),
        }
    }

    pub fn size(&self) -> (u32, u32) {
        (self.depth.width(), self.depth.height())
    }

    pub fn bytes(&self) -> u64 {
        let (w, h) = self.size();
        // Depth 4, normal 8, albedo 4, emission 8, geometric normal 8 bytes a pixel.
        u64::from(w) * u64::from(h) * 32
    }

    /// The surface techniques shadow: this G-buffer's depth and normals, seen by `camera`.
    pub fn surface(&self, device: &wgpu::Device, camera: CameraUniform) -> SurfaceInputs {
        let view_of = |t: &wgpu::Texture| t.create_view(&Default::default());
        let (w, h) = self.size();
        let mut surface = SurfaceInputs::new(device, view_of(&self.depth), view_of(&self.normal), camera, w, h);
        surface.set_geometric_normal(view_of(&self.geometric_normal));
        surface
    }

    /// Draws the draw groups `keep` takes, seen through the camera uniform `camera`.
    pub fn draw(
        &self,
        shared: &Shared,
        encoder: &mut wgpu::CommandEncoder,
        gpu_scene: &GpuScene,
        camera: &wgpu::Buffer,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
        keep: impl Fn(&DrawGroup) -> bool,
    ) {
        let views = [&self.normal, &self.albedo, &self.emissive, &self.geometric_normal]
            .map(|t| t.create_view(&Default::default()));
        let clear = |view| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })
        };
        let depth_view = self.depth.create_view(&Default::default());
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("g-buffer"),
            color_attachments: &[clear(&views[0]), clear(&views[1]), clear(&views[2]), clear(&views[3])],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth_view,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        let camera_group = camera_group(shared, camera);
        gpu_scene.bind(&mut pass);
        pass.set_bind_group(0, Some(&camera_group), &[]);
        for g in gpu_scene.groups.iter().filter(|g| keep(g)) {
            // Single-sided surfaces are seen from the front only; double-sided from both sides.
            let cull = if g.sidedness == Sidedness::DoubleSided { None } else { Some(wgpu::Face::Back) };
            pass.set_pipeline(&pipeline(shared, cull, g.mirrored));
            if let Some(texture) = gpu_scene.base_colours.get(g.texture as usize) {
                pass.set_bind_group(1, Some(texture), &[]);
            }
            gpu_scene.draw(&mut pass, std::iter::once(g));
        }
    }
}

fn camera_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("gbuffer camera", || {
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("gbuffer camera"),
            entries: &[crate::context::uniform_entry(0, wgpu::ShaderStages::VERTEX)],
        })
    })
}

fn camera_group(shared: &Shared, camera: &wgpu::Buffer) -> wgpu::BindGroup {
    shared.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("gbuffer camera"),
        layout: &camera_layout(shared),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: camera.as_entire_binding() }],
    })
}

fn pipeline(shared: &Shared, cull: Option<wgpu::Face>, mirrored: bool) -> wgpu::RenderPipeline {
    let key = format!("gbuffer {cull:?} mirrored={mirrored}");
    shared.render_pipeline(&key, || {
        let device = &shared.gpu.device;
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("gbuffer"),
            bind_group_layouts: &[Some(&camera_layout(shared)), Some(&crate::gpu_scene::base_colour_layout(device))],
            immediate_size: 0,
        });
        let module = crate::shader::module(device, "gbuffer", include_str!("gbuffer.wgsl"));
        let color = |format| Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL });
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(&key),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(VERTEX_LAYOUT), Some(INSTANCE_LAYOUT)],
            },
            primitive: wgpu::PrimitiveState {
                cull_mode: cull,
                front_face: if mirrored { wgpu::FrontFace::Cw } else { wgpu::FrontFace::Ccw },
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[
                    color(NORMAL_FORMAT),
                    color(ALBEDO_FORMAT),
                    color(EMISSIVE_FORMAT),
                    color(GEOMETRIC_NORMAL_FORMAT),
                ],
            }),
            multiview_mask: None,
            cache: None,
        })
    })
}
