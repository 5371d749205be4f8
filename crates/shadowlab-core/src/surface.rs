//! Per-pixel surface points: what the ground truth needs from any renderer.
//!
//! The GPU G-buffer is read back into this form, and the CPU reference can trace it itself from a
//! camera; either way the reference computes V_l for exactly these points, so technique and truth
//! are compared on the same surface samples (DESIGN.md §2).

use glam::Vec3;

/// Positions and normals per pixel, row-major with the top row first. Positions are in the scene's
/// local frame ([`crate::Scene::origin`]), like everything a renderer draws.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceBuffer {
    pub width: u32,
    pub height: u32,
    /// World-space position of the visible surface (meaningless where `covered` is false).
    pub positions: Vec<Vec3>,
    /// Unit world-space shading normal, turned by the facet's facing (DESIGN.md §3).
    pub normals: Vec<Vec3>,
    /// Unit geometric (facet) normal N_g, facing the camera.
    pub geometric_normals: Vec<Vec3>,
    /// Whether the pixel shows geometry (false: background).
    pub covered: Vec<bool>,
}

impl SurfaceBuffer {
    /// An empty (all-background) buffer.
    pub fn new(width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        Self {
            width,
            height,
            positions: vec![Vec3::ZERO; n],
            normals: vec![Vec3::Y; n],
            geometric_normals: vec![Vec3::Y; n],
            covered: vec![false; n],
        }
    }

    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    pub fn covered_count(&self) -> usize {
        self.covered.iter().filter(|&&c| c).count()
    }

    /// Whether pixel `i` is relevant for `light` (DESIGN.md §3): it shows geometry that faces the
    /// light by both its shading and its geometric normal, within the light's range and cone.
    pub fn is_relevant(&self, i: usize, light: &crate::light::Light) -> bool {
        self.covered[i] && light.is_relevant_surface(self.positions[i], self.normals[i], self.geometric_normals[i])
    }

    /// Per pixel: whether it is relevant for `light`.
    pub fn relevance(&self, light: &crate::light::Light) -> Vec<bool> {
        (0..self.len()).map(|i| self.is_relevant(i, light)).collect()
    }
}
