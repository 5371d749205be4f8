//! `ssm`: soft shadow mapping by back-projection (G. Guennebaud, L. Barthe, M. Paulin, "High-Quality
//! Adaptive Soft Shadow Mapping", Eurographics 2007, after their "Real-time Soft Shadow Mapping by
//! Backprojection", EGSR 2006; NOTES-002). One hard map from the light's centre stands in for the
//! scene; per pixel the occluders' contour in it is back-projected onto the emitter and the hidden
//! area integrated exactly, so overlapping blockers at different depths come out right where PCSS's
//! one average blocker depth cannot, at a bounded cost per pixel whatever the light's size:
//!
//! 1. **Hierarchical shadow map** (§3): a pyramid of (nearest, farthest) depths over the map
//!    (`hsm.wgsl`, a compute reduction). The search kernel, from Eq. 1 with the map's nearest depth,
//!    is tightened from the pyramid texels inside it, Eq. 1 read per texel (beyond the paper: a
//!    texel counts only if it is nearer the light than the receiver and within its own depth's
//!    kernel of it); its bounds classify pixels as lit or umbra without looking further.
//! 2. **Smooth contour detection** (§4.1): marching squares over the 2 × 2 sample blocks in the
//!    kernel, the contour grown or shrunk by `t` (0 on the finest level, `t_coarse` = 1 on coarser
//!    ones, which the min depth dilates). Beyond the paper, a coarse sample whose farthest depth
//!    occludes too (every finer texel it holds) keeps its border towards the background: its
//!    occluder ends there, and erosion would move the edge in by half the texel
//!    ([`shadowlab_core::backprojection::coarse_block_edges`]).
//! 3. **Radial area integration** (§4.2): each back-projected edge adds or removes the part of the
//!    emitter beyond it, seen from the emitter's centre, whose visibility comes from the same
//!    contour.
//! 4. **Light-space LOD** (§5.1, `lod`): the level where the kernel is at most `t_k` texels wide,
//!    blended with the next over a band `beta` of the continuous level λ (Eq. 3; the paper's
//!    second weight corrected to (1 − (1 − d)/β)/2, NOTES-002 §3).
//! 5. **Screen-space adaptive sampling** (§5.2, `adaptive`): penumbra pixels are computed on an
//!    ordered-dither pattern of `pattern`² where the penumbra is wider than `s_min` pixels on
//!    screen (Eqs. 4–6), always next to a depth or normal discontinuity, and the others filled by
//!    pull-push (`fill.wgsl`). The modern mapping of NOTES-002 §5: classify → append list →
//!    indirect dispatch → pull-push.
//!
//! 6. **Occluder layers** (beyond the paper, `layers`, `finer`): one level per pixel loses the small
//!    shadows of occluders near the receiver beside the wide penumbra of one near the light (the
//!    kernel, from the nearest occluder, sets the level). The occluders are cut by depth: those whose
//!    own kernel is at most the pixel's / 2^finer are traced `finer` levels finer over that kernel,
//!    and so on for up to `layers` layers, each about as costly as the first; the layers' visible
//!    fractions multiply ([`shadowlab_core::backprojection::occluder_layers`]), and their contours
//!    meet on the texel border where one body spans the cut
//!    ([`shadowlab_core::backprojection::layer_block_edges`]).
//!
//! The emitter's centre is tested against the contour where the receiver itself projects on the
//! map, not its biased lookup point: the edges are back-projected from the receiver, and both must
//! share one centre of projection or a contour between the two points counts half the emitter
//! twice or not at all.
//!
//! Emitters (DESIGN.md §3): a rectangle in its own plane, a sphere light as its disk facing the
//! pixel, the sun as its cone of directions in gnomonic projection (a disk of radius tan θ). The
//! CPU reference of the rules, with their unit tests, is [`shadowlab_core::backprojection`].
//!
//! Beyond the paper: the emitter's part below the receiver's tangent plane is hidden by the receiver
//! itself (the attached shadow at a terminator, which no depth map holds:
//! [`shadowlab_core::backprojection::fraction_above`]), combined with the contour's fraction by the
//! minimum; the receiver's plane (receiver-plane depth bias, Isidoro 2006) is extrapolated only
//! `plane_reach` texels, beyond which curved receivers leave it and it would hide real occluders;
//! nothing farther from the light than the receiver occludes it, nor anything on or behind a
//! rectangle light's plane (it emits on one side); the map holds the front faces; and
//! `show` writes the class, the level, the kernel, or the contour's or the horizon's fraction alone
//! instead of V, for analysis.
//!
//! Known limits: one depth layer (occluders hidden behind others in the map are missed, as in the
//! paper, §8); a point light's kernel stays on the cube face of the pixel, so penumbrae crossing a
//! face seam lose the edges beyond it.

use shadowlab_core::params::ParamDef;
use shadowlab_core::{Light, LightKind, ParamSet};

use crate::context::{Shared, storage_entry, uniform_entry};
use crate::frame::VisibilityLayer;
use crate::light_map::LightMap;
use crate::shadowmap::{CONSTANT_BIAS, lookup_layout};
use crate::technique::{FrameContext, Handover, ShadowTechnique, TechniqueError, TechniqueInfo, TechniqueStats};
use crate::timing::PassKind;

