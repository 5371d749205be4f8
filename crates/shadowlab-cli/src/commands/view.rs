//! `shadowlab view`: the interactive viewer (`shadowlab-viewer`) in a window.

use anyhow::Result;
use shadowlab_viewer::Setup;
use shadowlab_viewer::window::{WindowOptions, run as run_window};

use crate::args::{GlobalArgs, parse_size};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// A built-in scene (`shadowlab scenes`), optionally with options, or a .toml, .gltf, .glb or .obj file.
    #[arg(long, default_value = "room")]
    scene: String,
    /// A named view of the scene (default: its first).
    #[arg(long)]
    view: Option<String>,
    /// The scene image's size, WIDTHxHEIGHT (the window adds a 300-pixel panel on the left).
    #[arg(long, default_value = "640x480", value_parser = parse_size)]
    size: (u32, u32),
    /// The technique every light starts with (`ID` or `ID:K=V,...`).
    #[arg(long, default_value = "hard")]
    technique: String,
    /// Close after this many frames.
    #[arg(long)]
    frames: Option<u64>,
}

pub fn run(_global: &GlobalArgs, args: Args) -> Result<()> {
    let setup = Setup {
        scene: args.scene,
        view: args.view,
        width: args.size.0,
        height: args.size.1,
        technique: args.technique,
    };
    let frames = run_window(WindowOptions { setup, frames: args.frames, screenshot_dir: ".".into() })?;
    println!("{frames} frames");
    Ok(())
}
