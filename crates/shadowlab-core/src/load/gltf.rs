//! glTF 2.0 (`.gltf` with `.bin` or embedded data, and `.glb`).
//!
//! Read: the default scene's node tree (transforms compose down the tree), triangle primitives
//! (indexed or not; strips and fans converted), base colour factor and texture, double-sidedness,
//! emission, `KHR_lights_punctual` lights and perspective cameras. Errors name the JSON path
//! (`meshes[2].primitives[0].attributes.POSITION`). glTF cannot say what is static, dynamic or a
//! receiver, nor how large a light is: a TOML scene file that places the glTF adds that.

use std::path::Path;

use glam::{Affine3A, Mat4, Vec2, Vec3};
use gltf::mesh::Mode;
use rustc_hash::FxHashMap;

use super::Loaded;
use crate::camera::View;
use crate::error::{Location, Result, SceneError};
use crate::light::{Light, LightKind};
use crate::material::{AlphaMode, Material, TextureRef};
use crate::mesh::Mesh;
use crate::scene::{Instance, MaterialId, MeshId, Scene};

/// Node trees deeper than this are refused (a cycle, or a file built to exhaust the stack).
const MAX_DEPTH: usize = 256;

pub fn load(path: &Path) -> Result<Loaded> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, e))?;
    parse(&bytes, path)
}

/// Runs `read`, a call into the gltf crate, turning a panic into an error at `path` (`what`: the
/// part being read). gltf 1.4.1 panics on some malformed files instead of returning an error: its
/// validation indexes `accessors` with a mesh attribute's accessor index unchecked
/// (`gltf-json` `mesh.rs`, found by `fuzz/` target `gltf`); a user's file must not crash us.
fn guarded<T>(path: &Path, what: &str, read: impl FnOnce() -> Result<T>) -> Result<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(read)).unwrap_or_else(|payload| {
        let cause = payload
            .downcast_ref::<&str>()
            .map(|s| (*s).to_owned())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "no message".to_owned());
        Err(SceneError::parse(
            Location::file(path),
            format!("{what}: the glTF reader failed on this malformed file ({cause})"),
        ))
    })
}

/// Refuses external buffers that are not regular files before the gltf crate reads them whole
/// (`"uri": "/dev/zero"` was read until memory ran out; a FIFO waited forever). The URI is
/// percent-decoded and resolved against `base` as the crate does; what does not exist is left to
/// its own error.
fn check_buffer_files(doc: &gltf::Document, base: &Path) -> std::result::Result<(), String> {
    for buffer in doc.buffers() {
        let gltf::buffer::Source::Uri(uri) = buffer.source() else { continue };
        if uri.starts_with("data:") {
            continue;
        }
        let local = uri.strip_prefix("file://").unwrap_or(uri);
        let target = base.join(percent_decoded(local));
        if target.exists() && !target.is_file() {
            return Err(format!("buffer {}: '{uri}' is not a regular file", buffer.index()));
        }
    }
    Ok(())
}

