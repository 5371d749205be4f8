//! # shadowlab-viewer
//!
//! The interactive viewer (Stingl 2011 §5's framework, for every family of techniques): fly
//! through a scene, switch each light's technique and its parameters live (widgets built from the
//! registry's `ParamDef`s), drag objects (Toromanoff 2005's planner: temporary while dragged),
//! and see the analysis overlays. winit + egui on the engine's own wgpu device.
//!
//! - [`viewer`]: the state (live engine, camera, techniques, drag), window- and toolkit-free;
//! - [`ui`]: the egui panel and scene area;
//! - [`third_person`]: the second camera with the eye's and the maps' frusta drawn in;
//! - [`present`]: the scene image as an egui texture, egui drawn with egui-wgpu;
//! - [`truth`]: the ray-traced reference of the frame shown, on a background thread (feature
//!   `truth`, on by default; the CPU tracer is what a web build leaves out);
//! - [`headless`]: the same frames offscreen, driven by a [`script`], for tests and pictures;
//! - [`window`]: the winit window.
//!
//! Dependency boundary: the GPU engine and the UI; the CPU reference only behind `truth`.

pub mod args;
pub mod camera;
pub mod headless;
pub mod present;
pub mod script;
pub mod third_person;
#[cfg(feature = "truth")]
pub mod truth;
pub mod ui;
pub mod viewer;
pub mod window;

pub use shadowlab;
pub use viewer::{Overlay, Setup, Viewer, ViewerError};
