//! Latitude-longitude environment maps (Radiance .hdr), for scenes' image-based
//! lighting.

use std::path::Path;

use crate::error::{Error, Result};

/// Linear RGB radiance on a latitude-longitude grid: row 0 looks up (+y),
/// width = 2 x height.
///
/// Texture coordinates (u, v) in [0, 1]² (u = column / width, v = row /
/// height) map to the direction of the USC ICT / Probulator convention:
/// `d = (sin θ sin α, cos θ, -sin θ cos α)` with `θ = π v`, `α = π (2u - 1)`.
/// The image centre (u = 1/2) looks along -z, u = 3/4 along +x, and the seam
/// (u = 0 = 1) along +z. Texel (c, r) covers `θ ∈ [π r/h, π (r+1)/h]` and a
/// 2π/w slice of azimuth: solid angle `(2π / w) (cos θ0 - cos θ1)`.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentMap {
    /// Texels per row: twice `height`.
    pub width: u32,
    /// Rows, from +y (row 0) to -y.
    pub height: u32,
    /// Linear RGB radiance, row-major, finite and non-negative.
    pub texels: Vec<[f32; 3]>,
}

/// Largest side of a probe: far beyond any published light probe, and
/// what a 2D texture of most devices can hold.
pub const MAX_PROBE_SIDE: u32 = 16384;

/// Radiance RLE stores a run of up to 127 equal bytes in 2 bytes, per
/// channel: a file of `len` bytes decodes to at most about 64 x `len`
/// pixels. A header promising more (or nothing) is refused before any
/// pixel is allocated.
#[cfg(feature = "hdr")]
fn check_promised_size((width, height): (u32, u32), len: usize) -> std::result::Result<(), String> {
    if width == 0 || height == 0 {
        return Err(format!("declares {width}x{height} pixels; a probe needs at least one"));
    }
    if width > MAX_PROBE_SIDE || height > MAX_PROBE_SIDE {
        return Err(format!(
            "declares {width}x{height} pixels; penumbra reads probes up to {MAX_PROBE_SIDE} pixels a side"
        ));
    }
    let pixels = width as u64 * height as u64;
    if pixels > 64 * len as u64 + 4096 {
        return Err(format!(
            "declares {width}x{height} pixels, more than a {len}-byte file can hold"
        ));
    }
    Ok(())
}

impl EnvironmentMap {
    /// Loads and checks an .hdr file: readable RGBE, 2:1 aspect, finite and
    /// non-negative texels. Without the `hdr` feature, an error naming it.
    #[cfg(not(feature = "hdr"))]
    pub fn load(path: &Path) -> Result<EnvironmentMap> {
        Err(Error::file(
            path,
            "",
            "this build of penumbra does not read Radiance .hdr probes (the `hdr` cargo feature is off)",
        ))
    }

