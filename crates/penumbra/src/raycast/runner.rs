//! The reference AO runner (`ao --method raycast`): a scene's casters
//! occlude; its receivers' vertices, and the pixels a camera sees, get
//! ambient accessibility by ray casting, on whatever device it is given.
//! The displacement-field runner (`field::runner`) answers the same
//! request through fields and shares the pieces below.

use super::entry::AmbientOcclusion;
use super::points::hit_points;
use super::{AoPoint, AoSettings};
use crate::accel::BvhStats;
use crate::error::{Error, Result};
use crate::geom::ray::Ray;
use crate::gpu::device::{Device, Timed};
use crate::progress::Reporter;
use crate::raycast::tracer::Tracer;
use crate::scene::{Camera, Mesh, Role, Scene, View};

/// What AO is asked for: the receivers' vertices and/or an image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AoRequest {
    /// How the AO rays are cast.
    pub settings: AoSettings,
    /// Whether the receivers' vertices get AO.
    pub vertices: bool,
    /// The view whose visible pixels get AO; `None` for no image.
    pub image: Option<View>,
}

/// AO at the receivers' vertices, in `Scene::receivers` order.
#[derive(Debug, Clone, PartialEq)]
pub struct VertexAo {
    /// Ambient accessibility per vertex, in [0, 1]: the fraction of its
    /// rays that escaped (1 open).
    pub ao: Vec<f32>,
    /// Vertices no triangle of non-zero area uses: no normal, no rays, ao = 1.
    pub without_normal: usize,
    /// Milliseconds of the vertices' AO: the kernels' own time from GPU
    /// timestamps where the device has them, else wall clock; 0 where the
    /// runner times whole frames instead (`field::runner`).
    pub ms: f64,
}

/// AO at the pixels a camera sees; `None` where the primary ray misses.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelAo {
    /// Ambient accessibility per pixel, row by row from the top.
    pub values: Vec<Option<f32>>,
    /// The camera the image was seen through (the view's, completed).
    pub camera: Camera,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Milliseconds of the pixels' AO (the primary rays not included): the
    /// kernels' own time from GPU timestamps where the device has them,
    /// else wall clock.
    pub ms: f64,
}

impl PixelAo {
    /// Pixels whose primary ray hit.
    pub fn hit(&self) -> usize {
        self.values.iter().flatten().count()
    }

    /// Mean AO over the pixels hit.
    pub fn mean(&self) -> f64 {
        mean(&self.values.iter().flatten().copied().collect::<Vec<_>>())
    }
}

/// The reference AO of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct RaycastAo {
    /// The casters' triangles, merged.
    pub caster_triangles: usize,
    /// Those with an alpha cut-out, whose holes rays pass.
    pub cutout_triangles: usize,
    /// Problems that did not stop the work.
    pub warnings: Vec<String>,
    /// The casters' kd-tree build.
    pub build_ms: f64,
    /// On the CPU, the wide BVH the AO packets walked (`accel::Structure`).
    pub bvh: Option<BvhStats>,
    /// The vertices' AO, if asked for.
    pub vertices: Option<VertexAo>,
    /// The image's AO, if asked for.
    pub image: Option<PixelAo>,
}

impl RaycastAo {
    /// Points that cast rays (vertices and pixels hit).
    pub fn points(&self) -> usize {
        self.vertices.as_ref().map_or(0, |v| v.ao.len()) + self.image.as_ref().map_or(0, PixelAo::hit)
    }

    /// AO time, vertices and pixels together.
    pub fn ao_ms(&self) -> f64 {
        self.vertices.as_ref().map_or(0.0, |v| v.ms) + self.image.as_ref().map_or(0.0, |i| i.ms)
    }
}

/// AO of `request` by ray casting against the scene's casters on `device`.
pub fn raycast(device: &Device, scene: &Scene, request: &AoRequest, bars: &Reporter) -> Result<RaycastAo> {
    request.settings.validate()?;
    let mut ao = AmbientOcclusion::for_scene(device, scene)?.with_progress(bars.clone());
    ao.prepare()?;
    let vertices = match request.vertices {
        true => Some(ao.vertices(&request.settings)?),
        false => None,
    };
    let image = match &request.image {
        Some(view) => Some(ao.image(view, &request.settings)?),
        None => None,
    };
    Ok(RaycastAo::of(&ao, vertices, image))
}

