//! Scripts for headless runs (tests, the README's pictures): a TOML list of steps, each doing what
//! a user would do in the window.
//!
//! ```toml
//! [[step]]
//! light = "lamp"              # select a light (by name)
//! technique = "pcf:kernel=5"  # its technique
//! [[step]]
//! param = "kernel"            # one parameter of the selected light's technique
//! value = "7"
//! [[step]]
//! overlay = "sampling"        # none | visibility | splits | texels | sampling | fill | error
//! [[step]]
//! drag = "chair east"         # drag an instance by a world vector over `frames` frames, then release
//! by = [0.5, 0.0, 0.0]
//! frames = 8
//! [[step]]
//! view = "table"              # a named view of the scene
//! [[step]]
//! camera = "0,1.5,3:0,0.5,0:50"   # eye:target[:fov], as `shadowlab render --camera`
//! [[step]]
//! ab = "pcss"                 # A/B split: the selected light with pcss on the right half ("": off)
//! [[step]]
//! third_person = true         # the second camera, with the eye's and the light's map frusta
//! light_view = 2              # ... looking through the selected light's map view 2 (face, split)
//! [[step]]
//! truth = true                # trace the selected light's truth, frames drawn meanwhile; shows its error
//! [[step]]
//! frames = 3                  # just render frames
//! ```

use std::path::Path;

use serde::Deserialize;

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Script {
    #[serde(default)]
    pub step: Vec<Step>,
}

/// One step; the fields present run in this order: select the light, technique, parameter,
/// overlay, view, camera, A/B split, third-person view, light view, then the drag or the frames, then the truth.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Step {
    pub light: Option<String>,
    pub technique: Option<String>,
    pub param: Option<String>,
    pub value: Option<String>,
    pub overlay: Option<String>,
    pub view: Option<String>,
    pub camera: Option<String>,
    pub drag: Option<String>,
    pub by: Option<[f32; 3]>,
    /// The A/B split: the selected light with this technique on the right half ("" turns it off).
    pub ab: Option<String>,
    /// The third-person view on or off.
    pub third_person: Option<bool>,
    /// Look through map view k of the selected light (third-person view).
    pub light_view: Option<usize>,
    /// Trace the selected light's truth (the viewer keeps drawing until it is done).
    pub truth: Option<bool>,
    /// Frames to render (with `drag`: the frames the drag takes). Default 1.
    pub frames: Option<u32>,
}

/// The most frames one step may ask for (a typo should not run for hours).
pub const MAX_STEP_FRAMES: u32 = 1000;

impl Script {
    pub fn parse(text: &str) -> Result<Self, String> {
        let script: Script = toml::from_str(text).map_err(|e| e.to_string())?;
        for (i, s) in script.step.iter().enumerate() {
            let n = i + 1;
            if s.param.is_some() != s.value.is_some() {
                return Err(format!("step {n}: `param` and `value` go together"));
            }
            if s.drag.is_some() != s.by.is_some() {
                return Err(format!("step {n}: `drag` needs `by` (a world vector), and `by` a `drag`"));
            }
            if let Some(by) = s.by
                && !by.iter().all(|c| c.is_finite())
            {
                return Err(format!("step {n}: `by` must be finite"));
            }
            if s.frames.is_some_and(|f| f == 0 || f > MAX_STEP_FRAMES) {
                return Err(format!("step {n}: `frames` must be in 1..={MAX_STEP_FRAMES}"));
            }
        }
        Ok(script)
    }

    pub fn load(path: &Path) -> Result<Self, String> {
        let text = shadowlab_core::read_regular(path)
            .and_then(|b| String::from_utf8(b).map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e)))
            .map_err(|e| format!("{}: {e}", path.display()))?;
        Self::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scripts_parse_and_mistakes_are_errors() {
        let s = Script::parse("[[step]]\ntechnique = \"pcf\"\n[[step]]\ndrag = \"cup\"\nby = [1, 0, 0]\nframes = 4\n")
            .expect("valid");
        assert_eq!(s.step.len(), 2);
        assert_eq!(s.step[1].by, Some([1.0, 0.0, 0.0]));
        for bad in [
            "[[step]]\nparam = \"kernel\"\n",
            "[[step]]\ndrag = \"cup\"\n",
            "[[step]]\nframes = 0\n",
            "[[step]]\nframes = 100000\n",
            "[[step]]\ntecnique = \"pcf\"\n",
            "[[step]]\ndrag = \"cup\"\nby = [nan, 0, 0]\n",
            "step = 3",
        ] {
            assert!(Script::parse(bad).is_err(), "refused: {bad}");
        }
    }
}
