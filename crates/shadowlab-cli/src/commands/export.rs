//! `shadowlab export --scene S --out FILE.obj|FILE.glb`: the triangles the truth traces, for any
//! outside tool to check it with (the Embree cross-check, `scripts/embree_check.py`).
//!
//! The geometry is every instance's triangles in the scene's local frame — the frame
//! `reference`'s `positions.f32` are in (world = local + `origin`) — computed by the tracer's own
//! function ([`shadowlab_core::bvh::instance_triangles`]), so the coordinates are the very floats
//! it intersects, written in the shortest text that reads back to them. One OBJ object or glTF
//! node per instance, named after it. Beside it, `FILE.json` says what a tracer needs besides
//! triangles: which instances cast shadows (shadow rays see only those; camera rays see all), the
//! lights of the same `--lights` and `--emitter-scale` as `reference`, the origin, and the ray
//! offset rule of DESIGN.md §3 with its constants.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use serde_json::json;
use shadowlab_core::bvh::{EPSILON_SCALE, EPSILON_ULPS, instance_triangles};
use shadowlab_core::{Light, LightKind, Scene};

use crate::args::{GlobalArgs, SceneArgs};

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// The file to write: `.obj` (text) or `.glb` (binary glTF); `FILE.json` is written beside it.
    #[arg(long)]
    out: PathBuf,
}

/// One instance's triangles, flattened.
struct Object {
    name: String,
    casts_shadows: bool,
    /// Three corners per triangle.
    corners: Vec<[f32; 3]>,
}

pub fn run(_global: &GlobalArgs, args: Args) -> Result<()> {
    let format = match args.out.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("obj") => Format::Obj,
        Some("glb") => Format::Glb,
        _ => bail!("--out {}: the file name must end in .obj or .glb", args.out.display()),
    };
    if args.out.is_dir() {
        bail!("--out {} is a directory: name the file to write (scene.obj, scene.glb)", args.out.display());
    }
    let setup = args.scene.load()?;
    let scene = &setup.scene;
    let objects = flatten(scene);
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let bytes = match format {
        Format::Obj => obj(scene, &objects).into_bytes(),
        Format::Glb => glb(&objects)?,
    };
    std::fs::write(&args.out, bytes).with_context(|| format!("writing {}", args.out.display()))?;
    let sidecar = args.out.with_extension("json");
    let lights: Vec<(u32, &Light)> = setup.lights.iter().map(|id| (id.0, &scene.lights[id.index()])).collect();
    let description = describe(scene, &objects, &lights, &args.out);
    std::fs::write(&sidecar, serde_json::to_string_pretty(&description)? + "\n")
        .with_context(|| format!("writing {}", sidecar.display()))?;
    let triangles: usize = objects.iter().map(|o| o.corners.len() / 3).sum();
    let casting: usize = objects.iter().filter(|o| o.casts_shadows).map(|o| o.corners.len() / 3).sum();
    println!(
        "{}: {} instances, {triangles} triangles ({casting} cast shadows), {} lights → {} and {}",
        scene.name,
        objects.len(),
        lights.len(),
        args.out.display(),
        sidecar.display()
    );
    Ok(())
}

#[derive(Clone, Copy)]
enum Format {
    Obj,
    Glb,
}

fn flatten(scene: &Scene) -> Vec<Object> {
    scene
        .instances
        .iter()
        .map(|inst| Object {
            name: inst.name.clone(),
            casts_shadows: inst.casts_shadows,
            corners: instance_triangles(scene, inst).flat_map(|t| t.map(|v| v.to_array())).collect(),
        })
        .collect()
}

