//! The BVH against brute force (the smallest t, and at equal t the smaller
//! triangle index: exactly what a loop over all triangles in index order
//! with a strict `<` reports), on soups, shared edges, degenerate inputs
//! and extreme scales; its structure; the two box tests against each other.

use glam::Vec3;

use super::traverse::{BoxRay, BoxTest, Lanes8};
use super::*;
use crate::accel::kdtree::test_rng::{Rng, brute_force, random_soup};
use crate::accel::kdtree::watertight::ShearedRay;
use crate::accel::kdtree::{KdTree, KdTreeSettings};
use crate::accel::{Accel, Structure};

/// Rays from outside and inside, aimed at vertices, edge midpoints and
/// anywhere, some axis-parallel (zero direction components).
fn rays_for(rng: &mut Rng, tris: &[[Vec3; 3]], n: usize, reach: f32) -> Vec<(Vec3, Vec3, f32)> {
    (0..n)
        .map(|k| {
            let o = rng.vec(-reach, reach);
            let tri = tris[k % tris.len()];
            let d = match k % 6 {
                0 => tri[0] - o,
                1 => (tri[1] + tri[2]) * 0.5 - o,
                2 => [Vec3::X, -Vec3::Y, Vec3::Z][k % 3],
                3 => (tri[0] + tri[1] + tri[2]) / 3.0 - o,
                _ => rng.vec(-1.0, 1.0),
            };
            let t_max = if k % 5 == 0 {
                rng.next_f32() * 2.0
            } else {
                f32::INFINITY
            };
            (o, d, t_max)
        })
        .collect()
}

/// Every ray's closest hit equals brute force bit for bit, triangle
/// included; any-hit agrees. Returns (hits, rays whose closest t two
/// triangles share).
fn assert_brute_force(tris: &[[Vec3; 3]], rays: &[(Vec3, Vec3, f32)]) -> (usize, usize) {
    let accel = Accel::new(KdTree::from_triangles(tris.to_vec(), &KdTreeSettings::default()).unwrap());
    let bvh = accel.bvh();
    assert!(bvh.depth() <= 81, "depth {}", bvh.depth());
    let (mut hits, mut ties) = (0, 0);
    for (k, &(o, d, t_max)) in rays.iter().enumerate() {
        let expect = brute_force(tris, bvh.frame_scale, o, d, t_max);
        let got = accel.closest_hit(Structure::Bvh, o, d, t_max);
        assert_eq!(
            (got.t.to_bits(), got.triangle),
            (expect.t.to_bits(), expect.triangle),
            "ray {k}: {o} {d} t_max {t_max}"
        );
        assert_eq!(
            accel.any_hit(Structure::Bvh, o, d, t_max),
            expect.is_hit(),
            "any-hit, ray {k}"
        );
        if expect.is_hit() {
            hits += 1;
            let ray = ShearedRay::in_frame(o, d, bvh.frame_scale);
            let s = bvh.frame_scale;
            let shared = tris
                .iter()
                .filter(|t| ray.intersect(t[0] * s, t[1] * s, t[2] * s, t_max) == Some(got.t))
                .count();
            ties += (shared > 1) as usize;
        }
    }
    (hits, ties)
}

#[test]
fn random_soups_match_brute_force() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    for (n, size) in [(1, 0.5), (7, 0.3), (500, 0.1), (3000, 0.05)] {
        let tris = random_soup(&mut rng, n, size);
        let rays = rays_for(&mut rng, &tris, 3000, 3.0);
        let (hits, _) = assert_brute_force(&tris, &rays);
        assert!(hits > 300, "{n} triangles: {hits} hits");
    }
}

/// A curved grid of quads, two triangles each, and a copy of it after it
/// (each triangle again, at an index 2n^2 higher): rays through shared
/// edges and vertices, and every hit a tie between a triangle and its copy,
/// where the smaller index must win.
#[test]
fn shared_edges_and_ties_report_the_smaller_index() {
    let n = 24;
    let mut tris = Vec::new();
    let p = |i: usize, j: usize| {
        Vec3::new(
            i as f32 / n as f32,
            j as f32 / n as f32,
            0.25 * (i * j) as f32 / (n * n) as f32,
        )
    };
    for i in 0..n {
        for j in 0..n {
            tris.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
            tris.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
        }
    }
    tris.extend_from_within(..);
    let mut rng = Rng(5);
    let rays: Vec<_> = (0..4000)
        .map(|k| {
            let o = rng.vec(-1.0, 2.0) + Vec3::Z * 2.0;
            let (i, j) = (1 + k % (n - 1), 1 + (k / 7) % (n - 1));
            let target = if k % 2 == 0 {
                p(i, j)
            } else {
                (p(i, j) + p(i + 1, j + 1)) * 0.5
            };
            (o, target - o, f32::INFINITY)
        })
        .collect();
    let (hits, ties) = assert_brute_force(&tris, &rays);
    println!("grid: {hits} hits, {ties} at a t shared by two or more triangles");
    assert_eq!(ties, hits);
}

