//! Wavefront OBJ and MTL.
//!
//! A hand-written reader rather than a general crate, so that every error carries its line number and
//! no input can panic. What real files do is accepted: CRLF line ends, tabs, `\` line continuations,
//! negative (relative) indices, polygons (triangulated by ear clipping), unreferenced vertices, a
//! missing or broken MTL file (a warning, and a default material), vertex colours after `v x y z`.
//! What cannot be used is refused with the line: non-finite numbers, index 0 or out of range, a face
//! with fewer than three corners, a file with no faces.

use std::path::{Path, PathBuf};

/// Words of the warning for an unreadable `.mtl`: a scene file that assigns its own material to the
/// object drops it (the file's materials are not used then).
pub(crate) const MISSING_LIBRARY: &str = "material library";

use glam::{Vec2, Vec3};
use rustc_hash::FxHashMap;

use super::Loaded;
use crate::error::{Location, Result, SceneError};
use crate::material::{Material, TextureRef};
use crate::mesh::Mesh;
use crate::scene::{Instance, MaterialId, Scene};

/// Smoothing angle for files without normals: keeps scans smooth and architecture flat.
const CREASE_DEGREES: f32 = 60.0;

/// One corner of a face: 0-based indices into the file's v, vt and vn lists.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
struct Corner {
    v: u32,
    vt: Option<u32>,
    vn: Option<u32>,
}

struct Face {
    corners: std::ops::Range<usize>,
    material: usize,
    line: usize,
}

/// Reads an OBJ file (and its MTL files) into a scene with one object per material used.
pub fn load(path: &Path) -> Result<Loaded> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, e))?;
    parse(&bytes, path)
}

