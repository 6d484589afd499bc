//! Positional samples on the bounding sphere: the centres of an N x N grid
//! over the square, mapped to the sphere by the equal-area octahedral map
//! (Clarberg, "Fast Equal-Area Mapping of the (Hemi)Sphere using SIMD",
//! JGT 13(3), 2008; the formulation of pbrt-v4's `EqualAreaSquareToSphere`).
//!
//! The paper (section 3.3) uses Slater's triangle subdivision, which needs
//! "a quick inverse function that can convert an intersection point into the
//! nearest sample" and "distribute[s] the samples ... as evenly as
//! possible". The octahedral grid has both: the inverse is closed-form
//! (constant time), every cell has exactly the same area (the map preserves
//! area, so the largest-to-smallest cell-area ratio is 1; `cell_area_ratio`
//! measures it), and the grid is regular in the square, so the four samples
//! around any point — for interpolation between positional samples — are a
//! bilinear stencil. N = 65 gives 4225 samples, the paper's 4226 less one.
//!
//! The square's border folds onto itself: the point (-1, v) is the point
//! (-1, -v), and likewise on the other three edges, so the neighbour of a
//! border cell across the edge is the mirrored cell on the same side
//! (`wrap`).

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};

use glam::Vec3;

use crate::geom::float::floor;

use crate::geom::sampling::atan::atan_unit;

/// The positional samples: `side * side` points on the unit sphere.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OctahedralGrid {
    /// Side N of the grid: N x N samples, sample k = i + j N at grid cell
    /// (i, j).
    pub side: u32,
}

/// Unit vector of the square point `(u, v)` in [-1, 1]^2.
pub fn square_to_sphere(u: f32, v: f32) -> Vec3 {
    let (up, vp) = (u.abs(), v.abs());
    // Signed distance from the diagonal |u| + |v| = 1 (the equator).
    let signed = 1.0 - (up + vp);
    let r = 1.0 - signed.abs();
    let phi = if r == 0.0 { 1.0 } else { (vp - up) / r + 1.0 } * FRAC_PI_4;
    let z = (1.0 - r * r).copysign(signed);
    let (sin_phi, cos_phi) = phi.sin_cos();
    let ring = r * (2.0 - r * r).max(0.0).sqrt();
    Vec3::new(cos_phi.copysign(u) * ring, sin_phi.copysign(v) * ring, z)
}

/// The square point in [-1, 1]^2 of unit vector `d`: the inverse of
/// `square_to_sphere`. Branches as selects (one ratio, one arctangent), so
/// that `field::batch` vectorises it.
#[inline(always)]
pub fn sphere_to_square(d: Vec3) -> [f32; 2] {
    let (x, y) = (d.x.abs(), d.y.abs());
    let r = (1.0 - d.z.abs()).max(0.0).sqrt();
    // phi / (pi/2) in [0, 1], measured from the x axis; the angle from the
    // nearer axis keeps the ratio in [0, 1] for `atan_unit`.
    let x_major = x >= y;
    let angle = atan_unit(if x_major { y / x } else { x / y }) / FRAC_PI_2;
    let phi = if x == 0.0 && y == 0.0 {
        0.0
    } else if x_major {
        angle
    } else {
        1.0 - angle
    };
    let v = phi * r;
    let u = r - v;
    let below = d.z < 0.0;
    let (u, v) = (if below { 1.0 - v } else { u }, if below { 1.0 - u } else { v });
    [u.copysign(d.x), v.copysign(d.y)]
}

impl OctahedralGrid {
    /// The grid whose sample count is nearest `positions` (at least 1).
    pub fn with_count(positions: u32) -> OctahedralGrid {
        let side = (positions as f64).sqrt().round().max(1.0) as u32;
        OctahedralGrid { side }
    }

    /// Samples: `side` squared.
    pub fn count(&self) -> u32 {
        self.side * self.side
    }

    /// Unit vector of sample `k` (row-major: k = i + j * side).
    pub fn position(&self, k: u32) -> Vec3 {
        let (i, j) = (k % self.side, k / self.side);
        let n = self.side as f32;
        square_to_sphere((2.0 * i as f32 + 1.0) / n - 1.0, (2.0 * j as f32 + 1.0) / n - 1.0)
    }

    /// Continuous grid coordinates of a unit vector: sample (i, j)'s centre is
    /// at (i, j), the square's edges at -0.5 and side - 0.5.
    #[inline(always)]
    pub fn grid_coordinates(&self, d: Vec3) -> [f32; 2] {
        let [u, v] = sphere_to_square(d);
        let n = self.side as f32;
        [(u + 1.0) * 0.5 * n - 0.5, (v + 1.0) * 0.5 * n - 0.5]
    }

    /// The sample nearest `d` in the grid (the cell containing it).
    #[inline(always)]
    pub fn nearest(&self, d: Vec3) -> u32 {
        let [gx, gy] = self.grid_coordinates(d);
        let last = self.side as i32 - 1;
        // floor(x + 0.5), not round(): WGSL's round() goes to even at .5.
        let i = (floor(gx + 0.5) as i32).clamp(0, last) as u32;
        let j = (floor(gy + 0.5) as i32).clamp(0, last) as u32;
        i + j * self.side
    }

    /// The cell at grid index (i, j), which may lie one step outside the
    /// square: folded back across the edge it crossed.
    #[inline(always)]
    pub fn wrap(&self, i: i32, j: i32) -> u32 {
        let n = self.side as i32;
        let (i, j) = if i < 0 {
            (-i - 1, n - 1 - j)
        } else if i >= n {
            (2 * n - 1 - i, n - 1 - j)
        } else {
            (i, j)
        };
        let (i, j) = if j < 0 {
            (n - 1 - i, -j - 1)
        } else if j >= n {
            (n - 1 - i, 2 * n - 1 - j)
        } else {
            (i, j)
        };
        (i.clamp(0, n - 1) + j.clamp(0, n - 1) * n) as u32
    }

