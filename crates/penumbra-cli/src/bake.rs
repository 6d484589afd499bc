//! `penumbra bake`: AO baked into a copy of an asset, as a GLB with an AO
//! texture (each material's `occlusionTexture`) and per-vertex AO (`_AO`).

use std::path::PathBuf;

use serde_json::{Value, json};

use crate::args::{Common, check_outputs};
use crate::io::{merged, warn};
use penumbra::bake::{BakeJob, BakePiece, BakeSettings, bake, bake_scene};
use penumbra::io::shard::{Parts, Shard};

use crate::shard::Mode;
use penumbra::error::{Error, Result};
use penumbra::raycast::AoSettings;

#[derive(clap::Args)]
pub struct BakeArgs {
    /// The asset: glTF 2.0 (.gltf/.glb), OBJ (its MTL and `vt`) or PLY.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// A manifest instead: one asset a line with its options
    /// (`ASSET [--resolution N ...]`), each baked into the folder --out.
    #[arg(long, conflicts_with_all = ["mesh", "scene"])]
    pub manifest: Option<PathBuf>,
    /// A scene file instead: each mesh is baked where its first instance
    /// stands, every caster occluding it; --out is then a folder that gets
    /// one NAME.glb per mesh.
    #[arg(long, conflicts_with = "mesh")]
    pub scene: Option<PathBuf>,
    /// The baked asset (GLB): the input with the AO texture and `_AO`
    /// (with --scene: the folder of the baked assets).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the AO texture as its own PNG.
    #[arg(long)]
    pub texture: Option<PathBuf>,
    /// Texels per side of the AO texture; 0 bakes per-vertex AO alone.
    #[arg(long, default_value_t = 1024, allow_negative_numbers = true)]
    pub resolution: i64,
    /// Rings of texels filled around each UV chart, so that bilinear and
    /// mip-mapped lookups see no dark seams.
    #[arg(long, default_value_t = 4, allow_negative_numbers = true)]
    pub padding: i64,
    /// AO points per texel: 1 (its centre) or more (jittered), averaged.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub texel_samples: i64,
    /// Bits per channel of the texture: 8 or 16.
    #[arg(long, default_value_t = 8, allow_negative_numbers = true)]
    pub png_bits: i64,
    /// Per-vertex AO as the attribute `_AO`.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub vertex: OnOff,
    /// The per-vertex AO also as `COLOR_0` (grey, linear).
    #[arg(long)]
    pub vertex_colors: bool,
    /// Replace a material's own occlusionTexture (else it is kept).
    #[arg(long)]
    pub replace: bool,
    /// Rays per texel sample and per vertex.
    #[arg(long, default_value_t = 256, allow_negative_numbers = true)]
    pub rays: i64,
    /// Occluders beyond this distance do not count, as Blender's AO
    /// "distance" (default: infinite).
    #[arg(long, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// The fewest rays whose RMS error over the texels is, at 95%
    /// confidence, within this, estimated on a probe cast with --rays.
    #[arg(long, allow_negative_numbers = true)]
    pub max_error: Option<f64>,
    #[command(flatten)]
    pub common: Common,
    #[command(flatten)]
    pub shard: crate::shard::ShardArgs,
}

/// A switch given as a word.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum OnOff {
    On,
    Off,
}

fn in_range(value: i64, option: &str, lo: i64, hi: i64) -> Result<u32> {
    if (lo..=hi).contains(&value) {
        Ok(value as u32)
    } else {
        Err(Error::param(
            option,
            format!("must be between {lo} and {hi}, got {value}"),
        ))
    }
}

pub fn run(args: &BakeArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    if let Some(manifest) = &args.manifest {
        let report = crate::bake_manifest::run(args, manifest, &crate::shard::invocation_args())?;
        let device = args.common.open_device()?;
        return merged(args.common.report(&device, threads), report);
    }
    if args.scene.is_some() {
        if args.texture.is_some() {
            return Err(Error::param(
                "--texture",
                "goes with --mesh; with --scene each texture is inside its asset's GLB",
            ));
        }
        if !args.out.is_dir() {
            return Err(Error::param(
                "--out",
                format!("{}: with --scene, a folder that exists", args.out.display()),
            ));
        }
    } else {
        let out = Some(args.out.clone());
        check_outputs(&[(&out, "--out"), (&args.texture, "--texture")])?;
    }
    let settings = settings(args)?;
    let device = args.common.open_device()?;
    if let Some(scene) = &args.scene {
        if args.shard.shard.is_some() {
            let problem = "splits one asset's texels and vertices (--mesh); a scene's assets are not split";
            return Err(Error::param("--shard", problem));
        }
        let scene = crate::args::load_shaded_input(None, Some(scene))?;
        warn(&scene.warnings);
        let baked = bake_scene(&device, &scene, &settings, &crate::progress::stderr())?;
        let mut assets = Vec::new();
        for b in &baked {
            warn(&b.baked.warnings);
            let path = args.out.join(format!("{}.glb", b.name));
            let same = |a: &std::path::Path, b: &std::path::Path| matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y);
            if scene.meshes.iter().any(|m| same(&m.path, &path)) {
                return Err(Error::param(
                    "--out",
                    format!("{} is a mesh of the scene: baking would overwrite it", path.display()),
                ));
            }
            penumbra::io::output::write_bytes(&path, &b.baked.glb)?;
            assets.push(json!({
                "mesh": b.name,
                "instance": b.instance,
                "file": path.display().to_string(),
                "bake": b.baked.report,
            }));
        }
        let report = json!({"method": "bake", "assets": assets});
        return merged(args.common.report(&device, threads), report);
    }
    let mesh = args
        .mesh
        .as_ref()
        .ok_or_else(|| Error::param("mesh", "a mesh (--mesh FILE) or a scene (--scene FILE) is required"))?;
    let baked = match args.shard.mode()? {
        Mode::Whole => bake(&device, mesh, &settings, &crate::progress::stderr())?,
        Mode::Part(shard) => {
            let report = args.common.report(&device, threads);
            return part(args, &device, mesh, &settings, shard, report);
        }
        Mode::Merge(parts) => merge(&device, mesh, &settings, &parts)?,
    };
    warn(&baked.warnings);
    penumbra::io::output::write_bytes(&args.out, &baked.glb)?;
    let mut written = vec![args.out.display().to_string()];
    if let (Some(path), Some(png)) = (&args.texture, &baked.png) {
        penumbra::io::output::write_bytes(path, png)?;
        written.push(path.display().to_string());
    }
    let report = json!({
        "method": "bake",
        "rays_per_point": baked.report.rays_per_point,
        "bake": baked.report,
        "warnings": baked.warnings.len(),
        "files": written,
    });
    merged(args.common.report(&device, threads), report)
}

