//! Spherical harmonics: orthonormality, stability to 15 bands, the
//! Condon–Shortley convention, projection of environment maps, the
//! clamped-cosine zonal coefficients, irradiance against brute force on the
//! shared probes, and rotation.

mod common;

use glam::{DMat3, DVec3, Vec3};
use penumbra::scene::EnvironmentMap;
use penumbra::sh::quadrature::SphereQuadrature;
use penumbra::sh::rotation::{band_energies, evaluate, tangent_frame};
use penumbra::sh::zonal::{clamped_cosine_zonal, irradiance, irradiance_bands, irradiance_brute_force};
use penumbra::sh::{ShBasis, ShRotation, coefficient_count, index, project_environment};

/// Worst |∫ Y_i Y_j - δ_ij| by an exact product quadrature, in f64 and f32.
fn orthonormality_error(bands: usize) -> (f64, f64) {
    let basis = ShBasis::new(bands);
    let n = coefficient_count(bands);
    let q = SphereQuadrature::for_degree(2 * (bands - 1));
    let mut gram64 = vec![0.0f64; n * n];
    let mut gram32 = vec![0.0f64; n * n];
    let mut y64 = vec![0.0; n];
    let mut y32 = vec![0.0f32; n];
    for (p, w) in q.points.iter().zip(&q.weights) {
        basis.eval_f64(*p, &mut y64);
        basis.eval(p.as_vec3(), &mut y32);
        assert!(y32.iter().all(|v| v.is_finite()) && y64.iter().all(|v| v.is_finite()));
        for i in 0..n {
            for j in 0..n {
                gram64[i * n + j] += w * y64[i] * y64[j];
                gram32[i * n + j] += w * y32[i] as f64 * y32[j] as f64;
            }
        }
    }
    let worst = |g: &[f64]| {
        (0..n * n)
            .map(|k| (g[k] - if k / n == k % n { 1.0 } else { 0.0 }).abs())
            .fold(0.0, f64::max)
    };
    (worst(&gram64), worst(&gram32))
}

#[test]
fn basis_is_orthonormal_to_1e_6() {
    for bands in [1, 2, 3, 5, 8] {
        let (e64, e32) = orthonormality_error(bands);
        println!("{bands} bands: max |<Yi,Yj> - δij| = {e64:.2e} (f64), {e32:.2e} (f32)");
        assert!(e64 < 1e-6 && e32 < 1e-6, "{bands} bands: {e64} {e32}");
    }
}

#[test]
fn basis_is_stable_to_15_bands() {
    let (e64, e32) = orthonormality_error(15);
    println!("15 bands: max |<Yi,Yj> - δij| = {e64:.2e} (f64), {e32:.2e} (f32)");
    assert!(e64 < 1e-10, "{e64}");
    assert!(e32 < 1e-4, "{e32}");
    // Poles, the equator and near-pole directions: finite, and the
    // addition theorem Σ_m Y_lm² = (2l+1)/4π holds in every band.
    let basis = ShBasis::new(15);
    let mut y = vec![0.0f32; 225];
    for d in [
        Vec3::Z,
        -Vec3::Z,
        Vec3::X,
        Vec3::new(1e-7, 0.0, 1.0).normalize(),
        Vec3::new(0.6, -0.8, 0.0),
        Vec3::new(-1.0, 2.0, -3.0).normalize(),
    ] {
        basis.eval(d, &mut y);
        assert!(y.iter().all(|v| v.is_finite()), "NaN at {d}");
        for l in 0..15 {
            let s: f32 = y[l * l..(l + 1) * (l + 1)].iter().map(|v| v * v).sum();
            let expect = (2 * l + 1) as f32 / (4.0 * std::f32::consts::PI);
            assert!(
                (s - expect).abs() < 1e-4 * expect.max(1.0),
                "band {l} at {d}: {s} vs {expect}"
            );
        }
    }
}

#[test]
fn no_condon_shortley_phase() {
    let basis = ShBasis::new(3);
    let c = (3.0 / (4.0 * std::f64::consts::PI)).sqrt();
    let at = |d: DVec3, l, m| basis.at(d)[index(l, m)];
    assert!((at(DVec3::X, 1, 1) - c).abs() < 1e-15, "Y_1,1 = +c x");
    assert!((at(DVec3::Y, 1, -1) - c).abs() < 1e-15, "Y_1,-1 = +c y");
    assert!((at(DVec3::Z, 1, 0) - c).abs() < 1e-15, "Y_1,0 = +c z");
    assert!(at(DVec3::new(1.0, 0.0, 1.0).normalize(), 2, 1) > 0.0, "Y_2,1 = +c' x z");
}

