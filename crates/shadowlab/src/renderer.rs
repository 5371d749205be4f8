//! The deferred frame of DESIGN.md §2: G-buffer, shadows per light (a technique each, through the
//! embedded [`Shadows`]), additive lighting and tone mapping, with readbacks for the reference and
//! the reports.

use web_time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};
#[cfg(not(target_arch = "wasm32"))]
use shadowlab_core::SurfaceBuffer;
use shadowlab_core::{LightId, Scene, View};

use crate::context::Shared;
use crate::frame::{CameraUniform, SurfaceInputs, VisibilityLayer};
use crate::gbuffer::{GBuffer, target};
use crate::gpu::Gpu;
#[cfg(not(target_arch = "wasm32"))]
use crate::gpu::GpuError;
use crate::live::{Applied, Edit, EditError, Work};
use crate::registry::TechniqueSpec;
use crate::shadows::Shadows;
use crate::technique::TechniqueError;
use crate::timing::{FrameTimes, GpuTimer, PassKind};
use crate::util;

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct EnvironmentUniform {
    ambient: Vec4,
    background: Vec4,
}

const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// The final image.
pub const OUTPUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
pub use crate::gbuffer::DEPTH_FORMAT;
const BACKGROUND: Vec3 = Vec3::new(0.018, 0.022, 0.03);

/// Timings of one rendered frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameReport {
    /// GPU milliseconds per pass kind, when the adapter has timestamp queries.
    pub gpu: Option<FrameTimes>,
    /// Wall-clock milliseconds from recording to the GPU being done (includes CPU recording).
    pub cpu_ms: f64,
    /// Wall-clock milliseconds of recording and submitting the frame, before waiting for the GPU:
    /// the CPU's own part, which a fast GPU does not hide (a drag step's silhouettes and lists).
    pub record_ms: f64,
    /// What the shadows re-rendered this frame.
    pub work: Work,
}

/// The full deferred renderer: G-buffer, [`Shadows`], lighting, tone mapping.
pub struct Renderer {
    pub gpu: Gpu,
    pub shadows: Shadows,
    pub width: u32,
    pub height: u32,
    targets: Targets,
    environment: wgpu::Buffer,
    light_layout: wgpu::BindGroupLayout,
    timer: GpuTimer,
    pub exposure: f32,
    /// The view the camera was last set from: a resize rebuilds the camera from it (one rebuilt
    /// from the camera's own matrices is a few ulps off, and moved 1 242 of `room`'s pixel-lights
    /// under `ssm` at 128² in a resize to the same size).
    view: View,
}

/// The G-buffer and output targets of one size, with the bind groups over them.
struct Targets {
    surface: SurfaceInputs,
    gbuffer: GBuffer,
    hdr: wgpu::Texture,
    output: wgpu::Texture,
    lighting_group: wgpu::BindGroup,
    tonemap_group: wgpu::BindGroup,
}

impl Targets {
    fn new(shared: &Shared, environment: &wgpu::Buffer, camera: CameraUniform, width: u32, height: u32) -> Self {
        let device = &shared.gpu.device;
        let none = wgpu::TextureUsages::empty();
        let gbuffer = GBuffer::new(device, width, height);
        let hdr = target(device, "hdr", HDR_FORMAT, width, height, none);
        let output = target(device, "output", OUTPUT_FORMAT, width, height, wgpu::TextureUsages::COPY_SRC);
        let view_of = |t: &wgpu::Texture| t.create_view(&Default::default());
        let surface = gbuffer.surface(device, camera);
        let layouts = lighting_layouts(shared);
        let (albedo_view, emissive_view) = (view_of(&gbuffer.albedo), view_of(&gbuffer.emissive));
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 0, resource: surface.camera_buffer.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&surface.depth) },
            wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&surface.normal) },
            wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&albedo_view) },
            wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&emissive_view) },
            wgpu::BindGroupEntry { binding: 5, resource: environment.as_entire_binding() },
        ];
        if !shared.compute {
            // `SAMPLED_DEPTH` in lighting.wgsl.
            entries
                .push(wgpu::BindGroupEntry { binding: 6, resource: wgpu::BindingResource::Sampler(&shared.nearest) });
        }
        let lighting_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("lighting"),
            layout: &layouts.0,
            entries: &entries,
        });
        let tonemap_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tonemap"),
            layout: &layouts.2,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&view_of(&hdr)),
            }],
        });
        Self { surface, gbuffer, hdr, output, lighting_group, tonemap_group }
    }
}

