//! Traversal against brute force, and the extremes the tree must survive.

use glam::Vec3;

use super::test_rng::{Rng, brute_force, random_soup};
use super::*;

/// Closest hits equal brute force: same t; the triangle may differ only when
/// two triangles are hit at the same t (shared edges, duplicates).
fn assert_matches_brute_force(tree: &KdTree, rays: &[(Vec3, Vec3)]) -> usize {
    let mut hits = 0;
    for (k, &(o, d)) in rays.iter().enumerate() {
        let expect = brute_force(&tree.triangles, 1.0, o, d, f32::INFINITY);
        let got = tree.closest_hit(o, d, f32::INFINITY);
        assert_eq!(got.is_hit(), expect.is_hit(), "ray {k}: {o} {d}");
        if expect.is_hit() {
            hits += 1;
            assert_eq!(got.t, expect.t, "ray {k}: {o} {d}");
            assert!(tree.any_hit(o, d, f32::INFINITY));
            assert!(!tree.any_hit(o, d, expect.t), "any_hit must respect t_max");
        } else {
            assert!(!tree.any_hit(o, d, f32::INFINITY));
        }
    }
    hits
}

fn rays_at(rng: &mut Rng, n: usize, spread: f32) -> Vec<(Vec3, Vec3)> {
    (0..n)
        .map(|_| {
            let o = rng.vec(-3.0, 3.0);
            let target = rng.vec(-spread, spread);
            (o, target - o)
        })
        .collect()
}

#[test]
fn random_soups_match_brute_force() {
    let mut rng = Rng(0x9e3779b97f4a7c15);
    for (n, size) in [(1, 0.5), (10, 0.3), (500, 0.1), (3000, 0.05)] {
        let tree = KdTree::from_triangles(random_soup(&mut rng, n, size), &KdTreeSettings::default()).unwrap();
        let rays = rays_at(&mut rng, 2000, 1.0);
        let hits = assert_matches_brute_force(&tree, &rays);
        assert!(hits > 0, "{n} triangles: no ray hit anything");
    }
}

#[test]
fn sorted_ray_order_gives_the_same_hits() {
    let mut rng = Rng(0x51ed_270b_4a3f_1c9d);
    let tree = KdTree::from_triangles(random_soup(&mut rng, 2000, 0.05), &KdTreeSettings::default()).unwrap();
    let mut rays: Vec<Ray> = rays_at(&mut rng, 5000, 1.0)
        .into_iter()
        .map(|(o, d)| Ray::new(o, d))
        .collect();
    // Axis-parallel directions, and origins outside every octant of the box.
    rays.push(Ray::new(Vec3::new(-5.0, 0.0, 0.0), Vec3::X));
    rays.push(Ray::new(Vec3::new(0.1, 9.0, 0.2), -Vec3::Y));
    rays.push(Ray::new(Vec3::splat(7.0), Vec3::splat(1.0)));
    let hits = tree.trace_closest_incoherent(&rays);
    assert_eq!(hits, tree.trace_closest(&rays));
    assert!(hits.iter().filter(|h| h.is_hit()).count() > 100);
}

#[test]
fn origins_inside_the_scene_and_short_rays() {
    let mut rng = Rng(7);
    let tree = KdTree::from_triangles(random_soup(&mut rng, 2000, 0.08), &KdTreeSettings::default()).unwrap();
    for _ in 0..2000 {
        let o = rng.vec(-1.0, 1.0);
        let d = rng.vec(-1.0, 1.0);
        let t_max = rng.next_f32() * 2.0;
        let expect = brute_force(&tree.triangles, 1.0, o, d, t_max);
        let got = tree.closest_hit(o, d, t_max);
        assert_eq!(got.t.to_bits(), expect.t.to_bits());
        assert_eq!(tree.any_hit(o, d, t_max), expect.is_hit());
    }
}

