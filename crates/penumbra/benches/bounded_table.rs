//! What each epsilon of the bounded-error ray tracer buys, in one command:
//!
//! ```sh
//! PENUMBRA_DATA=../shared/data cargo bench --bench bounded_table
//! ```
//!
//! For `checker-spheres`, `cornell-mirror-glass` and
//! `checker-spheres-tessellated` (`assets/raytrace/NAME.json`, their own
//! cameras) and `$PENUMBRA_DATA/scenes/CornellBox-Original.obj` (when
//! `PENUMBRA_DATA` is set), on the CPU with rayon pools of 1 and 2 threads:
//! the exact Whitted render of the `FRAMES` frames of the built-in camera walk
//! (`CameraPath::Walk`, what `penumbra raytrace --method bounded --frames N`
//! takes without `--path`) at `WIDTH`x`HEIGHT`, then for every epsilon of
//! `EPSILONS` a fresh `BoundedRenderer` (default settings but epsilon) over
//! the same frames, each frame compared with the exact one
//! (`bounded::measure::compare`). Times are sums over the frames (no
//! repeats). Writes `assets/figures/bounded-epsilon.md` (also printed) and
//! `assets/figures/bounded-epsilon.png` (maximum relative error against
//! time).
//!
//! `BOUNDED_TABLE_QUICK=1`: 160x120, 4 frames, epsilons 0.01 and 0.2,
//! 1 thread, written to `target/bounded-epsilon-quick.md` and
//! `target/bounded-epsilon-quick.png` instead (tests the script).

mod common;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use common::plot::{CHAR_WIDTH, Rgb, dashed, line, square, text, text_width};
use common::raytrace::{BenchScene, load_scenes};
use glam::Vec3;
use penumbra::bounded::measure::compare;
use penumbra::bounded::{BoundedRenderer, BoundedSettings, FrameStats};
use penumbra::gpu::device::Device;
use penumbra::progress::{Bar, Reporter};
use penumbra::scene::CameraPath;
use penumbra::whitted::{LightingSettings, Packets, RenderScene, WhittedRenderer, WhittedSettings};
use rayon::ThreadPool;

/// The scenes, in table order (those not loaded are left out).
const SCENES: [&str; 4] = [
    "checker-spheres",
    "cornell-mirror-glass",
    "checker-spheres-tessellated",
    "CornellBox-Original",
];
const WIDTH: u32 = 640;
const HEIGHT: u32 = 480;
const FRAMES: u32 = 30;
const EPSILONS: [f32; 5] = [0.001, 0.01, 0.05, 0.2, 0.5];
const THREADS: [usize; 2] = [1, 2];
/// The epsilon of the cost-per-pixel line (1 thread); where the run does
/// not have it (quick mode), the nearest one it has.
const COST_EPSILON: f32 = 0.05;

/// What one run measures, and where it writes.
struct Mode {
    quick: bool,
    width: u32,
    height: u32,
    frames: u32,
    epsilons: Vec<f32>,
    threads: Vec<usize>,
    md: PathBuf,
    png: PathBuf,
}

impl Mode {
    fn from_env() -> Mode {
        let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
        if std::env::var_os("BOUNDED_TABLE_QUICK").is_some() {
            Mode {
                quick: true,
                width: 160,
                height: 120,
                frames: 4,
                epsilons: vec![0.01, 0.2],
                threads: vec![1],
                md: root.join("target/bounded-epsilon-quick.md"),
                png: root.join("target/bounded-epsilon-quick.png"),
            }
        } else {
            Mode {
                quick: false,
                width: WIDTH,
                height: HEIGHT,
                frames: FRAMES,
                epsilons: EPSILONS.to_vec(),
                threads: THREADS.to_vec(),
                md: root.join("assets/figures/bounded-epsilon.md"),
                png: root.join("assets/figures/bounded-epsilon.png"),
            }
        }
    }

    fn command(&self) -> String {
        let mut c = String::new();
        if self.quick {
            c.push_str("BOUNDED_TABLE_QUICK=1 ");
        }
        if std::env::var_os("PENUMBRA_DATA").is_some() {
            c.push_str("PENUMBRA_DATA=../shared/data ");
        }
        c.push_str("cargo bench --bench bounded_table");
        c
    }

