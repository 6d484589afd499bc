//! Every lane of the batch lookup against the scalar lookup, bit for bit,
//! in every instruction set this CPU runs.

use glam::Vec3;

use super::*;
use crate::field::build::DisplacementField;
use crate::field::lookup::FieldTrace;
use crate::field::positions::OctahedralGrid;
use crate::field::storage::{FieldSampling, Storage};
use crate::geom::simd::{Isa, Kernel, Lanes, dispatch};
use crate::progress::Bar;
use crate::scene::procedural::sphere_on_plane;

/// One batch as a kernel, to run in a chosen instruction set.
struct Batch<'b, 'q, 'f> {
    batch: &'b Batchable<'q, 'f>,
    o: Vec3,
    d: &'b Directions,
}

impl Kernel for Batch<'_, '_, '_> {
    type Out = Traces;
    #[inline(always)]
    fn run<V: Lanes>(self) -> Traces {
        self.batch.trace(self.o, self.d)
    }
}

fn field(directions: DirectionMapping, storage: Storage) -> DisplacementField {
    let params = FieldSampling {
        grid: OctahedralGrid { side: 17 },
        res: 16,
        storage,
        directions,
    };
    DisplacementField::build(&sphere_on_plane(), &params, "sphere on plane", &Bar::hidden())
        .unwrap()
        .0
}

/// A small deterministic generator (xorshift), uniform in [-1, 1).
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        (self.0 >> 8) as f32 / (1u32 << 23) as f32 - 1.0
    }
    fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.next(), self.next(), self.next());
            if v.length_squared() > 1e-4 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}

/// Origins outside, on and inside the sphere, and along the axes (where
/// the square maps have their seams), sixteen directions each; a few
/// directions along the axes and the diagonals too.
fn check(
    field: &DisplacementField,
    positional: Positional,
    run: impl Fn(&Batchable, Vec3, &Directions) -> Traces,
) -> usize {
    let query = FieldQuery::new(field);
    let batch = Batchable::of(&query, positional).expect("8-bit concentric maps batch");
    let mut rng = Rng(0x9e37_79b9);
    let (c, r) = (field.center, field.radius);
    let mut compared = 0;
    for k in 0..400 {
        let o = match k % 4 {
            0 => c + rng.unit() * r * 2.5,
            1 => c + rng.unit() * r * 0.6,
            2 => c + rng.unit() * r,
            _ => c + Vec3::Y * r * 1.5,
        };
        let mut d = Directions::default();
        for i in 0..LANES {
            let v = match (k, i) {
                (0..=3, 0) => Vec3::X,
                (0..=3, 1) => -Vec3::Z,
                (0..=3, 2) => Vec3::new(1.0, 1.0, 0.0).normalize(),
                (0..=3, 3) => -Vec3::Y,
                _ => rng.unit(),
            };
            (d.x[i], d.y[i], d.z[i]) = (v.x, v.y, v.z);
        }
        let traces = run(&batch, o, &d);
        assert_eq!(
            batch.enters(o, &d),
            !traces.outside,
            "`enters` is the lanes not outside"
        );
        for i in 0..LANES {
            let dir = Vec3::new(d.x[i], d.y[i], d.z[i]);
            let scalar = query.trace(o, dir, positional);
            let lane = traces.lane(i);
            let same = match (scalar, lane) {
                (FieldTrace::Hit { t: a, inside: x }, FieldTrace::Hit { t: b, inside: y }) => {
                    a.to_bits() == b.to_bits() && x == y
                }
                _ => scalar == lane,
            };
            assert!(
                same,
                "origin {o}, direction {dir}: scalar {scalar:?}, lane {i} {lane:?}"
            );
            compared += 1;
        }
    }
    compared
}

#[test]
fn every_lane_is_the_scalar_lookup_in_every_instruction_set() {
    let field = field(DirectionMapping::Concentric, Storage::U8);
    let mut hits = 0;
    let query = FieldQuery::new(&field);
    let batch = Batchable::of(&query, Positional::Bilinear).unwrap();
    let o = field.center + Vec3::Y * field.radius * 1.5;
    let mut d = Directions::default();
    for i in 0..LANES {
        let v = Vec3::new(0.05 * i as f32 - 0.4, -1.0, 0.1).normalize();
        (d.x[i], d.y[i], d.z[i]) = (v.x, v.y, v.z);
    }
    hits += batch.trace(o, &d).hit.count_ones();
    assert!(hits > 8, "the rays down onto the sphere hit ({hits} of 16)");
    for positional in [Positional::Bilinear, Positional::Nearest] {
        let n = check(&field, positional, |b, o, d| b.trace(o, d));
        assert_eq!(n, 400 * LANES);
        for isa in Isa::available() {
            let m = check(&field, positional, |batch, o, d| dispatch(isa, Batch { batch, o, d }));
            assert_eq!(m, n, "{isa:?} {positional:?}");
        }
    }
}

#[test]
fn only_8_bit_concentric_maps_batch() {
    for (directions, storage, positional, batches) in [
        (DirectionMapping::Concentric, Storage::U8, Positional::Bilinear, true),
        (DirectionMapping::Concentric, Storage::U8, Positional::Nearest, true),
        (DirectionMapping::Polar, Storage::U8, Positional::Bilinear, false),
        (DirectionMapping::Concentric, Storage::F32, Positional::Bilinear, false),
    ] {
        let field = field(directions, storage);
        let query = FieldQuery::new(&field);
        assert_eq!(Batchable::of(&query, positional).is_some(), batches);
    }
}
