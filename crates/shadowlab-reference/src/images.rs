//! Writing visibility buffers and error heatmaps: 16-bit PNGs to look at, raw little-endian f32 with
//! a JSON header for scripts.

use std::path::{Path, PathBuf};

use glam::Vec3;
use image::{ImageBuffer, Luma, Rgb};
use serde::Serialize;

/// An I/O or encoding failure, with the file it concerns.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: {source}")]
    Encode {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    #[error("{what}: {len} values for a {width}×{height}×{channels} image")]
    Size { what: String, len: usize, width: u32, height: u32, channels: u32 },
}

fn check_len(what: &Path, len: usize, width: u32, height: u32, channels: u32) -> Result<(), ImageError> {
    if len != (width as usize) * (height as usize) * channels as usize {
        return Err(ImageError::Size { what: what.display().to_string(), len, width, height, channels });
    }
    Ok(())
}

/// Writes V as a 16-bit grey PNG (0 → black, 1 → white); NaN (not relevant) as black.
pub fn write_visibility_png(path: &Path, values: &[f32], width: u32, height: u32) -> Result<(), ImageError> {
    check_len(path, values.len(), width, height, 1)?;
    let px: Vec<u16> =
        values.iter().map(|&v| if v.is_nan() { 0 } else { (v.clamp(0.0, 1.0) * 65535.0).round() as u16 }).collect();
    let img: ImageBuffer<Luma<u16>, Vec<u16>> = ImageBuffer::from_raw(width, height, px).expect("length checked");
    img.save(path).map_err(|source| ImageError::Encode { path: path.to_path_buf(), source })
}

/// Writes an 8-bit mask PNG (true → white).
pub fn write_mask_png(path: &Path, mask: &[bool], width: u32, height: u32) -> Result<(), ImageError> {
    check_len(path, mask.len(), width, height, 1)?;
    let px: Vec<u8> = mask.iter().map(|&m| if m { 255 } else { 0 }).collect();
    let img: ImageBuffer<Luma<u8>, Vec<u8>> = ImageBuffer::from_raw(width, height, px).expect("length checked");
    img.save(path).map_err(|source| ImageError::Encode { path: path.to_path_buf(), source })
}

/// Writes an sRGB 8-bit RGB PNG.
pub fn write_rgb_png(path: &Path, rgb: &[u8], width: u32, height: u32) -> Result<(), ImageError> {
    check_len(path, rgb.len(), width, height, 3)?;
    let img: ImageBuffer<Rgb<u8>, Vec<u8>> =
        ImageBuffer::from_raw(width, height, rgb.to_vec()).expect("length checked");
    img.save(path).map_err(|source| ImageError::Encode { path: path.to_path_buf(), source })
}

/// Encodes RGB bytes as a PNG in memory.
pub fn encode_rgb_png(rgb: &[u8], width: u32, height: u32) -> Result<Vec<u8>, ImageError> {
    check_len(Path::new("<memory>"), rgb.len(), width, height, 3)?;
    let mut out = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new(&mut out);
    image::ImageEncoder::write_image(encoder, rgb, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|source| ImageError::Encode { path: PathBuf::from("<memory>"), source })?;
    Ok(out)
}

/// Visibility as 8-bit grey RGB for display; not-relevant pixels in [`NOT_RELEVANT`] grey.
pub fn visibility_rgb(values: &[f32]) -> Vec<u8> {
    values
        .iter()
        .flat_map(|&v| {
            if v.is_nan() {
                NOT_RELEVANT
            } else {
                let g = (v.clamp(0.0, 1.0) * 255.0).round() as u8;
                [g, g, g]
            }
        })
        .collect()
}

/// The header written beside a raw f32 file.
#[derive(Debug, Clone, Serialize)]
pub struct RawHeader<'a> {
    pub file: String,
    pub width: u32,
    pub height: u32,
    pub channels: u32,
    pub dtype: &'static str,
    pub byte_order: &'static str,
    pub layout: &'static str,
    pub description: &'a str,
}

