//! The visible depth range from a GPU min/max reduction of the depth buffer, read back without
//! stalling: each frame's result is copied to a staging buffer and read when it is ready, so a
//! technique uses the range of an earlier frame (usually the previous one). The automatic near
//! plane of Stingl 2011, §4.3 (there read back with a stall, which halved the frame rate).

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use crate::context::Shared;
use crate::frame::SurfaceInputs;
use crate::timing::{GpuTimer, PassKind};

const SLOTS: usize = 3;
const EMPTY: [u32; 2] = [0x7f7f_ffff, 0];

#[derive(Debug)]
enum Slot {
    Idle,
    /// Holds the range of this frame, not yet mapped.
    Written(u64),
    /// Being mapped: 0 pending, 1 done, 2 failed.
    Mapping(u64, Arc<AtomicU8>),
}

/// The reduction, its staging ring and the latest range read back.
pub struct DepthRange {
    pipeline: wgpu::ComputePipeline,
    range: wgpu::Buffer,
    staging: Vec<wgpu::Buffer>,
    slots: Vec<Slot>,
    /// `(near, far, frame measured)`.
    latest: Option<(f32, f32, u64)>,
}

impl DepthRange {
    pub fn new(shared: &Shared) -> Self {
        let device = &shared.gpu.device;
        let pipeline = shared.compute_pipeline("depth range", || {
            let module = crate::shader::module(device, "depth range", include_str!("shaders/depth_range.wgsl"));
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("depth range"),
                layout: None,
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            })
        });
        let range = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("depth range"),
            size: 8,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let staging = (0..SLOTS)
            .map(|_| {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("depth range staging"),
                    size: 8,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })
            .collect();
        Self { pipeline, range, staging, slots: (0..SLOTS).map(|_| Slot::Idle).collect(), latest: None }
    }

    /// Collects finished readbacks (never waits): asks to map what the GPU has written, lets wgpu
    /// deliver what is ready, and keeps the newest range.
    pub fn poll(&mut self, device: &wgpu::Device) {
        for (i, slot) in self.slots.iter_mut().enumerate() {
            if let Slot::Written(frame) = *slot {
                let flag = Arc::new(AtomicU8::new(0));
                let f = flag.clone();
                self.staging[i].map_async(wgpu::MapMode::Read, .., move |r| {
                    f.store(if r.is_ok() { 1 } else { 2 }, Ordering::Release)
                });
                *slot = Slot::Mapping(frame, flag);
            }
        }
        let _ = device.poll(wgpu::PollType::Poll);
        for (i, slot) in self.slots.iter_mut().enumerate() {
            let Slot::Mapping(frame, flag) = slot else { continue };
            match flag.load(Ordering::Acquire) {
                1 => {
                    if let Ok(view) = self.staging[i].get_mapped_range(..) {
                        let words: Vec<u32> =
                            view.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
                        drop(view);
                        let (lo, hi) = (f32::from_bits(words[0]), f32::from_bits(words[1]));
                        if lo <= hi && lo.is_finite() && self.latest.is_none_or(|(_, _, f)| f < *frame) {
                            self.latest = Some((lo, hi, *frame));
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

    /// Reduces this frame's depth and queues its readback (skipped when every slot is busy).
    pub fn record(
        &mut self,
        shared: &Shared,
        encoder: &mut wgpu::CommandEncoder,
        surface: &SurfaceInputs,
        timer: &mut GpuTimer,
        frame: u64,
    ) {
        let Some(slot) = self.slots.iter().position(|s| matches!(s, Slot::Idle)) else { return };
        let device = &shared.gpu.device;
        shared.gpu.queue.write_buffer(&self.range, 0, bytemuck::cast_slice(&EMPTY));
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("depth range"),
            layout: &self.pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: surface.camera_buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&surface.depth) },
                wgpu::BindGroupEntry { binding: 2, resource: self.range.as_entire_binding() },
            ],
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
        encoder.copy_buffer_to_buffer(&self.range, 0, &self.staging[slot], 0, 8);
        self.slots[slot] = Slot::Written(frame);
    }

    /// The latest range read back and the frame it was measured in.
    pub fn latest(&self) -> Option<((f32, f32), u64)> {
        self.latest.map(|(lo, hi, f)| ((lo, hi), f))
    }

    pub fn bytes(&self) -> u64 {
        8 * (1 + SLOTS as u64)
    }
}
