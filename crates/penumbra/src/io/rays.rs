//! The command-line contract's binary formats: RAYS.f32 (N records of six
//! little-endian f32: origin, direction) and HITS.bin (N records of f32 t,
//! u32 triangle; a miss is +inf, 0xFFFFFFFF), so that other tracers can run
//! and compare the very same rays.

use std::path::Path;

use crate::error::{Error, Result};
use crate::geom::ray::{Hit, Ray};

/// Reads N records of 6 little-endian f32 (origin, direction). Every
/// component must be finite and every direction non-zero.
pub fn read_rays(path: &Path) -> Result<Vec<Ray>> {
    let bytes = std::fs::read(path).map_err(|e| Error::read(path, e))?;
    if bytes.len() % 24 != 0 {
        return Err(Error::file(
            path,
            "size",
            format!(
                "{} bytes is not a whole number of rays (24 bytes each: 6 little-endian f32)",
                bytes.len()
            ),
        ));
    }
    let mut rays = Vec::with_capacity(bytes.len() / 24);
    for (i, record) in bytes.chunks_exact(24).enumerate() {
        let mut c = [0f32; 6];
        for (k, slot) in c.iter_mut().enumerate() {
            *slot = f32::from_le_bytes(record[4 * k..4 * k + 4].try_into().expect("4 bytes"));
        }
        const NAMES: [&str; 6] = ["ox", "oy", "oz", "dx", "dy", "dz"];
        if let Some(k) = c.iter().position(|v| !v.is_finite()) {
            return Err(Error::file(
                path,
                format!("ray {i}"),
                format!("{} is {}; must be finite", NAMES[k], c[k]),
            ));
        }
        if c[3] == 0.0 && c[4] == 0.0 && c[5] == 0.0 {
            return Err(Error::file(path, format!("ray {i}"), "direction is the zero vector"));
        }
        rays.push(Ray {
            origin: [c[0], c[1], c[2]],
            dir: [c[3], c[4], c[5]],
        });
    }
    Ok(rays)
}

/// `read_rays` with the origins moved into the frame of a mesh whose
/// origin is `origin` (`scene::frame`). The move is exact (an f32 origin
/// minus a grid point near it, in f64, fits f32), so t and the hits are
/// those of the world-space rays; but the file's f32 origins are what they
/// are: 1e6 model sizes off, f32 steps are about 1/8 of the model, and an
/// origin between them was rounded when the file was written.
pub fn read_rays_in(path: &Path, origin: glam::DVec3) -> Result<Vec<Ray>> {
    let mut rays = read_rays(path)?;
    if origin != glam::DVec3::ZERO {
        for r in &mut rays {
            let world = glam::Vec3::from_array(r.origin).as_dvec3();
            r.origin = crate::scene::frame::to_local(origin, world).to_array();
        }
    }
    Ok(rays)
}

/// Writes rays as N records of 6 little-endian f32 (origin, direction).
pub fn write_rays(path: &Path, rays: &[Ray]) -> Result<()> {
    let mut bytes = Vec::with_capacity(rays.len() * 24);
    for r in rays {
        for c in r.origin.iter().chain(&r.dir) {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    crate::io::output::write_bytes(path, &bytes)
}

/// Writes N records of (f32 t, u32 triangle), little-endian; a miss is
/// (+inf, 0xFFFFFFFF).
pub fn write_hits(path: &Path, hits: &[Hit]) -> Result<()> {
    let mut bytes = Vec::with_capacity(hits.len() * 8);
    for h in hits {
        let (t, tri) = if h.is_hit() {
            (h.t, h.triangle)
        } else {
            (f32::INFINITY, Hit::MISS_INDEX)
        };
        bytes.extend_from_slice(&t.to_le_bytes());
        bytes.extend_from_slice(&tri.to_le_bytes());
    }
    crate::io::output::write_bytes(path, &bytes)
}
