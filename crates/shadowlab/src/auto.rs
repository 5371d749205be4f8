//! The automatic technique choice (`--technique auto`): per light, the candidate with the lowest
//! measured error among those whose measured cost fits the light's share of a frame budget.
//!
//! Pure logic, no GPU. The figures come from a [`Calibration`]: `shadowlab calibrate` measures,
//! per light, each candidate's shadow cost (its uncached frame minus the `none` frame) and its
//! error against the ray-traced truth on the scene's views (`docs/calibration-format.md`; the CLI
//! parses that file into these plain structs). Without a file, [`Calibration::built_in`] takes the
//! figures of [`DEFAULT_TABLE`] by light type.
//!
//! The rule ([`choose`]):
//! - the budget is `budget_ms × preference` ([`Preference::budget_factor`]: quality ×2,
//!   balanced ×1, speed ×0.5);
//! - each light's share is the budget times its weight; [`choose`] gives every light an equal share
//!   (weight 1/n for n lights), [`choose_weighted`] takes weights (normalised to sum 1);
//! - a light gets the candidate with the lowest `rmse` among those with `cost_ms ≤ share`; candidates
//!   within [`TIE_RMSE`] of that RMSE tie, and the cheapest of them wins;
//! - when no candidate fits, the cheapest one ("nothing fits: cheapest").
//!
//! Each [`Choice`] says why in its `reason`. An application embedding [`crate::Shadows`] sets it:
//!
//! ```no_run
//! # fn f(shadows: &mut shadowlab::Shadows, scene: &shadowlab::core::Scene) -> Result<(), shadowlab::TechniqueError> {
//! use shadowlab::auto::{Calibration, Preference, choose};
//! let calibration = Calibration::built_in_for(scene); // or the figures of a calibration file
//! for c in choose(&calibration, calibration.default_budget_ms(), Preference::Balanced) {
//!     shadows.set_technique(shadowlab::core::LightId(c.light), &c.technique()?, 1280, 720)?;
//! }
//! # Ok(()) }
//! ```

/// The candidates `shadowlab calibrate` measures unless `--candidate` names others. A light skips
/// the ones it does not support (`cascaded`: directional and spot lights only).
pub const CANDIDATES: &[&str] = &[
    "hard",
    "pcf",
    "pcss",
    "smoothies",
    "volumes",
    "lightmaps:samples=16",
    "lightmaps",
    "sampled:samples=16,mode=array",
    "cascaded:splits=4,scheme=practical",
];

/// The default budget per light, in multiples of the light's `hard` cost
/// ([`Calibration::default_budget_ms`]).
pub const DEFAULT_BUDGET_PER_HARD: f64 = 4.0;

/// Two RMSEs closer than this are a tie (the cheaper candidate wins): far below the reference's
/// noise floor (RMSE 0.002–0.01 between two 64-sample references), so only candidates that are
/// equally good in every measurable sense tie.
pub const TIE_RMSE: f64 = 1e-6;

/// What the user prefers: it scales the budget.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Preference {
    /// Twice the budget: better shadows, slower frames.
    Quality,
    /// The budget as given.
    #[default]
    Balanced,
    /// Half the budget: faster frames.
    Speed,
}

impl Preference {
    pub const ALL: [Preference; 3] = [Preference::Quality, Preference::Balanced, Preference::Speed];

    /// `quality`, `balanced` or `speed`.
    pub fn parse(text: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == text)
    }

    pub fn name(self) -> &'static str {
        match self {
            Preference::Quality => "quality",
            Preference::Balanced => "balanced",
            Preference::Speed => "speed",
        }
    }

    /// The factor the budget is multiplied by: 2, 1 or 0.5.
    pub fn budget_factor(self) -> f64 {
        match self {
            Preference::Quality => 2.0,
            Preference::Balanced => 1.0,
            Preference::Speed => 0.5,
        }
    }
}

