//! `volumes`: stencil shadow volumes (Crow 1977; Heidmann 1991), exact hard shadows with no
//! resolution to choose and no bias to tune, robust in every camera position.
//!
//! Per light (and per emitter sample, for area lights):
//! 1. **Extraction** (`extract.wgsl`, compute, in `prepare`): per (sample, caster), every face
//!    decides whether it occludes and emits its light and dark caps, every edge sums the signs of
//!    the faces around it and emits |net| side quads extruded to infinity (w = 0), into the caster's
//!    own regions of a persistent store with their own indirect draws (`store.rs`). Extraction is
//!    camera-independent and kept while neither the light nor the caster changed (Toromanoff
//!    2005 §3.2; the live cache's `VolumeObject` items): a still frame extracts nothing, a moved
//!    object only its own volumes. Silhouettes by counting make open and non-manifold meshes work
//!    (NOTES-001 §1.4, Hasselgren 2003 §2.3); the CPU reference is [`shadowlab_core::volumes`].
//! 2. **Stencil** (`stencil.wgsl`): the surface's depth is copied into a technique-owned
//!    depth-stencil target (in an infinite reversed depth mapping, so volumes at infinity fit),
//!    then the volumes of the casters the plan keeps are counted with two-sided stencil: z-pass,
//!    z-fail, or ZP+ (Hornus et al. 2005 as Toromanoff 2005 alg. 10 uses it: the stencil starts at
//!    the light's count of the near-capped volumes through the near plane). `auto` takes z-pass
//!    when Toromanoff's skip test proves the near plane outside every volume, ZP+ otherwise, and
//!    z-fail when the light lies in the near plane, where the ZP+ frustum is flat (its known
//!    failure). The method only selects regions: sides, plus both caps (z-fail) or the listed
//!    casters' light caps (ZP+).
//! 3. **Resolve** (`resolve.wgsl`): positive count → shadow (Haines 1994), or odd count with the
//!    invert stencil (Kilgard 2001). Area lights: N samples, averaged like `sampled`.
//!
//! Optimisations of Hasselgren 2003 §3.3: the light's scissor rectangle from its range, culling of
//! casters against the frustum through it (per object, at draw time: the rasteriser's clipping
//! drops the polygons outside, which extraction can no longer cull since it is shared by every
//! camera), and the robust depth pass with the invert stencil (`stencil=invert` with z-pass: depth
//! clamping instead of near clipping, the stencil started at the eye's parity; exact where volumes
//! do not overlap).
//!
//! Alpha-masked casters (leaves, fences: `AlphaMode::Mask`) cannot be extruded: a volume is built
//! from geometry, and a texture's holes have none. They fall back to a hard shadow map of their
//! own (a [`LightMap`] from the light's centre that draws only them, dropping their holes as every
//! map's depth pass does, `shaders/alpha_mask.wgsl`; cached like any map view), and the resolve
//! shadows a pixel that either the stencil or that map shadows. Their shadows are therefore a
//! map's: hard, from the centre even with `samples` > 1, with `hard`'s bias and resolution. With
//! `crop=true`, or as the shadow mask of `lightmesh`, they are extruded whole (opaque).

mod geometry;
mod plan;
mod store;

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec4};
use shadowlab_core::params::ParamDef;
use shadowlab_core::sampling::{EmitterPoint, EmitterSample, emitter_points};
use shadowlab_core::volumes::{LightSource, VolumeCamera};
use shadowlab_core::{Light, ParamSet, Role};

use self::geometry::{Caster, VolumeTopology};
use self::plan::{FrameView, Method, Mode, SamplePlan, Settings};
pub(crate) use self::plan::{focus_ndc, pixel_rect};
use self::store::{DARK_CAPS, LIGHT_CAPS, SIDES, Store, runs};
use crate::context::{Shared, storage_entry, uniform_entry};
use crate::frame::VisibilityLayer;
use crate::light_map::LightMap;
use crate::live::InstanceId;
use crate::shadowmap::lookup_layout;
use crate::technique::{FrameContext, ShadowTechnique, TechniqueError, TechniqueInfo, TechniqueStats, scissor_to};
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
    compose: None,
    fragment: false,
};

/// `struct VolumePass` of `common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct PassUniform {
    volume_matrix: Mat4,
    zp_matrix: Mat4,
    zp_origin: Vec4,
}

/// `struct VolumeSample` of `resolve.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct SampleUniform {
    position: Vec4,
    normal: Vec4,
    index: [u32; 4],
}

