//! Lights: the emitter shapes of DESIGN.md §3, their attenuation, and which surface points they reach.

use glam::Vec3;

use crate::scene::Mobility;

/// Largest spot cone half-angle: a perspective shadow map cannot cover a hemisphere.
pub const MAX_SPOT_HALF_ANGLE: f32 = std::f32::consts::FRAC_PI_2;
/// Largest angular radius of a directional light. The sun is 0.27°; beyond 45° a "direction" is
/// no longer a useful model.
pub const MAX_ANGULAR_RADIUS: f32 = std::f32::consts::FRAC_PI_4;
/// Largest accepted intensity; larger values are a unit mix-up, not a light.
pub const MAX_INTENSITY: f32 = 1.0e9;

/// The shape and placement of a light's emitter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightKind {
    /// Omnidirectional light; a sphere of `radius` (0: a point).
    Point { position: Vec3, radius: f32 },
    /// A point or sphere light restricted to a cone around `direction`.
    /// `inner_angle ≤ outer_angle` are half-angles in radians; the falloff runs between them.
    Spot { position: Vec3, direction: Vec3, inner_angle: f32, outer_angle: f32, radius: f32 },
    /// Light from infinitely far, travelling along `direction`; the cone of directions within
    /// `angular_radius` (radians) of it models the sun's disk (0: a single direction).
    Directional { direction: Vec3, angular_radius: f32 },
    /// A one-sided rectangle centred at `position`, emitting towards `direction` (its normal).
    /// `width` runs along `tangent`, `height` along `direction × tangent`.
    Rect { position: Vec3, direction: Vec3, tangent: Vec3, width: f32, height: f32 },
}

/// A light source of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Light {
    pub name: String,
    pub kind: LightKind,
    /// Linear RGB colour.
    pub color: Vec3,
    /// Scale of the emitted light (candela-like for local lights, lux-like for directional ones).
    pub intensity: f32,
    /// Distance beyond which a local light has no effect; `None` for unbounded.
    pub range: Option<f32>,
    pub mobility: Mobility,
}

impl Light {
    pub fn new(name: impl Into<String>, kind: LightKind, color: Vec3, intensity: f32) -> Self {
        Self { name: name.into(), kind, color, intensity, range: None, mobility: Mobility::Static }
    }

    pub fn with_range(mut self, range: f32) -> Self {
        self.range = Some(range);
        self
    }

    /// Moves the emitter's position by `f` (directions and sizes stay): [`crate::Scene::recentre`].
    pub fn translate(&mut self, f: impl Fn(Vec3) -> Vec3) {
        match &mut self.kind {
            LightKind::Point { position, .. } | LightKind::Spot { position, .. } | LightKind::Rect { position, .. } => {
                *position = f(*position)
            }
            LightKind::Directional { .. } => {}
        }
    }

