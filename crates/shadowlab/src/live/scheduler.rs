//! Work spread over frames (Toromanoff 2005 §VII.2–4, NOTES-000 §3.4–3.7: algorithms 13, 14 and 15).
//!
//! Every cache fill of the live engine is made of small resumable **units** (one map view, a batch of
//! a light map's emitter samples, one object's volumes for a light). Each frame has a [`Budget`]:
//! the target frame time minus the predicted render time minus a margin; units run, by priority,
//! while their predicted cost ([`CostModel`], running estimates from measured GPU time) fits, and at
//! least one runs every frame so that work always ends. What a unit renders is not shown until
//! every unit of its set is done (Toromanoff's all-or-nothing rule): a light shows the best level it
//! has complete.
//!
//! The rendering parameters that fix the render time itself (each light's rung on its quality
//! ladder) follow the measured frame time with hysteresis ([`Adaptation`], alg. 15), so that a cost
//! hovering at the target does not make them switch back and forth.

use std::collections::HashMap;

/// What a unit of work is, for its cost estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum UnitKind {
    /// One view of a map (a cube face, a cone, a cascade, an emitter sample's view).
    MapView,
    /// One emitter sample of one receiver's light map.
    LightMapSample,
    /// One object's volumes for one light sample.
    VolumeObject,
}

impl UnitKind {
    pub const ALL: [UnitKind; 3] = [Self::MapView, Self::LightMapSample, Self::VolumeObject];

    /// The cost assumed before anything was measured (ms on a CPU rasteriser, a conservative
    /// start) for a unit of the size given: a 1024² map view, a light-map sample into 256² texels,
    /// the volumes of a 1,024-face object.
    fn prior(self) -> (f64, UnitSize) {
        match self {
            Self::MapView => (4.0, 1 << 20),
            Self::LightMapSample => (1.0, 1 << 16),
            Self::VolumeObject => (0.2, 1 << 10),
        }
    }
}

/// How big a unit is, in what its cost grows with: texels for map views and light-map samples,
/// faces for an object's volumes.
pub type UnitSize = u64;

/// A unit size's class: ⌈log₂ size⌉ (units within a factor of two share an estimate).
pub fn size_class(size: UnitSize) -> u8 {
    (u64::BITS - size.max(1).saturating_sub(1).leading_zeros()) as u8
}

/// Units run in a frame: `(kind, size class, count)`, what a frame's measured time is shared among.
pub type UnitCounts = Vec<(UnitKind, u8, u32)>;

/// Adds `count` units of `kind` and `size` to `counts`.
pub fn count_units(counts: &mut UnitCounts, kind: UnitKind, size: UnitSize, count: u32) {
    let class = size_class(size);
    match counts.iter_mut().find(|c| c.0 == kind && c.1 == class) {
        Some(c) => c.2 += count,
        None => counts.push((kind, class, count)),
    }
}

/// Running estimates of what a unit costs, per kind and size class: an exponential moving average
/// of measured GPU milliseconds per unit. A class not measured yet is predicted from the nearest
/// measured class of its kind, or from the prior: scaled up in proportion to size from a smaller
/// class, kept as is from a larger one.
#[derive(Debug, Clone)]
pub struct CostModel {
    estimates: HashMap<(UnitKind, u8), f64>,
    /// Scripted costs per kind, whatever the size.
    fixed: HashMap<UnitKind, f64>,
    /// Weight of a new measurement (0.25: a quarter of the estimate moves each time; 0: scripted
    /// costs that measurements do not change).
    pub smoothing: f64,
}

impl Default for CostModel {
    fn default() -> Self {
        Self { estimates: HashMap::new(), fixed: HashMap::new(), smoothing: 0.25 }
    }
}

impl CostModel {
    /// Fixed costs (ms per unit of each kind, whatever its size) that measurements leave as they
    /// are: a scripted clock for deterministic tests and for applications that know their costs.
    pub fn scripted(costs: &[(UnitKind, f64)]) -> Self {
        Self { estimates: HashMap::new(), fixed: costs.iter().copied().collect(), smoothing: 0.0 }
    }

