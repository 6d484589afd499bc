//! PRT right by default on any mesh: the transfer error with
//! default settings against ray tracing on the shared models, both
//! animations and meshes we did not make; the self-check's estimate against
//! that measurement; the culling and sidedness decisions; and no negative
//! radiance under any shared probe (the navy blotches).
//!
//! The shared models need `PENUMBRA_DATA` (skipped with a note otherwise).
//! To keep the suite quick the measurement traces 2048 rays per vertex
//! instead of `--check`'s 4096 (a few tenths of a point more Monte Carlo
//! noise, which the 3% bound then includes), on every vertex of meshes up
//! to 4000 vertices and on every k-th of larger ones (the bunny). Not
//! fewer: the mean relative error of a folded sheet is carried by a few
//! nearly dark vertices (one of the curtain's is 0.4 points of its mean),
//! and a uniform subset of a third of its vertices put it at 5.9% where all
//! of them give 3.5%.

mod common;

use std::path::Path;

use common::data_model;
use glam::Vec3;
use penumbra::DEFAULT_SEED;
use penumbra::accel::Accel;
use penumbra::accel::kdtree::{KdTree, KdTreeSettings};
use penumbra::gpu::device::Device;
use penumbra::prt::pipeline::{FrameOutput, Prt, PrtSettings};
use penumbra::prt::probe::{Probe, ProbeReport, probe};
use penumbra::prt::reference::{reference_transfer, relative_l2_error};
use penumbra::prt::render::{auto_exposure, render};
use penumbra::prt::runner::{Playback, PrtRunner, RayTraced, Shadows, animate};
use penumbra::prt::selfcheck::{SelfCheck, estimate};
use penumbra::scene::animated::AnimatedScene;
use penumbra::scene::{Camera, EnvironmentMap, Scene, load_obj, used_bounds};

/// A mesh, a pose and the eye the CLI would use.
struct Case {
    name: String,
    rest: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    /// Poses checked (the rest pose for static meshes).
    poses: Vec<Vec<Vec3>>,
    eye: Vec3,
}

fn model(name: &str) -> Option<Case> {
    let path = data_model(&format!("{name}.obj"))?;
    let mesh = load_obj(&path).unwrap();
    Some(mesh_case(name, mesh.positions, mesh.triangles))
}

