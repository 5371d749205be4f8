//! `shadowlab compare`: every technique against the ray-traced truth, on the same surface.
//!
//! 1. Render the G-buffer once and read back the surface (positions as the techniques reconstruct
//!    them, and normals).
//! 2. Ray-trace the reference visibility of each chosen light on that surface (and a second one with
//!    another seed: the noise floor).
//! 3. Per technique: render warm-up and timed frames, read each light's visibility, measure it.
//! 4. Write `metrics.json`, the images, visibilities and error heatmaps, and `report.html`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde_json::{Value, json};
use shadowlab::TechniqueSpec;
use shadowlab_core::LightId;
use shadowlab_reference::images::{
    encode_rgb_png, error_heatmap, visibility_rgb, write_raw_f32, write_rgb_png, write_visibility_png,
};
use shadowlab_reference::metrics::{ErrorStats, flip_mean, image_rmse, rmse_between};
use shadowlab_reference::{ReferenceSettings, SceneBvh, Selection, reference};

use crate::args::{GlobalArgs, SceneArgs, Selected, Setup, TechniqueArgs, open_gpu, renderer, renderer_for, slug};
use crate::measure::{Timing, measure};
use crate::progress;
use crate::report::{self, PlotPoint};

/// The techniques compared when none are named.
pub const DEFAULT_TECHNIQUES: &[&str] = &["none", "hard", "pcf", "sampled"];

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    techniques: TechniqueArgs,
    /// Reference emitter samples per pixel for area lights. A hard light (zero-size emitter, as with
    /// `--emitter-scale 0`) needs and takes one ray per pixel whatever this says: its truth is exact.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=65536))]
    samples: u32,
    /// Reference seed (the noise floor uses seed + 1).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Timed frames per technique (the median is reported); `bench` defaults to more.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    frames: u32,
    /// Untimed frames before timing.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(0..=100))]
    warmup: u32,
    /// Output directory.
    #[arg(long, default_value = "out/compare")]
    out: PathBuf,
    /// Also measure `flicker` along a camera path: a path of the scene (`terrain`: `walk`) or
    /// comma-separated view names.
    #[arg(long)]
    path: Option<String>,
    /// Frames along the path (default: the path's own, or 24 for a list of views).
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..=10000))]
    path_frames: Option<u32>,
}

struct LightRef<'a> {
    id: LightId,
    name: &'a str,
    stem: String,
    values: Vec<f32>,
}

