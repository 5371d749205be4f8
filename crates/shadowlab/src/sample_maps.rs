//! A set of emitter samples with one hard shadow map each, and the group-2 resources of
//! `shaders/samples.wgsl`: shared by `sampled` (one set) and `cssm` (one set per cascade).
//!
//! Two layouts: every sample its own layers, looked up in one pass over the texture array (Azri
//! 2020 §3 reports this about 10% faster), kept across frames by the live engine's cache
//! ([`MapViews`]: only views whose signature changed are rendered, in `prepare`); or all samples
//! rendered in turn into the same layers and accumulated pass by pass (memory of one map, whatever
//! N), which cannot keep anything: those maps are rendered every frame, interleaved with their
//! lookups in `resolve`.

use bytemuck::{Pod, Zeroable};
use glam::Vec4;
use shadowlab_core::lightspace::{LightFrusta, ShadowView};
use shadowlab_core::sampling::{EmitterPoint, EmitterSample};

use crate::context::{Shared, storage_entry};
use crate::live::MapViews;
use crate::shadowmap::{BiasUniform, Raster, ShadowMapArray, lookup_group};
use crate::technique::{FrameContext, TechniqueError};
use crate::timing::PassKind;

/// `SET_*` flags of `samples.wgsl`.
pub const SET_PCF: u32 = 1;
pub const SET_FIRST: u32 = 4;

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct SampleInfo {
    position: Vec4,
    normal: Vec4,
}

/// `SampleSet` of `samples.wgsl`: which samples one dispatch looks up, and its depth weight.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct SetUniform {
    pub index: [u32; 4],
    pub range: [f32; 4],
}

impl SetUniform {
    /// Samples `first..first + count`, weight 1 at every depth.
    pub fn all(first: u32, count: u32, faces: u32, flags: u32) -> Self {
        Self { index: [first, count, faces, flags], range: [-f32::MAX, f32::MAX, f32::MAX, -f32::MAX] }
    }
}

/// Group 2 of `samples.wgsl`.
pub fn layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("sample set", || {
        let c = wgpu::ShaderStages::COMPUTE;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("sample set"),
            entries: &[
                storage_entry(0, c, true),
                storage_entry(1, c, false),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: c,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: true,
                        min_binding_size: std::num::NonZeroU64::new(32),
                    },
                    count: None,
                },
            ],
        })
    })
}

/// The per-pixel running sums (w·V, w) of a surface, for technique `id`; an error where they
/// would outgrow a storage binding (past about 16.7 million pixels on CPU adapters and in
/// browsers).
pub fn accumulation_buffer(shared: &Shared, id: &str, width: u32, height: u32) -> Result<wgpu::Buffer, TechniqueError> {
    let bytes = 8 * u64::from(width.max(1)) * u64::from(height.max(1));
    shared.check_output_buffer(id, "sample sums", bytes, width, height)?;
    Ok(shared.gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("sample sums"),
        size: bytes,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    }))
}

/// The views of every sample with one layout for all (all cube or all single), from `make(force_cube)`.
pub fn uniform_layout(make: impl Fn(bool) -> Vec<LightFrusta>) -> Vec<LightFrusta> {
    let first = make(false);
    if first.iter().any(|f| f.cube) && !first.iter().all(|f| f.cube) { make(true) } else { first }
}

/// Lookup settings of a sample set.
#[derive(Debug, Clone, Copy)]
pub struct SetConfig {
    pub size: u32,
    /// Every sample its own layers (one lookup pass) rather than shared layers.
    pub array: bool,
    pub normal_offset: f32,
    pub constant_bias: f32,
}

/// Samples with their maps and the group-2 bind group.
/// Where the samples' maps live.
pub enum SampleStorage {
    /// Every sample its own layers, cached.
    Cached(MapViews),
    /// The samples take turns in the same layers (one sample's views).
    Shared(ShadowMapArray),
}

pub struct SampleMaps {
    pub storage: SampleStorage,
    /// Views per sample (1, or 6 for cube maps).
    pub faces: u32,
    pub samples: u32,
    pub array: bool,
    pub lookup: wgpu::BindGroup,
    bias: wgpu::Buffer,
    /// The cached maps' generation the lookup group was made for.
    generation: u32,
    /// Every sample's views, in slot order (sample i's at `i·faces..`).
    views: Vec<ShadowView>,
    group: wgpu::BindGroup,
    sets: wgpu::Buffer,
    samples_buffer: wgpu::Buffer,
    stride: u64,
    bytes: u64,
    /// Views rendered by the last update (cached storage).
    pub rendered: u32,
}