    /// The epsilon of the cost line: `COST_EPSILON`, or the run's nearest
    /// (in ratio).
    fn cost_epsilon(&self) -> f32 {
        let d = |e: f32| (e / COST_EPSILON).ln().abs();
        self.epsilons
            .iter()
            .copied()
            .min_by(|a, b| d(*a).total_cmp(&d(*b)))
            .unwrap_or(COST_EPSILON)
    }
}

/// The exact Whitted frames of one (scene, threads), and the time of the
/// faster of the renderer's two CPU paths: on scenes of a few triangles
/// single rays beat the MLRTA packets (checker-spheres by 13%), and the
/// speed-up is measured against the best exact renderer.
struct Reference {
    ms: f64,
    /// Each path's time: packets on, off.
    ms_by_path: [f64; 2],
    /// Pixels where the two paths' frames differ (CornellBox-Original:
    /// a few, where packets and single rays meet different triangles at
    /// the box's edges); the packets' frames are the reference.
    paths_differ: usize,
    frames: Vec<Vec<Vec3>>,
}

/// Sums over the frames of one (scene, threads, epsilon).
#[derive(Default)]
struct Row {
    scene: String,
    threads: usize,
    epsilon: f32,
    bounded_ms: f64,
    exact_ms: f64,
    exact_ms_by_path: [f64; 2],
    exact_paths_differ: usize,
    /// Pixels by path, summed over the frames.
    reprojected: u64,
    span_filled: u64,
    interpolated: u64,
    background: u64,
    traced: u64,
    /// Traced pixels by the reason.
    traced_by: std::collections::BTreeMap<String, u64>,
    max_rel: f64,
    /// Mean over the frames of each frame's mean (over all pixels).
    mean_rel: f64,
    violations: u64,
    span_violations: u64,
    traced_differ: u64,
    memory_peak_bytes: usize,
    extremal_rays_requested: u64,
    extremal_rays_traced: u64,
    reproject_ms: f64,
    assign_ms: f64,
    build_ms: f64,
    trace_ms: f64,
    interpolate_ms: f64,
}

impl Row {
    fn add_frame(&mut self, s: &FrameStats) {
        self.bounded_ms += s.frame_ms;
        let p = &s.pixels;
        self.reprojected += p.reprojected;
        self.span_filled += p.span_filled;
        self.interpolated += p.interpolated;
        self.background += p.background;
        self.traced += p.traced;
        for (why, n) in &p.traced_by {
            *self.traced_by.entry(why.clone()).or_default() += n;
        }
        self.memory_peak_bytes = self.memory_peak_bytes.max(s.memory_peak_bytes);
        self.extremal_rays_requested += s.extremal_rays_requested;
        self.extremal_rays_traced += s.extremal_rays_traced;
        self.reproject_ms += s.reproject_ms;
        self.assign_ms += s.assign_ms;
        self.build_ms += s.build_ms;
        self.trace_ms += s.trace_ms;
        self.interpolate_ms += s.interpolate_ms;
    }

    /// Pixels that hit a surface.
    fn surfaces(&self) -> u64 {
        self.reprojected + self.span_filled + self.interpolated + self.traced
    }

    /// Share of the surface pixels not traced.
    fn success(&self) -> f64 {
        ratio(
            (self.reprojected + self.span_filled + self.interpolated) as f64,
            self.surfaces() as f64,
        )
    }

    /// Share of the surface pixels on the fast path (reprojected).
    fn fast(&self) -> f64 {
        ratio(self.reprojected as f64, self.surfaces() as f64)
    }

    fn speedup(&self) -> f64 {
        ratio(self.exact_ms, self.bounded_ms)
    }
}

fn ratio(a: f64, b: f64) -> f64 {
    if b > 0.0 { a / b } else { 0.0 }
}

/// A fresh renderer of the scene on the CPU (the CLI's default lighting).
fn whitted(device: &Device, s: &BenchScene) -> penumbra::Result<WhittedRenderer> {
    let scene = RenderScene::new(&s.scene, 0, &LightingSettings::default())?;
    WhittedRenderer::new(device, scene, &Reporter::silent())
}