/// One candidate's measured figures on one light.
#[derive(Debug, Clone, PartialEq)]
pub struct CandidateFigures {
    /// The technique spec (`pcf`, `lightmaps:samples=16`).
    pub spec: String,
    /// The light's shadow cost: median over views of (uncached frame − `none` frame), ms.
    pub cost_ms: f64,
    /// The same for the live engine's still frame (cache on), ms.
    pub still_ms: f64,
    /// RMSE of V − V_ref over the light's relevant pixels, pooled over views.
    pub rmse: f64,
    /// Fraction of those pixels with |V − V_ref| > 0.1.
    pub wrong_frac: f64,
    /// GPU memory the technique holds for this light (largest over views).
    pub memory_bytes: u64,
}

/// One light's candidates.
#[derive(Debug, Clone, PartialEq)]
pub struct LightFigures {
    /// The light's index in the scene.
    pub index: u32,
    pub name: String,
    /// `point`, `spot`, `directional` or `rect`.
    pub light_type: String,
    pub candidates: Vec<CandidateFigures>,
}

/// Measured figures per light: the input of [`choose`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Calibration {
    pub scene: String,
    pub lights: Vec<LightFigures>,
}

/// One row of [`DEFAULT_TABLE`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableRow {
    pub spec: &'static str,
    pub cost_ms: f64,
    pub still_ms: f64,
    pub rmse: f64,
    pub wrong_frac: f64,
    pub memory_bytes: u64,
}

const fn row(
    spec: &'static str,
    cost_ms: f64,
    still_ms: f64,
    rmse: f64,
    wrong_frac: f64,
    memory_bytes: u64,
) -> TableRow {
    TableRow { spec, cost_ms, still_ms, rmse, wrong_frac, memory_bytes }
}