fn mesh_case(name: &str, rest: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Case {
    let eye = Camera::default_for(&used_bounds(&rest, &triangles)).eye;
    Case {
        name: name.into(),
        poses: vec![rest.clone()],
        rest,
        triangles,
        eye,
    }
}

fn animated(name: &str, times: &[f32]) -> Case {
    let anim = AnimatedScene::parse(name).unwrap().build();
    let pose = |t: f32| {
        let mut p = Vec::new();
        anim.positions_at(t, &mut p);
        p
    };
    Case {
        name: name.into(),
        rest: pose(0.0),
        poses: times.iter().map(|&t| pose(t)).collect(),
        triangles: anim.triangles.clone(),
        eye: anim.camera.expect("built-in animations have a camera").0,
    }
}

/// Mean relative L2 transfer error of `prt` on `pose`: every k-th vertex
/// (at most ~4000) against 2048 ray-traced cosine samples each.
fn measured_error(prt: &Prt, case: &Case, pose: &[Vec3]) -> f64 {
    let mut out = FrameOutput::default();
    let light = vec![0.0; 3 * prt.coeffs()];
    prt.frame(pose, Some(case.eye), &light, false, false, &mut out).unwrap();
    let step = pose.len().div_ceil(4000);
    let at: Vec<usize> = (0..pose.len()).step_by(step).collect();
    let soup: Vec<[Vec3; 3]> = case.triangles.iter().map(|t| t.map(|i| pose[i as usize])).collect();
    let accel = Accel::new(KdTree::from_triangles(soup, &KdTreeSettings::default()).unwrap());
    let p: Vec<Vec3> = at.iter().map(|&v| pose[v]).collect();
    let n: Vec<Vec3> = at.iter().map(|&v| out.normals[v]).collect();
    let s = &prt.settings;
    let reference = reference_transfer(&accel, &p, &n, prt.scale, s.bands, &s.brdf, Some(case.eye), 2048, 1);
    let c = prt.coeffs();
    let mine: Vec<f32> = at
        .iter()
        .flat_map(|&v| out.transfer[v * c..(v + 1) * c].to_vec())
        .collect();
    let floor = 0.01 * prt.tables.unoccluded.iter().map(|v| v * v).sum::<f32>().sqrt();
    let (error, counted, skipped) = relative_l2_error(&mine, &reference, c, floor);
    // The mean is over the vertices above the floor only: with none (or
    // few) of them counted, a wrong transfer would pass as error 0.
    assert!(
        counted >= 9 * at.len() / 10,
        "only {counted} of {} vertices counted ({skipped} below the floor)",
        at.len()
    );
    error
}

/// The settings `prt` shades with by default: the probe's choice for the
/// rest pose, and its report.
fn probed(case: &Case) -> (PrtSettings, ProbeReport) {
    let base = PrtSettings::default();
    let report = probe(
        &case.rest,
        &case.triangles,
        &base,
        Some(case.eye),
        &Probe::default(),
        DEFAULT_SEED,
    )
    .unwrap();
    let mut settings = base;
    report.apply(&mut settings);
    (settings, report)
}

/// Default settings (the probe's choice): error <= 3% on every pose, and
/// the self-check's estimate within a point of the measurement.
fn check_defaults(case: &Case) {
    let (settings, report) = probed(case);
    let prt = Prt::new(&case.rest, &case.triangles, &settings).unwrap();
    let errors: Vec<f64> = case.poses.iter().map(|p| measured_error(&prt, case, p)).collect();
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    let poses: Vec<(usize, Vec<Vec3>)> = case.poses.iter().cloned().enumerate().collect();
    let selfcheck = estimate(&prt, &case.triangles, &poses, Some(case.eye), &SelfCheck::default(), 1).unwrap();
    println!(
        "{}: probe {} in {:.0} ms; error {:?}%, self-check {:.2}% +/- {:.2} ({:.0} ms); culling {}, two-sided {}, {:.0} blockers/vertex before culling",
        case.name,
        report.options(),
        report.ms,
        errors.iter().map(|e| (1e4 * e).round() / 100.0).collect::<Vec<_>>(),
        100.0 * selfcheck.estimate,
        100.0 * selfcheck.uncertainty,
        selfcheck.ms,
        prt.cull_backfaces,
        prt.two_sided,
        prt.average_candidates()
    );
    for e in &errors {
        assert!(
            *e <= 0.03,
            "{}: default transfer error {:.2}% > 3%",
            case.name,
            100.0 * e
        );
    }
    assert!(
        (selfcheck.estimate - mean).abs() <= 0.01,
        "{}: self-check {:.2}% vs measured {:.2}%",
        case.name,
        100.0 * selfcheck.estimate,
        100.0 * mean
    );
}

#[test]
fn defaults_are_within_three_percent_on_the_shared_models() {
    for name in ["cow", "spot", "teapot", "stanford-bunny"] {
        if let Some(case) = model(name) {
            check_defaults(&case);
        }
    }
}

/// The shipped meshes: the cylindrical well is 5.7% off with the hierarchy
/// at 32x32 masks, which the probe sees and leaves. Not here: the closed
/// box (seen from outside, every vertex is dark inside it: nothing to
/// measure), the sphere on its plane (1,067 of its 2,275 vertices are dark
/// in the reference, so fewer than the 90% this measure needs are counted;
/// `prt --reference` puts the rest at 0.8%) and the wall on its
/// floor, 8 vertices of which 4 lie on the contact line, 7% off at every
/// mask side tried (the probe says none is within the bound and the
/// self-check warns).
#[test]
fn defaults_are_within_three_percent_on_the_shipped_meshes() {
    for name in ["cylindrical-well", "cube-with-hole", "corner", "open-plane"] {
        let mesh = load_obj(&common::asset(&format!("{name}.obj"))).unwrap();
        check_defaults(&mesh_case(name, mesh.positions, mesh.triangles));
    }
}

/// The probe's choice is never dominated: no setting it estimated is both
/// cheaper (by the counted work) and at least as accurate, and what it
/// left unestimated is dearer than the choice. Its counted work does not
/// depend on the threads: the same choice on one thread as on all.
#[test]
fn the_probe_chooses_no_dominated_setting_and_the_same_on_any_thread_count() {
    let well = load_obj(&common::asset("cylindrical-well.obj")).unwrap();
    let mut cases = vec![mesh_case("cylindrical-well", well.positions, well.triangles), curtain()];
    cases.extend(model("cow"));
    for case in &cases {
        let (settings, report) = probed(case);
        let c = report.choice();
        let (error, upper) = (c.error.unwrap(), c.upper.unwrap());
        println!(
            "{}: {} ({}), {:.2}% (bound {:.2}%)",
            case.name,
            report.options(),
            report.rule,
            100.0 * error,
            100.0 * upper
        );
        for r in &report.rows {
            match r.upper {
                Some(u) => assert!(
                    !(r.model_ms < c.model_ms && u <= upper),
                    "{}: {r:?} dominates the choice {c:?}",
                    case.name
                ),
                None => assert!(r.model_ms >= c.model_ms, "{}: {r:?} unestimated but cheaper", case.name),
            }
        }
        if report.rule == "cheapest within the bound" {
            assert!(upper <= 0.03);
        }
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let (again, report1) = one.install(|| probed(case));
        assert_eq!(settings, again, "{}", case.name);
        let costs = |r: &ProbeReport| r.rows.iter().map(|r| r.model_ms).collect::<Vec<_>>();
        assert_eq!(costs(&report), costs(&report1), "{}", case.name);
    }
    // The well: the hierarchy's coarse level is 5-6% off at every mask
    // side; without it 32x32 is within the bound.
    let (settings, _) = probed(&cases[0]);
    assert!(!settings.hierarchy.enabled, "{settings:?}");
}

#[test]
fn defaults_are_within_three_percent_on_both_animations() {
    check_defaults(&animated("cloth", &[0.0, 1.5]));
    check_defaults(&animated("character", &[0.0, 1.5]));
}

/// A lat-long sphere's triangles (pole, `rings - 1` rings of `seg`, pole),
/// outward for positions from `sphere_dirs`.
fn sphere_grid(seg: u32, rings: u32) -> Vec<[u32; 3]> {
    let ring = |k: u32, i: u32| 1 + (k - 1) * seg + i % seg;
    let bottom = 1 + (rings - 1) * seg;
    let mut f = Vec::new();
    for i in 0..seg {
        f.push([0, ring(1, i + 1), ring(1, i)]);
        f.push([bottom, ring(rings - 1, i), ring(rings - 1, i + 1)]);
    }
    for k in 1..rings - 1 {
        for i in 0..seg {
            let (a, b, c, d) = (ring(k, i), ring(k, i + 1), ring(k + 1, i + 1), ring(k + 1, i));
            f.push([a, b, c]);
            f.push([a, c, d]);
        }
    }
    f
}

fn sphere_dir(seg: u32, rings: u32, k: u32, i: u32) -> Vec3 {
    let th = std::f32::consts::PI * k as f32 / rings as f32;
    let ph = std::f32::consts::TAU * i as f32 / seg as f32;
    Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin())
}

