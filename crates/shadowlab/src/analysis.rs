//! Analysis overlays composed on the CPU over a lit image (RGB): the colours of Stingl 2011 §5.2
//! for the maps behind each pixel ([`MapOverlay`]) and Hasselgren 2003 Fig. 8's heat for shadow-
//! volume fill. `shadowlab render --overlay`, `analyze` and the viewer draw the same pictures.

use glam::Vec3;
use shadowlab_core::cascades::{sampling_colour, split_colour};

use crate::renderer::MapOverlay;

/// Which picture of the maps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapPicture {
    /// Split (or cube face) colours: red, yellow, green, blue.
    Splits,
    /// The projected shadow-map texel grid.
    Texels,
    /// Shadow-map texels per screen pixel: red undersampled, green 1:1, blue oversampled.
    Sampling,
}

/// The heat colour of `n` volume fragments on a pixel: blue 1, green 5, yellow 10, red 15, white
/// 20 or more (Hasselgren 2003 Fig. 8: white is ≥ 20 passes).
pub fn fill_colour(n: u32) -> Vec3 {
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
    Vec3::from(c)
}

/// `image` (RGB) with the fill heat drawn over every pixel some volume covered.
pub fn compose_fill(image: &[u8], counts: &[u32]) -> Vec<u8> {
    let mut out = image.to_vec();
    for (i, &n) in counts.iter().enumerate() {
        if n > 0 && 3 * i + 3 <= out.len() {
            blend(&mut out[3 * i..3 * i + 3], fill_colour(n), 0.85);
        }
    }
    out
}

/// `image` (RGB) with `picture` of the maps drawn over it.
pub fn compose_maps(image: &[u8], o: &MapOverlay, picture: MapPicture) -> Vec<u8> {
    let mut out = image.to_vec();
    for i in 0..o.map.len().min(out.len() / 3) {
        if o.map[i] < 0 {
            continue;
        }
        let px = &mut out[3 * i..3 * i + 3];
        match picture {
            MapPicture::Splits => blend(px, split_colour(o.map[i] as usize), 0.45),
            MapPicture::Texels => {
                if o.grid_line[i] {
                    blend(px, Vec3::ZERO, 0.9);
                }
            }
            MapPicture::Sampling => {
                if o.on_map[i] {
                    blend(px, sampling_colour(o.texels_per_pixel[i]), 0.8);
                }
            }
        }
    }
    out
}

fn blend(dst: &mut [u8], colour: Vec3, alpha: f32) {
    for (d, c) in dst.iter_mut().zip(colour.to_array()) {
        *d = ((1.0 - alpha) * f32::from(*d) + alpha * 255.0 * c.clamp(0.0, 1.0)).round() as u8;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fill_heat_runs_from_blue_to_white_and_only_covered_pixels_change() {
        assert_eq!(fill_colour(1), Vec3::new(0.1, 0.2, 1.0));
        assert_eq!(fill_colour(20), Vec3::ONE);
        assert_eq!(fill_colour(500), Vec3::ONE);
        let image = vec![100u8; 6];
        let out = compose_fill(&image, &[0, 3]);
        assert_eq!(&out[..3], &image[..3], "no fragment, no change");
        assert_ne!(&out[3..], &image[3..]);
    }
}