    /// `point`, `spot`, `directional` or `rect`: the names used by the CLI, TOML files and reports.
    pub fn type_name(&self) -> &'static str {
        match self.kind {
            LightKind::Point { .. } => "point",
            LightKind::Spot { .. } => "spot",
            LightKind::Directional { .. } => "directional",
            LightKind::Rect { .. } => "rect",
        }
    }

    /// The emitter's centre; `None` for directional lights.
    pub fn position(&self) -> Option<Vec3> {
        match self.kind {
            LightKind::Point { position, .. } | LightKind::Spot { position, .. } | LightKind::Rect { position, .. } => {
                Some(position)
            }
            LightKind::Directional { .. } => None,
        }
    }

    /// The direction of emission: spot axis, rectangle normal, direction of travel of a directional
    /// light; `None` for point lights.
    pub fn direction(&self) -> Option<Vec3> {
        match self.kind {
            LightKind::Spot { direction, .. }
            | LightKind::Directional { direction, .. }
            | LightKind::Rect { direction, .. } => Some(direction),
            LightKind::Point { .. } => None,
        }
    }

    /// True when the emitter has no extent: visibility is binary (DESIGN.md §3).
    pub fn is_hard(&self) -> bool {
        match self.kind {
            LightKind::Point { radius, .. } | LightKind::Spot { radius, .. } => radius <= 0.0,
            LightKind::Directional { angular_radius, .. } => angular_radius <= 0.0,
            LightKind::Rect { width, height, .. } => width <= 0.0 && height <= 0.0,
        }
    }

    /// The emitter's size as one number for reports: radius (m), angular radius (degrees), or
    /// width × height as a string.
    pub fn emitter_size_text(&self) -> String {
        match self.kind {
            LightKind::Point { radius, .. } | LightKind::Spot { radius, .. } => {
                format!("radius {radius} m")
            }
            LightKind::Directional { angular_radius, .. } => {
                format!("angular radius {}°", degrees(angular_radius))
            }
            LightKind::Rect { width, height, .. } => format!("{width} × {height} m"),
        }
    }

    /// The emitter's size as the soft-shadow approximations (PCSS, smoothies) see it: a radius for
    /// local lights, the tangent of the angular radius for directional ones. A rectangle counts as
    /// the square of equal area, whose half side gives the exact penumbra width along its axes
    /// (the `penumbra` scene's closed form): `0.5·√(w·h)`.
    pub fn emitter_extent(&self) -> EmitterExtent {
        match self.kind {
            LightKind::Point { radius, .. } | LightKind::Spot { radius, .. } => EmitterExtent::Radius(radius.max(0.0)),
            LightKind::Rect { width, height, .. } => {
                EmitterExtent::Radius(0.5 * (width.max(0.0) * height.max(0.0)).sqrt())
            }
            LightKind::Directional { angular_radius, .. } => EmitterExtent::Angle(angular_radius.max(0.0).tan()),
        }
    }

    /// Half the width of the outer-to-inner penumbra that an occluder edge at distance `d` from the
    /// light casts on a receiver at distance `r ≥ d` (similar triangles: `R·(r − d)/d`; for a
    /// directional light `tan θ·(r − d)`).
    pub fn penumbra_half_width(&self, d: f32, r: f32) -> f32 {
        let gap = (r - d).max(0.0);
        match self.emitter_extent() {
            EmitterExtent::Radius(radius) => radius * gap / d.max(1e-6),
            EmitterExtent::Angle(tan) => tan * gap,
        }
    }

    /// Multiplies the emitter size by `s` (0 makes the light hard: a point or a single direction).
    pub fn scale_emitter(&mut self, s: f32) {
        match &mut self.kind {
            LightKind::Point { radius, .. } | LightKind::Spot { radius, .. } => *radius *= s,
            LightKind::Directional { angular_radius, .. } => {
                *angular_radius = (*angular_radius * s).min(MAX_ANGULAR_RADIUS)
            }
            LightKind::Rect { width, height, .. } => {
                *width *= s;
                *height *= s;
            }
        }
    }

    /// Unit vector from `p` towards the light's centre, and the distance to it (infinite for a
    /// directional light).
    pub fn to_light(&self, p: Vec3) -> (Vec3, f32) {
        match self.kind {
            LightKind::Directional { direction, .. } => (-direction, f32::INFINITY),
            _ => {
                let d = self.position().unwrap_or(Vec3::ZERO) - p;
                let len = d.length();
                (if len > 0.0 { d / len } else { Vec3::Y }, len)
            }
        }
    }

    /// Whether the point `p` with normal `n` is *relevant* for this light (DESIGN.md §3): the light's
    /// centre is in front of the surface, within range, inside a spot's cone and in front of a
    /// one-sided rectangle. Only relevant pixels enter the metrics.
    pub fn is_relevant(&self, p: Vec3, n: Vec3) -> bool {
        let (l, dist) = self.to_light(p);
        if n.dot(l) <= 0.0 {
            return false;
        }
        if let Some(range) = self.range
            && dist >= range
        {
            return false;
        }
        match self.kind {
            LightKind::Spot { direction, outer_angle, .. } => (-l).dot(direction) > outer_angle.cos(),
            LightKind::Rect { direction, .. } => (-l).dot(direction) > 0.0,
            _ => true,
        }
    }

    /// [`Light::is_relevant`] for a surface point with shading normal `n` and geometric normal `ng`:
    /// the light's centre must be in front by both (DESIGN.md §3). Where they disagree (terminators
    /// of smooth-shaded meshes) the visibility depends on conventions, not on the technique.
    pub fn is_relevant_surface(&self, p: Vec3, n: Vec3, ng: Vec3) -> bool {
        self.is_relevant(p, n) && ng.dot(self.to_light(p).0) > 0.0
    }

    /// The light's falloff at `p`: windowed inverse square for local lights (the window of the
    /// glTF `KHR_lights_punctual` specification, so it reaches 0 at `range`), the cone falloff of
    /// spot lights, the cosine of a one-sided rectangle emitter. 1 for directional lights.
    pub fn attenuation(&self, p: Vec3) -> f32 {
        let (l, dist) = self.to_light(p);
        let distance_term = |radius: f32| {
            // Inside the emitter the inverse square would explode; clamp at its radius (1 cm min).
            let d2 = (dist * dist).max((radius.max(0.01)).powi(2));
            let window = match self.range {
                Some(range) => (1.0 - (dist / range).powi(4)).clamp(0.0, 1.0),
                None => 1.0,
            };
            window / d2
        };
        match self.kind {
            LightKind::Directional { .. } => 1.0,
            LightKind::Point { radius, .. } => distance_term(radius),
            LightKind::Spot { direction, inner_angle, outer_angle, radius, .. } => {
                let cd = (-l).dot(direction);
                let (co, ci) = (outer_angle.cos(), inner_angle.cos());
                let t = if ci - co > 1e-6 {
                    ((cd - co) / (ci - co)).clamp(0.0, 1.0)
                } else if cd > co {
                    1.0
                } else {
                    0.0
                };
                distance_term(radius) * t * t
            }
            LightKind::Rect { direction, width, height, .. } => {
                distance_term(0.5 * width.max(height)) * (-l).dot(direction).max(0.0)
            }
        }
    }

    /// Returns a message naming the first absurd parameter (NaN, negative sizes, a spot cone wider
    /// than a hemisphere, an emitter larger than its range, ...).
    pub fn check(&self) -> Result<(), String> {
        let finite_nonneg = |what: &str, v: f32| {
            if v.is_finite() && v >= 0.0 { Ok(()) } else { Err(format!("{what} {v} must be finite and ≥ 0")) }
        };
        let unit = |what: &str, v: Vec3| {
            if v.is_finite() && (v.length() - 1.0).abs() < 1e-3 {
                Ok(())
            } else {
                Err(format!("{what} {v} must be a finite unit vector"))
            }
        };
        if !self.color.is_finite() || self.color.min_element() < 0.0 {
            return Err(format!("colour {} must be finite and ≥ 0", self.color));
        }
        finite_nonneg("intensity", self.intensity)?;
        if self.intensity > MAX_INTENSITY {
            return Err(format!("intensity {} exceeds {MAX_INTENSITY}", self.intensity));
        }
        if let Some(range) = self.range
            && !(range.is_finite() && range > 0.0)
        {
            return Err(format!("range {range} must be finite and > 0"));
        }
        if let Some(p) = self.position()
            && !p.is_finite()
        {
            return Err(format!("position {p} must be finite"));
        }
        let check_radius = |radius: f32| {
            finite_nonneg("radius", radius)?;
            match self.range {
                Some(range) if radius >= range => {
                    Err(format!("radius {radius} must be smaller than the range {range}"))
                }
                _ => Ok(()),
            }
        };
        match self.kind {
            LightKind::Point { radius, .. } => check_radius(radius)?,
            LightKind::Spot { direction, inner_angle, outer_angle, radius, .. } => {
                check_radius(radius)?;
                unit("direction", direction)?;
                if !(outer_angle.is_finite() && outer_angle > 0.0 && outer_angle <= MAX_SPOT_HALF_ANGLE) {
                    return Err(format!("outer cone half-angle {}° must be in (0°, 90°]", degrees(outer_angle)));
                }
                if !(inner_angle.is_finite() && inner_angle >= 0.0 && inner_angle <= outer_angle) {
                    return Err(format!(
                        "inner cone half-angle {}° must be in [0°, outer {}°]",
                        degrees(inner_angle),
                        degrees(outer_angle)
                    ));
                }
            }
            LightKind::Directional { direction, angular_radius } => {
                unit("direction", direction)?;
                if !(angular_radius.is_finite() && (0.0..=MAX_ANGULAR_RADIUS).contains(&angular_radius)) {
                    return Err(format!("angular radius {}° must be in [0°, 45°]", degrees(angular_radius)));
                }
            }
            LightKind::Rect { direction, tangent, width, height, .. } => {
                unit("direction", direction)?;
                unit("tangent", tangent)?;
                if direction.dot(tangent).abs() > 1e-3 {
                    return Err("tangent must be perpendicular to the direction".to_owned());
                }
                finite_nonneg("width", width)?;
                finite_nonneg("height", height)?;
                if let Some(range) = self.range
                    && 0.5 * width.hypot(height) >= range
                {
                    return Err(format!("rectangle {width} × {height} is larger than the range {range}"));
                }
            }
        }
        Ok(())
    }
}

