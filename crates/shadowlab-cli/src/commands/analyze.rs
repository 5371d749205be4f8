//! `shadowlab analyze`: perspective aliasing of a light's shadow maps, predicted and measured
//! (Stingl 2011, §3.3 and §5.7–5.8).
//!
//! - Predicted: m_x(z) and m_z(z) along the view direction (Lloyd et al.'s metric, Stingl Eqs.
//!   2.3–2.8) for every split, with its own depth range and warp distance, scaled by the split's
//!   actual texel size over that of a map focused on it (1 when focusing is on). Values above 1 are
//!   undersampling (a shadow-map texel covers more than a pixel).
//! - Measured: shadow-map texels per screen pixel at every pixel (the sampling overlay's
//!   determinant): median, 5th and 95th percentiles, fraction undersampled (< 1), overall and per
//!   split.
//!
//! Written to `--out`: `aliasing.csv`, `aliasing.svg`, `sampling.png`, `splits.png`, `analysis.json`.

use std::path::PathBuf;

use anyhow::{Context, Result};
use plotters::prelude::*;
use serde_json::json;
use shadowlab::techniques::cascade_settings;
use shadowlab_core::cascades::{aliasing_curves, compute_cascades};
use shadowlab_reference::images::write_rgb_png;

use crate::args::{GlobalArgs, SceneArgs, TechniqueArgs, open_gpu, renderer};
use crate::overlay::{Overlay, compose};

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    techniques: TechniqueArgs,
    /// Output directory.
    #[arg(long, default_value = "out/analyze")]
    out: PathBuf,
}

/// Percentile (0..=100) of sorted values, by nearest rank.
fn percentile(sorted: &[f32], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((p / 100.0) * (sorted.len() - 1) as f64).round() as usize;
    f64::from(sorted[i.min(sorted.len() - 1)])
}

fn distribution(values: &mut [f32]) -> serde_json::Value {
    values.sort_by(f32::total_cmp);
    let under = values.iter().filter(|&&v| v < 1.0).count();
    json!({
        "pixels": values.len(),
        "median": percentile(values, 50.0),
        "p5": percentile(values, 5.0),
        "p95": percentile(values, 95.0),
        "undersampled_frac": if values.is_empty() { 0.0 } else { under as f64 / values.len() as f64 },
    })
}

pub fn run(global: &GlobalArgs, args: Args) -> Result<()> {
    let setup = args.scene.load()?;
    let specs = args.techniques.specs(&["cascaded"])?;
    let spec = specs.first().context("no technique")?;
    let light_id = *setup.lights.first().context("no light to analyse")?;
    let light = &setup.scene.lights[light_id.index()];
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let (w, h) = (setup.width, setup.height);
    let aspect = w as f32 / h as f32;

    // Predicted.
    let settings = cascade_settings(&spec.params, light)?;
    let frame = compute_cascades(light, &setup.scene.bounds(), &setup.view, aspect, &settings);
    let focused = compute_cascades(
        light,
        &setup.scene.bounds(),
        &setup.view,
        aspect,
        &shadowlab_core::cascades::CascadeSettings { focus: true, ..settings.clone() },
    );
    let curves = aliasing_curves(&frame, &focused, setup.view.fov_y, (w, h), settings.map_size, 64);
    let mut csv = String::from("split,z,m_x,m_z\n");
    let mut splits_json = Vec::new();
    for (i, (c, curve)) in frame.cascades.iter().zip(&curves).enumerate() {
        for (z, mx, mz) in curve {
            csv.push_str(&format!("{i},{z},{mx},{mz}\n"));
        }
        let max_x = curve.iter().map(|v| v.1).fold(0.0f32, f32::max);
        let max_z = curve.iter().map(|v| v.2).fold(0.0f32, f32::max);
        splits_json.push(json!({
            "split": i, "near": c.near, "far": c.far,
            "warp_n": if c.warp_n.is_finite() { json!(c.warp_n) } else { json!(null) },
            "texel_m": c.view.texel_scale, "max_m_x": max_x, "max_m_z": max_z, "empty": c.empty,
        }));
    }
    std::fs::write(args.out.join("aliasing.csv"), csv)?;
    std::fs::write(args.out.join("aliasing.svg"), aliasing_svg(&curves, &spec.spec)?)?;

    // Measured.
    let gpu = open_gpu(global)?;
    let mut r = renderer(&gpu, &setup, spec)?;
    r.render()?;
    let o = r.map_overlay(light_id, 4)?.with_context(|| {
        format!("analyze needs a technique with one map per pixel (hard, pcf, cascaded), not '{}'", spec.spec)
    })?;
    let image = r.read_image()?;
    write_rgb_png(&args.out.join("sampling.png"), &compose(&image, &o, Overlay::Sampling)?, w, h)?;
    write_rgb_png(&args.out.join("splits.png"), &compose(&image, &o, Overlay::Splits)?, w, h)?;
    let mut all: Vec<f32> = Vec::new();
    let mut per: Vec<Vec<f32>> = vec![Vec::new(); frame.cascades.len().max(1)];
    for i in 0..o.map.len() {
        if o.map[i] >= 0 && o.on_map[i] && o.texels_per_pixel[i].is_finite() {
            all.push(o.texels_per_pixel[i]);
            if let Some(v) = per.get_mut(o.map[i] as usize) {
                v.push(o.texels_per_pixel[i]);
            }
        }
    }
    let measured = distribution(&mut all);
    let per_split: Vec<_> = per.iter_mut().map(|v| distribution(v)).collect();
    let doc = json!({
        "scene": setup.scene.name, "view": setup.view.name, "width": w, "height": h,
        "technique": spec.spec, "light": light.name,
        "adjusted_near": frame.near, "adjusted_far": frame.far, "gamma_deg": frame.gamma.to_degrees(),
        "predicted": { "splits": splits_json },
        "measured": { "texels_per_pixel": measured, "per_split": per_split },
    });
    std::fs::write(args.out.join("analysis.json"), serde_json::to_string_pretty(&doc)?)?;
    println!(
        "{} on {}/{}: γ = {:.1}°, depth {:.2}..{:.1}; texels per pixel median {:.3} (p5 {:.3}, p95 {:.3}), {:.1}% undersampled → {}",
        spec.spec,
        setup.scene.name,
        setup.view.name,
        frame.gamma.to_degrees(),
        frame.near,
        frame.far,
        doc["measured"]["texels_per_pixel"]["median"].as_f64().unwrap_or(f64::NAN),
        doc["measured"]["texels_per_pixel"]["p5"].as_f64().unwrap_or(f64::NAN),
        doc["measured"]["texels_per_pixel"]["p95"].as_f64().unwrap_or(f64::NAN),
        100.0 * doc["measured"]["texels_per_pixel"]["undersampled_frac"].as_f64().unwrap_or(0.0),
        args.out.display()
    );
    Ok(())
}

