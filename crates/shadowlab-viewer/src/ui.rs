//! The egui side: the panel (frame time, what the cache re-did, each light's technique with a
//! widget per parameter built from its `ParamDef`, the overlay) and the scene image, through which
//! the mouse and keys fly the camera and drag objects. Window-independent: the windowed and the
//! headless runs both call [`Ui::run`].

use egui::{Key, PointerButton, Sense};
use glam::Vec3;
use shadowlab::LightChange;
use shadowlab::registry;
use shadowlab_core::params::{ParamDef, ParamKind};
use shadowlab_core::{LightKind, ParamValue};

use crate::viewer::{Overlay, Viewer, spec_text};

/// The panel's width in pixels: the window is this much wider than the scene image.
pub const PANEL_WIDTH: u32 = 300;

/// Mouse look: radians per pixel.
const LOOK_SENSITIVITY: f32 = 0.004;

/// What the UI asks of the program around it (things a window does differently from a script).
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Requests {
    /// Text for the clipboard (the CLI command).
    pub copy: Option<String>,
    /// Save a screenshot of the window.
    pub screenshot: bool,
}

/// The egui context and the UI's own state.
pub struct Ui {
    pub ctx: egui::Context,
    /// The scene image's texture as egui knows it.
    pub scene_texture: egui::TextureId,
    /// The eye's image as a minimap in the third-person view.
    pub minimap_texture: egui::TextureId,
}

impl Ui {
    pub fn new(scene_texture: egui::TextureId, minimap_texture: egui::TextureId) -> Self {
        let ctx = egui::Context::default();
        ctx.set_visuals(egui::Visuals::dark());
        Self { ctx, scene_texture, minimap_texture }
    }

    /// One UI pass over `input`: changes `viewer` as the user asked (the scene is rendered after,
    /// so the image shown is this frame's). `seconds`: time since the last frame (camera travel).
    pub fn run(&mut self, viewer: &mut Viewer, input: egui::RawInput, seconds: f32) -> (egui::FullOutput, Requests) {
        let mut requests = Requests::default();
        let textures = (self.scene_texture, self.minimap_texture);
        #[cfg(feature = "truth")]
        match viewer.poll_truth() {
            // A new truth: show its error.
            Ok(true) => viewer.overlay = Overlay::Error,
            Ok(false) => {}
            Err(e) => viewer.status = e.to_string(),
        }
        let output = self.ctx.run_ui(input, |ui| {
            egui::Panel::left("panel").exact_size(PANEL_WIDTH as f32).resizable(false).show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| panel(ui, viewer, &mut requests));
            });
            egui::CentralPanel::no_frame().show(ui, |ui| scene_area(ui, viewer, textures, seconds));
        });
        (output, requests)
    }
}

