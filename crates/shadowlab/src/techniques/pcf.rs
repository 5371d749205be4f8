//! `pcf`: percentage-closer filtering (Reeves, Salesin & Cook, SIGGRAPH 1987) on the maps of `hard`.
//! Each tap is a hardware bilinear comparison (a 2 × 2 PCF of its own). Kernels: a box of N × N taps
//! (Azri 2020 §3 uses 3 × 3: `kernel=box,taps=9`), a Poisson disk of N taps, or the same disk rotated
//! per pixel (interleaved gradient noise, Jimenez 2014), which trades banding for noise. The radius
//! is in texels or in world units at the receiver.

use glam::Vec2;
use shadowlab_core::params::ParamDef;
use shadowlab_core::sampling::Rng;
use shadowlab_core::{Light, ParamSet};

use crate::frame::VisibilityLayer;
use crate::shadowmap::{LightMap, lookup_layout};
use crate::technique::{
    FrameContext, ShadowTechnique, Shared, TechniqueError, TechniqueInfo, TechniqueStats, dispatch_resolve,
    uniform_entry,
};

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "pcf",
    summary: "percentage-closer filtering: box, Poisson or rotated Poisson kernels",
    source: "Reeves et al. 1987; Azri 2020 §3 (3×3 PCF); Stingl 2011 §2.3",
    params: crate::map_params!(
        ParamDef::choice("kernel", "poisson", &["box", "poisson", "rotated"], "tap pattern"),
        ParamDef::int("taps", 16, 1, 64, "number of taps (box: rounded to N×N)"),
        ParamDef::float("radius", 1.5, 0.0, 64.0, "kernel radius"),
        ParamDef::choice("radius_unit", "texels", &["texels", "world"], "unit of the radius"),
    ),
    light_types: super::ALL_LIGHTS,
    create,
};

const MAX_TAPS: usize = 64;

/// The kernel uniform of `pcf.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct KernelUniform {
    params: [f32; 4],
    taps: [[f32; 4]; MAX_TAPS],
}

/// A progressive Poisson-disk sequence in the unit disk by Mitchell's best-candidate algorithm
/// (Mitchell 1991): each point is the farthest of k random candidates from those before it, so
/// every prefix is well spread. Deterministic.
pub fn poisson_disk(n: usize) -> Vec<Vec2> {
    let mut rng = Rng::new(0x0050_1550);
    let mut points: Vec<Vec2> = Vec::with_capacity(n);
    while points.len() < n {
        let candidates = 8 * (points.len() + 1);
        let mut best = Vec2::ZERO;
        let mut best_d = -1.0f32;
        for _ in 0..candidates {
            let c = loop {
                let c = Vec2::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
                if c.length_squared() <= 1.0 {
                    break c;
                }
            };
            let d = points.iter().map(|p| p.distance_squared(c)).fold(f32::INFINITY, f32::min);
            if d > best_d {
                best_d = d;
                best = c;
            }
        }
        points.push(best);
    }
    points
}

/// Offsets of an N × N box in [−1, 1]² (N = round(√taps)).
pub fn box_kernel(taps: usize) -> Vec<Vec2> {
    let n = ((taps as f32).sqrt().round() as usize).max(1);
    (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32, (i / n) as f32);
            if n == 1 { Vec2::ZERO } else { Vec2::new(2.0 * x / (n - 1) as f32 - 1.0, 2.0 * y / (n - 1) as f32 - 1.0) }
        })
        .collect()
}

struct Pcf {
    params: ParamSet,
    map: Option<LightMap>,
    pipeline: wgpu::ComputePipeline,
    kernel_group: wgpu::BindGroup,
    kernel_bytes: u64,
    triangles: u64,
}

fn kernel_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("pcf kernel", || {
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("pcf kernel"),
            entries: &[uniform_entry(0, wgpu::ShaderStages::COMPUTE)],
        })
    })
}

fn create(shared: &Shared, params: &ParamSet, _light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let taps = params.int("taps") as usize;
    let kind = params.choice("kernel");
    let offsets = if kind == "box" { box_kernel(taps) } else { poisson_disk(taps) };
    let mut kernel = KernelUniform {
        params: [
            offsets.len() as f32,
            params.float("radius") as f32,
            if params.choice("radius_unit") == "world" { 1.0 } else { 0.0 },
            if kind == "rotated" { 1.0 } else { 0.0 },
        ],
        taps: [[0.0; 4]; MAX_TAPS],
    };
    for (t, o) in kernel.taps.iter_mut().zip(&offsets) {
        *t = [o.x, o.y, 0.0, 0.0];
    }
    let buffer = crate::util::uniform_buffer(&shared.gpu.device, "pcf kernel", bytemuck::bytes_of(&kernel));
    let layout = kernel_layout(shared);
    let kernel_group = shared.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("pcf kernel"),
        layout: &layout,
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() }],
    });
    let pipeline =
        shared.resolve_pipeline("pcf", include_str!("pcf.wgsl"), "main", &[&lookup_layout(shared), &layout], &[]);
    Ok(Box::new(Pcf {
        params: params.clone(),
        map: None,
        pipeline,
        kernel_group,
        kernel_bytes: buffer.size(),
        triangles: 0,
    }))
}

impl ShadowTechnique for Pcf {
    fn id(&self) -> &'static str {
        INFO.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        let map = self
            .map
            .get_or_insert_with(|| LightMap::new(ctx.shared, ctx.light, &ctx.gpu_scene.bounds, &self.params, true));
        map.render(ctx);
        self.triangles = ctx.gpu_scene.triangles;
        Ok(())
    }

    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let Some(map) = &self.map else { return };
        let group0 = ctx.shared.resolve_bind_group(ctx.surface, ctx.light_buffer, out);
        dispatch_resolve(ctx, "pcf", &self.pipeline, &[&group0, &map.group, &self.kernel_group]);
    }

    fn stats(&self) -> TechniqueStats {
        match &self.map {
            Some(m) => {
                let (passes, draws, triangles) = m.counts(self.triangles);
                TechniqueStats { memory_bytes: m.bytes() + self.kernel_bytes, passes: passes + 1, draws, triangles }
            }
            None => TechniqueStats::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernels() {
        let b = box_kernel(9);
        assert_eq!(b.len(), 9);
        assert_eq!(b[0], Vec2::new(-1.0, -1.0));
        assert_eq!(b[4], Vec2::ZERO);
        assert_eq!(box_kernel(1), vec![Vec2::ZERO]);
        let p = poisson_disk(16);
        assert_eq!(p.len(), 16);
        assert!(p.iter().all(|q| q.length() <= 1.0));
        // Well spread: no two of 16 points in the unit disk closer than 0.25 (measured min 0.34).
        for i in 0..16 {
            for j in 0..i {
                assert!(p[i].distance(p[j]) > 0.25, "{i} {j}");
            }
        }
        assert_eq!(poisson_disk(16), p, "deterministic");
    }
}
