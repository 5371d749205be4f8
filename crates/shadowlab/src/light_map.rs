//! A light's hard shadow map from its centre, cached across frames: the views of
//! [`light_frusta`] (six cube faces, one cone or one orthographic box, fitted to the scene's bounds)
//! in a [`MapViews`], with the bias uniform and the bind groups of `shaders/maplookup.wgsl`. Used by
//! `hard`, `pcf`, `pcss`, `blurred`, `smoothies` and `volumes` (cropped receivers).

use glam::Vec4;
use shadowlab_core::lightspace::{LightFrusta, light_frusta};
use shadowlab_core::{Aabb, Light, ParamSet};

use crate::context::Shared;
use crate::live::MapViews;
use crate::live::validity::hash_values;
use crate::shadowmap::{BiasUniform, FaceMode, Raster, lookup_group, single_selection};
use crate::technique::{FrameContext, TechniqueError};

/// The layers a light map of `views` views asks the memory budget for: a static layer each, and
/// as many composite copies when dynamic casters exist (the most `MapViews` can hold).
fn layers_asked(views: u32, dynamic: bool) -> u32 {
    views * if dynamic { 2 } else { 1 }
}

pub struct LightMap {
    /// `None` until the first update (the views need the light and the scene's bounds).
    pub maps: Option<MapViews>,
    pub frusta: LightFrusta,
    pub raster: Raster,
    /// The size the parameters ask for, and the one allocated (smaller when the memory budget's
    /// share of this light does not hold the asked one).
    size: u32,
    granted: u32,
    linear: bool,
    bias: BiasUniform,
    params: wgpu::Buffer,
    group: Option<(wgpu::BindGroup, u32)>,
    /// One map (or one cube) for `shaders/selection.wgsl`.
    pub selection: wgpu::BindGroup,
    /// Views rendered by the last update.
    rendered: u32,
}

impl LightMap {
    /// From the map parameters in `p` (`map_size`, `faces`, `slope_bias`, `normal_offset`,
    /// `constant_bias`); `linear` selects bilinear comparison taps (2 × 2 PCF) over nearest ones.
    pub fn new(shared: &Shared, p: &ParamSet, linear: bool) -> Self {
        let size = p.int("map_size") as u32;
        let bias = BiasUniform {
            values: Vec4::new(p.float("normal_offset") as f32, p.float("constant_bias") as f32, size as f32, 0.0),
            mode: Vec4::new(if linear { 1.0 } else { 0.0 }, 0.0, 0.0, 0.0),
        };
        let params = crate::util::uniform_buffer(&shared.gpu.device, "map params", bytemuck::bytes_of(&bias));
        let raster = Raster {
            faces: FaceMode::parse(p.choice("faces")),
            slope_bias: p.float("slope_bias") as f32,
            linear_depth: false,
            only_masked: false,
        };
        Self {
            maps: None,
            frusta: LightFrusta { views: Vec::new(), cube: false },
            raster,
            size,
            granted: size,
            linear,
            bias,
            params,
            group: None,
            selection: single_selection(shared),
            rendered: 0,
        }
    }

    /// Whether a technique with parameters `p` can keep this map: the same map size (the
    /// allocation); faces and slope bias may differ (they are in every view's signature).
    pub fn fits(&self, p: &ParamSet) -> bool {
        p.int("map_size") as u32 == self.size
    }

    /// Takes the parameters of a technique that keeps this map ([`LightMap::fits`]): the lookup's
    /// offsets and taps at once, the raster state for the next update (views whose signature it
    /// changes are re-rendered then).
    pub fn set_params(&mut self, shared: &Shared, p: &ParamSet, linear: bool) {
        debug_assert!(self.fits(p));
        self.raster = Raster {
            faces: FaceMode::parse(p.choice("faces")),
            slope_bias: p.float("slope_bias") as f32,
            linear_depth: false,
            only_masked: self.raster.only_masked,
        };
        self.bias.values.x = p.float("normal_offset") as f32;
        self.bias.values.y = p.float("constant_bias") as f32;
        self.bias.mode.x = if linear { 1.0 } else { 0.0 };
        shared.gpu.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&self.bias));
        if linear != self.linear {
            // The lookup group holds the sampler that does the comparison taps.
            self.linear = linear;
            self.group = None;
        }
    }

    /// The maps a light map with parameters `p` asks for on `light`: their size and how many
    /// (its views, twice as many when `dynamic` casters may need composite copies).
    pub fn demand(p: &ParamSet, light: &Light, bounds: &Aabb, dynamic: bool) -> (u32, u32) {
        let size = p.int("map_size") as u32;
        (size, layers_asked(light_frusta(light, bounds, size).views.len() as u32, dynamic))
    }

    /// The size of the maps allocated (the asked one unless the memory budget cut it).
    pub fn granted_size(&self) -> u32 {
        self.granted
    }

    /// Fits the views to the light and the scene as they are now and renders the layers that are
    /// not valid. Returns the views rendered.
    pub fn update(&mut self, ctx: &mut FrameContext<'_>) -> Result<u32, TechniqueError> {
        let mut frusta = light_frusta(ctx.light, &ctx.gpu_scene.bounds, self.size);
        let n = frusta.views.len() as u32;
        let layers = layers_asked(n, ctx.live.has_dynamic_casters());
        let size = ctx.cache.grant_map_size(ctx.light_id, ctx.owner, self.size, layers);
        if size != self.size {
            frusta = light_frusta(ctx.light, &ctx.gpu_scene.bounds, size);
        }
        if self.maps.as_ref().is_none_or(|m| m.len() != n || m.size() != size) {
            if let Some(old) = &self.maps {
                old.forget_items(ctx);
            }
            self.maps = Some(MapViews::new(ctx.shared, ctx.cache, size, n));
            self.group = None;
        }
        self.granted = size;
        let cube = if frusta.cube { 1.0 } else { 0.0 };
        if self.bias.values.w != cube || self.bias.values.z != size as f32 {
            self.bias.values.w = cube;
            // Offsets are in texels of the map allocated.
            self.bias.values.z = size as f32;
            ctx.gpu.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&self.bias));
        }
        let maps = self.maps.as_mut().expect("made above");
        // The lookup offsets (normal offset, constant bias) do not change the maps' depths.
        let extra = hash_values(&[f64::from(size)]);
        self.rendered = maps.update(ctx, &frusta.views, &self.raster, extra)?;
        if self.group.as_ref().is_none_or(|g| g.1 != maps.generation()) {
            self.group = Some((lookup_group(ctx.shared, &maps.maps, &self.params, self.linear), maps.generation()));
        }
        self.frusta = frusta;
        Ok(self.rendered)
    }

    /// Whether the maps have a complete state to show.
    pub fn shown(&self) -> bool {
        self.maps.as_ref().is_some_and(MapViews::shown)
    }

    /// Whether the maps shown hold the current state.
    pub fn current(&self) -> bool {
        self.maps.as_ref().is_some_and(MapViews::current)
    }

    /// Group 1 of `shaders/maplookup.wgsl` (after the first update).
    pub fn group(&self) -> Option<&wgpu::BindGroup> {
        self.group.as_ref().map(|g| &g.0)
    }

    pub fn bytes(&self) -> u64 {
        self.maps.as_ref().map_or(0, MapViews::bytes) + self.params.size()
    }

    /// Passes, draws and triangles of the last update.
    pub fn counts(&self, gpu_scene_triangles: u64) -> (u32, u32, u64) {
        let draws = self.maps.as_ref().map_or(0, |m| m.draws);
        (self.rendered, draws, gpu_scene_triangles * u64::from(self.rendered))
    }
}