fn panel(ui: &mut egui::Ui, viewer: &mut Viewer, requests: &mut Requests) {
    ui.heading("shadowlab");
    let (w, h) = viewer.size();
    ui.label(format!("{} · {w}×{h}", viewer.scene().name));
    if let Some(r) = &viewer.last {
        let gpu = r.gpu.as_ref().map_or_else(|| "—".into(), |t| format!("{:.2} ms", t.total()));
        ui.label(format!("frame: GPU {gpu} · CPU {:.2} ms", r.cpu_ms));
        let w = &r.work;
        ui.label(format!(
            "re-done: {} map views, {} light-map samples ({:.2} M texels), {} volume objects, {} resolves ({} in a \
             region), {} reused",
            w.map_views,
            w.lightmap_samples,
            f64::from(w.lightmap_texels) / 1e6,
            w.volume_objects,
            w.resolves,
            w.region_resolves,
            w.reused
        ));
        if w.held_lights > 0 {
            ui.label(format!("{} lights wait their turn for the dragged objects' pass", w.held_lights));
        }
    }
    if let Some(name) = viewer.dragging() {
        ui.label(format!("dragging '{name}' (temporary: the caches leave it out)"));
    }
    if !viewer.status.is_empty() {
        ui.colored_label(egui::Color32::from_rgb(255, 170, 80), &viewer.status);
    }
    ui.separator();
    let names: Vec<String> = viewer.scene().lights.iter().map(|l| l.name.clone()).collect();
    if !names.is_empty() {
        viewer.selected_light = viewer.selected_light.min(names.len() - 1);
        egui::ComboBox::from_label("light").selected_text(&names[viewer.selected_light]).show_ui(ui, |ui| {
            for (i, n) in names.iter().enumerate() {
                ui.selectable_value(&mut viewer.selected_light, i, n);
            }
        });
        ui.horizontal_wrapped(|ui| {
            ui.label("overlay");
            for o in Overlay::ALL {
                ui.radio_value(&mut viewer.overlay, o, o.name());
            }
        });
        if viewer.overlay == Overlay::Texels {
            ui.add(egui::Slider::new(&mut viewer.grid, 1..=64).text("texels per line"));
        }
        ab_row(ui, viewer);
        let mut third = viewer.third_person.is_some();
        if ui.checkbox(&mut third, "third-person view (eye and map frusta)").changed() {
            report(viewer, |v| v.set_third_person(third));
        }
        let views = viewer.light_id(viewer.selected_light).map_or(0, |id| viewer.renderer.light_views(id).len());
        if views > 0 {
            let mut look = None;
            ui.horizontal_wrapped(|ui| {
                ui.label("light views:");
                if views <= 12 {
                    for k in 0..views {
                        if ui.small_button(format!("{k}")).on_hover_text("look through this map view").clicked() {
                            look = Some(k);
                        }
                    }
                } else {
                    // Samples × faces: pick one by number.
                    let k = &mut viewer.light_view_index;
                    ui.add(egui::DragValue::new(k).range(0..=views - 1));
                    if ui.small_button(format!("look (of {views})")).clicked() {
                        look = Some(*k);
                    }
                }
            });
            if let Some(k) = look {
                report(viewer, |v| v.look_from_light_view(k));
            }
        }
        #[cfg(feature = "truth")]
        truth_panel(ui, viewer);

        if let Some(curves) = viewer.aliasing_curves() {
            egui::CollapsingHeader::new("perspective error")
                .default_open(true)
                .show(ui, |ui| aliasing_plot(ui, &curves));
        }
        ui.separator();
        let light = viewer.selected_light;
        technique_panel(ui, viewer, light);
        egui::CollapsingHeader::new("light").default_open(false).show(ui, |ui| light_properties(ui, viewer, light));
    }
    ui.separator();
    camera_panel(ui, viewer);
    levels(ui, viewer);
    ui.separator();
    ui.horizontal(|ui| {
        if ui.button("copy command").clicked() {
            requests.copy = Some(viewer.cli_command());
        }
        if ui.button("screenshot").clicked() {
            requests.screenshot = true;
        }
    });
    ui.separator();
    ui.small("WASD/QE fly · right-drag look · left-drag an object to move it");
}

/// The predicted perspective aliasing error per split (Lloyd et al. 2006 as in Stingl 2011 §2,
/// `analyze`'s plot): m_x solid, m_z faint, log–log over eye depth, with the line m = 1.
fn aliasing_plot(ui: &mut egui::Ui, curves: &[Vec<(f32, f32, f32)>]) {
    let (rect, _) = ui.allocate_exact_size(egui::vec2(ui.available_width(), 120.0), Sense::hover());
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 2.0, egui::Color32::from_gray(20));
    let points = curves.iter().flatten();
    let finite = |v: f32| v.is_finite() && v > 0.0;
    let (mut z0, mut z1, mut m0, mut m1) = (f32::MAX, f32::MIN, 1.0f32, 1.0f32);
    for &(z, mx, mz) in points {
        if finite(z) {
            (z0, z1) = (z0.min(z), z1.max(z));
        }
        for m in [mx, mz].into_iter().filter(|&m| finite(m)) {
            (m0, m1) = (m0.min(m), m1.max(m));
        }
    }
    // No finite depth range (or a single depth): nothing to draw.
    if z0.partial_cmp(&z1) != Some(std::cmp::Ordering::Less) {
        return;
    }
    let (lz0, lz1, lm0, lm1) = (z0.ln(), z1.ln(), m0.ln() - 0.1, m1.ln() + 0.1);
    let at = |z: f32, m: f32| {
        egui::pos2(
            rect.left() + (z.ln() - lz0) / (lz1 - lz0) * rect.width(),
            rect.bottom() - (m.ln() - lm0) / (lm1 - lm0) * rect.height(),
        )
    };
    let one = at(z0, 1.0).y;
    painter.hline(rect.x_range(), one, egui::Stroke::new(1.0, egui::Color32::from_gray(120)));
    for (i, curve) in curves.iter().enumerate() {
        let c = shadowlab_core::cascades::split_colour(i);
        let colour = egui::Color32::from_rgb((c.x * 255.0) as u8, (c.y * 255.0) as u8, (c.z * 255.0) as u8);
        let line = |pick: fn(&(f32, f32, f32)) -> f32| -> Vec<egui::Pos2> {
            curve.iter().filter(|p| finite(p.0) && finite(pick(p))).map(|p| at(p.0, pick(p))).collect()
        };
        painter.add(egui::Shape::line(line(|p| p.1), egui::Stroke::new(1.5, colour)));
        painter.add(egui::Shape::line(line(|p| p.2), egui::Stroke::new(1.0, colour.gamma_multiply(0.5))));
    }
    ui.small(format!("aliasing error (pixels per texel) {m0:.2}–{m1:.2} over depth {z0:.2}–{z1:.1} (grey: 1)"));
}

