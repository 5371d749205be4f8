//! `shadowlab render`: one lit image with one technique on every chosen light.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use shadowlab_reference::images::write_rgb_png;

use crate::args::{GlobalArgs, SceneArgs, TechniqueArgs, open_gpu, renderer_for};
use crate::overlay::{Overlay, compose, compose_fill};

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    techniques: TechniqueArgs,
    /// Output PNG file.
    #[arg(long)]
    out: PathBuf,
    /// Draw an analysis overlay: for the first shadowed light's maps (hard, pcf, cascaded), or the
    /// volume fill of every shadowed light (`fill`: volumes, lightmesh).
    #[arg(long, value_enum)]
    overlay: Option<Overlay>,
    /// Texels between the lines of the texel-grid overlay.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=4096))]
    grid: u32,
}

pub fn run(global: &GlobalArgs, args: Args) -> Result<()> {
    // Checked before anything is rendered: `--out` names the PNG file to write.
    if args.out.is_dir() {
        bail!(
            "--out {} is a directory: name the PNG file to write (e.g. {}/render.png)",
            args.out.display(),
            args.out.display()
        );
    }
    if !args.out.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        bail!("--out {}: render writes a PNG image; name a file ending in .png", args.out.display());
    }
    let setup = args.scene.load()?;
    let specs = args.techniques.selected(&setup, &["hard"])?;
    let spec = specs.first().context("no technique")?;
    if specs.len() > 1 {
        eprintln!("warning: render uses one technique; rendering '{}'", spec.label());
    }
    if let Some(plan) = spec.auto() {
        for line in plan.describe() {
            println!("{line}");
        }
    }
    let gpu = open_gpu(global)?;
    let mut r = renderer_for(&gpu, &setup, spec)?;
    for warning in &r.shadows.gpu_scene().warnings {
        eprintln!("warning: {warning}");
    }
    let report = r.render()?;
    let mut image = r.read_image()?;
    if args.overlay == Some(Overlay::Fill) {
        let counts = r.fill_counts(&setup.lights)?.with_context(|| {
            format!("overlay 'fill' needs shadow volumes (volumes, lightmesh), not '{}'", spec.label())
        })?;
        let total: u64 = counts.iter().map(|&c| u64::from(c)).sum();
        let covered = counts.iter().filter(|&&c| c > 0).count();
        println!(
            "volume fill: {total} fragments, {:.2} per pixel, {covered} pixels covered, at most {} on one",
            total as f64 / counts.len().max(1) as f64,
            counts.iter().max().copied().unwrap_or(0)
        );
        image = compose_fill(&image, &counts);
    } else if let Some(kind) = args.overlay {
        let light = *setup.lights.first().context("no light to analyse")?;
        let data = r.map_overlay(light, args.grid)?.with_context(|| {
            format!(
                "overlays need a technique that shades from one map per pixel (hard, pcf, cascaded), not '{}'",
                spec.spec_for(light).map_or(spec.label(), |s| s.spec.as_str())
            )
        })?;
        image = compose(&image, &data, kind)?;
    }
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    write_rgb_png(&args.out, &image, setup.width, setup.height)?;
    println!(
        "{} on {}/{} at {}x{}: {} → {}",
        spec.label(),
        setup.scene.name,
        setup.view.name,
        setup.width,
        setup.height,
        match report.gpu {
            Some(t) => format!("{:.2} ms GPU", t.total()),
            None => format!("{:.2} ms CPU", report.cpu_ms),
        },
        args.out.display()
    );
    Ok(())
}