pub(crate) struct Volumes {
    params: ParamSet,
    settings: Settings,
    caster_set: CasterSet,
    /// Stop at the stencil's shadow mask (one sample, no cropping): [`Volumes::mask`].
    mask_only: bool,
    /// Bounding spheres of the non-static instances (the receivers of a focused instance).
    focus_spheres: Vec<(glam::Vec3, f32)>,
    crop: bool,
    samples: Vec<EmitterPoint>,
    /// The light's emitter version the samples were taken from.
    emitter_version: u64,
    topology: Option<Arc<VolumeTopology>>,
    /// The permanent casters, taken at scene epoch `caster_epoch`.
    casters: Vec<Caster>,
    caster_epoch: Option<u64>,
    /// Bounds of the casters' bounding spheres (the depth range of the ZP+ projection for the sun).
    caster_bounds: shadowlab_core::Aabb,
    /// Every caster's volumes for every sample (camera-independent, cached).
    store: Option<Store>,
    /// Screen-sized buffers and per-sample uniforms.
    state: Option<State>,
    receivers: Option<Receivers>,
    /// The alpha-masked casters' map (their fallback; see the module's doc), while the scene has
    /// any in this instance's set.
    masked: Option<LightMap>,
    /// The last frame's plans (methods, drawn casters, for the draws and the stats).
    plans: Vec<SamplePlan>,
    /// How the last resolve counted ([`counting_key`]): a region resolved under other methods
    /// would not match the pixels kept around it.
    resolved_counting: Option<u64>,
    /// When the last `prepare` filled objects' volumes alone, how many (the store's `extracted`;
    /// [`ShadowTechnique::filled_only`]).
    filled_volumes: Option<u32>,
    frames: u64,
    stats: VolumeStats,
}

#[derive(Debug, Clone, Default)]
struct VolumeStats {
    /// Volume fragments rasterised in the first frame, over all samples.
    fill: Option<u64>,
    /// Volume triangles drawn in the first frame, over all samples.
    triangles: Option<u64>,
    /// Vertices refused for lack of room in the first frame's drawn volumes (should be 0).
    overflow: u64,
    draws: u32,
}

/// The screen-sized buffers and per-sample uniforms, made for one output size and sample count.
struct State {
    size: (u32, u32),
    samples: usize,
    depth_stencil_view: wgpu::TextureView,
    mask_view: wgpu::TextureView,
    pass_buffer: wgpu::Buffer,
    pass_stride: u64,
    sample_buffer: wgpu::Buffer,
    sample_stride: u64,
    accum: wgpu::Buffer,
    fill: wgpu::Buffer,
    fill_group: wgpu::BindGroup,
    /// The fill counter and the store's draws and counters of the first frame, for the stats.
    readback: Option<wgpu::Buffer>,
    /// Whether the readback holds a frame not yet read.
    readback_pending: bool,
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
    Ok(Box::new(Volumes::new(shared, params, light, CasterSet::All, false)?))
}

/// Which casters' volumes a `volumes` instance draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum CasterSet {
    All,
    /// Static casters only (their shadows on dynamic receivers: `lightmesh`).
    Static,
    /// Dynamic casters only (their shadows on everything: `lightmesh`).
    Dynamic,
}

impl CasterSet {
    fn keeps(self, mobility: shadowlab_core::Mobility) -> bool {
        match self {
            Self::All => true,
            Self::Static => mobility == shadowlab_core::Mobility::Static,
            Self::Dynamic => mobility != shadowlab_core::Mobility::Static,
        }
    }
}