pub fn run(global: &GlobalArgs, args: Args) -> Result<()> {
    let setup = args.scene.load()?;
    let specs = args.techniques.selected(&setup, DEFAULT_TECHNIQUES)?;
    let specs = Selected::keep_applicable(specs, &setup)?;
    // Names are checked before the reference is traced.
    let path = args.path.as_deref().map(|p| resolve_path(&setup, p, args.path_frames)).transpose()?;
    // `auto`: which light got what, and why (one plan however often `auto` is listed).
    let auto = specs.iter().find_map(Selected::auto);
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let gpu = open_gpu(global)?;
    let (w, h) = (setup.width, setup.height);

    // 1. The surface, from a renderer that shadows nothing (its G-buffer is every technique's).
    let none = TechniqueSpec::parse("none", &[])?;
    let mut base = renderer(&gpu, &setup, &none)?;
    for warning in &base.shadows.gpu_scene().warnings {
        eprintln!("warning: {warning}");
    }
    base.render()?;
    let surface = base.read_surface()?;

    // 2. The reference and its noise floor.
    // (Its warnings, about alpha masks, are the GPU scene's above: the same textures.)
    let bvh = SceneBvh::build(&setup.scene, Selection::Casters);
    let lights: Vec<(u32, &shadowlab_core::Light)> =
        setup.lights.iter().map(|id| (id.0, &setup.scene.lights[id.index()])).collect();
    let settings = ReferenceSettings { samples: args.samples, seed: args.seed };
    let total = (surface.len() * lights.len() * 2) as u64;
    let bar = progress::bar(total, "reference (CPU ray tracing)");
    let half = (surface.len() * lights.len()) as u64;
    let truth = reference(&bvh, &surface, &lights, &settings, Some(&|d, _| bar.set_position(d as u64)));
    let second = ReferenceSettings { seed: args.seed.wrapping_add(1), ..settings };
    let noise = reference(&bvh, &surface, &lights, &second, Some(&|d, _| bar.set_position(half + d as u64)));
    bar.finish_and_clear();
    let noise_floor = {
        let (a, b): (Vec<f32>, Vec<f32>) = truth
            .lights
            .iter()
            .zip(&noise.lights)
            .flat_map(|(x, y)| x.values.iter().copied().zip(y.values.iter().copied()))
            .unzip();
        rmse_between(&a, &b)
    };
    eprintln!(
        "reference: {}, {:.1} s, {:.1} M rays/s, noise floor RMSE {noise_floor:.4}",
        super::reference::samples_text(&lights, args.samples),
        truth.seconds,
        truth.rays_per_second() / 1e6
    );

    let refs: Vec<LightRef> = setup
        .lights
        .iter()
        .zip(&truth.lights)
        .map(|(id, v)| {
            let light = &setup.scene.lights[id.index()];
            LightRef {
                id: *id,
                name: &light.name,
                stem: format!("light{}-{}", id.0, slug(&light.name)),
                values: v.values.clone(),
            }
        })
        .collect();
    let ref_layers: Vec<(LightId, &[f32])> = refs.iter().map(|r| (r.id, r.values.as_slice())).collect();
    let reference_image = base.image_with_visibility(&ref_layers)?;
    write_rgb_png(&args.out.join("reference.png"), &reference_image, w, h)?;
    for r in &refs {
        let stem = args.out.join(format!("reference-{}", r.stem));
        write_visibility_png(&stem.with_extension("png"), &r.values, w, h)?;
        write_raw_f32(&stem, &r.values, w, h, 1, "reference visibility V in [0,1]; NaN = not relevant")?;
    }
    drop(base);

    // 3. The techniques.
    let frames = args.frames as usize;
    let warmup = args.warmup as usize;
    let bar = progress::bar((2 * specs.len() * (frames + warmup)) as u64, "techniques (GPU)");
    let mut entries = Vec::new();
    let mut outcomes = Vec::new();
    let mut used = Vec::new();
    for spec in &specs {
        bar.set_message(format!("technique {}", spec.label()));
        let m = measure(&gpu, &setup, spec, warmup, frames, &|| bar.inc(1))?;
        let mut tslug = slug(spec.label());
        while used.contains(&tslug) {
            tslug.push('_');
        }
        used.push(tslug.clone());
        let image = m.renderer.read_image()?;
        write_rgb_png(&args.out.join(format!("{tslug}.png")), &image, w, h)?;
        let mut pooled = ErrorStats::default();
        let mut light_entries = Vec::new();
        let mut light_images = Vec::new();
        let unsupported = spec.unsupported(&setup)?;
        for r in &refs {
            let v = m.renderer.read_visibility(r.id)?.context("light without a visibility layer")?;
            let stats = ErrorStats::compare(&v, &r.values);
            let applicable = !unsupported.contains(&r.id);
            if applicable {
                pooled.merge(&stats);
            }
            let s = stats.summary();
            let mut entry = json!({
                "index": r.id.0, "name": r.name, "rmse": s.rmse, "mae": s.mae, "max_abs": s.max_abs,
                "wrong_frac": s.wrong_frac, "penumbra_rmse": s.penumbra_rmse, "relevant_pixels": s.relevant_pixels,
                "lit_darkened_frac": s.lit_darkened_frac, "shadow_brightened_frac": s.shadow_brightened_frac,
            });
            if let (Some(_), Some(chosen)) = (spec.auto(), spec.spec_for(r.id)) {
                entry["spec"] = json!(chosen.spec);
            }
            if !applicable {
                // The technique does not take this light: its figures are `hard`'s, outside the pool.
                entry["not_applicable"] = json!(true);
                entry["substitute"] = json!("hard");
            }
            light_entries.push(entry);
            // Shown where the reference is relevant; elsewhere the technique's value means nothing.
            let masked: Vec<f32> =
                v.iter().zip(&r.values).map(|(&x, &y)| if y.is_nan() { f32::NAN } else { x }).collect();
            let stem = args.out.join(format!("{tslug}-{}", r.stem));
            write_visibility_png(&stem.with_extension("png"), &masked, w, h)?;
            write_raw_f32(&stem, &masked, w, h, 1, "technique visibility V; NaN = not relevant for the reference")?;
            let heat = error_heatmap(&v, &r.values);
            write_rgb_png(&args.out.join(format!("{tslug}-{}-error.png", r.stem)), &heat, w, h)?;
            light_images.push((encode_rgb_png(&visibility_rgb(&masked), w, h)?, encode_rgb_png(&heat, w, h)?));
        }
        let flip = flip_mean(&reference_image, &image, w, h);
        // Azri 2020's measure: the lit images' RMSE in [0, 1], over pixels that hold geometry.
        let image_error = image_rmse(&image, &reference_image, Some(&surface.covered));
        let s = pooled.summary();
        let stats = m.renderer.shadows.stats();
        crate::args::warn_map_reductions(&m.renderer, spec.label());
        entries.push(json!({
            "id": spec.id(),
            "spec": spec.label(),
            "params": spec.params_json(),
            "rmse": s.rmse, "mae": s.mae, "max_abs": s.max_abs, "wrong_frac": s.wrong_frac,
            "penumbra_rmse": s.penumbra_rmse, "flip_mean": flip, "image_rmse": image_error,
            "lit_darkened_frac": s.lit_darkened_frac, "shadow_brightened_frac": s.shadow_brightened_frac,
            "lights": light_entries,
            "gpu_ms": m.timing.gpu_json(),
            "cpu_ms": { "median": m.timing.cpu_median },
            "cached_gpu_ms": m.cached.gpu_json(),
            "cached_cpu_ms": { "median": m.cached.cpu_median },
            "memory_bytes": stats.memory_bytes,
            "map_budget": crate::args::map_budget_json(&m.renderer),
            "frames": m.timing.frames, "warmup": m.timing.warmup,
            "passes": stats.passes, "draws": stats.draws, "shadow_triangles": stats.triangles,
            "technique_stats": stats.extra.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
        }));
        outcomes.push(Outcome {
            spec: spec.label().to_owned(),
            timing: m.timing.clone(),
            image: encode_rgb_png(&image, w, h)?,
            light_images,
        });
    }
    bar.finish_and_clear();

    // 4. Temporal stability along a path.
    let mut path_json = Value::Null;
    if let Some(path) = &path {
        let views = path.views();
        let flickers = measure_flicker(&gpu, &setup, &specs, &views, &settings)?;
        for (e, f) in entries.iter_mut().zip(&flickers) {
            e["flicker"] = json!(f.fraction());
            e["flicker_pixels"] = json!(f.pixels);
        }
        path_json = json!({ "name": path.name, "frames": views.len() });
    }

    // 5. Reports.
    // The baseline: plain `hard`, else the first `hard` with parameters (`hard:faces=front`).
    let is_hard = |spec: &str| spec.split(':').next() == Some("hard");
    let hard_ms = outcomes
        .iter()
        .find(|o| o.spec == "hard")
        .or_else(|| outcomes.iter().find(|o| is_hard(&o.spec)))
        .map(|o| o.timing.frame_ms());
    for (e, o) in entries.iter_mut().zip(&outcomes) {
        e["time_ratio_over_hard"] = hard_ms.map(|h| json!(o.timing.frame_ms() / h)).unwrap_or(Value::Null);
    }
    let mut metrics = json!({
        "scene": setup.scene.name,
        "view": setup.view.name,
        "width": w, "height": h,
        "adapter": { "name": gpu.adapter.name, "backend": gpu.adapter.backend, "device_type": gpu.adapter.device_type },
        "reference": {
            // The most any light took (1 when every light is hard); `samples_asked`: `--samples`.
            "samples": super::reference::used_samples(&lights, args.samples), "samples_asked": args.samples,
            "seed": args.seed, "seconds": truth.seconds,
            "noise_floor_rmse": noise_floor, "rays_per_second": truth.rays_per_second(),
        },
        "emitter_scale": args.scene.emitter_scale,
        "origin": setup.scene.origin.to_array(),
        "lights": refs.iter().map(|r| {
            let light = &setup.scene.lights[r.id.index()];
            json!({"index": r.id.0, "name": r.name, "type": light.type_name(),
                   "samples": shadowlab_reference::samples_for(light, args.samples)})
        }).collect::<Vec<_>>(),
        "techniques": entries,
        "path": path_json,
    });
    if let Some(plan) = auto {
        metrics["auto"] = plan.choices_json();
        metrics["auto_budget"] = plan.settings_json();
    }
    std::fs::write(args.out.join("metrics.json"), serde_json::to_string_pretty(&metrics)?)?;
    let html = report_html(&setup, &metrics, &outcomes, &refs, &encode_rgb_png(&reference_image, w, h)?, &args.out)?;
    std::fs::write(args.out.join("report.html"), html)?;
    print_summary(&metrics);
    println!("→ {}", args.out.join("report.html").display());
    Ok(())
}

