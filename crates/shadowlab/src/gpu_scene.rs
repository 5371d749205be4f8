//! The scene on the GPU: one vertex and one index buffer for all meshes, an instance buffer, and
//! draw groups that batch the instances of a mesh into one instanced draw.
//!
//! Meshes are uploaded once. Instances change: [`GpuScene::sync`] rewrites the instance buffer in
//! place after edits (moves, additions, removals, mobility changes), regrouping the draws, which are
//! split by mobility so that cached static maps draw the static casters only.

use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Vec4};
use shadowlab_core::{Aabb, Mobility, Scene, Topology};
use wgpu::util::DeviceExt;

/// Per-vertex data (`@location(0)` position, `@location(1)` normal, `@location(11)` texture
/// coordinates: zero where the mesh has none).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub uv: [f32; 2],
}

/// Per-instance data (`@location(2..=10)`): model matrix, normal matrix, material.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct InstanceData {
    pub model: [[f32; 4]; 4],
    /// Columns of the inverse transpose of the model's linear part (w unused).
    pub normal: [[f32; 4]; 3],
    /// rgb: albedo; a: Blinn-Phong specular strength.
    pub albedo_specular: [f32; 4],
    /// x: shininess; yzw: emissive.
    pub material: [f32; 4],
}

pub const VERTEX_LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
    array_stride: std::mem::size_of::<Vertex>() as u64,
    step_mode: wgpu::VertexStepMode::Vertex,
    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 11 => Float32x2],
};

pub const INSTANCE_LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
    array_stride: std::mem::size_of::<InstanceData>() as u64,
    step_mode: wgpu::VertexStepMode::Instance,
    attributes: &wgpu::vertex_attr_array![
        2 => Float32x4, 3 => Float32x4, 4 => Float32x4, 5 => Float32x4,
        6 => Float32x4, 7 => Float32x4, 8 => Float32x4,
        9 => Float32x4, 10 => Float32x4
    ],
};

/// How a draw group is culled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Sidedness {
    /// A closed, single-sided mesh: back faces are hidden by front faces.
    Closed,
    /// An open single-sided mesh (a plane, a terrain): seen only from the front, but both faces
    /// matter to a light.
    Open,
    /// A double-sided material: both faces are fronts.
    DoubleSided,
}

/// Instances `instances` (a contiguous range of the instance buffer) all drawing mesh `mesh`.
#[derive(Debug, Clone, PartialEq)]
pub struct DrawGroup {
    pub mesh: usize,
    pub instances: std::ops::Range<u32>,
    pub sidedness: Sidedness,
    /// The transform mirrors (negative determinant): front faces wind clockwise.
    pub mirrored: bool,
    pub casts_shadows: bool,
    pub mobility: Mobility,
    /// The alpha mask its material cuts holes with (index into [`GpuScene::masks`]), if any.
    pub mask: Option<u32>,
    /// Its material's base colour texture (index into [`GpuScene::base_colours`]; 0: none, white).
    pub texture: u32,
}

#[derive(Debug, Clone, Copy)]
pub struct MeshRange {
    pub base_vertex: i32,
    pub first_index: u32,
    pub index_count: u32,
}

pub struct GpuScene {
    pub vertices: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    pub instances: wgpu::Buffer,
    pub meshes: Vec<MeshRange>,
    /// Whether each mesh is closed (culling of its draw group).
    closed: Vec<bool>,
    /// Per mesh, its box in its own space (meshes never change after the upload; the scene's
    /// bounds are taken again after every edit).
    mesh_bounds: Vec<Aabb>,
    /// All groups; those with `casts_shadows` are the shadow casters.
    pub groups: Vec<DrawGroup>,
    /// The instance-buffer slot of each scene instance (by index in `Scene::instances`).
    pub slots: Vec<u32>,
    /// Bounds of every instance but temporary ones (what light views are fitted to).
    pub bounds: Aabb,
    pub caster_bounds: Aabb,
    pub triangles: u64,
    pub bytes: u64,
    /// Instances the instance buffer has room for.
    capacity: usize,
    /// The alpha masks of the scene's alpha-masked materials, `None` when it has none.
    pub masks: Option<AlphaMasks>,
    /// The mask of each material (index in `masks`), `None` for opaque ones.
    material_masks: Vec<Option<u32>>,
    /// Alpha-mask textures that could not be read (their materials keep the factor's alpha), and
    /// base colour textures that could not (white instead).
    pub warnings: Vec<String>,
    /// The G-buffer's base colour textures, one bind group each (`gbuffer.wgsl` group 1); the first
    /// is a white texel, for materials without one.
    pub base_colours: Vec<wgpu::BindGroup>,
    /// The base colour texture of each material (index into `base_colours`).
    material_textures: Vec<u32>,
    /// GPU memory of the base colour textures.
    texture_bytes: u64,
}

