//! `shadowlab bench`: frame times per technique (DESIGN.md §9): GPU time per pass from timestamp
//! queries, medians of `--frames` frames after warm-up, CPU frame time beside it, GPU memory, and
//! every time as a ratio over `hard` from the same run.

use std::path::PathBuf;

use anyhow::Result;
use serde_json::json;

use crate::args::{GlobalArgs, SceneArgs, Selected, TechniqueArgs, open_gpu};
use crate::measure::measure;
use crate::progress;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    techniques: TechniqueArgs,
    /// Timed frames per technique.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..=10000))]
    frames: u32,
    /// Untimed frames first (pipeline compilation, caches).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=1000))]
    warmup: u32,
    /// Also write the results as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
}

pub fn run(global: &GlobalArgs, args: Args) -> Result<()> {
    let setup = args.scene.load()?;
    let specs = args.techniques.selected(&setup, super::compare::DEFAULT_TECHNIQUES)?;
    let specs = Selected::keep_applicable(specs, &setup)?;
    let auto = specs.iter().find_map(Selected::auto);
    let gpu = open_gpu(global)?;
    let (frames, warmup) = (args.frames as usize, args.warmup as usize);
    let bar = progress::bar((2 * specs.len() * (frames + warmup)) as u64, "bench");
    let mut results = Vec::new();
    for spec in &specs {
        bar.set_message(format!("bench {}", spec.label()));
        let m = measure(&gpu, &setup, spec, warmup, frames, &|| bar.inc(1))?;
        let stats = m.renderer.shadows.stats();
        crate::args::warn_map_reductions(&m.renderer, spec.label());
        let budget = crate::args::map_budget_json(&m.renderer);
        results.push((
            spec.label().to_owned(),
            spec.id().to_owned(),
            spec.params_json(),
            m.timing,
            stats,
            m.cached,
            budget,
        ));
    }
    bar.finish_and_clear();
    // The baseline: plain `hard`, else the first `hard` with parameters (`hard:faces=front`).
    let hard = results
        .iter()
        .find(|r| r.0 == "hard")
        .or_else(|| results.iter().find(|r| r.1 == "hard"))
        .map(|r| r.3.frame_ms());
    println!(
        "{} / {} at {}x{}, {} frames after {} warm-up, adapter {}",
        setup.scene.name, setup.view.name, setup.width, setup.height, frames, warmup, gpu.adapter
    );
    if let Some(plan) = auto {
        for line in plan.describe() {
            println!("{line}");
        }
    }
    println!(
        "{:<34} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>7} {:>9} {:>9}",
        "technique", "frame ms", "gbuffer", "shadow", "visib.", "lighting", "CPU ms", "×hard", "still ms", "MiB"
    );
    let mut json_rows = Vec::new();
    for (spec, id, params, t, stats, cached, budget) in &results {
        let p = t.gpu_passes.unwrap_or([f64::NAN; 4]);
        let ratio = hard.map(|h| t.frame_ms() / h);
        println!(
            "{:<34} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>7} {:>9.2} {:>9.1}",
            spec,
            t.frame_ms(),
            p[0],
            p[1],
            p[2],
            p[3],
            t.cpu_median,
            ratio.map(|r| format!("{r:.2}")).unwrap_or_else(|| "–".into()),
            cached.frame_ms(),
            stats.memory_bytes as f64 / (1024.0 * 1024.0)
        );
        json_rows.push(json!({
            "id": id, "spec": spec, "params": params,
            "gpu_ms": t.gpu_json(), "cpu_ms": { "median": t.cpu_median },
            "cached_gpu_ms": cached.gpu_json(), "cached_cpu_ms": { "median": cached.cpu_median },
            "frames": t.frames, "warmup": t.warmup,
            "time_ratio_over_hard": ratio,
            "memory_bytes": stats.memory_bytes, "map_budget": budget, "passes": stats.passes, "draws": stats.draws,
            "shadow_triangles": stats.triangles,
            "technique_stats": stats.extra.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
        }));
    }
    if results.iter().all(|r| r.3.gpu_median.is_none()) {
        println!("(no timestamp queries on this adapter: frame ms are CPU wall-clock times)");
    }
    if let Some(path) = &args.json {
        let mut doc = json!({
            "scene": setup.scene.name, "view": setup.view.name, "width": setup.width, "height": setup.height,
            "adapter": { "name": gpu.adapter.name, "backend": gpu.adapter.backend, "device_type": gpu.adapter.device_type },
            "techniques": json_rows,
        });
        if let Some(plan) = auto {
            doc["auto"] = plan.choices_json();
            doc["auto_budget"] = plan.settings_json();
        }
        std::fs::write(path, serde_json::to_string_pretty(&doc)?)?;
        println!("→ {}", path.display());
    }
    Ok(())
}
