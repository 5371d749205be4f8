//! `lightmaps`: receiver light maps (Toromanoff 2005, NOTES-000 §F, G, H, K — his answer for soft
//! shadows on floors and walls), with the other pixels left to a second technique (`rest`,
//! `volumes` by default: Toromanoff's final pipeline).
//!
//! Every large planar receiver ([`shadowlab_core::receivers`]: role `receiver`, or any flat instance
//! of at least `min_area` m²) gets, per light, a visibility texture in its own plane at "object
//! resolution" (`texel` metres per texel, at most `max_texels` per side). It is filled one emitter
//! sample at a time: the casters are drawn from the sample through an off-centre frustum whose far
//! plane lies on the receiver and whose window is the receiver's rectangle (orthographic along the
//! sun's direction for directional samples), so each covered pixel is a texel in that sample's
//! shadow (Toromanoff alg. F–G); the samples' weights add up per texel (sphere lights: each
//! sample's projected area, as `sampled` does). `fill=sampled` takes `samples` points of the
//! emitter (`pattern`: grid, stratified, Toromanoff's rings); `fill=hard` one at its centre;
//! `fill=smoothies` the centre's hard shadow with the casters' smoothies drawn through the same
//! frustum (Chan & Durand 2003; Toromanoff alg. E): each texel keeps the least visibility of the
//! smoothies over it, their distance from the silhouette over the outer penumbra's width between
//! smoothie and receiver.
//!
//! The maps are view-independent: once filled they cost one lookup per pixel however the camera
//! moves, and each (light, receiver) map is a cached item of the live engine (its signature: the
//! light's emitter, the receiver's transform, the casters between them and their versions), so it
//! is refilled only when a caster in that region, the receiver or the light changes. The receiver
//! itself is left out of its own map (its plane is the frustum's far plane).
//!
//! A refill after casters alone changed covers only the texels they can shadow, before or after
//! the edit ([`region`]): a dragged chair's pick-up refills the patch of floor its shadow was on, not
//! the floor. Each sample draws only the casters that can cover a texel being filled, and up to 255
//! samples share a render pass (the stencil holds the sample's number), so a fill costs about what
//! its texels and casters do rather than a pass per sample.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3, Vec4};
use shadowlab_core::params::ParamDef;
use shadowlab_core::receivers::{Patch, PatchCache};
use shadowlab_core::sampling::{EmitterPoint, EmitterSample, SamplePattern, emitter_points_with};
use shadowlab_core::{Aabb, Light, ParamSet};

use super::sampled::PATTERN;
use crate::context::{Shared, storage_entry, texture_entry, uniform_entry};
use crate::frame::VisibilityLayer;
use crate::gpu_scene::{INSTANCE_LAYOUT, VERTEX_LAYOUT};
use crate::live::scheduler::UnitKind;
use crate::live::validity::{Region, hash_values, lightmap_signature};
use crate::live::{InstanceId, ItemKey, ItemKind, LiveScene, Signature};
use crate::shadowmap::PERMANENT;
use crate::technique::{
    Compose, FrameContext, ShadowTechnique, TechniqueError, TechniqueInfo, TechniqueStats, dispatch_resolve_in,
};
use crate::timing::PassKind;

mod region;

use region::{TexelRect, changed_boxes, covered_texels};

/// The techniques that may shadow the pixels off the receivers.
const REST: &[&str] =
    &["volumes", "none", "hard", "pcf", "pcss", "blurred", "sampled", "cssm", "smoothies", "cascaded"];

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "lightmaps",
    summary: "receiver light maps (sampled soft shadows in the receivers' planes), another technique elsewhere",
    source: "Toromanoff 2005 alg. F, G, H, K (NOTES-000)",
    params: &[
        ParamDef::choice("rest", "volumes", REST, "technique for the pixels off the receivers"),
        ParamDef::choice(
            "fill",
            "sampled",
            &["sampled", "hard", "smoothies"],
            "light maps from emitter samples, the centre only, or the centre with smoothies",
        ),
        ParamDef::int("samples", 64, 1, 1024, "emitter samples per light map (fill=sampled)"),
        PATTERN,
        ParamDef::float("texel", 0.02, 0.001, 1.0, "light-map texel size on the receiver, in world units"),
        ParamDef::int("max_texels", 1024, 16, 4096, "most texels per side of one light map"),
        ParamDef::float("min_area", 1.0, 0.01, 1.0e6, "smallest flat part (m²) that gets a light map"),
        ParamDef::int("max_maps", 64, 1, 1024, "most light maps per light (the largest flat parts keep theirs)"),
        ParamDef::bool(
            "bilinear",
            true,
            "bilinear lookups (false: nearest texel; bilinear ones bleed a texel of shadow into joints with walls)",
        ),
    ],
    light_types: super::ALL_LIGHTS,
    create,
    compose: Some(Compose { param: "rest", create: compose }),
    fragment: false,
};

/// Light maps are always made around another technique (the registry creates it from `rest`).
fn create(_shared: &Shared, _params: &ParamSet, _light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    Err(TechniqueError::Failed { id: INFO.id.into(), message: "create it through its spec (it wraps `rest`)".into() })
}

fn compose(
    shared: &Shared,
    params: &ParamSet,
    _light: &Light,
    rest: Box<dyn ShadowTechnique>,
) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let lookup = shared.resolve_pipeline(
        "lightmaps lookup",
        include_str!("lookup.wgsl"),
        "main",
        &[&lookup_layout(shared)],
        &[],
    );
    Ok(Box::new(Lightmaps {
        params: params.clone(),
        rest,
        state: None,
        patches: PatchCache::default(),
        lookup,
        filled: 0,
        draws: 0,
        version: 0,
        changed_itself: true,
        rest_stale: true,
        resolved_patches: None,
        rest_kept: 0,
        rest_version: None,
        looks: 0,
    }))
}

/// `struct Fill` of `fill.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct FillUniform {
    projection: Mat4,
    origin: Vec4,
    axis_u: Vec4,
    axis_v: Vec4,
    sphere: Vec4,
    centre: Vec4,
    texels: Vec4,
}

/// `struct Patch` of `lookup.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct PatchUniform {
    origin: Vec4,
    axis_u: Vec4,
    axis_v: Vec4,
    plane: Vec4,
    texels: Vec4,
}

/// Emitter samples drawn in one render pass: one stencil value each, 0 for none.
const SAMPLES_PER_PASS: usize = 255;

