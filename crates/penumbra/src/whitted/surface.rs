//! How a surface responds to light in the Whitted model: the coefficients
//! a material's MTL fields and `illum` mode come to.
//!
//! Radiance leaving a surface point towards the viewer (section 3 of the
//! bounded-error paper; Whitted 1980), with `E_j` light `j`'s irradiance at
//! normal incidence and `V_j` its visibility (1, 0, or the product of the
//! transmission of the glass in between):
//!
//! `L = Ke + Ka A + sum_j V_j E_j (Kd (N.L_j) + Ks (N.H_j)^Ns)
//!      + kr L_reflected + kt L_transmitted`
//!
//! with `A` the scene's ambient light and `H = normalize(L - I)` the half
//! vector (the paper writes `(N.(-I+L)/2)^n`; normalised, the highlight
//! peaks at 1 where the paper's would not). `E_j` is in the units of
//! penumbra's other methods (a directional light of radiance 1 lights a
//! white surface facing it to 1; emitters are scaled to match, see
//! `lights`). `kr` and `kt` are constant, as in the paper, or
//! Fresnel-weighted (Schlick) when the renderer is asked to.
//!
//! MTL `illum` modes: 0 constant colour `Kd` (no lighting); 1 ambient and
//! diffuse (`Ks` unused); 2 Phong; 3, 5 and 8 Phong plus mirror reflection
//! with `kr = Ks`; 4, 6, 7 and 9 glass: Phong, reflection `kr = Ks` and
//! refraction with index `Ni`, transmission `kt = Tf` (or `1 - d` where the
//! file gives `d` and no `Tf`); 10 as 2. A material with `d < 1` that is
//! not glass is dissolved: it lets `1 - d` through unbent and its other
//! terms are scaled by `d`.
//!
//! These are the spec's meanings. An MTL file's materials come here after
//! `scene::mtl_rules` has read them as their exporter meant where the file
//! shows it (Maya's opaque `illum 4` made illum 3, `Tr` written as opacity
//! made `d`, ...; `LightingSettings::mtl_rules`).

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::geom::float::floor;

use crate::scene::Material;
use crate::scene::texture_table::NO_MAP;

/// `Surface::flags`: lit by the lights and the ambient term (else the
/// constant colour `kd`, MTL illum 0).
pub const LIT: u32 = 1;
/// `Surface::flags`: transmits by refraction with index `ni`, tracking the
/// media a ray is inside (glass); else transmission goes straight through.
pub const REFRACTS: u32 = 2;

/// A material's shading coefficients, as the GPU reads them (128 bytes),
/// and its texture maps' ids.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Surface {
    pub ka: [f32; 3],
    pub flags: u32,
    pub kd: [f32; 3],
    pub ns: f32,
    pub ks: [f32; 3],
    pub ni: f32,
    /// Mirror reflection weight.
    pub kr: [f32; 3],
    /// The diffuse colour's texture map (an index into the scene's
    /// `TextureTable::maps`), or `NO_MAP`.
    pub map_kd: u32,
    /// Transmission weight.
    pub kt: [f32; 3],
    /// The ambient colour's map, or `NO_MAP` (then `map_kd` serves).
    pub map_ka: u32,
    /// Emitted radiance.
    pub ke: [f32; 3],
    /// The highlight colour's map, or `NO_MAP`.
    pub map_ks: u32,
    /// The checker texture (`Checker`): the factor of `ka` and `kd` on odd
    /// cubes, and the reciprocal of the cube size (0: no texture).
    pub checker_odd: [f32; 3],
    pub checker_inv_size: f32,
    pub checker_origin: [f32; 3],
    /// The cut-out's alpha map, or `NO_MAP`.
    pub map_alpha: u32,
}