    /// The four samples around `d` and their bilinear weights (summing to 1).
    #[inline(always)]
    pub fn bilinear(&self, d: Vec3) -> [(u32, f32); 4] {
        let [gx, gy] = self.grid_coordinates(d);
        let (x0, y0) = (floor(gx), floor(gy));
        let (fx, fy) = (gx - x0, gy - y0);
        let (i, j) = (x0 as i32, y0 as i32);
        [
            (self.wrap(i, j), (1.0 - fx) * (1.0 - fy)),
            (self.wrap(i + 1, j), fx * (1.0 - fy)),
            (self.wrap(i, j + 1), (1.0 - fx) * fy),
            (self.wrap(i + 1, j + 1), fx * fy),
        ]
    }

    /// Largest over smallest cell area on the sphere, each cell's area summed
    /// over `sub x sub` spherical quads between mapped points (exact in the
    /// limit; the map is area-preserving, so the ratio tends to 1).
    pub fn cell_area_ratio(&self, sub: u32) -> f64 {
        let n = self.side as f64;
        let point = |gx: f64, gy: f64| {
            let to_square = |g: f64| ((g + 0.5) / n * 2.0 - 1.0) as f32;
            square_to_sphere(to_square(gx), to_square(gy)).as_dvec3()
        };
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for k in 0..self.count() {
            let (i, j) = ((k % self.side) as f64, (k / self.side) as f64);
            let mut area = 0.0;
            for a in 0..sub {
                for b in 0..sub {
                    let s = |t: u32| t as f64 / sub as f64 - 0.5;
                    let p = [
                        point(i + s(a), j + s(b)),
                        point(i + s(a + 1), j + s(b)),
                        point(i + s(a + 1), j + s(b + 1)),
                        point(i + s(a), j + s(b + 1)),
                    ];
                    area += spherical_triangle_area(p[0], p[1], p[2]) + spherical_triangle_area(p[0], p[2], p[3]);
                }
            }
            lo = lo.min(area);
            hi = hi.max(area);
        }
        hi / lo
    }
}

/// Solid angle of the spherical triangle of three unit vectors (Van
/// Oosterom and Strackee).
fn spherical_triangle_area(a: glam::DVec3, b: glam::DVec3, c: glam::DVec3) -> f64 {
    let num = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * num.atan2(den)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_unit_length() {
        let mut worst = 0.0f32;
        for i in 0..=40 {
            for j in 0..=40 {
                let (u, v) = (i as f32 / 20.0 - 1.0, j as f32 / 20.0 - 1.0);
                let d = square_to_sphere(u, v);
                assert!((d.length() - 1.0).abs() < 1e-5, "({u}, {v}) -> {d}");
                let back = square_to_sphere(sphere_to_square(d)[0], sphere_to_square(d)[1]);
                worst = worst.max((back - d).length());
            }
        }
        assert!(worst < 1e-5, "worst round trip on the sphere {worst}");
    }

    #[test]
    fn poles_and_equator() {
        assert!(square_to_sphere(0.0, 0.0).abs_diff_eq(Vec3::Z, 1e-6));
        assert!(square_to_sphere(1.0, 1.0).abs_diff_eq(Vec3::NEG_Z, 1e-6));
        assert!(square_to_sphere(-1.0, -1.0).abs_diff_eq(Vec3::NEG_Z, 1e-6));
        assert!(square_to_sphere(1.0, 0.0).abs_diff_eq(Vec3::X, 1e-6));
        assert!(square_to_sphere(0.0, -1.0).abs_diff_eq(Vec3::NEG_Y, 1e-6));
    }

    #[test]
    fn every_direction_finds_its_own_cell() {
        let g = OctahedralGrid { side: 17 };
        for k in 0..g.count() {
            assert_eq!(g.nearest(g.position(k)), k);
            let w = g.bilinear(g.position(k));
            let own: f32 = w.iter().filter(|(i, _)| *i == k).map(|(_, w)| w).sum();
            assert!((own - 1.0).abs() < 1e-4, "sample {k}: weights {w:?}");
        }
    }

    #[test]
    fn folded_neighbours_are_neighbours_on_the_sphere() {
        let g = OctahedralGrid { side: 16 };
        let spacing = (4.0 * std::f32::consts::PI / g.count() as f32).sqrt();
        let n = g.side as i32;
        for t in 0..n {
            for (i, j, di, dj) in [(0, t, -1, 0), (n - 1, t, 1, 0), (t, 0, 0, -1), (t, n - 1, 0, 1)] {
                let here = g.position(g.wrap(i, j));
                let across = g.position(g.wrap(i + di, j + dj));
                let d = (here - across).length();
                assert!(
                    d < 2.5 * spacing,
                    "({i},{j}) and its neighbour across the edge are {d} apart"
                );
            }
        }
    }

    #[test]
    fn cells_have_equal_areas() {
        let g = OctahedralGrid { side: 9 };
        let ratio = g.cell_area_ratio(8);
        assert!(ratio < 1.01, "largest / smallest cell area {ratio}");
    }

    #[test]
    fn count_nearest_to_the_request() {
        assert_eq!(OctahedralGrid::with_count(4226).count(), 4225);
        assert_eq!(OctahedralGrid::with_count(1).count(), 1);
        assert_eq!(OctahedralGrid::with_count(0).count(), 1);
    }
}