/// The A/B split: the selected light with another technique on the right half.
fn ab_row(ui: &mut egui::Ui, viewer: &mut Viewer) {
    let Some(l) = viewer.scene().lights.get(viewer.selected_light).cloned() else { return };
    let mut on = viewer.ab.is_some();
    let current = viewer.ab.as_ref().map_or("pcss", |a| a.spec.info.id);
    let mut chosen = current;
    let toggled = ui
        .horizontal(|ui| {
            let t = ui.checkbox(&mut on, "A/B: right half with").changed();
            egui::ComboBox::from_id_salt("ab technique").selected_text(chosen).show_ui(ui, |ui| {
                for info in registry().iter().filter(|t| t.supports(&l)) {
                    ui.selectable_value(&mut chosen, info.id, info.id);
                }
            });
            t
        })
        .inner;
    if toggled || (on && chosen != current) {
        report(viewer, |v| v.set_ab(on.then_some(chosen)));
    }
}

/// Each light's quality level and whether it shows the current state (the scheduler's view);
/// the frame-time target and caching switches.
fn levels(ui: &mut egui::Ui, viewer: &mut Viewer) {
    let shadows = &viewer.renderer.shadows;
    let names: Vec<String> = viewer.scene().lights.iter().map(|l| l.name.clone()).collect();
    let rows: Vec<String> = shadows
        .levels()
        .into_iter()
        .map(|(id, level, current, samples)| {
            let name = shadows.live().light_index(id).and_then(|i| names.get(i)).map_or("?", String::as_str);
            let state = if current { "current" } else { "refining" };
            let samples = if samples > 0 { format!(", {samples} samples") } else { String::new() };
            format!("{name}: level {level}, {state}{samples}")
        })
        .collect();
    egui::CollapsingHeader::new("scheduler").default_open(false).show(ui, |ui| {
        for r in &rows {
            ui.small(r);
        }
        let mut target = viewer.renderer.shadows.target_ms();
        let mut on = target.is_some();
        ui.horizontal(|ui| {
            ui.checkbox(&mut on, "frame target");
            let mut ms = target.unwrap_or(33.0);
            ui.add_enabled(on, egui::DragValue::new(&mut ms).range(1.0..=1000.0).suffix(" ms"));
            target = on.then_some(ms);
        });
        if target != viewer.renderer.shadows.target_ms() {
            viewer.renderer.set_target_ms(target);
        }
        let mut caching = viewer.renderer.shadows.caching();
        if ui.checkbox(&mut caching, "keep caches (off: rebuild everything each frame)").changed() {
            viewer.renderer.shadows.set_caching(caching);
        }
    });
}

/// The scene's named views and camera paths.
fn camera_panel(ui: &mut egui::Ui, viewer: &mut Viewer) {
    let views: Vec<String> = viewer.scene().views.iter().map(|v| v.name.clone()).collect();
    let paths: Vec<String> = viewer.scene().paths.iter().map(|p| p.name.clone()).collect();
    let mut go = None;
    let mut play = None;
    ui.horizontal_wrapped(|ui| {
        ui.label("views:");
        for v in &views {
            if ui.small_button(v).clicked() {
                go = Some(v.clone());
            }
        }
    });
    if !paths.is_empty() {
        ui.horizontal_wrapped(|ui| {
            ui.label("paths:");
            for p in &paths {
                if ui.small_button(format!("▶ {p}")).clicked() {
                    play = Some(p.clone());
                }
            }
        });
    }
    if let Some((frame, frames)) = viewer.path_progress() {
        ui.add(egui::ProgressBar::new(frame as f32 / frames.max(1) as f32).text(format!("path {frame}/{frames}")));
    }
    if let Some(v) = go {
        report(viewer, |x| x.go_to_view(&v));
    }
    if let Some(p) = play {
        report(viewer, |x| x.play_path(&p));
    }
}

