//! What a ray-traced animation reports and writes: the fields every
//! `raytrace` report has, a pixel's ray tree, and the frames' images
//! (every frame where the output name holds `{}`, else the last).

use std::path::PathBuf;

use glam::Vec3;
use serde::Serialize;

use super::ray_tree::RayNode;
use super::runner::{WhittedRenderer, WhittedSettings};
use crate::error::Result;
use crate::io::image::write_radiance;
use crate::io::output::frame_output;
use crate::scene::Camera;
use crate::scene::mtl_rules::RuleApplied;

/// Which ray tracer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum RaytraceMethod {
    /// Exact Whitted ray tracing (section 3 of the bounded-error paper).
    Whitted,
    /// Radiance interpolants within a relative error bound (--epsilon).
    Bounded,
}

/// The fields of every `raytrace` report.
#[derive(Debug, Clone, Serialize)]
pub struct RenderReport {
    /// Which ray tracer rendered the frames.
    pub method: RaytraceMethod,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Frames rendered.
    pub frames: u32,
    /// `WhittedSettings::max_depth`.
    pub max_depth: u32,
    /// `WhittedSettings::spp`.
    pub spp: u32,
    /// `WhittedSettings::fresnel`.
    pub fresnel: bool,
    /// Wall-clock milliseconds of the kd-tree's build
    /// (`WhittedRenderer::build_ms`).
    pub build_ms: f64,
    /// Wall-clock milliseconds of preparing the CPU packets' tables (0 on a
    /// GPU; `WhittedRenderer::prepare_ms`).
    pub prepare_ms: f64,
    /// Triangles of the scene's instances together (one placeholder, never
    /// hit, in a scene of spheres alone).
    pub triangles: usize,
    /// Analytic spheres.
    pub spheres: usize,
    /// Lights, emissive polygons' samples included.
    pub lights: usize,
    /// Emissive polygons made into lights.
    pub emitters: usize,
    /// The last frame's camera, in world coordinates.
    pub camera: Camera,
    /// Warnings of the scene's files and of preparing it for rendering.
    pub warnings: usize,
    /// The MTL rules that read materials as their exporters meant, each
    /// with the materials it changed (`RenderScene::material_rules`).
    pub material_rules: Vec<RuleApplied>,
}

impl RenderReport {
    /// `frames` of `size` rendered by `renderer` with `settings`, the last
    /// through `camera`; `load_warnings`: the files' warnings.
    pub fn new(
        method: RaytraceMethod,
        renderer: &WhittedRenderer,
        settings: &WhittedSettings,
        ((width, height), frames): ((u32, u32), u32),
        camera: Camera,
        load_warnings: usize,
    ) -> Self {
        let scene = renderer.scene();
        RenderReport {
            method,
            width,
            height,
            frames,
            max_depth: settings.max_depth,
            spp: settings.spp,
            fresnel: settings.fresnel,
            build_ms: renderer.build_ms,
            prepare_ms: renderer.prepare_ms,
            triangles: scene.mesh.triangles.len(),
            spheres: scene.spheres.len(),
            lights: scene.lights.len(),
            emitters: scene.emitters,
            // In world coordinates, as the scene file and `--eye` give it
            // (the renderer works in the scene's recentred frame).
            camera: camera.in_world(scene.mesh.origin),
            warnings: load_warnings + scene.warnings.len(),
            material_rules: scene.material_rules.clone(),
        }
    }
}

/// The ray tree of one pixel's first sample, with the objects it meets.
#[derive(Debug, Clone, Serialize)]
pub struct PixelTree {
    /// The pixel, `[x, y]` from the top left.
    pub pixel: [u32; 2],
    /// The sample's radiance.
    pub radiance: [f32; 3],
    /// The tree's topology signature (`RayTree::signature`).
    pub signature: u32,
    /// The names of the objects its rays hit, each once, in order (`None`
    /// for an id the scene does not name).
    pub objects: Vec<Option<String>>,
    /// The tree's rays, root first (`RayTree::nodes`).
    pub nodes: Vec<RayNode>,
}

impl WhittedRenderer {
    /// The ray tree of pixel (x, y)'s first sample in an image of `camera` (CPU).
    pub fn pixel_tree_report(
        &self,
        camera: &Camera,
        size: (u32, u32),
        settings: &WhittedSettings,
        (x, y): (u32, u32),
    ) -> Result<PixelTree> {
        let (radiance, tree) = self.pixel_tree(camera, size, settings, (x, y, 0))?;
        let names = &self.scene().objects;
        Ok(PixelTree {
            pixel: [x, y],
            radiance: radiance.to_array(),
            signature: tree.signature(),
            objects: tree.objects().iter().map(|&o| names.get(o as usize).cloned()).collect(),
            nodes: tree.nodes,
        })
    }
}

/// Where an animation's images go: `out` names every frame's file where
/// it holds `{}` (or `{:04}`), else the last frame's.
#[derive(Debug, Clone)]
pub struct FrameImages {
    /// The image file name, `{}` or `{:04}` standing for the frame number;
    /// `None` writes no image.
    pub out: Option<PathBuf>,
    /// Width and height in pixels.
    pub size: (u32, u32),
    /// PNG only: radiance is multiplied by this before clamping to [0, 1].
    pub exposure: f32,
}

impl FrameImages {
    /// Writes frame `f` of `frames` where an image of it is asked for.
    pub fn frame(&self, (f, frames): (u32, u32), radiance: &[Vec3]) -> Result<()> {
        match self.out.as_deref().and_then(|t| frame_output(t, f, f + 1 == frames)) {
            Some(p) => write_radiance(&p, self.size.0, self.size.1, radiance, self.exposure),
            None => Ok(()),
        }
    }
}
