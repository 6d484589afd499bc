//! MLRTA tracing's knobs as command-line options (see `crate::options`).

use clap::Args;

use crate::options::{Applies, OnOff, applies};
use penumbra::accel::Structure;
use penumbra::error::Result;
use penumbra::mlrta::MlrtaSettings;
use penumbra::mlrta::aa::AaMode;
use penumbra::mlrta::runner::{AaRequest, ShadowLight, TraceRequest};
use penumbra::mlrta::tiles::{DEFAULT_EP_BUDGET, DEFAULT_MIN_TILE};
use penumbra::scene::View;

#[derive(Args, Clone, Debug)]
pub struct TraceOptions {
    /// Multi-level ray tracing: entry-point search with tile splitting
    /// (off: every 4x4 packet from the root, the paper's "no MLRT" rows).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub mlrta: OnOff,
    /// Trace rays one by one instead of in packets (the foundation's path).
    #[arg(long, conflicts_with = "mlrta")]
    pub single_ray: bool,
    /// What rays walk on the CPU [default: bvh with --single-ray, kdtree
    /// for packets]: packets through the kd-tree are MLRTA (tiles, entry
    /// points); `--accel bvh` traces each 4x4 packet through the wide BVH
    /// from its root instead (faster on the CPU; no tiles, entry points or
    /// anti-aliasing). The hits are the same.
    #[arg(long, value_enum)]
    pub accel: Option<Structure>,
    /// Initial tile side in pixels (the paper's ITS).
    #[arg(long, value_parser = crate::options::count::<u32>(4), default_value_t = 128, allow_negative_numbers = true)]
    pub tile: u32,
    /// Tiles no larger than this are not split (MTS) [default: 32, or --tile
    /// if smaller]. 8 traverses fewer cells; 32 is faster on the CPU.
    #[arg(long, value_parser = crate::options::count::<u32>(4), allow_negative_numbers = true)]
    pub min_tile: Option<u32>,
    /// Pieces a tile is split into (SF): 4, 16, 64...
    #[arg(long, value_parser = crate::options::count::<u32>(4), default_value_t = 16, allow_negative_numbers = true)]
    pub split_factor: u32,
    /// Nodes the entry-point search visits in a far subtree before it
    /// counts it as one with potential hits (the entry point moves up); 0
    /// searches every far subtree to the end, as the paper.
    #[arg(long, value_parser = crate::options::count::<u32>(0), default_value_t = DEFAULT_EP_BUDGET, allow_negative_numbers = true)]
    pub ep_budget: u32,
    /// Point light "X,Y,Z": adds a shadow ray per hit (Table 3's statistics).
    #[arg(long, value_parser = penumbra::scene::frame::parse_point, allow_hyphen_values = true)]
    pub light: Option<glam::DVec3>,
    /// Shadow rays to the default light (above the scene) when --light is
    /// not given: `--shadows` or `--shadows on`, as prt spells it.
    #[arg(long, value_enum, num_args = 0..=1, default_missing_value = "on")]
    pub shadows: Option<OnOff>,
    /// Anti-aliasing: extra rays in tiles whose entry point shows complex geometry.
    #[arg(long, value_enum, default_value_t = AaMode::None)]
    pub aa: AaMode,
    /// Rays per pixel where anti-aliasing applies (a square: 4, 16).
    #[arg(long, value_parser = crate::options::count::<u32>(4), default_value_t = 4, allow_negative_numbers = true)]
    pub aa_samples: u32,
    /// Measure the anti-aliased image's error on edge pixels against 16 rays
    /// per pixel everywhere, and the rays uniform supersampling would use.
    #[arg(long, alias = "aa-reference")]
    pub reference: bool,
}

impl TraceOptions {
    /// Tile knobs apply to packets, anti-aliasing knobs to --aa.
    pub fn applies(&self) -> Vec<Applies> {
        let mlrta = &["mlrta", "tile", "min_tile", "split_factor", "ep_budget", "aa"];
        let aa = &["aa_samples", "reference"];
        let needs = "MLRTA packets (without --single-ray or --accel bvh)";
        vec![
            applies(!self.single_ray && self.accel() == Structure::Kdtree, mlrta, needs),
            applies(self.aa != AaMode::None, aa, "--aa adaptive or uniform"),
        ]
    }

    /// `--accel`, or its default: the BVH for single rays, the kd-tree
    /// (MLRTA) for packets.
    fn accel(&self) -> Structure {
        self.accel.unwrap_or(if self.single_ray {
            Structure::Bvh
        } else {
            Structure::Kdtree
        })
    }

    /// The checked request for `view`.
    pub fn request(&self, view: View) -> Result<TraceRequest> {
        let request = TraceRequest {
            view,
            single_ray: self.single_ray,
            accel: self.accel(),
            params: MlrtaSettings {
                entry_points: self.mlrta.on(),
                initial_tile: self.tile,
                min_tile: self.min_tile.unwrap_or(DEFAULT_MIN_TILE.min(self.tile)),
                split_factor: self.split_factor,
                // The rays are the camera's.
                corner_frusta: true,
                ep_budget: self.ep_budget,
            },
            light: match (self.light, self.shadows.is_some_and(OnOff::on)) {
                (Some(p), _) => ShadowLight::At(p),
                (None, true) => ShadowLight::AboveScene,
                (None, false) => ShadowLight::None,
            },
            aa: AaRequest {
                mode: self.aa,
                samples: self.aa_samples,
                reference: self.reference,
            },
        };
        request.validate()?;
        Ok(request)
    }
}
