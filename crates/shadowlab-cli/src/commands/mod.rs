pub mod reference;
pub mod scenes;
