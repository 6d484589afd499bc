//! Latitude-longitude environment maps (Radiance .hdr), for scenes' image-based
//! lighting.

use std::path::Path;

use crate::error::{Error, Result};

/// Linear RGB radiance on a latitude-longitude grid: row 0 looks up (+y),
/// column 0 at azimuth 0, width = 2 x height.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentMap {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f32; 3]>,
}

impl EnvironmentMap {
    /// Loads and checks an .hdr file: readable RGBE, 2:1 aspect, finite and
    /// non-negative texels.
    pub fn load(path: &Path) -> Result<EnvironmentMap> {
        let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
        let decoder = image::codecs::hdr::HdrDecoder::new(std::io::Cursor::new(&bytes))
            .map_err(|e| Error::file(path, "header", format!("not a Radiance HDR file: {e}")))?;
        let image = image::DynamicImage::from_decoder(decoder)
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
}

#[cfg(test)]
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
