//! Built-in procedural scenes: no files needed, deterministic, each made to exercise hard cases.
//!
//! | name | what it tests |
//! | --- | --- |
//! | `room` | furnished interior, four lights of every kind (`lamps=N`: N point lamps), fine detail |
//! | `penumbra` | the analytic case: a square over a plane under a square light, closed-form truth |
//! | `columns` | three rooms with pillars and doorways, four point lights, dynamic objects (`movers=N` more) |
//! | `terrain` | 800 m of terrain under a directional light: the long-view, perspective-aliasing case |
//! | `city` | a 2 km city seen from street level under a hard sun: kilometre depth ranges, thin poles |

mod city;
mod columns;
pub mod penumbra;
mod room;
mod terrain;

use glam::{Affine3A, Vec3};

use crate::error::{Result, SceneError};
use crate::material::Material;
use crate::mesh::Mesh;
use crate::params::{ParamDef, ParamSet, parse_spec};
use crate::scene::{Instance, MaterialId, Scene};

/// A built-in scene: its name, a one-line summary, its options and its constructor.
pub struct BuiltinScene {
    pub name: &'static str,
    pub summary: &'static str,
    /// Options given as `name:key=value,...` (e.g. `terrain:sun=0.27`).
    pub options: &'static [ParamDef],
    build: fn(&ParamSet) -> Scene,
}

impl BuiltinScene {
    /// Builds the scene with the given options.
    pub fn build(&self, options: &ParamSet) -> Scene {
        (self.build)(options)
    }
}

static BUILTIN: &[BuiltinScene] = &[
    BuiltinScene { name: "room", summary: room::SUMMARY, options: room::OPTIONS, build: room::build },
    BuiltinScene { name: "penumbra", summary: penumbra::SUMMARY, options: penumbra::OPTIONS, build: penumbra::build },
    BuiltinScene { name: "columns", summary: columns::SUMMARY, options: columns::OPTIONS, build: columns::build },
    BuiltinScene { name: "terrain", summary: terrain::SUMMARY, options: terrain::OPTIONS, build: terrain::build },
    BuiltinScene { name: "city", summary: city::SUMMARY, options: city::OPTIONS, build: city::build },
];

/// All built-in scenes, in listing order.
pub fn builtin() -> &'static [BuiltinScene] {
    BUILTIN
}

pub fn find(name: &str) -> Option<&'static BuiltinScene> {
    BUILTIN.iter().find(|s| s.name == name)
}

/// Builds a built-in scene from `name` or `name:key=value,...`.
pub fn build(spec: &str) -> Result<Scene> {
    let (name, assignments) =
        parse_spec(spec).map_err(|source| SceneError::Option { scene: spec.to_owned(), source })?;
    let Some(def) = find(name) else {
        return Err(SceneError::UnknownScene {
            name: name.to_owned(),
            known: BUILTIN.iter().map(|s| s.name).collect::<Vec<_>>().join(", "),
        });
    };
    let mut options = ParamSet::new(def.options);
    options.apply(assignments).map_err(|source| SceneError::Option { scene: name.to_owned(), source })?;
    Ok(def.build(&options))
}

/// Scene assembly helpers shared by the built-in scenes.
pub(crate) struct Builder {
    pub scene: Scene,
}

impl Builder {
    pub fn new(name: &str) -> Self {
        Self { scene: Scene::new(name) }
    }

    pub fn material(&mut self, m: Material) -> MaterialId {
        self.scene.add_material(m)
    }

    /// Adds `mesh` (named `name`) as a new mesh with one instance.
    pub fn object(&mut self, name: &str, mut mesh: Mesh, material: MaterialId, transform: Affine3A) -> &mut Instance {
        mesh.name = name.to_owned();
        let id = self.scene.add_mesh(mesh);
        self.scene.add_instance(Instance::new(name, id, material, transform))
    }

    pub fn finish(self) -> Scene {
        self.scene
    }
}

/// Merges parts (each with its own placement) into one mesh.
pub(crate) fn combine(parts: impl IntoIterator<Item = (Mesh, Affine3A)>) -> Mesh {
    let mut m = Mesh::new("combined");
    for (part, t) in parts {
        m.append(&part, &t);
    }
    m
}

pub(crate) fn at(x: f32, y: f32, z: f32) -> Affine3A {
    Affine3A::from_translation(Vec3::new(x, y, z))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::Topology;

    #[test]
    fn every_builtin_scene_is_valid_with_three_views() {
        for def in builtin() {
            let scene = def.build(&ParamSet::new(def.options));
            scene.validate().unwrap_or_else(|e| panic!("{}: {e}", def.name));
            assert!(scene.views.len() >= 3, "{} has {} views", def.name, scene.views.len());
            assert!(!scene.lights.is_empty(), "{}", def.name);
            // Deterministic: the same options give the same scene.
            assert_eq!(scene, def.build(&ParamSet::new(def.options)), "{} is not deterministic", def.name);
        }
    }

    #[test]
    fn meshes_are_closed_except_documented_open_ones() {
        // The ground planes of `penumbra` and `terrain` are open by design (a plane, a heightfield).
        for def in builtin() {
            let scene = def.build(&ParamSet::new(def.options));
            for m in &scene.meshes {
                let r = Topology::build(m).report();
                let open_ok = matches!(m.name.as_str(), "ground" | "terrain");
                assert!(r.is_closed_manifold() || open_ok, "{} / {}: {r:?}", def.name, m.name);
            }
        }
    }

    #[test]
    fn unknown_scene_and_bad_options_are_errors() {
        let e = build("rooom").unwrap_err();
        assert!(e.to_string().contains("room, penumbra, columns, terrain"), "{e}");
        let e = build("terrain:sun=90").unwrap_err();
        assert!(e.to_string().contains("sun"), "{e}");
        let e = build("terrain:colour=red").unwrap_err();
        assert!(e.to_string().contains("unknown parameter"), "{e}");
    }
}