/// Inputs the SAH cannot split: identical triangles (one centroid), and
/// triangles whose sizes grow geometrically (an unbalanced SAH tree).
#[test]
fn degenerate_inputs() {
    let mut rng = Rng(17);
    let same = vec![[Vec3::ZERO, Vec3::X, Vec3::Y]; 1000];
    let rays = rays_for(&mut rng, &same, 500, 2.0);
    let (hits, _) = assert_brute_force(&same, &rays);
    assert!(hits > 50);
    let nested: Vec<[Vec3; 3]> = (0..120)
        .map(|i| {
            let s = 1.2f32.powi(i);
            [
                Vec3::new(-s, -s, s * 0.01),
                Vec3::new(s, -s, s * 0.01),
                Vec3::new(0.0, s, s * 0.01),
            ]
        })
        .collect();
    let rays = rays_for(&mut rng, &nested, 2000, 5.0);
    assert_brute_force(&nested, &rays);
}

/// Scenes of size 1e13 and 1e-13, and small scenes far from the origin
/// (the boxes' padding is in units of the largest coordinate).
#[test]
fn extreme_scales_and_offsets() {
    // A soup, and slivers (whose spatial splits cut triangles at rounded
    // crossing points).
    let scenes = [random_soup(&mut Rng(23), 800, 0.08), slivers(&mut Rng(23), 800)];
    for (scale, offset) in [(1e13f32, 0.0f32), (1e-13, 0.0), (1.0, 3.0e4)] {
        for unscaled in &scenes {
            let mut rng = Rng(29);
            let tris: Vec<[Vec3; 3]> = unscaled
                .iter()
                .map(|t| t.map(|v| v * scale + Vec3::splat(offset)))
                .collect();
            let rays: Vec<_> = rays_for(&mut rng, unscaled, 2000, 3.0)
                .into_iter()
                .map(|(o, d, t)| (o * scale + Vec3::splat(offset), d * scale, t))
                .collect();
            let (hits, _) = assert_brute_force(&tris, &rays);
            assert!(hits > 100, "scale {scale} offset {offset}: {hits} hits");
        }
    }
}

/// Long thin triangles across the unit cube (a kitchen's cables, rails
/// and wall strips) among small ones: where spatial splits pay.
fn slivers(rng: &mut Rng, n: usize) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|k| {
            if k % 3 == 0 {
                let a = rng.vec(-1.0, 1.0);
                let b = rng.vec(-1.0, 1.0);
                [a, b, a + rng.vec(-0.02, 0.02)]
            } else {
                let c = rng.vec(-1.0, 1.0);
                [0; 3].map(|_| c + rng.vec(-0.05, 0.05))
            }
        })
        .collect()
}

/// Leaves' boxes (as the walks see them, padded) and the triangles each
/// references; checks on the way that every child's box lies in its
/// parent's and no leaf holds a triangle twice.
fn leaves(bvh: &Bvh8) -> Vec<(Vec3, Vec3, Vec<u32>)> {
    fn walk(bvh: &Bvh8, child: u32, lo: Vec3, hi: Vec3, out: &mut Vec<(Vec3, Vec3, Vec<u32>)>) {
        if child & LEAF_BIT != 0 {
            let block = &bvh.blocks[(child & !LEAF_BIT) as usize];
            let ids: Vec<u32> = block.triangles.iter().copied().filter(|&t| t != u32::MAX).collect();
            assert!(
                ids.windows(2).all(|w| w[0] < w[1]),
                "a leaf's triangles ascend, once each"
            );
            out.push((lo, hi, ids));
            return;
        }
        let node = &bvh.nodes[child as usize];
        for slot in 0..WIDTH {
            if node.child[slot] == EMPTY_CHILD {
                continue;
            }
            let l = Vec3::new(node.planes[0][slot], node.planes[1][slot], node.planes[2][slot]);
            let h = Vec3::new(node.planes[3][slot], node.planes[4][slot], node.planes[5][slot]);
            assert!(l.cmpge(lo).all() && h.cmple(hi).all(), "child box outside its parent's");
            walk(bvh, node.child[slot], l, h, out);
        }
    }
    let mut out = Vec::new();
    walk(bvh, 0, Vec3::NEG_INFINITY, Vec3::INFINITY, &mut out);
    out
}

