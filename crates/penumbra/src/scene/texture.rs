//! Texture maps as scene files give them: which image, how texture
//! coordinates reach it (scale, offset, repeat or clamp), and the image
//! decoded to 8-bit RGBA.
//!
//! Texture coordinates follow OBJ's convention everywhere in penumbra: `v`
//! runs up the image (v = 0 is the bottom row, v = 1 the top). glTF's
//! `TEXCOORD_0` runs down, and its reader flips it (v -> 1 - v).
//!
//! Images are decoded when a scene is made ready to render, not when it is
//! read, so methods that only cast rays never pay for them. A map whose
//! image cannot be read is a warning naming the file; the material's colour
//! is used instead.

use std::path::PathBuf;
use std::sync::Arc;

use glam::Vec2;

/// Where a texture's image comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum TextureSource {
    /// An image file (a path as the scene file resolved it).
    File(PathBuf),
    /// An image inside the scene file (a glTF buffer view or data URI):
    /// its name for messages, and its encoded bytes.
    Embedded {
        /// The image's name in messages (the glTF image's name or index).
        name: String,
        /// The encoded image (PNG, JPEG, ...).
        bytes: Arc<[u8]>,
    },
}

impl TextureSource {
    /// How messages name the image: the file's path, or the embedded
    /// image's name.
    pub fn name(&self) -> String {
        match self {
            TextureSource::File(path) => path.display().to_string(),
            TextureSource::Embedded { name, .. } => name.clone(),
        }
    }
}

impl serde::Serialize for TextureSource {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(&self.name())
    }
}

/// One texture map of a material: an image, and how a surface point's
/// texture coordinates `(u, v)` reach it: `(u, v) * scale + offset`, then
/// repeated (the fractional part) or clamped to [0, 1] (MTL's `-clamp on`,
/// glTF's `CLAMP_TO_EDGE`). Looked up with bilinear filtering between texel
/// centres.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TextureMap {
    /// The image.
    pub source: TextureSource,
    /// Scale of the texture coordinates (MTL's `-s u v`).
    pub scale: Vec2,
    /// Offset added after scaling (MTL's `-o u v`).
    pub offset: Vec2,
    /// Clamp coordinates to [0, 1] instead of repeating the image.
    pub clamp: bool,
}

impl TextureMap {
    /// The map of `source` with no scale, offset or clamping.
    pub fn new(source: TextureSource) -> TextureMap {
        TextureMap {
            source,
            scale: Vec2::ONE,
            offset: Vec2::ZERO,
            clamp: false,
        }
    }
}

/// A cut-out: where the map's value times `factor` is below `cutoff`, the
/// surface is a hole every ray passes (MTL's `map_d`, glTF's `alphaMode`
/// `MASK` and `BLEND`). The value is the image's alpha channel, or (with
/// `luminance`, for MTL) its luminance where the image is opaque everywhere.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AlphaMap {
    /// The image holding the alpha.
    pub map: TextureMap,
    /// A factor on the map's value (glTF's `baseColorFactor` alpha; 1 for MTL).
    pub factor: f32,
    /// Values below it are holes (glTF's `alphaCutoff`, 0.5 by default).
    pub cutoff: f32,
    /// Whether an image with no transparent texel gives its luminance as
    /// the value (MTL's `map_d` of a grey mask); glTF reads the alpha
    /// channel only (an opaque image has no holes).
    pub luminance: bool,
}

/// A material's texture maps (none by default; boxed, so a material
/// without maps stays small).
///
/// `kd` multiplies the diffuse colour `Kd` and, where the material has no
/// `ka` map, the ambient colour `Ka` too (the ambient light reflects as the
/// diffuse does). Where `Kd` is black and a `kd` map is given, the map alone
/// is the diffuse colour (exporters write `Kd 0 0 0` beside a map); the same
/// holds for `Ka` and `Ks` with their maps. `ks` multiplies the highlight's
/// colour (not the mirror reflection's weight).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct MaterialMaps {
    /// `map_Kd` / glTF `baseColorTexture`: the diffuse colour.
    pub kd: Option<Box<TextureMap>>,
    /// `map_Ka`: the ambient colour.
    pub ka: Option<Box<TextureMap>>,
    /// `map_Ks`: the highlight's colour.
    pub ks: Option<Box<TextureMap>>,
    /// `map_d` / glTF alpha: a cut-out.
    pub alpha: Option<Box<AlphaMap>>,
}