/// The built-in figures per light type, used when there is no calibration file.
///
/// Measured by `shadowlab calibrate --scene room` and `--scene penumbra` with the defaults (128×96,
/// the default candidates, 64 reference samples, seed 1, 5 frames after 2 of warm-up) on the engine
/// of commit 972568c, llvmpipe (LLVM 15.0.6, Vulkan) on two CPU cores: GPU ms from timestamps of
/// that adapter, so only their ratios carry over to other machines. `point` is the mean of
/// `room`'s ceiling lamp (0.1 m) and accent (0.02 m), `spot` `room`'s reading lamp, `directional`
/// `room`'s sun (0.27°), each over the views default, table, window and sofa; `rect` is
/// `penumbra`'s panel over default, top and low. Memory: the larger of the lights'.
pub const DEFAULT_TABLE: &[(&str, &[TableRow])] = &[
    (
        "point",
        &[
            row("hard", 67.31, 0.58, 0.0764, 0.0468, 117639360),
            row("pcf", 70.00, 0.26, 0.0662, 0.0460, 117640400),
            row("pcss", 71.09, 0.36, 0.0387, 0.0152, 117640416),
            row("smoothies", 133.50, 65.74, 0.0761, 0.0515, 420155088),
            row("volumes", 6.95, 0.19, 0.0707, 0.0460, 10709656),
            row("lightmaps:samples=16", 178.47, 0.22, 0.0484, 0.0317, 18524908),
            row("lightmaps", 677.95, 0.83, 0.0445, 0.0242, 18696940),
            row("sampled:samples=16,mode=array", 160.83, 0.36, 0.0614, 0.0294, 126160160),
        ],
    ),
    (
        "spot",
        &[
            row("hard", 19.61, 0.00, 0.0365, 0.0133, 16974224),
            row("pcf", 19.71, 0.00, 0.0309, 0.0126, 16975264),
            row("pcss", 19.78, 0.00, 0.0167, 0.0053, 16975280),
            row("smoothies", 31.20, 11.04, 0.0394, 0.0152, 67830432),
            row("volumes", 7.12, 0.08, 0.0365, 0.0133, 10709656),
            row("lightmaps:samples=16", 180.09, 0.15, 0.0316, 0.0141, 18524908),
            row("lightmaps", 696.36, 0.67, 0.0302, 0.0124, 18696940),
            row("sampled:samples=16,mode=array", 65.99, 0.39, 0.0506, 0.0115, 17078816),
            row("cascaded:splits=4,scheme=practical", 77.07, 0.11, 0.0365, 0.0133, 67308112),
        ],
    ),
    (
        "directional",
        &[
            row("hard", 12.69, 0.16, 0.0216, 0.0021, 33751440),
            row("pcf", 13.58, 1.03, 0.0151, 0.0020, 33752480),
            row("pcss", 15.68, 0.00, 0.0128, 0.0005, 33752496),
            row("smoothies", 24.41, 12.12, 0.0208, 0.0023, 84607648),
            row("volumes", 6.31, 0.45, 0.0134, 0.0019, 6424456),
            row("lightmaps:samples=16", 179.09, 0.05, 0.1393, 0.0209, 14239708),
            row("lightmaps", 678.32, 1.61, 0.1393, 0.0211, 14411740),
            row("sampled:samples=16,mode=array", 54.46, 0.63, 0.0329, 0.0023, 33856032),
            row("cascaded:splits=4,scheme=practical", 68.87, 0.30, 0.0163, 0.0019, 134416976),
        ],
    ),
    (
        "rect",
        &[
            row("hard", 4.30, 0.00, 0.0854, 0.0714, 16826768),
            row("pcf", 4.16, 0.00, 0.0785, 0.0711, 16827808),
            row("pcss", 4.64, 0.00, 0.0134, 0.0018, 16827824),
            row("smoothies", 12.57, 7.43, 0.0915, 0.0741, 67160736),
            row("volumes", 1.66, 0.11, 0.0854, 0.0714, 127332),
            row("lightmaps:samples=16", 10.64, 0.00, 0.0150, 0.0031, 491524),
            row("lightmaps", 34.51, 0.05, 0.0093, 0.0003, 503812),
            row("sampled:samples=16,mode=array", 10.11, 0.25, 0.0159, 0.0044, 16931360),
        ],
    ),
];

/// The built-in rows for a light type (`point`, `spot`, `directional`, `rect`); empty for others.
pub fn default_rows(light_type: &str) -> &'static [TableRow] {
    DEFAULT_TABLE.iter().find(|(t, _)| *t == light_type).map_or(&[], |(_, rows)| rows)
}

impl CandidateFigures {
    fn from_row(r: &TableRow) -> Self {
        Self {
            spec: r.spec.to_owned(),
            cost_ms: r.cost_ms,
            still_ms: r.still_ms,
            rmse: r.rmse,
            wrong_frac: r.wrong_frac,
            memory_bytes: r.memory_bytes,
        }
    }
}

impl LightFigures {
    /// The candidate measured with `spec`, if any.
    pub fn candidate(&self, spec: &str) -> Option<&CandidateFigures> {
        self.candidates.iter().find(|c| c.spec == spec)
    }

    /// The light's `hard` cost, or its cheapest candidate's when `hard` was not measured; `None`
    /// without candidates.
    pub fn baseline_ms(&self) -> Option<f64> {
        self.candidate("hard")
            .map(|c| c.cost_ms)
            .filter(|c| c.is_finite())
            .or_else(|| self.candidates.iter().map(|c| c.cost_ms).filter(|c| c.is_finite()).min_by(f64::total_cmp))
    }
}

impl Calibration {
    /// The figures of [`DEFAULT_TABLE`] for `lights`, given as (index, name, type).
    pub fn built_in(scene: &str, lights: &[(u32, String, String)]) -> Self {
        let lights = lights
            .iter()
            .map(|(index, name, light_type)| LightFigures {
                index: *index,
                name: name.clone(),
                light_type: light_type.clone(),
                candidates: default_rows(light_type).iter().map(CandidateFigures::from_row).collect(),
            })
            .collect();
        Self { scene: scene.to_owned(), lights }
    }

