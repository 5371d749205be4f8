//! The volume store: every caster's extracted shadow volume for every light sample, kept across
//! frames while neither the light nor the caster changed (Toromanoff 2005 §3.2's table; the live
//! cache's [`ItemKind::VolumeObject`]).
//!
//! Each caster holds a **slot**: per light sample, three regions of one vertex buffer (side quads,
//! light caps, dark caps; capacities from the caster's mesh) and their three indirect draws. One
//! (sample, slot) pair is one cached item, keyed `index = sample × max_slots + slot` in this store's
//! set. Extraction is camera-independent and complete (sides, light and dark caps: whatever z-pass,
//! z-fail or ZP+ needs), so the camera only chooses which slots and regions the stencil passes draw.
//! A frame extracts only the items whose signature changed (the light's emitter, the sample and the
//! slot's layout, the caster's transform version), all of them in one set of dispatches (more only
//! where they exceed one storage binding). With caching off every item is extracted every frame.
//!
//! Capacities are bounds from the mesh (per sample: 6 vertices per possible side quad, 3 per face
//! for each cap; a closed one-sided mesh has one possible quad per edge, so about 15 vertices per
//! face), so memory grows with samples × faces: the room's 28 568 caster faces take 7 MB per
//! light sample (a quarter more for casters added later).
//!
//! Slots follow instances, not list positions: a caster keeps its slot while it stays a caster;
//! a removed (or dragged) one frees its slot, whose records are forgotten, and an added one takes a
//! free slot that fits or a new one. When nothing fits, the store is reallocated with a new set id
//! (every item extracted again).

use bytemuck::{Pod, Zeroable};
use shadowlab_core::volumes::LightSource;

use super::geometry::{Caster, Job, VolumeTopology, topology_layout};
use crate::context::{Shared, storage_entry};
use crate::live::validity::hash_values;
use crate::live::{InstanceId, ItemKey, ItemKind, Signature};
use crate::technique::{FrameContext, TechniqueError};
use crate::timing::PassKind;

/// Regions of a slot, per sample: their index in the draws and counters.
pub(super) const SIDES: u64 = 0;
pub(super) const LIGHT_CAPS: u64 = 1;
pub(super) const DARK_CAPS: u64 = 2;

/// `struct Extraction` of `common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct ExtractionUniform {
    /// Jobs, face work items, edge work items of this batch; items in the store.
    counts: [u32; 4],
    /// The batch's first job, and the first vertex of the window of the vertex buffer it binds.
    first: [u32; 4],
}

/// One caster's place in the store.
#[derive(Debug, Clone, Copy)]
struct Slot {
    /// The instance it holds; `None`: free.
    holder: Option<InstanceId>,
    /// The faces it was sized for.
    faces: u32,
    /// First vertex of sample 0's regions; sample `s` starts `s · per_sample` later.
    first: u64,
    /// Vertices of its sides, light caps and dark caps, per sample.
    capacity: [u32; 3],
}

impl Slot {
    fn per_sample(&self) -> u64 {
        self.capacity.iter().map(|&c| u64::from(c)).sum()
    }

    /// First vertex of each region for sample `s`.
    fn base(&self, s: u32) -> [u32; 3] {
        let first = self.first + u64::from(s) * self.per_sample();
        let [a, b, _] = self.capacity.map(u64::from);
        [first, first + a, first + a + b].map(|v| v as u32)
    }
}

/// What the store last checked: when none of it changed, every item is valid without looking.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Checked {
    epoch: u64,
    cache_generation: u64,
    emitter: u64,
}

/// The shape of a store: what its buffers were sized for.
#[derive(Debug, Clone, Copy)]
struct Budget {
    samples: u32,
    /// Point samples (side quads of two triangles, dark caps) or directional ones.
    point: bool,
    slots: u32,
    /// Vertices in the buffer, all samples together.
    vertices: u64,
    /// Vertices one extraction binds at most (a storage binding's limit, aligned for offsets).
    window: u64,
    /// < 1 when the device's buffer limit cut every capacity (refused vertices are counted).
    scale: f64,
}