    /// The predicted cost of one unit of `kind` and `size`, in ms.
    pub fn predict(&self, kind: UnitKind, size: UnitSize) -> f64 {
        if let Some(&ms) = self.fixed.get(&kind) {
            return ms;
        }
        let class = size_class(size);
        // Up from a smaller class in proportion to size; never down (a pass's fixed cost dominates
        // small units): predictions err towards frames under the target.
        let scaled = |ms: f64, from: u8| ms * 2f64.powi((i32::from(class) - i32::from(from)).max(0));
        if let Some(&ms) = self.estimates.get(&(kind, class)) {
            return ms;
        }
        let nearest = self
            .estimates
            .iter()
            .filter(|((k, _), _)| *k == kind)
            .min_by_key(|((_, c), _)| (c.abs_diff(class), *c))
            .map(|((_, c), &ms)| scaled(ms, *c));
        nearest.unwrap_or_else(|| {
            let (ms, at) = kind.prior();
            scaled(ms, size_class(at))
        })
    }

    /// Takes in a measurement: `units` units of `kind` and `size` took `ms` together. Non-finite
    /// or negative measurements are ignored, and so are all under a scripted clock.
    pub fn observe(&mut self, kind: UnitKind, size: UnitSize, units: u32, ms: f64) {
        if units == 0 || !ms.is_finite() || ms < 0.0 || self.fixed.contains_key(&kind) {
            return;
        }
        let per_unit = ms / f64::from(units);
        let alpha = self.smoothing.clamp(0.0, 1.0);
        let e = self.estimates.entry((kind, size_class(size))).or_insert(per_unit);
        *e += alpha * (per_unit - *e);
    }

    /// Takes in one frame's measured work time, shared among the units run in proportion to their
    /// predicted costs (a frame's timestamps do not tell units apart).
    pub fn observe_frame(&mut self, units: &[(UnitKind, u8, u32)], work_ms: f64) {
        let size = |class: u8| 1u64 << class.min(63);
        let predicted: f64 = units.iter().map(|&(k, c, n)| self.predict(k, size(c)) * f64::from(n)).sum();
        if predicted <= 0.0 || !work_ms.is_finite() || work_ms < 0.0 {
            return;
        }
        let scale = work_ms / predicted;
        let observed: Vec<(UnitKind, u8, u32, f64)> =
            units.iter().map(|&(k, c, n)| (k, c, n, self.predict(k, size(c)) * f64::from(n) * scale)).collect();
        for (k, c, n, ms) in observed {
            self.observe(k, size(c), n, ms);
        }
    }
}

/// One frame's allowance for work.
#[derive(Debug, Clone, PartialEq)]
pub struct Budget {
    /// Predicted ms the frame may spend on units (infinite: everything now, the default).
    limit_ms: f64,
    spent_ms: f64,
    units: u32,
    /// Units refused this frame (work left for later frames).
    pub deferred: u32,
}

impl Default for Budget {
    fn default() -> Self {
        Self::unlimited()
    }
}

impl Budget {
    /// No limit: every invalid item is rebuilt in the frame that invalidated it.
    pub fn unlimited() -> Self {
        Self { limit_ms: f64::INFINITY, spent_ms: 0.0, units: 0, deferred: 0 }
    }

    /// At most `ms` of predicted work (at least one unit runs whatever its cost).
    pub fn new(ms: f64) -> Self {
        Self { limit_ms: if ms.is_nan() { 0.0 } else { ms.max(0.0) }, spent_ms: 0.0, units: 0, deferred: 0 }
    }

    /// Toromanoff's alg. 15 budget: the target frame time minus the predicted render time minus a
    /// margin (a fraction of the target).
    pub fn for_frame(target_ms: f64, predicted_render_ms: f64, margin: f64) -> Self {
        Self::new(target_ms - predicted_render_ms - margin * target_ms)
    }

    pub fn is_unlimited(&self) -> bool {
        self.limit_ms.is_infinite()
    }