    /// [`Calibration::built_in`] for every light of `scene`.
    pub fn built_in_for(scene: &shadowlab_core::Scene) -> Self {
        let lights: Vec<(u32, String, String)> = scene
            .lights
            .iter()
            .enumerate()
            .map(|(i, l)| (i as u32, l.name.clone(), l.type_name().to_owned()))
            .collect();
        Self::built_in(&scene.name, &lights)
    }

    /// The light with scene index `index`.
    pub fn light(&self, index: u32) -> Option<&LightFigures> {
        self.lights.iter().find(|l| l.index == index)
    }

    /// The same calibration restricted to the lights with these indices (in this order).
    pub fn only(&self, indices: &[u32]) -> Self {
        Self { scene: self.scene.clone(), lights: indices.iter().filter_map(|&i| self.light(i).cloned()).collect() }
    }

    /// The default budget: [`DEFAULT_BUDGET_PER_HARD`] × the sum over lights of their `hard` cost
    /// (a light without `hard` counts its cheapest candidate).
    pub fn default_budget_ms(&self) -> f64 {
        DEFAULT_BUDGET_PER_HARD
            * self.lights.iter().filter_map(LightFigures::baseline_ms).map(|c| c.max(0.0)).sum::<f64>()
    }
}

/// What a light got, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Choice {
    /// The light's index in the scene.
    pub light: u32,
    pub name: String,
    /// The chosen spec.
    pub spec: String,
    /// The light's share of the budget, ms.
    pub share_ms: f64,
    /// The chosen candidate's measured cost and error (NaN when the light had no candidate).
    pub cost_ms: f64,
    pub rmse: f64,
    /// Whether its cost fits the share.
    pub fits: bool,
    pub reason: String,
}

impl Choice {
    /// The chosen technique, ready for [`crate::Shadows::set_technique`].
    pub fn technique(&self) -> Result<crate::TechniqueSpec, crate::TechniqueError> {
        crate::TechniqueSpec::parse(&self.spec, &[])
    }
}

/// Each light's choice with an equal share of `budget_ms × preference` (see the module's rule).
pub fn choose(calibration: &Calibration, budget_ms: f64, preference: Preference) -> Vec<Choice> {
    let weights = vec![1.0; calibration.lights.len()];
    choose_weighted(calibration, budget_ms, preference, &weights)
}

/// [`choose`] with light `i`'s share = budget × `weights[i]` / Σ weights (missing, negative or
/// non-finite weights count as 0; all zero: equal shares).
pub fn choose_weighted(
    calibration: &Calibration,
    budget_ms: f64,
    preference: Preference,
    weights: &[f64],
) -> Vec<Choice> {
    let n = calibration.lights.len();
    let w: Vec<f64> =
        (0..n).map(|i| weights.get(i).copied().filter(|x| x.is_finite() && *x > 0.0).unwrap_or(0.0)).collect();
    let total: f64 = w.iter().sum();
    let budget = budget_ms * preference.budget_factor();
    calibration
        .lights
        .iter()
        .enumerate()
        .map(|(i, light)| {
            let fraction = if total > 0.0 { w[i] / total } else { 1.0 / n as f64 };
            choose_light(light, budget * fraction)
        })
        .collect()
}

/// Errors compare with NaN last.
fn rmse_key(c: &CandidateFigures) -> f64 {
    if c.rmse.is_nan() { f64::INFINITY } else { c.rmse }
}

/// Costs compare with NaN last.
fn cost_key(c: &CandidateFigures) -> f64 {
    if c.cost_ms.is_nan() { f64::INFINITY } else { c.cost_ms }
}

