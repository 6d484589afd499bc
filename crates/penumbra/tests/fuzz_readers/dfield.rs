//! `.dfield`: `field::file::from_bytes` and `read`.

use std::path::Path;

use glam::Vec3;
use penumbra::field::{DirectionMapping, DisplacementField, FieldData, FieldSampling, OctahedralGrid, Storage, file};
use penumbra::progress::Bar;
use penumbra::scene::Mesh;
use proptest::collection::vec;
use proptest::option;
use proptest::prelude::*;
use proptest::sample::select;

use crate::harness::{Budget, KIB, Reader, agree, call, fail, finite, ok_or_bad_input, write_case};
use crate::inputs::{SPECIAL_F32, SPECIAL_U32, binary_edit, either, mutated, u32_word, wildness};

const BUDGET: Budget = Budget::new(3, 64 * KIB);

pub static DFIELD: Reader = Reader::new("dfield", &["dfield::from_bytes", "dfield::read"], check);

fn check(dir: &Path, input: &[u8]) -> Result<(), String> {
    let path = write_case(dir.join("case.dfield"), input)?;
    let len = input.len();
    let decoded = call("dfield::from_bytes", BUDGET, len, || file::from_bytes(input))?;
    ok_or_bad_input(&decoded, field_ok)?;
    let read = call("dfield::read", BUDGET, len, || file::read(&path))?;
    agree("from_bytes", &decoded, "read", read, &path, PartialEq::eq)
}

fn field_ok(f: &DisplacementField) -> Result<(), String> {
    let p = &f.params;
    p.validate().map_err(|e| format!("params {p:?}: {e}"))?;
    finite("sphere centre", f.center)?;
    finite("bounds min", f.bounds.min)?;
    finite("bounds max", f.bounds.max)?;
    if !(f.radius.is_finite() && f.radius > 0.0) || f.bounds.min.cmpgt(f.bounds.max).any() {
        return fail(format!("radius {} or bounds {:?}", f.radius, f.bounds));
    }
    let (maps, texels) = (p.maps(), p.texels_per_map());
    let unit = |v: &[f32]| v.iter().all(|x| (0.0..=1.0).contains(x));
    let ok = match &f.data {
        FieldData::F32(v) => v.len() == maps * texels && unit(v),
        FieldData::U8(v) => v.len() == maps * texels,
        FieldData::Bits { words, mean } => words.len() == maps * p.words_per_map() && mean.len() == maps && unit(mean),
    };
    if ok {
        Ok(())
    } else {
        fail(format!("maps inconsistent with {p:?}"))
    }
}

/// Fields of a small closed mesh at every storage and direction mapping.
pub fn seeds() -> Vec<Vec<u8>> {
    let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let positions = vec![p(0.0, 0.0, 0.0), p(1.0, 0.0, 0.0), p(0.0, 1.0, 0.0), p(0.0, 0.0, 1.0)];
    let triangles = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    let mesh = Mesh::new(positions, triangles).unwrap_or_else(|e| panic!("tetrahedron: {e}"));
    let storages = [Storage::F32, Storage::U8, Storage::Bit1];
    let mappings = [
        DirectionMapping::Concentric,
        DirectionMapping::Polar,
        DirectionMapping::Rejection,
    ];
    let mut seeds = Vec::new();
    for (k, (storage, directions)) in storages.into_iter().zip(mappings).enumerate() {
        for (side, res) in [(1, 2), (2 + k as u32, 3), (3, 6), (8, 16)] {
            let params = FieldSampling {
                grid: OctahedralGrid { side },
                res,
                storage,
                directions,
            };
            let (field, _) = DisplacementField::build(&mesh, &params, "tetrahedron", &Bar::hidden())
                .unwrap_or_else(|e| panic!("{params:?}: {e}"));
            seeds.push(file::to_bytes(&field));
        }
    }
    seeds
}

/// CRC-32 appended over `bytes` (as `.dfield` files end).
fn with_crc(mut bytes: Vec<u8>) -> Vec<u8> {
    let crc = crc32fast::hash(&bytes);
    bytes.extend_from_slice(&crc.to_le_bytes());
    bytes
}

