//! The GPU context every technique shares: the device, samplers, bind-group layouts and a cache of
//! compiled pipelines and scene resources. It sits below the techniques and knows none of them.

use std::any::Any;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use crate::frame::{SurfaceInputs, VisibilityLayer};
use crate::gpu::Gpu;

/// The pixel rectangle a resolve covers (`Region` in `shaders/resolve.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RegionUniform {
    /// x, y: the first pixel; z, w: width and height.
    pub rect: [u32; 4],
}

impl RegionUniform {
    /// Every pixel of any layer.
    pub fn whole() -> Self {
        Self { rect: [0, 0, u32::MAX, u32::MAX] }
    }
}

/// Resources shared by all techniques: samplers, layouts and a cache of compiled pipelines (so
/// four lights with the same technique compile its shaders once).
pub struct Shared {
    pub gpu: Gpu,
    /// Group 0 of visibility-resolve shaders (`shaders/resolve.wgsl`).
    pub resolve_layout: wgpu::BindGroupLayout,
    /// The region uniform of a resolve over the whole layer (origin 0, unbounded size).
    whole_region: wgpu::Buffer,
    /// Shadow maps are read through hardware comparison samplers (all backends but GL).
    pub hardware_compare: bool,
    /// The device runs compute shaders ([`crate::gpu::runs_compute`]): resolves are compute
    /// passes; without (WebGL2), the techniques with a fragment path resolve in render passes.
    pub compute: bool,
    /// Comparison samplers for shadow maps (reversed Z: lit when reference ≥ stored).
    pub compare_nearest: wgpu::Sampler,
    pub compare_linear: wgpu::Sampler,
    /// A nearest, non-filtering sampler. WebGL2 (GLES) leaves a depth texture "incomplete", so that
    /// it reads 0, unless it is sampled with nearest filtering: where there is no compute, depths
    /// are read through this sampler (`SAMPLED_DEPTH` in `lighting.wgsl`, `FRAGMENT` in
    /// `shaders/resolve.wgsl` and `shaders/maplookup.wgsl`) instead of `textureLoad`.
    pub nearest: wgpu::Sampler,
    render_pipelines: Mutex<HashMap<String, wgpu::RenderPipeline>>,
    compute_pipelines: Mutex<HashMap<String, wgpu::ComputePipeline>>,
    layouts: Mutex<HashMap<String, wgpu::BindGroupLayout>>,
    resources: Mutex<HashMap<String, Arc<dyn Any + Send + Sync>>>,
}

