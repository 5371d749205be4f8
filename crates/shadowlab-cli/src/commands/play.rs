//! `shadowlab play`: a timeline of edits over frames on the live engine (DESIGN.md §11), measured
//! frame by frame: time, the work each frame re-did, the cache's memory, and at checks the live
//! engine against a fresh uncached one and against the ray-traced truth on the same surface.
//!
//! 1. Load the scene, read the timeline (built-in or file) and resolve it whole ([`timeline`]):
//!    every error is found before the GPU opens.
//! 2. With `--target-ms`, set the engine's target frame time (`auto`: first measure frames with
//!    `hard` on every light in a renderer of their own): cache fills are then spread over frames.
//! 3. Per frame: apply the frame's steps (edits, a light added and shadowed, resize, camera),
//!    render, record time, work, budget, each light's quality level and memory; at checks read the
//!    surface and compare.
//! 4. Write `timeline.json`, `timeline.svg`, `report.html` and the timeline as run
//!    (`timeline.toml`).

pub mod timeline;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail, ensure};
use serde_json::{Value, json};
use shadowlab::auto::Preference;
use shadowlab::timing::PassKind;
use shadowlab::{Edit, Renderer, TechniqueSpec};
use shadowlab_core::LightId;
use shadowlab_reference::metrics::ErrorStats;
use shadowlab_reference::{ReferenceSettings, SceneBvh, Selection, reference};

use crate::args::{AUTO, GlobalArgs, SceneArgs, Selected, TechniqueArgs, choice_json, open_gpu, parse_size};
use crate::measure::median;
use crate::progress;
use crate::report;
use timeline::{BUILT_IN, DragMode, Plan, Step};

/// The technique set on every light when none is given.
pub const DEFAULT_TECHNIQUE: &str = "lightmaps";
/// `--target-ms auto`: frames of `hard` on every light measured (their median is taken, so the
/// first one, which compiles the pipelines, does not count).
pub const AUTO_TARGET_FRAMES: usize = 10;
/// `--target-ms auto`: the target is this many times the median frame with `hard`.
pub const AUTO_TARGET_FACTOR: f64 = 2.0;

/// `--target-ms`: a frame time in ms, or `auto`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Target {
    Auto,
    Ms(f64),
}

impl Target {
    fn json(self) -> Value {
        match self {
            Target::Auto => json!("auto"),
            Target::Ms(ms) => json!(ms),
        }
    }
}

/// Reads `--target-ms`: `auto`, or a finite number of ms above 0.
pub fn parse_target(text: &str) -> Result<Target, String> {
    let t = text.trim();
    if t.eq_ignore_ascii_case("auto") {
        return Ok(Target::Auto);
    }
    match t.parse::<f64>() {
        Ok(ms) if ms.is_finite() && ms > 0.0 => Ok(Target::Ms(ms)),
        Ok(_) => Err(format!("{text} ms is not a frame time: give a finite number of ms above 0, or `auto`")),
        Err(_) => Err(format!("'{text}' is neither a number of ms nor `auto`")),
    }
}

#[derive(clap::Args, Debug)]
pub struct Args {
    /// A built-in scene (`shadowlab scenes`), optionally with options (`room:lamps=8`), or a
    /// .toml, .gltf, .glb or .obj file.
    #[arg(long, default_value = "room")]
    scene: String,
    /// The view the timeline starts from (default: the scene's first view).
    #[arg(long)]
    view: Option<String>,
    /// `drag`, `lights`, `walk`, `startup`, `resize` (built in) or a timeline file
    /// (docs/timeline-format.md).
    #[arg(long)]
    timeline: String,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "160x120", value_parser = parse_size)]
    size: (u32, u32),
    #[command(flatten)]
    techniques: TechniqueArgs,
    /// Compare with a fresh engine and the truth every K frames (and on and after every event);
    /// 0: never.
    #[arg(long, default_value_t = 30)]
    check_every: u32,
    /// Reference emitter samples per pixel at checks (area lights).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=65536))]
    samples: u32,
    /// Reference seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Run with caching off: every frame rebuilds everything (the uncached baseline).
    #[arg(long)]
    no_cache: bool,
    /// Drag objects as a series of permanent moves instead of temporary objects (Toromanoff's
    /// configuration 1: every move invalidates the caches it reaches).
    #[arg(long)]
    drag_as_permanent: bool,
    /// Scale every light's emitter size; 0 makes all lights hard.
    #[arg(long, default_value_t = 1.0)]
    emitter_scale: f32,
    /// Emissive planar rectangles of a model become rect lights.
    #[arg(long)]
    emissive_lights: bool,
    /// Light meshes from `shadowlab precompute` for `lightmesh` (as `compare --light-meshes`).
    #[arg(long, value_name = "FILE")]
    light_meshes: Option<std::path::PathBuf>,
    /// GPU memory the shadow maps may take together, in MiB (0: no limit; as `compare --map-budget`).
    #[arg(long, value_name = "MIB", default_value_t = crate::args::DEFAULT_MAP_BUDGET_MIB)]
    map_budget: u64,
    /// Keep frames to a target time: MS, or `auto` (2 × the median time of a frame with `hard` on
    /// every light, measured first). Cache fills are spread over frames; a light shows its last
    /// complete state until the new one is complete. `--preference` scales it: quality ×2,
    /// balanced ×1, speed ×0.5.
    #[arg(long, value_name = "MS|auto", value_parser = parse_target, allow_hyphen_values = true)]
    target_ms: Option<Target>,
    /// Play the timeline this many times, each on a new engine, and report each frame's least
    /// time over the runs beside the first run's (`frames[].frame_ms_least`,
    /// `summary.least_over_runs`): a shared machine's interruptions only add time, so the least
    /// measures the engine. Checks run in the first run only.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    runs: u32,
    /// Check the timeline and print its events per frame as JSON, without a GPU.
    #[arg(long)]
    dry_run: bool,
    /// Output directory.
    #[arg(long, default_value = "out/play")]
    out: PathBuf,
}

/// One frame's measurements.
struct FrameRecord {
    gpu_ms: Option<f64>,
    cpu_ms: f64,
    record_ms: f64,
    /// The shadow passes' GPU time (the fills), without timestamps `None`.
    work_ms: Option<f64>,
    work: shadowlab::Work,
    cache_bytes: u64,
    width: u32,
    height: u32,
    /// Every shadowed light's quality after the frame, in id order.
    lights: Vec<LightLevel>,
}

/// One light's quality in one frame ([`shadowlab::Shadows::levels`]).
#[derive(Debug, Clone, PartialEq)]
struct LightLevel {
    id: LightId,
    name: String,
    /// Its index in the scene's lights.
    index: Option<usize>,
    /// The technique's spec, as given.
    technique: String,
    /// 0: no shadow (nothing complete yet); 1: the technique's base; higher: its upgrades.
    level: u32,
    /// Emitter samples behind the level (0 where that means nothing).
    samples: u32,
    /// What it shows is the scene's current state (no fill pending).
    current: bool,
}

