//! SSAO (src/ssao): the G-buffer pass against kd-tree primary rays, every
//! SSAO kernel against its CPU twin on the same G-buffer and samples, and
//! the extremes (R -> 0, huge R, background, image borders, grazing
//! normals, NaN-free output).
//!
//! Tolerances:
//! * G-buffer: >= 99% of pixels agree (same coverage, depth within 1e-3
//!   relative, normals within 0.999 dot); every other pixel is a silhouette
//!   pixel (a 3x3 neighbour differs from it in the CPU G-buffer by the same
//!   thresholds, or is background).
//! * Kernels: every pixel within 1e-4 of the CPU twin (AO before and after
//!   the filter, at full and half resolution, L~, the image), given the
//!   same G-buffer and sample table.

mod common;
mod twins;

use common::{asset, data_model, gpu};
use glam::Vec3;
use penumbra::accel::Accel;
use penumbra::accel::kdtree::{KdTree, KdTreeSettings};
use penumbra::progress::Bar;
use penumbra::scene::procedural::all_scenes;
use penumbra::scene::{Camera, Mesh, load_obj};
use penumbra::ssao::gbuffer::{GBuffer, ScreenView, gbuffer};
use penumbra::ssao::gpu::{GBufferSource, run_frame};
use penumbra::ssao::truth::{raytraced, screen_reference};
use penumbra::ssao::{Estimator, Measure, Resolution, ShadeSettings, SsaoSettings, rmse, run_cpu};
use twins::{compare_gbuffers, compare_ssao_kernels, cpu_gbuffer};

const W: u32 = 160;
const H: u32 = 120;

fn kitchen_inside() -> Camera {
    Camera {
        eye: Vec3::new(3.2, 1.6, 2.2),
        target: Vec3::new(-1.0, 0.9, -1.5),
        fov_degrees: 60.0,
    }
}

#[test]
fn gbuffer_pass_agrees_with_kd_tree_primary_rays() {
    let Some(ctx) = gpu() else { return };
    for (name, mesh) in all_scenes() {
        compare_gbuffers(&ctx, name, &mesh, &Camera::default_for(&mesh.bounds()), (W, H));
    }
    for model in ["stanford-bunny.obj", "kitchen.obj"] {
        let Some(path) = data_model(model) else { return };
        let mesh = load_obj(&path).unwrap();
        compare_gbuffers(&ctx, model, &mesh, &Camera::default_for(&mesh.bounds()), (W, H));
        if model == "kitchen.obj" {
            compare_gbuffers(&ctx, "kitchen.obj inside", &mesh, &kitchen_inside(), (W, H));
        }
    }
}

#[test]
fn ssao_kernels_equal_their_cpu_twins() {
    let Some(ctx) = gpu() else { return };
    let mesh = load_obj(&asset("sphere-on-plane.obj")).unwrap();
    let camera = Camera::default_for(&mesh.bounds());
    let view = ScreenView::new(&camera, W, H);
    compare_ssao_kernels(&ctx, "sphere-on-plane", &cpu_gbuffer(&mesh, &camera, W, H), &view, 0.5);
    if let Some(path) = data_model("kitchen.obj") {
        let mesh = load_obj(&path).unwrap();
        let camera = kitchen_inside();
        let view = ScreenView::new(&camera, W, H);
        compare_ssao_kernels(&ctx, "kitchen inside", &cpu_gbuffer(&mesh, &camera, W, H), &view, 0.3);
    }
    // Odd sizes: the half-resolution grid's last column and row have no
    // right or lower neighbour.
    let (w, h) = (W + 1, H - 1);
    let view = ScreenView::new(&camera, w, h);
    compare_ssao_kernels(
        &ctx,
        "sphere-on-plane odd",
        &cpu_gbuffer(&mesh, &camera, w, h),
        &view,
        0.5,
    );
}

/// Runs every estimator on the CPU (and GPU when there is one) and hands
/// the final AO to `check`.
fn each_estimator(gb: &GBuffer, view: &ScreenView, radius: f32, check: impl Fn(&str, &[f32])) {
    let ctx = gpu();
    for estimator in Estimator::ALL {
        let (full, half) = (Resolution::Full, Resolution::Half);
        for (interleave, filter, resolution) in [(true, true, full), (false, false, full), (true, true, half)] {
            let mut s = SsaoSettings::new(estimator, 8, radius);
            s.interleave = interleave;
            s.filter = filter;
            s.resolution = resolution;
            let label = format!(
                "{} interleave={interleave} filter={filter} resolution={}",
                estimator.name(),
                resolution.name()
            );
            let cpu = run_cpu(gb, view, &s, Some(&ShadeSettings::default())).unwrap();
            for v in cpu.image.as_ref().unwrap().iter().flatten() {
                assert!(v.is_finite(), "{label}: non-finite image value on the CPU");
            }
            check(&format!("cpu {label}"), &cpu.ao);
            if let Some(ctx) = &ctx {
                let g = run_frame(
                    ctx,
                    GBufferSource::Upload(gb),
                    view,
                    &s,
                    Some(&ShadeSettings::default()),
                    1,
                )
                .unwrap()
                .frame;
                for v in g.image.as_ref().unwrap().iter().flatten() {
                    assert!(v.is_finite(), "{label}: non-finite image value on the GPU");
                }
                check(&format!("gpu {label}"), &g.ao);
            }
        }
    }
}