struct Outcome {
    spec: String,
    timing: Timing,
    image: Vec<u8>,
    /// Per light: (visibility, error heatmap) PNGs.
    light_images: Vec<(Vec<u8>, Vec<u8>)>,
}

fn fmt(v: &Value, digits: usize) -> String {
    v.as_f64().map(|x| format!("{x:.digits$}")).unwrap_or_else(|| "–".to_owned())
}

/// A fraction as a percentage with two decimals; empty when absent.
fn percent(v: &Value) -> String {
    v.as_f64().map(|x| format!("{:.2}%", 100.0 * x)).unwrap_or_default()
}

fn print_summary(metrics: &Value) {
    for c in metrics["auto"].as_array().into_iter().flatten() {
        println!(
            "auto: light {} '{}' → {}: {}",
            c["light"],
            c["name"].as_str().unwrap_or(""),
            c["spec"].as_str().unwrap_or(""),
            c["reason"].as_str().unwrap_or("")
        );
    }
    let flicker = !metrics["path"].is_null();
    println!(
        "{:<34} {:>8} {:>8} {:>9} {:>9} {:>9} {:>8}{}",
        "technique",
        "RMSE",
        "wrong%",
        "pen.RMSE",
        "GPU ms",
        "×hard",
        "MiB",
        if flicker { "  flicker%" } else { "" }
    );
    for t in metrics["techniques"].as_array().into_iter().flatten() {
        println!(
            "{:<34} {:>8} {:>8} {:>9} {:>9} {:>9} {:>8.1}{}",
            t["spec"].as_str().unwrap_or(""),
            fmt(&t["rmse"], 4),
            t["wrong_frac"].as_f64().map(|x| format!("{:.2}", 100.0 * x)).unwrap_or_default(),
            fmt(&t["penumbra_rmse"], 4),
            fmt(&t["gpu_ms"]["median"], 2),
            fmt(&t["time_ratio_over_hard"], 2),
            t["memory_bytes"].as_f64().unwrap_or(0.0) / (1024.0 * 1024.0),
            if flicker { format!("  {:>8.3}", 100.0 * t["flicker"].as_f64().unwrap_or(0.0)) } else { String::new() }
        );
    }
}

