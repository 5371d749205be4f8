//! `penumbra`: the analytic case. A square occluder over a ground plane under a square area light,
//! all three parallel and centred on the y axis, so that the visibility of a ground point has a
//! closed form ([`PenumbraSetup::visibility`]): the test oracle for the reference and for every
//! soft-shadow technique.

use glam::{Vec2, Vec3};

use super::{Builder, at};
use crate::camera::View;
use crate::light::{Light, LightKind};
use crate::material::Material;
use crate::params::{ParamDef, ParamSet};
use crate::primitives;
use crate::scene::{Role, Scene};

pub const SUMMARY: &str = "analytic soft shadow: 1 m square at 1 m over a 4 m plane, 0.5 m square light at 3 m";

pub static OPTIONS: &[ParamDef] = &[
    ParamDef::float("light_size", 0.5, 0.0, 2.0, "side of the square light (m)"),
    ParamDef::float("occluder_size", 1.0, 0.01, 3.0, "side of the square occluder (m)"),
    ParamDef::float("occluder_height", 1.0, 0.05, 2.5, "height of the occluder above the ground (m)"),
    ParamDef::float("light_height", 3.0, 2.6, 10.0, "height of the light above the ground (m)"),
];

/// The geometry of the scene, and its closed-form visibility.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PenumbraSetup {
    pub ground_size: f32,
    pub occluder_size: f32,
    pub occluder_height: f32,
    pub light_size: f32,
    pub light_height: f32,
}

impl Default for PenumbraSetup {
    fn default() -> Self {
        Self::from_options(&ParamSet::new(OPTIONS))
    }
}

impl PenumbraSetup {
    pub fn from_options(o: &ParamSet) -> Self {
        Self {
            ground_size: 4.0,
            occluder_size: o.float("occluder_size") as f32,
            occluder_height: o.float("occluder_height") as f32,
            light_size: o.float("light_size") as f32,
            light_height: o.float("light_height") as f32,
        }
    }

    /// Exact visibility of the square light from `p` (DESIGN.md §3: the visible fraction of the
    /// emitter's area).
    ///
    /// Seen from `p`, the occluder's square (at height h_o) projects onto the light's plane (height
    /// h_l) as another axis-aligned square: a corner q maps to p + (q − p)·s with
    /// s = (h_l − p_y)/(h_o − p_y). V = 1 − area(light ∩ projection)/area(light), and the overlap of
    /// two axis-aligned squares is the product of the overlaps of their x and z intervals. Points at
    /// or above the occluder see the whole light.
    pub fn visibility(&self, p: Vec3) -> f32 {
        if p.y >= self.occluder_height {
            return 1.0;
        }
        let s = (self.light_height - p.y) / (self.occluder_height - p.y);
        let half_o = 0.5 * self.occluder_size;
        let half_l = 0.5 * self.light_size;
        if half_l <= 0.0 {
            // A point light: visible unless the ray to the centre crosses the occluder.
            let q = Vec2::new(p.x, p.z) * (1.0 - 1.0 / s);
            return if q.x.abs() < half_o && q.y.abs() < half_o { 0.0 } else { 1.0 };
        }
        let overlap = |pc: f32| {
            let lo = pc + (-half_o - pc) * s;
            let hi = pc + (half_o - pc) * s;
            (hi.min(half_l) - lo.max(-half_l)).max(0.0)
        };
        1.0 - overlap(p.x) * overlap(p.z) / (self.light_size * self.light_size)
    }
}

pub fn build(options: &ParamSet) -> Scene {
    let setup = PenumbraSetup::from_options(options);
    let mut b = Builder::new("penumbra");
    let grey = b.material(Material::diffuse("ground", Vec3::splat(0.75)));
    let dark = b.material(Material::diffuse("occluder", Vec3::new(0.6, 0.25, 0.2)));
    b.object("ground", primitives::plane(setup.ground_size, setup.ground_size, 1, 1), grey, at(0.0, 0.0, 0.0))
        .with_role(Role::Receiver);
    b.object(
        "occluder",
        primitives::card(setup.occluder_size, setup.occluder_size),
        dark,
        at(0.0, setup.occluder_height, 0.0),
    )
    .with_role(Role::Occluder);
    let mut scene = b.finish();
    scene.add_light(Light::new(
        "panel",
        LightKind::Rect {
            position: Vec3::new(0.0, setup.light_height, 0.0),
            direction: -Vec3::Y,
            tangent: Vec3::X,
            width: setup.light_size,
            height: setup.light_size,
        },
        Vec3::ONE,
        30.0,
    ));
    scene.views = vec![
        View::new("default", Vec3::new(3.2, 3.4, 4.2), Vec3::new(0.0, 0.2, 0.0), 0.1, 30.0).with_fov_degrees(45.0),
        // Straight down; up is −Z so that +X is to the right.
        View::new("top", Vec3::new(0.0, 5.0, 0.0), Vec3::ZERO, 0.5, 20.0).with_fov_degrees(45.0).with_up(-Vec3::Z),
        View::new("low", Vec3::new(-3.5, 0.6, 2.5), Vec3::new(0.3, 0.0, -0.2), 0.05, 30.0).with_fov_degrees(55.0),
    ];
    scene
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_form_limits() {
        let s = PenumbraSetup::default();
        // Under the centre the occluder's projection (3 m wide in the light plane) covers the light.
        assert_eq!(s.visibility(Vec3::ZERO), 0.0);
        // Far away nothing is hidden.
        assert_eq!(s.visibility(Vec3::new(1.9, 0.0, 1.9)), 1.0);
        // Above the occluder everything is visible.
        assert_eq!(s.visibility(Vec3::new(0.0, 1.5, 0.0)), 1.0);
        // On the x axis the projected square spans x ∈ [−1.5 − 2 p_x, 1.5 − 2 p_x]: fully covering
        // the light [−0.25, 0.25] until 1.5 − 2 p_x = 0.25 (p_x = 0.625), gone at p_x = 0.875.
        assert_eq!(s.visibility(Vec3::new(0.62, 0.0, 0.0)), 0.0);
        assert!((s.visibility(Vec3::new(0.75, 0.0, 0.0)) - 0.5).abs() < 1e-6);
        assert_eq!(s.visibility(Vec3::new(0.88, 0.0, 0.0)), 1.0);
    }

    #[test]
    fn monotone_across_the_penumbra() {
        let s = PenumbraSetup::default();
        let mut last = -1.0;
        for i in 0..=100 {
            let v = s.visibility(Vec3::new(0.5 + 0.005 * i as f32, 0.0, 0.1));
            assert!(v >= last - 1e-6);
            last = v;
        }
    }
}
