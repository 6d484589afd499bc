//! The `.dfield` file: a displacement field on disk.
//!
//! Little-endian throughout:
//!
//! | offset | size | field |
//! |---:|---:|---|
//! | 0 | 8 | magic `PENFIELD` |
//! | 8 | 4 | version (1) |
//! | 12 | 4 | header size in bytes (96) |
//! | 16 | 4 | positional grid side N (N x N maps, octahedral) |
//! | 20 | 4 | map resolution S (S x S texels) |
//! | 24 | 4 | storage bits: 32, 8 or 1 |
//! | 28 | 4 | direction mapping: 0 concentric, 1 polar, 2 rejection |
//! | 32 | 12 | sphere centre (f32 x 3, object space) |
//! | 44 | 4 | sphere radius (f32) |
//! | 48 | 24 | object bounds min, max (f32 x 6) |
//! | 72 | 4 | triangles of the object |
//! | 76 | 4 | maps (N^2, checked) |
//! | 80 | 8 | data size in bytes (u64) |
//! | 88 | 8 | reserved, zero |
//! | 96 | data size | maps: f32 or u8 per texel, map after map, texel (a, b) at b S + a; 1-bit: ceil(S^2/32) u32 words per map, then one f32 mean hit distance per map |
//! | end - 4 | 4 | CRC-32 (IEEE) of everything before it |

use std::path::Path;

use glam::Vec3;

use super::build::DisplacementField;
use super::directions::DirectionMapping;
use super::positions::OctahedralGrid;
use super::storage::{FieldData, FieldSampling, MAX_GRID_SIDE, MAX_RES, Storage};
use crate::error::{Error, Result};
use crate::geom::aabb::Aabb;

/// The first eight bytes of every `.dfield` file.
pub const MAGIC: &[u8; 8] = b"PENFIELD";
/// The format version this library writes, and the only one it reads.
pub const VERSION: u32 = 1;
const HEADER: usize = 96;

/// Encodes a field as `.dfield` bytes.
pub fn to_bytes(field: &DisplacementField) -> Vec<u8> {
    let p = &field.params;
    let mut data = Vec::with_capacity(field.data.bytes());
    match &field.data {
        FieldData::F32(v) => v.iter().for_each(|x| data.extend_from_slice(&x.to_le_bytes())),
        FieldData::U8(v) => data.extend_from_slice(v),
        FieldData::Bits { words, mean } => {
            words.iter().for_each(|w| data.extend_from_slice(&w.to_le_bytes()));
            mean.iter().for_each(|x| data.extend_from_slice(&x.to_le_bytes()));
        }
    }
    let mut out = Vec::with_capacity(HEADER + data.len() + 4);
    out.extend_from_slice(MAGIC);
    let u32s = |out: &mut Vec<u8>, v: &[u32]| v.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
    u32s(
        &mut out,
        &[
            VERSION,
            HEADER as u32,
            p.grid.side,
            p.res,
            p.storage.bits(),
            p.directions.code(),
        ],
    );
    let floats = [
        field.center.to_array().as_slice(),
        &[field.radius],
        &field.bounds.min.to_array(),
        &field.bounds.max.to_array(),
    ]
    .concat();
    floats.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
    u32s(&mut out, &[field.triangles, p.grid.count()]);
    out.extend_from_slice(&(data.len() as u64).to_le_bytes());
    out.extend_from_slice(&[0u8; 8]);
    debug_assert_eq!(out.len(), HEADER);
    out.extend_from_slice(&data);
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

/// Writes `field` to `path`, only if `read` would load it back (a field of
/// a degenerate mesh, say with a non-finite radius, is refused here rather
/// than on its next load).
pub fn write(path: &Path, field: &DisplacementField) -> Result<()> {
    let bytes = to_bytes(field);
    if let Err(e) = from_bytes(&bytes) {
        return Err(Error::file(
            path,
            "",
            format!("not written: the field would not load back ({e})"),
        ));
    }
    crate::io::output::write_bytes(path, &bytes)
}

/// Reads the `.dfield` file at `path`, checked as `from_bytes` checks it
/// (errors name the file and the header field).
pub fn read(path: &Path) -> Result<DisplacementField> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    from_bytes(&bytes).map_err(|e| e.in_file(path))
}

