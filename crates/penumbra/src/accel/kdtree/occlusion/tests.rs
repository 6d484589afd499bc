//! The packets against single rays, lane by lane, in every instruction set.

use glam::Vec3;

use super::*;
use crate::accel::kdtree::KdTreeSettings;

struct Rng(u32);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = crate::geom::sampling::hash_u32(self.0);
        (self.0 >> 8) as f32 / (1u32 << 24) as f32
    }
    fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * (hi - lo) + Vec3::splat(lo)
    }
}

/// A random soup, a grid of axis-aligned unit squares (split planes through
/// vertices, coplanar cells) and a box around both.
fn scene(rng: &mut Rng) -> Vec<[Vec3; 3]> {
    let mut tris: Vec<[Vec3; 3]> = (0..400)
        .map(|_| {
            let c = rng.vec(-1.0, 1.0);
            [c + rng.vec(-0.2, 0.2), c + rng.vec(-0.2, 0.2), c + rng.vec(-0.2, 0.2)]
        })
        .collect();
    for i in -2..2 {
        for j in -2..2 {
            let (x, z) = (i as f32 * 0.5, j as f32 * 0.5);
            let p = |a: f32, b: f32| Vec3::new(x + a, -0.5, z + b);
            tris.push([p(0.0, 0.0), p(0.5, 0.0), p(0.5, 0.5)]);
            tris.push([p(0.0, 0.0), p(0.5, 0.5), p(0.0, 0.5)]);
        }
    }
    tris
}

/// Directions: every other packet random (the lanes' own set-up), the
/// others mixing in axis-parallel ones and zero components (set up lane by
/// lane).
fn directions(rng: &mut Rng, k: usize) -> Vec<Vec3> {
    (0..16)
        .map(|r| match if k.is_multiple_of(2) { 3 } else { (k + r) % 9 } {
            0 => Vec3::X * if r % 2 == 0 { 1.0 } else { -1.0 },
            1 => Vec3::new(0.0, rng.next() - 0.5, rng.next() - 0.5),
            2 => Vec3::new(rng.next() - 0.5, 0.0, 0.0),
            _ => rng.vec(-1.0, 1.0),
        })
        .collect()
}

#[test]
fn packets_equal_single_rays_in_every_instruction_set() {
    let mut rng = Rng(7);
    let tree = KdTree::from_triangles(scene(&mut rng), &KdTreeSettings::default()).unwrap();
    let (mut rays, mut hit) = (0, 0);
    for k in 0..2000 {
        // Origins anywhere, on the grid's plane and at its vertices (on
        // split planes), and outside the box.
        let origin = match (k / 2) % 4 {
            0 => rng.vec(-1.2, 1.2),
            1 => Vec3::new(rng.next() - 0.5, -0.5, rng.next() - 0.5),
            2 => Vec3::new(0.5 * (k % 3) as f32 - 0.5, -0.5, 0.0),
            _ => rng.vec(-3.0, 3.0),
        };
        let dirs = directions(&mut rng, k);
        let t_max = [f32::INFINITY, 0.3, 1.0][k % 3];
        let n = 1 + k % 16;
        let expect = dirs[..n]
            .iter()
            .enumerate()
            .fold(0u16, |m, (r, &d)| m | ((tree.any_hit(origin, d, t_max) as u16) << r));
        for isa in Isa::available() {
            assert_eq!(
                occluded(&tree, origin, &dirs[..n], t_max, isa),
                expect,
                "{isa:?} packet {k} from {origin}"
            );
        }
        rays += n;
        hit += expect.count_ones();
    }
    assert!(
        hit > rays as u32 / 5 && hit < rays as u32 * 4 / 5,
        "{hit} of {rays} hit"
    );
}
