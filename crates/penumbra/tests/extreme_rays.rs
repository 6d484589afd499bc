//! Adversarial rays and cameras through every accelerator and path, with
//! `proptest`: components 0, +-denormal, +-1e38, +-3e38, +-inf and NaN,
//! directions of zero length, origins on the mesh's vertices and edges,
//! directions aimed at them, cameras with eye or target at the float
//! limits.
//!
//! The property: nothing panics, and every path gives the kd-tree single
//! ray's answer (`KdTree::closest_hit` / `any_hit`): the same t bit for bit
//! and the same triangle (or, for the BVH's ties, another triangle hit at
//! that very t), or a miss; a camera is refused by every path with the same
//! error, before any ray is traced, or traced by all to the same hits.
//!
//! Paths: the kd-tree's single rays, the wide BVH's single rays
//! (`Accel::closest_hit`/`any_hit` with `Structure::Bvh`), its 4x4 closest
//! packets (`bvh::packet::closest`), AO packets (`Accel::occluded` through
//! both structures in every instruction set, and `ao_rays_by` with every
//! `Casting`), primary rays of a camera (`PrimaryRays`: MLRTA's packets,
//! BVH packets and both structures' single rays) and, on a GPU (lavapipe
//! in CI), the kernels `trace_rays` and `ao_rays` through `Tracer`.
//!
//! Case counts are fixed and each test has its own fixed seed (ChaCha), as
//! the reader fuzz tests' (`fuzz_readers.rs`); `PENUMBRA_FUZZ_CASES=N` runs
//! N cases per test instead.

mod common;

use glam::{DVec3, Vec3};
use penumbra::accel::bvh::packet;
use penumbra::accel::kdtree::watertight::ShearedRay;
use penumbra::accel::kdtree::{KdTree, KdTreeSettings};
use penumbra::accel::{Accel, Structure};
use penumbra::geom::ray::{Hit, Ray};
use penumbra::geom::simd::Isa;
use penumbra::progress::Bar;
use penumbra::raycast::AoPoint;
use penumbra::raycast::ao_rays::{Casting, ao_rays_by};
use penumbra::scene::CameraSpec;
use penumbra::{AoSettings, Device, Mesh, PrimaryRays, TraceSettings, Tracer, View};
use proptest::prelude::*;
use proptest::sample::select;
use proptest::test_runner::{Config, RngAlgorithm, RngSeed, TestCaseError, TestError, TestRunner};

const ISAS: [Isa; 4] = [Isa::Avx512, Isa::Avx2, Isa::Sse, Isa::Scalar];

/// A small mesh: a tetrahedron's three faces at the origin, a fourth
/// sharing an edge with them, and a quad of two triangles away from them
/// (fewer children than a node has slots, shared edges and vertices).
fn mesh() -> Mesh {
    let positions = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(1.0, 1.0, 1.0),
        Vec3::new(3.0, -1.0, -1.0),
        Vec3::new(4.0, -1.0, -1.0),
        Vec3::new(4.0, 1.0, -1.0),
        Vec3::new(3.0, 1.0, -1.0),
    ];
    let triangles = vec![[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 4], [5, 6, 7], [5, 7, 8]];
    Mesh::new(positions, triangles).unwrap()
}

fn accel(mesh: &Mesh) -> Accel {
    Accel::new(KdTree::build(mesh, &KdTreeSettings::default()).unwrap())
}

/// The fixed configuration: `cases` cases (or `PENUMBRA_FUZZ_CASES`), a
/// seed of its own per test, nothing persisted.
fn config(test: &str, cases: u32) -> Config {
    let cases = common::fuzz_cases(cases);
    let seed = test.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    });
    Config {
        cases,
        failure_persistence: None,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(seed),
        max_shrink_iters: 4096,
        ..Config::default()
    }
}

/// Runs `cases` inputs of `strategy` through `check`; a failure (or a
/// panic, which proptest catches) fails the test with the shrunk input.
fn run<S: Strategy>(test: &str, cases: u32, strategy: S, check: impl Fn(S::Value) -> Result<(), String>)
where
    S::Value: std::fmt::Debug,
{
    let mut runner = TestRunner::new(config(test, cases));
    let result = runner.run(&strategy, |input| check(input).map_err(TestCaseError::fail));
    match result {
        Ok(()) => println!("{test}: {} cases passed", runner.config().cases),
        Err(TestError::Fail(reason, input)) => panic!("{test}: {reason}\ninput (shrunk): {input:?}"),
        Err(TestError::Abort(reason)) => panic!("{test}: aborted: {reason}"),
    }
}

