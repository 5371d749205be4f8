//! Error metrics of a technique's visibility against the reference (DESIGN.md §6).
//!
//! All figures are over *relevant* pixels: those where the reference holds a value (not NaN).
//! - `rmse`, `mae`, `max_abs`: of V − V_ref;
//! - `wrong_frac`: the fraction with |V − V_ref| > [`WRONG_THRESHOLD`];
//! - `penumbra_rmse`: RMSE over pixels where V_ref or V lies strictly inside
//!   ([`PENUMBRA_LO`], [`PENUMBRA_HI`]);
//! - a technique value that is NaN at a relevant pixel counts as an error of 1 (and is counted).
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
    pub penumbra_pixels: u64,
    penumbra_sum_sq: f64,
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
        let inside = |x: f32| x > PENUMBRA_LO && x < PENUMBRA_HI;
        if inside(reference) || inside(value) {
            self.penumbra_pixels += 1;
            self.penumbra_sum_sq += f64::from(d) * f64::from(d);
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

    /// `None` when no pixel is in a penumbra (hard shadows that agree).
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
        // Penumbra: value 0.2 (ref 0), ref 0.5: two pixels.
        assert_eq!(s.penumbra_pixels, 2);
        assert!((s.penumbra_rmse().unwrap() - ((0.04 + 0.0025) / 2.0f64).sqrt()).abs() < 1e-6);
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
