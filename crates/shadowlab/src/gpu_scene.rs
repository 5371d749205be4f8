//! The scene on the GPU: one vertex and one index buffer for all meshes, an instance buffer, and
//! draw groups that batch the instances of a mesh into one instanced draw.

use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Vec4};
use shadowlab_core::{Aabb, Scene, Topology};
use wgpu::util::DeviceExt;

/// Per-vertex data (`@location(0)` position, `@location(1)` normal).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
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
    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3],
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
    /// All groups; those with `casts_shadows` are the shadow casters.
    pub groups: Vec<DrawGroup>,
    pub bounds: Aabb,
    pub caster_bounds: Aabb,
    pub triangles: u64,
    pub bytes: u64,
}

impl GpuScene {
    pub fn new(device: &wgpu::Device, scene: &Scene) -> Self {
        let mut vertices: Vec<Vertex> = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        let mut meshes = Vec::with_capacity(scene.meshes.len());
        let mut closed = Vec::with_capacity(scene.meshes.len());
        for m in &scene.meshes {
            meshes.push(MeshRange {
                base_vertex: vertices.len() as i32,
                first_index: indices.len() as u32,
                index_count: (m.triangles.len() * 3) as u32,
            });
            vertices.extend(
                m.positions
                    .iter()
                    .zip(&m.normals)
                    .map(|(p, n)| Vertex { position: p.to_array(), normal: n.to_array() }),
            );
            indices.extend(m.triangles.iter().flatten());
            closed.push(Topology::build(m).report().is_closed());
        }
        // Order instances so that each (mesh, sidedness, mirror, caster) group is contiguous.
        let key = |i: usize| {
            let inst = &scene.instances[i];
            let double = scene.material(inst.material).double_sided;
            let sided = if double {
                Sidedness::DoubleSided
            } else if closed[inst.mesh.index()] {
                Sidedness::Closed
            } else {
                Sidedness::Open
            };
            (!inst.casts_shadows, inst.mesh.index(), sided, inst.transform.matrix3.determinant() < 0.0)
        };
        let mut order: Vec<usize> = (0..scene.instances.len()).collect();
        order.sort_by_key(|&i| key(i));
        let mut data = Vec::with_capacity(order.len());
        let mut groups: Vec<DrawGroup> = Vec::new();
        for (slot, &i) in order.iter().enumerate() {
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
            let (not_caster, mesh, sidedness, mirrored) = key(i);
            match groups.last_mut() {
                Some(g)
                    if g.mesh == mesh
                        && g.sidedness == sidedness
                        && g.mirrored == mirrored
                        && g.casts_shadows != not_caster =>
                {
                    g.instances.end = slot as u32 + 1;
                }
                _ => groups.push(DrawGroup {
                    mesh,
                    instances: slot as u32..slot as u32 + 1,
                    sidedness,
                    mirrored,
                    casts_shadows: !not_caster,
                }),
            }
        }
        let init = |label: &str, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
        };
        let vb = init("vertices", bytemuck::cast_slice(&vertices), wgpu::BufferUsages::VERTEX);
        let ib = init("indices", bytemuck::cast_slice(&indices), wgpu::BufferUsages::INDEX);
        let instances = init("instances", bytemuck::cast_slice(&data), wgpu::BufferUsages::VERTEX);
        let bytes = vb.size() + ib.size() + instances.size();
        Self {
            vertices: vb,
            indices: ib,
            instances,
            meshes,
            groups,
            bounds: scene.bounds(),
            caster_bounds: scene.caster_bounds(),
            triangles: scene.stats().triangles as u64,
            bytes,
        }
    }

    /// Issues the draws of `groups` (vertex and instance buffers must be bound at slots 0 and 1).
    pub fn draw<'g>(&self, pass: &mut wgpu::RenderPass<'_>, groups: impl Iterator<Item = &'g DrawGroup>) {
        for g in groups {
            let m = self.meshes[g.mesh];
            pass.draw_indexed(m.first_index..m.first_index + m.index_count, m.base_vertex, g.instances.clone());
        }
    }

    /// Binds the vertex, instance and index buffers.
    pub fn bind(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_vertex_buffer(1, self.instances.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
    }
}