    /// Loads and checks an .hdr file: readable RGBE, 2:1 aspect, finite and
    /// non-negative texels.
    #[cfg(feature = "hdr")]
    pub fn load(path: &Path) -> Result<EnvironmentMap> {
        let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
        let decoder = image::codecs::hdr::HdrDecoder::new(std::io::Cursor::new(&bytes))
            .map_err(|e| Error::file(path, "header", format!("not a Radiance HDR file: {e}")))?;
        check_promised_size(image::ImageDecoder::dimensions(&decoder), bytes.len())
            .map_err(|problem| Error::file(path, "header", problem))?;
        // A panic of the decoder is malformed pixel data too: image 0.25's
        // old-style RLE reader overflows its run-length multiplier on eight
        // run markers in a row (image-rs/image#2714; in builds with overflow
        // checks).
        let decoded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            image::DynamicImage::from_decoder(decoder)
        }))
        .map_err(|_| Error::file(path, "pixels", "cannot decode: malformed run lengths"))?;
        let image = decoded
            .map_err(|e| Error::file(path, "pixels", format!("cannot decode: {e}")))?
            .into_rgb32f();
        let (width, height) = image.dimensions();
        if width != 2 * height {
            return Err(Error::file(
                path,
                "dimensions",
                format!("{width}x{height} is not a 2:1 latitude-longitude map"),
            ));
        }
        let texels: Vec<[f32; 3]> = image.pixels().map(|p| p.0).collect();
        if let Some(i) = texels.iter().position(|t| t.iter().any(|c| !c.is_finite() || *c < 0.0)) {
            return Err(Error::file(
                path,
                format!("pixel ({}, {})", i as u32 % width, i as u32 / width),
                "radiance must be finite and non-negative",
            ));
        }
        Ok(EnvironmentMap { width, height, texels })
    }

    /// A map from texels in row-major order (row 0 up), checked like `load`.
    pub fn from_texels(width: u32, height: u32, texels: Vec<[f32; 3]>) -> Result<EnvironmentMap> {
        if height == 0 || width != 2 * height {
            return Err(Error::input(
                "environment map",
                format!("{width}x{height} is not a 2:1 latitude-longitude map"),
            ));
        }
        if texels.len() != (width * height) as usize {
            return Err(Error::input(
                "environment map",
                format!("{} texels for a {width}x{height} map", texels.len()),
            ));
        }
        if texels.iter().flatten().any(|c| !c.is_finite() || *c < 0.0) {
            return Err(Error::input(
                "environment map",
                "radiance must be finite and non-negative",
            ));
        }
        Ok(EnvironmentMap { width, height, texels })
    }

    /// A map of `height` rows whose texels hold `f` at their centre
    /// direction.
    pub fn from_fn(height: u32, f: impl Fn(glam::Vec3) -> [f32; 3]) -> Result<EnvironmentMap> {
        let width = 2 * height;
        let texels = (0..height)
            .flat_map(|r| (0..width).map(move |c| (c, r)))
            .map(|(c, r)| {
                let d = Self::direction_f64((c as f64 + 0.5) / width as f64, (r as f64 + 0.5) / height as f64);
                f(d.as_vec3())
            })
            .collect();
        Self::from_texels(width, height, texels)
    }

    /// The direction of texture coordinates (u, v) (see the type's docs).
    pub fn direction_f64(u: f64, v: f64) -> glam::DVec3 {
        let theta = std::f64::consts::PI * v;
        let alpha = std::f64::consts::PI * (2.0 * u - 1.0);
        glam::DVec3::new(theta.sin() * alpha.sin(), theta.cos(), -theta.sin() * alpha.cos())
    }

    /// Texture coordinates (u, v) of a unit direction: the inverse of
    /// `direction_f64`.
    pub fn texcoord(d: glam::Vec3) -> (f32, f32) {
        let u = 0.5 * (1.0 + d.x.atan2(-d.z) / std::f32::consts::PI);
        let v = d.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
        (u, v)
    }

    /// Solid angle of a texel of row `r`.
    pub fn texel_solid_angle(&self, r: u32) -> f64 {
        let h = self.height as f64;
        let t0 = std::f64::consts::PI * r as f64 / h;
        let t1 = std::f64::consts::PI * (r + 1) as f64 / h;
        std::f64::consts::TAU / self.width as f64 * (t0.cos() - t1.cos())
    }

    /// Radiance seen in direction `d` (bilinear, wrapping in azimuth).
    pub fn lookup(&self, d: glam::Vec3) -> [f32; 3] {
        let (u, v) = Self::texcoord(d.normalize_or(glam::Vec3::Y));
        let x = u * self.width as f32 - 0.5;
        let y = (v * self.height as f32 - 0.5).clamp(0.0, (self.height - 1) as f32);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let w = self.width as i64;
        let col = |i: i64| (i.rem_euclid(w)) as usize;
        let row = |j: f32| (j as usize).min(self.height as usize - 1);
        let at = |c: usize, r: usize| self.texels[r * self.width as usize + c];
        let (c0, c1) = (col(x0 as i64), col(x0 as i64 + 1));
        let (r0, r1) = (row(y0), row(y0 + 1.0));
        let mut out = [0.0; 3];
        for (k, o) in out.iter_mut().enumerate() {
            let top = at(c0, r0)[k] * (1.0 - fx) + at(c1, r0)[k] * fx;
            let bottom = at(c0, r1)[k] * (1.0 - fx) + at(c1, r1)[k] * fx;
            *o = top * (1.0 - fy) + bottom * fy;
        }
        out
    }
}

#[cfg(all(test, feature = "hdr"))]
mod tests {
    use super::*;

    #[test]
    fn rejects_non_hdr_and_wrong_aspect() {
        let dir = std::env::temp_dir().join(format!("penumbra-env-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bad = dir.join("bad.hdr");
        std::fs::write(&bad, b"this is not an hdr file").unwrap();
        let e = EnvironmentMap::load(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.hdr") && e.contains("not a Radiance HDR"), "{e}");

        let square = dir.join("square.hdr");
        let img = image::Rgb32FImage::from_pixel(4, 4, image::Rgb([1.0, 1.0, 1.0]));
        img.save(&square).unwrap();
        let e = EnvironmentMap::load(&square).unwrap_err().to_string();
        assert!(e.contains("2:1"), "{e}");

        let good = dir.join("good.hdr");
        image::Rgb32FImage::from_pixel(8, 4, image::Rgb([0.5, 1.0, 2.0]))
            .save(&good)
            .unwrap();
        let map = EnvironmentMap::load(&good).unwrap();
        assert_eq!((map.width, map.height), (8, 4));
        assert_eq!(map.texels[0], [0.5, 1.0, 2.0]);
        let _ = std::fs::remove_dir_all(dir);
    }
}
