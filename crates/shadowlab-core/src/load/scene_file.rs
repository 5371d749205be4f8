//! The TOML scene file: places meshes from files or primitives, and says what glTF and OBJ cannot:
//! static or dynamic, roles, emitter sizes, area lights, named views. The format is documented with
//! a full example in `docs/scene-format.md`.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Affine3A, Quat, Vec2, Vec3};
use serde::Deserialize;
use toml::Spanned;

use super::Loaded;
use crate::camera::View;
use crate::error::{Location, Result, SceneError};
use crate::light::{Light, LightKind};
use crate::material::{AlphaMode, Material, TextureRef};
use crate::primitives;
use crate::scene::{Instance, MaterialId, Mobility, Role, Scene};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: Option<String>,
    /// A built-in scene to start from (`"penumbra"`, `"room:..."`).
    base: Option<String>,
    ambient: Option<[f32; 3]>,
    /// Emissive planar rectangles become rect lights (`load::emissive`).
    emissive_lights: Option<bool>,
    #[serde(default)]
    material: Vec<Spanned<MaterialDef>>,
    #[serde(default)]
    object: Vec<Spanned<ObjectDef>>,
    #[serde(default)]
    light: Vec<Spanned<LightDef>>,
    #[serde(default)]
    view: Vec<Spanned<ViewDef>>,
    #[serde(default)]
    path: Vec<Spanned<PathDef>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PathDef {
    name: String,
    /// Names of views (of this file or the base scene), visited in order.
    views: Vec<String>,
    frames: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialDef {
    name: String,
    base_color: Option<[f32; 3]>,
    texture: Option<String>,
    specular: Option<f32>,
    shininess: Option<f32>,
    double_sided: Option<bool>,
    emissive: Option<[f32; 3]>,
    /// The base colour's alpha (multiplies the texture's).
    alpha: Option<f32>,
    /// Makes the material alpha-masked: points whose alpha is below it are holes.
    alpha_cutoff: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectDef {
    name: Option<String>,
    file: Option<String>,
    primitive: Option<PrimitiveDef>,
    material: Option<String>,
    #[serde(default)]
    position: [f32; 3],
    /// Degrees about X, then Y, then Z (world axes).
    #[serde(default)]
    rotation: [f32; 3],
    scale: Option<Scale>,
    mobility: Option<String>,
    casts_shadows: Option<bool>,
    receives_shadows: Option<bool>,
    role: Option<String>,
    /// For files: also take the file's lights and cameras (default true).
    import_lights: Option<bool>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Scale {
    Uniform(f32),
    Axes([f32; 3]),
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum PrimitiveDef {
    Box { size: [f32; 3] },
    Plane { size: [f32; 2], subdivisions: Option<u32> },
    Sphere { radius: f32, segments: Option<u32> },
    Cylinder { radius: f32, height: f32, segments: Option<u32> },
    Cone { radius: f32, height: f32, segments: Option<u32> },
    Torus { major_radius: f32, minor_radius: f32, segments: Option<u32> },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightDef {
    name: Option<String>,
    #[serde(rename = "type")]
    kind: String,
    position: Option<[f32; 3]>,
    direction: Option<[f32; 3]>,
    target: Option<[f32; 3]>,
    tangent: Option<[f32; 3]>,
    /// Sphere radius of point and spot lights (m).
    radius: Option<f32>,
    /// Rectangle width and height (m).
    size: Option<[f32; 2]>,
    /// Directional lights: angular radius in degrees.
    angular_radius: Option<f32>,
    /// Spot lights: cone half-angles in degrees.
    inner_angle: Option<f32>,
    outer_angle: Option<f32>,
    color: Option<[f32; 3]>,
    intensity: Option<f32>,
    range: Option<f32>,
    mobility: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ViewDef {
    name: String,
    position: [f32; 3],
    target: [f32; 3],
    up: Option<[f32; 3]>,
    /// Vertical field of view, degrees.
    fov: Option<f32>,
    near: Option<f32>,
    far: Option<f32>,
}

pub fn load(path: &Path) -> Result<Loaded> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, e))?;
    parse(&String::from_utf8_lossy(&bytes), path)
}

/// Parses scene-file text; `path` names the file in errors and anchors relative paths.
pub fn parse(text: &str, path: &Path) -> Result<Loaded> {
    let file: File = toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| line_of(text, s.start));
        let message = e.message().to_owned();
        SceneError::parse(Location { file: Some(path.to_path_buf()), line, path: None }, message)
    })?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut ctx = Context { text, path, dir, warnings: Vec::new(), file_cache: HashMap::new() };
    let emissive_lights = file.emissive_lights.unwrap_or(false);
    let mut scene = ctx.build(file)?;
    if emissive_lights {
        let warnings = super::emissive::lights_from_emissive(&mut scene);
        ctx.warnings.extend(warnings);
    }
    Ok(Loaded { scene, warnings: ctx.warnings })
}