/// Format of the light maps: R = Σ w·V, G = Σ w (blendable everywhere).
const MAP_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const STENCIL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Stencil8;

struct Lightmaps {
    params: ParamSet,
    rest: Box<dyn ShadowTechnique>,
    state: Option<State>,
    /// The receivers' planes, found again only for instances an edit changed.
    patches: PatchCache,
    lookup: wgpu::ComputePipeline,
    /// Light maps filled in the last frame.
    filled: u32,
    draws: u32,
    /// [`ShadowTechnique::shown_version`]: bumped when a shown layer is written, the textures are
    /// made again, `rest` shows something new or what the lookup reads besides the layers changes.
    version: u64,
    /// Whether the last `prepare` changed what the light maps show (not only `rest`).
    changed_itself: bool,
    /// Whether `rest` showed something new since the last `resolve`, and the patches then.
    rest_stale: bool,
    resolved_patches: Option<Vec<Patch>>,
    /// Resolves that kept `rest`'s pixels (`stats`: `rest_kept`).
    rest_kept: u32,
    /// `rest`'s own version when it tracks one.
    rest_version: Option<u64>,
    /// A hash of what the lookup reads besides the layers (the patches, which are shown).
    looks: u64,
}

/// The patches of the scene as it was at `epoch`, their textures and bind groups.
struct State {
    epoch: u64,
    patches: Vec<Patch>,
    /// Texels across each patch's width and height.
    texels: Vec<(u32, u32)>,
    /// The cache's set id of these textures.
    set: u32,
    /// The light maps shown, one layer per patch (what lookups read).
    maps: wgpu::Texture,
    layer_views: Vec<wgpu::TextureView>,
    /// Per patch, the light maps being accumulated over frames (a fill spread by the budget), made
    /// on first need; shown once every stale patch has reached a rung of the sample ladder.
    back: Option<(wgpu::Texture, Vec<wgpu::TextureView>)>,
    /// Per patch: samples in its back layer, the state they are for (with its casters' bounds),
    /// and the texels they cover (the rest of the shown layer is right for that state already).
    accumulated: Vec<u32>,
    back_signature: Vec<Option<Signature>>,
    back_bounds: Vec<Vec<Aabb>>,
    back_rect: Vec<TexelRect>,
    /// Per patch: samples its shown layer holds (0: nothing yet; the least over its texels), the
    /// state they are for with its casters' bounds, the texels that hold fewer than every sample,
    /// and whether that is the current state with every sample.
    front_samples: Vec<u32>,
    front_signature: Vec<Option<Signature>>,
    front_bounds: Vec<Vec<Aabb>>,
    front_incomplete: Vec<TexelRect>,
    front_current: Vec<bool>,
    size: (u32, u32),
    stencil: wgpu::TextureView,
    fills: wgpu::Buffer,
    fill_stride: u64,
    /// Fill uniforms reserved per patch (one per sample).
    samples_per_patch: usize,
    fill_group: wgpu::BindGroup,
    patch_buffer: wgpu::Buffer,
    count_buffer: wgpu::Buffer,
    group: wgpu::BindGroup,
    bytes: u64,
}

/// A patch's light map in texels: `texel` metres each, at most `max_texels` a side.
fn texels(params: &ParamSet, p: &Patch) -> (u32, u32) {
    let texel = params.float("texel") as f32;
    let max = params.int("max_texels") as u32;
    let n = |len: f32| ((len / texel).ceil().max(1.0) as u32).min(max);
    (n(p.width), n(p.height))
}

fn lookup_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("lightmaps lookup", || {
        let c = wgpu::ShaderStages::COMPUTE;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("lightmaps lookup"),
            entries: &[
                uniform_entry(0, c),
                storage_entry(1, c, true),
                texture_entry(
                    2,
                    c,
                    wgpu::TextureSampleType::Float { filterable: true },
                    wgpu::TextureViewDimension::D2Array,
                ),
                wgpu::BindGroupLayoutEntry {
                    binding: 3,
                    visibility: c,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        })
    })
}

fn fill_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("lightmaps fill", || {
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("lightmaps fill"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: std::num::NonZeroU64::new(std::mem::size_of::<FillUniform>() as u64),
                },
                count: None,
            }],
        })
    })
}

/// The fill pipelines: casters into the stencil (`occluder`); the lit and the shadowed texels'
/// sums (`lit`, `shadowed`: additive); smoothies and the umbra (`smoothie`, `umbra`: least value);
/// the sums' start within a scissor (`zero`: a load op clears the whole layer).
fn fill_pipeline(shared: &Shared, which: &str) -> wgpu::RenderPipeline {
    shared.render_pipeline(&format!("lightmaps {which}"), || {
        let device = &shared.gpu.device;
        let module = crate::shader::module(device, "lightmaps fill", include_str!("fill.wgsl"));
        let masks = crate::gpu_scene::mask_layout(device);
        let fill = fill_layout(shared);
        let groups: &[Option<&wgpu::BindGroupLayout>] =
            if which == "occluder_masked" { &[Some(&fill), Some(&masks)] } else { &[Some(&fill)] };
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("lightmaps fill"),
            bind_group_layouts: groups,
            immediate_size: 0,
        });
        let face = |compare, pass_op| wgpu::StencilFaceState {
            compare,
            fail_op: wgpu::StencilOperation::Keep,
            depth_fail_op: wgpu::StencilOperation::Keep,
            pass_op,
        };
        // The stencil holds which sample of the pass marked a texel last (`fill_patch`).
        let stencil_face = match which {
            "occluder" | "occluder_masked" => face(wgpu::CompareFunction::Always, wgpu::StencilOperation::Replace),
            "smoothie" | "zero" => face(wgpu::CompareFunction::Always, wgpu::StencilOperation::Keep),
            "lit" => face(wgpu::CompareFunction::NotEqual, wgpu::StencilOperation::Keep),
            _ => face(wgpu::CompareFunction::Equal, wgpu::StencilOperation::Keep),
        };
        let component = |operation| wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation,
        };
        let blend = match which {
            "occluder" | "occluder_masked" | "zero" => None,
            "smoothie" | "umbra" => Some(wgpu::BlendState {
                color: component(wgpu::BlendOperation::Min),
                alpha: component(wgpu::BlendOperation::Min),
            }),
            _ => Some(wgpu::BlendState {
                color: component(wgpu::BlendOperation::Add),
                alpha: component(wgpu::BlendOperation::Add),
            }),
        };
        const SMOOTHIE_LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
            array_stride: 16,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x4],
        };
        let (vertex_entry, buffers): (&str, &[Option<wgpu::VertexBufferLayout<'_>>]) = match which {
            "occluder" => ("occluder_vs", &[Some(VERTEX_LAYOUT), Some(INSTANCE_LAYOUT)]),
            "occluder_masked" => ("occluder_masked_vs", &[Some(VERTEX_LAYOUT), Some(INSTANCE_LAYOUT)]),
            "smoothie" => ("smoothie_vs", &[Some(SMOOTHIE_LAYOUT)]),
            _ => ("screen_vs", &[]),
        };
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(which),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some(vertex_entry),
                compilation_options: Default::default(),
                buffers,
            },
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: STENCIL_FORMAT,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: wgpu::StencilState {
                    front: stencil_face,
                    back: stencil_face,
                    read_mask: 0xff,
                    write_mask: 0xff,
                },
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some(match which {
                    "occluder" => "occluder_fs",
                    "occluder_masked" => "occluder_masked_fs",
                    "lit" => "lit_fs",
                    "smoothie" => "smoothie_fs",
                    "umbra" => "umbra_fs",
                    "zero" => "zero_fs",
                    _ => "shadowed_fs",
                }),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: MAP_FORMAT,
                    blend,
                    write_mask: if which.starts_with("occluder") {
                        wgpu::ColorWrites::empty()
                    } else {
                        wgpu::ColorWrites::ALL
                    },
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    })
}

