//! The self-contained `report.html` of `compare`: the metrics table, the quality/time plot (SVG by
//! plotters) and the images, all inline.

use std::fmt::Write;

use anyhow::Result;
use plotters::prelude::*;

/// The font plots are set in (DejaVu Sans, Bitstream Vera licence: `assets/DejaVuSans-LICENSE.txt`).
static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

pub fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The font is compiled in and known to parse; a failure would only lose text in plots.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

pub fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// Standard base64 (RFC 4648 §4) with padding.
pub fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ABC[((n >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// An `<img>` with the PNG inline.
pub fn img(png: &[u8], alt: &str) -> String {
    format!("<img alt=\"{}\" src=\"data:image/png;base64,{}\">", escape(alt), base64(png))
}

/// One point of the quality/time plot.
pub struct PlotPoint {
    pub label: String,
    pub ms: f64,
    pub error: f64,
}

/// A scatter plot of error against frame time, one labelled point per technique.
pub fn quality_time_svg(points: &[PlotPoint], error_name: &str, time_name: &str) -> Result<String> {
    register_font();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (720, 440)).into_drawing_area();
        root.fill(&WHITE)?;
        let finite: Vec<&PlotPoint> =
            points.iter().filter(|p| p.ms.is_finite() && p.ms > 0.0 && p.error.is_finite()).collect();
        let max_ms = finite.iter().map(|p| p.ms).fold(0.0f64, f64::max).max(1e-3);
        let min_ms = finite.iter().map(|p| p.ms).fold(f64::INFINITY, f64::min).min(max_ms);
        let max_err = finite.iter().map(|p| p.error).fold(0.0f64, f64::max).max(1e-4) * 1.15;
        let caption = format!("{error_name} against {time_name}");
        let mut builder = ChartBuilder::on(&root);
        builder.caption(caption, ("sans-serif", 18)).margin(16).x_label_area_size(42).y_label_area_size(64);
        // Times often span orders of magnitude (none … sampled): a log axis keeps every point apart.
        if max_ms / min_ms > 20.0 {
            let mut chart = builder.build_cartesian_2d((min_ms * 0.7..max_ms * 1.5).log_scale(), 0.0..max_err)?;
            chart
                .configure_mesh()
                .x_desc(format!("{time_name}, log scale"))
                .y_desc(error_name)
                .label_style(("sans-serif", 13))
                .draw()?;
            draw_points(&mut chart, &finite)?;
        } else {
            let mut chart = builder.build_cartesian_2d(0.0..max_ms * 1.15, 0.0..max_err)?;
            chart.configure_mesh().x_desc(time_name).y_desc(error_name).label_style(("sans-serif", 13)).draw()?;
            draw_points(&mut chart, &finite)?;
        }
        root.present()?;
    }
    Ok(svg)
}

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// One dot and label per technique, on a linear or a log time axis.
fn draw_points<DB: DrawingBackend, X: plotters::coord::ranged1d::Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, plotters::coord::types::RangedCoordf64>>,
    points: &[&PlotPoint],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    for (i, p) in points.iter().enumerate() {
        let c = PALETTE[i % PALETTE.len()];
        chart.draw_series(std::iter::once(Circle::new((p.ms, p.error), 6, c.filled())))?;
        chart.draw_series(std::iter::once(
            EmptyElement::at((p.ms, p.error))
                + Text::new(p.label.clone(), (9, -6), ("sans-serif", 13).into_font().color(&c)),
        ))?;
    }
    Ok(())
}

/// An HTML table.
pub fn table(headers: &[&str], rows: &[Vec<String>]) -> String {
    let mut s = String::from("<table><thead><tr>");
    for h in headers {
        let _ = write!(s, "<th>{}</th>", escape(h));
    }
    s.push_str("</tr></thead><tbody>");
    for r in rows {
        s.push_str("<tr>");
        for c in r {
            let _ = write!(s, "<td>{c}</td>");
        }
        s.push_str("</tr>");
    }
    s.push_str("</tbody></table>");
    s
}

pub const STYLE: &str = "body{font-family:system-ui,sans-serif;margin:2em;color:#222;max-width:1400px}\
table{border-collapse:collapse;margin:1em 0}th,td{border:1px solid #ccc;padding:4px 8px;text-align:right}\
th{background:#f3f3f3}td:first-child{text-align:left;font-family:monospace}\
.grid{display:flex;flex-wrap:wrap;gap:10px}.grid figure{margin:0}figcaption{font-size:12px;font-family:monospace}\
img{image-rendering:pixelated;border:1px solid #ddd}.note{color:#666;font-size:13px}";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        assert_eq!(base64(b""), "");
        assert_eq!(base64(b"f"), "Zg==");
        assert_eq!(base64(b"fo"), "Zm8=");
        assert_eq!(base64(b"foo"), "Zm9v");
        assert_eq!(base64(b"foobar"), "Zm9vYmFy");
    }

    #[test]
    fn plot_is_svg_with_labels() {
        let svg = quality_time_svg(
            &[
                PlotPoint { label: "hard".into(), ms: 1.0, error: 0.2 },
                PlotPoint { label: "pcf".into(), ms: 2.0, error: 0.1 },
            ],
            "penumbra RMSE",
            "GPU ms",
        )
        .unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("hard") && svg.contains("pcf"));
    }
}
