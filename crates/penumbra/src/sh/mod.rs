//! Real spherical harmonics (SH): basis, projection of environment maps,
//! rotation of coefficient vectors, zonal functions and irradiance.
//!
//! Conventions, used everywhere in penumbra:
//!
//! * **Order** is counted in bands: `bands = 5` means l = 0..4, 25
//!   coefficients (the paper's "4th-order, 25-term" basis).
//! * **Coefficient order**: index `i = l (l + 1) + m`, m = -l..l, so band l
//!   occupies `l²..(l+1)²` and m = 0 sits in its middle.
//! * **Normalisation**: orthonormal on the unit sphere, `∫ Y_i Y_j ds = δ_ij`.
//! * **Condon–Shortley phase: not included.** `Y_l,m ∝ +P_l^m(cos θ) cos(mφ)`,
//!   `Y_l,-m ∝ +P_l^m(cos θ) sin(mφ)` with P_l^m > 0 near the pole, so band 1 is
//!   `sqrt(3/4π) (y, z, x)` with positive signs (the convention of Sloan,
//!   Kautz and Snyder 2002 and of Ramamoorthi and Hanrahan 2001).
//! * **Angles**: θ from +z, φ from +x towards +y, in whatever frame the
//!   coefficients live in (world, or a vertex's tangent frame with the
//!   normal along +z).
//!
//! Evaluation (`basis`) is by fully normalised recurrences in (x, y, z),
//! stable to high order (tests go to 15 bands).

pub(crate) mod basis;
pub(crate) mod projection;
pub mod quadrature;
pub mod rotation;
pub mod window;
pub mod zonal;

pub use basis::ShBasis;
pub use projection::{ShRgb, project_environment};
pub use rotation::{ShRotation, tangent_frame};

/// Coefficients of `bands` bands.
#[inline]
pub const fn coefficient_count(bands: usize) -> usize {
    bands * bands
}

/// Index of coefficient (l, m).
#[inline]
pub const fn index(l: usize, m: isize) -> usize {
    ((l * (l + 1)) as isize + m) as usize
}

/// Most bands penumbra accepts (the rotation's scratch arrays; tests check
/// stability to 15).
pub const MAX_BANDS: usize = 16;