impl SampleMaps {
    /// `frusta[i]` are sample i's views (all with the same count); `sets` the dispatches this set
    /// will make (their uniforms, addressed by index in [`SampleMaps::dispatch`]).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        shared: &Shared,
        cache: &mut crate::live::ShadowCache,
        id: &str,
        points: &[EmitterPoint],
        frusta: &[LightFrusta],
        config: SetConfig,
        accum: &wgpu::Buffer,
        sets: &[SetUniform],
    ) -> Result<Self, TechniqueError> {
        let device = &shared.gpu.device;
        let n = points.len() as u32;
        let faces = frusta.first().map_or(1, |f| f.views.len() as u32);
        let layers = if config.array { n * faces } else { faces };
        let max_layers = device.limits().max_texture_array_layers;
        if layers > max_layers {
            return Err(TechniqueError::Failed {
                id: id.to_owned(),
                message: format!(
                    "{n} samples × {faces} views need {layers} texture layers; this device allows {max_layers} \
                     (use fewer samples or mode=accumulate)"
                ),
            });
        }
        let bytes_needed = u64::from(config.size).pow(2) * 4 * u64::from(layers);
        if bytes_needed > device.limits().max_buffer_size.max(1 << 32) {
            return Err(TechniqueError::Failed {
                id: id.to_owned(),
                message: format!("{layers} maps of {}² need {} MiB", config.size, bytes_needed >> 20),
            });
        }
        let storage = if config.array {
            SampleStorage::Cached(MapViews::new(shared, cache, config.size, n * faces))
        } else {
            SampleStorage::Shared(ShadowMapArray::new(shared, config.size, layers, n * faces))
        };
        let maps = match &storage {
            SampleStorage::Cached(m) => &m.maps,
            SampleStorage::Shared(m) => m,
        };
        let bias = BiasUniform {
            values: Vec4::new(
                config.normal_offset,
                config.constant_bias,
                config.size as f32,
                if faces == 6 { 1.0 } else { 0.0 },
            ),
            mode: Vec4::ZERO,
        };
        let bias_buffer = crate::util::uniform_buffer(device, "sample map params", bytemuck::bytes_of(&bias));
        let lookup = lookup_group(shared, maps, &bias_buffer, false);
        let sample_buffer = crate::util::storage_buffer(device, "samples", bytemuck::cast_slice(&sample_infos(points)));
        let stride = u64::from(device.limits().min_uniform_buffer_offset_alignment).max(32);
        let set_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sample sets"),
            size: stride * sets.len().max(1) as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        for (i, s) in sets.iter().enumerate() {
            shared.gpu.queue.write_buffer(&set_buffer, i as u64 * stride, bytemuck::bytes_of(s));
        }
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("sample set"),
            layout: &layout(shared),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: sample_buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: accum.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &set_buffer,
                        offset: 0,
                        size: std::num::NonZeroU64::new(32),
                    }),
                },
            ],
        });
        let bytes = sample_buffer.size() + set_buffer.size() + bias_buffer.size();
        let mut set = Self {
            storage,
            faces,
            samples: n,
            array: config.array,
            lookup,
            bias: bias_buffer,
            generation: 0,
            views: Vec::new(),
            group,
            sets: set_buffer,
            samples_buffer: sample_buffer,
            stride,
            bytes,
            rendered: 0,
        };
        set.set_views(&shared.gpu.queue, frusta);
        Ok(set)
    }

    /// Rewrites the samples' positions and weights (the light moved; same count).
    pub fn set_points(&self, queue: &wgpu::Queue, points: &[EmitterPoint]) {
        queue.write_buffer(&self.samples_buffer, 0, bytemuck::cast_slice(&sample_infos(points)));
    }

    /// The texture array the lookups read.
    pub fn maps(&self) -> &ShadowMapArray {
        match &self.storage {
            SampleStorage::Cached(m) => &m.maps,
            SampleStorage::Shared(m) => m,
        }
    }

    /// Every sample's views, in slot order.
    pub fn views(&self) -> &[ShadowView] {
        &self.views
    }

    /// Sets every sample's views (stored now for shared layers, where samples read their face's
    /// layer; at the next [`SampleMaps::update`] for cached ones).
    pub fn set_views(&mut self, queue: &wgpu::Queue, frusta: &[LightFrusta]) {
        self.views = frusta.iter().flat_map(|f| f.views.iter().copied()).collect();
        if let SampleStorage::Shared(maps) = &mut self.storage {
            let faces = self.faces.max(1);
            let layers: Vec<u32> = (0..self.views.len() as u32).map(|slot| slot % faces).collect();
            maps.set_views_in(queue, 0, &self.views, &layers);
        }
    }

    /// Renders the cached samples' views that are not valid (nothing for shared layers, which are
    /// rendered in turn by [`SampleMaps::render_sample`]). Returns the views rendered.
    pub fn update(&mut self, ctx: &mut FrameContext<'_>, raster: &Raster) -> Result<u32, TechniqueError> {
        let SampleStorage::Cached(maps) = &mut self.storage else { return Ok(0) };
        self.rendered = maps.update(ctx, &self.views, raster, 0)?;
        if self.generation != maps.generation() {
            self.lookup = lookup_group(ctx.shared, &maps.maps, &self.bias, false);
            self.generation = maps.generation();
        }
        Ok(self.rendered)
    }

    /// Whether every sample's maps have a complete state to show (shared layers always have: they
    /// are rendered in the frame that reads them).
    pub fn shown(&self) -> bool {
        match &self.storage {
            SampleStorage::Cached(m) => m.shown(),
            SampleStorage::Shared(_) => true,
        }
    }

    /// Whether the maps shown hold the current state.
    pub fn current(&self) -> bool {
        match &self.storage {
            SampleStorage::Cached(m) => m.current(),
            SampleStorage::Shared(_) => true,
        }
    }

    /// Drops the cached samples' records (before the set is replaced).
    pub fn forget_items(&self, ctx: &mut FrameContext<'_>) {
        if let SampleStorage::Cached(maps) = &self.storage {
            maps.forget_items(ctx);
        }
    }

    /// GPU bytes held (maps, samples, uniforms; not the shared sums).
    pub fn bytes(&self) -> u64 {
        self.bytes + self.maps().bytes()
    }

    /// Replaces the uniform of dispatch `set`.
    pub fn write_set(&self, queue: &wgpu::Queue, set: usize, value: &SetUniform) {
        queue.write_buffer(&self.sets, set as u64 * self.stride, bytemuck::bytes_of(value));
    }

    /// Renders sample `i`'s views into the shared layers (uncached storage). Returns the draws
    /// issued.
    pub fn render_sample(&self, ctx: &mut FrameContext<'_>, i: u32, raster: &Raster) -> u32 {
        let SampleStorage::Shared(maps) = &self.storage else { return 0 };
        let mut draws = 0;
        for face in 0..self.faces {
            draws += maps.render(ctx, face, i * self.faces + face, raster);
        }
        ctx.cache.work.map_views += self.faces;
        draws
    }

    /// One lookup dispatch over the surface with the set uniform `set`.
    pub fn dispatch(
        &self,
        ctx: &mut FrameContext<'_>,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        group0: &wgpu::BindGroup,
        set: usize,
    ) {
        let timestamps = ctx.timer.compute_pass(&ctx.gpu.device, PassKind::Visibility);
        let mut pass = ctx
            .encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: timestamps });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, Some(group0), &[]);
        pass.set_bind_group(1, Some(&self.lookup), &[]);
        pass.set_bind_group(2, Some(&self.group), &[(set as u64 * self.stride) as u32]);
        pass.dispatch_workgroups(
            crate::util::groups(ctx.surface.width, 8),
            crate::util::groups(ctx.surface.height, 8),
            1,
        );
    }
}

/// `SampleInfo`s of emitter points.
fn sample_infos(points: &[EmitterPoint]) -> Vec<SampleInfo> {
    points
        .iter()
        .map(|p| {
            let position = match p.sample {
                EmitterSample::Point(q) => q.extend(0.0),
                EmitterSample::Direction(d) => d.extend(1.0),
            };
            let normal = p.sphere_normal.map(|n| n.extend(1.0)).unwrap_or(Vec4::ZERO);
            SampleInfo { position, normal }
        })
        .collect()
}
