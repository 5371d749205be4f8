//! # shadowlab-web
//!
//! shadowlab in a web page (issue 16; Toromanoff 2005 built his engine for a planner embedded in
//! a browser page, NOTES-000 §0–1): the live engine ([`shadowlab::Renderer`]) drawing into a
//! `<canvas>` on WebGPU, driven from JavaScript through [`App`]: built-in scenes, scene files from
//! bytes (a file picker or a drop), a technique for every light, an orbiting camera. `web/` holds
//! the page and `web/build.sh`, which builds this crate with wasm-bindgen.
//!
//! Nothing here waits: the device is opened with `Gpu::open` (awaited), a frame is recorded and
//! submitted by [`App::frame`] (no readback), and the page's `requestAnimationFrame` drives it.
//!
//! WebGL2 (where the browser has no WebGPU): the device opens with WebGL2's limits (no compute, no
//! storage buffers), and the techniques with a fragment path (`TechniqueInfo::fragment`: `none`,
//! `hard`, `pcf`, `pcss`, `cascaded`) resolve in render passes; the page greys the others out
//! ([`App::note`]).
//!
//! The crate's body is compiled for `wasm32` only; natively it is empty.

#![cfg(target_arch = "wasm32")]

use glam::{Quat, Vec3};
use shadowlab::context::{UNFILTERED, texture_entry};
use shadowlab::core::{LightId, Scene, View};
use shadowlab::{Gpu, Renderer, TechniqueSpec};
use wasm_bindgen::prelude::*;

/// Panics reach the browser's console (a test fails on any console error), and so do wgpu's
/// warnings and errors (its `log` records: a backend's own errors, such as WebGL's).
#[wasm_bindgen(start)]
pub fn install_panic_hook() {
    std::panic::set_hook(Box::new(|info| web_sys::console::error_1(&format!("shadowlab panicked: {info}").into())));
    if log::set_logger(&CONSOLE).is_ok() {
        log::set_max_level(log::LevelFilter::Warn);
    }
}

/// `log` records to the browser's console: errors as errors, the rest as warnings.
struct Console;
static CONSOLE: Console = Console;

impl log::Log for Console {
    fn enabled(&self, metadata: &log::Metadata<'_>) -> bool {
        metadata.level() <= log::Level::Warn
    }

    fn log(&self, record: &log::Record<'_>) {
        if !self.enabled(record.metadata()) {
            return;
        }
        let text = format!("{}: {}", record.target(), record.args()).into();
        match record.level() {
            log::Level::Error => web_sys::console::error_1(&text),
            _ => web_sys::console::warn_1(&text),
        }
    }

    fn flush(&self) {}
}

/// The names of the built-in scenes, in listing order.
#[wasm_bindgen]
pub fn scenes() -> Vec<String> {
    shadowlab::core::scenes::builtin().iter().map(|s| s.name.to_owned()).collect()
}

/// The techniques as JSON: `[{"id", "summary", "lights", "fragment"}]` (`lights`: the light types
/// it takes; `fragment`: it runs without compute shaders, on WebGL2).
#[wasm_bindgen]
pub fn techniques() -> String {
    let list: Vec<_> = shadowlab::registry()
        .iter()
        .map(|t| serde_json::json!({ "id": t.id, "summary": t.summary, "lights": t.light_types, "fragment": t.fragment }))
        .collect();
    serde_json::Value::Array(list).to_string()
}

fn js_error(e: impl std::fmt::Display) -> JsError {
    JsError::new(&e.to_string())
}

/// The engine in a canvas.
#[wasm_bindgen]
pub struct App {
    gpu: Gpu,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    backend: wgpu::Backend,
    blit: Blit,
    /// `None` until the first scene is shown.
    renderer: Option<Renderer>,
    scene_name: String,
    view: View,
    spec: String,
    note: String,
    frames: u64,
}

