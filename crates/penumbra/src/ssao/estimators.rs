//! The paper's ambient-occlusion estimators over the depth buffer, as
//! sample tables plus three kernels (`ssao_points`, `ssao_march`,
//! `ssao_disk` here and in `wgsl/ssao_estimate.wgsl`).
//!
//! Everything is in units of R (rho = r / R, m(rho) = mu(R rho),
//! m' = R dmu/dr; see `measure`). Samples are points q in the tangent frame
//! (T, B, N) of the shaded point s (N = z), scaled by R: p = s + R (T q.x +
//! B q.y + N q.z). v(p) = 1 unless p lies behind the depth buffer (`occluded`).
//! Equation (1) of section 4, with the volume element dV = r^2 dr dw:
//!
//!   O = (1/pi) int_Omega int_0^R mu'(r) cos+ v dr dw
//!     = (1/pi) int_S mu'(r) cos+ v / r^2 dV.                       (2)
//!
//! Weights w_j (stored with each table entry, divided by n) make the
//! estimate O = sum_j w_j v(p_j):
//!
//! * `sphere` (4.1): p uniform in the ball, density 3 / (4 pi R^3), so
//!   F/p = (4 R^3 / 3) mu' cos+ / r^2 = (4/3) m'(rho) cos+ / rho^2 (the
//!   paper's 4R^3/(3N) sum ...). Direction: z = 1 - 2 u1, phi = 2 pi u2;
//!   rho = u3^(1/3) (the radius of a uniform ball point has density 3 rho^2).
//! * `hemisphere` (4.2): the half ball on the normal's side, density
//!   3 / (2 pi R^3): w = (2/3) m'(rho) cos / rho^2; z = cos = 1 - u1 uniform.
//! * `importance` (4.3): direction with density cos / pi (Malley's method:
//!   a uniform disk point lifted to the hemisphere; the paper's rejection
//!   sampling of the square gives the same density, we use the concentric
//!   map to keep the Sobol stratification) and rho = m^-1(u3) with density
//!   m'. The density is exactly the integrand of (1) without v, so w = 1.
//! * `tangent-sphere` (4.4): uniform in the sphere of radius R/2 touching s,
//!   centre s + N R/2, volume pi R^3 / 6: w = (1/6) m'(rho) / rho^2, divided
//!   by the estimate's value at an open point (`Measure::tangent_sphere_open_value`,
//!   derived there; 2/5 for poly4), so that an open point is 1.
//! * `raymarch` (3.2, the baseline): N = n / M rays with cosine-distributed
//!   directions, M jittered steps rho_k = (k + u3) / M each; a ray's value is
//!   m(rho_k) at its first occluded step, 1 if none; O = mean over rays
//!   (the cosine density makes the cosine factor implicit). Entries are the
//!   steps, ray-major, with w = m(rho_k) / N.
//! * `base-disk` (4.5): (x, y) uniform on the disk of radius R perpendicular
//!   to the view axis, w = 1/n; see `ssao_disk` for the pipe integral h.
//!
//! Calibration (`SsaoSettings::calibrate`, on by default): the weights of
//! each pixel's set are divided by their sum over the set (for base-disk,
//! the pixel's open-point sum of h), so a point without occluders gets
//! exactly 1 and the estimate is sum w v / sum w: the error the weights alone
//! add at open points (and that R -> 0 would show as noise around 1) is
//! gone, occlusion is estimated as before. `importance` and `raymarch` are
//! calibrated already (equal weights / one value per ray).

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use rayon::prelude::*;

use super::gbuffer::{GBuffer, ScreenConstants, ScreenView, valid_depth};
use super::interleave::Patterns;
use super::{ShadeSettings, SsaoSettings};
use crate::error::Result;
use crate::geom::sampling::{Frame, SampleSequence, concentric_disk, cosine_hemisphere};

