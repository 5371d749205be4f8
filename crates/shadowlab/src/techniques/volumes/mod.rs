//! `volumes`: stencil shadow volumes (Crow 1977; Heidmann 1991), exact hard shadows with no
//! resolution to choose and no bias to tune, robust in every camera position.
//!
//! Per light (and per emitter sample, for area lights):
//! 1. **Extraction** (`extract.wgsl`, compute): every caster face decides whether it occludes, every
//!    edge sums the signs of the faces around it and emits |net| side quads extruded to infinity
//!    (w = 0); z-fail and ZP+ also get caps. Silhouettes by counting make open and non-manifold
//!    meshes work (NOTES-001 §1.4, Hasselgren 2003 §2.3); the CPU reference is
//!    [`shadowlab_core::volumes`].
//! 2. **Stencil** (`stencil.wgsl`): the surface's depth is copied into a technique-owned
//!    depth-stencil target (in an infinite reversed depth mapping, so volumes at infinity fit),
//!    then the volumes are counted with two-sided stencil: z-pass, z-fail, or ZP+ (Hornus et al.
//!    2005 as Toromanoff 2005 alg. 10 uses it: the stencil starts at the light's count of the
//!    near-capped volumes through the near plane). `auto` takes z-pass when Toromanoff's skip test
//!    proves the near plane outside every volume, ZP+ otherwise, and z-fail when the light lies in
//!    the near plane, where the ZP+ frustum is flat (its known failure).
//! 3. **Resolve** (`resolve.wgsl`): positive count → shadow (Haines 1994), or odd count with the
//!    invert stencil (Kilgard 2001). Area lights: N samples, averaged like `sampled`.
//!
//! Optimisations of Hasselgren 2003 §3.3: the light's scissor rectangle from its range, culling of
//! casters and of volume polygons against the frustum through it, and the robust depth pass with the
//! invert stencil (`stencil=invert` with z-pass: depth clamping instead of near clipping, the stencil
//! started at the eye's parity; exact where volumes do not overlap).

mod geometry;
mod plan;

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec4};
use shadowlab_core::params::ParamDef;
use shadowlab_core::sampling::{EmitterPoint, EmitterSample, emitter_points};
use shadowlab_core::volumes::{LightSource, VolumeCamera};
use shadowlab_core::{Light, ParamSet, Role};

use self::geometry::{Caster, CasterRecord, VolumeTopology};
use self::plan::{FrameView, Method, Mode, SamplePlan, Settings};
use crate::context::{Shared, storage_entry, uniform_entry};
use crate::frame::VisibilityLayer;
use crate::light_map::LightMap;
use crate::shadowmap::lookup_layout;
use crate::technique::{FrameContext, ShadowTechnique, TechniqueError, TechniqueInfo, TechniqueStats};
use crate::timing::PassKind;

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "volumes",
    summary: "stencil shadow volumes: exact hard shadows; z-pass, z-fail, ZP+ or automatic",
    source: "Hasselgren 2003 §2.3, §3.3; Toromanoff 2005 alg. 2, 10, 11; Hornus et al. 2005 (ZP+)",
    params: crate::map_params!(
        ParamDef::choice(
            "mode",
            "auto",
            &["auto", "zpass", "zfail", "zpplus"],
            "stencil counting: auto picks z-pass when the camera is provably outside every volume, else ZP+ (z-fail when the light is in the near plane)",
        ),
        ParamDef::choice(
            "stencil",
            "count",
            &["count", "invert"],
            "signed counts (incr/decr), or parity (invert; with z-pass: Hasselgren's robust depth pass, exact for non-overlapping volumes)",
        ),
        ParamDef::bool("scissor", true, "scissor to the screen rectangle of the light's range"),
        ParamDef::bool("cull", true, "cull casters and volume polygons against the view frustum and the light's range"),
        ParamDef::int(
            "samples",
            1,
            1,
            1024,
            "emitter samples for area lights (one stencil pass each, averaged); 1 = the centre"
        ),
        ParamDef::bool(
            "crop",
            false,
            "receiver cropping: receivers (role receiver) take a shadow map's visibility (map_size, ...) and leave the stencil",
        ),
    ),
    light_types: super::ALL_LIGHTS,
    create,
};

/// `struct VolumePass` of `common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct PassUniform {
    volume_matrix: Mat4,
    zp_matrix: Mat4,
    zp_origin: Vec4,
    light: Vec4,
    planes: [Vec4; 5],
    counts: [u32; 4],
    options: [u32; 4],
    capacity: [u32; 4],
    base: [u32; 4],
}

/// `struct VolumeSample` of `resolve.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct SampleUniform {
    position: Vec4,
    normal: Vec4,
    index: [u32; 4],
}

const CAPS_NONE: u32 = 0;
const CAPS_ZP_PLUS: u32 = 1;
const CAPS_ZFAIL: u32 = 2;
/// Byte offset of the indirect draw of region `r` in the counters buffer.
fn draw_offset(r: u64) -> u64 {
    16 + 16 * r
}
const SIDES: u64 = 0;
const LIGHT_CAPS: u64 = 1;
const DARK_CAPS: u64 = 2;