/// Parses OBJ text; `path` names the file in errors and resolves `mtllib` and texture paths.
pub fn parse(bytes: &[u8], path: &Path) -> Result<Loaded> {
    let text = String::from_utf8_lossy(bytes);
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut warnings = Vec::new();

    let mut v: Vec<Vec3> = Vec::new();
    let mut vt: Vec<Vec2> = Vec::new();
    let mut vn: Vec<Vec3> = Vec::new();
    let mut corners: Vec<Corner> = Vec::new();
    let mut raw: Vec<(i64, Option<i64>, Option<i64>)> = Vec::new();
    let mut faces: Vec<Face> = Vec::new();
    // Material slots in order of first use; slot 0 is "no material".
    let mut material_names: Vec<String> = vec![String::new()];
    let mut current_material = 0usize;
    let mut libraries: Vec<(PathBuf, usize)> = Vec::new();

    for (line_no, line) in logical_lines(&text) {
        let line = match line.find('#') {
            Some(i) => &line[..i],
            None => &line[..],
        };
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else { continue };
        let at = || Location::line(path, line_no);
        match keyword {
            "v" => v.push(parse_vec3(&mut words, at, "vertex position")?),
            "vn" => vn.push(parse_vec3(&mut words, at, "vertex normal")?),
            "vt" => {
                let u = parse_f32(words.next(), at, "texture u")?;
                let t = match words.next() {
                    Some(w) => parse_f32(Some(w), at, "texture v")?,
                    None => 0.0,
                };
                vt.push(Vec2::new(u, t));
            }
            "f" => {
                raw.clear();
                for w in words {
                    raw.push(parse_corner(w, at)?);
                }
                if raw.len() < 3 {
                    return Err(SceneError::parse(at(), format!("face has {} corners, needs at least 3", raw.len())));
                }
                let start = corners.len();
                for &(iv, it, inorm) in &raw {
                    corners.push(Corner {
                        v: resolve(iv, v.len(), at, "vertex")?,
                        vt: it.map(|i| resolve(i, vt.len(), at, "texture coordinate")).transpose()?,
                        vn: inorm.map(|i| resolve(i, vn.len(), at, "normal")).transpose()?,
                    });
                }
                faces.push(Face { corners: start..corners.len(), material: current_material, line: line_no });
            }
            "usemtl" => {
                let name = words.collect::<Vec<_>>().join(" ");
                current_material = match material_names.iter().position(|n| *n == name) {
                    Some(i) => i,
                    None => {
                        material_names.push(name);
                        material_names.len() - 1
                    }
                };
            }
            "mtllib" => {
                // File names may contain spaces; most exporters write one library per line.
                let name = words.collect::<Vec<_>>().join(" ");
                if !name.is_empty() {
                    libraries.push((dir.join(name), line_no));
                }
            }
            // Groups, objects, smoothing groups, lines, points and free-form geometry: not needed.
            "g" | "o" | "s" | "l" | "p" | "vp" | "cstype" | "deg" | "curv" | "curv2" | "surf" | "parm" | "trim"
            | "hole" | "end" | "bmat" | "step" | "mg" | "lod" | "usemap" | "maplib" | "shadow_obj" | "trace_obj"
            | "ctech" | "stech" | "bevel" | "c_interp" | "d_interp" | "con" | "sp" | "call" => {}
            other => {
                if warnings.len() < 20 {
                    warnings.push(format!("{}: unknown statement '{other}' ignored", at()));
                }
            }
        }
    }

    if faces.is_empty() {
        return Err(SceneError::invalid(Location::file(path), "the file has no faces: nothing to draw"));
    }

    // Materials from the libraries, then a material per used slot.
    let mut library: FxHashMap<String, Material> = FxHashMap::default();
    for (lib, line) in &libraries {
        // Only regular files: a library named `/dev/zero` would be read forever.
        let read = if !lib.exists() || lib.is_file() {
            std::fs::read(lib)
        } else {
            Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file"))
        };
        match read {
            Ok(bytes) => match parse_mtl(&bytes, lib, &mut warnings) {
                Ok(mats) => library.extend(mats.into_iter().map(|m| (m.name.clone(), m))),
                Err(e) => warnings.push(format!("{e} (material library ignored)")),
            },
            Err(e) => warnings.push(format!(
                "{}: {MISSING_LIBRARY} {} cannot be read ({e}); default materials used",
                Location::line(path, *line),
                lib.display()
            )),
        }
    }

    let file_stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "obj".into());
    let mut scene = Scene::new(file_stem.clone());
    let mut slot_material: Vec<Option<MaterialId>> = vec![None; material_names.len()];
    let mut by_slot: Vec<Vec<usize>> = vec![Vec::new(); material_names.len()];
    for (i, f) in faces.iter().enumerate() {
        by_slot[f.material].push(i);
    }
    for (slot, face_ids) in by_slot.iter().enumerate() {
        if face_ids.is_empty() {
            continue;
        }
        let name = &material_names[slot];
        let material = if slot == 0 {
            Material::default()
        } else if let Some(m) = library.get(name) {
            m.clone()
        } else {
            if !libraries.is_empty() {
                warnings.push(format!("{}: material '{name}' is not in any library; default used", path.display()));
            }
            Material { name: name.clone(), ..Material::default() }
        };
        let mesh_name = if slot == 0 { file_stem.clone() } else { format!("{file_stem}:{name}") };
        let mesh = build_mesh(&mesh_name, face_ids.iter().map(|&i| &faces[i]), &corners, &v, &vt, &vn, path)?;
        let mat = *slot_material[slot].get_or_insert_with(|| scene.add_material(material));
        let mesh_id = scene.add_mesh(mesh);
        scene.add_instance(Instance::new(mesh_name, mesh_id, mat, glam::Affine3A::IDENTITY));
    }
    Ok(Loaded { scene, warnings })
}

/// Lines joined across trailing backslashes, with their 1-based number (of the first physical line).
fn logical_lines(text: &str) -> impl Iterator<Item = (usize, String)> + '_ {
    let mut lines = text.lines().enumerate().peekable();
    std::iter::from_fn(move || {
        let (i, first) = lines.next()?;
        let mut line = first.trim_end_matches('\r').to_owned();
        while line.ends_with('\\') {
            line.pop();
            match lines.next() {
                Some((_, next)) => {
                    line.push(' ');
                    line.push_str(next.trim_end_matches('\r'));
                }
                None => break,
            }
        }
        Some((i + 1, line))
    })
}

fn parse_f32(word: Option<&str>, at: impl Fn() -> Location, what: &str) -> Result<f32> {
    let word = word.ok_or_else(|| SceneError::parse(at(), format!("{what}: missing number")))?;
    let x: f32 = word.parse().map_err(|_| SceneError::parse(at(), format!("{what}: '{word}' is not a number")))?;
    if !x.is_finite() {
        return Err(SceneError::invalid(at(), format!("{what}: '{word}' is not finite")));
    }
    Ok(x)
}

