//! `shadowlab inspect --scene S [--json]`: what a scene holds, without a GPU — triangles, each mesh's
//! topology (open, closed, non-manifold edges: what shadow volumes must cope with), lights, views,
//! bounds and the loader's warnings. The first thing to run on a model from elsewhere.

use anyhow::{Context, Result};
use serde_json::json;
use shadowlab_core::topology::Topology;
use shadowlab_core::{LoadOptions, load_scene_with};

use crate::args::GlobalArgs;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// A built-in scene (with options: `terrain:sun=0.27`) or a .toml, .gltf, .glb or .obj file.
    #[arg(long, default_value = "room")]
    scene: String,
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
    let stats = scene.stats();
    let bounds = scene.bounds();
    let meshes: Vec<serde_json::Value> = scene
        .meshes
        .iter()
        .enumerate()
        .map(|(i, mesh)| {
            let t = Topology::build(mesh).report();
            let instances = scene.instances.iter().filter(|inst| inst.mesh.index() == i).count();
            json!({
                "name": mesh.name, "triangles": mesh.triangle_count(), "instances": instances,
                "topology": t.summary(), "boundary_edges": t.boundary_edges,
                "nonmanifold_edges": t.nonmanifold_edges, "orientation_conflicts": t.orientation_conflicts,
                "degenerate_triangles": t.degenerate_triangles,
            })
        })
        .collect();
    let summary = json!({
        "name": scene.name,
        "triangles": stats.triangles,
        "unique_triangles": stats.unique_triangles,
        "instances": stats.instances,
        "bounds": { "min": bounds.min.to_array(), "max": bounds.max.to_array() },
        "origin": scene.origin.to_array(),
        "meshes": meshes,
        "lights": scene.lights.iter().map(|l| json!({
            "name": l.name, "type": l.type_name(), "emitter": l.emitter_size_text(), "mobility": l.mobility.name(),
        })).collect::<Vec<_>>(),
        "views": scene.views.iter().map(|v| v.name.clone()).collect::<Vec<_>>(),
        "paths": scene.paths.iter().map(|p| p.name.clone()).collect::<Vec<_>>(),
        "warnings": loaded.warnings,
    });
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
        return Ok(());
    }
    println!(
        "{}: {} triangles ({} stored), {} instances of {} meshes",
        scene.name, stats.triangles, stats.unique_triangles, stats.instances, stats.meshes
    );
    let v3 = |v: [f64; 3]| format!("({:.3}, {:.3}, {:.3})", v[0], v[1], v[2]);
    let f64s = |v: glam::Vec3| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
    println!("  bounds {} … {} (origin {})", v3(f64s(bounds.min)), v3(f64s(bounds.max)), v3(scene.origin.to_array()));
    for m in &meshes {
        println!(
            "  mesh {:<24} {:>9} triangles ×{:<3} {} ({} boundary, {} non-manifold edges, {} winding conflicts, {} degenerate)",
            m["name"].as_str().unwrap_or(""),
            m["triangles"],
            m["instances"],
            m["topology"].as_str().unwrap_or(""),
            m["boundary_edges"],
            m["nonmanifold_edges"],
            m["orientation_conflicts"],
            m["degenerate_triangles"]
        );
    }
    for l in &scene.lights {
        println!("  light {:<16} {:<12} {} ({})", l.name, l.type_name(), l.emitter_size_text(), l.mobility.name());
    }
    let names = |v: Vec<&str>| if v.is_empty() { "none".to_owned() } else { v.join(", ") };
    println!("  views: {}", names(scene.views.iter().map(|v| v.name.as_str()).collect()));
    println!("  paths: {}", names(scene.paths.iter().map(|p| p.name.as_str()).collect()));
    for w in &loaded.warnings {
        println!("  warning: {w}");
    }
    Ok(())
}