/// Every point of every triangle (vertices, points along the edges and
/// inside) lies in the box of a leaf that references the triangle, with or
/// without spatial splits; without them each triangle is in one leaf; and
/// every node has two children or more, an incomplete node leaves only
/// (the widening opens inner children until eight).
#[test]
fn structure() {
    let mut rng = Rng(31);
    for (scene, tris) in [
        ("soup", random_soup(&mut rng, 5000, 0.05)),
        ("slivers", slivers(&mut rng, 3000)),
    ] {
        let accel = Accel::new(KdTree::from_triangles(tris.clone(), &KdTreeSettings::default()).unwrap());
        for budget in [0.0, 0.3, 2.0] {
            let params = BvhSettings {
                spatial_split_budget: budget,
                spatial_alpha: 0.0,
                spatial_min_span: 0.0,
            };
            let bvh = Bvh8::build(accel.kdtree(), &params);
            let mut held: Vec<Vec<(Vec3, Vec3)>> = vec![Vec::new(); tris.len()];
            for (lo, hi, ids) in leaves(&bvh) {
                for t in ids {
                    held[t as usize].push((lo, hi));
                }
            }
            let references: usize = held.iter().map(Vec::len).sum();
            assert_eq!(references, bvh.references());
            let extra = references - tris.len();
            assert!(
                extra as f32 <= budget * tris.len() as f32,
                "{scene} {budget}: {extra} copies"
            );
            if budget == 0.0 {
                assert!(held.iter().all(|h| h.len() == 1), "{scene}: a triangle in two leaves");
            } else if scene == "slivers" {
                assert!(extra > tris.len() / 20, "{scene} {budget}: only {extra} copies");
            }
            for (t, boxes) in tris.iter().zip(&held) {
                let steps = 16;
                for i in 0..=steps {
                    for j in 0..=steps - i {
                        let (u, v) = (i as f32 / steps as f32, j as f32 / steps as f32);
                        let p = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v;
                        assert!(
                            boxes.iter().any(|(lo, hi)| p.cmpge(*lo).all() && p.cmple(*hi).all()),
                            "{scene} {budget}: {p} of {t:?} in no leaf box of it"
                        );
                    }
                }
            }
            for node in &bvh.nodes {
                let used: Vec<u32> = node.child.iter().copied().filter(|&c| c != EMPTY_CHILD).collect();
                assert!(used.len() >= 2);
                assert!(used.len() == WIDTH || used.iter().all(|&c| c & LEAF_BIT != 0));
            }
        }
    }
}

/// Each of `expect`'s hits equals the packet's lane bit for bit: t and
/// triangle.
fn assert_lanes_equal(got: &[Hit], expect: &[Hit], what: &str) {
    for (r, e) in expect.iter().enumerate() {
        assert_eq!(
            (got[r].t.to_bits(), got[r].triangle),
            (e.t.to_bits(), e.triangle),
            "{what}, lane {r}"
        );
    }
}

/// `Accel::bvh_with` builds with its knobs once; `bvh` then returns that
/// BVH, and a later `bvh_with` does not rebuild.
#[test]
fn bvh_with_builds_once() {
    let mut rng = Rng(5);
    let tris = slivers(&mut rng, 600);
    let accel = Accel::new(KdTree::from_triangles(tris.clone(), &KdTreeSettings::default()).unwrap());
    let off = BvhSettings {
        spatial_split_budget: 0.0,
        ..BvhSettings::default()
    };
    assert_eq!(accel.bvh_with(&off).references(), tris.len());
    assert_eq!(accel.bvh().references(), tris.len());
    assert_eq!(accel.bvh_with(&BvhSettings::default()).references(), tris.len());
    let fresh = Accel::new(KdTree::from_triangles(tris.clone(), &KdTreeSettings::default()).unwrap());
    assert!(fresh.bvh().references() > tris.len(), "the default splits slivers");
}

