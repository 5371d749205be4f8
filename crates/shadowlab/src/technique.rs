//! The technique contract (DESIGN.md §5) and the registry of techniques.
//!
//! A technique is created per (light, technique) pair. Each frame it gets [`ShadowTechnique::prepare`]
//! (render maps, volumes, ...) and then [`ShadowTechnique::resolve`], which must write the light's
//! visibility V for every pixel into a [`VisibilityLayer`]. That layer is the whole interface to the
//! rest of the renderer, which is what makes techniques comparable, composable per light and
//! replaceable.

use std::any::Any;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use shadowlab_core::params::{ParamDef, ParamError, ParamSet, parse_spec, split_assignment};
use shadowlab_core::{Light, LightId, Scene};

use crate::frame::{SurfaceInputs, VisibilityLayer};
use crate::gpu::Gpu;
use crate::gpu_scene::GpuScene;
use crate::timing::GpuTimer;

/// A technique could not be set up or run.
#[derive(Debug, thiserror::Error)]
pub enum TechniqueError {
    #[error("unknown technique '{id}' (known: {known})")]
    Unknown { id: String, known: String },
    #[error("technique '{id}': {source}")]
    Param {
        id: String,
        #[source]
        source: ParamError,
    },
    #[error("technique '{id}' does not support {light_type} light '{light}'")]
    Unsupported { id: String, light: String, light_type: &'static str },
    #[error("technique '{id}': {message}")]
    Failed { id: String, message: String },
}

/// Resources and counts a technique reports.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TechniqueStats {
    /// Bytes of GPU memory the technique holds (maps, buffers), not counting shared resources.
    pub memory_bytes: u64,
    /// Render and compute passes per frame.
    pub passes: u32,
    /// Draw calls per frame.
    pub draws: u32,
    /// Triangles rasterised per frame for shadows.
    pub triangles: u64,
    /// Technique-specific figures for the reports (`auto_near_latency_frames`, ...).
    pub extra: Vec<(String, f64)>,
}

/// Everything a technique may use during a frame.
pub struct FrameContext<'a> {
    pub gpu: &'a Gpu,
    pub shared: &'a Shared,
    pub encoder: &'a mut wgpu::CommandEncoder,
    pub scene: &'a Scene,
    pub gpu_scene: &'a GpuScene,
    pub surface: &'a SurfaceInputs,
    pub light: &'a Light,
    pub light_id: LightId,
    /// The light's `LightUniform`.
    pub light_buffer: &'a wgpu::Buffer,
    pub timer: &'a mut GpuTimer,
    /// Frames rendered before this one (for techniques that cache or spread work over frames).
    pub frame_index: u64,
}

/// The maps a technique looks up, for the analysis overlays (`shadowlab render --overlay`).
pub struct MapAnalysis<'a> {
    /// Group 1 of `shaders/maplookup.wgsl`.
    pub lookup: &'a wgpu::BindGroup,
    /// Group 3 of `shaders/selection.wgsl`.
    pub selection: &'a wgpu::BindGroup,
}

/// The technique contract of DESIGN.md §5.
pub trait ShadowTechnique: Send {
    /// The stable id used by the CLI and the reports.
    fn id(&self) -> &'static str;
    fn params(&self) -> &ParamSet;
    /// Renders whatever the technique needs before resolving (shadow maps, volumes).
    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError>;
    /// Writes V for every pixel of the surface into `out`.
    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer);
    fn stats(&self) -> TechniqueStats;
    /// The maps behind the last frame, for techniques that shade each pixel from one map (hard,
    /// pcf, cascaded); `None` for the others.
    fn analysis(&self) -> Option<MapAnalysis<'_>> {
        None
    }
}

/// How to make a technique.
pub type Constructor = fn(&Shared, &ParamSet, &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError>;

/// A registry entry: what the technique is, where it comes from, what it takes.
#[derive(Debug)]
pub struct TechniqueInfo {
    pub id: &'static str,
    pub summary: &'static str,
    /// The source document and section it implements.
    pub source: &'static str,
    pub params: &'static [ParamDef],
    /// Light types it shadows (`point`, `spot`, `directional`, `rect`).
    pub light_types: &'static [&'static str],
    pub create: Constructor,
}

impl TechniqueInfo {
    pub fn supports(&self, light: &Light) -> bool {
        self.light_types.contains(&light.type_name())
    }
}

/// All techniques, in listing order.
pub fn registry() -> &'static [TechniqueInfo] {
    crate::techniques::REGISTRY
}

pub fn find(id: &str) -> Option<&'static TechniqueInfo> {
    registry().iter().find(|t| t.id == id)
}