#[test]
fn rule_settings_do_not_change_answers() {
    let mut rng = Rng(11);
    let soup = random_soup(&mut rng, 1500, 0.1);
    let rays = rays_at(&mut rng, 1000, 1.0);
    let variants = [
        KdTreeSettings::default(),
        KdTreeSettings::for_cpu(),
        KdTreeSettings {
            empty_cell_volume: 2.0,
            coplanar_rule: false,
            min_cell_area: 0.0,
            ..Default::default()
        },
        KdTreeSettings {
            exact_sah_below: 0,
            bins: 4,
            ..Default::default()
        },
        KdTreeSettings {
            max_depth: Some(3),
            ..Default::default()
        },
        KdTreeSettings {
            min_cell_area: 0.5,
            ..Default::default()
        },
    ];
    for params in variants {
        let tree = KdTree::from_triangles(soup.clone(), &params).unwrap();
        assert!(tree.stats.depth <= params.depth_limit(soup.len()));
        assert_matches_brute_force(&tree, &rays);
    }
}

#[test]
fn the_cpus_tree_has_fewer_larger_leaves_and_the_same_hits() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    let soup = random_soup(&mut rng, 4000, 0.05);
    let gpu = KdTree::from_triangles(soup.clone(), &KdTreeSettings::default()).unwrap();
    let cpu = KdTree::from_triangles(soup, &KdTreeSettings::for_cpu()).unwrap();
    assert_eq!((gpu.stats.traversal_cost, cpu.stats.traversal_cost), (1.0, 4.0));
    assert!(
        cpu.stats.nodes < gpu.stats.nodes && cpu.stats.mean_triangles_per_leaf > gpu.stats.mean_triangles_per_leaf,
        "a dearer step must give fewer, larger leaves: {} nodes ({:.1} a leaf) against {} ({:.1})",
        cpu.stats.nodes,
        cpu.stats.mean_triangles_per_leaf,
        gpu.stats.nodes,
        gpu.stats.mean_triangles_per_leaf
    );
    let rays: Vec<Ray> = rays_at(&mut rng, 3000, 1.0)
        .into_iter()
        .map(|(o, d)| Ray::new(o, d))
        .collect();
    let hits = cpu.trace_closest(&rays);
    assert_eq!(hits, gpu.trace_closest(&rays));
    assert!(hits.iter().filter(|h| h.is_hit()).count() > 300);
}

/// A regular grid of `n x n` quads in the plane z = 0 over [0,1]^2.
fn grid(n: usize, scale: f32, offset: Vec3) -> Vec<[Vec3; 3]> {
    let p = |i: usize, j: usize| Vec3::new(i as f32 / n as f32, j as f32 / n as f32, 0.0) * scale + offset;
    let mut tris = Vec::new();
    for i in 0..n {
        for j in 0..n {
            tris.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
            tris.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
        }
    }
    tris
}

#[test]
fn rays_through_vertices_and_edges_of_a_grid_never_leak() {
    for (scale, offset) in [
        (1.0, Vec3::ZERO),
        (1e-4, Vec3::ZERO),
        (1e5, Vec3::ZERO),
        (1.0, Vec3::splat(1e5)),
    ] {
        let n = 16;
        let tree = KdTree::from_triangles(grid(n, scale, offset), &KdTreeSettings::default()).unwrap();
        let eye = offset + Vec3::new(0.37, 0.21, 1.3) * scale;
        let mut leaks = 0;
        // Aim at every interior vertex, every interior edge's midpoint and
        // points along the diagonals: all shared by two or more triangles.
        // (The grid's outer boundary is shared by none, so it may be missed.)
        for i in 0..=n {
            for j in 0..=n {
                for (di, dj) in [(0.0, 0.0), (0.5, 0.0), (0.0, 0.5), (0.5, 0.5), (0.25, 0.25)] {
                    let (u, v) = ((i as f32 + di) / n as f32, (j as f32 + dj) / n as f32);
                    if u <= 0.0 || v <= 0.0 || u >= 1.0 || v >= 1.0 {
                        continue;
                    }
                    let target = offset + Vec3::new(u, v, 0.0) * scale;
                    if !tree.any_hit(eye, target - eye, f32::INFINITY) {
                        leaks += 1;
                    }
                }
            }
        }
        assert_eq!(leaks, 0, "scale {scale} offset {offset}");
    }
}

