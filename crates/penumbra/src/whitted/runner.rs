//! The Whitted renderer as a host and the CLI drive it: a scene made ready
//! once on a device (its kd-tree built and, on a GPU, uploaded with its
//! shading data), then images of it from any camera, with their ray counts
//! and time; single rays with their ray trees for the bounded-error method.

use glam::Vec3;
use serde::Serialize;

use super::gpu::WhittedBatches;
use super::packets::render_packets;
use super::ray_tree::RayTree;
use super::scene::RenderScene;
use super::tree_records::{self, RecordedTree, TreeLayout, TreeRay};
use super::whitted::{FRESNEL, MAX_DEPTH, Media, PixelOut, Whitted, WhittedUniforms, pixel_ray};
use crate::accel::kdtree::KdTree;
use crate::accel::kdtree::gpu::GpuKdTree;
use crate::error::{Error, Result};
use crate::geom::aabb::Aabb;
use crate::gpu::device::{Device, GpuOutput, OnDevice, Timing};
use crate::mlrta::prepared::PreparedTables;
use crate::mlrta::{MlrtaSettings, Prepared};
use crate::progress::{Bar, Reporter};
use crate::raycast::tracer::{build_tree, tree_params};
use crate::report::mrays_per_s;
use crate::scene::Camera;

/// The knobs of a render.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WhittedSettings {
    /// Deepest reflection/refraction (0: primary rays and shadows only).
    pub max_depth: u32,
    /// Samples per pixel: 1 through the pixel's centre, more jittered.
    pub spp: u32,
    /// Seeds the jitter.
    pub seed: u32,
    /// Fresnel-weighted (Schlick) reflection and transmission instead of
    /// the materials' constant coefficients.
    pub fresnel: bool,
    /// On the CPU, MLRTA packets for primary rays and point lights' shadow
    /// rays, or every ray alone as the GPU does: the same image, at
    /// different speeds (`Packets`).
    pub packets: Packets,
}

/// Whether the CPU path traces primary and point lights' shadow rays as
/// MLRTA packets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Packets {
    /// Packets from 8192 triangles up (PACKETS_FROM_TRIANGLES), single rays below.
    #[default]
    Auto,
    /// Always packets.
    On,
    /// Every ray alone.
    Off,
}

/// From this many triangles `Packets::Auto` traces packets. Thirty-frame
/// walks at 640x480, one thread, alternated (docs/results/whitted.md):
/// single rays win on the textured checker-spheres (2 triangles, 9 to
/// 17%), grazing (3,212, 16%), cow (5,804, 14%) and teapot (6,320, 20%);
/// packets win on cornell-mirror-glass (3,992, 2 to 7%: the one scene
/// this threshold misjudges), the tessellated twin (11,906, 9 to 14%),
/// the kitchen interior (56,939, 10 to 30%) and the bunny (69,451, 3 to
/// 10%). What decides is how much of the image a deep tree covers, which
/// the count only roughly tells.
pub const PACKETS_FROM_TRIANGLES: usize = 8192;

impl Packets {
    /// Whether a tree of `triangles` triangles is traced with packets.
    pub fn used(self, triangles: usize) -> bool {
        match self {
            Packets::On => true,
            Packets::Off => false,
            Packets::Auto => triangles >= PACKETS_FROM_TRIANGLES,
        }
    }
}

impl Default for WhittedSettings {
    fn default() -> Self {
        WhittedSettings {
            max_depth: 5,
            spp: 1,
            seed: crate::geom::sampling::DEFAULT_SEED,
            fresnel: false,
            packets: Packets::Auto,
        }
    }
}

/// Most samples per pixel.
pub const MAX_SPP: u32 = 4096;

impl WhittedSettings {
    /// Checks that `max_depth` is at most `MAX_DEPTH` and `spp` is between
    /// 1 and `MAX_SPP`.
    pub fn validate(&self) -> Result<()> {
        if self.max_depth > MAX_DEPTH {
            return Err(Error::param(
                "max_depth",
                format!("must be at most {MAX_DEPTH}, got {}", self.max_depth),
            ));
        }
        if self.spp == 0 || self.spp > MAX_SPP {
            return Err(Error::param(
                "spp",
                format!("must be between 1 and {MAX_SPP}, got {}", self.spp),
            ));
        }
        Ok(())
    }
}

