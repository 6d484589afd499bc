//! What the estimators are measured against.
//!
//! * `raytraced`: world-space ambient occlusion of the same fuzzy measure at
//!   the G-buffer's points, O = (1/pi) int mu(D(w)) cos+ dw with D the
//!   distance to the first surface of the whole scene (kd-tree closest hit,
//!   limited to R: farther is mu = 1). Directions are cosine-distributed, so
//!   O is the mean of mu(D). It sees what screen space cannot: surfaces
//!   hidden from the camera, outside the image, behind the first layer.
//! * `screen_reference`: the integral every screen-space estimator targets,
//!   equation (1) with the depth-buffer visibility v of `estimators::occluded`,
//!   by dense quadrature: importance sampling (section 4.3's density, exact
//!   for the integrand without v) with K stratified samples per pixel of an
//!   independent Owen-scrambled Sobol stream. The difference between an
//!   estimator and it is the estimator's own error (noise, and for
//!   tangent-sphere and base-disk their approximations).
//!
//! Both are computed as two halves with independent seeds, so their own
//! noise can be reported: for independent halves A and B of equal size, the
//! average (A + B)/2 has a per-pixel standard deviation of about
//! rms(A - B) / 2 (`Estimate::noise_rms`).

use crate::progress::Bar;
use glam::Vec3;
use rayon::prelude::*;

use super::estimators::{occluded, shaded_point};
use super::gbuffer::{GBuffer, ScreenView, world_point};
use super::{Measure, SsaoSettings};
use crate::accel::{Accel, Structure};
use crate::geom::sampling::{Frame, SampleSequence, cosine_hemisphere};
use crate::gpu::device::elapsed_ms;
use crate::scene::{Camera, ORIGIN_OFFSET};

/// Per-pixel values (1 on background) and their estimated noise.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Estimate {
    /// Per pixel, row-major: the mean of the two halves; 1 on the background.
    #[serde(skip)]
    pub values: Vec<f32>,
    /// RMS over surface pixels of the estimated standard deviation of each value.
    pub noise_rms: f64,
    /// Samples per pixel used.
    pub samples: u32,
    /// Wall-clock milliseconds of the whole estimate, both halves (CPU).
    pub ms: f64,
}

/// The two halves' size and independent sequences for `samples` per
/// pixel: one definition, so a sample of pixels (`raytraced_at`) traces
/// exactly the rays the full image (`halves`) does.
fn halves_of(samples: u32, seed: u32) -> (u32, [SampleSequence; 2]) {
    let half = (samples / 2).max(1);
    (
        half,
        [SampleSequence::new(seed), SampleSequence::new(seed ^ 0x6a09_e667)],
    )
}

/// `progress` advances by one per pixel.
fn halves(
    gb: &GBuffer,
    (samples, seed): (u32, u32),
    progress: &Bar,
    f: impl Fn(u32, u32, &SampleSequence, u32) -> f32 + Sync,
) -> Estimate {
    let start = std::time::Instant::now();
    let (half, seqs) = halves_of(samples, seed);
    let w = gb.width;
    let pairs: Vec<(f32, f32)> = (0..gb.pixels() as u32)
        .into_par_iter()
        .with_min_len(16)
        .map(|i| {
            progress.inc(1);
            if !gb.is_surface(i as usize) {
                return (1.0, 1.0);
            }
            (f(i % w, i / w, &seqs[0], half), f(i % w, i / w, &seqs[1], half))
        })
        .collect();
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (i, (a, b)) in pairs.iter().enumerate() {
        if gb.is_surface(i) {
            let d = (*a - *b) as f64;
            sum += d * d;
            n += 1;
        }
    }
    Estimate {
        values: pairs.iter().map(|(a, b)| 0.5 * (a + b)).collect(),
        noise_rms: if n == 0 { 0.0 } else { 0.5 * (sum / n as f64).sqrt() },
        samples: 2 * half,
        ms: elapsed_ms(start),
    }
}