/// The cheapest of `set` (the first on equal costs).
fn cheapest<'a>(set: impl Iterator<Item = &'a CandidateFigures>) -> Option<&'a CandidateFigures> {
    set.fold(None, |best: Option<&CandidateFigures>, c| match best {
        Some(b) if cost_key(b) <= cost_key(c) => Some(b),
        _ => Some(c),
    })
}

/// One light's choice for a share of `share_ms`.
pub fn choose_light(light: &LightFigures, share_ms: f64) -> Choice {
    let choice = |c: &CandidateFigures, fits: bool, reason: String| Choice {
        light: light.index,
        name: light.name.clone(),
        spec: c.spec.clone(),
        share_ms,
        cost_ms: c.cost_ms,
        rmse: c.rmse,
        fits,
        reason,
    };
    let fits = |c: &&CandidateFigures| c.cost_ms.is_finite() && c.cost_ms <= share_ms;
    let fitting: Vec<&CandidateFigures> = light.candidates.iter().filter(fits).collect();
    let Some(best_rmse) = fitting.iter().map(|c| rmse_key(c)).min_by(f64::total_cmp) else {
        return match cheapest(light.candidates.iter()) {
            Some(c) => choice(
                c,
                false,
                format!(
                    "nothing fits: cheapest ({} ms > share {} ms; RMSE {})",
                    ms(c.cost_ms),
                    ms(share_ms),
                    err(c.rmse)
                ),
            ),
            None => Choice {
                light: light.index,
                name: light.name.clone(),
                spec: "hard".to_owned(),
                share_ms,
                cost_ms: f64::NAN,
                rmse: f64::NAN,
                fits: false,
                reason: "no candidate measured: `hard`, the baseline".to_owned(),
            },
        };
    };
    let tied = fitting.iter().copied().filter(|c| rmse_key(c) <= best_rmse + TIE_RMSE);
    let chosen = cheapest(tied).expect("the best candidate is in its own tie");
    let mut reason = format!(
        "lowest RMSE {} of the {} candidate{} within its share {} ms (cost {} ms)",
        err(chosen.rmse),
        fitting.len(),
        if fitting.len() == 1 { "" } else { "s" },
        ms(share_ms),
        ms(chosen.cost_ms)
    );
    let ties: Vec<&str> = fitting
        .iter()
        .filter(|c| c.spec != chosen.spec && rmse_key(c) <= best_rmse + TIE_RMSE)
        .map(|c| c.spec.as_str())
        .collect();
    if !ties.is_empty() {
        reason.push_str(&format!("; ties {} on RMSE and is cheaper", ties.join(", ")));
    }
    // The cheapest better one left out: what a larger share would buy next.
    let next = cheapest(light.candidates.iter().filter(|c| !fits(c) && rmse_key(c) < best_rmse - TIE_RMSE));
    if let Some(o) = next {
        reason.push_str(&format!("; next better: {} (RMSE {}) at {} ms", o.spec, err(o.rmse), ms(o.cost_ms)));
    }
    choice(chosen, true, reason)
}

fn ms(x: f64) -> String {
    if x.abs() >= 10.0 { format!("{x:.1}") } else { format!("{x:.3}") }
}

