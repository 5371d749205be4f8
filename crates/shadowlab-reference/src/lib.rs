//! # shadowlab-reference
//!
//! The ground truth every technique is measured against: a BVH over the scene's triangles, the
//! visibility V_l(p) of DESIGN.md §3 by ray tracing (exact for hard lights, stratified sampling for
//! area emitters), CPU primary rays for when there is no GPU, and the error metrics, FLIP and
//! heatmaps of the reports.
//!
//! ```
//! use shadowlab_reference::{SceneBvh, Selection, ReferenceSettings, light_visibility, trace_surface};
//! let scene = shadowlab_core::load_scene("penumbra").unwrap().scene;
//! let view = scene.view("top").unwrap();
//! let all = SceneBvh::build(&scene, Selection::All);
//! let surface = trace_surface(&all, &scene, view, 32, 32);
//! let casters = SceneBvh::build(&scene, Selection::Casters);
//! let settings = ReferenceSettings { samples: 16, seed: 1 };
//! let v = light_visibility(&casters, &surface, &scene.lights[0], 0, &settings, None);
//! assert!(v.values.iter().filter(|v| !v.is_nan()).all(|&v| (0.0..=1.0).contains(&v)));
//! ```

pub use shadowlab_core::bvh;
pub mod images;
pub mod metrics;
pub mod surface;
pub mod temporal;
pub mod visibility;

pub use bvh::{SceneBvh, Selection};
pub use metrics::{ErrorStats, Metrics};
pub use surface::trace_surface;
pub use visibility::{ReferenceResult, ReferenceSettings, Visibility, light_visibility, reference, samples_for};