fn line_of(text: &str, byte: usize) -> usize {
    text.as_bytes()[..byte.min(text.len())].iter().filter(|&&b| b == b'\n').count() + 1
}

struct Context<'a> {
    text: &'a str,
    path: &'a Path,
    dir: PathBuf,
    warnings: Vec<String>,
    file_cache: HashMap<PathBuf, Scene>,
}

impl Context<'_> {
    fn at(&self, span: std::ops::Range<usize>, what: String) -> Location {
        Location { file: Some(self.path.to_path_buf()), line: Some(line_of(self.text, span.start)), path: Some(what) }
    }

    fn build(&mut self, file: File) -> Result<Scene> {
        let mut scene = match &file.base {
            Some(base) => crate::scenes::build(base)
                .map_err(|e| SceneError::invalid(Location::path("base").in_file(self.path), e.to_string()))?,
            None => Scene::new(""),
        };
        scene.name = file
            .name
            .clone()
            .or_else(|| (!scene.name.is_empty()).then(|| scene.name.clone()))
            .unwrap_or_else(|| self.path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default());
        if let Some(a) = file.ambient {
            scene.ambient = Vec3::from(a);
        }

        let mut materials: HashMap<String, MaterialId> = HashMap::new();
        for def in &file.material {
            let span = def.span();
            let d = def.get_ref();
            let at = self.at(span, format!("material '{}'", d.name));
            let defaults = Material::default();
            let m = Material {
                name: d.name.clone(),
                base_color: d.base_color.map(Vec3::from).unwrap_or(defaults.base_color),
                base_color_texture: d.texture.as_ref().map(|t| TextureRef::File(self.dir.join(t))),
                specular: d.specular.unwrap_or(defaults.specular),
                shininess: d.shininess.unwrap_or(defaults.shininess),
                double_sided: d.double_sided.unwrap_or(false),
                emissive: d.emissive.map(Vec3::from).unwrap_or(Vec3::ZERO),
                base_alpha: d.alpha.unwrap_or(defaults.base_alpha),
                alpha_mode: d.alpha_cutoff.map_or(AlphaMode::Opaque, |cutoff| AlphaMode::Mask { cutoff }),
            };
            m.check().map_err(|e| SceneError::invalid(at.clone(), e))?;
            if materials.insert(d.name.clone(), scene.add_material(m)).is_some() {
                return Err(SceneError::invalid(at, format!("material '{}' is defined twice", d.name)));
            }
        }

        for (i, def) in file.object.iter().enumerate() {
            self.object(&mut scene, &materials, i, def)?;
        }
        for (i, def) in file.light.iter().enumerate() {
            let d = def.get_ref();
            let name = d.name.clone().unwrap_or_else(|| format!("light{}", scene.lights.len()));
            let at = self.at(def.span(), format!("light[{i}] '{name}'"));
            let light = light(d, name).map_err(|e| SceneError::invalid(at.clone(), e))?;
            light.check().map_err(|e| SceneError::invalid(at, e))?;
            scene.add_light(light);
        }
        for (i, def) in file.view.iter().enumerate() {
            let d = def.get_ref();
            let at = self.at(def.span(), format!("view[{i}] '{}'", d.name));
            let v = View {
                name: d.name.clone(),
                position: Vec3::from(d.position),
                target: Vec3::from(d.target),
                up: d.up.map(Vec3::from).unwrap_or(Vec3::Y),
                fov_y: d.fov.unwrap_or(60.0).to_radians(),
                near: d.near.unwrap_or(0.05),
                far: d.far.unwrap_or(100.0),
            };
            v.check().map_err(|e| SceneError::invalid(at, e))?;
            scene.views.retain(|old| old.name != v.name);
            scene.views.push(v);
        }
        for (i, def) in file.path.iter().enumerate() {
            let d = def.get_ref();
            let at = self.at(def.span(), format!("path[{i}] '{}'", d.name));
            let frames = d.frames.unwrap_or(30);
            if !(2..=10_000).contains(&frames) {
                return Err(SceneError::invalid(at, format!("frames {frames} must be in 2..=10000")));
            }
            let keys = d
                .views
                .iter()
                .map(|n| {
                    scene
                        .view(n)
                        .cloned()
                        .ok_or_else(|| SceneError::invalid(at.clone(), format!("view '{n}' is not defined")))
                })
                .collect::<Result<Vec<_>>>()?;
            if keys.is_empty() {
                return Err(SceneError::invalid(at, "a path needs at least one view"));
            }
            scene.paths.retain(|old| old.name != d.name);
            scene.paths.push(crate::camera::CameraPath { name: d.name.clone(), keys, frames });
        }
        Ok(scene)
    }

    fn object(
        &mut self,
        scene: &mut Scene,
        materials: &HashMap<String, MaterialId>,
        i: usize,
        def: &Spanned<ObjectDef>,
    ) -> Result<()> {
        let d = def.get_ref();
        let name = d.name.clone().unwrap_or_else(|| format!("object{i}"));
        let at = self.at(def.span(), format!("object[{i}] '{name}'"));
        let invalid = |msg: String| SceneError::invalid(at.clone(), msg);

        let transform = object_transform(d).map_err(&invalid)?;
        let mobility = match d.mobility.as_deref() {
            None | Some("static") => Mobility::Static,
            Some("dynamic") => Mobility::Dynamic,
            Some(other) => return Err(invalid(format!("mobility '{other}' must be static or dynamic"))),
        };
        let role = match d.role.as_deref() {
            None => None,
            Some(r) => Some(Role::parse(r).ok_or_else(|| invalid(format!("role '{r}' must be receiver or occluder")))?),
        };
        let material = match &d.material {
            Some(m) => {
                Some(*materials.get(m).ok_or_else(|| invalid(format!("material '{m}' is not defined in this file")))?)
            }
            None => None,
        };
        let place = |mut inst: Instance| {
            inst.mobility = mobility;
            inst.casts_shadows = d.casts_shadows.unwrap_or(true);
            inst.receives_shadows = d.receives_shadows.unwrap_or(true);
            inst.role = role;
            inst
        };
        match (&d.file, &d.primitive) {
            (Some(_), Some(_)) => Err(invalid("give either 'file' or 'primitive', not both".into())),
            (None, None) => Err(invalid("needs a 'file' or a 'primitive'".into())),
            (None, Some(p)) => {
                let mut mesh = primitive(p).map_err(&invalid)?;
                mesh.name = name.clone();
                let mesh = scene.add_mesh(mesh);
                let material = material.unwrap_or_else(|| scene.add_material(Material::default()));
                scene.add_instance(place(Instance::new(name, mesh, material, transform)));
                Ok(())
            }
            (Some(file), None) => {
                let full = self.dir.join(file);
                let sub = match self.file_cache.get(&full) {
                    Some(s) => s.clone(),
                    None => {
                        if full.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml")) {
                            return Err(invalid(
                                "a scene file cannot place another scene file (use 'base' for a built-in scene)".into(),
                            ));
                        }
                        let loaded = super::load_file(&full)
                            .map_err(|e| SceneError::invalid(at.clone(), format!("in '{file}': {e}")))?;
                        // With a material of the scene file's own, the file's materials (and what
                        // went wrong reading them) do not matter.
                        let unused = |w: &String| material.is_some() && w.contains(super::obj::MISSING_LIBRARY);
                        self.warnings.extend(loaded.warnings.into_iter().filter(|w| !unused(w)));
                        self.file_cache.insert(full.clone(), loaded.scene.clone());
                        loaded.scene
                    }
                };
                merge(scene, sub, &name, transform, material, d.import_lights.unwrap_or(true), place);
                Ok(())
            }
        }
    }
}

