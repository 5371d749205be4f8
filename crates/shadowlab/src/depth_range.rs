//! The visible depth range from a GPU min/max reduction of the depth buffer, read back without
//! stalling: each frame's result is copied to a staging buffer and read when it is ready, so a
//! technique uses the range of an earlier frame (usually the previous one). The automatic near
//! plane of Stingl 2011, §4.3 (there read back with a stall, which halved the frame rate).
//!
//! With samples ([`DepthRange::with_samples`], `cascaded`'s `scheme=auto`) the same pass also sorts
//! the visible samples into log-spaced bins of eye depth and keeps each bin's box in the light's
//! frame (`shaders/depth_samples.wgsl`), read back through the same ring: the per-partition bounds
//! of sample distribution shadow maps (Lauritzen, Salvi and Lefohn 2011, §4).

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use glam::{Mat4, Vec3, Vec4};
use shadowlab_core::cascades::{DEPTH_BINS, DepthSamples, VisibleDepths, depth_bin_range};

use crate::context::Shared;
use crate::frame::SurfaceInputs;
use crate::timing::{GpuTimer, PassKind};

const SLOTS: usize = 3;
const EMPTY: [u32; 2] = [0x7f7f_ffff, 0];
/// Words of the samples' buffer: the range, then four per bin.
const SAMPLE_WORDS: usize = 2 + 4 * DEPTH_BINS;

/// Where and from where a frame's samples were binned: what turns its words into `DepthSamples`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BinSetup {
    /// The light frame the boxes are taken in (`shadowlab_core::cascades::light_frame`).
    pub light_view: Mat4,
    /// The eye depths the bins are log-spaced over (any positive range; samples beyond it fall
    /// into the end bins).
    pub near: f32,
    pub far: f32,
    pub eye: Vec3,
    pub forward: Vec3,
}

#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct BinsUniform {
    light_view: Mat4,
    range: Vec4,
}

#[derive(Debug)]
enum Slot {
    Idle,
    /// Holds the measurement of this frame, not yet mapped.
    Written(u64, Option<BinSetup>),
    /// Being mapped: 0 pending, 1 done, 2 failed.
    Mapping(u64, Option<BinSetup>, Arc<AtomicU8>),
}

/// The reduction, its staging ring and the latest measurement read back.
pub struct DepthRange {
    pipeline: wgpu::ComputePipeline,
    range: wgpu::Buffer,
    /// The bins' uniform, with samples.
    bins: Option<wgpu::Buffer>,
    words: usize,
    staging: Vec<wgpu::Buffer>,
    slots: Vec<Slot>,
    latest: Option<VisibleDepths>,
}

impl DepthRange {
    /// The range alone.
    pub fn new(shared: &Shared) -> Self {
        Self::make(shared, false)
    }

    /// The range and the binned samples (`record` then takes a `BinSetup`).
    pub fn with_samples(shared: &Shared) -> Self {
        Self::make(shared, true)
    }