/// A closed ball with 48 one-vertex spikes almost twice its radius: the
/// simplifier drops spikes, whose shadows the coarse level then misses.
fn spiky() -> Case {
    let (seg, rings) = (48, 24);
    let mut v = vec![Vec3::Y];
    for k in 1..rings {
        for i in 0..seg {
            let spike = k % 4 == 2 && i % 6 == (k / 4) % 6;
            v.push(sphere_dir(seg, rings, k, i) * if spike { 1.9 } else { 1.0 });
        }
    }
    v.push(-Vec3::Y);
    mesh_case("spiky ball", v, sphere_grid(seg, rings))
}

/// A closed bowl 3% thick (outer and inner hemispheres joined at the rim):
/// the coarse outer surface cuts through the inner one.
fn shell() -> Case {
    let (seg, half, t) = (48u32, 12u32, 0.03f32);
    let n = 1 + half * seg;
    let mut v = Vec::new();
    for r in [1.0, 1.0 - t] {
        v.push(Vec3::new(0.0, -r, 0.0));
        for k in 1..=half {
            for i in 0..seg {
                let th = std::f32::consts::FRAC_PI_2 * k as f32 / half as f32;
                let ph = std::f32::consts::TAU * i as f32 / seg as f32;
                v.push(r * Vec3::new(th.sin() * ph.cos(), -th.cos(), th.sin() * ph.sin()));
            }
        }
    }
    let ring = |s: u32, k: u32, i: u32| s * n + 1 + (k - 1) * seg + i % seg;
    let mut f = Vec::new();
    for s in 0..2 {
        let mut push = |t: [u32; 3]| f.push(if s == 1 { [t[2], t[1], t[0]] } else { t });
        for i in 0..seg {
            push([s * n, ring(s, 1, i), ring(s, 1, i + 1)]);
        }
        for k in 1..half {
            for i in 0..seg {
                let (a, b, c, d) = (
                    ring(s, k, i),
                    ring(s, k, i + 1),
                    ring(s, k + 1, i + 1),
                    ring(s, k + 1, i),
                );
                push([a, d, c]);
                push([a, c, b]);
            }
        }
    }
    for i in 0..seg {
        let (a, b, c, d) = (
            ring(0, half, i),
            ring(0, half, i + 1),
            ring(1, half, i + 1),
            ring(1, half, i),
        );
        f.push([a, d, c]);
        f.push([a, c, b]);
    }
    mesh_case("thin shell", v, f)
}

