//! Shadow maps: a depth texture array (one layer per view: a cube face, a cascade, a sample) and
//! the depth-only pass that renders the shadow casters into a layer. Shared by every map-based
//! technique; the views come from [`shadowlab_core::lightspace`].

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec4};
use shadowlab_core::lightspace::ShadowView;
use shadowlab_core::params::ParamDef;
use shadowlab_core::{Aabb, Mobility};

use crate::context::Shared;
use crate::gpu_scene::{DrawGroup, INSTANCE_LAYOUT, Sidedness, VERTEX_LAYOUT};
use crate::technique::FrameContext;
use crate::timing::PassKind;

pub const SHADOW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A view as the lookup shaders see it (`shaders/shadowmap.wgsl`, `struct ShadowView`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct ShadowViewUniform {
    pub view_proj: [[f32; 4]; 4],
    pub eye: [f32; 4],
    pub axis: [f32; 4],
    /// x, y: the view's near and far distances (to turn stored depths back into distances); z: the
    /// texture layer that holds its map; w: 1 when the map stores `depth · (p, 1)` (a warped map's
    /// linear depth, `ShadowView::linear_depth`) instead of the projected depth.
    pub range: [f32; 4],
    pub depth: [f32; 4],
}

impl ShadowViewUniform {
    /// View `v` with its map in texture layer `layer`.
    pub fn new(v: &ShadowView, layer: u32) -> Self {
        Self {
            view_proj: v.view_projection.to_cols_array_2d(),
            eye: v.eye.extend(if v.orthographic { 1.0 } else { 0.0 }).into(),
            axis: v.axis.extend(v.texel_scale).into(),
            range: [v.near, v.far, layer as f32, if v.linear_depth.is_some() { 1.0 } else { 0.0 }],
            depth: v.linear_depth.unwrap_or(Vec4::ZERO).into(),
        }
    }
}

/// Which faces of closed meshes go into the map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FaceMode {
    /// Back faces (from the light): the map holds the far side of each closed object, so lit
    /// surfaces are far from the stored depth and do not self-shadow (Stingl 2011, §2.2).
    Back,
    Front,
    Both,
}

impl FaceMode {
    pub fn parse(text: &str) -> Self {
        match text {
            "front" => Self::Front,
            "both" => Self::Both,
            _ => Self::Back,
        }
    }
}

/// Rasterisation state of the depth pass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Raster {
    pub faces: FaceMode,
    /// Slope-scaled depth bias (in units of the primitive's depth slope), pushing stored depths
    /// away from the light.
    pub slope_bias: f32,
    /// Store each view's `ShadowView::linear_depth` (warped maps), written by the fragment shader
    /// with the slope bias applied there, instead of the rasterised projective depth.
    pub linear_depth: bool,
    /// Draw only the alpha-masked casters: the map of the casters `volumes` cannot extrude
    /// (its fallback for them).
    pub only_masked: bool,
}

/// Parameters shared by `hard`, `pcf` and the other map techniques (see [`map_params!`](crate::map_params)).
pub const MAP_SIZE: ParamDef = ParamDef::int("map_size", 2048, 16, 8192, "shadow map resolution (texels per side)");
pub const FACES: ParamDef =
    ParamDef::choice("faces", "back", &["back", "front", "both"], "faces of closed meshes rendered into the map");
pub const SLOPE_BIAS: ParamDef = ParamDef::float("slope_bias", 1.5, 0.0, 20.0, "slope-scaled raster depth bias");
pub const NORMAL_OFFSET: ParamDef =
    ParamDef::float("normal_offset", 0.3, 0.0, 10.0, "lookup offset along the surface normal, in texels");
pub const CONSTANT_BIAS: ParamDef =
    ParamDef::float("constant_bias", 0.0, 0.0, 10.0, "lookup offset towards the light, in world units");

/// A technique's parameter list: the shared map parameters followed by its own.
#[macro_export]
macro_rules! map_params {
    ($($own:expr),* $(,)?) => {
        &[
            $crate::shadowmap::MAP_SIZE,
            $crate::shadowmap::FACES,
            $crate::shadowmap::SLOPE_BIAS,
            $crate::shadowmap::NORMAL_OFFSET,
            $crate::shadowmap::CONSTANT_BIAS,
            $($own),*
        ]
    };
}