#[test]
fn clamped_cosine_zonal_coefficients() {
    let z = clamped_cosine_zonal(5);
    println!("clamped cosine zonal coefficients: {z:?}");
    // The closed forms, to rounding.
    let pi = std::f64::consts::PI;
    let closed = [
        pi.sqrt() / 2.0,
        (pi / 3.0).sqrt(),
        (5.0 * pi).sqrt() / 8.0,
        0.0,
        -(pi).sqrt() * 0.0625,
    ];
    for (l, expect) in closed.iter().enumerate() {
        assert!((z[l] - expect).abs() < 1e-12, "h_{l} = {} (closed form {expect})", z[l]);
    }
    // The six-decimal figures (sqrt(pi/3) = 1.0233267 is quoted as
    // 1.023328, 1.3e-6 away, so the check is to the quoted precision).
    for (l, quoted) in [0.886227, 1.023328, 0.495416].iter().enumerate() {
        assert!((z[l] - quoted).abs() < 2e-6, "h_{l} = {} (quoted {quoted})", z[l]);
    }
}

#[test]
fn constant_environment_projects_to_dc_only() {
    let map = EnvironmentMap::from_fn(32, |_| [2.0, 1.0, 0.5]).unwrap();
    let sh = project_environment(&map, 5);
    let dc = 2.0 * (4.0 * std::f64::consts::PI).sqrt();
    assert!((sh.rgb[0][0] - dc).abs() < 1e-9 * dc, "{} vs {dc}", sh.rgb[0][0]);
    let worst = sh.rgb[1..].iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
    println!(
        "constant map: DC {:.9} (expected {dc:.9}), largest other |coefficient| {worst:.2e}",
        sh.rgb[0][0]
    );
    assert!(worst < 1e-9, "{worst}");
}

#[test]
fn projection_recovers_a_band_limited_environment() {
    // Radiance given by known world-space coefficients (made positive), sampled
    // at texel centres: the texel-exact projection recovers them up to the
    // texels' own averaging, O(texel²).
    let bands = 4;
    let basis = ShBasis::new(bands);
    let mut coeffs = vec![0.0; 16];
    coeffs[0] = 3.0;
    for (i, c) in coeffs.iter_mut().enumerate().skip(1) {
        *c = 0.3 * ((i as f64 * 1.7).sin());
    }
    let map = EnvironmentMap::from_fn(128, |d| {
        let v = evaluate(&basis, &coeffs, d.as_dvec3()) as f32;
        [v, 2.0 * v, 0.5 * v]
    })
    .unwrap();
    let sh = project_environment(&map, bands);
    let mut worst = 0.0f64;
    for (i, c) in coeffs.iter().enumerate() {
        worst = worst
            .max((sh.rgb[i][0] - c).abs())
            .max((sh.rgb[i][1] - 2.0 * c).abs() / 2.0);
    }
    println!("band-limited map (256x128): worst coefficient error {worst:.2e}");
    assert!(worst < 2e-3, "{worst}");
    // The direction convention round-trips.
    for d in [Vec3::X, -Vec3::Z, Vec3::new(0.3, -0.7, 0.4).normalize()] {
        let (u, v) = EnvironmentMap::texcoord(d);
        let back = EnvironmentMap::direction_f64(u as f64, v as f64).as_vec3();
        assert!((back - d).length() < 1e-5, "{d} -> ({u}, {v}) -> {back}");
    }
}

/// `n` normals spread evenly over the sphere (a Fibonacci spiral).
fn spiral_normals(n: usize) -> Vec<DVec3> {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = i as f64 * 2.399_963_229_728_653;
            DVec3::new(r * phi.cos(), z, r * phi.sin())
        })
        .collect()
}

