pub mod analyze;
pub mod bench;
pub mod compare;
pub mod play;
pub mod reference;
pub mod render;
pub mod scenes;
pub mod techniques;
