//! Named camera views and their projection conventions.
//!
//! Conventions (shared by the GPU renderer and the CPU reference, so that pixel `(x, y)` is the same
//! surface point in both): right-handed world, the camera looks along −Z of its own frame,
//! wgpu-style clip space with depth in [0, 1], pixel (0, 0) at the top left, and the primary ray of
//! a pixel through its centre `(x + ½, y + ½)`.

use glam::{Mat4, Vec3};

/// A perspective camera placed by position, target and up.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    pub name: String,
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    pub near: f32,
    pub far: f32,
}

impl View {
    /// `base` moved to the camera `text` = `X,Y,Z:TX,TY,TZ[:FOV]` (eye, target, vertical field of
    /// view in degrees; default `base`'s), as the CLI's `--camera` and the viewer's "copy
    /// command" write it. Near and far stay `base`'s.
    pub fn with_camera_text(base: &View, text: &str) -> Result<View, String> {
        let parts: Vec<&str> = text.split(':').collect();
        if !(2..=3).contains(&parts.len()) {
            return Err(format!("camera '{text}' is not X,Y,Z:TX,TY,TZ[:FOV_DEGREES]"));
        }
        let point = |part: &str| -> Result<Vec3, String> {
            let v: Vec<f32> = part
                .split(',')
                .map(|c| c.trim().parse::<f32>().map_err(|_| format!("'{c}' in camera '{text}' is not a number")))
                .collect::<Result<_, _>>()?;
            match v[..] {
                [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(x, y, z)),
                _ => Err(format!("'{part}' in camera '{text}' is not three finite numbers X,Y,Z")),
            }
        };
        let (position, target) = (point(parts[0])?, point(parts[1])?);
        if position.distance(target) <= 1e-6 * position.length().max(1.0) {
            return Err(format!("camera '{text}': the eye and the target are the same point"));
        }
        let fov_y = match parts.get(2) {
            Some(f) => {
                let degrees: f32 =
                    f.trim().parse().map_err(|_| format!("field of view '{f}' in camera '{text}' is not a number"))?;
                if !(1.0..=170.0).contains(&degrees) {
                    return Err(format!("field of view {degrees}° in camera '{text}' is outside 1..=170"));
                }
                degrees.to_radians()
            }
            None => base.fov_y,
        };
        let up = if (target - position).normalize().cross(Vec3::Y).length() < 1e-3 { Vec3::Z } else { Vec3::Y };
        Ok(View { name: "camera".into(), position, target, up, fov_y, near: base.near, far: base.far })
    }

    /// A view with a 60° vertical field of view.
    pub fn new(name: impl Into<String>, position: Vec3, target: Vec3, near: f32, far: f32) -> Self {
        Self { name: name.into(), position, target, up: Vec3::Y, fov_y: 60f32.to_radians(), near, far }
    }

    pub fn with_fov_degrees(mut self, fov_y_degrees: f32) -> Self {
        self.fov_y = fov_y_degrees.to_radians();
        self
    }

    pub fn with_up(mut self, up: Vec3) -> Self {
        self.up = up;
        self
    }

    /// Unit viewing direction.
    pub fn forward(&self) -> Vec3 {
        (self.target - self.position).normalize()
    }

    /// Orthonormal camera frame `(right, up, forward)`.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let f = self.forward();
        let r = f.cross(self.up).normalize();
        let u = r.cross(f);
        (r, u, f)
    }

    pub fn view_matrix(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.position, self.target, self.up)
    }

    /// Perspective projection into wgpu's clip space (y up, depth in [0, 1]) with **reversed Z**:
    /// the near plane maps to depth 1, the far plane to 0 (see [`crate::lightspace`]).
    pub fn projection(&self, aspect: f32) -> Mat4 {
        crate::lightspace::perspective_reversed(self.fov_y, aspect, self.near, self.far)
    }

    pub fn view_projection(&self, width: u32, height: u32) -> Mat4 {
        self.projection(width as f32 / height.max(1) as f32) * self.view_matrix()
    }

    /// The primary ray through the centre of pixel `(x, y)` of a `width × height` image: its origin
    /// (the camera position) and unit direction.
    pub fn pixel_ray(&self, x: u32, y: u32, width: u32, height: u32) -> (Vec3, Vec3) {
        self.image_ray(x as f32 + 0.5, y as f32 + 0.5, width, height)
    }

    /// The primary ray through the image point `(x, y)`, in pixels from the top-left corner (pixel
    /// centres at half-integers).
    pub fn image_ray(&self, x: f32, y: f32, width: u32, height: u32) -> (Vec3, Vec3) {
        let (r, u, f) = self.basis();
        let t = (0.5 * self.fov_y).tan();
        let aspect = width as f32 / height.max(1) as f32;
        let sx = (2.0 * x / width as f32 - 1.0) * t * aspect;
        let sy = (1.0 - 2.0 * y / height as f32) * t;
        (self.position, (f + sx * r + sy * u).normalize())
    }

    /// Returns a message naming the first unusable value.
    pub fn check(&self) -> Result<(), String> {
        if !(self.position.is_finite() && self.target.is_finite() && self.up.is_finite()) {
            return Err("position, target and up must be finite".to_owned());
        }
        let d = self.target - self.position;
        if d.length() <= 1e-6 * self.position.length().max(1.0) {
            return Err("target coincides with position".to_owned());
        }
        if d.normalize().cross(self.up).length() < 1e-4 {
            return Err("up is parallel to the viewing direction".to_owned());
        }
        let fov = self.fov_y.to_degrees();
        if !(fov.is_finite() && fov > 0.1 && fov < 179.0) {
            return Err(format!("vertical field of view {fov}° must be in (0.1°, 179°)"));
        }
        if !(self.near.is_finite() && self.near > 0.0) {
            return Err(format!("near {} must be > 0", self.near));
        }
        if !(self.far.is_finite() && self.far > self.near) {
            return Err(format!("far {} must be finite and > near {}", self.far, self.near));
        }
        if self.far / self.near > 1.0e7 {
            return Err(format!("far/near = {} exceeds 1e7: depth precision is lost", self.far / self.near));
        }
        Ok(())
    }
}

