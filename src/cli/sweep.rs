//! `penumbra sweep METHOD`: time and error of every setting of a knob grid
//! on the user's scene (`crate::sweep`), written to DIR/sweep.{csv,json,png}.

use std::path::PathBuf;

use clap::ValueEnum;
use serde_json::Value;

use super::args::{CameraArgs, Common, load_input, stem};
use crate::ao::AoSettings;
use crate::error::{Error, Result};
use crate::progress::Bars;
use crate::prt::runner::RayTraced;
use crate::raytrace::{LightingOptions, RenderScene, WhittedRenderer, WhittedSettings};
use crate::scene::{Scene, View, load_mesh, load_mesh_file, load_scene_shaded};
use crate::sweep::{self, Grid, SweepMethod};

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Method {
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

#[derive(clap::Args)]
pub struct SweepArgs {
    /// The method whose knobs are swept.
    #[arg(value_enum)]
    pub method: Method,
    /// Mesh: OBJ, PLY or glTF.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// A scene file instead of --mesh.
    #[arg(long, conflicts_with = "mesh")]
    pub scene: Option<PathBuf>,
    /// field: AO at this mesh's vertices [default: a ground under --mesh].
    #[arg(long, requires = "mesh")]
    pub receiver: Option<PathBuf>,
    /// Values of one knob, 'KNOB=V1,V2,...' (repeatable; one value fixes a
    /// knob). Knobs not named take the method's default grid.
    #[arg(long)]
    pub grid: Vec<String>,
    /// Output folder (created if missing) for sweep.csv, sweep.json, sweep.png.
    #[arg(long)]
    pub out: PathBuf,
    /// Runs per setting; the fastest counts.
    #[arg(long, default_value_t = 3, allow_negative_numbers = true)]
    pub repeat: u32,
    /// Rays per point of the truth (field: per vertex, as the methods; ssao:
    /// per pixel; prt: per vertex) [default: field 64, ssao 256, prt 1024].
    #[arg(long, allow_negative_numbers = true)]
    pub truth_rays: Option<u32>,
    /// field and ssao: the AO radius [default: field infinite, ssao 5% of the scene's diagonal].
    #[arg(long, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// Image width (ssao, trace, bounded).
    #[arg(long, default_value_t = 400, allow_negative_numbers = true)]
    pub width: u32,
    /// Image height (ssao, trace, bounded).
    #[arg(long, default_value_t = 300, allow_negative_numbers = true)]
    pub height: u32,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
}

impl SweepArgs {
    /// The files the sweep writes.
    pub fn outputs(&self) -> [PathBuf; 3] {
        sweep::output_files(&self.out)
    }
}

pub fn run(args: &SweepArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    if let Some(parent) = args.out.parent().filter(|p| !p.as_os_str().is_empty())
        && !parent.is_dir()
    {
        return Err(Error::param(
            "--out",
            format!("folder {} does not exist", parent.display()),
        ));
    }
    let view = View::new(args.camera.spec(), args.width, args.height)?;
    let rays = args.truth_rays;
    let device = args.common.open_device()?;
    let seed = args.common.seed;
    let scene;
    let mut method: Box<dyn SweepMethod + '_> = match args.method {
        Method::Field => {
            scene = field_scene(args)?;
            let settings = AoSettings {
                rays_per_point: rays.unwrap_or(64),
                radius: args.radius.unwrap_or(f32::INFINITY),
                seed,
            };
            Box::new(sweep::field::FieldSweep::new(device.clone(), &scene, settings)?)
        }
        Method::Ssao => {
            let scene = load_input(args.mesh.as_deref(), args.scene.as_deref())?;
            let bounds = scene.world_mesh(|_| true).bounds();
            let radius = args.radius.unwrap_or(0.05 * bounds.diagonal());
            let view = View {
                camera: view.camera.resolve(scene.camera, &bounds)?.into(),
                ..view
            };
            let ssao = sweep::ssao::SsaoSweep::new(device.clone(), scene, view, radius, rays.unwrap_or(256), seed)?;
            Box::new(ssao)
        }
        Method::Prt => {
            let path = args
                .mesh
                .as_ref()
                .ok_or_else(|| Error::param("--mesh", "sweep prt needs --mesh"))?;
            let mesh = load_mesh(path)?;
            let eye = view.camera.resolve(None, &mesh.bounds())?.eye;
            let reference = RayTraced {
                rays: rays.unwrap_or(1024),
                seed,
            };
            let prt = sweep::prt::PrtSweep::new(device.clone(), mesh.positions, mesh.triangles, eye, reference);
            Box::new(prt)
        }
        Method::Trace => {
            let scene = load_input(args.mesh.as_deref(), args.scene.as_deref())?;
            let mesh = scene.world_mesh(|_| true);
            let view = View {
                camera: view.camera.resolve(scene.camera, &mesh.bounds())?.into(),
                ..view
            };
            Box::new(sweep::trace::TraceSweep::new(device.clone(), mesh, view))
        }
        Method::Bounded => {
            let scene = shaded_scene(args)?;
            let render_scene = RenderScene::new(&scene, 0, &LightingOptions::default())?;
            let whitted = WhittedRenderer::new(&device, render_scene, Bars::Stderr)?;
            let camera = view.camera.resolve(scene.camera, &whitted.bounds())?;
            let settings = WhittedSettings {
                seed,
                ..WhittedSettings::default()
            };
            let size = (args.width, args.height);
            Box::new(sweep::bounded::BoundedSweep::new(whitted, camera, size, settings))
        }
    };
    let grid = Grid::parse(&args.grid, method.knobs())?;
    let mut report = sweep::sweep(method.as_mut(), &grid, args.repeat, Bars::Stderr)?;
    sweep::write_outputs(&mut report, &args.out)?;
    super::io::merged(args.common.report(&device, threads), &report)
}

/// field: the scene file, or --mesh casting onto --receiver or a ground.
fn field_scene(args: &SweepArgs) -> Result<Scene> {
    let mut scene = load_input(args.mesh.as_deref(), args.scene.as_deref())?;
    match (&args.mesh, &args.receiver) {
        (Some(_), Some(receiver)) => scene = super::ao::with_receiver(scene, receiver)?,
        (Some(path), None) => {
            let mesh = scene.meshes.remove(0).mesh;
            scene = sweep::field::on_ground(&stem(path), path, mesh)?;
        }
        _ => {}
    }
    Ok(scene)
}

/// bounded: the OBJ with its materials, or a scene file.
fn shaded_scene(args: &SweepArgs) -> Result<Scene> {
    match (&args.mesh, &args.scene) {
        (Some(m), None) => Ok(Scene::from_obj_file(&stem(m), m, load_mesh_file(m)?)),
        (None, Some(s)) => load_scene_shaded(s),
        _ => Err(Error::param(
            "--mesh",
            "a mesh (--mesh FILE) or a scene (--scene FILE) is required",
        )),
    }
}
