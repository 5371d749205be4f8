//! `shadowlab calibrate`: per light, each candidate technique's cost and error against the
//! ray-traced truth on the scene's views, for `--technique auto` (docs/calibration-format.md).
//!
//! Per view:
//! 1. Render the G-buffer once (every light `none`), read back the surface and ray-trace the
//!    reference of every chosen light on it.
//! 2. Time the `none` frame (the floor).
//! 3. Per light, per candidate it supports: a renderer with only that light shadowed (the others
//!    `none`), timed uncached and cached as `compare` times a technique; the light's shadow cost is
//!    its frame minus the `none` frame (GPU time of one frame cannot be split between lights, so
//!    each light is timed alone); its visibility is measured against the truth.
//!
//! Then per (light, candidate): the median cost over views, errors pooled over views' pixels, and
//! the largest memory; `cal.json` and `report.html` beside it.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use serde::{Deserialize, Deserializer, Serialize};
use shadowlab::TechniqueSpec;
use shadowlab::auto::{self, Calibration, CandidateFigures, LightFigures, Preference};
use shadowlab_core::LightId;
use shadowlab_reference::metrics::ErrorStats;
use shadowlab_reference::{ReferenceSettings, SceneBvh, Selection, reference};

use crate::args::{GlobalArgs, SceneArgs, Selected, open_gpu, parse_size, renderer};
use crate::measure::{measure, median};
use crate::progress;
use crate::report;

/// Views measured when none are named: the scene's first ones, at most this many.
pub const MAX_DEFAULT_VIEWS: usize = 4;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// A built-in scene (`shadowlab scenes`), optionally with options, or a .toml, .gltf, .glb or
    /// .obj file.
    #[arg(long, default_value = "room")]
    scene: String,
    /// Views to measure on (repeatable or comma-separated; default: the scene's first four).
    #[arg(long = "view", value_delimiter = ',')]
    views: Vec<String>,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "128x96", value_parser = parse_size)]
    size: (u32, u32),
    /// Only these lights (names or indices, comma-separated) are calibrated.
    #[arg(long, value_delimiter = ',')]
    lights: Vec<String>,
    /// Scale every light's emitter size; 0 makes all lights hard.
    #[arg(long, default_value_t = 1.0)]
    emitter_scale: f32,
    /// Emissive planar rectangles of a model become rect lights.
    #[arg(long)]
    emissive_lights: bool,
    /// A candidate technique spec (repeatable; default: hard, pcf, pcss, smoothies, volumes,
    /// lightmaps:samples=16, lightmaps, sampled:samples=16,mode=array, cascaded:splits=4). A light
    /// skips the candidates it does not support.
    #[arg(long = "candidate", value_name = "SPEC")]
    candidates: Vec<String>,
    /// Set a parameter on every candidate that has it.
    #[arg(long = "set", value_name = "K=V")]
    set: Vec<String>,
    /// Reference emitter samples per pixel (area lights).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=65536))]
    samples: u32,
    /// Reference seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Timed frames per (light, candidate, view), uncached and cached each (the median counts).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    frames: u32,
    /// Untimed frames before timing.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(0..=100))]
    warmup: u32,
    /// The calibration file to write; `report.html` goes beside it.
    #[arg(long, default_value = "out/calibrate/cal.json")]
    out: PathBuf,
}

/// `cal.json` (docs/calibration-format.md): keep names stable, add, never rename.
#[derive(Debug, Serialize, Deserialize)]
pub struct CalibrationFile {
    pub scene: String,
    /// The `--scene` argument as given (options included).
    #[serde(default)]
    pub scene_spec: Option<String>,
    pub views: Vec<String>,
    pub width: u32,
    pub height: u32,
    pub adapter: AdapterEntry,
    pub reference: ReferenceEntry,
    #[serde(default)]
    pub emitter_scale: Option<f32>,
    #[serde(default)]
    pub frames: Option<u32>,
    #[serde(default)]
    pub warmup: Option<u32>,
    /// `gpu` (timestamp queries) or `cpu` (wall clock: the adapter has no timestamps).
    #[serde(default)]
    pub time_source: Option<String>,
    /// Median over views of the `none` frame, uncached and cached (ms).
    #[serde(default, deserialize_with = "nan_if_null")]
    pub none_ms: f64,
    #[serde(default, deserialize_with = "nan_if_null")]
    pub none_still_ms: f64,
    /// The budget `--technique auto` takes when none is given: 4 × Σ lights' `hard` cost.
    #[serde(default, deserialize_with = "nan_if_null")]
    pub default_budget_ms: f64,
    pub lights: Vec<LightEntry>,
}