fn reference(
    renderer: &mut WhittedRenderer,
    pool: &ThreadPool,
    path: &CameraPath,
    mode: &Mode,
) -> penumbra::Result<Reference> {
    let mut r = Reference {
        ms: 0.0,
        ms_by_path: [0.0; 2],
        paths_differ: 0,
        frames: Vec::new(),
    };
    for (k, packets) in [Packets::On, Packets::Off].into_iter().enumerate() {
        let settings = WhittedSettings {
            packets,
            ..BoundedSettings::default().whitted
        };
        for f in 0..mode.frames {
            let camera = path.at(f, mode.frames);
            let exact =
                pool.install(|| renderer.render(&camera, mode.width, mode.height, &settings, &Bar::hidden()))?;
            r.ms_by_path[k] += exact.stats.render_ms;
            let radiance = exact.radiance();
            match r.frames.get(f as usize) {
                None => r.frames.push(radiance),
                Some(first) => r.paths_differ += first.iter().zip(&radiance).filter(|(a, b)| a != b).count(),
            }
        }
    }
    r.ms = r.ms_by_path[0].min(r.ms_by_path[1]);
    Ok(r)
}

/// The bounded renderer at `epsilon` over the walk, against `exact`; gives
/// the Whitted renderer back.
fn bounded(
    whitted: WhittedRenderer,
    pool: &ThreadPool,
    path: &CameraPath,
    mode: &Mode,
    exact: &Reference,
    epsilon: f32,
) -> penumbra::Result<(Row, WhittedRenderer)> {
    let settings = BoundedSettings {
        epsilon,
        ..BoundedSettings::default()
    };
    let mut renderer = BoundedRenderer::new(whitted, settings)?;
    let mut row = Row {
        epsilon,
        exact_ms: exact.ms,
        exact_ms_by_path: exact.ms_by_path,
        exact_paths_differ: exact.paths_differ,
        ..Row::default()
    };
    let mut mean_sum = 0.0;
    for (f, reference) in (0..mode.frames).zip(&exact.frames) {
        let camera = path.at(f, mode.frames);
        let frame = pool.install(|| renderer.render(&camera, mode.width, mode.height))?;
        row.add_frame(&frame.stats);
        let e = compare(&frame, reference, settings.epsilon, settings.floor);
        row.max_rel = row.max_rel.max(e.max_rel);
        mean_sum += e.mean_rel;
        row.violations += e.violations;
        row.span_violations += e.span_violations;
        row.traced_differ += e.traced_differ;
    }
    row.mean_rel = mean_sum / exact.frames.len().max(1) as f64;
    Ok((row, renderer.whitted))
}

/// Every (threads, epsilon) row of one scene.
fn scene_rows(cpu: &Device, s: &BenchScene, pools: &[(usize, ThreadPool)], mode: &Mode) -> penumbra::Result<Vec<Row>> {
    let mut renderer = whitted(cpu, s)?;
    let path = CameraPath::Walk(s.camera);
    // One untimed frame: the CPU packet tables the Whitted renderer keeps
    // between renders are built here, not in the first pool's reference.
    let first = path.at(0, mode.frames);
    let settings = BoundedSettings::default().whitted;
    renderer.render(&first, mode.width, mode.height, &settings, &Bar::hidden())?;
    let mut rows = Vec::new();
    for (threads, pool) in pools {
        let exact = reference(&mut renderer, pool, &path, mode)?;
        eprintln!(
            "{} / {threads} thread(s): exact Whitted {:.0} ms for {} frames (packets {:.0}, single rays {:.0}, \
             {} pixels differ)",
            s.name, exact.ms, mode.frames, exact.ms_by_path[0], exact.ms_by_path[1], exact.paths_differ
        );
        for &epsilon in &mode.epsilons {
            let (mut row, back) = bounded(renderer, pool, &path, mode, &exact, epsilon)?;
            renderer = back;
            row.scene = s.name.clone();
            row.threads = *threads;
            eprintln!(
                "{} / {threads} thread(s) / epsilon {epsilon}: {:.0} ms ({:.2}x), success {:.1}%, \
                 fast path {:.1}%, max rel. error {:.2e}, {} violations, {} traced pixels differ from \
                 the reference; traced: {:?}",
                s.name,
                row.bounded_ms,
                row.speedup(),
                100.0 * row.success(),
                100.0 * row.fast(),
                row.max_rel,
                row.violations,
                row.traced_differ,
                row.traced_by
            );
            if row.violations > 0 {
                eprintln!(
                    "\n!!!!!!!! WARNING: {} / {threads} thread(s) / epsilon {epsilon}: {} interpolated \
                     pixels over the error bound (the guarantee is broken) !!!!!!!!\n",
                    s.name, row.violations
                );
            }
            rows.push(row);
        }
    }
    Ok(rows)
}