pub(super) struct Store {
    set: u32,
    budget: Budget,
    slots: Vec<Slot>,
    used_vertices: u64,
    /// The slot of each caster of the current list.
    pub slot_of: Vec<u32>,
    vertices: wgpu::Buffer,
    /// Indirect draws (3 regions × items), then 4 counters per item (`extract.wgsl`).
    pub counters: wgpu::Buffer,
    jobs: wgpu::Buffer,
    /// Face signs one batch of jobs can hold (more faces take more batches).
    signs_faces: u64,
    signs: wgpu::Buffer,
    /// Per batch: its uniform (made as batches are needed).
    batches: Vec<wgpu::Buffer>,
    checked: Option<Checked>,
    /// Whether every item has been extracted once (before, the light shows no volumes), and
    /// whether none is stale now (the budget may leave some for later frames).
    pub complete_once: bool,
    /// The instances whose volumes the last [`Store::extract`] wrote (for any sample).
    pub extracted: Vec<InstanceId>,
    pub current: bool,
    pub bytes: u64,
}

fn extract_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("volumes extract", || {
        let c = wgpu::ShaderStages::COMPUTE;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("volumes extract"),
            entries: &[
                storage_entry(0, c, true),
                storage_entry(1, c, false),
                storage_entry(2, c, false),
                storage_entry(3, c, false),
                crate::context::uniform_entry(4, c),
            ],
        })
    })
}

fn extract_pipeline(shared: &Shared, entry: &str) -> wgpu::ComputePipeline {
    shared.compute_pipeline(&format!("volumes extract {entry}"), || {
        let device = &shared.gpu.device;
        let module = crate::shader::module(device, "volumes extract", include_str!("extract.wgsl"));
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("volumes extract"),
            bind_group_layouts: &[Some(&topology_layout(shared)), Some(&extract_layout(shared))],
            immediate_size: 0,
        });
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("volumes extract"),
            layout: Some(&layout),
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        })
    })
}

/// A caster's regions per sample: sides (6 vertices a quad for a point, 3 for a direction, where
/// a∞ = b∞), light caps and dark caps (none for a direction: they collapse to a point).
fn capacity(c: &Caster, topology: &VolumeTopology, point: bool, scale: f64) -> [u32; 3] {
    let m = &topology.meshes[c.mesh];
    let quads = u64::from(m.quads[usize::from(c.two_sided)]);
    let faces = u64::from(m.faces);
    let want = [quads * if point { 6 } else { 3 }, 3 * faces, if point { 3 * faces } else { 0 }];
    want.map(|v| ((v as f64 * scale) as u64 / 3 * 3).min(u64::from(u32::MAX / 4)) as u32)
}