#[derive(Debug, Serialize, Deserialize)]
pub struct AdapterEntry {
    pub name: String,
    pub backend: String,
    pub device_type: String,
}

#[derive(Debug, Serialize, Deserialize)]
pub struct ReferenceEntry {
    pub samples: u32,
    pub seed: u64,
}

#[derive(Debug, Serialize, Deserialize)]
pub struct LightEntry {
    pub index: u32,
    pub name: String,
    #[serde(rename = "type")]
    pub light_type: String,
    /// Relevant pixels over all views (the pixels the errors are over).
    #[serde(default)]
    pub relevant_pixels: u64,
    pub candidates: Vec<CandidateEntry>,
    /// Candidates that failed on this light (left out of `candidates`), with the error.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub failed: Vec<FailedEntry>,
}

#[derive(Debug, Serialize, Deserialize)]
pub struct FailedEntry {
    pub spec: String,
    pub view: String,
    pub error: String,
}

#[derive(Debug, Serialize, Deserialize)]
pub struct CandidateEntry {
    pub spec: String,
    #[serde(deserialize_with = "nan_if_null")]
    pub cost_ms: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub still_ms: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub rmse: f64,
    #[serde(deserialize_with = "nan_if_null")]
    pub wrong_frac: f64,
    pub memory_bytes: u64,
}

/// JSON has no NaN (serde_json writes it as null): null reads back as NaN.
fn nan_if_null<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

impl CalibrationFile {
    /// The figures `shadowlab::auto` chooses from.
    pub fn calibration(&self) -> Calibration {
        Calibration {
            scene: self.scene.clone(),
            lights: self
                .lights
                .iter()
                .map(|l| LightFigures {
                    index: l.index,
                    name: l.name.clone(),
                    light_type: l.light_type.clone(),
                    candidates: l
                        .candidates
                        .iter()
                        .map(|c| CandidateFigures {
                            spec: c.spec.clone(),
                            cost_ms: c.cost_ms,
                            still_ms: c.still_ms,
                            rmse: c.rmse,
                            wrong_frac: c.wrong_frac,
                            memory_bytes: c.memory_bytes,
                        })
                        .collect(),
                })
                .collect(),
        }
    }
}

/// Reads a calibration file written by `shadowlab calibrate`.
pub fn read_calibration(path: &Path) -> Result<Calibration> {
    let bytes =
        shadowlab_core::read_regular(path).with_context(|| format!("reading calibration {}", path.display()))?;
    let file: CalibrationFile =
        serde_json::from_slice(&bytes).with_context(|| format!("calibration {}", path.display()))?;
    Ok(file.calibration())
}

/// One (light, candidate)'s figures over the views.
struct Accumulated {
    spec: TechniqueSpec,
    costs: Vec<f64>,
    stills: Vec<f64>,
    stats: ErrorStats,
    memory_bytes: u64,
    /// The first failure (view, error): the candidate is then left out.
    failed: Option<(String, String)>,
}