/// An open sheet hanging in deep folds that lean over each other.
fn curtain() -> Case {
    let (nx, ny) = (64u32, 40u32);
    let mut v = Vec::new();
    for j in 0..ny {
        let t = j as f32 / (ny - 1) as f32;
        for i in 0..nx {
            let u = i as f32 / (nx - 1) as f32;
            let a = 0.22 * (0.4 + t);
            let w = 7.0 * std::f32::consts::PI * u;
            v.push(Vec3::new(-1.0 + 2.0 * u + 0.6 * a * w.cos(), 1.4 * t, a * w.sin()));
        }
    }
    let mut f = Vec::new();
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let a = j * nx + i;
            f.push([a, a + 1, a + nx + 1]);
            f.push([a, a + nx + 1, a + nx]);
        }
    }
    mesh_case("curtain", v, f)
}

/// Meshes we did not make the method for. On the closed spiky ball and thin
/// shell the plain two levels (tolerance 0) are far off and the checked
/// coarse level meets 3%. On the folded sheet the method itself is near 3%
/// even without the hierarchy (deep, overhanging folds: nearly dark
/// vertices); the default must stay within a point of that, and the
/// self-check must see it.
#[test]
fn the_coarse_level_falls_back_where_it_strays() {
    let with = |case: &Case, f: &dyn Fn(&mut PrtSettings)| {
        let mut s = PrtSettings::default();
        f(&mut s);
        let prt = Prt::new(&case.rest, &case.triangles, &s).unwrap();
        measured_error(&prt, case, &case.rest)
    };
    for case in [spiky(), shell()] {
        check_defaults(&case);
        let plain = with(&case, &|s| s.hierarchy.tolerance = 0.0);
        let default = with(&case, &|_| {});
        println!("{}: plain two levels {:.2}%", case.name, 100.0 * plain);
        assert!(
            plain > 0.05 && plain > 3.0 * default,
            "{}: {plain} vs {default}",
            case.name
        );
    }
    let case = curtain();
    let default = with(&case, &|_| {});
    let fine = with(&case, &|s| s.hierarchy.enabled = false);
    let prt = Prt::new(&case.rest, &case.triangles, &PrtSettings::default()).unwrap();
    let poses = vec![(0, case.rest.clone())];
    let sc = estimate(&prt, &case.triangles, &poses, Some(case.eye), &SelfCheck::default(), 1).unwrap();
    println!(
        "curtain: default {:.2}%, without hierarchy {:.2}%, self-check {:.2}% +/- {:.2}",
        100.0 * default,
        100.0 * fine,
        100.0 * sc.estimate,
        100.0 * sc.uncertainty
    );
    assert!(prt.two_sided && !prt.cull_backfaces);
    assert!(default <= fine + 0.01, "{default} vs {fine}");
    assert!((sc.estimate - default).abs() <= 0.01, "{} vs {default}", sc.estimate);
    assert_eq!(sc.exceeded, sc.estimate > 0.03);
}

