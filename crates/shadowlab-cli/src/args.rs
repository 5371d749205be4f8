//! Arguments shared by several commands (DESIGN.md §6).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use shadowlab_core::{LightId, Scene, View};

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
    /// A camera of your own instead of a named view: `X,Y,Z:TX,TY,TZ[:FOV_DEGREES]` (eye, target,
    /// vertical field of view; near and far from the view). The viewer's "copy command" writes it.
    #[arg(long, value_name = "EYE:TARGET[:FOV]", allow_hyphen_values = true)]
    pub camera: Option<String>,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "256x256", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Only these lights (names or indices, comma-separated) are shadowed and measured.
    #[arg(long, value_delimiter = ',')]
    pub lights: Vec<String>,
    /// Scale every light's emitter size; 0 makes all lights hard (points and single directions).
    #[arg(long, default_value_t = 1.0)]
    pub emitter_scale: f32,
    /// Emissive planar rectangles of a model (an OBJ's `Ke`, a glTF's emissive factor) become rect
    /// lights (the Cornell box's ceiling panel) instead of a default sun.
    #[arg(long)]
    pub emissive_lights: bool,
    /// Light meshes from `shadowlab precompute` for `lightmesh` (a file for another scene, an older
    /// format or a damaged file is reported, and the light meshes are computed instead).
    #[arg(long, value_name = "FILE")]
    pub light_meshes: Option<std::path::PathBuf>,
    /// GPU memory the shadow maps may take together, in MiB (0: no limit). Past it, map sizes
    /// are halved per light by screen importance, and the run says which.
    #[arg(long, value_name = "MIB", default_value_t = DEFAULT_MAP_BUDGET_MIB)]
    pub map_budget: u64,
}

/// `--map-budget`'s default: the engine's ([`shadowlab::DEFAULT_MAP_BUDGET`]) in MiB.
pub const DEFAULT_MAP_BUDGET_MIB: u64 = shadowlab::DEFAULT_MAP_BUDGET >> 20;

/// The scene, the chosen view and the chosen lights, ready to use.
pub struct Setup {
    pub scene: Scene,
    pub view: View,
    pub lights: Vec<LightId>,
    pub width: u32,
    pub height: u32,
    /// Light meshes read with `--light-meshes`, valid for `scene`.
    pub light_meshes: Vec<shadowlab_core::lightmesh::LightMesh>,
    /// `--map-budget` in bytes (`None`: no limit).
    pub map_budget: Option<u64>,
}