    fn make(shared: &Shared, samples: bool) -> Self {
        let device = &shared.gpu.device;
        let (key, source) = if samples {
            ("depth samples", include_str!("shaders/depth_samples.wgsl"))
        } else {
            ("depth range", include_str!("shaders/depth_range.wgsl"))
        };
        let pipeline = shared.compute_pipeline(key, || {
            let module = crate::shader::module(device, key, source);
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(key),
                layout: None,
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            })
        });
        let words = if samples { SAMPLE_WORDS } else { 2 };
        let size = 4 * words as u64;
        let range = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(key),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bins = samples.then(|| {
            crate::util::uniform_buffer(
                device,
                "depth samples bins",
                bytemuck::bytes_of(&BinsUniform { light_view: Mat4::IDENTITY, range: Vec4::ZERO }),
            )
        });
        let staging = (0..SLOTS)
            .map(|_| {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("depth range staging"),
                    size,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })
            .collect();
        Self { pipeline, range, bins, words, staging, slots: (0..SLOTS).map(|_| Slot::Idle).collect(), latest: None }
    }

    /// Collects finished readbacks (never waits): asks to map what the GPU has written, lets wgpu
    /// deliver what is ready, and keeps the newest range.
    pub fn poll(&mut self, device: &wgpu::Device) {
        for (i, slot) in self.slots.iter_mut().enumerate() {
            if let Slot::Written(frame, setup) = *slot {
                let flag = Arc::new(AtomicU8::new(0));
                let f = flag.clone();
                self.staging[i].map_async(wgpu::MapMode::Read, .., move |r| {
                    f.store(if r.is_ok() { 1 } else { 2 }, Ordering::Release)
                });
                *slot = Slot::Mapping(frame, setup, flag);
            }
        }
        let _ = device.poll(wgpu::PollType::Poll);
        for (i, slot) in self.slots.iter_mut().enumerate() {
            let Slot::Mapping(frame, setup, flag) = slot else { continue };
            match flag.load(Ordering::Acquire) {
                1 => {
                    if let Ok(view) = self.staging[i].get_mapped_range(..) {
                        let words: Vec<u32> =
                            view.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
                        drop(view);
                        let (lo, hi) = (f32::from_bits(words[0]), f32::from_bits(words[1]));
                        let newer = self.latest.as_ref().is_none_or(|l| l.frame < *frame);
                        if lo <= hi && lo.is_finite() && newer {
                            let samples = setup.and_then(|b| {
                                DepthSamples::from_words(&words, b.light_view, b.near, b.far, b.eye, b.forward)
                            });
                            self.latest = Some(VisibleDepths { range: (lo, hi), frame: *frame, samples });
                        }
                    }
                    self.staging[i].unmap();
                    *slot = Slot::Idle;
                }
                2 => *slot = Slot::Idle,
                _ => {}
            }
        }
    }

    /// Reduces this frame's depth (and bins its samples as `bins` says, with samples) and queues
    /// its readback; false when every slot was busy and nothing was recorded.
    pub fn record(
        &mut self,
        shared: &Shared,
        encoder: &mut wgpu::CommandEncoder,
        surface: &SurfaceInputs,
        timer: &mut GpuTimer,
        frame: u64,
        bins: Option<BinSetup>,
    ) -> bool {
        let Some(slot) = self.slots.iter().position(|s| matches!(s, Slot::Idle)) else { return false };
        let device = &shared.gpu.device;
        let queue = &shared.gpu.queue;
        let mut empty = EMPTY.to_vec();
        empty.resize(self.words, 0);
        for bin in empty[2..].chunks_exact_mut(4) {
            // Minima start at the largest ordered code, maxima at the smallest.
            bin.copy_from_slice(&[u32::MAX, u32::MAX, 0, 0]);
        }
        queue.write_buffer(&self.range, 0, bytemuck::cast_slice(&empty));
        let setup = match (&self.bins, bins) {
            (Some(buffer), Some(b)) => {
                let (near, far) = depth_bin_range(b.near, b.far);
                let range = Vec4::new(near, DEPTH_BINS as f32 / (far / near).ln(), 0.0, 0.0);
                queue.write_buffer(buffer, 0, bytemuck::bytes_of(&BinsUniform { light_view: b.light_view, range }));
                Some(BinSetup { near, far, ..b })
            }
            _ => None,
        };
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 0, resource: surface.camera_buffer.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&surface.depth) },
            wgpu::BindGroupEntry { binding: 2, resource: self.range.as_entire_binding() },
        ];
        if let Some(buffer) = &self.bins {
            entries.push(wgpu::BindGroupEntry { binding: 3, resource: buffer.as_entire_binding() });
        }
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("depth range"),
            layout: &self.pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        {
            let timestamps = timer.compute_pass(device, PassKind::Shadow);
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("depth range"),
                timestamp_writes: timestamps,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, Some(&group), &[]);
            pass.dispatch_workgroups(
                crate::util::groups(surface.width, 16),
                crate::util::groups(surface.height, 16),
                1,
            );
        }
        encoder.copy_buffer_to_buffer(&self.range, 0, &self.staging[slot], 0, 4 * self.words as u64);
        self.slots[slot] = Slot::Written(frame, setup);
        true
    }

    /// The latest range read back and the frame it was measured in.
    pub fn latest(&self) -> Option<((f32, f32), u64)> {
        self.latest.as_ref().map(|l| (l.range, l.frame))
    }

    /// The latest measurement whole (with its samples, if binned).
    pub fn measured(&self) -> Option<&VisibleDepths> {
        self.latest.as_ref()
    }

    /// Takes another engine's measurement as the latest (a fresh engine compared with a live one:
    /// both then fit their maps to the same samples). Readbacks measured later replace it.
    pub fn adopt(&mut self, measured: VisibleDepths) {
        self.latest = Some(measured);
    }

    pub fn bytes(&self) -> u64 {
        4 * self.words as u64 * (1 + SLOTS as u64) + self.bins.as_ref().map_or(0, wgpu::Buffer::size)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_shader_bins_as_many_depths_as_the_core() {
        let source = include_str!("shaders/depth_samples.wgsl");
        let line = format!("const BINS: u32 = {}u;", shadowlab_core::cascades::DEPTH_BINS);
        assert!(source.contains(&line), "depth_samples.wgsl must declare `{line}`");
        // One workgroup word per bin and side: 256 invocations initialise and flush them.
        assert_eq!(4 * shadowlab_core::cascades::DEPTH_BINS, 256);
    }
}