fn finite3(v: [f32; 3], what: &str) -> Result<Vec3, String> {
    let v = Vec3::from(v);
    if v.is_finite() { Ok(v) } else { Err(format!("{what} {v} is not finite")) }
}

fn object_transform(d: &ObjectDef) -> Result<Affine3A, String> {
    let t = finite3(d.position, "position")?;
    let r = finite3(d.rotation, "rotation")?;
    let s = match d.scale {
        None => Vec3::ONE,
        Some(Scale::Uniform(s)) => Vec3::splat(s),
        Some(Scale::Axes(a)) => Vec3::from(a),
    };
    if !s.is_finite() || s.abs().min_element() < 1e-9 {
        return Err(format!("scale {s} must be finite and non-zero"));
    }
    let q = Quat::from_rotation_z(r.z.to_radians())
        * Quat::from_rotation_y(r.y.to_radians())
        * Quat::from_rotation_x(r.x.to_radians());
    Ok(Affine3A::from_scale_rotation_translation(s, q, t))
}

fn primitive(p: &PrimitiveDef) -> Result<crate::mesh::Mesh, String> {
    let positive = |what: &str, v: f32| {
        if v.is_finite() && v > 0.0 && v < 1.0e7 {
            Ok(v)
        } else {
            Err(format!("primitive {what} {v} must be in (0, 1e7)"))
        }
    };
    let segments = |s: Option<u32>, default: u32| -> Result<u32, String> {
        match s.unwrap_or(default) {
            s @ 3..=1024 => Ok(s),
            s => Err(format!("primitive segments {s} must be in 3..=1024")),
        }
    };
    Ok(match *p {
        PrimitiveDef::Box { size } => primitives::cuboid(Vec3::new(
            positive("size x", size[0])?,
            positive("size y", size[1])?,
            positive("size z", size[2])?,
        )),
        PrimitiveDef::Plane { size, subdivisions } => {
            let n = subdivisions.unwrap_or(1);
            if !(1..=1024).contains(&n) {
                return Err(format!("plane subdivisions {n} must be in 1..=1024"));
            }
            primitives::plane(positive("width", size[0])?, positive("depth", size[1])?, n, n)
        }
        PrimitiveDef::Sphere { radius, segments: s } => {
            let s = segments(s, 48)?;
            primitives::sphere(positive("radius", radius)?, s, (s / 2).max(2))
        }
        PrimitiveDef::Cylinder { radius, height, segments: s } => {
            primitives::cylinder(positive("radius", radius)?, positive("height", height)?, segments(s, 48)?)
        }
        PrimitiveDef::Cone { radius, height, segments: s } => {
            primitives::cone(positive("radius", radius)?, positive("height", height)?, segments(s, 48)?)
        }
        PrimitiveDef::Torus { major_radius, minor_radius, segments: s } => {
            let s = segments(s, 48)?;
            let (big, small) = (positive("major_radius", major_radius)?, positive("minor_radius", minor_radius)?);
            if small >= big {
                return Err(format!("torus minor_radius {small} must be smaller than major_radius {big}"));
            }
            primitives::torus(big, small, s, (s / 2).max(3))
        }
    })
}

