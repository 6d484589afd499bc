//! Hemispherical rasterisation's knobs as command-line options (see
//! `crate::options`).

use std::path::Path;

use clap::Args;

use crate::options::{Applies, OnOff, applies, in_range, positive};
use penumbra::error::{Error, Result};
use penumbra::field::runner::MAX_FRAMES;
use penumbra::prt::hierarchy::{DEFAULT_POSES, DEFAULT_TOLERANCE, HierarchySettings, NearField};
use penumbra::prt::pipeline::{PrtSettings, Toggle};
use penumbra::prt::probe::Probe;
use penumbra::prt::runner::{Playback, PvsSampling, RayTraced, Shadows};
use penumbra::prt::selfcheck::SelfCheck;
use penumbra::prt::transfer::{Brdf, BrdfKind, Integration};
use penumbra::scene::animated::AnimatedScene;
use penumbra::scene::sequence::MeshSequence;
use penumbra::scene::{MeshFormat, Scene, load_gltf_animation, load_mesh};

#[derive(Args, Clone, Debug)]
pub struct PrtOptions {
    /// SH bands (5 = 25 coefficients).
    #[arg(long, default_value_t = 5, allow_negative_numbers = true)]
    pub order: i64,
    /// Visibility mask side in pixels: 16, 32 or 64 [default: chosen per mesh by the probe; 32 with --probe off].
    #[arg(long, allow_negative_numbers = true)]
    pub mask: Option<i64>,
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
    /// Two-level mesh hierarchy (coarse mesh for distant blockers) [default: chosen per mesh by the probe; on with --probe off].
    #[arg(long, value_enum)]
    pub hierarchy: Option<OnOff>,
    /// Fine triangles drawn near a vertex [default: chosen per mesh by the probe; clusters with --probe off].
    #[arg(long, value_enum)]
    pub near: Option<NearField>,
    /// Choose --mask, --hierarchy and --near (those not given) per mesh: each candidate's transfer error estimated on the self-check's sample of vertices and its frame's work counted and priced; the cheapest within 3% (95% upper bound) is used, else the most accurate. The work is counted, not timed, so every run and shard chooses alike.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub probe: OnOff,
    /// Ring of the full mesh drawn at full resolution: 1 or 2.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub ring: i64,
    /// Coarse triangles to aim for [default: triangles / 16, at most 8 sqrt(triangles) unless refinement outweighs it].
    #[arg(long, allow_negative_numbers = true)]
    pub coarse: Option<i64>,
    /// Angle (radians) a coarse triangle's distance from the fine surface may subtend at a vertex before the vertex draws the fine triangles instead (0: the paper's plain two levels).
    #[arg(long, default_value_t = DEFAULT_TOLERANCE, allow_negative_numbers = true)]
    pub coarse_tolerance: f32,
    /// Poses of an animation the coarse level is checked on, spread over the frames played (1: the first frame only).
    #[arg(long, default_value_t = DEFAULT_POSES as i64, allow_negative_numbers = true)]
    pub coarse_poses: i64,
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
        let hierarchy = &["near", "ring", "coarse", "coarse_tolerance", "coarse_poses"];
        vec![
            applies(self.brdf == BrdfKind::Phong, &["shininess", "specular"], "--brdf phong"),
            applies(self.hierarchy != Some(OnOff::Off), hierarchy, "--hierarchy on"),
        ]
    }

    /// The checked settings (`shadows`: rasterise at all).
    pub fn settings(&self, shadows: bool) -> Result<PrtSettings> {
        let base = PrtSettings::default();
        let settings = PrtSettings {
            mask_side: self
                .mask
                .map(|m| positive("--mask", m))
                .transpose()?
                .unwrap_or(base.mask_side),
            lut_size: positive("--lut", self.lut)?,
            bands: positive("--order", self.order)?,
            brdf: Brdf::new(self.brdf, self.shininess, self.specular),
            integration: self.integration,
            hierarchy: HierarchySettings {
                enabled: self.hierarchy.map_or(base.hierarchy.enabled, OnOff::on),
                near: self.near.unwrap_or(base.hierarchy.near),
                ring: positive("--ring", self.ring)?,
                coarse_triangles: self.coarse.map(|c| positive("--coarse", c)).transpose()?,
                group_size: positive("--group-size", self.group_size)?,
                tolerance: self.coarse_tolerance,
                poses: positive("--coarse-poses", self.coarse_poses)?,
            },
            group_culling: self.group_culling.on(),
            backface: self.backface,
            two_sided: self.two_sided,
            shadows,
        };
        Ok(settings)
    }
}

