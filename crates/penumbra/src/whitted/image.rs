//! Radiance images out: linear float radiance as OpenEXR (`.exr`) or
//! Portable FloatMap (`.pfm`), or tone-mapped sRGB (`.png`); the format
//! follows the extension and another extension is refused before
//! rendering. The writers are `crate::io::image`'s, shared by every command.

pub use crate::io::image::{ImageFormat, RadianceFormat, read_pfm, write_radiance};