/// Culling and sidedness from visibility, not from "any boundary edge".
#[test]
fn sides_follow_what_rays_see() {
    let decide = |case: &Case| Prt::new(&case.rest, &case.triangles, &PrtSettings::default()).unwrap();
    // Closed: no rays, culling on, one side.
    let ch = decide(&animated("character", &[0.0]));
    assert!(ch.cull_backfaces && !ch.two_sided && ch.sides.back_exposure.is_none());
    // Sheets show their backs: two-sided, no culling.
    for case in [animated("cloth", &[0.0]), curtain()] {
        let p = decide(&case);
        println!("{}: {:?}", case.name, p.sides);
        assert!(p.two_sided && !p.cull_backfaces, "{}", case.name);
        assert!(p.sides.back_exposure.unwrap() > 0.2);
    }
    if let Some(case) = model("stanford-bunny") {
        // Holes at the base: nearly closed, culling costs nothing.
        let p = decide(&case);
        println!("bunny: {:?}", p.sides);
        assert!(p.sides.topology.boundary_edges > 0);
        assert!(p.cull_backfaces && !p.two_sided);
    }
    if let Some(case) = model("teapot") {
        // Unwelded patches; the spout and handle end inside the body, where
        // culling would let the body's inside be seen through.
        let p = decide(&case);
        println!("teapot: {:?}", p.sides);
        assert!(!p.two_sided && !p.cull_backfaces);
        assert!(p.sides.culling_error.unwrap() > 0.05);
    }
}

/// No pixel with red and green at 0 while blue is lit
/// (navy), nor any vertex with a negative channel, under every shared probe
/// on both animations and the small shared models, default settings (the
/// character under Grace had 46-66 such pixels at the neck and hip). The
/// background is left black, so every pixel counted is the mesh.
#[test]
fn no_negative_radiance_under_any_probe() {
    let Some(root) = common::data_root() else {
        println!("PENUMBRA_DATA not set: skipping the probes");
        return;
    };
    let mut probes: Vec<_> = std::fs::read_dir(Path::new(&root).join("probes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "hdr"))
        .collect();
    probes.sort();
    assert!(!probes.is_empty());
    let mut scenes = vec![
        Scene::from_animation(AnimatedScene::Cloth.build()),
        Scene::from_animation(AnimatedScene::Character.build()),
    ];
    for name in ["cow", "spot", "teapot"] {
        let path = data_model(&format!("{name}.obj")).unwrap();
        scenes.push(Scene::from_mesh(name, &path, load_obj(&path).unwrap()));
    }
    let playback = Playback {
        frames: 1,
        start: 0.0,
        dt: 1.0 / 30.0,
        env_spin: 0.0,
        pvs: None,
        check_frames: 0,
        profile: false,
        self_check: None,
        bars: Default::default(),
    };
    let device = Device::cpu();
    for scene in &scenes {
        let mesh = &scene.meshes[0];
        let mut rest = Vec::new();
        mesh.positions_at(0.0, &mut rest);
        let tris = &mesh.mesh.triangles;
        let camera = scene
            .camera
            .unwrap_or_else(|| Camera::default_for(&used_bounds(&rest, tris)));
        let reference = RayTraced { rays: 16, seed: 1 };
        for probe in &probes {
            let env = EnvironmentMap::load(probe).unwrap();
            let mut runner =
                PrtRunner::new(&device, &rest, tris, &PrtSettings::default(), Shadows::On, reference).unwrap();
            let mut navy = 0;
            let mut negative = 0;
            let mut lit = 0;
            animate(&mut runner, mesh, &env, Some(camera.eye), &playback, |_, pos, out| {
                let exposure = auto_exposure(&out.radiance, Vec3::splat(0.8));
                let mean = 0.45 / exposure;
                negative = out
                    .radiance
                    .iter()
                    .filter(|r| r.iter().any(|c| *c < -1e-3 * mean))
                    .count();
                let pixels = render(
                    pos,
                    tris,
                    &out.radiance,
                    Vec3::splat(0.8),
                    None,
                    &camera,
                    160,
                    120,
                    exposure,
                )?;
                navy = pixels.iter().filter(|p| p[0] == 0 && p[1] == 0 && p[2] > 0).count();
                lit = pixels.iter().filter(|p| p.iter().any(|c| *c > 0)).count();
                Ok(())
            })
            .unwrap();
            println!(
                "{} under {}: {lit} lit pixels, {navy} navy, {negative} vertices below zero",
                mesh.name,
                probe.file_name().unwrap().to_string_lossy()
            );
            assert!(lit > 500, "the mesh is in view");
            assert_eq!(navy, 0, "{} under {}", mesh.name, probe.display());
            assert_eq!(negative, 0, "{} under {}", mesh.name, probe.display());
        }
    }
}