/// The ray-traced truth of the frame shown for the selected light: start it, watch it, read it.
#[cfg(feature = "truth")]
fn truth_panel(ui: &mut egui::Ui, viewer: &mut Viewer) {
    let pressed = !ui.ctx().egui_wants_keyboard_input() && ui.input(|i| i.key_pressed(Key::T));
    match &viewer.truth_job {
        Some(job) => {
            let light = viewer.scene().lights.get(job.light).map_or("?", |l| l.name.as_str()).to_owned();
            ui.add(egui::ProgressBar::new(job.progress()).show_percentage().text(format!("tracing '{light}'")));
        }
        None => {
            let clicked = ui
                .horizontal(|ui| {
                    let b = ui.button("trace the truth (T)").clicked();
                    ui.add(egui::DragValue::new(&mut viewer.truth_samples).range(1..=4096).suffix(" samples"));
                    b
                })
                .inner;
            if clicked || pressed {
                let samples = viewer.truth_samples;
                report(viewer, |v| v.start_truth(samples));
            }
        }
    }
    let current = viewer.current_truth().is_some();
    if let Some(t) = &viewer.truth {
        let s = &t.stats;
        let light = viewer.scene().lights.get(t.light).map_or("?", |l| l.name.as_str());
        let penumbra = s.penumbra_rmse().map_or_else(|| "—".into(), |p| format!("{p:.4}"));
        ui.label(format!(
            "{} on '{light}' ({:.1} s){}\nRMSE {:.4} · wrong {:.2} % · penumbra RMSE {penumbra}\nacne {:.2} % · leaks {:.2} %",
            t.technique,
            t.seconds,
            if current { "" } else { " — stale: the view, the scene or the technique changed" },
            s.rmse(),
            100.0 * s.wrong_frac(),
            100.0 * s.lit_darkened_frac(),
            100.0 * s.shadow_brightened_frac(),
        ));
    }
}

/// The technique of `light` and one widget per parameter.
fn technique_panel(ui: &mut egui::Ui, viewer: &mut Viewer, light: usize) {
    let Some(spec) = viewer.spec(light).cloned() else { return };
    let Some(l) = viewer.scene().lights.get(light).cloned() else { return };
    let mut chosen = spec.info.id;
    egui::ComboBox::from_label("technique").selected_text(chosen).show_ui(ui, |ui| {
        for info in registry().iter().filter(|t| t.supports(&l)) {
            ui.selectable_value(&mut chosen, info.id, info.id).on_hover_text(info.summary);
        }
    });
    if chosen != spec.info.id {
        report(viewer, |v| v.set_technique(light, chosen));
        return;
    }
    ui.small(spec.info.source);
    for (def, value) in spec.params.iter() {
        if let (_, Some(text)) = param_widget(ui, def, value) {
            report(viewer, |v| v.set_param(light, def.name, &text));
        }
    }
    ui.monospace(spec_text(&spec));
}

