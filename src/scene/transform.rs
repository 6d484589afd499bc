//! Rigid motions with uniform scale: what the displacement-field paper's
//! instances may undergo without invalidating a precomputed field.

use glam::{Quat, Vec3};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    pub translation: Vec3,
    pub rotation: Quat,
    /// Uniform scale, > 0.
    pub scale: f32,
}

impl Default for Transform {
    fn default() -> Self {
        Transform {
            translation: Vec3::ZERO,
            rotation: Quat::IDENTITY,
            scale: 1.0,
        }
    }
}

impl Transform {
    pub fn apply_point(&self, p: Vec3) -> Vec3 {
        self.rotation * (p * self.scale) + self.translation
    }

    /// Directions (normals too: uniform scale keeps them perpendicular).
    pub fn apply_vector(&self, v: Vec3) -> Vec3 {
        self.rotation * v
    }

    pub fn inverse_point(&self, p: Vec3) -> Vec3 {
        (self.rotation.inverse() * (p - self.translation)) / self.scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_undoes_apply() {
        let t = Transform {
            translation: Vec3::new(1.0, -2.0, 3.0),
            rotation: Quat::from_axis_angle(Vec3::new(1.0, 1.0, 0.0).normalize(), 0.7),
            scale: 2.5,
        };
        let p = Vec3::new(0.3, 0.2, -0.9);
        assert!((t.inverse_point(t.apply_point(p)) - p).length() < 1e-5);
    }
}