struct Volumes {
    params: ParamSet,
    settings: Settings,
    crop: bool,
    samples: Vec<EmitterPoint>,
    state: Option<State>,
    /// The light's emitter version the samples were taken from.
    emitter_version: u64,
    /// The last frame's plans (methods, for the stats).
    plans: Vec<SamplePlan>,
    frames: u64,
    stats: VolumeStats,
}

#[derive(Debug, Clone, Default)]
struct VolumeStats {
    /// Volume fragments rasterised in the first frame, over all samples.
    fill: Option<u64>,
    /// Volume triangles drawn in the first frame, over all samples.
    triangles: Option<u64>,
    /// Vertices refused for lack of room in the first frame (should be 0).
    overflow: u64,
    draws: u32,
}

/// Built on the first frame, when the surface size is known.
struct State {
    topology: Arc<VolumeTopology>,
    casters: Vec<Caster>,
    /// The scene epoch the casters and receivers were taken at.
    epoch: u64,
    /// What the buffers were sized for: more casters or faces need a new state.
    max_casters: usize,
    max_faces: u64,
    caster_bounds: shadowlab_core::Aabb,
    size: (u32, u32),
    depth_stencil_view: wgpu::TextureView,
    mask_view: wgpu::TextureView,
    caster_buffer: wgpu::Buffer,
    vertices: wgpu::Buffer,
    counters: wgpu::Buffer,
    pass_buffer: wgpu::Buffer,
    pass_stride: u64,
    sample_buffer: wgpu::Buffer,
    sample_stride: u64,
    accum: wgpu::Buffer,
    fill: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Whether the readback holds a frame not yet read.
    readback_pending: bool,
    extract_group: wgpu::BindGroup,
    fill_group: wgpu::BindGroup,
    capacity: [u32; 3],
    receivers: Option<Receivers>,
    bytes: u64,
}

/// Receiver cropping (Toromanoff 2005 alg. 12, NOTES-000 §K): the receivers' model matrices, their
/// draws (mesh range, instance), and the shadow map that gives their visibility.
struct Receivers {
    instances: wgpu::Buffer,
    draws: Vec<(crate::gpu_scene::MeshRange, u32)>,
    map: LightMap,
}

impl Receivers {
    /// The permanent receivers' draws and model matrices.
    fn models(ctx: &FrameContext<'_>) -> (Vec<(crate::gpu_scene::MeshRange, u32)>, Vec<Mat4>) {
        let mut models: Vec<Mat4> = Vec::new();
        let mut draws = Vec::new();
        let receivers = ctx.scene.instances.iter().filter(|i| i.role == Some(Role::Receiver));
        for inst in receivers.filter(|i| i.mobility != shadowlab_core::Mobility::Temporary) {
            draws.push((ctx.gpu_scene.meshes[inst.mesh.index()], models.len() as u32));
            models.push(Mat4::from(inst.transform));
        }
        models.resize(models.len().max(1), Mat4::IDENTITY);
        (draws, models)
    }

    fn new(ctx: &FrameContext<'_>, params: &ParamSet) -> Self {
        let (draws, models) = Self::models(ctx);
        let instances = wgpu::util::DeviceExt::create_buffer_init(
            &ctx.gpu.device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("volume receivers"),
                contents: bytemuck::cast_slice(&models),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            },
        );
        let map = LightMap::new(ctx.shared, params, false);
        Self { instances, draws, map }
    }

    /// Takes the receivers as they are now; `false` when there are more than the buffer holds.
    fn refresh(&mut self, ctx: &FrameContext<'_>) -> bool {
        let (draws, models) = Self::models(ctx);
        if (models.len() * std::mem::size_of::<Mat4>()) as u64 > self.instances.size() {
            return false;
        }
        ctx.gpu.queue.write_buffer(&self.instances, 0, bytemuck::cast_slice(&models));
        self.draws = draws;
        true
    }
}

fn create(shared: &Shared, params: &ParamSet, light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let settings = Settings {
        mode: Mode::parse(params.choice("mode")),
        parity: params.choice("stencil") == "invert",
        scissor: params.bool("scissor"),
        cull: params.bool("cull"),
    };
    let clamp = shared.gpu.device.features().contains(wgpu::Features::DEPTH_CLIP_CONTROL);
    if settings.parity && !clamp && settings.mode != Mode::ZFail {
        return Err(TechniqueError::Failed {
            id: INFO.id.into(),
            message: "stencil=invert counts from the eye with depth clamping, which this adapter lacks \
                      (DEPTH_CLIP_CONTROL); use stencil=count"
                .into(),
        });
    }
    let samples = volume_samples(params, light);
    Ok(Box::new(Volumes {
        params: params.clone(),
        settings,
        crop: params.bool("crop"),
        samples,
        state: None,
        emitter_version: 0,
        plans: Vec::new(),
        frames: 0,
        stats: VolumeStats::default(),
    }))
}

fn depth_stencil_format(shared: &Shared) -> wgpu::TextureFormat {
    if shared.gpu.device.features().contains(wgpu::Features::DEPTH32FLOAT_STENCIL8) {
        wgpu::TextureFormat::Depth32FloatStencil8
    } else {
        wgpu::TextureFormat::Depth24PlusStencil8
    }
}