    /// Whether a unit predicted to cost `ms` may run now; if so it is counted as spent. The first
    /// unit of a frame always may (so that work always ends).
    pub fn take(&mut self, ms: f64) -> bool {
        if self.units == 0 || self.spent_ms + ms <= self.limit_ms {
            self.spent_ms += ms.max(0.0);
            self.units += 1;
            true
        } else {
            self.deferred += 1;
            false
        }
    }

    /// Spends the whole budget on work of the frame's own that is not a unit (its first unit
    /// included): every unit of some cost asked for afterwards is refused.
    pub fn exhaust(&mut self) {
        if !self.is_unlimited() {
            self.spent_ms = self.spent_ms.max(self.limit_ms);
            self.units = self.units.max(1);
        }
    }

    /// Whether the budget allows nothing more of that cost (without counting a refusal).
    pub fn would_refuse(&self, ms: f64) -> bool {
        self.units > 0 && self.spent_ms + ms > self.limit_ms
    }

    pub fn spent_ms(&self) -> f64 {
        self.spent_ms
    }

    pub fn limit_ms(&self) -> f64 {
        self.limit_ms
    }

    pub fn units(&self) -> u32 {
        self.units
    }
}

/// Frame-rate adaptation with hysteresis (Toromanoff alg. 15; the text leaves the rule open, this
/// is ours): a level goes down one rung after `down_after` consecutive frames over the target, up
/// one rung after `up_after` consecutive frames under `up_below` × the target, and never switches
/// twice within `hold` frames.
#[derive(Debug, Clone, PartialEq)]
pub struct Adaptation {
    pub down_after: u32,
    pub up_after: u32,
    pub up_below: f64,
    pub hold: u32,
    over: u32,
    under: u32,
    since_switch: u32,
}

impl Default for Adaptation {
    fn default() -> Self {
        Self { down_after: 3, up_after: 30, up_below: 0.7, hold: 60, over: 0, under: 0, since_switch: u32::MAX / 2 }
    }
}

/// What [`Adaptation::step`] decides for the next frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    Down,
    Stay,
    Up,
}

impl Adaptation {
    /// Takes in one frame's time against the target and says whether to change level.
    pub fn step(&mut self, frame_ms: f64, target_ms: f64) -> Step {
        self.since_switch = self.since_switch.saturating_add(1);
        if frame_ms > target_ms {
            self.over += 1;
            self.under = 0;
        } else if frame_ms < self.up_below * target_ms {
            self.under += 1;
            self.over = 0;
        } else {
            self.over = 0;
            self.under = 0;
        }
        if self.since_switch < self.hold {
            return Step::Stay;
        }
        if self.over >= self.down_after {
            self.switched();
            return Step::Down;
        }
        if self.under >= self.up_after {
            self.switched();
            return Step::Up;
        }
        Step::Stay
    }

    fn switched(&mut self) {
        self.over = 0;
        self.under = 0;
        self.since_switch = 0;
    }
}

