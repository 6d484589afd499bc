//! Line space (the bounded-error paper, section 4.1): every ray that meets
//! an object crosses two parallel faces of its expanded bounding box, so
//! it can be named by its four intercepts `(a, b, c, d)` with them. Six
//! face pairs cover all directions: the ray's dominant axis and its sign
//! pick one. A ray whose dominant component is along axis `k` moves at
//! most as far sideways as along `k`, so faces expanded sideways by the
//! box's depth along `k` catch every such ray that meets the box.
//!
//! Linetree cells split these coordinates by halves; a cell's corners lie
//! on an integer lattice of `2^LATTICE_BITS` steps per coordinate, which
//! names extremal rays exactly, so that siblings find the rays they share
//! (section 7, "unique interpolant rays").

use glam::{DVec3, Vec3};

use crate::bounded::affine::{AVec3, Aff};
use crate::geom::aabb::Aabb;

/// Lattice steps per root coordinate: `2^LATTICE_BITS`, so a cell may be
/// halved this many times along each coordinate.
pub const LATTICE_BITS: u32 = 20;

/// The two faces of an object's expanded box that rays along `axis` (in
/// the direction of its `positive` sign, or against it) cross.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FacePair {
    pub axis: usize,
    pub positive: bool,
    /// The entry and exit planes' coordinates along `axis`.
    pub front: f64,
    pub back: f64,
    /// The faces' common rectangle over the two other axes `(u, v)`.
    pub lo: [f64; 2],
    pub hi: [f64; 2],
}

/// A line's coordinates: `[a, b]` where it crosses the front face, `[c, d]`
/// the back face (each in the face pair's `(u, v)` axes).
pub type LineCoords = [f64; 4];

/// Which face pair a direction uses: `axis * 2 + positive`.
pub fn pair_index(d: Vec3) -> usize {
    let a = d.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    axis * 2 + (d[axis] > 0.0) as usize
}

impl FacePair {
    /// Face pair `index` (`pair_index`) of an object with bounds `b`.
    pub fn new(b: &Aabb, index: usize) -> FacePair {
        let (axis, positive) = (index / 2, index % 2 == 1);
        let (min, max) = (b.min.as_dvec3(), b.max.as_dvec3());
        let size = (max - min).max_element().max(f64::MIN_POSITIVE);
        // A margin keeps the object strictly between the faces; a flat
        // object's slab is thickened to its size, or the lines of a cell
        // would differ in direction by the cell's width over a thin slab.
        let pad = 1e-3 * size + 0.5 * (size - (max[axis] - min[axis]));
        let depth = max[axis] - min[axis] + 2.0 * pad;
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let (near, far) = (min[axis] - pad, max[axis] + pad);
        FacePair {
            axis,
            positive,
            front: if positive { near } else { far },
            back: if positive { far } else { near },
            lo: [min[u] - depth - pad, min[v] - depth - pad],
            hi: [max[u] + depth + pad, max[v] + depth + pad],
        }
    }

    /// The `(u, v)` axes.
    pub fn uv(&self) -> (usize, usize) {
        ((self.axis + 1) % 3, (self.axis + 2) % 3)
    }

    /// The coordinates of the line through `o` along `d` (`d`'s dominant
    /// axis must be this pair's), or `None` where it leaves the faces.
    pub fn coords(&self, o: DVec3, d: DVec3) -> Option<LineCoords> {
        let (u, v) = self.uv();
        let k = self.axis;
        if d[k] == 0.0 {
            return None;
        }
        let tf = (self.front - o[k]) / d[k];
        let tb = (self.back - o[k]) / d[k];
        let c = [o[u] + tf * d[u], o[v] + tf * d[v], o[u] + tb * d[u], o[v] + tb * d[v]];
        let inside = (0..4).all(|i| c[i] >= self.lo[i % 2] && c[i] <= self.hi[i % 2]);
        inside.then_some(c)
    }

