//! The containers of a glTF asset: the GLB chunks, and the buffers its
//! JSON names (the GLB's BIN chunk, base64 `data:` URIs, files relative to
//! the asset).
//!
//! The GLB header and chunks are read here rather than by
//! `gltf::binary::Glb::from_slice`, which subtracts the 12-byte header from
//! the declared length unchecked (a length below 12 underflows) and reports
//! a bad chunk without saying which chunk or by how much.

use crate::scene::mesh_file::is_glb;
use std::path::{Path, PathBuf};

use base64::Engine;

use crate::error::{Error, Result};

const HEADER: usize = 12;
const CHUNK_HEADER: usize = 8;
const JSON: u32 = u32::from_le_bytes(*b"JSON");
const BIN: u32 = u32::from_le_bytes(*b"BIN\0");

/// The JSON chunk and the BIN chunk (if any) of a GLB file. Errors name the
/// header field or chunk and the problem.
pub fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>)> {
    let word = |at: usize| -> Option<u32> {
        let b = bytes.get(at..at + 4)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    if !is_glb(bytes) {
        return Err(Error::input(
            "GLB header",
            "the file does not start with the GLB magic 'glTF'",
        ));
    }
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err(Error::input(
            "GLB header",
            format!("is 12 bytes; the file has {}", bytes.len()),
        ));
    };
    if version != 2 {
        return Err(Error::input(
            "GLB header",
            format!("version {version} (only glTF 2.0 is read)"),
        ));
    }
    let length = length as usize;
    if length < HEADER || length > bytes.len() {
        return Err(Error::input(
            "GLB header",
            format!(
                "declares a length of {length} bytes; the file has {} (and the header alone 12)",
                bytes.len()
            ),
        ));
    }
    let mut chunks: Vec<(u32, &[u8])> = Vec::new();
    let mut at = HEADER;
    while at < length {
        let index = chunks.len();
        let (Some(size), Some(kind)) = (word(at).filter(|_| at + CHUNK_HEADER <= length), word(at + 4)) else {
            return Err(Error::input(
                format!("GLB chunk {index}"),
                format!("header at byte {at} is cut short by the end of the file ({length} bytes)"),
            ));
        };
        let start = at + CHUNK_HEADER;
        let end = start
            .checked_add(size as usize)
            .filter(|&end| end <= length)
            .ok_or_else(|| {
                Error::input(
                    format!("GLB chunk {index}"),
                    format!("declares {size} bytes at byte {start}, past the end of the file ({length} bytes)"),
                )
            })?;
        chunks.push((kind, &bytes[start..end]));
        // Chunks are 4-byte aligned; the padding is part of the length.
        at = end.next_multiple_of(4);
    }
    let json = match chunks.first() {
        Some(&(JSON, json)) => json,
        _ => return Err(Error::input("GLB chunk 0", "is not a JSON chunk")),
    };
    // A BIN chunk, if any, comes second; other chunk types are skipped (the
    // format reserves them for extensions).
    let bin = chunks.get(1).filter(|(kind, _)| *kind == BIN).map(|&(_, b)| b);
    Ok((json, bin))
}

