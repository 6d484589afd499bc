//! Spherical rasterisation of blocker triangles into a visibility mask
//! (section 3.1.1, Figure 2), on the CPU (`prt::gpu` explains why the
//! masks are not rasterised in WGSL).
//!
//! Each edge of a triangle abc (in the tangent frame, origin at the vertex)
//! defines a plane through the origin with normal `a × b`. With
//! `det = (a × b) · c`, the point c lies on the positive side of the edge
//! ab exactly when det > 0, and `(b × c)·a = (c × a)·b = det` too; so the
//! three normals `sign(det) (a×b, b×c, c×a)` all point into the triangle's
//! cone, and a pixel direction d is inside the spherical image iff
//! `d · m_e > 0` for all three edges (Figure 2a-c). The LUT gives each
//! half-space's mask; their AND is the triangle's coverage (Figure 2d), and
//! OR-ing coverage into the vertex's mask is the paper's occluder fusion.
//!
//! The face normal `(b - a) × (c - a)` satisfies `N · a = det`, so a
//! triangle faces the vertex (N points towards the origin) iff det < 0:
//! back-face culling is a sign test on the same determinant. `det = 0`
//! means the origin lies in the triangle's plane (seen edge-on: zero solid
//! angle); such triangles, zero-area ones included, are skipped.

use glam::Vec3;

use super::lut::PlaneLut;
use super::mask::MaskGrid;

/// Relative size of |det| below which a triangle counts as seen edge-on
/// (its solid angle is then below about 1e-6 sr).
pub const EDGE_ON: f32 = 1e-6;

/// What happened to one blocker triangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fate {
    /// No vertex above the tangent plane (z <= 0 for all three): it cannot
    /// block any direction of the hemisphere.
    BelowHorizon,
    /// It faces away from the vertex (`det > 0`) and back-face culling is on.
    BackFacing,
    /// The vertex lies in its plane (|det| below [`EDGE_ON`] relative to the
    /// vertices' lengths, or not finite): it subtends no solid angle.
    EdgeOn,
    /// Its coverage was OR-ed into the mask.
    Drawn,
}

/// The three inward edge-plane normals of a triangle seen from the origin,
/// or why it covers nothing.
#[inline(always)]
pub fn edge_planes(t: &[Vec3; 3], cull_backfaces: bool) -> Result<[Vec3; 3], Fate> {
    let [a, b, c] = *t;
    if a.z <= 0.0 && b.z <= 0.0 && c.z <= 0.0 {
        return Err(Fate::BelowHorizon);
    }
    let ab = a.cross(b);
    let det = ab.dot(c);
    let scale = a.length_squared() * b.length_squared() * c.length_squared();
    if det * det <= EDGE_ON * EDGE_ON * scale || !det.is_finite() {
        return Err(Fate::EdgeOn);
    }
    if cull_backfaces && det > 0.0 {
        return Err(Fate::BackFacing);
    }
    let s = if det > 0.0 { 1.0 } else { -1.0 };
    Ok([ab * s, b.cross(c) * s, c.cross(a) * s])
}

/// Rasterises one triangle with the LUT, OR-ing its coverage into `mask`
/// (`W` u64 words).
#[inline(always)]
pub fn raster_triangle<const W: usize>(
    lut: &PlaneLut,
    t: &[Vec3; 3],
    cull_backfaces: bool,
    mask: &mut [u64; W],
) -> Fate {
    match edge_planes(t, cull_backfaces) {
        Ok(planes) => {
            or_coverage(lut, &planes, mask);
            Fate::Drawn
        }
        Err(f) => f,
    }
}

