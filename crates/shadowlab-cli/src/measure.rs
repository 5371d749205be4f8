//! Rendering a technique for a number of frames and summarising its times (DESIGN.md §9: medians
//! after warm-up, GPU time per pass from timestamps, CPU frame time beside it).
//!
//! Two figures per technique: the frame with nothing kept (the cache off: every map, light map and
//! volume rebuilt, the cost of a frame where the light or everything in view changed: `gpu_ms`, as
//! before the live engine), and the still frame of the live engine (`cached_gpu_ms`: only what
//! must be redone each frame, e.g. lookups, stencil passes, camera-fitted views).

use anyhow::Result;
use serde_json::{Value, json};
use shadowlab::timing::PassKind;
use shadowlab::{FrameReport, Renderer};

use crate::args::{Selected, Setup, renderer_for};

/// Medians over the timed frames.
#[derive(Debug, Clone, PartialEq)]
pub struct Timing {
    pub frames: usize,
    pub warmup: usize,
    /// Median GPU ms of the whole frame and per pass kind; `None` without timestamp queries.
    pub gpu_median: Option<f64>,
    pub gpu_passes: Option<[f64; 4]>,
    pub cpu_median: f64,
}

impl Timing {
    pub fn from_reports(reports: &[FrameReport], warmup: usize) -> Self {
        let timed = &reports[warmup.min(reports.len())..];
        let cpu: Vec<f64> = timed.iter().map(|r| r.cpu_ms).collect();
        let gpu: Option<Vec<_>> = timed.iter().map(|r| r.gpu).collect();
        let (gpu_median, gpu_passes) = match gpu {
            Some(g) if !g.is_empty() => (
                Some(median(g.iter().map(|t| t.total()).collect())),
                Some(PassKind::ALL.map(|k| median(g.iter().map(|t| t.get(k)).collect()))),
            ),
            _ => (None, None),
        };
        Self { frames: timed.len(), warmup, gpu_median, gpu_passes, cpu_median: median(cpu) }
    }

    /// The time ratios are taken on: GPU when measured, CPU otherwise.
    pub fn frame_ms(&self) -> f64 {
        self.gpu_median.unwrap_or(self.cpu_median)
    }

    pub fn gpu_json(&self) -> Value {
        match (self.gpu_median, self.gpu_passes) {
            (Some(m), Some(p)) => json!({
                "median": m,
                "passes": PassKind::ALL.iter().zip(p).map(|(k, v)| (k.name().to_owned(), json!(v))).collect::<serde_json::Map<_, _>>(),
            }),
            _ => json!({ "median": null, "passes": null }),
        }
    }
}

pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// A technique rendered and timed: the renderer stays for readbacks.
pub struct Measured {
    pub renderer: Renderer,
    /// Frames with the cache off (everything rebuilt every frame).
    pub timing: Timing,
    /// Still frames with the cache on.
    pub cached: Timing,
}

/// Renders `warmup + frames` frames of `selected` (one spec, or one per light) uncached, then
/// `warmup + frames` with the cache on; `tick` is called after each frame.
pub fn measure(
    gpu: &shadowlab::Gpu,
    setup: &Setup,
    selected: &Selected,
    warmup: usize,
    frames: usize,
    tick: &dyn Fn(),
) -> Result<Measured> {
    let mut r = renderer_for(gpu, setup, selected)?;
    let run = |r: &mut Renderer| -> Result<Timing> {
        let mut reports = Vec::with_capacity(warmup + frames);
        for _ in 0..warmup + frames.max(1) {
            reports.push(r.render()?);
            tick();
        }
        Ok(Timing::from_reports(&reports, warmup))
    };
    r.shadows.set_caching(false);
    let timing = run(&mut r)?;
    r.shadows.set_caching(true);
    // The first cached frame fills the cache: it is part of the warm-up.
    let cached = run(&mut r)?;
    Ok(Measured { timing, cached, renderer: r })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(vec![]).is_nan());
    }
}
