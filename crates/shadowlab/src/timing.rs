//! GPU time per pass from timestamp queries, grouped into the passes of DESIGN.md §6: G-buffer,
//! shadow (maps, volumes), visibility (resolves) and lighting.

/// The categories GPU time is reported in (`metrics.json`: `gpu_ms.passes`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PassKind {
    Gbuffer,
    Shadow,
    Visibility,
    Lighting,
}

impl PassKind {
    pub const ALL: [PassKind; 4] = [Self::Gbuffer, Self::Shadow, Self::Visibility, Self::Lighting];

    pub fn name(self) -> &'static str {
        match self {
            Self::Gbuffer => "gbuffer",
            Self::Shadow => "shadow",
            Self::Visibility => "visibility",
            Self::Lighting => "lighting",
        }
    }
}

/// Milliseconds per category for one frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FrameTimes {
    pub gbuffer: f64,
    pub shadow: f64,
    pub visibility: f64,
    pub lighting: f64,
}

impl FrameTimes {
    pub fn get(&self, kind: PassKind) -> f64 {
        match kind {
            PassKind::Gbuffer => self.gbuffer,
            PassKind::Shadow => self.shadow,
            PassKind::Visibility => self.visibility,
            PassKind::Lighting => self.lighting,
        }
    }

    #[cfg(not(target_arch = "wasm32"))]
    fn add(&mut self, kind: PassKind, ms: f64) {
        match kind {
            PassKind::Gbuffer => self.gbuffer += ms,
            PassKind::Shadow => self.shadow += ms,
            PassKind::Visibility => self.visibility += ms,
            PassKind::Lighting => self.lighting += ms,
        }
    }

    pub fn total(&self) -> f64 {
        self.gbuffer + self.shadow + self.visibility + self.lighting
    }
}

/// Queries per query set (wgpu's maximum is 4096).
const SET_SIZE: u32 = 4096;

/// Hands out timestamp writes to passes and adds up their durations per [`PassKind`].
pub struct GpuTimer {
    enabled: bool,
    sets: Vec<wgpu::QuerySet>,
    /// The kind of each pass, in query order (pass k uses queries 2k and 2k + 1).
    passes: Vec<PassKind>,
    #[cfg_attr(target_arch = "wasm32", allow(dead_code))]
    period_ns: f64,
}

impl GpuTimer {
    pub fn new(gpu: &crate::gpu::Gpu) -> Self {
        Self {
            // Timestamps are read back by blocking (`read`): native only.
            enabled: gpu.timestamps && cfg!(not(target_arch = "wasm32")),
            sets: Vec::new(),
            passes: Vec::new(),
            period_ns: f64::from(gpu.queue.get_timestamp_period()),
        }
    }

    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Starts a new frame: forgets the previous passes (query sets are reused).
    pub fn begin_frame(&mut self) {
        self.passes.clear();
    }

    fn next(&mut self, device: &wgpu::Device, kind: PassKind) -> Option<(&wgpu::QuerySet, u32)> {
        if !self.enabled {
            return None;
        }
        let pass = self.passes.len() as u32;
        self.passes.push(kind);
        let (set, local) = ((2 * pass / SET_SIZE) as usize, 2 * pass % SET_SIZE);
        while self.sets.len() <= set {
            self.sets.push(device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: SET_SIZE,
            }));
        }
        Some((&self.sets[set], local))
    }

    pub fn render_pass(
        &mut self,
        device: &wgpu::Device,
        kind: PassKind,
    ) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        self.next(device, kind).map(|(query_set, i)| wgpu::RenderPassTimestampWrites {
            query_set,
            beginning_of_pass_write_index: Some(i),
            end_of_pass_write_index: Some(i + 1),
        })
    }

    pub fn compute_pass(
        &mut self,
        device: &wgpu::Device,
        kind: PassKind,
    ) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        self.next(device, kind).map(|(query_set, i)| wgpu::ComputePassTimestampWrites {
            query_set,
            beginning_of_pass_write_index: Some(i),
            end_of_pass_write_index: Some(i + 1),
        })
    }

    /// Resolves this frame's queries (after its last pass) and reads them back (blocking).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn read(&mut self, gpu: &crate::gpu::Gpu) -> Result<Option<FrameTimes>, crate::gpu::GpuError> {
        if !self.enabled || self.passes.is_empty() {
            return Ok(None);
        }
        let queries = 2 * self.passes.len() as u32;
        let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps"),
            size: u64::from(queries) * 8,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        for (s, set) in self.sets.iter().enumerate() {
            let start = s as u32 * SET_SIZE;
            if start >= queries {
                break;
            }
            let count = (queries - start).min(SET_SIZE);
            encoder.resolve_query_set(set, 0..count, &buffer, u64::from(start) * 8);
        }
        gpu.queue.submit([encoder.finish()]);
        let raw = crate::util::read_buffer(&gpu.device, &gpu.queue, &buffer)?;
        let ticks: Vec<u64> = raw.chunks_exact(8).map(|c| u64::from_le_bytes(c.try_into().expect("8 bytes"))).collect();
        let mut times = FrameTimes::default();
        for (k, kind) in self.passes.iter().enumerate() {
            let (a, b) = (ticks[2 * k], ticks[2 * k + 1]);
            times.add(*kind, b.saturating_sub(a) as f64 * self.period_ns * 1e-6);
        }
        Ok(Some(times))
    }
}