impl Surface {
    /// The coefficients of `m`; a problem with them (a weight above 1) is
    /// pushed to `warnings` and clamped, so no path gains energy.
    pub fn from_material(m: &Material, warnings: &mut Vec<String>) -> Surface {
        let (mut ka, mut kd, mut ks) = (m.ka, m.kd, m.ks);
        let (mut kr, mut kt, mut flags) = (Vec3::ZERO, Vec3::ZERO, LIT);
        match m.illum {
            0 => {
                flags = 0;
                ks = Vec3::ZERO;
            }
            1 => ks = Vec3::ZERO,
            3 | 5 | 8 => kr = m.ks,
            4 | 6 | 7 | 9 => {
                flags |= REFRACTS;
                kr = m.ks;
                kt = if m.has_tf || m.dissolve >= 1.0 {
                    m.tf
                } else {
                    Vec3::splat(1.0 - m.dissolve)
                };
            }
            _ => {}
        }
        if flags & REFRACTS == 0 && m.dissolve < 1.0 {
            // Dissolve: a see-through surface that does not bend light.
            kt = Vec3::splat(1.0 - m.dissolve);
            ka *= m.dissolve;
            kd *= m.dissolve;
            ks *= m.dissolve;
            kr *= m.dissolve;
        }
        let mut clamp = |what: &str, v: Vec3| {
            let c = v.clamp(Vec3::ZERO, Vec3::ONE);
            if c != v {
                warnings.push(format!(
                    "material '{}': {what} weight {v} is above 1 and is clamped to 1 (a surface cannot reflect more than it receives)",
                    m.name
                ));
            }
            c
        };
        kr = clamp("reflection (Ks)", kr);
        kt = clamp("transmission (Tf)", kt);
        Surface {
            ka: ka.to_array(),
            flags,
            kd: kd.to_array(),
            ns: m.ns,
            ks: ks.to_array(),
            ni: m.ni,
            kr: kr.to_array(),
            map_kd: NO_MAP,
            kt: kt.to_array(),
            map_ka: NO_MAP,
            ke: m.ke.to_array(),
            map_ks: NO_MAP,
            checker_odd: m.checker.map_or([1.0; 3], |c| c.odd.to_array()),
            checker_inv_size: m.checker.map_or(0.0, |c| 1.0 / c.size),
            checker_origin: m.checker.map_or([0.0; 3], |c| c.origin.to_array()),
            map_alpha: NO_MAP,
        }
    }

    /// Whether `ka` and `kd` vary over the surface (a checker texture).
    pub fn textured(&self) -> bool {
        self.checker_inv_size != 0.0
    }

    /// Whether any texture map (colour or cut-out) applies.
    pub fn mapped(&self) -> bool {
        [self.map_kd, self.map_ka, self.map_ks, self.map_alpha]
            .iter()
            .any(|&m| m != NO_MAP)
    }

    /// The cube of the checker texture that holds `p` (integer-valued).
    pub fn checker_cube(&self, p: Vec3) -> Vec3 {
        let q = (p - Vec3::from_array(self.checker_origin)) * self.checker_inv_size;
        Vec3::new(floor(q.x), floor(q.y), floor(q.z))
    }

    /// The texture's factor of `ka` and `kd` at `p`: 1, or `checker_odd`
    /// on odd cubes (the same operations as `texture` in whitted.wgsl).
    pub fn texture(&self, p: Vec3) -> Vec3 {
        if !self.textured() {
            return Vec3::ONE;
        }
        self.factor_of(self.checker_cube(p))
    }

    fn factor_of(&self, cube: Vec3) -> Vec3 {
        let k = cube.x + cube.y + cube.z;
        if k - 2.0 * floor(0.5 * k) != 0.0 {
            Vec3::from_array(self.checker_odd)
        } else {
            Vec3::ONE
        }
    }

    /// The texture's factor at every point within `margin` of `p` (per
    /// axis), or `None` where a cube's face lies that close.
    pub fn texture_near(&self, p: Vec3, margin: f32) -> Option<Vec3> {
        if !self.textured() {
            return Some(Vec3::ONE);
        }
        let lo = self.checker_cube(p - Vec3::splat(margin));
        (lo == self.checker_cube(p + Vec3::splat(margin))).then(|| self.factor_of(lo))
    }

    pub fn lit(&self) -> bool {
        self.flags & LIT != 0
    }

    pub fn refracts(&self) -> bool {
        self.flags & REFRACTS != 0
    }

    /// Lets light through (glass or dissolved): shadow rays pass, filtered.
    pub fn transmits(&self) -> bool {
        self.kt.iter().any(|&k| k > 0.0)
    }

