//! `shadowlab view`: the interactive viewer (`shadowlab-viewer`) in a window.

use anyhow::Result;
use shadowlab_viewer::args::ViewArgs;
use shadowlab_viewer::window::{WindowOptions, run as run_window};

use crate::args::GlobalArgs;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    view: ViewArgs,
}

pub fn run(_global: &GlobalArgs, args: Args) -> Result<()> {
    let options = WindowOptions { setup: args.view.setup(), frames: args.view.frames, screenshot_dir: ".".into() };
    let frames = run_window(options)?;
    println!("{frames} frames");
    Ok(())
}