/// A technique with its parameters, parsed from a spec (`pcf:kernel=poisson,taps=16`).
#[derive(Debug, Clone)]
pub struct TechniqueSpec {
    pub info: &'static TechniqueInfo,
    /// The spec as given.
    pub spec: String,
    pub params: ParamSet,
}

impl TechniqueSpec {
    /// Parses `spec`; `global` holds `--set K=V` assignments, applied first to every technique that
    /// has the parameter (the spec's own values win).
    pub fn parse(spec: &str, global: &[String]) -> Result<Self, TechniqueError> {
        let (id, assignments) =
            parse_spec(spec).map_err(|source| TechniqueError::Param { id: spec.to_owned(), source })?;
        let info = find(id).ok_or_else(|| TechniqueError::Unknown {
            id: id.to_owned(),
            known: registry().iter().map(|t| t.id).collect::<Vec<_>>().join(", "),
        })?;
        let mut params = ParamSet::new(info.params);
        for g in global {
            let (k, v) = split_assignment(g).map_err(|source| TechniqueError::Param { id: id.to_owned(), source })?;
            if params.has(k) {
                params.set(k, v).map_err(|source| TechniqueError::Param { id: id.to_owned(), source })?;
            }
        }
        params.apply(assignments).map_err(|source| TechniqueError::Param { id: id.to_owned(), source })?;
        Ok(Self { info, spec: spec.to_owned(), params })
    }

    /// Creates the technique for one light.
    pub fn create(&self, shared: &Shared, light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
        if !self.info.supports(light) {
            return Err(TechniqueError::Unsupported {
                id: self.info.id.to_owned(),
                light: light.name.clone(),
                light_type: light.type_name(),
            });
        }
        (self.info.create)(shared, &self.params, light)
    }
}

/// Checks that every `--set K=V` names a parameter of at least one of `specs` (a typo would
/// otherwise be silently ignored).
pub fn check_global_sets(specs: &[TechniqueSpec], global: &[String]) -> Result<(), TechniqueError> {
    for g in global {
        let (k, _) = split_assignment(g).map_err(|source| TechniqueError::Param { id: "--set".into(), source })?;
        if !specs.iter().any(|s| s.params.has(k)) {
            return Err(TechniqueError::Param {
                id: "--set".into(),
                source: ParamError::Unknown {
                    name: k.to_owned(),
                    known: {
                        let mut names: Vec<&str> =
                            specs.iter().flat_map(|s| s.info.params.iter().map(|p| p.name)).collect();
                        names.sort_unstable();
                        names.dedup();
                        names.join(", ")
                    },
                },
            });
        }
    }
    Ok(())
}

/// Resources shared by all techniques: samplers, layouts and a cache of compiled pipelines (so
/// four lights with the same technique compile its shaders once).
pub struct Shared {
    pub gpu: Gpu,
    /// Group 0 of visibility-resolve shaders (`shaders/resolve.wgsl`).
    pub resolve_layout: wgpu::BindGroupLayout,
    /// Shadow maps are read through hardware comparison samplers (all backends but GL).
    pub hardware_compare: bool,
    /// Comparison samplers for shadow maps (reversed Z: lit when reference ≥ stored).
    pub compare_nearest: wgpu::Sampler,
    pub compare_linear: wgpu::Sampler,
    render_pipelines: Mutex<HashMap<String, wgpu::RenderPipeline>>,
    compute_pipelines: Mutex<HashMap<String, wgpu::ComputePipeline>>,
    layouts: Mutex<HashMap<String, wgpu::BindGroupLayout>>,
    resources: Mutex<HashMap<String, Arc<dyn Any + Send + Sync>>>,
}