#[test]
fn rays_along_edges_in_the_plane_of_a_grid_hit_nothing_in_it() {
    // A ray lying in the grid's plane runs along its edges and through its
    // vertices; every in-plane triangle has det = 0 there, so nothing is hit,
    // and the traversal (which sees the ray in every split plane z = 0) ends.
    let mut tris = grid(8, 1.0, Vec3::ZERO);
    let tree = KdTree::from_triangles(tris.clone(), &KdTreeSettings::default()).unwrap();
    for (o, d) in [
        (Vec3::new(-1.0, 0.5, 0.0), Vec3::X),
        (Vec3::new(0.25, -1.0, 0.0), Vec3::Y),
        (Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)),
    ] {
        assert!(!tree.any_hit(o, d, f32::INFINITY), "{o} {d}");
    }
    // A wall standing on the grid is found by a ray along the grid's edge.
    tris.push([
        Vec3::new(2.0, -1.0, -1.0),
        Vec3::new(2.0, 2.0, -1.0),
        Vec3::new(2.0, 0.5, 2.0),
    ]);
    let tree = KdTree::from_triangles(tris, &KdTreeSettings::default()).unwrap();
    let h = tree.closest_hit(Vec3::new(-1.0, 0.5, 0.0), Vec3::X, f32::INFINITY);
    assert_eq!((h.t, h.triangle), (3.0, 128));
}

#[test]
fn rays_parallel_to_and_lying_in_split_planes() {
    // A closed cube's faces lie in the planes the builder splits on.
    let tris = cube(Vec3::ZERO, 1.0);
    let tree = KdTree::from_triangles(tris.clone(), &KdTreeSettings::default()).unwrap();
    // Axis-parallel rays from outside at many offsets, including exactly on
    // the face planes and edges.
    for k in 0..=8 {
        let c = k as f32 / 8.0;
        for (o, d) in [
            (Vec3::new(-1.0, c, 0.5), Vec3::X),
            (Vec3::new(0.5, -1.0, c), Vec3::Y),
            (Vec3::new(c, 0.5, 2.0), -Vec3::Z),
            (Vec3::new(-1.0, c, c), Vec3::X),
        ] {
            let expect = brute_force(&tris, 1.0, o, d, f32::INFINITY);
            let got = tree.closest_hit(o, d, f32::INFINITY);
            assert_eq!(got.t, expect.t, "{o} {d}");
            assert!(got.is_hit(), "ray {o} {d} must hit the cube");
        }
    }
    // Rays lying in a face plane hit nothing of that face (det = 0) but do
    // hit the perpendicular faces.
    let got = tree.closest_hit(Vec3::new(-1.0, 0.5, 0.0), Vec3::X, f32::INFINITY);
    assert_eq!(got.t, 1.0);
}

fn cube(min: Vec3, size: f32) -> Vec<[Vec3; 3]> {
    let v = |x: f32, y: f32, z: f32| min + Vec3::new(x, y, z) * size;
    let quads = [
        [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)],
        [v(0., 0., 1.), v(0., 1., 1.), v(1., 1., 1.), v(1., 0., 1.)],
        [v(0., 0., 0.), v(0., 1., 0.), v(0., 1., 1.), v(0., 0., 1.)],
        [v(1., 0., 0.), v(1., 0., 1.), v(1., 1., 1.), v(1., 1., 0.)],
        [v(0., 0., 0.), v(0., 0., 1.), v(1., 0., 1.), v(1., 0., 0.)],
        [v(0., 1., 0.), v(1., 1., 0.), v(1., 1., 1.), v(0., 1., 1.)],
    ];
    quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect()
}