/// The casters' smoothies for one light, per instance, in one vertex buffer.
struct SmoothieSet {
    buffer: wgpu::Buffer,
    /// Per instance index (in the scene): its vertex range.
    ranges: Vec<(usize, std::ops::Range<u32>)>,
}

impl Lightmaps {
    /// Texels across a patch (the `texel` size, at most `max_texels`).
    fn texels(&self, p: &Patch) -> (u32, u32) {
        texels(&self.params, p)
    }

    /// The emitter samples, in progressive order: any prefix is spread over the whole emitter, so
    /// that a fill spread over frames shows a fair estimate at every rung.
    fn emitter_samples(&self, light: &Light) -> Vec<EmitterPoint> {
        if self.params.choice("fill") != "sampled" || light.is_hard() {
            let mut centre = light.clone();
            centre.scale_emitter(0.0);
            return emitter_points_with(&centre, 1, SamplePattern::Grid);
        }
        let pattern = SamplePattern::parse(self.params.choice("pattern")).unwrap_or(SamplePattern::Grid);
        let points = emitter_points_with(light, self.params.int("samples") as u32, pattern);
        progressive_order(points.len()).into_iter().map(|i| points[i]).collect()
    }

    fn build(&self, ctx: &mut FrameContext<'_>, patches: Vec<Patch>, samples: usize) -> State {
        let shared = ctx.shared;
        let device = &shared.gpu.device;
        let texels: Vec<(u32, u32)> = patches.iter().map(|p| self.texels(p)).collect();
        let size = texels.iter().fold((1, 1), |a, t| (a.0.max(t.0), a.1.max(t.1)));
        let layers = crate::shadowmap::padded_layers(patches.len().max(1) as u32, shared.gpu.adapter.backend == "gl");
        let maps = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("light maps"),
            size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: layers },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: MAP_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let layer_views = (0..patches.len().max(1) as u32)
            .map(|l| {
                maps.create_view(&wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: l,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let stencil = device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("light map stencil"),
                size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: STENCIL_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
            .create_view(&Default::default());
        let fill_stride = crate::live::validity::aligned(
            std::mem::size_of::<FillUniform>() as u64,
            u64::from(device.limits().min_uniform_buffer_offset_alignment),
        );
        let fills = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("light map fills"),
            size: fill_stride * (patches.len().max(1) * samples.max(1)) as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let fill_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("light map fills"),
            layout: &fill_layout(shared),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &fills,
                    offset: 0,
                    size: std::num::NonZeroU64::new(std::mem::size_of::<FillUniform>() as u64),
                }),
            }],
        });
        let patch_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("light map patches"),
            size: (std::mem::size_of::<PatchUniform>() * patches.len().max(1)) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let count_buffer = crate::util::uniform_buffer(
            device,
            "light map count",
            bytemuck::bytes_of(&Vec4::new(0.0, size.0 as f32, size.1 as f32, 0.0)),
        );
        let filter = if self.params.bool("bilinear") { wgpu::FilterMode::Linear } else { wgpu::FilterMode::Nearest };
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("light maps"),
            mag_filter: filter,
            min_filter: filter,
            ..Default::default()
        });
        let array_view = maps.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("light map lookup"),
            layout: &lookup_layout(shared),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: count_buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: patch_buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&array_view) },
                wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::Sampler(&sampler) },
            ],
        });
        let bytes = u64::from(size.0) * u64::from(size.1) * (8 * u64::from(layers) + 1)
            + fills.size()
            + patch_buffer.size()
            + count_buffer.size();
        let n = patches.len();
        State {
            epoch: ctx.live.epoch(),
            patches,
            texels,
            set: ctx.cache.new_set(),
            accumulated: vec![0; n],
            back_signature: vec![None; n],
            back_bounds: vec![Vec::new(); n],
            back_rect: vec![TexelRect::EMPTY; n],
            front_samples: vec![0; n],
            front_signature: vec![None; n],
            front_bounds: vec![Vec::new(); n],
            front_incomplete: vec![TexelRect::EMPTY; n],
            front_current: vec![false; n],
            maps,
            layer_views,
            back: None,
            size,
            stencil,
            fills,
            fill_stride,
            samples_per_patch: samples.max(1),
            fill_group,
            patch_buffer,
            count_buffer,
            group,
            bytes,
        }
    }
}

impl State {
    /// Whether every lit receiver has a light map to show.
    fn maps_shown(&self) -> bool {
        self.front_samples.iter().zip(&self.front_current).all(|(&n, &current)| n > 0 || current)
    }

