//! Analysis overlays (`render --overlay`): the colours of Stingl 2011 §5.2 over the lit image.

use anyhow::{Result, bail};
use shadowlab::renderer::MapOverlay;
use shadowlab_core::cascades::{sampling_colour, split_colour};

/// Which overlay.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Overlay {
    /// Split (or cube face) colours: red, yellow, green, blue.
    Splits,
    /// The projected shadow-map texel grid.
    Texels,
    /// Shadow-map texels per screen pixel: red undersampled, green 1:1, blue oversampled.
    Sampling,
    /// What caches hold (for caching techniques).
    Cache,
    /// Shadow-volume fragments per pixel over every shadowed light (`volumes`, `lightmesh`): blue 1,
    /// green 5, yellow 10, red 15, white 20 or more (Hasselgren 2003 Fig. 8: white is ≥ 20 passes).
    Fill,
}

/// The heat colour of `n` volume fragments on a pixel.
pub fn fill_colour(n: u32) -> glam::Vec3 {
    const STOPS: [(f32, [f32; 3]); 5] = [
        (1.0, [0.1, 0.2, 1.0]),
        (5.0, [0.1, 0.8, 0.2]),
        (10.0, [1.0, 0.9, 0.1]),
        (15.0, [1.0, 0.15, 0.1]),
        (20.0, [1.0, 1.0, 1.0]),
    ];
    let x = n as f32;
    let mut c = STOPS[0].1;
    for w in STOPS.windows(2) {
        let ((a, ca), (b, cb)) = (w[0], w[1]);
        if x >= a {
            let t = ((x - a) / (b - a)).min(1.0);
            c = [0, 1, 2].map(|k| ca[k] + (cb[k] - ca[k]) * t);
        }
    }
    glam::Vec3::from(c)
}

/// `image` with the fill heat drawn over every pixel some volume covered.
pub fn compose_fill(image: &[u8], counts: &[u32]) -> Vec<u8> {
    let mut out = image.to_vec();
    for (i, &n) in counts.iter().enumerate() {
        if n > 0 && 3 * i + 3 <= out.len() {
            blend(&mut out[3 * i..3 * i + 3], fill_colour(n), 0.85);
        }
    }
    out
}

fn blend(dst: &mut [u8], colour: glam::Vec3, alpha: f32) {
    for (d, c) in dst.iter_mut().zip(colour.to_array()) {
        *d = ((1.0 - alpha) * f32::from(*d) + alpha * 255.0 * c.clamp(0.0, 1.0)).round() as u8;
    }
}

/// `image` (RGB) with the overlay drawn over it.
pub fn compose(image: &[u8], o: &MapOverlay, kind: Overlay) -> Result<Vec<u8>> {
    let mut out = image.to_vec();
    for i in 0..o.map.len() {
        if o.map[i] < 0 {
            continue;
        }
        let px = &mut out[3 * i..3 * i + 3];
        match kind {
            Overlay::Splits => blend(px, split_colour(o.map[i] as usize), 0.45),
            Overlay::Texels => {
                if o.grid_line[i] {
                    blend(px, glam::Vec3::ZERO, 0.9);
                }
            }
            Overlay::Sampling => {
                if o.on_map[i] {
                    blend(px, sampling_colour(o.texels_per_pixel[i]), 0.8);
                }
            }
            Overlay::Fill => bail!("overlay 'fill' is drawn from volume counts (compose_fill), not from maps"),
            Overlay::Cache => {
                bail!("overlay 'cache': no technique caches its maps yet (caching comes with the semi-static work)")
            }
        }
    }
    Ok(out)
}
