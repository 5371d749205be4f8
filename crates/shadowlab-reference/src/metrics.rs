//! Error metrics of a technique's visibility against the reference (DESIGN.md §6).
//!
//! All figures are over *relevant* pixels: those where the reference holds a value (not NaN).
//! - `rmse`, `mae`, `max_abs`: of V − V_ref;
//! - `wrong_frac`: the fraction with |V − V_ref| > [`WRONG_THRESHOLD`];
//! - `penumbra_rmse`: RMSE over the truth's penumbra, pixels where V_ref lies strictly inside
//!   ([`PENUMBRA_LO`], [`PENUMBRA_HI`]). Only V_ref decides: a set that also took pixels where the
//!   technique alone is partial let false faint shadows (small errors on truth-lit pixels) dilute it,
//!   so acne lowered the figure; those errors are counted by the two fractions below instead;
//! - `lit_darkened_frac`: the fraction with V_ref = 1 and V < [`PENUMBRA_HI`] (acne, false shadows);
//! - `shadow_brightened_frac`: the fraction with V_ref = 0 and V > [`PENUMBRA_LO`] (light leaks);
//! - a technique value that is NaN at a relevant pixel counts as an error of 1 (and is counted in
//!   `missing`): it is wrong, lit-darkened where V_ref = 1, shadow-brightened where V_ref = 0, and
//!   adds 1 to the penumbra's sum where V_ref is partial.
//!
//! V_ref = 1 and V_ref = 0 are exact: the reference is a ratio of visible samples, so a pixel that
//! every sample reaches (or none) holds exactly 1 (or 0).
//!
//! Technique-level figures pool the pixels of all lights: [`ErrorStats`] accumulates sums, so
//! pooling is adding.

use serde::Serialize;

pub const WRONG_THRESHOLD: f32 = 0.1;
pub const PENUMBRA_LO: f32 = 0.02;
pub const PENUMBRA_HI: f32 = 0.98;

/// Running sums from which every metric follows; add two to pool their pixels.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ErrorStats {
    pub pixels: u64,
    sum_sq: f64,
    sum_abs: f64,
    pub max_abs: f32,
    pub wrong: u64,
    /// Pixels of the truth's penumbra (V_ref strictly inside (PENUMBRA_LO, PENUMBRA_HI)).
    pub penumbra_pixels: u64,
    penumbra_sum_sq: f64,
    /// Pixels with V_ref = 1 and V < PENUMBRA_HI (or V NaN): acne.
    pub lit_darkened: u64,
    /// Pixels with V_ref = 0 and V > PENUMBRA_LO (or V NaN): leaks.
    pub shadow_brightened: u64,
    /// Relevant pixels where the technique gave no value (NaN).
    pub missing: u64,
}

impl ErrorStats {
    /// Compares `value` with `reference` pixel by pixel. Pixels where the reference is NaN are not
    /// relevant and are skipped.
    pub fn compare(value: &[f32], reference: &[f32]) -> Self {
        let mut s = Self::default();
        for (&v, &r) in value.iter().zip(reference) {
            if r.is_nan() {
                continue;
            }
            s.add(v, r);
        }
        s
    }

    /// Like [`ErrorStats::compare`], counting only pixels where `mask` is true as well.
    pub fn compare_masked(value: &[f32], reference: &[f32], mask: &[bool]) -> Self {
        let mut s = Self::default();
        for ((&v, &r), &m) in value.iter().zip(reference).zip(mask) {
            if m && !r.is_nan() {
                s.add(v, r);
            }
        }
        s
    }

    #[inline]
    pub fn add(&mut self, value: f32, reference: f32) {
        self.pixels += 1;
        let d = if value.is_nan() {
            self.missing += 1;
            1.0
        } else {
            (value - reference).abs()
        };
        self.sum_sq += f64::from(d) * f64::from(d);
        self.sum_abs += f64::from(d);
        self.max_abs = self.max_abs.max(d);
        if d > WRONG_THRESHOLD {
            self.wrong += 1;
        }
        if reference > PENUMBRA_LO && reference < PENUMBRA_HI {
            self.penumbra_pixels += 1;
            self.penumbra_sum_sq += f64::from(d) * f64::from(d);
        } else if reference >= 1.0 {
            if value.is_nan() || value < PENUMBRA_HI {
                self.lit_darkened += 1;
            }
        } else if reference <= 0.0 && (value.is_nan() || value > PENUMBRA_LO) {
            self.shadow_brightened += 1;
        }
    }

    pub fn merge(&mut self, other: &Self) {
        self.pixels += other.pixels;
        self.sum_sq += other.sum_sq;
        self.sum_abs += other.sum_abs;
        self.max_abs = self.max_abs.max(other.max_abs);
        self.wrong += other.wrong;
        self.penumbra_pixels += other.penumbra_pixels;
        self.penumbra_sum_sq += other.penumbra_sum_sq;
        self.lit_darkened += other.lit_darkened;
        self.shadow_brightened += other.shadow_brightened;
        self.missing += other.missing;
    }