impl RaycastAo {
    /// `vertices` and `image` (computed by `ao`, or by the shards of a job
    /// and read back) with what `ao` knows of its casters.
    pub fn of(ao: &AmbientOcclusion, vertices: Option<VertexAo>, image: Option<PixelAo>) -> RaycastAo {
        RaycastAo {
            caster_triangles: ao.caster_triangles(),
            cutout_triangles: ao.cutout_triangles(),
            warnings: ao.warnings().to_vec(),
            build_ms: ao.build_ms(),
            bvh: ao.bvh_stats().cloned(),
            vertices,
            image,
        }
    }
}

/// The casters at `frame`, merged; an error if there are none.
pub fn casters(scene: &Scene, frame: u32) -> Result<Mesh> {
    let mesh = scene.world_mesh_at(frame, Role::casts);
    if mesh.triangles.is_empty() {
        return Err(Error::param("scene", "no instance is a caster: nothing occludes"));
    }
    Ok(mesh)
}

/// The receivers at `frame`, merged; an error if there are none.
pub fn receivers(scene: &Scene, frame: u32) -> Result<Mesh> {
    let mesh = scene.world_mesh_at(frame, Role::receives);
    if mesh.triangles.is_empty() {
        return Err(Error::param("scene", "no instance is a receiver: no vertices to shade"));
    }
    Ok(mesh)
}

/// Writes per-vertex AO of the receivers at `frame` to `path`: CSV, or
/// the receivers' mesh with AO as vertex colours for a `.ply` name
/// (`crate::io::vertex`).
pub fn write_vertex_ao(path: &std::path::Path, scene: &Scene, frame: u32, ao: &[f32]) -> Result<()> {
    match crate::io::vertex::VertexFormat::of(path) {
        crate::io::vertex::VertexFormat::Csv => crate::io::vertex::write_ao_csv(path, ao),
        crate::io::vertex::VertexFormat::Ply => crate::io::vertex::write_ao_ply(path, &receivers(scene, frame)?, ao),
    }
}

/// AO at most this everywhere, with an infinite radius, earns a warning.
pub const NEAR_ZERO: f32 = 0.02;

/// A warning when every value of `ao` is near 0 with no `radius`: every
/// ray hits something, as inside a closed scene (a room), where AO with an
/// infinite radius is 0 everywhere and says nothing; it suggests a tenth
/// of the scene's bounding-box diagonal as `radius`.
pub fn near_zero_warning(ao: &[f32], radius: Option<f32>, scene: &Scene) -> Option<String> {
    let most = ao.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    if radius.is_some_and(f32::is_finite) || ao.is_empty() || most > NEAR_ZERO {
        return None;
    }
    let size = scene.world_mesh(|_| true).bounds().diagonal();
    Some(format!(
        "warning: AO is at most {most:.3} everywhere: with the default infinite `radius` every ray hits something, \
         as inside a closed scene (a room); give a finite `radius` for local occlusion, e.g. `radius` {:.3} \
         (a tenth of the scene's size)",
        0.1 * size
    ))
}

/// The AO points of the pixels a view sees, from `tracer`'s closest hits
/// on `everything` (the scene at that moment).
pub struct VisiblePoints {
    /// The view's camera, completed.
    pub camera: Camera,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The primary rays through the pixel centres, row by row from the top.
    pub rays: Vec<Ray>,
    /// Closest hit per pixel.
    pub hits: Timed<Vec<crate::geom::ray::Hit>>,
    /// One point per pixel hit, in pixel order (`stream` = pixel index).
    pub points: Vec<AoPoint>,
}

/// The points of `view` on `everything` (the scene's camera fills in what
/// the view leaves out).
pub fn visible_points(
    tracer: &mut Tracer,
    everything: &Mesh,
    scene_camera: Option<Camera>,
    view: &View,
) -> Result<VisiblePoints> {
    let camera = view
        .camera
        .resolve(scene_camera, &everything.bounds(), everything.origin)?;
    let rays = camera.primary_rays(view.width, view.height);
    let hits = tracer.closest(&rays)?;
    let points = hit_points(everything, &rays, &hits.value, everything.origin_offset());
    Ok(VisiblePoints {
        camera,
        width: view.width,
        height: view.height,
        rays,
        hits,
        points,
    })
}

impl VisiblePoints {
    /// Per-pixel values from one AO value per point.
    pub fn image(&self, ao: &[f32], ms: f64) -> PixelAo {
        let mut values = vec![None; self.rays.len()];
        for (p, a) in self.points.iter().zip(ao) {
            values[p.stream as usize] = Some(*a);
        }
        PixelAo {
            values,
            camera: self.camera,
            width: self.width,
            height: self.height,
            ms,
        }
    }
}

/// Mean of `v` in f64 (0 for none).
pub fn mean(v: &[f32]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
}