/// Lookup parameters, as the resolve shaders read them (`MapParams` in `shaders/maplookup.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, Default)]
pub struct BiasUniform {
    /// x: normal offset (texels); y: constant bias (world); z: map size; w: 1 when the map is a cube.
    pub values: Vec4,
    /// x: 1 for bilinear comparison taps.
    pub mode: Vec4,
}

/// Every mobility that permanent maps hold: temporary (dragged) objects have a pass of their own.
pub const PERMANENT: &[Mobility] = &[Mobility::Static, Mobility::Dynamic];

/// A depth texture array with the views it is rendered from.
pub struct ShadowMapArray {
    pub texture: wgpu::Texture,
    /// All layers, for sampling (`texture_depth_2d_array`).
    pub array_view: wgpu::TextureView,
    layer_views: Vec<wgpu::TextureView>,
    pub size: u32,
    pub layers: u32,
    /// View matrices for rendering, one 256-byte-aligned slot per view ([`RenderView`]).
    matrices: wgpu::Buffer,
    matrices_group: wgpu::BindGroup,
    /// The same slots with their linear-depth rows, for maps that store linear depth.
    linear_group: wgpu::BindGroup,
    stride: u64,
    /// `array<ShadowView>` for lookups.
    pub views: wgpu::Buffer,
    pub capacity: u32,
    /// Per slot, the clip matrix its passes render with (CPU side, to leave out the casters that
    /// cannot reach its window); `None` before the slot is set.
    clips: Vec<Option<Mat4>>,
}

