//! `shadowlab`: choose a shadow technique with numbers. See `shadowlab --help` and the README.

mod args;
mod commands;
mod progress;

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
    /// Ray-trace the reference visibility of every light on the CPU (no GPU needed).
    Reference(commands::reference::Args),
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Scenes(a) => commands::scenes::run(&cli.global, a),
        Command::Reference(a) => commands::reference::run(&cli.global, a),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
