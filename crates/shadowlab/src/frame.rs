//! What a shadow technique reads and writes each frame: the camera, the surface (depth and normal
//! buffers, ours or the application's), the light, and one visibility layer per light.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3, Vec4};
use shadowlab_core::convex::ConvexBody;
use shadowlab_core::{Aabb, Light, LightKind, View};

/// The camera as shaders see it (`shaders/common.wgsl`, `struct Camera`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct CameraUniform {
    pub view_proj: Mat4,
    pub inv_view_proj_rel: Mat4,
    pub position: Vec4,
    pub size: Vec4,
    pub depth: Vec4,
    /// xyz: unit viewing direction.
    pub forward: Vec4,
}

impl CameraUniform {
    /// From view and projection matrices (any convention wgpu accepts): `reversed_z` says whether the
    /// background (cleared) depth is 0 (reversed) or 1 (standard).
    pub fn new(view: Mat4, projection: Mat4, width: u32, height: u32, reversed_z: bool) -> Self {
        let inv = view.inverse();
        let eye = inv.w_axis.truncate();
        // The view without its translation: positions relative to the eye stay small and precise.
        let rotation = Mat4::from_mat3(glam::Mat3::from_mat4(view));
        Self {
            view_proj: projection * view,
            inv_view_proj_rel: (projection * rotation).inverse(),
            position: eye.extend(1.0),
            size: Vec4::new(width as f32, height as f32, 1.0 / width as f32, 1.0 / height as f32),
            depth: Vec4::new(if reversed_z { 0.0 } else { 1.0 }, 0.0, 0.0, 0.0),
            forward: (-inv.z_axis.truncate()).normalize_or(Vec3::NEG_Z).extend(0.0),
        }
    }

    /// A shadowlab view rendered at `width × height` (reversed Z).
    pub fn from_view(view: &View, width: u32, height: u32) -> Self {
        Self::new(view.view_matrix(), view.projection(width as f32 / height.max(1) as f32), width, height, true)
    }

    /// The camera as a [`View`] (position, direction, field of view, near and far), recovered from
    /// the matrices, for techniques that fit their maps to the view (cascades).
    pub fn view(&self) -> View {
        let rel = self.inv_view_proj_rel;
        let at = |x: f32, y: f32, z: f32| rel.project_point3(Vec3::new(x, y, z));
        let f = self.forward.truncate();
        let background = self.depth.x;
        let (near_z, far_z) = if background == 0.0 { (1.0, 1e-7) } else { (0.0, 1.0 - 1e-7) };
        let near = at(0.0, 0.0, near_z).dot(f);
        let far = at(0.0, 0.0, far_z).dot(f);
        let top = at(0.0, 1.0, near_z);
        let up = (top - f * top.dot(f)).normalize_or(Vec3::Y);
        let fov_y = 2.0 * (top - f * top.dot(f)).length().atan2(near);
        let position = self.position.truncate();
        View { name: "camera".into(), position, target: position + f, up, fov_y, near, far: far.max(near * 1.001) }
    }

    /// Width over height.
    pub fn aspect(&self) -> f32 {
        self.size.x / self.size.y.max(1.0)
    }

    /// The pixels whose surface a box may cover: its corners projected (relative to the eye, as
    /// the shaders reconstruct positions), rounded outwards and one pixel wider for the
    /// rasteriser's rounding. A box reaching behind the eye's plane may cover any pixel.
    pub fn footprint(&self, b: &Aabb) -> Footprint {
        if b.is_empty() {
            return Footprint::Nothing;
        }
        self.footprint_of(b.corners())
    }