fn main() {
    // `cargo bench` passes --bench; nothing else to parse.
    let mode = Mode::from_env();
    let scenes: Vec<BenchScene> = {
        let mut all = load_scenes();
        SCENES
            .iter()
            .filter_map(|name| all.iter().position(|s| s.name == *name).map(|i| all.swap_remove(i)))
            .collect()
    };
    let pools: Vec<(usize, ThreadPool)> = mode.threads.iter().map(|&n| (n, common::thread_pool(n))).collect();
    let cpu = Device::cpu();
    let mut rows = Vec::new();
    for s in &scenes {
        match scene_rows(&cpu, s, &pools, &mode) {
            Ok(r) => rows.extend(r),
            Err(e) => eprintln!("{}: skipped ({e})", s.name),
        }
    }

    let scene_names: Vec<&str> = SCENES
        .iter()
        .copied()
        .filter(|n| rows.iter().any(|r| r.scene == *n))
        .collect();
    let md = table(&rows, &scene_names, &mode);
    println!("{md}");
    for out in [&mode.md, &mode.png] {
        if let Some(dir) = out.parent() {
            std::fs::create_dir_all(dir).expect("creating the output folder");
        }
    }
    std::fs::write(&mode.md, &md).unwrap_or_else(|e| panic!("writing {}: {e}", mode.md.display()));
    plot(&mode.png, &rows, &scene_names, &mode);
    eprintln!("wrote {} and {}", mode.md.display(), mode.png.display());
    let violations: u64 = rows.iter().map(|r| r.violations).sum();
    if violations > 0 {
        eprintln!("\n!!!!!!!! WARNING: {violations} pixels over the error bound in all (see above) !!!!!!!!");
    }
}