/// What `show` can put in the visibility layer instead of V (for analysis).
const SHOW: [&str; 6] = ["visibility", "class", "level", "kernel", "contour", "horizon"];

/// Loop iterations an invocation may make on a CPU adapter (`ssm.wgsl`, `loop_budget`): llvmpipe
/// ends every loop once the invocations running together have made 65 535 in all (Mesa gallivm,
/// `LP_MAX_TGSI_LOOP_ITERATIONS`), and cuts the contour short without a word; a tenth is kept
/// spare. Pixels within [`LIGHT_PIXEL_LOOPS`] are computed several to an invocation, within the
/// budget; the others one to an invocation, at a coarser level where even that would exceed it.
const CPU_LOOP_BUDGET: u32 = 60_000;

/// The most loop iterations (`ssm.wgsl`, `pixel_loops`) of a pixel computed several to an
/// invocation on a CPU adapter: a kernel of about 40 samples at the level used, or two blended of
/// about 28 (with the defaults most penumbra pixels are below), so that an invocation takes 9.
const LIGHT_PIXEL_LOOPS: u32 = 6_000;

/// Pixels per invocation with `dispatch=direct` on an adapter without a loop budget (a GPU).
const GPU_DIRECT_PIXELS: u32 = 8;

/// Pyramid levels the uniform has room for (maps up to 2^15 texels wide).
const MAX_LEVELS: usize = 16;
/// Views of one light (a cube's faces).
const MAX_VIEWS: usize = 6;

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "ssm",
    summary: "soft shadow mapping by back-projection: the map's occluder contours integrated over the emitter",
    source: "Guennebaud, Barthe, Paulin 2007 (NOTES-002)",
    params: &[
        // The paper's 1k² map (§7.1): the levels used are coarse anyway, and the pyramid is
        // rebuilt whenever the map is.
        ParamDef::int("map_size", 1024, 16, 8192, "shadow map resolution (texels per side)"),
        // Front faces and less bias than the other map techniques: the contour's receiver-plane
        // test (`threshold` in ssm.wgsl) keeps a receiver in the map from shadowing itself, and
        // the surfaces the truth sees are the ones whose contours matter (on the bunny's body the
        // back faces' penumbra error was 0.29 RMSE, the front faces' 0.15 on `azri`; README, `ssm`).
        ParamDef::choice("faces", "front", &["back", "front", "both"], "faces of closed meshes rendered into the map"),
        ParamDef::float("slope_bias", 0.5, 0.0, 20.0, "slope-scaled raster depth bias"),
        ParamDef::float("normal_offset", 0.15, 0.0, 10.0, "lookup offset along the surface normal, in texels"),
        CONSTANT_BIAS,
        ParamDef::float("t", 0.0, -1.0, 1.0, "contour on the finest level: 0 sample borders, 1 occluder centres"),
        ParamDef::float("t_coarse", 1.0, -1.0, 1.0, "contour on coarser levels (1 undoes the min depth's dilation)"),
        ParamDef::bool("lod", true, "light-space LOD: the pyramid level where the kernel is at most t_k texels"),
        // t_k is not given in the paper (NOTES-002 §3). 9 puts the room's penumbra RMSE below
        // `pcss`'s (0.0643 against 0.0675; 0.0678 at 8) and the bunny's 2–5 % lower than at 8;
        // 10–12 lower them further but widen the 1 m light's penumbra on `penumbra` by 6 % (its
        // square's border inside level 3's texels, README, `ssm`).
        ParamDef::float("t_k", 9.0, 1.0, 64.0, "widest kernel (texels of the level used) with lod"),
        ParamDef::float("beta", 0.05, 0.0, 0.5, "band of the continuous level over which two levels blend"),
        ParamDef::int(
            "layers",
            3,
            1,
            4,
            "with lod: occluder layers by depth, each traced `finer` levels finer than the one nearer the light (1: the paper's one level)",
        ),
        ParamDef::int("finer", 2, 1, 8, "with layers: how many levels finer each layer is traced"),
        ParamDef::float("max_kernel", 256.0, 2.0, 4096.0, "widest kernel (texels) without lod; wider is clipped"),
        ParamDef::int("iterations", 4, 1, 16, "kernel-tightening steps"),
        ParamDef::float(
            "plane_reach",
            2.0,
            0.0,
            1.0e9,
            "how far (texels) the receiver's plane is extrapolated when testing samples (receiver-plane bias)",
        ),
        ParamDef::bool("adaptive", true, "screen-space adaptive sampling with pull-push"),
        ParamDef::float(
            "s_min",
            16.0,
            1.0,
            1.0e9,
            "penumbra width on screen (pixels) where pixels start being skipped",
        ),
        ParamDef::choice("pattern", "4", &["2", "4", "8"], "width of the selection pattern"),
        ParamDef::choice(
            "records",
            "auto",
            &["auto", "off"],
            "each listed pixel's setup kept from classify for visibility: auto, where the list then fits one storage binding (128 MiB on CPU adapters and in browsers: outputs up to about 6.7 million pixels); off, set up again (the same result, slower)",
        ),
        ParamDef::choice(
            "dispatch",
            "auto",
            &["auto", "indirect", "direct"],
            "listed pixels per invocation of an indirect dispatch: indirect one, direct several (on CPU adapters as many as their loop budget holds, else 8); auto: several on CPU adapters",
        ),
        ParamDef::choice(
            "show",
            "visibility",
            &SHOW,
            "analysis: the visibility; lit 1, penumbra ½, umbra 0; the level used (⅛ per level); the kernel's width (1 at 256 texels); the contour's fraction alone; the horizon's alone (both on computed penumbra pixels)",
        ),
    ],
    light_types: super::ALL_LIGHTS,
    create,
    compose: None,
    fragment: false,
};