/// The draw-group key of an instance: casters first, then by mobility, mesh, culling, winding and
/// alpha mask.
type GroupKey = (bool, Mobility, usize, Sidedness, bool, Option<u32>, u32);

impl GpuScene {
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, scene: &Scene) -> Self {
        let mut vertices: Vec<Vertex> = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        let mut meshes = Vec::with_capacity(scene.meshes.len());
        let mut closed = Vec::with_capacity(scene.meshes.len());
        // WebGL2 (no compute, and no base vertex in indexed draws either): indices hold the
        // offset into the shared vertex buffer themselves, and every draw's base vertex is 0.
        let absolute = !crate::gpu::runs_compute(device);
        for m in &scene.meshes {
            let base = vertices.len() as u32;
            meshes.push(MeshRange {
                base_vertex: if absolute { 0 } else { base as i32 },
                first_index: indices.len() as u32,
                index_count: (m.triangles.len() * 3) as u32,
            });
            let uv = |k: usize| m.uvs.as_ref().and_then(|uvs| uvs.get(k)).map_or([0.0; 2], |t| t.to_array());
            vertices.extend(m.positions.iter().zip(&m.normals).enumerate().map(|(k, (p, n))| Vertex {
                position: p.to_array(),
                normal: n.to_array(),
                uv: uv(k),
            }));
            let offset = if absolute { base } else { 0 };
            indices.extend(m.triangles.iter().flatten().map(|&i| i + offset));
            closed.push(Topology::build(m).report().is_closed());
        }
        let init = |label: &str, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
        };
        let vb = init("vertices", bytemuck::cast_slice(&vertices), wgpu::BufferUsages::VERTEX);
        let ib = init("indices", bytemuck::cast_slice(&indices), wgpu::BufferUsages::INDEX);
        let capacity = scene.instances.len().max(1);
        let instances = instance_buffer(device, capacity);
        let mut gpu_scene = Self {
            vertices: vb,
            indices: ib,
            instances,
            meshes,
            closed,
            mesh_bounds: scene.meshes.iter().map(|m| m.bounds()).collect(),
            groups: Vec::new(),
            slots: Vec::new(),
            bounds: Aabb::EMPTY,
            caster_bounds: Aabb::EMPTY,
            triangles: 0,
            bytes: 0,
            capacity,
            masks: None,
            material_masks: Vec::new(),
            warnings: Vec::new(),
            base_colours: Vec::new(),
            material_textures: Vec::new(),
            texture_bytes: 0,
        };
        gpu_scene.upload_masks(device, queue, scene);
        gpu_scene.upload_base_colours(device, queue, scene);
        let (data, groups, slots) = gpu_scene.layout(scene);
        gpu_scene.slots = slots;
        // Written at creation (mapped), so that the first frame needs no queue write.
        gpu_scene.instances = init(
            "instances",
            bytemuck::cast_slice(&padded(data, capacity)),
            wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
        );
        gpu_scene.groups = groups;
        gpu_scene.refresh_counts(scene);
        gpu_scene
    }

    /// Brings the instance buffer and draw groups up to date with `scene` (after edits): the buffer
    /// is rewritten in place (reallocated only when the instances outgrow it); meshes stay.
    pub fn sync(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, scene: &Scene) {
        let (data, groups, slots) = self.layout(scene);
        self.slots = slots;
        if data.len() > self.capacity {
            self.capacity = data.len().next_power_of_two();
            self.instances = instance_buffer(device, self.capacity);
        }
        if !data.is_empty() {
            queue.write_buffer(&self.instances, 0, bytemuck::cast_slice(&data));
        }
        self.groups = groups;
        self.refresh_counts(scene);
    }

    fn refresh_counts(&mut self, scene: &Scene) {
        let permanent = |i: &shadowlab_core::Instance| i.mobility != Mobility::Temporary;
        let (mut all, mut casters) = (Aabb::EMPTY, Aabb::EMPTY);
        for i in scene.instances.iter().filter(|i| permanent(i)) {
            let b = self.mesh_bounds.get(i.mesh.index()).map_or(Aabb::EMPTY, |b| b.transformed(&i.transform));
            all = all.union(&b);
            if i.casts_shadows {
                casters = casters.union(&b);
            }
        }
        self.bounds = all;
        self.caster_bounds = casters;
        self.triangles = scene.stats().triangles as u64;
        self.bytes = self.vertices.size()
            + self.indices.size()
            + self.instances.size()
            + self.masks.as_ref().map_or(0, |m| m.bytes)
            + self.texture_bytes;
    }

    fn key(&self, scene: &Scene, i: usize) -> GroupKey {
        let inst = &scene.instances[i];
        let double = scene.material(inst.material).double_sided;
        let sided = if double {
            Sidedness::DoubleSided
        } else if self.closed[inst.mesh.index()] {
            Sidedness::Closed
        } else {
            Sidedness::Open
        };
        let mask = self.material_masks.get(inst.material.index()).copied().flatten();
        let texture = self.material_textures.get(inst.material.index()).copied().unwrap_or(0);
        let mirrored = inst.transform.matrix3.determinant() < 0.0;
        (!inst.casts_shadows, inst.mobility, inst.mesh.index(), sided, mirrored, mask, texture)
    }

    /// Decodes and uploads the materials' base colour textures (sRGB), one per distinct reference.
    fn upload_base_colours(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, scene: &Scene) {
        let white = shadowlab_core::texture::Rgba8 { width: 1, height: 1, texels: vec![[255; 4]] };
        self.base_colours = vec![base_colour_group(device, queue, &white)];
        let mut seen: Vec<(&shadowlab_core::TextureRef, u32)> = Vec::new();
        self.material_textures = scene
            .materials
            .iter()
            .map(|m| {
                let Some(texture) = &m.base_color_texture else { return 0 };
                if let Some(&(_, k)) = seen.iter().find(|(t, _)| *t == texture) {
                    return k;
                }
                let largest = device.limits().max_texture_dimension_2d;
                let k = match shadowlab_core::texture::Rgba8::read(texture) {
                    Ok(Some(image)) if image.width.max(image.height) > largest => {
                        self.warnings.push(format!(
                            "material '{}': its {}×{} base colour texture exceeds the GPU's {largest} texels: left white",
                            m.name, image.width, image.height
                        ));
                        0
                    }
                    Ok(Some(image)) => {
                        self.texture_bytes += 4 * u64::from(image.width) * u64::from(image.height);
                        self.base_colours.push(base_colour_group(device, queue, &image));
                        self.base_colours.len() as u32 - 1
                    }
                    Ok(None) => {
                        self.warnings.push(format!("material '{}': a JPEG base colour texture is not read", m.name));
                        0
                    }
                    Err(e) => {
                        self.warnings.push(format!("material '{}': base colour texture ignored: {e}", m.name));
                        0
                    }
                };
                seen.push((texture, k));
                k
            })
            .collect();
    }

    /// Decodes the alpha masks of the scene's alpha-masked materials (`shadowlab_core::alpha`, as
    /// the truth reads them) into one texture array.
    fn upload_masks(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, scene: &Scene) {
        let (mut coverages, mut names) = (Vec::new(), Vec::new());
        self.material_masks = scene
            .materials
            .iter()
            .map(|m| {
                let coverage = match shadowlab_core::alpha::Coverage::of(m)? {
                    Ok(c) => c,
                    Err((c, warning)) => {
                        self.warnings.push(warning);
                        c
                    }
                };
                coverages.push(coverage);
                names.push(m.name.as_str());
                Some(coverages.len() as u32 - 1)
            })
            .collect();
        // A mask past the adapter's texture limits cannot be uploaded: its material is drawn
        // opaque into the maps, and said so (the truth still cuts its holes).
        let limits = device.limits();
        for (c, name) in coverages.iter_mut().zip(&names) {
            if let Some(mask) = &c.mask
                && mask.width.max(mask.height) > limits.max_texture_dimension_2d
            {
                self.warnings.push(format!(
                    "material '{name}': its {}×{} alpha mask exceeds the GPU's {} texels: the maps draw it opaque",
                    mask.width, mask.height, limits.max_texture_dimension_2d
                ));
                c.mask = None;
                c.base_alpha = 1.0;
                c.cutoff = 0.0;
            }
        }
        if coverages.len() as u32 + 1 > limits.max_texture_array_layers {
            self.warnings.push(format!(
                "{} alpha-masked materials exceed the GPU's {} texture layers: the maps draw them opaque",
                coverages.len(),
                limits.max_texture_array_layers
            ));
            self.material_masks.iter_mut().for_each(|m| *m = None);
            return;
        }
        if !coverages.is_empty() {
            self.masks = Some(AlphaMasks::new(device, queue, &coverages));
        }
    }

    /// Instance data in draw order, the groups over it, and each instance's slot.
    fn layout(&self, scene: &Scene) -> (Vec<InstanceData>, Vec<DrawGroup>, Vec<u32>) {
        // Order instances so that each (caster, mobility, mesh, sidedness, mirror) group is contiguous.
        let mut order: Vec<usize> = (0..scene.instances.len()).collect();
        order.sort_by_key(|&i| self.key(scene, i));
        let mut data = Vec::with_capacity(order.len());
        let mut groups: Vec<DrawGroup> = Vec::new();
        let mut slots = vec![0u32; order.len()];
        for (slot, &i) in order.iter().enumerate() {
            slots[i] = slot as u32;
            let inst = &scene.instances[i];
            let mat = scene.material(inst.material);
            let model = glam::Mat4::from(inst.transform);
            let normal = Mat3::from(inst.transform.matrix3).inverse().transpose();
            data.push(InstanceData {
                model: model.to_cols_array_2d(),
                normal: [
                    normal.x_axis.extend(0.0).into(),
                    normal.y_axis.extend(0.0).into(),
                    normal.z_axis.extend(0.0).into(),
                ],
                albedo_specular: mat.base_color.extend(mat.specular).into(),
                material: Vec4::new(mat.shininess, mat.emissive.x, mat.emissive.y, mat.emissive.z).into(),
            });
            let (not_caster, mobility, mesh, sidedness, mirrored, mask, texture) = self.key(scene, i);
            match groups.last_mut() {
                Some(g)
                    if g.mesh == mesh
                        && g.sidedness == sidedness
                        && g.mirrored == mirrored
                        && g.mobility == mobility
                        && g.casts_shadows != not_caster
                        && g.mask == mask
                        && g.texture == texture =>
                {
                    g.instances.end = slot as u32 + 1;
                }
                _ => groups.push(DrawGroup {
                    mesh,
                    instances: slot as u32..slot as u32 + 1,
                    sidedness,
                    mirrored,
                    casts_shadows: !not_caster,
                    mobility,
                    mask,
                    texture,
                }),
            }
        }
        (data, groups, slots)
    }

    /// The caster groups of the given mobilities.
    /// Whether the material at `index` cuts holes in the maps (alpha-masked and uploaded).
    pub fn masked_material(&self, index: usize) -> bool {
        self.material_masks.get(index).copied().flatten().is_some()
    }

    pub fn casters<'g>(&'g self, classes: &'g [Mobility]) -> impl Iterator<Item = &'g DrawGroup> + 'g {
        self.groups.iter().filter(move |g| g.casts_shadows && classes.contains(&g.mobility))
    }

    /// Issues the draws of `groups` (vertex and instance buffers must be bound at slots 0 and 1).
    pub fn draw<'g>(&self, pass: &mut wgpu::RenderPass<'_>, groups: impl Iterator<Item = &'g DrawGroup>) {
        for g in groups {
            let m = self.meshes[g.mesh];
            pass.draw_indexed(m.first_index..m.first_index + m.index_count, m.base_vertex, g.instances.clone());
        }
    }

    /// Issues the draws of `groups`' instances whose slot `keep` marks (a slot past its end is
    /// left out): one draw per run of kept slots. Returns the draws.
    pub fn draw_kept<'g>(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        groups: impl Iterator<Item = &'g DrawGroup>,
        keep: &[bool],
    ) -> u32 {
        let mut draws = 0;
        for g in groups {
            let m = self.meshes[g.mesh];
            let indices = m.first_index..m.first_index + m.index_count;
            let kept = |slot: u32| keep.get(slot as usize).copied().unwrap_or(false);
            let mut slot = g.instances.start;
            while slot < g.instances.end {
                if !kept(slot) {
                    slot += 1;
                    continue;
                }
                let start = slot;
                while slot < g.instances.end && kept(slot) {
                    slot += 1;
                }
                pass.draw_indexed(indices.clone(), m.base_vertex, start..slot);
                draws += 1;
            }
        }
        draws
    }

    /// Binds the vertex, instance and index buffers.
    pub fn bind(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_vertex_buffer(1, self.instances.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
    }
}