impl Volumes {
    /// A `volumes` instance over `casters`; with `focus`, drawn only over the non-static
    /// receivers' screen rectangle ([`Volumes::focus_rect`]).
    pub(crate) fn new(
        shared: &Shared,
        params: &ParamSet,
        light: &Light,
        casters: CasterSet,
        focus: bool,
    ) -> Result<Self, TechniqueError> {
        let settings = Settings {
            mode: Mode::parse(params.choice("mode")),
            parity: params.choice("stencil") == "invert",
            scissor: params.bool("scissor"),
            cull: params.bool("cull"),
            focus,
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
        Ok(Volumes {
            params: params.clone(),
            settings,
            caster_set: casters,
            mask_only: false,
            focus_spheres: Vec::new(),
            crop: params.bool("crop"),
            samples,
            emitter_version: 0,
            topology: None,
            casters: Vec::new(),
            caster_epoch: None,
            caster_bounds: shadowlab_core::Aabb::EMPTY,
            store: None,
            state: None,
            receivers: None,
            masked: None,
            plans: Vec::new(),
            resolved_counting: None,
            filled_volumes: None,
            frames: 0,
            stats: VolumeStats::default(),
        })
    }

    /// Makes `resolve` stop at the shadow mask (R8: 1 in shadow, 0 lit; what `mask` returns) when the
    /// light has one sample and receivers are not cropped: a caller combining several volumes reads
    /// the masks in one pass instead of each writing a visibility layer.
    pub(crate) fn stop_at_mask(&mut self) -> bool {
        self.mask_only = self.samples.len() == 1 && !self.crop;
        self.mask_only
    }

    /// The last frame's shadow mask (see [`Volumes::stop_at_mask`]).
    pub(crate) fn mask(&self) -> Option<&wgpu::TextureView> {
        self.state.as_ref().map(|s| &s.mask_view)
    }

    /// Whether any caster of its set is in the scene (else it would say 1 everywhere).
    pub(crate) fn has_casters(&self) -> bool {
        !self.casters.is_empty()
    }

    /// With focus: the pixels the last frame's result holds for (`[0; 4]`: none); `None` without.
    pub(crate) fn focus_rect(&self) -> Option<[u32; 4]> {
        self.plans.first().and_then(|p| p.focus_rect)
    }
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

/// The shadow map a resolve reads beside the stencil's mask.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Lookup {
    None,
    /// Cropped receivers take the map's visibility (`crop`).
    Crop,
    /// The alpha-masked casters' map shadows any pixel too (their fallback).
    Masked,
}

fn resolve_pipeline(shared: &Shared, entry: &str, lookup: Lookup) -> wgpu::ComputePipeline {
    let source = include_str!("resolve.wgsl");
    let layouts = [&lookup_layout(shared), &sample_layout(shared)];
    match lookup {
        Lookup::Crop => shared.resolve_pipeline_with(
            &format!("volumes resolve {entry} crop"),
            source,
            entry,
            &layouts,
            &[],
            &["MAPPED", "CROP"],
        ),
        Lookup::Masked => shared.resolve_pipeline_with(
            &format!("volumes resolve {entry} masked"),
            source,
            entry,
            &layouts,
            &[],
            &["MAPPED", "MASKED"],
        ),
        Lookup::None => {
            shared.resolve_pipeline(&format!("volumes resolve {entry}"), source, entry, &[&sample_layout(shared)], &[])
        }
    }
}

/// The instances whose material the maps draw with holes (`GpuScene::masked_material`).
fn masked_instances(ctx: &FrameContext<'_>) -> Vec<crate::live::InstanceId> {
    let scene = ctx.live.scene();
    scene
        .instances
        .iter()
        .zip(ctx.live.instances())
        .filter(|(i, _)| ctx.gpu_scene.masked_material(i.material.index()))
        .map(|(_, state)| state.id)
        .collect()
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
/// The eye as the volume planner sees it.
fn volume_camera(ctx: &FrameContext<'_>) -> VolumeCamera {
    let cam = &ctx.surface.camera;
    VolumeCamera {
        view_proj: cam.view_proj,
        eye: cam.position.truncate(),
        near_ndc_depth: if cam.depth.x == 0.0 { 1.0 } else { 0.0 },
    }
}

fn caster_bounds(casters: &[Caster]) -> shadowlab_core::Aabb {
    shadowlab_core::Aabb::from_points(
        casters.iter().flat_map(|c| [c.centre - glam::Vec3::splat(c.radius), c.centre + glam::Vec3::splat(c.radius)]),
    )
}

/// Bounding spheres of the instances that are not static (dynamic and dragged ones): where static
/// casters' shadows are not already in a light mesh.
pub(crate) fn focus_spheres(live: &crate::live::LiveScene) -> Vec<(glam::Vec3, f32)> {
    // The live scene keeps every instance's world bounds: nothing to recompute per frame.
    live.scene()
        .instances
        .iter()
        .zip(live.instances())
        .filter(|(i, _)| i.mobility != shadowlab_core::Mobility::Static)
        .map(|(_, state)| (state.bounds.center(), state.bounds.diagonal() * 0.5 * 1.0001 + 1e-6))
        .collect()
}

/// Aligned stride for dynamic uniform offsets.
fn stride(device: &wgpu::Device, size: usize) -> u64 {
    let align = u64::from(device.limits().min_uniform_buffer_offset_alignment).max(16);
    (size as u64).div_ceil(align) * align
}

impl Volumes {
    /// The screen-sized buffers and per-sample uniforms.
    fn build_state(&self, ctx: &FrameContext<'_>) -> State {
        let shared = ctx.shared;
        let device = &shared.gpu.device;
        let n = self.samples.len() as u64;
        let (w, h) = (ctx.surface.width, ctx.surface.height);
        let texture = |label, format, usage| {
            crate::util::texture_2d(device, label, format, (w, h), usage).create_view(&Default::default())
        };
        let attachment = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let depth_stencil_view = texture("volumes depth-stencil", depth_stencil_format(shared), attachment);
        let mask_view = texture("volumes shadow mask", MASK_FORMAT, attachment);
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
            // The total, then one counter per pixel.
            size: 16 + 4 * u64::from(w) * u64::from(h),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let fill_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("volumes fill"),
            layout: &fill_layout(shared),
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: fill.as_entire_binding() }],
        });
        let bytes = u64::from(w) * u64::from(h) * 6
            + [&pass_buffer, &sample_buffer, &accum, &fill].iter().map(|b| b.size()).sum::<u64>();
        State {
            size: (w, h),
            samples: self.samples.len(),
            depth_stencil_view,
            mask_view,
            pass_buffer,
            pass_stride,
            sample_buffer,
            sample_stride,
            accum,
            fill,
            fill_group,
            readback: None,
            readback_pending: false,
            bytes,
        }
    }

    /// Reads the statistics the first frame left in the readback buffer (blocking, once): the fill,
    /// and the triangles of the regions each plan drew. Native only: a browser cannot wait for a
    /// readback, so a web build reports no fill or triangles.
    #[cfg(not(target_arch = "wasm32"))]
    fn read_stats(&mut self, device: &wgpu::Device) {
        let (Some(state), Some(store)) = (&mut self.state, &self.store) else { return };
        if !state.readback_pending {
            return;
        }
        state.readback_pending = false;
        let Some(readback) = &state.readback else { return };
        let Ok(data) = crate::util::map_read(device, readback) else { return };
        let words: Vec<u32> = data.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        self.stats.fill = Some(u64::from(words[0]));
        // The store's draws and counters follow the fill counter.
        let counters = &words[4..];
        let (mut triangles, mut overflow) = (0u64, 0u64);
        for (i, plan) in self.plans.iter().enumerate() {
            for d in &plan.casters {
                let item = store.item(i as u32, d.slot);
                let vertices = |region: u64| u64::from(counters[(store.draw_offset(region, item) / 4) as usize]);
                let drawn = match plan.method {
                    Method::Skip => 0,
                    Method::ZPass => vertices(SIDES) + if d.see_through { vertices(LIGHT_CAPS) } else { 0 },
                    Method::ZFail => vertices(SIDES) + vertices(LIGHT_CAPS) + vertices(DARK_CAPS),
                    Method::ZpPlus(_) => {
                        vertices(SIDES)
                            + u64::from(u8::from(d.zp_listed) + u8::from(d.see_through)) * vertices(LIGHT_CAPS)
                    }
                };
                triangles += drawn / 3;
                overflow += u64::from(counters[store.count_word(item, 3)]);
            }
        }
        self.stats.triangles = Some(triangles);
        self.stats.overflow = overflow;
    }
}

