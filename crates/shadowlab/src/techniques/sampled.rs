//! `sampled`: the documents' own ground truth on the GPU. The area light is replaced by N point
//! samples with one hard shadow map each, and V is their average (Guennebaud et al. 2007, Fig. 1:
//! 1024 maps; Azri 2020 §3: k × k samples; Toromanoff 2005, algorithm D). Samples: the k × k grid on
//! rectangles, cone directions for the sun, and equal-area points on the sphere for sphere lights,
//! weighted per receiver by their projected area so that they cover the light's disk uniformly
//! ([`shadowlab_core::sampling::emitter_points`]). It doubles as a check of the CPU reference.
//!
//! The maps are rendered one sample at a time into the same layers and accumulated per pixel
//! ("accumulation over passes"): memory stays that of one map, time grows with N.

use bytemuck::{Pod, Zeroable};
use glam::Vec4;
use shadowlab_core::lightspace::{LightFrusta, ShadowView, directional_frustum, point_frusta_with};
use shadowlab_core::params::ParamDef;
use shadowlab_core::sampling::{EmitterSample, emitter_points};
use shadowlab_core::{Light, LightKind, ParamSet};

use crate::frame::VisibilityLayer;
use crate::shadowmap::{
    BiasUniform, CONSTANT_BIAS, FACES, FaceMode, NORMAL_OFFSET, Raster, SLOPE_BIAS, ShadowMapArray, lookup_group,
    lookup_layout,
};
use crate::technique::{
    FrameContext, ShadowTechnique, Shared, TechniqueError, TechniqueInfo, TechniqueStats, storage_entry,
};
use crate::timing::PassKind;

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "sampled",
    summary: "area light as N point samples with one hard shadow map each, averaged",
    source: "Guennebaud et al. 2007 Fig. 1; Azri 2020 §3; Toromanoff 2005 alg. D",
    params: &[
        ParamDef::int("samples", 64, 1, 4096, "emitter samples (one shadow map each)"),
        ParamDef::int("map_size", 512, 16, 8192, "shadow map resolution of each sample"),
        FACES,
        SLOPE_BIAS,
        NORMAL_OFFSET,
        CONSTANT_BIAS,
    ],
    light_types: super::ALL_LIGHTS,
    create,
};

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct SampleInfo {
    position: Vec4,
    normal: Vec4,
}

struct Sampled {
    params: ParamSet,
    state: Option<State>,
    accumulate: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    triangles: u64,
}

/// Built on the first frame, when the scene bounds and the surface size are known.
struct State {
    maps: ShadowMapArray,
    raster: Raster,
    faces: u32,
    samples: u32,
    lookup: wgpu::BindGroup,
    sample_group: wgpu::BindGroup,
    step_stride: u64,
    bytes: u64,
    draws: u32,
}

fn sample_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("sampled samples", || {
        let c = wgpu::ShaderStages::COMPUTE;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("sampled samples"),
            entries: &[
                storage_entry(0, c, true),
                storage_entry(1, c, false),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: c,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: true,
                        min_binding_size: std::num::NonZeroU64::new(16),
                    },
                    count: None,
                },
            ],
        })
    })
}

fn create(shared: &Shared, params: &ParamSet, _light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let extra = [&lookup_layout(shared), &sample_layout(shared)];
    let source = include_str!("sampled.wgsl");
    let accumulate = shared.resolve_pipeline("sampled accumulate", source, "accumulate", &extra, &[]);
    let finish = shared.resolve_pipeline("sampled finish", source, "finish", &extra, &[]);
    Ok(Box::new(Sampled { params: params.clone(), state: None, accumulate, finish, triangles: 0 }))
}

/// The views of every sample, all with the same layout (all cube or all single).
fn sample_frusta(
    light: &Light,
    points: &[EmitterSample],
    bounds: &shadowlab_core::Aabb,
    size: u32,
) -> Vec<LightFrusta> {
    let cone = match light.kind {
        LightKind::Spot { direction, outer_angle, .. } => Some((direction, outer_angle)),
        LightKind::Rect { direction, .. } => Some((direction, std::f32::consts::FRAC_PI_2)),
        _ => None,
    };
    let make = |force_cube: bool| -> Vec<LightFrusta> {
        points
            .iter()
            .map(|s| match *s {
                EmitterSample::Point(p) => point_frusta_with(p, bounds, cone, size, force_cube),
                EmitterSample::Direction(d) => directional_frustum(-d, bounds, size),
            })
            .collect()
    };
    let first = make(false);
    if first.iter().any(|f| f.cube) && !first.iter().all(|f| f.cube) { make(true) } else { first }
}