/// The share of the screen a light may shade (0..=1), for the order in which lights take the
/// budget (issue 12: "largest on screen first"): its range's sphere projected from the eye as a
/// disk, as a fraction of the view's area; 1 for lights without a position or a range, or when the
/// eye is within reach; 0 when the sphere is wholly behind the eye. The disk is taken as if on the
/// view axis: an estimate for ordering, not a bound.
pub fn screen_share(
    light: &shadowlab_core::Light,
    eye: glam::Vec3,
    forward: glam::Vec3,
    fov_y: f32,
    aspect: f32,
) -> f32 {
    let (Some(position), Some(range)) = (light.position(), light.range) else { return 1.0 };
    let to = position - eye;
    let d = to.length();
    if !(d.is_finite() && range.is_finite()) || d <= range {
        return 1.0;
    }
    if to.dot(forward) < -range {
        return 0.0;
    }
    // Apparent radius over the half-height of the view, then the disk's area over the view's.
    let r = (range / d).asin().tan() / (0.5 * fov_y).tan().max(1e-6);
    (std::f32::consts::PI * r * r / (4.0 * aspect.max(1e-6))).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lights_screen_share_grows_as_the_eye_nears_it() {
        use glam::Vec3;
        use shadowlab_core::{Light, LightKind};
        let lamp = |range: f32| {
            Light::new("l", LightKind::Point { position: Vec3::ZERO, radius: 0.0 }, Vec3::ONE, 1.0).with_range(range)
        };
        let fov = 60f32.to_radians();
        let share = |l: &Light, z: f32| screen_share(l, Vec3::new(0.0, 0.0, z), Vec3::NEG_Z, fov, 1.0);
        // Range 1 seen from 10 m: radius tan(asin 0.1) / tan 30° = 0.174 of the half-height;
        // π r² / 4 = 0.0238 of the view.
        assert!((share(&lamp(1.0), 10.0) - 0.0238).abs() < 1e-3, "{}", share(&lamp(1.0), 10.0));
        assert!(share(&lamp(1.0), 5.0) > share(&lamp(1.0), 10.0));
        assert!(share(&lamp(2.0), 10.0) > share(&lamp(1.0), 10.0));
        assert_eq!(share(&lamp(1.0), 0.5), 1.0, "within reach");
        assert_eq!(share(&lamp(1.0), -10.0), 0.0, "behind the eye");
        let unbounded = Light::new("u", LightKind::Point { position: Vec3::ZERO, radius: 0.0 }, Vec3::ONE, 1.0);
        assert_eq!(share(&unbounded, 100.0), 1.0);
        let sun =
            Light::new("s", LightKind::Directional { direction: Vec3::NEG_Y, angular_radius: 0.0 }, Vec3::ONE, 1.0);
        assert_eq!(share(&sun, 100.0), 1.0);
        let far = screen_share(&lamp(1.0), Vec3::splat(f32::NAN), Vec3::NEG_Z, fov, 1.0);
        assert!((0.0..=1.0).contains(&far), "NaN eye: {far}");
    }

    #[test]
    fn the_budget_admits_at_least_one_unit_and_never_more_than_its_limit() {
        let mut b = Budget::new(10.0);
        assert!(b.take(25.0), "the first unit runs whatever its cost");
        assert!(!b.take(1.0), "then nothing beyond the limit");
        let mut b = Budget::new(10.0);
        let costs = [3.0, 4.0, 2.0, 2.5, 0.5];
        let taken: Vec<bool> = costs.iter().map(|&c| b.take(c)).collect();
        assert_eq!(taken, [true, true, true, false, true]);
        assert!(b.spent_ms() <= 10.0 && b.deferred == 1);
        let mut u = Budget::unlimited();
        assert!((0..1000).all(|_| u.take(1e6)));
        assert!(Budget::new(f64::NAN).limit_ms() == 0.0 && Budget::new(-5.0).limit_ms() == 0.0);
        assert_eq!(Budget::for_frame(33.0, 20.0, 0.1).limit_ms(), 33.0 - 20.0 - 3.3);
        // A frame whose own work took the budget (a light's turn in a drag) runs no unit, not
        // even a first; without a limit it changes nothing.
        let mut b = Budget::new(10.0);
        b.exhaust();
        assert!(!b.take(0.5) && !b.take(25.0) && b.deferred == 2);
        let mut u = Budget::unlimited();
        u.exhaust();
        assert!(u.take(1e6) && u.is_unlimited());
    }

    /// A scripted sequence of budgets and costs: units planned never exceed the budget (but the
    /// first), and a list of units resumes where it stopped until every one has run.
    #[test]
    fn units_resume_where_they_stopped() {
        let costs: Vec<f64> = (0..40).map(|i| 1.0 + f64::from(i % 7)).collect();
        let mut next = 0;
        let mut frames = 0;
        while next < costs.len() {
            let mut b = Budget::new(8.0);
            let start = next;
            while next < costs.len() && b.take(costs[next]) {
                next += 1;
            }
            assert!(next > start, "frame {frames} made no progress");
            let planned: f64 = costs[start..next].iter().sum();
            assert!(next - start == 1 || planned <= 8.0, "frame {frames} planned {planned} ms");
            frames += 1;
        }
        // 160 ms of units in frames of at most 8 ms (but single larger units): at least 20 frames.
        assert!((20..=40).contains(&frames), "{frames}");
    }

    #[test]
    fn cost_estimates_follow_measurements() {
        const MAP: UnitSize = 1 << 20;
        let mut m = CostModel::default();
        assert_eq!(m.predict(UnitKind::MapView, MAP), UnitKind::MapView.prior().0);
        assert_eq!(
            m.predict(UnitKind::MapView, 4 * MAP),
            4.0 * UnitKind::MapView.prior().0,
            "the prior grows with size"
        );
        assert_eq!(m.predict(UnitKind::MapView, MAP / 4), UnitKind::MapView.prior().0, "but does not shrink");
        for _ in 0..50 {
            m.observe(UnitKind::MapView, MAP, 4, 8.0);
        }
        assert!((m.predict(UnitKind::MapView, MAP) - 2.0).abs() < 1e-3);
        m.observe(UnitKind::MapView, MAP, 0, 100.0);
        m.observe(UnitKind::MapView, MAP, 1, f64::NAN);
        assert!((m.predict(UnitKind::MapView, MAP) - 2.0).abs() < 1e-3, "ignored");
        // Sizes within a factor of two share an estimate; others are predicted from the nearest
        // measured class until measured themselves (up in proportion, not down).
        assert!((m.predict(UnitKind::MapView, MAP - 1000) - 2.0).abs() < 1e-3);
        assert!((m.predict(UnitKind::MapView, MAP / 4) - 2.0).abs() < 1e-3);
        assert!((m.predict(UnitKind::MapView, MAP * 4) - 8.0).abs() < 1e-3);
        for _ in 0..50 {
            m.observe(UnitKind::MapView, MAP / 4, 1, 1.5);
        }
        assert!((m.predict(UnitKind::MapView, MAP / 4) - 1.5).abs() < 1e-3, "measured: its own estimate");
        assert!((m.predict(UnitKind::MapView, MAP) - 2.0).abs() < 1e-3, "the other class kept its own");
        // A frame's time is shared in proportion to the predictions.
        let mut m = CostModel { smoothing: 1.0, ..CostModel::default() };
        m.observe(UnitKind::MapView, MAP, 1, 3.0);
        m.observe(UnitKind::LightMapSample, 1 << 16, 1, 1.0);
        m.observe_frame(&[(UnitKind::MapView, 20, 2), (UnitKind::LightMapSample, 16, 2)], 16.0);
        assert!(
            (m.predict(UnitKind::MapView, MAP) - 6.0).abs() < 1e-9
                && (m.predict(UnitKind::LightMapSample, 1 << 16) - 2.0).abs() < 1e-9
        );
        // Scripted costs hold whatever the size and whatever is observed.
        let mut m = CostModel::scripted(&[(UnitKind::MapView, 1.0)]);
        m.observe(UnitKind::MapView, MAP, 1, 50.0);
        assert_eq!((m.predict(UnitKind::MapView, 1), m.predict(UnitKind::MapView, 1 << 30)), (1.0, 1.0));
        assert_eq!(size_class(1), 0);
        assert_eq!((size_class(1024), size_class(1025), size_class(u64::MAX)), (10, 11, 64));
    }

    /// A frame time that hovers around the target (±15%, deterministic) must not make the level
    /// switch back and forth: at most 2 switches in 600 frames. Frames well over the target step
    /// down quickly; frames well under step up, slowly.
    #[test]
    fn a_cost_hovering_at_the_target_does_not_oscillate() {
        let mut a = Adaptation::default();
        let target = 20.0;
        let mut switches = 0;
        for i in 0..600 {
            let wobble = ((i * 7919) % 31) as f64 / 30.0 * 0.3 - 0.15;
            if a.step(target * (1.0 + wobble), target) != Step::Stay {
                switches += 1;
            }
        }
        assert!(switches <= 2, "{switches} switches");
        let mut a = Adaptation::default();
        let downs = (0..10).filter(|_| a.step(2.0 * target, target) == Step::Down).count();
        assert_eq!(downs, 1, "one step down within the hold");
        let mut a = Adaptation::default();
        let first_up = (0..200).position(|_| a.step(0.3 * target, target) == Step::Up);
        assert_eq!(first_up, Some(29), "up after 30 frames well under the target");
    }
}
