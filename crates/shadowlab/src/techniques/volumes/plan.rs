//! The CPU half of a shadow-volume frame: per light sample, which counting method to use, the
//! scissor rectangle, the casters whose volumes are drawn, and the stencil start value. Everything
//! here is decided from bounding spheres and the camera, before any GPU work is recorded; it is the
//! only place the camera enters (the extracted volumes are camera-independent and cached).

use glam::{Vec3, Vec4};
use shadowlab_core::Aabb;
use shadowlab_core::convex::{ConvexBody, Plane};
use shadowlab_core::volumes::{
    LightSource, SphereRect, VolumeCamera, ZpPlus, box_volume_touches, crossings, shadow_hull,
    sphere_volume_reaches_plane, sphere_volume_touches, volume_meets_body,
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

/// The casters of `plan` whose volumes may reach the pixels `rect` (x, y, width, height) of a
/// `width × height` surface: the plan's own culling (Hasselgren 2003 §3.3.1.2) against the
/// frustum through that rectangle and, when every surface point is known to lie in `extent`
/// (the scene's bounds, `SurfaceInputs::shows_only_scene`), against that frustum cut by it. A
/// resolve limited to a region (a dragged object's footprint) counts only there, and a caster
/// whose volumes contain no surface point of the region adds nothing to any count there,
/// whichever the method, as long as it is left out of every draw (caps and ZP+'s start
/// included): along a pixel's ray z-pass and ZP+ count its volumes' faces between the near
/// plane and the surface, z-fail behind the surface, and a closed volume that does not hold the
/// surface point is entered as often as it is left there. Only the parity mode's robust z-pass,
/// whose start was counted at the eye over the plan's casters, keeps the frustum test alone.
#[allow(clippy::too_many_arguments)]
pub(super) fn region_casters(
    plan: &SamplePlan,
    camera: &VolumeCamera,
    source: &LightSource,
    casters: &[Caster],
    slots: &[u32],
    rect: [u32; 4],
    size: (u32, u32),
    extent: Option<&Aabb>,
) -> Vec<Drawn> {
    let (w, h) = (size.0.max(1) as f32, size.1.max(1) as f32);
    let [x, y, rw, rh] = rect.map(|v| v as f32);
    let ndc = [2.0 * x / w - 1.0, 1.0 - 2.0 * (y + rh) / h, 2.0 * (x + rw) / w - 1.0, 1.0 - 2.0 * y / h];
    let planes = camera.planes(ndc);
    let body = extent.filter(|_| !plan.robust).map(|e| surface_body(e, &planes));
    let mut reaches = vec![false; slots.iter().max().map_or(0, |&m| m as usize + 1)];
    for (c, &slot) in casters.iter().zip(slots) {
        reaches[slot as usize] = planes.iter().all(|&pl| sphere_volume_reaches_plane(source, c.centre, c.radius, pl))
            && body.as_ref().is_none_or(|b| {
                volume_meets_body(source, &padded(&c.bounds), b)
                    && (c.parts.is_empty() || c.parts.iter().any(|p| volume_meets_body(source, &padded(p), b)))
            });
    }
    // A slot without a caster cannot happen; drawing it is the safe side.
    plan.casters.iter().copied().filter(|d| reaches.get(d.slot as usize).is_none_or(|&r| r)).collect()
}

/// `struct Hull` of `cull.wgsl`: the half-spaces `n·p + w ≥ 0` of a shadow hull; `count` 0 when
/// it is unbounded.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct GpuHull {
    planes: [Vec4; 10],
    count: [u32; 4],
}

/// What `cull.wgsl` tests for a region: per light sample, its drawn casters (item in the store,
/// first hull, parts, flags) and their hulls.
#[derive(Debug, Default)]
pub(super) struct CullInputs {
    /// `firsts[0]`: items in the store; sample `s`'s casters are `casters[firsts[s + 1]..firsts[s + 2]]`.
    pub firsts: Vec<u32>,
    pub casters: Vec<[u32; 4]>,
    pub hulls: Vec<GpuHull>,
}

/// `KEEP` of `cull.wgsl`: drawn whatever the surface.
const KEEP: u32 = 1;

impl CullInputs {
    pub fn new(items: u32) -> Self {
        Self { firsts: vec![items, 0], ..Self::default() }
    }

    /// Adds the next sample's casters (`drawn`, from [`region_casters`]): each caster's box hull,
    /// then its parts' (a caster is kept when the box hull and one part's hull meet the region's
    /// surface, as [`region_casters`] tests against the frustum). A plain z-pass keeps the casters
    /// its plan lists as touching the near pyramid, where its count starts (none, when `auto`
    /// chose it); `item` gives a slot's item in the store.
    pub fn push_sample(
        &mut self,
        plan: &SamplePlan,
        source: &LightSource,
        casters: &[Caster],
        slots: &[u32],
        drawn: &[Drawn],
        item: impl Fn(u32) -> u32,
    ) {
        let by_slot: std::collections::HashMap<u32, &Caster> = slots.iter().copied().zip(casters).collect();
        for d in drawn {
            let first = self.hulls.len() as u32;
            let keep = plan.method == Method::ZPass && d.zp_listed;
            let Some(c) = by_slot.get(&d.slot) else {
                // No caster in the slot: drawn, the safe side.
                self.hulls.push(gpu_hull(None));
                self.casters.push([item(d.slot), first, 0, KEEP]);
                continue;
            };
            self.hulls.push(gpu_hull(shadow_hull(source, &padded(&c.bounds))));
            for p in &c.parts {
                self.hulls.push(gpu_hull(shadow_hull(source, &padded(p))));
            }
            self.casters.push([item(d.slot), first, c.parts.len() as u32, if keep { KEEP } else { 0 }]);
        }
        self.firsts.push(self.casters.len() as u32);
    }
}