/// `Ssm` in `ssm.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct SsmUniform {
    contour: [f32; 4],
    adapt: [f32; 4],
    limits: [f32; 4],
    screen: [f32; 4],
    extra: [f32; 4],
    layers: [f32; 4],
    levels: [[u32; 4]; MAX_LEVELS],
    inv: [[[f32; 4]; 4]; MAX_VIEWS],
}

/// `Reduce` in `hsm.wgsl` and `Level` in `fill.wgsl`: the level written and the level read.
#[repr(C)]
#[derive(Clone, Copy, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct LevelUniform {
    dst: [u32; 4],
    src: [u32; 4],
}

/// A camera depth step of more than 5 % to a neighbour, or a normal turning by more than about
/// 25°, is a discontinuity that pull-push must not blur across (the paper's thresholded Sobel
/// filter does not give its thresholds).
const DEPTH_STEP: f32 = 0.05;
const NORMAL_COS: f32 = 0.9;

/// The depth pyramid over a light's maps: per view, levels 1… (level 0 is the map itself).
struct Pyramid {
    buffer: wgpu::Buffer,
    size: u32,
    views: u32,
    /// (offset in a view's block, side) of levels 1…; index 0 unused.
    levels: Vec<(u32, u32)>,
    per_view: u32,
    /// One reduction per level ≥ 1, with its bind group.
    reduce: Vec<wgpu::BindGroup>,
    /// The maps' (generation, shown version) it was built from.
    built: Option<(u32, u64)>,
}

/// Buffers sized by the output: the v-buffer and its pull-push pyramid, the pixel list, the
/// discontinuities.
struct Screen {
    width: u32,
    height: u32,
    /// Whether the list holds each listed pixel's setup behind its slots (`ssm.wgsl`, `record`):
    /// five words a pixel, which past about 6.7 million pixels (4K) outgrow the 128 MiB that a
    /// storage binding may hold on CPU adapters and in browsers; without, `visibility` sets each
    /// listed pixel up again (the same code: the same result, slower).
    recorded: bool,
    /// Offset and size of each pull-push level (0: the output).
    levels: Vec<(u32, u32, u32)>,
    own: wgpu::BindGroup,
    work: wgpu::Buffer,
    args: wgpu::Buffer,
    /// Group 3 per pull (k → k + 1), per push (k + 1 → k, k ≥ 1), the last push, and the
    /// write without pull-push.
    pulls: Vec<wgpu::BindGroup>,
    pushes: Vec<wgpu::BindGroup>,
    finish: wgpu::BindGroup,
    finish_plain: wgpu::BindGroup,
    bytes: u64,
}

struct Pipelines {
    /// The pyramid's level 1 from the map, and each further level from the last.
    reduce_map: wgpu::ComputePipeline,
    reduce: wgpu::ComputePipeline,
    edges: wgpu::ComputePipeline,
    classify: wgpu::ComputePipeline,
    args: wgpu::ComputePipeline,
    visibility: wgpu::ComputePipeline,
    heavy: wgpu::ComputePipeline,
    pull: wgpu::ComputePipeline,
    push: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
}

/// The emitter's normalised domain, compiled into `ssm.wgsl`'s pipelines (`DISK`): a CPU adapter
/// runs both branches of an `if` that varies, so one shape's code runs faster than both (lavapipe,
/// alternated runs with the select in `edge_term`: the bunny's rectangle light 146–159 → 121–122 ms).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum EmitterShape {
    /// A rectangle light: [−1, 1]², one-sided.
    Square,
    /// A sphere light's disk facing the pixel, the sun's cone of directions.
    Disk,
}

impl EmitterShape {
    fn of(light: &Light) -> Self {
        if matches!(light.kind, LightKind::Rect { .. }) { Self::Square } else { Self::Disk }
    }
}

struct Ssm {
    params: ParamSet,
    map: Option<LightMap>,
    pipelines: Pipelines,
    /// The shape `pipelines` were built for (a light replaced by one of another kind rebuilds them),
    /// and whether they record each listed pixel's setup ([`Screen::recorded`]).
    shape: EmitterShape,
    recorded: bool,
    uniform: wgpu::Buffer,
    values: SsmUniform,
    pyramid: Option<Pyramid>,
    screen: Option<Screen>,
    triangles: u64,
    /// Pyramid levels reduced by the last frame.
    reduced: u32,
    /// Whether the adapter ends loops past a budget ([`CPU_LOOP_BUDGET`]: CPU adapters).
    budgeted: bool,
}