/// The estimators of the paper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Estimator {
    /// N rays x M steps (section 3.2), the baseline.
    Raymarch,
    /// Uniform points in the neighbourhood sphere (4.1).
    Sphere,
    /// Uniform points in the half sphere above the surface (4.2).
    Hemisphere,
    /// Cosine directions, r = mu^-1(xi) (4.3).
    Importance,
    /// Uniform points in the tangent sphere (4.4).
    TangentSphere,
    /// Pipes through the base disk, analytic line integral (4.5; poly4 only).
    BaseDisk,
}

crate::choice!(Estimator { Raymarch = "raymarch", Sphere = "sphere", Hemisphere = "hemisphere", Importance = "importance", TangentSphere = "tangent-sphere", BaseDisk = "base-disk" });

impl Estimator {
    /// Every estimator, in the order of the paper's sections.
    pub const ALL: [Estimator; 6] = [
        Estimator::Raymarch,
        Estimator::Sphere,
        Estimator::Hemisphere,
        Estimator::Importance,
        Estimator::TangentSphere,
        Estimator::BaseDisk,
    ];

    /// The name the command line and reports use: `raymarch`, `sphere`,
    /// `hemisphere`, `importance`, `tangent-sphere` or `base-disk`.
    pub fn name(&self) -> &'static str {
        match self {
            Estimator::Raymarch => "raymarch",
            Estimator::Sphere => "sphere",
            Estimator::Hemisphere => "hemisphere",
            Estimator::Importance => "importance",
            Estimator::TangentSphere => "tangent-sphere",
            Estimator::BaseDisk => "base-disk",
        }
    }

    /// Which kernel runs it.
    pub fn family(&self) -> Family {
        match self {
            Estimator::Raymarch => Family::March,
            Estimator::BaseDisk => Family::Disk,
            _ => Family::Points,
        }
    }

    /// Draws r uniformly in a volume and weights by dmu/dr.
    pub fn needs_density(&self) -> bool {
        matches!(
            self,
            Estimator::Sphere | Estimator::Hemisphere | Estimator::TangentSphere
        )
    }
}

/// The three kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// Weighted point samples in the tangent frame (`ssao_points`).
    Points,
    /// Rays of steps (`ssao_march`).
    March,
    /// Pipes through a disk perpendicular to the view axis (`ssao_disk`).
    Disk,
}

impl Family {
    /// `table_kind` of the indirect kernel: 0 = tangent-frame points,
    /// 1 = disk offsets in camera x, y.
    pub fn table_kind(&self) -> u32 {
        match self {
            Family::Disk => 1,
            _ => 0,
        }
    }
}

/// The per-pixel sample sets of one estimator: `pattern_count * samples`
/// entries (q.x, q.y, q.z, w), set k first (the `table` buffer of the
/// kernels, uploaded as it is).
#[derive(Debug, Clone, PartialEq)]
pub struct SampleTable {
    /// The kernel that reads the table.
    pub family: Family,
    /// Which set each pixel uses: 4x4 interleaved sets, or a tile of
    /// independent ones (`SsaoSettings::interleave`).
    pub patterns: Patterns,
    /// Entries per set (= spp).
    pub samples: u32,
    /// Rays per set: for raymarch samples / steps, for the others `samples`.
    pub rays: u32,
    /// Steps per ray: raymarch's (rays * steps = samples), 1 for the others.
    pub steps: u32,
    /// Raymarch: value of a ray without occluded step (1 / rays).
    pub open_weight: f32,
    /// The sets one after another, `samples` entries each: (q.x, q.y, q.z, w),
    /// the sample point in the tangent frame in units of R (base-disk: the disk
    /// offset in camera x, y) and its weight.
    pub entries: Vec<[f32; 4]>,
    /// Sets of a volume estimator (`Estimator::needs_density`) that carry
    /// no weight at an open point, where the estimator's expectation is 1:
    /// every weight is zero in f32 (calibrated sets: calibration rescales
    /// any positive sum to 1) or they sum to less than `WEIGHTLESS`
    /// (uncalibrated). The measure's weight then lies closer to the point
    /// than any of the set's uniform samples (the exponential measure at a
    /// large sigma R), and the pixels using the set read about 0 whatever
    /// occludes them.
    pub weightless_sets: u32,
}

