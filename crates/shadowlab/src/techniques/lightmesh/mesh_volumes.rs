//! Static casters' shadows on dynamic objects from volumes built on the light mesh (Hasselgren 2003
//! §3.3.1–3.3.2, NOTES-001 §1.8–1.9), drawn by `mesh_volumes.wgsl`:
//! - **Volumes**: a side quad on every edge that belongs to one lit triangle only, extruded away from
//!   the light to infinity. No caps: depth pass needs none (§3.3.2.1).
//! - **Culling** (§3.3.1.2): quads entirely outside the frustum through the focus rectangle are left
//!   out. (Not behind the farthest dynamic point as Hasselgren does: the static pixels of the
//!   rectangle that the light mesh leaves dark take the count too.)
//! - **Robust depth pass** (§3.3.2.2): depth clamping instead of near clipping and a z-pass count
//!   started at the eye's: the lit triangles its segment to the light crosses. Hasselgren counts
//!   parity with the invert stencil, exact because the regions behind distinct lit pieces are
//!   disjoint; real scenes break that where static surfaces overlap (a wall's face running into the
//!   ceiling slab's coplanar side: both lit, their regions overlap), so the volumes are oriented
//!   outwards (the lit piece on the left of each boundary edge seen from the light) and counted:
//!   exact for overlaps too.

use glam::{Vec3, Vec3A, Vec4};
use shadowlab_core::bvh::PreparedRay;
use shadowlab_core::lightmesh::LightMesh;
use shadowlab_core::volumes::LightSource;
use std::collections::HashMap;

use crate::context::{Shared, UNFILTERED, texture_entry, uniform_entry};

/// The stencil target's format (depth unused: the fragment shader tests the G-buffer's depth).
const STENCIL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth24PlusStencil8;
pub(super) const SHADOW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R8Unorm;

/// The light mesh's boundary quads and what the last frame drew of them.
pub(super) struct MeshVolumes {
    /// Boundary edges (world positions).
    edges: Vec<(Vec3, Vec3)>,
    /// The lit triangles, for the eye's count.
    triangles: Vec<[Vec3; 3]>,
    /// The light the mesh was built for: while a rebuild for a moved light runs in the background,
    /// the volumes stay those of the mesh shown, not a mix of old edges and the new light.
    source: LightSource,
    vertices: wgpu::Buffer,
    /// Vertices drawn (6 per kept quad) and the stencil's start value, of the last plan.
    pub drawn: u32,
    pub start: u32,
}

/// The frame's view of the focus: frustum planes (`n·p + d ≥ 0` inside) through the focus
/// rectangle.
pub(super) struct Focus {
    pub planes: Vec<Vec4>,
    pub eye: Vec3,
}