/// AND of the three half-space masks, OR-ed into `mask`.
#[inline(always)]
pub fn or_coverage<const W: usize>(lut: &PlaneLut, planes: &[Vec3; 3], mask: &mut [u64; W]) {
    // The planes are non-zero (det != 0), so every lookup succeeds.
    let r = planes.map(|m| lut.lookup(m).expect("non-zero plane normal"));
    let flip = r.map(|r| if r.complement { u64::MAX } else { 0 });
    let m0: &[u64; W] = lut.mask(r[0].entry).try_into().expect("W words");
    let m1: &[u64; W] = lut.mask(r[1].entry).try_into().expect("W words");
    let m2: &[u64; W] = lut.mask(r[2].entry).try_into().expect("W words");
    for k in 0..W {
        mask[k] |= (m0[k] ^ flip[0]) & (m1[k] ^ flip[1]) & (m2[k] ^ flip[2]);
    }
}

/// The exact mask of one triangle: every pixel direction tested against the
/// three edge planes (the reference for the LUT's quantisation error).
pub fn raster_triangle_exact(grid: &MaskGrid, t: &[Vec3; 3], cull_backfaces: bool, mask: &mut [u64]) -> Fate {
    match edge_planes(t, cull_backfaces) {
        Ok([m0, m1, m2]) => {
            for (p, d) in grid.dirs.iter().enumerate() {
                if d.dot(m0) > 0.0 && d.dot(m1) > 0.0 && d.dot(m2) > 0.0 {
                    mask[p / 64] |= 1 << (p % 64);
                }
            }
            Fate::Drawn
        }
        Err(f) => f,
    }
}

/// Blocker triangles of one vertex in structure-of-arrays form (tangent
/// frame), so that plane set-up runs over many triangles at once in SIMD
/// lanes. The arrays only grow; `len` triangles are valid.
#[derive(Debug, Default, Clone)]
pub struct TriangleBatch {
    /// x, y, z of vertices a, b, c: `v[3 * vertex + axis][i]`.
    pub v: [Vec<f32>; 9],
    /// Number of valid triangles, slots `0..len` of every array.
    pub len: usize,
}

impl TriangleBatch {
    /// Makes room for `n` triangles.
    pub fn reserve(&mut self, n: usize) {
        for a in &mut self.v {
            if a.len() < n {
                a.resize(n, 0.0);
            }
        }
    }

    /// Appends a triangle (room must have been reserved).
    #[inline(always)]
    pub fn push(&mut self, t: [Vec3; 3]) {
        self.reserve(self.len + 1);
        self.write(t);
        self.len += 1;
    }

    /// Writes a triangle in slot `len` without advancing: with
    /// `len += keep` afterwards this compacts without a branch.
    #[inline(always)]
    pub fn write(&mut self, t: [Vec3; 3]) {
        let i = self.len;
        for (k, p) in t.iter().enumerate() {
            self.v[3 * k][i] = p.x;
            self.v[3 * k + 1][i] = p.y;
            self.v[3 * k + 2][i] = p.z;
        }
    }

    /// Empties the batch, keeping its storage.
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Number of valid triangles.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when no triangle is valid.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Triangle `i` (vertices a, b, c in the tangent frame).
    pub fn get(&self, i: usize) -> [Vec3; 3] {
        let p = |k: usize| Vec3::new(self.v[3 * k][i], self.v[3 * k + 1][i], self.v[3 * k + 2][i]);
        [p(0), p(1), p(2)]
    }
}

/// LUT references of a batch, structure of arrays: for each edge k the
/// entry index with the complement flag in bit 31, and whether each
/// triangle is drawn.
#[derive(Debug, Default, Clone)]
pub struct BatchRefs {
    /// Per edge ab, bc, ca and per triangle: the LUT entry of the inward
    /// edge plane, [`COMPLEMENT`] set when its mask is to be complemented.
    pub edge: [Vec<u32>; 3],
    /// Per triangle, 1 if it is drawn, 0 if it is edge-on or culled as
    /// back-facing.
    pub keep: Vec<u32>,
    /// First and last 64-byte line of the masks the triangle can touch
    /// (`first | last << 16`), see `line_span`.
    pub lines: Vec<u32>,
}

