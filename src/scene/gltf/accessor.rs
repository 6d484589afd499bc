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
