//! # shadowlab
//!
//! Real-time shadow techniques on wgpu, each writing a per-light visibility layer that the
//! ray-traced reference can check pixel by pixel.
//!
//! - [`gpu::Gpu`]: a device found headless ([`gpu::Gpu::new`]) or an application's own
//!   ([`gpu::Gpu::from_device`]).
//! - [`shadows::Shadows`]: shadows for every light over a [`frame::SurfaceInputs`] (depth,
//!   normals, camera): what applications embed.
//! - [`renderer::Renderer`]: shadowlab's own deferred frame around it (G-buffer, lighting, tone
//!   mapping) with readbacks for the reports.
//! - [`technique`]: the technique contract and registry; [`techniques`]: the techniques.

pub mod analysis;
pub mod auto;
pub mod context;
pub mod depth_range;
pub mod frame;
pub mod gbuffer;
pub mod gpu;
pub mod gpu_scene;
pub mod kernel;
pub mod light_map;
pub mod live;
pub mod registry;
pub mod renderer;
pub mod sample_maps;
pub mod shader;
pub mod shadowmap;
pub mod shadows;
pub mod technique;
pub mod techniques;
pub mod timing;
pub mod util;

pub use frame::{CameraUniform, SurfaceInputs, VisibilityLayer};
pub use gpu::{BackendChoice, Gpu, GpuError, OUT_OF_MEMORY};
pub use live::{Edit, EditError, InstanceId, LightChange, Work};
pub use registry::{TechniqueSpec, registry};
pub use renderer::{FrameReport, Renderer};
pub use shadowlab_core as core;
pub use shadows::{DEFAULT_MAP_BUDGET, Shadows};
pub use technique::{ShadowTechnique, TechniqueError, TechniqueInfo, TechniqueStats};
