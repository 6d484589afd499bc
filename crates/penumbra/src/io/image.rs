//! Images out, in the format the file's extension names, checked before
//! any work (`ImageFormat::check`):
//!
//! * `.png`: 8-bit (or 16-bit for grey values, `PngBits`). Radiance is
//!   tone-mapped (times an exposure, clamped to [0, 1], sRGB-encoded);
//!   grey values in [0, 1] (AO, |cos|) are stored linearly, so pixel /
//!   255 (or / 65535) is the value.
//! * `.exr`: OpenEXR, 32-bit float, linear (the `image` crate's encoder):
//!   radiance as it is (no exposure), grey values as R = G = B = value, with
//!   an alpha channel (1 on the surface, 0 elsewhere) when the background is
//!   transparent.
//! * `.pfm`: Portable FloatMap, written here: a three-line header (`PF`
//!   colour or `Pf` grey, width and height, `-1.0` for little-endian) and
//!   raw little-endian floats, bottom row first, as the format says. It has
//!   no alpha channel.
//!
//! Every file goes through `crate::io::output`'s atomic writer.

use std::path::Path;

use glam::Vec3;

use crate::error::{Error, Result};
#[cfg(feature = "png")]
use crate::geom::color::srgb8;

/// The image formats penumbra writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFormat {
    /// `.png`: 8-bit sRGB radiance, or linear 8- or 16-bit grey (the
    /// `png` feature).
    Png,
    /// `.exr`: OpenEXR, linear 32-bit float (the `exr` feature).
    Exr,
    /// `.pfm`: Portable FloatMap, linear 32-bit float, no alpha (always
    /// available).
    Pfm,
}

/// What the formats hold, for error messages.
const ACCEPTED: &str = ".png (8-bit sRGB, or linear grey), .exr or .pfm (linear float)";

impl ImageFormat {
    /// The format `path`'s extension names (case-insensitive); an error
    /// naming `option`, the file and the formats accepted otherwise.
    pub fn check(path: &Path, option: &str) -> Result<ImageFormat> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => ImageFormat::Png.compiled_in(path, option),
            Some("exr") => ImageFormat::Exr.compiled_in(path, option),
            Some("pfm") => Ok(ImageFormat::Pfm),
            _ => Err(Error::param(
                option,
                format!(
                    "{}: unknown image format; the extension must be {ACCEPTED}",
                    path.display()
                ),
            )),
        }
    }

    /// `self` where this build writes it (PNG and EXR sit behind the `png`
    /// and `exr` features), else an error naming the feature, before any
    /// work.
    fn compiled_in(self, path: &Path, option: &str) -> Result<ImageFormat> {
        let (on, feature) = match self {
            ImageFormat::Png => (cfg!(feature = "png"), "png"),
            ImageFormat::Exr => (cfg!(feature = "exr"), "exr"),
            ImageFormat::Pfm => (true, ""),
        };
        if on {
            return Ok(self);
        }
        Err(Error::param(
            option,
            format!(
                "{}: this build of penumbra does not write .{feature} (the `{feature}` cargo feature is off); \
                 use .pfm or enable the feature",
                path.display()
            ),
        ))
    }

    /// `check` for `--out`.
    pub fn of(path: &Path) -> Result<ImageFormat> {
        Self::check(path, "out")
    }

    /// Refuses anything but `.png` (images that are pictures of counts or
    /// categories, with no linear quantity to keep).
    pub fn check_png(path: &Path, option: &str) -> Result<()> {
        match Self::check(path, option)? {
            ImageFormat::Png => Ok(()),
            _ => Err(Error::param(
                option,
                format!(
                    "{}: this image is a colour-coded map; only .png is written",
                    path.display()
                ),
            )),
        }
    }
}

/// The format of a radiance output: the same formats as grey images.
pub type RadianceFormat = ImageFormat;

