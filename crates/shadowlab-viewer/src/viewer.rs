//! The viewer's state, apart from any window or UI toolkit: the live engine, the camera, each
//! light's technique, the overlay, the object being dragged. The UI (`ui.rs`) reads and changes it;
//! scripts (`script.rs`) drive the same methods, so a headless run does what a user would.

use glam::{Affine3A, Vec3};
use shadowlab::live::LiveScene;
use shadowlab::{Edit, FrameReport, Gpu, InstanceId, LightChange, Renderer, TechniqueSpec};
use shadowlab_core::bvh::{PreparedRay, SceneBvh, Selection};
use shadowlab_core::{LightId, Mobility, Scene};

use crate::camera::FlyCamera;

/// What can go wrong when the viewer opens or changes something.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    /// The loader's message names the scene or file itself.
    #[error("{message}")]
    Scene { spec: String, message: String },
    #[error("the scene has no view named '{name}' (views: {known})")]
    UnknownView { name: String, known: String },
    #[error("the scene has no light named '{name}' (lights: {known})")]
    UnknownLight { name: String, known: String },
    #[error("the scene has no instance named '{0}'")]
    UnknownInstance(String),
    #[error(transparent)]
    Technique(#[from] shadowlab::TechniqueError),
    #[error(transparent)]
    Edit(#[from] shadowlab::EditError),
    #[error(transparent)]
    Gpu(#[from] shadowlab::GpuError),
    #[error("{0}")]
    Other(String),
}

/// How the viewer starts.
#[derive(Debug, Clone)]
pub struct Setup {
    /// A built-in scene (with options) or a scene file, as the CLI's `--scene`.
    pub scene: String,
    /// A named view of the scene; `None`: its first.
    pub view: Option<String>,
    /// The scene image's size in pixels.
    pub width: u32,
    pub height: u32,
    /// The technique every light starts with (`ID` or `ID:K=V,...`).
    pub technique: String,
}

impl Default for Setup {
    fn default() -> Self {
        Self { scene: "room".into(), view: None, width: 480, height: 360, technique: "hard".into() }
    }
}

/// An analysis drawn over the scene image (`shadowlab::analysis`'s pictures, as `render --overlay`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Overlay {
    #[default]
    None,
    /// The selected light's visibility, black (shadowed) to white (lit).
    Visibility,
    /// Which map (cascade split, cube face) shades each pixel (Stingl 2011 §5.2's colours).
    Splits,
    /// The projected texel grid of the selected light's maps (Stingl 2011 §5.2).
    Texels,
    /// Map texels per screen pixel (Stingl 2011 Listing A.3: red undersampled, green 1:1, blue over).
    Sampling,
    /// Shadow-volume fragments per pixel of every light (Hasselgren 2003 Fig. 8's overdraw).
    Fill,
    /// The selected light's error against the ray-traced truth (blue: too dark, red: too bright),
    /// once traced for the frame shown.
    Error,
}

impl Overlay {
    pub const ALL: [Overlay; 7] = [
        Overlay::None,
        Overlay::Visibility,
        Overlay::Splits,
        Overlay::Texels,
        Overlay::Sampling,
        Overlay::Fill,
        Overlay::Error,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Visibility => "visibility",
            Self::Splits => "splits",
            Self::Texels => "texels",
            Self::Sampling => "sampling",
            Self::Fill => "fill",
            Self::Error => "error",
        }
    }

    pub fn parse(text: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|o| o.name() == text)
    }
}

/// The A/B split: the selected light with another technique, in a renderer of its own, shown on
/// the right half of the scene image.
pub struct AbSplit {
    pub light: usize,
    pub spec: TechniqueSpec,
    renderer: Renderer,
    /// The scene epoch, the techniques' version and the size it was built for.
    built: (u64, u64, (u32, u32)),
}

/// An object being dragged: it slides on the horizontal plane through the point where it was
/// picked (its supporting plane for furniture on a floor).
#[derive(Debug, Clone)]
struct Drag {
    instance: InstanceId,
    /// Its mobility before the drag, restored on release.
    mobility: Mobility,
    start: Affine3A,
    /// The picked point and the plane's height.
    anchor: Vec3,
}

