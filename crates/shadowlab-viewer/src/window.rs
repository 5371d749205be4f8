//! The viewer in a real window (winit 0.30): a surface on the adapter that can present to it, egui
//! fed by egui-winit, the same UI passes and drawing as the headless run.

use std::sync::Arc;
use std::time::Instant;

use shadowlab::Gpu;
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::window::{Window, WindowId};

use crate::present::{Painter, step};
use crate::ui::{PANEL_WIDTH, Ui};
use crate::viewer::{Setup, Viewer, ViewerError};

/// How the windowed run ends: the user closes it, or after `frames` frames (tests under Xvfb).
#[derive(Debug, Clone)]
pub struct WindowOptions {
    pub setup: Setup,
    pub frames: Option<u64>,
    /// Where the "screenshot" button writes.
    pub screenshot_dir: std::path::PathBuf,
}

/// Opens the window and runs until it closes; the frames drawn.
pub fn run(options: WindowOptions) -> Result<u64, ViewerError> {
    // The scene first: a mistake in it is reported before any window opens.
    let loaded = Viewer::load(&options.setup)?;
    let event_loop = EventLoop::new().map_err(|e| ViewerError::Other(format!("no window system: {e}")))?;
    let mut app = App { options, loaded: Some(loaded), running: None, error: None, frames: 0 };
    event_loop.run_app(&mut app).map_err(|e| ViewerError::Other(format!("event loop: {e}")))?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(app.frames),
    }
}

struct App {
    options: WindowOptions,
    /// The scene, until the window's viewer takes it.
    loaded: Option<shadowlab_core::load::Loaded>,
    running: Option<Running>,
    error: Option<ViewerError>,
    frames: u64,
}

struct Running {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: Gpu,
    viewer: Viewer,
    ui: Ui,
    painter: Painter,
    input: egui_winit::State,
    last: Instant,
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: ViewerError) {
        self.error.get_or_insert(e);
        event_loop.exit();
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        let Some(loaded) = self.loaded.take() else { return };
        match open(event_loop, &self.options.setup, loaded) {
            Ok(r) => {
                r.window.request_redraw();
                self.running = Some(r);
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(r) = &mut self.running else { return };
        let _ = r.input.on_window_event(&r.window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                r.config.width = size.width.max(1);
                r.config.height = size.height.max(1);
                r.surface.configure(&r.gpu.device, &r.config);
                // The scene image is shown at one point per pixel: on a high-density screen it
                // takes the window's size in points, less the panel.
                let scale = r.window.scale_factor().max(0.25);
                let points = |px: u32| (f64::from(px) / scale) as u32;
                let (w, h) = (points(size.width).saturating_sub(PANEL_WIDTH).max(16), points(size.height).max(16));
                if (w, h) != r.viewer.size()
                    && let Err(e) = r.viewer.renderer.resize(w, h)
                {
                    r.viewer.status = e.to_string();
                }
            }
            WindowEvent::RedrawRequested => {
                let result = frame(r, &self.options);
                self.frames += 1;
                match result {
                    Err(e) => self.fail(event_loop, e),
                    Ok(()) if self.options.frames.is_some_and(|n| self.frames >= n) => event_loop.exit(),
                    Ok(()) => {}
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(r) = &self.running {
            r.window.request_redraw();
        }
    }
}

/// The window's surface and an adapter that can present to it, from an instance that checks
/// indirect calls' arguments or not.
fn presenting_adapter(
    event_loop: &ActiveEventLoop,
    window: &Arc<Window>,
    check_indirect: bool,
) -> Result<(wgpu::Surface<'static>, wgpu::Adapter), ViewerError> {
    let mut desc = wgpu::InstanceDescriptor::new_with_display_handle(Box::new(event_loop.owned_display_handle()));
    if !check_indirect {
        desc.flags.remove(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL);
    }
    let instance = wgpu::Instance::new(desc);
    let surface = instance
        .create_surface(window.clone())
        .map_err(|e| ViewerError::Other(format!("cannot draw into the window: {e}")))?;
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        force_fallback_adapter: false,
        compatible_surface: Some(&surface),
        ..Default::default()
    }))
    .map_err(|e| ViewerError::Other(format!("no GPU can present to the window: {e}")))?;
    Ok((surface, adapter))
}