#[test]
fn origins_on_a_surface_do_not_hit_it() {
    let tree = KdTree::from_triangles(cube(Vec3::ZERO, 1.0), &KdTreeSettings::default()).unwrap();
    // From a point on the floor going up: hits the ceiling at t = 1.
    let h = tree.closest_hit(Vec3::new(0.3, 0.4, 0.0), Vec3::Z, f32::INFINITY);
    assert_eq!(h.t, 1.0);
    // Leaving the floor downwards: nothing below.
    assert!(!tree.any_hit(Vec3::new(0.3, 0.4, 0.0), -Vec3::Z, f32::INFINITY));
}

#[test]
fn degenerate_and_needle_triangles() {
    let mut rng = Rng(3);
    let mut tris = random_soup(&mut rng, 300, 0.1);
    // Zero-area: a point and a segment; needles: 1e-7 wide, 1 long.
    tris.push([Vec3::ZERO; 3]);
    tris.push([Vec3::ZERO, Vec3::X, Vec3::X * 2.0]);
    for k in 0..50 {
        let c = rng.vec(-1.0, 1.0);
        let dir = rng.vec(-1.0, 1.0).normalize();
        tris.push([c, c + dir, c + dir + Vec3::splat(1e-7) * (k as f32 + 1.0)]);
    }
    let tree = KdTree::from_triangles(tris, &KdTreeSettings::default()).unwrap();
    assert_matches_brute_force(&tree, &rays_at(&mut rng, 2000, 1.0));
}

#[test]
fn a_single_triangle() {
    let tree = KdTree::from_triangles(vec![[Vec3::ZERO, Vec3::X, Vec3::Y]], &KdTreeSettings::default()).unwrap();
    assert_eq!(tree.stats.triangles, 1);
    let h = tree.closest_hit(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z, f32::INFINITY);
    assert_eq!((h.t, h.triangle), (1.0, 0));
    // Just inside hits, just outside misses; exactly on its (unshared) edges
    // and vertices either may happen, but the tree agrees with brute force.
    let o = Vec3::new(0.2, 0.1, 2.0);
    for (target, expect) in [
        (Vec3::new(0.49, 0.49, 0.0), Some(true)),
        (Vec3::new(0.51, 0.51, 0.0), Some(false)),
        (Vec3::new(0.5, 0.5, 0.0), None),
        (Vec3::ZERO, None),
        (Vec3::X, None),
    ] {
        let got = tree.closest_hit(o, target - o, f32::INFINITY);
        assert_eq!(got, brute_force(&tree.triangles, 1.0, o, target - o, f32::INFINITY));
        if let Some(e) = expect {
            assert_eq!(got.is_hit(), e, "{target}");
        }
    }
}

#[test]
fn a_million_coplanar_triangles() {
    // 708^2 * 2 > 1e6 triangles in the plane z = 0: the root cell is flat,
    // splits happen in x and y only, and the tree must stay shallow and small.
    let tris = grid(708, 1.0, Vec3::ZERO);
    assert!(tris.len() >= 1_000_000);
    let tree = KdTree::from_triangles(tris, &KdTreeSettings::default()).unwrap();
    let s = &tree.stats;
    assert!(s.depth <= s.depth_limit);
    assert!(
        s.leaf_references < 4 * s.triangles,
        "leaf references {} for {} triangles",
        s.leaf_references,
        s.triangles
    );
    let mut rng = Rng(5);
    for _ in 0..2000 {
        let target = rng.vec(0.0, 1.0) * Vec3::new(1.0, 1.0, 0.0);
        let o = rng.vec(-1.0, 2.0) + Vec3::Z * 2.0;
        let h = tree.closest_hit(o, target - o, f32::INFINITY);
        assert!(h.is_hit(), "ray to {target} leaked");
        assert!((h.t - 1.0).abs() < 1e-5, "t = {}", h.t);
    }
}