impl Renderer {
    pub fn new(gpu: &Gpu, scene: Scene, view: &View, width: u32, height: u32) -> Self {
        let environment = util::uniform_buffer(
            &gpu.device,
            "environment",
            bytemuck::bytes_of(&EnvironmentUniform {
                ambient: scene.ambient.extend(1.0),
                background: BACKGROUND.extend(1.0),
            }),
        );
        let shadows = Shadows::new(gpu, scene);
        let layouts = lighting_layouts(shadows.shared());
        let targets =
            Targets::new(shadows.shared(), &environment, CameraUniform::from_view(view, width, height), width, height);
        Self {
            gpu: gpu.clone(),
            timer: GpuTimer::new(gpu),
            shadows,
            width,
            height,
            targets,
            environment,
            light_layout: layouts.1,
            exposure: 1.0,
            view: view.clone(),
        }
    }

    /// The surface the shadows are computed on (depth, normals, camera).
    pub fn surface(&self) -> &SurfaceInputs {
        &self.targets.surface
    }

    /// [`Shadows::provide_light_meshes`].
    pub fn provide_light_meshes(&mut self, meshes: Vec<shadowlab_core::lightmesh::LightMesh>) -> usize {
        self.shadows.provide_light_meshes(meshes)
    }

    /// Applies a scene edit between frames (see [`Shadows::apply`]).
    pub fn apply(&mut self, edit: Edit) -> Result<Applied, EditError> {
        self.shadows.apply(edit)
    }

    /// Resizes the output: the G-buffer, the image and every light's visibility layer.
    pub fn resize(&mut self, width: u32, height: u32) -> Result<(), EditError> {
        self.shadows.resize(width, height)?;
        // Keep the view, with the new aspect ratio.
        let view = &self.view;
        self.width = width;
        self.height = height;
        self.targets = Targets::new(
            self.shadows.shared(),
            &self.environment,
            CameraUniform::from_view(view, width, height),
            width,
            height,
        );
        Ok(())
    }

    pub fn scene(&self) -> &Scene {
        self.shadows.scene()
    }

    pub fn set_view(&mut self, view: &View) {
        self.targets.surface.set_camera(&self.gpu.queue, CameraUniform::from_view(view, self.width, self.height));
        self.view = view.clone();
    }

    /// Shadows `light` with `spec`.
    pub fn set_technique(&mut self, light: LightId, spec: &TechniqueSpec) -> Result<(), TechniqueError> {
        self.shadows.set_technique(light, spec, self.width, self.height)
    }

    /// Records and submits one frame without waiting for it (what a browser's frame callback
    /// calls: nothing here blocks); returns what the frame re-did. The scheduler learns from
    /// [`Renderer::observe`]'s frame times instead of timestamps read back.
    pub fn frame(&mut self) -> Result<Work, TechniqueError> {
        let (work, _) = self.record_frame()?;
        Ok(work)
    }

    /// Tells the scheduler what the last frame submitted by [`Renderer::frame`] cost (the
    /// application's own clock, milliseconds).
    pub fn observe(&mut self, work: &Work, frame_ms: f64) {
        self.shadows.observe_measured(work, f64::NAN, frame_ms);
    }