impl MeshVolumes {
    pub fn new(device: &wgpu::Device, mesh: &LightMesh, source: LightSource) -> Self {
        // Undirected edge → uses, and its direction in the (first) triangle using it: the lit
        // triangles face the light counter-clockwise, so a boundary edge has its piece on the left.
        let mut uses: HashMap<(u32, u32), (u32, (u32, u32))> = HashMap::new();
        for t in &mesh.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                uses.entry((a.min(b), a.max(b))).or_insert((0, (a, b))).0 += 1;
            }
        }
        let mut edges: Vec<(Vec3, Vec3)> = uses
            .into_values()
            .filter(|&(n, _)| n == 1)
            .map(|(_, (a, b))| (mesh.positions[a as usize], mesh.positions[b as usize]))
            .collect();
        // A fixed order: equal light meshes give equal draws.
        edges.sort_by(|x, y| {
            x.0.to_array()
                .partial_cmp(&y.0.to_array())
                .unwrap_or(std::cmp::Ordering::Equal)
                .then(x.1.to_array().partial_cmp(&y.1.to_array()).unwrap_or(std::cmp::Ordering::Equal))
        });
        let triangles = (0..mesh.triangle_count()).map(|t| mesh.corners(t)).collect();
        let vertices = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("light mesh volumes"),
            size: (edges.len().max(1) * 6 * 16) as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self { edges, triangles, source, vertices, drawn: 0, start: 0 }
    }

    pub fn bytes(&self) -> u64 {
        self.vertices.size()
    }

    pub fn quads(&self) -> usize {
        self.edges.len()
    }

    /// Culls the quads against `focus`, writes the kept ones and finds the stencil's start.
    pub fn plan(&mut self, queue: &wgpu::Queue, focus: &Focus) {
        let light = self.source;
        let mut out: Vec<[f32; 4]> = Vec::with_capacity(self.edges.len() * 6);
        for &(a, b) in &self.edges {
            let (da, db) = (self.source.extrude(a), self.source.extrude(b));
            // Outside a plane: both ends outside and both extrusions leading further out.
            let outside = focus.planes.iter().any(|p| {
                p.dot(a.extend(1.0)) < 0.0 && p.dot(b.extend(1.0)) < 0.0 && p.dot(da) <= 0.0 && p.dot(db) <= 0.0
            });
            if outside {
                continue;
            }
            // Outward, as `shadowlab_core::volumes::shadow_volume`: (b, a, a∞), (b, a∞, b∞).
            let (a, b) = (a.extend(1.0).to_array(), b.extend(1.0).to_array());
            let (da, db) = (da.to_array(), db.to_array());
            out.extend_from_slice(&[b, a, da, b, da, db]);
        }
        self.drawn = out.len() as u32;
        if !out.is_empty() {
            queue.write_buffer(&self.vertices, 0, bytemuck::cast_slice(&out));
        }
        self.start = self.eye_count(&light, focus.eye);
    }

    /// How many lit regions hold the eye: the lit triangles its segment to the light crosses
    /// (watertight: a ray through a shared edge meets one of the two triangles).
    fn eye_count(&self, light: &LightSource, eye: Vec3) -> u32 {
        let (dir, len) = match *light {
            LightSource::Point(l) => ((l - eye).normalize_or_zero(), eye.distance(l)),
            LightSource::Directional(d) => (-d.normalize_or_zero(), f32::INFINITY),
        };
        if dir == Vec3::ZERO {
            return 0;
        }
        let ray = PreparedRay::new(eye, dir, 0.0, len);
        let hits = self.triangles.iter().filter(|t| ray.intersect(&t.map(Vec3A::from)).is_some()).count();
        hits.min(255) as u32
    }

    /// Counts the kept quads into a stencil of its own, then marks the pixels with a count in
    /// `shadow` (R8: 1 in the static shadow), within `scissor`. With `fill`, also counts every quad
    /// fragment into it (the fill view).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        shared: &Shared,
        encoder: &mut wgpu::CommandEncoder,
        group: &wgpu::BindGroup,
        stencil: &wgpu::TextureView,
        shadow: &wgpu::TextureView,
        scissor: [u32; 4],
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
        fill: Option<&wgpu::BindGroup>,
    ) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("light mesh volumes"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: shadow,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: stencil,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Discard }),
                stencil_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(self.start),
                    store: wgpu::StoreOp::Discard,
                }),
            }),
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        let [x, y, w, h] = scissor;
        if w == 0 || h == 0 {
            return;
        }
        pass.set_scissor_rect(x, y, w, h);
        pass.set_bind_group(0, Some(group), &[]);
        if self.drawn > 0 {
            pass.set_pipeline(&pipeline(shared, Draw::Quads));
            pass.set_vertex_buffer(0, self.vertices.slice(..u64::from(self.drawn) * 16));
            pass.draw(0..self.drawn, 0..1);
            if let Some(fill) = fill {
                pass.set_pipeline(&pipeline(shared, Draw::Fill));
                pass.set_bind_group(1, Some(fill), &[]);
                pass.draw(0..self.drawn, 0..1);
            }
        }
        pass.set_pipeline(&pipeline(shared, Draw::Mask));
        pass.set_stencil_reference(0);
        pass.draw(0..3, 0..1);
    }
}

