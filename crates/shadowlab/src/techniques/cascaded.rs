//! `cascaded`: robust hard shadows for large views (Stingl 2011), one technique whose parameters
//! switch each part on:
//! - `focus`: the map fitted to the body B = (V ∩ S) extended towards the light (§3.1);
//! - `warp`: PSM, LiSPSM (n_opt), reparametrised LiSPSM (n_repar(γ)) or an arbitrary η (§3.2), with
//!   the projection centre that moves continuously with the camera (§4.1);
//! - `splits`, `scheme`, `lambda`: z-partitioning (PSSM / CSM, §3.3), each split focused and warped;
//!   `scheme=auto` fits the splits to the visible samples (sample distribution shadow maps,
//!   Lauritzen, Salvi and Lefohn 2011): log splits over the tight depth range of a frame before
//!   (with a guard band), each unwarped directional split cut to the light-space box of the samples
//!   it held (`DepthRange::with_samples`, read back without stalling); until a measurement arrives,
//!   the practical scheme with `lambda`. The default;
//! - `selection`: split by eye depth or by best resolution (§3.3.3); `blend`: a band between splits;
//! - `pseudo_near`, `pseudo_far`: Lloyd's pseudo-near and Stingl's pseudo-far planes (§4.2);
//! - `auto_near`: near and far from a GPU min/max reduction of the previous frame's depth (§4.3);
//! - `stabilize`: quantised scale and texel-snapped offsets against flicker (§3.5; not with warping);
//!   `quantize` (on by default) does the same for a focused map's own box, without squaring it or
//!   tying its size to the scene's (`shadowlab_core::cascades`, `quantised_box`);
//! - the bias of `hard` and the kernel of `pcf`, the radius kept at split 0's world size (Eq. 3.9).
//!
//! `map_size` is per split: PSSM(4) at 1024² spends the texels of one 2048² map. The maps are the
//! layers of one texture array. Directional lights get everything; spot lights get focusing and
//! splits (their maps are perspective already, warping does not apply).

use bytemuck::{Pod, Zeroable};
use glam::Vec4;
use shadowlab_core::cascades::{
    CascadeFrame, CascadeSettings, VisibleDepths, Warp, adjusted_depth_range, compute_cascades, light_frame,
    scheme_lambda,
};
use shadowlab_core::lightspace::ShadowView;
use shadowlab_core::params::ParamDef;
use shadowlab_core::{Light, LightKind, ParamSet};

use crate::context::Shared;
use crate::depth_range::{BinSetup, DepthRange};
use crate::frame::VisibilityLayer;
use crate::kernel;
use crate::live::{MapViews, ShadowCache};
use crate::shadowmap::{BiasUniform, FaceMode, Raster, lookup_group, lookup_layout, selection_layout};
use crate::technique::{
    FrameContext, MapAnalysis, ShadowTechnique, TechniqueError, TechniqueInfo, TechniqueStats, dispatch_program_in,
};

