//! # shadowlab
//!
//! The engine applications embed: wgpu context, G-buffer, lighting and the shadow techniques. It is
//! built up in the GPU pipeline issue; today it re-exports the scene model it will render.

pub use shadowlab_core as core;