impl MaterialMaps {
    /// Whether no map is given.
    pub fn is_empty(&self) -> bool {
        self.kd.is_none() && self.ka.is_none() && self.ks.is_none() && self.alpha.is_none()
    }
}

/// A decoded image: 8-bit RGBA texels, row-major from the top-left corner,
/// as stored (colour maps sRGB-encoded).
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    /// Its source's name, for messages.
    pub name: String,
    /// Width in texels (>= 1).
    pub width: u32,
    /// Height in texels (>= 1).
    pub height: u32,
    /// `width * height` texels.
    pub texels: Vec<[u8; 4]>,
}

impl Texture {
    /// Whether any texel is not fully opaque.
    pub fn has_alpha(&self) -> bool {
        self.texels.iter().any(|t| t[3] != 255)
    }

    /// Half the size in each dimension (at least 1), each texel the mean of
    /// the 2x2 (or fewer, at an odd edge) texels it covers: how a texture
    /// too large for a device is reduced.
    pub fn halved(&self) -> Texture {
        let (w, h) = ((self.width / 2).max(1), (self.height / 2).max(1));
        let mut texels = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                let mut sum = [0u32; 4];
                let mut n = 0u32;
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (sx, sy) = (2 * x + dx, 2 * y + dy);
                    if sx < self.width && sy < self.height {
                        let t = self.texels[(sy * self.width + sx) as usize];
                        for c in 0..4 {
                            sum[c] += t[c] as u32;
                        }
                        n += 1;
                    }
                }
                texels.push(sum.map(|s| ((s + n / 2) / n) as u8));
            }
        }
        Texture {
            name: self.name.clone(),
            width: w,
            height: h,
            texels,
        }
    }
}

/// Decodes `source`'s image (PNG, JPEG, BMP or TGA, told apart by content)
/// into 8-bit RGBA; the error says why, for a warning naming the file.
#[cfg(feature = "textures")]
pub fn decode_texture(source: &TextureSource) -> std::result::Result<Texture, String> {
    let bytes: std::borrow::Cow<[u8]> = match source {
        TextureSource::File(path) => std::fs::read(path)
            .map_err(|e| {
                if e.kind() == std::io::ErrorKind::NotFound {
                    "not found".to_string()
                } else {
                    format!("cannot be read: {e}")
                }
            })?
            .into(),
        TextureSource::Embedded { bytes, .. } => bytes.as_ref().into(),
    };
    let format = image::guess_format(&bytes)
        .or_else(|e| match source {
            // TGA has no magic number: its extension says it.
            TextureSource::File(path) => image::ImageFormat::from_path(path).map_err(|_| e),
            TextureSource::Embedded { .. } => Err(e),
        })
        .map_err(|_| "is not an image penumbra reads (PNG, JPEG, BMP or TGA)".to_string())?;
    let image = image::load_from_memory_with_format(&bytes, format).map_err(|e| format!("cannot be decoded: {e}"))?;
    let rgba = image.to_rgba8();
    let (width, height) = rgba.dimensions();
    if width == 0 || height == 0 {
        return Err("has no texels".into());
    }
    let texels = rgba.pixels().map(|p| p.0).collect();
    Ok(Texture {
        name: source.name(),
        width,
        height,
        texels,
    })
}

/// Without the `textures` feature no image is decoded.
#[cfg(not(feature = "textures"))]
pub fn decode_texture(_source: &TextureSource) -> std::result::Result<Texture, String> {
    Err("is not read: penumbra was built without the `textures` feature".into())
}

/// The linear value of each 8-bit sRGB code (IEC 61966-2-1), as the
/// renderer's texture lookups decode colour maps on the CPU and the GPU.
pub fn srgb_to_linear_table() -> [f32; 256] {
    std::array::from_fn(|i| {
        let c = i as f64 / 255.0;
        let l = if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        };
        l as f32
    })
}