    pub fn emits(&self) -> bool {
        self.ke.iter().any(|&k| k > 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn material(illum: u32) -> Material {
        Material {
            ks: Vec3::splat(0.5),
            tf: Vec3::new(0.9, 0.8, 0.7),
            has_tf: true,
            illum,
            ..Material::named("m")
        }
    }

    #[test]
    fn illum_modes_map_to_coefficients() {
        let mut w = Vec::new();
        let s = Surface::from_material(&material(0), &mut w);
        assert!(!s.lit() && s.ks == [0.0; 3]);
        let s = Surface::from_material(&material(1), &mut w);
        assert!(s.lit() && s.ks == [0.0; 3] && s.kr == [0.0; 3]);
        let s = Surface::from_material(&material(2), &mut w);
        assert!(s.ks == [0.5; 3] && s.kr == [0.0; 3] && !s.transmits());
        for illum in [3, 5, 8] {
            let s = Surface::from_material(&material(illum), &mut w);
            assert!(s.kr == [0.5; 3] && !s.transmits(), "illum {illum}");
        }
        for illum in [4, 6, 7, 9] {
            let s = Surface::from_material(&material(illum), &mut w);
            assert!(
                s.refracts() && s.kt == [0.9, 0.8, 0.7] && s.kr == [0.5; 3],
                "illum {illum}"
            );
        }
        assert!(w.is_empty());
    }

    #[test]
    fn dissolve_and_clamping() {
        let mut w = Vec::new();
        let m = Material {
            dissolve: 0.25,
            ..Material::named("veil")
        };
        let s = Surface::from_material(&m, &mut w);
        assert!(!s.refracts() && s.kt == [0.75; 3]);
        assert!((s.kd[0] - 0.2).abs() < 1e-6);
        // Glass given by d alone transmits 1 - d.
        let m = Material {
            dissolve: 0.1,
            illum: 7,
            ..Material::named("glass")
        };
        assert_eq!(Surface::from_material(&m, &mut w).kt, [0.9; 3]);
        let m = Material {
            ks: Vec3::splat(2.0),
            illum: 3,
            ..Material::named("hot")
        };
        assert_eq!(Surface::from_material(&m, &mut w).kr, [1.0; 3]);
        assert_eq!(w.len(), 1);
        assert!(w[0].contains("'hot'"), "{w:?}");
    }

    #[test]
    fn checker_alternates_by_cube_parity() {
        let m = Material {
            checker: Some(crate::scene::Checker {
                size: 0.5,
                origin: Vec3::new(0.0, -0.25, 0.0),
                odd: Vec3::new(0.1, 0.2, 0.3),
            }),
            ..Material::named("floor")
        };
        let s = Surface::from_material(&m, &mut Vec::new());
        assert!(s.textured() && !Surface::from_material(&material(2), &mut Vec::new()).textured());
        let odd = Vec3::new(0.1, 0.2, 0.3);
        // On the plane y = 0 (inside the layer of cubes -0.25..0.25).
        assert_eq!(s.texture(Vec3::new(0.1, 0.0, 0.1)), Vec3::ONE);
        assert_eq!(s.texture(Vec3::new(0.6, 0.0, 0.1)), odd);
        assert_eq!(s.texture(Vec3::new(0.6, 0.0, 0.6)), Vec3::ONE);
        assert_eq!(s.texture(Vec3::new(-0.1, 0.0, 0.1)), odd);
        assert_eq!(s.texture(Vec3::new(-0.1, 0.0, -0.1)), Vec3::ONE);
        assert_eq!(s.texture(Vec3::new(-1.1, 1e-7, -0.1)), Vec3::ONE);
        assert_eq!(s.texture(Vec3::new(0.1, 0.3, 0.1)), odd);
        // Near an edge (x = 0.5) only with a margin that does not reach it.
        assert_eq!(s.texture_near(Vec3::new(0.49, 0.0, 0.1), 0.005), Some(Vec3::ONE));
        assert_eq!(s.texture_near(Vec3::new(0.49, 0.0, 0.1), 0.02), None);
        assert_eq!(s.texture_near(Vec3::new(0.51, 0.0, 0.1), 0.005), Some(odd));
    }
}
