//! The wide BVH against the kd-tree on meshes we did not make: the same
//! hits, ray for ray.

mod common;

use common::{Rng, data_model};
use glam::Vec3;
use penumbra::accel::kdtree::watertight::ShearedRay;
use penumbra::accel::kdtree::{KdTree, KdTreeSettings};
use penumbra::accel::{Accel, Structure};
use penumbra::geom::ray::Ray;
use penumbra::scene::load_mesh;

/// Random rays from a box three times the mesh's, aimed at points of its
/// box, and rays from eight corners fanned over it (coherent, as a camera's).
fn rays_at(rng: &mut Rng, lo: Vec3, hi: Vec3, n: usize) -> Vec<Ray> {
    let (c, e) = ((lo + hi) * 0.5, hi - lo);
    (0..n)
        .map(|k| {
            let target = lo + e * rng.vec3(0.0, 1.0);
            let o = if k % 2 == 0 {
                c + e * rng.vec3(-1.5, 1.5)
            } else {
                let corner = Vec3::new(
                    (k & 2) as f32 - 1.0,
                    (k & 4) as f32 / 2.0 - 1.0,
                    (k & 8) as f32 / 4.0 - 1.0,
                );
                c + e * corner * 1.2
            };
            Ray::new(o, target - o)
        })
        .collect()
}

/// Closest hits of the BVH and the kd-tree: t bit for bit on every ray; the
/// triangle the same, or both triangles hit at that very t (a tie, which
/// the BVH breaks towards the smaller index).
fn compare(path: &std::path::Path, n: usize) {
    let mesh = load_mesh(path).unwrap();
    let accel = Accel::new(KdTree::build(&mesh, &KdTreeSettings::default()).unwrap());
    let (tree, bvh) = (accel.kdtree(), accel.bvh());
    let rays = rays_at(&mut Rng(0x5eed), tree.bounds.min, tree.bounds.max, n);
    let (kd, wide) = (
        accel.trace_closest(Structure::Kdtree, &rays),
        accel.trace_closest(Structure::Bvh, &rays),
    );
    let (mut hits, mut ties) = (0, 0);
    for (k, (a, b)) in kd.iter().zip(&wide).enumerate() {
        assert_eq!(
            a.t.to_bits(),
            b.t.to_bits(),
            "{}: ray {k} {:?}",
            path.display(),
            rays[k]
        );
        hits += a.is_hit() as usize;
        if a.triangle != b.triangle {
            let ray = ShearedRay::in_frame(rays[k].o(), rays[k].d(), tree.frame_scale);
            let t_of = |i: u32| {
                let v = tree.triangles[i as usize].map(|p| p * tree.frame_scale);
                ray.intersect(v[0], v[1], v[2], f32::INFINITY)
            };
            assert_eq!(t_of(a.triangle), Some(a.t), "ray {k}");
            assert_eq!(t_of(b.triangle), Some(b.t), "ray {k}");
            assert!(b.triangle < a.triangle, "ray {k}: a tie goes to the smaller index");
            ties += 1;
        }
    }
    println!(
        "{}: {n} rays, {hits} hits, {ties} ties reported differently; BVH {} nodes (depth {}), {} blocks",
        path.display(),
        bvh.nodes.len(),
        bvh.depth(),
        bvh.blocks.len()
    );
    assert!(hits > n / 10);
}

#[test]
fn shared_models_give_the_kdtrees_hits() {
    for name in ["stanford-bunny.obj", "dragon100k.obj", "kitchen.obj", "cow.obj"] {
        if let Some(path) = data_model(name) {
            compare(&path, 200_000);
        }
    }
}

/// The BVH's 4x4 packets (`trace --accel bvh`) on camera images of meshes
/// we did not make, the kitchen from inside: each pixel's hit is the
/// single ray's through the BVH, bit for bit, in every instruction set.
#[test]
fn packets_give_the_single_rays_hits_on_camera_images() {
    use penumbra::accel::bvh::packet::trace_image;
    use penumbra::geom::simd::Isa;
    use penumbra::scene::Camera;
    for name in ["stanford-bunny.obj", "dragon100k.obj", "kitchen.obj", "cow.obj"] {
        let Some(path) = data_model(name) else { continue };
        let mesh = load_mesh(&path).unwrap();
        let accel = Accel::new(KdTree::build(&mesh, &KdTreeSettings::default()).unwrap());
        // The kitchen from inside, as `benches/embree_table.py` views it
        // (world coordinates into the mesh's frame).
        let local = |x: f64, y: f64, z: f64| (glam::DVec3::new(x, y, z) - mesh.origin).as_vec3();
        let camera = match name {
            "kitchen.obj" => Camera {
                eye: local(3.2, 1.6, 2.2),
                target: local(-1.0, 0.9, -1.5),
                fov_degrees: 60.0,
            },
            _ => Camera::default_for(&mesh.bounds()),
        };
        let (w, h) = (258, 190);
        let rays = camera.primary_rays(w, h);
        let expect = accel.trace_closest(Structure::Bvh, &rays);
        for isa in Isa::available() {
            let (got, counts) = trace_image(accel.bvh(), accel.kdtree(), &rays, w, h, isa);
            let differ = got.iter().zip(&expect).filter(|(a, b)| a != b).count();
            assert_eq!(differ, 0, "{name}, {isa:?}: {differ} of {} pixels differ", rays.len());
            println!("{name} {isa:?}: {counts:?}");
        }
        assert!(expect.iter().filter(|h| h.is_hit()).count() > rays.len() / 20, "{name}");
    }
}

#[test]
fn shipped_meshes_give_the_kdtrees_hits() {
    for name in [
        "sphere-on-plane.obj",
        "cube-with-hole.obj",
        "closed-box.obj",
        "cylindrical-well.obj",
    ] {
        compare(&common::asset(name), 20_000);
    }
}
