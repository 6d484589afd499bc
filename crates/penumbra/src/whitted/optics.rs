//! Perfect specular reflection and refraction (Whitted 1980; the
//! bounded-error paper's section 3 base ray tracer): the mirror direction,
//! Snell's law with total internal reflection, and Schlick's approximation
//! of the Fresnel reflectance for the optional Fresnel weighting.
//!
//! Twins of `reflect_dir`, `refract_dir` and `schlick` in
//! `wgsl/whitted.wgsl`, written in the same order of operations.

use glam::Vec3;

/// The mirror direction of unit `d` about unit `n` (either side).
#[inline]
pub fn reflect_dir(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// The refracted direction of unit `d` through a surface with unit normal
/// `n` facing the incoming ray (`d . n < 0`), `eta` = n1 / n2 (incident over
/// transmitted index), or `None` beyond the critical angle (total internal
/// reflection). Snell's law: `n1 sin(theta_i) = n2 sin(theta_t)`.
///
/// `eta == 1` passes `d` through unchanged, exactly: an interface between
/// equal indices neither bends nor reflects totally.
#[inline]
pub fn refract_dir(d: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    if eta == 1.0 {
        return Some(d);
    }
    let cos_i = -d.dot(n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((eta * d + (eta * cos_i - cos_t) * n).normalize())
}

/// Schlick's approximation of the unpolarised Fresnel reflectance at an
/// interface from index `n1` to `n2`, for a ray at `cos_i` to the normal:
/// `R0 + (1 - R0) (1 - cos)^5`, `R0 = ((n1 - n2) / (n1 + n2))^2`, with the
/// cosine on the denser side (the transmitted angle when leaving a denser
/// medium). 1 under total internal reflection.
#[inline]
pub fn schlick(cos_i: f32, n1: f32, n2: f32) -> f32 {
    let r0 = ((n1 - n2) / (n1 + n2)).powi(2);
    let mut cos = cos_i;
    if n1 > n2 {
        let eta = n1 / n2;
        let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
        if sin2_t >= 1.0 {
            return 1.0;
        }
        cos = (1.0 - sin2_t).sqrt();
    }
    let m = (1.0 - cos).clamp(0.0, 1.0);
    r0 + (1.0 - r0) * m * m * m * m * m
}

/// Schlick's approximation for a mirror of normal-incidence reflectance
/// `r0` (a metal-like mirror with `Ks` as its colour): the reflectance rises
/// to 1 at grazing angles.
#[inline]
pub fn schlick_mirror(cos_i: f32, r0: Vec3) -> Vec3 {
    let m = (1.0 - cos_i).clamp(0.0, 1.0);
    r0 + (Vec3::ONE - r0) * (m * m * m * m * m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflection_keeps_the_angle_and_flips_the_normal_component() {
        let d = Vec3::new(1.0, -1.0, 0.0).normalize();
        let r = reflect_dir(d, Vec3::Y);
        assert!((r - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6);
        assert!((r.length() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn snell_holds_and_equal_indices_do_not_bend() {
        let d = Vec3::new(0.6, -0.8, 0.0);
        for eta in [1.0 / 1.5, 1.0 / 1.33, 1.2] {
            let t = refract_dir(d, Vec3::Y, eta).unwrap();
            // sin(theta_t) = eta sin(theta_i), on the far side of the surface.
            assert!((t.x - eta * d.x).abs() < 1e-6, "eta {eta}: {t}");
            assert!(t.y < 0.0 && (t.length() - 1.0).abs() < 1e-6);
        }
        assert_eq!(refract_dir(d, Vec3::Y, 1.0), Some(d));
    }

    #[test]
    fn total_internal_reflection_beyond_the_critical_angle_only() {
        // Glass (1.5) to air: critical angle asin(1/1.5) = 41.8 degrees.
        let eta = 1.5;
        let critical = (1.0f32 / eta).asin();
        for (degrees, tir) in [(30.0f32, false), (41.0, false), (42.5, true), (80.0, true)] {
            let a = degrees.to_radians();
            let d = Vec3::new(a.sin(), -a.cos(), 0.0);
            assert_eq!(refract_dir(d, Vec3::Y, eta).is_none(), tir, "{degrees} degrees");
            assert_eq!(a > critical, tir);
        }
    }

    #[test]
    fn schlick_limits() {
        // Normal incidence on glass: 4%; grazing: 1; TIR: 1; same indices: 0 at normal.
        assert!((schlick(1.0, 1.0, 1.5) - 0.04).abs() < 1e-6);
        assert!((schlick(0.0, 1.0, 1.5) - 1.0).abs() < 1e-6);
        assert_eq!(schlick(0.3, 1.5, 1.0), 1.0);
        assert_eq!(schlick(1.0, 1.2, 1.2), 0.0);
        // Symmetric at normal incidence.
        assert!((schlick(1.0, 1.5, 1.0) - 0.04).abs() < 1e-6);
        let m = schlick_mirror(1.0, Vec3::splat(0.5));
        assert_eq!(m, Vec3::splat(0.5));
        assert!((schlick_mirror(0.0, Vec3::splat(0.5)) - Vec3::ONE).length() < 1e-6);
    }
}
