//! # shadowlab-viewer
//!
//! The interactive analysis framework (texel density, cascades, frusta, error maps), after Stingl
//! 2011 §5. Not built yet: this crate holds its place in the workspace so that its dependency
//! boundary (GPU engine + UI, no CPU reference) is fixed from the start.

pub use shadowlab;
