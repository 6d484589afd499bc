//! `sweep prt`: hemispherical rasterisation's knobs against Monte Carlo
//! ray-traced visibility of the same vertices and shading normals (the
//! truth of `prt --check`), traced once per band count and normals. The
//! error is the transfer's mean relative L2 error, which does not depend
//! on the lighting, so no probe is needed.

use std::time::Instant;

use glam::Vec3;
use serde_json::{Value, json};

use super::{Knob, Run, Setting, SweepMethod};
use crate::error::Result;
use crate::gpu::device::{Device, elapsed_ms};
use crate::progress::Reporter;
use crate::prt::hierarchy::{HierarchySettings, NearField};
use crate::prt::pipeline::{FrameOutput, PrtSettings, Toggle};
use crate::prt::reference::relative_l2_error;
use crate::prt::runner::{PrtRunner, RayTraced, Shadows};
use crate::prt::transfer::Integration;

const KNOBS: &[Knob] = &[
    Knob {
        name: "mask",
        help: "visibility mask side: 16, 32 or 64",
        default_grid: &["16", "32", "64"],
    },
    Knob {
        name: "hierarchy",
        help: "two-level mesh hierarchy (on/off)",
        default_grid: &["on", "off"],
    },
    Knob {
        name: "order",
        help: "SH bands",
        default_grid: &[],
    },
    Knob {
        name: "lut",
        help: "plane LUT cells per cube-face side",
        default_grid: &[],
    },
    Knob {
        name: "integration",
        help: "cells, cells-linear or pixels",
        default_grid: &[],
    },
    Knob {
        name: "near",
        help: "near field: clusters or rings",
        default_grid: &[],
    },
    Knob {
        name: "ring",
        help: "rings drawn at full resolution: 1 or 2",
        default_grid: &[],
    },
    Knob {
        name: "coarse",
        help: "coarse triangles to aim for",
        default_grid: &[],
    },
    Knob {
        name: "coarse-tolerance",
        help: "angle (rad) a coarse triangle may deviate before fine ones are drawn",
        default_grid: &[],
    },
    Knob {
        name: "group-size",
        help: "far triangles per culling group",
        default_grid: &[],
    },
    Knob {
        name: "group-culling",
        help: "skip groups below the tangent plane (on/off)",
        default_grid: &[],
    },
    Knob {
        name: "backface",
        help: "cull back-facing blockers: auto, on, off",
        default_grid: &[],
    },
    Knob {
        name: "two-sided",
        help: "shade the side facing the eye: auto, on, off",
        default_grid: &[],
    },
];

/// What the truth depends on: the bands and the shading normals.
type TruthKey = (usize, Vec<Vec3>);

/// The PRT sweep of one static pose.
pub struct PrtSweep {
    device: Device,
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    eye: Vec3,
    reference: RayTraced,
    /// Truths traced so far: (bands, shading normals) and the transfer.
    truths: Vec<(TruthKey, Vec<f32>)>,
    /// The runner of the last settings (repeats reuse it) and its setup time.
    runner: Option<(PrtSettings, PrtRunner, f64)>,
}

impl PrtSweep {
    pub fn new(
        device: Device,
        positions: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        eye: Vec3,
        reference: RayTraced,
    ) -> Self {
        PrtSweep {
            device,
            positions,
            triangles,
            eye,
            reference,
            truths: Vec::new(),
            runner: None,
        }
    }

