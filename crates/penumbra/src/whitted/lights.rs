//! The lights a Whitted ray tracer shades with: point and directional
//! lights of a scene file, and emissive faces (MTL `Ke`) turned into point
//! lights so that Cornell-box-style scenes light themselves.
//!
//! A polygon of area `A` and emitted radiance `Ke` becomes `n` points
//! (`light_samples`; 1 = its centroid) of intensity `Ke A / (pi n)` in its
//! normal's direction, falling off with the cosine to that normal: one
//! side emits, as its winding says. (The shading takes `Kd` times the
//! irradiance, as the paper's `D = N.L` and penumbra's other methods do;
//! the `1/pi` makes a diffuse surface lit by an emitter as bright as
//! physics says, `Kd E / pi`, for the irradiance `E` of the emitter.) Each point is lifted off the polygon
//! along that normal (the ray offset of `offset`), so its shadow rays do
//! not stop at the emitter itself. Several points are stratified over the
//! polygon (area-weighted over its triangles, Owen-scrambled Sobol points
//! seeded by the polygon), so their shadows soften towards the area
//! light's penumbrae as `n` grows.
//!
//! Twin of `Light` in `wgsl/whitted.wgsl`.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::error::{Error, Result};
use crate::geom::offset::{max_abs, offset_point};
use crate::geom::sampling::SampleSequence;

/// `LightSample::kind`: a point light at `position`.
pub const POINT: u32 = 0;
/// `LightSample::kind`: a directional light travelling along `position`
/// (a unit vector), from infinitely far.
pub const DIRECTIONAL: u32 = 1;

/// Most lights a render takes (the GPU's light loop and the ray trees'
/// per-light codes); more emitter samples than this are refused.
pub const MAX_LIGHTS: usize = 4096;

/// One light as the GPU reads it (48 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct LightSample {
    /// A point light's position, or a directional light's direction of travel.
    pub position: [f32; 3],
    pub kind: u32,
    /// Intensity (W/sr) of a point light, irradiance at normal incidence of
    /// a directional one, per colour channel.
    pub intensity: [f32; 3],
    pub _pad0: u32,
    /// An emitter sample's unit normal (emits to its side only, with the
    /// cosine); zero for a light that emits equally in every direction.
    pub normal: [f32; 3],
    pub _pad1: u32,
}

impl LightSample {
    pub fn point(position: Vec3, intensity: Vec3) -> LightSample {
        Self::new(position, POINT, intensity, Vec3::ZERO)
    }

    pub fn directional(direction: Vec3, irradiance: Vec3) -> LightSample {
        Self::new(direction.normalize(), DIRECTIONAL, irradiance, Vec3::ZERO)
    }

    fn new(position: Vec3, kind: u32, intensity: Vec3, normal: Vec3) -> LightSample {
        LightSample {
            position: position.to_array(),
            kind,
            intensity: intensity.to_array(),
            _pad0: 0,
            normal: normal.to_array(),
            _pad1: 0,
        }
    }

    pub fn position(&self) -> Vec3 {
        Vec3::from_array(self.position)
    }

    pub fn intensity(&self) -> Vec3 {
        Vec3::from_array(self.intensity)
    }

    pub fn normal(&self) -> Vec3 {
        Vec3::from_array(self.normal)
    }
}

/// An emissive polygon: its triangles (world space) and radiance.
pub struct Emitter {
    pub triangles: Vec<[Vec3; 3]>,
    pub radiance: Vec3,
    /// Seeds its sample points.
    pub index: u32,
}