    /// The point of the front (or back) face at `(u, v)`.
    pub fn point(&self, u_value: f64, v_value: f64, front: bool) -> DVec3 {
        let (u, v) = self.uv();
        let mut p = DVec3::ZERO;
        p[self.axis] = if front { self.front } else { self.back };
        p[u] = u_value;
        p[v] = v_value;
        p
    }

    /// The line's ray: from its front point towards its back point.
    pub fn ray(&self, c: LineCoords) -> (DVec3, DVec3) {
        let f = self.point(c[0], c[1], true);
        (f, self.point(c[2], c[3], false) - f)
    }

    /// Whether `p` lies before the front face (on the side rays come from).
    pub fn before_front(&self, p: DVec3) -> bool {
        if self.positive {
            p[self.axis] < self.front
        } else {
            p[self.axis] > self.front
        }
    }
}

/// A cell of a linetree: per coordinate, how often the root was halved
/// (`depth`) and which part (`index` < 2^depth).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CellBox {
    pub depth: [u8; 4],
    pub index: [u32; 4],
}

impl CellBox {
    pub const ROOT: CellBox = CellBox {
        depth: [0; 4],
        index: [0; 4],
    };

    /// The cell's range of coordinate `i` in a pair's units.
    pub fn range(&self, pair: &FacePair, i: usize) -> (f64, f64) {
        let (lo, hi) = (pair.lo[i % 2], pair.hi[i % 2]);
        let w = (hi - lo) / (1u64 << self.depth[i]) as f64;
        let a = lo + self.index[i] as f64 * w;
        (a, a + w)
    }

    /// Lattice coordinate of corner `bit` (0 low, 1 high) of coordinate `i`.
    pub fn lattice(&self, i: usize, bit: u32) -> u32 {
        (self.index[i] + bit) << (LATTICE_BITS - self.depth[i] as u32)
    }

    /// Corner `k` (bit i of k: the high end of coordinate i) as lattice
    /// coordinates.
    pub fn corner_lattice(&self, k: usize) -> [u32; 4] {
        [0, 1, 2, 3].map(|i| self.lattice(i, (k >> i) as u32 & 1))
    }

    /// Corner `k`'s line coordinates.
    pub fn corner(&self, pair: &FacePair, k: usize) -> LineCoords {
        [0, 1, 2, 3].map(|i| {
            let (lo, hi) = self.range(pair, i);
            if (k >> i) & 1 == 1 { hi } else { lo }
        })
    }

    /// Whether `c` lies in the cell (closed).
    pub fn contains(&self, pair: &FacePair, c: &LineCoords) -> bool {
        (0..4).all(|i| {
            let (lo, hi) = self.range(pair, i);
            c[i] >= lo && c[i] <= hi
        })
    }

    /// Whether coordinate `i` can still be halved.
    pub fn splittable(&self, i: usize) -> bool {
        (self.depth[i] as u32) < LATTICE_BITS
    }

    /// The child of this cell that contains `c`, halving the coordinates in
    /// `axes` (a bit per coordinate).
    pub fn child_containing(&self, pair: &FacePair, axes: u8, c: &LineCoords) -> CellBox {
        let mut child = *self;
        for i in (0..4).filter(|i| axes >> i & 1 == 1) {
            let (lo, hi) = self.range(pair, i);
            let upper = c[i] >= 0.5 * (lo + hi);
            child.depth[i] += 1;
            child.index[i] = self.index[i] * 2 + upper as u32;
        }
        child
    }

    /// Coordinates in `[0, 1]^4` of `c` within the cell (for interpolation).
    pub fn local(&self, pair: &FacePair, c: &LineCoords) -> [f32; 4] {
        [0, 1, 2, 3].map(|i| {
            let (lo, hi) = self.range(pair, i);
            (((c[i] - lo) / (hi - lo)).clamp(0.0, 1.0)) as f32
        })
    }

