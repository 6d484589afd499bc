//! `sweep trace` ([`TraceSweep`], `crate::tune`): the MLRTA paper's knobs
//! (entry points, tile sizes, split factor, the entry-point search's
//! budget), which change speed only: the error is the fraction of pixels
//! whose closest hit differs from single-ray traversal, and must be 0.

use serde_json::{Value, json};

use super::MlrtaSettings;
use super::aa::AaMode;
use super::runner::{AaRequest, ShadowLight, TraceRequest, trace_view};
use super::tiles::{DEFAULT_EP_BUDGET, DEFAULT_MIN_TILE};
use crate::accel::Structure;
use crate::error::Result;
use crate::geom::ray::Hit;
use crate::gpu::device::Device;
use crate::progress::Reporter;
use crate::scene::{Mesh, View};
use crate::tune::{Knob, Run, Setting, Sweep, Tunable};

/// MLRTA's knobs.
pub const KNOBS: &[Knob] = &[
    Knob::new::<bool>(
        "mlrta",
        "entry-point search with tile splitting (on/off)",
        &["on", "off"],
    ),
    Knob::new::<bool>("single-ray", "rays one by one instead of 4x4 packets (on/off)", &[]),
    Knob::new::<u32>("tile", "initial tile side in pixels", &[]),
    Knob::new::<u32>("min-tile", "tiles this small are not split", &["8", "16", "32"]),
    Knob::new::<u32>("split-factor", "pieces a tile is split into", &[]),
    Knob::new::<u32>(
        "ep-budget",
        "nodes the entry-point search visits in a far subtree (0: all)",
        &[],
    ),
];

/// The trace sweep of one mesh and view.
pub struct TraceSweep {
    device: Device,
    mesh: Mesh,
    view: View,
    truth: Vec<Hit>,
}

impl TraceSweep {
    /// The sweep of `mesh` seen as `view`.
    pub fn new(device: Device, mesh: Mesh, view: View) -> Self {
        TraceSweep {
            device,
            mesh,
            view,
            truth: Vec::new(),
        }
    }

    fn request(&self, s: &Setting) -> Result<TraceRequest> {
        let tile = s.get("tile").unwrap_or(128);
        let single_ray = s.get("single-ray").unwrap_or(false);
        let request = TraceRequest {
            view: self.view,
            single_ray,
            // `trace`'s defaults: the BVH for single rays, MLRTA for packets.
            accel: if single_ray { Structure::Bvh } else { Structure::Kdtree },
            params: MlrtaSettings {
                entry_points: s.get("mlrta").unwrap_or(true),
                initial_tile: tile,
                min_tile: s.get("min-tile").unwrap_or(DEFAULT_MIN_TILE.min(tile)),
                split_factor: s.get("split-factor").unwrap_or(16),
                corner_frusta: true,
                ep_budget: s.get("ep-budget").unwrap_or(DEFAULT_EP_BUDGET),
            },
            light: ShadowLight::None,
            aa: AaRequest {
                mode: AaMode::None,
                samples: 4,
                reference: false,
            },
        };
        request.validate()?;
        Ok(request)
    }
}

impl Tunable for TraceSweep {
    fn name(&self) -> &'static str {
        "trace"
    }

    fn knobs(&self) -> &'static [Knob] {
        KNOBS
    }
}

impl Sweep for TraceSweep {
    fn time_measure(&self) -> &'static str {
        "primary rays, trace_ms"
    }

    fn error_measure(&self) -> &'static str {
        "fraction of pixels whose hit differs from single rays"
    }

    fn check(&self, setting: &Setting) -> Result<()> {
        self.request(setting).map(|_| ())
    }

    fn truth(&mut self, bars: &Reporter) -> Result<Value> {
        let single = Setting::default().with("single-ray", true);
        let traced = trace_view(&self.device, &self.mesh, None, &self.request(&single)?, bars)?;
        self.truth = traced.hits;
        Ok(json!({
            "what": "single-ray traversal of the same primary rays",
            "rays": self.truth.len(),
            "hits": traced.stats.hits,
            "ms": traced.stats.trace_ms,
        }))
    }

    fn run(&mut self, setting: &Setting) -> Result<Run> {
        let traced = trace_view(
            &self.device,
            &self.mesh,
            None,
            &self.request(setting)?,
            &Reporter::silent(),
        )?;
        let differ = traced
            .hits
            .iter()
            .zip(&self.truth)
            .filter(|(a, b)| a.triangle != b.triangle)
            .count();
        let s = &traced.stats;
        Ok(Run {
            time_ms: s.trace_ms,
            error: differ as f64 / self.truth.len().max(1) as f64,
            memory_bytes: None,
            phases: vec![
                ("build_ms", s.build_ms),
                ("cells_per_packet", s.cells_per_packet),
                ("isects_per_packet", s.isects_per_packet),
            ],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_default_grid_reads_as_its_knob() {
        let grid = crate::tune::Grid::parse(&[], KNOBS).unwrap();
        assert_eq!(grid.len(), 2 * 3);
        for s in grid.settings() {
            assert!(s.get::<bool>("mlrta").is_some() && s.get::<u32>("min-tile").is_some());
        }
    }
}
