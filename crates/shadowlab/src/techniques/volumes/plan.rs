//! The CPU half of a shadow-volume frame: per light sample, which counting method to use, the
//! scissor rectangle, the casters whose volumes are drawn, and the stencil start value. Everything
//! here is decided from bounding spheres and the camera, before any GPU work is recorded; it is the
//! only place the camera enters (the extracted volumes are camera-independent and cached).

use glam::{Vec3, Vec4};
use shadowlab_core::Aabb;
use shadowlab_core::volumes::{
    LightSource, SphereRect, VolumeCamera, ZpPlus, box_volume_touches, crossings, sphere_volume_reaches_plane,
    sphere_volume_touches,
};

use super::geometry::{Caster, VolumeTopology};

/// The `mode` parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Mode {
    Auto,
    ZPass,
    ZFail,
    ZpPlus,
}

impl Mode {
    pub fn parse(text: &str) -> Self {
        match text {
            "zpass" => Self::ZPass,
            "zfail" => Self::ZFail,
            "zpplus" => Self::ZpPlus,
            _ => Self::Auto,
        }
    }
}

/// How one sample's volumes are counted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Method {
    /// Nothing can shadow a visible pixel: the stencil stays at zero.
    Skip,
    /// Counting in front of the surface from the near plane (Heidmann 1991).
    ZPass,
    /// Counting behind the surface, with caps (Bilodeau 1999, Carmack 2000).
    ZFail,
    /// Z-pass started from the light's view of the near plane (Hornus et al. 2005).
    ZpPlus(ZpPlus),
}

impl Method {
    pub fn name(&self) -> &'static str {
        match self {
            Self::Skip => "skip",
            Self::ZPass => "zpass",
            Self::ZFail => "zfail",
            Self::ZpPlus(_) => "zpplus",
        }
    }
}

#[derive(Debug, Clone, Copy)]
pub(super) struct Settings {
    pub mode: Mode,
    /// Parity counting with the invert stencil operation.
    pub parity: bool,
    pub scissor: bool,
    pub cull: bool,
    /// Draw only where the focus receivers (`FrameView::focus`) are: the scissor and the culling
    /// frustum shrink to their screen rectangle (Hasselgren 2003 §3.3.1.1–2, the static volumes of
    /// `lightmesh`, merged per light as §3.3.1.3 chooses).
    pub focus: bool,
}

/// One light sample's frame.
#[derive(Debug, Clone)]
pub(super) struct SamplePlan {
    pub method: Method,
    /// ZP+ was asked for, but the light lies in the near plane: z-fail instead.
    pub fallback: bool,
    /// Depth clamping instead of near clipping, the stencil starting at the eye's count
    /// (Hasselgren 2003 §3.3.2's robust depth pass).
    pub robust: bool,
    pub stencil_start: u32,
    /// Pixels (x, y, width, height); `None`: the whole surface.
    pub scissor: Option<[u32; 4]>,
    /// With `Settings::focus`: the pixels whose result is meaningful (the focus receivers'
    /// rectangle within the light's); `[0, 0, 0, 0]` when no focus receiver is on screen.
    pub focus_rect: Option<[u32; 4]>,
    /// The casters whose volumes are drawn (culled against the frustum through the scissor and
    /// the light's range), in slot order.
    pub casters: Vec<Drawn>,
}

/// A caster drawn for one sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Drawn {
    /// Its slot in the volume store (`store.rs`).
    pub slot: u32,
    /// ZP+ starts the count with its light caps (Toromanoff 2005 §VI.2.a: in `auto`, only casters
    /// whose volume may meet the near pyramid).
    pub zp_listed: bool,
    /// Its light caps are drawn when counting in front of the surface (`Caster::see_through`).
    pub see_through: bool,
}

/// Everything a plan needs to know about the frame.
pub(super) struct FrameView<'a> {
    pub camera: &'a VolumeCamera,
    pub width: u32,
    pub height: u32,
    pub range: Option<f32>,
    pub casters: &'a [Caster],
    /// The store slot of each caster.
    pub slots: &'a [u32],
    pub topology: &'a VolumeTopology,
    /// Bounds of every caster (the depth range of the ZP+ projection for the sun).
    pub bounds: &'a Aabb,
    /// Bounding spheres of the receivers that need the volumes (with `Settings::focus`).
    pub focus: &'a [(Vec3, f32)],
}

