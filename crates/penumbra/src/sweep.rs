//! From a user's files to a sweep (`penumbra sweep`): which method, on
//! which mesh or scene, seen how, against how many truth rays. Each
//! method's sweep (`field::tune::FieldSweep`, ...) is built here with the
//! defaults `penumbra sweep` documents, so a host tool sweeps exactly as
//! the command line does; the sweep itself is `tune::sweep`. This module
//! sits above every method: it is the one place that names them all.

use std::path::Path;

use crate::bounded::tune::BoundedSweep;
use crate::error::{Error, Result};
use crate::field::tune::{FieldSweep, on_ground};
use crate::gpu::device::Device;
use crate::mlrta::tune::TraceSweep;
use crate::progress::Reporter;
use crate::prt::runner::RayTraced;
use crate::prt::tune::PrtSweep;
use crate::raycast::AoSettings;
use crate::scene::{Scene, View, file_stem, load_input_in, load_mesh, load_shaded_input_in};
use crate::ssao::tune::SsaoSweep;
use crate::tune::Sweep;
use crate::whitted::{LightingSettings, RenderScene, WhittedRenderer, WhittedSettings};

/// The methods a sweep drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum SweepKind {
    /// Displacement fields against ray casting (receivers: --receiver, the scene's, or a ground).
    Field,
    /// Screen-space AO estimators against ray-traced AO.
    Ssao,
    /// Hemispherical rasterisation against ray-traced transfer.
    Prt,
    /// MLRTA traversal knobs (exact: error = hits that differ).
    Trace,
    /// Bounded-error ray tracing against exact Whitted.
    Bounded,
}

impl SweepKind {
    /// What the method's GPU path needs of a device (`Device::require`).
    pub fn gpu_needs(self) -> &'static crate::gpu::device::Needs {
        match self {
            SweepKind::Ssao => &crate::gpu::device::Needs::SSAO,
            _ => &crate::gpu::device::Needs::COMPUTE,
        }
    }
}

/// What a sweep runs on.
#[derive(Debug, Clone, Copy)]
pub struct SweepInputs<'a> {
    /// A mesh file.
    pub mesh: Option<&'a Path>,
    /// A scene file instead of `mesh`.
    pub scene: Option<&'a Path>,
    /// field: AO at this mesh's vertices [default: a ground under `mesh`].
    pub receiver: Option<&'a Path>,
    /// Image size and camera (ssao, trace, bounded; prt: the eye).
    pub view: View,
    /// Rays per point of the truth [default: field 64, ssao 256, prt 1024].
    pub truth_rays: Option<u32>,
    /// field and ssao: the AO radius [default: field infinite, ssao 5% of the scene's diagonal].
    pub radius: Option<f32>,
    /// The seed of every sample sequence.
    pub seed: u32,
    /// What `$PENUMBRA_DATA` in a scene file stands for.
    pub data_dir: Option<&'a Path>,
}

/// Runs `sweep` on the method's sweep of `kind` for `inputs` on `device`.
pub fn with_method<R>(
    kind: SweepKind,
    inputs: &SweepInputs,
    device: &Device,
    bars: &Reporter,
    sweep: impl FnOnce(&mut dyn Sweep) -> Result<R>,
) -> Result<R> {
    let SweepInputs { view, seed, .. } = *inputs;
    let rays = inputs.truth_rays;
    match kind {
        SweepKind::Field => {
            let scene = field_scene(inputs)?;
            let settings = AoSettings {
                rays_per_point: rays.unwrap_or(64),
                radius: inputs.radius.unwrap_or(f32::INFINITY),
                seed,
            };
            sweep(&mut FieldSweep::new(device.clone(), &scene, settings)?)
        }
        SweepKind::Ssao => {
            let scene = load_input_in(inputs.mesh, inputs.scene, inputs.data_dir)?;
            let bounds = scene.world_mesh(|_| true).bounds();
            let radius = inputs.radius.unwrap_or_else(|| crate::ssao::suggested_radius(&scene));
            let camera = scene.complete_camera(&view.camera, &bounds)?;
            let view = View { camera, ..view };
            let truth = rays.unwrap_or(256);
            sweep(&mut SsaoSweep::new(device.clone(), scene, view, radius, truth, seed)?)
        }
        SweepKind::Prt => {
            let path = inputs
                .mesh
                .ok_or_else(|| Error::param("mesh", "sweep prt needs a mesh"))?;
            let mesh = load_mesh(path)?;
            let eye = view.camera.resolve(None, &mesh.bounds(), mesh.origin)?.eye;
            let reference = RayTraced {
                rays: rays.unwrap_or(1024),
                seed,
            };
            let device = device.clone();
            sweep(&mut PrtSweep::new(
                device,
                mesh.positions,
                mesh.triangles,
                eye,
                reference,
            ))
        }
        SweepKind::Trace => {
            let scene = load_input_in(inputs.mesh, inputs.scene, inputs.data_dir)?;
            let mesh = scene.world_mesh(|_| true);
            let camera = scene.complete_camera(&view.camera, &mesh.bounds())?;
            let view = View { camera, ..view };
            sweep(&mut TraceSweep::new(device.clone(), mesh, view))
        }
        SweepKind::Bounded => {
            let scene = load_shaded_input_in(inputs.mesh, inputs.scene, inputs.data_dir)?;
            let render_scene = RenderScene::new(&scene, 0, &LightingSettings::default())?;
            let whitted = WhittedRenderer::new(device, render_scene, bars)?;
            let camera = view.camera.resolve(scene.camera, &whitted.bounds(), scene.origin)?;
            let settings = WhittedSettings {
                seed,
                ..WhittedSettings::default()
            };
            let size = (view.width, view.height);
            sweep(&mut BoundedSweep::new(whitted, camera, size, settings))
        }
    }
}

/// field: the scene file, or the mesh casting onto the receiver or a ground.
fn field_scene(inputs: &SweepInputs) -> Result<Scene> {
    let mut scene = load_input_in(inputs.mesh, inputs.scene, inputs.data_dir)?;
    match (inputs.mesh, inputs.receiver) {
        (Some(_), Some(receiver)) => scene = scene.with_receiver_file(receiver)?,
        (Some(path), None) => {
            let mesh = scene.meshes.remove(0).mesh;
            scene = on_ground(&file_stem(path), path, mesh)?;
        }
        _ => {}
    }
    Ok(scene)
}