#[wasm_bindgen]
impl App {
    /// Opens a device that can draw into `canvas` and shows the built-in `scene` with `spec` on
    /// every light. `backend`: `webgpu`, `webgl2`, or `auto` (WebGPU where the browser offers it).
    pub async fn start(
        canvas: web_sys::HtmlCanvasElement,
        backend: String,
        scene: String,
        spec: String,
    ) -> Result<App, JsError> {
        let backends = match backend.as_str() {
            "webgpu" => wgpu::Backends::BROWSER_WEBGPU,
            "webgl2" => wgpu::Backends::GL,
            "auto" => wgpu::Backends::BROWSER_WEBGPU | wgpu::Backends::GL,
            other => return Err(JsError::new(&format!("unknown backend '{other}': webgpu, webgl2 or auto"))),
        };
        let (width, height) = (canvas.width().max(1), canvas.height().max(1));
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = backends;
        // With WebGPU asked for, the instance is a WebGPU one only if the browser can give an adapter.
        let instance = wgpu::util::new_instance_with_webgpu_detection(desc).await;
        let surface = instance
            .create_surface(wgpu::SurfaceTarget::Canvas(canvas))
            .map_err(|e| js_error(format!("the canvas: {e}")))?;
        let adapter = instance
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter: false,
                compatible_surface: Some(&surface),
                ..Default::default()
            })
            .await
            .map_err(|e| js_error(format!("no {backend} adapter can draw into the canvas: {e}")))?;
        let gpu = Gpu::open(&adapter).await.map_err(js_error)?;
        // Every target the renderer makes is the canvas's size: past the device's largest texture
        // they would fail one by one, as device errors that name no cause.
        let max = gpu.device.limits().max_texture_dimension_2d;
        if width > max || height > max {
            return Err(JsError::new(&format!(
                "the canvas is {width} × {height} pixels, and this device draws at most {max} a side: make it smaller"
            )));
        }
        let caps = surface.get_capabilities(&adapter);
        let format = caps.formats.first().copied().ok_or_else(|| JsError::new("the canvas offers no format"))?;
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            color_space: wgpu::SurfaceColorSpace::Auto,
            width,
            height,
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
        };
        surface.configure(&gpu.device, &config);
        let blit = Blit::new(&gpu.device, format);
        let compute = adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS);
        let mut app = App {
            backend: adapter.get_info().backend,
            gpu,
            surface,
            config,
            blit,
            renderer: None,
            scene_name: String::new(),
            view: View::new("default", Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, 0.1, 100.0),
            spec,
            note: String::new(),
            frames: 0,
        };
        if !compute {
            let able: Vec<&str> = shadowlab::registry().iter().filter(|t| t.fragment).map(|t| t.id).collect();
            app.note = format!(
                "WebGL2 (this browser has no WebGPU): no compute shaders, so only the techniques with a fragment \
                 path run here ({}); the others need WebGPU.",
                able.join(", ")
            );
        }
        app.load_builtin(&scene)?;
        Ok(app)
    }

    /// `WebGPU` or `WebGL2`.
    pub fn backend(&self) -> String {
        match self.backend {
            wgpu::Backend::BrowserWebGpu => "WebGPU".into(),
            wgpu::Backend::Gl => "WebGL2".into(),
            other => format!("{other:?}"),
        }
    }

    /// The adapter's name (browsers may hide it: then its kind).
    pub fn adapter(&self) -> String {
        let a = &self.gpu.adapter;
        if a.name.is_empty() { format!("a {} adapter", a.device_type) } else { a.name.clone() }
    }

    /// What this adapter cannot do (empty on WebGPU).
    pub fn note(&self) -> String {
        self.note.clone()
    }

    /// Whether the device runs compute shaders: every technique is available (false on WebGL2,
    /// where only those with `fragment` in [`techniques`] are).
    pub fn compute(&self) -> bool {
        shadowlab::gpu::runs_compute(&self.gpu.device)
    }

    /// The scene shown.
    pub fn scene(&self) -> String {
        self.scene_name.clone()
    }

    /// The technique spec on every light.
    pub fn technique(&self) -> String {
        self.spec.clone()
    }

    /// Frames drawn so far (a plain number in JavaScript: it saturates at 2³²−1).
    pub fn frames(&self) -> u32 {
        u32::try_from(self.frames).unwrap_or(u32::MAX)
    }

    /// Shows a built-in scene (`room`, `penumbra:light_size=1`, ...).
    pub fn load_builtin(&mut self, spec: &str) -> Result<(), JsError> {
        self.alive()?;
        let scene = shadowlab::core::scenes::build(spec).map_err(js_error)?;
        self.show(spec.to_owned(), scene)
    }

    /// Shows a scene file given as bytes (`name` decides the format: `.toml`, `.gltf`, `.glb`,
    /// `.obj`; a glTF's other files and an OBJ's `.mtl` are not read, so their materials are the
    /// defaults). Returns the loader's warnings, one per line.
    pub fn load_file(&mut self, name: &str, bytes: &[u8]) -> Result<String, JsError> {
        self.alive()?;
        let path = std::path::Path::new(name);
        let loaded = shadowlab::core::load::parse_file_bytes(bytes, path, Default::default()).map_err(js_error)?;
        self.show(name.to_owned(), loaded.scene)?;
        Ok(loaded.warnings.join("\n"))
    }

    /// Puts `spec` (`pcf`, `pcss:light_size=2`, ...) on every light; a light the technique does
    /// not take gets `hard`. Returns the lights that did, one per line.
    pub fn set_technique(&mut self, spec: &str) -> Result<String, JsError> {
        self.alive()?;
        let parsed = TechniqueSpec::parse(spec, &[]).map_err(js_error)?;
        let fallback = self.apply_technique(&parsed)?;
        self.spec = spec.to_owned();
        Ok(fallback.join("\n"))
    }

    /// The scene's named views.
    pub fn views(&self) -> Vec<String> {
        self.renderer.as_ref().map_or_else(Vec::new, |r| r.scene().views.iter().map(|v| v.name.clone()).collect())
    }

    /// Looks through the scene's view `name`.
    pub fn set_view(&mut self, name: &str) -> Result<(), JsError> {
        self.alive()?;
        let Some(renderer) = &mut self.renderer else { return Err(JsError::new("no scene yet")) };
        let view = renderer.scene().view(name).cloned().ok_or_else(|| JsError::new(&format!("no view '{name}'")))?;
        renderer.set_view(&view);
        self.view = view;
        Ok(())
    }

    /// The lights, one per line: name and type.
    pub fn lights(&self) -> String {
        self.renderer.as_ref().map_or_else(String::new, |r| {
            r.scene().lights.iter().map(|l| format!("{} ({})", l.name, l.type_name())).collect::<Vec<_>>().join("\n")
        })
    }

    /// Turns the camera around its target: `dx` and `dy` in radians (yaw, pitch; anything not
    /// finite is ignored).
    pub fn orbit(&mut self, dx: f32, dy: f32) {
        if !(dx.is_finite() && dy.is_finite()) {
            return;
        }
        let offset = self.view.position - self.view.target;
        let up = self.view.up.normalize_or(Vec3::Y);
        let yawed = Quat::from_axis_angle(up, -dx) * offset;
        let side = up.cross(yawed).normalize_or_zero();
        // Pitch only while the camera stays off the up axis (no flip over the pole).
        let pitched = Quat::from_axis_angle(side, -dy) * yawed;
        let keep = pitched.normalize_or_zero().dot(up).abs() < 0.98 && side != Vec3::ZERO;
        self.view.position = self.view.target + if keep { pitched } else { yawed };
        if let Some(r) = &mut self.renderer {
            r.set_view(&self.view);
        }
    }

    /// Moves the camera towards its target (`factor` < 1) or away (> 1), from 1 mm to 100 times
    /// the scene's size (without that bound, about 128 calls of `zoom(2)` took the camera to
    /// infinity).
    pub fn zoom(&mut self, factor: f32) {
        if !(factor.is_finite() && factor > 0.0) {
            return;
        }
        let offset = (self.view.position - self.view.target) * factor.clamp(0.5, 2.0);
        // The GPU scene's kept bounds: `Scene::bounds` walks every mesh's triangles, at every
        // wheel step.
        let farthest = self.renderer.as_ref().map_or(1e4, |r| 100.0 * r.shadows.gpu_scene().bounds.diagonal().max(0.1));
        if offset.length() > 1e-3 && offset.length() <= farthest {
            self.view.position = self.view.target + offset;
        }
        if let Some(r) = &mut self.renderer {
            r.set_view(&self.view);
        }
    }

    /// Destroys the GPU device, as a driver reset or the end of the browser's GPU process loses it
    /// (for tests: the page must then say so, and refuse work without a panic).
    pub fn lose_device(&self) {
        self.gpu.device.destroy();
    }

    /// Records and submits one frame and shows it in the canvas.
    pub fn frame(&mut self) -> Result<(), JsError> {
        self.alive()?;
        let Some(renderer) = &mut self.renderer else { return Ok(()) };
        renderer.frame().map_err(js_error)?;
        if let Some(e) = self.gpu.take_error() {
            return Err(js_error(renderer.device_error(&e)));
        }
        let texture = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            _ => {
                // Lost or outdated: configure again and draw the next frame.
                self.surface.configure(&self.gpu.device, &self.config);
                return Ok(());
            }
        };
        let target = texture.texture.create_view(&Default::default());
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        self.blit.draw(&self.gpu.device, &mut encoder, renderer.output_texture(), &target);
        self.gpu.queue.submit([encoder.finish()]);
        self.gpu.queue.present(texture);
        self.frames += 1;
        Ok(())
    }
}