/// A map statement's arguments (`map_Kd -s 2 2 1 -clamp on wood.png`):
/// the options penumbra uses (`-s`, `-o`, `-clamp`) and the file name (the
/// rest of the line, spaces kept). Options it does not use are skipped and
/// named in `ignored` (`-bm`, `-mm`, `-t`, `-blendu`, ...); an option with
/// a bad value is an error.
pub fn parse_map_statement(
    args: &[&str],
    ignored: &mut Vec<String>,
) -> std::result::Result<(String, TextureMap), String> {
    // Options and how many values each takes (at most; -s, -o and -t take
    // 1 to 3 numbers).
    const SKIPPED: [(&str, usize); 9] = [
        ("-blendu", 1),
        ("-blendv", 1),
        ("-bm", 1),
        ("-boost", 1),
        ("-cc", 1),
        ("-imfchan", 1),
        ("-texres", 1),
        ("-type", 1),
        ("-mm", 2),
    ];
    let mut map = TextureMap::new(TextureSource::File(PathBuf::new()));
    let mut i = 0;
    let numbers = |i: &mut usize, option: &str| -> std::result::Result<Vec<f32>, String> {
        let mut v = Vec::new();
        while v.len() < 3 && *i < args.len() {
            match args[*i].parse::<f32>() {
                Ok(x) if x.is_finite() => v.push(x),
                Ok(_) => return Err(format!("{option}: '{}' is not a finite number", args[*i])),
                Err(_) => break,
            }
            *i += 1;
        }
        if v.is_empty() {
            return Err(format!("{option} needs 1 to 3 numbers"));
        }
        Ok(v)
    };
    while i < args.len() && args[i].starts_with('-') && args[i].len() > 1 && args[i].parse::<f64>().is_err() {
        let option = args[i];
        i += 1;
        match option {
            "-s" | "-o" => {
                let v = numbers(&mut i, option)?;
                let uv = Vec2::new(
                    v[0],
                    v.get(1).copied().unwrap_or(if option == "-s" { 1.0 } else { 0.0 }),
                );
                if option == "-s" {
                    map.scale = uv;
                } else {
                    map.offset = uv;
                }
            }
            "-t" => {
                numbers(&mut i, option)?;
                ignored.push(option.into());
            }
            "-clamp" => {
                let value = args.get(i).ok_or("-clamp needs on or off")?;
                map.clamp = match *value {
                    "on" => true,
                    "off" => false,
                    other => return Err(format!("-clamp '{other}' is neither on nor off")),
                };
                i += 1;
            }
            _ => {
                let Some(&(_, count)) = SKIPPED.iter().find(|(name, _)| *name == option) else {
                    return Err(format!("unknown option '{option}'"));
                };
                i = (i + count).min(args.len());
                ignored.push(option.into());
            }
        }
    }
    if i >= args.len() {
        return Err("names no image file".into());
    }
    Ok((args[i..].join(" "), map))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(line: &str) -> std::result::Result<(String, TextureMap, Vec<String>), String> {
        let args: Vec<&str> = line.split_ascii_whitespace().collect();
        let mut ignored = Vec::new();
        parse_map_statement(&args, &mut ignored).map(|(f, m)| (f, m, ignored))
    }

    #[test]
    fn map_statements_and_their_options() {
        let (file, map, ignored) = parse("wood.png").unwrap();
        assert_eq!(
            (file.as_str(), map.scale, map.offset, map.clamp),
            ("wood.png", Vec2::ONE, Vec2::ZERO, false)
        );
        assert!(ignored.is_empty());
        let (file, map, ignored) = parse("-s 2 3 1 -o 0.5 -0.25 0 -clamp on -bm 0.3 my wood.tga").unwrap();
        assert_eq!(file, "my wood.tga", "a name with spaces is kept");
        assert_eq!(
            (map.scale, map.offset, map.clamp),
            (Vec2::new(2.0, 3.0), Vec2::new(0.5, -0.25), true)
        );
        assert_eq!(ignored, ["-bm"]);
        let (_, map, _) = parse("-s 4 a.png").unwrap();
        assert_eq!(map.scale, Vec2::new(4.0, 1.0), "one number scales u only");
        let (file, _, ignored) = parse("-mm 0 1 -imfchan m -t 0.1 0.1 a.png").unwrap();
        assert_eq!((file.as_str(), ignored.len()), ("a.png", 3));
        assert_eq!(
            parse("-clamp maybe a.png").unwrap_err(),
            "-clamp 'maybe' is neither on nor off"
        );
        assert_eq!(parse("-s a.png").unwrap_err(), "-s needs 1 to 3 numbers");
        assert_eq!(parse("-s 2 2").unwrap_err(), "names no image file");
        assert_eq!(parse("-frobnicate a.png").unwrap_err(), "unknown option '-frobnicate'");
        assert_eq!(parse("").unwrap_err(), "names no image file");
    }

    #[cfg(feature = "textures")]
    #[test]
    fn every_format_decodes_to_the_same_texels() {
        // A 3x2 image of distinct colours, written in each format.
        let rgb = image::RgbImage::from_fn(3, 2, |x, y| image::Rgb([(x * 80) as u8, (y * 200) as u8, 30]));
        let dir = std::env::temp_dir().join(format!("penumbra-textures-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (ext, exact) in [("png", true), ("bmp", true), ("tga", true), ("jpg", false)] {
            let path = dir.join(format!("t.{ext}"));
            rgb.save(&path).unwrap();
            let t = decode_texture(&TextureSource::File(path.clone())).unwrap_or_else(|e| panic!("{ext}: {e}"));
            assert_eq!((t.width, t.height, t.name.clone()), (3, 2, path.display().to_string()));
            for (texel, p) in t.texels.iter().zip(rgb.pixels()) {
                let worst = (0..3).map(|c| texel[c].abs_diff(p.0[c])).max().unwrap();
                // JPEG is lossy: close, not equal.
                assert!(worst == 0 || (!exact && worst < 40), "{ext}: {texel:?} vs {:?}", p.0);
                assert_eq!(texel[3], 255);
            }
            // The same bytes embedded (a glTF image) decode alike.
            let bytes: Arc<[u8]> = std::fs::read(&path).unwrap().into();
            let embedded = decode_texture(&TextureSource::Embedded {
                name: "e".into(),
                bytes,
            });
            if ext != "tga" {
                assert_eq!(embedded.unwrap().texels, t.texels, "{ext}");
            }
        }
        let missing = decode_texture(&TextureSource::File(dir.join("none.png"))).unwrap_err();
        assert_eq!(missing, "not found");
        std::fs::write(dir.join("text.png"), "not an image").unwrap();
        let junk = decode_texture(&TextureSource::File(dir.join("text.png"))).unwrap_err();
        assert!(
            junk.contains("cannot be decoded") || junk.contains("is not an image"),
            "{junk}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn srgb_table_ends_and_midpoint() {
        let t = srgb_to_linear_table();
        assert_eq!((t[0], t[255]), (0.0, 1.0));
        // sRGB 188 is about linear 0.5.
        assert!((t[188] - 0.5029).abs() < 1e-3, "{}", t[188]);
        assert!(t.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn halving_averages_and_keeps_odd_edges() {
        let t = Texture {
            name: "t".into(),
            width: 3,
            height: 2,
            texels: vec![
                [0, 0, 0, 255],
                [255, 255, 255, 255],
                [10, 20, 30, 40],
                [0; 4],
                [255; 4],
                [10, 20, 30, 40],
            ],
        };
        let h = t.halved();
        assert_eq!((h.width, h.height), (1, 1));
        assert_eq!(h.texels, vec![[128, 128, 128, 191]]);
        assert!(
            t.has_alpha()
                && !Texture {
                    texels: vec![[1, 2, 3, 255]],
                    width: 1,
                    height: 1,
                    name: "o".into()
                }
                .has_alpha()
        );
    }
}
