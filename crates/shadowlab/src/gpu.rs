//! The wgpu device shadowlab renders with: found headless by [`Gpu::new`] or handed in by an
//! application with [`Gpu::from_device`].

use std::fmt;

/// Which backend to look for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BackendChoice {
    /// A real GPU (Vulkan, Metal, DX12) first, then Vulkan on the CPU (Mesa lavapipe), then GL.
    #[default]
    Auto,
    Vulkan,
    Gl,
}

impl BackendChoice {
    pub fn parse(text: &str) -> Option<Self> {
        match text {
            "auto" => Some(Self::Auto),
            "vulkan" => Some(Self::Vulkan),
            "gl" => Some(Self::Gl),
            _ => None,
        }
    }
}

/// Failure to find or open a GPU.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no {wanted} adapter found. On Linux without a GPU install Mesa's CPU drivers: \
         `apt-get install mesa-vulkan-drivers` (Vulkan, lavapipe) or `libgl1-mesa-dri libegl1` (GL, llvmpipe)"
    )]
    NoAdapter { wanted: &'static str },
    #[error("the GPU device was lost: {0}")]
    Lost(String),
    #[error("the adapter '{adapter}' refused a device: {source}")]
    Device {
        adapter: String,
        #[source]
        source: wgpu::RequestDeviceError,
    },
}

/// What the reports say about the adapter.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AdapterSummary {
    pub name: String,
    /// `vulkan`, `gl`, `metal`, `dx12`, `webgpu`.
    pub backend: String,
    /// `discrete`, `integrated`, `virtual`, `cpu`, `other`.
    pub device_type: String,
    pub driver: String,
}

impl fmt::Display for AdapterSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({}, {})", self.name, self.backend, self.device_type)
    }
}

impl From<&wgpu::AdapterInfo> for AdapterSummary {
    fn from(info: &wgpu::AdapterInfo) -> Self {
        let backend = match info.backend {
            wgpu::Backend::Vulkan => "vulkan",
            wgpu::Backend::Gl => "gl",
            wgpu::Backend::Metal => "metal",
            wgpu::Backend::Dx12 => "dx12",
            wgpu::Backend::BrowserWebGpu => "webgpu",
            _ => "other",
        };
        let device_type = match info.device_type {
            wgpu::DeviceType::DiscreteGpu => "discrete",
            wgpu::DeviceType::IntegratedGpu => "integrated",
            wgpu::DeviceType::VirtualGpu => "virtual",
            wgpu::DeviceType::Cpu => "cpu",
            wgpu::DeviceType::Other => "other",
        };
        Self {
            name: info.name.clone(),
            backend: backend.to_owned(),
            device_type: device_type.to_owned(),
            driver: format!("{} {}", info.driver, info.driver_info).trim().to_owned(),
        }
    }
}

/// How [`Gpu::take_error`]'s message starts when the device ran out of memory.
pub const OUT_OF_MEMORY: &str = "out of GPU memory";

/// A device and queue, and what they can do.
#[derive(Debug, Clone)]
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: AdapterSummary,
    pub info: wgpu::AdapterInfo,
    /// Timestamp queries around passes are available (GPU timing per pass).
    pub timestamps: bool,
    /// The first uncaptured device error (out of memory, a limit exceeded), when shadowlab owns
    /// the device; see [`Gpu::take_error`].
    errors: std::sync::Arc<std::sync::Mutex<Option<String>>>,
    /// Why the device was lost (a driver reset, the browser's GPU process ended, `destroy`), once
    /// it was, when shadowlab owns the device; see [`Gpu::lost`].
    lost: std::sync::Arc<std::sync::Mutex<Option<String>>>,
}

/// Whether `device` runs compute shaders (and storage buffers and textures): every GPU and CPU
/// adapter but WebGL2, where `Gpu::open` asks for WebGL2's limits, with no compute at all. Without
/// them the techniques that have a fragment path ([`crate::TechniqueInfo::fragment`]) resolve in
/// render passes instead, and the others cannot run.
pub fn runs_compute(device: &wgpu::Device) -> bool {
    device.limits().max_compute_workgroups_per_dimension > 0
}