impl PrtOptions {
    /// The probe of the knobs not given (`None` with `--probe off` or all
    /// three given): each given one is the only value tried.
    pub fn probe(&self) -> Option<Probe> {
        if self.probe == OnOff::Off || (self.mask.is_some() && self.hierarchy.is_some() && self.near.is_some()) {
            return None;
        }
        let mut p = Probe::default();
        if let Some(m) = self.mask {
            p.masks = vec![m.max(0) as usize];
        }
        if let Some(h) = self.hierarchy {
            p.hierarchy = vec![h.on()];
        }
        if let Some(n) = self.near {
            p.near = vec![n];
            p.hierarchy = vec![true];
        }
        (p.masks.len() * p.hierarchy.len() * p.near.len() > 1).then_some(p)
    }
}

/// Users' animations: a mesh sequence, or the clip of an
/// animated glTF `--mesh`.
#[derive(Args, Clone, Debug, Default)]
pub struct AnimationOptions {
    /// An animation as one mesh file per frame (OBJ, PLY or glTF; one
    /// topology), e.g. 'frames/*.obj' quoted: `*` and `?` in the file name,
    /// natural order (f2 before f10). Frame 0 is the rest pose.
    #[arg(long, conflicts_with_all = ["mesh", "animated"])]
    pub mesh_sequence: Option<String>,
    /// Frames per second of --mesh-sequence (frame k plays at time k / fps).
    #[arg(long, default_value_t = 30.0, allow_negative_numbers = true)]
    pub sequence_fps: f32,
    /// The animation of a glTF --mesh to play: its name or index [default:
    /// the first], or `none` for the rest pose. Skins and morph targets
    /// are applied.
    #[arg(long)]
    pub animation: Option<String>,
}

impl AnimationOptions {
    /// The one-mesh scene of `--mesh`, `--animated` or `--mesh-sequence`:
    /// a glTF mesh with an animation plays it (unless `--animation none`).
    pub fn scene(&self, mesh: Option<&Path>, animated: Option<&str>) -> Result<Scene> {
        match (mesh, animated, &self.mesh_sequence) {
            (None, None, Some(pattern)) => {
                let sequence = MeshSequence::load(pattern, self.sequence_fps)?;
                let name = Path::new(pattern)
                    .parent()
                    .and_then(|d| d.file_name())
                    .map_or_else(|| "sequence".to_string(), |d| d.to_string_lossy().into_owned());
                let origin = sequence.origin;
                let mut scene = Scene::from_user_animation(Path::new(pattern), sequence.into_animation(&name))?;
                // The scene is in frame 0's frame: world inputs follow it.
                (scene.origin, scene.meshes[0].mesh.origin) = (origin, origin);
                Ok(scene)
            }
            (Some(path), None, None) => {
                let selector = self.animation.as_deref();
                let gltf = load_mesh_format(path)?.is_some_and(|f| matches!(f, MeshFormat::Gltf | MeshFormat::Glb));
                if gltf
                    && selector != Some("none")
                    && let Some(animation) = load_gltf_animation(path, selector)?
                {
                    return Scene::from_user_animation(path, animation);
                }
                if selector.is_some_and(|s| s != "none") && !gltf {
                    return Err(Error::param(
                        "--animation",
                        format!(
                            "{} is not a glTF file; only glTF meshes hold animations",
                            path.display()
                        ),
                    ));
                }
                let name = path
                    .file_stem()
                    .map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
                Ok(Scene::from_mesh(&name, path, load_mesh(path)?))
            }
            (None, Some(name), None) => Ok(Scene::from_animation(AnimatedScene::parse(name)?.build())),
            _ => Err(Error::param(
                "--mesh",
                "give one of --mesh FILE, --animated cloth|character or --mesh-sequence PATTERN",
            )),
        }
    }

    /// Whether the scene may move (`--start` and `--dt` apply).
    pub fn may_animate(&self, mesh: Option<&Path>, animated: bool) -> bool {
        let gltf = mesh.and_then(|m| m.extension()).is_some_and(|e| {
            let e = e.to_string_lossy().to_ascii_lowercase();
            e == "gltf" || e == "glb"
        });
        animated || self.mesh_sequence.is_some() || (gltf && self.animation.as_deref() != Some("none"))
    }
}