/// Writes `data` as raw little-endian f32 to `stem.f32` and its header to `stem.json`.
/// Layout: row-major, top row first, channels interleaved. Returns the two paths.
pub fn write_raw_f32(
    stem: &Path,
    data: &[f32],
    width: u32,
    height: u32,
    channels: u32,
    description: &str,
) -> Result<(PathBuf, PathBuf), ImageError> {
    check_len(stem, data.len(), width, height, channels)?;
    let bin = stem.with_extension("f32");
    let json = stem.with_extension("json");
    let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(&bin, bytes).map_err(|source| ImageError::Io { path: bin.clone(), source })?;
    let header = RawHeader {
        file: bin.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default(),
        width,
        height,
        channels,
        dtype: "f32",
        byte_order: "little-endian",
        layout: "row-major, top row first, channels interleaved",
        description,
    };
    let text = serde_json::to_string_pretty(&header).expect("serialisable");
    std::fs::write(&json, text).map_err(|source| ImageError::Io { path: json.clone(), source })?;
    Ok((bin, json))
}

/// Reads a raw f32 file written by [`write_raw_f32`] (the header is not needed: `len` checks it).
pub fn read_raw_f32(path: &Path) -> Result<Vec<f32>, ImageError> {
    let bytes =
        shadowlab_core::read_regular(path).map_err(|source| ImageError::Io { path: path.to_path_buf(), source })?;
    Ok(bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
}

/// Background of heatmaps where a pixel is not relevant: dark grey, distinct from "exact" (white).
pub const NOT_RELEVANT: [u8; 3] = [48, 48, 48];

/// Colour of a signed error d = V − V_ref in [−1, 1] on a diverging map: white at 0, blue where the
/// technique is too dark (d < 0), red where it is too bright (d > 0). The square root stretches
/// small errors so that a 1% error is visible (10% of the way to full colour).
pub fn error_colour(d: f32) -> [u8; 3] {
    let t = d.abs().clamp(0.0, 1.0).sqrt();
    let white = Vec3::ONE;
    let far = if d < 0.0 { Vec3::new(0.02, 0.19, 0.65) } else { Vec3::new(0.7, 0.02, 0.05) };
    let c = white.lerp(far, t);
    [(c.x * 255.0).round() as u8, (c.y * 255.0).round() as u8, (c.z * 255.0).round() as u8]
}

/// The signed error heatmap of `value` against `reference` as RGB bytes.
pub fn error_heatmap(value: &[f32], reference: &[f32]) -> Vec<u8> {
    value
        .iter()
        .zip(reference)
        .flat_map(|(&v, &r)| {
            if r.is_nan() {
                NOT_RELEVANT
            } else if v.is_nan() {
                error_colour(-1.0)
            } else {
                error_colour(v - r)
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diverging_colours() {
        assert_eq!(error_colour(0.0), [255, 255, 255]);
        let dark = error_colour(-1.0);
        let bright = error_colour(1.0);
        assert!(dark[2] > dark[0], "too dark is blue: {dark:?}");
        assert!(bright[0] > bright[2], "too bright is red: {bright:?}");
        let small = error_colour(0.01);
        assert!(small[1] < 255, "a 1% error is visible");
    }

    #[test]
    fn raw_round_trip() {
        let dir = std::env::temp_dir().join(format!("shadowlab-raw-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let data = [0.0, 0.5, f32::NAN, 1.0];
        let (bin, json) = write_raw_f32(&dir.join("v"), &data, 2, 2, 1, "test").unwrap();
        let back = read_raw_f32(&bin).unwrap();
        assert_eq!(back[1], 0.5);
        assert!(back[2].is_nan());
        let header: serde_json::Value = serde_json::from_slice(&std::fs::read(json).unwrap()).unwrap();
        assert_eq!(header["width"], 2);
        assert!(write_raw_f32(&dir.join("w"), &data, 3, 2, 1, "bad").is_err());
        write_visibility_png(&dir.join("v.png"), &data, 2, 2).unwrap();
        std::fs::remove_dir_all(dir).ok();
    }
}