/// An uncalibrated set's value at an open point below which it counts as
/// weightless.
pub const WEIGHTLESS: f64 = 1e-3;

impl SampleTable {
    /// The table of `s`'s estimator, measure, radius, samples per pixel,
    /// interleaving, calibration and seed; checks `s` first.
    pub fn build(s: &SsaoSettings) -> Result<SampleTable> {
        s.validate()?;
        let n = s.spp;
        let family = s.estimator.family();
        let (rays, steps) = match family {
            Family::March => (n / s.steps, s.steps),
            _ => (n, 1),
        };
        let patterns = Patterns::new(s.interleave, n);
        let seq = SampleSequence::new(s.seed);
        let m = s.measure;
        let r = s.radius;
        let tangent_norm = m.tangent_sphere_open_value(r);
        let mut entries = Vec::with_capacity((patterns.count() * n) as usize);
        let mut weightless_sets = 0;
        for pattern in 0..patterns.count() {
            let first = entries.len();
            for j in 0..rays {
                let [u1, u2, u3] = patterns.sample(&seq, pattern, rays, j);
                match s.estimator {
                    Estimator::Raymarch => {
                        let w = cosine_hemisphere(u1, u2);
                        for k in 0..steps {
                            let rho = (k as f32 + u3) / steps as f32;
                            let q = w * rho;
                            let value = m.m(rho as f64, r) / rays as f64;
                            entries.push([q.x, q.y, q.z, value as f32]);
                        }
                    }
                    Estimator::Sphere => {
                        let w = uniform_sphere(u1, u2);
                        let rho = (u3 as f64).cbrt();
                        let weight = 4.0 / 3.0 * m.dm(rho, r) * (w.z.max(0.0) as f64) / (rho * rho);
                        entries.push(point(w * rho as f32, weight / n as f64));
                    }
                    Estimator::Hemisphere => {
                        let z = 1.0 - u1;
                        let w = direction(z, u2);
                        let rho = (u3 as f64).cbrt();
                        let weight = 2.0 / 3.0 * m.dm(rho, r) * z as f64 / (rho * rho);
                        entries.push(point(w * rho as f32, weight / n as f64));
                    }
                    Estimator::Importance => {
                        let w = cosine_hemisphere(u1, u2);
                        let rho = m.inverse(u3 as f64, r);
                        entries.push(point(w * rho as f32, 1.0 / n as f64));
                    }
                    Estimator::TangentSphere => {
                        let b = uniform_sphere(u1, u2) * (u3 as f64).cbrt() as f32;
                        let q = Vec3::new(0.0, 0.0, 0.5) + 0.5 * b;
                        let rho = (q.length() as f64).max(1e-6);
                        let weight = m.dm(rho, r) / (6.0 * rho * rho) / tangent_norm;
                        entries.push(point(q, weight / n as f64));
                    }
                    Estimator::BaseDisk => {
                        let [x, y] = concentric_disk(u1, u2);
                        entries.push([x, y, 0.0, 1.0 / n as f32]);
                    }
                }
            }
            // Every volume estimator's weight carries the cosine factor
            // max(0, z) (tangent sphere: points above the plane only), so
            // the plain sum is the set's value at an open point.
            let open: f64 = entries[first..].iter().map(|e| e[3] as f64).sum();
            let least = if s.calibrate { f64::MIN_POSITIVE } else { WEIGHTLESS };
            if s.estimator.needs_density() && open < least {
                weightless_sets += 1;
            }
            if s.calibrate && family == Family::Points {
                let sum = open;
                if sum > 0.0 {
                    for e in &mut entries[first..] {
                        e[3] = (e[3] as f64 / sum) as f32;
                    }
                }
            }
        }
        Ok(SampleTable {
            family,
            patterns,
            samples: n,
            rays,
            steps,
            open_weight: 1.0 / rays as f32,
            entries,
            weightless_sets,
        })
    }
}