/// The stencil draws of a method: (vertex entry, counting, region, only the casters ZP+ lists).
/// Which of a sample's drawn casters a draw takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Selection {
    All,
    /// ZP+'s start: the casters whose volumes may meet the near plane (`Drawn::zp_listed`).
    Listed,
    /// Open single-sided casters, whose light caps the eye may cross (`Drawn::see_through`).
    SeeThrough,
}

/// The draws of a counting method: vertex entry, counting, store region, casters.
fn method_draws(method: &Method) -> &'static [(&'static str, Counting, u64, Selection)] {
    use Selection::*;
    match method {
        // Counting in front of the surface needs no caps where every light cap is a visible
        // surface (pushed behind it by `cap_vs`), but the eye sees through an open single-sided
        // caster's back faces and enters its volume there (Sibenik: 1.25% of pixels lit in shadow).
        Method::ZPass => &[("side_vs", Counting::Pass, SIDES, All), ("cap_vs", Counting::Pass, LIGHT_CAPS, SeeThrough)],
        Method::ZFail => &[
            ("side_vs", Counting::Fail, SIDES, All),
            ("side_vs", Counting::Fail, DARK_CAPS, All),
            ("cap_vs", Counting::Fail, LIGHT_CAPS, All),
        ],
        Method::ZpPlus(_) => &[
            ("zp_vs", Counting::Always, LIGHT_CAPS, Listed),
            ("side_vs", Counting::Pass, SIDES, All),
            ("cap_vs", Counting::Pass, LIGHT_CAPS, SeeThrough),
        ],
        Method::Skip => &[],
    }
}

