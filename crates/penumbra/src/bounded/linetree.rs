//! Linetrees (the bounded-error paper, sections 4.2, 4.3 and 7): per
//! surface (a flat face, a sphere, a smooth patch of a mesh, a smooth
//! mirror or glass triangle) and face pair a 4D tree over line space, built lazily: a cell is
//! built (its 16 extremal rays traced and judged) only when a pixel's ray
//! falls in it, and split (16 ways, or 4 along the coordinates the bound
//! blames) only when it fails and covers enough pixels. Extremal rays are
//! kept in a table keyed by their lattice coordinates, so siblings trace
//! the rays they share once; cells and samples count their bytes, and the
//! least recently used leaves are evicted under a memory cap (an evicted
//! leaf is simply unbuilt again, so the guarantee does not depend on it).

// foldhash: lattice keys have long runs of zero low bits, which FxHash
// buckets badly and SipHash hashes slowly; a fixed seed keeps runs repeatable.
pub(crate) type HashMap<K, V> = std::collections::HashMap<K, V, foldhash::fast::FixedState>;
pub(crate) type HashSet<K> = std::collections::HashSet<K, foldhash::fast::FixedState>;

use glam::{DVec3, Vec3};

use crate::bounded::linespace::{CellBox, FacePair, LATTICE_BITS, LineCoords};
use crate::bounded::predicate::{Accepted, Failure, RootFace};
use crate::whitted::ray_tree::{RayNode, RayTree};

/// An extremal ray's radiance and ray tree.
#[derive(Debug, Clone)]
pub struct Sample {
    /// The Whitted radiance leaving the linetree's surface along the ray.
    pub radiance: Vec3,
    /// Its first hit's ambient and diffuse terms before the texture
    /// (`RayOut::diffuse`).
    pub diffuse: Vec3,
    /// Its ray tree: the surfaces, lights and occluders its radiance
    /// depends on (section 5.1), which the predicate compares and culls.
    pub tree: RayTree,
    refs: u32,
    key: u128,
}

impl Sample {
    /// A traced sample, held by no cell yet.
    pub fn new(radiance: Vec3, diffuse: Vec3, tree: RayTree) -> Sample {
        Sample {
            radiance,
            diffuse,
            tree,
            refs: 0,
            key: 0,
        }
    }

    fn bytes(&self) -> usize {
        std::mem::size_of::<Sample>()
            + self
                .tree
                .nodes
                .iter()
                .map(|n| {
                    // The lists' heap blocks where they outgrew their inline room.
                    let heap = |spilled: bool, bytes: usize| if spilled { bytes } else { 0 };
                    std::mem::size_of::<RayNode>()
                        + heap(n.lights.spilled(), n.lights.capacity())
                        + heap(n.occluders.spilled(), 4 * n.occluders.capacity())
                })
                .sum::<usize>()
    }
}

/// An accepted cell: its corners' radiance and what the predicate proved.
/// On a textured surface (`diffuse` given) the radiance of a line is
/// `radiance + T diffuse`, both interpolated, with `T` the texture at the
/// line's exact hit (the paper's section 7, "Textures": the texture is
/// looked up, not interpolated).
#[derive(Debug, Clone)]
pub struct Interpolant {
    /// Radiance, or on a textured surface what its texture does not scale.
    pub radiance: [Vec3; 16],
    /// The ambient and diffuse terms the texture scales, where it has one.
    pub diffuse: Option<Box<[Vec3; 16]>>,
    /// What the predicate proved of the cell: its bound, surface and hits.
    pub accepted: Accepted,
}

impl Interpolant {
    /// The radiance at `local` in the cell, where the line's hit has the
    /// texture factor `texture` (1 where there is none).
    pub fn at(&self, local: [f32; 4], texture: Vec3) -> Vec3 {
        use crate::bounded::interpolate::{weighted, weights};
        let w = weights(local);
        let base = weighted(self.radiance.iter().copied(), &w);
        match &self.diffuse {
            Some(d) => base + texture * weighted(d.iter().copied(), &w),
            None => base,
        }
    }

