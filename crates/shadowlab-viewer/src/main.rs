//! `shadowlab-viewer`: the interactive viewer, in a window, or headless with a script and a
//! screenshot (tests, documentation).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Parser;
use shadowlab::{BackendChoice, Gpu};
use shadowlab_viewer::Setup;
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
    /// A built-in scene (`shadowlab scenes`), optionally with options, or a .toml, .gltf, .glb or .obj file.
    #[arg(long, default_value = "room")]
    scene: String,
    /// A named view of the scene (default: its first).
    #[arg(long)]
    view: Option<String>,
    /// The scene image's size, WIDTHxHEIGHT (the window adds the panel's 300 pixels on the left).
    #[arg(long, default_value = "640x480", value_parser = parse_size)]
    size: (u32, u32),
    /// The technique every light starts with (`ID` or `ID:K=V,...`).
    #[arg(long, default_value = "hard")]
    technique: String,
    /// Headless: run this script of UI actions offscreen (see the `script` module's docs).
    #[arg(long, value_name = "FILE")]
    script: Option<PathBuf>,
    /// Headless: write the whole window (UI included) as a PNG after the script.
    #[arg(long, value_name = "OUT.png")]
    screenshot: Option<PathBuf>,
    /// Windowed: close after this many frames (for tests under Xvfb).
    #[arg(long)]
    frames: Option<u64>,
    /// GPU backend for headless runs: auto, vulkan or gl.
    #[arg(long, default_value = "auto", value_parser = ["auto", "vulkan", "gl"])]
    backend: String,
}

fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(|| format!("'{text}' is not WIDTHxHEIGHT"))?;
    let parse = |s: &str| s.trim().parse::<u32>().map_err(|_| format!("'{s}' in '{text}' is not a whole number"));
    let (w, h) = (parse(w)?, parse(h)?);
    if !(16..=8192).contains(&w) || !(16..=8192).contains(&h) {
        return Err(format!("size {w}x{h} must be between 16x16 and 8192x8192"));
    }
    Ok((w, h))
}

fn main() {
    if let Err(e) = run_viewer(Args::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run_viewer(args: Args) -> Result<()> {
    let setup = Setup {
        scene: args.scene.clone(),
        view: args.view.clone(),
        width: args.size.0,
        height: args.size.1,
        technique: args.technique.clone(),
    };
    if args.script.is_some() || args.screenshot.is_some() {
        if args.frames.is_some() {
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
    let frames = run(WindowOptions { setup, frames: args.frames, screenshot_dir: PathBuf::from(".") })?;
    println!("{frames} frames");
    Ok(())
}