/// Light `light`'s colour, intensity, position and size, edited through the live engine.
fn light_properties(ui: &mut egui::Ui, viewer: &mut Viewer, light: usize) {
    let Some(l) = viewer.scene().lights.get(light).cloned() else { return };
    let mut colour = l.color.to_array();
    let mut intensity = l.intensity;
    let c = ui.horizontal(|ui| {
        ui.label("colour");
        ui.color_edit_button_rgb(&mut colour).changed()
    });
    let i = ui.add(egui::Slider::new(&mut intensity, 0.0..=(4.0 * l.intensity.max(1.0))).text("intensity")).changed();
    if c.inner {
        report(viewer, |v| v.set_light_colour(light, Vec3::from_array(colour)));
    }
    if let Some(p) = l.position() {
        let mut q = p.to_array();
        let step = 0.005 * viewer.scene().bounds().diagonal().max(1e-3);
        let moved = ui
            .horizontal(|ui| {
                ui.label("position");
                q.iter_mut().map(|c| ui.add(egui::DragValue::new(c).speed(step)).changed()).fold(false, |a, b| a | b)
            })
            .inner;
        if moved {
            report(viewer, |v| v.edit_light(light, LightChange::Position(Vec3::from_array(q))));
        }
    }
    match l.kind {
        LightKind::Point { radius, .. } | LightKind::Spot { radius, .. } => {
            let mut r = radius;
            if ui.add(egui::Slider::new(&mut r, 0.0..=(4.0 * radius).max(0.5)).text("radius")).changed() {
                report(viewer, |v| v.edit_light(light, LightChange::Radius(r)));
            }
        }
        LightKind::Directional { angular_radius, .. } => {
            let mut r = angular_radius.to_degrees();
            if ui.add(egui::Slider::new(&mut r, 0.0..=5.0).text("angular radius °")).changed() {
                report(viewer, |v| v.edit_light(light, LightChange::Radius(r.to_radians())));
            }
        }
        LightKind::Rect { width, height, .. } => {
            let (mut w, mut h) = (width, height);
            let a = ui.add(egui::Slider::new(&mut w, 0.01..=(4.0 * width).max(1.0)).text("width")).changed();
            let b = ui.add(egui::Slider::new(&mut h, 0.01..=(4.0 * height).max(1.0)).text("height")).changed();
            if a || b {
                report(viewer, |v| v.edit_light(light, LightChange::Size(w, h)));
            }
        }
    }
    if i {
        report(viewer, |v| v.set_light_intensity(light, intensity));
    }
}

fn report(viewer: &mut Viewer, f: impl FnOnce(&mut Viewer) -> Result<(), crate::viewer::ViewerError>) {
    match f(viewer) {
        Ok(()) => viewer.status.clear(),
        Err(e) => viewer.status = e.to_string(),
    }
}

/// The widget for one parameter, from its declaration alone: a checkbox, an integer or real
/// slider over its range (logarithmic when the range spans decades), or a choice box. Returns
/// its response and, when the user changed it, the new value as text.
pub fn param_widget(ui: &mut egui::Ui, def: &ParamDef, value: &ParamValue) -> (egui::Response, Option<String>) {
    let (response, text) = match (def.kind, value) {
        (ParamKind::Bool, ParamValue::Bool(b)) => {
            let mut v = *b;
            let r = ui.checkbox(&mut v, def.name);
            let changed = r.changed().then(|| v.to_string());
            (r, changed)
        }
        (ParamKind::Int { min, max }, ParamValue::Int(x)) => {
            let mut v = *x;
            let log = min > 0 && max / min.max(1) >= 100;
            let r = ui.add(egui::Slider::new(&mut v, min..=max).logarithmic(log).text(def.name));
            let changed = r.changed().then(|| v.to_string());
            (r, changed)
        }
        (ParamKind::Float { min, max }, ParamValue::Float(x)) => {
            let mut v = *x;
            let log = min > 0.0 && max / min >= 100.0;
            let r = ui.add(egui::Slider::new(&mut v, min..=max).logarithmic(log).text(def.name));
            let changed = r.changed().then(|| format!("{v}"));
            (r, changed)
        }
        (ParamKind::Choice(choices), ParamValue::Choice(c)) => {
            let mut v = *c;
            let r = egui::ComboBox::from_label(def.name)
                .selected_text(v)
                .show_ui(ui, |ui| {
                    for &choice in choices {
                        ui.selectable_value(&mut v, choice, choice);
                    }
                })
                .response;
            let changed = (v != *c).then(|| v.to_owned());
            (r, changed)
        }
        // A value of another kind than its declaration cannot be made by `ParamSet`.
        _ => (ui.label(format!("{} = {value}", def.name)), None),
    };
    (response.on_hover_text(def.doc), text)
}