fn table(rows: &[Row], scenes: &[&str], mode: &Mode) -> String {
    let mut md = String::new();
    let (w, h, frames) = (mode.width, mode.height, mode.frames);
    let d = BoundedSettings::default();
    let threads: Vec<String> = mode.threads.iter().map(|t| t.to_string()).collect();
    writeln!(md, "### Bounded-error ray tracing: what each epsilon buys\n").unwrap();
    writeln!(
        md,
        "Generated by `{}` on {}, on the CPU with rayon pools of {} thread(s). {w}x{h} pixels, {frames} \
         frames of the built-in camera walk from each scene's camera (`CameraPath::Walk`, what \
         `penumbra raytrace --method bounded --frames {frames}` renders without `--path`), max depth {}, \
         1 sample per pixel, constant reflection/transmission coefficients (no Fresnel). Every \
         epsilon starts a fresh `BoundedRenderer` (no cells kept from another epsilon) with the \
         default settings but epsilon: floor {:.5} (1/255), {:?} bound, {:?} split, reprojection {}, \
         span filling {}, memory cap {} MiB, min. pixels {}. Times are sums over the {frames} frames, \
         each measured once: the bounded renderer's `frame_ms` (the whole frame, wall clock) and the \
         exact Whitted renderer's `render_ms`, the faster of its two CPU paths (primary and shadow \
         rays as MLRTA packets, or every ray alone: the same images but where noted, the packets' \
         the reference; both times listed; one untimed frame first).\n",
        mode.command(),
        common::machine(),
        threads.join(" and "),
        d.whitted.max_depth,
        d.floor,
        d.bound,
        d.split,
        if d.reproject { "on" } else { "off" },
        if d.span { "on" } else { "off" },
        d.memory_mb,
        d.min_pixels,
    )
    .unwrap();
    writeln!(
        md,
        "Columns: **speed-up** = exact ms / bounded ms. **success** = share of the pixels that hit a \
         surface (not background) that were not traced (reprojected or interpolated); **fast path** = \
         share of them reprojected from the previous frame's cells. **max / mean rel. error** = \
         `|L - L_exact| / max(L_exact, floor)`, largest channel, over all pixels of all frames (mean: \
         of the frames' means). **violations** = interpolated pixels over epsilon (the guarantee: \
         must be 0). **memory** = peak bytes of linetree cells and samples (MiB). **extremal rays** \
         = rays traced to build cells (requested ones shared with built cells are not traced again). \
         Phases (ms, summed): **reproject** (fast path), **assign** (every other pixel's primary ray \
         and its linetree leaf), **build** (extremal rays, predicates and splits), **trace** (the \
         slow path: the Whitted tracer from the known primary hit), **interpolate**.\n"
    )
    .unwrap();
    let cost_eps = mode.cost_epsilon();
    for scene in scenes {
        let of_scene: Vec<&Row> = rows.iter().filter(|r| r.scene == *scene).collect();
        writeln!(md, "#### {scene}\n").unwrap();
        let exact: Vec<String> = mode
            .threads
            .iter()
            .filter_map(|t| {
                of_scene.iter().find(|r| r.threads == *t).map(|r| {
                    let [on, off] = r.exact_ms_by_path;
                    let differ = match r.exact_paths_differ {
                        0 => String::new(),
                        n => format!(", {n} pixels of the walk differ between the two"),
                    };
                    format!(
                        "{:.0} ms with {t} thread(s) (packets {on:.0}, single rays {off:.0}{differ})",
                        r.exact_ms
                    )
                })
            })
            .collect();
        writeln!(md, "Exact Whitted, {frames} frames: {}.\n", exact.join(", ")).unwrap();
        writeln!(
            md,
            "| threads | epsilon | bounded ms | exact ms | speed-up | success | fast path | max rel. error | \
             mean rel. error | violations | memory MiB | extremal rays | reproject ms | assign ms | \
             build ms | trace ms | interpolate ms |"
        )
        .unwrap();
        writeln!(
            md,
            "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
        )
        .unwrap();
        for r in &of_scene {
            writeln!(
                md,
                "| {} | {} | {:.0} | {:.0} | {:.2}x | {:.1}% | {:.1}% | {} | {} | {}{} | {:.1} | {} | \
                 {:.0} | {:.0} | {:.0} | {:.0} | {:.0} |",
                r.threads,
                r.epsilon,
                r.bounded_ms,
                r.exact_ms,
                r.speedup(),
                100.0 * r.success(),
                100.0 * r.fast(),
                sci(r.max_rel),
                sci(r.mean_rel),
                r.violations,
                if r.violations > 0 { " **WARNING**" } else { "" },
                r.memory_peak_bytes as f64 / (1024.0 * 1024.0),
                r.extremal_rays_traced,
                r.reproject_ms,
                r.assign_ms,
                r.build_ms,
                r.trace_ms,
                r.interpolate_ms,
            )
            .unwrap();
        }
        if let Some(r) = of_scene.iter().find(|r| r.threads == 1 && r.epsilon == cost_eps) {
            writeln!(md, "\n{}", cost_line(r)).unwrap();
        }
        writeln!(md).unwrap();
    }
    writeln!(
        md,
        "Cost per pixel by path (the paper's Table 1), from the phase times of the 1-thread run: \
         **fast path** = (reproject ms + interpolate ms x reprojected / (reprojected + interpolated)) / \
         reprojected pixels, the interpolation charged to the two paths by their pixels (the renderer \
         times one interpolation pass over both); **interpolate** = (assign ms + build ms) / \
         interpolated pixels, where assign also casts the primary rays of the pixels that are then \
         traced or background and build also judges the cells that fail; **trace** = trace ms / \
         traced pixels, without the primary ray (cast in assign). Ratios are to the fast path.\n"
    )
    .unwrap();
    writeln!(
        md,
        "Plot: `{}` (maximum relative error, log scale, against the total time; one line per scene \
         and thread count through the epsilons, the first and last epsilon labelled; dashed \
         verticals: the exact Whitted time).",
        plot_name(mode)
    )
    .unwrap();
    md
}

