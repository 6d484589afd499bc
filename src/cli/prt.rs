//! `penumbra prt`: self-shadowed rendering under an environment map with
//! transfer recomputed every frame by hemispherical rasterisation (Kautz,
//! Lehtinen and Aila 2004), on a mesh or one of the built-in animations.

use std::path::PathBuf;
use std::time::Instant;

use clap::ValueEnum;
use glam::Vec3;
use serde_json::{Value, json};

use super::Device;
use super::args::DeviceArg;
use super::args::{CameraArgs, Common, check_image_size, check_output, parse_vec3};
use super::io::write_rgb_png;
use crate::error::{Error, Result};
use crate::kdtree::{KdTree, KdTreeParams};
use crate::prt::gpu::{GpuTransfer, MAX_GPU_BANDS, ShTransferPass};
use crate::prt::hierarchy::{HierarchySettings, NearField};
use crate::prt::pipeline::{FrameOutput, Prt, PrtSettings, Toggle};
use crate::prt::reference::{reference_transfer, relative_l2_error};
use crate::prt::render::{auto_exposure, render};
use crate::prt::transfer::{Brdf, Integration, radiance};
use crate::scene::animated::{AnimatedScene, Animation};
use crate::scene::{Camera, EnvironmentMap, load_obj};
use crate::sh::{ShRgb, ShRotation, coefficient_count, project_environment};

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AutoOnOff {
    Auto,
    On,
    Off,
}