/// A mutated seed, its checksum recomputed half of the time so that the
/// mutation reaches the checks behind it.
pub fn mutations() -> impl Strategy<Value = Vec<u8>> {
    (mutated(seeds(), binary_edit(), 4), any::<bool>()).prop_map(|(bytes, fix)| {
        if fix && bytes.len() >= 4 {
            with_crc(bytes[..bytes.len() - 4].to_vec())
        } else {
            bytes
        }
    })
}

/// A header of plausible and wild values, maps of the size it declares
/// (where small) or a few stray bytes, a checksum right or wrong.
pub fn structured() -> impl Strategy<Value = Vec<u8>> {
    wildness().prop_flat_map(header)
}

fn header(wild: f64) -> impl Strategy<Value = Vec<u8>> {
    let word = || select(SPECIAL_U32);
    let sizes = (
        either(wild, 1u32..5, word()),
        either(wild, 2u32..9, word()),
        either(wild, select(vec![1u32, 8, 32]), word()),
        either(wild, 0u32..3, word()),
    );
    // Centre, radius and bounds around them; some replaced by specials.
    let sphere = (vec(-2.0f32..2.0, 3), 0.1f32..4.0);
    let odd_floats = vec((prop::bool::weighted(wild), select(SPECIAL_F32)), 10);
    let declared = (
        any::<u32>(),
        either(wild, Just(None), option::of(u32_word())),
        either(wild, Just(None), option::of(any::<u64>())),
    );
    let body = (
        either(wild, Just(0u8), 1u8..3),
        any::<u64>(),
        vec(any::<u8>(), 0..64),
        prop::bool::weighted(1.0 - wild),
    );
    (sizes, sphere, odd_floats, declared, body).prop_map(
        |((side, res, bits, mapping), (c, r), odd, (triangles, maps, size), (fill, seed, stray, good_crc))| {
            let plain = [
                c[0],
                c[1],
                c[2],
                r,
                c[0] - r,
                c[1] - r,
                c[2] - r,
                c[0] + r,
                c[1] + r,
                c[2] + r,
            ];
            let floats: Vec<f32> = plain
                .iter()
                .zip(&odd)
                .map(|(&p, &(w, o))| if w { o } else { p })
                .collect();
            let maps_u64 = side as u64 * side as u64;
            let texels = res as u64 * res as u64;
            let expected = match bits {
                32 => maps_u64 * texels * 4,
                8 => maps_u64 * texels,
                _ => maps_u64 * (texels.div_ceil(32) * 4 + 4),
            };
            let mut b = Vec::new();
            b.extend_from_slice(file::MAGIC);
            for w in [file::VERSION, 96, side, res, bits, mapping] {
                b.extend_from_slice(&w.to_le_bytes());
            }
            floats.iter().for_each(|x| b.extend_from_slice(&x.to_le_bytes()));
            b.extend_from_slice(&triangles.to_le_bytes());
            b.extend_from_slice(&maps.unwrap_or(side.wrapping_mul(side)).to_le_bytes());
            b.extend_from_slice(&size.unwrap_or(expected).to_le_bytes());
            b.extend_from_slice(&[0; 8]);
            if expected <= 256 * KIB as u64 {
                // Distances in [0, 1] (fill 0), with specials (1), or any bits (2).
                let mut rng = seed | 1;
                for _ in 0..expected / 4 {
                    rng ^= rng << 13;
                    rng ^= rng >> 7;
                    rng ^= rng << 17;
                    let unit = (rng >> 40) as f32 / (1u64 << 24) as f32;
                    let value = match fill {
                        0 => unit,
                        1 => [0.0, 1.0, -0.0, 1.0000001, f32::NAN][(rng % 5) as usize],
                        _ => f32::from_bits(rng as u32),
                    };
                    b.extend_from_slice(&value.to_le_bytes());
                }
                b.extend(std::iter::repeat_n(0u8, (expected % 4) as usize));
            } else {
                b.extend_from_slice(&stray);
            }
            if good_crc {
                with_crc(b)
            } else {
                b.extend_from_slice(&(seed as u32).to_le_bytes());
                b
            }
        },
    )
}