impl ShadowMapArray {
    /// `layers` layers of `size`², and room for `capacity` views.
    pub fn new(shared: &Shared, size: u32, layers: u32, capacity: u32) -> Self {
        let device = &shared.gpu.device;
        let allocated = padded_layers(layers, shared.gpu.adapter.backend == "gl");
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("shadow maps"),
            size: wgpu::Extent3d { width: size, height: size, depth_or_array_layers: allocated },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: SHADOW_FORMAT,
            // Copies: cached static maps are copied before dynamic casters are drawn over them.
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let array_view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let layer_views = (0..layers)
            .map(|l| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: l,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let align = u64::from(device.limits().min_uniform_buffer_offset_alignment).max(16);
        let stride = (std::mem::size_of::<RenderView>() as u64).div_ceil(align) * align;
        let matrices = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shadow view matrices"),
            size: stride * u64::from(capacity.max(1)),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let layout = matrices_layout(shared);
        let matrices_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadow view matrices"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &matrices,
                    offset: 0,
                    size: std::num::NonZeroU64::new(64),
                }),
            }],
        });
        let linear_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadow view matrices (linear depth)"),
            layout: &linear_matrices_layout(shared),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &matrices,
                    offset: 0,
                    size: std::num::NonZeroU64::new(std::mem::size_of::<RenderView>() as u64),
                }),
            }],
        });
        // Without storage buffers (no compute: WebGL2) the lookups read a uniform array of
        // `UNIFORM_VIEWS` views (`shaders/maplookup.wgsl`).
        let (slots, usage) = if shared.compute {
            (capacity.max(1), wgpu::BufferUsages::STORAGE)
        } else {
            (capacity.max(UNIFORM_VIEWS), wgpu::BufferUsages::UNIFORM)
        };
        let views = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shadow views"),
            size: (std::mem::size_of::<ShadowViewUniform>() as u64) * u64::from(slots),
            usage: usage | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            texture,
            array_view,
            layer_views,
            size,
            layers,
            matrices,
            matrices_group,
            linear_group,
            stride,
            views,
            capacity,
            clips: vec![None; capacity as usize],
        }
    }

    /// Copies layer `from` into layer `to` (a cached static map under its composite copy).
    pub fn copy_layer(&self, encoder: &mut wgpu::CommandEncoder, from: u32, to: u32) {
        let at = |layer: u32| wgpu::TexelCopyTextureInfo {
            texture: &self.texture,
            mip_level: 0,
            origin: wgpu::Origin3d { x: 0, y: 0, z: layer },
            aspect: wgpu::TextureAspect::All,
        };
        encoder.copy_texture_to_texture(
            at(from),
            at(to),
            wgpu::Extent3d { width: self.size, height: self.size, depth_or_array_layers: 1 },
        );
    }

    /// The same array with `layers` layers (at least as many as now), the current ones copied over:
    /// the views, matrices and their buffers stay.
    pub fn grown(self, shared: &Shared, encoder: &mut wgpu::CommandEncoder, layers: u32) -> Self {
        let mut bigger = Self::new(shared, self.size, layers.max(self.layers), self.capacity);
        // Layer by layer: wgpu-core 30 records at most two barriers per copy, and the layers of a
        // used array may be in several states (one copy of all of them panics in `finish`).
        for layer in 0..self.layers {
            let at = |texture| wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d { x: 0, y: 0, z: layer },
                aspect: wgpu::TextureAspect::All,
            };
            encoder.copy_texture_to_texture(
                at(&self.texture),
                at(&bigger.texture),
                wgpu::Extent3d { width: self.size, height: self.size, depth_or_array_layers: 1 },
            );
        }
        // Keep the old buffers: they hold the views already written.
        bigger.matrices = self.matrices;
        bigger.matrices_group = self.matrices_group;
        bigger.linear_group = self.linear_group;
        bigger.views = self.views;
        bigger
    }

    /// Bytes held on the GPU.
    pub fn bytes(&self) -> u64 {
        u64::from(self.size) * u64::from(self.size) * u64::from(self.texture.depth_or_array_layers()) * 4
            + self.matrices.size()
            + self.views.size()
    }

    /// Stores `views` in slots `first..`, each view's map in the layer of its slot.
    pub fn set_views(&mut self, queue: &wgpu::Queue, first: u32, views: &[ShadowView]) {
        let layers: Vec<u32> = (first..first + views.len() as u32).collect();
        self.set_views_in(queue, first, views, &layers);
    }

    /// Stores `views` in slots `first..` with their maps in `layers` (views may share layers).
    pub fn set_views_in(&mut self, queue: &wgpu::Queue, first: u32, views: &[ShadowView], layers: &[u32]) {
        self.set_render_views(queue, first, views);
        let data: Vec<ShadowViewUniform> =
            views.iter().zip(layers).map(|(v, &layer)| ShadowViewUniform::new(v, layer)).collect();
        queue.write_buffer(
            &self.views,
            u64::from(first) * std::mem::size_of::<ShadowViewUniform>() as u64,
            bytemuck::cast_slice(&data),
        );
    }

    /// Stores the matrices passes render view slots `first..` with (not what lookups read: see
    /// [`ShadowMapArray::set_view_layer`]).
    pub fn set_render_views(&mut self, queue: &wgpu::Queue, first: u32, views: &[ShadowView]) {
        for (i, v) in views.iter().enumerate() {
            let slot = u64::from(first) + i as u64;
            queue.write_buffer(&self.matrices, slot * self.stride, bytemuck::bytes_of(&RenderView::new(v)));
            if let Some(clip) = self.clips.get_mut(slot as usize) {
                *clip = Some(v.view_projection);
            }
        }
    }

    /// What lookups of view `slot` read: `view` (the one its map was rendered with) in texture
    /// `layer`.
    pub fn set_view_layer(&self, queue: &wgpu::Queue, slot: u32, view: &ShadowView, layer: u32) {
        let u = ShadowViewUniform::new(view, layer);
        queue.write_buffer(
            &self.views,
            u64::from(slot) * std::mem::size_of::<ShadowViewUniform>() as u64,
            bytemuck::bytes_of(&u),
        );
    }

    /// Lets slot `slot` draw every caster, not only those that reach its view's window.
    pub fn draw_everything_in(&mut self, slot: u32) {
        if let Some(clip) = self.clips.get_mut(slot as usize) {
            *clip = None;
        }
    }

    /// Renders every permanent shadow caster into `layer` from the view in `slot`. Returns the
    /// draws issued.
    pub fn render(&self, ctx: &mut FrameContext<'_>, layer: u32, slot: u32, raster: &Raster) -> u32 {
        self.render_casters(ctx, layer, slot, raster, PERMANENT, true)
    }

    /// Renders the casters of the given mobilities into `layer` from the view in `slot`, over a
    /// cleared layer or over what it holds (`clear: false`: dynamic casters over a static copy).
    pub fn render_casters(
        &self,
        ctx: &mut FrameContext<'_>,
        layer: u32,
        slot: u32,
        raster: &Raster,
        classes: &[Mobility],
        clear: bool,
    ) -> u32 {
        self.render_tiles(ctx, layer, &[(slot, None)], raster, classes, clear)
    }

    /// Renders the casters of the given mobilities into `layer` from several views in one pass,
    /// each into its own viewport (`None`: the whole layer): an atlas of small maps, such as the
    /// dragged objects' one per light, costs one pass instead of one per view. Returns the draws
    /// issued.
    pub fn render_tiles(
        &self,
        ctx: &mut FrameContext<'_>,
        layer: u32,
        tiles: &[(u32, Option<[u32; 4]>)],
        raster: &Raster,
        classes: &[Mobility],
        clear: bool,
    ) -> u32 {
        let timestamps = ctx.timer.render_pass(&ctx.gpu.device, PassKind::Shadow);
        // Reversed Z: 0 is "infinitely far", every caster is closer.
        let load = if clear { wgpu::LoadOp::Clear(0.0) } else { wgpu::LoadOp::Load };
        let mut pass = ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("shadow map"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.layer_views[layer as usize],
                depth_ops: Some(wgpu::Operations { load, store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        ctx.gpu_scene.bind(&mut pass);
        let group = if raster.linear_depth { &self.linear_group } else { &self.matrices_group };
        let mut draws = 0;
        for &(slot, viewport) in tiles {
            if let Some([x, y, w, h]) = viewport {
                pass.set_viewport(x as f32, y as f32, w as f32, h as f32, 0.0, 1.0);
                // The viewport maps the view's window onto the tile; what lies outside the window
                // must not reach the neighbours.
                pass.set_scissor_rect(x, y, w, h);
            }
            pass.set_bind_group(0, Some(group), &[(u64::from(slot) * self.stride) as u32]);
            // Only the casters that can reach the view's window: a cube face or a fitted frustum
            // sees a part of the scene, and a CPU rasteriser pays for every vertex it is given.
            let keep = self.clips.get(slot as usize).copied().flatten().map(|clip| {
                let mut keep = vec![false; ctx.gpu_scene.slots.iter().map(|&s| s as usize + 1).max().unwrap_or(0)];
                for (&s, state) in ctx.gpu_scene.slots.iter().zip(ctx.live.instances()) {
                    keep[s as usize] = meets_window(&clip, &state.bounds);
                }
                keep
            });
            let mut current: Option<(wgpu::Face, bool, bool, bool)> = None;
            for g in ctx.gpu_scene.casters(classes).filter(|g| !raster.only_masked || g.mask.is_some()) {
                let cull = cull_mode(g, raster.faces);
                let mask = g.mask.zip(ctx.gpu_scene.masks.as_ref());
                let key = (cull.unwrap_or(wgpu::Face::Front), cull.is_none(), g.mirrored, mask.is_some());
                if current != Some(key) {
                    pass.set_pipeline(&depth_pipeline(ctx.shared, cull, g.mirrored, mask.is_some(), raster));
                    current = Some(key);
                }
                if let Some((k, masks)) = mask {
                    pass.set_bind_group(1, Some(&masks.group), &[k * masks.stride]);
                }
                match &keep {
                    Some(keep) => draws += ctx.gpu_scene.draw_kept(&mut pass, std::iter::once(g), keep),
                    None => {
                        ctx.gpu_scene.draw(&mut pass, std::iter::once(g));
                        draws += 1;
                    }
                }
            }
        }
        draws
    }
}

/// Whether box `b` can put a fragment in the window of the view with clip matrix `clip`: it is not
/// wholly beyond one of the four side planes. In clip space x = ±w and y = ±w are planes of the
/// world whatever w's sign, so testing the corners is exact; a relative margin keeps round-off
/// from losing a caster that touches a side. Depth is not tested: casters before the near plane
/// still cast (their depth is clamped).
pub fn meets_window(clip: &Mat4, b: &Aabb) -> bool {
    let corners = b.corners().map(|c| *clip * c.extend(1.0));
    let beyond = |f: &dyn Fn(Vec4) -> (f32, f32)| {
        corners.iter().all(|&c| {
            let (d, w) = f(c);
            d - w > 1e-5 * (d.abs() + w.abs()) + 1e-9
        })
    };
    !(beyond(&|c| (c.x, c.w)) || beyond(&|c| (-c.x, c.w)) || beyond(&|c| (c.y, c.w)) || beyond(&|c| (-c.y, c.w)))
}

/// The layers to allocate for `layers` maps, so that no backend takes the array for a cube map.
/// wgpu's GL backend guesses a texture's GL target from its layer count (gfx-rs/wgpu#7428): 1 layer
/// is a 2D texture, 6 square layers a cube map, more than 6 in multiples of 6 a cube-map array, and
/// a 2D-array view of any of those reads nothing (every sample's map "lit"). One spare layer
/// makes them plain arrays. Vulkan keeps the count.
pub(crate) fn padded_layers(layers: u32, gl: bool) -> u32 {
    let cube_like = layers == 1 || layers == 6 || (layers > 6 && layers.is_multiple_of(6));
    if gl && cube_like { layers + 1 } else { layers }
}

/// Culling for a draw group: closed meshes follow the face mode; open and double-sided ones are
/// drawn whole (either side may face the light).
fn cull_mode(g: &DrawGroup, faces: FaceMode) -> Option<wgpu::Face> {
    match (g.sidedness, faces) {
        (Sidedness::Closed, FaceMode::Back) => Some(wgpu::Face::Front),
        (Sidedness::Closed, FaceMode::Front) => Some(wgpu::Face::Back),
        _ => None,
    }
}

/// What a depth pass reads of its view (`shaders/shadow_depth_linear.wgsl`; the plain depth pass
/// reads the matrix only).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct RenderView {
    view_projection: [[f32; 4]; 4],
    /// `ShadowView::linear_depth` (zero when the view has none).
    depth: [f32; 4],
}

impl RenderView {
    fn new(v: &ShadowView) -> Self {
        Self {
            view_projection: v.view_projection.to_cols_array_2d(),
            depth: v.linear_depth.unwrap_or(Vec4::ZERO).into(),
        }
    }
}

/// Group 0 of linear-depth passes: a view's matrix and depth row per layer, by dynamic offset.
fn linear_matrices_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("shadow view matrices (linear depth)", || {
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadow view matrices (linear depth)"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: std::num::NonZeroU64::new(std::mem::size_of::<RenderView>() as u64),
                },
                count: None,
            }],
        })
    })
}