    /// The pixels a convex body may cover: its part inside the eye's frustum (cut by the near
    /// plane and the four sides, each widened by 1% of the depth so that round-off never cuts a
    /// covered pixel), projected as [`CameraUniform::footprint_of`]. Unlike projecting the whole
    /// body, a body that reaches behind the eye (a shadow's prism running past the camera) still
    /// gets the rectangle of what the eye sees of it.
    pub fn footprint_of_body(&self, body: &ConvexBody) -> Footprint {
        let eye = self.position.truncate();
        // Relative to the eye, as the shaders reconstruct positions.
        let rel = ConvexBody { faces: body.faces.iter().map(|f| f.iter().map(|&p| p - eye).collect()).collect() };
        // (`Camera::projection` is reversed Z.)
        let seen = rel.clip_to_view(&self.inv_view_proj_rel.inverse(), 0.01, 0.01);
        if seen.is_empty() {
            return Footprint::Nothing;
        }
        self.footprint_of(seen.points().map(|p| p + eye))
    }

    /// Where on screen (in pixels, x right, y down) the part of a convex body inside the eye's
    /// frustum lies: its vertices projected, as [`CameraUniform::footprint_of_body`] cuts them;
    /// the convex hull of these points is the body's silhouette. `None` where they cannot be
    /// projected (a point at the eye's plane, or not finite): anywhere.
    pub fn pixels_of_body(&self, body: &ConvexBody) -> Option<Vec<glam::Vec2>> {
        let eye = self.position.truncate();
        let to_clip = self.inv_view_proj_rel.inverse();
        let (widen, near) = (0.01, 0.01);
        // Wholly in view (most bodies a drag step projects): the clip would keep every point of
        // every face (faces of fewer than three points are dropped by it), so take them as they are.
        let planes = shadowlab_core::convex::view_planes(&to_clip, widen, near);
        let faces = || body.faces.iter().filter(|f| f.len() >= 3).flatten();
        let seen: Vec<Vec3> = if faces().all(|&p| planes.iter().all(|plane| plane.distance(p - eye) >= 0.0)) {
            faces().map(|&p| p - eye).collect()
        } else {
            let rel = ConvexBody { faces: body.faces.iter().map(|f| f.iter().map(|&p| p - eye).collect()).collect() };
            rel.clip_to_view(&to_clip, widen, near).points().collect()
        };
        let (w, h) = (self.size.x.max(0.0), self.size.y.max(0.0));
        seen.into_iter()
            .map(|p| {
                let clip = to_clip * p.extend(1.0);
                let ahead = clip.w > 1e-6 * clip.truncate().length().max(1.0);
                let ndc = glam::Vec2::new(clip.x, clip.y) / clip.w;
                let pixel = glam::Vec2::new((ndc.x + 1.0) * 0.5 * w, (1.0 - ndc.y) * 0.5 * h);
                (ahead && pixel.is_finite()).then_some(pixel)
            })
            .collect()
    }

    /// The pixels the convex hull of `points` may cover ([`CameraUniform::footprint`]'s rules).
    pub fn footprint_of(&self, points: impl IntoIterator<Item = Vec3>) -> Footprint {
        let (width, height) = (self.size.x.max(0.0) as u32, self.size.y.max(0.0) as u32);
        let to_clip = self.inv_view_proj_rel.inverse();
        let eye = self.position.truncate();
        let (mut lo, mut hi) = (glam::Vec2::splat(f32::INFINITY), glam::Vec2::splat(f32::NEG_INFINITY));
        for p in points {
            let clip = to_clip * (p - eye).extend(1.0);
            // Near the eye's plane the projection explodes (and flips behind it); NaN fails too.
            let ahead = clip.w > 1e-6 * clip.truncate().length().max(1.0);
            if !ahead {
                return Footprint::Whole;
            }
            let ndc = glam::Vec2::new(clip.x, clip.y) / clip.w;
            lo = lo.min(ndc);
            hi = hi.max(ndc);
        }
        if lo.x > hi.x {
            return Footprint::Nothing;
        }
        if !(lo.is_finite() && hi.is_finite()) {
            return Footprint::Whole;
        }
        let (w, h) = (width as f32, height as f32);
        let x0 = ((lo.x + 1.0) * 0.5 * w).floor() - 1.0;
        let x1 = ((hi.x + 1.0) * 0.5 * w).ceil() + 1.0;
        let y0 = ((1.0 - hi.y) * 0.5 * h).floor() - 1.0;
        let y1 = ((1.0 - lo.y) * 0.5 * h).ceil() + 1.0;
        let (x0, x1, y0, y1) = (x0.clamp(0.0, w), x1.clamp(0.0, w), y0.clamp(0.0, h), y1.clamp(0.0, h));
        if x1 <= x0 || y1 <= y0 {
            return Footprint::Nothing;
        }
        Footprint::Rect([x0 as u32, y0 as u32, (x1 - x0) as u32, (y1 - y0) as u32])
    }
}