fn dynamic_uniform(binding: u32, visibility: wgpu::ShaderStages, size: u64) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: true,
            min_binding_size: std::num::NonZeroU64::new(size),
        },
        count: None,
    }
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
                dynamic_uniform(4, c, std::mem::size_of::<PassUniform>() as u64),
            ],
        })
    })
}

fn stencil_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("volumes stencil", || {
        let vf = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("volumes stencil"),
            entries: &[
                uniform_entry(0, vf),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                dynamic_uniform(2, vf, std::mem::size_of::<PassUniform>() as u64),
            ],
        })
    })
}

fn fill_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("volumes fill", || {
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("volumes fill"),
            entries: &[storage_entry(0, wgpu::ShaderStages::FRAGMENT, false)],
        })
    })
}

fn sample_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("volumes samples", || {
        let c = wgpu::ShaderStages::COMPUTE;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("volumes samples"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: c,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                storage_entry(1, c, false),
                dynamic_uniform(2, c, std::mem::size_of::<SampleUniform>() as u64),
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
            bind_group_layouts: &[Some(&geometry::topology_layout(shared)), Some(&extract_layout(shared))],
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

/// Which stencil passes a pipeline implements.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Counting {
    /// Count where the depth test passes (in front of the surface).
    Pass,
    /// Count where it fails (behind the surface).
    Fail,
    /// Count every fragment (the ZP+ start pass from the light).
    Always,
    /// Count nothing: the fill statistics.
    Fill,
}

/// A stencil pipeline for volume geometry (`vertex`: `side_vs`, `cap_vs` or `zp_vs`).
/// With `crop`, pixels whose stencil top bit marks a receiver are left alone and counts use the
/// low seven bits.
fn volume_pipeline(
    shared: &Shared,
    vertex: &str,
    counting: Counting,
    parity: bool,
    clamp: bool,
    crop: bool,
) -> wgpu::RenderPipeline {
    let format = depth_stencil_format(shared);
    let key = format!("volumes {vertex} {counting:?} parity={parity} clamp={clamp} crop={crop} {format:?}");
    shared.render_pipeline(&key, || {
        let device = &shared.gpu.device;
        let module = crate::shader::module(device, "volumes stencil", include_str!("stencil.wgsl"));
        let stencil_layout = stencil_layout(shared);
        let fill_layout = fill_layout(shared);
        let layouts: Vec<Option<&wgpu::BindGroupLayout>> = if counting == Counting::Fill {
            vec![Some(&stencil_layout), Some(&fill_layout)]
        } else {
            vec![Some(&stencil_layout)]
        };
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(&key),
            bind_group_layouts: &layouts,
            immediate_size: 0,
        });
        // Outward-facing volumes: a ray entering a volume crosses a front face, leaving it a back
        // face. Z-pass counts +1 in / −1 out in front of the surface; z-fail −1 / +1 behind it.
        let (up, down) = if parity {
            (wgpu::StencilOperation::Invert, wgpu::StencilOperation::Invert)
        } else {
            (wgpu::StencilOperation::IncrementWrap, wgpu::StencilOperation::DecrementWrap)
        };
        let keep = wgpu::StencilOperation::Keep;
        // Cropped: pass only where the receiver bit equals the reference's (0).
        let compare = if crop { wgpu::CompareFunction::Equal } else { wgpu::CompareFunction::Always };
        let face = |pass_op, depth_fail_op| wgpu::StencilFaceState { compare, fail_op: keep, depth_fail_op, pass_op };
        let (front, back) = match counting {
            Counting::Pass => (face(up, keep), face(down, keep)),
            Counting::Fail => (face(keep, down), face(keep, up)),
            Counting::Always => (face(up, keep), face(up, keep)),
            Counting::Fill => (face(keep, keep), face(keep, keep)),
        };
        let depth_compare = match counting {
            // Reversed depth: nearer is greater.
            Counting::Pass | Counting::Fail => wgpu::CompareFunction::Greater,
            Counting::Always | Counting::Fill => wgpu::CompareFunction::Always,
        };
        let fragment = (counting == Counting::Fill).then(|| wgpu::FragmentState {
            module: &module,
            entry_point: Some("fill_fs"),
            compilation_options: Default::default(),
            targets: &[],
        });
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(&key),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some(vertex),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: 16,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x4],
                })],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: None,
                unclipped_depth: clamp,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format,
                depth_write_enabled: Some(false),
                depth_compare: Some(depth_compare),
                stencil: wgpu::StencilState {
                    front,
                    back,
                    read_mask: if crop { 0x80 } else { 0xff },
                    write_mask: match (counting, crop) {
                        (Counting::Fill, _) => 0,
                        (_, true) => 0x7f,
                        (_, false) => 0xff,
                    },
                },
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment,
            multiview_mask: None,
            cache: None,
        })
    })
}

/// The pipeline that converts the surface depth into the volumes' depth mapping.
fn copy_pipeline(shared: &Shared) -> wgpu::RenderPipeline {
    let format = depth_stencil_format(shared);
    shared.render_pipeline(&format!("volumes depth copy {format:?}"), || {
        let device = &shared.gpu.device;
        let module = crate::shader::module(device, "volumes stencil", include_str!("stencil.wgsl"));
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("volumes depth copy"),
            bind_group_layouts: &[Some(&stencil_layout(shared))],
            immediate_size: 0,
        });
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("volumes depth copy"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("copy_vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("copy_fs"),
                compilation_options: Default::default(),
                targets: &[],
            }),
            multiview_mask: None,
            cache: None,
        })
    })
}