fn light(d: &LightDef, name: String) -> Result<Light, String> {
    let need = |v: Option<[f32; 3]>, what: &str| {
        v.ok_or_else(|| format!("{} light needs '{what}'", d.kind)).and_then(|v| finite3(v, what))
    };
    let position = || need(d.position, "position");
    let direction = || -> Result<Vec3, String> {
        let dir = match (d.direction, d.target) {
            (Some(_), Some(_)) => return Err("give either 'direction' or 'target', not both".into()),
            (Some(dir), None) => finite3(dir, "direction")?,
            (None, Some(t)) => finite3(t, "target")? - position()?,
            (None, None) => return Err(format!("{} light needs 'direction' or 'target'", d.kind)),
        };
        if dir.length() < 1e-9 {
            return Err("direction has zero length (target equals position?)".into());
        }
        Ok(dir.normalize())
    };
    let radius = d.radius.unwrap_or(0.0);
    let kind = match d.kind.as_str() {
        "point" => LightKind::Point { position: position()?, radius },
        "spot" => LightKind::Spot {
            position: position()?,
            direction: direction()?,
            inner_angle: d.inner_angle.unwrap_or(0.0).to_radians(),
            outer_angle: d.outer_angle.unwrap_or(45.0).to_radians(),
            radius,
        },
        "directional" => LightKind::Directional {
            direction: direction()?,
            angular_radius: d.angular_radius.unwrap_or(0.0).to_radians(),
        },
        "rect" => {
            let direction = direction()?;
            let size = Vec2::from(d.size.ok_or("rect light needs 'size' = [width, height]")?);
            let tangent = match d.tangent {
                Some(t) => finite3(t, "tangent")?,
                None => default_tangent(direction),
            };
            // Keep only the part perpendicular to the normal, so a sloppy tangent still works.
            let tangent = (tangent - direction * tangent.dot(direction)).normalize_or_zero();
            if tangent == Vec3::ZERO {
                return Err("tangent is parallel to the direction".into());
            }
            LightKind::Rect { position: position()?, direction, tangent, width: size.x, height: size.y }
        }
        other => return Err(format!("light type '{other}' must be point, spot, directional or rect")),
    };
    let mut light = Light::new(name, kind, d.color.map(Vec3::from).unwrap_or(Vec3::ONE), d.intensity.unwrap_or(1.0));
    light.range = d.range;
    light.mobility = match d.mobility.as_deref() {
        None | Some("static") => Mobility::Static,
        Some("dynamic") => Mobility::Dynamic,
        Some(other) => return Err(format!("mobility '{other}' must be static or dynamic")),
    };
    Ok(light)
}

