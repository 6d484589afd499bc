//! Rays and hits in the command-line contract's units.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// A ray `o + t d`. The direction need not be normalised: `t` is measured in
/// units of `d`, as in the `trace-rays` file format.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Ray {
    pub origin: [f32; 3],
    pub dir: [f32; 3],
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Ray {
            origin: origin.to_array(),
            dir: dir.to_array(),
        }
    }

    pub fn o(&self) -> Vec3 {
        Vec3::from_array(self.origin)
    }

    pub fn d(&self) -> Vec3 {
        Vec3::from_array(self.dir)
    }
}

/// Closest hit of a ray: `(t, triangle index)`, a miss is `(+inf, MISS)`.
/// Same layout as a `HITS.bin` record and as the GPU kernel's output.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Hit {
    pub t: f32,
    pub triangle: u32,
}

impl Hit {
    /// Triangle index of a miss.
    pub const MISS_INDEX: u32 = u32::MAX;
    pub const MISS: Hit = Hit {
        t: f32::INFINITY,
        triangle: Hit::MISS_INDEX,
    };

    pub fn is_hit(&self) -> bool {
        self.triangle != Hit::MISS_INDEX
    }
}