    /// Bytes it holds, for the memory cap.
    fn bytes(&self) -> usize {
        std::mem::size_of::<Interpolant>()
            + self.diffuse.as_ref().map_or(0, |_| std::mem::size_of::<[Vec3; 16]>())
            + std::mem::size_of_val(&*self.accepted.pieces)
            + self
                .accepted
                .hit_points
                .as_ref()
                .map_or(0, |q| std::mem::size_of_val(&**q))
    }
}

/// Where a linetree cell stands.
#[derive(Debug, Clone)]
pub enum CellState {
    /// A leaf no pixel has built yet, or one evicted under the memory cap.
    Unbuilt,
    /// A leaf the predicate accepted: its interpolant.
    Valid(Box<Interpolant>),
    /// Rejected; `pixels` asked for it when it was (the cost model splits
    /// it when more do), `split` the 4-way split's coordinates.
    Failed {
        /// The sub-test that rejected it.
        failure: Failure,
        /// The coordinates a 4-way split halves: `0b0101` (a, c) or
        /// `0b1010` (b, d).
        split: u8,
        /// The most pixels one frame asked of it.
        pixels: u32,
    },
    /// Its children are `first ..first + 2^popcount(axes)`.
    Split {
        /// The coordinates halved, bit i for coordinate i of (a, b, c, d):
        /// `0b1111` for 16 children.
        axes: u8,
        /// Its first child's index in `Linetrees::cells`.
        first: u32,
    },
}

/// A cell of a linetree: a 4D box of lines (section 4.2) and what is
/// known of it.
#[derive(Debug, Clone)]
pub struct Cell {
    /// Its linetree's index in `Linetrees::trees`.
    pub tree: u32,
    /// Its box in line space: how often and where the root was halved.
    pub cell: CellBox,
    /// Unbuilt, accepted, rejected or split.
    pub state: CellState,
    /// The last frame a pixel used it.
    pub used: u32,
    /// The samples it holds (built cells).
    samples: Option<[u32; 16]>,
}

/// One surface's linetree over one face pair. (Per surface, not per
/// object: a flat face's own box keeps its cells' rays on it, where an
/// object's box would mix the faces of a checkerboard.)
#[derive(Debug, Clone)]
pub struct Linetree {
    /// The surface whose outgoing radiance it interpolates.
    pub surface: RootFace,
    /// The face pair that names its lines (section 4.1): two faces of the
    /// surface's expanded box, across its lines' dominant axis and sign.
    pub pair: FacePair,
    /// Its root cell's index in `Linetrees::cells`.
    pub root: u32,
}

/// Every linetree of a scene, their cells and the extremal rays' samples.
#[derive(Default)]
pub struct Linetrees {
    index: HashMap<(RootFace, u8), u32>,
    /// The linetrees, in the order they were made.
    pub trees: Vec<Linetree>,
    /// The cells of every tree; a split appends its children, and cells
    /// are never removed (an evicted leaf is `Unbuilt` again).
    pub cells: Vec<Cell>,
    sample_index: HashMap<u128, u32>,
    samples: Vec<Option<Sample>>,
    free: Vec<u32>,
    bytes: usize,
    /// The most bytes cells and samples have taken at once.
    pub peak_bytes: usize,
}

/// The key of an extremal ray: its tree and lattice coordinates.
pub fn sample_key(tree: u32, lattice: [u32; 4]) -> u128 {
    let mut k = tree as u128;
    for c in lattice {
        k = (k << 24) | c as u128;
    }
    k
}

impl Linetrees {
    /// The tree of `surface` over `pair` (`pair_index`), made on first use.
    pub fn tree(&mut self, surface: RootFace, pair_index: usize, make: impl FnOnce() -> FacePair) -> u32 {
        if let Some(&t) = self.index.get(&(surface, pair_index as u8)) {
            return t;
        }
        let root = self.push_cell(self.trees.len() as u32, CellBox::ROOT);
        self.trees.push(Linetree {
            surface,
            pair: make(),
            root,
        });
        let t = self.trees.len() as u32 - 1;
        self.index.insert((surface, pair_index as u8), t);
        t
    }

