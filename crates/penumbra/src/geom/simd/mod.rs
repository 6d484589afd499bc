//! Sixteen f32 lanes for packet traversal, in whatever vector registers the
//! CPU has: one AVX-512 register, two AVX2 registers, four SSE registers
//! (SSE2 is part of x86-64, so always there), or a plain array elsewhere.
//!
//! The kernels that use them (`kdtree::occlusion`) are written once, generic
//! over `Lanes`, and instantiated inside a `#[target_feature]` function per
//! instruction set, chosen at run time by `Isa::best()` (as the PRT
//! rasteriser dispatches its AVX2 path). Every lane operation is one IEEE
//! operation with Rust's scalar semantics (no fused multiply-add, ordered
//! comparisons false on NaN, `!=` true on NaN), so a lane computes bit for
//! bit what the scalar code computes for its ray.
//!
//! Only code inlined into the `#[target_feature]` function gets its
//! instruction set: a closure over lanes that the compiler keeps out of
//! line, or hands to `array::map` / `array::from_fn` (generic library code
//! compiled without the feature), turns every intrinsic in it into a call.
//! Kernels therefore use `#[inline(always)]` functions, not such closures;
//! `nm -C` on the binary lists no `core_arch` intrinsic as a function when
//! all is inlined (the AO packets on AVX2 ran 30 to 50% slower otherwise).

mod lanes;
mod scalar;
#[cfg(target_arch = "x86_64")]
mod x86;

pub use lanes::{Lanes, Mask};
pub use scalar::Scalar16;
#[cfg(target_arch = "x86_64")]
pub use x86::{Avx2x2, Avx512, Ssex4};

use std::sync::OnceLock;

/// An instruction set the lanes can run in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Isa {
    /// One 512-bit register and a 16-bit mask register (AVX-512 F, BW, DQ, VL).
    Avx512,
    /// Two 256-bit registers (AVX2).
    Avx2,
    /// Four 128-bit registers (SSE2, every x86-64 CPU).
    Sse,
    /// Sixteen scalars (the compiler vectorises what it can).
    Scalar,
}

/// The set `best` returns, chosen once per process.
static BEST: OnceLock<Isa> = OnceLock::new();

impl Isa {
    /// Whether this CPU runs `self`.
    pub fn is_available(self) -> bool {
        match self {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                std::is_x86_feature_detected!("avx512f")
                    && std::is_x86_feature_detected!("avx512bw")
                    && std::is_x86_feature_detected!("avx512dq")
                    && std::is_x86_feature_detected!("avx512vl")
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => std::is_x86_feature_detected!("avx2"),
            #[cfg(target_arch = "x86_64")]
            Isa::Sse => true,
            Isa::Scalar => true,
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// Every instruction set this CPU runs, widest first.
    pub fn available() -> Vec<Isa> {
        [Isa::Avx512, Isa::Avx2, Isa::Sse, Isa::Scalar]
            .into_iter()
            .filter(|i| i.is_available())
            .collect()
    }

    /// The widest available (detected once), or the one `prefer` chose.
    pub fn best() -> Isa {
        *BEST.get_or_init(|| Isa::available()[0])
    }

    /// Makes `isa` (where this CPU runs it) what `best` returns for the rest
    /// of the process, to measure what a wider set buys; must come before
    /// any traversal asks. Returns the set in force: `isa`, or the one
    /// already chosen or detected.
    pub fn prefer(isa: Isa) -> Isa {
        *BEST.get_or_init(|| if isa.is_available() { isa } else { Isa::available()[0] })
    }

    /// The set named `s` (`avx512`, `avx2`, `sse`, `scalar`; any case).
    pub fn parse(s: &str) -> Option<Isa> {
        match s.to_ascii_lowercase().as_str() {
            "avx512" => Some(Isa::Avx512),
            "avx2" => Some(Isa::Avx2),
            "sse" => Some(Isa::Sse),
            "scalar" => Some(Isa::Scalar),
            _ => None,
        }
    }

    /// `self` if this CPU runs it, else the widest one it runs.
    pub fn or_best(self) -> Isa {
        if self.is_available() { self } else { Isa::best() }
    }
}

/// Writes `value` into `out[r]` for every lane `r` whose bit is set in
/// `bits` (a mask's bits: the lanes a triangle hit, say).
#[inline(always)]
pub fn set_lanes<T: Copy>(out: &mut [T; 16], bits: u16, value: T) {
    let mut bits = bits;
    while bits != 0 {
        let r = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        out[r] = value;
    }
}

/// Work generic over the lanes, run by `dispatch` in one instruction set.
pub trait Kernel {
    /// What the work returns.
    type Out;
    /// The work in lanes `V`. Implementations are `#[inline(always)]` (as
    /// everything they call on the lanes), so that they compile into the
    /// dispatching `#[target_feature]` function.
    fn run<V: Lanes>(self) -> Self::Out;
}

/// Runs `kernel` in `isa`, or in the widest instruction set the CPU has if
/// it lacks `isa`.
#[inline]
pub fn dispatch<K: Kernel>(isa: Isa, kernel: K) -> K::Out {
    match isa.or_best() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `or_best` returns an instruction set this CPU has.
        Isa::Avx512 => unsafe { run_avx512(kernel) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above.
        Isa::Avx2 => unsafe { run_avx2(kernel) },
        #[cfg(target_arch = "x86_64")]
        Isa::Sse => kernel.run::<Ssex4>(),
        _ => kernel.run::<Scalar16>(),
    }
}

// The kernel compiled with each instruction set enabled, so that the lanes'
// intrinsics inline as single instructions (and the compiler may use the
// wider registers for the kernel's scalar loops too).
// AVX-512 as Skylake-X and later have it (F, BW, DQ, VL: what Embree's
// AVX-512 path requires too); the lanes use F only, the rest lets the
// compiler vectorise the kernels' integer loops (the AO samples' hashing).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512dq,avx512vl")]
fn run_avx512<K: Kernel>(kernel: K) -> K::Out {
    kernel.run::<Avx512>()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn run_avx2<K: Kernel>(kernel: K) -> K::Out {
    kernel.run::<Avx2x2>()
}

#[cfg(test)]
mod tests;