/// Group 0 of depth-only passes: one view-projection matrix per layer, by dynamic offset.
pub(crate) fn matrices_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("shadow view matrices", || {
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadow view matrices"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: std::num::NonZeroU64::new(64),
                },
                count: None,
            }],
        })
    })
}

/// The depth pass's pipeline for casters culled by `cull`, wound `mirrored`, rasterised by
/// `raster`; `masked`: alpha-masked casters, whose fragment stage drops the mask's holes
/// (`shaders/alpha_mask.wgsl`, group 1).
pub(crate) fn depth_pipeline(
    shared: &Shared,
    cull: Option<wgpu::Face>,
    mirrored: bool,
    masked: bool,
    raster: &Raster,
) -> wgpu::RenderPipeline {
    let (slope_bias, linear) = (raster.slope_bias, raster.linear_depth);
    let key = format!(
        "shadow depth {cull:?} mirrored={mirrored} masked={masked} slope={} linear={linear}",
        slope_bias.to_bits()
    );
    shared.render_pipeline(&key, || {
        let device = &shared.gpu.device;
        let (module, layout) = if linear {
            let source = include_str!("shaders/shadow_depth_linear.wgsl");
            (crate::shader::module(device, "shadow depth (linear)", source), linear_matrices_layout(shared))
        } else {
            (
                crate::shader::module(device, "shadow depth", include_str!("shaders/shadow_depth.wgsl")),
                matrices_layout(shared),
            )
        };
        // The linear shader applies the slope bias to the depth it writes (a written depth takes
        // no raster bias).
        let constants = [("slope_bias", f64::from(slope_bias))];
        let masks = crate::gpu_scene::mask_layout(device);
        let groups: &[Option<&wgpu::BindGroupLayout>] =
            if masked { &[Some(&layout), Some(&masks)] } else { &[Some(&layout)] };
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadow depth"),
            bind_group_layouts: groups,
            immediate_size: 0,
        });
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(&key),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some(if masked { "vs_masked" } else { "vs_main" }),
                compilation_options: Default::default(),
                buffers: &[Some(VERTEX_LAYOUT), Some(INSTANCE_LAYOUT)],
            },
            primitive: wgpu::PrimitiveState {
                cull_mode: cull,
                front_face: if mirrored { wgpu::FrontFace::Cw } else { wgpu::FrontFace::Ccw },
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: SHADOW_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                // Reversed Z: a negative bias pushes stored depths away from the light.
                bias: wgpu::DepthBiasState {
                    constant: 0,
                    slope_scale: if linear { 0.0 } else { -slope_bias },
                    clamp: 0.0,
                },
            }),
            multisample: Default::default(),
            fragment: (linear || masked).then(|| wgpu::FragmentState {
                module: &module,
                entry_point: Some(if masked { "fs_masked" } else { "fs_main" }),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: if linear { &constants } else { &[] },
                    ..Default::default()
                },
                targets: &[],
            }),
            multiview_mask: None,
            cache: None,
        })
    })
}

