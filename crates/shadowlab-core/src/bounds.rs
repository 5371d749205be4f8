//! Axis-aligned bounding boxes.

use glam::{Affine3A, Vec3};
use serde::{Deserialize, Serialize};

/// An axis-aligned box. The empty box has `min > max` and absorbs nothing.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    pub const EMPTY: Self = Self { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        let mut b = Self::EMPTY;
        for p in points {
            b.grow(p);
        }
        b
    }

    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }

    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    pub fn union(&self, other: &Self) -> Self {
        Self { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    pub fn extent(&self) -> Vec3 {
        if self.is_empty() { Vec3::ZERO } else { self.max - self.min }
    }

    /// Length of the diagonal; 0 for an empty box.
    pub fn diagonal(&self) -> f32 {
        self.extent().length()
    }

    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    pub fn corners(&self) -> [Vec3; 8] {
        let (a, b) = (self.min, self.max);
        [
            Vec3::new(a.x, a.y, a.z),
            Vec3::new(b.x, a.y, a.z),
            Vec3::new(a.x, b.y, a.z),
            Vec3::new(b.x, b.y, a.z),
            Vec3::new(a.x, a.y, b.z),
            Vec3::new(b.x, a.y, b.z),
            Vec3::new(a.x, b.y, b.z),
            Vec3::new(b.x, b.y, b.z),
        ]
    }

    /// The bounds of this box after an affine transform (conservative: the box of the 8 corners).
    pub fn transformed(&self, t: &Affine3A) -> Self {
        if self.is_empty() {
            return *self;
        }
        Self::from_points(self.corners().map(|c| t.transform_point3(c)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_and_growth() {
        let mut b = Aabb::EMPTY;
        assert!(b.is_empty());
        assert_eq!(b.diagonal(), 0.0);
        b.grow(Vec3::new(1.0, 2.0, 3.0));
        b.grow(Vec3::new(-1.0, 0.0, 3.0));
        assert!(!b.is_empty());
        assert_eq!(b.extent(), Vec3::new(2.0, 2.0, 0.0));
        assert!(b.contains(Vec3::new(0.0, 1.0, 3.0)));
        let t = Affine3A::from_translation(Vec3::X);
        assert_eq!(b.transformed(&t).min, Vec3::new(0.0, 0.0, 3.0));
    }
}