pub fn run(global: &GlobalArgs, args: Args) -> Result<()> {
    let scene_args = SceneArgs {
        scene: args.scene.clone(),
        view: None,
        camera: None,
        size: args.size,
        lights: args.lights.clone(),
        emitter_scale: args.emitter_scale,
        emissive_lights: args.emissive_lights,
        light_meshes: None,
        map_budget: crate::args::DEFAULT_MAP_BUDGET_MIB,
    };
    let mut setup = scene_args.load()?;
    let views: Vec<shadowlab_core::View> = if args.views.is_empty() {
        setup.scene.views.iter().take(MAX_DEFAULT_VIEWS).cloned().collect()
    } else {
        args.views
            .iter()
            .map(|name| {
                setup.scene.view(name.trim()).cloned().with_context(|| {
                    let known: Vec<&str> = setup.scene.views.iter().map(|v| v.name.as_str()).collect();
                    format!("scene '{}' has no view '{name}' (views: {})", setup.scene.name, known.join(", "))
                })
            })
            .collect::<Result<_>>()?
    };
    if views.is_empty() {
        bail!("scene '{}' has no views", setup.scene.name);
    }
    let given: Vec<String> = if args.candidates.is_empty() {
        auto::CANDIDATES.iter().map(|s| (*s).to_owned()).collect()
    } else {
        args.candidates.clone()
    };
    if given.iter().any(|s| s == crate::args::AUTO) {
        bail!("--candidate auto: candidates are techniques");
    }
    let specs = given.iter().map(|s| TechniqueSpec::parse(s, &args.set)).collect::<Result<Vec<_>, _>>()?;
    shadowlab::registry::check_global_sets(&specs, &args.set)?;
    let lights = setup.lights.clone();
    // Per light, the candidates it supports.
    let mut table: Vec<(LightId, Vec<Accumulated>)> = lights
        .iter()
        .map(|id| {
            let light = &setup.scene.lights[id.index()];
            let cands = specs
                .iter()
                .filter(|s| s.info.supports(light))
                .map(|s| Accumulated {
                    spec: s.clone(),
                    costs: Vec::new(),
                    stills: Vec::new(),
                    stats: ErrorStats::default(),
                    memory_bytes: 0,
                    failed: None,
                })
                .collect();
            (*id, cands)
        })
        .collect();
    for s in specs.iter().filter(|_| !args.candidates.is_empty()) {
        if !lights.iter().any(|id| s.info.supports(&setup.scene.lights[id.index()])) {
            eprintln!("warning: candidate '{}' supports none of the calibrated lights", s.spec);
        }
    }
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let gpu = open_gpu(global)?;
    let (frames, warmup) = (args.frames as usize, args.warmup as usize);
    let settings = ReferenceSettings { samples: args.samples, seed: args.seed };
    let none = TechniqueSpec::parse("none", &[])?;
    let runs: usize = 1 + table.iter().map(|(_, c)| c.len()).sum::<usize>();
    let bar = progress::bar((views.len() * runs * 2 * (warmup + frames)) as u64, "calibrate (GPU)");
    let bvh = SceneBvh::build(&setup.scene, Selection::Casters);
    let mut none_ms = Vec::new();
    let mut none_still_ms = Vec::new();
    let mut relevant = vec![0u64; lights.len()];
    let mut timed_on_gpu = true;
    for view in &views {
        setup.view = view.clone();
        setup.lights = lights.clone();
        // 1. The surface and the truth on it.
        bar.set_message(format!("{}: reference", view.name));
        let mut base = renderer(&gpu, &setup, &none)?;
        base.render()?;
        let surface = base.read_surface()?;
        drop(base);
        let refs: Vec<(u32, &shadowlab_core::Light)> =
            lights.iter().map(|id| (id.0, &setup.scene.lights[id.index()])).collect();
        let truth = reference(&bvh, &surface, &refs, &settings, None);
        // 2. The floor.
        bar.set_message(format!("{}: none", view.name));
        let floor = measure(&gpu, &setup, &Selected::Spec(none.clone()), warmup, frames, &|| bar.inc(1))?;
        timed_on_gpu &= floor.timing.gpu_median.is_some();
        let (floor_ms, floor_still) = (floor.timing.frame_ms(), floor.cached.frame_ms());
        none_ms.push(floor_ms);
        none_still_ms.push(floor_still);
        drop(floor);
        // 3. Each light alone with each candidate.
        for (k, (id, cands)) in table.iter_mut().enumerate() {
            setup.lights = vec![*id];
            let truth_values = &truth.lights[k].values;
            relevant[k] += truth_values.iter().filter(|v| !v.is_nan()).count() as u64;
            for c in cands.iter_mut() {
                if c.failed.is_some() {
                    bar.inc((2 * (warmup + frames)) as u64);
                    continue;
                }
                bar.set_message(format!("{}: light {} {}", view.name, id.0, c.spec.spec));
                // A candidate that fails on a light (a limit of the adapter, a scene it cannot
                // handle) is left out for that light, and said so; the others go on.
                let m = match measure(&gpu, &setup, &Selected::Spec(c.spec.clone()), warmup, frames, &|| bar.inc(1)) {
                    Ok(m) => m,
                    Err(e) => {
                        // One line: wgpu's validation errors span several.
                        let text = format!("{e:#}").split_whitespace().collect::<Vec<_>>().join(" ");
                        bar.suspend(|| {
                            eprintln!(
                                "warning: candidate '{}' failed on light {} in view '{}', left out: {text}",
                                c.spec.spec, id.0, view.name
                            )
                        });
                        c.failed = Some((view.name.clone(), text));
                        continue;
                    }
                };
                timed_on_gpu &= m.timing.gpu_median.is_some();
                let v = m.renderer.read_visibility(*id)?.context("light without a visibility layer")?;
                c.stats.merge(&ErrorStats::compare(&v, truth_values));
                c.costs.push(m.timing.frame_ms() - floor_ms);
                c.stills.push(m.cached.frame_ms() - floor_still);
                c.memory_bytes = c.memory_bytes.max(m.renderer.shadows.stats().memory_bytes);
            }
        }
    }
    bar.finish_and_clear();
    setup.lights = lights.clone();

    // A negative difference is timing noise around a cost of about 0.
    let cost = |v: &[f64]| median(v.to_vec()).max(0.0);
    let file = CalibrationFile {
        scene: setup.scene.name.clone(),
        scene_spec: Some(args.scene.clone()),
        views: views.iter().map(|v| v.name.clone()).collect(),
        width: setup.width,
        height: setup.height,
        adapter: AdapterEntry {
            name: gpu.adapter.name.clone(),
            backend: gpu.adapter.backend.clone(),
            device_type: gpu.adapter.device_type.clone(),
        },
        reference: ReferenceEntry { samples: args.samples, seed: args.seed },
        emitter_scale: Some(args.emitter_scale),
        frames: Some(args.frames),
        warmup: Some(args.warmup),
        time_source: Some(if timed_on_gpu { "gpu" } else { "cpu" }.to_owned()),
        none_ms: median(none_ms),
        none_still_ms: median(none_still_ms),
        default_budget_ms: f64::NAN,
        lights: table
            .iter()
            .zip(&relevant)
            .map(|((id, cands), &relevant_pixels)| {
                let light = &setup.scene.lights[id.index()];
                LightEntry {
                    index: id.0,
                    name: light.name.clone(),
                    light_type: light.type_name().to_owned(),
                    relevant_pixels,
                    candidates: cands
                        .iter()
                        .filter(|c| c.failed.is_none())
                        .map(|c| CandidateEntry {
                            spec: c.spec.spec.clone(),
                            cost_ms: cost(&c.costs),
                            still_ms: cost(&c.stills),
                            rmse: c.stats.rmse(),
                            wrong_frac: c.stats.wrong_frac(),
                            memory_bytes: c.memory_bytes,
                        })
                        .collect(),
                    failed: cands
                        .iter()
                        .filter_map(|c| {
                            let (view, error) = c.failed.clone()?;
                            Some(FailedEntry { spec: c.spec.spec.clone(), view, error })
                        })
                        .collect(),
                }
            })
            .collect(),
    };
    let calibration = file.calibration();
    let file = CalibrationFile { default_budget_ms: calibration.default_budget_ms(), ..file };
    std::fs::write(&args.out, serde_json::to_string_pretty(&file)?)
        .with_context(|| format!("writing {}", args.out.display()))?;
    let html_path = args.out.with_file_name("report.html");
    std::fs::write(&html_path, report_html(&file, &calibration))
        .with_context(|| format!("writing {}", html_path.display()))?;
    print_summary(&file, &calibration);
    println!("→ {} and {}", args.out.display(), html_path.display());
    Ok(())
}

