//! What shadow volumes need of the scene on the GPU: every mesh's welded topology (faces, edges and
//! the faces around each edge, from [`shadowlab_core::Topology`]) and the shadow casters. The
//! topology is shared by every light (a [`Shared::resource`]); casters are listed per scene change.

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use glam::{Affine3A, Mat4, Vec3, Vec4};
use shadowlab_core::{Scene, Topology};

use crate::context::{Shared, storage_entry};
use crate::live::{InstanceId, LiveScene};

/// One mesh's place in the shared topology buffers.
#[derive(Debug, Clone, Copy)]
pub(super) struct MeshRanges {
    pub first_face: u32,
    pub faces: u32,
    pub first_edge: u32,
    pub edges: u32,
    /// The most side quads the mesh can extrude for one light position, one-sided and two-sided:
    /// over its edges, the largest |net| of the signs around each (one-sided faces sign 0 or 1, so
    /// at most the larger of the edge's forward and backward uses; two-sided ones ±1, so at most
    /// its uses). A closed one-sided mesh extrudes at most one quad per edge.
    pub quads: [u32; 2],
    /// Whether the mesh is closed ([`Topology::report`] walks every edge: a caster list, made
    /// again at every drag step, reads it here), and the box around all its positions.
    pub closed: bool,
    pub bounds: shadowlab_core::Aabb,
}

/// The welded topology of every mesh of the scene, on the GPU and on the CPU (the CPU copy counts
/// the volumes around the eye for the robust depth pass).
pub(super) struct VolumeTopology {
    pub meshes: Vec<MeshRanges>,
    pub topologies: Vec<Topology>,
    pub group: wgpu::BindGroup,
    pub bytes: u64,
}

pub(super) fn topology_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("volumes topology", || {
        let c = wgpu::ShaderStages::COMPUTE;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("volumes topology"),
            entries: &[
                storage_entry(0, c, true),
                storage_entry(1, c, true),
                storage_entry(2, c, true),
                storage_entry(3, c, true),
            ],
        })
    })
}

/// A storage buffer of at least 16 bytes (wgpu does not bind empty buffers).
fn buffer(device: &wgpu::Device, label: &str, mut bytes: Vec<u8>) -> wgpu::Buffer {
    bytes.resize(bytes.len().max(16), 0);
    crate::util::storage_buffer(device, label, &bytes)
}

impl VolumeTopology {
    /// The scene's topology, built once per [`Shared`] and shared by every light.
    pub fn shared(shared: &Shared, scene: &Scene) -> Arc<Self> {
        shared.resource("volumes topology", || Self::new(shared, scene))
    }

    fn new(shared: &Shared, scene: &Scene) -> Self {
        let mut positions: Vec<Vec4> = Vec::new();
        let mut triangles: Vec<[u32; 4]> = Vec::new();
        let mut edges: Vec<[u32; 4]> = Vec::new();
        let mut uses: Vec<u32> = Vec::new();
        let mut meshes = Vec::with_capacity(scene.meshes.len());
        let mut topologies = Vec::with_capacity(scene.meshes.len());
        for mesh in &scene.meshes {
            let topo = Topology::build(mesh);
            let base = positions.len() as u32;
            let mut quads = [0u32; 2];
            for e in 0..topo.edges.len() {
                let list = topo.edge_uses(e);
                let forward = list.iter().filter(|u| u.forward).count() as u32;
                quads[0] += forward.max(list.len() as u32 - forward);
                quads[1] += list.len() as u32;
            }
            meshes.push(MeshRanges {
                first_face: triangles.len() as u32,
                faces: topo.triangles.len() as u32,
                first_edge: edges.len() as u32,
                edges: topo.edges.len() as u32,
                quads,
                closed: topo.report().is_closed(),
                bounds: shadowlab_core::Aabb::from_points(mesh.positions.iter().copied()),
            });
            positions.extend(topo.positions.iter().map(|p| p.extend(1.0)));
            triangles.extend(
                topo.triangles
                    .iter()
                    .zip(&topo.degenerate)
                    .map(|(t, &d)| [t[0] + base, t[1] + base, t[2] + base, u32::from(d)]),
            );
            for (e, edge) in topo.edges.iter().enumerate() {
                let list = topo.edge_uses(e);
                edges.push([edge.v[0] + base, edge.v[1] + base, uses.len() as u32, list.len() as u32]);
                uses.extend(list.iter().map(|u| u.face | if u.forward { 1 << 31 } else { 0 }));
            }
            topologies.push(topo);
        }
        let device = &shared.gpu.device;
        let buffers = [
            buffer(device, "volume positions", bytemuck::cast_slice(&positions).to_vec()),
            buffer(device, "volume faces", bytemuck::cast_slice(&triangles).to_vec()),
            buffer(device, "volume edges", bytemuck::cast_slice(&edges).to_vec()),
            buffer(device, "volume edge uses", bytemuck::cast_slice(&uses).to_vec()),
        ];
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("volumes topology"),
            layout: &topology_layout(shared),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: buffers[0].as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: buffers[1].as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: buffers[2].as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: buffers[3].as_entire_binding() },
            ],
        });
        let bytes = buffers.iter().map(wgpu::Buffer::size).sum();
        Self { meshes, topologies, group, bytes }
    }
}