pub const INFO: TechniqueInfo = TechniqueInfo {
    id: "cascaded",
    summary: "focused, warped (PSM/LiSPSM) and z-partitioned (PSSM/CSM) shadow maps, stabilised",
    source: "Stingl 2011 §3-4; Wimmer & Scherzer 2006; Zhang et al. 2006/2009; Lloyd et al. 2008; Lauritzen et al. 2011 (auto)",
    params: crate::map_params!(
        ParamDef::bool("focus", true, "fit each map to the visible part of the scene"),
        ParamDef::choice("warp", "none", &["none", "psm", "lispsm", "repar", "arbitrary"], "perspective warp"),
        ParamDef::float("warp_strength", 0.0, -1.0, 1.0, "η for warp=arbitrary: -1 uniform, 0 LiSPSM, 1 PSM"),
        ParamDef::int("splits", 1, 1, 16, "z-partitions (cascades)"),
        ParamDef::choice(
            "scheme",
            "auto",
            &["uniform", "log", "practical", "auto"],
            "split scheme (auto: fitted to the visible depths of a frame before, SDSM)"
        ),
        ParamDef::float(
            "lambda",
            0.5,
            0.0,
            1.0,
            "practical scheme (and auto's until a measurement): 0 uniform … 1 logarithmic"
        ),
        ParamDef::choice("selection", "best", &["depth", "best"], "split choice: eye depth or best resolution"),
        ParamDef::float("pseudo_near", 0.0, 0.0, 0.95, "pseudo-near plane, fraction of the depth range"),
        ParamDef::float("pseudo_far", 0.0, 0.0, 0.95, "pseudo-far plane, fraction of the depth range from the far end"),
        ParamDef::bool("auto_near", false, "near/far from the previous frame's visible depth range"),
        ParamDef::bool("stabilize", false, "quantised scale and texel-snapped offsets (no warping)"),
        ParamDef::bool("quantize", true, "focus box on a 9% ladder of sizes, centre on whole texels (unwarped)"),
        ParamDef::float("blend", 0.0, 0.0, 0.5, "blend band between splits, fraction of a split (depth selection)"),
        ParamDef::choice("kernel", "none", &["none", "box", "poisson", "rotated"], "PCF tap pattern (none: one tap)"),
        kernel::TAPS,
        ParamDef::float("radius", 1.5, 0.0, 64.0, "PCF radius"),
        ParamDef::choice("radius_unit", "texels", &["texels", "world"], "texels of split 0, or world units"),
        kernel::MAX_BLUR,
    ),
    light_types: &["directional", "spot"],
    create,
    compose: None,
    fragment: true,
};

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct SelectionUniform {
    params: Vec4,
    distances: [Vec4; 5],
}

/// What the visible depths depend on: the surface's generation, the instances' epoch, the bins.
type MeasuredState = (u64, u64, Option<BinSetup>);

struct Cascaded {
    params: ParamSet,
    settings: CascadeSettings,
    pipeline: crate::context::ResolveProgram,
    kernel_group: wgpu::BindGroup,
    kernel_bytes: u64,
    state: Option<State>,
    depth_range: Option<DepthRange>,
    last: Option<CascadeFrame>,
    /// Frames between the depth range measured and its use (auto_near).
    latency: Option<u64>,
    /// What the visible depths depend on (the surface's generation, the instances' epoch, the
    /// bins' frame) as last measured, and the frame it took that state: once a measurement of a
    /// frame since then is read back, still frames measure nothing.
    measuring: Option<(MeasuredState, u64)>,
    /// Depth reductions recorded (`technique_stats`: `depth_passes`).
    depth_passes: u64,
    triangles: u64,
}

struct State {
    maps: MapViews,
    bias_buffer: wgpu::Buffer,
    /// The maps' generation the lookup group was made for.
    generation: u32,
    /// Splits rendered by the last frame (the others were still valid).
    rendered: u32,
    raster: Raster,
    lookup: wgpu::BindGroup,
    selection: wgpu::Buffer,
    selection_group: wgpu::BindGroup,
    bytes: u64,
    draws: u32,
}