pub(super) fn fill_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("light mesh volumes fill", || {
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("light mesh volumes fill"),
            entries: &[crate::context::storage_entry(0, wgpu::ShaderStages::FRAGMENT, false)],
        })
    })
}

/// What a pipeline draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Draw {
    /// The quads into the stencil.
    Quads,
    /// The quads into the fill counters (stencil untouched).
    Fill,
    /// The full-screen mask where the count is not 0.
    Mask,
}

pub(super) fn layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("light mesh volumes", || {
        let vf = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("light mesh volumes"),
            entries: &[
                uniform_entry(0, vf),
                texture_entry(1, wgpu::ShaderStages::FRAGMENT, UNFILTERED, wgpu::TextureViewDimension::D2),
            ],
        })
    })
}

/// The quads' pipeline (z-pass: front faces +1, back faces −1, where the shader's depth test
/// passes) or the mask's (writes 1 where the count is not 0).
fn pipeline(shared: &Shared, draw: Draw) -> wgpu::RenderPipeline {
    let key = format!("light mesh volumes {draw:?}");
    shared.render_pipeline(&key, || {
        let mask = draw == Draw::Mask;
        let device = &shared.gpu.device;
        let module = crate::shader::module(device, "light mesh volumes", include_str!("mesh_volumes.wgsl"));
        let fill_layout = fill_layout(shared);
        let main_layout = layout(shared);
        let layouts: Vec<Option<&wgpu::BindGroupLayout>> =
            if draw == Draw::Fill { vec![Some(&main_layout), Some(&fill_layout)] } else { vec![Some(&main_layout)] };
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(&key),
            bind_group_layouts: &layouts,
            immediate_size: 0,
        });
        let keep = wgpu::StencilOperation::Keep;
        let face = |compare, pass_op| wgpu::StencilFaceState { compare, fail_op: keep, depth_fail_op: keep, pass_op };
        let (front, back) = if mask {
            let f = face(wgpu::CompareFunction::NotEqual, keep);
            (f, f)
        } else if draw == Draw::Fill {
            let f = face(wgpu::CompareFunction::Always, keep);
            (f, f)
        } else {
            (
                face(wgpu::CompareFunction::Always, wgpu::StencilOperation::IncrementWrap),
                face(wgpu::CompareFunction::Always, wgpu::StencilOperation::DecrementWrap),
            )
        };
        let vertex_buffers = [Some(wgpu::VertexBufferLayout {
            array_stride: 16,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x4],
        })];
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(&key),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some(if mask { "mask_vs" } else { "quad_vs" }),
                compilation_options: Default::default(),
                buffers: if mask { &[] } else { &vertex_buffers },
            },
            primitive: wgpu::PrimitiveState {
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: None,
                // Depth clamping instead of near clipping (§3.3.2.2).
                unclipped_depth: !mask,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: STENCIL_FORMAT,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: wgpu::StencilState {
                    front,
                    back,
                    read_mask: 0xff,
                    write_mask: if draw == Draw::Quads { 0xff } else { 0 },
                },
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some(match draw {
                    Draw::Quads => "quad_fs",
                    Draw::Fill => "fill_fs",
                    Draw::Mask => "mask_fs",
                }),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: SHADOW_FORMAT,
                    blend: None,
                    write_mask: if mask { wgpu::ColorWrites::RED } else { wgpu::ColorWrites::empty() },
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    })
}

/// The stencil target for a surface of `size`.
pub(super) fn stencil_target(device: &wgpu::Device, size: (u32, u32)) -> wgpu::TextureView {
    crate::util::texture_2d(
        device,
        "light mesh volumes stencil",
        STENCIL_FORMAT,
        size,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    )
    .create_view(&Default::default())
}
