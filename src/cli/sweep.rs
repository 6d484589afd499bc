//! `penumbra sweep METHOD`: time and error of every setting of a knob grid
//! on the user's scene (`crate::sweep`), written to DIR/sweep.{csv,json,png}.

use std::path::PathBuf;

use serde_json::Value;

use super::args::{CameraArgs, Common};
use crate::error::{Error, Result};
use crate::progress::Bars;
use crate::scene::View;
pub use crate::sweep::SweepKind as Method;
use crate::sweep::{self, Grid, SweepInputs};

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
    /// Rays per point of the reference, the ground truth (field: per vertex; ssao: per
    /// pixel; prt: per vertex) [default: field 64, ssao 256, prt 1024].
    #[arg(long, alias = "truth-rays", allow_negative_numbers = true)]
    pub reference_rays: Option<u32>,
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
    let runs = args.common.runs.runs(3)?;
    if let Some(parent) = args.out.parent().filter(|p| !p.as_os_str().is_empty())
        && !parent.is_dir()
    {
        let problem = format!("folder {} does not exist", parent.display());
        return Err(Error::param("--out", problem));
    }
    let inputs = SweepInputs {
        mesh: args.mesh.as_deref(),
        scene: args.scene.as_deref(),
        receiver: args.receiver.as_deref(),
        view: View::new(args.camera.spec(), args.width, args.height)?,
        truth_rays: args.reference_rays,
        radius: args.radius,
        seed: args.common.seed,
    };
    let device = args.common.open_device_for(args.method.gpu_needs())?;
    let mut report = sweep::with_method(args.method, &inputs, &device, |method| {
        let grid = Grid::parse(&args.grid, method.knobs())?;
        sweep::sweep(method, &grid, runs, Bars::Stderr)
    })?;
    sweep::write_outputs(&mut report, &args.out)?;
    super::io::merged(args.common.report(&device, threads), &report)
}