/// The cascade settings of a `cascaded` parameter set (or of `hard` / `pcf`, which are one unfocused,
/// unwarped map), with the checks that need the light.
pub fn cascade_settings(params: &ParamSet, light: &Light) -> Result<CascadeSettings, TechniqueError> {
    let fail = |message: String| TechniqueError::Failed { id: INFO.id.to_owned(), message };
    if !params.has("warp") {
        return Ok(CascadeSettings {
            focus: false,
            warp: Warp::None,
            splits: 1,
            lambda: 0.5,
            pseudo_near: 0.0,
            pseudo_far: 0.0,
            stabilize: false,
            quantize: false,
            map_size: params.int("map_size") as u32,
            depth_range: None,
            visible_near: None,
            auto: false,
            samples: None,
        });
    }
    let warp = Warp::parse(params.choice("warp"), params.float("warp_strength") as f32)
        .ok_or_else(|| fail("unknown warp".into()))?;
    if warp != Warp::None && matches!(light.kind, LightKind::Spot { .. }) {
        return Err(fail(format!(
            "warp={} needs a directional light; spot light '{}' is perspective already",
            params.choice("warp"),
            light.name
        )));
    }
    if params.bool("stabilize") && warp != Warp::None {
        return Err(fail(
            "stabilize cannot apply to warped maps: their texels are not uniform (Stingl 2011 §3.5); use warp=none or filter with PCF".into(),
        ));
    }
    Ok(CascadeSettings {
        focus: params.bool("focus"),
        warp,
        splits: params.int("splits") as usize,
        lambda: scheme_lambda(params.choice("scheme"), params.float("lambda") as f32),
        pseudo_near: params.float("pseudo_near") as f32,
        pseudo_far: params.float("pseudo_far") as f32,
        stabilize: params.bool("stabilize"),
        quantize: params.bool("quantize"),
        map_size: params.int("map_size") as u32,
        depth_range: None,
        visible_near: None,
        auto: params.choice("scheme") == "auto",
        samples: None,
    })
}

fn create(shared: &Shared, params: &ParamSet, light: &Light) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
    let mut settings = cascade_settings(params, light)?;
    if !shared.compute {
        // Without compute (WebGL2) the visible depths cannot be measured (`DepthRange` is a compute
        // reduction): `scheme=auto` keeps the splits it starts from (`lambda`), and what needs the
        // measurement is refused.
        settings.auto = false;
        if params.bool("auto_near") || settings.warp == Warp::Psm {
            return Err(TechniqueError::Failed {
                id: INFO.id.into(),
                message: "auto_near and warp=psm measure the visible depths in a compute pass, which this device \
                          lacks (WebGL2)"
                    .into(),
            });
        }
    }
    let k = kernel::from_params(params);
    let (kernel_group, kernel_bytes) = kernel::bind_group(shared, &k);
    let pipeline = shared.resolve_program(
        "cascaded",
        include_str!("cascaded.wgsl"),
        "main",
        &[&lookup_layout(shared), &kernel::layout(shared), &selection_layout(shared)],
        &[],
    );
    // PSM needs the visible near plane for its warp (CascadeSettings::visible_near), auto_near for
    // the split range.
    // the split range, and scheme=auto the binned samples too.
    let depth_range = if settings.auto {
        Some(DepthRange::with_samples(shared))
    } else {
        (params.bool("auto_near") || settings.warp == Warp::Psm).then(|| DepthRange::new(shared))
    };
    Ok(Box::new(Cascaded {
        params: params.clone(),
        settings,
        pipeline,
        kernel_group,
        kernel_bytes,
        state: None,
        depth_range,
        last: None,
        latency: None,
        measuring: None,
        depth_passes: 0,
        triangles: 0,
    }))
}