/// Per light: candidates by cost, with the default budget's choice.
fn print_summary(file: &CalibrationFile, calibration: &Calibration) {
    let budget = calibration.default_budget_ms();
    let choices = auto::choose(calibration, budget, Preference::Balanced);
    println!(
        "{} at {}x{}, views {}, {} ms per frame ({}), none frame {:.3} ms",
        file.scene,
        file.width,
        file.height,
        file.views.join(", "),
        file.time_source.as_deref().unwrap_or("?").to_uppercase(),
        file.adapter.name,
        file.none_ms
    );
    for (l, choice) in file.lights.iter().zip(&choices) {
        println!("light {} '{}' ({}):", l.index, l.name, l.light_type);
        println!("  {:<34} {:>9} {:>9} {:>8} {:>8} {:>9}", "candidate", "cost ms", "still ms", "RMSE", "wrong%", "MiB");
        let mut order: Vec<&CandidateEntry> = l.candidates.iter().collect();
        order.sort_by(|a, b| a.cost_ms.total_cmp(&b.cost_ms));
        for c in order {
            println!(
                "{} {:<34} {:>9.3} {:>9.3} {:>8.4} {:>8.2} {:>9.1}",
                if c.spec == choice.spec { "*" } else { " " },
                c.spec,
                c.cost_ms,
                c.still_ms,
                c.rmse,
                100.0 * c.wrong_frac,
                c.memory_bytes as f64 / (1024.0 * 1024.0)
            );
        }
        for f in &l.failed {
            println!("  {:<34} failed in view '{}', left out: {}", f.spec, f.view, f.error);
        }
    }
    println!("default budget {budget:.3} ms (4 × Σ hard), equal shares:");
    for c in &choices {
        println!("  light {} '{}' → {}: {}", c.light, c.name, c.spec, c.reason);
    }
}