fn own_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("ssm", || {
        let c = wgpu::ShaderStages::COMPUTE;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("ssm"),
            entries: &[
                uniform_entry(0, c),
                storage_entry(1, c, true),
                storage_entry(2, c, false),
                storage_entry(3, c, false),
                storage_entry(4, c, false),
                storage_entry(5, c, false),
            ],
        })
    })
}

/// Group 2 of `hsm.wgsl` and group 3 of `fill.wgsl`: a level uniform, one writable buffer, and
/// the nearest sampler (`hsm.wgsl`'s gathers).
fn level_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("ssm level", || {
        let c = wgpu::ShaderStages::COMPUTE;
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("ssm level"),
            entries: &[
                uniform_entry(0, c),
                storage_entry(1, c, false),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: c,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::NonFiltering),
                    count: None,
                },
            ],
        })
    })
}

fn pipelines(shared: &Shared, shape: EmitterShape, recorded: bool) -> Pipelines {
    let (lookup, own, level) = (lookup_layout(shared), own_layout(shared), level_layout(shared));
    let ssm = include_str!("ssm.wgsl");
    let fill = include_str!("fill.wgsl");
    let (mut suffix, mut defines) = match shape {
        EmitterShape::Square => (" square".to_string(), vec!["SQUARE_EMITTER"]),
        EmitterShape::Disk => (String::new(), vec![]),
    };
    if !recorded {
        suffix.push_str(" unrecorded");
        defines.push("UNRECORDED");
    }
    let defines = &defines[..];
    let main = |entry: &str| {
        shared.resolve_pipeline_with(&format!("ssm {entry}{suffix}"), ssm, entry, &[&lookup, &own], &[], defines)
    };
    let filled =
        |entry: &str| shared.resolve_pipeline(&format!("ssm {entry}"), fill, entry, &[&lookup, &own, &level], &[]);
    Pipelines {
        reduce_map: shared.resolve_pipeline(
            "ssm reduce map",
            include_str!("hsm.wgsl"),
            "from_map",
            &[&lookup, &level],
            &[],
        ),
        reduce: shared.resolve_pipeline("ssm reduce", include_str!("hsm.wgsl"), "from_level", &[&lookup, &level], &[]),
        edges: main("edges"),
        classify: main("classify"),
        visibility: main("visibility"),
        heavy: main("heavy"),
        args: filled("dispatch_args"),
        pull: filled("pull"),
        push: filled("push"),
        finish: filled("finish"),
    }
}

fn create(shared: &Shared, params: &ParamSet, light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let device = &shared.gpu.device;
    let pattern: u32 = params.choice("pattern").parse().unwrap_or(4);
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    let show = SHOW.iter().position(|&c| c == params.choice("show")).unwrap_or(0);
    let values = SsmUniform {
        contour: [
            params.float("t") as f32,
            params.float("t_coarse") as f32,
            params.float("t_k") as f32,
            params.float("beta") as f32,
        ],
        adapt: [flag(params.bool("lod")), flag(params.bool("adaptive")), params.float("s_min") as f32, pattern as f32],
        limits: [params.int("iterations") as f32, params.float("max_kernel") as f32, 0.0, 0.0],
        // Discontinuities force exact pixels as far as the pattern spaces them.
        screen: [DEPTH_STEP, NORMAL_COS, pattern as f32, show as f32],
        extra: [0.0, params.float("plane_reach") as f32, 0.0, 1.0],
        layers: [params.int("layers") as f32, params.int("finer") as f32, 0.0, 0.0],
        levels: [[0; 4]; MAX_LEVELS],
        inv: [[[0.0; 4]; 4]; MAX_VIEWS],
    };
    let budgeted = shared.gpu.adapter.device_type == "cpu";
    let mut values = values;
    values.extra = per_invocation(&values, params.choice("dispatch"), budgeted);
    let uniform = crate::util::uniform_buffer(device, "ssm", bytemuck::bytes_of(&values));
    Ok(Box::new(Ssm {
        params: params.clone(),
        map: None,
        pipelines: pipelines(shared, EmitterShape::of(light), true),
        shape: EmitterShape::of(light),
        recorded: true,
        uniform,
        values,
        pyramid: None,
        screen: None,
        triangles: 0,
        reduced: 0,
        budgeted,
    }))
}

/// `ssm.wgsl`'s `setup_loops` and `ROUND_LOOPS`.
fn setup_loops(iterations: f32) -> u32 {
    36 * (iterations as u32 + 3) + 20 + 40
}

/// The uniform's `extra` with its budget terms: x, the most loops of a pixel computed several to
/// an invocation; z, the loop budget (0: none); w, pixels per invocation at the front of the list.
/// `dispatch=indirect` takes one per invocation; `auto` several on CPU adapters only, as many as
/// the budget holds at [`LIGHT_PIXEL_LOOPS`] each with their `setup`; `direct` several anywhere.
fn per_invocation(v: &SsmUniform, dispatch: &str, budgeted: bool) -> [f32; 4] {
    let budget = if budgeted { CPU_LOOP_BUDGET } else { 0 };
    let several =
        if budgeted { CPU_LOOP_BUDGET / (LIGHT_PIXEL_LOOPS + setup_loops(v.limits[0])) } else { GPU_DIRECT_PIXELS };
    let per = match dispatch {
        "indirect" => 1,
        "direct" => several,
        _ if budgeted => several,
        _ => 1,
    };
    [LIGHT_PIXEL_LOOPS as f32, v.extra[1], budget as f32, per.max(1) as f32]
}