impl SceneArgs {
    pub fn load(&self) -> Result<Setup> {
        if !(self.emitter_scale.is_finite() && (0.0..=100.0).contains(&self.emitter_scale)) {
            bail!("--emitter-scale {} must be in [0, 100]", self.emitter_scale);
        }
        let options = shadowlab_core::LoadOptions { emissive_lights: self.emissive_lights };
        let loaded = shadowlab_core::load_scene_with(&self.scene, options)
            .with_context(|| format!("loading scene '{}'", self.scene))?;
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
        let view = match &self.camera {
            Some(text) => View::with_camera_text(&view, text).map_err(|e| anyhow::anyhow!("--camera: {e}"))?,
            None => view,
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
        let light_meshes = match &self.light_meshes {
            Some(path) => read_light_meshes(path, &scene)?,
            None => Vec::new(),
        };
        if self.map_budget > 1 << 30 {
            bail!("--map-budget {} MiB is more than any GPU holds (at most {} MiB)", self.map_budget, 1u64 << 30);
        }
        let map_budget = (self.map_budget > 0).then_some(self.map_budget << 20);
        Ok(Setup { scene, view, lights, width, height, light_meshes, map_budget })
    }
}

/// The light meshes of `path` still valid for `scene`. A missing file is an error (a typo); a stale,
/// foreign or damaged one is reported and ignored, and `lightmesh` computes its meshes.
fn read_light_meshes(path: &std::path::Path, scene: &Scene) -> Result<Vec<shadowlab_core::lightmesh::LightMesh>> {
    use shadowlab_core::lightmesh::file::{self, LightMeshFileError};
    match file::read(path, scene) {
        Ok(decoded) => {
            for &i in &decoded.stale {
                eprintln!(
                    "warning: --light-meshes {}: light '{}' moved since it was precomputed; its light mesh is computed again",
                    path.display(),
                    scene.lights[i].name
                );
            }
            Ok(decoded.meshes)
        }
        Err(e @ LightMeshFileError::Io { .. }) => Err(e.into()),
        Err(e) => {
            eprintln!("warning: --light-meshes {}: {e}; the light meshes are computed instead", path.display());
            Ok(Vec::new())
        }
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

/// Technique selection shared by render, compare, bench and play (and analyze, without `auto`).
#[derive(clap::Args, Debug, Clone)]
pub struct TechniqueArgs {
    /// Techniques with default parameters, comma-separated (`hard,pcf,sampled`; `auto`: one per
    /// light, chosen by measured error within a budget).
    #[arg(long, value_delimiter = ',', conflicts_with = "technique")]
    pub techniques: Vec<String>,
    /// A technique with parameters, `ID` or `ID:K=V,K=V`; repeat to compare configurations. `auto`
    /// gives each light the candidate with the lowest measured error that fits its share of
    /// `--budget-ms` (docs/calibration-format.md).
    #[arg(long)]
    pub technique: Vec<String>,
    /// Set a parameter on every technique that has it (`--set map_size=1024`).
    #[arg(long = "set", value_name = "K=V")]
    pub set: Vec<String>,
    /// With `auto`: the file `shadowlab calibrate` wrote (default: the built-in table by light type).
    #[arg(long, value_name = "FILE")]
    pub calibration: Option<PathBuf>,
    /// With `auto`: the frame's shadow budget in the calibration's ms, shared equally by the
    /// shadowed lights (default: 4 × the sum of their `hard` costs).
    #[arg(long, value_name = "MS")]
    pub budget_ms: Option<f64>,
    /// With `auto`: quality (the budget ×2), balanced (×1) or speed (×0.5).
    #[arg(long, value_name = "P", value_parser = ["quality", "balanced", "speed"])]
    pub preference: Option<String>,
}

/// The pseudo-technique that picks one technique per light.
pub const AUTO: &str = "auto";

impl TechniqueArgs {
    /// The specs as given, or `default` when none was.
    fn given(&self, default: &[&str]) -> Vec<String> {
        if !self.technique.is_empty() {
            self.technique.clone()
        } else if !self.techniques.is_empty() {
            self.techniques.iter().map(|t| t.trim().to_owned()).filter(|t| !t.is_empty()).collect()
        } else {
            default.iter().map(|s| (*s).to_owned()).collect()
        }
    }

    /// Whether any of `--calibration`, `--budget-ms`, `--preference` was given.
    fn auto_options_given(&self) -> bool {
        self.calibration.is_some() || self.budget_ms.is_some() || self.preference.is_some()
    }

    /// The specs given, or `default` when none was (`auto` is refused: for commands that set one
    /// technique on every light).
    pub fn specs(&self, default: &[&str]) -> Result<Vec<shadowlab::TechniqueSpec>> {
        let given = self.given(default);
        if given.iter().any(|s| s == AUTO) || self.auto_options_given() {
            bail!(
                "--technique auto (and --calibration, --budget-ms, --preference) is for render, compare, bench and play"
            );
        }
        let specs =
            given.iter().map(|s| shadowlab::TechniqueSpec::parse(s, &self.set)).collect::<Result<Vec<_>, _>>()?;
        shadowlab::registry::check_global_sets(&specs, &self.set)?;
        Ok(specs)
    }

    /// The techniques given (or `default`), `auto` resolved to one spec per light of
    /// `setup.lights`, which share the budget.
    pub fn selected(&self, setup: &Setup, default: &[&str]) -> Result<Vec<Selected>> {
        let given = self.given(default);
        let wants_auto = given.iter().any(|s| s == AUTO);
        if !wants_auto && self.auto_options_given() {
            bail!("--calibration, --budget-ms and --preference go with --technique auto");
        }
        let plan = if wants_auto { Some(std::rc::Rc::new(self.resolve_auto(setup)?)) } else { None };
        let selected = given
            .iter()
            .map(|s| match &plan {
                Some(p) if s == AUTO => Ok(Selected::Auto(p.clone())),
                _ => Ok(Selected::Spec(shadowlab::TechniqueSpec::parse(s, &self.set)?)),
            })
            .collect::<Result<Vec<_>>>()?;
        let mut all: Vec<shadowlab::TechniqueSpec> = Vec::new();
        for s in &selected {
            match s {
                Selected::Spec(spec) => all.push(spec.clone()),
                Selected::Auto(p) => all.extend(p.specs.iter().map(|(_, spec)| spec.clone())),
            }
        }
        shadowlab::registry::check_global_sets(&all, &self.set)?;
        Ok(selected)
    }

    /// Reads the calibration (or takes the built-in table) and chooses per light.
    fn resolve_auto(&self, setup: &Setup) -> Result<AutoPlan> {
        let preference = match &self.preference {
            Some(p) => shadowlab::auto::Preference::parse(p).with_context(|| format!("--preference {p}"))?,
            None => shadowlab::auto::Preference::default(),
        };
        let indices: Vec<u32> = setup.lights.iter().map(|id| id.0).collect();
        let (calibration, source) = match &self.calibration {
            Some(path) => {
                let cal = crate::commands::calibrate::read_calibration(path)?;
                if cal.scene != setup.scene.name {
                    bail!(
                        "calibration {} is for scene '{}', not '{}': run `shadowlab calibrate --scene ...` for this scene",
                        path.display(),
                        cal.scene,
                        setup.scene.name
                    );
                }
                for id in &setup.lights {
                    let light = &setup.scene.lights[id.index()];
                    match cal.light(id.0) {
                        Some(l) if l.name == light.name => {}
                        Some(l) => bail!(
                            "calibration {}: light {} is '{}' there, '{}' in the scene",
                            path.display(),
                            id.0,
                            l.name,
                            light.name
                        ),
                        None => {
                            bail!("calibration {} has no figures for light {} '{}'", path.display(), id.0, light.name)
                        }
                    }
                }
                (cal, path.display().to_string())
            }
            None => {
                let lights: Vec<(u32, String, String)> = setup
                    .lights
                    .iter()
                    .map(|id| {
                        let l = &setup.scene.lights[id.index()];
                        (id.0, l.name.clone(), l.type_name().to_owned())
                    })
                    .collect();
                (shadowlab::auto::Calibration::built_in(&setup.scene.name, &lights), "built-in table".to_owned())
            }
        };
        let calibration = calibration.only(&indices);
        let default_budget = calibration.default_budget_ms();
        let budget_ms = match self.budget_ms {
            Some(b) if b.is_finite() && b >= 0.0 => b,
            Some(b) => bail!("--budget-ms {b} must be a number ≥ 0"),
            None => default_budget,
        };
        let choices = shadowlab::auto::choose(&calibration, budget_ms, preference);
        let mut specs = Vec::with_capacity(choices.len());
        for c in &choices {
            let id = LightId(c.light);
            let light = &setup.scene.lights[id.index()];
            let spec = shadowlab::TechniqueSpec::parse(&c.spec, &self.set)
                .with_context(|| format!("auto: light '{}' from {source}", light.name))?;
            if !spec.info.supports(light) {
                bail!("auto: '{}' from {source} does not support {} light '{}'", c.spec, light.type_name(), light.name);
            }
            specs.push((id, spec));
        }
        Ok(AutoPlan {
            choices,
            specs,
            source,
            budget_ms,
            default_budget: self.budget_ms.is_none(),
            preference,
            light_types: setup
                .lights
                .iter()
                .map(|id| (id.0, setup.scene.lights[id.index()].type_name().to_owned()))
                .collect(),
        })
    }
}

/// `--technique auto` resolved: the spec each light got, and why.
#[derive(Debug)]
pub struct AutoPlan {
    pub choices: Vec<shadowlab::auto::Choice>,
    pub specs: Vec<(LightId, shadowlab::TechniqueSpec)>,
    /// The calibration file, or "built-in table".
    pub source: String,
    pub budget_ms: f64,
    /// Whether the budget is the default one (4 × the lights' `hard` costs).
    pub default_budget: bool,
    pub preference: shadowlab::auto::Preference,
    /// (light index, type) of the planned lights.
    light_types: Vec<(u32, String)>,
}

impl AutoPlan {
    /// The spec chosen for `light`, if it was planned.
    pub fn spec_for(&self, light: LightId) -> Option<&shadowlab::TechniqueSpec> {
        self.specs.iter().find(|(id, _)| *id == light).map(|(_, s)| s)
    }

    /// For a light added after planning (`play`): the choice of the first planned light of the
    /// same type, if any.
    pub fn like(&self, light: &shadowlab_core::Light) -> Option<(&shadowlab::auto::Choice, &shadowlab::TechniqueSpec)> {
        let (index, _) = self.light_types.iter().find(|(_, t)| t == light.type_name())?;
        let choice = self.choices.iter().find(|c| c.light == *index)?;
        Some((choice, self.spec_for(LightId(*index))?))
    }

    /// `[{light, name, spec, reason, share_ms, cost_ms, rmse, fits}]`: metrics.json's `auto`.
    pub fn choices_json(&self) -> serde_json::Value {
        serde_json::Value::Array(self.choices.iter().map(choice_json).collect())
    }

    /// The budget and where the figures came from.
    pub fn settings_json(&self) -> serde_json::Value {
        serde_json::json!({
            "budget_ms": self.budget_ms,
            "default_budget": self.default_budget,
            "preference": self.preference.name(),
            "budget_factor": self.preference.budget_factor(),
            "effective_budget_ms": self.budget_ms * self.preference.budget_factor(),
            "calibration": self.source,
        })
    }

    /// One line on the budget, then one per light: what it got, and why.
    pub fn describe(&self) -> Vec<String> {
        let mut lines = vec![format!(
            "auto: budget {:.3} ms{} × {} ({}) from {}, shared equally by {} light{}",
            self.budget_ms,
            if self.default_budget { " (default: 4 × hard)" } else { "" },
            self.preference.budget_factor(),
            self.preference.name(),
            self.source,
            self.choices.len(),
            if self.choices.len() == 1 { "" } else { "s" }
        )];
        for c in &self.choices {
            lines.push(format!("auto: light {} '{}' → {}: {}", c.light, c.name, c.spec, c.reason));
        }
        lines
    }
}

/// One choice as JSON (non-finite numbers as null).
pub fn choice_json(c: &shadowlab::auto::Choice) -> serde_json::Value {
    let num = |x: f64| if x.is_finite() { serde_json::json!(x) } else { serde_json::Value::Null };
    serde_json::json!({
        "light": c.light, "name": c.name, "spec": c.spec, "reason": c.reason,
        "share_ms": num(c.share_ms), "cost_ms": num(c.cost_ms), "rmse": num(c.rmse), "fits": c.fits,
    })
}

/// What a run sets on the chosen lights: one spec on every light, or one per light (`auto`).
#[derive(Debug, Clone)]
pub enum Selected {
    Spec(shadowlab::TechniqueSpec),
    Auto(std::rc::Rc<AutoPlan>),
}

impl Selected {
    /// The spec as given, or `auto`.
    pub fn label(&self) -> &str {
        match self {
            Selected::Spec(s) => &s.spec,
            Selected::Auto(_) => AUTO,
        }
    }

    /// The bare id, or `auto`.
    pub fn id(&self) -> &str {
        match self {
            Selected::Spec(s) => s.info.id,
            Selected::Auto(_) => AUTO,
        }
    }

    /// The parameters (`auto`: its budget and source).
    pub fn params_json(&self) -> serde_json::Value {
        match self {
            Selected::Spec(s) => s.params.to_json(),
            Selected::Auto(p) => p.settings_json(),
        }
    }

    pub fn auto(&self) -> Option<&AutoPlan> {
        match self {
            Selected::Spec(_) => None,
            Selected::Auto(p) => Some(p),
        }
    }

    /// The spec for `light` (`id`): the one spec, or the light's choice.
    pub fn spec_for(&self, id: LightId) -> Option<&shadowlab::TechniqueSpec> {
        match self {
            Selected::Spec(s) => Some(s),
            Selected::Auto(p) => p.spec_for(id),
        }
    }

    /// The chosen lights the technique cannot shadow (a rect light for `cascaded`): the renderer gives
    /// them `hard` instead ([`renderer_for`]), the reports list them as not applicable.
    pub fn unsupported(&self, setup: &Setup) -> Result<Vec<LightId>> {
        let mut out = Vec::new();
        for id in &setup.lights {
            let l = &setup.scene.lights[id.index()];
            let spec = self.spec_for(*id).with_context(|| format!("auto chose nothing for light '{}'", l.name))?;
            if !spec.info.supports(l) {
                out.push(*id);
            }
        }
        Ok(out)
    }

    /// Drops the techniques that no chosen light supports and warns about lights that fall back to
    /// `hard`, so that one technique that does not fit a light does not abort a comparison.
    pub fn keep_applicable(specs: Vec<Selected>, setup: &Setup) -> Result<Vec<Selected>> {
        let mut kept = Vec::with_capacity(specs.len());
        for spec in specs {
            let unsupported = spec.unsupported(setup)?;
            let names = |ids: &[LightId]| {
                ids.iter()
                    .map(|id| {
                        let l = &setup.scene.lights[id.index()];
                        format!("{} light '{}'", l.type_name(), l.name)
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            if unsupported.len() == setup.lights.len() {
                eprintln!("warning: '{}' supports none of the lights ({}): skipped", spec.label(), names(&unsupported));
                continue;
            }
            if !unsupported.is_empty() {
                eprintln!(
                    "warning: '{}' does not support {}: shadowed by `hard` there and left out of its figures",
                    spec.label(),
                    names(&unsupported)
                );
            }
            kept.push(spec);
        }
        anyhow::ensure!(!kept.is_empty(), "no technique applies to the chosen lights");
        Ok(kept)
    }
}

/// A renderer for `setup` with `spec` on the chosen lights and `none` on the others.
pub fn renderer(gpu: &shadowlab::Gpu, setup: &Setup, spec: &shadowlab::TechniqueSpec) -> Result<shadowlab::Renderer> {
    renderer_for(gpu, setup, &Selected::Spec(spec.clone()))
}

/// A renderer for `setup` with each chosen light's spec of `selected` and `none` on the others.
pub fn renderer_for(gpu: &shadowlab::Gpu, setup: &Setup, selected: &Selected) -> Result<shadowlab::Renderer> {
    let mut r = shadowlab::Renderer::new(gpu, setup.scene.clone(), &setup.view, setup.width, setup.height);
    r.shadows.set_map_budget(setup.map_budget);
    if !setup.light_meshes.is_empty() {
        r.provide_light_meshes(setup.light_meshes.clone());
    }
    let none = shadowlab::TechniqueSpec::parse("none", &[])?;
    for (i, light) in setup.scene.lights.iter().enumerate() {
        let id = LightId(i as u32);
        if setup.lights.contains(&id) {
            let spec =
                selected.spec_for(id).with_context(|| format!("auto chose nothing for light '{}'", light.name))?;
            if spec.info.supports(light) {
                r.set_technique(id, spec).with_context(|| format!("light '{}'", light.name))?;
            } else {
                // Not applicable to this light (`Selected::unsupported`): the baseline stands in.
                r.set_technique(id, &shadowlab::TechniqueSpec::parse("hard", &[])?)?;
            }
        } else {
            r.set_technique(id, &none)?;
        }
    }
    Ok(r)
}

/// What the map-memory budget did in `r`'s last frame, for `metrics.json`/`bench --json`:
/// `{budget_bytes, reduced: [{light, asked, granted}]}` (`budget_bytes` null without a limit).
pub fn map_budget_json(r: &shadowlab::Renderer) -> serde_json::Value {
    let reduced: Vec<serde_json::Value> = r
        .shadows
        .map_reductions()
        .into_iter()
        .map(|(light, asked, granted)| {
            let name = r.scene().lights.get(light.0 as usize).map_or("?", |l| l.name.as_str());
            serde_json::json!({ "light": name, "asked": asked, "granted": granted })
        })
        .collect();
    serde_json::json!({ "budget_bytes": r.shadows.map_budget(), "reduced": reduced })
}

/// Says on stderr which lights' maps the budget made smaller in `r` (`label`: the technique).
pub fn warn_map_reductions(r: &shadowlab::Renderer, label: &str) {
    let cut = r.shadows.map_reductions();
    if cut.is_empty() {
        return;
    }
    let budget = r.shadows.map_budget().map_or("no".to_owned(), |b| format!("{} MiB", b >> 20));
    let lights: Vec<String> = cut
        .iter()
        .map(|(l, a, g)| {
            let name = r.scene().lights.get(l.0 as usize).map_or("?", |l| l.name.as_str());
            format!("'{name}' {a}² → {g}²")
        })
        .collect();
    eprintln!("warning: {label}: shadow maps cut to fit the {budget} map budget (--map-budget): {}", lights.join(", "));
}
