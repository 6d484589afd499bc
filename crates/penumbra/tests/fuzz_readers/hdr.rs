//! HDR probes: `EnvironmentMap::load`.

use std::path::Path;

use image::Rgb;
use image::codecs::hdr::HdrEncoder;
use penumbra::scene::EnvironmentMap;
use proptest::collection::vec;
use proptest::option;
use proptest::prelude::*;
use proptest::sample::{Index, select};

use crate::harness::{Budget, MIB, Reader, call, fail, names, write_case};
use crate::inputs::{either, pick, wildness};

/// A `width` x `height` Radiance HDR file (RLE from width 8) of smooth
/// radiance; `variant` changes the values.
pub fn hdr_bytes(width: usize, height: usize, variant: u32) -> Vec<u8> {
    let pixels: Vec<Rgb<f32>> = (0..width * height)
        .map(|i| {
            let (x, y) = ((i % width) as f32, (i / width) as f32);
            match variant {
                0 => Rgb([1.0 + x / 8.0, 0.5 + y, 0.25]),
                1 => Rgb([3.0, 3.0, 3.0]),
                _ => Rgb([x * 1e3, 1e-3 * y, if (i / 7) % 2 == 0 { 0.0 } else { 60000.0 }]),
            }
        })
        .collect();
    let mut out = Vec::new();
    if let Err(e) = HdrEncoder::new(&mut out).encode(&pixels, width, height) {
        panic!("encoding a {width}x{height} probe: {e}");
    }
    out
}

/// Encoded probes (flat and RLE), an old-style RLE file and bare headers.
pub fn seeds() -> Vec<Vec<u8>> {
    let mut seeds = vec![
        hdr_bytes(8, 4, 0),
        hdr_bytes(2, 1, 0),
        hdr_bytes(32, 16, 2),
        hdr_bytes(64, 32, 1),
        hdr_bytes(4, 4, 0),
        // Long runs: the most pixels per byte RLE gives.
        hdr_bytes(1024, 512, 1),
    ];
    // Old-style RLE at the most pixels per byte the reader admits: a pixel
    // and two run markers (255 + 3 x 256 repeats) a row, padded to 1/64
    // byte a pixel.
    let (width, height) = (1024, 512);
    let mut dense = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n").into_bytes();
    for _ in 0..height {
        dense.extend_from_slice(&[128, 64, 32, 129, 1, 1, 1, 255, 1, 1, 1, 3]);
    }
    dense.resize((width * height - 4096) / 64, 0);
    seeds.push(dense);
    let header = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1.0\n\n-Y 2 +X 4\n";
    // One pixel, then old-style repeat records: 3 more pixels, a row each.
    let mut old_rle = header.to_vec();
    for _ in 0..2 {
        old_rle.extend_from_slice(&[128, 64, 32, 129, 1, 1, 1, 3]);
    }
    seeds.push(old_rle);
    seeds.push(header.to_vec());
    seeds.push(b"#?RGBE\n\n+Y 1 +X 2\n\x80\x80\x80\x81\x40\x40\x40\x80".to_vec());
    seeds
}

const BUDGET: Budget = Budget::new(64 * 12 * 2, MIB);

pub static HDR: Reader = Reader::new("hdr", &["EnvironmentMap::load"], check);

fn check(dir: &Path, input: &[u8]) -> Result<(), String> {
    let path = write_case(dir.join("case.hdr"), input)?;
    match call("EnvironmentMap::load", BUDGET, input.len(), || {
        EnvironmentMap::load(&path)
    })? {
        Ok(map) => map_ok(&map),
        Err(e) => names(&e, &path),
    }
}

pub fn map_ok(map: &EnvironmentMap) -> Result<(), String> {
    let (w, h) = (map.width as usize, map.height as usize);
    if h == 0 || w != 2 * h || map.texels.len() != w * h {
        return fail(format!("a {w}x{h} map of {} texels", map.texels.len()));
    }
    match map
        .texels
        .iter()
        .position(|t| t.iter().any(|c| !c.is_finite() || *c < 0.0))
    {
        Some(i) => fail(format!("texel {i} is {:?}", map.texels[i])),
        None => Ok(()),
    }
}

/// A header of random attribute and dimension lines, then a flat, RLE or
/// old-RLE body.
pub fn structured() -> impl Strategy<Value = Vec<u8>> {
    wildness().prop_flat_map(hdr_file)
}

