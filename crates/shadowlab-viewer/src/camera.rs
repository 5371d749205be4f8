//! The fly camera: a position, a heading and a pitch, moved by keys and turned by the mouse.

use glam::Vec3;
use shadowlab_core::View;

/// Pitch stays short of straight up or down, where the heading is undefined.
const MAX_PITCH: f32 = 1.55;

#[derive(Debug, Clone, PartialEq)]
pub struct FlyCamera {
    pub position: Vec3,
    /// Heading around +y, radians (0 looks along -z).
    pub yaw: f32,
    /// Radians above the horizon.
    pub pitch: f32,
    pub fov_y: f32,
    pub near: f32,
    pub far: f32,
    /// Metres per second of key movement (scaled to the scene).
    pub speed: f32,
}

impl FlyCamera {
    /// The camera of a scene's view; `scene_size` (the scene box's diagonal) sets the speed.
    pub fn from_view(view: &View, scene_size: f32) -> Self {
        let d = (view.target - view.position).normalize_or(Vec3::NEG_Z);
        Self {
            position: view.position,
            yaw: (-d.x).atan2(-d.z),
            pitch: d.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH),
            fov_y: view.fov_y,
            near: view.near,
            far: view.far,
            speed: (0.25 * scene_size).max(1e-3),
        }
    }

    pub fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(-sy * cp, sp, -cy * cp)
    }

    pub fn right(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        Vec3::new(cy, 0.0, -sy)
    }

    pub fn view(&self) -> View {
        View {
            name: "viewer".into(),
            position: self.position,
            target: self.position + self.forward(),
            up: Vec3::Y,
            fov_y: self.fov_y,
            near: self.near,
            far: self.far,
        }
    }

    /// Turns by a mouse movement of `dx`, `dy` pixels (`sensitivity` radians per pixel).
    pub fn turn(&mut self, dx: f32, dy: f32, sensitivity: f32) {
        if !(dx.is_finite() && dy.is_finite()) {
            return;
        }
        self.yaw -= dx * sensitivity;
        self.pitch = (self.pitch - dy * sensitivity).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Moves by `seconds` of travel along (right, up, forward) in `-1..=1` each.
    pub fn travel(&mut self, along: Vec3, seconds: f32) {
        if !(along.is_finite() && seconds.is_finite()) {
            return;
        }
        let step = self.right() * along.x + Vec3::Y * along.y + self.forward() * along.z;
        self.position += step * self.speed * seconds;
    }

    /// The world-space ray through the pixel centre `(x, y)` of a `width × height` image.
    pub fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> (Vec3, Vec3) {
        let (w, h) = (width.max(1) as f32, height.max(1) as f32);
        let ndc_x = 2.0 * x / w - 1.0;
        let ndc_y = 1.0 - 2.0 * y / h;
        let t = (0.5 * self.fov_y).tan();
        let dir = self.forward() + self.right() * (ndc_x * t * w / h) + self.up() * (ndc_y * t);
        (self.position, dir.normalize_or(self.forward()))
    }

    fn up(&self) -> Vec3 {
        self.right().cross(self.forward())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_view_round_trips_through_the_fly_camera() {
        let view = View::new("v", Vec3::new(1.0, 2.0, 3.0), Vec3::new(-1.0, 1.0, -2.0), 0.1, 50.0);
        let cam = FlyCamera::from_view(&view, 10.0);
        let back = cam.view();
        let d = (view.target - view.position).normalize();
        assert!((back.target - back.position).abs_diff_eq(d, 1e-5), "{:?} vs {d}", back.target - back.position);
        assert_eq!(back.position, view.position);
    }

    #[test]
    fn the_centre_ray_is_the_forward_direction_and_corners_spread_by_the_field_of_view() {
        let view = View::new("v", Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 0.1, 50.0);
        let cam = FlyCamera::from_view(&view, 10.0);
        let (_, centre) = cam.ray(50.0, 25.0, 100, 50);
        assert!(centre.abs_diff_eq(Vec3::NEG_Z, 1e-6));
        // The top edge's centre is half the vertical field of view above the axis.
        let (_, top) = cam.ray(50.0, 0.0, 100, 50);
        assert!((top.angle_between(Vec3::NEG_Z) - 0.5 * view.fov_y).abs() < 1e-5);
        assert!(top.y > 0.0, "up is up");
        let (_, right) = cam.ray(100.0, 25.0, 100, 50);
        assert!(right.x > 0.0, "right is right");
    }

    #[test]
    fn pitch_stops_short_of_the_poles_and_nan_is_ignored() {
        let mut cam = FlyCamera::from_view(&View::new("v", Vec3::ZERO, Vec3::NEG_Z, 0.1, 5.0), 1.0);
        cam.turn(0.0, -1e6, 0.01);
        assert!(cam.pitch <= MAX_PITCH && cam.forward().is_finite());
        let before = cam.clone();
        cam.turn(f32::NAN, 1.0, 0.01);
        cam.travel(Vec3::new(f32::NAN, 0.0, 0.0), 1.0);
        assert_eq!(cam, before);
    }
}