fn parse_vec3<'a>(
    words: &mut impl Iterator<Item = &'a str>,
    at: impl Fn() -> Location + Copy,
    what: &str,
) -> Result<Vec3> {
    Ok(Vec3::new(
        parse_f32(words.next(), at, what)?,
        parse_f32(words.next(), at, what)?,
        parse_f32(words.next(), at, what)?,
    ))
}

fn parse_index(text: &str, at: impl Fn() -> Location) -> Result<i64> {
    let i: i64 = text.parse().map_err(|_| SceneError::parse(at(), format!("face index '{text}' is not an integer")))?;
    if i == 0 {
        return Err(SceneError::invalid(at(), "face index 0: OBJ indices start at 1"));
    }
    Ok(i)
}

/// `v`, `v/vt`, `v//vn` or `v/vt/vn`.
fn parse_corner(word: &str, at: impl Fn() -> Location + Copy) -> Result<(i64, Option<i64>, Option<i64>)> {
    let mut parts = word.split('/');
    let v = parse_index(parts.next().unwrap_or(""), at)?;
    let vt = match parts.next() {
        Some("") | None => None,
        Some(t) => Some(parse_index(t, at)?),
    };
    let vn = match parts.next() {
        Some("") | None => None,
        Some(n) => Some(parse_index(n, at)?),
    };
    if parts.next().is_some() {
        return Err(SceneError::parse(at(), format!("face corner '{word}' has more than three indices")));
    }
    Ok((v, vt, vn))
}

/// 1-based or negative (relative) index → 0-based, checked against the elements defined so far.
fn resolve(i: i64, count: usize, at: impl Fn() -> Location, what: &str) -> Result<u32> {
    let abs = if i > 0 { i - 1 } else { count as i64 + i };
    if abs < 0 || abs >= count as i64 {
        return Err(SceneError::invalid(
            at(),
            format!("{what} index {i} is out of range: {count} defined before this line"),
        ));
    }
    Ok(abs as u32)
}

fn build_mesh<'a>(
    name: &str,
    faces: impl Iterator<Item = &'a Face>,
    corners: &[Corner],
    v: &[Vec3],
    vt: &[Vec2],
    vn: &[Vec3],
    path: &Path,
) -> Result<Mesh> {
    let mut vertex_of: FxHashMap<Corner, u32> = FxHashMap::default();
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    let mut triangles = Vec::new();
    let mut all_normals = true;
    let mut any_uvs = false;
    let mut polygon: Vec<u32> = Vec::new();
    for face in faces {
        polygon.clear();
        for c in &corners[face.corners.clone()] {
            all_normals &= c.vn.is_some();
            any_uvs |= c.vt.is_some();
            let next = positions.len() as u32;
            polygon.push(*vertex_of.entry(*c).or_insert_with(|| {
                positions.push(v[c.v as usize]);
                normals.push(c.vn.map(|n| vn[n as usize]).unwrap_or(Vec3::ZERO));
                uvs.push(c.vt.map(|t| vt[t as usize]).unwrap_or(Vec2::ZERO));
                next
            }));
        }
        triangulate(&polygon, &positions, &mut triangles)
            .map_err(|msg| SceneError::invalid(Location::line(path, face.line), msg))?;
    }
    let uvs = any_uvs.then_some(uvs);
    let mut mesh = if all_normals {
        Mesh { name: name.to_owned(), positions, normals, uvs, triangles }
    } else {
        Mesh::with_computed_normals_and_uvs(name, &positions, uvs.as_deref(), &triangles, CREASE_DEGREES)
    };
    mesh.repair_normals();
    Ok(mesh)
}

/// Triangulates a polygon of vertex indices: a triangle as is, larger polygons by ear clipping in
/// their best-fit plane (so concave faces come out right), falling back to a fan when the polygon
/// is too degenerate to clip.
/// The most corners a face may have: ear clipping costs up to the square of them (1 s for a
/// 10 000-corner circle here, whose nearly straight corners all count as reflex), and a face
/// built larger would stall loading.
const MAX_FACE_CORNERS: usize = 10_000;