fn open(
    event_loop: &ActiveEventLoop,
    setup: &Setup,
    loaded: shadowlab_core::load::Loaded,
) -> Result<Running, ViewerError> {
    let attributes = Window::default_attributes()
        .with_title(format!("shadowlab — {}", setup.scene))
        .with_inner_size(winit::dpi::PhysicalSize::new(setup.width + PANEL_WIDTH, setup.height));
    let window = Arc::new(
        event_loop.create_window(attributes).map_err(|e| ViewerError::Other(format!("cannot open a window: {e}")))?,
    );
    let (mut surface, mut adapter) = presenting_adapter(event_loop, &window, true)?;
    if adapter.get_info().device_type == wgpu::DeviceType::Cpu {
        // As `Gpu::new` does: wgpu's check of each indirect dispatch costs about 25 ms on llvmpipe,
        // and shadowlab bounds its indirect arguments itself (ARCHITECTURE.md, invariants).
        drop((surface, adapter));
        (surface, adapter) = presenting_adapter(event_loop, &window, false)?;
    }
    let gpu = pollster::block_on(Gpu::open(&adapter))?;
    let caps = surface.get_capabilities(&adapter);
    // egui draws in gamma space: a non-sRGB surface shows its bytes as they are.
    let format = caps
        .formats
        .iter()
        .copied()
        .find(|f| !f.is_srgb())
        .or_else(|| caps.formats.first().copied())
        .ok_or_else(|| ViewerError::Other("the window's surface offers no format".into()))?;
    let size = window.inner_size();
    let config = wgpu::SurfaceConfiguration {
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        format,
        color_space: wgpu::SurfaceColorSpace::Auto,
        width: size.width.max(1),
        height: size.height.max(1),
        present_mode: wgpu::PresentMode::AutoVsync,
        desired_maximum_frame_latency: 2,
        alpha_mode: caps.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
        view_formats: vec![],
    };
    surface.configure(&gpu.device, &config);
    let viewer = Viewer::with_scene(&gpu, setup.clone(), loaded)?;
    let (w, h) = viewer.size();
    let painter = Painter::new(&gpu, format, w, h);
    let ui = Ui::new(painter.scene_texture, painter.minimap_texture);
    let input = egui_winit::State::new(
        ui.ctx.clone(),
        egui::ViewportId::ROOT,
        &window,
        Some(window.scale_factor() as f32),
        None,
        Some(gpu.device.limits().max_texture_dimension_2d as usize),
    );
    Ok(Running { window, surface, config, gpu, viewer, ui, painter, input, last: Instant::now() })
}

fn frame(r: &mut Running, options: &WindowOptions) -> Result<(), ViewerError> {
    let seconds = r.last.elapsed().as_secs_f32();
    r.last = Instant::now();
    let input = r.input.take_egui_input(&r.window);
    let (output, requests) = step(&r.gpu, &mut r.viewer, &mut r.ui, &mut r.painter, input, seconds)?;
    if let Some(text) = &requests.copy {
        r.ui.ctx.copy_text(text.clone());
        r.viewer.status = format!("copied: {text}");
    }
    if requests.screenshot {
        let path = options.screenshot_dir.join(format!("shadowlab-{}.png", r.viewer.frames));
        r.viewer.status = match r.viewer.image_rgba().map(|rgba| {
            let (w, h) = r.viewer.size();
            image::RgbaImage::from_raw(w, h, rgba).map(|img| img.save(&path))
        }) {
            Ok(Some(Ok(()))) => format!("saved {}", path.display()),
            Ok(Some(Err(e))) => format!("{}: {e}", path.display()),
            Ok(None) => "screenshot: wrong size".into(),
            Err(e) => e.to_string(),
        };
    }
    let platform = output.platform_output.clone();
    let texture = match r.surface.get_current_texture() {
        wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
        other => {
            // Lost or outdated (a resize in flight): configure again and skip this frame.
            r.surface.configure(&r.gpu.device, &r.config);
            let _ = other;
            return Ok(());
        }
    };
    let view = texture.texture.create_view(&Default::default());
    let ctx = r.ui.ctx.clone();
    r.painter.paint(&r.gpu, &ctx, output, &view, [r.config.width, r.config.height]);
    r.window.pre_present_notify();
    r.gpu.queue.present(texture);
    r.input.handle_platform_output(&r.window, platform);
    Ok(())
}