fn report_html(
    setup: &Setup,
    metrics: &Value,
    outcomes: &[Outcome],
    refs: &[LightRef],
    reference_png: &[u8],
    out: &Path,
) -> Result<String> {
    let techniques = metrics["techniques"].as_array().cloned().unwrap_or_default();
    let rows: Vec<Vec<String>> = techniques
        .iter()
        .map(|t| {
            let passes = &t["gpu_ms"]["passes"];
            vec![
                report::escape(t["spec"].as_str().unwrap_or("")),
                fmt(&t["rmse"], 4),
                fmt(&t["mae"], 4),
                fmt(&t["max_abs"], 3),
                percent(&t["wrong_frac"]),
                fmt(&t["penumbra_rmse"], 4),
                percent(&t["lit_darkened_frac"]),
                percent(&t["shadow_brightened_frac"]),
                fmt(&t["flip_mean"], 4),
                fmt(&t["image_rmse"], 4),
                fmt(&t["gpu_ms"]["median"], 2),
                fmt(&t["time_ratio_over_hard"], 2),
                format!(
                    "{} / {} / {} / {}",
                    fmt(&passes["gbuffer"], 2),
                    fmt(&passes["shadow"], 2),
                    fmt(&passes["visibility"], 2),
                    fmt(&passes["lighting"], 2)
                ),
                fmt(&t["cpu_ms"]["median"], 1),
                format!("{:.1}", t["memory_bytes"].as_f64().unwrap_or(0.0) / (1024.0 * 1024.0)),
            ]
        })
        .collect();
    let table = report::table(
        &[
            "technique",
            "RMSE",
            "MAE",
            "max |Δ|",
            "wrong",
            "penumbra RMSE",
            "lit darkened",
            "shadow brightened",
            "FLIP",
            "image RMSE",
            "GPU ms",
            "× hard",
            "G-buf / shadow / vis / light ms",
            "CPU ms",
            "MiB",
        ],
        &rows,
    );
    // Penumbra RMSE when every technique has penumbra pixels, else the wrong-pixel fraction.
    let use_penumbra = techniques.iter().all(|t| t["penumbra_rmse"].is_number());
    let (error_name, key) =
        if use_penumbra { ("penumbra RMSE", "penumbra_rmse") } else { ("wrong-pixel fraction", "wrong_frac") };
    let timed_on_gpu = outcomes.iter().all(|o| o.timing.gpu_median.is_some());
    let points: Vec<PlotPoint> = techniques
        .iter()
        .zip(outcomes)
        .map(|(t, o)| PlotPoint {
            label: o.spec.clone(),
            ms: o.timing.frame_ms(),
            error: t[key].as_f64().unwrap_or(f64::NAN),
        })
        .collect();
    let svg = report::quality_time_svg(
        &points,
        error_name,
        if timed_on_gpu { "GPU ms per frame (median)" } else { "CPU ms per frame (median)" },
    )?;
    std::fs::write(out.join("quality_time.svg"), &svg)?;

    let mut images = String::from("<div class=\"grid\">");
    images.push_str(&format!(
        "<figure>{}<figcaption>reference (ray traced)</figcaption></figure>",
        report::img(reference_png, "reference")
    ));
    for o in outcomes {
        images.push_str(&format!(
            "<figure>{}<figcaption>{}</figcaption></figure>",
            report::img(&o.image, &o.spec),
            report::escape(&o.spec)
        ));
    }
    images.push_str("</div>");
    let mut per_light = String::new();
    for (k, r) in refs.iter().enumerate() {
        per_light.push_str(&format!("<h3>light {} '{}'</h3><div class=\"grid\">", r.id.0, report::escape(r.name)));
        let ref_png = encode_rgb_png(&visibility_rgb(&r.values), setup.width, setup.height)?;
        per_light.push_str(&format!(
            "<figure>{}<figcaption>reference V</figcaption></figure>",
            report::img(&ref_png, "reference")
        ));
        for o in outcomes {
            let (vis, heat) = &o.light_images[k];
            per_light.push_str(&format!(
                "<figure>{}<figcaption>{} V</figcaption></figure><figure>{}<figcaption>{} error</figcaption></figure>",
                report::img(vis, &o.spec),
                report::escape(&o.spec),
                report::img(heat, &o.spec),
                report::escape(&o.spec)
            ));
        }
        per_light.push_str("</div>");
    }
    let a = &metrics["adapter"];
    let r = &metrics["reference"];
    Ok(format!(
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>shadowlab: {scene}/{view}</title><style>{style}</style></head><body>\
<h1>shadowlab compare: {scene} / {view}</h1>\
<p>{w}×{h} pixels · lights: {lights} · adapter: {adapter} ({backend}, {dtype}) · reference: {samples}, seed {seed}, {secs:.1} s · noise floor RMSE {noise:.4}</p>\
<h2>Which technique, at what cost, how wrong</h2>{table}\
<p class=\"note\">Errors over relevant pixels (DESIGN.md §6): wrong = |V − V<sub>ref</sub>| &gt; 0.1; penumbra RMSE over the truth's penumbra, pixels where V<sub>ref</sub> is in (0.02, 0.98) (only V<sub>ref</sub> decides, so false faint shadows cannot dilute it); lit darkened = fraction with V<sub>ref</sub> = 1 and V &lt; 0.98 (acne, false shadows); shadow brightened = fraction with V<sub>ref</sub> = 0 and V &gt; 0.02 (light leaks); a missing V (NaN) counts as an error of 1; FLIP and image RMSE (Azri 2020's measure, over pixels with geometry) of the final image against the image lit with the reference visibility. Times are medians of {frames} frames after warm-up; ratios over <code>hard</code> hold across machines, absolute times do not (a CPU adapter is not a GPU).</p>\
{auto}<h2>Quality against time</h2>{svg}\
<h2>Images</h2>{images}\
<h2>Visibility and error per light</h2><p class=\"note\">Error heatmaps: white exact, blue too dark (V &lt; V<sub>ref</sub>), red too bright; grey not relevant. Colour ∝ √|Δ|.</p>{per_light}\
</body></html>",
        scene = report::escape(&setup.scene.name),
        view = report::escape(&setup.view.name),
        style = report::STYLE,
        w = setup.width,
        h = setup.height,
        lights = refs.iter().map(|r| report::escape(r.name)).collect::<Vec<_>>().join(", "),
        adapter = report::escape(a["name"].as_str().unwrap_or("")),
        backend = a["backend"].as_str().unwrap_or(""),
        dtype = a["device_type"].as_str().unwrap_or(""),
        samples = match r["samples"].as_u64() {
            Some(1) => "1 ray per pixel (hard lights)".to_owned(),
            n => format!("{} samples", n.unwrap_or(0)),
        },
        seed = r["seed"],
        secs = r["seconds"].as_f64().unwrap_or(0.0),
        noise = r["noise_floor_rmse"].as_f64().unwrap_or(0.0),
        frames = outcomes.first().map(|o| o.timing.frames).unwrap_or(0),
        auto = auto_html(metrics),
    ))
}

