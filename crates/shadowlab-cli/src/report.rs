//! The self-contained `report.html` of `compare`: the metrics table, the quality/time plot (SVG by
//! plotters) and the images, all inline.

use std::fmt::Write;

use anyhow::Result;
use plotters::prelude::*;

/// The font plots are set in (DejaVu Sans, Bitstream Vera licence: `assets/DejaVuSans-LICENSE.txt`).
static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

fn register_font() {
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
        let finite: Vec<&PlotPoint> = points.iter().filter(|p| p.ms.is_finite() && p.error.is_finite()).collect();
        let max_ms = finite.iter().map(|p| p.ms).fold(0.0f64, f64::max).max(1e-3) * 1.15;
        let max_err = finite.iter().map(|p| p.error).fold(0.0f64, f64::max).max(1e-4) * 1.15;
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("{error_name} against {time_name}"), ("sans-serif", 18))
            .margin(16)
            .x_label_area_size(42)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..max_ms, 0.0..max_err)?;
        chart.configure_mesh().x_desc(time_name).y_desc(error_name).label_style(("sans-serif", 13)).draw()?;
        let palette = [
            RGBColor(31, 119, 180),
            RGBColor(214, 39, 40),
            RGBColor(44, 160, 44),
            RGBColor(148, 103, 189),
            RGBColor(255, 127, 14),
            RGBColor(140, 86, 75),
            RGBColor(227, 119, 194),
            RGBColor(23, 190, 207),
        ];
        for (i, p) in finite.iter().enumerate() {
            let c = palette[i % palette.len()];
            chart.draw_series(std::iter::once(Circle::new((p.ms, p.error), 6, c.filled())))?;
            chart.draw_series(std::iter::once(Text::new(
                p.label.clone(),
                (p.ms, p.error),
                ("sans-serif", 13).into_font().color(&c),
            )))?;
        }
        root.present()?;
    }
    Ok(svg)
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