    /// The back layers' views (made on first need, like the shown ones).
    fn back_layers(&mut self, ctx: &FrameContext<'_>) -> Vec<wgpu::TextureView> {
        if self.back.is_none() {
            let texture = ctx.gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("light maps (accumulating)"),
                size: self.maps.size(),
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: MAP_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            });
            let views = (0..self.layer_views.len() as u32)
                .map(|l| {
                    texture.create_view(&wgpu::TextureViewDescriptor {
                        dimension: Some(wgpu::TextureViewDimension::D2),
                        base_array_layer: l,
                        array_layer_count: Some(1),
                        ..Default::default()
                    })
                })
                .collect();
            self.bytes +=
                u64::from(self.size.0) * u64::from(self.size.1) * 8 * u64::from(texture.depth_or_array_layers());
            self.back = Some((texture, views));
        }
        self.back.as_ref().expect("made above").1.clone()
    }

    /// Shows the texels `rect` of patch `k`'s accumulated layer: copies them over the shown ones.
    fn copy_back(&self, ctx: &mut FrameContext<'_>, k: usize, rect: TexelRect) {
        let Some((back, _)) = &self.back else { return };
        if rect.is_empty() {
            return;
        }
        let at = |texture| wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d { x: rect.x0, y: rect.y0, z: k as u32 },
            aspect: wgpu::TextureAspect::All,
        };
        ctx.encoder.copy_texture_to_texture(
            at(back),
            at(&self.maps),
            wgpu::Extent3d { width: rect.x1 - rect.x0, height: rect.y1 - rect.y0, depth_or_array_layers: 1 },
        );
    }

    /// The texels of patch `k` to fill again for the state `signature` (`bounds`: its casters'
    /// bounds). When the shown layer is for the same light, patch and receiver and the cache still
    /// vouches for it (`known`), those that the casters changed since can cover through the sample
    /// frustums `projections` ([`region`]), with those it holds incomplete; otherwise (no layer
    /// shown yet, no frustums to bound by: `None`) all of them.
    fn stale_texels(
        &self,
        k: usize,
        signature: &Signature,
        bounds: &[Aabb],
        projections: Option<&[Mat4]>,
        known: bool,
    ) -> TexelRect {
        let full = TexelRect::full(self.texels[k]);
        let (Some(front), Some(projections)) = (&self.front_signature[k], projections) else { return full };
        if !known
            || self.front_samples[k] == 0
            || (front.emitter, front.view, front.object) != (signature.emitter, signature.view, signature.object)
        {
            return full;
        }
        let mut rect = self.front_incomplete[k];
        for b in changed_boxes(&front.casters, &self.front_bounds[k], &signature.casters, bounds) {
            match covered_texels(projections, self.texels[k], &b) {
                Some(r) => rect = rect.union(r),
                None => return full,
            }
        }
        rect
    }
}

/// The rungs of the progressive sample ladder for `n` samples: 4, 16, 64, ... below `n`, and `n`.
fn sample_ladder(n: u32) -> Vec<u32> {
    let mut rungs: Vec<u32> = std::iter::successors(Some(4u32), |r| r.checked_mul(4)).take_while(|&r| r < n).collect();
    rungs.push(n.max(1));
    rungs
}

/// An order of `n` samples (in their pattern's order) whose every prefix spreads over all of them:
/// the bit-reversed permutation (van der Corput), skipping indices past `n`.
fn progressive_order(n: usize) -> Vec<usize> {
    let bits = n.next_power_of_two().trailing_zeros();
    let reverse = |i: usize| if bits == 0 { 0 } else { i.reverse_bits() >> (usize::BITS - bits) };
    (0..n.next_power_of_two()).map(reverse).filter(|&i| i < n).collect()
}

/// The clip-space projection of one emitter sample onto a patch: a frustum from the sample whose
/// far plane is the patch's plane and whose window is its rectangle (texel rows down `axis_v`);
/// for a direction, the parallel projection along it. `None` when the sample is behind the plane.
fn sample_projection(p: &Patch, sample: &EmitterSample, reach: f32) -> Option<Mat4> {
    let (n, c, o, eu, ev) = (p.normal, p.offset, p.origin, p.axis_u, p.axis_v);
    let (w, h) = (p.width.max(1e-6), p.height.max(1e-6));
    // Rows of the clip matrix as (xyz, constant) pairs: clip = Σ row · (p, 1).
    let row = |v: Vec3, k: f32| Vec4::new(v.x, v.y, v.z, k);
    match *sample {
        EmitterSample::Point(s) => {
            let hs = n.dot(s) - c;
            if hs <= 1e-4 * reach {
                return None;
            }
            // w(p) = n·(s − p)/h_s: 1 on the plane, 0 at the sample's level.
            let rw = row(-n / hs, n.dot(s) / hs);
            // u·w = ((s − o)·e_u · w + (p − s)·e_u) / W, then x = 2·u·w − w.
            let su = (s - o).dot(eu);
            let sv = (s - o).dot(ev);
            let ru = (rw * su + row(eu, -s.dot(eu))) / w;
            let rv = (rw * sv + row(ev, -s.dot(ev))) / h;
            let rx = ru * 2.0 - rw;
            let ry = rw - rv * 2.0;
            // z/w from 0 at w = 1e-4 (next to the sample) to 1 on the plane; beyond it > 1 (clipped).
            let near = 1e-4;
            let rz = rw * (1.0 / (1.0 - near)) + Vec4::new(0.0, 0.0, 0.0, -near / (1.0 - near));
            Some(Mat4::from_cols(rx, ry, rz, rw).transpose())
        }
        EmitterSample::Direction(to_light) => {
            let l = to_light.normalize_or(Vec3::Y);
            let nl = n.dot(l);
            if nl <= 1e-4 {
                return None;
            }
            // q = p − l·height/(n·l) on the plane; height = n·p − c.
            let q_u = row(eu - n * (l.dot(eu) / nl), c * l.dot(eu) / nl - o.dot(eu));
            let q_v = row(ev - n * (l.dot(ev) / nl), c * l.dot(ev) / nl - o.dot(ev));
            let rx = q_u * (2.0 / w) + Vec4::new(0.0, 0.0, 0.0, -1.0);
            let ry = Vec4::new(0.0, 0.0, 0.0, 1.0) - q_v * (2.0 / h);
            // Depth 1 on the plane, 0 at `reach` above it (towards the light); below it > 1.
            let rz = row(-n / reach, 1.0 + c / reach);
            let rw = Vec4::new(0.0, 0.0, 0.0, 1.0);
            Some(Mat4::from_cols(rx, ry, rz, rw).transpose())
        }
    }
}