fn instance_buffer(device: &wgpu::Device, capacity: usize) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("instances"),
        size: (capacity.max(1) * std::mem::size_of::<InstanceData>()) as u64,
        usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// `data` padded with zeroed instances up to `capacity`.
fn padded(mut data: Vec<InstanceData>, capacity: usize) -> Vec<InstanceData> {
    data.resize(capacity.max(1), InstanceData::zeroed());
    data
}

/// The scene's alpha masks on the GPU (`shaders/alpha_mask.wgsl`): every mask's alpha in one
/// `R8Unorm` texture array (a layer each, padded to the largest), and per mask a uniform block
/// (its size, cutoff and factor alpha) picked by dynamic offset, one bind group for all.
pub struct AlphaMasks {
    pub group: wgpu::BindGroup,
    /// Bytes between two masks' uniform blocks (the dynamic offset of mask k is k × stride).
    pub stride: u32,
    pub bytes: u64,
}

/// `MaskUniform` in `shaders/alpha_mask.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct MaskUniform {
    /// x, y: the mask's texels; z: its layer; w unused.
    size: [u32; 4],
    /// x: cutoff; y: the factor's alpha; z: 1 when the mask has a texture (else alpha 1).
    test: [f32; 4],
}

impl AlphaMasks {
    fn new(device: &wgpu::Device, queue: &wgpu::Queue, coverages: &[shadowlab_core::alpha::Coverage]) -> Self {
        let (w, h) = coverages
            .iter()
            .filter_map(|c| c.mask.as_ref())
            .fold((1, 1), |(w, h), m| (w.max(m.width), h.max(m.height)));
        // Padded as on GL (which takes 1 layer for a 2D texture, 6 for a cube map) whatever the
        // backend: one spare layer at most.
        let layers = crate::shadowmap::padded_layers(coverages.len() as u32, true);
        // Layer k holds mask k's alpha in its top-left corner (the rest never read).
        let mut texels = vec![0u8; (w as usize) * (h as usize) * layers as usize];
        for (k, m) in coverages.iter().enumerate().filter_map(|(k, c)| c.mask.as_ref().map(|m| (k, m))) {
            for (y, row) in m.alpha.chunks(m.width as usize).enumerate() {
                let at = (k * h as usize + y) * w as usize;
                texels[at..at + row.len()].copy_from_slice(row);
            }
        }
        let texture = device.create_texture_with_data(
            queue,
            &wgpu::TextureDescriptor {
                label: Some("alpha masks"),
                size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: layers },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::R8Unorm,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            &texels,
        );
        let stride = device.limits().min_uniform_buffer_offset_alignment.max(std::mem::size_of::<MaskUniform>() as u32);
        let mut uniforms = vec![0u8; (stride as usize) * coverages.len()];
        for (k, c) in coverages.iter().enumerate() {
            let (mw, mh) = c.mask.as_ref().map_or((1, 1), |m| (m.width, m.height));
            let u = MaskUniform {
                size: [mw, mh, k as u32, 0],
                test: [c.cutoff, c.base_alpha, if c.mask.is_some() { 1.0 } else { 0.0 }, 0.0],
            };
            let at = k * stride as usize;
            uniforms[at..at + std::mem::size_of::<MaskUniform>()].copy_from_slice(bytemuck::bytes_of(&u));
        }
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("alpha mask uniforms"),
            contents: &uniforms,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let layout = mask_layout(device);
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("alpha masks"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &buffer,
                        offset: 0,
                        size: std::num::NonZeroU64::new(std::mem::size_of::<MaskUniform>() as u64),
                    }),
                },
            ],
        });
        let bytes = u64::from(w) * u64::from(h) * u64::from(layers) + uniforms.len() as u64;
        Self { group, stride, bytes }
    }
}