#[test]
fn covered_planes_become_splits() {
    // A box whose floor is one big quad, with small triangles above it: the
    // floor's plane is covered and must be split on (rule 2).
    let mut rng = Rng(9);
    let mut tris = grid(1, 4.0, Vec3::new(-2.0, -2.0, -1.0));
    tris.extend(random_soup(&mut rng, 400, 0.05));
    let tree = KdTree::from_triangles(tris, &KdTreeSettings::default()).unwrap();
    assert!(tree.stats.covered_plane_splits >= 1, "{:?}", tree.stats);
    let off = KdTree::from_triangles(
        tree.triangles.clone(),
        &KdTreeSettings {
            coplanar_rule: false,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(off.stats.covered_plane_splits, 0);
    assert_matches_brute_force(&tree, &rays_at(&mut rng, 1000, 2.0));
}

#[test]
fn empty_space_is_cut_off() {
    // Two clusters far apart: rule 1 must cut the empty space between them.
    let mut rng = Rng(13);
    let mut tris = random_soup(&mut rng, 200, 0.05);
    tris.extend(
        random_soup(&mut rng, 200, 0.05)
            .iter()
            .map(|t| t.map(|v| v + Vec3::X * 10.0)),
    );
    let tree = KdTree::from_triangles(tris, &KdTreeSettings::default()).unwrap();
    assert!(tree.stats.empty_cuts >= 1, "{:?}", tree.stats);
}

#[test]
fn depth_limit_is_respected_and_the_stack_suffices() {
    let mut rng = Rng(17);
    let soup = random_soup(&mut rng, 20_000, 0.01);
    for depth in [1, 5, MAX_TREE_DEPTH] {
        let tree = KdTree::from_triangles(
            soup.clone(),
            &KdTreeSettings {
                max_depth: Some(depth),
                min_cell_area: 0.0,
                ..Default::default()
            },
        )
        .unwrap();
        assert!(tree.stats.depth <= depth, "depth {} > {depth}", tree.stats.depth);
        assert_matches_brute_force(&tree, &rays_at(&mut rng, 300, 1.0));
    }
}

#[test]
fn bad_input_is_rejected() {
    let p = KdTreeSettings::default();
    assert!(
        KdTree::from_triangles(vec![], &p)
            .unwrap_err()
            .to_string()
            .contains("no triangles")
    );
    let e = KdTree::from_triangles(vec![[Vec3::ZERO, Vec3::X, Vec3::new(f32::NAN, 0.0, 0.0)]], &p).unwrap_err();
    assert!(e.to_string().contains("non-finite"), "{e}");
    let bad = KdTreeSettings {
        intersection_cost: -1.0,
        ..Default::default()
    };
    assert!(KdTree::from_triangles(vec![[Vec3::ZERO, Vec3::X, Vec3::Y]], &bad).is_err());
    let bad = KdTreeSettings {
        max_depth: Some(MAX_TREE_DEPTH + 1),
        ..Default::default()
    };
    assert!(KdTree::from_triangles(vec![[Vec3::ZERO, Vec3::X, Vec3::Y]], &bad).is_err());
}

/// Heavily overlapping geometry (20,000 large triangles in a box twice
/// their size, as thousands of overlapping instances make) keeps the tree
/// within its reference budget and still answers exactly; a mesh that
/// duplicates little is untouched by the budget.
#[test]
fn overlapping_geometry_stays_within_the_reference_budget() {
    let mut rng = Rng(77);
    let tris = random_soup(&mut rng, 20_000, 1.0);
    let tree = KdTree::from_triangles(tris.clone(), &KdTreeSettings::default()).unwrap();
    let s = &tree.stats;
    println!(
        "{} triangles: {} references ({:.1} per triangle), {} budget leaves, {:.0} ms",
        s.triangles,
        s.leaf_references,
        s.leaf_references as f64 / s.triangles as f64,
        s.budget_leaves,
        s.build_ms
    );
    assert!(s.budget_leaves > 0, "the budget must have been reached here");
    // The hard limit, plus what the cells being split when it was reached add.
    assert!(s.leaf_references <= 2 * build::MAX_REFERENCES_PER_TRIANGLE * 2 * tris.len());
    assert_matches_brute_force(&tree, &rays_at(&mut rng, 300, 1.5));
    let sparse = random_soup(&mut rng, 20_000, 0.01);
    let tree = KdTree::from_triangles(sparse, &KdTreeSettings::default()).unwrap();
    assert_eq!(tree.stats.budget_leaves, 0);
}

/// The build's bar is full exactly when the tree is,
/// on spread-out triangles and on overlapping ones that spend the reference
/// budget: every leaf advances it by its cell's share of the triangles.
#[test]
fn the_build_progress_bar_fills_exactly_when_the_tree_is_built() {
    let mut rng = Rng(5);
    for spread in [0.01, 1.0] {
        let soup = random_soup(&mut rng, 20_000, spread);
        let progress = crate::progress::Bar::hidden();
        let tree = KdTree::from_triangles_with(soup, &KdTreeSettings::default(), &progress).unwrap();
        assert_eq!(progress.position(), 20_000, "spread {spread}");
        assert!(tree.stats.leaves > 1000, "advanced by many leaves, not one step");
    }
}

/// A triangle without area (here a segment along z, as the kitchen has 26
/// of) is in no leaf: a ray whose origin lies on its line, where the
/// watertight edge functions are rounding error, hits nothing through
/// either tree. The kitchen's numbers: the AO origin of its vertex 24,890,
/// one of its rays and the segment it "hit" at t = 0.35 (a point far off
/// the segment), beside a small triangle with area that the ray passes,
/// so that the one leaf's box holds that point.
#[test]
fn triangles_without_area_are_never_hit() {
    let segment = [
        Vec3::new(2.496711, 0.001504, -1.825862),
        Vec3::new(2.496711, 0.001504, -1.855137),
        Vec3::new(2.496711, 0.001504, -1.515188),
    ];
    assert!(!watertight::has_area(&segment));
    assert!(watertight::has_area(&[Vec3::ZERO, Vec3::X, Vec3::Y]));
    assert!(!watertight::has_area(&[Vec3::ONE; 3]));
    let small = [
        Vec3::new(2.6, -0.05, -1.9),
        Vec3::new(2.61, -0.05, -1.9),
        Vec3::new(2.6, -0.04, -1.9),
    ];
    let origin = Vec3::new(2.496711, 0.001504, -1.4867059);
    let d = Vec3::new(0.17147863, -0.1154121, -0.97840434);
    // The arithmetic alone reports the segment.
    let t = watertight::ShearedRay::new(origin, d).intersect(segment[0], segment[1], segment[2], f32::INFINITY);
    assert!(t.is_some_and(|t| t > 0.3), "{t:?}");
    let tree = KdTree::from_triangles(vec![segment, small], &KdTreeSettings::default()).unwrap();
    assert!(!tree.closest_hit(origin, d, f32::INFINITY).is_hit(), "kd-tree");
    assert!(!tree.any_hit(origin, d, f32::INFINITY), "kd-tree, any hit");
    let accel = crate::accel::Accel::new(tree);
    let bvh = crate::accel::Structure::Bvh;
    assert!(!accel.closest_hit(bvh, origin, d, f32::INFINITY).is_hit(), "BVH");
    assert!(!accel.any_hit(bvh, origin, d, f32::INFINITY), "BVH, any hit");
    assert_eq!(accel.bvh().references(), 1, "only the triangle with area is in a leaf");
}
