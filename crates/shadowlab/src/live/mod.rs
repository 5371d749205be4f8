//! The live engine's shared layer (DESIGN.md §11): scene edits and their versions, the one table of
//! validity rules, the one store of cached items, and cached map views with their static/dynamic
//! split. It sits below the techniques, which use it, and is driven by [`crate::Shadows`].
//!
//! ```text
//! edits ──► LiveScene (ids, versions) ──► signatures of cached items ──► ShadowCache (valid?)
//!                                                     ▲
//! techniques: MapViews::update(views) ── render only the invalid static / composite layers
//! ```

pub mod cache;
pub mod edits;
pub mod maps;
pub mod scene;
pub mod scheduler;
pub mod temporary;
pub mod validity;

pub use cache::{ItemKey, ShadowCache, Work};
pub use edits::{Edit, EditError, EditKind, InstanceId, LightChange};
pub use maps::MapViews;
pub use scene::{Applied, InstanceState, LightState, LiveScene};
pub use validity::{ItemKind, Region, Rule, Signature};