/// The `auto` section: which light got what, and why; empty without `auto`.
fn auto_html(metrics: &Value) -> String {
    let Some(choices) = metrics["auto"].as_array() else {
        return String::new();
    };
    // This run's error of each light under `auto`.
    let here = metrics["techniques"]
        .as_array()
        .and_then(|t| t.iter().find(|t| t["id"] == "auto"))
        .and_then(|t| t["lights"].as_array().cloned())
        .unwrap_or_default();
    let rows: Vec<Vec<String>> = choices
        .iter()
        .map(|c| {
            let measured = here.iter().find(|l| l["index"] == c["light"]).map(|l| &l["rmse"]).unwrap_or(&Value::Null);
            vec![
                report::escape(&format!("{} '{}'", c["light"], c["name"].as_str().unwrap_or(""))),
                report::escape(c["spec"].as_str().unwrap_or("")),
                fmt(&c["share_ms"], 3),
                fmt(&c["cost_ms"], 3),
                if c["fits"].as_bool() == Some(true) { "yes".to_owned() } else { "no".to_owned() },
                fmt(&c["rmse"], 4),
                fmt(measured, 4),
                format!(
                    "<span style=\"text-align:left;display:block\">{}</span>",
                    report::escape(c["reason"].as_str().unwrap_or(""))
                ),
            ]
        })
        .collect();
    let b = &metrics["auto_budget"];
    format!(
        "<h2>auto: which light got what, and why</h2>\
<p>budget {budget} ms{default} × {factor} ({preference}) = {effective} ms, shared equally by the lights; figures from {source}.</p>{table}\
<p class=\"note\">Each light gets the candidate with the lowest calibrated RMSE among those whose calibrated cost (uncached frame − <code>none</code> frame) fits its share; when none fits, the cheapest. Costs and RMSE are the calibration's (or the built-in table's); “RMSE here” is this run's.</p>",
        budget = fmt(&b["budget_ms"], 3),
        default =
            if b["default_budget"].as_bool() == Some(true) { " (default: 4 × the lights' hard cost)" } else { "" },
        factor = b["budget_factor"],
        preference = report::escape(b["preference"].as_str().unwrap_or("")),
        effective = fmt(&b["effective_budget_ms"], 3),
        source = report::escape(b["calibration"].as_str().unwrap_or("")),
        table = report::table(
            &["light", "spec", "share ms", "cost ms", "fits", "RMSE (calibration)", "RMSE here", "why"],
            &rows
        ),
    )
}