fn sphere_scene() -> (GBuffer, ScreenView) {
    let mesh = load_obj(&asset("sphere-on-plane.obj")).unwrap();
    let camera = Camera::default_for(&mesh.bounds());
    (cpu_gbuffer(&mesh, &camera, W, H), ScreenView::new(&camera, W, H))
}

#[test]
fn radius_to_zero_gives_accessibility_one_everywhere() {
    let (gb, view) = sphere_scene();
    each_estimator(&gb, &view, 1e-6, |label, ao| {
        let worst = ao.iter().map(|a| (1.0 - a).abs()).fold(0.0f32, f32::max);
        assert!(
            worst <= 1e-5,
            "{label}: accessibility {worst} away from 1 with R = 1e-6"
        );
    });
}

#[test]
fn huge_radius_stays_finite_and_in_range() {
    let (gb, view) = sphere_scene();
    for radius in [1e4f32, 1e30] {
        each_estimator(&gb, &view, radius, |label, ao| {
            assert!(
                ao.iter().all(|a| a.is_finite() && (0.0..=1.0).contains(a)),
                "{label}: R = {radius}"
            );
        });
    }
}

#[test]
fn background_and_border_pixels_and_grazing_normals() {
    // A plane seen almost edge-on (grazing normals), cut off by the image
    // border, above a background: every pixel's AO is finite and in range;
    // background pixels are 1; border pixels are estimated like the others.
    let positions = vec![
        Vec3::new(-50.0, 0.0, -50.0),
        Vec3::new(50.0, 0.0, -50.0),
        Vec3::new(50.0, 0.0, 50.0),
        Vec3::new(-50.0, 0.0, 50.0),
        // a small box standing on it, so something occludes
        Vec3::new(-0.5, 0.0, -0.5),
        Vec3::new(0.5, 0.0, -0.5),
        Vec3::new(0.5, 1.0, -0.5),
        Vec3::new(-0.5, 1.0, -0.5),
    ];
    let triangles = vec![[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7]];
    let mesh = Mesh::new(positions, triangles).unwrap();
    let camera = Camera {
        eye: Vec3::new(0.0, 0.05, 6.0),
        target: Vec3::new(0.0, 0.0, 0.0),
        fov_degrees: 40.0,
    };
    let gb = cpu_gbuffer(&mesh, &camera, W, H);
    let view = ScreenView::new(&camera, W, H);
    let background = (0..gb.pixels()).filter(|&i| !gb.is_surface(i)).count();
    assert!(background > 0 && background < gb.pixels());
    // Grazing: the plane's normal is nearly perpendicular to the view.
    let grazing = (0..gb.pixels())
        .filter(|&i| gb.is_surface(i) && gb.normal(i).z.abs() < 0.05)
        .count();
    assert!(grazing > 100, "{grazing} grazing pixels");
    each_estimator(&gb, &view, 0.5, |label, ao| {
        for (i, a) in ao.iter().enumerate() {
            assert!(a.is_finite() && (0.0..=1.0).contains(a), "{label}: pixel {i} = {a}");
            if !gb.is_surface(i) {
                assert_eq!(*a, 1.0, "{label}: background pixel {i}");
            }
        }
        // Bottom row (the border): surface pixels, estimated, not NaN.
        let row = (H - 1) as usize * W as usize;
        assert!((row..row + W as usize).all(|i| gb.is_surface(i)));
        // The box's foot is occluded somewhere.
        assert!(ao.iter().any(|&a| a < 0.9), "{label}");
    });
}