/// World X projected onto the emitter plane (world Z when X is the normal).
fn default_tangent(direction: Vec3) -> Vec3 {
    let axis = if direction.x.abs() > 0.9 { Vec3::Z } else { Vec3::X };
    (axis - direction * axis.dot(direction)).normalize()
}

/// Adds a loaded file's meshes, materials and instances (and optionally lights and views) to
/// `scene`, under `transform`.
fn merge(
    scene: &mut Scene,
    sub: Scene,
    name: &str,
    transform: Affine3A,
    material: Option<MaterialId>,
    import_lights: bool,
    place: impl Fn(Instance) -> Instance,
) {
    let mesh_base = scene.meshes.len() as u32;
    let mat_base = scene.materials.len() as u32;
    scene.meshes.extend(sub.meshes);
    if material.is_none() {
        scene.materials.extend(sub.materials);
    }
    let single = sub.instances.len() == 1;
    for inst in sub.instances {
        let mut i = Instance::new(
            if single { name.to_owned() } else { format!("{name}/{}", inst.name) },
            crate::scene::MeshId(mesh_base + inst.mesh.0),
            material.unwrap_or(MaterialId(mat_base + inst.material.0)),
            transform * inst.transform,
        );
        i = place(i);
        // A file's own "does not cast" stays.
        i.casts_shadows &= inst.casts_shadows;
        scene.instances.push(i);
    }
    if import_lights {
        for mut l in sub.lights {
            l.kind = transform_light(l.kind, &transform);
            scene.lights.push(l);
        }
        for mut v in sub.views {
            v.position = transform.transform_point3(v.position);
            v.target = transform.transform_point3(v.target);
            v.up = transform.transform_vector3(v.up).normalize_or(Vec3::Y);
            scene.views.push(v);
        }
    }
}

