//! Truth in the loop: the ray-traced reference of the current frame for one light, traced on a
//! background thread (the UI keeps drawing frames), then the error heatmap and the metrics of
//! `compare` (DESIGN.md §3: the same surface points, the same definition of V).
//!
//! Behind the `truth` feature (on by default): the CPU tracer is the one dependency a web build
//! leaves out.

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::thread::JoinHandle;

use shadowlab_reference::images::error_heatmap;
use shadowlab_reference::{ErrorStats, ReferenceSettings, SceneBvh, Selection, light_visibility};

use crate::viewer::{Viewer, ViewerError};

/// Emitter samples per pixel of the viewer's reference (area lights; point lights take one).
pub const DEFAULT_SAMPLES: u32 = 64;

/// The traced truth and how the technique fared against it.
#[derive(Debug, Clone)]
pub struct Truth {
    pub light: usize,
    /// The technique it was compared with (its spec text).
    pub technique: String,
    /// The viewer's state it was traced for (`Viewer::state`): the heatmap is stale once the camera,
    /// the scene or the technique changed.
    pub frame: u64,
    pub width: u32,
    pub height: u32,
    pub stats: ErrorStats,
    /// The signed error heatmap, RGB (blue: too dark, red: too bright; `compare`'s colours).
    pub heatmap: Vec<u8>,
    pub seconds: f64,
}

/// A trace under way.
pub struct TruthJob {
    handle: Option<JoinHandle<Truth>>,
    done: Arc<AtomicUsize>,
    total: usize,
    pub light: usize,
}

impl TruthJob {
    /// Starts tracing light `light`'s truth for the viewer's last frame (its surface read back
    /// now, the scene copied: edits after this do not touch the trace).
    pub fn start(viewer: &Viewer, light: usize, samples: u32) -> Result<Self, ViewerError> {
        let r = &viewer.renderer;
        let surface = r.read_surface()?;
        let scene = r.scene().clone();
        let Some(lamp) = scene.lights.get(light).cloned() else {
            return Err(ViewerError::Other(format!("no light {light}")));
        };
        let id = viewer.light_id(light)?;
        let value = r
            .read_visibility(id)?
            .ok_or_else(|| ViewerError::Other(format!("light '{}' has no visibility layer", lamp.name)))?;
        let technique = viewer.spec(light).map_or_else(String::new, crate::viewer::spec_text);
        let frame = viewer.state();
        let done = Arc::new(AtomicUsize::new(0));
        let total = surface.len();
        let counter = done.clone();
        let handle = std::thread::Builder::new()
            .name("truth".into())
            .spawn(move || {
                let start = std::time::Instant::now();
                let bvh = SceneBvh::build(&scene, Selection::Casters);
                let progress = |n: usize, _: usize| {
                    counter.store(n, Ordering::Relaxed);
                };
                let settings = ReferenceSettings { samples, seed: 1 };
                let reference = light_visibility(&bvh, &surface, &lamp, light as u32, &settings, Some(&progress));
                let stats = ErrorStats::compare(&value, &reference.values);
                Truth {
                    light,
                    technique,
                    frame,
                    width: surface.width,
                    height: surface.height,
                    stats,
                    heatmap: error_heatmap(&value, &reference.values),
                    seconds: start.elapsed().as_secs_f64(),
                }
            })
            .map_err(|e| ViewerError::Other(format!("cannot start the tracing thread: {e}")))?;
        Ok(Self { handle: Some(handle), done, total, light })
    }

    /// The fraction of pixels traced.
    pub fn progress(&self) -> f32 {
        self.done.load(Ordering::Relaxed) as f32 / self.total.max(1) as f32
    }

    /// The result once the thread has finished (without waiting); `Err` if it panicked.
    pub fn poll(&mut self) -> Option<Result<Truth, ViewerError>> {
        if !self.handle.as_ref().is_some_and(JoinHandle::is_finished) {
            return None;
        }
        let handle = self.handle.take()?;
        Some(handle.join().map_err(|_| ViewerError::Other("the truth's tracer failed".into())))
    }
}