/// Pixels of a `width` x `height` probe from `seed`: flat RGBE, or rows of
/// Radiance's RLE (runs and literals, per channel), exponents kept sane.
fn rgbe_body(width: usize, height: usize, rle: bool, seed: u64) -> Vec<u8> {
    let mut rng = seed | 1;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    let mut value = |channel: usize| {
        let r = next();
        if channel == 3 { 100 + (r % 40) as u8 } else { r as u8 }
    };
    let mut out = Vec::new();
    for _ in 0..height {
        if !rle {
            for _ in 0..width {
                out.extend((0..4).map(&mut value));
            }
            continue;
        }
        out.extend_from_slice(&[2, 2, (width >> 8) as u8, width as u8]);
        for channel in 0..4 {
            let mut left = width;
            while left > 0 {
                let n = 1 + (value(0) as usize % left.min(127));
                if value(0) % 2 == 0 {
                    out.extend_from_slice(&[128 + n as u8, value(channel)]);
                } else {
                    out.push(n as u8);
                    out.extend((0..n).map(|_| value(channel)));
                }
                left -= n;
            }
        }
    }
    out
}

/// A probe file: a header of attribute lines and dimensions, and a body
/// that matches them (where tame) or not.
fn hdr_file(wild: f64) -> impl Strategy<Value = Vec<u8>> {
    let signature = either(
        wild,
        pick(&["#?RADIANCE\n", "#?RGBE\n"]),
        pick(&["", "#?\n", "#?RADIANCE", "#?X\n"]),
    );
    let attribute = either(
        wild,
        pick(&[
            "FORMAT=32-bit_rle_rgbe",
            "EXPOSURE=1",
            "GAMMA=2.2",
            "# comment",
            "PIXASPECT=1",
            "SOFTWARE=x",
        ]),
        pick(&[
            "FORMAT=32-bit_rle_xyze",
            "FORMAT=foo",
            "EXPOSURE=nan",
            "EXPOSURE=-1e39",
            "PIXASPECT=0",
            "COLORCORR=1 1",
            "PRIMARIES=0 0 0 0 0 0 0 0",
            "x",
            "=",
        ]),
    );
    let dim = prop_oneof![
        4 => (1u32..40).prop_map(|n| n.to_string()),
        1 => pick(&["0", "16384", "16385", "32768", "4294967295", "4294967296", "-1", "99999999999999999999",
            "x", "", "+4"]),
    ];
    let axes = select(vec![
        ("-Y", "+X"),
        ("+Y", "+X"),
        ("-Y", "-X"),
        ("+X", "-Y"),
        ("Y", "X"),
        ("-Z", "+X"),
    ]);
    let odd_dims = option::of((axes, dim.clone(), dim));
    let body = (
        1usize..12,
        any::<bool>(),
        any::<u64>(),
        either(wild, Just(0u8), 1u8..4),
        vec(any::<u8>(), 0..512),
        any::<Index>(),
    );
    (
        signature,
        vec(attribute, 0..3),
        either(wild, Just(None), odd_dims),
        body,
    )
        .prop_map(
            |(signature, attributes, odd_dims, (height, rle, seed, corrupt, noise, at))| {
                let width = 2 * height;
                let mut b = signature.into_bytes();
                attributes
                    .iter()
                    .for_each(|a| b.extend_from_slice(format!("{a}\n").as_bytes()));
                let dims = match odd_dims {
                    Some(((y, x), h, w)) => format!("{y} {h} {x} {w}"),
                    None => format!("-Y {height} +X {width}"),
                };
                b.extend_from_slice(format!("\n{dims}\n").as_bytes());
                let mut pixels = rgbe_body(width, height, rle && width >= 8, seed);
                match corrupt {
                    0 => {}
                    1 => pixels = noise,
                    2 => pixels.truncate(at.index(pixels.len() + 1)),
                    _ => noise.iter().enumerate().for_each(|(k, &x)| {
                        let i = (at.index(pixels.len().max(1)) + 97 * k) % pixels.len().max(1);
                        if let Some(p) = pixels.get_mut(i) {
                            *p ^= x;
                        }
                    }),
                }
                b.extend(pixels);
                b
            },
        )
}
