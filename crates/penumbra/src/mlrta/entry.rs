//! [`PrimaryRays`]: a camera's image of a mesh by multi-level ray tracing
//! (Reshetov, Soupikov and Hurley 2005): 4x4 packets that start their walk
//! at an entry point found once per tile, tiles split where their rays
//! diverge.

use std::borrow::Cow;

use super::MlrtaSettings;
use super::aa::AaMode;
use super::runner::{AaRequest, ShadowLight, TraceRequest, TracedImage, trace_view};
use super::tiles::DEFAULT_MIN_TILE;
use crate::accel::Structure;
use crate::error::Result;
use crate::gpu::device::Device;
use crate::progress::Reporter;
use crate::scene::{Camera, Mesh, Scene, View};

/// How a camera's primary rays are traced: the command line's `trace`
/// knobs. `Default` is its defaults: MLRTA packets through the kd-tree
/// (entry points on, tiles of 128 split by 16 down to 32 pixels, tile
/// frusta from the camera's corner rays), no shadow rays, no
/// anti-aliasing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceSettings {
    /// One ray at a time instead of packets.
    pub single_ray: bool,
    /// What rays walk on the CPU: single rays the BVH or the kd-tree;
    /// packets the kd-tree with MLRTA or, with `Structure::Bvh`, the BVH from
    /// its root. The GPU walks the kd-tree.
    pub accel: Structure,
    /// The packets' entry points and tiles.
    pub mlrta: MlrtaSettings,
    /// A point light for one shadow ray per hit.
    pub light: ShadowLight,
    /// Anti-aliasing.
    pub aa: AaRequest,
}

impl Default for TraceSettings {
    fn default() -> Self {
        TraceSettings {
            single_ray: false,
            accel: Structure::Kdtree,
            mlrta: MlrtaSettings {
                min_tile: DEFAULT_MIN_TILE,
                corner_frusta: true,
                ..MlrtaSettings::default()
            },
            light: ShadowLight::None,
            aa: AaRequest {
                mode: AaMode::None,
                samples: 4,
                reference: false,
            },
        }
    }
}

impl TraceSettings {
    /// The request of an image through `view` with these settings.
    pub fn request(&self, view: &View) -> TraceRequest {
        TraceRequest {
            view: *view,
            single_ray: self.single_ray,
            accel: self.accel,
            params: self.mlrta,
            light: self.light,
            aa: self.aa,
        }
    }
}

/// Primary rays of a mesh (or a scene at one moment): closest hits per
/// pixel, shadows from a point light, traversal statistics by the paper's
/// Tables 2 and 3. Packets run in the WGSL kernel `packet_traverse` on a
/// GPU (tiles and entry points found on the CPU) and on the CPU's vector
/// lanes otherwise; the hits are the same.
///
/// ```
/// use penumbra::{Device, PrimaryRays, TraceSettings, View};
/// use penumbra::scene::procedural::sphere_on_plane;
///
/// let device = Device::cpu();
/// let mesh = sphere_on_plane();
/// let image = PrimaryRays::new(&device, &mesh).trace(&View::sized(64, 48), &TraceSettings::default())?;
/// assert_eq!(image.hits.len(), 64 * 48);
/// assert!(image.stats.hits > 0);
/// # Ok::<(), penumbra::Error>(())
/// ```
pub struct PrimaryRays<'m> {
    device: Device,
    mesh: Cow<'m, Mesh>,
    camera: Option<Camera>,
    progress: Reporter,
}

impl<'m> PrimaryRays<'m> {
    /// Primary rays of `mesh` on `device`.
    pub fn new(device: &Device, mesh: &'m Mesh) -> PrimaryRays<'m> {
        PrimaryRays {
            device: device.clone(),
            mesh: Cow::Borrowed(mesh),
            camera: None,
            progress: Reporter::silent(),
        }
    }

    /// Primary rays of every instance of `scene` at its first frame,
    /// through the scene's camera unless a view names another.
    pub fn for_scene(device: &Device, scene: &Scene) -> PrimaryRays<'static> {
        PrimaryRays {
            device: device.clone(),
            mesh: Cow::Owned(scene.world_mesh(|_| true)),
            camera: scene.camera,
            progress: Reporter::silent(),
        }
    }

    /// Follows the work with `progress`.
    pub fn with_progress(mut self, progress: Reporter) -> Self {
        self.progress = progress;
        self
    }

    /// The image through `view` (its camera completed from the scene's,
    /// else framing the mesh) traced with `settings`.
    pub fn trace(&self, view: &View, settings: &TraceSettings) -> Result<TracedImage> {
        self.run(&settings.request(view))
    }

    /// The image `request` asks for.
    pub fn run(&self, request: &TraceRequest) -> Result<TracedImage> {
        trace_view(&self.device, &self.mesh, self.camera, request, &self.progress)
    }
}