/// A shadow caster: an instance with `casts_shadows`.
#[derive(Debug, Clone)]
pub(super) struct Caster {
    /// The instance's stable id and transform version (what its cached volumes record).
    pub id: InstanceId,
    pub version: u64,
    pub mesh: usize,
    pub transform: Affine3A,
    /// Open meshes and double-sided materials occlude with both faces.
    pub two_sided: bool,
    /// An open mesh with a single-sided material: the G-buffer culls its back faces, so the eye
    /// may look through one into the face's own shadow, entering the volume through its light
    /// cap, which counting in front of the surface (z-pass, ZP+) must then draw.
    pub see_through: bool,
    pub mirrored: bool,
    /// A world-space bounding sphere and box.
    pub centre: Vec3,
    pub radius: f32,
    pub bounds: shadowlab_core::Aabb,
    pub mobility: shadowlab_core::Mobility,
}

impl Caster {
    /// Every permanent caster (temporary, dragged objects have a pass of their own).
    pub fn all(live: &LiveScene, topology: &VolumeTopology) -> Vec<Caster> {
        let scene = live.scene();
        scene
            .instances
            .iter()
            .zip(live.instances())
            .filter(|(i, _)| i.casts_shadows && i.mobility != shadowlab_core::Mobility::Temporary)
            .filter(|(i, _)| topology.meshes[i.mesh.index()].faces > 0)
            .map(|(i, state)| {
                let ranges = &topology.meshes[i.mesh.index()];
                let closed = ranges.closed;
                let corners = ranges.bounds.corners().map(|c| i.transform.transform_point3(c));
                let bounds = shadowlab_core::Aabb::from_points(corners);
                let centre = bounds.center();
                let radius = corners.iter().map(|c| c.distance(centre)).fold(0.0, f32::max) * 1.0001 + 1e-6;
                Caster {
                    id: state.id,
                    version: state.version,
                    mesh: i.mesh.index(),
                    transform: i.transform,
                    two_sided: !closed || scene.material(i.material).double_sided,
                    see_through: !closed && !scene.material(i.material).double_sided,
                    mirrored: i.transform.matrix3.determinant() < 0.0,
                    centre,
                    radius,
                    bounds,
                    mobility: i.mobility,
                }
            })
            .collect()
    }

    /// Whether a point light `source` lies inside this (closed) caster.
    pub fn encloses(&self, topology: &VolumeTopology, source: &shadowlab_core::volumes::LightSource) -> bool {
        let shadowlab_core::volumes::LightSource::Point(l) = *source else { return false };
        if !self.bounds.contains(l) {
            return false;
        }
        let topo = &topology.topologies[self.mesh];
        let world: Vec<Vec3> = topo.positions.iter().map(|&p| self.transform.transform_point3(p)).collect();
        shadowlab_core::volumes::encloses_light(topo, &world, source)
    }

    /// `CASTER_*` flags of `extract.wgsl`.
    pub fn flags(&self) -> u32 {
        let mut flags = 0;
        if self.two_sided {
            flags |= CASTER_TWO_SIDED;
        }
        if self.mirrored {
            flags |= CASTER_MIRRORED;
        }
        flags
    }
}

pub(super) const CASTER_TWO_SIDED: u32 = 1;
pub(super) const CASTER_MIRRORED: u32 = 2;

/// `struct Job` of `extract.wgsl`: one (light sample, caster) extraction into the caster's region.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(super) struct Job {
    pub model: Mat4,
    /// The light sample: position (w = 1) or direction of travel (w = 0).
    pub light: Vec4,
    /// First face, faces, first edge, edges in the shared topology buffers.
    pub ranges: [u32; 4],
    /// This job's first face and edge work items within its batch, its item (the index of its
    /// counters and draws), its `CASTER_*` flags.
    pub work: [u32; 4],
    /// First vertex of its sides, light caps and dark caps (in the whole vertex buffer).
    pub base: [u32; 4],
    /// Vertices each of those regions holds.
    pub capacity: [u32; 4],
}
