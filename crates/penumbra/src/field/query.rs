//! A field made ready for many lookups (Algorithm 2's inner loop).
//!
//! Every tap of a lookup reads its map in the map's own frame, whose normal
//! is the positional sample's position on the sphere: the octahedral map
//! (`positions::square_to_sphere`) costs a sine and a cosine, four times per
//! ray with bilinear positional interpolation. The frames depend only on the
//! map, so `FieldQuery` computes each once into a table (4225 maps: 150 KB)
//! and the lookups read it. The values are the very ones `map_frame` returns,
//! so answers are bit for bit those of `DisplacementField::trace` (and the
//! WGSL kernels, which compute the frames per tap, see the same frames).

use glam::Vec3;

use super::build::{DisplacementField, map_frame};
use super::lookup::{FieldTrace, Positional};
use crate::geom::sampling::Frame;

/// A field with its maps' frames tabulated.
#[derive(Debug, Clone)]
pub struct FieldQuery<'f> {
    /// The field the lookups read.
    pub field: &'f DisplacementField,
    frames: Vec<Frame>,
}

impl<'f> FieldQuery<'f> {
    /// `field` with its maps' frames computed, one per map.
    pub fn new(field: &'f DisplacementField) -> Self {
        let frames = (0..field.params.grid.count())
            .map(|m| map_frame(&field.params, m))
            .collect();
        FieldQuery { field, frames }
    }

    /// Map m's frame is `frames()[m]`.
    pub fn frames(&self) -> &[Frame] {
        &self.frames
    }

    /// `DisplacementField::trace`, reading the frames from the table.
    #[inline]
    pub fn trace(&self, o: Vec3, d: Vec3, positional: Positional) -> FieldTrace {
        self.field.trace_in(o, d, positional, |m| self.frames[m as usize])
    }
}