fn triangulate(poly: &[u32], positions: &[Vec3], out: &mut Vec<[u32; 3]>) -> Result<(), String> {
    if poly.len() < 3 {
        return Err(format!("face has {} corners, needs at least 3", poly.len()));
    }
    if poly.len() == 3 {
        out.push([poly[0], poly[1], poly[2]]);
        return Ok(());
    }
    if poly.len() > MAX_FACE_CORNERS {
        return Err(format!(
            "face has {} corners; at most {MAX_FACE_CORNERS} are triangulated (split it into smaller faces)",
            poly.len()
        ));
    }
    // Newell's normal of the polygon; project on the plane perpendicular to its largest axis.
    let pts: Vec<Vec3> = poly.iter().map(|&i| positions[i as usize]).collect();
    let mut n = Vec3::ZERO;
    for k in 0..pts.len() {
        let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
        n += Vec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    let axis = n.abs().max_position();
    let flat: Vec<Vec2> = pts
        .iter()
        .map(|p| match axis {
            0 => Vec2::new(p.y, p.z) * n.x.signum(),
            1 => Vec2::new(p.z, p.x) * n.y.signum(),
            _ => Vec2::new(p.x, p.y) * n.z.signum(),
        })
        .collect();
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a - o).perp_dot(b - o);
    // Ear clipping in O(n · r) for r reflex corners: only a reflex corner can lie inside a
    // candidate ear (a convex one inside would put a reflex one inside too), and the search goes on
    // from the last ear instead of from the first corner. (Testing every corner from the start
    // took 33 s on a 4 000-corner C-shaped face.) A corner only turns from reflex to convex as
    // ears go, so the reflex list only shrinks.
    let mut remaining: Vec<usize> = (0..poly.len()).collect();
    let corner = |remaining: &[usize], k: usize| {
        let m = remaining.len();
        (remaining[(k + m - 1) % m], remaining[k], remaining[(k + 1) % m])
    };
    let convex = |(a, b, c): (usize, usize, usize)| cross(flat[a], flat[b], flat[c]) > 0.0;
    let mut reflex: Vec<usize> =
        (0..remaining.len()).filter(|&k| !convex(corner(&remaining, k))).map(|k| remaining[k]).collect();
    let start = out.len();
    let mut from = 0;
    while remaining.len() > 3 {
        let m = remaining.len();
        let ear = (0..m).map(|i| (from + i) % m).find(|&k| {
            let (a, b, c) = corner(&remaining, k);
            if !convex((a, b, c)) {
                return false; // reflex or degenerate corner
            }
            reflex.iter().all(|&j| {
                j == a || j == b || j == c || {
                    let p = flat[j];
                    !(cross(flat[a], flat[b], p) >= 0.0
                        && cross(flat[b], flat[c], p) >= 0.0
                        && cross(flat[c], flat[a], p) >= 0.0)
                }
            })
        });
        match ear {
            Some(k) => {
                let (a, b, c) = corner(&remaining, k);
                out.push([poly[a], poly[b], poly[c]]);
                remaining.remove(k);
                // The ear's neighbours may have turned convex.
                let m = remaining.len();
                let (before, after) = ((k + m - 1) % m, k % m);
                for q in [before, after] {
                    if convex(corner(&remaining, q)) {
                        let v = remaining[q];
                        reflex.retain(|&j| j != v);
                    }
                }
                from = before;
            }
            None => {
                // Self-intersecting or collinear: a fan is as good as anything.
                out.truncate(start);
                for k in 1..poly.len() - 1 {
                    out.push([poly[0], poly[k], poly[k + 1]]);
                }
                return Ok(());
            }
        }
    }
    out.push([poly[remaining[0]], poly[remaining[1]], poly[remaining[2]]]);
    Ok(())
}

