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

use crate::material::{AlphaMode, Material};
use crate::texture::Rgba8;

/// A texture's alpha channel, top row first.
#[derive(Debug, Clone, PartialEq)]
pub struct AlphaMask {
    pub width: u32,
    pub height: u32,
    pub alpha: Vec<u8>,
}

impl AlphaMask {
    /// The alpha channel of an image.
    pub fn of(image: &Rgba8) -> Self {
        Self { width: image.width, height: image.height, alpha: image.texels.iter().map(|t| t[3]).collect() }
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
        Some(match Rgba8::read(texture) {
            Ok(image) => {
                coverage.mask = image.as_ref().map(AlphaMask::of);
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
