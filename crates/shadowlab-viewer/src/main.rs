//! `shadowlab-viewer`: the interactive viewer, in a window, or headless with a script and a
//! screenshot (tests, documentation).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Parser;
use shadowlab::{BackendChoice, Gpu};
use shadowlab_viewer::args::ViewArgs;
use shadowlab_viewer::headless::Headless;
use shadowlab_viewer::script::Script;
use shadowlab_viewer::window::{WindowOptions, run};

#[derive(Parser, Debug)]
#[command(
    name = "shadowlab-viewer",
    version,
    about = "Walk, drag, switch shadow techniques live, and see why a shadow fails"
)]
struct Args {
    #[command(flatten)]
    view: ViewArgs,
    /// Headless: run this script of UI actions offscreen (see the `script` module's docs).
    #[arg(long, value_name = "FILE")]
    script: Option<PathBuf>,
    /// Headless: write the whole window (UI included) as a PNG after the script.
    #[arg(long, value_name = "OUT.png")]
    screenshot: Option<PathBuf>,
    /// GPU backend for headless runs: auto, vulkan or gl.
    #[arg(long, default_value = "auto", value_parser = ["auto", "vulkan", "gl"])]
    backend: String,
}

fn main() {
    if let Err(e) = run_viewer(Args::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run_viewer(args: Args) -> Result<()> {
    let setup = args.view.setup();
    if args.script.is_some() || args.screenshot.is_some() {
        if args.view.frames.is_some() {
            bail!("--frames is for the windowed viewer; a headless run renders the script's frames");
        }
        let script = match &args.script {
            Some(path) => Script::load(path).map_err(anyhow::Error::msg)?,
            None => Script::default(),
        };
        let choice = BackendChoice::parse(&args.backend).context("backend")?;
        let gpu = Gpu::new(choice)?;
        let mut headless = Headless::new(gpu, setup)?;
        headless.frame(Vec::new())?;
        headless.run_script(&script)?;
        if !headless.viewer.status.is_empty() {
            eprintln!("viewer: {}", headless.viewer.status);
        }
        if let Some(path) = &args.screenshot {
            headless.screenshot()?.save(path).with_context(|| format!("writing {}", path.display()))?;
            println!("→ {}", path.display());
        }
        return Ok(());
    }
    let frames = run(WindowOptions { setup, frames: args.view.frames, screenshot_dir: PathBuf::from(".") })?;
    println!("{frames} frames");
    Ok(())
}
