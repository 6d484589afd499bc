//! The images of a PRT animation: each frame's vertex radiance rendered
//! through the camera (`render::render_radiance`) and written where asked:
//! a folder of every frame, and `--out`'s file (every frame where its name
//! holds `{}`, else the last). Exposure is fixed on the first frame drawn,
//! so an animation does not flicker.

use std::path::{Path, PathBuf};

use glam::Vec3;

use super::render::{auto_exposure, render_radiance};
use crate::error::{Error, Result};
use crate::io::image::write_radiance;
use crate::io::output::frame_output;
use crate::scene::{Camera, EnvironmentMap};

/// Where and how the frames of a PRT animation are drawn; [`FrameImages::frame`]
/// writes each frame's images.
pub struct FrameImages<'a> {
    /// A folder for frame-0000.png, frame-0001.png, ...
    pub folder: Option<&'a Path>,
    /// One image, or one per frame where the name holds `{}`.
    pub out: Option<&'a Path>,
    /// Width and height of every image, pixels.
    pub size: (u32, u32),
    /// RGB albedo the transfer's albedo-1 radiance is multiplied by
    /// (non-negative).
    pub albedo: Vec3,
    /// `None`: the first frame drawn sets it (`auto_exposure`).
    pub exposure: Option<f32>,
    /// The background.
    pub env: &'a EnvironmentMap,
    /// The camera every frame is seen through.
    pub camera: Camera,
    /// Images written so far.
    pub written: usize,
}

impl<'a> FrameImages<'a> {
    /// Nothing written yet; `exposure` None: the first frame drawn sets it.
    pub fn new(
        (folder, out): (Option<&'a Path>, Option<&'a Path>),
        size: (u32, u32),
        albedo: Vec3,
        exposure: Option<f32>,
        env: &'a EnvironmentMap,
        camera: Camera,
    ) -> FrameImages<'a> {
        FrameImages {
            folder,
            out,
            size,
            albedo,
            exposure,
            env,
            camera,
            written: 0,
        }
    }

    /// Refuses a non-positive exposure, a negative albedo and a frames'
    /// `folder` that is not one.
    pub fn check(exposure: Option<f32>, albedo: Vec3, folder: Option<&Path>) -> Result<()> {
        if let Some(dir) = folder
            && !dir.is_dir()
        {
            return Err(Error::param("out_frames", format!("{} is not a folder", dir.display())));
        }
        if let Some(e) = exposure
            && !(e.is_finite() && e > 0.0)
        {
            return Err(Error::param("exposure", format!("must be positive, got {e}")));
        }
        if albedo.min_element() < 0.0 || !albedo.is_finite() {
            return Err(Error::param("albedo", "must be non-negative and finite"));
        }
        Ok(())
    }

    /// Draws and writes frame `f` of `frames` where an image of it is asked for.
    pub fn frame(
        &mut self,
        (f, frames): (usize, usize),
        (positions, triangles): (&[Vec3], &[[u32; 3]]),
        radiance: &[[f32; 3]],
    ) -> Result<()> {
        let last = f + 1 == frames;
        let paths: Vec<PathBuf> = [
            self.folder.map(|d| d.join(format!("frame-{f:04}.png"))),
            self.out.and_then(|p| frame_output(p, f as u32, last)),
        ]
        .into_iter()
        .flatten()
        .collect();
        if paths.is_empty() {
            return Ok(());
        }
        let exposure = *self
            .exposure
            .get_or_insert_with(|| auto_exposure(radiance, self.albedo));
        let (w, h) = self.size;
        let env = Some(self.env);
        let image = render_radiance(positions, triangles, radiance, self.albedo, env, &self.camera, w, h)?;
        for path in &paths {
            write_radiance(path, w, h, &image, exposure)?;
            self.written += 1;
        }
        Ok(())
    }
}