    /// The tree of `surface` over pair `pair_index`, if made.
    pub fn find(&self, surface: RootFace, pair_index: usize) -> Option<u32> {
        self.index.get(&(surface, pair_index as u8)).copied()
    }

    fn push_cell(&mut self, tree: u32, cell: CellBox) -> u32 {
        self.cells.push(Cell {
            tree,
            cell,
            state: CellState::Unbuilt,
            used: 0,
            samples: None,
        });
        self.account(std::mem::size_of::<Cell>() as isize);
        self.cells.len() as u32 - 1
    }

    fn account(&mut self, delta: isize) {
        self.bytes = (self.bytes as isize + delta).max(0) as usize;
        self.peak_bytes = self.peak_bytes.max(self.bytes);
    }

    /// Bytes of cells and samples now.
    pub fn bytes(&self) -> usize {
        self.bytes
    }

    /// The leaf of tree `t` whose cell contains `c`.
    pub fn leaf(&self, t: u32, c: &LineCoords) -> u32 {
        self.leaf_below(self.trees[t as usize].root, c)
    }

    /// The leaf under cell `i` (which contains `c`) that contains `c`.
    /// The line is put on the lattice once, so each level of the descent
    /// is a bit test rather than a cell's midpoint in floating point (this
    /// walk runs for every pixel that reprojection leaves).
    pub fn leaf_below(&self, i: u32, c: &LineCoords) -> u32 {
        let pair = &self.trees[self.cells[i as usize].tree as usize].pair;
        self.descend(i, &lattice_of(pair, c))
    }

    /// `leaf`, trying `hint` first: lines met one after another (a row of
    /// pixels) mostly fall in the same leaf, and checking that a leaf holds
    /// the line's lattice point is cheaper than descending to it. The
    /// answer is `leaf`'s: a tree's leaves do not overlap on the lattice.
    pub fn leaf_hinted(&self, t: u32, c: &LineCoords, hint: Option<u32>) -> u32 {
        let root = self.trees[t as usize].root;
        let q = lattice_of(&self.trees[t as usize].pair, c);
        if let Some(h) = hint {
            let cell = &self.cells[h as usize];
            let leaf = !matches!(cell.state, CellState::Split { .. });
            if cell.tree == t && leaf && holds_lattice_point(&cell.cell, &q) {
                return h;
            }
        }
        self.descend(root, &q)
    }

    fn descend(&self, mut i: u32, q: &[u32; 4]) -> u32 {
        while let CellState::Split { axes, first } = self.cells[i as usize].state {
            let cell = &self.cells[i as usize].cell;
            i = first + child_number(cell, axes, q);
        }
        i
    }

    /// Splits leaf `i` halving the coordinates in `axes`.
    pub fn split(&mut self, i: u32, axes: u8) {
        let (tree, cell) = (self.cells[i as usize].tree, self.cells[i as usize].cell);
        let first = self.cells.len() as u32;
        let count = 1u32 << axes.count_ones();
        for k in 0..count {
            let mut child = cell;
            for (bit, a) in (0..4).filter(|a| axes >> a & 1 == 1).enumerate() {
                child.depth[a] += 1;
                child.index[a] = cell.index[a] * 2 + (k >> bit & 1);
            }
            self.push_cell(tree, child);
        }
        self.cells[i as usize].state = CellState::Split { axes, first };
    }

    /// The sample of key `k`, if traced.
    pub fn sample(&self, k: u128) -> Option<&Sample> {
        self.sample_index
            .get(&k)
            .and_then(|&i| self.samples[i as usize].as_ref())
    }

    /// The keys of cell `i`'s corners.
    pub fn corner_keys(&self, i: u32) -> [u128; 16] {
        let c = &self.cells[i as usize];
        std::array::from_fn(|k| sample_key(c.tree, c.cell.corner_lattice(k)))
    }

    /// Stores a traced sample under `k`.
    pub fn insert_sample(&mut self, k: u128, mut s: Sample) {
        if self.sample_index.contains_key(&k) {
            return;
        }
        s.key = k;
        self.account(s.bytes() as isize + 48);
        let id = match self.free.pop() {
            Some(id) => {
                self.samples[id as usize] = Some(s);
                id
            }
            None => {
                self.samples.push(Some(s));
                self.samples.len() as u32 - 1
            }
        };
        self.sample_index.insert(k, id);
    }