/// How a frame's plans count, apart from which casters they draw: each sample's method (with
/// ZP+'s projection), fallback, robustness, start value, scissor and focus.
fn counting_key(plans: &[SamplePlan]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::hash::DefaultHasher::new();
    for p in plans {
        // Debug prints every float so that it reads back exactly.
        format!("{:?}", (p.method, p.fallback, p.robust, p.stencil_start, p.scissor, p.focus_rect)).hash(&mut h);
    }
    h.finish()
}

impl Volumes {
    fn prepare_volumes(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        #[cfg(not(target_arch = "wasm32"))]
        self.read_stats(&ctx.gpu.device);
        let size = (ctx.surface.width, ctx.surface.height);
        let emitter = ctx.live.light_state(ctx.light_id).map_or(0, |s| s.emitter_version);
        if emitter != self.emitter_version {
            // The light moved or changed size: new samples (and new buffers when their count
            // changed). The store's items record the emitter version: they re-extract.
            let samples = volume_samples(&self.params, ctx.light);
            if let Some(state) = &self.state
                && state.samples == samples.len()
            {
                write_samples(&ctx.gpu.queue, &state.sample_buffer, state.sample_stride, &samples);
            }
            self.samples = samples;
            self.emitter_version = emitter;
        }
        let topology = self.topology.get_or_insert_with(|| VolumeTopology::shared(ctx.shared, ctx.scene)).clone();
        if self.caster_epoch != Some(ctx.live.epoch()) {
            // The scene changed: take its casters and receivers as they are now, in the same buffers
            // when they fit (each caster keeps its slot, and its volumes while it stands still).
            self.casters = Caster::all(ctx.live, &topology);
            let set = self.caster_set;
            self.casters.retain(|c| set.keeps(c.mobility));
            // Alpha-masked casters leave the volumes for their own map (see the module's doc).
            let masked = masked_instances(ctx);
            let fallback = !self.crop && !self.mask_only && self.casters.iter().any(|c| masked.contains(&c.id));
            if fallback {
                self.casters.retain(|c| !masked.contains(&c.id));
                if self.masked.is_none() {
                    let mut map = LightMap::new(ctx.shared, &self.params, false);
                    map.raster.only_masked = true;
                    self.masked = Some(map);
                }
            } else if let Some(map) = self.masked.take()
                && let Some(maps) = &map.maps
            {
                maps.forget_items(ctx);
            }
            self.caster_bounds = caster_bounds(&self.casters);
            self.caster_epoch = Some(ctx.live.epoch());
            if let Some(store) = &mut self.store
                && !store.place(ctx, &topology, &self.casters)
            {
                store.forget_all(ctx);
                self.store = None;
            }
            if let Some(r) = &mut self.receivers
                && !r.refresh(ctx)
            {
                if let Some(maps) = &r.map.maps {
                    maps.forget_items(ctx);
                }
                self.receivers = None;
            }
        }
        let sources: Vec<LightSource> = self.samples.iter().map(|s| LightSource::of_sample(s.sample)).collect();
        let point = matches!(sources.first(), Some(LightSource::Point(_)));
        if let Some(store) = &self.store
            && !store.fits_samples(sources.len() as u32, point)
        {
            store.forget_all(ctx);
            self.store = None;
        }
        let store = match &mut self.store {
            Some(store) => store,
            None => self.store.insert(Store::new(ctx, &topology, &self.casters, sources.len() as u32, point)),
        };
        store.extract(ctx, &topology, &self.casters, &sources)?;
        if self.state.as_ref().is_none_or(|s| s.size != size || s.samples != self.samples.len()) {
            if self.samples.len() > 1 {
                // The per-pixel sums of several samples (`build_state`).
                let bytes = 8 * u64::from(size.0) * u64::from(size.1);
                ctx.shared.check_output_buffer(INFO.id, "sample sums", bytes, size.0, size.1)?;
            }
            self.state = Some(self.build_state(ctx));
        }
        if self.crop && self.receivers.is_none() {
            self.receivers = Some(Receivers::new(ctx, &self.params));
        }
        if let Some(r) = &mut self.receivers {
            r.map.update(ctx)?;
        }
        if let Some(map) = &mut self.masked {
            map.update(ctx)?;
        }
        let (Some(state), Some(store)) = (&self.state, &self.store) else { return Ok(()) };
        let camera = volume_camera(ctx);
        if self.settings.focus {
            self.focus_spheres = focus_spheres(ctx.live);
        }
        let frame = FrameView {
            camera: &camera,
            width: size.0,
            height: size.1,
            range: ctx.light.range,
            casters: &self.casters,
            slots: &store.slot_of,
            topology: &topology,
            bounds: &self.caster_bounds,
            focus: &self.focus_spheres,
        };
        let volume_matrix = camera.volume_matrix();
        self.plans.clear();
        for (i, &source) in sources.iter().enumerate() {
            let plan = plan::plan(&self.settings, &frame, source);
            let (zp_matrix, zp_origin) = match plan.method {
                Method::ZpPlus(zp) => (zp.matrix, zp.origin.extend(1.0)),
                _ => (Mat4::IDENTITY, Vec4::ZERO),
            };
            let uniform = PassUniform { volume_matrix, zp_matrix, zp_origin };
            ctx.gpu.queue.write_buffer(&state.pass_buffer, i as u64 * state.pass_stride, bytemuck::bytes_of(&uniform));
            self.plans.push(plan);
        }
        Ok(())
    }