/// Bits per channel of a grey PNG.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum PngBits {
    #[default]
    #[cfg_attr(feature = "clap", value(name = "8"))]
    #[serde(rename = "8")]
    /// 8 bits: pixel / 255 is the value.
    Eight,
    #[cfg_attr(feature = "clap", value(name = "16"))]
    #[serde(rename = "16")]
    /// 16 bits: pixel / 65535 is the value.
    Sixteen,
}

/// What a grey image shows where no surface is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Background {
    /// Opaque, value 0 (no alpha channel).
    #[default]
    Black,
    /// Alpha 0 (PNG and EXR; PFM has no alpha channel).
    Transparent,
}

/// How a grey image is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GreyStyle {
    /// Bits per channel when the file is a PNG (EXR and PFM are always
    /// 32-bit float).
    pub bits: PngBits,
    /// What pixels without a surface hold.
    pub background: Background,
}

impl GreyStyle {
    /// 8 bits, background transparent where the format has alpha (PNG,
    /// EXR), else black (PFM).
    pub fn keyed(path: &Path) -> GreyStyle {
        let pfm = ImageFormat::check(path, "out").ok() == Some(ImageFormat::Pfm);
        GreyStyle {
            bits: PngBits::Eight,
            background: if pfm {
                Background::Black
            } else {
                Background::Transparent
            },
        }
    }

    /// Checks `path` (named by `option`) before any work: a known format,
    /// and one that can hold the background.
    pub fn check(&self, path: &Path, option: &str) -> Result<ImageFormat> {
        let format = ImageFormat::check(path, option)?;
        if format == ImageFormat::Pfm && self.background == Background::Transparent {
            return Err(Error::param(
                option,
                format!(
                    "{}: PFM has no alpha channel, so the background cannot be transparent; use .png or .exr",
                    path.display()
                ),
            ));
        }
        Ok(format)
    }
}

fn wrong_size() -> Error {
    Error::internal("image of the wrong size")
}

/// Writes grey `values` (row-major, row 0 at the top; `None`: no surface)
/// to `path` in the format its extension names.
pub fn write_grey(path: &Path, width: u32, height: u32, values: &[Option<f32>], style: GreyStyle) -> Result<()> {
    if values.len() != width as usize * height as usize {
        return Err(wrong_size());
    }
    let format = style.check(path, "out")?;
    let transparent = style.background == Background::Transparent;
    match (format, style.bits, transparent) {
        #[cfg(feature = "png")]
        (ImageFormat::Png, PngBits::Eight, false) => {
            let data = values.iter().map(|v| quantise(*v, 255.0) as u8).collect();
            let img = image::GrayImage::from_raw(width, height, data).ok_or_else(wrong_size)?;
            crate::io::output::write_image(path, &img, image::ImageFormat::Png)
        }
        #[cfg(feature = "png")]
        (ImageFormat::Png, PngBits::Eight, true) => {
            let data = values
                .iter()
                .flat_map(|v| [quantise(*v, 255.0) as u8, if v.is_some() { 255 } else { 0 }])
                .collect();
            let img = image::GrayAlphaImage::from_raw(width, height, data).ok_or_else(wrong_size)?;
            crate::io::output::write_image(path, &img, image::ImageFormat::Png)
        }
        #[cfg(feature = "png")]
        (ImageFormat::Png, PngBits::Sixteen, false) => {
            let data = values.iter().map(|v| quantise(*v, 65535.0)).collect();
            let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(width, height, data)
                .ok_or_else(wrong_size)?;
            crate::io::output::write_image(path, &img, image::ImageFormat::Png)
        }
        #[cfg(feature = "png")]
        (ImageFormat::Png, PngBits::Sixteen, true) => {
            let data = values
                .iter()
                .flat_map(|v| [quantise(*v, 65535.0), if v.is_some() { 65535 } else { 0 }])
                .collect();
            let img = image::ImageBuffer::<image::LumaA<u16>, Vec<u16>>::from_raw(width, height, data)
                .ok_or_else(wrong_size)?;
            crate::io::output::write_image(path, &img, image::ImageFormat::Png)
        }
        #[cfg(feature = "exr")]
        (ImageFormat::Exr, _, false) => {
            let data = values.iter().flat_map(|v| [v.unwrap_or(0.0); 3]).collect();
            let img = image::Rgb32FImage::from_raw(width, height, data).ok_or_else(wrong_size)?;
            crate::io::output::write_image(path, &img, image::ImageFormat::OpenExr)
        }
        #[cfg(feature = "exr")]
        (ImageFormat::Exr, _, true) => {
            let data = values
                .iter()
                .flat_map(|v| {
                    let g = v.unwrap_or(0.0);
                    [g, g, g, if v.is_some() { 1.0 } else { 0.0 }]
                })
                .collect();
            let img = image::Rgba32FImage::from_raw(width, height, data).ok_or_else(wrong_size)?;
            crate::io::output::write_image(path, &img, image::ImageFormat::OpenExr)
        }
        (ImageFormat::Pfm, _, _) => {
            let grey: Vec<f32> = values.iter().map(|v| v.unwrap_or(0.0)).collect();
            crate::io::output::write_bytes(path, &pfm_bytes(width, height, 1, &grey))
        }
        #[allow(unreachable_patterns)]
        (format, _, _) => format.compiled_in(path, "out").map(drop),
    }
}