/// `x` in 3 significant digits, exponent form; 0 as "0".
fn sci(x: f64) -> String {
    if x == 0.0 { "0".to_string() } else { format!("{x:.2e}") }
}

fn plot_name(mode: &Mode) -> String {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let root = root.as_path();
    mode.png.strip_prefix(root).unwrap_or(&mode.png).display().to_string()
}

/// The paper's Table 1 for one run: µs per pixel of each path.
fn cost_line(r: &Row) -> String {
    let us = |ms: f64, pixels: u64| (pixels > 0).then(|| 1e3 * ms / pixels as f64);
    let interp_share = ratio(r.reprojected as f64, (r.reprojected + r.interpolated) as f64);
    let fast = us(r.reproject_ms + r.interpolate_ms * interp_share, r.reprojected);
    let built = us(r.assign_ms + r.build_ms, r.interpolated);
    let traced = us(r.trace_ms, r.traced);
    let show = |v: Option<f64>| match (v, fast) {
        (Some(v), Some(f)) if f > 0.0 => format!("{v:.3} µs ({:.1}x)", v / f),
        (Some(v), _) => format!("{v:.3} µs"),
        (None, _) => "– (no such pixels)".to_string(),
    };
    format!(
        "Cost per pixel by path (epsilon {}, 1 thread): fast path {}, interpolate {}, trace {}.",
        r.epsilon,
        show(fast),
        show(built),
        show(traced)
    )
}

/// Colours of the scenes, in `SCENES` order.
const COLORS: [Rgb; 4] = [[230, 159, 0], [0, 114, 178], [0, 158, 115], [204, 121, 167]];