    fn resolve_volumes(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let (Some(state), Some(store)) = (&mut self.state, &self.store) else { return };
        let shared = ctx.shared;
        let device = &ctx.gpu.device;
        // The first frame's statistics, read back (blocking) at the next: native only.
        let measure = self.frames == 0 && cfg!(not(target_arch = "wasm32"));
        let clamp = device.features().contains(wgpu::Features::DEPTH_CLIP_CONTROL);
        let parity = self.settings.parity;
        let crop = self.crop;
        // The map the resolve reads beside the stencil: the cropped receivers', or the alpha-masked
        // casters' (never both: cropping keeps masked casters in the volumes).
        let map = self.receivers.as_ref().map(|r| &r.map).or(self.masked.as_ref());
        let lookup = match (&self.receivers, &self.masked) {
            (Some(_), _) => Lookup::Crop,
            (None, Some(_)) => Lookup::Masked,
            (None, None) => Lookup::None,
        };
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
        let group0 = ctx.resolve_group(out);
        // A region (a dragged object's footprint): the stencil and mask passes are scissored to it
        // and the compute passes cover only it.
        let region = ctx.region_rect();
        let [_, _, rw, rh] = ctx.resolve_rect();
        let single = self.samples.len() == 1;
        if measure {
            ctx.encoder.clear_buffer(&state.fill, 0, None);
        }
        let mut draws = 0;
        for (i, plan) in self.plans.iter().enumerate() {
            let pass_offset = (i as u64 * state.pass_stride) as u32;
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
                // Focused: nothing outside the focus rectangle is read, not even the depth copy.
                let focus_scissor = plan.focus_rect.filter(|r| r[2] > 0 && r[3] > 0);
                // Nothing of the region in focus: the pass only clears (the mask then reads lit).
                let visible = scissor_to(&mut pass, region, focus_scissor);
                if visible && i == 0 {
                    pass.set_pipeline(&copy_pipeline(shared));
                    pass.draw(0..3, 0..1);
                    draws += 1;
                }
                if let Some(r) = self.receivers.as_ref().filter(|_| visible) {
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
                if visible
                    && plan.method != Method::Skip
                    && scissor_to(&mut pass, region, plan.scissor.or(focus_scissor))
                {
                    pass.set_vertex_buffer(0, store.vertices().slice(..));
                    let casters = &plan.casters;
                    let indirect = &store.counters;
                    // The drawn casters' regions, as runs of consecutive slots: one multi-draw each.
                    let all = runs(casters.iter().map(|d| d.slot));
                    let listed = runs(casters.iter().filter(|d| d.zp_listed).map(|d| d.slot));
                    let see_through = runs(casters.iter().filter(|d| d.see_through).map(|d| d.slot));
                    let chosen = |selection: Selection| match selection {
                        Selection::All => &all,
                        Selection::Listed => &listed,
                        Selection::SeeThrough => &see_through,
                    };
                    let list = method_draws(&plan.method);
                    let clamp_for = |counting: Counting| match counting {
                        Counting::Pass => plan.robust,
                        Counting::Fail => clamp,
                        _ => false,
                    };
                    let base = store.item(i as u32, 0);
                    let record = |pass: &mut wgpu::RenderPass<'_>, region: u64, selection: Selection| {
                        for &(first, count) in chosen(selection) {
                            pass.multi_draw_indirect(indirect, store.draw_offset(region, base + first), count);
                        }
                    };
                    let list: Vec<_> = list.iter().filter(|d| !chosen(d.3).is_empty()).collect();
                    for &&(vertex, counting, region, selection) in &list {
                        pass.set_pipeline(&volume_pipeline(
                            shared,
                            vertex,
                            counting,
                            parity,
                            clamp_for(counting),
                            crop,
                        ));
                        record(&mut pass, region, selection);
                        draws += chosen(selection).len() as u32;
                    }
                    if measure {
                        pass.set_bind_group(1, Some(&state.fill_group), &[]);
                        for &&(vertex, counting, region, selection) in &list {
                            pass.set_pipeline(&volume_pipeline(
                                shared,
                                vertex,
                                Counting::Fill,
                                parity,
                                clamp_for(counting),
                                crop,
                            ));
                            record(&mut pass, region, selection);
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
                if scissor_to(&mut pass, region, plan.focus_rect.filter(|r| r[2] > 0 && r[3] > 0)) {
                    for d in mask_draws(parity, crop) {
                        pass.set_pipeline(&mask_pipeline(shared, &d));
                        pass.set_stencil_reference(d.reference);
                        pass.draw(0..3, 0..1);
                    }
                }
            }
            if self.mask_only && single {
                // The caller reads the mask itself (`lightmesh`).
                continue;
            }
            let entry = if single { "single" } else { "accumulate" };
            let timestamps = ctx.timer.compute_pass(device, PassKind::Visibility);
            let mut pass = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("volume resolve"),
                timestamp_writes: timestamps,
            });
            pass.set_pipeline(&resolve_pipeline(shared, entry, lookup));
            pass.set_bind_group(0, Some(&group0), &[]);
            let offset = (i as u64 * state.sample_stride) as u32;
            match map {
                Some(map) => {
                    pass.set_bind_group(1, map.group(), &[]);
                    pass.set_bind_group(2, Some(&sample_group), &[offset]);
                }
                None => pass.set_bind_group(1, Some(&sample_group), &[offset]),
            }
            pass.dispatch_workgroups(crate::util::groups(rw, 8), crate::util::groups(rh, 8), 1);
        }
        if !single {
            let timestamps = ctx.timer.compute_pass(device, PassKind::Visibility);
            let mut pass = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("volume finish"),
                timestamp_writes: timestamps,
            });
            pass.set_pipeline(&resolve_pipeline(shared, "finish", lookup));
            pass.set_bind_group(0, Some(&group0), &[]);
            match map {
                Some(map) => {
                    pass.set_bind_group(1, map.group(), &[]);
                    pass.set_bind_group(2, Some(&sample_group), &[0]);
                }
                None => pass.set_bind_group(1, Some(&sample_group), &[0]),
            }
            pass.dispatch_workgroups(crate::util::groups(rw, 8), crate::util::groups(rh, 8), 1);
        }
        if measure {
            // The fill counter, then the store's draws and counters: the triangles each plan drew.
            let readback = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("volume stats readback"),
                size: 16 + store.counters.size(),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            ctx.encoder.copy_buffer_to_buffer(&state.fill, 0, &readback, 0, 16);
            ctx.encoder.copy_buffer_to_buffer(&store.counters, 0, &readback, 16, store.counters.size());
            state.readback = Some(readback);
            state.readback_pending = true;
        }
        self.stats.draws = draws;
        self.frames += 1;
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
        let (fills, objects) = (ctx.cache.work.fills(), ctx.cache.work.volume_objects);
        let prepared = self.prepare_volumes(ctx);
        // Only objects' volumes filled (the other fills are the receivers' maps): those objects'.
        let extracted = ctx.cache.work.volume_objects - objects;
        let others = ctx.cache.work.fills().iter().zip(fills).map(|(a, b)| a - b).sum::<u32>() - extracted;
        self.filled_volumes = (prepared.is_ok() && others == 0).then_some(extracted);
        prepared
    }

    fn filled_only(&self) -> Option<&[InstanceId]> {
        match (self.filled_volumes, &self.store) {
            (Some(0), _) => Some(&[]),
            (Some(_), Some(store)) => Some(&store.extracted),
            _ => None,
        }
    }

    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let counting = counting_key(&self.plans);
        if ctx.region.is_some() && self.resolved_counting != Some(counting) {
            // The pixels kept around the region were counted otherwise (a caster that left
            // touched the near plane, or the parity start changed): every pixel again.
            ctx.region = None;
        }
        self.resolved_counting = Some(counting);
        self.resolve_volumes(ctx, out);
    }

    /// Shown once every object's volumes were extracted (alg. 14: a light is shadowed by volumes
    /// only when all its objects' are ready); later updates are atomic per object.
    fn shown(&self) -> bool {
        self.store.as_ref().is_some_and(|s| s.complete_once)
            && self.receivers.as_ref().is_none_or(|r| r.map.shown())
            && self.masked.as_ref().is_none_or(LightMap::shown)
    }

    fn current(&self) -> bool {
        self.store.as_ref().is_some_and(|s| s.current)
            && self.receivers.as_ref().is_none_or(|r| r.map.current())
            && self.masked.as_ref().is_none_or(LightMap::current)
    }

    fn fill_counts(&self) -> Vec<&wgpu::Buffer> {
        match &self.state {
            Some(state) if self.frames > 0 => vec![&state.fill],
            _ => Vec::new(),
        }
    }

    /// A pixel's counts depend on its depth and the volumes alone.
    fn resolves_per_pixel(&self) -> bool {
        true
    }

    /// A caster's volumes count only where they enclose a point; the cropped receivers' and the
    /// alpha-masked casters' maps change only through fills.
    fn resolves_locally(&self) -> bool {
        true
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
            self.plans.iter().map(|p| p.casters.len()).sum::<usize>() as f64 / f64::from(n.max(1)),
        ));
        if let Some(fill) = self.stats.fill {
            extra.push(("fill_fragments".into(), fill as f64));
        }
        if self.stats.overflow > 0 {
            extra.push(("overflow_vertices".into(), self.stats.overflow as f64));
        }
        let topology = self.topology.as_ref().map_or(0, |t| t.bytes);
        let store = self.store.as_ref().map_or(0, |s| s.bytes);
        let receivers = self.receivers.as_ref().map_or(0, |r| r.instances.size() + r.map.bytes());
        let masked = self.masked.as_ref().map_or(0, LightMap::bytes);
        TechniqueStats {
            memory_bytes: state.bytes + store + receivers + masked + topology,
            passes: if self.mask_only { 2 * n } else { 3 * n + u32::from(n > 1) },
            draws: self.stats.draws,
            triangles: self.stats.triangles.unwrap_or(0),
            extra,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::techniques::volumes::plan::Drawn;

    fn plan(method: Method, stencil_start: u32, casters: &[u32]) -> SamplePlan {
        SamplePlan {
            method,
            fallback: false,
            robust: stencil_start > 0,
            stencil_start,
            scissor: Some([0, 0, 48, 36]),
            focus_rect: None,
            casters: casters.iter().map(|&slot| Drawn { slot, zp_listed: false, see_through: false }).collect(),
        }
    }

    /// A pick-up's region is kept only while the plans count the same way: a caster leaving the
    /// drawn list keeps the key; another method, start value or sample count changes it. Fails
    /// with the method left out of the key.
    #[test]
    fn the_counting_key_ignores_the_casters_drawn_and_nothing_else() {
        let before = [plan(Method::ZPass, 0, &[0, 1, 2]), plan(Method::ZFail, 0, &[0, 1, 2])];
        let without = [plan(Method::ZPass, 0, &[0, 2]), plan(Method::ZFail, 0, &[0, 2])];
        assert_eq!(counting_key(&before), counting_key(&without));
        let flipped = [plan(Method::ZFail, 0, &[0, 2]), plan(Method::ZFail, 0, &[0, 2])];
        let started = [plan(Method::ZPass, 1, &[0, 2]), plan(Method::ZFail, 0, &[0, 2])];
        for other in [&flipped[..], &started[..], &without[..1]] {
            assert_ne!(counting_key(&before), counting_key(other), "{other:?}");
        }
    }
}