/// The box that holds every caster able to shadow a patch: the patch and the emitter (for the sun,
/// the patch pulled `reach` towards it).
fn patch_region(p: &Patch, light: &Light, samples: &[EmitterPoint], reach: f32) -> Aabb {
    let mut b = Aabb::from_points(p.corners());
    for s in samples {
        match s.sample {
            EmitterSample::Point(q) => b.grow(q),
            EmitterSample::Direction(d) => {
                for c in p.corners() {
                    b.grow(c + d.normalize_or(Vec3::Y) * reach);
                }
            }
        }
    }
    if let Some(q) = light.position() {
        b.grow(q);
    }
    b
}

impl ShadowTechnique for Lightmaps {
    fn id(&self) -> &'static str {
        INFO.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        let before = ctx.cache.work.fills();
        self.rest.prepare(ctx)?;
        // What `rest` shows changed: by its own version where it tracks one, else by any fill.
        let rest_changed = match self.rest.shown_version() {
            Some(v) => self.rest_version.replace(v) != Some(v),
            None => ctx.cache.work.fills() != before,
        };
        if rest_changed {
            self.version += 1;
            self.rest_stale = true;
        }
        let by_rest = self.version;
        let samples = self.emitter_samples(ctx.light);
        let epoch = ctx.live.epoch();
        if self.state.as_ref().is_none_or(|s| s.epoch != epoch) {
            let mut patches = self.patches.patches(ctx.scene, self.params.float("min_area") as f32);
            // A heightfield is a receiver of many small planes: keep the largest (layers and
            // per-pixel lookups are bounded), the rest of the surface goes to `rest`.
            let max_maps = self.params.int("max_maps") as usize;
            if patches.len() > max_maps {
                patches.sort_by(|a, b| b.area.total_cmp(&a.area).then(a.instance.cmp(&b.instance)));
                patches.truncate(max_maps);
            }
            let same_layout = self.state.as_ref().is_some_and(|s| {
                s.patches.len() == patches.len() && patches.iter().zip(&s.texels).all(|(p, &t)| self.texels(p) == t)
            });
            let fits = self
                .state
                .as_ref()
                .is_some_and(|s| s.fills.size() >= s.fill_stride * (patches.len() * samples.len()) as u64);
            if same_layout && fits {
                let state = self.state.as_mut().expect("checked");
                state.patches = patches;
                state.epoch = epoch;
            } else {
                if let Some(old) = &self.state {
                    for k in 0..old.patches.len() as u32 {
                        let key = ItemKey {
                            light: ctx.light_id,
                            owner: ctx.owner,
                            set: old.set,
                            kind: ItemKind::LightMap,
                            index: k,
                        };
                        ctx.cache.forget(&key);
                    }
                }
                self.state = Some(self.build(ctx, patches, samples.len()));
                self.version += 1;
            }
        }
        let state = self.state.as_mut().expect("made above");
        let queue = ctx.gpu.queue.clone();
        let reach = 2.0 * ctx.gpu_scene.bounds.diagonal().max(1e-3);
        let params_hash = hash_values(&[
            self.params.int("samples") as f64,
            self.params.float("texel"),
            self.params.int("max_texels") as f64,
            match self.params.choice("fill") {
                "hard" => 1.0,
                "smoothies" => 2.0,
                _ => 0.0,
            },
            SamplePattern::parse(self.params.choice("pattern")).map_or(0.0, |p| p as u8 as f64),
        ]);
        let mut uniforms = Vec::with_capacity(state.patches.len());
        let mut stale: Vec<usize> = Vec::new();
        let mut smoothies: Option<SmoothieSet> = None;
        let smoothie_fill = self.params.choice("fill") == "smoothies" && !ctx.light.is_hard();
        self.filled = 0;
        self.draws = 0;
        for k in 0..state.patches.len() {
            let patch = state.patches[k];
            let patch = &patch;
            let (tw, th) = state.texels[k];
            let receiver = ctx.live.instances()[patch.instance];
            let lit_side = samples.iter().any(|s| sample_projection(patch, &s.sample, reach).is_some());
            uniforms.push(PatchUniform {
                origin: patch.origin.extend(patch.width),
                axis_u: patch.axis_u.extend(patch.height),
                axis_v: patch.axis_v.extend(k as f32),
                plane: patch.normal.extend(patch.offset),
                texels: Vec4::new(tw as f32, th as f32, 2e-4 * reach, if lit_side { 1.0 } else { 0.0 }),
            });
            if !lit_side {
                state.front_current[k] = true;
                continue;
            }
            let region = Region::of_box(&patch_region(patch, ctx.light, &samples, reach), ctx.light);
            let view = hash_values(&[
                f64::from(patch.origin.x),
                f64::from(patch.origin.y),
                f64::from(patch.origin.z),
                f64::from(patch.width),
                f64::from(patch.height),
                f64::from(tw),
                f64::from(th),
                params_hash as f64,
            ]);
            let signature = lightmap_signature(ctx.live, ctx.light_id, &region, view, patch.instance);
            let key = ItemKey {
                light: ctx.light_id,
                owner: ctx.owner,
                set: state.set,
                kind: ItemKind::LightMap,
                index: k as u32,
            };
            if ctx.cache.is_valid(&key, &signature) && state.front_samples[k] > 0 {
                ctx.cache.work.reused += 1;
                state.front_current[k] = true;
                continue;
            }
            state.front_current[k] = false;
            let n = samples.len() as u32;
            let unlimited = ctx.budget.is_unlimited();
            // The texels to fill: those the changed casters reach (smoothies spread past the
            // casters' frustum images: all of them), unless a fill spread over frames is under way
            // for this very state.
            let restart = unlimited || state.back_signature[k].as_ref() != Some(&signature);
            let mut bounds = Vec::new();
            if restart {
                bounds = caster_bounds(ctx.live, &signature.casters);
                let projections: Option<Vec<Mat4>> = (!smoothie_fill)
                    .then(|| samples.iter().filter_map(|s| sample_projection(patch, &s.sample, reach)).collect());
                let rect = state.stale_texels(k, &signature, &bounds, projections.as_deref(), ctx.cache.holds(&key));
                if rect.is_empty() {
                    // Nothing that changed reaches a texel: the shown layer is right as it is.
                    ctx.cache.commit(key, signature.clone());
                    ctx.cache.work.reused += 1;
                    state.front_signature[k] = Some(signature);
                    state.front_bounds[k] = bounds;
                    state.front_current[k] = true;
                    state.accumulated[k] = 0;
                    state.back_signature[k] = None;
                    continue;
                }
                state.back_rect[k] = rect;
            }
            if smoothie_fill && smoothies.is_none() {
                smoothies = Some(smoothie_set(ctx));
            }
            let rect = state.back_rect[k];
            if unlimited {
                // Every sample now, into the shown layer.
                let target = state.layer_views[k].clone();
                self.draws += fill_patch(
                    ctx,
                    state,
                    &target,
                    k,
                    patch,
                    &samples,
                    0,
                    reach,
                    receiver.id,
                    smoothies.as_ref(),
                    rect,
                );
                ctx.cache.commit(key, signature.clone());
                ctx.cache.work.lightmap_samples += n;
                add_texels(&mut ctx.cache.work, n, rect);
                state.front_samples[k] = n;
                state.front_signature[k] = Some(signature);
                state.front_bounds[k] = bounds;
                state.front_incomplete[k] = TexelRect::EMPTY;
                state.front_current[k] = true;
                state.accumulated[k] = 0;
                state.back_signature[k] = None;
                self.filled += 1;
                self.version += 1;
                continue;
            }
            // Spread over frames: samples accumulate in the back layer (restarting when the state
            // they are for changed), filled below rung by rung across the stale patches.
            stale.push(k);
            if restart {
                state.accumulated[k] = 0;
                state.back_signature[k] = Some(signature);
                state.back_bounds[k] = bounds;
            }
        }
        if !stale.is_empty() {
            let back = state.back_layers(ctx);
            // Smoothie fills are one pass for all samples; sampled ones one pass per sample.
            let per_unit = if smoothie_fill { samples.len() } else { 1 };
            'rungs: for rung in sample_ladder(samples.len() as u32) {
                for &k in &stale {
                    let first = state.accumulated[k] as usize;
                    let rect = state.back_rect[k];
                    let size = rect.area();
                    let mut count = 0;
                    while first + count < rung as usize
                        && ctx.take_units(UnitKind::LightMapSample, size, per_unit as u32)
                    {
                        count += per_unit;
                    }
                    let count = count.min(samples.len() - first);
                    if count > 0 {
                        let patch = state.patches[k];
                        let receiver = ctx.live.instances()[patch.instance].id;
                        let chunk = &samples[first..first + count];
                        self.draws += fill_patch(
                            ctx,
                            state,
                            &back[k],
                            k,
                            &patch,
                            chunk,
                            first,
                            reach,
                            receiver,
                            smoothies.as_ref(),
                            rect,
                        );
                        state.accumulated[k] += count as u32;
                        ctx.cache.work.lightmap_samples += count as u32;
                        add_texels(&mut ctx.cache.work, count as u32, rect);
                    }
                    if state.accumulated[k] < rung {
                        break 'rungs;
                    }
                }
            }
        }
        // All or nothing: the stale patches are shown when every one of them has reached a rung of
        // the sample ladder (4, 16, 64, ... all), each with what it has accumulated.
        if !stale.is_empty() {
            let reached = stale.iter().map(|&k| state.accumulated[k]).min().unwrap_or(0);
            let rung = sample_ladder(samples.len() as u32).into_iter().filter(|&r| r <= reached).max().unwrap_or(0);
            if rung > 0 {
                let n = samples.len() as u32;
                for &k in &stale {
                    // Every stale patch has reached the rung: each shows all it has accumulated,
                    // when that is a rung it did not show yet or all its samples. Between rungs
                    // samples accumulate out of sight, and the light is not resolved again.
                    let newer = state.front_signature[k] != state.back_signature[k];
                    let (shown, accumulated) = (state.front_samples[k], state.accumulated[k]);
                    if newer || (shown < accumulated && (shown < rung || accumulated == n)) {
                        state.copy_back(ctx, k, state.back_rect[k]);
                        self.version += 1;
                        state.front_samples[k] = state.accumulated[k];
                        state.front_signature[k] = state.back_signature[k].clone();
                        state.front_bounds[k] = state.back_bounds[k].clone();
                        state.front_incomplete[k] = if state.accumulated[k] == samples.len() as u32 {
                            TexelRect::EMPTY
                        } else {
                            state.back_rect[k]
                        };
                        self.filled += 1;
                    }
                    if state.front_samples[k] == n && state.front_signature[k] == state.back_signature[k] {
                        let key = ItemKey {
                            light: ctx.light_id,
                            owner: ctx.owner,
                            set: state.set,
                            kind: ItemKind::LightMap,
                            index: k as u32,
                        };
                        if let Some(sig) = state.front_signature[k].clone() {
                            ctx.cache.commit(key, sig);
                        }
                        state.front_current[k] = true;
                    }
                }
            }
        }
        let floats: &[f32] = bytemuck::cast_slice(&uniforms);
        let mut looks: Vec<f64> = floats.iter().map(|&f| f64::from(f)).collect();
        looks.push(f64::from(u8::from(state.maps_shown())));
        let looks = hash_values(&looks);
        if std::mem::replace(&mut self.looks, looks) != looks {
            self.version += 1;
        }
        queue.write_buffer(&state.patch_buffer, 0, bytemuck::cast_slice(&uniforms));
        queue.write_buffer(
            &state.count_buffer,
            0,
            bytemuck::bytes_of(&Vec4::new(state.patches.len() as f32, state.size.0 as f32, state.size.1 as f32, 0.0)),
        );
        self.changed_itself = self.version != by_rest;
        Ok(())
    }

    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let patches = self.state.as_ref().map(|s| s.patches.clone());
        // `rest` wrote the pixels off the patches last time: while it shows what it showed then,
        // over the same patches, surface and camera (`ctx.kept`), they hold (a light map's refill
        // shown mid-drag then costs its lookup alone, not `volumes` again).
        let keep_rest = ctx.kept && !self.rest_stale && patches.is_some() && self.resolved_patches == patches;
        self.rest_stale = false;
        self.resolved_patches = patches;
        let Some(state) = self.state.as_ref().filter(|s| !s.patches.is_empty() && s.maps_shown()) else {
            self.rest.resolve(ctx, out);
            return;
        };
        // The lookup below overwrites every pixel on a filled patch.
        if keep_rest {
            self.rest_kept += 1;
        } else {
            self.rest.resolve(ctx, out);
        }
        let group0 = ctx.resolve_group(out);
        dispatch_resolve_in(ctx, "light maps", &self.lookup, &[&group0, &state.group]);
    }

    /// The lookup reads the pixel's own surface; the rest decides for the others.
    fn resolves_per_pixel(&self) -> bool {
        self.rest.resolves_per_pixel()
    }

    /// The light maps shown change only through fills (a pick-up's refill shows when complete);
    /// the rest decides for the other pixels.
    fn resolves_locally(&self) -> bool {
        self.rest.resolves_locally()
    }

    /// What `rest` filled, when the light maps showed nothing new.
    fn filled_only(&self) -> Option<&[InstanceId]> {
        if self.changed_itself { None } else { self.rest.filled_only() }
    }

    fn map_demand(&self, light: &Light, bounds: &shadowlab_core::Aabb, dynamic: bool) -> Option<(u32, u32)> {
        self.rest.map_demand(light, bounds, dynamic)
    }

    fn measured(&self) -> Option<shadowlab_core::cascades::VisibleDepths> {
        self.rest.measured()
    }

    fn adopt_measured(&mut self, measured: shadowlab_core::cascades::VisibleDepths) {
        self.rest.adopt_measured(measured);
    }

    /// Shown as soon as `rest` is: until every lit receiver has a light map, receivers are shadowed
    /// like the other pixels (Toromanoff's alg. 13: "otherwise render receivers like the other
    /// objects").
    fn shown(&self) -> bool {
        self.rest.shown()
    }

    fn progress(&self) -> (u32, u32) {
        match &self.state {
            Some(s) if s.maps_shown() => {
                // Level 2 at the ladder's first rung, one more per rung reached by every map.
                let samples = s.front_samples.iter().filter(|&&n| n > 0).min().copied().unwrap_or(0);
                let reached = sample_ladder(s.samples_per_patch as u32).iter().filter(|&&r| r <= samples).count();
                (1 + reached.max(1) as u32, samples)
            }
            _ => (1, 0),
        }
    }

    fn current(&self) -> bool {
        self.rest.current() && self.state.as_ref().is_some_and(|s| s.front_current.iter().all(|&c| c))
    }

    fn shown_version(&self) -> Option<u64> {
        Some(self.version)
    }

    fn stats(&self) -> TechniqueStats {
        let rest = self.rest.stats();
        let mut extra = rest.extra;
        if let Some(s) = &self.state {
            extra.push(("light_maps".into(), s.patches.len() as f64));
            extra.push(("light_maps_filled".into(), f64::from(self.filled)));
        }
        extra.push((format!("rest_{}", self.rest.id()), 1.0));
        extra.push(("rest_kept".into(), f64::from(self.rest_kept)));
        TechniqueStats {
            memory_bytes: rest.memory_bytes + self.state.as_ref().map_or(0, |s| s.bytes),
            passes: rest.passes + 1,
            draws: rest.draws + self.draws,
            triangles: rest.triangles,
            extra,
        }
    }
}