    fn settings(s: &Setting) -> Result<PrtSettings> {
        let (base, h) = (PrtSettings::default(), HierarchySettings::default());
        let settings = PrtSettings {
            mask_side: s.get("mask")?.unwrap_or(base.mask_side),
            lut_size: s.get("lut")?.unwrap_or(base.lut_size),
            bands: s.get("order")?.unwrap_or(base.bands),
            integration: s.get_enum::<Integration>("integration")?.unwrap_or(base.integration),
            hierarchy: HierarchySettings {
                enabled: s.get_on_off("hierarchy")?.unwrap_or(h.enabled),
                near: s.get_enum::<NearField>("near")?.unwrap_or(h.near),
                ring: s.get("ring")?.unwrap_or(h.ring),
                coarse_triangles: s.get("coarse")?.or(h.coarse_triangles),
                group_size: s.get("group-size")?.unwrap_or(h.group_size),
                tolerance: s.get("coarse-tolerance")?.unwrap_or(h.tolerance),
                poses: s.get("coarse-poses")?.unwrap_or(h.poses),
            },
            group_culling: s.get_on_off("group-culling")?.unwrap_or(base.group_culling),
            backface: s.get_enum::<Toggle>("backface")?.unwrap_or(base.backface),
            two_sided: s.get_enum::<Toggle>("two-sided")?.unwrap_or(base.two_sided),
            ..base
        };
        settings.validate()?;
        Ok(settings)
    }

    /// Builds the runner of `settings` unless the last run's was the same.
    fn ensure_runner(&mut self, settings: PrtSettings) -> Result<()> {
        if !matches!(&self.runner, Some((s, _, _)) if *s == settings) {
            self.runner = None;
            let start = Instant::now();
            let runner = PrtRunner::new(
                &self.device,
                &self.positions,
                &self.triangles,
                &settings,
                Shadows::On,
                self.reference,
            )?;
            self.runner = Some((settings, runner, elapsed_ms(start)));
        }
        Ok(())
    }
}

impl SweepMethod for PrtSweep {
    fn name(&self) -> &'static str {
        "prt"
    }

    fn knobs(&self) -> &'static [Knob] {
        KNOBS
    }

    fn time_measure(&self) -> &'static str {
        "one frame's transfer at every vertex"
    }

    fn error_measure(&self) -> &'static str {
        "mean relative L2 transfer error vs ray tracing"
    }

    fn check(&self, setting: &Setting) -> Result<()> {
        Self::settings(setting).map(|_| ())
    }

    fn truth(&mut self, _bars: &Reporter) -> Result<Value> {
        // The truth depends on the bands and the shading normals, which the
        // settings decide: it is traced on each one's first run.
        Ok(json!({
            "what": "Monte Carlo ray-traced visibility of the same vertices and normals",
            "rays_per_vertex": self.reference.rays,
            "vertices": self.positions.len(),
            "triangles": self.triangles.len(),
        }))
    }

    fn run(&mut self, setting: &Setting) -> Result<Run> {
        let settings = Self::settings(setting)?;
        let (positions, eye) = (self.positions.clone(), Some(self.eye));
        self.ensure_runner(settings)?;
        let (_, runner, setup_ms) = self.runner.as_mut().expect("built above");
        let setup_ms = *setup_ms;
        let coeffs = runner.prt().coeffs();
        let lighting = vec![0.0; 3 * coeffs];
        let mut out = FrameOutput::default();
        let start = Instant::now();
        runner.frame(&positions, eye, &lighting, false, &mut out)?;
        let time_ms = elapsed_ms(start);
        let key = (runner.prt().settings.bands, out.normals.clone());
        let t = &runner.prt().tables;
        let floor = 0.01 * t.unoccluded.iter().map(|v| v * v).sum::<f32>().sqrt();
        let truth = match self.truths.iter().position(|(k, _)| *k == key) {
            Some(i) => &self.truths[i].1,
            None => {
                let traced = runner.reference_transfer(&positions, &out.normals, eye)?;
                self.truths.push((key, traced));
                &self.truths.last().expect("just pushed").1
            }
        };
        let (error, _, _) = relative_l2_error(&out.transfer, truth, coeffs, floor);
        Ok(Run {
            time_ms,
            error,
            memory_bytes: None,
            phases: vec![
                ("setup_ms", setup_ms),
                (
                    "drawn_per_vertex",
                    out.stats.drawn as f64 / out.stats.vertices.max(1) as f64,
                ),
            ],
        })
    }
}