fn point(q: Vec3, w: f64) -> [f32; 4] {
    [q.x, q.y, q.z, w as f32]
}

/// Unit vector with z = `z` and azimuth 2 pi u.
fn direction(z: f32, u: f32) -> Vec3 {
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (2.0 * std::f32::consts::PI * u).sin_cos();
    Vec3::new(r * c, r * s, z)
}

fn uniform_sphere(u1: f32, u2: f32) -> Vec3 {
    direction(1.0 - 2.0 * u1, u2)
}

/// `SsaoUniforms` in `wgsl/ssao_common.wgsl`: one uniform for every SSAO
/// kernel, and what their CPU twins take, so a test can run both on the
/// same input.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct SsaoUniforms {
    pub width: u32,
    pub height: u32,
    /// Table entries per set.
    pub samples: u32,
    /// Pattern side P.
    pub pattern: u32,
    pub steps: u32,
    pub rays: u32,
    pub table_kind: u32,
    pub calibrate: u32,
    pub radius: f32,
    /// Relative depth bias: bias_px x 2 tan(fov/2) / H.
    pub bias: f32,
    pub filter_depth: f32,
    pub ambient: f32,
    pub tan_half_x: f32,
    pub tan_half_y: f32,
    pub inv_tan_half_x: f32,
    pub inv_tan_half_y: f32,
    pub half_w: f32,
    pub half_h: f32,
    pub px_x: f32,
    pub px_y: f32,
    pub open_weight: f32,
    /// The estimation grid: every `scale`-th pixel in x and y,
    /// lo_width x lo_height cells (`Resolution`; see `estimate_cpu`).
    pub lo_width: u32,
    pub lo_height: u32,
    pub scale: u32,
}

impl SsaoUniforms {
    pub fn new(view: &ScreenView, s: &SsaoSettings, table: &SampleTable, shade: ShadeSettings) -> SsaoUniforms {
        let c = view.constants();
        let scale = s.resolution.scale();
        SsaoUniforms {
            width: view.width,
            height: view.height,
            samples: table.samples,
            pattern: table.patterns.side,
            steps: table.steps,
            rays: table.rays,
            table_kind: table.family.table_kind(),
            calibrate: s.calibrate as u32,
            radius: s.radius,
            bias: s.bias_px * 2.0 * view.tan_half_y / view.height as f32,
            filter_depth: s.filter_depth(),
            ambient: shade.ambient,
            tan_half_x: c.tan_half_x,
            tan_half_y: c.tan_half_y,
            inv_tan_half_x: c.inv_tan_half_x,
            inv_tan_half_y: c.inv_tan_half_y,
            half_w: c.half_w,
            half_h: c.half_h,
            px_x: c.px_x,
            px_y: c.px_y,
            open_weight: table.open_weight,
            lo_width: view.width.div_ceil(scale),
            lo_height: view.height.div_ceil(scale),
            scale,
        }
    }

    /// Cells of the estimation grid.
    pub fn cells(&self) -> usize {
        self.lo_width as usize * self.lo_height as usize
    }

    /// Depth of grid cell (x, y)'s pixel (`grid_depth` in the WGSL).
    #[inline]
    pub fn grid_depth(&self, gb: &GBuffer, x: u32, y: u32) -> f32 {
        gb.geometry[(y * self.scale * self.width + x * self.scale) as usize][3]
    }

    pub fn screen(&self) -> ScreenConstants {
        ScreenConstants {
            width: self.width,
            height: self.height,
            tan_half_x: self.tan_half_x,
            tan_half_y: self.tan_half_y,
            inv_tan_half_x: self.inv_tan_half_x,
            inv_tan_half_y: self.inv_tan_half_y,
            half_w: self.half_w,
            half_h: self.half_h,
            px_x: self.px_x,
            px_y: self.px_y,
        }
    }

