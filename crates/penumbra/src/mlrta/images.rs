//! The images a traced view can be written as: the shading, the paper's
//! tile map (its figure 7), where anti-aliasing put its rays, and the
//! primary rays themselves (so another tracer can run exactly them).

use std::path::Path;

use super::runner::TracedImage;
use crate::error::Result;
use crate::io::image::{Background, GreyStyle, PngBits, write_grey, write_rgb_png};
use crate::io::rays::write_rays;
use crate::scene::Mesh;

/// Where each image goes; `None`: not wanted.
#[derive(Debug, Clone, Copy, Default)]
pub struct TraceImages<'a> {
    /// |cos| between the ray and the hit triangle, shadowed hits at a quarter.
    pub shading: Option<&'a Path>,
    /// The final tiles (packets only; PNG).
    pub tiles: Option<&'a Path>,
    /// Rays per pixel of anti-aliasing (with AA only).
    pub aa_rays: Option<&'a Path>,
    /// The primary rays, in the ray-file format.
    pub rays: Option<&'a Path>,
    /// What the shading and anti-aliasing images show where no surface is:
    /// black (opaque, the default of every grey image) or transparent.
    pub background: Background,
}

impl TraceImages<'_> {
    /// Writes what `image` (of `mesh`) has of the wanted images.
    pub fn write(&self, image: &TracedImage, mesh: &Mesh) -> Result<()> {
        let (w, h) = (image.width, image.height);
        let style = GreyStyle {
            bits: PngBits::Eight,
            background: self.background,
        };
        if let Some(path) = self.rays {
            write_rays(path, &image.rays)?;
        }
        if let Some(path) = self.tiles.filter(|_| !image.tiles.is_empty()) {
            write_rgb_png(path, w, h, &image.tile_map())?;
        }
        if let (Some(path), Some(rays)) = (self.aa_rays, image.aa_rays()) {
            write_grey(path, w, h, &rays, style)?;
        }
        if let Some(path) = self.shading {
            write_grey(path, w, h, &image.shading(mesh), style)?;
        }
        Ok(())
    }
}