#[test]
fn nan_and_far_plane_depths_are_background() {
    // A G-buffer with NaN and infinite depths and NaN normals: treated as
    // background or open, never propagated.
    let (mut gb, view) = sphere_scene();
    let n = gb.pixels();
    for i in (0..n).step_by(7) {
        gb.geometry[i] = [f32::NAN, 0.0, 0.0, f32::NAN];
    }
    for i in (3..n).step_by(11) {
        gb.geometry[i][3] = f32::INFINITY;
    }
    for estimator in Estimator::ALL {
        let s = SsaoSettings::new(estimator, 8, 0.5);
        let f = run_cpu(&gb, &view, &s, Some(&ShadeSettings::default())).unwrap();
        assert!(
            f.ao.iter().all(|a| a.is_finite() && (0.0..=1.0).contains(a)),
            "{}",
            estimator.name()
        );
        assert_eq!(f.ao.len(), n);
        // The pixels of no finite depth are background: fully open.
        for i in (0..n).step_by(7).chain((3..n).step_by(11)) {
            assert_eq!(
                f.ao[i],
                1.0,
                "{}: pixel {i}, of NaN or infinite depth",
                estimator.name()
            );
        }
    }
}

#[test]
fn open_plane_is_fully_accessible_for_truth_reference_and_estimators() {
    let mesh = load_obj(&asset("open-plane.obj")).unwrap();
    let b = mesh.bounds();
    let camera = Camera {
        eye: b.center() + Vec3::new(0.0, 0.5, 0.8) * b.diagonal(),
        target: b.center(),
        fov_degrees: 30.0,
    };
    let accel = Accel::new(KdTree::build(&mesh, &KdTreeSettings::default()).unwrap());
    let gb = gbuffer(accel.kdtree(), &mesh, &camera, &[], 64, 48);
    let view = ScreenView::new(&camera, 64, 48);
    let radius = 0.05 * b.diagonal();
    let truth = raytraced(
        &accel,
        &camera,
        &view,
        &gb,
        Measure::Poly4,
        radius,
        (64, 1),
        &Bar::hidden(),
    );
    let s = SsaoSettings::new(Estimator::Importance, 16, radius);
    let reference = screen_reference(&gb, &view, &s, 256, &Bar::hidden());
    for (what, v) in [("truth", &truth.values), ("reference", &reference.values)] {
        assert!(v.iter().all(|&a| a == 1.0), "{what}");
    }
    for estimator in Estimator::ALL {
        let s = SsaoSettings::new(estimator, 16, radius);
        let f = run_cpu(&gb, &view, &s, None).unwrap();
        let e = rmse(&gb, &f.ao, &truth.values);
        assert!(e < 1e-5, "{}: rmse {e} on an open plane", estimator.name());
    }
}

#[test]
fn estimators_converge_to_the_screen_reference() {
    // Every estimator of the volumetric integral approaches the dense
    // quadrature as samples grow (tangent-sphere and base-disk keep their
    // approximations' bias: looser bound).
    let (gb, view) = sphere_scene();
    let radius = 0.5;
    let base = SsaoSettings::new(Estimator::Importance, 16, radius);
    let reference = screen_reference(&gb, &view, &base, 2048, &Bar::hidden());
    for estimator in Estimator::ALL {
        let errors: Vec<f64> = [4, 64]
            .iter()
            .map(|&spp| {
                let mut s = SsaoSettings::new(estimator, spp, radius);
                s.filter = false;
                rmse(&gb, &run_cpu(&gb, &view, &s, None).unwrap().ao, &reference.values)
            })
            .collect();
        println!("{}: rmse vs reference at 4 and 64 spp: {errors:?}", estimator.name());
        assert!(errors[1] < errors[0], "{}: {errors:?}", estimator.name());
        let bound = match estimator {
            Estimator::TangentSphere | Estimator::BaseDisk | Estimator::Raymarch => 0.1,
            _ => 0.03,
        };
        assert!(errors[1] < bound, "{}: {errors:?}", estimator.name());
    }
}

#[test]
fn ground_truth_noise_is_reported_and_shrinks() {
    let (gb, view) = sphere_scene();
    let mesh = load_obj(&asset("sphere-on-plane.obj")).unwrap();
    let accel = Accel::new(KdTree::build(&mesh, &KdTreeSettings::default()).unwrap());
    let camera = Camera::default_for(&mesh.bounds());
    let truth = |rays| {
        raytraced(
            &accel,
            &camera,
            &view,
            &gb,
            Measure::Step,
            0.5,
            (rays, 1),
            &Bar::hidden(),
        )
    };
    let (a, b) = (truth(16), truth(256));
    println!("truth noise: 16 rays {:.4}, 256 rays {:.4}", a.noise_rms, b.noise_rms);
    assert!(b.noise_rms < 0.5 * a.noise_rms && b.noise_rms > 0.0);
    // The estimate of the noise is honest: the 16-ray truth differs from
    // the 256-ray one by about its own noise.
    let diff = rmse(&gb, &a.values, &b.values);
    assert!(
        diff < 2.0 * a.noise_rms && diff > 0.5 * a.noise_rms,
        "{diff} vs {}",
        a.noise_rms
    );
}