fn level_group(shared: &Shared, label: &str, value: LevelUniform, target: &wgpu::Buffer) -> wgpu::BindGroup {
    let device = &shared.gpu.device;
    let buffer = crate::util::uniform_buffer(device, label, bytemuck::bytes_of(&value));
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout: &level_layout(shared),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: target.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&shared.nearest) },
        ],
    })
}

fn storage(device: &wgpu::Device, label: &str, bytes: u64, extra: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(16),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | extra,
        mapped_at_creation: false,
    })
}

/// A clear error where the pyramid of `views` maps of side `size`, or the screen buffers of a
/// `width` × `height` output, would outgrow a storage binding on this device.
fn check_sizes(shared: &Shared, size: u32, views: u32, width: u32, height: u32) -> Result<(), TechniqueError> {
    let limit = shared.storage_binding_limit();
    let mib = |b: u64| b.div_ceil(1 << 20);
    let pyramid = Pyramid::bytes(size, views);
    if pyramid > limit {
        let fits = (1..=size.ilog2()).rev().map(|k| 1u32 << k).find(|&s| Pyramid::bytes(s, views) <= limit);
        let hint = fits.map_or(String::new(), |s| format!(": use map_size={s} or less"));
        let message = format!(
            "the depth pyramid over {views} view{} of {size}² needs {} MiB, and this device binds at most {} MiB{hint}",
            if views == 1 { "" } else { "s" },
            mib(pyramid),
            mib(limit)
        );
        return Err(TechniqueError::Failed { id: INFO.id.into(), message });
    }
    let (_, texels) = Screen::levels(width, height);
    let screen = (texels * 8).max(Screen::list_bytes(width, height, false));
    shared.check_output_buffer(INFO.id, "screen buffers", screen, width, height)
}

impl Pyramid {
    /// Bytes of the levels ≥ 1 of `views` maps of side `size`.
    fn bytes(size: u32, views: u32) -> u64 {
        let (mut side, mut texels) = (size, 0u64);
        while side > 1 {
            side = side.div_ceil(2);
            texels += u64::from(side) * u64::from(side);
        }
        texels.max(1) * u64::from(views) * 8
    }

    fn new(shared: &Shared, size: u32, views: u32) -> Self {
        let mut levels = vec![(0, size)];
        let mut offset = 0;
        let mut side = size;
        while side > 1 {
            side = side.div_ceil(2);
            levels.push((offset, side));
            offset += side * side;
        }
        let per_view = offset.max(1);
        let buffer =
            storage(&shared.gpu.device, "ssm hsm", u64::from(per_view * views) * 8, wgpu::BufferUsages::empty());
        let reduce = (1..levels.len())
            .map(|l| {
                let (src_offset, src_side) = levels[l - 1];
                let (dst_offset, dst_side) = levels[l];
                let value = LevelUniform {
                    dst: [l as u32, dst_offset, dst_side, per_view],
                    src: [l as u32 - 1, src_offset, src_side, 0],
                };
                level_group(shared, "ssm reduce", value, &buffer)
            })
            .collect();
        Self { buffer, size, views, levels, per_view, reduce, built: None }
    }

    fn top(&self) -> u32 {
        self.levels.len() as u32 - 1
    }
}

impl Screen {
    /// The pull-push levels (offset, width, height) of a `width` × `height` output, and the
    /// texels of all of them.
    fn levels(width: u32, height: u32) -> (Vec<(u32, u32, u32)>, u64) {
        let mut levels = vec![(0, width, height)];
        let (mut offset, mut w, mut h) = (u64::from(width) * u64::from(height), width, height);
        while w > 1 || h > 1 {
            (w, h) = (w.div_ceil(2), h.div_ceil(2));
            levels.push((offset as u32, w, h));
            offset += u64::from(w) * u64::from(h);
        }
        (levels, offset)
    }

    /// Bytes of the list with and without the setups recorded.
    fn list_bytes(width: u32, height: u32, recorded: bool) -> u64 {
        u64::from(width) * u64::from(height) * 4 * if recorded { 5 } else { 1 }
    }