pub struct Viewer {
    pub renderer: Renderer,
    pub camera: FlyCamera,
    setup: Setup,
    /// Per light (scene order): the technique it is shadowed with.
    specs: Vec<TechniqueSpec>,
    pub selected_light: usize,
    pub overlay: Overlay,
    /// The map view picked to look through when there are many (samples × faces).
    pub light_view_index: usize,
    /// Texels between texel-grid lines.
    pub grid: u32,
    drag: Option<Drag>,
    pub last: Option<FrameReport>,
    pub frames: u64,
    /// The truth being traced, and the last one traced.
    #[cfg(feature = "truth")]
    pub truth_job: Option<crate::truth::TruthJob>,
    #[cfg(feature = "truth")]
    pub truth: Option<crate::truth::Truth>,
    /// Emitter samples per pixel of the traced truth.
    pub truth_samples: u32,
    /// What the shown frame depends on (camera, scene edits, techniques): a traced truth is
    /// current while it is unchanged.
    state: u64,
    /// The camera and the scene's edit epoch of the last frame.
    shown: u64,
    /// The A/B split, when on.
    pub ab: Option<AbSplit>,
    /// The third-person view, when on.
    pub third_person: Option<crate::third_person::ThirdPerson>,
    /// Counts technique changes (the third-person renderer follows them).
    specs_version: u64,
    /// A camera path being played: its views and the next one.
    path: Option<(Vec<shadowlab_core::View>, usize)>,
    /// The last error or message for the status line.
    pub status: String,
}

impl Viewer {
    pub fn new(gpu: &Gpu, setup: Setup) -> Result<Self, ViewerError> {
        let loaded = Self::load(&setup)?;
        Self::with_scene(gpu, setup, loaded)
    }

    /// Loads and checks what `setup` names (no GPU): a windowed run does this before it opens
    /// its window, so that a mistyped scene is an error, not an empty window.
    pub fn load(setup: &Setup) -> Result<shadowlab_core::load::Loaded, ViewerError> {
        let loaded = shadowlab_core::load::load_scene(&setup.scene)
            .map_err(|e| ViewerError::Scene { spec: setup.scene.clone(), message: e.to_string() })?;
        if let Some(name) = &setup.view {
            find_view(&loaded.scene, name)?;
        }
        check_size(setup.width, setup.height)?;
        TechniqueSpec::parse(&setup.technique, &[])?;
        Ok(loaded)
    }

    /// The viewer of a scene [`Viewer::load`] loaded for `setup`.
    pub fn with_scene(gpu: &Gpu, setup: Setup, loaded: shadowlab_core::load::Loaded) -> Result<Self, ViewerError> {
        let scene = loaded.scene;
        let view = match &setup.view {
            Some(name) => find_view(&scene, name)?,
            None => scene.views.first().cloned().ok_or_else(|| ViewerError::Other("the scene has no view".into()))?,
        };
        check_size(setup.width, setup.height)?;
        let spec = TechniqueSpec::parse(&setup.technique, &[])?;
        let camera = FlyCamera::from_view(&view, scene.bounds().diagonal());
        let mut renderer = Renderer::new(gpu, scene.clone(), &view, setup.width, setup.height);
        let mut specs = Vec::new();
        for (i, light) in scene.lights.iter().enumerate() {
            // A technique that does not shadow this light type: the baseline stands in.
            let s = if spec.info.supports(light) { spec.clone() } else { TechniqueSpec::parse("hard", &[])? };
            renderer.set_technique(LightId(i as u32), &s)?;
            specs.push(s);
        }
        let status = loaded.warnings.join("; ");
        Ok(Self {
            renderer,
            camera,
            setup,
            specs,
            selected_light: 0,
            overlay: Overlay::None,
            light_view_index: 0,
            grid: 4,
            drag: None,
            last: None,
            frames: 0,
            #[cfg(feature = "truth")]
            truth_job: None,
            #[cfg(feature = "truth")]
            truth: None,
            truth_samples: 64,
            state: 0,
            shown: 0,
            path: None,
            third_person: None,
            ab: None,
            specs_version: 0,
            status,
        })
    }