const MASK_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R8Unorm;

/// A stencil-tested full-screen draw that writes `value` into the shadow mask where
/// `reference & read_mask` compares with `stencil & read_mask`. The resolve reads the mask, not the
/// stencil: wgpu's GL backend cannot sample stencil textures.
#[derive(Debug, Clone, Copy)]
struct MaskDraw {
    compare: wgpu::CompareFunction,
    read_mask: u32,
    reference: u32,
    value: f64,
}

/// The mask draws: 1 where the count is positive (or odd), 0.5 on cropped receivers.
fn mask_draws(parity: bool, crop: bool) -> Vec<MaskDraw> {
    use wgpu::CompareFunction::{Equal, NotEqual};
    // Counts use eight bits, or seven below the receiver bit; the top one is the sign.
    let (bits, sign) = if crop { (0x7f, 0x40) } else { (0xff, 0x80) };
    let mut draws = if parity {
        vec![MaskDraw { compare: Equal, read_mask: 1, reference: 1, value: 1.0 }]
    } else {
        vec![
            MaskDraw { compare: NotEqual, read_mask: bits, reference: 0, value: 1.0 },
            MaskDraw { compare: Equal, read_mask: sign, reference: sign, value: 0.0 },
        ]
    };
    if crop {
        draws.push(MaskDraw { compare: Equal, read_mask: 0x80, reference: 0x80, value: 0.5 });
    }
    draws
}

fn mask_pipeline(shared: &Shared, draw: &MaskDraw) -> wgpu::RenderPipeline {
    let format = depth_stencil_format(shared);
    let key = format!("volumes mask {:?} {:#x} {} {format:?}", draw.compare, draw.read_mask, draw.value);
    shared.render_pipeline(&key, || {
        let device = &shared.gpu.device;
        let module = crate::shader::module(device, "volumes stencil", include_str!("stencil.wgsl"));
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("volumes mask"),
            bind_group_layouts: &[Some(&stencil_layout(shared))],
            immediate_size: 0,
        });
        let face = wgpu::StencilFaceState {
            compare: draw.compare,
            fail_op: wgpu::StencilOperation::Keep,
            depth_fail_op: wgpu::StencilOperation::Keep,
            pass_op: wgpu::StencilOperation::Keep,
        };
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(&key),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("copy_vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: wgpu::StencilState { front: face, back: face, read_mask: draw.read_mask, write_mask: 0 },
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("mask_fs"),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &[("mask_value", draw.value)],
                    ..Default::default()
                },
                targets: &[Some(wgpu::ColorTargetState {
                    format: MASK_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::RED,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    })
}

/// Marks the receivers seen in front in the stencil's top bit.
fn receiver_pipeline(shared: &Shared) -> wgpu::RenderPipeline {
    let format = depth_stencil_format(shared);
    shared.render_pipeline(&format!("volumes receivers {format:?}"), || {
        let device = &shared.gpu.device;
        let module = crate::shader::module(device, "volumes stencil", include_str!("stencil.wgsl"));
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("volumes receivers"),
            bind_group_layouts: &[Some(&stencil_layout(shared))],
            immediate_size: 0,
        });
        let mark = wgpu::StencilFaceState {
            compare: wgpu::CompareFunction::Always,
            fail_op: wgpu::StencilOperation::Keep,
            depth_fail_op: wgpu::StencilOperation::Keep,
            pass_op: wgpu::StencilOperation::Replace,
        };
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("volumes receivers"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("receiver_vs"),
                compilation_options: Default::default(),
                buffers: &[
                    Some(crate::gpu_scene::VERTEX_LAYOUT),
                    Some(wgpu::VertexBufferLayout {
                        array_stride: 64,
                        step_mode: wgpu::VertexStepMode::Instance,
                        attributes: &wgpu::vertex_attr_array![2 => Float32x4, 3 => Float32x4, 4 => Float32x4, 5 => Float32x4],
                    }),
                ],
            },
            primitive: Default::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
                stencil: wgpu::StencilState { front: mark, back: mark, read_mask: 0x80, write_mask: 0x80 },
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: None,
            multiview_mask: None,
            cache: None,
        })
    })
}

fn resolve_pipeline(shared: &Shared, entry: &str, crop: bool) -> wgpu::ComputePipeline {
    let source = include_str!("resolve.wgsl");
    if crop {
        shared.resolve_pipeline_with(
            &format!("volumes resolve {entry} crop"),
            source,
            entry,
            &[&lookup_layout(shared), &sample_layout(shared)],
            &[],
            &["CROP"],
        )
    } else {
        shared.resolve_pipeline(&format!("volumes resolve {entry}"), source, entry, &[&sample_layout(shared)], &[])
    }
}

/// The light's samples: its centre, or `samples` points on an area emitter.
fn volume_samples(params: &ParamSet, light: &Light) -> Vec<EmitterPoint> {
    let n = params.int("samples").max(1) as u32;
    if n == 1 || light.is_hard() {
        let mut centre = light.clone();
        centre.scale_emitter(0.0);
        emitter_points(&centre, 1)
    } else {
        emitter_points(light, n)
    }
}