fn report_html(file: &CalibrationFile, calibration: &Calibration) -> String {
    let budget = calibration.default_budget_ms();
    let mut sections = String::new();
    let choices = auto::choose(calibration, budget, Preference::Balanced);
    let choice_rows: Vec<Vec<String>> = choices
        .iter()
        .map(|c| {
            vec![
                report::escape(&format!("{} '{}'", c.light, c.name)),
                report::escape(&c.spec),
                format!("{:.3}", c.share_ms),
                format!("{:.3}", c.cost_ms),
                format!("{:.4}", c.rmse),
                report::escape(&c.reason),
            ]
        })
        .collect();
    sections.push_str(&format!(
        "<h2>--technique auto at the default budget ({budget:.3} ms, balanced)</h2>{}",
        report::table(&["light", "spec", "share ms", "cost ms", "RMSE", "why"], &choice_rows)
    ));
    for (l, choice) in file.lights.iter().zip(&choices) {
        let hard = l.candidates.iter().find(|c| c.spec == "hard").map(|c| c.cost_ms);
        let rows: Vec<Vec<String>> = l
            .candidates
            .iter()
            .map(|c| {
                vec![
                    format!("{}{}", report::escape(&c.spec), if c.spec == choice.spec { " ◀" } else { "" }),
                    format!("{:.3}", c.cost_ms),
                    hard.filter(|h| *h > 0.0).map(|h| format!("{:.2}", c.cost_ms / h)).unwrap_or_else(|| "–".into()),
                    format!("{:.3}", c.still_ms),
                    format!("{:.4}", c.rmse),
                    format!("{:.2}%", 100.0 * c.wrong_frac),
                    format!("{:.1}", c.memory_bytes as f64 / (1024.0 * 1024.0)),
                ]
            })
            .collect();
        sections.push_str(&format!(
            "<h3>light {} '{}' ({}, {} relevant pixels)</h3>{}",
            l.index,
            report::escape(&l.name),
            report::escape(&l.light_type),
            l.relevant_pixels,
            report::table(&["candidate", "cost ms", "× hard", "still ms", "RMSE", "wrong", "MiB"], &rows)
        ));
        for f in &l.failed {
            sections.push_str(&format!(
                "<p class=\"note\">{} failed in view '{}' and is left out: {}</p>",
                report::escape(&f.spec),
                report::escape(&f.view),
                report::escape(&f.error)
            ));
        }
    }
    format!(
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>shadowlab calibrate: {scene}</title><style>{style}</style></head><body>\
<h1>shadowlab calibrate: {scene}</h1>\
<p>{w}×{h} pixels · views: {views} · adapter: {adapter} ({backend}, {dtype}) · times: {source} · reference: {samples} samples, seed {seed} · none frame {none:.3} ms</p>\
<p class=\"note\">Per light, each candidate alone (the other lights <code>none</code>): cost = the median over views of its uncached frame minus the <code>none</code> frame; still = the same with the cache on; RMSE and wrong (|V − V<sub>ref</sub>| &gt; 0.1) over the light's relevant pixels of all views; memory the largest over views. ◀ marks the default budget's choice. On a CPU adapter only ratios mean anything.</p>\
{sections}</body></html>",
        scene = report::escape(&file.scene),
        style = report::STYLE,
        w = file.width,
        h = file.height,
        views = report::escape(&file.views.join(", ")),
        adapter = report::escape(&file.adapter.name),
        backend = report::escape(&file.adapter.backend),
        dtype = report::escape(&file.adapter.device_type),
        source = file.time_source.as_deref().unwrap_or(""),
        samples = file.reference.samples,
        seed = file.reference.seed,
        none = file.none_ms,
    )
}