/// World-space ray-traced AO at the G-buffer's points with `rays` rays per
/// pixel. `accel` holds every occluder of the scene; origins are offset by
/// 1e-4 of the scene diagonal along the normal, as for `ao`.
#[allow(clippy::too_many_arguments)]
pub fn raytraced(
    accel: &Accel,
    camera: &Camera,
    view: &ScreenView,
    gb: &GBuffer,
    measure: Measure,
    radius: f32,
    (rays, seed): (u32, u32),
    progress: &Bar,
) -> Estimate {
    let traced = Traced::new(accel, camera, view, gb, measure, radius);
    halves(gb, (rays, seed), progress, |x, y, seq, n| traced.at(x, y, seq, n))
}

/// `raytraced`'s values at the pixels `pixels` only (indices y * width + x):
/// the same rays, so the same values as the full image has there (the
/// sample `ssao --max-error` estimates the full error from).
#[allow(clippy::too_many_arguments)]
pub fn raytraced_at(
    accel: &Accel,
    camera: &Camera,
    view: &ScreenView,
    gb: &GBuffer,
    measure: Measure,
    radius: f32,
    rays: u32,
    seed: u32,
    pixels: &[u32],
) -> Vec<f32> {
    let traced = Traced::new(accel, camera, view, gb, measure, radius);
    let (half, seqs) = halves_of(rays, seed);
    let w = gb.width;
    pixels
        .par_iter()
        .map(|&i| {
            if !gb.is_surface(i as usize) {
                return 1.0;
            }
            let (x, y) = (i % w, i / w);
            0.5 * (traced.at(x, y, &seqs[0], half) + traced.at(x, y, &seqs[1], half))
        })
        .collect()
}

/// Ray-traced AO at one G-buffer point.
struct Traced<'a> {
    accel: &'a Accel,
    camera: &'a Camera,
    sc: super::gbuffer::ScreenConstants,
    gb: &'a GBuffer,
    measure: Measure,
    radius: f32,
    offset: f32,
}

impl<'a> Traced<'a> {
    fn new(
        accel: &'a Accel,
        camera: &'a Camera,
        view: &ScreenView,
        gb: &'a GBuffer,
        measure: Measure,
        radius: f32,
    ) -> Self {
        Traced {
            accel,
            camera,
            sc: view.constants(),
            gb,
            measure,
            radius,
            offset: ORIGIN_OFFSET * accel.kdtree().bounds.diagonal(),
        }
    }

    /// The mean of mu over `n` cosine-distributed rays of `seq` at (x, y).
    fn at(&self, x: u32, y: u32, seq: &SampleSequence, n: u32) -> f32 {
        let (p, normal) = world_point(self.camera, &self.sc, self.gb, x, y);
        if normal == Vec3::ZERO {
            return 1.0;
        }
        let frame = Frame::from_normal(normal);
        let origin = p + self.offset * normal;
        let stream = seq.stream(y * self.gb.width + x);
        let mut sum = 0.0f64;
        for j in 0..n {
            let [u, v] = stream.sample(j);
            let d = frame.to_world(cosine_hemisphere(u, v));
            // Through the wide BVH: the kd-tree's hit, twice as fast.
            let hit = self.accel.closest_hit(Structure::Bvh, origin, d, self.radius);
            let dist = if hit.is_hit() { hit.t } else { f32::INFINITY };
            sum += self.measure.mu(dist, self.radius) as f64;
        }
        (sum / n as f64) as f32
    }
}

/// Dense quadrature of equation (1) over the depth buffer with `samples`
/// points per pixel.
pub fn screen_reference(
    gb: &GBuffer,
    view: &ScreenView,
    settings: &SsaoSettings,
    samples: u32,
    progress: &Bar,
) -> Estimate {
    let sc = view.constants();
    let bias = settings.bias_px * 2.0 * view.tan_half_y / view.height as f32;
    let (measure, radius) = (settings.measure, settings.radius);
    halves(gb, (samples, settings.seed ^ 0x3c6e_f372), progress, |x, y, seq, n| {
        let Some((s, normal)) = shaded_point(gb, &sc, x, y) else {
            return 1.0;
        };
        let f = Frame::from_normal(normal);
        let stream = y * gb.width + x;
        let mut open = 0u32;
        for j in 0..n {
            let [u, v] = seq.sample(stream, j);
            let rho = measure.inverse(seq.padded_1d(stream, j) as f64, radius) as f32;
            let p = s + radius * rho * f.to_world(cosine_hemisphere(u, v));
            if !occluded(gb, &sc, bias, p) {
                open += 1;
            }
        }
        open as f32 / n as f32
    })
}
