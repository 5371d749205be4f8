//! Temporal stability: how much a technique's shadows flicker along a camera path where the true
//! shadows hold still.
//!
//! `flicker` (in `metrics.json` when `compare --path` is given) is the fraction of relevant pixels
//! whose visibility changes by more than [`crate::metrics::WRONG_THRESHOLD`] between consecutive
//! frames while the reference visibility of the same surface point does not. The point is found by
//! reprojecting the pixel's world position into the previous frame (nearest pixel); a pixel is a
//! disocclusion, and skipped, when the previous frame shows another surface there (farther than two
//! pixel footprints from it).

use shadowlab_core::{SurfaceBuffer, View};

use crate::metrics::WRONG_THRESHOLD;

/// One frame of a technique along a path.
pub struct FrameSample<'a> {
    pub view: &'a View,
    pub surface: &'a SurfaceBuffer,
    /// The technique's visibility.
    pub value: &'a [f32],
    /// The reference visibility (NaN where not relevant).
    pub reference: &'a [f32],
}

/// Counts for [`flicker`]; add them up over frames and lights.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FlickerStats {
    /// Relevant pixels with a valid reprojection into the previous frame.
    pub pixels: u64,
    /// Of those, pixels whose technique visibility changed while the reference did not.
    pub flickering: u64,
    /// Pixels whose reference visibility changed (true shadow motion), not counted as flicker.
    pub moving: u64,
}

impl FlickerStats {
    pub fn add(&mut self, o: &Self) {
        self.pixels += o.pixels;
        self.flickering += o.flickering;
        self.moving += o.moving;
    }

    pub fn fraction(&self) -> f64 {
        if self.pixels == 0 { 0.0 } else { self.flickering as f64 / self.pixels as f64 }
    }
}

/// Compares frame `cur` with the frame before it.
pub fn flicker(prev: &FrameSample<'_>, cur: &FrameSample<'_>) -> FlickerStats {
    let (w, h) = (prev.surface.width, prev.surface.height);
    let vp = prev.view.view_projection(w, h);
    let eye = cur.view.position;
    let forward = cur.view.forward();
    let footprint = 2.0 * (0.5 * cur.view.fov_y).tan() / cur.surface.height.max(1) as f32;
    let mut s = FlickerStats::default();
    for i in 0..cur.surface.len() {
        if !cur.surface.covered[i] || cur.reference[i].is_nan() {
            continue;
        }
        let p = cur.surface.positions[i];
        let clip = vp * p.extend(1.0);
        if clip.w <= 0.0 {
            continue;
        }
        let ndc = clip.truncate() / clip.w;
        let (x, y) = ((0.5 * ndc.x + 0.5) * w as f32, (0.5 - 0.5 * ndc.y) * h as f32);
        if !(x >= 0.0 && y >= 0.0 && x < w as f32 && y < h as f32) {
            continue;
        }
        let j = (y as usize) * w as usize + x as usize;
        if !prev.surface.covered[j] || prev.reference[j].is_nan() {
            continue;
        }
        let depth = (p - eye).dot(forward).max(0.0);
        let tolerance = 2.0 * footprint * depth + 1e-5 * depth;
        if prev.surface.positions[j].distance(p) > tolerance {
            continue; // disocclusion: another surface was there
        }
        s.pixels += 1;
        let reference_changed = (cur.reference[i] - prev.reference[j]).abs() > WRONG_THRESHOLD;
        let value_changed = (cur.value[i] - prev.value[j]).abs() > WRONG_THRESHOLD;
        if reference_changed {
            s.moving += 1;
        } else if value_changed {
            s.flickering += 1;
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn flat(view: &View, n: u32) -> SurfaceBuffer {
        // A floor at y = 0 seen by `view`: intersect each pixel ray with the plane.
        let mut s = SurfaceBuffer::new(n, n);
        for y in 0..n {
            for x in 0..n {
                let (o, d) = view.pixel_ray(x, y, n, n);
                if d.y < -1e-3 {
                    let i = (y * n + x) as usize;
                    s.positions[i] = o + d * (-o.y / d.y);
                    s.normals[i] = Vec3::Y;
                    s.covered[i] = true;
                }
            }
        }
        s
    }

    #[test]
    fn counts_changes_only_where_the_truth_holds_still() {
        let n = 32;
        let a = View::new("a", Vec3::new(0.0, 5.0, 5.0), Vec3::ZERO, 0.1, 50.0);
        let b = View {
            position: a.position + Vec3::new(0.01, 0.0, 0.0),
            target: a.target + Vec3::new(0.01, 0.0, 0.0),
            ..a.clone()
        };
        let (sa, sb) = (flat(&a, n), flat(&b, n));
        // Truth: shadow where x < 0 (a fixed world-space edge); technique A matches it, technique B
        // is right in the first frame and wrong in a stripe in the second.
        let truth = |s: &SurfaceBuffer| -> Vec<f32> {
            (0..s.len())
                .map(|i| {
                    if !s.covered[i] {
                        f32::NAN
                    } else if s.positions[i].x < 0.0 {
                        0.0
                    } else {
                        1.0
                    }
                })
                .collect()
        };
        let (ra, rb) = (truth(&sa), truth(&sb));
        let good = flicker(
            &FrameSample { view: &a, surface: &sa, value: &ra, reference: &ra },
            &FrameSample { view: &b, surface: &sb, value: &rb, reference: &rb },
        );
        assert!(good.pixels > 500);
        assert_eq!(good.flickering, 0);
        let bad_b: Vec<f32> = (0..sb.len())
            .map(|i| if sb.positions[i].z > 1.0 && sb.positions[i].x > 0.5 { 0.0 } else { rb[i] })
            .collect();
        let bad = flicker(
            &FrameSample { view: &a, surface: &sa, value: &ra, reference: &ra },
            &FrameSample { view: &b, surface: &sb, value: &bad_b, reference: &rb },
        );
        assert!(bad.flickering > 20 && bad.fraction() > 0.02, "{bad:?}");
    }
}