/// Spatial splits change which leaves hold a triangle, never a hit: long
/// thin triangles, copied into several leaves, against brute force (t and
/// triangle bit for bit, ties to the smaller index), for single rays, and
/// packets against single rays, every instruction set.
#[test]
fn spatial_splits_keep_every_hit() {
    let mut rng = Rng(77);
    let tris = slivers(&mut rng, 2000);
    let accel = Accel::new(KdTree::from_triangles(tris.clone(), &KdTreeSettings::default()).unwrap());
    assert!(
        accel.bvh().references() > tris.len(),
        "the default build splits these slivers"
    );
    let rays = rays_for(&mut rng, &tris, 6000, 2.0);
    let (hits, _) = assert_brute_force(&tris, &rays);
    assert!(hits > 1000, "{hits} hits");
    // Packets of 16 rays from one origin, aimed at the slivers.
    let mut counts = [0usize; 2];
    for k in 0..400 {
        let origin = rng.vec(-1.5, 1.5);
        let dirs: Vec<Vec3> = (0..16)
            .map(|r| {
                let t = tris[3 * ((k * 16 + r) % (tris.len() / 3))];
                t[0] + (t[1] - t[0]) * rng.next_f32() - origin
            })
            .collect();
        let t_max = if k % 3 == 0 {
            rng.next_f32() * 2.0
        } else {
            f32::INFINITY
        };
        let expect: Vec<_> = dirs
            .iter()
            .map(|&d| brute_force(&tris, accel.kdtree().frame_scale, origin, d, t_max))
            .collect();
        let mask = expect
            .iter()
            .enumerate()
            .fold(0u16, |m, (r, h)| m | (h.is_hit() as u16) << r);
        for isa in crate::geom::simd::Isa::available() {
            let got = packet::closest(accel.bvh(), accel.kdtree(), origin, &dirs, t_max, isa);
            assert_lanes_equal(&got, &expect, &format!("packet {k}, {isa:?}"));
            assert_eq!(
                accel.occluded(Structure::Bvh, origin, &dirs, t_max, isa),
                mask,
                "packet {k}, {isa:?}"
            );
        }
        counts[0] += mask.count_ones() as usize;
        counts[1] += 16 - mask.count_ones() as usize;
    }
    assert!(counts[0] > 1000 && counts[1] > 500, "{counts:?}");
}

/// A node whose first `slots` children have random boxes in [-1, 1]^3,
/// the rest empty.
#[cfg(target_arch = "x86_64")]
fn random_node(rng: &mut Rng, slots: usize) -> Node8 {
    let mut node = Node8::EMPTY;
    for slot in 0..slots {
        let (a, b) = (rng.vec(-1.0, 1.0), rng.vec(-1.0, 1.0));
        for axis in 0..3 {
            node.planes[axis][slot] = a[axis].min(b[axis]);
            node.planes[axis + 3][slot] = a[axis].max(b[axis]);
        }
        node.child[slot] = slot as u32;
        node.used |= 1 << slot;
    }
    node
}

/// The AVX box test gives the portable one's mask and entry distances bit
/// for bit, with zero direction components and origins on box planes.
#[cfg(target_arch = "x86_64")]
#[test]
fn box_tests_agree() {
    if !std::arch::is_x86_feature_detected!("avx2") {
        return;
    }
    #[target_feature(enable = "avx2")]
    fn avx(node: &Node8, ray: &BoxRay, t_far: f32) -> (u32, [f32; WIDTH]) {
        super::traverse::Avx8::test(node, ray, t_far)
    }
    let mut rng = Rng(41);
    let mut entered = 0;
    for k in 0..20_000 {
        let node = random_node(&mut rng, k % WIDTH + 1);
        let mut o = rng.vec(-2.0, 2.0);
        if k % 4 == 0 {
            o.x = node.planes[0][0];
        }
        let mut d = rng.vec(-1.0, 1.0);
        match k % 5 {
            0 => d.x = 0.0,
            1 => d.y = -0.0,
            _ => {}
        }
        let ray = BoxRay::new(o, d);
        let t_far = if k % 3 == 0 { rng.next_f32() } else { f32::INFINITY };
        let portable = Lanes8::test(&node, &ray, t_far);
        // SAFETY: the CPU has AVX2 (checked above).
        let wide = unsafe { avx(&node, &ray, t_far) };
        assert_eq!(portable.0, wide.0, "case {k}: masks");
        for l in 0..WIDTH {
            if portable.0 >> l & 1 == 1 {
                assert_eq!(portable.1[l].to_bits(), wide.1[l].to_bits(), "case {k} lane {l}");
            }
        }
        entered += portable.0.count_ones();
    }
    assert!(entered > 1_000, "{entered}");
}