    pub fn scene(&self) -> &Scene {
        self.renderer.scene()
    }

    fn live(&self) -> &LiveScene {
        self.renderer.shadows.live()
    }

    pub fn size(&self) -> (u32, u32) {
        (self.renderer.width, self.renderer.height)
    }

    /// The technique of light `light` (scene order).
    pub fn spec(&self, light: usize) -> Option<&TechniqueSpec> {
        self.specs.get(light)
    }

    /// Counts changes of what the shown frame depends on (camera, scene edits, techniques).
    pub fn state(&self) -> u64 {
        self.state
    }

    /// The live engine's id of light `light` (scene order).
    pub fn light_id(&self, light: usize) -> Result<LightId, ViewerError> {
        self.live().lights().get(light).map(|s| s.id).ok_or_else(|| ViewerError::Other(format!("no light {light}")))
    }

    /// The index of the light named `name`.
    pub fn find_light(&self, name: &str) -> Result<usize, ViewerError> {
        self.scene().lights.iter().position(|l| l.name == name).ok_or_else(|| ViewerError::UnknownLight {
            name: name.into(),
            known: self.scene().lights.iter().map(|l| l.name.as_str()).collect::<Vec<_>>().join(", "),
        })
    }

    /// Shadows light `light` with `spec` (`ID` or `ID:K=V,...`); on an error nothing changes.
    pub fn set_technique(&mut self, light: usize, spec: &str) -> Result<(), ViewerError> {
        let spec = TechniqueSpec::parse(spec, &[])?;
        self.apply_spec(light, spec)
    }

    /// Sets one parameter of light `light`'s technique (`value` as text, as on the command line).
    pub fn set_param(&mut self, light: usize, name: &str, value: &str) -> Result<(), ViewerError> {
        let Some(current) = self.specs.get(light) else { return Err(ViewerError::Other(format!("no light {light}"))) };
        let mut spec = current.clone();
        spec.params
            .set(name, value)
            .map_err(|source| shadowlab::TechniqueError::Param { id: spec.info.id.into(), source })?;
        spec.spec = spec_text(&spec);
        self.apply_spec(light, spec)
    }

    fn apply_spec(&mut self, light: usize, spec: TechniqueSpec) -> Result<(), ViewerError> {
        let Some(l) = self.scene().lights.get(light) else {
            return Err(ViewerError::Other(format!("no light {light}")));
        };
        if !spec.info.supports(l) {
            return Err(ViewerError::Other(format!(
                "'{}' does not shadow {} lights like '{}' (it shadows: {})",
                spec.info.id,
                l.type_name(),
                l.name,
                spec.info.light_types.join(", ")
            )));
        }
        self.renderer.set_technique(self.light_id(light)?, &spec)?;
        self.specs[light] = spec;
        self.state += 1;
        self.specs_version += 1;
        Ok(())
    }

    /// Shows the selected light with `spec` on the right half of the image (the A/B split), or
    /// turns the split off (`None`).
    pub fn set_ab(&mut self, spec: Option<&str>) -> Result<(), ViewerError> {
        let Some(text) = spec else {
            self.ab = None;
            return Ok(());
        };
        let spec = TechniqueSpec::parse(text, &[])?;
        let light = self.selected_light;
        let Some(l) = self.scene().lights.get(light) else {
            return Err(ViewerError::Other(format!("no light {light}")));
        };
        if !spec.info.supports(l) {
            return Err(ViewerError::Other(format!("'{}' does not shadow {} lights", spec.info.id, l.type_name())));
        }
        let mut specs = self.specs.clone();
        specs[light] = spec.clone();
        let built = (self.live().epoch(), self.specs_version, self.size());
        let renderer =
            crate::third_person::build(&self.renderer.gpu, self.scene(), &specs, &self.camera.view(), built.2)?;
        self.ab = Some(AbSplit { light, spec, renderer, built });
        Ok(())
    }