/// A log axis's range over `values` (finite and positive), at least `floor` and a factor 1.01
/// wide; 0.1 to 10 when there are none.
fn log_range(values: impl Iterator<Item = f32> + Clone, floor: f32) -> (f32, f32) {
    let lo = values.clone().fold(f32::INFINITY, f32::min);
    let hi = values.fold(0.0f32, f32::max);
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.1, 10.0);
    }
    let lo = lo.max(floor);
    (lo, hi.max(lo * 1.01))
}

fn aliasing_svg(curves: &[Vec<(f32, f32, f32)>], title: &str) -> Result<String> {
    crate::report::register_font();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 420)).into_drawing_area();
        root.fill(&WHITE)?;
        // Finite, positive values only; a degenerate scene (all its geometry one point) has none,
        // and infinite bounds sent plotters' log axis making ticks until memory ran out.
        let pts = curves.iter().flatten();
        let usable = |v: &f32| v.is_finite() && *v > 0.0;
        let (z_lo, z_hi) = log_range(pts.clone().map(|p| p.0).filter(usable), 1e-4);
        let (m_lo, m_hi) = log_range(pts.flat_map(|p| [p.1, p.2]).filter(usable), 1e-6);
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("perspective aliasing of {title} (m > 1: undersampled)"), ("sans-serif", 16))
            .margin(14)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d((z_lo..z_hi).log_scale(), (m_lo * 0.8..m_hi * 1.25).log_scale())?;
        chart.configure_mesh().x_desc("eye depth z (log)").y_desc("m (log)").label_style(("sans-serif", 12)).draw()?;
        let orange = RGBColor(230, 120, 20);
        let blue = RGBColor(30, 90, 200);
        for (i, c) in curves.iter().enumerate() {
            let drawn = |m: fn(&(f32, f32, f32)) -> f32| {
                c.iter().map(move |p| (p.0, m(p))).filter(|(z, v)| usable(z) && usable(v))
            };
            let a = chart.draw_series(LineSeries::new(drawn(|p| p.1), orange.stroke_width(2)))?;
            if i == 0 {
                a.label("m_x")
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], orange.stroke_width(2)));
            }
            let b = chart.draw_series(LineSeries::new(drawn(|p| p.2), blue.stroke_width(2)))?;
            if i == 0 {
                b.label("m_z").legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], blue.stroke_width(2)));
            }
        }
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
        root.present()?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Axis ranges from what can be drawn on a log axis: without finite positive values a fixed
    /// range (infinite ones made plotters tick until memory ran out), and a curve of NaN and
    /// infinities draws as an empty plot.
    #[test]
    fn log_ranges_are_finite() {
        assert_eq!(log_range(std::iter::empty(), 1e-4), (0.1, 10.0));
        assert_eq!(log_range([2.0f32, 8.0].into_iter(), 1e-4), (2.0, 8.0));
        assert_eq!(log_range([3.0f32].into_iter(), 1e-4), (3.0, 3.0 * 1.01));
        assert_eq!(log_range([1e-9f32, 1.0].into_iter(), 1e-4), (1e-4, 1.0));
        let svg = aliasing_svg(&[vec![(f32::NAN, f32::INFINITY, 0.0), (0.0, f32::NAN, -1.0)]], "nothing").unwrap();
        assert!(svg.contains("<svg"));
    }
}
