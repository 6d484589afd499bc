//! Rigid motions with uniform scale: what the displacement-field paper's
//! instances may undergo without invalidating a precomputed field.

use glam::{Quat, Vec3};

/// A placement: scale uniformly, rotate, then translate
/// (`p' = rotation (scale p) + translation`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// Where the mesh's coordinate zero lands, in the scene's frame.
    pub translation: Vec3,
    /// A unit quaternion.
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
    /// A point of the mesh placed in the scene.
    pub fn apply_point(&self, p: Vec3) -> Vec3 {
        self.rotation * (p * self.scale) + self.translation
    }

    /// Directions (normals too: uniform scale keeps them perpendicular).
    pub fn apply_vector(&self, v: Vec3) -> Vec3 {
        self.rotation * v
    }

    /// A point of the scene in the mesh's coordinates: the inverse of
    /// `apply_point`.
    pub fn inverse_point(&self, p: Vec3) -> Vec3 {
        (self.rotation.inverse() * (p - self.translation)) / self.scale
    }
}

/// A rigid motion per animation frame: a rotation about `pivot` and a
/// translation, applied `frame` times on top of an instance's placement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// The unit axis of the rotation.
    pub axis: Vec3,
    /// The rotation per frame, in degrees (right-handed about `axis`).
    pub degrees_per_frame: f32,
    /// The point the rotation turns about, in the scene's frame.
    pub pivot: Vec3,
    /// The translation per frame, in scene units.
    pub velocity: Vec3,
}

impl Motion {
    /// `placement` after `frame` frames of this motion.
    pub fn at(&self, placement: &Transform, frame: u32) -> Transform {
        let f = frame as f32;
        let spin = Quat::from_axis_angle(self.axis, (self.degrees_per_frame * f).to_radians());
        Transform {
            translation: spin * (placement.translation - self.pivot) + self.pivot + self.velocity * f,
            rotation: (spin * placement.rotation).normalize(),
            scale: placement.scale,
        }
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

    #[test]
    fn motion_is_rigid_and_starts_at_the_placement() {
        let placement = Transform {
            translation: Vec3::new(1.0, 0.0, 0.0),
            rotation: Quat::IDENTITY,
            scale: 2.0,
        };
        let m = Motion {
            axis: Vec3::Y,
            degrees_per_frame: 90.0,
            pivot: Vec3::ZERO,
            velocity: Vec3::new(0.0, 0.5, 0.0),
        };
        assert_eq!(m.at(&placement, 0), placement);
        let t = m.at(&placement, 1);
        // The instance's origin orbits the pivot and rises.
        assert!(t.apply_point(Vec3::ZERO).abs_diff_eq(Vec3::new(0.0, 0.5, -1.0), 1e-5));
        // Distances scale by the instance's scale only.
        let (a, b) = (Vec3::new(0.1, 0.2, 0.3), Vec3::new(-0.4, 0.0, 0.2));
        assert!(((t.apply_point(a) - t.apply_point(b)).length() - 2.0 * (a - b).length()).abs() < 1e-5);
    }
}