/// The views a lookup reads from a uniform array where there are no storage buffers (WebGL2).
pub const UNIFORM_VIEWS: u32 = 16;

/// The group-1 layout of `shaders/maplookup.wgsl`.
pub fn lookup_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("map lookup", || {
        let c = shared.resolve_stage();
        let entries = {
            let mut entries = vec![
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: c,
                    ty: wgpu::BindingType::Texture {
                        sample_type: if shared.hardware_compare {
                            wgpu::TextureSampleType::Depth
                        } else {
                            wgpu::TextureSampleType::Float { filterable: false }
                        },
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
                if shared.compute {
                    crate::context::storage_entry(2, c, true)
                } else {
                    crate::context::uniform_entry(2, c)
                },
                // A uniform, as storage buffers are few (8 a stage on the web; `ssm` uses them all).
                crate::context::uniform_entry(3, c),
            ];
            if shared.hardware_compare {
                entries.push(wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: c,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
                    count: None,
                });
            }
            entries
        };
        shared
            .gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("map lookup"), entries: &entries })
    })
}

/// The group-1 bind group of `shaders/maplookup.wgsl`; `linear` selects bilinear comparison taps.
pub fn lookup_group(shared: &Shared, maps: &ShadowMapArray, params: &wgpu::Buffer, linear: bool) -> wgpu::BindGroup {
    let mut entries = vec![
        wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&maps.array_view) },
        wgpu::BindGroupEntry { binding: 2, resource: maps.views.as_entire_binding() },
        wgpu::BindGroupEntry { binding: 3, resource: params.as_entire_binding() },
    ];
    if shared.hardware_compare {
        let sampler = if linear { &shared.compare_linear } else { &shared.compare_nearest };
        entries.push(wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(sampler) });
    }
    shared.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("map lookup"),
        layout: &lookup_layout(shared),
        entries: &entries,
    })
}