    fn new(
        shared: &Shared,
        uniform: &wgpu::Buffer,
        hsm: &wgpu::Buffer,
        width: u32,
        height: u32,
        records: bool,
    ) -> Self {
        let device = &shared.gpu.device;
        let (levels, texels) = Self::levels(width, height);
        let pixels = u64::from(width) * u64::from(height);
        let recorded = records && Self::list_bytes(width, height, true) <= shared.storage_binding_limit();
        let vbuf = storage(device, "ssm v-buffer", texels * 8, wgpu::BufferUsages::empty());
        // The front of the list from slot 0 up, the heavy pixels from the last slot down; behind
        // the slots, each pixel's setup as `classify` found it (`ssm.wgsl`, `record`: 4 words).
        let list = storage(device, "ssm list", Self::list_bytes(width, height, recorded), wgpu::BufferUsages::empty());
        let flags = storage(device, "ssm discontinuities", pixels * 4, wgpu::BufferUsages::empty());
        let work = storage(device, "ssm work", 16, wgpu::BufferUsages::empty());
        // Two indirect dispatches: `visibility`'s at 0, `heavy`'s at 12.
        let args = storage(device, "ssm dispatch", 32, wgpu::BufferUsages::INDIRECT);
        let own = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("ssm"),
            layout: &own_layout(shared),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: hsm.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: vbuf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: work.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: list.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 5, resource: flags.as_entire_binding() },
            ],
        });
        let at = |(o, w, h): (u32, u32, u32)| [o, w, h, 0];
        let pair = |dst: usize, src: Option<usize>| LevelUniform {
            dst: at(levels[dst]),
            src: src.map_or([0; 4], |s| at(levels[s])),
        };
        let pulls =
            (0..levels.len() - 1).map(|k| level_group(shared, "ssm pull", pair(k + 1, Some(k)), &args)).collect();
        let pushes =
            (1..levels.len() - 1).rev().map(|k| level_group(shared, "ssm push", pair(k, Some(k + 1)), &args)).collect();
        let coarser = (levels.len() > 1).then_some(1);
        let finish = level_group(shared, "ssm finish", pair(0, coarser), &args);
        let finish_plain = level_group(shared, "ssm finish", pair(0, None), &args);
        let bytes = vbuf.size() + list.size() + flags.size() + work.size() + args.size();
        Self { width, height, recorded, levels, own, work, args, pulls, pushes, finish, finish_plain, bytes }
    }
}

impl Ssm {
    /// Fits the pyramid to the maps and the screen buffers to the output, and writes the uniform
    /// (levels, the shown views' inverses). Returns false when there is nothing to look up yet.
    fn fit(&mut self, ctx: &FrameContext<'_>) -> bool {
        let Some(maps) = self.map.as_ref().and_then(|m| m.maps.as_ref()) else { return false };
        let (size, views) = (maps.size(), maps.len());
        if self.pyramid.as_ref().is_none_or(|p| p.size != size || p.views != views) {
            self.pyramid = Some(Pyramid::new(ctx.shared, size, views));
            self.screen = None;
        }
        let pyramid = self.pyramid.as_ref().expect("made above");
        let (width, height) = (ctx.surface.width, ctx.surface.height);
        if self.screen.as_ref().is_none_or(|s| s.width != width || s.height != height) {
            let records = self.params.choice("records") != "off";
            self.screen = Some(Screen::new(ctx.shared, &self.uniform, &pyramid.buffer, width, height, records));
        }
        let v = &mut self.values;
        v.limits[2] = pyramid.top() as f32;
        v.limits[3] = pyramid.per_view as f32;
        for (l, &(offset, side)) in pyramid.levels.iter().enumerate().take(MAX_LEVELS) {
            v.levels[l] = [offset, side, 0, 0];
        }
        for i in 0..views.min(MAX_VIEWS as u32) {
            if let Some(view) = maps.shown_view(i) {
                // In f64: the inverse of a projection with a far/near ratio of thousands.
                v.inv[i as usize] = view.view_projection.as_dmat4().inverse().as_mat4().to_cols_array_2d();
            }
        }
        ctx.gpu.queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&self.values));
        maps.shown()
    }

    /// Rebuilds the pyramid when the maps it was built from changed.
    fn reduce(&mut self, ctx: &mut FrameContext<'_>, lookup: &wgpu::BindGroup, group0: &wgpu::BindGroup) {
        self.reduced = 0;
        let Some(maps) = self.map.as_ref().and_then(|m| m.maps.as_ref()) else { return };
        let Some(pyramid) = self.pyramid.as_mut() else { return };
        let version = (maps.generation(), maps.shown_version());
        if pyramid.built == Some(version) {
            return;
        }
        let timestamps = ctx.timer.compute_pass(&ctx.gpu.device, PassKind::Shadow);
        let mut pass = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("ssm pyramid"),
            timestamp_writes: timestamps,
        });
        pass.set_bind_group(0, Some(group0), &[]);
        pass.set_bind_group(1, Some(lookup), &[]);
        for (l, group) in pyramid.reduce.iter().enumerate() {
            let side = pyramid.levels[l + 1].1;
            pass.set_pipeline(if l == 0 { &self.pipelines.reduce_map } else { &self.pipelines.reduce });
            pass.set_bind_group(2, Some(group), &[]);
            pass.dispatch_workgroups(side.div_ceil(8), side.div_ceil(8), pyramid.views);
        }
        self.reduced = pyramid.reduce.len() as u32;
        pyramid.built = Some(version);
    }
}

