//! The shape shared by `hard`, `pcf`, `pcss` and `blurred`: one hard map from the light's centre
//! ([`LightMap`]) and one resolve that looks it up (a compute pass, or a fragment pass where the
//! device has no compute: `hard`, `pcf` and `pcss` have that path), with an optional bind group of the
//! technique's own (group 2: a filter kernel, PCSS's taps). The modules differ only in their WGSL
//! and that group.

use shadowlab_core::ParamSet;

use crate::context::{ResolveProgram, Shared};
use crate::frame::VisibilityLayer;
use crate::light_map::LightMap;
use crate::technique::{
    FrameContext, Handover, MapAnalysis, ShadowTechnique, TechniqueError, TechniqueStats, dispatch_program_in,
};

/// Rewrites the part of a technique's own uniform that depends on the light (PCSS's emitter size),
/// when the light's emitter changes.
pub(super) type OnLight = fn(&shadowlab_core::Light, &wgpu::Queue, &wgpu::Buffer);

pub(super) struct MapLookup {
    id: &'static str,
    params: ParamSet,
    /// Bilinear comparison taps (2 × 2 PCF) rather than nearest ones.
    linear: bool,
    map: Option<LightMap>,
    pipeline: ResolveProgram,
    /// The technique's group 2 and the bytes its buffers hold.
    own: Option<(wgpu::BindGroup, u64)>,
    /// The own uniform's light-dependent part, and the emitter version it was written for.
    on_light: Option<(OnLight, wgpu::Buffer, u64)>,
    triangles: u64,
}

impl MapLookup {
    pub fn boxed(
        id: &'static str,
        params: &ParamSet,
        linear: bool,
        pipeline: ResolveProgram,
        own: Option<(wgpu::BindGroup, u64)>,
    ) -> Box<dyn ShadowTechnique> {
        Box::new(Self { id, params: params.clone(), linear, map: None, pipeline, own, on_light: None, triangles: 0 })
    }

    /// [`MapLookup::boxed`] whose own uniform `buffer` follows the light through `on_light`.
    pub fn boxed_with_light(
        id: &'static str,
        params: &ParamSet,
        linear: bool,
        pipeline: ResolveProgram,
        own: (wgpu::BindGroup, u64),
        on_light: OnLight,
        buffer: wgpu::Buffer,
    ) -> Box<dyn ShadowTechnique> {
        Box::new(Self {
            id,
            params: params.clone(),
            linear,
            map: None,
            pipeline,
            own: Some(own),
            on_light: Some((on_light, buffer, 0)),
            triangles: 0,
        })
    }
}

impl ShadowTechnique for MapLookup {
    fn id(&self) -> &'static str {
        self.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        let (params, linear) = (&self.params, self.linear);
        let map = self.map.get_or_insert_with(|| LightMap::new(ctx.shared, params, linear));
        map.update(ctx)?;
        if let Some((update, buffer, version)) = &mut self.on_light {
            let now = ctx.live.light_state(ctx.light_id).map_or(0, |s| s.emitter_version);
            if *version != now {
                update(ctx.light, &ctx.gpu.queue, buffer);
                *version = now;
            }
        }
        self.triangles = ctx.gpu_scene.triangles;
        Ok(())
    }

    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let Some(group) = self.map.as_ref().and_then(LightMap::group) else { return };
        let group0 = ctx.resolve_group(out);
        match &self.own {
            Some((own, _)) => dispatch_program_in(ctx, self.id, &self.pipeline, &[&group0, group, own], out),
            None => dispatch_program_in(ctx, self.id, &self.pipeline, &[&group0, group], out),
        }
    }

    /// One map lookup (a fixed kernel) at the pixel's own surface point.
    fn resolves_per_pixel(&self) -> bool {
        true
    }

    fn map_demand(
        &self,
        light: &shadowlab_core::Light,
        bounds: &shadowlab_core::Aabb,
        dynamic: bool,
    ) -> Option<(u32, u32)> {
        Some(LightMap::demand(&self.params, light, bounds, dynamic))
    }

    fn stats(&self) -> TechniqueStats {
        let Some(m) = &self.map else { return TechniqueStats::default() };
        let (passes, draws, triangles) = m.counts(self.triangles);
        TechniqueStats {
            memory_bytes: m.bytes() + self.own.as_ref().map_or(0, |o| o.1),
            passes: passes + 1,
            draws,
            triangles,
            extra: Vec::new(),
        }
    }

    fn shown(&self) -> bool {
        self.map.as_ref().is_some_and(LightMap::shown)
    }

    fn current(&self) -> bool {
        self.map.as_ref().is_some_and(LightMap::current)
    }

    fn analysis(&self) -> Option<MapAnalysis<'_>> {
        let m = self.map.as_ref()?;
        Some(MapAnalysis { lookup: m.group()?, selection: &m.selection, views: &m.frusta.views })
    }

    fn hand_over(&mut self) -> Option<Handover> {
        self.map.take().map(|m| Handover::Map(Box::new(m)))
    }

    /// Any of `hard`, `pcf`, `pcss` and `blurred` keeps another's map of the same size: they differ
    /// only in the lookup.
    fn take_over(&mut self, shared: &Shared, handover: Handover) -> Result<(), Handover> {
        match handover {
            Handover::Map(mut map) if self.map.is_none() && map.fits(&self.params) => {
                map.set_params(shared, &self.params, self.linear);
                self.map = Some(*map);
                Ok(())
            }
            other => Err(other),
        }
    }
}