/// The bounds of `casters` as they are now (empty for one no longer in the scene).
fn caster_bounds(live: &LiveScene, casters: &[(InstanceId, u64)]) -> Vec<Aabb> {
    let by_id: std::collections::HashMap<InstanceId, Aabb> =
        live.instances().iter().map(|s| (s.id, s.bounds)).collect();
    casters.iter().map(|(id, _)| by_id.get(id).copied().unwrap_or(Aabb::EMPTY)).collect()
}

/// Counts `samples` samples' texels over `rect`.
fn add_texels(work: &mut crate::live::Work, samples: u32, rect: TexelRect) {
    let texels = u64::from(samples) * rect.area();
    work.lightmap_texels = work.lightmap_texels.saturating_add(u32::try_from(texels).unwrap_or(u32::MAX));
}

/// Fills the texels `rect` of patch `k`'s light map in `target` from `samples` (the receiver `skip`
/// left out); from the first sample, `rect` starts from nothing (the whole layer when `rect` is
/// all of it) and the texels outside it keep what they hold. Returns the draws.
#[allow(clippy::too_many_arguments)]
fn fill_patch(
    ctx: &mut FrameContext<'_>,
    state: &State,
    target: &wgpu::TextureView,
    k: usize,
    patch: &Patch,
    samples: &[EmitterPoint],
    first: usize,
    reach: f32,
    skip: crate::live::InstanceId,
    smoothies: Option<&SmoothieSet>,
    rect: TexelRect,
) -> u32 {
    let shared = ctx.shared;
    let (tw, th) = state.texels[k];
    let centre = ctx.light.position().unwrap_or(Vec3::ZERO);
    let directional = ctx.light.direction().filter(|_| ctx.light.position().is_none());
    let emitter = super::smoothies::emitter_size(ctx.light);
    // The permanent casters (the receiver left out), by instance-buffer slot, with their bounds.
    let skip_index = ctx.live.instance_index(skip);
    let casters: Vec<(u32, Aabb)> = ctx
        .scene
        .instances
        .iter()
        .enumerate()
        .filter(|&(i, inst)| inst.casts_shadows && PERMANENT.contains(&inst.mobility) && Some(i) != skip_index)
        .filter_map(|(i, _)| Some((*ctx.gpu_scene.slots.get(i)?, ctx.live.instances().get(i)?.bounds)))
        .collect();
    let mut keep = vec![false; casters.iter().map(|c| c.0 as usize + 1).max().unwrap_or(0)];
    let (occluder, lit, shadowed) =
        (fill_pipeline(shared, "occluder"), fill_pipeline(shared, "lit"), fill_pipeline(shared, "shadowed"));
    // Compiled with the others: a refill of part of a map (an edit's, often a drag's) needs it,
    // and must not compile in that frame (`tests/live.rs`, `a_drag_compiles_no_pipeline`).
    fill_pipeline(shared, "zero");
    let projections: Vec<Option<Mat4>> = samples.iter().map(|s| sample_projection(patch, &s.sample, reach)).collect();
    for (j, s) in samples.iter().enumerate() {
        let projection = projections[j];
        let u = FillUniform {
            projection: projection.unwrap_or(Mat4::IDENTITY),
            origin: patch.origin.extend(patch.width),
            axis_u: patch.axis_u.extend(patch.height),
            axis_v: patch.axis_v.extend(if projection.is_none() { 1.0 } else { 0.0 }),
            sphere: match (s.sphere_normal, directional) {
                (Some(n), _) => n.extend(1.0),
                (None, Some(d)) => (-d).normalize_or(Vec3::Y).extend(0.0),
                (None, None) => Vec4::ZERO,
            },
            centre: centre.extend(tw as f32),
            texels: Vec4::new(th as f32, emitter, if directional.is_some() { 1.0 } else { 0.0 }, 0.0),
        };
        let slot = (k * state.samples_per_patch + first + j) as u64 * state.fill_stride;
        ctx.gpu.queue.write_buffer(&state.fills, slot, bytemuck::bytes_of(&u));
    }
    let mut draws = 0;
    // Smoothie fills (least values from 1) are always whole.
    let whole = rect == TexelRect::full((tw, th)) || smoothies.is_some();
    // Up to 255 samples share a render pass: sample j's casters mark the stencil with j + 1, and
    // its sums read "marked j + 1" as shadowed, anything else as lit, so the stencil need not be
    // cleared between them (a pass of its own per sample cost more than its draws on a CPU
    // rasteriser).
    for (c, chunk) in samples.chunks(SAMPLES_PER_PASS).enumerate() {
        let at = c * SAMPLES_PER_PASS;
        // Sums start at 0; the smoothie fill's least visibility starts at (1, 1): lit.
        let clear = match (smoothies, projections[at]) {
            (Some(_), Some(_)) => wgpu::Color { r: 1.0, g: 1.0, b: 0.0, a: 0.0 },
            (Some(_), None) => wgpu::Color { r: 0.0, g: 1.0, b: 0.0, a: 0.0 },
            (None, _) => wgpu::Color::TRANSPARENT,
        };
        let timestamps = ctx.timer.render_pass(&ctx.gpu.device, PassKind::Shadow);
        let mut pass = ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("light map samples"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: if first + at == 0 && whole { wgpu::LoadOp::Clear(clear) } else { wgpu::LoadOp::Load },
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &state.stencil,
                depth_ops: None,
                stencil_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0), store: wgpu::StoreOp::Discard }),
            }),
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_viewport(0.0, 0.0, tw as f32, th as f32, 0.0, 1.0);
        // The viewport is the whole map's, so texels are the same wherever the scissor cuts.
        pass.set_scissor_rect(rect.x0, rect.y0, rect.x1.min(tw) - rect.x0, rect.y1.min(th) - rect.y0);
        if first + at == 0 && !whole {
            // The sums start at 0 within the rectangle; the texels outside keep theirs.
            pass.set_pipeline(&fill_pipeline(shared, "zero"));
            pass.set_bind_group(0, Some(&state.fill_group), &[0]);
            pass.draw(0..3, 0..1);
            draws += 1;
        }
        for j in 0..chunk.len() {
            let projection = projections[at + j];
            let slot = (k * state.samples_per_patch + first + at + j) as u64 * state.fill_stride;
            let mark = j as u32 + 1;
            pass.set_bind_group(0, Some(&state.fill_group), &[slot as u32]);
            pass.set_stencil_reference(mark);
            if let Some(projection) = projection {
                // Only the casters that can cover a texel of `rect` from this sample: the others
                // would mark nothing there (the stencil's marks do not depend on drawing order).
                keep.fill(false);
                for &(slot, bounds) in &casters {
                    let covered = covered_texels(&[projection], (tw, th), &bounds).is_none_or(|r| r.meets(&rect));
                    keep[slot as usize] = covered;
                }
                ctx.gpu_scene.bind(&mut pass);
                // Opaque casters in one go; alpha-masked ones group by group, each with its mask.
                pass.set_pipeline(&occluder);
                let opaque = ctx.gpu_scene.casters(PERMANENT).filter(|g| g.mask.is_none());
                draws += ctx.gpu_scene.draw_kept(&mut pass, opaque, &keep);
                if let Some(masks) = &ctx.gpu_scene.masks {
                    pass.set_pipeline(&fill_pipeline(shared, "occluder_masked"));
                    for g in ctx.gpu_scene.casters(PERMANENT) {
                        let Some(k) = g.mask else { continue };
                        pass.set_bind_group(1, Some(&masks.group), &[k * masks.stride]);
                        draws += ctx.gpu_scene.draw_kept(&mut pass, std::iter::once(g), &keep);
                    }
                }
            }
            if let Some(set) = smoothies {
                // The smoothies (outside the receiver), then the umbra, each keeping the least value.
                if projection.is_some() {
                    pass.set_pipeline(&fill_pipeline(shared, "smoothie"));
                    pass.set_vertex_buffer(0, set.buffer.slice(..));
                    for (instance, range) in &set.ranges {
                        if Some(*instance) != skip_index && !range.is_empty() {
                            pass.draw(range.clone(), 0..1);
                            draws += 1;
                        }
                    }
                    pass.set_pipeline(&fill_pipeline(shared, "umbra"));
                    pass.draw(0..3, 0..1);
                    draws += 1;
                }
                continue;
            }
            pass.set_pipeline(&lit);
            pass.draw(0..3, 0..1);
            pass.set_pipeline(&shadowed);
            pass.draw(0..3, 0..1);
            draws += 2;
        }
    }
    draws
}

/// The smoothies of every permanent caster for the context's light, uploaded once for the frame.
fn smoothie_set(ctx: &FrameContext<'_>) -> SmoothieSet {
    let topologies = super::smoothies::topologies(ctx.shared, ctx.scene);
    let emitter = super::smoothies::emitter_size(ctx.light);
    let per_instance = super::smoothies::instance_smoothies(ctx.scene, &topologies, ctx.light, emitter);
    let mut vertices: Vec<[f32; 4]> = Vec::new();
    let mut ranges = Vec::with_capacity(per_instance.len());
    for (instance, v) in per_instance {
        let start = vertices.len() as u32;
        vertices.extend(v);
        ranges.push((instance, start..vertices.len() as u32));
    }
    vertices.resize(vertices.len().max(3), [0.0; 4]);
    let buffer = wgpu::util::DeviceExt::create_buffer_init(
        &ctx.gpu.device,
        &wgpu::util::BufferInitDescriptor {
            label: Some("light map smoothies"),
            contents: bytemuck::cast_slice(&vertices),
            usage: wgpu::BufferUsages::VERTEX,
        },
    );
    SmoothieSet { buffer, ranges }
}