/// Writes the samples' uniforms (one per dynamic offset).
fn write_samples(queue: &wgpu::Queue, buffer: &wgpu::Buffer, stride: u64, samples: &[EmitterPoint]) {
    for (i, p) in samples.iter().enumerate() {
        let position = match p.sample {
            EmitterSample::Point(q) => q.extend(0.0),
            EmitterSample::Direction(d) => d.extend(1.0),
        };
        let normal = p.sphere_normal.map(|n| n.extend(1.0)).unwrap_or(Vec4::ZERO);
        let u = SampleUniform { position, normal, index: [i as u32, 0, 0, 0] };
        queue.write_buffer(buffer, i as u64 * stride, bytemuck::bytes_of(&u));
    }
}

/// The bounds of the casters' bounding spheres.
fn caster_bounds(casters: &[Caster]) -> shadowlab_core::Aabb {
    shadowlab_core::Aabb::from_points(
        casters.iter().flat_map(|c| [c.centre - glam::Vec3::splat(c.radius), c.centre + glam::Vec3::splat(c.radius)]),
    )
}

/// Aligned stride for dynamic uniform offsets.
fn stride(device: &wgpu::Device, size: usize) -> u64 {
    let align = u64::from(device.limits().min_uniform_buffer_offset_alignment).max(16);
    (size as u64).div_ceil(align) * align
}

impl Volumes {
    fn build(&self, ctx: &FrameContext<'_>) -> State {
        let shared = ctx.shared;
        let device = &shared.gpu.device;
        let topology = VolumeTopology::shared(shared, ctx.scene);
        let casters = Caster::all(ctx.scene, &topology);
        let faces: u64 = casters.iter().map(|c| u64::from(topology.meshes[c.mesh].faces)).sum();
        let n = self.samples.len() as u64;
        let (w, h) = (ctx.surface.width, ctx.surface.height);
        let format = depth_stencil_format(shared);
        let depth_stencil = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("volumes depth-stencil"),
            size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let depth_stencil_view = depth_stencil.create_view(&Default::default());
        let mask_view = device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("volumes shadow mask"),
                size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: MASK_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
            .create_view(&Default::default());
        // Worst case per sample: every face use of every edge a side quad (6 vertices per use, 3
        // uses per face), and a light and a dark cap per face; clamped to what one binding holds.
        let limit = device.limits().max_storage_buffer_binding_size.min(device.limits().max_buffer_size) / 16;
        let want = [18 * faces, 3 * faces, 3 * faces].map(|v| v.max(3));
        let total: u64 = want.iter().sum();
        let scale = if total > limit { limit as f64 / total as f64 } else { 1.0 };
        let capacity = want.map(|v| ((v as f64 * scale) as u64 / 3 * 3).min(u64::from(u32::MAX / 2)) as u32);
        let vertex_bytes = 16 * capacity.iter().map(|&c| u64::from(c)).sum::<u64>();
        let vertices = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume vertices"),
            size: vertex_bytes.max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::VERTEX,
            mapped_at_creation: false,
        });
        let counters = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume counters"),
            size: 64,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::INDIRECT
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let caster_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume casters"),
            size: (std::mem::size_of::<CasterRecord>() as u64 * casters.len() as u64 * n).max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let signs = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume face signs"),
            size: (4 * faces).max(16),
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let pass_stride = stride(device, std::mem::size_of::<PassUniform>());
        let pass_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume passes"),
            size: pass_stride * n,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let sample_stride = stride(device, std::mem::size_of::<SampleUniform>());
        let sample_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume samples"),
            size: sample_stride * n,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        write_samples(&shared.gpu.queue, &sample_buffer, sample_stride, &self.samples);
        let accum = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume accumulation"),
            size: if n > 1 { 8 * u64::from(w) * u64::from(h) } else { 16 },
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let fill = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume fill"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume stats readback"),
            size: 16 + 16 * n,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let extract_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("volumes extract"),
            layout: &extract_layout(shared),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: caster_buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: signs.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: vertices.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: counters.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &pass_buffer,
                        offset: 0,
                        size: std::num::NonZeroU64::new(std::mem::size_of::<PassUniform>() as u64),
                    }),
                },
            ],
        });
        let fill_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("volumes fill"),
            layout: &fill_layout(shared),
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: fill.as_entire_binding() }],
        });
        let bytes = u64::from(w) * u64::from(h) * 6
            + [&caster_buffer, &vertices, &counters, &signs, &pass_buffer, &sample_buffer, &accum, &fill, &readback]
                .iter()
                .map(|b| b.size())
                .sum::<u64>();
        let receivers = self.crop.then(|| Receivers::new(ctx, &self.params));
        let bytes = bytes + receivers.as_ref().map_or(0, |r| r.instances.size() + r.map.bytes());
        let caster_bounds = caster_bounds(&casters);
        State {
            topology,
            max_casters: casters.len(),
            max_faces: faces,
            casters,
            epoch: ctx.live.epoch(),
            caster_bounds,
            size: (w, h),
            depth_stencil_view,
            mask_view,
            caster_buffer,
            vertices,
            counters,
            pass_buffer,
            pass_stride,
            sample_buffer,
            sample_stride,
            accum,
            fill,
            readback,
            readback_pending: false,
            extract_group,
            fill_group,
            capacity,
            receivers,
            bytes,
        }
    }

    /// Reads the statistics the first frame left in the readback buffer (blocking, once).
    fn read_stats(&mut self, device: &wgpu::Device) {
        let Some(state) = &mut self.state else { return };
        if !state.readback_pending {
            return;
        }
        state.readback_pending = false;
        let Ok(data) = crate::util::map_read(device, &state.readback) else { return };
        let words: Vec<u32> = data.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        self.stats.fill = Some(u64::from(words[0]));
        let mut triangles = 0;
        let mut overflow = 0;
        for (i, plan) in self.plans.iter().enumerate() {
            let c = &words[4 + 4 * i..8 + 4 * i];
            // Counters hold vertices; sides are drawn, caps as the method needs them.
            let drawn = match plan.method {
                Method::Skip => 0,
                Method::ZPass => c[0],
                Method::ZFail => c[0] + c[1] + c[2],
                Method::ZpPlus(_) => c[0] + c[1],
            };
            triangles += u64::from(drawn / 3);
            overflow += u64::from(c[3]);
        }
        self.stats.triangles = Some(triangles);
        self.stats.overflow = overflow;
    }
}