    pub fn rmse(&self) -> f64 {
        if self.pixels == 0 { 0.0 } else { (self.sum_sq / self.pixels as f64).sqrt() }
    }

    pub fn mae(&self) -> f64 {
        if self.pixels == 0 { 0.0 } else { self.sum_abs / self.pixels as f64 }
    }

    pub fn wrong_frac(&self) -> f64 {
        if self.pixels == 0 { 0.0 } else { self.wrong as f64 / self.pixels as f64 }
    }

    /// Fraction of relevant pixels lit in the truth that the technique darkens (acne).
    pub fn lit_darkened_frac(&self) -> f64 {
        if self.pixels == 0 { 0.0 } else { self.lit_darkened as f64 / self.pixels as f64 }
    }

    /// Fraction of relevant pixels in the truth's umbra that the technique brightens (leaks).
    pub fn shadow_brightened_frac(&self) -> f64 {
        if self.pixels == 0 { 0.0 } else { self.shadow_brightened as f64 / self.pixels as f64 }
    }

    /// `None` when the truth has no penumbra pixel (hard shadows).
    pub fn penumbra_rmse(&self) -> Option<f64> {
        (self.penumbra_pixels > 0).then(|| (self.penumbra_sum_sq / self.penumbra_pixels as f64).sqrt())
    }

    pub fn summary(&self) -> Metrics {
        Metrics {
            rmse: self.rmse(),
            mae: self.mae(),
            max_abs: f64::from(self.max_abs),
            wrong_frac: self.wrong_frac(),
            penumbra_rmse: self.penumbra_rmse(),
            lit_darkened_frac: self.lit_darkened_frac(),
            shadow_brightened_frac: self.shadow_brightened_frac(),
            relevant_pixels: self.pixels,
            penumbra_pixels: self.penumbra_pixels,
        }
    }
}

/// The metrics of one light or of a pooled set, as they appear in `metrics.json`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Metrics {
    pub rmse: f64,
    pub mae: f64,
    pub max_abs: f64,
    pub wrong_frac: f64,
    pub penumbra_rmse: Option<f64>,
    pub lit_darkened_frac: f64,
    pub shadow_brightened_frac: f64,
    pub relevant_pixels: u64,
    pub penumbra_pixels: u64,
}

/// RMSE between two visibility buffers over pixels relevant in both: the noise floor when they are
/// two references with different seeds.
pub fn rmse_between(a: &[f32], b: &[f32]) -> f64 {
    let mut s = ErrorStats::default();
    for (&x, &y) in a.iter().zip(b) {
        if !x.is_nan() && !y.is_nan() {
            s.add(x, y);
        }
    }
    s.rmse()
}

/// RMSE between two 8-bit RGB images in [0, 1] units over the pixels where `mask` is true (all
/// when `None`): the image measure of Azri 2020 §3.4 (NOTES-003: "RMSE between images", values
/// around 0.008 that suggest a [0, 1] normalisation). Unlike visibility RMSE it sees shading: an
/// error where N·L is small or the albedo dark counts little. `None` when the sizes disagree or no
/// pixel is counted.
pub fn image_rmse(a_rgb: &[u8], b_rgb: &[u8], mask: Option<&[bool]>) -> Option<f64> {
    if a_rgb.len() != b_rgb.len() || !a_rgb.len().is_multiple_of(3) {
        return None;
    }
    if mask.is_some_and(|m| m.len() * 3 != a_rgb.len()) {
        return None;
    }
    let (mut sum, mut n) = (0.0f64, 0u64);
    for (i, (a, b)) in a_rgb.chunks_exact(3).zip(b_rgb.chunks_exact(3)).enumerate() {
        if mask.is_some_and(|m| !m[i]) {
            continue;
        }
        for k in 0..3 {
            let d = (f64::from(a[k]) - f64::from(b[k])) / 255.0;
            sum += d * d;
        }
        n += 3;
    }
    (n > 0).then(|| (sum / n as f64).sqrt())
}