fn err(x: f64) -> String {
    format!("{x:.4}")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cand(spec: &str, cost_ms: f64, rmse: f64) -> CandidateFigures {
        CandidateFigures { spec: spec.into(), cost_ms, still_ms: 0.0, rmse, wrong_frac: 0.0, memory_bytes: 0 }
    }

    fn light(index: u32, candidates: Vec<CandidateFigures>) -> LightFigures {
        LightFigures { index, name: format!("l{index}"), light_type: "point".into(), candidates }
    }

    /// A scripted light: cheap and wrong to dear and right.
    fn ladder(index: u32) -> LightFigures {
        light(
            index,
            vec![
                cand("hard", 1.0, 0.08),
                cand("pcf", 1.5, 0.05),
                cand("pcss", 3.0, 0.03),
                cand("sampled:samples=16,mode=array", 10.0, 0.01),
            ],
        )
    }

    fn cal(lights: Vec<LightFigures>) -> Calibration {
        Calibration { scene: "test".into(), lights }
    }

    #[test]
    fn lowest_error_that_fits() {
        let c = choose_light(&ladder(0), 3.0);
        // The share is inclusive: pcss costs exactly 3.0.
        assert_eq!(c.spec, "pcss");
        assert!(c.fits);
        assert!(c.reason.contains("lowest RMSE 0.0300 of the 3 candidates"), "{}", c.reason);
        assert!(
            c.reason.contains("next better: sampled:samples=16,mode=array (RMSE 0.0100) at 10.0 ms"),
            "{}",
            c.reason
        );
        // The cheapest better one is named, not the best.
        let c = choose_light(&ladder(0), 1.2);
        assert!(c.reason.contains("next better: pcf (RMSE 0.0500) at 1.500 ms"), "{}", c.reason);
        assert_eq!(choose_light(&ladder(0), 2.9).spec, "pcf");
        assert_eq!(choose_light(&ladder(0), 100.0).spec, "sampled:samples=16,mode=array");
        assert_eq!(choose_light(&ladder(0), 1.0).spec, "hard");
    }

    #[test]
    fn nothing_fits_takes_the_cheapest() {
        let c = choose_light(&ladder(3), 0.5);
        assert_eq!(c.spec, "hard");
        assert!(!c.fits);
        assert!(c.reason.starts_with("nothing fits: cheapest"), "{}", c.reason);
        assert_eq!(c.light, 3);
        // Unordered candidates: still the cheapest, not the first.
        let l = light(0, vec![cand("pcss", 3.0, 0.03), cand("pcf", 1.5, 0.05), cand("volumes", f64::NAN, 0.0)]);
        assert_eq!(choose_light(&l, 1.0).spec, "pcf");
        // A NaN cost never fits, however large the share.
        assert_eq!(choose_light(&l, 1e9).spec, "pcss");
    }

    #[test]
    fn ties_go_to_the_cheaper() {
        let l = light(0, vec![cand("volumes", 2.0, 0.02), cand("hard", 1.0, 0.02), cand("pcf", 1.5, 0.0200000001)]);
        let c = choose_light(&l, 5.0);
        assert_eq!(c.spec, "hard");
        assert!(c.reason.contains("ties volumes, pcf on RMSE and is cheaper"), "{}", c.reason);
        // Equal costs too: the first listed.
        let l = light(0, vec![cand("a", 1.0, 0.02), cand("b", 1.0, 0.02)]);
        assert_eq!(choose_light(&l, 1.0).spec, "a");
    }

    #[test]
    fn equal_shares_and_weights() {
        let c = cal(vec![ladder(0), ladder(1)]);
        // 6 ms for two lights: 3 ms each.
        let choices = choose(&c, 6.0, Preference::Balanced);
        assert_eq!(choices.len(), 2);
        assert!(choices.iter().all(|x| x.spec == "pcss" && x.share_ms == 3.0));
        assert_eq!((choices[0].light, choices[1].light), (0, 1));
        // Weights 3:1 of 8 ms: 6 ms and 2 ms.
        let w = choose_weighted(&c, 8.0, Preference::Balanced, &[3.0, 1.0]);
        assert_eq!((w[0].share_ms, w[1].share_ms), (6.0, 2.0));
        assert_eq!((w[0].spec.as_str(), w[1].spec.as_str()), ("pcss", "pcf"));
        // No usable weight: equal shares.
        let w = choose_weighted(&c, 6.0, Preference::Balanced, &[0.0, f64::NAN]);
        assert!(w.iter().all(|x| x.share_ms == 3.0));
    }

    #[test]
    fn preference_scales_the_budget() {
        let c = cal(vec![ladder(0)]);
        let pick = |p| choose(&c, 3.0, p)[0].spec.clone();
        assert_eq!(pick(Preference::Balanced), "pcss");
        // ×2: 6 ms, still below sampled's 10.
        assert_eq!(pick(Preference::Quality), "pcss");
        assert_eq!(choose(&c, 5.0, Preference::Quality)[0].spec, "sampled:samples=16,mode=array");
        // ×0.5: 1.5 ms.
        assert_eq!(pick(Preference::Speed), "pcf");
        assert_eq!(choose(&c, 3.0, Preference::Speed)[0].share_ms, 1.5);
        for p in Preference::ALL {
            assert_eq!(Preference::parse(p.name()), Some(p));
        }
        assert_eq!(Preference::parse("fast"), None);
    }

    #[test]
    fn never_picks_what_does_not_fit_when_something_does() {
        // Every share from 0 to 12 ms over the ladder: the pick fits whenever any candidate fits,
        // and no fitting candidate has a lower RMSE.
        let l = ladder(0);
        for k in 0..=120 {
            let share = f64::from(k) * 0.1;
            let c = choose_light(&l, share);
            let fitting: Vec<_> = l.candidates.iter().filter(|x| x.cost_ms <= share).collect();
            if fitting.is_empty() {
                assert!(!c.fits);
            } else {
                assert!(c.fits && c.cost_ms <= share, "{share}: {c:?}");
                assert!(fitting.iter().all(|x| x.rmse >= c.rmse), "{share}: {c:?}");
            }
        }
    }

    #[test]
    fn default_budget_and_built_in_table() {
        let c = cal(vec![ladder(0), light(1, vec![cand("pcf", 2.0, 0.1), cand("pcss", 3.0, 0.05)])]);
        // 4 × (hard 1.0 + cheapest 2.0).
        assert_eq!(c.default_budget_ms(), 12.0);
        assert_eq!(c.only(&[1]).lights.len(), 1);
        assert_eq!(c.only(&[1, 7]).lights[0].index, 1);
        let lights = [
            (0, "lamp".to_owned(), "point".to_owned()),
            (1, "sun".to_owned(), "directional".to_owned()),
            (2, "panel".to_owned(), "rect".to_owned()),
            (3, "spot".to_owned(), "spot".to_owned()),
        ];
        let b = Calibration::built_in("room", &lights);
        for l in &b.lights {
            assert!(l.candidate("hard").is_some(), "{}", l.light_type);
            // `cascaded` only where it runs.
            let cascaded = l.candidates.iter().any(|c| c.spec.starts_with("cascaded"));
            assert_eq!(cascaded, matches!(l.light_type.as_str(), "directional" | "spot"), "{}", l.light_type);
            // Every built-in row is a candidate of the default list.
            assert!(l.candidates.iter().all(|c| CANDIDATES.contains(&c.spec.as_str())));
        }
        // At the default budget every light gets something that fits.
        let choices = choose(&b, b.default_budget_ms(), Preference::Balanced);
        assert!(choices.iter().all(|c| c.fits && c.technique().is_ok()), "{choices:?}");
        // `room`'s lights (point, spot, point, sun) get `pcss` everywhere, as the calibration the
        // table comes from chose at its default budget.
        let room: Vec<(u32, String, String)> = ["point", "spot", "point", "directional"]
            .iter()
            .enumerate()
            .map(|(i, t)| (i as u32, format!("l{i}"), (*t).to_owned()))
            .collect();
        let r = Calibration::built_in("room", &room);
        let choices = choose(&r, r.default_budget_ms(), Preference::Balanced);
        assert!(choices.iter().all(|c| c.spec == "pcss"), "{choices:?}");
        // Unknown light types have no rows: the baseline.
        let u = Calibration::built_in("x", &[(0, "odd".into(), "odd".into())]);
        assert_eq!(choose(&u, 1.0, Preference::Balanced)[0].spec, "hard");
    }
}