/// The bind group layout of [`AlphaMasks`] (`shaders/alpha_mask.wgsl`). Made per device: layouts
/// compare by content, so the pipelines' own copy (`mask_layout` through `Shared`) matches it.
pub fn mask_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("alpha masks"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: std::num::NonZeroU64::new(std::mem::size_of::<MaskUniform>() as u64),
                },
                count: None,
            },
        ],
    })
}

/// A base colour texture's bind group (`gbuffer.wgsl` group 1: the texture, sRGB, and a repeating
/// linear sampler).
fn base_colour_group(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    image: &shadowlab_core::texture::Rgba8,
) -> wgpu::BindGroup {
    let texture = device.create_texture_with_data(
        queue,
        &wgpu::TextureDescriptor {
            label: Some("base colour"),
            size: wgpu::Extent3d { width: image.width, height: image.height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        bytemuck::cast_slice(&image.texels),
    );
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("base colour"),
        address_mode_u: wgpu::AddressMode::Repeat,
        address_mode_v: wgpu::AddressMode::Repeat,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    });
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("base colour"),
        layout: &base_colour_layout(device),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&texture.create_view(&Default::default())),
            },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&sampler) },
        ],
    })
}

/// The layout of [`GpuScene::base_colours`]' groups (`gbuffer.wgsl` group 1).
pub fn base_colour_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("base colour"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
        ],
    })
}