fn transform_light(kind: LightKind, t: &Affine3A) -> LightKind {
    let p = |v: Vec3| t.transform_point3(v);
    let d = |v: Vec3| t.transform_vector3(v).normalize_or(v);
    match kind {
        LightKind::Point { position, radius } => LightKind::Point { position: p(position), radius },
        LightKind::Spot { position, direction, inner_angle, outer_angle, radius } => {
            LightKind::Spot { position: p(position), direction: d(direction), inner_angle, outer_angle, radius }
        }
        LightKind::Directional { direction, angular_radius } => {
            LightKind::Directional { direction: d(direction), angular_radius }
        }
        LightKind::Rect { position, direction, tangent, width, height } => {
            LightKind::Rect { position: p(position), direction: d(direction), tangent: d(tangent), width, height }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_str(s: &str) -> Result<Loaded> {
        parse(s, Path::new("dir/scene.toml"))
    }

    const GOOD: &str = r#"
name = "test"
[[material]]
name = "grey"
base_color = [0.5, 0.5, 0.5]

[[object]]
name = "floor"
primitive = { type = "plane", size = [4, 4] }
material = "grey"
role = "receiver"

[[object]]
name = "ball"
primitive = { type = "sphere", radius = 0.5 }
position = [0, 1, 0]
mobility = "dynamic"

[[light]]
name = "panel"
type = "rect"
position = [0, 3, 0]
direction = [0, -1, 0]
size = [0.5, 0.25]
intensity = 20

[[view]]
name = "top"
position = [0, 5, 1]
target = [0, 0, 0]

[[view]]
name = "side"
position = [5, 2, 0]
target = [0, 0, 0]

[[path]]
name = "swing"
views = ["top", "side"]
frames = 12
"#;

    /// An OBJ whose `.mtl` is missing warns that defaults are used, unless the scene file gives the
    /// object a material of its own (then the OBJ's materials are not used at all).
    #[test]
    fn a_missing_mtl_matters_only_without_a_material_of_the_scene_file() {
        let dir = std::env::temp_dir().join(format!("shadowlab-mtl-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("tri.obj"), "mtllib nowhere.mtl\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
            .unwrap();
        let scene = |material: &str| {
            format!(
                "[[material]]\nname = \"grey\"\nbase_color = [0.5, 0.5, 0.5]\n\n[[object]]\nfile = \"tri.obj\"\n{material}\n"
            )
        };
        let warned = |text: String| {
            let loaded = parse(&text, &dir.join("scene.toml")).unwrap();
            loaded.warnings.iter().any(|w| w.contains("nowhere.mtl"))
        };
        assert!(warned(scene("")), "the file's own materials are used: say they are defaults");
        assert!(!warned(scene("material = \"grey\"")), "the scene file's material replaces them");
        std::fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn good_file() {
        let l = parse_str(GOOD).unwrap();
        let s = &l.scene;
        assert_eq!(s.name, "test");
        assert_eq!(s.instances.len(), 2);
        assert_eq!(s.instances[0].role, Some(Role::Receiver));
        assert_eq!(s.instances[1].mobility, Mobility::Dynamic);
        match s.lights[0].kind {
            LightKind::Rect { tangent, width, height, .. } => {
                assert_eq!(tangent, Vec3::X);
                assert_eq!((width, height), (0.5, 0.25));
            }
            ref k => panic!("{k:?}"),
        }
        assert_eq!(s.path("swing").unwrap().views().len(), 12);
        s.validate().unwrap();
    }

    #[test]
    fn errors_say_where() {
        let e = parse_str(
            "[[object]]\nname = \"a\"\nprimitive = { type = \"box\", size = [1, 1, 1] }\nmaterial = \"nope\"\n",
        )
        .unwrap_err();
        assert!(e.to_string().contains("scene.toml:line 1") && e.to_string().contains("'nope'"), "{e}");
        let e =
            parse_str("[[light]]\ntype = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nouter_angle = 120\n")
                .unwrap_err();
        assert!(e.to_string().contains("outer cone") && e.to_string().contains("light[0]"), "{e}");
        let e = parse_str("[[light]]\ntype = \"point\"\nposition = [0, nan, 0]\n").unwrap_err();
        assert!(e.to_string().contains("not finite"), "{e}");
        let e = parse_str("\n\n[[object]]\nnmae = \"typo\"\n").unwrap_err();
        assert!(e.to_string().contains("line 4") && e.to_string().contains("nmae"), "{e}");
        let e = parse_str("[[light]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = -3\n").unwrap_err();
        assert!(e.to_string().contains("intensity"), "{e}");
        let e = parse_str("[[object]]\nfile = \"missing.obj\"\n").unwrap_err();
        assert!(e.to_string().contains("missing.obj"), "{e}");
        let e = parse_str("[[path]]\nname = \"p\"\nviews = [\"nowhere\"]\n").unwrap_err();
        assert!(e.to_string().contains("'nowhere'") && e.to_string().contains("path[0]"), "{e}");
        let e = parse_str("[[object]]\nprimitive = { type = \"sphere\", radius = -1 }\n").unwrap_err();
        assert!(e.to_string().contains("radius"), "{e}");
    }

    #[test]
    fn base_scene_is_extended() {
        let l =
            parse_str("base = \"penumbra\"\n[[view]]\nname = \"extra\"\nposition = [3, 3, 3]\ntarget = [0, 0, 0]\n")
                .unwrap();
        assert!(l.scene.view("extra").is_some());
        assert!(l.scene.instances.len() >= 2);
    }
}