impl ShadowTechnique for Volumes {
    fn id(&self) -> &'static str {
        INFO.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        self.read_stats(&ctx.gpu.device);
        let size = (ctx.surface.width, ctx.surface.height);
        let emitter = ctx.live.light_state(ctx.light_id).map_or(0, |s| s.emitter_version);
        if emitter != self.emitter_version {
            // The light moved or changed size: new samples (and new buffers when their count changed).
            let samples = volume_samples(&self.params, ctx.light);
            if samples.len() != self.samples.len() {
                self.state = None;
            } else if let Some(state) = &self.state {
                write_samples(&ctx.gpu.queue, &state.sample_buffer, state.sample_stride, &samples);
            }
            self.samples = samples;
            self.emitter_version = emitter;
        }
        if let Some(state) = self.state.as_mut()
            && state.size == size
            && state.epoch != ctx.live.epoch()
        {
            // The scene changed: take its casters and receivers as they are now, in the same buffers
            // when they fit.
            let casters = Caster::all(ctx.scene, &state.topology);
            let faces: u64 = casters.iter().map(|c| u64::from(state.topology.meshes[c.mesh].faces)).sum();
            let receivers_fit = state.receivers.as_mut().is_none_or(|r| r.refresh(ctx));
            if casters.len() <= state.max_casters && faces <= state.max_faces && receivers_fit {
                state.caster_bounds = caster_bounds(&casters);
                state.casters = casters;
                state.epoch = ctx.live.epoch();
            } else {
                if let Some(r) = &state.receivers
                    && let Some(maps) = &r.map.maps
                {
                    maps.forget_items(ctx);
                }
                self.state = None;
            }
        }
        if self.state.as_ref().is_none_or(|s| s.size != size) {
            self.state = Some(self.build(ctx));
        }
        if let Some(r) = self.state.as_mut().and_then(|s| s.receivers.as_mut()) {
            r.map.update(ctx)?;
        }
        let Some(state) = &self.state else { return Ok(()) };
        let cam = &ctx.surface.camera;
        let camera = VolumeCamera {
            view_proj: cam.view_proj,
            eye: cam.position.truncate(),
            near_ndc_depth: if cam.depth.x == 0.0 { 1.0 } else { 0.0 },
        };
        let frame = FrameView {
            camera: &camera,
            width: size.0,
            height: size.1,
            range: ctx.light.range,
            casters: &state.casters,
            topology: &state.topology,
            bounds: &state.caster_bounds,
        };
        let queue = &ctx.gpu.queue;
        let volume_matrix = camera.volume_matrix();
        self.plans.clear();
        for (i, sample) in self.samples.iter().enumerate() {
            let plan = plan::plan(&self.settings, &frame, LightSource::of_sample(sample.sample));
            let first = i * state.casters.len();
            if !plan.records.is_empty() {
                queue.write_buffer(
                    &state.caster_buffer,
                    (first * std::mem::size_of::<CasterRecord>()) as u64,
                    bytemuck::cast_slice(&plan.records),
                );
            }
            let (zp_matrix, zp_origin) = match plan.method {
                Method::ZpPlus(zp) => (zp.matrix, zp.origin.extend(1.0)),
                _ => (Mat4::IDENTITY, Vec4::ZERO),
            };
            let caps = match plan.method {
                Method::ZFail => CAPS_ZFAIL,
                Method::ZpPlus(_) => CAPS_ZP_PLUS,
                Method::Skip | Method::ZPass => CAPS_NONE,
            };
            let c = state.capacity;
            let uniform = PassUniform {
                volume_matrix,
                zp_matrix,
                zp_origin,
                light: plan.source.to_vec4(),
                planes: plan.planes,
                counts: [plan.records.len() as u32, first as u32, plan.faces, plan.edges],
                options: [caps, u32::from(self.settings.cull), 0, 0],
                capacity: [c[0], c[1], c[2], 0],
                base: [0, c[0], c[0] + c[1], 0],
            };
            queue.write_buffer(&state.pass_buffer, i as u64 * state.pass_stride, bytemuck::bytes_of(&uniform));
            self.plans.push(plan);
        }
        Ok(())
    }

    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let Some(state) = &mut self.state else { return };
        let shared = ctx.shared;
        let device = &ctx.gpu.device;
        let measure = self.frames == 0;
        let clamp = device.features().contains(wgpu::Features::DEPTH_CLIP_CONTROL);
        let parity = self.settings.parity;
        let crop = self.crop;
        let stencil_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("volumes stencil"),
            layout: &stencil_layout(shared),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: ctx.surface.camera_buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&ctx.surface.depth) },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &state.pass_buffer,
                        offset: 0,
                        size: std::num::NonZeroU64::new(std::mem::size_of::<PassUniform>() as u64),
                    }),
                },
            ],
        });
        let sample_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("volumes samples"),
            layout: &sample_layout(shared),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&state.mask_view) },
                wgpu::BindGroupEntry { binding: 1, resource: state.accum.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &state.sample_buffer,
                        offset: 0,
                        size: std::num::NonZeroU64::new(std::mem::size_of::<SampleUniform>() as u64),
                    }),
                },
            ],
        });
        let group0 = shared.resolve_bind_group(ctx.surface, ctx.light_buffer, out);
        let single = self.samples.len() == 1;
        let (faces_pipeline, sides_pipeline, finish_pipeline) =
            (extract_pipeline(shared, "faces"), extract_pipeline(shared, "sides"), extract_pipeline(shared, "finish"));
        if measure {
            ctx.encoder.clear_buffer(&state.fill, 0, None);
        }
        let mut draws = 0;
        for (i, plan) in self.plans.iter().enumerate() {
            let pass_offset = (i as u64 * state.pass_stride) as u32;
            ctx.encoder.clear_buffer(&state.counters, 0, None);
            if plan.method != Method::Skip {
                let timestamps = ctx.timer.compute_pass(device, PassKind::Shadow);
                let mut pass = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("volume extraction"),
                    timestamp_writes: timestamps,
                });
                pass.set_bind_group(0, Some(&state.topology.group), &[]);
                pass.set_bind_group(1, Some(&state.extract_group), &[pass_offset]);
                for (pipeline, items) in [(&faces_pipeline, plan.faces), (&sides_pipeline, plan.edges)] {
                    let groups = crate::util::groups(items, 64);
                    if groups > 0 {
                        pass.set_pipeline(pipeline);
                        let x = groups.min(65535);
                        pass.dispatch_workgroups(x, groups.div_ceil(x), 1);
                    }
                }
                pass.set_pipeline(&finish_pipeline);
                pass.dispatch_workgroups(1, 1, 1);
            }
            {
                let timestamps = ctx.timer.render_pass(device, PassKind::Shadow);
                let mut pass = ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("volume stencil"),
                    color_attachments: &[],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: &state.depth_stencil_view,
                        depth_ops: Some(wgpu::Operations {
                            load: if i == 0 { wgpu::LoadOp::Clear(0.0) } else { wgpu::LoadOp::Load },
                            store: wgpu::StoreOp::Store,
                        }),
                        stencil_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Clear(plan.stencil_start),
                            store: wgpu::StoreOp::Store,
                        }),
                    }),
                    timestamp_writes: timestamps,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_bind_group(0, Some(&stencil_group), &[pass_offset]);
                if i == 0 {
                    pass.set_pipeline(&copy_pipeline(shared));
                    pass.draw(0..3, 0..1);
                    draws += 1;
                }
                if let Some(r) = &state.receivers {
                    pass.set_pipeline(&receiver_pipeline(shared));
                    pass.set_stencil_reference(0x80);
                    pass.set_vertex_buffer(0, ctx.gpu_scene.vertices.slice(..));
                    pass.set_vertex_buffer(1, r.instances.slice(..));
                    pass.set_index_buffer(ctx.gpu_scene.indices.slice(..), wgpu::IndexFormat::Uint32);
                    for (m, k) in &r.draws {
                        pass.draw_indexed(m.first_index..m.first_index + m.index_count, m.base_vertex, *k..*k + 1);
                        draws += 1;
                    }
                    pass.set_stencil_reference(0);
                }
                if plan.method != Method::Skip {
                    if let Some([x, y, w, h]) = plan.scissor {
                        pass.set_scissor_rect(x, y, w, h);
                    }
                    pass.set_vertex_buffer(0, state.vertices.slice(..));
                    // (vertex entry, counting, region) of each draw.
                    let list: &[(&str, Counting, u64)] = match plan.method {
                        Method::ZPass => &[("side_vs", Counting::Pass, SIDES)],
                        Method::ZFail => &[
                            ("side_vs", Counting::Fail, SIDES),
                            ("side_vs", Counting::Fail, DARK_CAPS),
                            ("cap_vs", Counting::Fail, LIGHT_CAPS),
                        ],
                        Method::ZpPlus(_) => {
                            &[("zp_vs", Counting::Always, LIGHT_CAPS), ("side_vs", Counting::Pass, SIDES)]
                        }
                        Method::Skip => &[],
                    };
                    let clamp_for = |counting: Counting| match counting {
                        Counting::Pass => plan.robust,
                        Counting::Fail => clamp,
                        _ => false,
                    };
                    for &(vertex, counting, region) in list {
                        pass.set_pipeline(&volume_pipeline(
                            shared,
                            vertex,
                            counting,
                            parity,
                            clamp_for(counting),
                            crop,
                        ));
                        pass.draw_indirect(&state.counters, draw_offset(region));
                        draws += 1;
                    }
                    if measure {
                        pass.set_bind_group(1, Some(&state.fill_group), &[]);
                        for &(vertex, counting, region) in list {
                            pass.set_pipeline(&volume_pipeline(
                                shared,
                                vertex,
                                Counting::Fill,
                                parity,
                                clamp_for(counting),
                                crop,
                            ));
                            pass.draw_indirect(&state.counters, draw_offset(region));
                        }
                    }
                }
            }
            {
                let timestamps = ctx.timer.render_pass(device, PassKind::Visibility);
                let mut pass = ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("volume shadow mask"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &state.mask_view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: &state.depth_stencil_view,
                        depth_ops: None,
                        stencil_ops: None,
                    }),
                    timestamp_writes: timestamps,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_bind_group(0, Some(&stencil_group), &[pass_offset]);
                for d in mask_draws(parity, crop) {
                    pass.set_pipeline(&mask_pipeline(shared, &d));
                    pass.set_stencil_reference(d.reference);
                    pass.draw(0..3, 0..1);
                }
            }
            if measure {
                ctx.encoder.copy_buffer_to_buffer(&state.counters, 0, &state.readback, 16 + 16 * i as u64, 16);
            }
            let entry = if single { "single" } else { "accumulate" };
            let timestamps = ctx.timer.compute_pass(device, PassKind::Visibility);
            let mut pass = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("volume resolve"),
                timestamp_writes: timestamps,
            });
            pass.set_pipeline(&resolve_pipeline(shared, entry, crop));
            pass.set_bind_group(0, Some(&group0), &[]);
            let offset = (i as u64 * state.sample_stride) as u32;
            match &state.receivers {
                Some(r) => {
                    pass.set_bind_group(1, r.map.group(), &[]);
                    pass.set_bind_group(2, Some(&sample_group), &[offset]);
                }
                None => pass.set_bind_group(1, Some(&sample_group), &[offset]),
            }
            pass.dispatch_workgroups(
                crate::util::groups(ctx.surface.width, 8),
                crate::util::groups(ctx.surface.height, 8),
                1,
            );
        }
        if !single {
            let timestamps = ctx.timer.compute_pass(device, PassKind::Visibility);
            let mut pass = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("volume finish"),
                timestamp_writes: timestamps,
            });
            pass.set_pipeline(&resolve_pipeline(shared, "finish", crop));
            pass.set_bind_group(0, Some(&group0), &[]);
            match &state.receivers {
                Some(r) => {
                    pass.set_bind_group(1, r.map.group(), &[]);
                    pass.set_bind_group(2, Some(&sample_group), &[0]);
                }
                None => pass.set_bind_group(1, Some(&sample_group), &[0]),
            }
            pass.dispatch_workgroups(
                crate::util::groups(ctx.surface.width, 8),
                crate::util::groups(ctx.surface.height, 8),
                1,
            );
        }
        if measure {
            ctx.encoder.copy_buffer_to_buffer(&state.fill, 0, &state.readback, 0, 16);
            state.readback_pending = true;
        }
        self.stats.draws = draws;
        self.frames += 1;
    }

    fn stats(&self) -> TechniqueStats {
        let Some(state) = &self.state else { return TechniqueStats::default() };
        let n = self.plans.len() as u32;
        let mut extra = vec![("samples".to_owned(), f64::from(n))];
        for method in ["zpass", "zfail", "zpplus", "skip"] {
            let count = self.plans.iter().filter(|p| p.method.name() == method).count();
            extra.push((format!("method_{method}"), count as f64));
        }
        extra.push(("zfail_fallbacks".into(), self.plans.iter().filter(|p| p.fallback).count() as f64));
        extra.push((
            "scissor_fraction".into(),
            self.plans
                .iter()
                .map(|p| match p.scissor {
                    Some([_, _, w, h]) => {
                        f64::from(w) * f64::from(h) / (f64::from(state.size.0) * f64::from(state.size.1))
                    }
                    None if p.method == Method::Skip => 0.0,
                    None => 1.0,
                })
                .sum::<f64>()
                / f64::from(n.max(1)),
        ));
        extra.push((
            "casters".into(),
            self.plans.iter().map(|p| p.records.len()).sum::<usize>() as f64 / f64::from(n.max(1)),
        ));
        if let Some(fill) = self.stats.fill {
            extra.push(("fill_fragments".into(), fill as f64));
        }
        if self.stats.overflow > 0 {
            extra.push(("overflow_vertices".into(), self.stats.overflow as f64));
        }
        TechniqueStats {
            memory_bytes: state.bytes + state.topology.bytes,
            passes: 3 * n + u32::from(n > 1),
            draws: self.stats.draws,
            triangles: self.stats.triangles.unwrap_or(0),
            extra,
        }
    }
}
