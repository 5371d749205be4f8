//! Drawing the window: the scene image handed to egui as a texture, then egui's triangles
//! (egui-wgpu) into whatever target the run has, a window's surface or an offscreen texture.

use shadowlab::Gpu;

use crate::ui::{Requests, Ui};
use crate::viewer::{Overlay, Viewer, ViewerError};

/// The part of a frame every run shares: a UI pass over `input` (which may change `viewer`), the
/// scene rendered, its image brought into the painter (an overlay the technique cannot show is
/// turned off with a message). The caller paints the returned output into its target.
pub fn step(
    gpu: &Gpu,
    viewer: &mut Viewer,
    ui: &mut Ui,
    painter: &mut Painter,
    input: egui::RawInput,
    seconds: f32,
) -> Result<(egui::FullOutput, Requests), ViewerError> {
    let (mut output, requests) = ui.run(viewer, input, seconds);
    let mut shown = match viewer.render() {
        Ok(_) => painter.update_scene(gpu, viewer),
        // Not an overlay's fault: no retry below.
        Err(e) => {
            output.textures_delta.clear();
            return Err(e);
        }
    };
    if let Err(e) = &shown
        && viewer.overlay != Overlay::None
    {
        viewer.status = e.to_string();
        viewer.overlay = Overlay::None;
        shown = painter.update_scene(gpu, viewer);
    }
    match shown {
        Ok(()) => Ok((output, requests)),
        Err(e) => {
            // Nothing is drawn this frame (egui hands its texture changes out again).
            output.textures_delta.clear();
            Err(e)
        }
    }
}

/// The format egui draws in and the scene image is shown from: gamma-space bytes (egui-wgpu's
/// preferred output; the renderer's sRGB image is copied byte for byte, so the window shows
/// exactly its pixels).
pub const UI_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

pub struct Painter {
    egui: egui_wgpu::Renderer,
    /// The scene image in `UI_FORMAT` (egui's native textures must be `Rgba8Unorm`).
    scene: wgpu::Texture,
    pub scene_texture: egui::TextureId,
    /// The eye's image while the third-person view fills the scene area.
    minimap: wgpu::Texture,
    pub minimap_texture: egui::TextureId,
}

impl Painter {
    /// A painter drawing into targets of `format` (the surface's, or `UI_FORMAT` offscreen).
    pub fn new(gpu: &Gpu, format: wgpu::TextureFormat, width: u32, height: u32) -> Self {
        let options = egui_wgpu::RendererOptions { dithering: false, ..egui_wgpu::RendererOptions::PREDICTABLE };
        let mut egui = egui_wgpu::Renderer::new(&gpu.device, format, options);
        let scene = scene_texture_of(gpu, width, height);
        let view = scene.create_view(&Default::default());
        let scene_texture = egui.register_native_texture(&gpu.device, &view, wgpu::FilterMode::Nearest);
        let minimap = scene_texture_of(gpu, width, height);
        let view = minimap.create_view(&Default::default());
        let minimap_texture = egui.register_native_texture(&gpu.device, &view, wgpu::FilterMode::Linear);
        Self { egui, scene, scene_texture, minimap, minimap_texture }
    }

    /// Brings the viewer's last image (and overlay) into the scene texture.
    pub fn update_scene(&mut self, gpu: &Gpu, viewer: &Viewer) -> Result<(), ViewerError> {
        let (w, h) = viewer.size();
        if (self.scene.width(), self.scene.height()) != (w, h) {
            self.scene = scene_texture_of(gpu, w, h);
            self.minimap = scene_texture_of(gpu, w, h);
            let minimap = self.minimap.create_view(&Default::default());
            self.egui.update_egui_texture_from_wgpu_texture(
                &gpu.device,
                &minimap,
                wgpu::FilterMode::Linear,
                self.minimap_texture,
            );
            let view = self.scene.create_view(&Default::default());
            self.egui.update_egui_texture_from_wgpu_texture(
                &gpu.device,
                &view,
                wgpu::FilterMode::Nearest,
                self.scene_texture,
            );
        }
        if let Some(tp) = &viewer.third_person {
            // The second camera's image in the scene area, the eye's (with its overlay) in the minimap.
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            encoder.copy_texture_to_texture(
                tp.renderer.output_texture().as_image_copy(),
                self.scene.as_image_copy(),
                self.scene.size(),
            );
            gpu.queue.submit([encoder.finish()]);
            return write_or_copy(gpu, viewer, &self.minimap);
        }
        write_or_copy(gpu, viewer, &self.scene)
    }

    /// Draws `output` (one UI pass) into `target` of `size` pixels.
    pub fn paint(
        &mut self,
        gpu: &Gpu,
        ctx: &egui::Context,
        mut output: egui::FullOutput,
        target: &wgpu::TextureView,
        size: [u32; 2],
    ) {
        let pixels_per_point = output.pixels_per_point;
        let screen = egui_wgpu::ScreenDescriptor { size_in_pixels: size, pixels_per_point };
        for (id, deltas) in output.textures_delta.set.drain() {
            for delta in &deltas {
                self.egui.update_texture(&gpu.device, &gpu.queue, id, delta);
            }
        }
        let jobs = ctx.tessellate(std::mem::take(&mut output.shapes), pixels_per_point);
        let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("ui") });
        let extra = self.egui.update_buffers(&gpu.device, &gpu.queue, &mut encoder, &jobs, &screen);
        {
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("ui"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: target,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                })
                .forget_lifetime();
            self.egui.render(&mut pass, &jobs, &screen);
        }
        gpu.queue.submit(extra.into_iter().chain([encoder.finish()]));
        for id in output.textures_delta.free.drain() {
            self.egui.free_texture(&id);
        }
    }
}

/// The eye's image into `target`: a GPU copy of the sRGB output, or the overlay composed on the CPU.
fn write_or_copy(gpu: &Gpu, viewer: &Viewer, target: &wgpu::Texture) -> Result<(), ViewerError> {
    let (w, h) = viewer.size();
    if viewer.overlay == Overlay::None && viewer.ab.is_none() {
        // On the GPU: the sRGB output's bytes, as they are.
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_texture(
            viewer.renderer.output_texture().as_image_copy(),
            target.as_image_copy(),
            target.size(),
        );
        gpu.queue.submit([encoder.finish()]);
    } else {
        let rgba = viewer.image_rgba()?;
        gpu.queue.write_texture(
            target.as_image_copy(),
            &rgba,
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * w), rows_per_image: Some(h) },
            target.size(),
        );
    }
    Ok(())
}

fn scene_texture_of(gpu: &Gpu, width: u32, height: u32) -> wgpu::Texture {
    ui_texture(gpu, "viewer scene", width, height, wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST)
}

/// A `UI_FORMAT` texture of `width × height`.
pub fn ui_texture(gpu: &Gpu, label: &str, width: u32, height: u32, usage: wgpu::TextureUsages) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: UI_FORMAT,
        usage,
        view_formats: &[],
    })
}