/// Wavefront OBJ, one `o` per instance, three vertices per triangle (no welding: every corner as
/// the tracer holds it). Rust prints an f32 in the shortest decimal that parses back to the same
/// float, so nothing is rounded.
fn obj(scene: &Scene, objects: &[Object]) -> String {
    let mut text = String::new();
    let _ = writeln!(text, "# shadowlab export: '{}', the scene's local frame (world = this + origin)", scene.name);
    let _ = writeln!(text, "# origin {} {} {}", scene.origin.x, scene.origin.y, scene.origin.z);
    let mut next = 1usize;
    for o in objects {
        // A name is the rest of the line; line breaks would end it.
        let name: String = o.name.chars().map(|c| if c.is_control() { ' ' } else { c }).collect();
        let _ = writeln!(text, "o {name}");
        for c in &o.corners {
            let _ = writeln!(text, "v {} {} {}", c[0], c[1], c[2]);
        }
        for _ in 0..o.corners.len() / 3 {
            let _ = writeln!(text, "f {} {} {}", next, next + 1, next + 2);
            next += 3;
        }
    }
    text
}

/// Binary glTF 2.0: one mesh and node per instance (positions only, non-indexed triangles), the
/// positions of all of them in one buffer. `extras.casts_shadows` on each node.
fn glb(objects: &[Object]) -> Result<Vec<u8>> {
    let mut bin: Vec<u8> = Vec::new();
    let (mut nodes, mut meshes, mut accessors, mut views) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for o in objects.iter().filter(|o| !o.corners.is_empty()) {
        let offset = bin.len();
        let (mut min, mut max) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for c in &o.corners {
            for k in 0..3 {
                min[k] = min[k].min(c[k]);
                max[k] = max[k].max(c[k]);
                bin.extend_from_slice(&c[k].to_le_bytes());
            }
        }
        let k = accessors.len();
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bin.len() - offset, "target": 34962}));
        accessors.push(json!({
            "bufferView": k, "componentType": 5126, "count": o.corners.len(), "type": "VEC3", "min": min, "max": max,
        }));
        meshes.push(json!({"name": o.name, "primitives": [{"attributes": {"POSITION": k}, "mode": 4}]}));
        nodes.push(json!({"name": o.name, "mesh": k, "extras": {"casts_shadows": o.casts_shadows}}));
    }
    let node_ids: Vec<usize> = (0..nodes.len()).collect();
    let mut document = json!({
        "asset": {"version": "2.0", "generator": "shadowlab export"},
        "scene": 0,
        "scenes": [{"nodes": node_ids}],
        "nodes": nodes,
        "meshes": meshes,
        "accessors": accessors,
        "bufferViews": views,
    });
    if !bin.is_empty() {
        document["buffers"] = json!([{"byteLength": bin.len()}]);
    }
    let mut text = serde_json::to_vec(&document)?;
    // Chunks are 4-byte aligned: JSON padded with spaces, the binary with zeros.
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let chunks = 8 + text.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let total = u32::try_from(12 + chunks).context("the scene is too large for one .glb (4 GiB): export .obj")?;
    let mut out = Vec::with_capacity(total as usize);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total.to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
    }
    Ok(out)
}

/// What a tracer needs besides the triangles (the sidecar `FILE.json`).
fn describe(scene: &Scene, objects: &[Object], lights: &[(u32, &Light)], geometry: &Path) -> serde_json::Value {
    let mut first = 0usize;
    let instances: Vec<serde_json::Value> = objects
        .iter()
        .map(|o| {
            let n = o.corners.len() / 3;
            let entry =
                json!({"name": o.name, "casts_shadows": o.casts_shadows, "first_triangle": first, "triangles": n});
            first += n;
            entry
        })
        .collect();
    json!({
        "scene": scene.name,
        "geometry": geometry.file_name().map(|f| f.to_string_lossy().into_owned()),
        "frame": "the scene's local frame: world = local + origin; reference's positions.f32 are in it",
        "origin": scene.origin.to_array(),
        "triangles": first,
        "instances": instances,
        "shadow_rays_see": "the instances with casts_shadows (camera rays see every instance); both faces occlude",
        "ray_offset": {
            "rule": "origin = p + eps * N_g, eps = max(scale * scene_diagonal, ulps * FLT_EPSILON * max|p_i|); \
                     a point emitter sample q is traced to |q - origin| - eps; samples with N_g . dir <= 0 are occluded",
            "scale": EPSILON_SCALE,
            "ulps": EPSILON_ULPS,
            "scene_diagonal": scene.bounds().diagonal(),
        },
        // `index` is the light's index in the scene, as in reference.json.
        "lights": lights.iter().map(|&(index, l)| {
            let mut v = light_json(l);
            v["index"] = json!(index);
            v
        }).collect::<Vec<_>>(),
    })
}

