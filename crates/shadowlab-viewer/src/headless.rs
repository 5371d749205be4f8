//! The viewer without a window: the same UI passes and drawing, into an offscreen texture that is
//! read back as the "screenshot" of the whole window. Tests and the README's pictures use it.

use std::time::Instant;

use glam::Vec3;
use shadowlab::Gpu;
use shadowlab_core::View;

use crate::present::{Painter, UI_FORMAT, step, ui_texture};
use crate::script::Script;
use crate::ui::{PANEL_WIDTH, Requests, Ui};
use crate::viewer::{Overlay, Setup, Viewer, ViewerError};

pub struct Headless {
    pub gpu: Gpu,
    pub viewer: Viewer,
    ui: Ui,
    painter: Painter,
    target: wgpu::Texture,
    start: Instant,
}

impl Headless {
    pub fn new(gpu: Gpu, setup: Setup) -> Result<Self, ViewerError> {
        let viewer = Viewer::new(&gpu, setup)?;
        let (w, h) = viewer.size();
        let painter = Painter::new(&gpu, UI_FORMAT, w, h);
        let ui = Ui::new(painter.scene_texture, painter.minimap_texture);
        let target = window_target(&gpu, w + PANEL_WIDTH, h);
        Ok(Self { gpu, viewer, ui, painter, target, start: Instant::now() })
    }

    /// The window's size: the panel beside the scene image.
    pub fn window_size(&self) -> (u32, u32) {
        let (w, h) = self.viewer.size();
        (w + PANEL_WIDTH, h)
    }

    /// One frame: a UI pass over `events` (pointer and keys, in window pixels), the scene
    /// rendered, the window drawn.
    pub fn frame(&mut self, events: Vec<egui::Event>) -> Result<Requests, ViewerError> {
        let (ww, wh) = self.window_size();
        let mut input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(ww as f32, wh as f32))),
            time: Some(self.start.elapsed().as_secs_f64()),
            events,
            focused: true,
            ..Default::default()
        };
        input.viewports.entry(egui::ViewportId::ROOT).or_default().native_pixels_per_point = Some(1.0);
        let (output, requests) = step(&self.gpu, &mut self.viewer, &mut self.ui, &mut self.painter, input, 1.0 / 30.0)?;
        if (self.target.width(), self.target.height()) != (ww, wh) {
            self.target = window_target(&self.gpu, ww, wh);
        }
        let view = self.target.create_view(&Default::default());
        let ctx = self.ui.ctx.clone();
        self.painter.paint(&self.gpu, &ctx, output, &view, [ww, wh]);
        Ok(requests)
    }

    /// The whole window as RGBA8, top row first.
    pub fn screenshot(&self) -> Result<image::RgbaImage, ViewerError> {
        let (w, h) = (self.target.width(), self.target.height());
        let bytes = shadowlab::util::read_texture(&self.gpu.device, &self.gpu.queue, &self.target, 4)?;
        image::RgbaImage::from_raw(w, h, bytes).ok_or_else(|| ViewerError::Other("screenshot size".into()))
    }

    /// Runs `script`'s steps, each followed by its frames.
    pub fn run_script(&mut self, script: &Script) -> Result<(), ViewerError> {
        for (i, step) in script.step.iter().enumerate() {
            let at = |e: ViewerError| ViewerError::Other(format!("script step {}: {e}", i + 1));
            let v = &mut self.viewer;
            if let Some(name) = &step.light {
                v.selected_light = v.find_light(name).map_err(at)?;
            }
            if let Some(spec) = &step.technique {
                v.set_technique(v.selected_light, spec).map_err(at)?;
            }
            if let (Some(p), Some(value)) = (&step.param, &step.value) {
                v.set_param(v.selected_light, p, value).map_err(at)?;
            }
            if let Some(o) = &step.overlay {
                v.overlay = Overlay::parse(o).ok_or_else(|| {
                    at(ViewerError::Other(format!(
                        "overlay '{o}' (known: none, visibility, splits, texels, sampling, fill, error)"
                    )))
                })?;
            }
            if let Some(name) = &step.view {
                v.go_to_view(name).map_err(at)?;
            }
            if let Some(text) = &step.camera {
                let view = View::with_camera_text(&v.camera.view(), text).map_err(|e| at(ViewerError::Other(e)))?;
                v.camera = crate::camera::FlyCamera::from_view(&view, v.scene().bounds().diagonal());
            }
            if let Some(spec) = &step.ab {
                v.set_ab((!spec.is_empty()).then_some(spec.as_str())).map_err(at)?;
            }
            if let Some(on) = step.third_person {
                v.set_third_person(on).map_err(at)?;
            }
            if let Some(k) = step.light_view {
                v.look_from_light_view(k).map_err(at)?;
            }
            let frames = step.frames.unwrap_or(1);
            if let (Some(name), Some(by)) = (&step.drag, step.by) {
                v.drag_by(name, Vec3::from_array(by), frames).map_err(at)?;
                self.frame(Vec::new()).map_err(at)?;
            } else {
                for _ in 0..frames {
                    self.frame(Vec::new()).map_err(at)?;
                }
            }
            #[cfg(feature = "truth")]
            if step.truth == Some(true) {
                let samples = self.viewer.truth_samples;
                self.viewer.start_truth(samples).map_err(at)?;
                while self.viewer.truth_job.is_some() {
                    self.frame(Vec::new()).map_err(at)?;
                }
            }
            #[cfg(not(feature = "truth"))]
            if step.truth == Some(true) {
                return Err(at(ViewerError::Other("built without the `truth` feature".into())));
            }
        }
        Ok(())
    }
}

fn window_target(gpu: &Gpu, width: u32, height: u32) -> wgpu::Texture {
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
    ui_texture(gpu, "viewer window", width, height, usage)
}