/// Irradiance from 9 coefficients against brute-force integration over the
/// probe's texels, at 200 normals. The error measure is Ramamoorthi and
/// Hanrahan's: |E_9 - E| relative to the probe's largest irradiance,
/// averaged over the normals (asserted < 3%). Per-normal relative errors are
/// printed too: they are large where E is small (the dark side of grace),
/// which is the 9-term truncation itself — with 12 bands the same code lands
/// within about 1% everywhere (asserted), so projection and integration agree.
#[test]
fn irradiance_from_nine_coefficients_on_the_shared_probes() {
    let Some(root) = common::data_root() else {
        println!("PENUMBRA_DATA not set: skipping the probe irradiance check");
        return;
    };
    let normals = spiral_normals(200);
    for probe in ["grace", "pisa", "uffizi"] {
        let path = std::path::Path::new(&root).join("probes").join(format!("{probe}.hdr"));
        let map = EnvironmentMap::load(&path).unwrap();
        let sh = project_environment(&map, 12);
        let exact: Vec<f64> = irradiance_brute_force(&map, &normals, 2)
            .iter()
            .map(|e| e.iter().sum())
            .collect();
        let peak = exact.iter().cloned().fold(0.0, f64::max);
        for bands in [3, 12] {
            let (mut mean_peak, mut max_peak, mut mean_rel, mut max_rel) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
            for (n, e) in normals.iter().zip(&exact) {
                let a: f64 = irradiance_bands(&sh, *n, bands).iter().sum();
                mean_peak += (a - e).abs() / peak / normals.len() as f64;
                max_peak = max_peak.max((a - e).abs() / peak);
                mean_rel += (a - e).abs() / e / normals.len() as f64;
                max_rel = max_rel.max((a - e).abs() / e);
            }
            println!(
                "{probe}, {} coefficients: |E_sh - E| / max E: mean {:.2}%, max {:.2}%; |E_sh - E| / E: mean {:.2}%, max {:.2}%",
                bands * bands,
                100.0 * mean_peak,
                100.0 * max_peak,
                100.0 * mean_rel,
                100.0 * max_rel
            );
            if bands == 3 {
                assert!(mean_peak < 0.03, "{probe}: {mean_peak}");
                // irradiance() is the 9-coefficient entry point.
                let direct: f64 = irradiance(&sh.truncated(3), normals[7]).iter().sum();
                let via: f64 = irradiance_bands(&sh, normals[7], 3).iter().sum();
                assert!((direct - via).abs() < 1e-12 * via.abs());
            } else {
                assert!(max_peak < 0.015 && mean_rel < 0.015, "{probe}: {max_peak} {mean_rel}");
            }
        }
    }
}

fn random_rotation(rng: &mut common::Rng) -> DMat3 {
    let axis = rng.vec3(-1.0, 1.0).as_dvec3().normalize_or(DVec3::X);
    DMat3::from_axis_angle(axis, (rng.f32() as f64 - 0.5) * 6.0)
}

#[test]
fn rotation_preserves_band_energy_and_rotates_the_function() {
    let mut rng = common::Rng(42);
    for bands in [3, 5, 9, 15] {
        let rot = ShRotation::new(bands);
        let basis = ShBasis::new(bands);
        let mut worst_energy = 0.0f64;
        let mut worst_value = 0.0f64;
        for _ in 0..8 {
            let r = random_rotation(&mut rng);
            let f: Vec<f64> = (0..bands * bands).map(|_| rng.f32() as f64 - 0.5).collect();
            let mut g = f.clone();
            rot.rotate(r, &mut g);
            for (a, b) in band_energies(&f, bands).iter().zip(band_energies(&g, bands)) {
                worst_energy = worst_energy.max((a - b).abs() / a.max(1e-30));
            }
            for _ in 0..4 {
                let s = rng.vec3(-1.0, 1.0).as_dvec3().normalize_or(DVec3::Z);
                let expect = evaluate(&basis, &f, r.transpose() * s);
                worst_value = worst_value.max((evaluate(&basis, &g, s) - expect).abs());
            }
        }
        println!("{bands} bands: band energy rel. change {worst_energy:.2e}, |g(s) - f(R^-1 s)| {worst_value:.2e}");
        assert!(worst_energy < 1e-6, "{bands}: {worst_energy}");
        assert!(worst_value < 1e-6 * (bands * bands) as f64, "{bands}: {worst_value}");
    }
}

#[test]
fn tangent_frame_rotation_matches_the_general_rotation() {
    let bands = 5;
    let rot = ShRotation::new(bands);
    let mut rng = common::Rng(7);
    for n in [
        Vec3::Z,
        -Vec3::Z,
        Vec3::X,
        Vec3::new(0.2, 0.9, -0.3).normalize(),
        rng.vec3(-1.0, 1.0).normalize(),
    ] {
        let f: Vec<f32> = (0..25).map(|_| rng.f32() - 0.5).collect();
        let mut fast = f.clone();
        rot.frame_to_world(n, &mut fast);
        let frame = tangent_frame(n).as_dmat3();
        let mut slow: Vec<f64> = f.iter().map(|&v| v as f64).collect();
        rot.rotate(frame, &mut slow);
        let worst = fast
            .iter()
            .zip(&slow)
            .map(|(a, b)| (*a as f64 - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-5, "{n}: {worst}");
    }
}
