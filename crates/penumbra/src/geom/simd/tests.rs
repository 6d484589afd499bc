use super::*;

/// Every operation on `a` and `b`, as bits (so NaNs compare).
#[inline(always)]
fn ops<V: Lanes>(a: [f32; 16], b: [f32; 16], m: u16) -> Vec<u32> {
    let (x, y) = (V::from_array(a), V::from_array(b));
    let mut out = Vec::new();
    for v in [
        x.add(y),
        x.sub(y),
        x.mul(y),
        x.div(y),
        x.sqrt(),
        V::select(V::M::from_bits(m), x, y),
        x.compress(V::M::from_bits(m)),
        x.expand(V::M::from_bits(m), y),
    ] {
        out.extend(v.to_array().map(f32::to_bits));
    }
    for k in [x.lt(y), x.le(y), x.gt(y), x.ge(y), x.eq(y), x.ne(y)] {
        out.push(k.bits() as u32);
    }
    let k = x.lt(y);
    let j = V::M::from_bits(m);
    out.extend([k.and(j), k.or(j), k.and_not(j)].map(|k| k.bits() as u32));
    out.push(k.any() as u32);
    // min and max are specified for non-NaN operands only, and up to the
    // sign of a zero (min(-0, 0) may be either).
    let finite = |v: [f32; 16]| v.map(|f| if f.is_nan() { 0.5 } else { f });
    let (x, y) = (V::from_array(finite(a)), V::from_array(finite(b)));
    for v in [x.min(y), x.max(y)] {
        out.extend(v.to_array().map(|f| if f == 0.0 { 0 } else { f.to_bits() }));
    }
    let zero_as_one = |f: f32| if f == 0.0 { 0 } else { f.to_bits() };
    out.extend([x.min_lane(), x.max_lane(), y.min_lane(), y.max_lane()].map(zero_as_one));
    out
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512dq,avx512vl")]
fn ops_avx512(a: [f32; 16], b: [f32; 16], m: u16) -> Vec<u32> {
    ops::<Avx512>(a, b, m)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn ops_avx2(a: [f32; 16], b: [f32; 16], m: u16) -> Vec<u32> {
    ops::<Avx2x2>(a, b, m)
}

#[test]
fn every_isa_computes_what_scalar_code_does() {
    let specials = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        1e-40,
        3.5,
        -2.25,
    ];
    let mut state = 12345u32;
    let mut next = || {
        state = crate::geom::sampling::hash_u32(state);
        state
    };
    for round in 0..200 {
        let mut pick = || {
            let r = next();
            if r % 3 == 0 {
                specials[(r / 3) as usize % specials.len()]
            } else {
                (r as f32 / u32::MAX as f32 - 0.5) * 10.0
            }
        };
        let a: [f32; 16] = std::array::from_fn(|_| pick());
        let mut b: [f32; 16] = std::array::from_fn(|_| pick());
        if round % 4 == 0 {
            b[3] = a[3];
        }
        let m = next() as u16;
        let expect = ops::<Scalar16>(a, b, m);
        for isa in Isa::available() {
            let got = match isa {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: `available` checked the CPU.
                Isa::Avx512 => unsafe { ops_avx512(a, b, m) },
                #[cfg(target_arch = "x86_64")]
                // SAFETY: as above.
                Isa::Avx2 => unsafe { ops_avx2(a, b, m) },
                #[cfg(target_arch = "x86_64")]
                Isa::Sse => ops::<Ssex4>(a, b, m),
                _ => ops::<Scalar16>(a, b, m),
            };
            let first = got.iter().zip(&expect).position(|(g, e)| g != e);
            assert!(
                first.is_none(),
                "{isa:?} on {a:?} {b:?}: word {first:?}, {:?}",
                first.map(|i| (got[i], expect[i]))
            );
        }
    }
}

/// `compress` and `expand` as defined (the scalar lanes' default, which
/// the other sets are compared with above).
#[test]
fn compress_packs_and_expand_spreads_in_order() {
    let x = Scalar16::from_array(std::array::from_fn(|i| i as f32));
    let packed = x.compress(0b1000_0000_0001_0110).to_array();
    assert_eq!(packed[..5], [1.0, 2.0, 4.0, 15.0, 0.0]);
    let back = Scalar16::from_array(packed).expand(0b1000_0000_0001_0110, Scalar16::splat(-1.0));
    let mut expect = [-1.0f32; 16];
    for r in [1, 2, 4, 15] {
        expect[r] = r as f32;
    }
    assert_eq!(back.to_array(), expect);
}

#[test]
fn best_is_available() {
    assert!(Isa::best().is_available());
    assert_eq!(Isa::available().last(), Some(&Isa::Scalar));
}
