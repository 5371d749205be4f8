//! Alpha masks: where an alpha-masked material ([`AlphaMode::Mask`]) is a hole (glTF 2.0 §3.9.4:
//! a point is opaque where its alpha, the base colour factor's times the base colour texture's, is
//! at least the cutoff, and fully transparent elsewhere).
//!
//! The truth decides a shadow ray's hit on such a triangle here: the texture's alpha at the hit's
//! texture coordinates, the **nearest texel**, coordinates wrapped (glTF's default sampler,
//! `REPEAT`), (0, 0) the image's first pixel. Nearest rather than bilinear so that a map
//! technique's depth pass, sampling the same texels with a nearest sampler, cuts the same holes.
//! Only PNG carries an alpha channel worth reading here; a JPEG's alpha is 1 everywhere.

use glam::Vec2;

use crate::material::{AlphaMode, Material, TextureRef};

/// A texture's alpha channel, top row first.
#[derive(Debug, Clone, PartialEq)]
pub struct AlphaMask {
    pub width: u32,
    pub height: u32,
    pub alpha: Vec<u8>,
}

impl AlphaMask {
    /// The alpha of a PNG (8 or 16 bits, any colour type: no alpha channel gives 1 everywhere;
    /// a `tRNS` chunk is expanded to one).
    pub fn from_png(bytes: &[u8]) -> Result<Self, String> {
        let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        decoder.set_transformations(png::Transformations::normalize_to_color8());
        let mut reader = decoder.read_info().map_err(|e| format!("not a readable PNG: {e}"))?;
        let size = reader.output_buffer_size().ok_or("the PNG is too large")?;
        let mut buf = vec![0u8; size];
        let info = reader.next_frame(&mut buf).map_err(|e| format!("not a readable PNG: {e}"))?;
        let (channels, alpha_at) = match info.color_type {
            png::ColorType::GrayscaleAlpha => (2, Some(1)),
            png::ColorType::Rgba => (4, Some(3)),
            png::ColorType::Grayscale => (1, None),
            png::ColorType::Rgb => (3, None),
            png::ColorType::Indexed => return Err("an indexed PNG was not expanded".into()),
        };
        let (width, height) = (info.width, info.height);
        let mut alpha = Vec::with_capacity(width as usize * height as usize);
        for row in buf.chunks(info.line_size).take(height as usize) {
            for px in row.chunks(channels).take(width as usize) {
                alpha.push(alpha_at.map_or(255, |a| px[a]));
            }
        }
        if width == 0 || height == 0 || alpha.len() != width as usize * height as usize {
            return Err(format!("a {width}×{height} PNG has no pixels to read"));
        }
        Ok(Self { width, height, alpha })
    }

    /// The alpha, in [0, 1], of the texel nearest to `uv` (wrapped).
    pub fn at(&self, uv: Vec2) -> f32 {
        let texel = |c: f32, n: u32| {
            let c = if c.is_finite() { c } else { 0.0 };
            ((c - c.floor()) * n as f32).floor().clamp(0.0, (n - 1) as f32) as usize
        };
        let (x, y) = (texel(uv.x, self.width), texel(uv.y, self.height));
        f32::from(self.alpha[y * self.width as usize + x]) / 255.0
    }
}

/// What decides whether a material's point blocks light.
#[derive(Debug, Clone, PartialEq)]
pub struct Coverage {
    pub base_alpha: f32,
    pub cutoff: f32,
    /// The base colour texture's alpha; `None`: 1 everywhere.
    pub mask: Option<AlphaMask>,
}

impl Coverage {
    /// The coverage of an alpha-masked material, `None` for an opaque one. A texture that cannot
    /// be read is reported in `Err` with the coverage it leaves (the factor's alpha alone).
    pub fn of(material: &Material) -> Option<Result<Self, (Self, String)>> {
        let AlphaMode::Mask { cutoff } = material.alpha_mode else { return None };
        let mut coverage = Self { base_alpha: material.base_alpha, cutoff, mask: None };
        let Some(texture) = &material.base_color_texture else { return Some(Ok(coverage)) };
        let read = match texture {
            TextureRef::Embedded { mime_type, bytes } if mime_type.contains("jpeg") => return Some(Ok(coverage)),
            TextureRef::Embedded { bytes, .. } => AlphaMask::from_png(bytes),
            TextureRef::File(path) => {
                let jpeg =
                    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("jpg") || e.eq_ignore_ascii_case("jpeg"));
                if jpeg {
                    return Some(Ok(coverage));
                }
                std::fs::read(path)
                    .map_err(|e| format!("{}: {e}", path.display()))
                    .and_then(|bytes| AlphaMask::from_png(&bytes).map_err(|e| format!("{}: {e}", path.display())))
            }
        };
        Some(match read {
            Ok(mask) => {
                coverage.mask = Some(mask);
                Ok(coverage)
            }
            Err(e) => Err((coverage, format!("material '{}': alpha mask texture ignored: {e}", material.name))),
        })
    }

    /// Whether the point at texture coordinates `uv` blocks light.
    pub fn blocks(&self, uv: Vec2) -> bool {
        self.base_alpha * self.mask.as_ref().map_or(1.0, |m| m.at(uv)) >= self.cutoff
    }
}