/// Mean FLIP error (Andersson et al. 2020, NVIDIA's reference implementation through `nv-flip`)
/// between two sRGB 8-bit RGB images of the same size, at the default viewing distance (67 pixels
/// per degree). Returns `None` when the sizes disagree.
pub fn flip_mean(reference_rgb: &[u8], test_rgb: &[u8], width: u32, height: u32) -> Option<f32> {
    let n = (width as usize) * (height as usize) * 3;
    if reference_rgb.len() != n || test_rgb.len() != n || n == 0 {
        return None;
    }
    let r = nv_flip::FlipImageRgb8::with_data(width, height, reference_rgb);
    let t = nv_flip::FlipImageRgb8::with_data(width, height, test_rgb);
    let err = nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    Some(nv_flip::FlipPool::from_image(&err).mean())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_rmse_counts_masked_channels_in_unit_range() {
        let a = [0u8, 0, 0, 255, 255, 255];
        let b = [0u8, 0, 0, 0, 0, 0];
        // One of two pixels fully wrong: sqrt(3 / 6).
        assert!((image_rmse(&a, &b, None).unwrap() - 0.5f64.sqrt()).abs() < 1e-12);
        assert_eq!(image_rmse(&a, &b, Some(&[true, false])), Some(0.0));
        assert_eq!(image_rmse(&a, &b, Some(&[false, false])), None);
        assert_eq!(image_rmse(&a, &b[..3], None), None);
        assert_eq!(image_rmse(&a, &b, Some(&[true])), None);
    }

    #[test]
    fn metrics_by_hand() {
        let reference = [1.0, 0.0, 0.5, f32::NAN, 1.0];
        let value = [1.0, 0.2, 0.45, 0.3, f32::NAN];
        let s = ErrorStats::compare(&value, &reference);
        assert_eq!(s.pixels, 4);
        assert_eq!(s.missing, 1);
        // Errors: 0, 0.2, 0.05, 1 (missing).
        let rmse = ((0.04 + 0.0025 + 1.0) / 4.0f64).sqrt();
        assert!((s.rmse() - rmse).abs() < 1e-6);
        assert!((s.mae() - 1.25 / 4.0).abs() < 1e-6);
        assert_eq!(s.max_abs, 1.0);
        assert_eq!(s.wrong, 2);
        // The truth's penumbra is the one pixel with ref 0.5 (value 0.2 over ref 0 is a leak, not
        // penumbra); 1e-6 is f32 rounding of 0.45 − 0.5.
        assert_eq!(s.penumbra_pixels, 1);
        assert!((s.penumbra_rmse().unwrap() - 0.05).abs() < 1e-6);
        assert_eq!((s.lit_darkened, s.shadow_brightened), (1, 1));
    }

    /// The old `penumbra_rmse`: over pixels where V_ref *or* V is partial. Kept here only to show
    /// what it got wrong.
    fn old_penumbra_rmse(value: &[f32], reference: &[f32]) -> f64 {
        let inside = |x: f32| x > PENUMBRA_LO && x < PENUMBRA_HI;
        let (mut sum, mut n) = (0.0f64, 0u32);
        for (&v, &r) in value.iter().zip(reference) {
            if inside(v) || inside(r) {
                sum += f64::from(v - r).powi(2);
                n += 1;
            }
        }
        (sum / f64::from(n)).sqrt()
    }

    #[test]
    fn penumbra_rmse_is_over_the_truths_penumbra_and_acne_is_flagged_apart() {
        // 10 truth-penumbra pixels (V_ref 0.5), 90 truth-lit pixels, 20 umbra pixels.
        let mut reference = vec![0.5f32; 10];
        reference.extend([1.0; 90]);
        reference.extend([0.0; 20]);
        // A: faint false shadows (V = 0.9) on every truth-lit pixel, and a penumbra 0.2 too bright.
        let a: Vec<f32> = reference
            .iter()
            .map(|&r| {
                if r == 1.0 {
                    0.9
                } else if r == 0.5 {
                    0.7
                } else {
                    r
                }
            })
            .collect();
        // B: no acne, a penumbra 0.15 too bright: B's penumbra is the better one.
        let b: Vec<f32> = reference.iter().map(|&r| if r == 0.5 { 0.65 } else { r }).collect();
        // Old definition: A's 90 acne pixels (error 0.1) joined its 10 penumbra pixels (error 0.2)
        // and diluted them: √((10·0.04 + 90·0.01) / 100) = 0.114 < B's 0.15. A ranked better.
        let (old_a, old_b) = (old_penumbra_rmse(&a, &reference), old_penumbra_rmse(&b, &reference));
        // 1e-6: f32 rounding of the inputs.
        assert!((old_a - 0.013f64.sqrt()).abs() < 1e-6 && (old_b - 0.15).abs() < 1e-6, "{old_a} {old_b}");
        assert!(old_a < old_b);
        // New definition: the truth's penumbra only, 0.2 against 0.15: B ranks better.
        let (sa, sb) = (ErrorStats::compare(&a, &reference), ErrorStats::compare(&b, &reference));
        assert_eq!((sa.penumbra_pixels, sb.penumbra_pixels), (10, 10));
        let (new_a, new_b) = (sa.penumbra_rmse().unwrap(), sb.penumbra_rmse().unwrap());
        // 1e-6: f32 rounding of the inputs.
        assert!((new_a - 0.2).abs() < 1e-6 && (new_b - 0.15).abs() < 1e-6, "{new_a} {new_b}");
        assert!(new_b < new_a);
        // The acne is where it belongs: 90 of 120 relevant pixels are lit and darkened in A, none in B.
        assert_eq!(sa.summary().lit_darkened_frac, 90.0 / 120.0);
        assert_eq!(sb.summary().lit_darkened_frac, 0.0);
        assert_eq!((sa.shadow_brightened, sb.shadow_brightened), (0, 0));
        // With A's penumbra correct, acne no longer shows in penumbra_rmse (it did before: 0.095).
        let a_exact: Vec<f32> = a.iter().zip(&reference).map(|(&v, &r)| if r == 0.5 { r } else { v }).collect();
        let s = ErrorStats::compare(&a_exact, &reference);
        assert_eq!(s.penumbra_rmse(), Some(0.0));
        assert_eq!(s.lit_darkened, 90);
        // √(90·0.01 / 100) = 0.0949; 1e-6: f32 rounding.
        assert!((old_penumbra_rmse(&a_exact, &reference) - 0.009f64.sqrt()).abs() < 1e-6);
    }

    #[test]
    fn lit_darkened_and_shadow_brightened_by_hand_and_pooled() {
        // Light 1: V_ref = 1 at four pixels, of which V 0.97 and 0.5 are darkened (< 0.98) and
        // 0.98 and 1.0 are not (the bound is strict); V_ref = 0 at two pixels, one brightened (0.03 > 0.02).
        let l1 = ErrorStats::compare(&[0.97, 0.98, 1.0, 0.5, 0.03, 0.02], &[1.0, 1.0, 1.0, 1.0, 0.0, 0.0]);
        assert_eq!((l1.pixels, l1.lit_darkened, l1.shadow_brightened), (6, 2, 1));
        assert_eq!(l1.lit_darkened_frac(), 2.0 / 6.0);
        assert_eq!(l1.shadow_brightened_frac(), 1.0 / 6.0);
        // Light 2: a partial truth (0.99: neither lit nor in the penumbra, so in neither fraction),
        // an umbra pixel leaking fully, and one not relevant (NaN reference).
        let l2 = ErrorStats::compare(&[0.5, 1.0, 0.0], &[0.99, 0.0, f32::NAN]);
        assert_eq!((l2.pixels, l2.lit_darkened, l2.shadow_brightened, l2.penumbra_pixels), (2, 0, 1, 0));
        assert_eq!(l2.summary().shadow_brightened_frac, 0.5);
        // Pooled: the pixels of both lights, 2 darkened and 2 brightened of 8.
        let mut pooled = l1;
        pooled.merge(&l2);
        let m = pooled.summary();
        assert_eq!(m.relevant_pixels, 8);
        assert_eq!((m.lit_darkened_frac, m.shadow_brightened_frac), (0.25, 0.25));
        let none = ErrorStats::default().summary();
        assert_eq!((none.lit_darkened_frac, none.shadow_brightened_frac), (0.0, 0.0));
    }

    #[test]
    fn nan_values_are_errors_in_every_measure() {
        // A NaN technique value where the truth is lit, in umbra, and in the penumbra.
        let s = ErrorStats::compare(&[f32::NAN; 3], &[1.0, 0.0, 0.5]);
        assert_eq!((s.pixels, s.missing, s.wrong), (3, 3, 3));
        assert_eq!((s.lit_darkened, s.shadow_brightened, s.penumbra_pixels), (1, 1, 1));
        // Each counts as an error of 1.
        assert_eq!(s.rmse(), 1.0);
        assert_eq!(s.penumbra_rmse(), Some(1.0));
    }

    #[test]
    fn pooling_adds_pixels() {
        let a = ErrorStats::compare(&[0.0, 1.0], &[0.0, 0.0]);
        let b = ErrorStats::compare(&[0.5], &[0.5]);
        let mut p = a;
        p.merge(&b);
        assert_eq!(p.pixels, 3);
        assert!((p.rmse() - (1.0f64 / 3.0).sqrt()).abs() < 1e-9);
        assert_eq!(ErrorStats::default().penumbra_rmse(), None);
    }

    #[test]
    fn flip_of_identical_images_is_zero() {
        let img: Vec<u8> = (0..16 * 16 * 3).map(|i| (i * 7 % 256) as u8).collect();
        assert_eq!(flip_mean(&img, &img, 16, 16), Some(0.0));
        let mut other = img.clone();
        other.iter_mut().for_each(|v| *v = 255 - *v);
        assert!(flip_mean(&img, &other, 16, 16).unwrap() > 0.1);
        assert_eq!(flip_mean(&img, &other, 8, 8), None);
    }
}