/// A scripted camera path: key views visited in order, interpolated over `frames` frames (position
/// and target move linearly between keys). Used to measure temporal stability (flicker).
#[derive(Debug, Clone, PartialEq)]
pub struct CameraPath {
    pub name: String,
    pub keys: Vec<View>,
    pub frames: u32,
}

impl CameraPath {
    /// The view of every frame.
    pub fn views(&self) -> Vec<View> {
        let frames = self.frames.max(2) as usize;
        if self.keys.is_empty() {
            return Vec::new();
        }
        if self.keys.len() == 1 {
            return vec![self.keys[0].clone(); frames];
        }
        let segments = (self.keys.len() - 1) as f32;
        (0..frames)
            .map(|f| {
                let t = f as f32 / (frames - 1) as f32 * segments;
                let k = (t.floor() as usize).min(self.keys.len() - 2);
                let u = t - k as f32;
                let (a, b) = (&self.keys[k], &self.keys[k + 1]);
                View {
                    name: format!("{}#{f}", self.name),
                    position: a.position.lerp(b.position, u),
                    target: a.target.lerp(b.target, u),
                    up: a.up.lerp(b.up, u).normalize_or(Vec3::Y),
                    fov_y: a.fov_y + (b.fov_y - a.fov_y) * u,
                    near: a.near + (b.near - a.near) * u,
                    far: a.far + (b.far - a.far) * u,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_text_parses_and_bad_text_is_an_error() {
        let base = View::new("base", Vec3::ZERO, Vec3::NEG_Z, 0.05, 40.0);
        let v = View::with_camera_text(&base, "1,2,3:0,1,0:45").expect("valid");
        assert_eq!((v.position, v.target), (Vec3::new(1.0, 2.0, 3.0), Vec3::Y));
        assert!((v.fov_y.to_degrees() - 45.0).abs() < 1e-4);
        assert_eq!((v.near, v.far), (0.05, 40.0), "near and far are the base view's");
        assert_eq!(View::with_camera_text(&base, "1,2,3:0,1,0").expect("valid").fov_y, base.fov_y);
        for bad in
            ["", "1,2,3", "1,2:0,0,0", "1,2,3:1,2,3", "nan,0,0:1,1,1", "0,0,0:1,1,1:0", "0,0,0:1,1,1:x", "a:b:c:d"]
        {
            assert!(View::with_camera_text(&base, bad).is_err(), "'{bad}' is refused");
        }
        // Looking straight down picks another up vector.
        let down = View::with_camera_text(&base, "0,5,0:0,0,0").expect("valid");
        assert_eq!(down.up, Vec3::Z);
    }
    use glam::Vec4Swizzles;

    #[test]
    fn pixel_ray_matches_projection() {
        let v = View::new("v", Vec3::new(1.0, 2.0, 5.0), Vec3::new(0.0, 0.5, 0.0), 0.1, 100.0).with_fov_degrees(50.0);
        let (w, h) = (64, 48);
        let vp = v.view_projection(w, h);
        for &(x, y) in &[(0u32, 0u32), (63, 47), (10, 30), (32, 24)] {
            let (o, d) = v.pixel_ray(x, y, w, h);
            let p = o + 3.0 * d;
            let c = vp * p.extend(1.0);
            let ndc = c.xyz() / c.w;
            let px = (ndc.x * 0.5 + 0.5) * w as f32;
            let py = (0.5 - ndc.y * 0.5) * h as f32;
            assert!((px - (x as f32 + 0.5)).abs() < 1e-3, "{px} vs {x}");
            assert!((py - (y as f32 + 0.5)).abs() < 1e-3, "{py} vs {y}");
            assert!(ndc.z > 0.0 && ndc.z < 1.0);
        }
    }

    #[test]
    fn paths_interpolate_between_keys() {
        let a = View::new("a", Vec3::ZERO, Vec3::X, 0.1, 10.0);
        let b = View::new("b", Vec3::new(0.0, 0.0, 2.0), Vec3::new(1.0, 0.0, 2.0), 0.1, 10.0);
        let p = CameraPath { name: "p".into(), keys: vec![a.clone(), b], frames: 5 };
        let v = p.views();
        assert_eq!(v.len(), 5);
        assert_eq!(v[0].position, a.position);
        assert!((v[2].position.z - 1.0).abs() < 1e-6);
        assert!((v[4].position.z - 2.0).abs() < 1e-6);
    }

    #[test]
    fn check_names_problems() {
        let v = View::new("v", Vec3::ZERO, Vec3::Y, 0.1, 10.0);
        assert!(v.check().unwrap_err().contains("parallel"));
        let v = View::new("v", Vec3::ZERO, Vec3::X, 0.0, 10.0);
        assert!(v.check().unwrap_err().contains("near"));
        let v = View::new("v", Vec3::ZERO, Vec3::X, 1.0, 0.5);
        assert!(v.check().unwrap_err().contains("far"));
        View::new("v", Vec3::ZERO, Vec3::X, 0.1, 10.0).check().unwrap();
    }
}