/// Rays traced, by kind.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct RayCounts {
    /// Eye rays: one per sample.
    pub primary: u64,
    /// Shadow rays: one per lit hit and light that does not face away, and
    /// in a scene with glass one more per transmitting surface it passes
    /// (each segment counts).
    pub shadow: u64,
    /// Mirror reflections traced.
    pub reflection: u64,
    /// Transmitted rays traced (refracted, or straight through a dissolved
    /// surface).
    pub refraction: u64,
}

impl RayCounts {
    /// Rays of every kind.
    pub fn total(&self) -> u64 {
        self.primary + self.shadow + self.reflection + self.refraction
    }

    /// The rays of `pixels`, summed by kind.
    pub fn of(pixels: &[PixelOut]) -> RayCounts {
        let mut c = [0u64; 4];
        for p in pixels {
            for (sum, &r) in c.iter_mut().zip(&p.rays) {
                *sum += r as u64;
            }
        }
        RayCounts {
            primary: c[0],
            shadow: c[1],
            reflection: c[2],
            refraction: c[3],
        }
    }
}

/// What a render measured.
#[derive(Debug, Clone, Serialize)]
pub struct RenderStats {
    /// Rays traced, summed over the pixels.
    pub rays: RayCounts,
    /// Milliseconds of the render: kernel time from GPU timestamps where the
    /// device has them, else wall-clock time (`timing` says which).
    pub render_ms: f64,
    /// How `render_ms` was measured.
    pub timing: Timing,
    /// All rays (primary, shadow and secondary) per second of `render_ms`.
    pub mrays_per_s: f64,
    /// `WhittedSettings::max_depth` of the render.
    pub max_depth: u32,
    /// `WhittedSettings::spp` of the render.
    pub spp: u32,
    /// Which path traced the rays: "gpu", "cpu-packets" or "cpu-single".
    pub path: &'static str,
}

/// An image and its statistics.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The camera it was rendered through, in the scene's frame.
    pub camera: Camera,
    /// Row-major, row 0 at the top.
    pub pixels: Vec<PixelOut>,
    /// Rays, time and the settings that matter for them.
    pub stats: RenderStats,
}

impl Rendered {
    /// Linear radiance per pixel.
    pub fn radiance(&self) -> Vec<Vec3> {
        self.pixels.iter().map(|p| Vec3::from_array(p.radiance)).collect()
    }
}

impl RenderScene {
    /// The Whitted kernel's parameters (and the CPU twin's) for the whole
    /// `width` x `height` image of `camera` rendered with `settings`: what
    /// `WhittedPass::prepare` takes, for a host that records the pass
    /// itself (its `first_pixel` and `pixel_count` give the batch).
    pub fn params(
        &self,
        camera: &Camera,
        width: u32,
        height: u32,
        settings: &WhittedSettings,
    ) -> Result<WhittedUniforms> {
        settings.validate()?;
        crate::scene::check_image_size(width, height)?;
        camera.validate()?;
        let (right, up, forward) = camera.basis();
        let tan_half = (0.5 * camera.fov_degrees.to_radians()).tan();
        let aspect = width as f32 / height as f32;
        let media = self.media_at(camera.eye);
        let mut ids = [0u32; 4];
        for (slot, &m) in ids.iter_mut().zip(&media) {
            *slot = m;
        }
        let (_, at) = super::gpu::scene_records(self);
        Ok(WhittedUniforms {
            eye: camera.eye.to_array(),
            width,
            forward: forward.to_array(),
            height,
            right: (right * (tan_half * aspect)).to_array(),
            spp: settings.spp,
            up: (up * tan_half).to_array(),
            seed: settings.seed,
            ambient: self.ambient.to_array(),
            max_depth: settings.max_depth,
            background: self.background.to_array(),
            flags: if settings.fresnel { FRESNEL } else { 0 },
            media: ids,
            media_len: media.len().min(4) as u32,
            light_count: self.lights.len() as u32,
            sphere_count: self.spheres.len() as u32,
            transmissive: self.transmissive as u32,
            first_pixel: 0,
            pixel_count: width * height,
            row_pitch: 0,
            lights_at: at.lights,
            spheres_at: at.spheres,
            tree_capacity: 0,
            tree_stride: 0,
            maps_at: at.maps,
        })
    }
}

/// What the renderer keeps on a GPU.
pub struct GpuWhitted {
    tree: GpuKdTree,
    pass: WhittedBatches,
}

/// A scene ready to render on a device.
pub struct WhittedRenderer {
    scene: RenderScene,
    tree: KdTree,
    /// The CPU packets' tables over `tree`, prepared on first use.
    prepared: Option<PreparedTables>,
    gpu: OnDevice<GpuWhitted>,
    /// The kd-tree's build time.
    pub build_ms: f64,
    /// Preparing the CPU packets' tables (occluders, closed objects) once.
    pub prepare_ms: f64,
}