    fn record_frame(&mut self) -> Result<(Work, Instant), TechniqueError> {
        let start = Instant::now();
        self.timer.begin_frame();
        let device = self.gpu.device.clone();
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        // The G-buffer draws this frame's instances: edits reach the GPU first.
        self.shadows.sync();
        self.gbuffer_pass(&mut encoder);
        let work = self.shadows.record(&mut encoder, &self.targets.surface, &mut self.timer)?;
        self.lighting_passes(&mut encoder, None);
        self.gpu.queue.submit([encoder.finish()]);
        Ok((work, start))
    }

    /// The frame's error for device error `e`: after running out of memory, with what the
    /// shadows hold and the largest holder.
    pub fn device_error(&self, e: &str) -> TechniqueError {
        let mut message = format!("GPU error: {e}");
        if e.starts_with(crate::gpu::OUT_OF_MEMORY) {
            message += &format!("; {}", self.shadows.out_of_memory_hint());
        }
        TechniqueError::Failed { id: "frame".into(), message }
    }

    /// Renders one frame and waits for it; returns its timings (native only: it blocks).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn render(&mut self) -> Result<FrameReport, TechniqueError> {
        let (work, start) = self.record_frame()?;
        let record_ms = start.elapsed().as_secs_f64() * 1e3;
        self.gpu.wait();
        if let Some(e) = self.gpu.take_error() {
            return Err(self.device_error(&e));
        }
        let cpu_ms = start.elapsed().as_secs_f64() * 1e3;
        let gpu = self
            .timer
            .read(&self.gpu)
            .map_err(|e| TechniqueError::Failed { id: "frame".into(), message: e.to_string() })?;
        // The scheduler learns from what the frame cost: its fills (the shadow passes) and the rest.
        match gpu {
            Some(t) => {
                let fill = t.get(PassKind::Shadow);
                self.shadows.observe_measured(&work, fill, t.total() - fill);
            }
            None => self.shadows.observe_measured(&work, f64::NAN, cpu_ms),
        }
        Ok(FrameReport { gpu, cpu_ms, record_ms, work })
    }

    /// Shadows `light` with a quality ladder (see [`Shadows::set_ladder`]).
    pub fn set_ladder(&mut self, light: LightId, specs: &[TechniqueSpec]) -> Result<(), TechniqueError> {
        self.shadows.set_ladder(light, specs, self.width, self.height)
    }

    /// Spreads the shadows' cache fills over frames to keep to `target_ms` (see
    /// [`Shadows::set_target_ms`]).
    pub fn set_target_ms(&mut self, target_ms: Option<f64>) {
        self.shadows.set_target_ms(target_ms);
    }

    fn gbuffer_pass(&mut self, encoder: &mut wgpu::CommandEncoder) {
        let timestamps = self.timer.render_pass(&self.gpu.device, PassKind::Gbuffer);
        let camera = &self.targets.surface.camera_buffer;
        self.targets
            .gbuffer
            .draw(self.shadows.shared(), encoder, self.shadows.gpu_scene(), camera, timestamps, |_| true);
    }

    /// Base pass, one additive pass per light, tone mapping. With `override_layers`, lights use
    /// those layers instead of their techniques' (to light the frame with reference visibility).
    fn lighting_passes(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        override_layers: Option<&[(LightId, VisibilityLayer)]>,
    ) {
        let shared = self.shadows.shared();
        let device = &self.gpu.device;
        let hdr_view = self.targets.hdr.create_view(&Default::default());
        let timestamps = self.timer.render_pass(device, PassKind::Lighting);
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("lighting"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &hdr_view,
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
            pass.set_bind_group(0, Some(&self.targets.lighting_group), &[]);
            pass.set_pipeline(&lighting_pipeline(shared, "fs_base", false));
            pass.draw(0..3, 0..1);
            pass.set_pipeline(&lighting_pipeline(shared, "fs_light", true));
            for s in &self.shadows.lights {
                let layer = match override_layers {
                    Some(list) => match list.iter().find(|(id, _)| *id == s.light) {
                        Some((_, l)) => l,
                        None => continue,
                    },
                    None => &s.layer,
                };
                let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("light"),
                    layout: &self.light_layout,
                    entries: &[
                        wgpu::BindGroupEntry { binding: 0, resource: s.light_buffer.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&layer.view) },
                    ],
                });
                pass.set_bind_group(1, Some(&group), &[]);
                pass.draw(0..3, 0..1);
            }
        }
        let output_view = self.targets.output.create_view(&Default::default());
        let timestamps = self.timer.render_pass(device, PassKind::Lighting);
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("tone mapping"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &output_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        self.gpu.queue.write_buffer(
            &self.environment,
            0,
            bytemuck::bytes_of(&EnvironmentUniform {
                ambient: self.shadows.scene().ambient.extend(self.exposure),
                background: BACKGROUND.extend(1.0),
            }),
        );
        pass.set_pipeline(&tonemap_pipeline(shared));
        pass.set_bind_group(0, Some(&self.targets.lighting_group), &[]);
        pass.set_bind_group(2, Some(&self.targets.tonemap_group), &[]);
        pass.draw(0..3, 0..1);
    }

    /// The final image as tightly packed sRGB RGB bytes.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn read_image(&self) -> Result<Vec<u8>, GpuError> {
        let rgba = util::read_texture(&self.gpu.device, &self.gpu.queue, &self.targets.output, 4)?;
        Ok(rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect())
    }

    /// The tone-mapped image (`OUTPUT_FORMAT`, sampled and copied from), for an application that
    /// shows it itself (the viewer draws it inside its window).
    pub fn output_texture(&self) -> &wgpu::Texture {
        &self.targets.output
    }

    /// A light's visibility layer as floats (row-major, top row first).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn read_visibility(&self, light: LightId) -> Result<Option<Vec<f32>>, GpuError> {
        match self.shadows.lights.iter().find(|s| s.light == light) {
            Some(s) => {
                Ok(Some(util::f32s(&util::read_texture(&self.gpu.device, &self.gpu.queue, &s.layer.texture, 4)?)))
            }
            None => Ok(None),
        }
    }

    /// The visibility a fresh, uncached engine on the same state (scene, techniques, size) gives on
    /// the last rendered frame's surface, per shadowed light **index** (`scene().lights[i]`): what
    /// the live engine must equal (DESIGN.md §11, "never stale").
    #[cfg(not(target_arch = "wasm32"))]
    pub fn fresh_visibility(&self) -> Result<Vec<(usize, Vec<f32>)>, TechniqueError> {
        let fail = |e: GpuError| TechniqueError::Failed { id: "fresh".into(), message: e.to_string() };
        let mut fresh = self.shadows.fresh()?;
        let mut timer = GpuTimer::new(&self.gpu);
        timer.begin_frame();
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        fresh.record(&mut encoder, &self.targets.surface, &mut timer)?;
        self.gpu.queue.submit([encoder.finish()]);
        self.gpu.wait();
        let mut out = Vec::new();
        for s in &fresh.lights {
            let values = util::read_texture(&self.gpu.device, &self.gpu.queue, &s.layer.texture, 4).map_err(fail)?;
            out.push((s.light.index(), util::f32s(&values)));
        }
        Ok(out)
    }

    /// The visibility of every shadowed light, by light index (as [`Renderer::fresh_visibility`]).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn live_visibility(&self) -> Result<Vec<(usize, Vec<f32>)>, GpuError> {
        let mut out = Vec::new();
        for s in &self.shadows.lights {
            let Some(index) = self.shadows.live().light_index(s.light) else { continue };
            let values = util::read_texture(&self.gpu.device, &self.gpu.queue, &s.layer.texture, 4)?;
            out.push((index, util::f32s(&values)));
        }
        Ok(out)
    }

    /// The surface the techniques shade: positions (in the scene's local frame) reconstructed from
    /// depth exactly as their shaders do, the G-buffer normals and the facets' normals.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn read_surface(&self) -> Result<SurfaceBuffer, GpuError> {
        let device = &self.gpu.device;
        let n = u64::from(self.width) * u64::from(self.height);
        let make = |label| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: n * 16,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let (positions, normals, geometric_normals) = (make("positions"), make("normals"), make("geometric normals"));
        let shared = self.shadows.shared();
        let pipeline = shared.compute_pipeline("export surface", || {
            let module = crate::shader::module(device, "export surface", include_str!("export_surface.wgsl"));
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("export surface"),
                layout: None,
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            })
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("export surface"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.targets.surface.camera_buffer.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&self.targets.surface.depth),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&self.targets.surface.normal),
                },
                wgpu::BindGroupEntry { binding: 3, resource: positions.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: normals.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::TextureView(
                        &self.targets.gbuffer.geometric_normal.create_view(&Default::default()),
                    ),
                },
                wgpu::BindGroupEntry { binding: 6, resource: geometric_normals.as_entire_binding() },
            ],
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, Some(&group), &[]);
            pass.dispatch_workgroups(util::groups(self.width, 8), util::groups(self.height, 8), 1);
        }
        self.gpu.queue.submit([encoder.finish()]);
        let p = util::f32s(&util::read_buffer(device, &self.gpu.queue, &positions)?);
        let nn = util::f32s(&util::read_buffer(device, &self.gpu.queue, &normals)?);
        let ng = util::f32s(&util::read_buffer(device, &self.gpu.queue, &geometric_normals)?);
        let mut out = SurfaceBuffer::new(self.width, self.height);
        for i in 0..n as usize {
            out.covered[i] = p[4 * i + 3] > 0.5;
            out.positions[i] = Vec3::new(p[4 * i], p[4 * i + 1], p[4 * i + 2]);
            out.normals[i] = Vec3::new(nn[4 * i], nn[4 * i + 1], nn[4 * i + 2]).normalize_or(Vec3::Y);
            out.geometric_normals[i] = Vec3::new(ng[4 * i], ng[4 * i + 1], ng[4 * i + 2]).normalize_or(out.normals[i]);
        }
        Ok(out)
    }

    /// Relights the current G-buffer with the given visibility per light (NaN counts as 1) and
    /// returns the image: how the frame looks with, say, the reference's shadows.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn image_with_visibility(&mut self, layers: &[(LightId, &[f32])]) -> Result<Vec<u8>, GpuError> {
        let device = self.gpu.device.clone();
        let uploaded: Vec<(LightId, VisibilityLayer)> = layers
            .iter()
            .map(|(id, values)| {
                let layer = VisibilityLayer::new(&device, self.width, self.height, "override");
                let clean: Vec<f32> = values.iter().map(|v| if v.is_nan() { 1.0 } else { *v }).collect();
                self.gpu.queue.write_texture(
                    layer.texture.as_image_copy(),
                    bytemuck::cast_slice(&clean),
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(4 * self.width),
                        rows_per_image: Some(self.height),
                    },
                    layer.texture.size(),
                );
                (*id, layer)
            })
            .collect();
        self.timer.begin_frame();
        let mut encoder = device.create_command_encoder(&Default::default());
        self.lighting_passes(&mut encoder, Some(&uploaded));
        self.gpu.queue.submit([encoder.finish()]);
        self.gpu.wait();
        self.read_image()
    }
}

