//! Reading accessors: positions and normals (FLOAT VEC3) and indices
//! (UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT SCALAR).
//!
//! Read here rather than through the `gltf` crate's `utils` reader, which
//! computes `offset + stride * (count - 1) + size` unchecked (a count of 0
//! underflows), asserts on short slices, yields fewer items than `count`
//! when a view is too short, and answers `None` for every problem: penumbra
//! must say which accessor, view or buffer is wrong and how. Every bound
//! here is checked in u128 before a byte is read, and the output is
//! allocated only once the accessor's bytes are known to be there, so its
//! size is bounded by the data.

use ::gltf::accessor::{Accessor, DataType, Dimensions};
use glam::Vec3;

/// Problems come back as text; the caller names the file, mesh, primitive
/// and attribute.
type Result<T> = std::result::Result<T, String>;

/// The bytes an accessor's elements are read from: its view's slice of the
/// buffer, the stride between elements and the element count.
struct Layout<'b> {
    bytes: &'b [u8],
    stride: usize,
    count: usize,
}

/// Where accessor `a`'s `count` elements of `size` bytes lie in `buffers`
/// (indexed as the JSON's buffers; `None` where a buffer is not loaded).
fn layout<'b>(a: &Accessor, size: usize, buffer: &'b [u8]) -> Result<Layout<'b>> {
    let name = format!("accessor {}", a.index());
    if a.sparse().is_some() {
        return Err(format!("{name} is sparse; sparse accessors are not read"));
    }
    let Some(view) = a.view() else {
        return Err(format!(
            "{name} has no bufferView (all zeros); such accessors are not read"
        ));
    };
    let v = view.index();
    let (view_start, view_len) = (view.offset() as u128, view.length() as u128);
    if view_start + view_len > buffer.len() as u128 {
        return Err(format!(
            "bufferView {v} (bytes {view_start}..{}) runs past the end of buffer {} ({} bytes)",
            view_start + view_len,
            view.buffer().index(),
            buffer.len()
        ));
    }
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "bufferView {v} has a byteStride of {stride}, less than {name}'s {size}-byte elements"
        ));
    }
    let count = a.count();
    if count == 0 {
        return Err(format!("{name} has a count of 0"));
    }
    let offset = a.offset() as u128;
    let needed = offset + stride as u128 * (count as u128 - 1) + size as u128;
    if needed > view_len {
        return Err(format!(
            "{name} needs {needed} bytes of bufferView {v} ({count} elements, stride {stride}, offset {offset}), \
             which has {view_len}"
        ));
    }
    let start = (view_start + offset) as usize;
    Ok(Layout {
        bytes: &buffer[start..start + needed as usize - offset as usize],
        stride,
        count,
    })
}

/// The type an accessor has, for messages (`FLOAT VEC3`).
fn described(a: &Accessor) -> String {
    let component = match a.data_type() {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    };
    let dimensions = match a.dimensions() {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    };
    format!("{component} {dimensions}")
}

/// A FLOAT VEC3 accessor (POSITION, NORMAL), little-endian as glTF is.
pub fn vec3(a: &Accessor, buffer: &[u8]) -> Result<Vec<Vec3>> {
    if a.data_type() != DataType::F32 || a.dimensions() != Dimensions::Vec3 || a.normalized() {
        return Err(format!(
            "accessor {} is {}{}; only FLOAT VEC3 is read (quantized meshes are not)",
            a.index(),
            described(a),
            if a.normalized() { " normalized" } else { "" }
        ));
    }
    let l = layout(a, 12, buffer)?;
    let float = |b: &[u8], k: usize| f32::from_le_bytes([b[k], b[k + 1], b[k + 2], b[k + 3]]);
    Ok((0..l.count)
        .map(|i| {
            let e = &l.bytes[i * l.stride..];
            Vec3::new(float(e, 0), float(e, 4), float(e, 8))
        })
        .collect())
}

/// An index accessor: an unsigned SCALAR, as u32.
pub fn indices(a: &Accessor, buffer: &[u8]) -> Result<Vec<u32>> {
    let size = match (a.data_type(), a.dimensions()) {
        (DataType::U8, Dimensions::Scalar) => 1,
        (DataType::U16, Dimensions::Scalar) => 2,
        (DataType::U32, Dimensions::Scalar) => 4,
        _ => {
            return Err(format!(
                "accessor {} is {}; indices are UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT SCALAR",
                a.index(),
                described(a)
            ));
        }
    };
    let l = layout(a, size, buffer)?;
    Ok((0..l.count)
        .map(|i| {
            let e = &l.bytes[i * l.stride..];
            match size {
                1 => e[0] as u32,
                2 => u16::from_le_bytes([e[0], e[1]]) as u32,
                _ => u32::from_le_bytes([e[0], e[1], e[2], e[3]]),
            }
        })
        .collect())
}

/// The components of each element of a float accessor of `dimensions`
/// (skins' matrices, animations' keyframes, weights), flattened: FLOAT, or
/// a normalized integer type mapped to [0, 1] or [-1, 1] as glTF 2.0
/// section 3.11 says. Every value is checked finite.
pub fn floats(a: &Accessor, buffer: &[u8], dimensions: Dimensions) -> Result<Vec<f32>> {
    let width = dimensions.multiplicity();
    let component = match (a.data_type(), a.normalized()) {
        (DataType::F32, _) => 4,
        (DataType::U8 | DataType::I8, true) => 1,
        (DataType::U16 | DataType::I16, true) => 2,
        _ => 0,
    };
    if a.dimensions() != dimensions || component == 0 {
        return Err(format!(
            "accessor {} is {}{}; FLOAT (or a normalized integer) {dimensions:?} is read here",
            a.index(),
            described(a),
            if a.normalized() { " normalized" } else { "" }
        ));
    }
    let l = layout(a, component * width, buffer)?;
    let mut out = Vec::with_capacity(l.count * width);
    for i in 0..l.count {
        let e = &l.bytes[i * l.stride..];
        for c in 0..width {
            let b = &e[c * component..];
            let v = match a.data_type() {
                DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                DataType::U8 => b[0] as f32 / 255.0,
                DataType::I8 => (b[0] as i8 as f32 / 127.0).max(-1.0),
                DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0,
                _ => (i16::from_le_bytes([b[0], b[1]]) as f32 / 32767.0).max(-1.0),
            };
            if !v.is_finite() {
                return Err(format!("accessor {}: element {i} is not finite ({v})", a.index()));
            }
            out.push(v);
        }
    }
    Ok(out)
}

/// A JOINTS accessor: UNSIGNED_BYTE or UNSIGNED_SHORT VEC4, not normalized.
pub fn joints(a: &Accessor, buffer: &[u8]) -> Result<Vec<[u32; 4]>> {
    let size = match (a.data_type(), a.dimensions(), a.normalized()) {
        (DataType::U8, Dimensions::Vec4, false) => 1,
        (DataType::U16, Dimensions::Vec4, false) => 2,
        _ => {
            return Err(format!(
                "accessor {} is {}; joints are UNSIGNED_BYTE or UNSIGNED_SHORT VEC4",
                a.index(),
                described(a)
            ));
        }
    };
    let l = layout(a, 4 * size, buffer)?;
    Ok((0..l.count)
        .map(|i| {
            let e = &l.bytes[i * l.stride..];
            std::array::from_fn(|c| match size {
                1 => e[c] as u32,
                _ => u16::from_le_bytes([e[2 * c], e[2 * c + 1]]) as u32,
            })
        })
        .collect())
}