impl WhittedRenderer {
    /// A renderer of `scene` (its materials as its OBJ/MTL or glTF files
    /// give them, its lights, its first frame) on `device`, lit with the
    /// default lighting.
    ///
    /// ```
    /// use penumbra::{Device, Scene, WhittedRenderer, WhittedSettings};
    /// use penumbra::scene::procedural::sphere_on_plane;
    ///
    /// let scene = Scene::from_mesh("sphere", "sphere.obj".as_ref(), sphere_on_plane());
    /// let mut renderer = WhittedRenderer::for_scene(&Device::cpu(), &scene)?;
    /// let camera = scene.camera_in(&Default::default(), &renderer.bounds())?;
    /// let image = renderer.image(&camera, 64, 48, &WhittedSettings::default())?;
    /// assert_eq!(image.radiance().len(), 64 * 48);
    /// # Ok::<(), penumbra::Error>(())
    /// ```
    pub fn for_scene(device: &Device, scene: &crate::scene::Scene) -> Result<WhittedRenderer> {
        let render_scene = RenderScene::new(scene, 0, &super::LightingSettings::default())?;
        WhittedRenderer::new(device, render_scene, &Reporter::silent())
    }

    /// Builds the scene's kd-tree and, on a GPU, uploads it with the
    /// scene, following the build with `bars`.
    pub fn new(device: &Device, scene: RenderScene, bars: &Reporter) -> Result<WhittedRenderer> {
        let tree = build_tree(&scene.mesh, &tree_params(device), bars, "raytrace")?;
        let gpu = device.prepare(|ctx| {
            let tree = GpuKdTree::upload(&ctx.device, &tree)?;
            let mut pass = WhittedBatches::new(ctx);
            pass.pass.prepare_scene(&ctx.device, &ctx.queue, &scene)?;
            Ok(GpuWhitted { tree, pass })
        })?;
        // The CPU path's packets need the tree's occluders; prepared once
        // here, not in the first image's time.
        let (prepared, prepare_ms) = if gpu.state().is_none() {
            let (p, stats) = Prepared::new(&tree, &scene.mesh);
            (Some(p.into_tables()), stats.prepare_ms)
        } else {
            (None, 0.0)
        };
        Ok(WhittedRenderer {
            build_ms: tree.stats.build_ms,
            prepare_ms,
            scene,
            tree,
            prepared,
            gpu,
        })
    }

    /// The scene as it renders: triangles with their surfaces, spheres and
    /// lights.
    pub fn scene(&self) -> &RenderScene {
        &self.scene
    }

    /// The GPU images render on, if any.
    pub fn context(&self) -> Option<&crate::gpu::GpuContext> {
        match &self.gpu {
            OnDevice::Gpu { ctx, .. } => Some(ctx),
            OnDevice::Cpu => None,
        }
    }

    /// Whether images render on a GPU.
    pub fn is_gpu(&self) -> bool {
        self.gpu.state().is_some()
    }

    /// The kd-tree over the scene's triangles (spheres are tested apart).
    pub fn tree(&self) -> &KdTree {
        &self.tree
    }

    /// Bounds of the triangles and spheres (for the default camera).
    pub fn bounds(&self) -> Aabb {
        let mut b = self.scene.mesh.bounds();
        for s in &self.scene.spheres {
            b = b
                .grow(s.center() - Vec3::splat(s.radius))
                .grow(s.center() + Vec3::splat(s.radius));
        }
        b
    }

    /// The kernel's parameters for an image of `camera`
    /// (`RenderScene::params`).
    pub fn params(
        &self,
        camera: &Camera,
        width: u32,
        height: u32,
        settings: &WhittedSettings,
    ) -> Result<WhittedUniforms> {
        self.scene.params(camera, width, height, settings)
    }