impl ShadowTechnique for Ssm {
    fn id(&self) -> &'static str {
        INFO.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        let params = &self.params;
        let map = self.map.get_or_insert_with(|| LightMap::new(ctx.shared, params, false));
        map.update(ctx)?;
        self.triangles = ctx.gpu_scene.triangles;
        // A clear error rather than a failed binding later (storage bindings hold 128 MiB on CPU
        // adapters and in browsers: a cube of 4096² maps, or an output past about 12 million pixels).
        let (size, views) = map.maps.as_ref().map_or((1, 1), |m| (m.size(), m.len()));
        check_sizes(ctx.shared, size, views, ctx.surface.width, ctx.surface.height)
    }

    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        if !self.fit(ctx) {
            return;
        }
        let shape = EmitterShape::of(ctx.light);
        let recorded = self.screen.as_ref().is_none_or(|s| s.recorded);
        if (shape, recorded) != (self.shape, self.recorded) {
            self.pipelines = pipelines(ctx.shared, shape, recorded);
            (self.shape, self.recorded) = (shape, recorded);
        }
        let Some(lookup) = self.map.as_ref().and_then(LightMap::group).cloned() else { return };
        let group0 = ctx.shared.resolve_bind_group(ctx.surface, ctx.light_buffer, out);
        self.reduce(ctx, &lookup, &group0);
        let Some(screen) = self.screen.as_ref() else { return };
        let p = &self.pipelines;
        let adaptive = self.values.adapt[1] > 0.5;
        let (gx, gy) = (ctx.surface.width.div_ceil(8), ctx.surface.height.div_ceil(8));
        ctx.encoder.clear_buffer(&screen.work, 0, None);
        {
            // Classify every pixel; list the penumbra pixels to compute.
            let timestamps = ctx.timer.compute_pass(&ctx.gpu.device, PassKind::Visibility);
            let mut pass = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("ssm classify"),
                timestamp_writes: timestamps,
            });
            pass.set_bind_group(0, Some(&group0), &[]);
            pass.set_bind_group(1, Some(&lookup), &[]);
            pass.set_bind_group(2, Some(&screen.own), &[]);
            if adaptive {
                pass.set_pipeline(&p.edges);
                pass.dispatch_workgroups(gx, gy, 1);
            }
            pass.set_pipeline(&p.classify);
            pass.dispatch_workgroups(gx, gy, 1);
            pass.set_bind_group(3, Some(&screen.finish), &[]);
            pass.set_pipeline(&p.args);
            pass.dispatch_workgroups(1, 1, 1);
        }
        {
            // The listed pixels' visibility: the back-projection proper.
            let timestamps = ctx.timer.compute_pass(&ctx.gpu.device, PassKind::Visibility);
            let mut pass = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("ssm visibility"),
                timestamp_writes: timestamps,
            });
            pass.set_bind_group(0, Some(&group0), &[]);
            pass.set_bind_group(1, Some(&lookup), &[]);
            pass.set_bind_group(2, Some(&screen.own), &[]);
            pass.set_pipeline(&p.visibility);
            pass.dispatch_workgroups_indirect(&screen.args, 0);
            if self.budgeted {
                pass.set_pipeline(&p.heavy);
                pass.dispatch_workgroups_indirect(&screen.args, 12);
            }
        }
        let timestamps = ctx.timer.compute_pass(&ctx.gpu.device, PassKind::Visibility);
        let mut pass = ctx
            .encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("ssm fill"), timestamp_writes: timestamps });
        pass.set_bind_group(0, Some(&group0), &[]);
        pass.set_bind_group(1, Some(&lookup), &[]);
        pass.set_bind_group(2, Some(&screen.own), &[]);
        let dispatch = |pass: &mut wgpu::ComputePass<'_>, (_, w, h): (u32, u32, u32)| {
            pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        };
        if adaptive {
            pass.set_pipeline(&p.pull);
            for (k, group) in screen.pulls.iter().enumerate() {
                pass.set_bind_group(3, Some(group), &[]);
                dispatch(&mut pass, screen.levels[k + 1]);
            }
            pass.set_pipeline(&p.push);
            let count = screen.pushes.len();
            for (i, group) in screen.pushes.iter().enumerate() {
                pass.set_bind_group(3, Some(group), &[]);
                dispatch(&mut pass, screen.levels[count - i]);
            }
            pass.set_bind_group(3, Some(&screen.finish), &[]);
        } else {
            pass.set_bind_group(3, Some(&screen.finish_plain), &[]);
        }
        pass.set_pipeline(&p.finish);
        dispatch(&mut pass, screen.levels[0]);
    }

    fn stats(&self) -> TechniqueStats {
        let Some(m) = &self.map else { return TechniqueStats::default() };
        let (passes, draws, triangles) = m.counts(self.triangles);
        let pyramid = self.pyramid.as_ref().map_or(0, |p| p.buffer.size());
        let screen = self.screen.as_ref().map_or(0, |s| s.bytes);
        TechniqueStats {
            memory_bytes: m.bytes() + pyramid + screen + self.uniform.size(),
            passes: passes + u32::from(self.reduced > 0) + 3,
            draws,
            triangles,
            extra: vec![
                ("ssm_pyramid_levels_reduced".into(), f64::from(self.reduced)),
                // 1 while the list keeps each listed pixel's setup (`Screen::recorded`).
                ("ssm_setups_recorded".into(), f64::from(u8::from(self.screen.as_ref().is_some_and(|s| s.recorded)))),
            ],
        }
    }

    fn shown(&self) -> bool {
        self.map.as_ref().is_some_and(LightMap::shown)
    }

    fn current(&self) -> bool {
        self.map.as_ref().is_some_and(LightMap::current)
    }

    fn hand_over(&mut self) -> Option<Handover> {
        self.map.take().map(|m| Handover::Map(Box::new(m)))
    }

    /// Keeps a map-lookup technique's map of the same size (a slider moved, `pcss` → `ssm`).
    fn take_over(&mut self, shared: &Shared, handover: Handover) -> Result<(), Handover> {
        match handover {
            Handover::Map(mut map) if self.map.is_none() && map.fits(&self.params) => {
                map.set_params(shared, &self.params, false);
                self.map = Some(*map);
                Ok(())
            }
            other => Err(other),
        }
    }
}