/// A path of the scene, or views named in a comma-separated list.
fn resolve_path(setup: &Setup, spec: &str, frames: Option<u32>) -> Result<shadowlab_core::CameraPath> {
    if let Some(p) = setup.scene.path(spec) {
        let mut p = p.clone();
        if let Some(f) = frames {
            p.frames = f;
        }
        return Ok(p);
    }
    let keys = spec
        .split(',')
        .map(|n| {
            setup.scene.view(n.trim()).cloned().with_context(|| {
                let list = |names: Vec<&str>| {
                    if names.is_empty() { "the scene has none".to_owned() } else { names.join(", ") }
                };
                let paths = list(setup.scene.paths.iter().map(|p| p.name.as_str()).collect());
                let views = list(setup.scene.views.iter().map(|v| v.name.as_str()).collect());
                format!("--path '{spec}': '{n}' is neither a path ({paths}) nor a view ({views})")
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(shadowlab_core::CameraPath { name: spec.to_owned(), keys, frames: frames.unwrap_or(24) })
}

/// Renders every technique along `views` and counts flicker against the reference of each frame.
fn measure_flicker(
    gpu: &shadowlab::Gpu,
    setup: &Setup,
    specs: &[Selected],
    views: &[shadowlab_core::View],
    settings: &ReferenceSettings,
) -> Result<Vec<shadowlab_reference::temporal::FlickerStats>> {
    use shadowlab_reference::temporal::{FlickerStats, FrameSample, flicker};
    let none = TechniqueSpec::parse("none", &[])?;
    let mut base = renderer(gpu, setup, &none)?;
    let bvh = SceneBvh::build(&setup.scene, Selection::Casters);
    let lights: Vec<(u32, &shadowlab_core::Light)> =
        setup.lights.iter().map(|id| (id.0, &setup.scene.lights[id.index()])).collect();
    let bar = progress::bar((views.len() * (1 + specs.len())) as u64, "path: reference per frame");
    let mut surfaces = Vec::with_capacity(views.len());
    let mut references: Vec<Vec<Vec<f32>>> = Vec::with_capacity(views.len());
    for v in views {
        base.set_view(v);
        base.render()?;
        let surface = base.read_surface()?;
        let r = reference(&bvh, &surface, &lights, settings, None);
        references.push(r.lights.into_iter().map(|l| l.values).collect());
        surfaces.push(surface);
        bar.inc(1);
    }
    let mut out = Vec::with_capacity(specs.len());
    for spec in specs {
        bar.set_message(format!("path: {}", spec.label()));
        let mut r = renderer_for(gpu, setup, spec)?;
        let mut stats = FlickerStats::default();
        let mut previous: Option<Vec<Vec<f32>>> = None;
        for (t, v) in views.iter().enumerate() {
            r.set_view(v);
            r.render()?;
            let values: Vec<Vec<f32>> = setup
                .lights
                .iter()
                .map(|id| r.read_visibility(*id).map(|o| o.unwrap_or_default()))
                .collect::<Result<_, _>>()?;
            if let Some(prev) = &previous {
                for k in 0..values.len() {
                    let a = FrameSample {
                        view: &views[t - 1],
                        surface: &surfaces[t - 1],
                        value: &prev[k],
                        reference: &references[t - 1][k],
                    };
                    let b =
                        FrameSample { view: v, surface: &surfaces[t], value: &values[k], reference: &references[t][k] };
                    stats.add(&flicker(&a, &b));
                }
            }
            previous = Some(values);
            bar.inc(1);
        }
        out.push(stats);
    }
    bar.finish_and_clear();
    Ok(out)
}