    /// The cell's lines as affine forms: origin on the front face, towards
    /// the back face (unnormalised), in the four cell coordinates.
    pub fn family(&self, pair: &FacePair) -> (AVec3, AVec3) {
        let coord = |i: usize| {
            let (lo, hi) = self.range(pair, i);
            Aff::coordinate(i, 0.5 * (lo + hi), 0.5 * (hi - lo))
        };
        let (u, v) = pair.uv();
        let mut origin = [Aff::ZERO; 3];
        let mut back = [Aff::ZERO; 3];
        origin[pair.axis] = Aff::constant(pair.front);
        back[pair.axis] = Aff::constant(pair.back);
        origin[u] = coord(0);
        origin[v] = coord(1);
        back[u] = coord(2);
        back[v] = coord(3);
        let o = AVec3::new(origin[0], origin[1], origin[2]);
        let b = AVec3::new(back[0], back[1], back[2]);
        (o, b.sub(o))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box() -> Aabb {
        Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0))
    }

    #[test]
    fn every_ray_that_meets_the_box_has_coordinates_in_its_pair() {
        let b = unit_box();
        let mut seed = 7u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1 << 24) as f32 * 2.0 - 1.0
        };
        for _ in 0..2000 {
            let target = Vec3::new(rnd(), rnd(), rnd()) * 0.99;
            let d = Vec3::new(rnd(), rnd(), rnd()).normalize();
            let o = target - 5.0 * d;
            let pair = FacePair::new(&b, pair_index(d));
            let c = pair.coords(o.as_dvec3(), d.as_dvec3()).expect("inside the faces");
            // The line of the coordinates is the same line.
            let (f, dir) = pair.ray(c);
            let off = (f - o.as_dvec3()).cross(d.as_dvec3()).length();
            assert!(off < 1e-5, "{off}");
            assert!(dir.normalize().dot(d.as_dvec3()) > 0.99999);
            assert!(pair.before_front(o.as_dvec3()));
        }
    }

    #[test]
    fn cells_nest_and_corners_share_lattice_points() {
        let pair = FacePair::new(&unit_box(), 5);
        let c = [0.3, -0.2, 0.1, 0.25];
        let mut cell = CellBox::ROOT;
        for _ in 0..5 {
            assert!(cell.contains(&pair, &c));
            cell = cell.child_containing(&pair, 0b1111, &c);
        }
        assert!(cell.contains(&pair, &c));
        // Siblings across coordinate 0 share the corners of their common
        // face: 8 lattice points.
        let parent = CellBox::ROOT.child_containing(&pair, 0b1111, &c);
        let kids: Vec<CellBox> = (0..2)
            .map(|i| CellBox {
                depth: parent.depth.map(|d| d + 1),
                index: [
                    parent.index[0] * 2 + i,
                    parent.index[1] * 2,
                    parent.index[2] * 2,
                    parent.index[3] * 2,
                ],
            })
            .collect();
        let corners = |k: &CellBox| {
            (0..16)
                .map(|i| k.corner_lattice(i))
                .collect::<std::collections::HashSet<_>>()
        };
        assert_eq!(corners(&kids[0]).intersection(&corners(&kids[1])).count(), 8);
        // A 16-way split has 81 lattice points, 16 of them the parent's.
        let mut all = std::collections::HashSet::new();
        for k in 0..16u32 {
            let child = CellBox {
                depth: parent.depth.map(|d| d + 1),
                index: [0, 1, 2, 3].map(|i| parent.index[i] * 2 + (k >> i & 1)),
            };
            all.extend(corners(&child));
        }
        assert_eq!(all.len(), 81);
        assert_eq!(all.intersection(&corners(&parent)).count(), 16);
    }

    #[test]
    fn the_family_encloses_the_corner_rays() {
        let pair = FacePair::new(&unit_box(), 2);
        let cell = CellBox {
            depth: [2; 4],
            index: [1, 2, 1, 3],
        };
        let (o, d) = cell.family(&pair);
        for k in 0..16 {
            let (f, dir) = pair.ray(cell.corner(&pair, k));
            for (form, value) in o.axes().iter().zip(f.to_array()) {
                assert!(value >= form.lo() - 1e-12 && value <= form.hi() + 1e-12);
            }
            for (form, value) in d.axes().iter().zip(dir.to_array()) {
                assert!(value >= form.lo() - 1e-12 && value <= form.hi() + 1e-12);
            }
        }
    }
}