fn lighting_layouts(shared: &Shared) -> (wgpu::BindGroupLayout, wgpu::BindGroupLayout, wgpu::BindGroupLayout) {
    let device = &shared.gpu.device;
    let tex = |binding, sample_type| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    };
    let float = wgpu::TextureSampleType::Float { filterable: false };
    let frag = wgpu::ShaderStages::FRAGMENT;
    let g0 = shared.layout("lighting group 0", || {
        let mut entries = vec![
            crate::context::uniform_entry(0, frag),
            tex(1, float),
            tex(2, float),
            tex(3, float),
            tex(4, float),
            crate::context::uniform_entry(5, frag),
        ];
        if !shared.compute {
            // `SAMPLED_DEPTH`: depths through `Shared::nearest`.
            entries.push(wgpu::BindGroupLayoutEntry {
                binding: 6,
                visibility: frag,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::NonFiltering),
                count: None,
            });
        }
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("lighting group 0"),
            entries: &entries,
        })
    });
    let g1 = shared.layout("lighting group 1", || {
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("lighting group 1"),
            entries: &[
                // The light (`util::branch_buffer`).
                crate::context::branch_entry(0, frag, shared.compute),
                tex(1, float),
            ],
        })
    });
    let g2 = shared.layout("lighting group 2", || {
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("lighting group 2"),
            entries: &[tex(0, float)],
        })
    });
    (g0, g1, g2)
}

