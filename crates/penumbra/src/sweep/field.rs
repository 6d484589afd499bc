//! `sweep field`: displacement fields' sampling and storage against ray
//! casting with the very same rays (`ao --method raycast`, the truth of
//! `ao --method field --reference`), cast once.

use glam::Vec3;
use serde_json::{Value, json};

use super::{Knob, Run, Setting, SweepMethod};
use crate::error::Result;
use crate::field::reach::Reach;
use crate::field::runner::FieldAo;
use crate::field::{DirectionMapping, FieldParams, Positional};
use crate::gpu::device::Device;
use crate::progress::Reporter;
use crate::raycast::AoSettings;
use crate::raycast::runner::{AoRequest, raycast};
use crate::scene::{Mesh, Scene, SceneMesh};

const KNOBS: &[Knob] = &[
    Knob {
        name: "positions",
        help: "positional samples on the bounding sphere",
        default_grid: &["1026", "4226"],
    },
    Knob {
        name: "res",
        help: "each map is RES x RES directions",
        default_grid: &["16", "32"],
    },
    Knob {
        name: "bits",
        help: "bits per direction: 32, 8 or 1",
        default_grid: &["1", "8", "32"],
    },
    Knob {
        name: "directions",
        help: "texel mapping: concentric, polar or rejection",
        default_grid: &[],
    },
    Knob {
        name: "positional",
        help: "nearest sample or bilinear between four",
        default_grid: &[],
    },
];

/// The field sweep of a scene with casters and receivers.
pub struct FieldSweep<'s> {
    device: Device,
    scene: &'s Scene,
    request: AoRequest,
    truth: Vec<f32>,
    /// The fields of the last parameters, reused by repeats and by settings
    /// that change only the lookup.
    built: Option<(FieldParams, Positional, FieldAo<'s>, f64)>,
}

impl<'s> FieldSweep<'s> {
    pub fn new(device: Device, scene: &'s Scene, settings: AoSettings) -> Result<Self> {
        settings.validate()?;
        Ok(FieldSweep {
            device,
            scene,
            request: AoRequest {
                settings,
                vertices: true,
                image: None,
            },
            truth: Vec::new(),
            built: None,
        })
    }

    fn params(s: &Setting) -> Result<(FieldParams, Positional)> {
        let directions = s.get_enum("directions")?.unwrap_or(DirectionMapping::Concentric);
        let params = FieldParams::new(
            s.get("positions")?.unwrap_or(4226),
            s.get("res")?.unwrap_or(32),
            s.get("bits")?.unwrap_or(8),
            directions,
        )?;
        Ok((params, s.get_enum("positional")?.unwrap_or(Positional::Bilinear)))
    }
}

/// `mesh` casting onto a ground it stands on: a square of 64 x 64 vertices,
/// twice the mesh's footprint, at its lowest point (+y up): the
/// displacement-field paper's object over a receiving floor, for a mesh
/// given without a receiver.
pub fn on_ground(name: &str, path: &std::path::Path, mesh: Mesh) -> Result<Scene> {
    let b = mesh.bounds();
    let (centre, half) = (b.center(), b.extent().max_element());
    let n = 64u32;
    let positions = (0..n * n)
        .map(|i| {
            let (u, v) = ((i % n) as f32 / (n - 1) as f32, (i / n) as f32 / (n - 1) as f32);
            Vec3::new(
                centre.x + (2.0 * u - 1.0) * half,
                b.min.y,
                centre.z + (2.0 * v - 1.0) * half,
            )
        })
        .collect();
    let triangles = (0..(n - 1) * (n - 1))
        .flat_map(|q| {
            let (x, y) = (q % (n - 1), q / (n - 1));
            let i = y * n + x;
            [[i, i + n, i + 1], [i + 1, i + n, i + n + 1]]
        })
        .collect();
    let ground = SceneMesh::new(
        "ground",
        std::path::Path::new("<ground>"),
        Mesh::new(positions, triangles)?,
    );
    Ok(Scene::from_mesh(name, path, mesh).with_receiver(ground))
}

impl FieldSweep<'_> {
    /// The sweep runs one frame at the request's radius.
    fn reach(&self) -> Reach {
        Reach {
            radius: self.request.settings.radius,
            frames: 1,
        }
    }
}

impl<'s> SweepMethod for FieldSweep<'s> {
    fn name(&self) -> &'static str {
        "field"
    }

    fn knobs(&self) -> &'static [Knob] {
        KNOBS
    }

    fn time_measure(&self) -> &'static str {
        "field AO lookups of every receiver vertex, ao_ms"
    }

    fn error_measure(&self) -> &'static str {
        "RMS of per-vertex AO vs ray casting, same rays"
    }

    fn check(&self, setting: &Setting) -> Result<()> {
        Self::params(setting).map(|_| ())
    }

    fn truth(&mut self, bars: &Reporter) -> Result<Value> {
        let cast = raycast(&self.device, self.scene, &self.request, bars)?;
        let vertices = cast.vertices.expect("vertices were asked for");
        self.truth = vertices.ao;
        Ok(json!({
            "what": "ray casting against the casters' triangles, the same rays",
            "receiver_vertices": self.truth.len(),
            "rays_per_point": self.request.settings.rays_per_point,
            "ms": vertices.ms,
            "build_ms": cast.build_ms,
        }))
    }

    fn run(&mut self, setting: &Setting) -> Result<Run> {
        let (params, positional) = Self::params(setting)?;
        let reuse = matches!(&self.built, Some((p, l, _, _)) if *p == params && *l == positional);
        if !reuse {
            self.built = None;
            let mut fields = FieldAo::new(self.scene, &params, positional, self.reach(), &Reporter::silent())?;
            fields.upload(&self.device)?;
            let build_ms = fields.reports().iter().filter_map(|r| r.build_ms).sum();
            self.built = Some((params, positional, fields, build_ms));
        }
        let (_, _, fields, build_ms) = self.built.as_mut().expect("built above");
        let bytes: usize = fields.reports().iter().map(|r| r.summary.map_bytes).sum();
        let run = fields.run(&self.request, 1, false)?;
        let ao = run.vertices.expect("vertices were asked for").ao;
        Ok(Run {
            time_ms: run.frame_ao_ms[0],
            error: crate::geom::color::rms_difference(&ao, &self.truth, None),
            memory_bytes: Some(bytes as u64),
            phases: vec![("build_ms", *build_ms)],
        })
    }
}
