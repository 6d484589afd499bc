//! AO rays in shared-origin packets, through the kd-tree and through its
//! wide BVH, against the kd-tree's single-ray any-hit path:
//! the same visibility, ray for ray, in every instruction set this CPU has,
//! on every procedural scene and (with `PENUMBRA_DATA`) the cow and the
//! bunny; with an infinite radius and a short one (rays that end inside the
//! tree), and a ray count that leaves a packet partly empty.

mod common;

use common::data_model;
use penumbra::accel::kdtree::{KdTree, KdTreeSettings};
use penumbra::accel::{Accel, Structure};
use penumbra::geom::simd::Isa;
use penumbra::progress::Bar;
use penumbra::raycast::AoSettings;
use penumbra::raycast::ao_rays::{Casting, ao_rays, ao_rays_by};
use penumbra::raycast::points::vertex_points;
use penumbra::scene::procedural::all_scenes;
use penumbra::scene::{Mesh, load_obj};

fn compare(name: &str, mesh: &Mesh, rays_per_point: u32) {
    let accel = Accel::new(KdTree::build(mesh, &KdTreeSettings::default()).unwrap());
    let points = vertex_points(mesh);
    let diagonal = mesh.bounds().diagonal();
    for radius in [f32::INFINITY, 0.05 * diagonal] {
        let settings = AoSettings {
            rays_per_point,
            radius,
            seed: 11,
        };
        let single = ao_rays_by(&accel, &points, &settings, &Bar::hidden(), Casting::Single);
        let total = points.len() as u64 * rays_per_point as u64;
        let open: u64 = single.bits.iter().map(|w| w.count_ones() as u64).sum();
        for isa in Isa::available() {
            let kd = Casting::Packets(Structure::Kdtree, isa);
            let packets = ao_rays_by(&accel, &points, &settings, &Bar::hidden(), kd);
            let differ = single.differing_rays(&packets);
            println!("{name} radius {radius}: {isa:?}, {total} rays ({open} open), {differ} differ");
            assert_eq!(differ, 0, "{name}, radius {radius}, {isa:?}");
            let wide = Casting::Packets(Structure::Bvh, isa);
            let bvh = ao_rays_by(&accel, &points, &settings, &Bar::hidden(), wide);
            let differ = single.differing_rays(&bvh);
            println!("{name} radius {radius}: BVH packets {isa:?}, {differ} differ");
            assert_eq!(differ, 0, "{name}, radius {radius}, BVH packets {isa:?}");
        }
        assert_eq!(ao_rays(&accel, &points, &settings, &Bar::hidden()), single);
    }
}

#[test]
fn packets_equal_single_rays_on_procedural_scenes() {
    for (name, mesh) in all_scenes() {
        compare(name, &mesh, 40);
    }
}

#[test]
fn packets_equal_single_rays_on_shared_models() {
    for model in ["cow.obj", "stanford-bunny.obj"] {
        let Some(path) = data_model(model) else {
            println!("PENUMBRA_DATA not set: {model} skipped");
            continue;
        };
        let mesh = load_obj(&path).unwrap();
        compare(model, &mesh, 64);
    }
}

/// A run one point short is not equal to the full one, whatever the
/// words it has in common say.
#[test]
fn masks_of_another_length_differ() {
    let full = penumbra::raycast::VisibilityMasks {
        rays_per_point: 32,
        words_per_point: 1,
        bits: vec![0xffff_0000; 4],
    };
    let mut short = full.clone();
    short.bits.pop();
    assert_eq!(full.differing_rays(&full), 0);
    assert_eq!(full.differing_rays(&short), 128);
    assert_eq!(short.differing_rays(&full), 128);
}