/// Components at the edges of f32 and a few ordinary ones.
const SPECIAL: [f32; 17] = [
    0.0,
    -0.0,
    1e-40,
    -1e-40,
    1e38,
    -1e38,
    3e38,
    -3e38,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    1.0,
    -1.0,
    0.5,
    2.0,
    -2.0,
    f32::MIN_POSITIVE,
];

fn component() -> impl Strategy<Value = f32> {
    prop_oneof![3 => select(SPECIAL.to_vec()), 2 => -3.0f32..5.0]
}

fn vec3() -> impl Strategy<Value = Vec3> {
    (component(), component(), component()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// A point of the mesh: a vertex, or a point of an edge (its middle, a
/// quarter along, or anywhere).
fn on_mesh(mesh: &Mesh) -> impl Strategy<Value = Vec3> + use<> {
    let (p, tris) = (mesh.positions.clone(), mesh.triangles.clone());
    let vertex = select(p.clone());
    let edge = (
        select(tris),
        0..3usize,
        prop_oneof![Just(0.5f32), Just(0.25), 0.0f32..1.0],
    )
        .prop_map(move |(t, e, s)| {
            let (a, b) = (p[t[e] as usize], p[t[(e + 1) % 3] as usize]);
            a + (b - a) * s
        });
    prop_oneof![vertex, edge]
}

/// A ray's origin: extreme components or a point of the mesh.
fn origin(mesh: &Mesh) -> impl Strategy<Value = Vec3> + use<> {
    prop_oneof![2 => vec3(), 1 => on_mesh(mesh)]
}

/// A direction as generated: extreme components, zero, or towards a point
/// of the mesh (from wherever the origin is).
#[derive(Debug, Clone, Copy)]
enum Aim {
    Along(Vec3),
    Towards(Vec3),
}

impl Aim {
    fn dir(self, origin: Vec3) -> Vec3 {
        match self {
            Aim::Along(d) => d,
            Aim::Towards(p) => p - origin,
        }
    }
}

fn aim(mesh: &Mesh) -> impl Strategy<Value = Aim> + use<> {
    prop_oneof![
        3 => vec3().prop_map(Aim::Along),
        1 => Just(Aim::Along(Vec3::ZERO)),
        2 => on_mesh(mesh).prop_map(Aim::Towards),
    ]
}

fn t_max() -> impl Strategy<Value = f32> {
    select(vec![f32::INFINITY, f32::INFINITY, 1e38, 3.0, 0.5, 1e-40])
}

/// `b` is `a` (the kd-tree's answer): t bit for bit, and the same
/// triangle or another that the ray hits at that very t (a tie).
fn same_hit(tree: &KdTree, o: Vec3, d: Vec3, a: Hit, b: Hit, what: &str) -> Result<(), String> {
    if a.t.to_bits() != b.t.to_bits() || a.is_hit() != b.is_hit() {
        return Err(format!("{what}: {b:?}, the kd-tree {a:?}"));
    }
    if a.triangle != b.triangle {
        let ray = ShearedRay::in_frame(o, d, tree.frame_scale);
        let v = tree.triangles[b.triangle as usize].map(|p| p * tree.frame_scale);
        if ray.intersect(v[0], v[1], v[2], f32::INFINITY) != Some(b.t) {
            return Err(format!("{what}: {b:?}, the kd-tree {a:?} (not a tie)"));
        }
    }
    Ok(())
}

#[test]
fn single_rays_kdtree_and_bvh() {
    let mesh = mesh();
    let accel = accel(&mesh);
    let tree = accel.kdtree();
    let strategy = (origin(&mesh), aim(&mesh), t_max());
    run("single_rays", 4096, strategy, |(o, aim, t_max)| {
        let d = aim.dir(o);
        let kd = tree.closest_hit(o, d, t_max);
        if tree.any_hit(o, d, t_max) != kd.is_hit() {
            return Err(format!("kd-tree any_hit disagrees with its closest hit {kd:?}"));
        }
        if kd.is_hit() && !(kd.t > 0.0 && kd.t < t_max) {
            return Err(format!("kd-tree hit {kd:?} outside (0, {t_max})"));
        }
        let bvh = accel.closest_hit(Structure::Bvh, o, d, t_max);
        same_hit(tree, o, d, kd, bvh, "BVH closest_hit")?;
        if accel.any_hit(Structure::Bvh, o, d, t_max) != kd.is_hit() {
            return Err(format!("BVH any_hit disagrees with the kd-tree's {kd:?}"));
        }
        let unbounded = tree.closest_hit(o, d, f32::INFINITY);
        let hits = accel.trace_closest(Structure::Bvh, &[Ray::new(o, d)]);
        same_hit(tree, o, d, unbounded, hits[0], "BVH trace_closest")
    });
}

/// Up to 16 rays sharing an origin, as BVH closest packets and AO packets
/// through both structures in every instruction set.
#[test]
fn packets_bvh_closest_and_occluded() {
    let mesh = mesh();
    let accel = accel(&mesh);
    let tree = accel.kdtree();
    let strategy = (origin(&mesh), prop::collection::vec(aim(&mesh), 1..=16), t_max());
    run("packets", 1024, strategy, |(o, aims, t_max)| {
        let dirs: Vec<Vec3> = aims.iter().map(|a| a.dir(o)).collect();
        let kd: Vec<Hit> = dirs.iter().map(|&d| tree.closest_hit(o, d, t_max)).collect();
        let blocked = kd
            .iter()
            .enumerate()
            .fold(0u16, |m, (r, h)| m | ((h.is_hit() as u16) << r));
        for isa in ISAS {
            let hits = packet::closest(accel.bvh(), tree, o, &dirs, t_max, isa);
            for (r, &d) in dirs.iter().enumerate() {
                same_hit(tree, o, d, kd[r], hits[r], &format!("BVH packet ({isa:?}) ray {r}"))?;
            }
            for structure in [Structure::Bvh, Structure::Kdtree] {
                let mask = accel.occluded(structure, o, &dirs, t_max, isa);
                if mask != blocked {
                    return Err(format!(
                        "occluded ({structure:?}, {isa:?}): {mask:016b}, the kd-tree's rays {blocked:016b}"
                    ));
                }
            }
        }
        Ok(())
    });
}

fn normal() -> impl Strategy<Value = Vec3> {
    prop_oneof![
        select(vec![
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
            Vec3::ZERO
        ]),
        (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)
            .prop_map(|(x, y, z)| Vec3::new(x, y, z).try_normalize().unwrap_or(Vec3::Z)),
    ]
}

fn ao_points(mesh: &Mesh) -> impl Strategy<Value = Vec<AoPoint>> + use<> {
    prop::collection::vec((origin(mesh), normal()), 1..6).prop_map(|points| {
        points
            .into_iter()
            .enumerate()
            .map(|(i, (o, n))| AoPoint::new(o, n, i as u32))
            .collect()
    })
}

fn ao_settings() -> impl Strategy<Value = AoSettings> {
    (
        select(vec![1u32, 16, 40]),
        select(vec![f32::INFINITY, 1e38, 1.0, 1e-40]),
    )
        .prop_map(|(rays, radius)| AoSettings {
            rays_per_point: rays,
            radius,
            ..AoSettings::default()
        })
}

/// AO rays from extreme points: every `Casting` gives the single rays' bits.
#[test]
fn ao_rays_every_casting() {
    let mesh = mesh();
    let accel = accel(&mesh);
    run(
        "ao_rays",
        256,
        (ao_points(&mesh), ao_settings()),
        |(points, settings)| {
            let bar = Bar::hidden();
            let single = ao_rays_by(&accel, &points, &settings, &bar, Casting::Single);
            for structure in [Structure::Bvh, Structure::Kdtree] {
                for isa in ISAS {
                    let cast = ao_rays_by(&accel, &points, &settings, &bar, Casting::Packets(structure, isa));
                    if cast.bits != single.bits {
                        return Err(format!(
                            "packets ({structure:?}, {isa:?}): {:x?}, single rays {:x?}",
                            cast.bits, single.bits
                        ));
                    }
                }
            }
            Ok(())
        },
    );
}

/// Eye and target: extreme components, or points of an ordinary view.
fn camera_point() -> impl Strategy<Value = DVec3> {
    let extreme = select(vec![
        0.0,
        1e-40,
        -1e-40,
        1e30,
        -1e30,
        1e38,
        -1e38,
        3e38,
        -3e38,
        1e39,
        1.0,
        f64::INFINITY,
        f64::NAN,
    ]);
    let c = prop_oneof![2 => extreme, 1 => -4.0f64..4.0];
    (c.clone(), c.clone(), c).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

fn camera() -> impl Strategy<Value = CameraSpec> {
    let fov = prop_oneof![
        3 => Just(None),
        1 => select(vec![Some(60.0f32), Some(1e-30), Some(179.99), Some(0.0), Some(180.0), Some(f32::NAN)]),
    ];
    (
        prop::option::weighted(0.8, camera_point()),
        prop::option::weighted(0.6, camera_point()),
        fov,
    )
        .prop_map(|(eye, target, fov_degrees)| CameraSpec {
            eye,
            target,
            fov_degrees,
        })
}

/// The settings of every path primary rays take on the CPU.
fn trace_paths() -> Vec<(&'static str, TraceSettings)> {
    let with = |single_ray, accel| TraceSettings {
        single_ray,
        accel,
        ..TraceSettings::default()
    };
    vec![
        ("MLRTA packets", with(false, Structure::Kdtree)),
        ("BVH packets", with(false, Structure::Bvh)),
        ("kd-tree single rays", with(true, Structure::Kdtree)),
        ("BVH single rays", with(true, Structure::Bvh)),
    ]
}

/// A camera's primary rays through every path: all refuse it with the
/// same error, or all give the kd-tree single rays' hits.
#[test]
fn cameras_every_primary_ray_path() {
    let mesh = mesh();
    let device = Device::cpu();
    // The tree the runner builds for primary rays.
    let tree = KdTree::build(&mesh, &penumbra::raycast::tracer::tree_params(&device)).unwrap();
    let tree = &tree;
    let paths = trace_paths();
    run("cameras", 256, camera(), |camera| {
        let view = View::new(camera, 12, 8).unwrap();
        let results: Vec<_> = paths
            .iter()
            .map(|(name, settings)| (name, PrimaryRays::new(&device, &mesh).trace(&view, settings)))
            .collect();
        let (first, reference) = &results[0];
        for (name, result) in &results[1..] {
            match (reference, result) {
                (Err(a), Err(b)) if a.to_string() == b.to_string() => {}
                (Ok(_), Ok(_)) => {}
                (a, b) => {
                    return Err(format!(
                        "{first}: {:?}; {name}: {:?}",
                        a.as_ref().err(),
                        b.as_ref().err()
                    ));
                }
            }
        }
        if let Err(e) = reference {
            let shown = e.to_string();
            if shown.trim().is_empty() {
                return Err("an empty error".into());
            }
            return Ok(());
        }
        for (name, result) in &results {
            let image = result.as_ref().unwrap();
            for (r, (ray, &hit)) in image.rays.iter().zip(&image.hits).enumerate() {
                let kd = tree.closest_hit(ray.o(), ray.d(), f32::INFINITY);
                same_hit(tree, ray.o(), ray.d(), kd, hit, &format!("{name} pixel {r}"))?;
            }
        }
        Ok(())
    });
}

/// The GPU kernels (`trace_rays` closest hits, `ao_rays`) on the same
/// rays, with a small budget: the kd-tree's answers (t within the twins'
/// 1e-5 relative tolerance: a GPU compiler may fuse multiply-adds).
#[test]
fn gpu_kernels() {
    let Some(ctx) = common::gpu() else { return };
    let mesh = mesh();
    let accel = accel(&mesh);
    let tree = accel.kdtree();
    let gpu = std::sync::Mutex::new(Tracer::new(&Device::gpu(ctx), &mesh).unwrap());
    let rays = prop::collection::vec((origin(&mesh), aim(&mesh)), 1..64);
    run(
        "gpu_kernels",
        48,
        (rays, ao_points(&mesh), ao_settings()),
        |(rays, points, settings)| {
            let mut gpu = gpu.lock().unwrap();
            let rays: Vec<Ray> = rays.iter().map(|&(o, a)| Ray::new(o, a.dir(o))).collect();
            let hits = gpu.closest(&rays).map_err(|e| e.to_string())?.value;
            for (r, (ray, hit)) in rays.iter().zip(hits).enumerate() {
                let kd = tree.closest_hit(ray.o(), ray.d(), f32::INFINITY);
                let close = kd.is_hit() == hit.is_hit() && (!kd.is_hit() || (hit.t - kd.t).abs() <= 1e-5 * kd.t);
                if !close {
                    return Err(format!("trace_rays ray {r} {ray:?}: {hit:?}, the kd-tree {kd:?}"));
                }
            }
            let bar = Bar::hidden();
            let single = ao_rays_by(&accel, &points, &settings, &bar, Casting::Single);
            let masks = gpu
                .ao_visibility(&points, &settings, &bar)
                .map_err(|e| e.to_string())?
                .value;
            if masks.bits != single.bits {
                return Err(format!("ao_rays: {:x?}, single rays {:x?}", masks.bits, single.bits));
            }
            Ok(())
        },
    );
}
