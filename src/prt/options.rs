//! Hemispherical rasterisation's knobs as command-line options (see
//! `crate::options`).

use clap::Args;

use super::hierarchy::{DEFAULT_TOLERANCE, HierarchySettings, NearField};
use super::pipeline::{PrtSettings, Toggle};
use super::transfer::{Brdf, BrdfKind, Integration};
use crate::error::Result;
use crate::options::{Applies, OnOff, applies, positive};

#[derive(Args, Clone, Debug)]
pub struct PrtOptions {
    /// SH bands (5 = 25 coefficients).
    #[arg(long, default_value_t = 5, allow_negative_numbers = true)]
    pub order: i64,
    /// Visibility mask side in pixels: 16, 32 or 64.
    #[arg(long, default_value_t = 32, allow_negative_numbers = true)]
    pub mask: i64,
    /// Plane LUT cells per cube-face side (the paper: 128).
    #[arg(long, default_value_t = 128, allow_negative_numbers = true)]
    pub lut: i64,
    /// BRDF of the transfer.
    #[arg(long, value_enum, default_value_t = BrdfKind::Diffuse)]
    pub brdf: BrdfKind,
    /// Phong exponent.
    #[arg(long, default_value_t = 16.0, allow_negative_numbers = true)]
    pub shininess: f32,
    /// Phong lobe weight k_s in [0, 1] (the rest is diffuse).
    #[arg(long, default_value_t = 0.4, allow_negative_numbers = true)]
    pub specular: f32,
    /// Mask integration: 4x4 grey levels (the paper), grey levels with first
    /// moments, or every pixel.
    #[arg(long, value_enum, default_value_t = Integration::CellsLinear)]
    pub integration: Integration,
    /// Two-level mesh hierarchy (coarse mesh for distant blockers).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub hierarchy: OnOff,
    /// Fine triangles drawn near a vertex.
    #[arg(long, value_enum, default_value_t = NearField::Clusters)]
    pub near: NearField,
    /// Ring of the full mesh drawn at full resolution: 1 or 2.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub ring: i64,
    /// Coarse triangles to aim for [default: triangles / 16, at most 8 sqrt(triangles) unless refinement outweighs it].
    #[arg(long, allow_negative_numbers = true)]
    pub coarse: Option<i64>,
    /// Angle (radians) a coarse triangle's distance from the fine surface may subtend at a vertex before the vertex draws the fine triangles instead (0: the paper's plain two levels).
    #[arg(long, default_value_t = DEFAULT_TOLERANCE, allow_negative_numbers = true)]
    pub coarse_tolerance: f32,
    /// Far triangles per culling group.
    #[arg(long, default_value_t = 16, allow_negative_numbers = true)]
    pub group_size: i64,
    /// Skip culling groups below the tangent plane.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub group_culling: OnOff,
    /// Cull blockers facing away from the vertex (auto: where rays find it costs no accuracy).
    #[arg(long, value_enum, default_value_t = Toggle::Auto)]
    pub backface: Toggle,
    /// Shade each vertex's side facing the camera (auto: where the mesh's back is seen from outside).
    #[arg(long, value_enum, default_value_t = Toggle::Auto)]
    pub two_sided: Toggle,
}

impl PrtOptions {
    /// Which knobs apply to the chosen BRDF and hierarchy.
    pub fn applies(&self) -> Vec<Applies> {
        let hierarchy = &["near", "ring", "coarse", "coarse_tolerance"];
        vec![
            applies(self.brdf == BrdfKind::Phong, &["shininess", "specular"], "--brdf phong"),
            applies(self.hierarchy == OnOff::On, hierarchy, "--hierarchy on"),
        ]
    }

    /// The checked settings (`shadows`: rasterise at all).
    pub fn settings(&self, shadows: bool) -> Result<PrtSettings> {
        let settings = PrtSettings {
            mask_side: positive("--mask", self.mask)?,
            lut_size: positive("--lut", self.lut)?,
            bands: positive("--order", self.order)?,
            brdf: Brdf::new(self.brdf, self.shininess, self.specular),
            integration: self.integration,
            hierarchy: HierarchySettings {
                enabled: self.hierarchy.on(),
                near: self.near,
                ring: positive("--ring", self.ring)?,
                coarse_triangles: self.coarse.map(|c| positive("--coarse", c)).transpose()?,
                group_size: positive("--group-size", self.group_size)?,
                tolerance: self.coarse_tolerance,
            },
            group_culling: self.group_culling.on(),
            backface: self.backface,
            two_sided: self.two_sided,
            shadows,
        };
        Ok(settings)
    }
}