/// Bit 31 of a reference: complement the entry's mask.
pub const COMPLEMENT: u32 = 1 << 31;

/// Plane set-up for a whole batch, written without branches so the
/// compiler can run it in SIMD lanes: edge planes, edge-on and back-face
/// tests, and the cube-map LUT index of each plane (the same arithmetic as
/// `edge_planes` and `lut_index`). Horizon culling already happened when the
/// batch was gathered. Returns (drawn, back-facing, edge-on).
pub fn batch_refs(
    batch: &TriangleBatch,
    cull_backfaces: bool,
    lut_n: u32,
    side: u32,
    refs: &mut BatchRefs,
) -> (u64, u64, u64) {
    let n = batch.len();
    for e in &mut refs.edge {
        e.clear();
        e.resize(n, 0);
    }
    refs.keep.clear();
    refs.keep.resize(n, 0);
    refs.lines.clear();
    refs.lines.resize(n, 0);
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU has AVX2 and FMA (checked above).
        return unsafe { batch_refs_avx2(batch, cull_backfaces, lut_n, side, refs) };
    }
    batch_refs_body(batch, cull_backfaces, lut_n, side, refs)
}

/// `batch_refs` without the CPU dispatch (for callers already compiled
/// with the features they want).
#[inline(always)]
pub fn batch_refs_inline(
    batch: &TriangleBatch,
    cull_backfaces: bool,
    lut_n: u32,
    side: u32,
    refs: &mut BatchRefs,
) -> (u64, u64, u64) {
    let n = batch.len();
    for e in &mut refs.edge {
        if e.len() < n {
            e.resize(n, 0);
        }
    }
    if refs.keep.len() < n {
        refs.keep.resize(n, 0);
        refs.lines.resize(n, 0);
    }
    batch_refs_body(batch, cull_backfaces, lut_n, side, refs)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn batch_refs_avx2(
    batch: &TriangleBatch,
    cull_backfaces: bool,
    lut_n: u32,
    side: u32,
    refs: &mut BatchRefs,
) -> (u64, u64, u64) {
    batch_refs_body(batch, cull_backfaces, lut_n, side, refs)
}

/// The mask rows a triangle's image can reach, as 64-byte lines of the mask
/// (`first | last << 16`).
///
/// The image is inside the cone of positive combinations of a, b, c. For
/// k <= 0 the set of directions with `d_y <= k` is a convex cone, so if every
/// vertex has `d_y = y / |v| <= k < 0`, so does the whole image: rows above
/// k are empty. Likewise below `min d_y` when it is positive. (A bound from
/// the vertices alone fails when the signs differ: an arc between two
/// vertices can bulge past both.) One row of slack on each side covers the
/// pixel directions of `MaskGrid`, which are area means rather than pixel
/// centres.
#[inline(always)]
pub fn line_span(ay: f32, la: f32, by: f32, lb: f32, cy: f32, lc: f32, side: u32) -> u32 {
    let rows_per_line = (512 / side).max(1) as f32;
    let last_line = ((side * side / 512).max(1) - 1) as f32;
    let (da, db, dc) = (ay / la.sqrt(), by / lb.sqrt(), cy / lc.sqrt());
    // Selects rather than f32::max/floor keep this loop in SIMD lanes.
    let max2 = |a: f32, b: f32| if a > b { a } else { b };
    let min2 = |a: f32, b: f32| if a < b { a } else { b };
    let ymax = max2(max2(da, db), dc);
    let ymin = min2(min2(da, db), dc);
    let s = side as f32;
    // A vertex at the origin makes these NaN: the comparisons then fail and
    // the span is every line.
    let hi = if ymax < 0.0 {
        (ymax + 1.0) * 0.5 * s + 1.0
    } else {
        s - 1.0
    };
    let lo = if ymin > 0.0 { (ymin + 1.0) * 0.5 * s - 1.0 } else { 0.0 };
    let clamp = |v: f32, a: f32, b: f32| {
        if v < a {
            a
        } else if v > b {
            b
        } else {
            v
        }
    };
    // Truncation is the floor here: both are >= 0.
    let first = clamp(lo / rows_per_line, 0.0, last_line);
    let last = clamp(hi / rows_per_line, 0.0, last_line);
    // SAFETY: both are finite and in [0, last_line].
    let (first, last) = unsafe { (first.to_int_unchecked::<u32>(), last.to_int_unchecked::<u32>()) };
    first | last.max(first) << 16
}

/// One cube-map index (branch-free form of `lut::lut_index`).
#[inline(always)]
fn cube_ref(mx: f32, my: f32, mz: f32, lut_n: u32, half_n: f32, max_i: f32) -> u32 {
    let (px, py, pz) = (mx.abs(), my.abs(), mz.abs());
    let is_x = px >= py && px >= pz;
    let is_y = !is_x && py >= pz;
    // (axis, major, u, v): u, v follow the axis cyclically, as in `lut`.
    let (axis, major, u, v) = if is_x {
        (0, mx, my, mz)
    } else if is_y {
        (1, my, mz, mx)
    } else {
        (2, mz, mx, my)
    };
    let safe = if major == 0.0 { 1.0 } else { major };
    let inv = 1.0 / safe;
    let fu = ((u * inv + 1.0) * half_n).max(0.0).min(max_i);
    let fv = ((v * inv + 1.0) * half_n).max(0.0).min(max_i);
    // SAFETY: fu, fv are finite and in [0, n - 1] (inv is finite, u/major in [-1, 1]).
    let (iu, iv) = unsafe { (fu.to_int_unchecked::<u32>(), fv.to_int_unchecked::<u32>()) };
    ((axis * lut_n + iv) * lut_n + iu) | if major < 0.0 { COMPLEMENT } else { 0 }
}

#[inline(always)]
fn batch_refs_body(
    batch: &TriangleBatch,
    cull_backfaces: bool,
    lut_n: u32,
    side: u32,
    refs: &mut BatchRefs,
) -> (u64, u64, u64) {
    let n = batch.len();
    let [ax, ay, az, bx, by, bz, cx, cy, cz] = &batch.v;
    let (ax, ay, az) = (&ax[..n], &ay[..n], &az[..n]);
    let (bx, by, bz) = (&bx[..n], &by[..n], &bz[..n]);
    let (cx, cy, cz) = (&cx[..n], &cy[..n], &cz[..n]);
    let [e0, e1, e2] = &mut refs.edge;
    let (e0, e1, e2, keep) = (&mut e0[..n], &mut e1[..n], &mut e2[..n], &mut refs.keep[..n]);
    let lines = &mut refs.lines[..n];
    let nf = lut_n as f32;
    let half_n = 0.5 * nf;
    let max_i = nf - 1.0;
    let (mut drawn, mut back, mut edge) = (0u32, 0u32, 0u32);
    for i in 0..n {
        let (ax, ay, az) = (ax[i], ay[i], az[i]);
        let (bx, by, bz) = (bx[i], by[i], bz[i]);
        let (cx, cy, cz) = (cx[i], cy[i], cz[i]);
        // a x b, b x c, c x a
        let (abx, aby, abz) = (ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx);
        let (bcx, bcy, bcz) = (by * cz - bz * cy, bz * cx - bx * cz, bx * cy - by * cx);
        let (cax, cay, caz) = (cy * az - cz * ay, cz * ax - cx * az, cx * ay - cy * ax);
        let det = abx * cx + aby * cy + abz * cz;
        let la = ax * ax + ay * ay + az * az;
        let lb = bx * bx + by * by + bz * bz;
        let lc = cx * cx + cy * cy + cz * cz;
        // Negated on purpose: a NaN determinant counts as edge-on.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        let edge_on = !(det * det > EDGE_ON * EDGE_ON * (la * lb * lc));
        let backfacing = cull_backfaces & (det > 0.0) & !edge_on;
        let kept = !edge_on & !backfacing;
        let s = if det > 0.0 { 1.0 } else { -1.0 };
        e0[i] = cube_ref(abx * s, aby * s, abz * s, lut_n, half_n, max_i);
        e1[i] = cube_ref(bcx * s, bcy * s, bcz * s, lut_n, half_n, max_i);
        e2[i] = cube_ref(cax * s, cay * s, caz * s, lut_n, half_n, max_i);
        keep[i] = kept as u32;
        drawn += kept as u32;
        back += backfacing as u32;
        edge += edge_on as u32;
    }
    // A separate pass: the vectoriser gives up on one loop doing both.
    for i in 0..n {
        let la = ax[i] * ax[i] + ay[i] * ay[i] + az[i] * az[i];
        let lb = bx[i] * bx[i] + by[i] * by[i] + bz[i] * bz[i];
        let lc = cx[i] * cx[i] + cy[i] * cy[i] + cz[i] * cz[i];
        lines[i] = line_span(ay[i], la, by[i], lb, cy[i], lc, side);
    }

    (drawn as u64, back as u64, edge as u64)
}

/// Triangles ahead whose LUT lines `batch_or` asks the cache for: the
/// table (6 MB at 128) lives in L3, and the AND/OR loop would otherwise wait
/// on each fetch (measured: prefetching halves the rasterisation time).
pub const PREFETCH_AHEAD: usize = 8;

/// ORs the coverage of the first `n` triangles of `refs` into `mask`,
/// touching only the 64-byte lines of the masks each triangle can reach.
#[inline(always)]
pub fn batch_or<const W: usize>(lut: &PlaneLut, refs: &BatchRefs, n: usize, mask: &mut [u64; W]) {
    let table = lut.words_slice();
    let [e0, e1, e2] = &refs.edge;
    let ahead = PREFETCH_AHEAD;
    // Words per block: a cache line, or the whole mask when it is smaller.
    let bw = W.min(8);
    for i in 0..n {
        if i + ahead < n {
            let span = refs.lines[i + ahead];
            prefetch_entry::<W>(table, e0[i + ahead], span);
            prefetch_entry::<W>(table, e1[i + ahead], span);
            prefetch_entry::<W>(table, e2[i + ahead], span);
        }
        if refs.keep[i] == 0 {
            continue;
        }
        let m = |r: u32| {
            let b = (r & !COMPLEMENT) as usize * W;
            let words: &[u64; W] = table[b..b + W].try_into().expect("W words");
            (words, if r & COMPLEMENT != 0 { u64::MAX } else { 0 })
        };
        let ((m0, f0), (m1, f1), (m2, f2)) = (m(e0[i]), m(e1[i]), m(e2[i]));
        let span = refs.lines[i];
        let (first, last) = ((span & 0xffff) as usize, (span >> 16) as usize);
        for line in 0..W / bw {
            if line < first || line > last {
                continue;
            }
            for k in line * bw..(line + 1) * bw {
                mask[k] |= (m0[k] ^ f0) & (m1[k] ^ f1) & (m2[k] ^ f2);
            }
        }
    }
}

/// Asks the cache for the lines `span` of a LUT entry.
#[inline(always)]
fn prefetch_entry<const W: usize>(table: &[u64], r: u32, span: u32) {
    #[cfg(target_arch = "x86_64")]
    {
        let e = (r & !COMPLEMENT) as usize * W;
        let mut k = (span & 0xffff) as usize * 8;
        let end = (((span >> 16) as usize + 1) * 8).min(W);
        while k < end {
            if let Some(w) = table.get(e + k) {
                // SAFETY: prefetching is a hint; the address is in bounds.
                unsafe {
                    std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>((w as *const u64).cast())
                };
            }
            k += 8;
        }
    }
}
