//! Filter kernels for percentage-closer filtering, shared by `pcf`, `cascaded` and the soft
//! techniques (`shaders/pcfkernel.wgsl`, group 2).

use glam::Vec2;
use shadowlab_core::ParamSet;
use shadowlab_core::params::ParamDef;
use shadowlab_core::sampling::Rng;

use crate::context::{Shared, uniform_entry};

pub const MAX_TAPS: usize = 64;

/// The PCF parameters, as a technique's parameter list includes them.
pub const KERNEL: ParamDef = ParamDef::choice("kernel", "poisson", &["box", "poisson", "rotated"], "tap pattern");
pub const TAPS: ParamDef = ParamDef::int("taps", 16, 1, 64, "number of taps (box: rounded to N×N)");
pub const RADIUS: ParamDef = ParamDef::float("radius", 1.5, 0.0, 64.0, "kernel radius");
pub const RADIUS_UNIT: ParamDef = ParamDef::choice("radius_unit", "texels", &["texels", "world"], "unit of the radius");
/// The blur's bound in screen pixels: where a map's texels cover many pixels (near the eye, or on
/// ground the light grazes), a kernel of 1.5 texels spreads each edge over metres of lit surface.
pub const MAX_BLUR: ParamDef =
    ParamDef::float("max_blur", 1.0, 0.0, 64.0, "largest blur in screen pixels where texels are larger (0: none)");

/// The kernel uniform of `pcfkernel.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct KernelUniform {
    pub params: [f32; 4],
    pub taps: [[f32; 4]; MAX_TAPS],
    /// x: the largest blur in screen pixels (0: unbounded).
    pub limits: [f32; 4],
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

/// A kernel: `kind` is `box`, `poisson`, `rotated` (rotated Poisson) or `none` (one central tap);
/// `max_blur` bounds its blur in screen pixels (0: unbounded).
pub fn kernel_uniform(kind: &str, taps: usize, radius: f32, world_units: bool, max_blur: f32) -> KernelUniform {
    let offsets = match kind {
        "box" => box_kernel(taps),
        "none" => vec![Vec2::ZERO],
        _ => poisson_disk(taps.min(MAX_TAPS)),
    };
    let mut k = KernelUniform {
        params: [
            offsets.len() as f32,
            radius,
            if world_units { 1.0 } else { 0.0 },
            if kind == "rotated" { 1.0 } else { 0.0 },
        ],
        taps: [[0.0; 4]; MAX_TAPS],
        limits: [max_blur, 0.0, 0.0, 0.0],
    };
    for (t, o) in k.taps.iter_mut().zip(&offsets) {
        *t = [o.x, o.y, 0.0, 0.0];
    }
    k
}

/// A kernel from a technique's `kernel`, `taps`, `radius`, `radius_unit` and `max_blur` parameters.
pub fn from_params(p: &ParamSet) -> KernelUniform {
    kernel_uniform(
        p.choice("kernel"),
        p.int("taps") as usize,
        p.float("radius") as f32,
        p.choice("radius_unit") == "world",
        p.float("max_blur") as f32,
    )
}

pub fn layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("pcf kernel", || {
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("pcf kernel"),
            entries: &[uniform_entry(0, shared.resolve_stage())],
        })
    })
}

/// The kernel's bind group and the bytes its buffer holds.
pub fn bind_group(shared: &Shared, k: &KernelUniform) -> (wgpu::BindGroup, u64) {
    let buffer = crate::util::uniform_buffer(&shared.gpu.device, "pcf kernel", bytemuck::bytes_of(k));
    let group = shared.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("pcf kernel"),
        layout: &layout(shared),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() }],
    });
    (group, buffer.size())
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
        assert_eq!(kernel_uniform("none", 16, 2.0, false, 1.0).params[0], 1.0);
    }
}
