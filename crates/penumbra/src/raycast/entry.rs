//! [`AmbientOcclusion`]: ambient occlusion by ray casting, the reference
//! every other AO method is measured against.

use std::borrow::Cow;

use super::AoSettings;
use super::points::{points_without_hemisphere, vertex_points};
use super::runner::{PixelAo, VertexAo, casters, receivers, visible_points};
use super::tracer::Tracer;
use crate::accel::BvhStats;
use crate::error::Result;
use crate::gpu::device::Device;
use crate::progress::Reporter;
use crate::scene::cutouts::Cutouts;
use crate::scene::texture_table::DEFAULT_TEXTURE_BYTES;
use crate::scene::{Mesh, Role, Scene, View};
use std::sync::Arc;

/// Ambient occlusion of a mesh or a scene by ray casting: for each point,
/// the fraction of `rays_per_point` cosine-distributed rays that escape
/// within `radius` (the ambient accessibility of the displacement-field
/// paper, section 2). Rays run in the WGSL kernel `ao_rays` on a GPU device
/// and in its CPU twin otherwise, with the same answer.
///
/// The casters' acceleration structure is built once, in `new`; every call
/// after that only casts rays.
///
/// ```
/// use penumbra::{AmbientOcclusion, AoSettings, Device};
/// use penumbra::scene::procedural::sphere_on_plane;
///
/// let device = Device::cpu();
/// let mesh = sphere_on_plane();
/// let mut ao = AmbientOcclusion::new(&device, &mesh)?;
/// let vertices = ao.vertices(&AoSettings { rays_per_point: 64, ..Default::default() })?;
/// assert_eq!(vertices.ao.len(), mesh.positions.len());
/// assert!(vertices.mean() > 0.0 && vertices.mean() < 1.0);
/// # Ok::<(), penumbra::Error>(())
/// ```
pub struct AmbientOcclusion<'s> {
    device: Device,
    scene: Cow<'s, Scene>,
    /// What occludes, merged.
    occluders: Mesh,
    /// The casters' structure, built on first use.
    casters: Option<Tracer>,
    /// Every instance's, for primary visibility, when not all of them cast.
    everything: Option<Tracer>,
    /// The casters' alpha cut-outs, holes for every AO ray.
    cutouts: Option<Arc<Cutouts>>,
    /// Every instance's, holes for primary rays.
    all_cutouts: Option<Arc<Cutouts>>,
    warnings: Vec<String>,
    progress: Reporter,
}