/// The format of a mesh file by its content, if it can be read at all
/// (the loader reports unreadable files).
fn load_mesh_format(path: &Path) -> Result<Option<MeshFormat>> {
    let Ok(bytes) = std::fs::read(path) else {
        return Ok(None);
    };
    Ok(MeshFormat::detect(path, &bytes).ok())
}

/// How the animation is played and checked: frames and times, PVS,
/// visibility's source, the ray-traced check and self-check, profiling.
#[derive(Args, Clone, Debug)]
pub struct PlaybackOptions {
    /// Frames to compute [default: 1; an animation's own frames].
    #[arg(long, allow_negative_numbers = true)]
    pub frames: Option<i64>,
    /// Animation time of the first frame, seconds.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub start: f32,
    /// Animation time between frames, seconds [default: 1/30; a clip's span / (--frames - 1)].
    #[arg(long, allow_negative_numbers = true)]
    pub dt: Option<f32>,
    /// Potentially visible sets from sampled animation frames.
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub pvs: OnOff,
    /// Animation frames sampled for the PVS (spread over --pvs-span seconds).
    #[arg(long, default_value_t = 8, allow_negative_numbers = true)]
    pub pvs_frames: i64,
    /// Animation time the PVS samples, seconds from --start [default: the frames' span, at least 2 s].
    #[arg(long, allow_negative_numbers = true)]
    pub pvs_span: Option<f32>,
    /// Where visibility comes from.
    #[arg(long, value_enum, default_value_t = Shadows::On)]
    pub shadows: Shadows,
    /// Compare the transfer with Monte Carlo ray-traced visibility.
    #[arg(long, alias = "check")]
    pub reference: bool,
    /// Rays per vertex of the reference.
    #[arg(long, alias = "check-rays", default_value_t = 4096, allow_negative_numbers = true)]
    pub reference_rays: i64,
    /// Frames compared, evenly spread over the frames computed.
    #[arg(long, alias = "check-frames", default_value_t = 4, allow_negative_numbers = true)]
    pub reference_frames: i64,
    /// Estimate the transfer error at setup by ray tracing a sample of vertices (`self_check` in --json).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub self_check: OnOff,
    /// Warn on stderr when the self-check's estimated error exceeds this.
    #[arg(long, default_value_t = 0.03, allow_negative_numbers = true)]
    pub self_check_threshold: f64,
    /// Per-phase times (the paper's Table 2); adds a little overhead.
    #[arg(long)]
    pub profile: bool,
    /// Turn the lighting about +y by this many degrees per frame.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub env_spin: f32,
}

impl PlaybackOptions {
    /// The checked playback and the reference's rays (`seed`: theirs).
    pub fn playback(&self, seed: u32) -> Result<(Playback, RayTraced)> {
        let check_frames = positive("reference_frames", self.reference_frames)?;
        let playback = Playback {
            // Bounded like every animated method's (a per-frame record
            // each: 2^32 frames asked for 34 GB at once).
            frames: in_range("frames", self.frames.unwrap_or(1), 1, MAX_FRAMES.into())?,
            start: self.start,
            dt: self.dt.unwrap_or(1.0 / 30.0),
            env_spin: self.env_spin,
            pvs: self.pvs.on().then_some(PvsSampling {
                frames: in_range("pvs_frames", self.pvs_frames, 1, MAX_FRAMES.into())?,
                span: self.pvs_span,
            }),
            check_frames: if self.reference { check_frames } else { 0 },
            profile: self.profile,
            self_check: self.self_check.on().then_some(SelfCheck {
                threshold: self.self_check_threshold,
                ..SelfCheck::default()
            }),
            bars: penumbra::progress::Reporter::silent(),
        };
        playback.validate()?;
        let rays = positive("reference_rays", self.reference_rays)?;
        let rays = u32::try_from(rays).map_err(|_| Error::param("reference_rays", "is too large"))?;
        Ok((playback, RayTraced { rays, seed }))
    }

    /// Which options apply to the chosen visibility, PVS and checks.
    pub fn applies(&self) -> Vec<Applies> {
        let on = self.shadows == Shadows::On;
        let raytraced = self.reference || self.shadows == Shadows::Raytraced;
        vec![
            applies(self.pvs == OnOff::On, &["pvs_frames", "pvs_span"], "--pvs on"),
            applies(raytraced, &["reference_rays"], "--reference or --shadows raytraced"),
            applies(self.reference, &["reference_frames"], "--reference"),
            applies(on, &["self_check"], "--shadows on"),
            applies(on && self.self_check.on(), &["self_check_threshold"], "--self-check on"),
        ]
    }
}
