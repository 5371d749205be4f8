//! The command-line options of a viewer run, shared by `shadowlab-viewer` and `shadowlab view`.

use crate::viewer::Setup;

#[derive(clap::Args, Debug, Clone)]
pub struct ViewArgs {
    /// A built-in scene (`shadowlab scenes`), optionally with options, or a .toml, .gltf, .glb or .obj file.
    #[arg(long, default_value = "room")]
    pub scene: String,
    /// A named view of the scene (default: its first).
    #[arg(long)]
    pub view: Option<String>,
    /// The scene image's size, WIDTHxHEIGHT (the window adds the panel's 300 pixels on the left).
    #[arg(long, default_value = "640x480", value_parser = parse_size)]
    pub size: (u32, u32),
    /// The technique every light starts with (`ID` or `ID:K=V,...`).
    #[arg(long, default_value = "hard")]
    pub technique: String,
    /// Windowed: close after this many frames (tests under Xvfb).
    #[arg(long)]
    pub frames: Option<u64>,
}

impl ViewArgs {
    pub fn setup(&self) -> Setup {
        Setup {
            scene: self.scene.clone(),
            view: self.view.clone(),
            width: self.size.0,
            height: self.size.1,
            technique: self.technique.clone(),
        }
    }
}

/// `WIDTHxHEIGHT`, each side in 16..=8192.
pub fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(|| format!("'{text}' is not WIDTHxHEIGHT"))?;
    let parse = |s: &str| s.trim().parse::<u32>().map_err(|_| format!("'{s}' in '{text}' is not a whole number"));
    let (w, h) = (parse(w)?, parse(h)?);
    if !(16..=8192).contains(&w) || !(16..=8192).contains(&h) {
        return Err(format!("size {w}x{h} must be between 16x16 and 8192x8192"));
    }
    Ok((w, h))
}
