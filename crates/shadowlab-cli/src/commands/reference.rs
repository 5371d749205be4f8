//! `shadowlab reference`: the ray-traced ground truth of every chosen light, on the CPU.
//!
//! Primary rays are traced on the CPU too, so this runs on any machine. Written to `--out`:
//! - `light<i>-<name>.png`: visibility as a 16-bit grey PNG (not-relevant pixels black);
//! - `light<i>-<name>.f32` + `.json`: the same as raw little-endian f32, NaN where not relevant;
//! - `positions.f32`, `normals.f32`, `geometric_normals.f32` (+ `.json`): the surface points used and
//!   their shading and facet normals, 3 floats per pixel; positions are in the scene's local frame
//!   (world = position + `origin` of `reference.json`);
//! - `reference.json`: the settings, timings and per-light summary.

use std::path::PathBuf;

use anyhow::{Context, Result};
use serde_json::json;
use shadowlab_core::Light;
use shadowlab_reference::images::{write_raw_f32, write_visibility_png};
use shadowlab_reference::{ReferenceSettings, SceneBvh, Selection, reference, samples_for, trace_surface};

use crate::args::{GlobalArgs, SceneArgs, slug};
use crate::progress;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// Emitter samples per pixel for area lights (hard lights use one ray).
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=65536))]
    samples: u32,
    /// Seed of the sample patterns: the same seed gives bit-identical output.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory (created if needed).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(_global: &GlobalArgs, args: Args) -> Result<()> {
    let setup = args.scene.load()?;
    let (w, h) = (setup.width, setup.height);
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let scene = &setup.scene;

    let all = SceneBvh::build(scene, Selection::All);
    let surface = trace_surface(&all, scene, &setup.view, w, h);
    let casters = SceneBvh::build(scene, Selection::Casters);
    // The alpha masks' textures that could not be read (the casters' build read them).
    for warning in &casters.warnings {
        eprintln!("warning: {warning}");
    }
    let lights: Vec<(u32, &shadowlab_core::Light)> =
        setup.lights.iter().map(|id| (id.0, &scene.lights[id.index()])).collect();
    let settings = ReferenceSettings { samples: args.samples, seed: args.seed };

    let bar = progress::bar((surface.len() * lights.len()) as u64, "reference (CPU ray tracing)");
    let result = reference(&casters, &surface, &lights, &settings, Some(&|done, _| bar.set_position(done as u64)));
    bar.finish_and_clear();

    let mut light_entries = Vec::new();
    for (v, &(index, light)) in result.lights.iter().zip(&lights) {
        let stem = args.out.join(format!("light{index}-{}", slug(&light.name)));
        write_visibility_png(&stem.with_extension("png"), &v.values, w, h)?;
        write_raw_f32(&stem, &v.values, w, h, 1, "reference visibility V in [0,1]; NaN = not relevant")?;
        light_entries.push(json!({
            "index": index, "name": light.name, "type": light.type_name(), "emitter": light.emitter_size_text(),
            "samples": samples_for(light, args.samples),
            "relevant_pixels": v.relevant_pixels, "rays": v.rays, "seconds": v.seconds,
            "png": stem.with_extension("png").file_name().map(|f| f.to_string_lossy().into_owned()),
            "f32": stem.with_extension("f32").file_name().map(|f| f.to_string_lossy().into_owned()),
        }));
    }
    let flat = |v: &[glam::Vec3], covered: &[bool]| -> Vec<f32> {
        v.iter().zip(covered).flat_map(|(p, &c)| if c { p.to_array() } else { [f32::NAN; 3] }).collect()
    };
    write_raw_f32(
        &args.out.join("positions"),
        &flat(&surface.positions, &surface.covered),
        w,
        h,
        3,
        "position xyz in the scene's local frame (world = this + reference.json's origin); NaN = background",
    )?;
    write_raw_f32(
        &args.out.join("normals"),
        &flat(&surface.normals, &surface.covered),
        w,
        h,
        3,
        "unit shading normal xyz, turned by the facet's facing; NaN = background",
    )?;
    write_raw_f32(
        &args.out.join("geometric_normals"),
        &flat(&surface.geometric_normals, &surface.covered),
        w,
        h,
        3,
        "unit facet normal N_g xyz, facing the camera (ray origins are offset along it); NaN = background",
    )?;
    let summary = json!({
        "scene": scene.name, "view": setup.view.name, "width": w, "height": h,
        // The most any light took (1 when every light is hard); `samples_asked`: `--samples`.
        "samples": used_samples(&lights, args.samples), "samples_asked": args.samples,
        "seed": args.seed, "origin": scene.origin.to_array(),
        "seconds": result.seconds, "bvh_build_seconds": result.bvh_build.as_secs_f64(),
        "rays": result.rays, "rays_per_second": result.rays_per_second(),
        "triangles": casters.len(), "lights": light_entries,
    });
    std::fs::write(args.out.join("reference.json"), serde_json::to_string_pretty(&summary)?)?;
    println!(
        "reference of {} light(s) on {}/{} at {w}x{h}, {}: {:.2} s, {:.2} M shadow rays/s → {}",
        lights.len(),
        scene.name,
        setup.view.name,
        samples_text(&lights, args.samples),
        result.seconds,
        result.rays_per_second() / 1e6,
        args.out.display()
    );
    Ok(())
}

/// The most emitter samples per pixel any of `lights` takes (hard lights take one ray).
pub(crate) fn used_samples(lights: &[(u32, &Light)], samples: u32) -> u32 {
    lights.iter().map(|&(_, l)| samples_for(l, samples)).max().unwrap_or(1)
}

/// "256 samples", "1 ray per pixel (hard lights)" or "256 samples (hard lights: 1 ray)".
pub(crate) fn samples_text(lights: &[(u32, &Light)], samples: u32) -> String {
    let hard = lights.iter().filter(|(_, l)| l.is_hard()).count();
    if hard == lights.len() {
        "1 ray per pixel (hard lights)".to_owned()
    } else if hard > 0 {
        format!("{samples} samples (hard lights: 1 ray)")
    } else {
        format!("{samples} samples")
    }
}