/// Features shadowlab uses when the adapter has them; none is required.
fn wanted_features() -> wgpu::Features {
    wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::DEPTH_CLIP_CONTROL | wgpu::Features::DEPTH32FLOAT_STENCIL8
}

impl Gpu {
    /// Finds an adapter by `choice` and opens a device on it (blocking: native only; a web page
    /// awaits [`Gpu::new_async`]).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn new(choice: BackendChoice) -> Result<Self, GpuError> {
        pollster::block_on(Self::new_async(choice))
    }

    /// [`Gpu::new`] with WebGL2's limits, whatever the adapter has: no compute shaders and no
    /// storage buffers, so the fragment paths run as in a browser without WebGPU (native only:
    /// the tests of those paths).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn new_without_compute(choice: BackendChoice) -> Result<Self, GpuError> {
        pollster::block_on(async {
            let adapter = Self::find(choice).await?;
            Self::open_with(&adapter, false).await
        })
    }

    pub async fn new_async(choice: BackendChoice) -> Result<Self, GpuError> {
        let adapter = Self::find(choice).await?;
        Self::open(&adapter).await
    }

    /// The adapter `choice` asks for, best first (real GPUs, then Vulkan on the CPU, then GL).
    async fn find(choice: BackendChoice) -> Result<wgpu::Adapter, GpuError> {
        let backends = match choice {
            BackendChoice::Auto => wgpu::Backends::PRIMARY | wgpu::Backends::GL,
            BackendChoice::Vulkan => wgpu::Backends::VULKAN,
            BackendChoice::Gl => wgpu::Backends::GL,
        };
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = backends;
        let instance = wgpu::Instance::new(desc);
        let adapters = instance.enumerate_adapters(backends).await;
        // Rank: real GPUs first, then the CPU Vulkan driver, then GL; within a rank keep wgpu's order.
        let rank = |a: &wgpu::Adapter| {
            let info = a.get_info();
            let real = matches!(
                info.device_type,
                wgpu::DeviceType::DiscreteGpu | wgpu::DeviceType::IntegratedGpu | wgpu::DeviceType::VirtualGpu
            );
            match (info.backend, real) {
                (wgpu::Backend::Gl, true) => 2,
                (wgpu::Backend::Gl, false) => 3,
                (_, true) => {
                    if info.device_type == wgpu::DeviceType::DiscreteGpu {
                        0
                    } else {
                        1
                    }
                }
                (_, false) => 2,
            }
        };
        let best = adapters.into_iter().min_by_key(rank);
        if let Some(cpu) = best.as_ref().map(wgpu::Adapter::get_info).filter(|i| i.device_type == wgpu::DeviceType::Cpu)
        {
            // wgpu checks every indirect dispatch's arguments with a compute pass of its own
            // (`InstanceFlags::VALIDATION_INDIRECT_CALL`): on llvmpipe about 25 ms each, which
            // took `ssm`'s listed pixels from 20 to 70 ms at 128². shadowlab writes its indirect
            // arguments itself, bounded (workgroups ≤ 65 535, draws within the store), so on a CPU
            // adapter, where nothing can hang a GPU, it opens the same adapter without the check.
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
            desc.backends = backends;
            desc.flags.remove(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL);
            let unchecked = wgpu::Instance::new(desc).enumerate_adapters(backends).await;
            if let Some(same) = unchecked.into_iter().find(|a| {
                let i = a.get_info();
                (i.name.as_str(), i.backend, i.device_type) == (cpu.name.as_str(), cpu.backend, cpu.device_type)
            }) {
                return Ok(same);
            }
        }
        best.ok_or(GpuError::NoAdapter {
            wanted: match choice {
                BackendChoice::Auto => "GPU, Vulkan or GL",
                BackendChoice::Vulkan => "Vulkan",
                BackendChoice::Gl => "GL",
            },
        })
    }

    /// Opens a device on `adapter` with the features and limits shadowlab wants (an application
    /// that owns a window picks the adapter that can present to it, then opens it here).
    pub async fn open(adapter: &wgpu::Adapter) -> Result<Self, GpuError> {
        let compute = adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS);
        Self::open_with(adapter, compute).await
    }

    /// [`Gpu::open`], with compute shaders or, `compute = false`, with WebGL2's limits.
    async fn open_with(adapter: &wgpu::Adapter, compute: bool) -> Result<Self, GpuError> {
        let info = adapter.get_info();
        let features = adapter.features() & wanted_features();
        // Only limits the adapter has: WebGL2 (no compute) starts from WebGL2's own defaults.
        let base = if compute { wgpu::Limits::downlevel_defaults() } else { wgpu::Limits::downlevel_webgl2_defaults() };
        let mut limits = base.using_resolution(adapter.limits());
        // Shadow maps want large textures and many array layers (cube faces, cascades, samples).
        let al = adapter.limits();
        limits.max_texture_dimension_2d = al.max_texture_dimension_2d;
        limits.max_texture_array_layers = al.max_texture_array_layers;
        limits.max_buffer_size = al.max_buffer_size;
        if compute {
            limits.max_storage_buffer_binding_size = al.max_storage_buffer_binding_size;
            limits.max_compute_workgroup_storage_size = al.max_compute_workgroup_storage_size;
            limits.max_storage_buffers_per_shader_stage = al.max_storage_buffers_per_shader_stage.min(8);
            limits.max_storage_textures_per_shader_stage = al.max_storage_textures_per_shader_stage.min(4);
        }
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("shadowlab"),
                required_features: features,
                required_limits: limits,
                ..Default::default()
            })
            .await
            .map_err(|source| GpuError::Device { adapter: info.name.clone(), source })?;
        let gpu = Self::from_device(device, queue, &info);
        // wgpu's default handler panics on any device error; a user's oversized map must instead
        // become an error message. Record the first one; `take_error` hands it out.
        let slot = gpu.errors.clone();
        gpu.device.on_uncaptured_error(std::sync::Arc::new(move |e: wgpu::Error| {
            let mut slot = slot.lock().unwrap_or_else(|p| p.into_inner());
            if slot.is_none() {
                *slot = Some(match e {
                    // wgpu's own text ("Out of Memory") names no resource: callers add what they
                    // hold, keyed on this prefix.
                    wgpu::Error::OutOfMemory { .. } => format!("{OUT_OF_MEMORY} ({e})"),
                    e => e.to_string(),
                });
            }
        }));
        // Nothing drawn on a lost device shows, and some calls on it fail outright (a buffer
        // mapped at creation, in a browser): callers check `lost` first and say why instead.
        let lost = gpu.lost.clone();
        gpu.device.set_device_lost_callback(move |reason, message| {
            let mut slot = lost.lock().unwrap_or_else(|p| p.into_inner());
            let message = message.trim().trim_end_matches('.');
            let detail = if message.is_empty() { String::new() } else { format!(": {message}") };
            slot.get_or_insert_with(|| format!("the GPU device was lost ({reason:?}){detail}"));
        });
        Ok(gpu)
    }

    /// The first device error since the last call (only on devices shadowlab opened itself; an
    /// application's device keeps the application's own error handler).
    pub fn take_error(&self) -> Option<String> {
        self.errors.lock().unwrap_or_else(|p| p.into_inner()).take()
    }

    /// Why the device was lost, once it was (only on devices shadowlab opened itself). Unlike
    /// [`Gpu::take_error`] it stays: nothing more can be drawn on that device.
    pub fn lost(&self) -> Option<String> {
        self.lost.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Uses an application's own device and queue (how shadowlab is embedded).
    pub fn from_device(device: wgpu::Device, queue: wgpu::Queue, info: &wgpu::AdapterInfo) -> Self {
        let timestamps = device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        Self {
            device,
            queue,
            adapter: AdapterSummary::from(info),
            info: info.clone(),
            timestamps,
            errors: Default::default(),
            lost: Default::default(),
        }
    }

    /// Blocks until all submitted work has finished (native only).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn wait(&self) {
        // A poll error means the device was lost; the next use reports it.
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
    }
}