/// Maximum relative error (log) against total ms: per scene (colour) and
/// thread count (1: solid line, filled squares; 2: dashed, hollow), a
/// polyline through the epsilons, and the exact time as a dashed vertical.
fn plot(path: &Path, rows: &[Row], scenes: &[&str], mode: &Mode) {
    let (w, h) = (1000i32, 600i32);
    let (left, right, top, bottom) = (80i32, 280i32, 50i32, 60i32);
    let mut img = image::RgbImage::from_pixel(w as u32, h as u32, image::Rgb([255, 255, 255]));
    let black = [0, 0, 0];
    let grey = [200, 200, 200];
    let max_ms = rows.iter().flat_map(|r| [r.bounded_ms, r.exact_ms]).fold(1.0, f64::max);
    // Room on the right for the last points' labels.
    let max_ms = 1.08 * max_ms;
    let step = nice_step(max_ms / 5.0);
    let max_ms = (max_ms / step).ceil() * step;
    // Decades of the error axis; zero errors (nothing interpolated) on a
    // row labelled 0 one decade below the smallest.
    let positive = rows.iter().map(|r| r.max_rel).filter(|&e| e > 0.0);
    let lo = positive.clone().fold(f64::INFINITY, f64::min);
    let hi = positive.fold(0.0, f64::max);
    let (d0, d1) = if hi > 0.0 {
        let d0 = lo.log10().floor() as i32;
        (d0, (hi.log10().ceil() as i32).max(d0 + 1))
    } else {
        (-4, 0)
    };
    let zero_row = rows.iter().any(|r| r.max_rel <= 0.0);
    let d0 = if zero_row { d0 - 1 } else { d0 };
    let (px0, px1, py0, py1) = (left, w - right, h - bottom, top);
    let to_px = |ms: f64, e: f64| {
        let x = px0 + ((ms / max_ms) * (px1 - px0) as f64).round() as i32;
        let l = if e > 0.0 { e.log10() } else { d0 as f64 };
        let t = ((l - d0 as f64) / (d1 - d0) as f64).clamp(0.0, 1.0);
        (x, py0 - (t * (py0 - py1) as f64).round() as i32)
    };

    // Grid, axes, ticks and labels.
    for k in 0..=((max_ms / step).round() as i32) {
        let ms = step * k as f64;
        let (x, _) = to_px(ms, 0.0);
        if k > 0 {
            dashed(&mut img, (x, py0), (x, py1), grey, 1, 3);
        }
        line(&mut img, (x, py0), (x, py0 + 4), black);
        let label = format!("{ms:.0}");
        text(&mut img, x - text_width(&label) / 2, py0 + 9, &label, black);
    }
    for d in d0..=d1 {
        let (_, y) = to_px(0.0, 10f64.powi(d));
        if d > d0 {
            dashed(&mut img, (px0, y), (px1, y), grey, 1, 3);
        }
        line(&mut img, (px0 - 4, y), (px0, y), black);
        let label = match d {
            _ if zero_row && d == d0 => "0".to_string(),
            0 => "1".to_string(),
            _ => format!("1e{d}"),
        };
        text(&mut img, px0 - 8 - text_width(&label), y - 5, &label, black);
    }
    line(&mut img, (px0, py0), (px1, py0), black);
    line(&mut img, (px0, py0), (px0, py1), black);
    let xlabel = format!("total time of {} frames (ms)", mode.frames);
    text(
        &mut img,
        (px0 + px1 - text_width(&xlabel)) / 2,
        py0 + 32,
        &xlabel,
        black,
    );
    text(&mut img, px0 - 60, py1 - 30, "max relative error (log)", black);
    let title = format!("bounded-error vs exact whitted, {}x{}", mode.width, mode.height);
    text(&mut img, (px0 + px1 - text_width(&title)) / 2, 10, &title, black);

    // Exact times, then the polylines.
    for (k, scene) in scenes.iter().enumerate() {
        let colour = COLORS[SCENES.iter().position(|s| s == scene).unwrap_or(k) % COLORS.len()];
        for &threads in &mode.threads {
            let of: Vec<&Row> = rows
                .iter()
                .filter(|r| r.scene == *scene && r.threads == threads)
                .collect();
            let Some(first) = of.first() else { continue };
            let (x, _) = to_px(first.exact_ms, 1.0);
            let (on, off) = if threads == 1 { (8, 4) } else { (3, 4) };
            dashed(&mut img, (x, py0), (x, py1), colour, on, off);
            let filled = threads == 1;
            let pts: Vec<(i32, i32)> = of.iter().map(|r| to_px(r.bounded_ms, r.max_rel)).collect();
            for p in pts.windows(2) {
                if filled {
                    line(&mut img, p[0], p[1], colour);
                } else {
                    dashed(&mut img, p[0], p[1], colour, 5, 3);
                }
            }
            for &(x, y) in &pts {
                square(&mut img, x, y, 3, colour, filled);
            }
            // The first thread count's lines: their first and last epsilons.
            if Some(&threads) == mode.threads.first() {
                for r in [of.first(), of.last()].into_iter().flatten() {
                    let (x, y) = to_px(r.bounded_ms, r.max_rel);
                    text(&mut img, x + 6, y - 12, &r.epsilon.to_string(), colour);
                }
            }
        }
    }

    // Legend.
    let lx = px1 + 20;
    let mut ly = py1 + 4;
    for (k, scene) in scenes.iter().enumerate() {
        let colour = COLORS[SCENES.iter().position(|s| s == scene).unwrap_or(k) % COLORS.len()];
        square(&mut img, lx + 4, ly + 4, 4, colour, true);
        text(&mut img, lx + 16, ly, scene, black);
        ly += 20;
    }
    ly += 10;
    for &threads in &mode.threads {
        let filled = threads == 1;
        square(&mut img, lx + 4, ly + 4, 3, black, filled);
        let label = if filled {
            "1 thread".to_string()
        } else {
            format!("{threads} threads")
        };
        text(&mut img, lx + 16, ly, &label, black);
        ly += 20;
    }
    dashed(&mut img, (lx + 4, ly - 2), (lx + 4, ly + 12), black, 3, 2);
    text(&mut img, lx + 16, ly, "exact whitted", black);
    ly += 30;
    text(&mut img, lx, ly, "points: epsilons", black);
    text(&mut img, lx, ly + 2 * CHAR_WIDTH, "(ends labelled)", black);
    img.save(path)
        .unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
}

/// 1, 2 or 5 times a power of ten, at least `x`.
fn nice_step(x: f64) -> f64 {
    let p = 10f64.powf(x.max(1e-9).log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|&s| s >= x)
        .unwrap_or(10.0 * p)
}