    #[inline]
    pub fn pattern_index(&self, x: u32, y: u32) -> u32 {
        (x % self.pattern) + self.pattern * (y % self.pattern)
    }
}

/// Whether camera-space point p lies behind the depth buffer (`occluded` in
/// the WGSL): it projects into the image onto a surface pixel of depth d and
/// p.z > d + bias d. Points behind the camera, outside the image or over
/// the background are open: screen space knows nothing there.
#[inline]
pub fn occluded(gb: &GBuffer, sc: &ScreenConstants, bias: f32, p: Vec3) -> bool {
    match sc.project(p) {
        Some((x, y)) => {
            let d = gb.geometry[(y * sc.width + x) as usize][3];
            valid_depth(d) && p.z > d + bias * d
        }
        None => false,
    }
}

/// The shaded point of pixel (x, y): camera-space position and unit normal,
/// or None for background and degenerate (zero-normal) pixels, which get 1.
#[inline]
pub fn shaded_point(gb: &GBuffer, sc: &ScreenConstants, x: u32, y: u32) -> Option<(Vec3, Vec3)> {
    let g = gb.geometry[(y * sc.width + x) as usize];
    let n = Vec3::new(g[0], g[1], g[2]);
    if !valid_depth(g[3]) || n == Vec3::ZERO {
        return None;
    }
    Some((sc.cam_point(x, y, g[3]), n))
}

/// Whether h = `ScreenConstants::homogeneous(p)` lies behind the depth
/// buffer: `occluded` through the homogeneous projection
/// (`occluded_homogeneous` in the WGSL).
#[inline]
pub fn occluded_homogeneous(gb: &GBuffer, sc: &ScreenConstants, bias: f32, h: Vec3) -> bool {
    match sc.project_homogeneous(h) {
        Some((x, y)) => {
            let d = gb.geometry[(y * sc.width + x) as usize][3];
            valid_depth(d) && h.z > d + bias * d
        }
        None => false,
    }
}