/// `%XX` escapes replaced by their bytes (invalid escapes kept as written).
fn percent_decoded(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Parses glTF or GLB bytes; `path` names the file in errors and resolves external buffers.
pub fn parse(bytes: &[u8], path: &Path) -> Result<Loaded> {
    let file = || Location::file(path);
    // Neither a GLB (it starts with the magic bytes "glTF") nor JSON (it starts with '{' after
    // whitespace): say what the file is not, rather than the JSON parser's first complaint.
    let first = bytes.iter().find(|b| !b.is_ascii_whitespace()).copied();
    if !bytes.starts_with(b"glTF") && first != Some(b'{') {
        return Err(SceneError::parse(
            file(),
            "not a glTF or GLB file (a .glb starts with the bytes 'glTF', a .gltf is a JSON object)",
        ));
    }
    let gltf = guarded(path, "the document", || {
        gltf::Gltf::from_slice(bytes).map_err(|e| SceneError::parse(file(), gltf_message(e)))
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    check_buffer_files(&gltf.document, base).map_err(|message| SceneError::parse(file(), message))?;
    let buffers = guarded(path, "buffers", || {
        gltf::import_buffers(&gltf.document, Some(base), gltf.blob.clone())
            .map_err(|e| SceneError::parse(file(), format!("buffers: {}", gltf_message(e))))
    })?;
    let doc = &gltf.document;
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "gltf".into());
    let mut b = Builder {
        path,
        buffers: &buffers,
        scene: Scene::new(name),
        meshes: FxHashMap::default(),
        materials: FxHashMap::default(),
        warnings: Vec::new(),
        lights_seen: 0,
        cameras_seen: 0,
    };

    let Some(root) = doc.default_scene().or_else(|| doc.scenes().next()) else {
        return Err(SceneError::invalid(file(), "the file has no scene"));
    };
    let mut visited = vec![false; doc.nodes().len()];
    for node in root.nodes() {
        b.visit(node, Mat4::IDENTITY, 0, &mut visited)?;
    }
    if b.scene.instances.is_empty() {
        return Err(SceneError::invalid(file(), format!("scenes[{}] draws no triangles", root.index())));
    }
    Ok(Loaded { scene: b.scene, warnings: b.warnings })
}

/// The gltf crate's messages, with its validation paths kept.
fn gltf_message(e: gltf::Error) -> String {
    match e {
        gltf::Error::Validation(list) => {
            let shown: Vec<String> = list.iter().take(5).map(|(path, err)| format!("{path}: {err}")).collect();
            format!(
                "invalid glTF: {}{}",
                shown.join("; "),
                if list.len() > 5 { format!(" (and {} more)", list.len() - 5) } else { String::new() }
            )
        }
        other => other.to_string(),
    }
}

struct Builder<'a> {
    path: &'a Path,
    buffers: &'a [gltf::buffer::Data],
    scene: Scene,
    /// (mesh, primitive) → mesh id, so instanced meshes are stored once.
    meshes: FxHashMap<(usize, usize), MeshId>,
    materials: FxHashMap<Option<usize>, MaterialId>,
    warnings: Vec<String>,
    lights_seen: usize,
    cameras_seen: usize,
}

impl Builder<'_> {
    fn at(&self, json_path: String) -> Location {
        Location { file: Some(self.path.to_path_buf()), line: None, path: Some(json_path) }
    }

    fn visit(&mut self, node: gltf::Node<'_>, parent: Mat4, depth: usize, visited: &mut [bool]) -> Result<()> {
        let here = format!("nodes[{}]", node.index());
        if depth > MAX_DEPTH || visited[node.index()] {
            return Err(SceneError::invalid(self.at(here), "node appears twice in the tree (a cycle or shared child)"));
        }
        visited[node.index()] = true;
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        if !world.is_finite() {
            return Err(SceneError::invalid(self.at(here), "transform is not finite"));
        }
        let row3 = world.row(3);
        if (row3 - glam::Vec4::W).abs().max_element() > 1e-5 {
            return Err(SceneError::invalid(self.at(here), "transform is not affine (projective last row)"));
        }
        let affine = Affine3A::from_mat4(world);
        let node_name = node.name().map(str::to_owned).unwrap_or_else(|| format!("node{}", node.index()));

        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let Some(mesh_id) = self.primitive(&mesh, &prim)? else { continue };
                let material = self.material(prim.material())?;
                let name = if mesh.primitives().len() > 1 {
                    format!("{node_name}.{}", prim.index())
                } else {
                    node_name.clone()
                };
                self.scene.add_instance(Instance::new(name, mesh_id, material, affine));
            }
        }
        if let Some(light) = node.light() {
            self.light(&light, &affine, &node_name)?;
        }
        if let Some(camera) = node.camera() {
            self.camera(&camera, &affine, &node_name);
        }
        for child in node.children() {
            self.visit(child, world, depth + 1, visited)?;
        }
        Ok(())
    }

    fn primitive(&mut self, mesh: &gltf::Mesh<'_>, prim: &gltf::Primitive<'_>) -> Result<Option<MeshId>> {
        let key = (mesh.index(), prim.index());
        if let Some(&id) = self.meshes.get(&key) {
            return Ok(Some(id));
        }
        let here = format!("meshes[{}].primitives[{}]", mesh.index(), prim.index());
        let mode = prim.mode();
        if matches!(mode, Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip) {
            self.warnings.push(format!("{}: {mode:?} primitive skipped (only triangles cast shadows)", self.at(here)));
            return Ok(None);
        }
        let buffers = self.buffers;
        let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
        let bad = |what: &str| {
            SceneError::invalid(
                self.at(format!("{here}.{what}")),
                "accessor data lies outside its buffer or is missing",
            )
        };
        // The attributes as the gltf crate reads them (guarded: it panics on some malformed files).
        let path = self.path;
        let (positions, normals, uvs, indices) = guarded(path, &here, || {
            let positions: Vec<Vec3> =
                reader.read_positions().ok_or_else(|| bad("attributes.POSITION"))?.map(Vec3::from).collect();
            let normals: Option<Vec<Vec3>> = reader.read_normals().map(|n| n.map(Vec3::from).collect());
            let uvs: Option<Vec<Vec2>> = reader.read_tex_coords(0).map(|t| t.into_f32().map(Vec2::from).collect());
            let indices: Option<Vec<u32>> = reader.read_indices().map(|i| i.into_u32().collect());
            Ok((positions, normals, uvs, indices))
        })?;
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(SceneError::invalid(
                self.at(format!("{here}.attributes.POSITION[{i}]")),
                format!("position {} is not finite", positions[i]),
            ));
        }
        if let Some(n) = &normals {
            if n.len() != positions.len() {
                return Err(bad("attributes.NORMAL"));
            }
            if let Some(i) = n.iter().position(|v| !v.is_finite()) {
                return Err(SceneError::invalid(
                    self.at(format!("{here}.attributes.NORMAL[{i}]")),
                    "normal is not finite",
                ));
            }
        }
        if let Some(t) = &uvs
            && (t.len() != positions.len() || t.iter().any(|v| !v.is_finite()))
        {
            return Err(SceneError::invalid(
                self.at(format!("{here}.attributes.TEXCOORD_0")),
                "texture coordinates are not finite or do not match the positions",
            ));
        }
        let indices: Vec<u32> = match indices {
            Some(i) => i,
            None if prim.indices().is_some() => return Err(bad("indices")),
            None => (0..positions.len() as u32).collect(),
        };
        if let Some(&i) = indices.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(SceneError::invalid(
                self.at(format!("{here}.indices")),
                format!("index {i} out of range ({} vertices)", positions.len()),
            ));
        }
        let triangles: Vec<[u32; 3]> = match mode {
            Mode::Triangles => indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
            Mode::TriangleStrip => (2..indices.len())
                .map(|k| {
                    if k % 2 == 0 {
                        [indices[k - 2], indices[k - 1], indices[k]]
                    } else {
                        [indices[k - 1], indices[k - 2], indices[k]]
                    }
                })
                .collect(),
            Mode::TriangleFan => (2..indices.len()).map(|k| [indices[0], indices[k - 1], indices[k]]).collect(),
            _ => unreachable!("non-triangle modes returned above"),
        };
        if triangles.is_empty() {
            return Err(SceneError::invalid(self.at(here), "primitive has no triangles"));
        }
        let name = mesh.name().map(str::to_owned).unwrap_or_else(|| format!("mesh{}", mesh.index()));
        let mut m = match normals {
            Some(normals) => Mesh { name, positions, normals, uvs, triangles },
            // The specification asks for flat normals when none are given.
            None => Mesh::with_computed_normals_and_uvs(name, &positions, uvs.as_deref(), &triangles, 0.0),
        };
        m.repair_normals();
        let id = self.scene.add_mesh(m);
        self.meshes.insert(key, id);
        Ok(Some(id))
    }

    fn material(&mut self, mat: gltf::Material<'_>) -> Result<MaterialId> {
        if let Some(&id) = self.materials.get(&mat.index()) {
            return Ok(id);
        }
        let pbr = mat.pbr_metallic_roughness();
        let [r, g, b, a] = pbr.base_color_factor();
        let roughness = pbr.roughness_factor().clamp(0.0, 1.0);
        // Blinn-Phong from roughness: exponent 2/α² − 2 with α = roughness² (Walter et al. 2007's
        // correspondence), and a highlight that fades with roughness.
        let alpha = (roughness * roughness).max(0.02);
        let texture = pbr.base_color_texture().map(|info| match info.texture().source().source() {
            gltf::image::Source::Uri { uri, mime_type } => {
                if let Some((mime, bytes)) = decode_data_uri(uri) {
                    TextureRef::Embedded { mime_type: mime_type.unwrap_or(mime).to_owned(), bytes }
                } else {
                    TextureRef::File(self.path.parent().unwrap_or(Path::new(".")).join(uri))
                }
            }
            gltf::image::Source::View { view, mime_type } => {
                let data = self
                    .buffers
                    .get(view.buffer().index())
                    .and_then(|d| d.0.get(view.offset()..view.offset() + view.length()));
                TextureRef::Embedded {
                    mime_type: mime_type.to_owned(),
                    bytes: data.map(<[u8]>::to_vec).unwrap_or_default(),
                }
            }
        });
        let m = Material {
            name: mat.name().map(str::to_owned).unwrap_or_else(|| match mat.index() {
                Some(i) => format!("material{i}"),
                None => "default".to_owned(),
            }),
            base_color: Vec3::new(r, g, b),
            base_color_texture: texture,
            specular: 0.5 * (1.0 - roughness) * (1.0 - pbr.metallic_factor().clamp(0.0, 1.0) * 0.5),
            shininess: (2.0 / (alpha * alpha) - 2.0).clamp(1.0, 1.0e4),
            double_sided: mat.double_sided(),
            emissive: Vec3::from(mat.emissive_factor()),
            base_alpha: a,
            // BLEND (translucency) is opaque here: visibility is binary per point (DESIGN.md §3).
            alpha_mode: match mat.alpha_mode() {
                gltf::material::AlphaMode::Mask => AlphaMode::Mask { cutoff: mat.alpha_cutoff().unwrap_or(0.5) },
                _ => AlphaMode::Opaque,
            },
        };
        if let Err(e) = m.check() {
            let here = mat.index().map(|i| format!("materials[{i}]")).unwrap_or_else(|| "default material".into());
            return Err(SceneError::invalid(self.at(here), e));
        }
        let id = self.scene.add_material(m);
        self.materials.insert(mat.index(), id);
        Ok(id)
    }

    fn light(&mut self, light: &gltf::khr_lights_punctual::Light<'_>, world: &Affine3A, node_name: &str) -> Result<()> {
        use gltf::khr_lights_punctual::Kind;
        let position = world.translation.into();
        let direction = world.transform_vector3(-Vec3::Z).normalize_or_zero();
        let kind = match light.kind() {
            Kind::Point => LightKind::Point { position, radius: 0.0 },
            Kind::Directional => LightKind::Directional { direction, angular_radius: 0.0 },
            Kind::Spot { inner_cone_angle, outer_cone_angle } => LightKind::Spot {
                position,
                direction,
                inner_angle: inner_cone_angle,
                outer_angle: outer_cone_angle,
                radius: 0.0,
            },
        };
        self.lights_seen += 1;
        let name = light.name().map(str::to_owned).unwrap_or_else(|| format!("{node_name}.light"));
        let mut l = Light::new(name, kind, Vec3::from(light.color()), light.intensity());
        l.range = light.range();
        if let Err(e) = l.check() {
            return Err(SceneError::invalid(
                self.at(format!("extensions.KHR_lights_punctual.lights[{}]", light.index())),
                e,
            ));
        }
        self.scene.add_light(l);
        Ok(())
    }

    fn camera(&mut self, camera: &gltf::Camera<'_>, world: &Affine3A, node_name: &str) {
        self.cameras_seen += 1;
        let here = self.at(format!("cameras[{}]", camera.index()));
        match camera.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let position: Vec3 = world.translation.into();
                let forward = world.transform_vector3(-Vec3::Z).normalize_or_zero();
                let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
                let near = p.znear();
                // An infinite far plane becomes a finite one: shadow maps need a depth range.
                let far = p.zfar().unwrap_or(near * 1.0e5);
                let name = camera.name().map(str::to_owned).unwrap_or_else(|| node_name.to_owned());
                let view = View { name, position, target: position + forward, up, fov_y: p.yfov(), near, far };
                match view.check() {
                    Ok(()) => self.scene.views.push(view),
                    Err(e) => self.warnings.push(format!("{here}: camera skipped: {e}")),
                }
            }
            gltf::camera::Projection::Orthographic(_) => {
                self.warnings.push(format!("{here}: orthographic camera skipped (views are perspective)"));
            }
        }
    }
}