    /// Turns the third-person view on (a second camera behind the eye, with the frusta drawn) or off.
    pub fn set_third_person(&mut self, on: bool) -> Result<(), ViewerError> {
        if on == self.third_person.is_some() {
            return Ok(());
        }
        self.third_person = if on {
            let built = (self.live().epoch(), self.specs_version);
            let gpu = self.renderer.gpu.clone();
            Some(crate::third_person::ThirdPerson::new(
                &gpu,
                self.scene(),
                &self.specs,
                &self.camera,
                self.size(),
                built,
            )?)
        } else {
            None
        };
        Ok(())
    }

    /// The camera the keys and the mouse move: the third person's when that view is on (leaving a
    /// light view it looked through, from where it was).
    pub fn active_camera(&mut self) -> &mut FlyCamera {
        let diagonal = self.renderer.scene().bounds().diagonal();
        match &mut self.third_person {
            Some(tp) => {
                if let Some(v) = tp.fixed.take() {
                    tp.camera = FlyCamera::from_view(&v, diagonal);
                }
                &mut tp.camera
            }
            None => &mut self.camera,
        }
    }

    /// Looks through map view `k` of the selected light (a cube face, a cascade split) in the
    /// third-person view (turned on if off), with the eye's frustum drawn in: Stingl 2011 §5's
    /// light views.
    pub fn look_from_light_view(&mut self, k: usize) -> Result<(), ViewerError> {
        let views = self.renderer.light_views(self.light_id(self.selected_light)?);
        let Some(view) = views.get(k) else {
            return Err(ViewerError::Other(format!(
                "the selected light's technique has {} map views here; no view {k}",
                views.len()
            )));
        };
        let camera = crate::third_person::light_view_camera(view, self.scene().bounds().diagonal());
        self.set_third_person(true)?;
        if let Some(tp) = &mut self.third_person {
            tp.fixed = Some(camera);
        }
        Ok(())
    }

    /// The lines of the third-person view: the eye's frustum (to the scene's size), the focus body
    /// H = V ∩ S (extruded towards a directional light: B), where the selected light is and where it
    /// shines, and its map views of the frame shown.
    pub fn frusta(&self) -> Vec<crate::third_person::Segment> {
        use crate::third_person::{eye_frustum, focus_body, focus_extrusion, light_marker, view_colour, view_frustum};
        let (w, h) = self.size();
        let (eye, aspect, bounds) = (self.camera.view(), w as f32 / h.max(1) as f32, self.scene().bounds());
        let mut s = eye_frustum(&eye, aspect, bounds.diagonal());
        let body = focus_body(&eye, aspect, &bounds);
        if let Some(light) = self.scene().lights.get(self.selected_light) {
            s.extend(focus_extrusion(&body, &bounds, light));
            s.extend(light_marker(light, &bounds));
        }
        s.extend(body);
        if let Ok(id) = self.light_id(self.selected_light) {
            // Sampled lights have a view per sample and face: the first ones make the point.
            for (k, v) in self.renderer.light_views(id).iter().take(MAX_DRAWN_VIEWS).enumerate() {
                s.extend(view_frustum(v, view_colour(k)));
            }
        }
        s
    }

    /// The predicted perspective aliasing error (`(z, m_x, m_z)` along the view direction,
    /// per split) of the selected light's `cascaded` maps for the camera now: `shadowlab analyze`'s
    /// curves, live (Stingl 2011 §2). `None` for other techniques.
    pub fn aliasing_curves(&self) -> Option<Vec<Vec<(f32, f32, f32)>>> {
        use shadowlab_core::cascades::{CascadeSettings, aliasing_curves, compute_cascades};
        let spec = self.specs.get(self.selected_light).filter(|s| s.info.id == "cascaded")?;
        let light = self.scene().lights.get(self.selected_light)?;
        let settings = shadowlab::techniques::cascade_settings(&spec.params, light).ok()?;
        let (w, h) = self.size();
        let (view, aspect, bounds) = (self.camera.view(), w as f32 / h.max(1) as f32, self.scene().bounds());
        let frame = compute_cascades(light, &bounds, &view, aspect, &settings);
        let focused =
            compute_cascades(light, &bounds, &view, aspect, &CascadeSettings { focus: true, ..settings.clone() });
        Some(aliasing_curves(&frame, &focused, view.fov_y, (w, h), settings.map_size, 48))
    }