/// Decodes `.dfield` bytes, rejecting anything inconsistent; errors name the
/// header field (`Error::in_file` adds the path).
pub fn from_bytes(bytes: &[u8]) -> Result<DisplacementField> {
    let bad = |field: &str, problem: String| Error::input(field, problem);
    if bytes.len() < HEADER + 4 {
        return Err(bad(
            "header",
            format!(
                "file is {} bytes, shorter than the {}-byte header and checksum",
                bytes.len(),
                HEADER + 4
            ),
        ));
    }
    if &bytes[..8] != MAGIC {
        return Err(bad("magic", "not a penumbra displacement field (.dfield) file".into()));
    }
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let version = u32_at(8);
    if version != VERSION {
        return Err(bad(
            "version",
            format!("is {version}; this penumbra reads version {VERSION}"),
        ));
    }
    if u32_at(12) as usize != HEADER {
        return Err(bad("header size", format!("is {}, expected {HEADER}", u32_at(12))));
    }
    let (side, res) = (u32_at(16), u32_at(20));
    if side == 0 || side > MAX_GRID_SIDE {
        return Err(bad("grid side", format!("is {side}, must be 1 to {MAX_GRID_SIDE}")));
    }
    if !(2..=MAX_RES).contains(&res) {
        return Err(bad("resolution", format!("is {res}, must be 2 to {MAX_RES}")));
    }
    let storage = Storage::from_bits(u32_at(24))
        .ok_or_else(|| bad("storage bits", format!("is {}, must be 32, 8 or 1", u32_at(24))))?;
    let directions = DirectionMapping::from_code(u32_at(28)).ok_or_else(|| {
        bad(
            "direction mapping",
            format!("is {}, must be 0 (concentric), 1 (polar) or 2 (rejection)", u32_at(28)),
        )
    })?;
    let floats: Vec<f32> = (0..10).map(|k| f32_at(32 + 4 * k)).collect();
    if let Some(k) = floats.iter().position(|x| !x.is_finite()) {
        let name = ["sphere centre", "sphere radius", "bounds"][match k {
            0..=2 => 0,
            3 => 1,
            _ => 2,
        }];
        return Err(bad(name, "is not finite".into()));
    }
    let center = Vec3::new(floats[0], floats[1], floats[2]);
    let radius = floats[3];
    if radius <= 0.0 {
        return Err(bad("sphere radius", format!("is {radius}, must be positive")));
    }
    let bounds = Aabb::new(
        Vec3::new(floats[4], floats[5], floats[6]),
        Vec3::new(floats[7], floats[8], floats[9]),
    );
    if bounds.min.cmpgt(bounds.max).any() {
        return Err(bad("bounds", "minimum exceeds maximum".into()));
    }
    let triangles = u32_at(72);
    if u32_at(76) != side * side {
        return Err(bad(
            "maps",
            format!("is {}, but a {side} x {side} grid has {}", u32_at(76), side * side),
        ));
    }
    let params = FieldSampling {
        grid: OctahedralGrid { side },
        res,
        storage,
        directions,
    };
    let expected = match storage {
        Storage::F32 => params.maps() * params.texels_per_map() * 4,
        Storage::U8 => params.maps() * params.texels_per_map(),
        Storage::Bit1 => params.maps() * (params.words_per_map() * 4 + 4),
    };
    let declared = u64::from_le_bytes(bytes[80..88].try_into().unwrap());
    if declared != expected as u64 {
        return Err(bad(
            "data size",
            format!(
                "is {declared} bytes, but {side}^2 maps of {res}x{res} at {} bits need {expected}",
                storage.bits()
            ),
        ));
    }
    if bytes.len() != HEADER + expected + 4 {
        return Err(bad(
            "data",
            format!(
                "file is {} bytes, expected {} (header, {expected} bytes of maps, checksum): truncated or padded",
                bytes.len(),
                HEADER + expected + 4
            ),
        ));
    }
    let body = &bytes[..HEADER + expected];
    let stored = u32::from_le_bytes(bytes[HEADER + expected..].try_into().unwrap());
    if crc32fast::hash(body) != stored {
        return Err(bad(
            "checksum",
            "does not match the contents: the file is corrupt".into(),
        ));
    }
    let data = &body[HEADER..];
    let f32s = |b: &[u8]| -> Vec<f32> {
        b.chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect()
    };
    let in_unit = |v: &[f32], what: &str| -> Result<()> {
        match v.iter().position(|x| !(0.0..=1.0).contains(x)) {
            Some(i) => Err(bad(what, format!("entry {i} is {}, must be in [0, 1]", v[i]))),
            None => Ok(()),
        }
    };
    let data = match storage {
        Storage::F32 => {
            let v = f32s(data);
            in_unit(&v, "distances")?;
            FieldData::F32(v)
        }
        Storage::U8 => FieldData::U8(data.to_vec()),
        Storage::Bit1 => {
            let split = params.maps() * params.words_per_map() * 4;
            let words = data[..split]
                .chunks_exact(4)
                .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
                .collect();
            let mean = f32s(&data[split..]);
            in_unit(&mean, "mean distances")?;
            FieldData::Bits { words, mean }
        }
    };
    Ok(DisplacementField {
        params,
        center,
        radius,
        bounds,
        triangles,
        data,
    })
}