impl Cascaded {
    fn build(&self, shared: &Shared, cache: &mut ShadowCache) -> State {
        let device = &shared.gpu.device;
        let m = self.settings.splits.max(1) as u32;
        let size = self.settings.map_size;
        let maps = MapViews::new(shared, cache, size, m);
        let linear = self.params.choice("kernel") != "none";
        let bias = BiasUniform {
            values: Vec4::new(
                self.params.float("normal_offset") as f32,
                self.params.float("constant_bias") as f32,
                size as f32,
                0.0,
            ),
            mode: Vec4::new(if linear { 1.0 } else { 0.0 }, 0.0, 0.0, 0.0),
        };
        let bias_buffer = crate::util::uniform_buffer(device, "cascaded bias", bytemuck::bytes_of(&bias));
        let lookup = lookup_group(shared, &maps.maps, &bias_buffer, linear);
        let selection = crate::util::uniform_buffer(
            device,
            "selection",
            bytemuck::bytes_of(&SelectionUniform { params: Vec4::ZERO, distances: [Vec4::ZERO; 5] }),
        );
        let selection_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("selection"),
            layout: &selection_layout(shared),
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: selection.as_entire_binding() }],
        });
        let bytes = bias_buffer.size() + selection.size() + self.kernel_bytes;
        State {
            maps,
            bias_buffer,
            generation: 0,
            rendered: 0,
            raster: Raster {
                faces: FaceMode::parse(self.params.choice("faces")),
                slope_bias: self.params.float("slope_bias") as f32,
                // Warped splits store linear depth (ShadowView::linear_depth).
                linear_depth: self.settings.warp != Warp::None,
                only_masked: false,
            },
            lookup,
            selection,
            selection_group,
            bytes,
            draws: 0,
        }
    }
}

impl Cascaded {
    /// The figures the reports show: adjusted depth range, split distances, warp distances, and
    /// the automatic near plane's latency.
    fn report(&self) -> Vec<(String, f64)> {
        let mut out = Vec::new();
        if let Some(f) = &self.last {
            out.push(("near".into(), f64::from(f.near)));
            out.push(("far".into(), f64::from(f.far)));
            out.push(("gamma_deg".into(), f64::from(f.gamma.to_degrees())));
            for (i, c) in f.cascades.iter().enumerate() {
                out.push((format!("split{i}_far"), f64::from(c.far)));
                if c.warp_n.is_finite() {
                    out.push((format!("split{i}_warp_n"), f64::from(c.warp_n)));
                } else if self.settings.warp != Warp::None {
                    // Warping was asked, but the split's n degenerated (the light along the view).
                    out.push((format!("split{i}_unwarped"), 1.0));
                }
                if c.psm_limited {
                    out.push((format!("split{i}_psm_limited"), 1.0));
                }
            }
        }
        if let Some(l) = self.latency {
            out.push(("auto_near_latency_frames".into(), l as f64));
        }
        if self.settings.auto {
            // Whether this frame's splits were fitted to measured samples (0: the practical
            // fallback before the first readback).
            let fitted = self.depth_range.as_ref().and_then(DepthRange::measured).is_some_and(|m| m.samples.is_some());
            out.push(("auto_fitted".into(), if fitted { 1.0 } else { 0.0 }));
        }
        if self.depth_range.is_some() {
            out.push(("depth_passes".into(), self.depth_passes as f64));
        }
        out
    }
}

