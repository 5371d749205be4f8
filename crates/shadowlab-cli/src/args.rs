//! Arguments shared by several commands (DESIGN.md §6).

use anyhow::{Context, Result, bail};
use shadowlab_core::{LightId, Scene, View, load_scene};

/// Options every command accepts.
#[derive(clap::Args, Debug, Clone)]
pub struct GlobalArgs {
    /// GPU backend: auto (a real GPU, then Vulkan on the CPU, then GL), vulkan or gl.
    #[arg(long, global = true, default_value = "auto", value_parser = ["auto", "vulkan", "gl"])]
    pub backend: String,
}

/// Which scene, view, size and lights a command works on.
#[derive(clap::Args, Debug, Clone)]
pub struct SceneArgs {
    /// A built-in scene (`shadowlab scenes`), optionally with options (`terrain:sun=0.27`), or a
    /// .toml, .gltf, .glb or .obj file.
    #[arg(long, default_value = "room")]
    pub scene: String,
    /// A named view of the scene (default: its first view).
    #[arg(long)]
    pub view: Option<String>,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "256x256", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Only these lights (names or indices, comma-separated) are shadowed and measured.
    #[arg(long, value_delimiter = ',')]
    pub lights: Vec<String>,
    /// Scale every light's emitter size; 0 makes all lights hard (points and single directions).
    #[arg(long, default_value_t = 1.0)]
    pub emitter_scale: f32,
}

/// The scene, the chosen view and the chosen lights, ready to use.
pub struct Setup {
    pub scene: Scene,
    pub view: View,
    pub lights: Vec<LightId>,
    pub width: u32,
    pub height: u32,
}

impl SceneArgs {
    pub fn load(&self) -> Result<Setup> {
        if !(self.emitter_scale.is_finite() && (0.0..=100.0).contains(&self.emitter_scale)) {
            bail!("--emitter-scale {} must be in [0, 100]", self.emitter_scale);
        }
        let loaded = load_scene(&self.scene).with_context(|| format!("loading scene '{}'", self.scene))?;
        for w in &loaded.warnings {
            eprintln!("warning: {w}");
        }
        let mut scene = loaded.scene;
        if self.emitter_scale != 1.0 {
            scene.scale_emitters(self.emitter_scale);
        }
        let view = match &self.view {
            Some(name) => scene.view(name).cloned().with_context(|| {
                let known: Vec<&str> = scene.views.iter().map(|v| v.name.as_str()).collect();
                format!("scene '{}' has no view '{name}' (views: {})", scene.name, known.join(", "))
            })?,
            None => scene.views.first().cloned().context("the scene has no views")?,
        };
        let lights = if self.lights.is_empty() {
            (0..scene.lights.len() as u32).map(LightId).collect()
        } else {
            self.lights
                .iter()
                .map(|l| {
                    scene.find_light(l).with_context(|| {
                        let known: Vec<&str> = scene.lights.iter().map(|l| l.name.as_str()).collect();
                        format!("scene '{}' has no light '{l}' (lights: {})", scene.name, known.join(", "))
                    })
                })
                .collect::<Result<Vec<_>>>()?
        };
        let (width, height) = self.size;
        Ok(Setup { scene, view, lights, width, height })
    }
}

/// Parses `WIDTHxHEIGHT` (1..=8192 each).
pub fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(|| format!("'{text}' is not WIDTHxHEIGHT"))?;
    let parse = |s: &str| s.trim().parse::<u32>().map_err(|_| format!("'{s}' in '{text}' is not a whole number"));
    let (w, h) = (parse(w)?, parse(h)?);
    if !(1..=8192).contains(&w) || !(1..=8192).contains(&h) {
        return Err(format!("size {w}x{h} must be between 1x1 and 8192x8192"));
    }
    Ok((w, h))
}

/// A file-name-safe form of a light or technique name.
pub fn slug(name: &str) -> String {
    let s: String =
        name.chars().map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '-' }).collect();
    let s = s.split('-').filter(|p| !p.is_empty()).collect::<Vec<_>>().join("-");
    if s.is_empty() { "unnamed".to_owned() } else { s }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(parse_size("640x480"), Ok((640, 480)));
        assert!(parse_size("640").is_err());
        assert!(parse_size("0x10").is_err());
        assert!(parse_size("axb").is_err());
    }

    #[test]
    fn slugs() {
        assert_eq!(slug("Ceiling lamp"), "ceiling-lamp");
        assert_eq!(slug("pcf:taps=16"), "pcf-taps-16");
        assert_eq!(slug("///"), "unnamed");
    }
}

/// Opens the GPU chosen by `--backend` and says which adapter it is.
pub fn open_gpu(global: &GlobalArgs) -> Result<shadowlab::Gpu> {
    let choice = shadowlab::BackendChoice::parse(&global.backend).context("--backend must be auto, vulkan or gl")?;
    let gpu = shadowlab::Gpu::new(choice)?;
    eprintln!("adapter: {}", gpu.adapter);
    Ok(gpu)
}

/// Technique selection shared by render, compare and bench.
#[derive(clap::Args, Debug, Clone)]
pub struct TechniqueArgs {
    /// Techniques with default parameters, comma-separated (`hard,pcf,sampled`).
    #[arg(long, value_delimiter = ',', conflicts_with = "technique")]
    pub techniques: Vec<String>,
    /// A technique with parameters, `ID` or `ID:K=V,K=V`; repeat to compare configurations.
    #[arg(long)]
    pub technique: Vec<String>,
    /// Set a parameter on every technique that has it (`--set map_size=1024`).
    #[arg(long = "set", value_name = "K=V")]
    pub set: Vec<String>,
}

impl TechniqueArgs {
    /// The specs given, or `default` when none was.
    pub fn specs(&self, default: &[&str]) -> Result<Vec<shadowlab::TechniqueSpec>> {
        let given: Vec<String> = if !self.technique.is_empty() {
            self.technique.clone()
        } else if !self.techniques.is_empty() {
            self.techniques.iter().map(|t| t.trim().to_owned()).filter(|t| !t.is_empty()).collect()
        } else {
            default.iter().map(|s| (*s).to_owned()).collect()
        };
        let specs =
            given.iter().map(|s| shadowlab::TechniqueSpec::parse(s, &self.set)).collect::<Result<Vec<_>, _>>()?;
        shadowlab::registry::check_global_sets(&specs, &self.set)?;
        Ok(specs)
    }
}

/// A renderer for `setup` with `spec` on the chosen lights and `none` on the others.
pub fn renderer(gpu: &shadowlab::Gpu, setup: &Setup, spec: &shadowlab::TechniqueSpec) -> Result<shadowlab::Renderer> {
    let mut r = shadowlab::Renderer::new(gpu, setup.scene.clone(), &setup.view, setup.width, setup.height);
    let none = shadowlab::TechniqueSpec::parse("none", &[])?;
    for (i, light) in setup.scene.lights.iter().enumerate() {
        let id = LightId(i as u32);
        if setup.lights.contains(&id) {
            r.set_technique(id, spec).with_context(|| format!("light '{}'", light.name))?;
        } else {
            r.set_technique(id, &none)?;
        }
    }
    Ok(r)
}
