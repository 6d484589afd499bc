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

/// The fields of every `raytrace` report.
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

#[derive(Debug, Clone, Serialize)]
pub struct RenderReport {
    pub method: RaytraceMethod,
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    pub max_depth: u32,
    pub spp: u32,
    pub fresnel: bool,
    pub build_ms: f64,
    pub prepare_ms: f64,
    pub triangles: usize,
    pub spheres: usize,
    pub lights: usize,
    pub emitters: usize,
    /// The last frame's camera, in world coordinates.
    pub camera: Camera,
    /// Warnings of the scene's files and of preparing it for rendering.
    pub warnings: usize,
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
        }
    }
}

/// The ray tree of one pixel's first sample, with the objects it meets.
#[derive(Debug, Clone, Serialize)]
pub struct PixelTree {
    pub pixel: [u32; 2],
    pub radiance: [f32; 3],
    pub signature: u32,
    pub objects: Vec<Option<String>>,
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
    pub out: Option<PathBuf>,
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