pub(super) fn plan(settings: &Settings, frame: &FrameView<'_>, source: LightSource) -> SamplePlan {
    let mut plan = SamplePlan {
        method: Method::Skip,
        fallback: false,
        robust: false,
        stencil_start: 0,
        scissor: None,
        focus_rect: None,
        casters: Vec::new(),
    };
    let mut planes: [Vec4; 5] = frame.camera.planes([-1.0, -1.0, 1.0, 1.0]);
    let mut light_ndc = [-1.0, -1.0, 1.0, 1.0];
    // Hasselgren 2003 §3.3.1.1: the light's screen rectangle bounds everything it lights.
    let light_sphere = match (source, frame.range) {
        (LightSource::Point(p), Some(r)) => Some((p, r)),
        _ => None,
    };
    if settings.scissor
        && let Some((p, r)) = light_sphere
    {
        match frame.camera.sphere_rect(p, r) {
            SphereRect::Full => {}
            SphereRect::Outside => {
                plan.focus_rect = settings.focus.then_some([0; 4]);
                return plan;
            }
            SphereRect::Rect(ndc) => {
                let Some(rect) = pixel_rect(ndc, frame.width, frame.height) else {
                    plan.focus_rect = settings.focus.then_some([0; 4]);
                    return plan;
                };
                plan.scissor = Some(rect);
                planes = frame.camera.planes(ndc);
                light_ndc = ndc;
            }
        }
    }
    if settings.focus {
        let rect = focus_ndc(frame.camera, frame.focus, light_ndc);
        match rect.and_then(|ndc| pixel_rect(ndc, frame.width, frame.height).map(|px| (ndc, px))) {
            Some((ndc, px)) => {
                plan.scissor = Some(px);
                plan.focus_rect = Some(px);
                planes = frame.camera.planes(ndc);
            }
            None => {
                plan.scissor = None;
                plan.focus_rect = Some([0; 4]);
                return plan;
            }
        }
    }
    let active: Vec<(&Caster, u32)> = frame
        .casters
        .iter()
        .zip(frame.slots.iter().copied())
        .filter(|(c, _)| {
            !settings.cull
                || (light_sphere.is_none_or(|(p, r)| p.distance(c.centre) - c.radius <= r)
                    && planes.iter().all(|&pl| sphere_volume_reaches_plane(&source, c.centre, c.radius, pl)))
        })
        .collect();
    if active.is_empty() {
        return plan;
    }
    let (near_centre, near_radius) = frame.camera.near_pyramid_sphere();
    let touches = |c: &Caster, q, rho| {
        sphere_volume_touches(&source, c.centre, c.radius, q, rho) && box_volume_touches(&source, &c.bounds, q, rho)
    };
    let touching: Vec<bool> = active.iter().map(|(c, _)| touches(c, near_centre, near_radius)).collect();
    let zp_plus = |plan: &mut SamplePlan| match frame.camera.zp_plus(&source, frame.bounds) {
        Some(zp) => Method::ZpPlus(zp),
        None => {
            plan.fallback = true;
            Method::ZFail
        }
    };
    plan.method = match settings.mode {
        Mode::ZPass => Method::ZPass,
        Mode::ZFail => Method::ZFail,
        Mode::ZpPlus => zp_plus(&mut plan),
        // Toromanoff 2005 §VI.2.a: z-pass fails only where the near pyramid meets a volume.
        Mode::Auto if !touching.contains(&true) => Method::ZPass,
        Mode::Auto => zp_plus(&mut plan),
    };
    // Only the listed casters start the count in ZP+: the others' volumes miss the near plane.
    let listed = |i: usize| match settings.mode {
        Mode::Auto => touching[i],
        _ => true,
    };
    if settings.parity && plan.method == Method::ZPass {
        plan.robust = true;
        let eye = frame.camera.eye;
        let inside: u32 = active
            .iter()
            .filter(|(c, _)| touches(c, eye, 0.0))
            .map(|(c, _)| crossings(&frame.topology.topologies[c.mesh], &c.transform, &source, c.two_sided, eye))
            .sum();
        plan.stencil_start = inside & 1;
    }
    plan.casters = active
        .iter()
        .enumerate()
        .map(|(i, &(c, slot))| Drawn { slot, zp_listed: listed(i), see_through: c.see_through })
        .collect();
    plan.casters.sort_unstable_by_key(|d| d.slot);
    plan
}

/// The union of the focus receivers' screen rectangles (bounding spheres), within `within` (NDC
/// [x0, y0, x1, y1]); `None` when none is on screen (Hasselgren 2003 §3.3.1.1, merged per light).
pub(crate) fn focus_ndc(camera: &VolumeCamera, focus: &[(Vec3, f32)], within: [f32; 4]) -> Option<[f32; 4]> {
    let mut union: Option<[f32; 4]> = None;
    for &(c, r) in focus {
        let ndc = match camera.sphere_rect(c, r) {
            SphereRect::Outside => continue,
            SphereRect::Full => [-1.0, -1.0, 1.0, 1.0],
            SphereRect::Rect(ndc) => ndc,
        };
        union = Some(union.map_or(ndc, |u| [u[0].min(ndc[0]), u[1].min(ndc[1]), u[2].max(ndc[2]), u[3].max(ndc[3])]));
    }
    union.map(|u| [u[0].max(within[0]), u[1].max(within[1]), u[2].min(within[2]), u[3].min(within[3])])
}

/// NDC [x0, y0, x1, y1] → pixels (x, y, width, height), rounded outwards; `None` when empty.
pub(crate) fn pixel_rect(ndc: [f32; 4], width: u32, height: u32) -> Option<[u32; 4]> {
    let (w, h) = (width as f32, height as f32);
    let x0 = ((ndc[0] + 1.0) * 0.5 * w).floor().clamp(0.0, w) as u32;
    let x1 = ((ndc[2] + 1.0) * 0.5 * w).ceil().clamp(0.0, w) as u32;
    let y0 = ((1.0 - ndc[3]) * 0.5 * h).floor().clamp(0.0, h) as u32;
    let y1 = ((1.0 - ndc[1]) * 0.5 * h).ceil().clamp(0.0, h) as u32;
    (x1 > x0 && y1 > y0).then_some([x0, y0, x1 - x0, y1 - y0])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_rects_round_outwards_and_clamp() {
        assert_eq!(pixel_rect([-1.0, -1.0, 1.0, 1.0], 100, 50), Some([0, 0, 100, 50]));
        assert_eq!(pixel_rect([-0.01, -0.01, 0.01, 0.01], 100, 100), Some([49, 49, 2, 2]));
        assert_eq!(pixel_rect([-3.0, 0.5, 3.0, 0.9], 100, 100), Some([0, 5, 100, 20]));
        assert_eq!(pixel_rect([1.5, 0.2, 2.0, 0.3], 100, 100), None, "off screen");
    }
}
