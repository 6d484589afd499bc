//! Radiance images out: linear float radiance as OpenEXR (`.exr`, the
//! `image` crate's OpenEXR support, 32-bit float RGB) or Portable FloatMap
//! (`.pfm`, written here: a three-line header and raw little-endian floats,
//! bottom row first, as the format says), or tone-mapped sRGB (`.png`: the
//! radiance times an exposure, clamped to [0, 1], sRGB-encoded). The format
//! follows the extension; another extension is refused before rendering.

use std::path::Path;

use glam::Vec3;

use crate::color::srgb8;
use crate::error::{Error, Result};

/// The image formats radiance is written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RadianceFormat {
    Png,
    Exr,
    Pfm,
}

impl RadianceFormat {
    /// The format `path`'s extension names (case-insensitive).
    pub fn of(path: &Path) -> Result<RadianceFormat> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(RadianceFormat::Png),
            Some("exr") => Ok(RadianceFormat::Exr),
            Some("pfm") => Ok(RadianceFormat::Pfm),
            _ => Err(Error::param(
                "out",
                format!(
                    "{}: the extension must be .png (tone-mapped sRGB), .exr or .pfm (linear float radiance)",
                    path.display()
                ),
            )),
        }
    }
}

/// Writes `radiance` (row-major, row 0 at the top) to `path` in the format
/// its extension names; `exposure` scales what a PNG shows.
pub fn write_radiance(path: &Path, width: u32, height: u32, radiance: &[Vec3], exposure: f32) -> Result<()> {
    if radiance.len() != width as usize * height as usize {
        return Err(Error::internal("radiance image of the wrong size"));
    }
    match RadianceFormat::of(path)? {
        RadianceFormat::Png => {
            let mut img = image::RgbImage::new(width, height);
            for (p, l) in img.pixels_mut().zip(radiance) {
                *p = image::Rgb((*l * exposure).to_array().map(srgb8));
            }
            crate::output::write_image(path, &img, image::ImageFormat::Png)
        }
        RadianceFormat::Exr => {
            let data: Vec<f32> = radiance.iter().flat_map(|l| l.to_array()).collect();
            let img = image::Rgb32FImage::from_raw(width, height, data)
                .ok_or_else(|| Error::internal("radiance image of the wrong size"))?;
            crate::output::write_image(path, &img, image::ImageFormat::OpenExr)
        }
        RadianceFormat::Pfm => {
            let mut bytes = format!("PF\n{width} {height}\n-1.0\n").into_bytes();
            for row in radiance.chunks(width as usize).rev() {
                for l in row {
                    for c in l.to_array() {
                        bytes.extend_from_slice(&c.to_le_bytes());
                    }
                }
            }
            crate::output::write_bytes(path, &bytes)
        }
    }
}

/// Reads a colour PFM file (either byte order): width, height and the
/// radiance row-major with row 0 at the top.
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
            return Err(bad("is incomplete (need PF, width, height, scale)"));
        }
        fields.push(String::from_utf8_lossy(&bytes[start..at]).into_owned());
    }
    at += 1; // the single whitespace byte after the scale
    if fields[0] != "PF" {
        return Err(bad("is not a colour PFM (must start with PF)"));
    }
    let (width, height): (u32, u32) = match (fields[1].parse(), fields[2].parse()) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 => (w, h),
        _ => return Err(bad("has no valid positive width and height")),
    };
    let scale: f32 = fields[3].parse().map_err(|_| bad("scale is not a number"))?;
    let n = width as usize * height as usize;
    let data = bytes.get(at..).unwrap_or_default();
    if data.len() != n * 12 {
        return Err(Error::file(
            path,
            "data",
            format!("has {} bytes, {width}x{height} RGB floats need {}", data.len(), n * 12),
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
    let mut out = vec![Vec3::ZERO; n];
    for (k, slot) in (0..n).map(|k| {
        (
            k,
            (height as usize - 1 - k / width as usize) * width as usize + k % width as usize,
        )
    }) {
        out[slot] = Vec3::new(value(3 * k), value(3 * k + 1), value(3 * k + 2));
    }
    Ok((width, height, out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pfm_and_exr_round_trip_exactly() {
        let dir = std::env::temp_dir().join(format!("penumbra-radiance-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
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
}
