//! `shadowlab scenes [--json]`: the built-in scenes with their lights, views and sizes.

use anyhow::Result;
use serde_json::json;
use shadowlab_core::ParamSet;
use shadowlab_core::scenes::builtin;

use crate::args::GlobalArgs;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

pub fn run(_global: &GlobalArgs, args: Args) -> Result<()> {
    let mut list = Vec::new();
    for def in builtin() {
        let scene = def.build(&ParamSet::new(def.options));
        let stats = scene.stats();
        list.push(json!({
            "name": def.name,
            "summary": def.summary,
            "triangles": stats.triangles,
            "unique_triangles": stats.unique_triangles,
            "instances": stats.instances,
            "bounds": { "min": scene.bounds().min.to_array(), "max": scene.bounds().max.to_array() },
            "lights": scene.lights.iter().map(|l| json!({
                "name": l.name, "type": l.type_name(), "emitter": l.emitter_size_text(),
                "mobility": l.mobility.name(),
            })).collect::<Vec<_>>(),
            "views": scene.views.iter().map(|v| v.name.clone()).collect::<Vec<_>>(),
            "options": def.options.iter().map(|o| json!({
                "name": o.name, "default": o.default.to_json(), "range": o.range_text(), "doc": o.doc,
            })).collect::<Vec<_>>(),
        }));
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&list)?);
        return Ok(());
    }
    for s in &list {
        println!("{}  —  {}", s["name"].as_str().unwrap_or(""), s["summary"].as_str().unwrap_or(""));
        println!(
            "    {} triangles ({} instances), views: {}",
            s["triangles"],
            s["instances"],
            s["views"]
                .as_array()
                .map(|v| v.iter().filter_map(|x| x.as_str()).collect::<Vec<_>>().join(", "))
                .unwrap_or_default()
        );
        for l in s["lights"].as_array().into_iter().flatten() {
            println!(
                "    light {:<14} {:<12} {}",
                l["name"].as_str().unwrap_or(""),
                l["type"].as_str().unwrap_or(""),
                l["emitter"].as_str().unwrap_or("")
            );
        }
        for o in s["options"].as_array().into_iter().flatten() {
            println!(
                "    option {}={} ({}): {}",
                o["name"].as_str().unwrap_or(""),
                o["default"],
                o["range"].as_str().unwrap_or(""),
                o["doc"].as_str().unwrap_or("")
            );
        }
        println!();
    }
    Ok(())
}