fn lighting_pipeline(shared: &Shared, entry: &str, additive: bool) -> wgpu::RenderPipeline {
    let key = format!("lighting {entry}");
    shared.render_pipeline(&key, || {
        let device = &shared.gpu.device;
        let (g0, g1, g2) = lighting_layouts(shared);
        let _ = g2;
        // The base pass reads group 0 only; light passes groups 0 and 1.
        let groups: &[Option<&wgpu::BindGroupLayout>] = if additive { &[Some(&g0), Some(&g1)] } else { &[Some(&g0)] };
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(&key),
            bind_group_layouts: groups,
            immediate_size: 0,
        });
        let defines: &[&str] = if shared.compute { &[] } else { &["SAMPLED_DEPTH"] };
        let module = crate::shader::module_with(device, "lighting", include_str!("lighting.wgsl"), defines);
        let blend = additive.then_some(wgpu::BlendState {
            color: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::One,
                dst_factor: wgpu::BlendFactor::One,
                operation: wgpu::BlendOperation::Add,
            },
            alpha: wgpu::BlendComponent::REPLACE,
        });
        fullscreen_pipeline(device, &key, &layout, &module, entry, HDR_FORMAT, blend)
    })
}

fn tonemap_pipeline(shared: &Shared) -> wgpu::RenderPipeline {
    shared.render_pipeline("tonemap", || {
        let device = &shared.gpu.device;
        let (g0, _, g2) = lighting_layouts(shared);
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("tonemap"),
            bind_group_layouts: &[Some(&g0), None, Some(&g2)],
            immediate_size: 0,
        });
        let defines: &[&str] = if shared.compute { &[] } else { &["SAMPLED_DEPTH"] };
        let module = crate::shader::module_with(device, "lighting", include_str!("lighting.wgsl"), defines);
        fullscreen_pipeline(device, "tonemap", &layout, &module, "fs_tonemap", OUTPUT_FORMAT, None)
    })
}