    /// Moves the camera to the scene's view `name`.
    pub fn go_to_view(&mut self, name: &str) -> Result<(), ViewerError> {
        let view = find_view(self.scene(), name)?;
        let diagonal = self.scene().bounds().diagonal();
        self.path = None;
        self.camera = FlyCamera::from_view(&view, diagonal);
        Ok(())
    }

    /// Plays the scene's camera path `name`, one view per frame.
    pub fn play_path(&mut self, name: &str) -> Result<(), ViewerError> {
        let scene = self.scene();
        let path = scene.paths.iter().find(|p| p.name == name).ok_or_else(|| {
            ViewerError::Other(format!(
                "the scene has no camera path '{name}' (paths: {})",
                scene.paths.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join(", ")
            ))
        })?;
        self.path = Some((path.views(), 0));
        Ok(())
    }

    /// The camera path being played: (frame, frames).
    pub fn path_progress(&self) -> Option<(usize, usize)> {
        self.path.as_ref().map(|(v, n)| (*n, v.len()))
    }

    /// Changes a light's colour (an edit that invalidates no shadow data).
    pub fn set_light_colour(&mut self, light: usize, colour: Vec3) -> Result<(), ViewerError> {
        self.edit_light(light, LightChange::Color(colour))
    }

    pub fn set_light_intensity(&mut self, light: usize, intensity: f32) -> Result<(), ViewerError> {
        self.edit_light(light, LightChange::Intensity(intensity))
    }

    /// Any change of light `light` through the live engine (position, radius, size, ...).
    pub fn edit_light(&mut self, light: usize, change: LightChange) -> Result<(), ViewerError> {
        let Some(state) = self.live().lights().get(light) else {
            return Err(ViewerError::Other(format!("no light {light}")));
        };
        let id = state.id;
        self.renderer.apply(Edit::Light { light: id, change })?;
        Ok(())
    }

    /// Renders a frame from the camera; keeps its report.
    pub fn render(&mut self) -> Result<&FrameReport, ViewerError> {
        if let Some((views, next)) = &mut self.path {
            let diagonal = self.renderer.scene().bounds().diagonal();
            match views.get(*next) {
                Some(v) => {
                    self.camera = FlyCamera::from_view(v, diagonal);
                    *next += 1;
                }
                None => self.path = None,
            }
        }
        let view = self.camera.view();
        self.renderer.set_view(&view);
        let report = self.renderer.render()?;
        // After the frame: a light still refining (a quality ladder, fills spread over frames)
        // changes what is shown without any edit.
        let levels = self.renderer.shadows.levels();
        let signature = state_signature(&view, self.live().epoch(), self.size(), &levels);
        if signature != self.shown {
            self.shown = signature;
            self.state += 1;
        }
        let size = self.size();
        if let Some(ab) = &mut self.ab {
            let built = (self.renderer.shadows.live().epoch(), self.specs_version, size);
            if built != ab.built {
                let mut specs = self.specs.clone();
                specs[ab.light] = ab.spec.clone();
                ab.renderer =
                    crate::third_person::build(&self.renderer.gpu, self.renderer.scene(), &specs, &view, built.2)?;
                ab.built = built;
            }
            ab.renderer.set_view(&view);
            ab.renderer.render()?;
        }
        if let Some(tp) = &mut self.third_person {
            let built = (self.renderer.shadows.live().epoch(), self.specs_version);
            let size = (self.renderer.width, self.renderer.height);
            tp.render(&self.renderer.gpu, self.renderer.scene(), &self.specs, size, built)?;
        }
        self.frames += 1;
        Ok(self.last.insert(report))
    }