fn gpu_hull(planes: Option<Vec<Plane>>) -> GpuHull {
    let mut hull = GpuHull { planes: [Vec4::ZERO; 10], count: [0; 4] };
    // A hull has at most 3 faces and 6 silhouette edges; one with more (never) is unbounded.
    if let Some(planes) = planes.filter(|p| p.len() <= 10) {
        for (slot, p) in hull.planes.iter_mut().zip(&planes) {
            *slot = p.n.extend(p.d);
        }
        hull.count[0] = planes.len() as u32;
    }
    hull
}

/// The surface points a frustum (`planes`, inside `≥ 0`) can see within `extent`, a little
/// larger than both for round-off.
fn surface_body(extent: &Aabb, planes: &[Vec4; 5]) -> ConvexBody {
    let mut body = ConvexBody::from_aabb(&padded(extent));
    for pl in planes {
        let n = pl.truncate();
        // Moved outwards by a millionth of the extent's size.
        let slack = 1e-6 * extent.diagonal().max(1.0) * n.length();
        body = body.clip(&Plane { n, d: pl.w + slack });
        if body.is_empty() {
            break;
        }
    }
    body
}

/// A box a little larger (relative and absolute margins), so that round-off in the culling tests
/// never drops a caster that touches what it is tested against.
fn padded(b: &Aabb) -> Aabb {
    let e = Vec3::splat(1e-4 * b.diagonal() + 1e-5);
    Aabb::new(b.min - e, b.max + e)
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

    /// The GPU's inputs: per sample, each drawn caster's item, its box hull then its parts', and
    /// the z-pass flag; the hull planes are `shadow_hull`'s of the padded boxes.
    #[test]
    fn cull_inputs_list_each_casters_hulls() {
        use shadowlab_core::{Aabb, Mobility};
        let caster = |id: u32, min: Vec3, parts: Vec<Aabb>| Caster {
            id: crate::live::InstanceId(id),
            version: 0,
            mesh: 0,
            transform: glam::Affine3A::IDENTITY,
            two_sided: false,
            see_through: false,
            mirrored: false,
            centre: min + Vec3::splat(0.5),
            radius: 0.9,
            bounds: Aabb::new(min, min + Vec3::ONE),
            parts,
            mobility: Mobility::Static,
        };
        let half = |min: Vec3| Aabb::new(min, min + Vec3::new(0.5, 1.0, 1.0));
        let casters =
            [caster(0, Vec3::ZERO, vec![]), caster(1, Vec3::X * 3.0, vec![half(Vec3::X * 3.0), half(Vec3::X * 3.5)])];
        let slots = [4, 7];
        let source = LightSource::Point(Vec3::new(0.0, 10.0, 0.0));
        let mut plan = SamplePlan {
            method: Method::ZFail,
            fallback: false,
            robust: false,
            stencil_start: 0,
            scissor: None,
            focus_rect: None,
            casters: vec![],
        };
        let drawn = [
            Drawn { slot: 4, zp_listed: true, see_through: false },
            Drawn { slot: 7, zp_listed: false, see_through: false },
        ];
        let mut inputs = CullInputs::new(20);
        inputs.push_sample(&plan, &source, &casters, &slots, &drawn, |slot| slot);
        plan.method = Method::ZPass;
        inputs.push_sample(&plan, &source, &casters, &slots, &drawn[..1], |slot| 10 + slot);
        assert_eq!(inputs.firsts, vec![20, 0, 2, 3]);
        // Item, first hull, parts, flags: z-fail keeps nothing by flag; z-pass the listed caster.
        assert_eq!(inputs.casters, vec![[4, 0, 0, 0], [7, 1, 2, 0], [14, 4, 0, KEEP]]);
        assert_eq!(inputs.hulls.len(), 5);
        let planes = shadow_hull(&source, &padded(&casters[1].parts[1])).unwrap();
        assert_eq!(inputs.hulls[3].count[0] as usize, planes.len());
        assert_eq!(inputs.hulls[3].planes[0], planes[0].n.extend(planes[0].d));
        // The light inside a box: its hull is unbounded (count 0, always met).
        let inside = LightSource::Point(Vec3::splat(0.5));
        let mut lit = CullInputs::new(20);
        lit.push_sample(&plan, &inside, &casters, &slots, &drawn[..1], |slot| slot);
        assert_eq!(lit.hulls[0].count[0], 0);
    }

    #[test]
    fn pixel_rects_round_outwards_and_clamp() {
        assert_eq!(pixel_rect([-1.0, -1.0, 1.0, 1.0], 100, 50), Some([0, 0, 100, 50]));
        assert_eq!(pixel_rect([-0.01, -0.01, 0.01, 0.01], 100, 100), Some([49, 49, 2, 2]));
        assert_eq!(pixel_rect([-3.0, 0.5, 3.0, 0.9], 100, 100), Some([0, 5, 100, 20]));
        assert_eq!(pixel_rect([1.5, 0.2, 2.0, 0.3], 100, 100), None, "off screen");
    }
}