impl Shared {
    pub fn new(gpu: &Gpu) -> Self {
        let device = &gpu.device;
        let compute = crate::gpu::runs_compute(device);
        let stage = if compute { wgpu::ShaderStages::COMPUTE } else { wgpu::ShaderStages::FRAGMENT };
        let mut entries = vec![
            uniform_entry(0, stage),
            // Depth read as an unfilterable float: GL cannot `textureLoad` depth textures.
            texture_entry(1, stage, UNFILTERED, wgpu::TextureViewDimension::D2),
            texture_entry(2, stage, UNFILTERED, wgpu::TextureViewDimension::D2),
            branch_entry(3, stage, compute),
            // The pixel region a resolve covers (`ResolveRegion`): a uniform, as storage buffers
            // are few (8 a stage on the web, and `ssm`'s edge pass uses all of them).
            uniform_entry(5, stage),
            // The facets' own normals (`SurfaceInputs::set_geometric_normal`).
            texture_entry(6, stage, UNFILTERED, wgpu::TextureViewDimension::D2),
        ];
        if !compute {
            // Depths read through a nearest sampler (see `Shared::nearest`).
            entries.push(wgpu::BindGroupLayoutEntry {
                binding: 7,
                visibility: stage,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::NonFiltering),
                count: None,
            });
        }
        if compute {
            // The layer written (a fragment resolve draws into it instead).
            entries.push(wgpu::BindGroupLayoutEntry {
                binding: 4,
                visibility: stage,
                ty: wgpu::BindingType::StorageTexture {
                    access: wgpu::StorageTextureAccess::WriteOnly,
                    format: crate::frame::VISIBILITY_FORMAT,
                    view_dimension: wgpu::TextureViewDimension::D2,
                },
                count: None,
            });
        }
        let resolve_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("resolve group 0"),
            entries: &entries,
        });
        let whole_region =
            crate::util::uniform_buffer(device, "whole region", bytemuck::bytes_of(&RegionUniform::whole()));
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
            whole_region,
            // wgpu's GL backend returns 0 from comparison samples of depth arrays (seen on Mesa).
            hardware_compare: gpu.adapter.backend != "gl",
            compute,
            compare_nearest: compare(wgpu::FilterMode::Nearest),
            compare_linear: compare(wgpu::FilterMode::Linear),
            nearest: device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("nearest"),
                address_mode_u: wgpu::AddressMode::ClampToEdge,
                address_mode_v: wgpu::AddressMode::ClampToEdge,
                ..Default::default()
            }),
            render_pipelines: Mutex::default(),
            compute_pipelines: Mutex::default(),
            layouts: Mutex::default(),
            resources: Mutex::default(),
        }
    }

    /// The group-0 bind group of a resolve shader writing `out`, over the whole layer.
    pub fn resolve_bind_group(
        &self,
        surface: &SurfaceInputs,
        light: &wgpu::Buffer,
        out: &VisibilityLayer,
    ) -> wgpu::BindGroup {
        self.resolve_bind_group_in(surface, light, out, &self.whole_region)
    }

    /// The group-0 bind group of a resolve shader writing `out` over the region whose
    /// [`RegionUniform`] is in `region` (`region_pixel` in `shaders/resolve.wgsl` offsets the
    /// invocation ids by its origin, `in_frame` keeps to its size).
    pub fn resolve_bind_group_in(
        &self,
        surface: &SurfaceInputs,
        light: &wgpu::Buffer,
        out: &VisibilityLayer,
        region: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 0, resource: surface.camera_buffer.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&surface.depth) },
            wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&surface.normal) },
            wgpu::BindGroupEntry { binding: 3, resource: light.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 5, resource: region.as_entire_binding() },
            wgpu::BindGroupEntry {
                binding: 6,
                resource: wgpu::BindingResource::TextureView(surface.geometric_normal()),
            },
        ];
        if self.compute {
            entries.push(wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&out.view) });
        } else {
            entries.push(wgpu::BindGroupEntry { binding: 7, resource: wgpu::BindingResource::Sampler(&self.nearest) });
        }
        self.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("resolve group 0"),
            layout: &self.resolve_layout,
            entries: &entries,
        })
    }

    /// The shader stage resolves run in: compute, or fragment where the device has no compute.
    pub fn resolve_stage(&self) -> wgpu::ShaderStages {
        if self.compute { wgpu::ShaderStages::COMPUTE } else { wgpu::ShaderStages::FRAGMENT }
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

    /// The keys of every pipeline compiled so far, sorted (what a frame compiled shows as new keys).
    pub fn pipeline_keys(&self) -> Vec<String> {
        let render =
            self.render_pipelines.lock().unwrap_or_else(|e| e.into_inner()).keys().cloned().collect::<Vec<_>>();
        let compute =
            self.compute_pipelines.lock().unwrap_or_else(|e| e.into_inner()).keys().cloned().collect::<Vec<_>>();
        let mut keys: Vec<String> = render.into_iter().chain(compute).collect();
        keys.sort();
        keys
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
            let (module, layout) = self.resolve_module(key, source, extra, defines);
            self.gpu.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
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

impl Shared {
    /// The most bytes one storage binding (and one buffer) may hold on this device: 128 MiB on
    /// CPU adapters and in browsers. Buffers sized by the output or a map check against it, so
    /// that a size past it is a clear error, not a failed binding.
    pub fn storage_binding_limit(&self) -> u64 {
        let limits = self.gpu.device.limits();
        limits.max_storage_buffer_binding_size.min(limits.max_buffer_size)
    }

    /// Technique `id`'s clear error where `bytes` of `what` (for an output of `width` × `height`)
    /// would outgrow [`Shared::storage_binding_limit`].
    pub fn check_output_buffer(
        &self,
        id: &str,
        what: &str,
        bytes: u64,
        width: u32,
        height: u32,
    ) -> Result<(), crate::technique::TechniqueError> {
        let limit = self.storage_binding_limit();
        if bytes <= limit {
            return Ok(());
        }
        Err(crate::technique::TechniqueError::Failed {
            id: id.into(),
            message: format!(
                "an output of {width} × {height} needs {} MiB of {what}, and this device binds at most {} MiB",
                bytes.div_ceil(1 << 20),
                limit.div_ceil(1 << 20)
            ),
        })
    }
}

impl Shared {
    /// A resolve shader's module (with `defines`, and the comparison path the device takes) and
    /// its pipeline layout: group 0 the resolve layout, then `extra`.
    fn resolve_module(
        &self,
        key: &str,
        source: &str,
        extra: &[&wgpu::BindGroupLayout],
        defines: &[&str],
    ) -> (wgpu::ShaderModule, wgpu::PipelineLayout) {
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
        (module, layout)
    }
}

/// A resolve shader compiled for the device: a compute pipeline (8 × 8 workgroups over the
/// pixels), or, where the device has no compute (WebGL2), a render pipeline drawing one
/// triangle over the layer as a render target (`shaders/resolve.wgsl`'s `FRAGMENT`).
#[derive(Clone)]
pub enum ResolveProgram {
    Compute(wgpu::ComputePipeline),
    Fragment(wgpu::RenderPipeline),
}

impl Shared {
    /// A resolve shader with a fragment path: the same WGSL compiled as a compute pipeline, or
    /// with `FRAGMENT` defined as a render pipeline (vertex `resolve_vs`, fragment `entry`) where
    /// the device has no compute. Dispatched by `technique::dispatch_program_in`.
    pub fn resolve_program(
        &self,
        key: &str,
        source: &str,
        entry: &str,
        extra: &[&wgpu::BindGroupLayout],
        defines: &[&str],
    ) -> ResolveProgram {
        if self.compute {
            return ResolveProgram::Compute(self.resolve_pipeline_with(key, source, entry, extra, &[], defines));
        }
        ResolveProgram::Fragment(self.render_pipeline(&format!("{key} (fragment)"), || {
            let mut all: Vec<&str> = defines.to_vec();
            all.push("FRAGMENT");
            let (module, layout) = self.resolve_module(key, source, extra, &all);
            self.gpu.device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(key),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("resolve_vs"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: crate::frame::VISIBILITY_FORMAT,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                primitive: Default::default(),
                depth_stencil: None,
                multisample: Default::default(),
                multiview_mask: None,
                cache: None,
            })
        }))
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

/// Floats read with `textureLoad` (no sampler).
pub const UNFILTERED: wgpu::TextureSampleType = wgpu::TextureSampleType::Float { filterable: false };

/// A sampled-texture entry of a bind-group layout.
pub fn texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    sample_type: wgpu::TextureSampleType,
    view_dimension: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture { sample_type, view_dimension, multisampled: false },
        count: None,
    }
}

/// The entry of a buffer made by `util::branch_buffer`: read-only storage where compute runs, a
/// uniform without (the shaders declare it under `FRAGMENT` likewise).
pub fn branch_entry(binding: u32, visibility: wgpu::ShaderStages, compute: bool) -> wgpu::BindGroupLayoutEntry {
    if compute { storage_entry(binding, visibility, true) } else { uniform_entry(binding, visibility) }
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