/// The frame time the run keeps to, and where it came from.
struct TargetInfo {
    given: Target,
    preference: Preference,
    /// With `auto`: the median frame with `hard` on every light, and its time source.
    hard: Option<(f64, &'static str)>,
    /// The target the engine gets: given (or 2 × the `hard` frame) × the preference's factor.
    ms: f64,
}

impl TargetInfo {
    fn json(&self) -> Value {
        json!({
            "given": self.given.json(),
            "hard_frame_ms": self.hard.map(|h| h.0),
            "hard_frame_source": self.hard.map(|h| h.1),
            "hard_frames": self.hard.map(|_| AUTO_TARGET_FRAMES),
            "auto_factor": self.hard.map(|_| AUTO_TARGET_FACTOR),
            "preference": self.preference.name(),
            "preference_factor": self.preference.budget_factor(),
            "target_ms": self.ms,
        })
    }
}

/// One check's figures, pooled over the measured lights.
struct Check {
    frame: usize,
    vs_fresh: ErrorStats,
    vs_truth: ErrorStats,
}

pub fn run(global: &GlobalArgs, args: Args) -> Result<()> {
    let scene_args = SceneArgs {
        scene: args.scene.clone(),
        view: args.view.clone(),
        camera: None,
        size: args.size,
        lights: Vec::new(),
        emitter_scale: args.emitter_scale,
        emissive_lights: args.emissive_lights,
        light_meshes: args.light_meshes.clone(),
        map_budget: args.map_budget,
    };
    let setup = scene_args.load()?;
    // `--preference` scales the `auto` budget with `--technique auto` and the target with
    // `--target-ms` (both with both): the same factor, on the time each gives.
    let wants_auto = args.techniques.technique.iter().chain(&args.techniques.techniques).any(|s| s.trim() == AUTO);
    let preference = match &args.techniques.preference {
        Some(p) => Some(Preference::parse(p).with_context(|| format!("--preference {p}"))?),
        None => None,
    };
    if preference.is_some() && !wants_auto && args.target_ms.is_none() {
        bail!("--preference goes with --technique auto (it scales the budget) or --target-ms (it scales the target)");
    }
    let mut technique_args = args.techniques.clone();
    if !wants_auto {
        technique_args.preference = None;
    }
    let preference = preference.unwrap_or_default();
    let specs = technique_args.selected(&setup, &[DEFAULT_TECHNIQUE])?;
    let (name, text) = read_timeline(&args.timeline, &setup.scene, (setup.width, setup.height))?;
    let mode = if args.drag_as_permanent { DragMode::Permanent } else { DragMode::Temporary };
    let plan = timeline::parse(&text)
        .and_then(|t| timeline::plan(&t, &setup.scene, mode))
        .with_context(|| format!("timeline {name}"))?;
    if args.dry_run {
        let events: Vec<Value> = plan
            .frames
            .iter()
            .enumerate()
            .filter(|(_, f)| f.has_event())
            .map(|(i, f)| json!({ "frame": i, "events": f.events }))
            .collect();
        let target = args.target_ms.map(|t| {
            json!({ "given": t.json(), "preference": preference.name(), "preference_factor": preference.budget_factor() })
        });
        let out = json!({
            "timeline": name, "scene": setup.scene.name, "frames": plan.frames.len(), "target": target, "events": events,
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    std::fs::write(args.out.join("timeline.toml"), &text)?;
    let gpu = open_gpu(global)?;
    let target = match args.target_ms {
        None => None,
        Some(given) => {
            let hard = match given {
                Target::Auto => Some(hard_frame_ms(&gpu, &setup).context("--target-ms auto: timing `hard`")?),
                Target::Ms(_) => None,
            };
            let base = match (given, hard) {
                (Target::Ms(ms), _) => ms,
                (Target::Auto, Some((ms, _))) => AUTO_TARGET_FACTOR * ms,
                (Target::Auto, None) => unreachable!("measured above"),
            };
            let ms = base * preference.budget_factor();
            ensure!(ms.is_finite() && ms > 0.0, "--target-ms: the target came out as {ms} ms");
            let info = TargetInfo { given, preference, hard, ms };
            match hard {
                Some((h, source)) => println!(
                    "target: {ms:.3} ms = {AUTO_TARGET_FACTOR} × {h:.3} {source} ms (median frame with `hard`) × {} ({})",
                    preference.budget_factor(),
                    preference.name()
                ),
                None => {
                    println!("target: {ms:.3} ms = {base} ms × {} ({})", preference.budget_factor(), preference.name())
                }
            }
            Some(info)
        }
    };
    if let Some(plan) = specs.iter().find_map(Selected::auto) {
        for line in plan.describe() {
            println!("{line}");
        }
    }
    let settings = ReferenceSettings { samples: args.samples, seed: args.seed };
    let first =
        play_once(&gpu, &setup, &args, &specs, &plan, target.as_ref(), preference, Some(&settings), "timeline (GPU)")?;
    let Run { records, checks, auto_added } = first;
    // Each frame's least time over the runs: interruptions of a shared machine only add time.
    let mut least: Vec<f64> = ms(&records, records.iter().all(|r| r.gpu_ms.is_some()));
    let mut same_work = true;
    for run in 1..args.runs {
        let again = play_once(
            &gpu,
            &setup,
            &args,
            &specs,
            &plan,
            target.as_ref(),
            preference,
            None,
            &format!("run {} of {}", run + 1, args.runs),
        )?;
        let gpu_timed = again.records.iter().all(|r| r.gpu_ms.is_some());
        for (l, t) in least.iter_mut().zip(ms(&again.records, gpu_timed)) {
            *l = l.min(t);
        }
        same_work &= again.records.iter().zip(&records).all(|(a, b)| a.work.counts() == b.work.counts());
    }
    let runs = (args.runs > 1).then_some(Runs { count: args.runs, least, same_work });

    let mut doc =
        document(&args, &name, &setup, &specs, &gpu, &plan, &records, &checks, target.as_ref(), runs.as_ref());
    if let Some(p) = specs.iter().find_map(Selected::auto) {
        let mut choices = p.choices_json();
        if let Some(list) = choices.as_array_mut() {
            list.extend(auto_added);
        }
        doc["auto"] = choices;
        doc["auto_budget"] = p.settings_json();
    }
    std::fs::write(args.out.join("timeline.json"), serde_json::to_string_pretty(&doc)?)?;
    let svg = plot(&plan, &records, doc["time_source"].as_str().unwrap_or("cpu"), target.as_ref().map(|t| t.ms))?;
    std::fs::write(args.out.join("timeline.svg"), &svg)?;
    std::fs::write(args.out.join("report.html"), report_html(&doc, &svg))?;
    print_summary(&doc);
    println!("→ {}", args.out.join("report.html").display());
    Ok(())
}

/// One run of the timeline on a new engine.
struct Run {
    records: Vec<FrameRecord>,
    checks: Vec<Check>,
    auto_added: Vec<Value>,
}

/// All runs of the timeline (`--runs`): each frame's least time over them.
struct Runs {
    count: u32,
    least: Vec<f64>,
    /// Every run did the same work in every frame (a target can make runs differ).
    same_work: bool,
}

/// Plays the timeline once on a new engine; checks (with `settings`) every `--check-every` frames.
#[allow(clippy::too_many_arguments)]
fn play_once(
    gpu: &shadowlab::Gpu,
    setup: &crate::args::Setup,
    args: &Args,
    specs: &[Selected],
    plan: &Plan,
    target: Option<&TargetInfo>,
    preference: Preference,
    settings: Option<&ReferenceSettings>,
    label: &str,
) -> Result<Run> {
    let mut r = Renderer::new(gpu, setup.scene.clone(), &setup.view, setup.width, setup.height);
    r.provide_light_meshes(setup.light_meshes.clone());
    r.shadows.set_map_budget(setup.map_budget);
    r.shadows.set_caching(!args.no_cache);
    // The engine scales the target by the preference itself (the factors are powers of two: exact).
    r.set_target_ms(target.map(|t| t.ms / preference.budget_factor()));
    r.shadows.set_preference(preference);
    let none = TechniqueSpec::parse("none", &[])?;
    // `auto` on lights the timeline adds: what each got, and why.
    let mut auto_added = Vec::new();
    let mut measured = Vec::new();
    for i in 0..setup.scene.lights.len() as u32 {
        if shadow_light(&mut r, LightId(i), specs, &none, &mut auto_added)? {
            measured.push(LightId(i));
        }
    }
    let k = if settings.is_some() { args.check_every as usize } else { 0 };
    let checked = |f: usize| {
        k > 0 && (f.is_multiple_of(k) || plan.frames[f].has_event() || (f > 0 && plan.frames[f - 1].has_event()))
    };

    let bar = progress::bar(plan.frames.len() as u64, label);
    let mut records = Vec::with_capacity(plan.frames.len());
    let mut checks = Vec::new();
    for (f, fp) in plan.frames.iter().enumerate() {
        for step in &fp.steps {
            apply(&mut r, step, specs, &none, &mut measured, &mut auto_added).with_context(|| format!("frame {f}"))?;
        }
        let report = r.render().with_context(|| format!("frame {f}"))?;
        records.push(FrameRecord {
            gpu_ms: report.gpu.as_ref().map(|t| t.total()),
            cpu_ms: report.cpu_ms,
            record_ms: report.record_ms,
            work_ms: report.gpu.as_ref().map(|t| t.get(PassKind::Shadow)),
            work: report.work,
            cache_bytes: r.shadows.memory_bytes(),
            width: r.width,
            height: r.height,
            lights: light_levels(&r),
        });
        if let Some(settings) = settings.filter(|_| checked(f)) {
            bar.set_message(format!("check at frame {f}"));
            checks.push(check(&r, f, &measured, settings).with_context(|| format!("check at frame {f}"))?);
            bar.set_message(label.to_owned());
        }
        bar.inc(1);
    }
    bar.finish_and_clear();

    Ok(Run { records, checks, auto_added })
}

/// The median time (and its source: `gpu` when every frame has timestamps, else `cpu`) of
/// [`AUTO_TARGET_FRAMES`] frames of the scene with `hard` on every light it supports, uncached (every
/// map rendered every frame), in a renderer of their own: what `--target-ms auto` doubles.
fn hard_frame_ms(gpu: &shadowlab::Gpu, setup: &crate::args::Setup) -> Result<(f64, &'static str)> {
    let mut r = Renderer::new(gpu, setup.scene.clone(), &setup.view, setup.width, setup.height);
    r.provide_light_meshes(setup.light_meshes.clone());
    r.shadows.set_map_budget(setup.map_budget);
    r.shadows.set_caching(false);
    let hard = TechniqueSpec::parse("hard", &[])?;
    let none = TechniqueSpec::parse("none", &[])?;
    for (i, light) in setup.scene.lights.iter().enumerate() {
        let spec = if hard.info.supports(light) { &hard } else { &none };
        r.set_technique(LightId(i as u32), spec).with_context(|| format!("light '{}'", light.name))?;
    }
    let mut reports = Vec::with_capacity(AUTO_TARGET_FRAMES);
    for _ in 0..AUTO_TARGET_FRAMES {
        reports.push(r.render()?);
    }
    let timed = reports.iter().all(|f| f.gpu.is_some());
    let times: Vec<f64> =
        reports.iter().map(|f| if timed { f.gpu.as_ref().map_or(f64::NAN, |t| t.total()) } else { f.cpu_ms }).collect();
    Ok((median(times), if timed { "gpu" } else { "cpu" }))
}

/// Every shadowed light's quality level after the frame just rendered.
fn light_levels(r: &Renderer) -> Vec<LightLevel> {
    let live = r.shadows.live();
    r.shadows
        .levels()
        .into_iter()
        .map(|(id, level, current, samples)| LightLevel {
            id,
            name: live.light(id).map_or_else(String::new, |l| l.name.clone()),
            index: live.light_index(id),
            technique: r.shadows.spec(id).map_or_else(String::new, |s| s.spec.clone()),
            level,
            samples,
            current,
        })
        .collect()
}

/// The timeline's name and text: a built-in for the scene, or a file.
fn read_timeline(spec: &str, scene: &shadowlab_core::Scene, size: (u32, u32)) -> Result<(String, String)> {
    let path = Path::new(spec);
    // A built-in's name is never taken for a file of that name in the working directory.
    let is_file = spec.contains(['/', '\\']) || spec.ends_with(".toml") || (!BUILT_IN.contains(&spec) && path.exists());
    if !is_file {
        return match timeline::built_in(spec, scene, size)
            .with_context(|| format!("built-in timeline '{spec}' on scene '{}'", scene.name))?
        {
            Some(text) => Ok((spec.to_owned(), text)),
            None => bail!("no built-in timeline '{spec}' (built in: {}; or a .toml file)", BUILT_IN.join(", ")),
        };
    }
    let bytes = shadowlab_core::read_regular(path).with_context(|| format!("reading timeline {}", path.display()))?;
    let text = String::from_utf8(bytes).with_context(|| format!("timeline {} is not UTF-8 text", path.display()))?;
    Ok((path.display().to_string(), text))
}

/// Shadows `id` with the last spec that supports it (`auto`: the light's choice; for a light the
/// timeline adds, the choice of the first light of its type, noted in `auto_added`), or leaves it
/// unshadowed (`none`) with a warning; returns whether it is measured (has a technique of the run).
fn shadow_light(
    r: &mut Renderer,
    id: LightId,
    specs: &[Selected],
    none: &TechniqueSpec,
    auto_added: &mut Vec<Value>,
) -> Result<bool> {
    let light = r.shadows.live().light(id).context("no such light")?.clone();
    let found = specs.iter().rev().find_map(|s| match s {
        Selected::Spec(spec) => spec.info.supports(&light).then(|| spec.clone()),
        Selected::Auto(plan) => plan.spec_for(id).cloned().or_else(|| {
            let (like, spec) = plan.like(&light)?;
            let mut choice = like.clone();
            choice.light = id.0;
            choice.name = light.name.clone();
            choice.reason =
                format!("added by the timeline: as {} light '{}' ({})", light.type_name(), like.name, like.reason);
            println!("auto: light {} '{}' → {}: {}", id.0, light.name, choice.spec, choice.reason);
            auto_added.push(choice_json(&choice));
            Some(spec.clone())
        }),
    });
    match found {
        Some(spec) => {
            r.set_technique(id, &spec).with_context(|| format!("light '{}'", light.name))?;
            Ok(true)
        }
        None => {
            eprintln!(
                "warning: no technique given supports {} light '{}': it stays unshadowed",
                light.type_name(),
                light.name
            );
            r.set_technique(id, none)?;
            Ok(false)
        }
    }
}

fn apply(
    r: &mut Renderer,
    step: &Step,
    specs: &[Selected],
    none: &TechniqueSpec,
    measured: &mut Vec<LightId>,
    auto_added: &mut Vec<Value>,
) -> Result<()> {
    match step {
        Step::Edit(edit) => {
            r.apply(edit.clone())?;
        }
        Step::AddLight { light, id } => {
            let applied = r.apply(Edit::AddLight(light.clone()))?;
            // The plan's dry run gave the ids the engine gives: later edits of this light use it.
            ensure!(applied.light == Some(*id), "light '{}' got id {:?}, the plan {:?}", light.name, applied.light, id);
            if shadow_light(r, *id, specs, none, auto_added)? {
                measured.push(*id);
            }
        }
        Step::Resize(w, h) => r.resize(*w, *h)?,
        Step::Camera(view) => r.set_view(view),
    }
    Ok(())
}

/// The live engine against a fresh uncached one (over each light's relevant pixels) and against
/// the ray-traced truth, on the surface of the frame just rendered, pooled over the measured lights.
fn check(r: &Renderer, frame: usize, measured: &[LightId], settings: &ReferenceSettings) -> Result<Check> {
    let surface = r.read_surface()?;
    let live = r.live_visibility()?;
    let fresh = r.fresh_visibility()?;
    let scene = r.scene();
    let indices: Vec<usize> = measured.iter().filter_map(|id| r.shadows.live().light_index(*id)).collect();
    let lights: Vec<(u32, &shadowlab_core::Light)> = indices.iter().map(|&i| (i as u32, &scene.lights[i])).collect();
    let bvh = SceneBvh::build(scene, Selection::Casters);
    let truth = reference(&bvh, &surface, &lights, settings, None);
    let (mut vs_fresh, mut vs_truth) = (ErrorStats::default(), ErrorStats::default());
    for (k, &i) in indices.iter().enumerate() {
        let find = |list: &[(usize, Vec<f32>)]| list.iter().find(|(j, _)| *j == i).map(|(_, v)| v.clone());
        let name = &scene.lights[i].name;
        let lv = find(&live).with_context(|| format!("light '{name}' has no live visibility"))?;
        let fv = find(&fresh).with_context(|| format!("light '{name}' has no fresh visibility"))?;
        vs_fresh.merge(&ErrorStats::compare_masked(&lv, &fv, &surface.relevance(&scene.lights[i])));
        vs_truth.merge(&ErrorStats::compare(&lv, &truth.lights[k].values));
    }
    Ok(Check { frame, vs_fresh, vs_truth })
}

fn ms(records: &[FrameRecord], gpu: bool) -> Vec<f64> {
    records.iter().map(|r| if gpu { r.gpu_ms.unwrap_or(f64::NAN) } else { r.cpu_ms }).collect()
}

/// A number, or null when not finite (JSON has no NaN).
fn finite(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

/// `timeline.json`.
#[allow(clippy::too_many_arguments)]
fn document(
    args: &Args,
    name: &str,
    setup: &crate::args::Setup,
    specs: &[Selected],
    gpu: &shadowlab::Gpu,
    plan: &Plan,
    records: &[FrameRecord],
    checks: &[Check],
    target: Option<&TargetInfo>,
    runs: Option<&Runs>,
) -> Value {
    let gpu_timed = records.iter().all(|r| r.gpu_ms.is_some());
    let times = ms(records, gpu_timed);
    let still = plan.still();
    let frames: Vec<Value> = records
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let fp = &plan.frames[i];
            json!({
                "index": i,
                "gpu_ms": r.gpu_ms,
                "cpu_ms": r.cpu_ms,
                "record_ms": r.record_ms,
                "frame_ms": finite(times[i]),
                "frame_ms_least": runs.map(|r| finite(r.least[i])),
                "events": fp.events,
                "work": r.work.counts().iter().map(|(k, v)| ((*k).to_owned(), json!(v))).collect::<serde_json::Map<_, _>>(),
                "cache_bytes": r.cache_bytes,
                "still": still[i],
                "dragging": fp.dragging,
                "camera_moving": fp.camera_moving,
                "width": r.width,
                "height": r.height,
                "budget_ms": finite(r.work.budget_ms),
                "planned_ms": finite(r.work.planned_ms),
                "work_ms": r.work_ms,
                "deferred": r.work.deferred,
                "lights": r.lights.iter().map(|l| json!({
                    "light": l.name,
                    "index": l.index,
                    "level": l.level,
                    "technique": l.technique,
                    "samples": l.samples,
                    "current": l.current,
                })).collect::<Vec<_>>(),
            })
        })
        .collect();
    let pick = |keep: &dyn Fn(usize) -> bool| -> Vec<f64> {
        times.iter().enumerate().filter(|&(i, t)| keep(i) && t.is_finite()).map(|(_, t)| *t).collect()
    };
    let still_ms = pick(&|i| still[i]);
    let drag_ms = pick(&|i| plan.frames[i].dragging);
    let all_ms = pick(&|_| true);
    // A drag's first frame (the pick-up) refills what the object leaves: the steps after it.
    let stepping = |i: usize| plan.frames[i].dragging && i > 0 && plan.frames[i - 1].dragging;
    let step_ms = pick(&stepping);
    let opt = |v: &[f64], f: fn(Vec<f64>) -> f64| if v.is_empty() { Value::Null } else { finite(f(v.to_vec())) };
    let max = |v: Vec<f64>| v.into_iter().fold(f64::NEG_INFINITY, f64::max);
    let record = |keep: &dyn Fn(usize) -> bool| -> Vec<f64> {
        records
            .iter()
            .enumerate()
            .filter(|&(i, r)| keep(i) && r.record_ms.is_finite())
            .map(|(_, r)| r.record_ms)
            .collect()
    };
    let record_ms = [
        opt(&record(&|i| still[i]), median),
        opt(&record(&|i| plan.frames[i].dragging), median),
        opt(&record(&stepping), max),
    ];
    let rmse = |s: &ErrorStats| if s.pixels == 0 { Value::Null } else { finite(s.rmse()) };
    // Every light shows the current state at frame `f` (with a target, a light may show an older
    // one while its fill is spread over frames: the fresh engine differs there by design).
    let all_current = |f: usize| records.get(f).is_some_and(|r| r.lights.iter().all(|l| l.current));
    let checks_json: Vec<Value> = checks
        .iter()
        .map(|c| {
            json!({
                "frame": c.frame,
                "rmse_vs_fresh": rmse(&c.vs_fresh),
                "max_abs_vs_fresh": if c.vs_fresh.pixels == 0 { Value::Null } else { json!(c.vs_fresh.max_abs) },
                "rmse_vs_truth": rmse(&c.vs_truth),
                "wrong_frac_vs_truth": if c.vs_truth.pixels == 0 { Value::Null } else { finite(c.vs_truth.wrong_frac()) },
                "relevant_pixels": c.vs_fresh.pixels,
                "current": all_current(c.frame),
            })
        })
        .collect();
    let total = |key: &str| -> u64 {
        records.iter().map(|r| r.work.counts().iter().find(|(k, _)| *k == key).map_or(0, |(_, v)| u64::from(*v))).sum()
    };
    let full = full_quality(plan, records);
    let target_ms = target.map(|t| t.ms);
    let over = |t: f64| all_ms.iter().filter(|&&ms| ms > t).count();
    let least_over_runs = runs.map(|r| {
        let least = |keep: &dyn Fn(usize) -> bool| -> Vec<f64> {
            r.least.iter().enumerate().filter(|&(i, t)| keep(i) && t.is_finite()).map(|(_, t)| *t).collect()
        };
        json!({
            "runs": r.count,
            "same_work": r.same_work,
            "median_still_ms": opt(&least(&|i| still[i]), median),
            "max_still_ms": opt(&least(&|i| still[i]), max),
            "median_drag_ms": opt(&least(&|i| plan.frames[i].dragging), median),
            "max_drag_ms": opt(&least(&|i| plan.frames[i].dragging), max),
            "max_drag_step_ms": opt(&least(&stepping), max),
            "max_frame_ms": opt(&least(&|_| true), max),
        })
    });
    let mut out = json!({
        "scene": setup.scene.name,
        "timeline": name,
        "techniques": specs.iter().map(|s| s.label().to_owned()).collect::<Vec<_>>(),
        "adapter": { "name": gpu.adapter.name, "backend": gpu.adapter.backend, "device_type": gpu.adapter.device_type },
        "width": setup.width,
        "height": setup.height,
        "view": setup.view.name,
        "cached": !args.no_cache,
        "drag_as_permanent": args.drag_as_permanent,
        "time_source": if gpu_timed { "gpu" } else { "cpu" },
        "check_every": args.check_every,
        "reference": { "samples": args.samples, "seed": args.seed },
        "target_ms": target_ms,
        "target": target.map(TargetInfo::json),
        "frames": frames,
        "checks": checks_json,
        "summary": {
            "median_still_ms": opt(&still_ms, median),
            "max_drag_ms": opt(&drag_ms, max),
            "median_drag_ms": opt(&drag_ms, median),
            "max_drag_step_ms": opt(&step_ms, max),
            "max_frame_ms": opt(&all_ms, max),
            "median_frame_ms": opt(&all_ms, median),
            "cache_bytes_first": records.first().map(|r| r.cache_bytes),
            "cache_bytes_last": records.last().map(|r| r.cache_bytes),
            "still_frames": still_ms.len(),
            "drag_frames": drag_ms.len(),
            "map_views_total": total("map_views"),
            "temporary_views_total": total("temporary_views"),
            "max_rmse_vs_fresh": checks.iter().filter(|c| c.vs_fresh.pixels > 0).map(|c| c.vs_fresh.rmse()).reduce(f64::max),
            "max_abs_vs_fresh": checks.iter().filter(|c| c.vs_fresh.pixels > 0).map(|c| f64::from(c.vs_fresh.max_abs)).reduce(f64::max),
            "max_rmse_vs_fresh_current": checks.iter().filter(|c| c.vs_fresh.pixels > 0 && all_current(c.frame)).map(|c| c.vs_fresh.rmse()).reduce(f64::max),
            "max_abs_vs_fresh_current": checks.iter().filter(|c| c.vs_fresh.pixels > 0 && all_current(c.frame)).map(|c| f64::from(c.vs_fresh.max_abs)).reduce(f64::max),
            "frames_to_full_quality": full.first().and_then(|&(_, f)| f),
            "full_quality_after_events": full.iter().map(|&(e, f)| json!({
                "frame": e,
                "events": plan.frames[e].events,
                "frames_to_full_quality": f.map(|f| f - e),
            })).collect::<Vec<_>>(),
            "level_switches": level_switches(records),
            "max_frame_over_target": target_ms.and_then(|t| (!all_ms.is_empty()).then(|| max(all_ms.clone()) / t)),
            "frames_over_target": target_ms.map(over),
            "least_over_runs": least_over_runs,
        },
    });
    // The CPU's part of the frames (one run), beside the frame times (the `json!` above is as deep
    // as the macro goes).
    let [still_record, drag_record, step_record] = record_ms;
    if let Some(summary) = out.get_mut("summary").and_then(Value::as_object_mut) {
        summary.insert("median_still_record_ms".into(), still_record);
        summary.insert("median_drag_record_ms".into(), drag_record);
        summary.insert("max_drag_step_record_ms".into(), step_record);
    }
    out
}

/// For each stretch of the run from a frame with an event (the first frame's `start` included) to
/// the next one: that frame and the first frame from which every light shows its current state at
/// the highest level it reaches in the stretch, on every frame to the stretch's end (`None`: not
/// before the stretch ends).
fn full_quality(plan: &Plan, records: &[FrameRecord]) -> Vec<(usize, Option<usize>)> {
    let n = records.len().min(plan.frames.len());
    let starts: Vec<usize> = (0..n).filter(|&i| i == 0 || plan.frames[i].has_event()).collect();
    starts
        .iter()
        .enumerate()
        .map(|(k, &start)| {
            let end = starts.get(k + 1).copied().unwrap_or(n);
            let stretch = &records[start..end];
            let mut top: Vec<(LightId, u32)> = Vec::new();
            for l in stretch.iter().flat_map(|r| &r.lights) {
                match top.iter_mut().find(|(id, _)| *id == l.id) {
                    Some((_, t)) => *t = (*t).max(l.level),
                    None => top.push((l.id, l.level)),
                }
            }
            let full = |r: &FrameRecord| {
                r.lights.iter().all(|l| l.current && top.iter().any(|&(id, t)| id == l.id && t == l.level))
            };
            let settled = stretch.iter().rev().take_while(|r| full(r)).count();
            (start, (settled > 0).then(|| end - settled))
        })
        .collect()
}

/// Changes of a light's level from one frame to the next (up or down), over all lights and frames
/// (a light's first frame is none).
fn level_switches(records: &[FrameRecord]) -> usize {
    records
        .windows(2)
        .map(|w| w[1].lights.iter().filter(|l| w[0].lights.iter().any(|p| p.id == l.id && p.level != l.level)).count())
        .sum()
}

/// Frame time per frame (line), the target (dashed), map views re-rendered per frame (bars, right
/// axis), each event a vertical line with its label; below, each light's level per frame (step
/// lines, with a legend). Times far above the median (the first frame builds every cache) are
/// clipped to keep the rest readable, their values written beside them.
fn plot(plan: &Plan, records: &[FrameRecord], time_source: &str, target_ms: Option<f64>) -> Result<String> {
    use plotters::prelude::*;
    report::register_font();
    let times = ms(records, time_source == "gpu");
    let n = records.len().max(1) as f64;
    let finite: Vec<f64> = times.iter().copied().filter(|t| t.is_finite()).collect();
    let highest = finite.iter().copied().fold(0.0, f64::max).max(1e-3);
    // With a target, frames up to twice it are drawn whole (the frames that matter against it).
    let clip = highest.min((5.0 * median(finite.clone()).max(1e-3)).max(2.0 * target_ms.unwrap_or(0.0)));
    let top_of_data = clip.max(target_ms.unwrap_or(0.0));
    // Room above the highest point for the events' labels.
    let top = top_of_data * 1.4;
    let max_views = records.iter().map(|r| r.work.map_views).max().unwrap_or(0).max(1) as f64 * 1.4;
    let unit = time_source.to_uppercase();
    // The lights in the order they first appear, with their technique.
    let mut lights: Vec<(LightId, String)> = Vec::new();
    for l in records.iter().flat_map(|r| &r.lights) {
        if !lights.iter().any(|(id, _)| *id == l.id) {
            let mut label = format!("{} ({})", l.name, l.technique);
            if label.chars().count() > 34 {
                label = label.chars().take(33).collect::<String>() + "…";
            }
            lights.push((l.id, label));
        }
    }
    let max_level = records.iter().flat_map(|r| &r.lights).map(|l| l.level).max().unwrap_or(1).max(1);
    // The legend under the levels: four lights a row.
    const LEGEND_COLUMNS: usize = 4;
    let legend_height = if lights.is_empty() { 0 } else { 8 + 18 * lights.len().div_ceil(LEGEND_COLUMNS) as u32 };
    let (upper_height, lower_height) = (440, if lights.is_empty() { 0 } else { 220 });
    let mut svg = String::new();
    {
        let root =
            SVGBackend::with_string(&mut svg, (960, upper_height + lower_height + legend_height)).into_drawing_area();
        root.fill(&WHITE)?;
        let (upper, rest) = root.split_vertically(upper_height);
        let (lower, legend) = rest.split_vertically(lower_height);
        let caption = match target_ms {
            Some(t) => format!(
                "{unit} ms per frame (blue), its CPU recording (purple), target {t:.2} ms (dashed), map views re-rendered (orange, right axis)"
            ),
            None => format!(
                "{unit} ms per frame (blue), its CPU recording (purple), map views re-rendered (orange bars, right axis)"
            ),
        };
        let mut chart = ChartBuilder::on(&upper)
            .caption(caption, ("sans-serif", 16))
            .margin(16)
            .x_label_area_size(42)
            .y_label_area_size(64)
            .right_y_label_area_size(64)
            .build_cartesian_2d(-0.5..n - 0.5, 0.0..top)?
            .set_secondary_coord(-0.5..n - 0.5, 0.0..max_views);
        chart
            .configure_mesh()
            .x_desc("frame")
            .y_desc(format!("{unit} ms per frame"))
            .x_label_formatter(&|x| format!("{x:.0}"))
            .label_style(("sans-serif", 13))
            .draw()?;
        chart
            .configure_secondary_axes()
            .y_desc("map views re-rendered")
            .y_label_formatter(&|y| if y.fract() == 0.0 { format!("{y:.0}") } else { String::new() })
            .label_style(("sans-serif", 13))
            .draw()?;
        let bars = RGBColor(255, 127, 14);
        chart.draw_secondary_series(records.iter().enumerate().filter(|(_, r)| r.work.map_views > 0).map(
            |(i, r)| {
                let x = i as f64;
                Rectangle::new([(x - 0.4, 0.0), (x + 0.4, f64::from(r.work.map_views))], bars.mix(0.5).filled())
            },
        ))?;
        if let Some(t) = target_ms {
            chart.draw_series(DashedLineSeries::new(
                [(-0.5, t), (n - 0.5, t)],
                8,
                6,
                RGBColor(44, 160, 44).stroke_width(2),
            ))?;
        }
        let line = RGBColor(31, 119, 180);
        let points: Vec<(f64, f64)> =
            times.iter().enumerate().filter(|(_, t)| t.is_finite()).map(|(i, t)| (i as f64, t.min(clip))).collect();
        chart.draw_series(LineSeries::new(points, line.stroke_width(2)))?;
        // The CPU's part, which a fast GPU does not hide (within the frame time on a CPU adapter).
        let recording: Vec<(f64, f64)> = records
            .iter()
            .enumerate()
            .filter(|(_, r)| r.record_ms.is_finite())
            .map(|(i, r)| (i as f64, r.record_ms.min(clip)))
            .collect();
        chart.draw_series(LineSeries::new(recording, RGBColor(148, 103, 189).stroke_width(1)))?;
        for (i, t) in times.iter().enumerate().filter(|(_, t)| **t > clip) {
            chart.draw_series(std::iter::once(
                EmptyElement::at((i as f64, clip))
                    + Text::new(format!("{t:.0} ▲"), (4, -14), ("sans-serif", 12).into_font().color(&line)),
            ))?;
        }
        let mark = RGBColor(214, 39, 40);
        for (row, (i, fp)) in plan.frames.iter().enumerate().filter(|(_, f)| f.has_event()).enumerate() {
            let x = i as f64;
            chart.draw_series(std::iter::once(PathElement::new(vec![(x, 0.0), (x, top)], mark.mix(0.6))))?;
            let mut label = fp.events.join("; ");
            if label.chars().count() > 40 {
                label = label.chars().take(39).collect::<String>() + "…";
            }
            let y = top * (0.97 - 0.06 * (row % 4) as f64);
            chart.draw_series(std::iter::once(
                EmptyElement::at((x, y)) + Text::new(label, (4, 0), ("sans-serif", 12).into_font().color(&mark)),
            ))?;
        }
        if !lights.is_empty() {
            let mut levels = ChartBuilder::on(&lower)
                .caption(
                    "each light's level (0 no shadow, 1 the technique's base, higher its upgrades; dots: not yet current)",
                    ("sans-serif", 14),
                )
                .margin(16)
                .x_label_area_size(36)
                .y_label_area_size(64)
                .right_y_label_area_size(64)
                .build_cartesian_2d(-0.5..n - 0.5, -0.3..f64::from(max_level) + 0.5)?;
            levels
                .configure_mesh()
                .x_desc("frame")
                .y_desc("level")
                .x_label_formatter(&|x| format!("{x:.0}"))
                .y_labels(max_level as usize + 2)
                .y_label_formatter(&|y| if y.fract() == 0.0 { format!("{y:.0}") } else { String::new() })
                .label_style(("sans-serif", 13))
                .draw()?;
            // Lines a little apart so that lights on the same level stay visible.
            let spread = if lights.len() > 1 { 0.24 / (lights.len() - 1) as f64 } else { 0.0 };
            for (k, (id, label)) in lights.iter().enumerate() {
                let colour = Palette99::pick(k).to_rgba();
                let offset = spread * k as f64 - 0.12 * f64::from(u8::from(lights.len() > 1));
                let steps: Vec<(usize, u32, bool)> = records
                    .iter()
                    .enumerate()
                    .filter_map(|(i, r)| r.lights.iter().find(|l| l.id == *id).map(|l| (i, l.level, l.current)))
                    .collect();
                let mut path = Vec::with_capacity(2 * steps.len());
                for &(i, level, _) in &steps {
                    let y = f64::from(level) + offset;
                    path.push((i as f64 - 0.5, y));
                    path.push((i as f64 + 0.5, y));
                }
                levels.draw_series(LineSeries::new(path, colour.stroke_width(2)))?;
                let (x, y) = (80 + 220 * (k % LEGEND_COLUMNS) as i32, 8 + 18 * (k / LEGEND_COLUMNS) as i32);
                legend.draw(&PathElement::new(vec![(x, y + 6), (x + 18, y + 6)], colour.stroke_width(2)))?;
                legend.draw(&Text::new(label.clone(), (x + 24, y), ("sans-serif", 12).into_font()))?;
                // Frames whose state is not the current one: a dot above the line.
                levels.draw_series(
                    steps
                        .iter()
                        .filter(|s| !s.2)
                        .map(|&(i, level, _)| Circle::new((i as f64, f64::from(level) + offset), 2, colour.filled())),
                )?;
            }
        }
        root.present()?;
    }
    Ok(svg)
}

fn fmt(v: &Value, digits: usize) -> String {
    v.as_f64().map(|x| format!("{x:.digits$}")).unwrap_or_else(|| "–".to_owned())
}

fn mib(v: &Value) -> String {
    v.as_f64().map(|b| format!("{:.1}", b / (1024.0 * 1024.0))).unwrap_or_else(|| "–".to_owned())
}

fn print_summary(doc: &Value) {
    let s = &doc["summary"];
    let unit = doc["time_source"].as_str().unwrap_or("cpu").to_uppercase();
    println!(
        "{} frames ({} still, {} dragging), {unit} ms: median still {}, median drag {}, max drag {}, max {}; cache {} → {} MiB",
        doc["frames"].as_array().map_or(0, Vec::len),
        s["still_frames"],
        s["drag_frames"],
        fmt(&s["median_still_ms"], 2),
        fmt(&s["median_drag_ms"], 2),
        fmt(&s["max_drag_ms"], 2),
        fmt(&s["max_frame_ms"], 2),
        mib(&s["cache_bytes_first"]),
        mib(&s["cache_bytes_last"]),
    );
    println!(
        "recording (CPU ms before the GPU's part): median still {}, median drag {}, max drag step {}",
        fmt(&s["median_still_record_ms"], 2),
        fmt(&s["median_drag_record_ms"], 2),
        fmt(&s["max_drag_step_record_ms"], 2),
    );
    let least = &s["least_over_runs"];
    if least.is_object() {
        println!(
            "each frame's least over {} runs{}, {unit} ms: median still {}, max still {}, median drag {}, max drag step {}, max drag {}",
            least["runs"],
            if least["same_work"].as_bool() == Some(true) { "" } else { " (the runs' work differed)" },
            fmt(&least["median_still_ms"], 2),
            fmt(&least["max_still_ms"], 2),
            fmt(&least["median_drag_ms"], 2),
            fmt(&least["max_drag_step_ms"], 2),
            fmt(&least["max_drag_ms"], 2),
        );
    }
    println!("{}", quality_line(doc));
    if let Some(checks) = doc["checks"].as_array().filter(|c| !c.is_empty()) {
        println!(
            "{} checks: max RMSE vs fresh {}, max |Δ| vs fresh {}; where every light is current {}, {}",
            checks.len(),
            fmt(&s["max_rmse_vs_fresh"], 5),
            fmt(&s["max_abs_vs_fresh"], 5),
            fmt(&s["max_rmse_vs_fresh_current"], 5),
            fmt(&s["max_abs_vs_fresh_current"], 5)
        );
    }
}

/// The target, how soon every light was at full quality, and how often levels switched.
fn quality_line(doc: &Value) -> String {
    let s = &doc["summary"];
    let target = match doc["target_ms"].as_f64() {
        Some(t) => format!(
            "target {t:.3} ms: max frame ÷ target {}, {} frames over it",
            fmt(&s["max_frame_over_target"], 2),
            s["frames_over_target"]
        ),
        None => "no target (every fill in the frame that needs it)".to_owned(),
    };
    let full = match s["frames_to_full_quality"].as_u64() {
        Some(f) => format!("every light current at its top level from frame {f}"),
        None => "not every light reached its top level before the first event".to_owned(),
    };
    format!("{target}; {full}; {} level switches", s["level_switches"])
}

fn report_html(doc: &Value, svg: &str) -> String {
    let s = &doc["summary"];
    let summary = report::table(
        &[
            "frames",
            "still",
            "dragging",
            "median still ms",
            "median drag ms",
            "max drag ms",
            "max frame ms",
            "median drag recording ms",
            "map views (all frames)",
            "cache MiB first",
            "cache MiB last",
        ],
        &[vec![
            doc["frames"].as_array().map_or(0, Vec::len).to_string(),
            s["still_frames"].to_string(),
            s["drag_frames"].to_string(),
            fmt(&s["median_still_ms"], 2),
            fmt(&s["median_drag_ms"], 2),
            fmt(&s["max_drag_ms"], 2),
            fmt(&s["max_frame_ms"], 2),
            fmt(&s["median_drag_record_ms"], 2),
            s["map_views_total"].to_string(),
            mib(&s["cache_bytes_first"]),
            mib(&s["cache_bytes_last"]),
        ]],
    );
    let empty = Vec::new();
    let frames = doc["frames"].as_array().unwrap_or(&empty);
    let checks_rows: Vec<Vec<String>> = doc["checks"]
        .as_array()
        .unwrap_or(&empty)
        .iter()
        .map(|c| {
            let f = c["frame"].as_u64().unwrap_or(0) as usize;
            let events = frames.get(f).and_then(|x| x["events"].as_array()).cloned().unwrap_or_default();
            vec![
                f.to_string(),
                fmt(&c["rmse_vs_fresh"], 5),
                fmt(&c["max_abs_vs_fresh"], 5),
                fmt(&c["rmse_vs_truth"], 4),
                c["wrong_frac_vs_truth"].as_f64().map(|x| format!("{:.2}%", 100.0 * x)).unwrap_or_default(),
                if c["current"].as_bool() == Some(false) { "no" } else { "yes" }.to_owned(),
                report::escape(&events.iter().filter_map(Value::as_str).collect::<Vec<_>>().join("; ")),
            ]
        })
        .collect();
    let checks = report::table(
        &[
            "frame",
            "RMSE vs fresh",
            "max |Δ| vs fresh",
            "RMSE vs truth",
            "wrong vs truth",
            "all current",
            "events this frame",
        ],
        &checks_rows,
    );
    let event_rows: Vec<Vec<String>> = frames
        .iter()
        .filter(|f| f["events"].as_array().is_some_and(|e| !e.is_empty()))
        .map(|f| {
            let w = &f["work"];
            vec![
                f["index"].to_string(),
                report::escape(
                    &f["events"]
                        .as_array()
                        .unwrap_or(&empty)
                        .iter()
                        .filter_map(Value::as_str)
                        .collect::<Vec<_>>()
                        .join("; "),
                ),
                fmt(&f["frame_ms"], 2),
                w["map_views"].to_string(),
                w["temporary_views"].to_string(),
                w["reused"].to_string(),
            ]
        })
        .collect();
    let events = report::table(&["frame", "events", "ms", "map views", "temporary views", "reused"], &event_rows);
    let a = &doc["adapter"];
    let techniques: Vec<String> =
        doc["techniques"].as_array().unwrap_or(&empty).iter().filter_map(Value::as_str).map(report::escape).collect();
    format!(
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>shadowlab play: {scene} / {timeline}</title><style>{style}</style></head><body>\
<h1>shadowlab play: {scene} / {timeline}</h1>\
<p>{w}×{h} pixels · techniques: {techniques} · caching {cached} · drags {drags} · adapter: {adapter} ({backend}, {dtype}) · times: {source}</p>\
<h2>Summary</h2>{summary}<p>{quality}.</p>{target}{auto}\
<p class=\"note\">Still frames: no event, no drag, and more than {settling} frames after the last event (the first frame, which builds every cache, counts as one). Drag frames: a drag is active. On a CPU adapter only ratios within a run (or between a cached and an uncached run) mean anything.</p>\
<h2>Frame time and work</h2>{svg}\
<h2>Checks</h2><p class=\"note\">The live engine against a fresh, uncached engine on the same state and surface (over each light's relevant pixels; it must be 0 for exact techniques where every light is current: with a target, a light whose fill is spread over frames shows an older state meanwhile), and against the ray-traced truth ({samples} samples; wrong = |Δ| &gt; 0.1), pooled over the shadowed lights.</p>{checks}\
<h2>Events</h2>{events}\
</body></html>",
        scene = report::escape(doc["scene"].as_str().unwrap_or("")),
        timeline = report::escape(doc["timeline"].as_str().unwrap_or("")),
        style = report::STYLE,
        w = doc["width"],
        h = doc["height"],
        techniques = techniques.join(", "),
        cached = if doc["cached"].as_bool() == Some(true) { "on" } else { "off" },
        drags = if doc["drag_as_permanent"].as_bool() == Some(true) { "as permanent moves" } else { "temporary" },
        adapter = report::escape(a["name"].as_str().unwrap_or("")),
        backend = a["backend"].as_str().unwrap_or(""),
        dtype = a["device_type"].as_str().unwrap_or(""),
        source = doc["time_source"].as_str().unwrap_or(""),
        settling = timeline::SETTLING_FRAMES,
        samples = doc["reference"]["samples"],
        auto = auto_html(doc),
        quality = report::escape(&quality_line(doc)),
        target = target_html(doc),
    )
}

/// With a target: where it came from, and per event how many frames until full quality.
fn target_html(doc: &Value) -> String {
    let empty = Vec::new();
    let rows: Vec<Vec<String>> = doc["summary"]["full_quality_after_events"]
        .as_array()
        .unwrap_or(&empty)
        .iter()
        .map(|e| {
            let events: Vec<&str> = e["events"].as_array().unwrap_or(&empty).iter().filter_map(Value::as_str).collect();
            vec![
                e["frame"].to_string(),
                report::escape(&events.join("; ")),
                e["frames_to_full_quality"]
                    .as_u64()
                    .map_or_else(|| "not before the next event".to_owned(), |f| f.to_string()),
            ]
        })
        .collect();
    let t = &doc["target"];
    let source = if t.is_null() {
        "No target: every fill is done in the frame that needs it.".to_owned()
    } else if t["given"] == "auto" {
        format!(
            "Target {} ms = {} × {} {} ms (the median of {} frames with <code>hard</code> on every light, uncached) × {} ({}).",
            fmt(&t["target_ms"], 3),
            t["auto_factor"],
            fmt(&t["hard_frame_ms"], 3),
            t["hard_frame_source"].as_str().unwrap_or(""),
            t["hard_frames"],
            t["preference_factor"],
            t["preference"].as_str().unwrap_or("")
        )
    } else {
        format!(
            "Target {} ms = {} ms × {} ({}).",
            fmt(&t["target_ms"], 3),
            t["given"],
            t["preference_factor"],
            t["preference"].as_str().unwrap_or("")
        )
    };
    format!(
        "<h2>Target and quality levels</h2><p>{source} A light shows its last complete state until its new one is complete (level 0: unshadowed until the first).</p>{}",
        report::table(&["event frame", "events", "frames to full quality"], &rows)
    )
}

/// With `auto`: which light got what, and why.
fn auto_html(doc: &Value) -> String {
    let Some(choices) = doc["auto"].as_array() else {
        return String::new();
    };
    let rows: Vec<Vec<String>> = choices
        .iter()
        .map(|c| {
            vec![
                report::escape(&format!("{} '{}'", c["light"], c["name"].as_str().unwrap_or(""))),
                report::escape(c["spec"].as_str().unwrap_or("")),
                fmt(&c["share_ms"], 3),
                fmt(&c["cost_ms"], 3),
                report::escape(c["reason"].as_str().unwrap_or("")),
            ]
        })
        .collect();
    let b = &doc["auto_budget"];
    format!(
        "<h2>auto: which light got what, and why</h2><p>budget {} ms × {} ({}), shared equally; figures from {}.</p>{}",
        fmt(&b["budget_ms"], 3),
        b["budget_factor"],
        report::escape(b["preference"].as_str().unwrap_or("")),
        report::escape(b["calibration"].as_str().unwrap_or("")),
        report::table(&["light", "spec", "share ms", "cost ms", "why"], &rows)
    )
}