    /// The image with the overlay drawn in, RGBA8 (sRGB), top row first.
    pub fn image_rgba(&self) -> Result<Vec<u8>, ViewerError> {
        use shadowlab::analysis::{MapPicture, compose_fill, compose_maps};
        let image = self.renderer.read_image()?;
        let light = self.light_id(self.selected_light)?;
        let maps = |picture: MapPicture, what: &str| -> Result<Vec<u8>, ViewerError> {
            let o = self.renderer.map_overlay(light, self.grid)?.ok_or_else(|| self.no_maps(what))?;
            Ok(compose_maps(&image, &o, picture))
        };
        let rgb = match self.overlay {
            Overlay::None => image.clone(),
            Overlay::Visibility => match self.renderer.read_visibility(light)? {
                Some(v) => v.iter().flat_map(|&x| [(x.clamp(0.0, 1.0) * 255.0).round() as u8; 3]).collect(),
                None => image.clone(),
            },
            Overlay::Splits => maps(MapPicture::Splits, "the splits overlay")?,
            Overlay::Texels => maps(MapPicture::Texels, "the texel grid")?,
            Overlay::Sampling => maps(MapPicture::Sampling, "the sampling overlay")?,
            Overlay::Fill => {
                let lights: Vec<LightId> = self.live().lights().iter().map(|s| s.id).collect();
                let counts = self.renderer.fill_counts(&lights)?.ok_or_else(|| {
                    ViewerError::Other(
                        "the fill overlay needs shadow volumes (volumes, lightmesh, lightmaps over volumes)".into(),
                    )
                })?;
                compose_fill(&image, &counts)
            }
            Overlay::Error => self.error_heatmap()?,
        };
        let mut rgba: Vec<u8> = rgb.chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect();
        if let Some(ab) = &self.ab {
            self.compose_ab(ab, &mut rgba)?;
        }
        Ok(rgba)
    }

    /// The traced truth's heatmap of the frame shown and the selected light.
    fn error_heatmap(&self) -> Result<Vec<u8>, ViewerError> {
        #[cfg(feature = "truth")]
        if let Some(t) = self.current_truth()
            && (t.width, t.height) == self.size()
        {
            return Ok(t.heatmap.clone());
        }
        Err(ViewerError::Other(
            "the error overlay needs the truth of this frame and light: press T (trace the truth)".into(),
        ))
    }

    /// The right half of `rgba` from the A/B split's renderer (its visibility with the visibility
    /// overlay, else its image), a white line between.
    fn compose_ab(&self, ab: &AbSplit, rgba: &mut [u8]) -> Result<(), ViewerError> {
        let (w, h) = self.size();
        let b: Vec<[u8; 3]> = match self.overlay {
            Overlay::Visibility => {
                let id = ab.renderer.shadows.live().lights().get(ab.light).map(|s| s.id);
                let v = match id {
                    Some(id) => ab.renderer.read_visibility(id)?.unwrap_or_default(),
                    None => Vec::new(),
                };
                v.iter().map(|&x| [(x.clamp(0.0, 1.0) * 255.0).round() as u8; 3]).collect()
            }
            _ => ab.renderer.read_image()?.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect(),
        };
        let half = w / 2;
        for y in 0..h as usize {
            for x in half as usize..w as usize {
                let i = y * w as usize + x;
                let c = if x <= half as usize + 1 { [255; 3] } else { b.get(i).copied().unwrap_or([0; 3]) };
                rgba[4 * i..4 * i + 3].copy_from_slice(&c);
            }
        }
        Ok(())
    }

    fn no_maps(&self, what: &str) -> ViewerError {
        let id = self.specs.get(self.selected_light).map_or("?", |s| s.info.id);
        ViewerError::Other(format!("{what} needs a technique that shades from one map per pixel, not '{id}'"))
    }

    /// The instance under pixel `(x, y)` of the scene image (a CPU ray on the scene's BVH).
    pub fn pick(&self, x: f32, y: f32) -> Option<(usize, Vec3)> {
        let (w, h) = self.size();
        // Off the image (or NaN): nothing.
        if !((0.0..w as f32).contains(&x) && (0.0..h as f32).contains(&y)) {
            return None;
        }
        let (origin, dir) = self.camera.ray(x, y, w, h);
        let bvh = SceneBvh::build(self.scene(), Selection::All);
        let ray = PreparedRay::new(origin, dir, 0.0, f32::INFINITY);
        let hit = bvh.closest(&ray, |_, _| true)?;
        let tri = bvh.triangles()[hit.index as usize];
        Some((tri.instance as usize, origin + dir * hit.t))
    }

