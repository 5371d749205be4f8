//! # shadowlab-core
//!
//! The CPU half of shadowlab, shared by every other crate and free of any GPU dependency: the scene
//! model ([`Scene`]: meshes, materials, instances, lights, views), loaders for glTF, OBJ and TOML
//! scene files, the built-in procedural scenes, mesh topology (welding, edge → face maps,
//! closedness), emitter sampling patterns and the typed parameters used by scenes and techniques.
//!
//! ```
//! let loaded = shadowlab_core::load_scene("penumbra").unwrap();
//! let scene = loaded.scene;
//! assert_eq!(scene.lights[0].type_name(), "rect");
//! assert!(scene.view("default").is_some());
//! ```

pub mod alpha;
pub mod backprojection;
pub mod bounds;
pub mod bvh;
pub mod camera;
pub mod cascades;
pub mod convex;
pub mod error;
pub mod light;
pub mod lightmesh;
pub mod lightspace;
pub mod load;
pub mod material;
pub mod mesh;
pub mod params;
pub mod primitives;
pub mod receivers;
pub mod sampling;
pub mod scene;
pub mod scenes;
pub mod smoothies;
pub mod surface;
pub mod texture;
pub mod topology;
pub mod volumes;

pub use bounds::Aabb;
pub use camera::{CameraPath, View};
pub use error::{Location, SceneError};
pub use glam;
pub use light::{EmitterExtent, Light, LightKind};
pub use load::{LoadOptions, Loaded, load_scene, load_scene_with, read_regular};
pub use material::{AlphaMode, Material, TextureRef};
pub use mesh::Mesh;
pub use params::{ParamDef, ParamError, ParamKind, ParamSet, ParamValue};
pub use scene::{Instance, LightId, MaterialId, MeshId, Mobility, Role, Scene, SceneStats};
pub use surface::SurfaceBuffer;
pub use topology::{Topology, TopologyReport};