impl ShadowTechnique for Cascaded {
    fn id(&self) -> &'static str {
        INFO.id
    }

    fn params(&self) -> &ParamSet {
        &self.params
    }

    fn prepare(&mut self, ctx: &mut FrameContext<'_>) -> Result<(), TechniqueError> {
        if self.state.is_none() {
            self.state = Some(self.build(ctx.shared, ctx.cache));
        }
        let mut settings = self.settings.clone();
        if let Some(dr) = &mut self.depth_range {
            dr.poll(&ctx.gpu.device);
            if let Some(m) = dr.measured() {
                if self.params.bool("auto_near") || settings.auto {
                    settings.depth_range = Some(m.range);
                }
                settings.visible_near = Some(m.range.0);
                settings.samples = m.samples.clone();
                self.latency = Some(ctx.frame_index.saturating_sub(m.frame));
            }
        }
        let view = ctx.surface.camera.view();
        let frame = compute_cascades(ctx.light, &ctx.gpu_scene.bounds, &view, ctx.surface.camera.aspect(), &settings);
        let state = self.state.as_mut().expect("built above");
        let views: Vec<ShadowView> = frame.cascades.iter().map(|c| c.view).collect();
        let mut distances = [Vec4::ZERO; 5];
        for (i, d) in frame.split_distances().iter().enumerate().take(20) {
            distances[i / 4][i % 4] = *d;
        }
        let texel_radius = self.params.choice("radius_unit") == "texels";
        let sel = SelectionUniform {
            params: Vec4::new(
                views.len() as f32,
                if self.params.choice("selection") == "best" { 1.0 } else { 0.0 },
                self.params.float("blend") as f32,
                if texel_radius { 1.0 } else { 0.0 },
            ),
            distances,
        };
        ctx.gpu.queue.write_buffer(&state.selection, 0, bytemuck::bytes_of(&sel));
        // Stabilised splits keep their views while the camera moves within a texel: their maps stay.
        state.rendered = state.maps.update(ctx, &views, &state.raster, 0)?;
        state.draws = state.maps.draws;
        if state.generation != state.maps.generation() {
            let linear = self.params.choice("kernel") != "none";
            state.lookup = lookup_group(ctx.shared, &state.maps.maps, &state.bias_buffer, linear);
            state.generation = state.maps.generation();
        }
        if let Some(dr) = &mut self.depth_range {
            // The samples are binned over this frame's depth range clipped to the scene, in the
            // light frame of unwarped directional splits.
            let bins = ctx.light.direction().filter(|_| settings.auto).map(|dir| {
                let bounds = &ctx.gpu_scene.bounds;
                let (near, far) =
                    adjusted_depth_range(&view, ctx.surface.camera.aspect(), bounds).unwrap_or((view.near, view.far));
                BinSetup {
                    light_view: light_frame(dir.normalize(), bounds),
                    near,
                    far,
                    eye: view.position,
                    forward: view.forward(),
                }
            });
            let key = (ctx.surface.generation(), ctx.live.instances_epoch(), bins);
            let since = match self.measuring {
                Some((k, since)) if k == key => since,
                _ => ctx.frame_index,
            };
            self.measuring = Some((key, since));
            let current = dr.latest().is_some_and(|(_, measured)| measured >= since);
            if !current && dr.record(ctx.shared, ctx.encoder, ctx.surface, ctx.timer, ctx.frame_index, bins) {
                self.depth_passes += 1;
            }
        }
        self.triangles = ctx.gpu_scene.triangles;
        self.last = Some(frame);
        Ok(())
    }

    fn resolve(&mut self, ctx: &mut FrameContext<'_>, out: &VisibilityLayer) {
        let Some(state) = &self.state else { return };
        let group0 = ctx.resolve_group(out);
        dispatch_program_in(
            ctx,
            "cascaded",
            &self.pipeline,
            &[&group0, &state.lookup, &self.kernel_group, &state.selection_group],
            out,
        );
    }

    fn stats(&self) -> TechniqueStats {
        match &self.state {
            Some(s) => TechniqueStats {
                memory_bytes: s.bytes + s.maps.bytes() + self.depth_range.as_ref().map_or(0, DepthRange::bytes),
                passes: s.rendered + 1 + u32::from(self.depth_range.is_some()),
                draws: s.draws,
                triangles: self.triangles * u64::from(s.rendered),
                extra: self.report(),
            },
            None => TechniqueStats::default(),
        }
    }

    fn shown(&self) -> bool {
        self.state.as_ref().is_some_and(|s| s.maps.shown())
    }

    fn current(&self) -> bool {
        self.state.as_ref().is_some_and(|s| s.maps.current())
    }

    fn measured(&self) -> Option<VisibleDepths> {
        self.depth_range.as_ref().and_then(DepthRange::measured).cloned()
    }

    fn adopt_measured(&mut self, measured: VisibleDepths) {
        if let Some(dr) = &mut self.depth_range {
            dr.adopt(measured);
        }
    }

    fn analysis(&self) -> Option<MapAnalysis<'_>> {
        self.state.as_ref().map(|s| MapAnalysis {
            lookup: &s.lookup,
            selection: &s.selection_group,
            views: s.maps.views(),
        })
    }
}
