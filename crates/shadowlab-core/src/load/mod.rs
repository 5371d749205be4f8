//! Scene loading: built-in scenes by name, and files by extension (`.toml`, `.gltf`, `.glb`, `.obj`).
//!
//! A loader either returns a complete, validated scene or an error that says what and where; it
//! never returns a partial scene and never panics. Things worth knowing that are not errors (a
//! missing MTL file, an orthographic camera skipped) come back as warnings for the caller to show.

pub mod emissive;
pub mod gltf;
pub mod obj;
pub mod scene_file;

use std::path::Path;

use glam::Vec3;

use crate::camera::View;
use crate::error::{Location, Result, SceneError};
use crate::light::{Light, LightKind};
use crate::scene::Scene;
use crate::scenes;

/// A loaded scene and what the loader thinks the user should know.
#[derive(Debug)]
pub struct Loaded {
    pub scene: Scene,
    pub warnings: Vec<String>,
}

/// How files become scenes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Emissive planar rectangles become rect lights ([`emissive::lights_from_emissive`]): the
    /// Cornell box lit by its ceiling panel. A scene file asks for it with `emissive_lights = true`.
    pub emissive_lights: bool,
}

/// Loads `spec`: a built-in scene name with optional options (`terrain:sun=0.27`), or a path to a
/// scene file. The result is validated; a file without views or lights gets a default of each
/// (with a warning), so that every command can run on a bare model. The scene comes recentred
/// ([`Scene::recentre`]): far from the world's origin its coordinates are local ones, and
/// `scene.origin` says where they are.
pub fn load_scene(spec: &str) -> Result<Loaded> {
    load_scene_with(spec, LoadOptions::default())
}

/// [`load_scene`] with `options` (for files; built-in scenes ignore them).
pub fn load_scene_with(spec: &str, options: LoadOptions) -> Result<Loaded> {
    let path = Path::new(spec);
    if path.exists() || spec.contains(['/', '\\']) || has_scene_extension(path) {
        let loaded = load_file(path)?;
        return finish_file(loaded, path, options);
    }
    let mut scene = scenes::build(spec)?;
    scene.validate()?;
    scene.recentre();
    Ok(Loaded { scene, warnings: Vec::new() })
}

/// A scene file's bytes, as [`load_scene_with`] loads the file at `path` (which names it in
/// errors, picks the format by its extension and anchors relative paths): parsed, given defaults,
/// validated and recentred. The loaders' fuzz targets (`fuzz/`) and their corpus replay call it.
pub fn parse_file_bytes(bytes: &[u8], path: &Path, options: LoadOptions) -> Result<Loaded> {
    let loaded = match extension(path).as_deref() {
        Some("toml") => scene_file::parse(&String::from_utf8_lossy(bytes), path)?,
        Some("gltf" | "glb") => gltf::parse(bytes, path)?,
        Some("obj") => obj::parse(bytes, path)?,
        _ => return Err(SceneError::UnsupportedFormat { location: Location::file(path) }),
    };
    finish_file(loaded, path, options)
}

/// What every loaded file goes through: emissive lights when asked, defaults, validation,
/// recentring.
fn finish_file(mut loaded: Loaded, path: &Path, options: LoadOptions) -> Result<Loaded> {
    if options.emissive_lights {
        let warnings = emissive::lights_from_emissive(&mut loaded.scene);
        loaded.warnings.extend(warnings);
    }
    add_defaults(&mut loaded);
    loaded.scene.validate().map_err(|e| e.in_file(path))?;
    loaded.scene.recentre();
    Ok(loaded)
}

fn has_scene_extension(path: &Path) -> bool {
    matches!(extension(path).as_deref(), Some("toml" | "gltf" | "glb" | "obj"))
}

fn extension(path: &Path) -> Option<String> {
    path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase())
}

/// Reads a whole file a user named (a texture, a timeline, a calibration, light meshes), refusing
/// what is not a regular file first: `/dev/zero` would be read until memory ran out, and a FIFO
/// would wait forever for a writer.
pub fn read_regular(path: &Path) -> std::io::Result<Vec<u8>> {
    if path.exists() && !path.is_file() {
        return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file"));
    }
    std::fs::read(path)
}

/// Loads a file by its extension, without defaults or whole-scene validation (used for files
/// placed by a scene file too).
pub fn load_file(path: &Path) -> Result<Loaded> {
    if !path.exists() {
        return Err(SceneError::Io {
            location: Location::file(path),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
        });
    }
    // A directory or a device (`/dev/zero`) is not a scene: refuse before reading it.
    if !path.is_file() {
        return Err(SceneError::Io {
            location: Location::file(path),
            source: std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file"),
        });
    }
    match extension(path).as_deref() {
        Some("toml") => scene_file::load(path),
        Some("gltf" | "glb") => gltf::load(path),
        Some("obj") => obj::load(path),
        _ => Err(SceneError::UnsupportedFormat { location: Location::file(path) }),
    }
}

/// Gives a scene without views a view that frames its bounds, and one without lights a sun.
pub fn add_defaults(loaded: &mut Loaded) {
    let scene = &mut loaded.scene;
    let bounds = scene.bounds();
    if bounds.is_empty() || !bounds.diagonal().is_finite() {
        return; // validation will say why
    }
    let (c, d) = (bounds.center(), bounds.diagonal().max(1e-6));
    if scene.views.is_empty() {
        let dir = Vec3::new(0.55, 0.45, 0.7).normalize();
        scene.views.push(View::new("default", c + dir * 1.1 * d, c, 0.01 * d, 10.0 * d).with_fov_degrees(50.0));
        loaded.warnings.push("the file has no camera: added view 'default' framing the scene".to_owned());
    }
    if scene.lights.is_empty() {
        let direction = Vec3::new(-0.35, -1.0, -0.45).normalize();
        scene.add_light(Light::new(
            "sun",
            LightKind::Directional { direction, angular_radius: 0.27f32.to_radians() },
            Vec3::new(1.0, 0.96, 0.9),
            3.0,
        ));
        loaded.warnings.push("the file has no lights: added directional light 'sun'".to_owned());
    }
}

#[cfg(all(test, unix))]
mod read_tests {
    /// A device is refused before it is read (`/dev/zero` would be read until memory ran out),
    /// a regular file is read, a missing one is the system's own error.
    #[test]
    fn only_regular_files_are_read() {
        let e = super::read_regular(std::path::Path::new("/dev/zero")).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
        let here = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml");
        assert!(super::read_regular(&here).unwrap().starts_with(b"["));
        let missing = super::read_regular(std::path::Path::new("/nonexistent/shadowlab")).unwrap_err();
        assert_eq!(missing.kind(), std::io::ErrorKind::NotFound);
    }
}