// The uniform's layout is WGSL's: six vec4s, 16 level entries, 6 matrices.
const _: () = assert!(std::mem::size_of::<SsmUniform>() == 6 * 16 + MAX_LEVELS * 16 + MAX_VIEWS * 64);

#[cfg(test)]
mod tests {
    use super::*;

    /// `ssm.wgsl`'s bound on the loop iterations of `visibility_at` for a kernel `width` samples of
    /// its level wide (`level_loops`: tiles of 4 × 4 blocks, 35 per tile, 2 per row of tiles).
    fn level_loops(width: f32) -> u32 {
        let tiles = ((width + 2.0) / 4.0).clamp(0.0, 4096.0) as u32 + 2;
        tiles * (tiles * 35 + 2) + 2
    }

    /// The sizes the README and the parameter's help give against the 128 MiB that storage
    /// bindings hold on CPU adapters and in browsers: the list with the setups fits 2560 × 1440
    /// and not 3840 × 2160 (166 MB), without them 3840 × 2160 fits; a cube of 2048² maps has its
    /// pyramid bound and one of 4096² does not (268 MB), nor one 8192² view (179 MB). Fails with
    /// the record's words or the pyramid's levels miscounted.
    #[test]
    fn buffer_sizes_are_those_the_limits_are_stated_for() {
        let limit = 128u64 << 20;
        assert!(Screen::list_bytes(2560, 1440, true) <= limit);
        assert_eq!(Screen::list_bytes(3840, 2160, true), 165_888_000);
        assert!(Screen::list_bytes(3840, 2160, false) <= limit);
        let (levels, texels) = Screen::levels(3840, 2160);
        assert_eq!(levels.last().map(|l| (l.1, l.2)), Some((1, 1)));
        assert!(texels * 8 <= limit && texels > 8_294_400 * 4 / 3);
        assert!(Pyramid::bytes(2048, 6) <= limit);
        assert_eq!(Pyramid::bytes(4096, 6), 268_435_440);
        assert_eq!(Pyramid::bytes(8192, 1), 178_956_968);
    }

    fn uniform(iterations: f32) -> SsmUniform {
        SsmUniform {
            contour: [0.0, 1.0, 8.0, 0.05],
            adapt: [1.0, 1.0, 16.0, 4.0],
            limits: [iterations, 256.0, 10.0, 0.0],
            screen: [0.0; 4],
            extra: [0.0, 2.0, 0.0, 1.0],
            layers: [0.0; 4],
            levels: [[0; 4]; MAX_LEVELS],
            inv: [[[0.0; 4]; 4]; MAX_VIEWS],
        }
    }

    /// On a CPU adapter the pixels one invocation computes at the front of the list, each at its
    /// bound with its setup and its share of the loop, stay within the budget for every
    /// `iterations`; the defaults put several to an invocation (the point: its fixed cost shared).
    /// `indirect` keeps one everywhere; GPUs have no budget.
    #[test]
    fn an_invocation_stays_within_the_loop_budget() {
        for iterations in 1..=16 {
            let v = uniform(iterations as f32);
            for dispatch in ["auto", "direct", "indirect"] {
                let [light, _, budget, per] = per_invocation(&v, dispatch, true);
                assert_eq!((light as u32, budget as u32), (LIGHT_PIXEL_LOOPS, CPU_LOOP_BUDGET));
                let spent = per as u32 * (light as u32 + setup_loops(iterations as f32));
                assert!(spent <= CPU_LOOP_BUDGET, "{iterations} iterations, {dispatch}: {spent}");
            }
            assert_eq!(per_invocation(&v, "indirect", true)[3], 1.0);
        }
        // 60 000 / (6 000 + 98) = 9 pixels at the default 4 iterations; at least 8, so that an
        // invocation's fixed cost is shared about as the old unbounded loop shared it (8 at 128²).
        assert!(per_invocation(&uniform(4.0), "auto", true)[3] >= 8.0);
        assert_eq!(per_invocation(&uniform(4.0), "auto", false), [LIGHT_PIXEL_LOOPS as f32, 2.0, 0.0, 1.0]);
        // A 256-texel kernel without LOD is far past the front's bound: one to an invocation.
        assert!(level_loops(256.0) > LIGHT_PIXEL_LOOPS);
    }
}