impl App {
    /// An error saying so once the device is lost: nothing more can be drawn, and some calls
    /// would fail outright (reloading the page opens a new device).
    fn alive(&self) -> Result<(), JsError> {
        match self.gpu.lost() {
            Some(why) => Err(JsError::new(&format!("{why}; reload the page"))),
            None => Ok(()),
        }
    }

    fn show(&mut self, name: String, scene: Scene) -> Result<(), JsError> {
        let view = scene.views.first().cloned().ok_or_else(|| JsError::new("the scene has no view"))?;
        let renderer = Renderer::new(&self.gpu, scene, &view, self.config.width, self.config.height);
        let (old, old_view) = (self.renderer.replace(renderer), std::mem::replace(&mut self.view, view));
        let spec = TechniqueSpec::parse(&self.spec, &[]).map_err(js_error)?;
        if let Err(e) = self.apply_technique(&spec) {
            // The scene stays as it was.
            (self.renderer, self.view) = (old, old_view);
            return Err(e);
        }
        self.scene_name = name;
        Ok(())
    }

    /// Why this browser's adapter cannot run technique `id`, if it cannot. `ssm`'s contour tracing
    /// (`visibility` in its WGSL) is a large shader: on a CPU WebGPU adapter (Chromium's
    /// SwiftShader) the GPU process passed 6 GB compiling it and the browser went down with it
    /// (measured on Chromium 156 headless; with parts of the shader cut out it compiled, in 0.2–0.5 GB,
    /// so it is the whole shader's size, not one construct). Refused in words instead.
    fn cannot_run(&self, id: &str) -> Option<String> {
        let cpu = self.backend == wgpu::Backend::BrowserWebGpu && self.gpu.adapter.device_type == "cpu";
        (cpu && id == "ssm").then(|| {
            "technique 'ssm': its shaders are too large for this browser's WebGPU on the CPU (SwiftShader) \
             to compile (it runs out of memory); it needs WebGPU on a GPU, or the native build"
                .to_owned()
        })
    }