impl Emitter {
    /// Its point lights (see the module's description); none when the
    /// polygon has no area.
    pub fn samples(&self, n: u32) -> Vec<LightSample> {
        let cross: Vec<Vec3> = self
            .triangles
            .iter()
            .map(|[a, b, c]| (*b - *a).cross(*c - *a))
            .collect();
        let areas: Vec<f32> = cross.iter().map(|c| 0.5 * c.length()).collect();
        let area: f32 = areas.iter().sum();
        let Some(normal) = cross.iter().sum::<Vec3>().try_normalize() else {
            return Vec::new();
        };
        if !(area > 0.0 && area.is_finite()) {
            return Vec::new();
        }
        let magnitude = self.triangles.iter().flatten().map(|&v| max_abs(v)).fold(0.0, f32::max);
        let intensity = self.radiance * (area / (std::f32::consts::PI * n as f32));
        let lift = |p: Vec3| offset_point(p, normal, magnitude);
        if n == 1 {
            let centroid = self
                .triangles
                .iter()
                .zip(&areas)
                .map(|([a, b, c], &w)| (*a + *b + *c) * (w / 3.0))
                .sum::<Vec3>()
                / area;
            return vec![LightSample::new(lift(centroid), POINT, intensity, normal)];
        }
        let sequence = SampleSequence::new(0x11_6b7);
        (0..n)
            .map(|k| {
                let [u, v] = sequence.sample(self.index, k);
                // Pick a triangle by area with u, reuse u's remainder in it.
                let mut target = u * area;
                let mut t = 0;
                while t + 1 < areas.len() && target >= areas[t] {
                    target -= areas[t];
                    t += 1;
                }
                let su = (target / areas[t].max(f32::MIN_POSITIVE)).clamp(0.0, 1.0).sqrt();
                let [a, b, c] = self.triangles[t];
                let p = a * (1.0 - su) + b * (su * (1.0 - v)) + c * (su * v);
                LightSample::new(lift(p), POINT, intensity, normal)
            })
            .collect()
    }
}

/// Checks a count of lights against what a render takes.
pub fn check_light_count(n: usize) -> Result<()> {
    if n > MAX_LIGHTS {
        return Err(Error::param(
            "light_samples",
            format!("the scene would have {n} lights, more than {MAX_LIGHTS}; ask for fewer samples per emitter"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Emitter {
        // A 2 x 1 quad at y = 3 facing down (-y), as the Cornell box's light.
        let (a, b, c, d) = (
            Vec3::new(0.0, 3.0, 0.0),
            Vec3::new(0.0, 3.0, 1.0),
            Vec3::new(2.0, 3.0, 1.0),
            Vec3::new(2.0, 3.0, 0.0),
        );
        Emitter {
            triangles: vec![[a, d, c], [a, c, b]],
            radiance: Vec3::new(4.0, 2.0, 1.0),
            index: 3,
        }
    }

    #[test]
    fn one_sample_is_the_centroid_with_the_whole_power() {
        let s = quad().samples(1);
        assert_eq!(s.len(), 1);
        assert!((s[0].position() - Vec3::new(1.0, 3.0, 0.5)).length() < 1e-3);
        assert!(s[0].position().y < 3.0, "lifted to the emitting side");
        assert_eq!(s[0].normal(), -Vec3::Y);
        assert!((s[0].intensity() * std::f32::consts::PI - Vec3::new(8.0, 4.0, 2.0)).length() < 1e-5);
    }

    #[test]
    fn many_samples_cover_the_polygon_and_share_its_power() {
        let s = quad().samples(64);
        let total: Vec3 = s.iter().map(|l| l.intensity()).sum();
        assert!((total * std::f32::consts::PI - Vec3::new(8.0, 4.0, 2.0)).length() < 1e-4);
        // Stratified: each of the 8 strips along x gets 8 points.
        let mut strips = [0; 8];
        for l in &s {
            let p = l.position();
            assert!((0.0..=2.0).contains(&p.x) && (0.0..=1.0).contains(&p.z));
            strips[((p.x / 2.0 * 8.0) as usize).min(7)] += 1;
        }
        assert!(strips.iter().all(|&c| (4..=12).contains(&c)), "{strips:?}");
        assert_eq!(s, quad().samples(64), "deterministic");
    }
}