/// Splits a `data:MIME;base64,PAYLOAD` URI into its MIME type and decoded bytes.
fn decode_data_uri(uri: &str) -> Option<(&str, Vec<u8>)> {
    let rest = uri.strip_prefix("data:")?;
    let (header, payload) = rest.split_once(',')?;
    let mime = header.strip_suffix(";base64")?;
    Some((mime, decode_base64(payload)?))
}

/// Standard base64 (RFC 4648 §4), padding optional; `None` on any other character.
fn decode_base64(text: &str) -> Option<Vec<u8>> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => Some(c - b'A'),
        b'a'..=b'z' => Some(c - b'a' + 26),
        b'0'..=b'9' => Some(c - b'0' + 52),
        b'+' => Some(62),
        b'/' => Some(63),
        _ => None,
    };
    let mut out = Vec::with_capacity(text.len() * 3 / 4);
    let (mut acc, mut bits) = (0u32, 0u32);
    for &c in text.trim_end_matches('=').as_bytes() {
        acc = (acc << 6) | u32::from(value(c)?);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trip() {
        assert_eq!(decode_base64("aGVsbG8gd29ybGQ=").unwrap(), b"hello world");
        assert_eq!(decode_base64("YQ").unwrap(), b"a");
        assert!(decode_base64("a$b").is_none());
        assert_eq!(decode_data_uri("data:image/png;base64,YWJj").unwrap(), ("image/png", b"abc".to_vec()));
    }

    /// An external buffer that is a device is refused before the gltf crate reads it whole
    /// (`/dev/zero` was read until memory ran out), whether its URI is written plainly or
    /// percent-encoded; a missing file is still the crate's own error.
    #[cfg(unix)]
    #[test]
    fn a_buffer_that_is_not_a_regular_file_is_refused() {
        let document = |uri: &str| {
            format!(
                r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"uri":"{uri}","byteLength":36}}],"scenes":[{{"nodes":[]}}]}}"#
            )
        };
        for uri in ["/dev/zero", "%2Fdev%2Fzero", "file:///dev/zero"] {
            let Err(e) = parse(document(uri).as_bytes(), Path::new("t.gltf")) else { panic!("{uri}: read") };
            let e = e.to_string();
            assert!(e.contains("not a regular file"), "{uri}: {e}");
        }
        let Err(e) = parse(document("missing.bin").as_bytes(), Path::new("t.gltf")) else {
            panic!("a missing buffer read")
        };
        let e = e.to_string();
        assert!(!e.contains("not a regular file"), "{e}");
        assert_eq!(percent_decoded("a%20b%zz%4"), "a b%zz%4");
    }
}