    /// Sets `spec` on every light of the renderer (`hard` where it does not apply); the names of
    /// the lights that fell back.
    fn apply_technique(&mut self, spec: &TechniqueSpec) -> Result<Vec<String>, JsError> {
        if let Some(why) = self.cannot_run(spec.info.id) {
            return Err(JsError::new(&why));
        }
        let Some(renderer) = &mut self.renderer else { return Err(JsError::new("no scene yet")) };
        let hard = TechniqueSpec::parse("hard", &[]).map_err(js_error)?;
        let mut fallback = Vec::new();
        let lights: Vec<_> = renderer.scene().lights.iter().map(|l| (spec.info.supports(l), l.name.clone())).collect();
        for (i, (supported, name)) in lights.into_iter().enumerate() {
            let chosen = if supported { spec } else { &hard };
            if !supported {
                fallback.push(name);
            }
            renderer.set_technique(LightId(i as u32), chosen).map_err(js_error)?;
        }
        Ok(fallback)
    }
}

/// Copies the engine's image onto the canvas.
struct Blit {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
}

impl Blit {
    fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("blit"),
            source: wgpu::ShaderSource::Wgsl(include_str!("blit.wgsl").into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("blit"),
            entries: &[texture_entry(0, wgpu::ShaderStages::FRAGMENT, UNFILTERED, wgpu::TextureViewDimension::D2)],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("blit"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("blit"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some(if format.is_srgb() { "fs_srgb" } else { "fs_encode" }),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
            }),
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            multiview_mask: None,
            cache: None,
        });
        Self { pipeline, layout }
    }

    fn draw(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        image: &wgpu::Texture,
        target: &wgpu::TextureView,
    ) {
        let view = image.create_view(&Default::default());
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("blit"),
            layout: &self.layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) }],
        });
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("blit"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, Some(&group), &[]);
        pass.draw(0..3, 0..1);
    }
}