/// `v` in [0, 1] as an integer in [0, `max`]; no surface is 0.
#[cfg(feature = "png")]
fn quantise(v: Option<f32>, max: f32) -> u16 {
    v.map_or(0, |v| (v.clamp(0.0, 1.0) * max).round() as u16)
}

/// A PFM file: `channels` (1 or 3) floats per pixel, rows top first in
/// `data`, written bottom first.
fn pfm_bytes(width: u32, height: u32, channels: usize, data: &[f32]) -> Vec<u8> {
    let magic = if channels == 1 { "Pf" } else { "PF" };
    let mut bytes = format!("{magic}\n{width} {height}\n-1.0\n").into_bytes();
    bytes.reserve(data.len() * 4);
    for row in data.chunks(width as usize * channels).rev() {
        for c in row {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    bytes
}

/// Writes `radiance` (row-major, row 0 at the top) to `path` in the format
/// its extension names; `exposure` scales what a PNG shows.
pub fn write_radiance(path: &Path, width: u32, height: u32, radiance: &[Vec3], exposure: f32) -> Result<()> {
    // Only a tone-mapped PNG uses the exposure.
    let _ = exposure;
    if radiance.len() != width as usize * height as usize {
        return Err(wrong_size());
    }
    match ImageFormat::of(path)? {
        #[cfg(feature = "png")]
        ImageFormat::Png => {
            let mut img = image::RgbImage::new(width, height);
            for (p, l) in img.pixels_mut().zip(radiance) {
                *p = image::Rgb((*l * exposure).to_array().map(srgb8));
            }
            crate::io::output::write_image(path, &img, image::ImageFormat::Png)
        }
        #[cfg(feature = "exr")]
        ImageFormat::Exr => {
            let data: Vec<f32> = radiance.iter().flat_map(|l| l.to_array()).collect();
            let img = image::Rgb32FImage::from_raw(width, height, data).ok_or_else(wrong_size)?;
            crate::io::output::write_image(path, &img, image::ImageFormat::OpenExr)
        }
        ImageFormat::Pfm => {
            let data: Vec<f32> = radiance.iter().flat_map(|l| l.to_array()).collect();
            crate::io::output::write_bytes(path, &pfm_bytes(width, height, 3, &data))
        }
        #[allow(unreachable_patterns)]
        format => format.compiled_in(path, "out").map(drop),
    }
}

/// Reads a PFM file (colour `PF` or grey `Pf`, either byte order): width,
/// height and the pixels row-major with row 0 at the top (grey in all three
/// channels).
pub fn read_pfm(path: &Path) -> Result<(u32, u32, Vec<Vec3>)> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    let bad = |problem: &str| Error::file(path, "header", problem.to_string());
    let mut fields = Vec::new();
    let mut at = 0;
    while fields.len() < 4 {
        while at < bytes.len() && bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        let start = at;
        while at < bytes.len() && !bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        if start == at {
            return Err(bad("is incomplete (need PF or Pf, width, height, scale)"));
        }
        fields.push(String::from_utf8_lossy(&bytes[start..at]).into_owned());
    }
    at += 1; // the single whitespace byte after the scale
    let channels = match fields[0].as_str() {
        "PF" => 3,
        "Pf" => 1,
        _ => return Err(bad("is not a PFM (must start with PF or Pf)")),
    };
    let (width, height): (u32, u32) = match (fields[1].parse(), fields[2].parse()) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 => (w, h),
        _ => return Err(bad("has no valid positive width and height")),
    };
    let scale: f32 = fields[3].parse().map_err(|_| bad("scale is not a number"))?;
    let n = (width as usize)
        .checked_mul(height as usize)
        .ok_or_else(|| bad("is too large"))?;
    let data = bytes.get(at..).unwrap_or_default();
    if data.len() != n * 4 * channels {
        return Err(Error::file(
            path,
            "data",
            format!(
                "has {} bytes, {width}x{height}x{channels} floats need {}",
                data.len(),
                n * 4 * channels
            ),
        ));
    }
    let value = |k: usize| {
        let b = [data[4 * k], data[4 * k + 1], data[4 * k + 2], data[4 * k + 3]];
        if scale < 0.0 {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        }
    };
    let (w, h) = (width as usize, height as usize);
    let mut out = vec![Vec3::ZERO; n];
    for k in 0..n {
        let slot = (h - 1 - k / w) * w + k % w;
        out[slot] = match channels {
            1 => Vec3::splat(value(k)),
            _ => Vec3::new(value(3 * k), value(3 * k + 1), value(3 * k + 2)),
        };
    }
    Ok((width, height, out))
}