    /// Marks cell `i` built with `state`, holding its corner samples.
    pub fn settle(&mut self, i: u32, state: CellState) {
        let keys = self.corner_keys(i);
        let ids = keys.map(|k| self.sample_index[&k]);
        for &id in &ids {
            if let Some(s) = self.samples[id as usize].as_mut() {
                s.refs += 1;
            }
        }
        if let CellState::Valid(interp) = &state {
            self.account(interp.bytes() as isize);
        }
        let cell = &mut self.cells[i as usize];
        if let Some(old) = cell.samples.replace(ids) {
            self.release(old);
        }
        self.cells[i as usize].state = state;
    }

    fn release(&mut self, ids: [u32; 16]) {
        for id in ids {
            let freed = match self.samples[id as usize].as_mut() {
                Some(s) => {
                    s.refs = s.refs.saturating_sub(1);
                    s.refs == 0
                }
                None => false,
            };
            if freed && let Some(s) = self.samples[id as usize].take() {
                self.account(-(s.bytes() as isize + 48));
                self.sample_index.remove(&s.key);
                self.free.push(id);
            }
        }
    }

    /// Releases the samples of split cells (their children hold what they
    /// share), at the end of a frame.
    pub fn release_split(&mut self) {
        let mut held = Vec::new();
        for c in &mut self.cells {
            if matches!(c.state, CellState::Split { .. })
                && let Some(ids) = c.samples.take()
            {
                held.push(ids);
            }
        }
        for ids in held {
            self.release(ids);
        }
    }

    /// Evicts the least recently used built leaves (not used in frame
    /// `frame`) until the cells and samples take at most `cap` bytes.
    /// Returns how many were evicted.
    pub fn evict(&mut self, cap: usize, frame: u32) -> usize {
        if self.bytes <= cap {
            return 0;
        }
        let mut leaves: Vec<(u32, u32)> = self
            .cells
            .iter()
            .enumerate()
            .filter(|(_, c)| c.samples.is_some() && c.used < frame)
            .map(|(i, c)| (c.used, i as u32))
            .collect();
        leaves.sort_unstable();
        let mut evicted = 0;
        for (_, i) in leaves {
            if self.bytes <= cap * 9 / 10 {
                break;
            }
            let cell = &mut self.cells[i as usize];
            let held = match &cell.state {
                CellState::Valid(interp) => interp.bytes(),
                _ => 0,
            };
            cell.state = CellState::Unbuilt;
            if let Some(ids) = cell.samples.take() {
                self.account(-(held as isize));
                self.release(ids);
                evicted += 1;
            }
        }
        evicted
    }

    /// Cells, leaves among them (not split), and accepted leaves.
    pub fn counts(&self) -> (usize, usize, usize) {
        let leaves = self
            .cells
            .iter()
            .filter(|c| !matches!(c.state, CellState::Split { .. }))
            .count();
        let valid = self
            .cells
            .iter()
            .filter(|c| matches!(c.state, CellState::Valid(_)))
            .count();
        (self.cells.len(), leaves, valid)
    }

    /// The extremal rays' samples held now.
    pub fn samples_held(&self) -> usize {
        self.sample_index.len()
    }
}

/// A line's lattice coordinates: per coordinate, which of the
/// `2^LATTICE_BITS` finest steps of the root holds it (clamped, so the
/// closed root's upper faces fall in its last step).
fn lattice_of(pair: &FacePair, c: &LineCoords) -> [u32; 4] {
    let steps = (1u64 << LATTICE_BITS) as f64;
    std::array::from_fn(|a| {
        let (lo, hi) = (pair.lo[a % 2], pair.hi[a % 2]);
        ((c[a] - lo) / (hi - lo) * steps).clamp(0.0, steps - 1.0) as u32
    })
}

/// Whether lattice point `q` lies in `cell`: the cell's index along each
/// coordinate is the point's top `depth` bits there, as the descent reads
/// them one level at a time.
fn holds_lattice_point(cell: &CellBox, q: &[u32; 4]) -> bool {
    (0..4).all(|a| q[a] >> (LATTICE_BITS - cell.depth[a] as u32) == cell.index[a])
}