/// Where on screen something may be ([`CameraUniform::footprint`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Footprint {
    Nothing,
    /// x, y, width, height in pixels.
    Rect([u32; 4]),
    Whole,
}

impl Footprint {
    /// The smallest footprint holding both.
    pub fn union(self, other: Footprint) -> Footprint {
        match (self, other) {
            (Footprint::Whole, _) | (_, Footprint::Whole) => Footprint::Whole,
            (Footprint::Nothing, f) | (f, Footprint::Nothing) => f,
            (Footprint::Rect(a), Footprint::Rect(b)) => {
                let (x0, y0) = (a[0].min(b[0]), a[1].min(b[1]));
                let x1 = (a[0] + a[2]).max(b[0] + b[2]);
                let y1 = (a[1] + a[3]).max(b[1] + b[3]);
                Footprint::Rect([x0, y0, x1 - x0, y1 - y0])
            }
        }
    }
}

/// A light as shaders see it (`shaders/lights.wgsl`, `struct Light`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct LightUniform {
    pub position: Vec4,
    pub direction: Vec4,
    pub color: Vec4,
    pub cone: Vec4,
    pub tangent: Vec4,
}

impl LightUniform {
    pub fn new(light: &Light) -> Self {
        let rgb = light.color * light.intensity;
        let range = light.range.unwrap_or(0.0);
        let (kind, position, direction, size, cone, tangent) = match light.kind {
            LightKind::Point { position, radius } => (0.0, position, Vec3::ZERO, radius, Vec4::ZERO, Vec3::ZERO),
            LightKind::Spot { position, direction, inner_angle, outer_angle, radius } => (
                1.0,
                position,
                direction,
                radius,
                Vec4::new(inner_angle.cos(), outer_angle.cos(), 0.0, 0.0),
                Vec3::ZERO,
            ),
            LightKind::Directional { direction, angular_radius } => {
                (2.0, Vec3::ZERO, direction, angular_radius, Vec4::ZERO, Vec3::ZERO)
            }
            LightKind::Rect { position, direction, tangent, width, height } => {
                (3.0, position, direction, 0.0, Vec4::new(0.0, 0.0, width, height), tangent)
            }
        };
        Self {
            position: position.extend(kind),
            direction: direction.extend(range),
            color: rgb.extend(size),
            cone,
            tangent: tangent.extend(0.0),
        }
    }
}

/// The per-pixel surface a technique shadows: a depth buffer, a world-space normal buffer and the
/// camera that made them. The renderer's own G-buffer provides one; an application embedding
/// shadowlab builds one from its own buffers with [`SurfaceInputs::new`].
///
/// Requirements: `depth` is a depth texture view (depth aspect only) of size `width × height`;
/// `normal` is a float texture (e.g. `Rgba16Float`) whose `xyz` is the unit world-space normal
/// facing the camera. Optionally ([`SurfaceInputs::set_geometric_normal`]) a texture of the facets'
/// own normals, in the same form, for the tests that must hold on the facet (DESIGN.md §3: the
/// receiver's horizon); without it the shading normal stands in.
pub struct SurfaceInputs {
    pub width: u32,
    pub height: u32,
    pub depth: wgpu::TextureView,
    pub normal: wgpu::TextureView,
    geometric_normal: Option<wgpu::TextureView>,
    pub camera: CameraUniform,
    pub camera_buffer: wgpu::Buffer,
    /// Changes whenever the surface may have: a new camera, or [`SurfaceInputs::touch`]. With the
    /// scene unchanged too, a light's visibility of the last frame still holds.
    generation: u64,
    /// What [`SurfaceInputs::set_shows_only_scene`] said (read by nothing).
    only_scene: bool,
}