/// `--shard I/N`: this shard's texel rows and vertices, recorded piece by
/// piece in `OUT.part-I-of-N`.
fn part(
    args: &BakeArgs,
    device: &penumbra::Device,
    mesh: &std::path::Path,
    settings: &BakeSettings,
    shard: Shard,
    report: Value,
) -> Result<Value> {
    let progress = crate::progress::stderr();
    let mut job = BakeJob::new(device, mesh, settings, &progress)?;
    let mut writer = crate::shard::open_part(&args.out, shard, job.items())?;
    // Pieces of at most a sixteenth of the shard: a shard killed part-way
    // computes again at most that much.
    let step = writer.items().len().div_ceil(16).max(1);
    let pieces = job
        .pieces()
        .into_iter()
        .flat_map(|p| (p.start..p.end).step_by(step).map(move |s| s..(s + step).min(p.end)));
    let left = writer.left(pieces);
    let bar = progress.bar(left.iter().map(|p| p.len() as u64).sum(), "AO texel rows and vertices");
    let (mut points, mut ms) = (0, 0.0);
    for piece in left {
        let done = job.compute(piece.clone())?;
        (points, ms) = (points + done.points, ms + done.ms);
        writer.record(piece.clone(), &done.to_bytes())?;
        bar.inc(piece.len() as u64);
    }
    bar.finish();
    let fields = json!({ "method": "bake", "points": points, "ao_ms": ms });
    crate::shard::finish_part(writer, merged(report, fields)?)
}

/// `penumbra merge OUT`: the asset from every shard's pieces, as one process
/// bakes it.
fn merge(
    device: &penumbra::Device,
    mesh: &std::path::Path,
    settings: &BakeSettings,
    parts: &Parts,
) -> Result<penumbra::bake::Baked> {
    let job = BakeJob::new(device, mesh, settings, &penumbra::Reporter::silent())?;
    if job.items() != parts.total_items() {
        let problem = format!(
            "the parts hold {} items, the asset gives {}",
            parts.total_items(),
            job.items()
        );
        return Err(Error::file(&parts.output, "", problem));
    }
    let mut pieces = Vec::new();
    for (items, bytes) in parts.records()? {
        let piece = BakePiece::from_bytes(&bytes)
            .filter(|p| p.items == items)
            .ok_or_else(|| {
                Error::file(
                    &parts.output,
                    "",
                    format!("the record of items {items:?} is not a bake's"),
                )
            })?;
        pieces.push(piece);
    }
    job.finish(pieces)
}

/// The bake the options ask for, each checked against its range.
pub fn settings(args: &BakeArgs) -> Result<BakeSettings> {
    let settings = BakeSettings {
        resolution: in_range(
            args.resolution,
            "--resolution",
            0,
            penumbra::bake::MAX_RESOLUTION as i64,
        )?,
        padding: in_range(args.padding, "--padding", 0, 64)?,
        texel_samples: in_range(args.texel_samples, "--texel-samples", 1, 64)?,
        png_bits: match args.png_bits {
            8 => 8,
            16 => 16,
            b => return Err(Error::param("--png-bits", format!("must be 8 or 16, got {b}"))),
        },
        vertex: args.vertex == OnOff::On,
        vertex_colors: args.vertex_colors,
        replace: args.replace,
        ao: AoSettings {
            rays_per_point: in_range(args.rays, "--rays", 1, penumbra::raycast::MAX_RAYS_PER_POINT as i64)?,
            radius: args.radius.unwrap_or(f32::INFINITY),
            seed: args.common.seed,
        },
        max_error: args.max_error,
    };
    if args.texture.is_some() && settings.resolution == 0 {
        return Err(Error::param("--texture", "needs a texture: --resolution is 0"));
    }
    if args.vertex_colors && !settings.vertex {
        return Err(Error::param(
            "--vertex-colors",
            "needs the per-vertex AO: --vertex is off",
        ));
    }
    settings.validate().map_err(|e| e.with_names(crate::args::flag))?;
    Ok(settings)
}