impl<'s> AmbientOcclusion<'s> {
    /// AO of `mesh` onto itself (self-occlusion), on `device`.
    pub fn new(device: &Device, mesh: &Mesh) -> Result<AmbientOcclusion<'static>> {
        let scene = Scene::from_mesh("mesh", std::path::Path::new("mesh"), mesh.clone());
        AmbientOcclusion::of(device, Cow::Owned(scene))
    }

    /// AO of `scene`: its casters occlude, its receivers' vertices and the
    /// pixels a camera sees get AO. An error when nothing casts or nothing
    /// receives.
    pub fn for_scene(device: &Device, scene: &'s Scene) -> Result<AmbientOcclusion<'s>> {
        AmbientOcclusion::of(device, Cow::Borrowed(scene))
    }

    fn of(device: &Device, scene: Cow<'s, Scene>) -> Result<AmbientOcclusion<'s>> {
        let occluders = casters(&scene, 0)?;
        receivers(&scene, 0)?;
        let mut warnings = Vec::new();
        let cutouts = Cutouts::of_scene(&scene, Role::casts, DEFAULT_TEXTURE_BYTES, &mut warnings).map(Arc::new);
        let all_cutouts = match scene.instances.iter().all(|i| i.role.casts()) {
            true => cutouts.clone(),
            false => Cutouts::of_scene(&scene, |_| true, DEFAULT_TEXTURE_BYTES, &mut Vec::new()).map(Arc::new),
        };
        Ok(AmbientOcclusion {
            device: device.clone(),
            scene,
            occluders,
            casters: None,
            everything: None,
            cutouts,
            all_cutouts,
            warnings,
            progress: Reporter::silent(),
        })
    }

    /// Follows the work (the kd-tree's build, the rays) with `progress`.
    pub fn with_progress(mut self, progress: Reporter) -> Self {
        self.progress = progress;
        self
    }

    /// Builds the casters' kd-tree (and on a GPU uploads it) now rather
    /// than on the first call.
    pub fn prepare(&mut self) -> Result<()> {
        self.casters().map(drop)
    }

    fn casters(&mut self) -> Result<&mut Tracer> {
        if self.casters.is_none() {
            let tracer = Tracer::build_labelled(&self.device, &self.occluders, &self.progress, "casters")?;
            self.casters = Some(tracer.with_cutouts(self.cutouts.clone()));
        }
        Ok(self.casters.as_mut().expect("built above"))
    }

    /// AO at the receivers' vertices (for a mesh, its vertices), in the
    /// mesh's order.
    pub fn vertices(&mut self, settings: &AoSettings) -> Result<VertexAo> {
        self.vertices_in(0..usize::MAX, settings)
    }

    /// The receivers' vertex count: the items of [`AmbientOcclusion::vertices_in`].
    pub fn vertex_count(&self) -> Result<usize> {
        Ok(receivers(&self.scene, 0)?.positions.len())
    }

    /// AO at the receivers' vertices `items` (clamped to their count): the
    /// values `vertices` gives those vertices, bit for bit, as each
    /// vertex's rays depend on its index alone. `without_normal` counts
    /// those vertices only.
    pub fn vertices_in(&mut self, items: std::ops::Range<usize>, settings: &AoSettings) -> Result<VertexAo> {
        settings.validate()?;
        self.prepare()?;
        let mut points = vertex_points(&receivers(&self.scene, 0)?);
        let end = items.end.min(points.len());
        points.truncate(end);
        points.drain(..items.start.min(end));
        let bar = self.progress.bar(points.len() as u64, "AO vertices");
        let masks = self.casters()?.ao_visibility(&points, settings, &bar)?;
        Ok(VertexAo {
            ao: masks.value.accessibility(),
            without_normal: points_without_hemisphere(&points),
            ms: masks.ms,
        })
    }

    /// AO at the pixels `view` sees (`None` where its primary ray misses):
    /// primary visibility sees every instance, only casters occlude. The
    /// view's camera is completed from the scene's, else it frames the
    /// scene.
    pub fn image(&mut self, view: &View, settings: &AoSettings) -> Result<PixelAo> {
        self.image_in(view, settings, 0..usize::MAX)
    }

    /// `image` with AO rays cast from the pixels `pixels` only (row by
    /// row from the top, clamped to the image): the values `image` gives
    /// those pixels, bit for bit (a pixel's rays depend on its index
    /// alone); the others are `None`, hit or not.
    pub fn image_in(&mut self, view: &View, settings: &AoSettings, pixels: std::ops::Range<usize>) -> Result<PixelAo> {
        settings.validate()?;
        self.prepare()?;
        let everything = self.scene.world_mesh(|_| true);
        if everything.triangles.len() != self.occluders.triangles.len() && self.everything.is_none() {
            let all = Tracer::build_labelled(&self.device, &everything, &self.progress, "all instances")?;
            self.everything = Some(all.with_cutouts(self.all_cutouts.clone()));
        }
        let primary = match self.everything.as_mut() {
            Some(all) => all,
            None => self.casters.as_mut().expect("prepared"),
        };
        let mut seen = visible_points(primary, &everything, self.scene.camera, view)?;
        seen.points.retain(|p| pixels.contains(&(p.stream as usize)));
        let bar = self.progress.bar(seen.points.len() as u64, "AO pixels");
        let masks = self.casters()?.ao_visibility(&seen.points, settings, &bar)?;
        Ok(seen.image(&masks.value.accessibility(), masks.ms))
    }

    /// The casters' triangle count.
    pub fn caster_triangles(&self) -> usize {
        self.occluders.triangles.len()
    }

    /// The casters' triangles with an alpha cut-out (MTL `map_d`, glTF
    /// `alphaMode` MASK or BLEND): rays pass their holes.
    pub fn cutout_triangles(&self) -> usize {
        self.cutouts.as_ref().map_or(0, |c| c.records.len())
    }

    /// Problems that did not stop the work (a cut-out's image that cannot
    /// be read: its triangles are then opaque).
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// What building the casters' kd-tree cost, in milliseconds (0 before
    /// it is built).
    pub fn build_ms(&self) -> f64 {
        self.casters.as_ref().map_or(0.0, |t| t.accel().kdtree().stats.build_ms)
    }

    /// On the CPU, the wide BVH the AO packets walked.
    pub fn bvh_stats(&self) -> Option<&BvhStats> {
        self.casters.as_ref().and_then(Tracer::bvh_stats)
    }
}

impl VertexAo {
    /// Mean AO over the vertices.
    pub fn mean(&self) -> f64 {
        super::runner::mean(&self.ao)
    }
}
