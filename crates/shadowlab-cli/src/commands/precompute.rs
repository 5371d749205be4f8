//! `shadowlab precompute --scene S --out FILE`: the light meshes of a scene's static lights
//! (Hasselgren 2003 §3.2; `shadowlab_core::lightmesh`), with the time, the triangles before and after
//! and the file size. No GPU. The `lightmesh` technique reads the file (`--light-meshes FILE`) and
//! recomputes what is missing or stale.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use serde_json::json;
use shadowlab_core::lightmesh::{self, file};
use shadowlab_core::{LoadOptions, load_scene_with};

use crate::args::GlobalArgs;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// A built-in scene (with options: `columns:movers=2`) or a .toml, .gltf, .glb or .obj file.
    #[arg(long, default_value = "columns")]
    scene: String,
    /// The light-mesh file to write.
    #[arg(long)]
    out: PathBuf,
    /// Only these lights (names or indices, comma-separated); default: every static light.
    #[arg(long, value_delimiter = ',')]
    lights: Vec<String>,
    /// Fake soft shadows for `lightmesh:soft=true`: penumbra wedges, `half` (the outer half, no
    /// leak next to dynamic hard shadows) or `full`; default: hard light meshes.
    #[arg(long, value_parser = ["half", "full"])]
    soft: Option<String>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
    /// Emissive planar rectangles become rect lights (as `--emissive-lights` of the other commands).
    #[arg(long)]
    emissive_lights: bool,
}

pub fn run(_global: &GlobalArgs, args: Args) -> Result<()> {
    let options = LoadOptions { emissive_lights: args.emissive_lights };
    let loaded = load_scene_with(&args.scene, options).with_context(|| format!("loading scene '{}'", args.scene))?;
    let scene = &loaded.scene;
    if args.out.is_dir() {
        bail!("--out {} is a directory: give a file name (e.g. {}.lmesh)", args.out.display(), scene.name);
    }
    let chosen: Vec<usize> = if args.lights.is_empty() {
        (0..scene.lights.len()).filter(|&i| lightmesh::is_static_light(&scene.lights[i])).collect()
    } else {
        args.lights
            .iter()
            .map(|name| {
                scene.find_light(name).map(|id| id.index()).with_context(|| {
                    let names: Vec<&str> = scene.lights.iter().map(|l| l.name.as_str()).collect();
                    format!("no light '{name}' in {} (lights: {})", scene.name, names.join(", "))
                })
            })
            .collect::<Result<_>>()?
    };
    if chosen.is_empty() {
        bail!("{} has no static light: light meshes are for lights that never move", scene.name);
    }
    let start = std::time::Instant::now();
    let casters = lightmesh::static_casters(scene);
    let bar = crate::progress::bar(chosen.len() as u64, "light meshes");
    let mut meshes = Vec::new();
    let mut rows = Vec::new();
    for &i in &chosen {
        let mode = match args.soft.as_deref() {
            Some("half") => lightmesh::Mode::Soft(lightmesh::Penumbra::Half),
            Some(_) => lightmesh::Mode::Soft(lightmesh::Penumbra::Full),
            None => lightmesh::Mode::Hard,
        };
        let (mesh, stats) = lightmesh::build_with(scene, i, &casters, mode)?;
        bar.inc(1);
        rows.push(json!({
            "light": scene.lights[i].name, "index": i,
            "receiver_triangles": stats.receiver_triangles, "cut_planes": stats.cut_planes,
            "cap_faces": stats.cap_faces, "pieces": stats.pieces, "lit_pieces": stats.lit_pieces,
            "triangles": stats.triangles, "seconds": stats.seconds,
        }));
        meshes.push(mesh);
    }
    bar.finish_and_clear();
    let bytes = file::write(&args.out, scene, &meshes)?;
    let seconds = start.elapsed().as_secs_f64();
    let static_triangles: usize =
        scene.instances.iter().filter(|i| lightmesh::is_static(i)).map(|i| scene.mesh(i.mesh).triangle_count()).sum();
    let summary = json!({
        "scene": scene.name, "file": args.out.display().to_string(), "bytes": bytes,
        "seconds": seconds, "bvh_seconds": casters.build_time.as_secs_f64(),
        "static_triangles": static_triangles, "soft": args.soft, "lights": rows,
    });
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
        return Ok(());
    }
    println!(
        "{}: {} light meshes in {:.2} s ({} static triangles) → {} ({:.1} KiB)",
        scene.name,
        meshes.len(),
        seconds,
        static_triangles,
        args.out.display(),
        bytes as f64 / 1024.0
    );
    for r in &rows {
        println!(
            "  {:<20} {:>7} receiver triangles → {:>7} pieces ({:>6} lit) → {:>7} triangles  {:>6.2} s",
            r["light"].as_str().unwrap_or(""),
            r["receiver_triangles"],
            r["pieces"],
            r["lit_pieces"],
            r["triangles"],
            r["seconds"].as_f64().unwrap_or(0.0)
        );
    }
    Ok(())
}