    /// Of a coarse grid of `camera`'s primary rays (32 x 24 across an
    /// image of `width` x `height`), how many hit something and how many
    /// of those meet the back of a face (the side its winding faces away
    /// from). A camera framing a room from outside sees mostly backs of
    /// walls: the command line warns then.
    pub fn back_faces(&self, camera: &Camera, width: u32, height: u32) -> Result<(u32, u32)> {
        let settings = WhittedSettings::default();
        let params = self.params(camera, width, height, &settings)?;
        let twin = self.twin(&params);
        let (mut hits, mut backs) = (0, 0);
        for j in 0..24 {
            for i in 0..32 {
                let (x, y) = ((2 * i + 1) * width / 64, (2 * j + 1) * height / 48);
                let (o, d) = super::whitted::pixel_ray(&params, y * width + x, 0);
                if let Some((t, primitive)) = twin.closest(o, d, f32::INFINITY, None) {
                    hits += 1;
                    if primitive < self.scene.triangles.len() as u32 {
                        backs += (d.dot(twin.hit_info(o, d, t, primitive).geometric) > 0.0) as u32;
                    }
                }
            }
        }
        Ok((hits, backs))
    }

    /// The CPU twin over this scene for `params`.
    pub fn twin<'a>(&'a self, params: &'a WhittedUniforms) -> Whitted<'a> {
        Whitted {
            scene: &self.scene,
            tree: &self.tree,
            params,
        }
    }

    /// An image of `camera`, `width` x `height` pixels, rendered with
    /// `settings` (`render` without following its rows).
    pub fn image(&mut self, camera: &Camera, width: u32, height: u32, settings: &WhittedSettings) -> Result<Rendered> {
        self.render(camera, width, height, settings, &Bar::hidden())
    }

    /// Renders an image of `camera`: on a GPU the kernel, on the CPU the
    /// twin (through packets where `settings.packets` says so for this
    /// scene's tree).
    pub fn render(
        &mut self,
        camera: &Camera,
        width: u32,
        height: u32,
        settings: &WhittedSettings,
        progress: &Bar,
    ) -> Result<Rendered> {
        self.render_rows(camera, (width, height), 0..height, settings, progress)
    }

    /// The rows `rows` of the image `render` gives (a band of a large
    /// image, as a shard renders it): each pixel bit for bit the one of the
    /// whole image, on the same path. `pixels` holds the band's rows only;
    /// `width` and `height` are the whole image's.
    pub fn render_rows(
        &mut self,
        camera: &Camera,
        (width, height): (u32, u32),
        rows: std::ops::Range<u32>,
        settings: &WhittedSettings,
        progress: &Bar,
    ) -> Result<Rendered> {
        let mut params = self.params(camera, width, height, settings)?;
        if rows.start > rows.end || rows.end > height {
            let problem = format!("rows {rows:?} of an image {height} rows high");
            return Err(crate::error::Error::param("rows", problem));
        }
        params.first_pixel = rows.start * width;
        params.pixel_count = (rows.end - rows.start) * width;
        let (scene, tree, tables) = (&self.scene, &self.tree, &mut self.prepared);
        let twin = Whitted {
            scene,
            tree,
            params: &params,
        };
        let packets = settings.packets.used(self.tree.triangles.len());
        let cpu_path = if packets { "cpu-packets" } else { "cpu-single" };
        let path = if self.gpu.state().is_some() { "gpu" } else { cpu_path };
        let timed = self.gpu.run(
            |ctx, g| {
                let (pixels, gpu_ms) = g.pass.render(ctx, &g.tree, &params, progress)?;
                Ok(GpuOutput { value: pixels, gpu_ms })
            },
            || {
                if packets {
                    let prepared = match tables.take() {
                        Some(t) => Prepared::from_tables(tree, t),
                        None => Prepared::new(tree, &scene.mesh).0,
                    };
                    // Corner rays bound a tile's rays only through pixel
                    // centres; jittered edge pixels may leave that frustum.
                    let mlrta = MlrtaSettings {
                        corner_frusta: settings.spp == 1,
                        ..MlrtaSettings::default()
                    };
                    let pixels = render_packets(&twin, &prepared, &mlrta);
                    *tables = Some(prepared.into_tables());
                    Ok(pixels?.0)
                } else {
                    use rayon::prelude::*;
                    Ok((params.first_pixel..params.first_pixel + params.pixel_count)
                        .into_par_iter()
                        .with_min_len(64)
                        .map(|i| twin.whitted(i))
                        .collect())
                }
            },
        )?;
        let rays = RayCounts::of(&timed.value);
        Ok(Rendered {
            width,
            height,
            camera: *camera,
            stats: RenderStats {
                rays,
                render_ms: timed.ms,
                timing: timed.timing,
                mrays_per_s: mrays_per_s(rays.total() as usize, timed.ms),
                max_depth: settings.max_depth,
                spp: settings.spp,
                path,
            },
            pixels: timed.value,
        })
    }