/// An angle in degrees for messages, rounded to 1e-4° so that a 120° cone given in degrees and
/// stored in radians (f32) reads 120°, not 120.00001°.
pub fn degrees(radians: f32) -> f64 {
    (f64::from(radians).to_degrees() * 1e4).round() / 1e4
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spot() -> Light {
        Light::new(
            "s",
            LightKind::Spot {
                position: Vec3::new(0.0, 2.0, 0.0),
                direction: -Vec3::Y,
                inner_angle: 20f32.to_radians(),
                outer_angle: 30f32.to_radians(),
                radius: 0.05,
            },
            Vec3::ONE,
            10.0,
        )
    }

    #[test]
    fn relevance() {
        let s = spot();
        assert!(s.is_relevant(Vec3::ZERO, Vec3::Y));
        assert!(!s.is_relevant(Vec3::ZERO, -Vec3::Y), "back-facing");
        assert!(!s.is_relevant(Vec3::new(2.0, 0.0, 0.0), Vec3::Y), "outside the 30° cone");
        let s = s.with_range(1.5);
        assert!(!s.is_relevant(Vec3::ZERO, Vec3::Y), "out of range");
        let sun =
            Light::new("sun", LightKind::Directional { direction: -Vec3::Y, angular_radius: 0.0 }, Vec3::ONE, 1.0);
        assert!(sun.is_relevant(Vec3::splat(1e6), Vec3::Y));
        assert!(!sun.is_relevant(Vec3::ZERO, Vec3::X), "grazing counts as not in front");
    }

    #[test]
    fn attenuation_falls_to_zero_at_range() {
        let p = Light::new("p", LightKind::Point { position: Vec3::ZERO, radius: 0.0 }, Vec3::ONE, 1.0).with_range(4.0);
        assert!((p.attenuation(Vec3::new(1.0, 0.0, 0.0)) - (1.0 - 1.0 / 256.0)).abs() < 1e-6);
        assert_eq!(p.attenuation(Vec3::new(4.0, 0.0, 0.0)), 0.0);
        let s = spot();
        assert!(s.attenuation(Vec3::ZERO) > 0.0);
        assert_eq!(s.attenuation(Vec3::new(2.0, 0.0, 0.0)), 0.0);
    }

    #[test]
    fn absurd_parameters_are_named() {
        let mut s = spot();
        s.kind = LightKind::Spot {
            position: Vec3::ZERO,
            direction: -Vec3::Y,
            inner_angle: 0.1,
            outer_angle: 2.0,
            radius: 0.0,
        };
        assert!(s.check().unwrap_err().contains("outer cone"));
        // Degrees as given: 120°, not the f32 round trip's 120.00001°.
        s.kind = LightKind::Spot {
            position: Vec3::ZERO,
            direction: -Vec3::Y,
            inner_angle: 0.1,
            outer_angle: 120f32.to_radians(),
            radius: 0.0,
        };
        let message = s.check().unwrap_err();
        assert!(message.contains("half-angle 120° must be"), "{message}");
        let mut s = spot();
        s.intensity = f32::NAN;
        assert!(s.check().unwrap_err().contains("intensity"));
        let mut s = spot();
        s.range = Some(0.01);
        assert!(s.check().unwrap_err().contains("radius"));
        let p = Light::new("p", LightKind::Point { position: Vec3::NAN, radius: 0.1 }, Vec3::ONE, 1.0);
        assert!(p.check().unwrap_err().contains("position"));
        spot().check().unwrap();
    }

    #[test]
    fn emitter_scale_zero_makes_hard() {
        let mut s = spot();
        assert!(!s.is_hard());
        s.scale_emitter(0.0);
        assert!(s.is_hard());
    }
}

/// An emitter's size for soft-shadow approximations ([`Light::emitter_extent`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EmitterExtent {
    /// Radius in world units (sphere lights; rectangles as their equal-area square's half side).
    Radius(f32),
    /// Tangent of the angular radius (directional lights).
    Angle(f32),
}