/// The packet frustum's reciprocal bounds are its rays' own extremes, and
/// its AVX box test gives the portable one's mask and entry distances bit
/// for bit: packets of one sign per axis and packets
/// straddling an axis (open: 0 x inf is NaN where the origin lies on a
/// plane), full and partial, short and infinite limits.
#[cfg(target_arch = "x86_64")]
#[test]
fn frustum_box_tests_agree() {
    use super::packet::Frustum;
    use crate::geom::simd::{Lanes, Scalar16};
    if !std::arch::is_x86_feature_detected!("avx2") {
        return;
    }
    #[target_feature(enable = "avx2")]
    fn avx(f: &Frustum, node: &Node8, latest: f32) -> (u32, [f32; WIDTH]) {
        // SAFETY: this function requires AVX2.
        unsafe { f.enters_avx(node, latest) }
    }
    let mut rng = Rng(43);
    let (mut entered, mut open) = (0, 0);
    for k in 0..20_000 {
        let node = random_node(&mut rng, k % WIDTH + 1);
        let mut o = rng.vec(-2.0, 2.0);
        if k % 4 == 0 {
            o.y = node.planes[4][0];
        }
        // A cone of directions around `mean`: narrow ones keep every axis's
        // sign, wide ones (or a mean near an axis plane) straddle it.
        let mean = rng.vec(-1.0, 1.0);
        let spread = [0.05, 0.5, 2.0][k % 3];
        let dirs: Vec<Vec3> = (0..1 + k % 16).map(|_| mean + rng.vec(-spread, spread)).collect();
        let latest = if k % 3 == 0 {
            rng.next_f32() * 3.0
        } else {
            f32::INFINITY
        };
        if dirs.iter().any(|d| d.cmpeq(Vec3::ZERO).any()) {
            continue;
        }
        let column = |a: usize| Scalar16::from_array(std::array::from_fn(|r| dirs[r.min(dirs.len() - 1)][a]));
        let f = Frustum::of_directions(o, &[column(0), column(1), column(2)]);
        // Each axis's bounds are the rays' own extreme reciprocals, or open.
        let (lo, hi) = f.reciprocals();
        for a in 0..3 {
            let inv = dirs.iter().map(|d| 1.0 / d[a]);
            let (min, max) = (
                inv.clone().fold(f32::INFINITY, f32::min),
                inv.fold(f32::NEG_INFINITY, f32::max),
            );
            if min > 0.0 || max < 0.0 {
                assert_eq!((lo[a], hi[a]), (min, max), "case {k} axis {a}");
            } else {
                assert_eq!((lo[a], hi[a]), (f32::NEG_INFINITY, f32::INFINITY), "case {k} axis {a}");
            }
        }
        let portable = f.enters_lanes(&node, latest);
        // SAFETY: the CPU has AVX2 (checked above).
        let wide = unsafe { avx(&f, &node, latest) };
        assert_eq!(portable.0, wide.0, "case {k}: masks");
        for l in 0..WIDTH {
            assert_eq!(portable.1[l].to_bits(), wide.1[l].to_bits(), "case {k} lane {l}");
        }
        entered += portable.0.count_ones();
        open += f.straddles() as u32;
    }
    assert!(
        entered > 1_000 && open > 1_000,
        "{entered} entered, {open} with an open axis"
    );
}

/// The BVH's any-hit packets answer as the single rays do, in every
/// instruction set: random soups, origins inside and out, rays with zero
/// direction components (taken ray by ray), short and infinite limits,
/// partly filled packets.
#[test]
fn packets_equal_single_rays() {
    use crate::geom::simd::Isa;
    let mut rng = Rng(0x0cc1_0de5);
    let tris = random_soup(&mut rng, 3000, 0.15);
    let accel = Accel::new(KdTree::from_triangles(tris, &KdTreeSettings::default()).unwrap());
    let mut counts = [0usize; 2];
    for k in 0..1500 {
        let origin = rng.vec(-1.5, 1.5);
        let n = 1 + k % 16;
        let dirs: Vec<Vec3> = (0..n)
            .map(|r| {
                let mut d = rng.vec(-1.0, 1.0);
                if k % 7 == 0 && r == 3 {
                    d.y = 0.0;
                }
                d
            })
            .collect();
        let t_max = if k % 3 == 0 { rng.next_f32() } else { f32::INFINITY };
        let expect = dirs.iter().enumerate().fold(0u16, |m, (r, &d)| {
            m | (accel.kdtree().any_hit(origin, d, t_max) as u16) << r
        });
        for isa in Isa::available() {
            let got = accel.occluded(Structure::Bvh, origin, &dirs, t_max, isa);
            assert_eq!(got, expect, "packet {k}, {isa:?}");
        }
        counts[0] += expect.count_ones() as usize;
        counts[1] += n - expect.count_ones() as usize;
    }
    assert!(counts[0] > 2000 && counts[1] > 2000, "{counts:?}");
}