impl Sampled {
    fn build(&self, ctx: &FrameContext<'_>) -> State {
        let shared = ctx.shared;
        let device = &shared.gpu.device;
        let size = self.params.int("map_size") as u32;
        let points = emitter_points(ctx.light, self.params.int("samples") as u32);
        let samples: Vec<EmitterSample> = points.iter().map(|p| p.sample).collect();
        let frusta = sample_frusta(ctx.light, &samples, &ctx.gpu_scene.bounds, size);
        let faces = frusta[0].views.len() as u32;
        let n = points.len() as u32;
        let maps = ShadowMapArray::new(shared, size, faces, n * faces);
        let views: Vec<ShadowView> = frusta.iter().flat_map(|f| f.views.iter().copied()).collect();
        maps.set_views(&shared.gpu.queue, 0, &views);
        let bias = BiasUniform {
            values: Vec4::new(
                self.params.float("normal_offset") as f32,
                self.params.float("constant_bias") as f32,
                size as f32,
                if faces == 6 { 1.0 } else { 0.0 },
            ),
            mode: Vec4::ZERO,
        };
        let bias_buffer = crate::util::uniform_buffer(device, "sampled bias", bytemuck::bytes_of(&bias));
        let lookup = lookup_group(shared, &maps, &bias_buffer, false);
        let infos: Vec<SampleInfo> = points
            .iter()
            .map(|p| {
                let position = match p.sample {
                    EmitterSample::Point(q) => q.extend(0.0),
                    EmitterSample::Direction(d) => d.extend(1.0),
                };
                let normal = p.sphere_normal.map(|n| n.extend(1.0)).unwrap_or(Vec4::ZERO);
                SampleInfo { position, normal }
            })
            .collect();
        let sample_buffer = crate::util::storage_buffer(device, "samples", bytemuck::cast_slice(&infos));
        let accum = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sampled accumulation"),
            size: 8 * u64::from(ctx.surface.width) * u64::from(ctx.surface.height),
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let stride = u64::from(device.limits().min_uniform_buffer_offset_alignment).max(16);
        let steps = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sampled steps"),
            size: stride * u64::from(n),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        for i in 0..n {
            shared.gpu.queue.write_buffer(
                &steps,
                u64::from(i) * stride,
                bytemuck::cast_slice(&[i, i * faces, faces, 0u32]),
            );
        }
        let sample_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("sampled samples"),
            layout: &sample_layout(shared),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: sample_buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: accum.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &steps,
                        offset: 0,
                        size: std::num::NonZeroU64::new(16),
                    }),
                },
            ],
        });
        let bytes = maps.bytes() + sample_buffer.size() + accum.size() + steps.size() + bias_buffer.size();
        State {
            maps,
            raster: Raster {
                faces: FaceMode::parse(self.params.choice("faces")),
                slope_bias: self.params.float("slope_bias") as f32,
            },
            faces,
            samples: n,
            lookup,
            sample_group,
            step_stride: stride,
            bytes,
            draws: 0,
        }
    }
}

impl ShadowTechnique for Sampled {
    fn id(&self) -> &'static str {
        INFO.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        if self.state.is_none() {
            self.state = Some(self.build(ctx));
        }
        self.triangles = ctx.gpu_scene.triangles;
        Ok(())
    }

    /// Renders and accumulates the samples one after the other, then writes V.
    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let Some(state) = &mut self.state else { return };
        let group0 = ctx.shared.resolve_bind_group(ctx.surface, ctx.light_buffer, out);
        let (w, h) = (crate::util::groups(ctx.surface.width, 8), crate::util::groups(ctx.surface.height, 8));
        state.draws = 0;
        for i in 0..state.samples {
            for face in 0..state.faces {
                state.draws += state.maps.render(ctx, face, i * state.faces + face, &state.raster);
            }
            let timestamps = ctx.timer.compute_pass(&ctx.gpu.device, PassKind::Visibility);
            let mut pass = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("sampled accumulate"),
                timestamp_writes: timestamps,
            });
            pass.set_pipeline(&self.accumulate);
            pass.set_bind_group(0, Some(&group0), &[]);
            pass.set_bind_group(1, Some(&state.lookup), &[]);
            pass.set_bind_group(2, Some(&state.sample_group), &[(u64::from(i) * state.step_stride) as u32]);
            pass.dispatch_workgroups(w, h, 1);
        }
        let timestamps = ctx.timer.compute_pass(&ctx.gpu.device, PassKind::Visibility);
        let mut pass = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("sampled finish"),
            timestamp_writes: timestamps,
        });
        pass.set_pipeline(&self.finish);
        pass.set_bind_group(0, Some(&group0), &[]);
        pass.set_bind_group(1, Some(&state.lookup), &[]);
        pass.set_bind_group(2, Some(&state.sample_group), &[0]);
        pass.dispatch_workgroups(w, h, 1);
    }

    fn stats(&self) -> TechniqueStats {
        match &self.state {
            Some(s) => TechniqueStats {
                memory_bytes: s.bytes,
                passes: s.samples * (s.faces + 1) + 1,
                draws: s.draws,
                triangles: self.triangles * u64::from(s.samples * s.faces),
                extra: vec![("samples".into(), f64::from(s.samples)), ("views_per_sample".into(), f64::from(s.faces))],
            },
            None => TechniqueStats::default(),
        }
    }
}