fn fullscreen_pipeline(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    entry: &str,
    format: wgpu::TextureFormat,
    blend: Option<wgpu::BlendState>,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_fullscreen"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState { format, blend, write_mask: wgpu::ColorWrites::ALL })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// Per-pixel analysis of the maps that shade one light (`overlay.wgsl`).
#[derive(Debug, Clone)]
pub struct MapOverlay {
    pub width: u32,
    pub height: u32,
    /// The map (split, cube face) that shades each pixel; −1 for the background.
    pub map: Vec<i32>,
    /// Shadow-map texels per screen pixel (Lloyd's determinant): < 1 undersampled.
    pub texels_per_pixel: Vec<f32>,
    /// The pixel lies on a line of the projected texel grid.
    pub grid_line: Vec<bool>,
    /// The pixel projects inside its map.
    pub on_map: Vec<bool>,
}

impl Renderer {
    /// Shadow-volume fragments per pixel of the first rendered frame, summed over `lights`
    /// (Hasselgren 2003 Fig. 8's overdraw); `None` when none of their techniques draws volumes.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn fill_counts(&self, lights: &[LightId]) -> Result<Option<Vec<u32>>, GpuError> {
        let pixels = self.width as usize * self.height as usize;
        let mut total: Option<Vec<u32>> = None;
        for s in self.shadows.lights.iter().filter(|s| lights.contains(&s.light)) {
            for buffer in s.shown_technique().fill_counts() {
                let bytes = util::read_buffer(&self.gpu.device, &self.gpu.queue, buffer)?;
                let sum = total.get_or_insert_with(|| vec![0; pixels]);
                for (t, c) in sum.iter_mut().zip(bytes[16..].chunks_exact(4)) {
                    *t = t.saturating_add(u32::from_le_bytes([c[0], c[1], c[2], c[3]]));
                }
            }
        }
        Ok(total)
    }

    /// The map views (cube faces, cascade splits, emitter samples' views) `light`'s technique
    /// shaded the last frame from; empty for techniques without maps.
    pub fn light_views(&self, light: LightId) -> Vec<shadowlab_core::lightspace::ShadowView> {
        let Some(s) = self.shadows.lights.iter().find(|s| s.light == light) else { return Vec::new() };
        s.shown_technique().map_views()
    }

    /// Analyses the maps of `light`'s technique for the last rendered frame; `None` when the
    /// technique does not shade from one map per pixel (`none`, `sampled`). `grid` is the spacing of
    /// the texel-grid lines in texels.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn map_overlay(&self, light: LightId, grid: u32) -> Result<Option<MapOverlay>, GpuError> {
        let Some(s) = self.shadows.lights.iter().find(|s| s.light == light) else { return Ok(None) };
        let Some(maps) = s.shown_technique().analysis() else { return Ok(None) };
        let shared = self.shadows.shared();
        let device = &self.gpu.device;
        let (w, h) = (self.width, self.height);
        let layout = shared.layout("overlay", || {
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("overlay"),
                entries: &[
                    crate::context::uniform_entry(0, wgpu::ShaderStages::COMPUTE),
                    wgpu::BindGroupLayoutEntry {
                        binding: 1,
                        visibility: wgpu::ShaderStages::COMPUTE,
                        ty: wgpu::BindingType::StorageTexture {
                            access: wgpu::StorageTextureAccess::WriteOnly,
                            format: wgpu::TextureFormat::Rgba32Float,
                            view_dimension: wgpu::TextureViewDimension::D2,
                        },
                        count: None,
                    },
                ],
            })
        });
        let pipeline = shared.resolve_pipeline(
            "overlay",
            include_str!("overlay.wgsl"),
            "main",
            &[&crate::shadowmap::lookup_layout(shared), &layout, &crate::shadowmap::selection_layout(shared)],
            &[],
        );
        let out = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("overlay"),
            size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba32Float,
            usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let params =
            util::uniform_buffer(device, "overlay params", bytemuck::cast_slice(&[grid.max(1) as f32, 0.0, 0.0, 0.0]));
        let out_view = out.create_view(&Default::default());
        let group2 = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("overlay"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&out_view) },
            ],
        });
        let group0 = shared.resolve_bind_group(&self.targets.surface, &s.light_buffer, &s.layer);
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            for (i, g) in [&group0, maps.lookup, &group2, maps.selection].into_iter().enumerate() {
                pass.set_bind_group(i as u32, Some(g), &[]);
            }
            pass.dispatch_workgroups(util::groups(w, 8), util::groups(h, 8), 1);
        }
        self.gpu.queue.submit([encoder.finish()]);
        let v = util::f32s(&util::read_texture(device, &self.gpu.queue, &out, 16)?);
        let n = (w * h) as usize;
        Ok(Some(MapOverlay {
            width: w,
            height: h,
            map: (0..n).map(|i| v[4 * i] as i32).collect(),
            texels_per_pixel: (0..n).map(|i| v[4 * i + 1]).collect(),
            grid_line: (0..n).map(|i| v[4 * i + 2] > 0.5).collect(),
            on_map: (0..n).map(|i| v[4 * i + 3] > 0.5).collect(),
        }))
    }
}