/// Surface generations are unique across all surfaces.
static SURFACE_GENERATION: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

fn next_generation() -> u64 {
    SURFACE_GENERATION.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

impl SurfaceInputs {
    pub fn new(
        device: &wgpu::Device,
        depth: wgpu::TextureView,
        normal: wgpu::TextureView,
        camera: CameraUniform,
        width: u32,
        height: u32,
    ) -> Self {
        let camera_buffer = crate::util::uniform_buffer(device, "camera", bytemuck::bytes_of(&camera));
        Self {
            width,
            height,
            depth,
            normal,
            geometric_normal: None,
            camera,
            camera_buffer,
            generation: next_generation(),
            only_scene: false,
        }
    }

    /// Gives the facets' own (geometric) normals, facing the camera, beside the shading normals:
    /// the receiver's horizon (`shaders/horizon.wgsl`) is then the facet's, as the truth's.
    pub fn set_geometric_normal(&mut self, view: wgpu::TextureView) {
        self.geometric_normal = Some(view);
        self.touch();
    }

    /// The geometric normals, or the shading normals where none were given.
    pub fn geometric_normal(&self) -> &wgpu::TextureView {
        self.geometric_normal.as_ref().unwrap_or(&self.normal)
    }

    /// Said that the depth buffer shows the scene's instances and nothing else, for the culling of
    /// a dragged object's footprint in shadow volumes. Dragged objects no longer make any technique
    /// resolve a footprint (the permanent surface, `live::temporary::PermanentSurface`), so nothing
    /// reads it.
    #[deprecated(note = "nothing reads it: dragged objects no longer make techniques resolve a footprint")]
    pub fn set_shows_only_scene(&mut self, only: bool) {
        self.only_scene = only;
    }

    #[deprecated(note = "nothing reads it: dragged objects no longer make techniques resolve a footprint")]
    pub fn shows_only_scene(&self) -> bool {
        self.only_scene
    }

    /// Updates the camera (after the application moved it).
    pub fn set_camera(&mut self, queue: &wgpu::Queue, camera: CameraUniform) {
        self.camera = camera;
        queue.write_buffer(&self.camera_buffer, 0, bytemuck::bytes_of(&camera));
        self.touch();
    }

    /// Says that the depth or normal buffers changed (an application that draws them itself, with
    /// things shadowlab does not know of, calls this every frame they change). The scene's own
    /// edits and camera moves are tracked without it.
    pub fn touch(&mut self) {
        self.generation = next_generation();
    }

    pub fn generation(&self) -> u64 {
        self.generation
    }
}

/// Format of visibility layers: one float per pixel, exact enough for metrics.
pub const VISIBILITY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

/// One light's visibility V_l for every pixel (DESIGN.md §2): the only thing a technique produces.
pub struct VisibilityLayer {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
}

impl VisibilityLayer {
    pub fn new(device: &wgpu::Device, width: u32, height: u32, label: &str) -> Self {
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: VISIBILITY_FORMAT,
            // Written by compute resolves (storage), or by fragment resolves where the device has
            // no compute (a render target: `technique::dispatch_program_in`).
            usage: if crate::gpu::runs_compute(device) {
                wgpu::TextureUsages::STORAGE_BINDING
            } else {
                wgpu::TextureUsages::RENDER_ATTACHMENT
            } | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        Self { texture, view }
    }

    pub fn bytes(&self) -> u64 {
        let s = self.texture.size();
        u64::from(s.width) * u64::from(s.height) * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> CameraUniform {
        let view = View {
            name: "test".into(),
            position: Vec3::new(0.0, 1.0, 5.0),
            target: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
            near: 0.1,
            far: 100.0,
        };
        CameraUniform::from_view(&view, 100, 80)
    }

    #[test]
    fn footprints_bound_what_a_box_covers() {
        let c = camera();
        // A small box on the axis: a rectangle around the centre pixel (50, 40), one pixel wider.
        let b = Aabb::new(Vec3::new(-0.1, 0.9, -0.1), Vec3::new(0.1, 1.1, 0.1));
        let Footprint::Rect([x, y, w, h]) = c.footprint(&b) else { panic!("{:?}", c.footprint(&b)) };
        assert!(x < 50 && x + w > 50 && y < 40 && y + h > 40, "{:?}", [x, y, w, h]);
        // Its half-width at distance 4.9..5.1: 0.1 / (5 · tan 30°) of 40 pixels ≈ 1.4 px; with the
        // pixel of padding and outward rounding, at most 10 pixels across.
        assert!(w <= 10 && h <= 10, "{:?}", [x, y, w, h]);
        // Wholly outside the view: nothing; reaching behind the eye: anything.
        assert_eq!(c.footprint(&Aabb::new(Vec3::new(50.0, 0.0, 0.0), Vec3::new(51.0, 1.0, 1.0))), Footprint::Nothing);
        assert_eq!(c.footprint(&Aabb::new(Vec3::new(-1.0, 0.0, 4.0), Vec3::new(1.0, 2.0, 6.0))), Footprint::Whole);
        assert_eq!(c.footprint(&Aabb::EMPTY), Footprint::Nothing);
        assert_eq!(c.footprint_of([Vec3::new(0.0, 1.0, f32::NAN)]), Footprint::Whole);
    }

    /// A body reaching behind the eye (a shadow's prism running past the camera) covers what the
    /// eye sees of it, not the whole screen; one wholly behind the eye covers nothing.
    #[test]
    fn a_body_reaching_behind_the_eye_covers_only_what_the_eye_sees() {
        let c = camera();
        // A bar on the right of the view, from 7 m ahead of the eye (at z = 5) to 5 m behind it.
        let bar = Aabb::new(Vec3::new(0.5, 0.9, -2.0), Vec3::new(1.0, 1.1, 10.0));
        assert_eq!(c.footprint(&bar), Footprint::Whole, "its corners alone cannot bound it");
        let Footprint::Rect([x, y, w, h]) = c.footprint_of_body(&ConvexBody::from_aabb(&bar)) else {
            panic!("{:?}", c.footprint_of_body(&ConvexBody::from_aabb(&bar)))
        };
        // Right of the centre column (50), reaching the right edge, and the bar's far end inside.
        assert!(x >= 49 && x + w == 100, "{:?}", [x, y, w, h]);
        let Footprint::Rect([fx, fy, _, _]) = c.footprint_of([Vec3::new(0.75, 1.0, -2.0)]) else { panic!() };
        assert!(fx >= x && fx < x + w && fy >= y && fy < y + h, "{:?} outside {:?}", (fx, fy), [x, y, w, h]);
        let behind = Aabb::new(Vec3::new(-1.0, 0.0, 6.0), Vec3::new(1.0, 2.0, 9.0));
        assert_eq!(c.footprint_of_body(&ConvexBody::from_aabb(&behind)), Footprint::Nothing);
    }

    #[test]
    fn footprints_unite() {
        let (a, b) = (Footprint::Rect([0, 0, 2, 2]), Footprint::Rect([5, 1, 1, 4]));
        assert_eq!(a.union(b), Footprint::Rect([0, 0, 6, 5]));
        assert_eq!(a.union(Footprint::Nothing), a);
        assert_eq!(Footprint::Nothing.union(b), b);
        assert_eq!(a.union(Footprint::Whole), Footprint::Whole);
    }
}