impl From<AutoOnOff> for Toggle {
    fn from(v: AutoOnOff) -> Toggle {
        match v {
            AutoOnOff::Auto => Toggle::Auto,
            AutoOnOff::On => Toggle::On,
            AutoOnOff::Off => Toggle::Off,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BrdfArg {
    /// Lambertian.
    Diffuse,
    /// Diffuse base plus a normalised Phong lobe (view-dependent transfer vector).
    Phong,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum IntegrationArg {
    /// 4x4 grey levels times each cell's mean basis (section 3.2).
    Cells,
    /// 4x4 grey levels plus first moments against a linear fit of the basis.
    CellsLinear,
    /// Every occluded pixel with its own basis integral.
    Pixels,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum NearArg {
    /// Whole clusters of the k-ring at full resolution, their coarse triangles skipped.
    Clusters,
    /// The k-ring at full resolution plus every coarse triangle (the paper's text).
    Rings,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ShadowsArg {
    /// Hemispherical rasterisation.
    On,
    /// No visibility (unshadowed transfer).
    Off,
    /// Monte Carlo ray-traced visibility (--check-rays rays per vertex; slow).
    Raytraced,
}

#[derive(clap::Args)]
pub struct PrtArgs {
    /// Wavefront OBJ mesh (static: the transfer is still recomputed every frame).
    #[arg(long, required_unless_present = "animated")]
    pub mesh: Option<PathBuf>,
    /// A built-in animation instead of --mesh: cloth or character.
    #[arg(long, conflicts_with = "mesh")]
    pub animated: Option<String>,
    /// Radiance .hdr latitude-longitude light probe.
    #[arg(long)]
    pub env: PathBuf,
    /// Frames to compute.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub frames: i64,
    /// Animation time of the first frame, seconds.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub start: f32,
    /// Animation time between frames, seconds.
    #[arg(long, default_value_t = 1.0 / 30.0, allow_negative_numbers = true)]
    pub dt: f32,
    /// SH bands (5 = 25 coefficients).
    #[arg(long, default_value_t = 5, allow_negative_numbers = true)]
    pub order: i64,
    /// Visibility mask side in pixels: 16, 32 or 64.
    #[arg(long, default_value_t = 32, allow_negative_numbers = true)]
    pub mask: i64,
    /// Plane LUT cells per cube-face side (the paper: 128).
    #[arg(long, default_value_t = 128, allow_negative_numbers = true)]
    pub lut: i64,
    #[arg(long, value_enum, default_value_t = BrdfArg::Diffuse)]
    pub brdf: BrdfArg,
    /// Phong exponent.
    #[arg(long, default_value_t = 16.0, allow_negative_numbers = true)]
    pub shininess: f32,
    /// Phong lobe weight k_s in [0, 1] (the rest is diffuse).
    #[arg(long, default_value_t = 0.4, allow_negative_numbers = true)]
    pub specular: f32,
    /// Mask integration: 4x4 grey levels (the paper), grey levels with first
    /// moments, or every pixel.
    #[arg(long, value_enum, default_value_t = IntegrationArg::CellsLinear)]
    pub integration: IntegrationArg,
    /// Two-level mesh hierarchy (coarse mesh for distant blockers).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub hierarchy: OnOff,
    #[arg(long, value_enum, default_value_t = NearArg::Clusters)]
    pub near: NearArg,
    /// Ring of the full mesh drawn at full resolution: 1 or 2.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub ring: i64,
    /// Coarse triangles to aim for [default: triangles / 16].
    #[arg(long, allow_negative_numbers = true)]
    pub coarse: Option<i64>,
    /// Far triangles per culling group.
    #[arg(long, default_value_t = 16, allow_negative_numbers = true)]
    pub group_size: i64,
    /// Skip culling groups below the tangent plane.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub group_culling: OnOff,
    /// Potentially visible sets from sampled animation frames.
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub pvs: OnOff,
    /// Animation frames sampled for the PVS (spread over --pvs-span seconds).
    #[arg(long, default_value_t = 8, allow_negative_numbers = true)]
    pub pvs_frames: i64,
    /// Animation time the PVS samples, seconds from --start [default: the frames' span, at least 2 s].
    #[arg(long, allow_negative_numbers = true)]
    pub pvs_span: Option<f32>,
    /// Cull blockers facing away from the vertex (auto: when the mesh is closed).
    #[arg(long, value_enum, default_value_t = AutoOnOff::Auto)]
    pub backface: AutoOnOff,
    /// Shade each vertex's side facing the camera (auto: open meshes).
    #[arg(long, value_enum, default_value_t = AutoOnOff::Auto)]
    pub two_sided: AutoOnOff,
    #[arg(long, value_enum, default_value_t = ShadowsArg::On)]
    pub shadows: ShadowsArg,
    /// Compare the transfer with Monte Carlo ray-traced visibility.
    #[arg(long)]
    pub check: bool,
    /// Rays per vertex of the reference.
    #[arg(long, default_value_t = 4096, allow_negative_numbers = true)]
    pub check_rays: i64,
    /// Frames compared (evenly spread over the frames computed).
    #[arg(long, default_value_t = 4, allow_negative_numbers = true)]
    pub check_frames: i64,
    /// Per-phase times (the paper's Table 2); adds a little overhead.
    #[arg(long)]
    pub profile: bool,
    /// Image of the last frame.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Folder for every frame's image (frame-0000.png, ...).
    #[arg(long)]
    pub out_frames: Option<PathBuf>,
    #[arg(long, default_value_t = 640, allow_negative_numbers = true)]
    pub width: u32,
    #[arg(long, default_value_t = 480, allow_negative_numbers = true)]
    pub height: u32,
    /// Exposure multiplier [default: mean vertex luminance of the first frame to 0.45].
    #[arg(long, allow_negative_numbers = true)]
    pub exposure: Option<f32>,
    /// Surface colour "R,G,B".
    #[arg(long, value_parser = parse_vec3, default_value = "0.8,0.8,0.8")]
    pub albedo: Vec3,
    /// Turn the lighting about +y by this many degrees per frame.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub env_spin: f32,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub common: Common,
}

fn positive(name: &str, v: i64) -> Result<usize> {
    if v <= 0 {
        return Err(Error::param(name, format!("must be positive, got {v}")));
    }
    usize::try_from(v).map_err(|_| Error::param(name, "is too large"))
}

/// The geometry a run shades: an animation or a static mesh.
enum Source {
    Animated(Animation),
    Static {
        positions: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        name: String,
    },
}

impl Source {
    fn triangles(&self) -> &[[u32; 3]] {
        match self {
            Source::Animated(a) => &a.triangles,
            Source::Static { triangles, .. } => triangles,
        }
    }
    fn positions_at(&self, t: f32, out: &mut Vec<Vec3>) {
        match self {
            Source::Animated(a) => a.positions_at(t, out),
            Source::Static { positions, .. } => {
                out.clear();
                out.extend_from_slice(positions);
            }
        }
    }
    fn name(&self) -> String {
        match self {
            Source::Animated(a) => a.name.to_string(),
            Source::Static { name, .. } => name.clone(),
        }
    }
}

pub fn run(args: &PrtArgs) -> Result<Value> {
    let threads = args.common.init_threads()?;
    let frames = positive("--frames", args.frames)?;
    let bands = positive("--order", args.order)?;
    let mask = positive("--mask", args.mask)?;
    let lut = positive("--lut", args.lut)?;
    let ring = positive("--ring", args.ring)?;
    let group_size = positive("--group-size", args.group_size)?;
    let check_rays = positive("--check-rays", args.check_rays)?;
    let check_frames = positive("--check-frames", args.check_frames)?;
    let pvs_frames = positive("--pvs-frames", args.pvs_frames)?;
    let coarse = args.coarse.map(|c| positive("--coarse", c)).transpose()?;
    if !(args.dt.is_finite() && args.start.is_finite() && args.env_spin.is_finite()) {
        return Err(Error::param("--dt/--start/--env-spin", "must be finite"));
    }
    if let Some(e) = args.exposure
        && !(e.is_finite() && e > 0.0)
    {
        return Err(Error::param("--exposure", format!("must be positive, got {e}")));
    }
    if args.albedo.min_element() < 0.0 {
        return Err(Error::param("--albedo", "must be non-negative"));
    }
    if check_rays > u32::MAX as usize {
        return Err(Error::param("--check-rays", "is too large"));
    }
    check_image_size(args.width, args.height)?;
    let out_png = args.out.as_deref().map(|p| check_output(p, "--out")).transpose()?;
    if let Some(dir) = &args.out_frames
        && !dir.is_dir()
    {
        return Err(Error::param(
            "--out-frames",
            format!("{} is not a folder", dir.display()),
        ));
    }
    let brdf = match args.brdf {
        BrdfArg::Diffuse => Brdf::Diffuse,
        BrdfArg::Phong => Brdf::Phong {
            shininess: args.shininess,
            specular: args.specular,
        },
    };
    let settings = PrtSettings {
        mask_side: mask,
        lut_size: lut,
        bands,
        brdf,
        integration: match args.integration {
            IntegrationArg::Cells => Integration::Cells,
            IntegrationArg::CellsLinear => Integration::CellsLinear,
            IntegrationArg::Pixels => Integration::Pixels,
        },
        hierarchy: HierarchySettings {
            enabled: args.hierarchy == OnOff::On,
            near: match args.near {
                NearArg::Clusters => NearField::Clusters,
                NearArg::Rings => NearField::Rings,
            },
            ring,
            coarse_triangles: coarse,
            group_size,
        },
        group_culling: args.group_culling == OnOff::On,
        backface: args.backface.into(),
        two_sided: args.two_sided.into(),
        shadows: args.shadows == ShadowsArg::On,
    };
    settings.validate()?;

    // Inputs: the probe first (a bad file fails before any work).
    let env = EnvironmentMap::load(&args.env)?;
    let source = match (&args.mesh, &args.animated) {
        (Some(path), None) => {
            let mesh = load_obj(path)?;
            let name = path
                .file_stem()
                .map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
            Source::Static {
                positions: mesh.positions,
                triangles: mesh.triangles,
                name,
            }
        }
        (None, Some(name)) => Source::Animated(AnimatedScene::parse(name)?.build()),
        _ => return Err(Error::param("--mesh", "give --mesh FILE or --animated cloth|character")),
    };
    let mut device = Device::open(args.common.device)?;
    if matches!(device, Device::Gpu(_)) && bands > MAX_GPU_BANDS && args.common.device == DeviceArg::Auto {
        eprintln!(
            "penumbra: the GPU kernel integrates up to {MAX_GPU_BANDS} SH bands; --order {bands} runs on the CPU"
        );
        device = Device::Cpu;
    }
    let lighting_world = project_environment(&env, bands);
    let rotation = ShRotation::new(bands);

    let mut positions = Vec::new();
    source.positions_at(args.start, &mut positions);
    let setup = Instant::now();
    let mut prt = Prt::new(&positions, source.triangles(), &settings)?;
    let setup_ms = setup.elapsed().as_secs_f64() * 1e3;

    // Camera: the animation's, else the contract's default; options override.
    let bounds = crate::aabb::Aabb::from_points(positions.iter());
    let base_camera = match &source {
        Source::Animated(a) => Some(Camera {
            eye: a.camera.0,
            target: a.camera.1,
            fov_degrees: a.camera.2,
        }),
        Source::Static { .. } => None,
    };
    let camera = args.camera.camera(base_camera, &bounds)?;
    let eye = Some(camera.eye);

    let mut pvs_ms = None;
    if args.pvs == OnOff::On {
        let t = Instant::now();
        let span = args.pvs_span.unwrap_or(((frames - 1) as f32 * args.dt).max(2.0));
        let sampled: Vec<Vec<Vec3>> = (0..pvs_frames)
            .map(|k| {
                let mut p = Vec::new();
                let time = args.start + span * k as f32 / (pvs_frames.max(2) - 1) as f32;
                source.positions_at(time, &mut p);
                p
            })
            .collect();
        let pvs = crate::prt::pvs::build_pvs(&prt, &sampled)?;
        prt.set_pvs(Some(pvs));
        pvs_ms = Some(t.elapsed().as_secs_f64() * 1e3);
    }

    let coeffs = coefficient_count(bands);
    let check_at: Vec<usize> = if args.check {
        let k = check_frames.min(frames);
        (0..k)
            .map(|i| if k == 1 { 0 } else { i * (frames - 1) / (k - 1) })
            .collect()
    } else {
        Vec::new()
    };
    let mut errors = Vec::new();
    let mut check_counts = (0usize, 0usize);
    let mut frame_ms = Vec::with_capacity(frames);
    let mut gpu_ms = Vec::new();
    let mut stats_sum = crate::prt::pipeline::FrameStats::default();
    let mut out = FrameOutput::default();
    let mut exposure = args.exposure;
    let mut images = 0usize;
    let unoccluded_norm = prt.tables.unoccluded.iter().map(|v| v * v).sum::<f32>().sqrt();
    // GPU: masks on the CPU, integration, rotation and shading in WGSL.
    let gpu = match (&device, args.shadows) {
        (Device::Gpu(ctx), ShadowsArg::On | ShadowsArg::Off) => {
            let pass = ShTransferPass::cached(ctx);
            let resident = GpuTransfer::new(ctx, &pass, &prt)?;
            Some((ctx, pass, resident))
        }
        _ => None,
    };

    // Monte Carlo ray-traced transfer of the current pose (kd-tree of the full mesh).
    let traced_transfer = |positions: &[Vec3], normals: &[Vec3]| -> Result<Vec<f32>> {
        let tree = fine_tree(positions, source.triangles())?;
        Ok(reference_transfer(
            &tree,
            positions,
            normals,
            prt.scale,
            bands,
            &brdf,
            eye,
            check_rays as u32,
            args.common.seed,
        ))
    };
    for f in 0..frames {
        let time = args.start + f as f32 * args.dt;
        source.positions_at(time, &mut positions);
        let lighting = spun_lighting(&lighting_world, &rotation, args.env_spin * f as f32);
        let planar = lighting.to_f32_planar();
        let start = Instant::now();
        match args.shadows {
            ShadowsArg::Raytraced => {
                prt.shading_normals(&positions, eye, &mut out.normals);
                out.transfer = traced_transfer(&positions, &out.normals)?;
                out.radiance = out.transfer.chunks(coeffs).map(|t| radiance(&planar, t)).collect();
                out.stats = Default::default();
            }
            _ => match &gpu {
                Some((ctx, pass, resident)) => {
                    prt.frame_masks(&positions, eye, args.profile, &mut out)?;
                    let g = resident.run_frame(ctx, pass, &out.masks, &positions, &out.normals, eye, &planar)?;
                    out.transfer = g.transfer;
                    out.radiance = g.radiance;
                    if let Some(ms) = g.kernel_ms {
                        gpu_ms.push(ms);
                    }
                }
                None => prt.frame(&positions, eye, &planar, args.profile, false, &mut out)?,
            },
        }
        frame_ms.push(start.elapsed().as_secs_f64() * 1e3);
        add_stats(&mut stats_sum, &out.stats);

        if check_at.contains(&f) {
            // Ray-traced shadows already are the reference: no second trace.
            let reference = match args.shadows {
                ShadowsArg::Raytraced => out.transfer.clone(),
                _ => traced_transfer(&positions, &out.normals)?,
            };
            let (e, counted, skipped) = relative_l2_error(&out.transfer, &reference, coeffs, 0.01 * unoccluded_norm);
            errors.push(e);
            check_counts.0 += counted;
            check_counts.1 += skipped;
        }
        let last = f + 1 == frames;
        if args.out_frames.is_some() || (last && out_png.is_some()) {
            let exp = *exposure.get_or_insert_with(|| auto_exposure(&out.radiance, args.albedo));
            let pixels = render(
                &positions,
                source.triangles(),
                &out.radiance,
                args.albedo,
                Some(&env),
                &camera,
                args.width,
                args.height,
                exp,
            )?;
            if let Some(dir) = &args.out_frames {
                write_rgb_png(&dir.join(format!("frame-{f:04}.png")), args.width, args.height, &pixels)?;
                images += 1;
            }
            if last && let Some(p) = &out_png {
                write_rgb_png(p, args.width, args.height, &pixels)?;
                images += 1;
            }
        }
    }

    let nf = frames as f64;
    let verts = stats_sum.vertices.max(1) as f64;
    let total_ms: f64 = frame_ms.iter().sum();
    let best_ms = frame_ms.iter().cloned().fold(f64::INFINITY, f64::min);
    let mut sorted = frame_ms.clone();
    sorted.sort_by(f64::total_cmp);
    let median_ms = sorted[sorted.len() / 2];
    let phases = if args.profile {
        // CPU phases are summed over threads; per frame they are divided by
        // the thread count. On the GPU path integration is the kernel's
        // time and "other" the rest of the frame (uploads, readback, waits).
        let mut ms = stats_sum.phase_ns.map(|n| n as f64 * 1e-6 / nf / threads as f64);
        if gpu.is_some() && !gpu_ms.is_empty() {
            ms[2] = gpu_ms.iter().sum::<f64>() / gpu_ms.len() as f64;
            ms[3] = (total_ms / nf - ms[0] - ms[1] - ms[2]).max(0.0);
        }
        let total: f64 = ms.iter().sum();
        let share = |i: usize| ms[i] / total.max(1e-12);
        json!({
            "transform": share(0), "rasterization": share(1), "integration": share(2), "other": share(3),
            "ms_per_frame": ms,
        })
    } else {
        Value::Null
    };
    let h = &prt.hierarchy;
    Ok(json!({
        "scene": source.name(),
        "vertices": prt.vertex_count,
        "triangles": source.triangles().len(),
        "avg_blockers_per_vertex": stats_sum.drawn as f64 / verts,
        "fps": 1e3 * nf / total_ms.max(1e-9),
        "fps_best": 1e3 / best_ms.max(1e-9),
        "transfer_l2_error": if errors.is_empty() { Value::Null } else { json!(errors.iter().sum::<f64>() / errors.len() as f64) },
        "device": device.kind(),
        "adapter": device.adapter(),
        "threads": threads,
        "frames": frames,
        "frame_ms": { "mean": total_ms / nf, "median": median_ms, "best": best_ms },
        "gpu_ms_per_frame": if gpu_ms.is_empty() { Value::Null } else { json!(gpu_ms.iter().sum::<f64>() / gpu_ms.len() as f64) },
        "order": bands,
        "coefficients": coeffs,
        "mask": mask,
        "integration": settings.integration.name(),
        "lut": { "size": lut, "bytes": prt.lut.bytes(), "paper_layout_bytes": prt.lut.six_face_bytes(), "build_ms": prt.lut_ms },
        "brdf": match brdf { Brdf::Diffuse => json!({"kind": "diffuse"}), Brdf::Phong { shininess, specular } => json!({"kind": "phong", "shininess": shininess, "specular": specular}) },
        "shadows": format!("{:?}", args.shadows).to_lowercase(),
        "hierarchy": {
            "enabled": settings.hierarchy.enabled,
            "near": format!("{:?}", settings.hierarchy.near).to_lowercase(),
            "ring": ring,
            "low_res_triangles": if h.coarse { Some(h.far.len()) } else { None },
            "groups": h.groups.len(),
            "group_culling": settings.group_culling,
        },
        "backface_culling": prt.cull_backfaces,
        "two_sided": prt.two_sided,
        "pvs": match prt.pvs() {
            Some(p) => json!({"frames": pvs_frames, "build_ms": pvs_ms, "avg_size": p.items.len() as f64 / prt.vertex_count.max(1) as f64}),
            None => Value::Null,
        },
        "avg_candidates_per_vertex": stats_sum.candidates as f64 / verts,
        "culling_per_vertex": {
            "groups": stats_sum.group_culled as f64 / verts,
            "below_horizon": stats_sum.below_horizon as f64 / verts,
            "back_facing": stats_sum.back_facing as f64 / verts,
            "edge_on": stats_sum.edge_on as f64 / verts,
        },
        "without_normal": stats_sum.without_normal / frames as u64,
        "phases": phases,
        "setup_ms": setup_ms,
        "check": if args.check { json!({
            "rays": check_rays, "frames": check_at, "per_frame": errors,
            "vertices": check_counts.0, "skipped_dark": check_counts.1, "seed": args.common.seed,
        }) } else { Value::Null },
        "images": images,
        "exposure": exposure,
        "camera": { "eye": camera.eye.to_array(), "target": camera.target.to_array(), "fov": camera.fov_degrees },
    }))
}

fn fine_tree(positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<KdTree> {
    let soup: Vec<[Vec3; 3]> = triangles.iter().map(|t| t.map(|i| positions[i as usize])).collect();
    KdTree::from_triangles(soup, &KdTreeParams::default())
}

fn spun_lighting(lighting: &ShRgb, rot: &ShRotation, degrees: f32) -> ShRgb {
    if degrees == 0.0 {
        return lighting.clone();
    }
    lighting.rotated(rot, glam::DMat3::from_rotation_y((degrees as f64).to_radians()))
}

fn add_stats(sum: &mut crate::prt::pipeline::FrameStats, s: &crate::prt::pipeline::FrameStats) {
    sum.vertices += s.vertices;
    sum.without_normal += s.without_normal;
    sum.candidates += s.candidates;
    sum.group_culled += s.group_culled;
    sum.below_horizon += s.below_horizon;
    sum.back_facing += s.back_facing;
    sum.edge_on += s.edge_on;
    sum.drawn += s.drawn;
    for i in 0..4 {
        sum.phase_ns[i] += s.phase_ns[i];
    }
}