/// An RGB image, 8 bits per channel.
#[cfg(feature = "png")]
pub fn write_rgb_png(path: &Path, width: u32, height: u32, pixels: &[[u8; 3]]) -> Result<()> {
    let mut img = image::RgbImage::new(width, height);
    for (p, v) in img.pixels_mut().zip(pixels) {
        *p = image::Rgb(*v);
    }
    crate::io::output::write_image(path, &img, image::ImageFormat::Png)
}

/// An RGB image, 8 bits per channel: refused, this build has no PNG writer.
#[cfg(not(feature = "png"))]
pub fn write_rgb_png(path: &Path, _width: u32, _height: u32, _pixels: &[[u8; 3]]) -> Result<()> {
    ImageFormat::Png.compiled_in(path, "out").map(drop)
}

#[cfg(all(test, feature = "png", feature = "exr"))]
mod tests {
    use super::*;

    fn folder(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("penumbra-image-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn pfm_and_exr_round_trip_exactly() {
        let dir = folder("radiance");
        let (w, h) = (3, 2);
        let img: Vec<Vec3> = (0..6)
            .map(|i| Vec3::new(i as f32 * 0.5, 1e-7 * i as f32, 1e4 + i as f32))
            .collect();
        let pfm = dir.join("a.pfm");
        write_radiance(&pfm, w, h, &img, 1.0).unwrap();
        assert_eq!(read_pfm(&pfm).unwrap(), (w, h, img.clone()));
        let exr = dir.join("a.exr");
        write_radiance(&exr, w, h, &img, 1.0).unwrap();
        let back = image::open(&exr).unwrap().into_rgb32f();
        let values: Vec<Vec3> = back.pixels().map(|p| Vec3::from_array(p.0)).collect();
        assert_eq!(values, img);
        let png = dir.join("a.png");
        write_radiance(&png, w, h, &img, 1.0).unwrap();
        assert_eq!(image::open(&png).unwrap().into_rgb8().get_pixel(1, 0).0, [188, 0, 255]);
        assert!(RadianceFormat::of(&dir.join("a.jpg")).is_err());
        let _ = std::fs::remove_dir_all(dir);
    }

    /// Every grey format and style read back: PNG values within half a
    /// step, EXR and PFM exact, the background as asked.
    #[test]
    fn grey_images_read_back_in_every_format() {
        let dir = folder("grey");
        let (w, h) = (3, 2);
        let values = [Some(0.0), Some(0.25), None, Some(1.0), Some(0.123_456), None];
        let styles = [
            (PngBits::Eight, Background::Black),
            (PngBits::Eight, Background::Transparent),
            (PngBits::Sixteen, Background::Black),
            (PngBits::Sixteen, Background::Transparent),
        ];
        for (bits, background) in styles {
            let style = GreyStyle { bits, background };
            let png = dir.join("g.png");
            write_grey(&png, w, h, &values, style).unwrap();
            let img = image::open(&png).unwrap();
            let transparent = background == Background::Transparent;
            assert_eq!(img.color().has_alpha(), transparent, "{style:?}");
            let max = if bits == PngBits::Sixteen { 65535.0 } else { 255.0 };
            assert_eq!(
                img.color().bytes_per_pixel() as usize,
                (1 + transparent as usize) * if bits == PngBits::Sixteen { 2 } else { 1 }
            );
            let la = img.into_luma_alpha16();
            for (p, v) in la.pixels().zip(&values) {
                // into_luma_alpha16 widens 8-bit values by 257.
                let scale = if bits == PngBits::Eight { 257.0 } else { 1.0 };
                let back = p.0[0] as f32 / scale / max;
                assert!(
                    (back - v.unwrap_or(0.0)).abs() <= 0.5 / max,
                    "{style:?}: {back} for {v:?}"
                );
                let opaque = v.is_some() || !transparent;
                assert_eq!(p.0[1], if opaque { 65535 } else { 0 }, "{style:?}");
            }
            let exr = dir.join("g.exr");
            write_grey(&exr, w, h, &values, style).unwrap();
            let back = image::open(&exr).unwrap().into_rgba32f();
            for (p, v) in back.pixels().zip(&values) {
                let g = v.unwrap_or(0.0);
                let alpha = if transparent && v.is_none() { 0.0 } else { 1.0 };
                assert_eq!(p.0, [g, g, g, alpha], "{style:?}");
            }
        }
        let pfm = dir.join("g.pfm");
        write_grey(&pfm, w, h, &values, GreyStyle::default()).unwrap();
        assert!(std::fs::read(&pfm).unwrap().starts_with(b"Pf\n3 2\n-1.0\n"));
        let (_, _, back) = read_pfm(&pfm).unwrap();
        let expected: Vec<Vec3> = values.iter().map(|v| Vec3::splat(v.unwrap_or(0.0))).collect();
        assert_eq!(back, expected);
        let transparent = GreyStyle {
            background: Background::Transparent,
            ..GreyStyle::default()
        };
        let e = write_grey(&pfm, w, h, &values, transparent).unwrap_err();
        assert!(e.to_string().contains("no alpha"), "{e}");
        let e = ImageFormat::check(&dir.join("g.jpg"), "--image").unwrap_err();
        assert_eq!(e.exit_code(), 2);
        for part in ["--image", "g.jpg", ".png", ".exr", ".pfm"] {
            assert!(e.to_string().contains(part), "{e}");
        }
        assert!(ImageFormat::check_png(&dir.join("t.exr"), "--tiles-image").is_err());
        assert!(ImageFormat::check_png(&dir.join("t.PNG"), "--tiles-image").is_ok());
        let _ = std::fs::remove_dir_all(dir);
    }
}