/// The data of a buffer, by the JSON's description of it.
pub enum Source<'a> {
    /// The GLB's BIN chunk (a buffer without a URI).
    Bin(Option<&'a [u8]>),
    Uri(&'a str),
}

/// Loads one buffer's bytes: the BIN chunk, a base64 `data:` URI or a file
/// relative to `dir` (percent-decoded). At least `length` bytes (the
/// buffer's `byteLength`) must be there; the rest is cut off, so that a
/// view past `byteLength` is an error as the format says. Problems come
/// back as text; the caller names the glTF file and the buffer.
pub fn load(source: Source, length: usize, dir: &Path) -> std::result::Result<Vec<u8>, String> {
    let mut data = match source {
        Source::Bin(Some(bin)) => bin.to_vec(),
        Source::Bin(None) => return Err("has no uri and the file has no GLB BIN chunk".into()),
        Source::Uri(uri) if uri.starts_with("data:") => data_uri(uri)?,
        Source::Uri(uri) => read_file(uri, &relative_path(uri, dir)?, length)?,
    };
    if data.len() < length {
        return Err(format!(
            "byteLength is {length} but the data holds {} bytes",
            data.len()
        ));
    }
    data.truncate(length);
    Ok(data)
}

/// The first `length` bytes of a buffer's file: a regular file (not a
/// device or a pipe, which could be endless) at least that long, so that
/// what is allocated is bounded by the file and by `byteLength` both.
fn read_file(uri: &str, path: &Path, length: usize) -> std::result::Result<Vec<u8>, String> {
    use std::io::Read;
    let cannot = |e: std::io::Error| format!("cannot read '{uri}' ({}): {e}", path.display());
    let file = std::fs::File::open(path).map_err(cannot)?;
    let meta = file.metadata().map_err(cannot)?;
    if !meta.is_file() {
        return Err(format!("'{uri}' ({}) is not a regular file", path.display()));
    }
    if meta.len() < length as u64 {
        return Err(format!(
            "byteLength is {length} but '{uri}' ({}) holds {} bytes",
            path.display(),
            meta.len()
        ));
    }
    let mut data = Vec::with_capacity(length);
    file.take(length as u64).read_to_end(&mut data).map_err(cannot)?;
    Ok(data)
}

pub fn data_uri(uri: &str) -> std::result::Result<Vec<u8>, String> {
    let (_, payload) = uri
        .split_once(";base64,")
        .ok_or_else(|| "is a data: URI that is not base64 (';base64,' is missing)".to_string())?;
    base64::engine::general_purpose::STANDARD
        .decode(payload.trim_end())
        .map_err(|e| format!("data: URI is not valid base64: {e}"))
}

/// A relative URI reference as a path under `dir`. URIs with a scheme
/// (`http:`, `file:`) are refused: a mesh is read from the asset's folder.
pub fn relative_path(uri: &str, dir: &Path) -> std::result::Result<PathBuf, String> {
    let scheme = uri
        .split_once(':')
        .map(|(s, _)| s)
        .filter(|s| s.len() > 1 && s.bytes().all(|b| b.is_ascii_alphanumeric() || b"+-.".contains(&b)));
    if let Some(scheme) = scheme {
        return Err(format!(
            "uri '{uri}' has the scheme '{scheme}:'; only relative paths and data: URIs are read"
        ));
    }
    let decoded = percent_encoding::percent_decode_str(uri)
        .decode_utf8()
        .map_err(|_| format!("uri '{uri}' is not UTF-8 once percent-decoded"))?;
    Ok(dir.join(decoded.as_ref()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::mesh_file::is_gltf_json;

    fn glb(chunks: &[(&[u8; 4], &[u8])], length: Option<u32>) -> Vec<u8> {
        let mut body = Vec::new();
        for (kind, data) in chunks {
            body.extend((data.len() as u32).to_le_bytes());
            body.extend(*kind);
            body.extend(*data);
        }
        let mut out = b"glTF".to_vec();
        out.extend(2u32.to_le_bytes());
        out.extend(length.unwrap_or(12 + body.len() as u32).to_le_bytes());
        out.extend(body);
        out
    }

    #[test]
    fn glb_chunks_are_checked() {
        let ok = glb(&[(b"JSON", b"{}  "), (b"BIN\0", b"abcd"), (b"XTRA", b"")], None);
        assert_eq!(split_glb(&ok).unwrap(), (&b"{}  "[..], Some(&b"abcd"[..])));
        let no_bin = glb(&[(b"JSON", b"{}  ")], None);
        assert_eq!(split_glb(&no_bin).unwrap(), (&b"{}  "[..], None));
        let cases: [(Vec<u8>, &str); 6] = [
            (b"glTF\x02\0\0\0".to_vec(), "GLB header: is 12 bytes; the file has 8"),
            (glb(&[], Some(8)), "GLB header: declares a length of 8 bytes"),
            (
                glb(&[(b"JSON", b"{}")], Some(1000)),
                "GLB header: declares a length of 1000 bytes; the file has 22",
            ),
            (
                {
                    let mut b = glb(&[(b"JSON", b"{}  ")], None);
                    b[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
                    b
                },
                "GLB chunk 0: declares 4294967295 bytes at byte 20, past the end",
            ),
            (glb(&[(b"BIN\0", b"{}  ")], None), "GLB chunk 0: is not a JSON chunk"),
            (
                {
                    let mut b = glb(&[(b"JSON", b"{}  ")], None);
                    b.extend([0; 4]);
                    let n = b.len() as u32;
                    b[8..12].copy_from_slice(&n.to_le_bytes());
                    b
                },
                "GLB chunk 1: header at byte 24 is cut short",
            ),
        ];
        for (bytes, expected) in cases {
            let e = split_glb(&bytes).unwrap_err().to_string();
            assert!(e.starts_with(expected), "{e}");
        }
        let mut v1 = ok.clone();
        v1[4] = 1;
        assert!(split_glb(&v1).unwrap_err().to_string().contains("version 1"));
    }

    #[test]
    fn buffers_from_uris() {
        let dir = Path::new("/nonexistent-penumbra-dir");
        let data = "data:application/octet-stream;base64,AAECAw==";
        assert_eq!(load(Source::Uri(data), 3, dir).unwrap(), [0, 1, 2]);
        assert!(
            load(Source::Uri(data), 5, dir)
                .unwrap_err()
                .contains("byteLength is 5 but the data holds 4")
        );
        assert!(
            load(Source::Uri("data:,abc"), 1, dir)
                .unwrap_err()
                .contains("not base64")
        );
        assert!(
            load(Source::Uri("data:x;base64,!!"), 1, dir)
                .unwrap_err()
                .contains("not valid base64")
        );
        let e = load(Source::Uri("https://example.com/a.bin"), 1, dir).unwrap_err();
        assert!(e.contains("scheme 'https:'"), "{e}");
        let e = load(Source::Uri("my%20mesh.bin"), 1, dir).unwrap_err();
        assert!(
            e.contains("cannot read 'my%20mesh.bin' (/nonexistent-penumbra-dir/my mesh.bin)"),
            "{e}"
        );
        assert!(
            load(Source::Bin(None), 1, dir)
                .unwrap_err()
                .contains("no GLB BIN chunk")
        );
        assert_eq!(load(Source::Bin(Some(b"abcd")), 2, dir).unwrap(), b"ab");
        let e = load(Source::Uri("."), 1, Path::new("/tmp")).unwrap_err();
        assert!(e.contains("is not a regular file"), "{e}");
    }

    #[test]
    fn gltf_json_is_an_object_with_an_asset_key() {
        assert!(is_gltf_json(
            b"\xef\xbb\xbf \n{\"asset\": {\"version\": \"2.0\"}, \"x\": [1, {}]}"
        ));
        assert!(!is_gltf_json(b"{\"meshes\": {}}"));
        assert!(!is_gltf_json(b"[{\"asset\": 1}]"));
        assert!(!is_gltf_json(b"{\"asset\": 1"));
        assert!(!is_gltf_json(b"v 0 0 0"));
    }
}