    /// Renders only the pixels `list` (indices into the row-major image
    /// `params` describes, any order) and returns them in the list's order:
    /// on a GPU the kernel's `whitted_listed` entry, on the CPU the twin one
    /// ray at a time. Each pixel is the one `render` gives on a GPU, and the
    /// single-ray path's on the CPU, bit for bit. The bounded renderer's
    /// slow path on a GPU.
    pub fn render_listed(
        &mut self,
        params: &WhittedUniforms,
        list: &[u32],
        progress: &Bar,
    ) -> Result<crate::gpu::device::Timed<Vec<PixelOut>>> {
        super::whitted::check_pixels(params, list)?;
        let twin = Whitted {
            scene: &self.scene,
            tree: &self.tree,
            params,
        };
        self.gpu.run(
            |ctx, g| {
                let (pixels, gpu_ms) = g.pass.render_listed(ctx, &g.tree, params, list, progress)?;
                Ok(GpuOutput { value: pixels, gpu_ms })
            },
            || {
                use rayon::prelude::*;
                Ok(list.par_iter().with_min_len(64).map(|&i| twin.whitted(i)).collect())
            },
        )
    }

    /// The radiance, root diffuse terms and ray tree of each of `rays`, in
    /// air from its given root hit, through the kernel's `whitted_trees`
    /// entry (blocking; `Ok(None)` on the CPU, where the caller traces them
    /// with the twin, `Whitted::trace_tree`). A ray whose tree does not fit
    /// its slot comes back `None`; a ray `tree_records::check_rays` rejects
    /// is an error (exit 2), on either device.
    pub fn trace_trees(
        &mut self,
        params: &WhittedUniforms,
        rays: &[TreeRay],
    ) -> Result<Option<Vec<Option<RecordedTree>>>> {
        let primitives = (self.scene.triangles.len() + self.scene.spheres.len()) as u32;
        tree_records::check_rays(rays, primitives)?;
        let OnDevice::Gpu { ctx, state: g } = &mut self.gpu else {
            return Ok(None);
        };
        let layout = TreeLayout::new(params.max_depth, params.light_count);
        let (slots, _) = g
            .pass
            .trace_trees(ctx, &g.tree, params, &layout, rays, &Bar::hidden())?;
        let trees = slots
            .chunks_exact(layout.slot_words4())
            .map(|slot| tree_records::decode(&layout, slot))
            .collect();
        Ok(Some(trees))
    }

    /// The radiance and ray tree of sample `sample` of pixel (x, y) of an
    /// image of `camera` (CPU).
    pub fn pixel_tree(
        &self,
        camera: &Camera,
        (width, height): (u32, u32),
        settings: &WhittedSettings,
        (x, y, sample): (u32, u32, u32),
    ) -> Result<(Vec3, RayTree)> {
        let params = self.params(camera, width, height, settings)?;
        if x >= width || y >= height {
            return Err(Error::param(
                "pixel",
                format!("({x}, {y}) is outside the {width}x{height} image"),
            ));
        }
        let (o, d) = pixel_ray(&params, y * width + x, sample);
        let media = Media::from_ids(&params.media[..params.media_len as usize]);
        let mut tree = RayTree::default();
        let out = self.twin(&params).shade(o, d, media, None, Some(&mut tree));
        Ok((out.radiance, tree))
    }

    /// The radiance and ray tree of any ray from `origin` along `dir`
    /// (normalised here), starting in the media around `origin` (CPU).
    pub fn ray_tree(&self, origin: Vec3, dir: Vec3, settings: &WhittedSettings) -> Result<(Vec3, RayTree)> {
        let camera = Camera {
            eye: origin,
            target: origin + dir,
            fov_degrees: 45.0,
        };
        let params = self.params(&camera, 1, 1, settings)?;
        let media = Media::from_ids(&params.media[..params.media_len as usize]);
        let mut tree = RayTree::default();
        let out = self
            .twin(&params)
            .shade(origin, dir.normalize(), media, None, Some(&mut tree));
        Ok((out.radiance, tree))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_packets_start_at_the_threshold_and_on_off_are_obeyed() {
        for triangles in [0, 2, PACKETS_FROM_TRIANGLES - 1, PACKETS_FROM_TRIANGLES, 1 << 20] {
            assert!(Packets::On.used(triangles));
            assert!(!Packets::Off.used(triangles));
            assert_eq!(Packets::Auto.used(triangles), triangles >= PACKETS_FROM_TRIANGLES);
        }
        assert_eq!(WhittedSettings::default().packets, Packets::Auto);
    }
}
