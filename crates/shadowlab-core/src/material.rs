//! Surface materials: what the lighting pass needs (DESIGN.md §3, Lambert + Blinn-Phong).

use std::path::PathBuf;

use glam::Vec3;

/// Where a texture's pixels come from. Decoding is left to the renderer, so loading a scene stays
/// cheap and `shadowlab-core` needs no image codecs.
#[derive(Debug, Clone, PartialEq)]
pub enum TextureRef {
    /// An image file (absolute, or relative to the current directory).
    File(PathBuf),
    /// Image bytes embedded in the scene file (a `.glb` buffer view or a data URI).
    Embedded { mime_type: String, bytes: Vec<u8> },
}

/// How a material's coverage (its base colour's alpha) decides what it hides (glTF 2.0 §3.9.4
/// `alphaMode`). Visibility here is binary per point, so translucency (`BLEND`) is taken as opaque.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum AlphaMode {
    /// Every point of the surface blocks light.
    #[default]
    Opaque,
    /// A point blocks light where its alpha (the base colour factor's times the base colour
    /// texture's) is at least `cutoff`, and is a hole elsewhere: leaves, fences, grilles.
    Mask { cutoff: f32 },
}

/// A surface's reflectance.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub name: String,
    /// Diffuse albedo, linear RGB in [0, 1].
    pub base_color: Vec3,
    /// Multiplies `base_color` when present.
    pub base_color_texture: Option<TextureRef>,
    /// Blinn-Phong specular strength, in [0, 1].
    pub specular: f32,
    /// Blinn-Phong exponent, ≥ 1.
    pub shininess: f32,
    /// Both sides are front faces: rendered and shadowed without back-face culling. Open surfaces
    /// (a single quad as an occluder, leaves, cloth) need it; closed meshes should not have it.
    pub double_sided: bool,
    /// Emitted radiance (linear RGB), added unshadowed; for visible light fixtures.
    pub emissive: Vec3,
    /// The base colour factor's alpha, in [0, 1] (multiplies the texture's).
    pub base_alpha: f32,
    /// Whether the alpha cuts holes ([`AlphaMode`]).
    pub alpha_mode: AlphaMode,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: "default".to_owned(),
            base_color: Vec3::splat(0.8),
            base_color_texture: None,
            specular: 0.0,
            shininess: 32.0,
            double_sided: false,
            emissive: Vec3::ZERO,
            base_alpha: 1.0,
            alpha_mode: AlphaMode::Opaque,
        }
    }
}

impl Material {
    /// A diffuse material of the given linear colour.
    pub fn diffuse(name: impl Into<String>, base_color: Vec3) -> Self {
        Self { name: name.into(), base_color, ..Self::default() }
    }

    /// Adds a Blinn-Phong highlight.
    pub fn with_specular(mut self, specular: f32, shininess: f32) -> Self {
        self.specular = specular;
        self.shininess = shininess;
        self
    }

    pub fn double_sided(mut self) -> Self {
        self.double_sided = true;
        self
    }

    /// Returns a message naming the first unusable value.
    pub fn check(&self) -> Result<(), String> {
        let colour_ok = |c: Vec3| c.is_finite() && c.min_element() >= 0.0;
        if !colour_ok(self.base_color) || self.base_color.max_element() > 1.0 {
            return Err(format!("base colour {} must be finite and in [0, 1]", self.base_color));
        }
        if !colour_ok(self.emissive) {
            return Err(format!("emissive {} must be finite and ≥ 0", self.emissive));
        }
        if !(self.specular.is_finite() && (0.0..=1.0).contains(&self.specular)) {
            return Err(format!("specular {} must be in [0, 1]", self.specular));
        }
        if !(self.shininess.is_finite() && (1.0..=1.0e4).contains(&self.shininess)) {
            return Err(format!("shininess {} must be in [1, 10000]", self.shininess));
        }
        if !(self.base_alpha.is_finite() && (0.0..=1.0).contains(&self.base_alpha)) {
            return Err(format!("base colour alpha {} must be in [0, 1]", self.base_alpha));
        }
        if let AlphaMode::Mask { cutoff } = self.alpha_mode
            && !(cutoff.is_finite() && (0.0..=1.0).contains(&cutoff))
        {
            return Err(format!("alpha cutoff {cutoff} must be in [0, 1]"));
        }
        Ok(())
    }
}