pub fn selection_layout(shared: &Shared) -> wgpu::BindGroupLayout {
    shared.layout("selection", || {
        shared.gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("selection"),
            entries: &[crate::context::uniform_entry(0, shared.resolve_stage())],
        })
    })
}

/// `selection.wgsl`'s uniform for a single map (or cube): one "split" covering every depth.
pub fn single_selection(shared: &Shared) -> wgpu::BindGroup {
    let mut data = [0f32; 24];
    data[0] = 1.0;
    data[5] = f32::MAX;
    let buffer = crate::util::uniform_buffer(&shared.gpu.device, "single selection", bytemuck::cast_slice(&data));
    shared.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("single selection"),
        layout: &selection_layout(shared),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() }],
    })
}

#[cfg(test)]
mod tests {
    use super::{meets_window, padded_layers};
    use glam::Vec3;
    use shadowlab_core::Aabb;
    use shadowlab_core::lightspace::ShadowView;

    /// A small deterministic generator (xorshift) for reproducible random boxes.
    fn next(state: &mut u64) -> f32 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A box left out of a view has no point in its window (points of the box tested on a grid,
    /// behind the eye too), and a box with a point well inside the window is kept: for a cube
    /// face and for an orthographic view. Culling that drops a box whose corner alone reaches
    /// the window fails the first check; culling nothing fails the count of boxes left out.
    #[test]
    fn a_caster_is_left_out_only_when_no_point_of_it_reaches_the_window() {
        let eye = Vec3::new(0.3, 2.0, -0.4);
        let views = [
            ShadowView::perspective(eye, Vec3::NEG_Y, 90f32.to_radians(), 0.05, 20.0, 256),
            ShadowView::perspective(eye, Vec3::new(1.0, -0.2, 0.1).normalize(), 90f32.to_radians(), 0.05, 20.0, 256),
        ];
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for view in views {
            let clip = view.view_projection;
            let (mut out, mut kept) = (0, 0);
            for _ in 0..2000 {
                let c = Vec3::new(next(&mut state), next(&mut state), next(&mut state)) * 8.0 - Vec3::splat(4.0);
                let h = Vec3::new(next(&mut state), next(&mut state), next(&mut state)) * 0.6;
                let b = Aabb::new(c - h, c + h);
                let inside = |p: Vec3| {
                    let q = clip * p.extend(1.0);
                    q.x.abs() <= q.w && q.y.abs() <= q.w && q.w > 0.0
                };
                let n = 6;
                let points = (0..=n).flat_map(|i| {
                    (0..=n).flat_map(move |j| {
                        (0..=n)
                            .map(move |k| b.min + (b.max - b.min) * Vec3::new(i as f32, j as f32, k as f32) / n as f32)
                    })
                });
                let any_inside = points.clone().any(inside);
                if meets_window(&clip, &b) {
                    kept += 1;
                } else {
                    out += 1;
                    assert!(!any_inside, "{b:?} was left out, yet reaches the window");
                }
                if points.clone().any(|p| {
                    let q = clip * p.extend(1.0);
                    q.x.abs() < 0.9 * q.w && q.y.abs() < 0.9 * q.w && q.w > 0.0
                }) {
                    assert!(meets_window(&clip, &b), "{b:?} is well inside the window");
                }
            }
            // Measured: 1032 and 1573 of the 2000 boxes left out (968 and 427 kept) for the two
            // faces; both counts bounded well below, so that neither check is vacuous.
            assert!(out > 200 && kept > 200, "{out} left out, {kept} kept");
        }
    }

    #[test]
    fn no_gl_array_is_allocated_with_a_cube_like_layer_count() {
        for layers in 1..=100 {
            let n = padded_layers(layers, true);
            assert!(n == layers || n == layers + 1);
            assert!(n != 1 && n != 6 && (n < 6 || !n.is_multiple_of(6)), "{layers} → {n}");
            assert_eq!(padded_layers(layers, false), layers, "Vulkan keeps {layers}");
        }
        // Plain counts stay as they are on GL too: cascades, samples.
        assert_eq!([2, 4, 16, 25].map(|l| padded_layers(l, true)), [2, 4, 16, 25]);
    }
}