/// The shaded point s and its tangent frame scaled by R, mapped by
/// `ScreenConstants::homogeneous`: table entry q's sample point maps to
/// s + t q.x + b q.y + n q.z (`homogeneous_frame` in the WGSL).
pub struct HomogeneousFrame {
    pub s: Vec3,
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl HomogeneousFrame {
    #[inline]
    pub fn new(sc: &ScreenConstants, radius: f32, s: Vec3, n: Vec3) -> HomogeneousFrame {
        let f = Frame::from_normal(n);
        HomogeneousFrame {
            s: sc.homogeneous(s),
            t: sc.homogeneous(radius * f.t),
            b: sc.homogeneous(radius * f.b),
            n: sc.homogeneous(radius * n),
        }
    }

    #[inline]
    pub fn sample(&self, q: &[f32; 4]) -> Vec3 {
        self.s + self.t * q[0] + self.b * q[1] + self.n * q[2]
    }
}

/// Runs the estimator's kernel on the CPU: one value per cell of the
/// estimation grid (`SsaoUniforms::lo_width` x `lo_height`; cell (X, Y)
/// shades pixel (scale X, scale Y) with sample set pattern_index(X, Y)).
pub fn estimate_cpu(family: Family, gb: &GBuffer, params: &SsaoUniforms, table: &[[f32; 4]]) -> Vec<f32> {
    match family {
        Family::Points => ssao_points(gb, params, table),
        Family::March => ssao_march(gb, params, table),
        Family::Disk => ssao_disk(gb, params, table),
    }
}

/// `f(x, y, base)` per grid cell: its pixel and its set's first table entry.
fn per_cell(params: &SsaoUniforms, f: impl Fn(u32, u32, usize) -> f32 + Sync) -> Vec<f32> {
    let (w, scale) = (params.lo_width, params.scale);
    (0..params.cells() as u32)
        .into_par_iter()
        .with_min_len(64)
        .map(|i| {
            let (cx, cy) = (i % w, i / w);
            let base = (params.pattern_index(cx, cy) * params.samples) as usize;
            f(cx * scale, cy * scale, base)
        })
        .collect()
}

/// CPU twin of `ssao_points`: O = sum_j w_j v(s + R (T q.x + B q.y + N q.z)).
pub fn ssao_points(gb: &GBuffer, params: &SsaoUniforms, table: &[[f32; 4]]) -> Vec<f32> {
    let sc = params.screen();
    per_cell(params, |x, y, base| {
        let Some((s, n)) = shaded_point(gb, &sc, x, y) else {
            return 1.0;
        };
        let h = HomogeneousFrame::new(&sc, params.radius, s, n);
        let mut sum = 0.0f32;
        for q in &table[base..base + params.samples as usize] {
            if !occluded_homogeneous(gb, &sc, params.bias, h.sample(q)) {
                sum += q[3];
            }
        }
        sum
    })
}

/// CPU twin of `ssao_march`: each ray is worth m(rho_k) / N at its first
/// occluded step, 1 / N if none.
pub fn ssao_march(gb: &GBuffer, params: &SsaoUniforms, table: &[[f32; 4]]) -> Vec<f32> {
    let sc = params.screen();
    per_cell(params, |x, y, base| {
        let Some((s, n)) = shaded_point(gb, &sc, x, y) else {
            return 1.0;
        };
        let h = HomogeneousFrame::new(&sc, params.radius, s, n);
        let mut sum = 0.0f32;
        for ray in 0..params.rays as usize {
            let mut value = params.open_weight;
            for k in 0..params.steps as usize {
                let q = &table[base + ray * params.steps as usize + k];
                if occluded_homogeneous(gb, &sc, params.bias, h.sample(q)) {
                    value = q[3];
                    break;
                }
            }
            sum += value;
        }
        sum
    })
}

/// h of section 4.5 for mu = (r/R)^4, in units of R, over the pipe interval
/// [t0, t1] (t = (z - s.z) / R), times 1/R^2.
///
/// Derivation (the formula the text conversion lost). In a pipe at disk
/// offset (x, y), the point o = s + (x, y, t) has r^2 = x^2 + y^2 + t^2 and
/// (o - s) . N = a + N.z t with a = x N.x + y N.y. For mu = (r/R)^4,
/// dmu/dr = 4 r^3 / R^4, so the integrand of h,
///   (dmu/dr) (1/r^2) ((o - s) . N) / r = (4 / R^4) (a + N.z t),
/// is linear in t and
///   h = (4 / R^4) [a (t1 - t0) + N.z (t1^2 - t0^2) / 2].
/// With lengths in units of R this is (1/R^2) times
///   4 [a (t1 - t0) + N.z (t1^2 - t0^2) / 2],
/// and the disk quadrature O = (1/pi) int_C h dx dy ~ (R^2 / n) sum h_i
/// becomes the R-free (1/n) sum of the bracket. Check: with nothing in the
/// way the pipes fill the half ball, and (1/pi)(4/R^4) int (p.N) dV =
/// (4/(pi R^4)) int_0^R h pi (R^2 - h^2) dh = 1.
#[inline]
pub fn pipe_integral(a: f32, nz: f32, t0: f32, t1: f32) -> f32 {
    4.0 * (a * (t1 - t0) + 0.5 * nz * (t1 * t1 - t0 * t0))
}

/// CPU twin of `ssao_disk` (section 4.5). For each disk point (x, y) (units
/// of R) the pipe parallel to the view axis is cut to
/// * the sphere: |t| <= sqrt(1 - x^2 - y^2);
/// * the tangent plane's front: a + N.z t >= 0;
/// * the front of the depth buffer: z <= d (1 + bias), d read at the pixel
///   of (s.x + R x, s.y + R y, s.z) (the quasi-orthogonal approximation of
///   section 3.1: within the neighbourhood view rays are taken parallel
///   to z);
///
/// and contributes w h. Calibrated, the sum is divided by the same sum
/// without the depth cut (the pixel's open value).
pub fn ssao_disk(gb: &GBuffer, params: &SsaoUniforms, table: &[[f32; 4]]) -> Vec<f32> {
    let sc = params.screen();
    per_cell(params, |x, y, base| {
        let Some((s, n)) = shaded_point(gb, &sc, x, y) else {
            return 1.0;
        };
        // Disk point (x, y) projects to (fx0 + ax x, fy0 + ay y): the disk
        // is at the shaded depth (see `ScreenConstants::homogeneous`).
        let hs = sc.homogeneous(s);
        let inv_z = 1.0 / hs.z;
        let (fx0, fy0) = (hs.x * inv_z, hs.y * inv_z);
        let ax = sc.homogeneous(Vec3::new(params.radius, 0.0, 0.0)).x * inv_z;
        let ay = sc.homogeneous(Vec3::new(0.0, params.radius, 0.0)).y * inv_z;
        let (inv_r, inv_nz) = (1.0 / params.radius, 1.0 / n.z);
        let (w, h) = (sc.width as f32, sc.height as f32);
        let (mut sum, mut open) = (0.0f32, 0.0f32);
        for q in &table[base..base + params.samples as usize] {
            let w2 = 1.0 - q[0] * q[0] - q[1] * q[1];
            if w2.is_nan() || w2 <= 0.0 {
                continue;
            }
            let hw = w2.sqrt();
            let a = q[0] * n.x + q[1] * n.y;
            let (mut t0, mut t1) = (-hw, hw);
            if n.z < 0.0 {
                t1 = t1.min(-a * inv_nz);
            } else if n.z > 0.0 {
                t0 = t0.max(-a * inv_nz);
            } else if a < 0.0 {
                t1 = t0;
            }
            if t1 > t0 {
                open += q[3] * pipe_integral(a, n.z, t0, t1);
            }
            let (fx, fy) = (fx0 + ax * q[0], fy0 + ay * q[1]);
            if fx >= 0.0 && fx < w && fy >= 0.0 && fy < h {
                let d = gb.geometry[(fy as u32 * sc.width + fx as u32) as usize][3];
                if valid_depth(d) {
                    t1 = t1.min((d + params.bias * d - s.z) * inv_r);
                }
            }
            if t1 > t0 {
                sum += q[3] * pipe_integral(a, n.z, t0, t1);
            }
        }
        if params.calibrate != 0 {
            if open > 0.0 { sum / open } else { 1.0 }
        } else {
            sum
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ssao::Measure;

    fn settings(e: Estimator, m: Measure) -> SsaoSettings {
        let mut s = SsaoSettings::new(e, 16, 1.0);
        s.measure = m;
        s.calibrate = false;
        s
    }

    /// A volume estimator's sets carry no weight once the exponential
    /// measure's weight lies closer to the point than its samples reach
    /// (sigma R 1000: e^-(sigma r) underflows f32 beyond r = R / 11), and
    /// carry it at the default sigma R 3; importance sampling never loses it.
    #[test]
    fn weightless_sets_are_counted_where_the_measure_outruns_the_samples() {
        for calibrate in [true, false] {
            for e in [
                Estimator::Sphere,
                Estimator::Hemisphere,
                Estimator::TangentSphere,
                Estimator::Importance,
            ] {
                let count = |sigma: f32| {
                    let mut s = settings(e, Measure::Exp { sigma });
                    s.calibrate = calibrate;
                    let t = SampleTable::build(&s).unwrap();
                    (t.weightless_sets, t.patterns.count())
                };
                let (at_default, _) = count(3.0);
                let (far, sets) = count(1000.0);
                println!(
                    "{} calibrate {calibrate}: sigma R 3 -> {at_default}, 1000 -> {far} of {sets}",
                    e.name()
                );
                assert_eq!(at_default, 0, "{}", e.name());
                let expected = if e.needs_density() { sets } else { 0 };
                // One tangent-sphere set of 16 may hold a point close enough.
                assert!(far + 1 >= expected && far <= expected, "{}: {far} of {sets}", e.name());
            }
        }
    }

    /// Without calibration, each estimator's weights average to 1 over many
    /// sets (the open-point value is unbiased).
    #[test]
    fn open_point_weights_are_unbiased() {
        for e in [
            Estimator::Sphere,
            Estimator::Hemisphere,
            Estimator::Importance,
            Estimator::TangentSphere,
        ] {
            for m in [Measure::Poly4, Measure::Exp { sigma: 2.0 }] {
                let mut s = settings(e, m);
                s.interleave = false;
                s.spp = 256;
                let t = SampleTable::build(&s).unwrap();
                let sets = t.patterns.count() as f64;
                let mean: f64 = t.entries.iter().map(|q| q[3] as f64).sum::<f64>() / sets;
                // exp's 1/r^2 weights near r = 0 are heavy-tailed: looser.
                let tol = if matches!(m, Measure::Exp { .. }) && e != Estimator::Importance {
                    0.05
                } else {
                    0.01
                };
                assert!((mean - 1.0).abs() < tol, "{} {m:?}: {mean}", e.name());
            }
        }
    }

    #[test]
    fn open_disk_pipes_integrate_to_one() {
        // The mean of h over the disk for several normals: 1.
        let s = SsaoSettings {
            spp: 4096,
            interleave: true,
            ..settings(Estimator::BaseDisk, Measure::Poly4)
        };
        let t = SampleTable::build(&s).unwrap();
        for n in [
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.6, 0.0, -0.8),
            Vec3::new(0.0, -0.96, -0.28),
        ] {
            let mut sum = 0.0f64;
            for q in &t.entries[..4096] {
                let w2 = 1.0 - q[0] * q[0] - q[1] * q[1];
                let hw = w2.max(0.0).sqrt();
                let a = q[0] * n.x + q[1] * n.y;
                let t1 = hw.min(-a / n.z);
                if t1 > -hw {
                    sum += pipe_integral(a, n.z, -hw, t1) as f64 / 4096.0;
                }
            }
            assert!((sum - 1.0).abs() < 0.01, "{n}: {sum}");
        }
    }

    #[test]
    fn calibrated_sets_sum_to_one() {
        for e in [Estimator::Sphere, Estimator::Hemisphere, Estimator::TangentSphere] {
            let mut s = settings(e, Measure::Poly4);
            s.calibrate = true;
            let t = SampleTable::build(&s).unwrap();
            for set in t.entries.chunks(16) {
                let sum: f32 = set.iter().map(|q| q[3]).sum();
                assert!((sum - 1.0).abs() < 1e-5, "{}: {sum}", e.name());
            }
        }
    }

    #[test]
    fn samples_lie_where_the_estimator_says() {
        for e in Estimator::ALL {
            let s = settings(e, Measure::Poly4);
            let t = SampleTable::build(&s).unwrap();
            for q in &t.entries {
                let p = Vec3::new(q[0], q[1], q[2]);
                assert!(q.iter().all(|c| c.is_finite()), "{}", e.name());
                assert!(p.length() <= 1.0 + 1e-5, "{}: {p}", e.name());
                match e {
                    Estimator::Hemisphere | Estimator::Importance | Estimator::Raymarch => assert!(p.z >= 0.0),
                    Estimator::TangentSphere => assert!((p - Vec3::new(0.0, 0.0, 0.5)).length() <= 0.5 + 1e-5),
                    _ => {}
                }
            }
        }
    }
}