fn light_json(light: &Light) -> serde_json::Value {
    let mut v = match light.kind {
        LightKind::Point { position, radius } => {
            json!({"type": "point", "position": position.to_array(), "radius": radius})
        }
        LightKind::Spot { position, direction, inner_angle, outer_angle, radius } => json!({
            "type": "spot", "position": position.to_array(), "direction": direction.to_array(),
            "inner_angle": inner_angle, "outer_angle": outer_angle, "radius": radius,
        }),
        LightKind::Directional { direction, angular_radius } => {
            json!({"type": "directional", "direction": direction.to_array(), "angular_radius": angular_radius})
        }
        LightKind::Rect { position, direction, tangent, width, height } => json!({
            "type": "rect", "position": position.to_array(), "direction": direction.to_array(),
            "tangent": tangent.to_array(), "bitangent": direction.cross(tangent).to_array(),
            "width": width, "height": height,
        }),
    };
    v["name"] = json!(light.name);
    v["range"] = json!(light.range);
    v["emitter"] = json!(match light.kind {
        LightKind::Point { .. } | LightKind::Spot { .. } =>
            "sphere: uniform over the disk of the radius perpendicular to the direction from p to the centre",
        LightKind::Directional { .. } => "uniform over the cone of directions within angular_radius of -direction",
        LightKind::Rect { .. } => "uniform over the rectangle",
    });
    if light.is_hard() {
        v["emitter"] = json!("hard: one ray to the position (or along -direction)");
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> Scene {
        shadowlab_core::load_scene("columns").expect("built-in").scene
    }

    #[test]
    fn the_obj_reads_back_to_the_tracers_own_floats() {
        let scene = scene();
        let objects = flatten(&scene);
        let text = obj(&scene, &objects);
        let corners: Vec<[f32; 3]> = text
            .lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|l| {
                let v: Vec<f32> = l.split(' ').map(|x| x.parse().expect("a float")).collect();
                [v[0], v[1], v[2]]
            })
            .collect();
        let bvh = shadowlab_core::bvh::SceneBvh::build(&scene, shadowlab_core::bvh::Selection::All);
        assert_eq!(corners.len(), 3 * bvh.len());
        // Bit for bit: the first instance's first triangle as the tracer holds it.
        let first = instance_triangles(&scene, &scene.instances[0]).next().expect("a triangle");
        assert_eq!(corners[0..3], first.map(|v| v.to_array()));
        let faces = text.lines().filter(|l| l.starts_with("f ")).count();
        assert_eq!(faces, bvh.len());
        assert_eq!(text.lines().filter(|l| l.starts_with("o ")).count(), scene.instances.len());
    }

    #[test]
    fn the_glb_loads_back_with_every_triangle_and_name() {
        let scene = scene();
        let objects = flatten(&scene);
        let path = std::env::temp_dir().join(format!("shadowlab-export-{}.glb", std::process::id()));
        std::fs::write(&path, glb(&objects).expect("glb")).expect("written");
        let loaded = shadowlab_core::load_scene(path.to_str().expect("utf-8")).expect("a valid glb").scene;
        let _ = std::fs::remove_file(&path);
        let expected: usize = objects.iter().map(|o| o.corners.len() / 3).sum();
        assert_eq!(loaded.stats().triangles, expected);
        let names: Vec<&str> = loaded.instances.iter().map(|i| i.name.as_str()).collect();
        for o in &objects {
            assert!(names.contains(&o.name.as_str()), "'{}' missing from {names:?}", o.name);
        }
        // The same corners: the loader reads the floats as written (no recentring near the origin),
        // so the bounds agree exactly; 1e-5 m is slack for a loader that re-derives them.
        let bounds = |s: &Scene| s.bounds();
        let (a, b) = (bounds(&scene), bounds(&loaded));
        assert!(
            (a.min - b.min).abs().max_element() < 1e-5 && (a.max - b.max).abs().max_element() < 1e-5,
            "{a:?} {b:?}"
        );
    }
}