impl Shared {
    pub fn new(gpu: &Gpu) -> Self {
        let device = &gpu.device;
        let resolve_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("resolve group 0"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::COMPUTE),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    // Depth read as an unfilterable float: GL cannot `textureLoad` depth textures.
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                uniform_entry(3, wgpu::ShaderStages::COMPUTE),
                wgpu::BindGroupLayoutEntry {
                    binding: 4,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: crate::frame::VISIBILITY_FORMAT,
                        view_dimension: wgpu::TextureViewDimension::D2,
                    },
                    count: None,
                },
            ],
        });
        let compare = |filter| {
            device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("shadow compare"),
                address_mode_u: wgpu::AddressMode::ClampToEdge,
                address_mode_v: wgpu::AddressMode::ClampToEdge,
                mag_filter: filter,
                min_filter: filter,
                compare: Some(wgpu::CompareFunction::GreaterEqual),
                ..Default::default()
            })
        };
        Self {
            gpu: gpu.clone(),
            resolve_layout,
            // wgpu's GL backend returns 0 from comparison samples of depth arrays (seen on Mesa).
            hardware_compare: gpu.adapter.backend != "gl",
            compare_nearest: compare(wgpu::FilterMode::Nearest),
            compare_linear: compare(wgpu::FilterMode::Linear),
            render_pipelines: Mutex::default(),
            compute_pipelines: Mutex::default(),
            layouts: Mutex::default(),
            resources: Mutex::default(),
        }
    }

    /// The group-0 bind group of a resolve shader writing `out`.
    pub fn resolve_bind_group(
        &self,
        surface: &SurfaceInputs,
        light: &wgpu::Buffer,
        out: &VisibilityLayer,
    ) -> wgpu::BindGroup {
        self.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("resolve group 0"),
            layout: &self.resolve_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: surface.camera_buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&surface.depth) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&surface.normal) },
                wgpu::BindGroupEntry { binding: 3, resource: light.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&out.view) },
            ],
        })
    }

    /// A render pipeline from the cache, built by `make` the first time `key` is asked for.
    pub fn render_pipeline(&self, key: &str, make: impl FnOnce() -> wgpu::RenderPipeline) -> wgpu::RenderPipeline {
        let mut cache = self.render_pipelines.lock().unwrap_or_else(|e| e.into_inner());
        cache.entry(key.to_owned()).or_insert_with(make).clone()
    }

    pub fn compute_pipeline(&self, key: &str, make: impl FnOnce() -> wgpu::ComputePipeline) -> wgpu::ComputePipeline {
        let mut cache = self.compute_pipelines.lock().unwrap_or_else(|e| e.into_inner());
        cache.entry(key.to_owned()).or_insert_with(make).clone()
    }

    pub fn layout(&self, key: &str, make: impl FnOnce() -> wgpu::BindGroupLayout) -> wgpu::BindGroupLayout {
        let mut cache = self.layouts.lock().unwrap_or_else(|e| e.into_inner());
        cache.entry(key.to_owned()).or_insert_with(make).clone()
    }

    /// A scene resource shared by every light's technique (GPU copies of mesh topology, say),
    /// built by `make` the first time `key` is asked for.
    pub fn resource<T: Any + Send + Sync>(&self, key: &str, make: impl FnOnce() -> T) -> Arc<T> {
        let mut cache = self.resources.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(found) = cache.get(key).and_then(|r| Arc::clone(r).downcast::<T>().ok()) {
            return found;
        }
        let made = Arc::new(make());
        cache.insert(key.to_owned(), Arc::clone(&made) as Arc<dyn Any + Send + Sync>);
        made
    }

    /// A compute pipeline for a resolve shader: group 0 is the resolve layout, `extra` the
    /// technique's own groups.
    pub fn resolve_pipeline(
        &self,
        key: &str,
        source: &str,
        entry: &str,
        extra: &[&wgpu::BindGroupLayout],
        constants: &[(&str, f64)],
    ) -> wgpu::ComputePipeline {
        self.resolve_pipeline_with(key, source, entry, extra, constants, &[])
    }

    /// [`Shared::resolve_pipeline`] with `// #ifdef` names of its own (`key` must tell them apart).
    pub fn resolve_pipeline_with(
        &self,
        key: &str,
        source: &str,
        entry: &str,
        extra: &[&wgpu::BindGroupLayout],
        constants: &[(&str, f64)],
        defines: &[&str],
    ) -> wgpu::ComputePipeline {
        self.compute_pipeline(key, || {
            let device = &self.gpu.device;
            let mut all: Vec<&str> = defines.to_vec();
            if self.hardware_compare {
                all.push("HARDWARE_COMPARE");
            }
            let module = crate::shader::module_with(device, key, source, &all);
            let mut layouts: Vec<Option<&wgpu::BindGroupLayout>> = vec![Some(&self.resolve_layout)];
            layouts.extend(extra.iter().map(|l| Some(*l)));
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(key),
                bind_group_layouts: &layouts,
                immediate_size: 0,
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(key),
                layout: Some(&layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions { constants, ..Default::default() },
                cache: None,
            })
        })
    }
}

pub fn uniform_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub fn storage_entry(binding: u32, visibility: wgpu::ShaderStages, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Dispatches a resolve shader over the whole surface (8 × 8 workgroups).
pub fn dispatch_resolve(
    ctx: &mut FrameContext<'_>,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
) {
    let timestamps = ctx.timer.compute_pass(&ctx.gpu.device, crate::timing::PassKind::Visibility);
    let mut pass = ctx
        .encoder
        .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: timestamps });
    pass.set_pipeline(pipeline);
    for (i, g) in groups.iter().enumerate() {
        pass.set_bind_group(i as u32, Some(*g), &[]);
    }
    pass.dispatch_workgroups(crate::util::groups(ctx.surface.width, 8), crate::util::groups(ctx.surface.height, 8), 1);
}