/// The scene image, 1:1 at the central panel's top left; mouse and keys over it. In the
/// third-person view: that camera's image with the frusta drawn over it, the eye's in a corner.
fn scene_area(
    ui: &mut egui::Ui,
    viewer: &mut Viewer,
    (texture, minimap): (egui::TextureId, egui::TextureId),
    seconds: f32,
) {
    let (w, h) = viewer.size();
    let size = egui::vec2(w as f32, h as f32);
    let image = egui::Image::new(egui::load::SizedTexture::new(texture, size)).sense(Sense::click_and_drag());
    let response = ui.add(image);
    let origin = response.rect.min;
    let third = viewer.third_person.as_ref().map(|tp| tp.view().view_projection(w, h));
    if let Some(view_proj) = third {
        let painter = ui.painter_at(response.rect);
        for (segment, [r, g, b]) in viewer.frusta() {
            if let Some([a, c]) = crate::third_person::project_segment(&view_proj, segment, w, h) {
                let stroke = egui::Stroke::new(1.5, egui::Color32::from_rgb(r, g, b));
                painter.line_segment([origin + egui::vec2(a.x, a.y), origin + egui::vec2(c.x, c.y)], stroke);
            }
        }
        // The eye's own view, a quarter of the size, at the bottom right.
        let mini = egui::Rect::from_min_size(response.rect.max - size * 0.25 - egui::vec2(8.0, 8.0), size * 0.25);
        painter.image(
            minimap,
            mini,
            egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
            egui::Color32::WHITE,
        );
        painter.rect_stroke(mini, 0.0, egui::Stroke::new(1.0, egui::Color32::WHITE), egui::StrokeKind::Outside);
    }
    let local = |p: egui::Pos2| (p.x - origin.x, p.y - origin.y);
    if response.dragged_by(PointerButton::Secondary) {
        let d = response.drag_delta();
        viewer.active_camera().turn(d.x, d.y, LOOK_SENSITIVITY);
    }
    // Objects are dragged in the eye's view only.
    if third.is_none() {
        if response.drag_started_by(PointerButton::Primary)
            && let Some(p) = response.interact_pointer_pos()
        {
            let (x, y) = local(p);
            report(viewer, |v| v.begin_drag(x, y).map(|_| ()));
        } else if response.dragged_by(PointerButton::Primary)
            && let Some(p) = response.interact_pointer_pos()
        {
            let (x, y) = local(p);
            report(viewer, |v| v.drag_to(x, y));
        }
        if response.drag_stopped() {
            report(viewer, Viewer::end_drag);
        }
    }
    if !ui.ctx().egui_wants_keyboard_input() {
        let along = ui.input(|i| {
            let axis =
                |plus: Key, minus: Key| f32::from(u8::from(i.key_down(plus))) - f32::from(u8::from(i.key_down(minus)));
            Vec3::new(axis(Key::D, Key::A), axis(Key::E, Key::Q), axis(Key::W, Key::S))
        });
        if along != Vec3::ZERO {
            viewer.active_camera().travel(along, seconds.clamp(0.0, 0.25));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shadowlab_core::ParamSet;

    /// Every registered technique gets one widget per parameter, from its `ParamDef`s alone (no
    /// technique-specific UI code), each laid out with a size; and the text a widget hands back
    /// for any value in range is one `ParamSet::set` accepts.
    #[test]
    fn every_registered_technique_gets_a_widget_per_parameter() {
        let ctx = egui::Context::default();
        let mut total = 0;
        for info in registry() {
            let params = ParamSet::new(info.params);
            let mut responses = Vec::new();
            let input = egui::RawInput {
                screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(400.0, 4000.0))),
                ..Default::default()
            };
            let mut output = ctx.run_ui(input, |ui| {
                for (def, value) in params.iter() {
                    responses.push((def.name, param_widget(ui, def, value).0));
                }
            });
            // Nothing is painted here.
            output.textures_delta.clear();
            assert_eq!(responses.len(), info.params.len(), "{}", info.id);
            for (name, r) in &responses {
                assert!(r.rect.width() > 0.0 && r.rect.height() > 0.0, "{}: {name} has no size", info.id);
            }
            for def in info.params {
                let mut set = ParamSet::new(info.params);
                let samples: Vec<String> = match def.kind {
                    ParamKind::Bool => vec!["true".into(), "false".into()],
                    ParamKind::Int { min, max } => vec![min.to_string(), max.to_string()],
                    ParamKind::Float { min, max } => {
                        vec![format!("{min}"), format!("{max}"), format!("{}", 0.5 * (min + max))]
                    }
                    ParamKind::Choice(c) => c.iter().map(|s| (*s).to_owned()).collect(),
                };
                for text in samples {
                    set.set(def.name, &text).unwrap_or_else(|e| panic!("{}: {}={text}: {e}", info.id, def.name));
                }
            }
            total += responses.len();
        }
        // The registry declares 133 parameters (measured; every map technique repeats the map ones);
        // 20 only guards against a loop that saw nothing.
        assert!(total > 20, "only {total} parameters in the registry");
    }
}
