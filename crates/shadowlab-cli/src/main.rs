//! `shadowlab`: choose a shadow technique with numbers. See `shadowlab --help` and the README.

mod args;
mod commands;
mod measure;
mod overlay;
mod progress;
mod report;

use clap::{Parser, Subcommand};

/// Real-time shadow techniques measured against a ray-traced ground truth.
#[derive(Parser)]
#[command(name = "shadowlab", version, about, long_about = None)]
struct Cli {
    #[command(flatten)]
    global: args::GlobalArgs,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the built-in scenes: lights, views, triangle counts, options.
    Scenes(commands::scenes::Args),
    /// List the shadow techniques: ids, light types, parameters.
    Techniques(commands::techniques::Args),
    /// Load a scene and summarise it without a GPU: triangles, mesh topology (open, non-manifold),
    /// lights, views, bounds, warnings.
    Inspect(commands::inspect::Args),
    /// Render one lit image with a technique.
    Render(commands::render::Args),
    /// Ray-trace the reference visibility of every light on the CPU (no GPU needed).
    Reference(commands::reference::Args),
    /// Compare techniques with the ray-traced truth: metrics.json, images, report.html.
    Compare(commands::compare::Args),
    /// Write the triangles the truth traces (the scene's local frame, one object per instance) as
    /// .obj or .glb, with a .json of the lights and the ray-offset rule: for outside tracers.
    Export(commands::export::Args),
    /// Time techniques: GPU ms per pass, CPU ms, memory, ratios over `hard`.
    Bench(commands::bench::Args),
    /// Measure, per light, each candidate technique's cost and error against the truth on the
    /// scene's views: the calibration file `--technique auto` chooses from.
    Calibrate(commands::calibrate::Args),
    /// Perspective aliasing of a light's maps: predicted curves and measured texels per pixel.
    Analyze(commands::analyze::Args),
    /// Run a timeline of edits (drags, light changes, moves, camera) on the live engine: time and
    /// work per frame, checks against a fresh engine and the truth; timeline.json, report.html.
    Play(commands::play::Args),
    /// Precompute the light meshes of the static lights (no GPU): static receivers cut along the
    /// static shadows, lit pieces only (Hasselgren 2003), for the `lightmesh` technique.
    Precompute(commands::precompute::Args),
    /// Open the interactive viewer (as `shadowlab-viewer`): fly, drag objects, switch each light's
    /// technique and parameters live, overlays.
    View(commands::view::Args),
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Scenes(a) => commands::scenes::run(&cli.global, a),
        Command::Techniques(a) => commands::techniques::run(&cli.global, a),
        Command::Inspect(a) => commands::inspect::run(&cli.global, a),
        Command::Render(a) => commands::render::run(&cli.global, a),
        Command::Reference(a) => commands::reference::run(&cli.global, a),
        Command::Compare(a) => commands::compare::run(&cli.global, a),
        Command::Export(a) => commands::export::run(&cli.global, a),
        Command::Bench(a) => commands::bench::run(&cli.global, a),
        Command::Calibrate(a) => commands::calibrate::run(&cli.global, a),
        Command::Analyze(a) => commands::analyze::run(&cli.global, a),
        Command::View(a) => commands::view::run(&cli.global, a),
        Command::Play(a) => commands::play::run(&cli.global, a),
        Command::Precompute(a) => commands::precompute::run(&cli.global, a),
    };
    if let Err(e) = result {
        eprintln!("error: {}", chain_text(&e));
        std::process::exit(1);
    }
}

/// The error and its causes, each cause left out when the message before already says it (our
/// library errors quote their source).
fn chain_text(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !text.contains(&c) {
            text.push_str(": ");
            text.push_str(&c);
        }
    }
    text
}