/// The closest-hit packets give each lane its single ray's hit bit for bit
/// (t and triangle), in every instruction set: random soups with origins
/// inside and out, fans of rays aimed at vertices and edges (ties between
/// a triangle and its copy), zero direction components, short limits,
/// partly filled packets.
#[test]
fn closest_packets_equal_single_rays() {
    use crate::geom::simd::Isa;
    let mut rng = Rng(0xc105_e575);
    let mut tris = random_soup(&mut rng, 2000, 0.15);
    // Copies of the first 300 triangles: every hit on them is a tie.
    tris.extend_from_within(..300);
    let accel = Accel::new(KdTree::from_triangles(tris.clone(), &KdTreeSettings::default()).unwrap());
    let (mut hits, mut ties, mut rays) = (0usize, 0usize, 0usize);
    for k in 0..1500 {
        let origin = rng.vec(-1.5, 1.5);
        let n = 1 + k % 16;
        let dirs: Vec<Vec3> = (0..n)
            .map(|r| {
                let tri = tris[(k * 16 + r) % 300];
                let mut d = match r % 3 {
                    0 => tri[0] - origin,
                    1 => (tri[1] + tri[2]) * 0.5 - origin,
                    _ => rng.vec(-1.0, 1.0),
                };
                if k % 7 == 0 && r == 3 {
                    d.y = 0.0;
                }
                d
            })
            .collect();
        let t_max = if k % 3 == 0 {
            rng.next_f32() * 2.0
        } else {
            f32::INFINITY
        };
        let expect: Vec<_> = dirs
            .iter()
            .map(|&d| accel.closest_hit(Structure::Bvh, origin, d, t_max))
            .collect();
        for isa in Isa::available() {
            let got = packet::closest(accel.bvh(), accel.kdtree(), origin, &dirs, t_max, isa);
            assert_lanes_equal(&got, &expect, &format!("packet {k}, {isa:?}"));
            assert!(got[n..].iter().all(|h| !h.is_hit()), "unused lanes stay misses");
        }
        rays += n;
        for e in expect.iter().filter(|e| e.is_hit()) {
            hits += 1;
            ties += (e.triangle < 300) as usize;
        }
    }
    println!("{rays} rays, {hits} hits, {ties} on a triangle that has a copy");
    assert!(
        hits > 4000 && ties > 1000 && rays - hits > 2000,
        "{rays} rays, {hits} hits, {ties} ties"
    );
}

/// A camera's image through `packet::trace_image` equals single rays, and
/// blocks whose rays do not share an origin go ray by ray.
#[test]
fn packet_images_equal_single_rays() {
    use crate::geom::ray::Ray;
    use crate::geom::simd::Isa;
    let mut rng = Rng(41);
    let tris = random_soup(&mut rng, 1500, 0.2);
    let accel = Accel::new(KdTree::from_triangles(tris, &KdTreeSettings::default()).unwrap());
    let (w, h) = (37u32, 22u32);
    let eye = Vec3::new(0.3, -0.2, 4.0);
    let mut rays: Vec<Ray> = (0..w * h)
        .map(|i| {
            // Pixel centres off the axis: no zero direction component.
            let (x, y) = (((i % w) as f32 + 0.3) / w as f32, ((i / w) as f32 + 0.3) / h as f32);
            Ray::new(eye, Vec3::new(x - 0.5, y - 0.5, -1.5).normalize())
        })
        .collect();
    // One block with a second origin.
    rays[w as usize + 1] = Ray::new(Vec3::new(0.0, 0.0, -3.0), Vec3::Z);
    let expect: Vec<_> = rays
        .iter()
        .map(|r| accel.closest_hit(Structure::Bvh, r.o(), r.d(), f32::INFINITY))
        .collect();
    for isa in Isa::available() {
        let (got, counts) = packet::trace_image(accel.bvh(), accel.kdtree(), &rays, w, h, isa);
        assert_eq!(got, expect, "{isa:?}");
        assert_eq!(counts.single_rays, 16, "{isa:?}: one block ray by ray");
        assert_eq!(counts.packets, 10 * 6 - 1, "{isa:?}");
    }
    assert!(expect.iter().filter(|h| h.is_hit()).count() > 200);
}
