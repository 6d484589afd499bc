//! Reference AO against closed forms, on the CPU and (when there is an
//! adapter) on the GPU. An estimate passes when it is within 3 standard
//! errors, sqrt(p (1 - p) / N) of the estimate p; where p is 0 or 1 that
//! means exactly equal.

mod common;

use glam::Vec3;
use penumbra::progress::Bar;
use penumbra::raycast::tracer::Tracer;
use penumbra::raycast::{AoPoint, AoSettings};
use penumbra::scene::Mesh;
use penumbra::scene::procedural::{closed_box, cylindrical_well, open_plane, wall_on_floor, well_floor_accessibility};

const RAYS: u32 = 4096;
const SEEDS: [u32; 3] = [1, 2, 3];

/// Estimates AO at `points` on the CPU and the GPU, for several seeds, and
/// checks each estimate against `exact`.
fn check(name: &str, mesh: &Mesh, points: &[AoPoint], exact: f64) {
    let mut tracers: Vec<Tracer> = common::devices()
        .iter()
        .map(|d| Tracer::new(d, mesh).unwrap())
        .collect();
    let mut worst_z = 0.0f64;
    for seed in SEEDS {
        let settings = AoSettings {
            rays_per_point: RAYS,
            radius: f32::INFINITY,
            seed,
        };
        for (k, tracer) in tracers.iter_mut().enumerate() {
            let device = ["cpu", "gpu"][k];
            let masks = tracer.ao_visibility(points, &settings, &Bar::hidden()).unwrap().value;
            for (i, &p) in masks.accessibility().iter().enumerate() {
                let p = p as f64;
                let se = (p * (1.0 - p) / RAYS as f64).sqrt();
                let err = (p - exact).abs();
                if se > 0.0 {
                    worst_z = worst_z.max(err / se);
                }
                assert!(
                    err <= 3.0 * se,
                    "{name} ({device}, seed {seed}, point {i}): estimate {p} vs exact {exact}, \
                     error {err:.2e} > 3 SE = {:.2e}",
                    3.0 * se
                );
            }
        }
    }
    println!("{name}: exact {exact}, worst error / SE = {worst_z:.3}");
}

fn up(p: Vec3, offset: f32) -> AoPoint {
    AoPoint::new(p + Vec3::Y * offset, Vec3::Y, 0)
}

#[test]
fn a_point_on_an_open_plane_sees_everything() {
    let mesh = open_plane(1000.0);
    let points: Vec<AoPoint> = [Vec3::ZERO, Vec3::new(3.0, 0.0, -7.0), Vec3::new(-999.0, 0.0, 999.0)]
        .iter()
        .map(|&p| up(p, 1e-4))
        .collect();
    check("open plane", &mesh, &points, 1.0);
}

#[test]
fn a_point_inside_a_closed_box_sees_nothing() {
    let mesh = closed_box(1.0);
    // Inward normals; points on the floor, including next to the walls and
    // in a corner, where rays would escape through any crack in the seams.
    let floor = [
        Vec3::new(0.5, 0.0, 0.5),
        Vec3::new(0.001, 0.0, 0.5),
        Vec3::new(0.5, 0.0, 0.999),
        Vec3::new(0.0005, 0.0, 0.0005),
        Vec3::new(0.125, 0.0, 0.375), // under a grid vertex of the tessellation
    ];
    let mut points: Vec<AoPoint> = floor.iter().map(|&p| up(p, 1e-4)).collect();
    // And from the middle of the box, looking along each axis.
    for n in [Vec3::X, -Vec3::X, Vec3::Z, -Vec3::Z, -Vec3::Y] {
        points.push(AoPoint::new(Vec3::splat(0.5), n, 0));
    }
    check("closed box", &mesh, &points, 0.0);
}

#[test]
fn a_point_on_the_floor_next_to_an_infinite_wall_sees_half() {
    // The wall blocks every direction towards it; with a wall 1000 units
    // high and wide, the unblocked part beyond its edges is below 1e-5.
    let mesh = wall_on_floor(1000.0);
    let points: Vec<AoPoint> = [0.01, 0.1, 1.0]
        .iter()
        .map(|&d| up(Vec3::new(d, 0.0, 0.3), 1e-4))
        .collect();
    check("floor next to a wall", &mesh, &points, 0.5);
}

#[test]
fn the_bottom_of_a_cylindrical_well() {
    // Smooth well: a^2 / (a^2 + h^2); the 64-gon well lets in 0.13% less,
    // the exact polygonal value is used.
    for (a, h) in [(1.0f32, 2.0f32), (1.0, 0.5), (0.5, 3.0)] {
        let mesh = cylindrical_well(a, h, 64);
        let exact = well_floor_accessibility(a as f64, h as f64, 64);
        let smooth = (a * a / (a * a + h * h)) as f64;
        assert!((exact - smooth).abs() / smooth < 2e-3);
        check(&format!("well a={a} h={h}"), &mesh, &[up(Vec3::ZERO, 1e-4)], exact);
    }
}

/// The closed forms survive extreme scales and offsets, with ray origins
/// offset by the contract's 1e-4 x bounding-box diagonal.
#[test]
fn closed_forms_at_extreme_scales_and_offsets() {
    // (scale, translation): tiny, huge, and far from the origin (where the
    // offset is still 20 ulps of the coordinates).
    for (scale, shift) in [(1e-4f32, 0.0f32), (1e5, 0.0), (1e3, 1e5)] {
        let place = |m: Mesh| m.map_positions(|p| p * scale + Vec3::splat(shift));
        let at = |m: &Mesh, p: Vec3| {
            let offset = 1e-4 * m.bounds().diagonal();
            up(p * scale + Vec3::splat(shift), offset)
        };
        let boxed = place(closed_box(1.0));
        check(
            &format!("closed box x{scale} +{shift}"),
            &boxed,
            &[at(&boxed, Vec3::new(0.5, 0.0, 0.5))],
            0.0,
        );
        let plane = place(open_plane(10.0));
        check(
            &format!("open plane x{scale} +{shift}"),
            &plane,
            &[at(&plane, Vec3::new(0.3, 0.0, 0.1))],
            1.0,
        );
        let wall = place(wall_on_floor(1000.0));
        check(
            &format!("wall x{scale} +{shift}"),
            &wall,
            &[at(&wall, Vec3::new(0.5, 0.0, 0.0))],
            0.5,
        );
    }
}