impl Store {
    /// A store for `casters` with room to spare (a quarter more slots and vertices), its slots
    /// assigned in list order.
    pub fn new(
        ctx: &mut FrameContext<'_>,
        topology: &VolumeTopology,
        casters: &[Caster],
        samples: u32,
        point: bool,
    ) -> Self {
        let device = &ctx.gpu.device;
        let limits = device.limits();
        // Extraction binds the vertex buffer a window at a time (storage bindings are smaller than
        // buffers: 128 MiB and 2 GiB on lavapipe); the stencil passes draw from all of it.
        let align = (u64::from(limits.min_storage_buffer_offset_alignment) / 16).max(1);
        let window = (limits.max_storage_buffer_binding_size.min(limits.max_buffer_size) / 16) / align * align;
        let buffer_limit = (limits.max_buffer_size / 16).min(u64::from(u32::MAX));
        let faces: u64 = casters.iter().map(|c| u64::from(topology.meshes[c.mesh].faces)).sum();
        let vertices_of = |c: &Caster| capacity(c, topology, point, 1.0).iter().map(|&v| u64::from(v)).sum::<u64>();
        let per_sample: u64 = casters.iter().map(vertices_of).sum();
        let largest = casters.iter().map(vertices_of).max().unwrap_or(0).max(1);
        let room = |v: u64| v + v / 4;
        let want = (u64::from(samples) * room(per_sample)).max(3);
        // Beyond the device's buffers, every capacity shrinks alike (refused vertices are counted
        // and reported as `overflow_vertices`).
        let scale = (buffer_limit as f64 / want as f64).min(window as f64 / largest as f64).min(1.0);
        let budget = Budget {
            samples,
            point,
            slots: room(casters.len() as u64) as u32 + 4,
            vertices: ((want as f64 * scale) as u64).max(3),
            window,
            scale,
        };
        let items = u64::from(samples) * u64::from(budget.slots);
        let vertices = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume vertices"),
            size: 16 * budget.vertices,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::VERTEX,
            mapped_at_creation: false,
        });
        let counters = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume draws and counters"),
            size: 64 * items,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::INDIRECT
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let jobs = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume jobs"),
            size: std::mem::size_of::<Job>() as u64 * items,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let signs_faces = (u64::from(samples) * room(faces))
            .min(limits.max_storage_buffer_binding_size.min(limits.max_buffer_size) / 4)
            .max(4);
        let signs = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume face signs"),
            size: 4 * signs_faces,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let bytes = [&vertices, &counters, &jobs, &signs].iter().map(|b| b.size()).sum();
        // Draws of items that were never extracted must draw nothing.
        ctx.encoder.clear_buffer(&counters, 0, None);
        let mut store = Self {
            set: ctx.cache.new_set(),
            budget,
            slots: Vec::new(),
            used_vertices: 0,
            slot_of: Vec::new(),
            vertices,
            counters,
            jobs,
            signs_faces,
            signs,
            batches: Vec::new(),
            checked: None,
            complete_once: false,
            extracted: Vec::new(),
            current: false,
            bytes,
        };
        let placed = store.place(ctx, topology, casters);
        debug_assert!(placed, "a new store holds the casters it was sized for");
        store
    }

    /// Whether the store was made for this many samples of this kind.
    pub fn fits_samples(&self, samples: u32, point: bool) -> bool {
        self.budget.samples == samples && self.budget.point == point
    }

    /// Items (sample × slot pairs) the store holds.
    pub fn items(&self) -> u32 {
        self.budget.samples * self.budget.slots
    }

    /// The item of slot `slot` for sample `s`.
    pub fn item(&self, s: u32, slot: u32) -> u32 {
        s * self.budget.slots + slot
    }

    pub fn vertices(&self) -> &wgpu::Buffer {
        &self.vertices
    }

    /// Byte offset of the indirect draw of `region` of `item` in [`Store::counters`]; the draws of
    /// consecutive items of one region follow each other.
    pub fn draw_offset(&self, region: u64, item: u32) -> u64 {
        16 * (region * u64::from(self.items()) + u64::from(item))
    }

    /// Word index (in [`Store::counters`]) of counter `r` of `item` (3: refused reservations).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn count_word(&self, item: u32, r: u32) -> usize {
        (12 * self.items() + 4 * item + r) as usize
    }

    fn key(&self, ctx: &FrameContext<'_>, item: u32) -> ItemKey {
        ItemKey { light: ctx.light_id, owner: ctx.owner, set: self.set, kind: ItemKind::VolumeObject, index: item }
    }

    /// Forgets the records of slot `slot` (its memory is freed or handed to another caster).
    fn forget_slot(&self, ctx: &mut FrameContext<'_>, slot: u32) {
        for s in 0..self.budget.samples {
            let key = self.key(ctx, self.item(s, slot));
            ctx.cache.forget(&key);
        }
    }

    /// Forgets every record of this store (its memory is about to be freed).
    pub fn forget_all(&self, ctx: &mut FrameContext<'_>) {
        for slot in 0..self.slots.len() as u32 {
            self.forget_slot(ctx, slot);
        }
    }

    /// Gives every caster of the list a slot: the one it holds, a free one that fits, or a new one.
    /// Slots of instances no longer in the list are freed. `false` when they do not all fit (the
    /// store must be replaced).
    pub fn place(&mut self, ctx: &mut FrameContext<'_>, topology: &VolumeTopology, casters: &[Caster]) -> bool {
        let scale = self.budget.scale;
        let point = self.budget.point;
        let wanted = |c: &Caster| (topology.meshes[c.mesh].faces, capacity(c, topology, point, scale));
        let fits = |slot: &Slot, c: &Caster| {
            let (faces, cap) = wanted(c);
            slot.faces >= faces && slot.capacity.iter().zip(cap).all(|(&have, need)| have >= need)
        };
        // Free the slots of instances gone, or that no longer fit their slot.
        for (i, slot) in self.slots.clone().iter().enumerate() {
            let Some(holder) = slot.holder else { continue };
            if !casters.iter().any(|c| c.id == holder && fits(slot, c)) {
                self.forget_slot(ctx, i as u32);
                self.slots[i].holder = None;
            }
        }
        let mut slot_of = Vec::with_capacity(casters.len());
        for c in casters {
            if let Some(i) = self.slots.iter().position(|s| s.holder == Some(c.id)) {
                slot_of.push(i as u32);
                continue;
            }
            // The smallest free slot that fits, else a new one.
            let free = (0..self.slots.len())
                .filter(|&i| self.slots[i].holder.is_none() && fits(&self.slots[i], c))
                .min_by_key(|&i| self.slots[i].per_sample());
            let i = match free {
                Some(i) => i,
                None => {
                    let (faces, capacity) = wanted(c);
                    let slot = Slot { holder: None, faces, first: self.used_vertices, capacity };
                    let vertices = u64::from(self.budget.samples) * slot.per_sample();
                    if self.slots.len() as u32 >= self.budget.slots
                        || self.used_vertices + vertices > self.budget.vertices
                    {
                        return false;
                    }
                    self.used_vertices += vertices;
                    self.slots.push(slot);
                    self.slots.len() - 1
                }
            };
            // A slot handed over keeps no record of its previous holder.
            self.forget_slot(ctx, i as u32);
            self.slots[i].holder = Some(c.id);
            slot_of.push(i as u32);
        }
        self.slot_of = slot_of;
        self.checked = None;
        true
    }

    /// Extracts the volumes of every (sample, caster) whose cached one is stale: all of them with
    /// caching off. Returns how many were extracted.
    pub fn extract(
        &mut self,
        ctx: &mut FrameContext<'_>,
        topology: &VolumeTopology,
        casters: &[Caster],
        sources: &[LightSource],
    ) -> Result<u32, TechniqueError> {
        debug_assert_eq!(sources.len() as u32, self.budget.samples);
        debug_assert_eq!(casters.len(), self.slot_of.len());
        let emitter = ctx.live.light_state(ctx.light_id).map_or(0, |s| s.emitter_version);
        let now = Checked { epoch: ctx.live.epoch(), cache_generation: ctx.cache.generation(), emitter };
        let n_items = (sources.len() * casters.len()) as u32;
        self.extracted.clear();
        if ctx.cache.enabled() && self.checked == Some(now) {
            ctx.cache.work.reused += n_items;
            self.current = true;
            return Ok(0);
        }
        let mut jobs: Vec<Job> = Vec::new();
        let mut deferred = false;
        for (s, source) in sources.iter().enumerate() {
            let light = source.to_vec4();
            for (c, &slot_index) in casters.iter().zip(&self.slot_of) {
                // A one-sided closed caster around the light occludes with every face turned
                // towards it (`shadowlab_core::volumes::encloses_light`).
                let flags = if !c.two_sided && c.encloses(topology, source) {
                    c.flags() | super::geometry::CASTER_TWO_SIDED
                } else {
                    c.flags()
                };
                let slot = self.slots[slot_index as usize];
                let item = self.item(s as u32, slot_index);
                let base = slot.base(s as u32);
                let view = hash_values(&[
                    f64::from(light.x),
                    f64::from(light.y),
                    f64::from(light.z),
                    f64::from(light.w),
                    f64::from(flags),
                    c.mesh as f64,
                    f64::from(base[0]),
                    f64::from(slot.capacity[0]),
                    f64::from(slot.capacity[1]),
                    f64::from(slot.capacity[2]),
                ]);
                let signature = Signature { emitter, view, casters: Vec::new(), object: c.version };
                let key = self.key(ctx, item);
                if ctx.cache.is_valid(&key, &signature) {
                    ctx.cache.work.reused += 1;
                    continue;
                }
                // One object's volumes for one light sample is a unit of the frame's budget (alg. 14).
                let faces = u64::from(topology.meshes[c.mesh].faces);
                if !ctx.take_needed_units(crate::live::scheduler::UnitKind::VolumeObject, faces, 1) {
                    deferred = true;
                    continue;
                }
                let m = &topology.meshes[c.mesh];
                jobs.push(Job {
                    model: glam::Mat4::from(c.transform),
                    light,
                    ranges: [m.first_face, m.faces, m.first_edge, m.edges],
                    // The work items are numbered by `dispatch`.
                    work: [0, 0, item, flags],
                    base: [base[0], base[1], base[2], 0],
                    capacity: [slot.capacity[0], slot.capacity[1], slot.capacity[2], 0],
                });
                ctx.cache.commit(key, signature);
                ctx.cache.work.volume_objects += 1;
                if !self.extracted.contains(&c.id) {
                    self.extracted.push(c.id);
                }
            }
        }
        // With items left for later frames, look again next frame.
        self.checked = (!deferred).then_some(Checked { cache_generation: ctx.cache.generation(), ..now });
        self.current = !deferred;
        self.complete_once |= !deferred;
        if jobs.is_empty() {
            return Ok(0);
        }
        self.dispatch(ctx, topology, &mut jobs)?;
        Ok(jobs.len() as u32)
    }

    /// Records the extraction of `jobs`, in batches whose face signs fit the signs buffer and whose
    /// regions fit one window of the vertex buffer.
    fn dispatch(
        &mut self,
        ctx: &mut FrameContext<'_>,
        topology: &VolumeTopology,
        jobs: &mut [Job],
    ) -> Result<(), TechniqueError> {
        let window = self.budget.window;
        let align = (u64::from(ctx.gpu.device.limits().min_storage_buffer_offset_alignment) / 16).max(1);
        jobs.sort_unstable_by_key(|j| j.base[0]);
        // (first job, end, faces, edges, first vertex of the window) per batch; work items number
        // from each batch's start.
        let mut batches: Vec<(usize, usize, u32, u32, u64)> = Vec::new();
        let mut start = 0;
        while start < jobs.len() {
            let from = u64::from(jobs[start].base[0]) / align * align;
            let (mut faces, mut edges, mut end) = (0u32, 0u32, start);
            while end < jobs.len() {
                let j = &jobs[end];
                let last = u64::from(j.base[0]) + j.capacity.iter().map(|&c| u64::from(c)).sum::<u64>();
                if u64::from(faces + j.ranges[1]) > self.signs_faces || last - from > window {
                    break;
                }
                jobs[end].work[0] = faces;
                jobs[end].work[1] = edges;
                faces += jobs[end].ranges[1];
                edges += jobs[end].ranges[3];
                end += 1;
            }
            if end == start {
                return Err(TechniqueError::Failed {
                    id: "volumes".into(),
                    message: format!("a caster of {} faces does not fit the volume buffers", jobs[start].ranges[1]),
                });
            }
            batches.push((start, end, faces, edges, from));
            start = end;
        }
        let shared = ctx.shared;
        let device = &ctx.gpu.device;
        let queue = &ctx.gpu.queue;
        queue.write_buffer(&self.jobs, 0, bytemuck::cast_slice(jobs));
        while self.batches.len() < batches.len() {
            let zero = ExtractionUniform::zeroed();
            self.batches.push(crate::util::uniform_buffer(device, "volume extraction", bytemuck::bytes_of(&zero)));
        }
        let pipelines = ["reset", "faces", "sides", "finish"].map(|e| extract_pipeline(shared, e));
        for (b, &(start, end, faces, edges, from)) in batches.iter().enumerate() {
            let uniform = ExtractionUniform {
                counts: [(end - start) as u32, faces, edges, self.items()],
                first: [start as u32, from as u32, 0, 0],
            };
            queue.write_buffer(&self.batches[b], 0, bytemuck::bytes_of(&uniform));
            let size = window.min(self.budget.vertices - from);
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("volumes extract"),
                layout: &extract_layout(shared),
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: self.jobs.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: self.signs.as_entire_binding() },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &self.vertices,
                            offset: 16 * from,
                            size: std::num::NonZeroU64::new(16 * size),
                        }),
                    },
                    wgpu::BindGroupEntry { binding: 3, resource: self.counters.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 4, resource: self.batches[b].as_entire_binding() },
                ],
            });
            let timestamps = ctx.timer.compute_pass(device, PassKind::Shadow);
            let mut pass = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("volume extraction"),
                timestamp_writes: timestamps,
            });
            pass.set_bind_group(0, Some(&topology.group), &[]);
            pass.set_bind_group(1, Some(&group), &[]);
            for (pipeline, items) in pipelines.iter().zip([end - start, faces as usize, edges as usize, end - start]) {
                let groups = crate::util::groups(items as u32, 64);
                if groups > 0 {
                    pass.set_pipeline(pipeline);
                    let x = groups.min(65535);
                    pass.dispatch_workgroups(x, groups.div_ceil(x), 1);
                }
            }
        }
        Ok(())
    }
}

/// Consecutive slots as (first, count) runs: one multi-draw each.
pub(super) fn runs(slots: impl Iterator<Item = u32>) -> Vec<(u32, u32)> {
    let mut out: Vec<(u32, u32)> = Vec::new();
    for s in slots {
        match out.last_mut() {
            Some((first, count)) if *first + *count == s => *count += 1,
            _ => out.push((s, 1)),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::runs;

    #[test]
    fn runs_join_consecutive_slots() {
        assert_eq!(runs([0, 1, 2, 5, 6, 9].into_iter()), vec![(0, 3), (5, 2), (9, 1)]);
        assert_eq!(runs(std::iter::empty()), vec![]);
    }
}