/// Parses an MTL library. Colours above 1 are clamped with a warning (common in exported files).
pub fn parse_mtl(bytes: &[u8], path: &Path, warnings: &mut Vec<String>) -> Result<Vec<Material>> {
    let text = String::from_utf8_lossy(bytes);
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut out: Vec<Material> = Vec::new();
    for (line_no, line) in logical_lines(&text) {
        let line = match line.find('#') {
            Some(i) => &line[..i],
            None => &line[..],
        };
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else { continue };
        let at = || Location::line(path, line_no);
        if keyword == "newmtl" {
            out.push(Material { name: words.collect::<Vec<_>>().join(" "), ..Material::default() });
            continue;
        }
        let Some(m) = out.last_mut() else {
            if matches!(keyword, "Kd" | "Ks" | "Ke" | "Ns" | "map_Kd") {
                return Err(SceneError::parse(at(), format!("'{keyword}' before any 'newmtl'")));
            }
            continue;
        };
        let mut colour = |what: &str, warnings: &mut Vec<String>| -> Result<Vec3> {
            let c = parse_vec3(&mut words, at, what)?;
            if c.min_element() < 0.0 || c.max_element() > 1.0 {
                warnings.push(format!("{}: {what} {c} clamped to [0, 1]", at()));
            }
            Ok(c.clamp(Vec3::ZERO, Vec3::ONE))
        };
        match keyword {
            "Kd" => m.base_color = colour("Kd", warnings)?,
            "Ks" => m.specular = colour("Ks", warnings)?.max_element(),
            "Ke" => {
                let e = parse_vec3(&mut words, at, "Ke")?;
                m.emissive = e.max(Vec3::ZERO);
            }
            "Ns" => m.shininess = parse_f32(words.next(), at, "Ns")?.clamp(1.0, 1.0e4),
            "map_Kd" => {
                // Options (-s, -o, ...) precede the file name, which is the last word.
                if let Some(file) = words.last() {
                    m.base_color_texture = Some(TextureRef::File(dir.join(file)));
                }
            }
            _ => {}
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_str(s: &str) -> Result<Loaded> {
        parse(s.as_bytes(), Path::new("test.obj"))
    }

    #[test]
    fn quads_negative_indices_crlf_and_tabs() {
        let s = "v 0 0 0\r\nv\t1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\nf -4 -3 -2 -1\r\n";
        let l = parse_str(s).unwrap();
        let m = &l.scene.meshes[0];
        assert_eq!(m.triangle_count(), 2);
        assert_eq!(m.vertex_count(), 4);
        for n in &m.normals {
            assert!((*n - Vec3::Z).length() < 1e-6, "computed normals face +z: {n}");
        }
    }

    #[test]
    fn concave_polygon_is_ear_clipped() {
        // An L shape (6 corners): a fan from corner 0 would cover the notch.
        let s = "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nf 1 2 3 4 5 6\n";
        let l = parse_str(s).unwrap();
        let m = &l.scene.meshes[0];
        assert_eq!(m.triangle_count(), 4);
        let area: f32 = (0..4).map(|t| 0.5 * m.face_normal_area(t).z).sum();
        assert!((area - 3.0).abs() < 1e-5, "area {area}: every triangle inside, all facing +z");
    }

    /// A thin C-shaped strip (an outer and an inner arc, 400 corners, the inner ones all reflex):
    /// ear clipping that tests only the reflex corners and goes on from the last ear still
    /// tiles it exactly, every triangle inside and facing +z (the fan it falls back to would
    /// not). Past `MAX_FACE_CORNERS` a face is an error.
    #[test]
    fn a_long_concave_face_is_ear_clipped_and_a_huge_one_refused() {
        let k = 200;
        let d = std::f32::consts::PI / (k - 1) as f32;
        let (outer, inner) = (1.0f32, 0.8f32);
        let mut s = String::new();
        for i in 0..k {
            s += &format!("v {} {} 0\n", outer * (i as f32 * d).cos(), outer * (i as f32 * d).sin());
        }
        for i in (0..k).rev() {
            s += &format!("v {} {} 0\n", inner * (i as f32 * d).cos(), inner * (i as f32 * d).sin());
        }
        s += &format!("f {}\n", (1..=2 * k).map(|i| i.to_string()).collect::<Vec<_>>().join(" "));
        let l = parse_str(&s).unwrap();
        let m = &l.scene.meshes[0];
        assert_eq!(m.triangle_count(), 2 * k - 2);
        let areas: Vec<f32> = (0..m.triangle_count()).map(|t| 0.5 * m.face_normal_area(t).z).collect();
        assert!(areas.iter().all(|&a| a >= 0.0), "a triangle faces away: outside the strip");
        // The polygon's own area: k − 1 pairs of triangles fanned from the arcs' centre.
        let exact = 0.5 * (k - 1) as f64 * f64::from(d).sin() * f64::from(outer * outer - inner * inner);
        let total: f64 = areas.iter().map(|&a| f64::from(a)).sum();
        // Measured: 2.1e-8 relative (f32 areas); bound 1e-4, far below a missing or doubled
        // triangle (1/398 of the area, 2.5e-3).
        assert!((total - exact).abs() < 1e-4 * exact, "area {total} against {exact}");
        // A U: the first corner's triangle would hold the notch's reflex corners.
        let u = "v 0 0 0\nv 3 0 0\nv 3 3 0\nv 2 3 0\nv 2 1 0\nv 1 1 0\nv 1 3 0\nv 0 3 0\nf 1 2 3 4 5 6 7 8\n";
        let m = &parse_str(u).unwrap().scene.meshes[0];
        let areas: Vec<f32> = (0..m.triangle_count()).map(|t| 0.5 * m.face_normal_area(t).z).collect();
        // Signed areas add up to the polygon's whatever the triangles; overlapping ones show as
        // one facing away.
        assert!(areas.iter().all(|&a| a >= 0.0), "U: a triangle faces away: {areas:?}");
        // Measured: exact (0) on these integer corners; bound 1e-5 for rounding.
        assert!((areas.iter().sum::<f32>() - 7.0).abs() < 1e-5, "U: area {areas:?}, 7 inside");
        let huge = (0..=MAX_FACE_CORNERS)
            .map(|i| {
                let t = i as f32 / 2000.0;
                format!("v {} {} 0\n", t.cos(), t.sin())
            })
            .collect::<String>()
            + &format!("f {}\n", (1..=MAX_FACE_CORNERS + 1).map(|i| i.to_string()).collect::<Vec<_>>().join(" "));
        let e = parse_str(&huge).unwrap_err().to_string();
        assert!(e.contains("10001 corners") && e.contains("at most 10000"), "{e}");
    }

    #[test]
    fn errors_carry_line_numbers() {
        let e = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 nan\nf 1 2 3\n").unwrap_err();
        assert!(e.to_string().contains("test.obj:line 3") && e.to_string().contains("not finite"), "{e}");
        let e = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").unwrap_err();
        assert!(e.to_string().contains("line 4") && e.to_string().contains("out of range"), "{e}");
        let e = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n").unwrap_err();
        assert!(e.to_string().contains("index 0"), "{e}");
        let e = parse_str("v 0 0 0\nv 1 0 0\n").unwrap_err();
        assert!(e.to_string().contains("no faces"), "{e}");
        let e = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n").unwrap_err();
        assert!(e.to_string().contains("line 4"), "{e}");
        let e = parse_str("v 0 zero 0\n").unwrap_err();
        assert!(e.to_string().contains("line 1") && e.to_string().contains("not a number"), "{e}");
    }

    #[test]
    fn missing_mtl_is_a_warning() {
        let s = "mtllib nowhere.mtl\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let l = parse_str(s).unwrap();
        assert_eq!(l.scene.materials[0].name, "red");
        assert!(l.warnings.iter().any(|w| w.contains("nowhere.mtl")), "{:?}", l.warnings);
    }

    #[test]
    fn mtl_colours() {
        let mut w = Vec::new();
        let mats =
            parse_mtl(b"newmtl a\nKd 0.5 0.25 1.5\nNs 10\nKs 0.2 0.3 0.1\n", Path::new("m.mtl"), &mut w).unwrap();
        assert_eq!(mats[0].base_color, Vec3::new(0.5, 0.25, 1.0));
        assert_eq!(mats[0].shininess, 10.0);
        assert_eq!(mats[0].specular, 0.3);
        assert_eq!(w.len(), 1, "clamping warned");
        assert!(
            parse_mtl(b"newmtl a\nKd 0.5 x 1\n", Path::new("m.mtl"), &mut w)
                .unwrap_err()
                .to_string()
                .contains("line 2")
        );
    }

    #[test]
    fn groups_by_material() {
        let s = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nusemtl a\nf 1 2 3\nusemtl b\nf 2 4 3\nusemtl a\nf 1 3 2\n";
        let l = parse_str(s).unwrap();
        assert_eq!(l.scene.meshes.len(), 2);
        assert_eq!(l.scene.meshes[0].triangle_count(), 2);
        assert_eq!(l.scene.instances.len(), 2);
    }
}
