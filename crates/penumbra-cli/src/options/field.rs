//! A displacement field's sampling and storage as command-line options (see
//! `crate::options`): `field build` and `ao --method field` share them.

use crate::options::{Applies, applies};
use penumbra::error::Result;
use penumbra::field::{DirectionMapping, FieldSampling};

/// The field's sampling and storage (`ao --method field` builds fields
/// with them on the fly, without `--field`).
#[derive(clap::Args, Clone, Debug)]
pub struct FieldOptions {
    /// Positional samples on the bounding sphere; the octahedral grid takes
    /// the nearest square (4226 -> 65 x 65 = 4225).
    #[arg(long, default_value_t = 4226, allow_negative_numbers = true)]
    pub positions: i64,
    /// Each map is RES x RES directions.
    #[arg(long, default_value_t = 32, allow_negative_numbers = true)]
    pub res: i64,
    /// Bits per direction: 32 (float), 8, or 1 (visibility + mean distance).
    #[arg(long, default_value_t = 8, allow_negative_numbers = true)]
    pub bits: i64,
    /// How the map's texels cover the hemisphere of directions.
    #[arg(long, value_enum, default_value_t = DirectionMapping::Concentric)]
    pub directions: DirectionMapping,
}

impl FieldOptions {
    /// The options that apply only where fields are built (`used`).
    pub fn applies(used: bool, needs: &'static str) -> Applies {
        applies(used, &["positions", "res", "bits", "directions"], needs)
    }

    pub fn params(&self) -> Result<FieldSampling> {
        FieldSampling::new(self.positions, self.res, self.bits, self.directions)
    }
}