    /// Starts dragging the instance under `(x, y)` (made temporary: the caches leave it out);
    /// false when nothing is there.
    pub fn begin_drag(&mut self, x: f32, y: f32) -> Result<bool, ViewerError> {
        self.end_drag()?;
        let Some((index, anchor)) = self.pick(x, y) else { return Ok(false) };
        self.begin_drag_of(index, anchor)?;
        Ok(true)
    }

    fn begin_drag_of(&mut self, index: usize, anchor: Vec3) -> Result<(), ViewerError> {
        let instance = self.live().instances()[index].id;
        let inst = &self.scene().instances[index];
        let (mobility, start) = (inst.mobility, inst.transform);
        self.renderer.apply(Edit::Mobility { instance, mobility: Mobility::Temporary })?;
        self.drag = Some(Drag { instance, mobility, start, anchor });
        Ok(())
    }

    /// Moves the dragged object so that the picked point follows the cursor on its plane.
    pub fn drag_to(&mut self, x: f32, y: f32) -> Result<(), ViewerError> {
        let Some(drag) = &self.drag else { return Ok(()) };
        let (w, h) = self.size();
        let (origin, dir) = self.camera.ray(x, y, w, h);
        // The horizontal plane through the anchor; a ray nearly parallel to it leaves the object.
        if dir.y.abs() < 1e-4 {
            return Ok(());
        }
        let t = (drag.anchor.y - origin.y) / dir.y;
        if !(t > 0.0 && t.is_finite()) {
            return Ok(());
        }
        let by = origin + dir * t - drag.anchor;
        self.move_dragged(by)
    }

    fn move_dragged(&mut self, by: Vec3) -> Result<(), ViewerError> {
        let Some(drag) = &self.drag else { return Ok(()) };
        let mut transform = drag.start;
        transform.translation += glam::Vec3A::from(by);
        self.renderer.apply(Edit::Transform { instance: drag.instance, transform })?;
        Ok(())
    }

    /// Releases the dragged object: permanent again, the caches it reaches rebuilt once.
    pub fn end_drag(&mut self) -> Result<(), ViewerError> {
        if let Some(drag) = self.drag.take() {
            self.renderer.apply(Edit::Mobility { instance: drag.instance, mobility: drag.mobility })?;
        }
        Ok(())
    }

    pub fn dragging(&self) -> Option<&str> {
        let drag = self.drag.as_ref()?;
        self.live().instance(drag.instance).map(|i| i.name.as_str())
    }

    /// Drags instance `name` by `by` (world units) over `steps` rendered frames, then releases it
    /// (scripts; the same edits as a mouse drag).
    pub fn drag_by(&mut self, name: &str, by: Vec3, steps: u32) -> Result<(), ViewerError> {
        self.end_drag()?;
        let id = self.live().find_instance(name).ok_or_else(|| ViewerError::UnknownInstance(name.into()))?;
        let index = self.live().instance_index(id).ok_or_else(|| ViewerError::UnknownInstance(name.into()))?;
        let anchor = self.live().instances()[index].bounds.center();
        self.begin_drag_of(index, anchor)?;
        let steps = steps.max(1);
        for k in 1..=steps {
            self.move_dragged(by * (k as f32 / steps as f32))?;
            self.render()?;
        }
        self.end_drag()
    }

    /// Starts tracing the selected light's truth for the frame shown (a background thread).
    #[cfg(feature = "truth")]
    pub fn start_truth(&mut self, samples: u32) -> Result<(), ViewerError> {
        if self.truth_job.is_some() {
            return Err(ViewerError::Other("the truth is being traced already".into()));
        }
        let job = crate::truth::TruthJob::start(self, self.selected_light, samples)?;
        self.truth_job = Some(job);
        Ok(())
    }

    /// Takes the finished truth, if the trace has ended (each frame); true when one arrived.
    #[cfg(feature = "truth")]
    pub fn poll_truth(&mut self) -> Result<bool, ViewerError> {
        let Some(job) = &mut self.truth_job else { return Ok(false) };
        let Some(result) = job.poll() else { return Ok(false) };
        self.truth_job = None;
        self.truth = Some(result?);
        Ok(true)
    }

