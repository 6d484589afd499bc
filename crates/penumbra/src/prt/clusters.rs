//! Clusters of the two-level hierarchy: each fine triangle belongs to the
//! coarse triangle nearest to it, found through a uniform grid of the coarse
//! triangles (a brute-force search is fine x coarse, eight seconds for the
//! 69K-triangle bunny).

use std::collections::HashMap;

use glam::{IVec3, Vec3};
use rayon::prelude::*;

use super::geometry::point_triangle_distance_sq;

/// Coarse triangles binned by the grid cells their bounding boxes overlap.
struct TriangleGrid<'a> {
    tris: &'a [[Vec3; 3]],
    origin: Vec3,
    cell: f32,
    cells: HashMap<IVec3, Vec<u32>>,
    /// Cell coordinates' bounds over all triangles.
    lo: IVec3,
    hi: IVec3,
}

impl<'a> TriangleGrid<'a> {
    fn new(tris: &'a [[Vec3; 3]]) -> TriangleGrid<'a> {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let mut area = 0.0f32;
        for t in tris {
            for p in t {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
            area += 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
        }
        // Cells about a triangle across: each holds a few triangles.
        let typical = (area / tris.len().max(1) as f32).sqrt();
        let cell = typical.max((hi - lo).max_element() / 256.0).max(f32::MIN_POSITIVE);
        let mut grid = TriangleGrid {
            tris,
            origin: lo,
            cell,
            cells: HashMap::new(),
            lo: IVec3::MAX,
            hi: IVec3::MIN,
        };
        for (i, t) in tris.iter().enumerate() {
            let a = grid.coord(t[0].min(t[1]).min(t[2]));
            let b = grid.coord(t[0].max(t[1]).max(t[2]));
            grid.lo = grid.lo.min(a);
            grid.hi = grid.hi.max(b);
            for z in a.z..=b.z {
                for y in a.y..=b.y {
                    for x in a.x..=b.x {
                        grid.cells.entry(IVec3::new(x, y, z)).or_default().push(i as u32);
                    }
                }
            }
        }
        grid
    }

    fn coord(&self, p: Vec3) -> IVec3 {
        ((p - self.origin) / self.cell).floor().as_ivec3()
    }

    /// The nearest triangle to `x` that `accept` takes: (squared distance,
    /// index), searching shells of cells outwards until no unvisited cell
    /// can hold a nearer one.
    fn nearest(&self, x: Vec3, accept: impl Fn(u32) -> bool) -> Option<(f32, u32)> {
        let c = self.coord(x);
        let mut best: Option<(f32, u32)> = None;
        // Shells beyond this cover every occupied cell.
        let reach = (self.lo - c).abs().max((self.hi - c).abs()).max_element();
        for k in 0..=reach {
            for z in c.z - k..=c.z + k {
                for y in c.y - k..=c.y + k {
                    let shell = z == c.z - k || z == c.z + k || y == c.y - k || y == c.y + k;
                    let xs: &mut dyn Iterator<Item = i32> = if shell {
                        &mut (c.x - k..=c.x + k)
                    } else {
                        &mut [c.x - k, c.x + k].into_iter()
                    };
                    for x_ in xs {
                        let Some(list) = self.cells.get(&IVec3::new(x_, y, z)) else {
                            continue;
                        };
                        for &i in list {
                            if !accept(i) {
                                continue;
                            }
                            let d = point_triangle_distance_sq(x, &self.tris[i as usize]);
                            if best.is_none_or(|(b, j)| d < b || (d == b && i < j)) {
                                best = Some((d, i));
                            }
                        }
                    }
                }
            }
            // Cells outside shell k are at least k cells from x's cell.
            let cleared = k as f32 * self.cell;
            if best.is_some_and(|(b, _)| b <= cleared * cleared) {
                break;
            }
        }
        best
    }
}

/// Each fine triangle's cluster: the coarse triangle nearest to its centroid
/// (point-triangle distance) among those whose normal is within 90 degrees
/// of its own, or the nearest of all when none is.
pub fn assign_clusters(rest: &[Vec3], fine: &[[u32; 3]], coarse: &[[u32; 3]]) -> Vec<u32> {
    let tri = |t: &[u32; 3]| t.map(|i| rest[i as usize]);
    let normal = |p: &[Vec3; 3]| (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
    let coarse_pts: Vec<[Vec3; 3]> = coarse.iter().map(tri).collect();
    let coarse_n: Vec<Vec3> = coarse_pts.iter().map(normal).collect();
    let grid = TriangleGrid::new(&coarse_pts);
    fine.par_iter()
        .with_min_len(64)
        .map(|t| {
            let p = tri(t);
            let c = (p[0] + p[1] + p[2]) / 3.0;
            let n = normal(&p);
            grid.nearest(c, |i| n.dot(coarse_n[i as usize]) > 0.0)
                .or_else(|| grid.nearest(c, |_| true))
                .map_or(0, |(_, i)| i)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The grid finds what a brute-force search finds.
    #[test]
    fn grid_search_matches_brute_force() {
        let mut s = 12345u32;
        let mut rnd = || {
            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (s >> 8) as f32 / (1 << 24) as f32
        };
        let pts: Vec<Vec3> = (0..300).map(|_| Vec3::new(rnd(), rnd() * 0.5, rnd() * 2.0)).collect();
        let coarse: Vec<[u32; 3]> = (0..60).map(|i| [i * 3, i * 3 + 1, i * 3 + 2]).collect();
        let fine: Vec<[u32; 3]> = (0..100).map(|i| [i, (i + 100) % 300, (i + 200) % 300]).collect();
        let got = assign_clusters(&pts, &fine, &coarse);
        let tri = |t: &[u32; 3]| t.map(|i| pts[i as usize]);
        let normal = |p: &[Vec3; 3]| (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        for (f, g) in fine.iter().zip(&got) {
            let p = tri(f);
            let c = (p[0] + p[1] + p[2]) / 3.0;
            let n = normal(&p);
            let dist = |i: usize| point_triangle_distance_sq(c, &tri(&coarse[i]));
            let ok: Vec<usize> = (0..coarse.len())
                .filter(|&i| n.dot(normal(&tri(&coarse[i]))) > 0.0)
                .collect();
            let pool = if ok.is_empty() { (0..coarse.len()).collect() } else { ok };
            let best = pool.iter().map(|&i| dist(i)).fold(f32::INFINITY, f32::min);
            assert_eq!(dist(*g as usize), best);
        }
    }
}