/// Which child of `cell` (split along `axes`) holds the line at lattice
/// coordinates `q`: the bit below the cell's depth of each halved one.
fn child_number(cell: &CellBox, axes: u8, q: &[u32; 4]) -> u32 {
    let mut k = 0;
    for (bit, a) in (0..4).filter(|a| axes >> a & 1 == 1).enumerate() {
        let upper = q[a] >> (LATTICE_BITS - 1 - cell.depth[a] as u32) & 1;
        k |= upper << bit;
    }
    k
}

/// The ray of lattice corner `k` of a cell: from its front point towards
/// its back point, unit direction.
pub fn corner_ray(pair: &FacePair, cell: &CellBox, k: usize) -> (DVec3, DVec3) {
    let (o, d) = pair.ray(cell.corner(pair, k));
    (o, d.normalize())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hint saves the descent only where it gives `leaf`'s own answer:
    /// over a tree split unevenly (16 and 4 ways, to several depths), every
    /// line with every kind of hint (its own leaf, a neighbour, a split
    /// cell, another tree's cell, none).
    #[test]
    fn a_hinted_lookup_finds_the_leaf_the_descent_finds() {
        let pair = FacePair::new(&crate::geom::aabb::Aabb::new(Vec3::ZERO, Vec3::ONE), 5);
        let mut trees = Linetrees::default();
        let t = trees.tree(RootFace::Sphere(0), 5, || pair);
        let other = trees.tree(RootFace::Sphere(1), 5, || pair);
        let mut rng = crate::accel::kdtree::test_rng::Rng(0x2545_f491_4f6c_dd1d);
        let line = |rng: &mut crate::accel::kdtree::test_rng::Rng| -> LineCoords {
            std::array::from_fn(|a| {
                let (lo, hi) = (pair.lo[a % 2], pair.hi[a % 2]);
                lo + (hi - lo) * rng.next_f32() as f64
            })
        };
        for round in 0..40 {
            let c = line(&mut rng);
            let leaf = trees.leaf(t, &c);
            let axes = if round % 3 == 0 { 0b0101 } else { 0b1111 };
            if (0..4)
                .filter(|a| axes >> a & 1 == 1)
                .all(|a| trees.cells[leaf as usize].cell.splittable(a))
            {
                trees.split(leaf, axes);
            }
        }
        let (mut hits, mut n) = (0, 0);
        let mut last = None;
        for k in 0..20_000u32 {
            let c = line(&mut rng);
            let hint = match k % 5 {
                0 => Some(trees.trees[other as usize].root),
                1 => Some(trees.trees[t as usize].root),
                2 => None,
                _ => last,
            };
            let found = trees.leaf_hinted(t, &c, hint);
            assert_eq!(found, trees.leaf(t, &c), "line {c:?}, hint {hint:?}");
            hits += (Some(found) == hint) as u32;
            n += 1;
            last = Some(found);
        }
        // Some hints were right, so the shortcut was taken.
        assert!(hits > 0 && hits < n, "{hits} of {n}");
    }

    #[test]
    fn a_sixteen_way_split_needs_65_new_rays_and_a_four_way_split_20() {
        let pair = FacePair::new(&crate::geom::aabb::Aabb::new(Vec3::ZERO, Vec3::ONE), 5);
        for (axes, new) in [(0b1111u8, 65usize), (0b0101, 20)] {
            let mut trees = Linetrees::default();
            let t = trees.tree(RootFace::Sphere(0), 5, || pair);
            let root = trees.trees[t as usize].root;
            let parent: std::collections::HashSet<u128> = trees.corner_keys(root).into_iter().collect();
            trees.split(root, axes);
            let CellState::Split { first, .. } = trees.cells[root as usize].state else {
                panic!("split")
            };
            let mut keys = std::collections::HashSet::new();
            for c in first..first + (1 << axes.count_ones()) {
                keys.extend(trees.corner_keys(c));
            }
            assert_eq!(keys.difference(&parent).count(), new, "axes {axes:b}");
        }
    }
}
