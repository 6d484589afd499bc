//! [`Ssao`]: screen-space ambient occlusion of a scene seen through a
//! camera, with the paper's estimators (Szirmay-Kalos et al., sections 3
//! and 4), interleaved sampling and the depth-aware filter (section 5).

use super::runner::{SsaoRequest, SsaoRun, run};
use super::{ShadeSettings, SsaoSettings};
use crate::error::Result;
use crate::gpu::device::Device;
use crate::progress::Reporter;
use crate::report::repeats::Repeats;
use crate::scene::{Mesh, Scene, View};

/// SSAO of a scene: a G-buffer through the view's camera (rasterised on a
/// GPU, ray cast on the CPU), the estimator's samples against its depths,
/// the filter; the WGSL kernels `ssao_estimate`, `ssao_filter` and
/// `ssao_indirect` on a GPU, their CPU twins otherwise.
///
/// ```
/// use penumbra::{Device, Ssao, SsaoSettings, View};
/// use penumbra::scene::procedural::sphere_on_plane;
///
/// let device = Device::cpu();
/// let ssao = Ssao::new(&device, &sphere_on_plane());
/// let frame = ssao.frame(&View::sized(160, 120), &SsaoSettings { radius: 0.5, ..Default::default() })?;
/// let ao = frame.ao_image();
/// assert_eq!(ao.len(), 160 * 120);
/// assert!(ao.iter().flatten().any(|&a| a < 0.9), "the sphere darkens the plane");
/// # Ok::<(), penumbra::Error>(())
/// ```
pub struct Ssao {
    device: Device,
    scene: Scene,
    progress: Reporter,
}

impl Ssao {
    /// SSAO of `mesh` alone.
    pub fn new(device: &Device, mesh: &Mesh) -> Ssao {
        let scene = Scene::from_mesh("mesh", std::path::Path::new("mesh"), mesh.clone());
        Ssao::for_scene(device, &scene)
    }

    /// SSAO of `scene`: every instance is drawn (its lights shade the
    /// image).
    pub fn for_scene(device: &Device, scene: &Scene) -> Ssao {
        Ssao {
            device: device.clone(),
            scene: scene.clone(),
            progress: Reporter::silent(),
        }
    }

    /// Follows the work with `progress`.
    pub fn with_progress(mut self, progress: Reporter) -> Self {
        self.progress = progress;
        self
    }

    /// One frame through `view` (its camera completed from the scene's,
    /// else framing the scene) with `settings`: the G-buffer, the
    /// accessibility per pixel and its timings.
    pub fn frame(&self, view: &View, settings: &SsaoSettings) -> Result<SsaoRun> {
        self.run(&SsaoRequest {
            settings: *settings,
            view: *view,
            shade: None,
            truth_rays: 0,
            reference_spp: 0,
            runs: Repeats::default(),
        })
    }

    /// `frame` with the indirect light and the shaded image of ambient
    /// radiance `shade.ambient` (section 4).
    pub fn shaded(&self, view: &View, settings: &SsaoSettings, shade: &ShadeSettings) -> Result<SsaoRun> {
        self.run(&SsaoRequest {
            settings: *settings,
            view: *view,
            shade: Some(*shade),
            truth_rays: 0,
            reference_spp: 0,
            runs: Repeats::default(),
        })
    }

    /// A frame with its references (ray-traced truth, screen-space
    /// reference) and repeats, as `request` asks.
    pub fn run(&self, request: &SsaoRequest) -> Result<SsaoRun> {
        run(&self.device, &self.scene, request, &self.progress)
    }

    /// A radius R for this scene: [`suggested_radius`](super::suggested_radius).
    pub fn suggested_radius(&self) -> f32 {
        super::suggested_radius(&self.scene)
    }
}