    /// The last traced truth, if it is for the frame shown and the selected light.
    #[cfg(feature = "truth")]
    pub fn current_truth(&self) -> Option<&crate::truth::Truth> {
        self.truth.as_ref().filter(|t| t.frame == self.state && t.light == self.selected_light)
    }

    /// The `shadowlab render` command that reproduces this view with the selected light's
    /// technique. `render` gives every light one technique (the baseline where it does not apply),
    /// so lights set to others here are listed after a `#`: the command does not reproduce them.
    pub fn cli_command(&self) -> String {
        let v = self.camera.view();
        let (w, h) = self.size();
        let spec = self.specs.get(self.selected_light).map_or_else(|| "hard".into(), spec_text);
        let f = |p: Vec3| format!("{:.3},{:.3},{:.3}", p.x, p.y, p.z);
        let mut command = format!(
            "shadowlab render --scene {} --size {w}x{h} --technique '{spec}' --camera {}:{}:{:.1} --out view.png",
            shell_word(&self.setup.scene),
            f(v.position),
            f(v.target),
            v.fov_y.to_degrees()
        );
        let selected = self.specs.get(self.selected_light);
        // A light the selected technique does not take gets `hard` from `render` too.
        let substituted =
            |l: &shadowlab_core::Light, s: &str| s == "hard" && selected.is_some_and(|x| !x.info.supports(l));
        let others: Vec<String> = self
            .scene()
            .lights
            .iter()
            .zip(&self.specs)
            .map(|(l, s)| (l, spec_text(s)))
            .filter(|(l, s)| *s != spec && !substituted(l, s))
            .map(|(l, s)| format!("'{}' {s}", l.name))
            .collect();
        if !others.is_empty() {
            command.push_str(&format!("  # not reproduced: {}", others.join(", ")));
        }
        command
    }
}

/// The scene's view `name`, or an error naming the views it has.
fn find_view(scene: &Scene, name: &str) -> Result<shadowlab_core::View, ViewerError> {
    scene.view(name).cloned().ok_or_else(|| ViewerError::UnknownView {
        name: name.into(),
        known: scene.views.iter().map(|v| v.name.as_str()).collect::<Vec<_>>().join(", "),
    })
}

/// `ID` followed by the parameters that differ from their defaults (`pcf:kernel=5`).
pub fn spec_text(spec: &TechniqueSpec) -> String {
    let changed: Vec<String> = spec
        .params
        .iter()
        .filter(|(def, value)| def.default != **value)
        .map(|(def, value)| format!("{}={}", def.name, value))
        .collect();
    if changed.is_empty() { spec.info.id.to_owned() } else { format!("{}:{}", spec.info.id, changed.join(",")) }
}

/// The most map views the third-person view draws (64 samples of a cube make 384).
const MAX_DRAWN_VIEWS: usize = 48;

/// A hash of what the frame shown depends on besides the techniques: the camera, the scene's edit
/// epoch, the image size, and each light's quality level and whether it is current.
fn state_signature(
    view: &shadowlab_core::View,
    epoch: u64,
    size: (u32, u32),
    levels: &[(LightId, u32, bool, u32)],
) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for v in [view.position, view.target, view.up] {
        v.to_array().map(f32::to_bits).hash(&mut h);
    }
    [view.fov_y, view.near, view.far].map(f32::to_bits).hash(&mut h);
    (epoch, size).hash(&mut h);
    for &(id, level, current, samples) in levels {
        (id.0, level, current, samples).hash(&mut h);
    }
    h.finish()
}

fn shell_word(text: &str) -> String {
    if text.chars().all(|c| c.is_ascii_alphanumeric() || "-_.:/=,".contains(c)) {
        text.to_owned()
    } else {
        format!("'{}'", text.replace('\'', "'\\''"))
    }
}

fn check_size(width: u32, height: u32) -> Result<(), ViewerError> {
    if !(16..=8192).contains(&width) || !(16..=8192).contains(&height) {
        return Err(ViewerError::Other(format!("image size {width}×{height}: each side must be in 16..=8192")));
    }
    Ok(())
}
