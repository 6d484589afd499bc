//! The Whitted ray tracer's speed by kind of ray, in one command:
//!
//! ```sh
//! PENUMBRA_DATA=../shared/data cargo bench --bench whitted_table
//! ```
//!
//! For every shipped scene (`assets/raytrace/NAME.json`, its own camera) and
//! `$PENUMBRA_DATA/scenes/CornellBox-Original.obj` (when `PENUMBRA_DATA` is
//! set), at 512x512, 1 sample per pixel, on the CPU with 1 thread (MLRTA
//! packets off and on), with 2 threads (packets on), and on the GPU adapter
//! if there is one, it times three renders, each the best of `REPEAT`:
//! A (no lights, max depth 0: primary rays), B (the lights, max depth 0:
//! primary and shadow rays) and C (max depth 5: the whole render), and
//! derives each kind's rate from the differences (see the file's header).
//! Writes `assets/figures/whitted-speed.md` and prints it.
//!
//! `WHITTED_TABLE_QUICK=1`: 128x128, one repeat, written to
//! `target/whitted-speed-quick.md` instead (tests the script).

mod common;

use common::raytrace::{BenchScene, load_scenes};
use std::fmt::Write as _;
use std::path::PathBuf;

use penumbra::gpu::GpuContext;
use penumbra::gpu::device::{Device, Timing};
use penumbra::progress::{Bar, Reporter};
use penumbra::scene::Camera;
use penumbra::whitted::{LightingSettings, Packets, RayCounts, RenderScene, WhittedRenderer, WhittedSettings};
use rayon::ThreadPool;

/// Renders per measurement (the fastest is kept).
const REPEAT: usize = 5;
/// Side of the images.
const SIZE: u32 = 512;
/// Max depth of the whole render (C).
const FULL_DEPTH: u32 = 5;

/// The scene's renderer on `device`, with its lights or without any.
fn renderer(device: &Device, s: &BenchScene, lights: bool) -> penumbra::Result<WhittedRenderer> {
    let mut scene = RenderScene::new(&s.scene, 0, &LightingSettings::default())?;
    if !lights {
        scene.lights.clear();
    }
    WhittedRenderer::new(device, scene, &Reporter::silent())
}

/// Where renders run.
#[derive(Clone, Copy)]
enum Config<'a> {
    Cpu {
        pool: &'a ThreadPool,
        threads: usize,
        packets: bool,
    },
    Gpu {
        name: &'a str,
    },
}

impl Config<'_> {
    fn label(&self) -> String {
        match self {
            Config::Cpu { threads, packets, .. } => format!(
                "CPU, {threads} thread{}, {}",
                if *threads == 1 { "" } else { "s" },
                if *packets { "packets" } else { "single rays" }
            ),
            Config::Gpu { name } => format!("GPU: {name}"),
        }
    }
}

/// The best of `repeat` renders.
struct Measured {
    ms: f64,
    rays: RayCounts,
    timing: Timing,
}

fn measure(
    renderer: &mut WhittedRenderer,
    config: &Config<'_>,
    camera: &Camera,
    size: u32,
    max_depth: u32,
    repeat: usize,
) -> penumbra::Result<Measured> {
    let progress = Bar::hidden();
    let render = |renderer: &mut WhittedRenderer| {
        let settings = WhittedSettings {
            max_depth,
            packets: match config {
                Config::Cpu { packets: false, .. } => Packets::Off,
                _ => Packets::On,
            },
            ..WhittedSettings::default()
        };
        match config {
            Config::Cpu { pool, .. } => pool.install(|| renderer.render(camera, size, size, &settings, &progress)),
            Config::Gpu { .. } => renderer.render(camera, size, size, &settings, &progress),
        }
    };
    if matches!(config, Config::Gpu { .. }) {
        // Pipeline compilation and first-use costs out of the times.
        render(renderer)?;
    }
    let mut best: Option<Measured> = None;
    for _ in 0..repeat {
        let r = render(renderer)?;
        if best.as_ref().is_none_or(|b| r.stats.render_ms < b.ms) {
            best = Some(Measured {
                ms: r.stats.render_ms,
                rays: r.stats.rays,
                timing: r.stats.timing,
            });
        }
    }
    Ok(best.expect("at least one repeat"))
}

/// One (scene, configuration): renders A, B and C.
struct Row {
    scene: String,
    config: String,
    /// CPU, 1 thread, single rays: the speedups' baseline.
    baseline: bool,
    a: Measured,
    b: Measured,
    c: Measured,
}

fn mrays(rays: u64, ms: f64) -> f64 {
    rays as f64 / (ms * 1e3)
}

/// A marginal rate, or "–" where the difference says nothing.
fn marginal(rays: u64, ms: f64) -> String {
    if rays == 0 || ms <= 0.0 {
        "–".to_string()
    } else {
        format!("{:.1}", mrays(rays, ms))
    }
}

fn main() {
    // `cargo bench` passes --bench; nothing else to parse.
    let quick = std::env::var_os("WHITTED_TABLE_QUICK").is_some();
    let size = if quick { 128 } else { SIZE };
    let repeat = if quick { 1 } else { REPEAT };
    let scenes = load_scenes();
    let pools: Vec<(usize, ThreadPool)> = [1, 2].into_iter().map(|n| (n, common::thread_pool(n))).collect();
    let mut cpu_configs = Vec::new();
    for (threads, pool) in &pools {
        for packets in [false, true] {
            // Packets off only with one thread: the packet speedup.
            if !packets && *threads != 1 {
                continue;
            }
            cpu_configs.push(Config::Cpu {
                pool,
                threads: *threads,
                packets,
            });
        }
    }
    let gpu = match GpuContext::headless() {
        Ok(ctx) => Some(ctx),
        Err(e) => {
            eprintln!("whitted_table: no GPU adapter ({e}); CPU rows only");
            None
        }
    };
    let gpu_name = gpu.as_ref().map(|ctx| ctx.name.clone());
    let gpu_device = gpu.map(Device::gpu);
    let cpu = Device::cpu();

    let mut rows = Vec::new();
    for s in &scenes {
        let mut devices: Vec<(&Device, Vec<Config<'_>>)> = Vec::new();
        devices.push((&cpu, cpu_configs.clone()));
        if let (Some(device), Some(name)) = (&gpu_device, &gpu_name) {
            devices.push((device, vec![Config::Gpu { name }]));
        }
        for (device, configs) in devices {
            let built = renderer(device, s, false).and_then(|a| Ok((a, renderer(device, s, true)?)));
            let (mut dark, mut lit) = match built {
                Ok(r) => r,
                Err(e) => {
                    eprintln!("{} on {}: skipped ({e})", s.name, device.kind());
                    continue;
                }
            };
            for config in configs {
                let label = config.label();
                let mut run = || -> penumbra::Result<Row> {
                    let a = measure(&mut dark, &config, &s.camera, size, 0, repeat)?;
                    let b = measure(&mut lit, &config, &s.camera, size, 0, repeat)?;
                    let c = measure(&mut lit, &config, &s.camera, size, FULL_DEPTH, repeat)?;
                    Ok(Row {
                        scene: s.name.clone(),
                        config: label.clone(),
                        baseline: matches!(
                            config,
                            Config::Cpu {
                                threads: 1,
                                packets: false,
                                ..
                            }
                        ),
                        a,
                        b,
                        c,
                    })
                };
                match run() {
                    Ok(row) => {
                        eprintln!(
                            "{} / {}: A {:.1} ms, B {:.1} ms, C {:.1} ms, {} rays",
                            row.scene,
                            row.config,
                            row.a.ms,
                            row.b.ms,
                            row.c.ms,
                            row.c.rays.total()
                        );
                        rows.push(row);
                    }
                    Err(e) => eprintln!("{} / {label}: skipped ({e})", s.name),
                }
            }
        }
    }

    let md = table(&rows, size, repeat, gpu_name.as_deref());
    println!("{md}");
    let out = if quick {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/whitted-speed-quick.md")
    } else {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../assets/figures/whitted-speed.md")
    };
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir).expect("creating the output folder");
    }
    std::fs::write(&out, &md).unwrap_or_else(|e| panic!("writing {}: {e}", out.display()));
    eprintln!("wrote {}", out.display());
}

fn table(rows: &[Row], size: u32, repeat: usize, gpu: Option<&str>) -> String {
    let mut md = String::new();
    let command = if size == SIZE {
        "PENUMBRA_DATA=../shared/data cargo bench --bench whitted_table".to_string()
    } else {
        "WHITTED_TABLE_QUICK=1 PENUMBRA_DATA=../shared/data cargo bench --bench whitted_table".to_string()
    };
    writeln!(md, "### Whitted ray tracing speed by kind of ray\n").unwrap();
    writeln!(
        md,
        "Generated by `{command}` on {} (CPU rows: rayon pools of 1 and 2 threads){}. \
         {size}x{size} pixels, 1 sample per pixel, constant reflection/transmission coefficients \
         (no Fresnel); every time is the fastest of {repeat} render{}{}.\n",
        common::machine(),
        match gpu {
            Some(name) => format!("; GPU rows: {name}"),
            None => "; no GPU adapter".to_string(),
        },
        if repeat == 1 { "" } else { "s" },
        if gpu.is_some() {
            " (on the GPU after one untimed render, so pipeline compilation is not counted)"
        } else {
            ""
        }
    )
    .unwrap();
    writeln!(
        md,
        "Each scene and configuration is rendered three ways: **A** without lights and at max depth 0 \
         (primary rays only), **B** with the scene's lights at max depth 0 (primary rays and their \
         shadow rays), and **C** the whole render at max depth {FULL_DEPTH} (plus reflection and \
         refraction rays and their shadow rays). The primary rate is A's primary rays over A's time. \
         The other two rates are marginal, by difference: shadow = B's shadow rays / (time B − time A), \
         secondary = (rays C − rays B) / (time C − time B), where rays C − rays B are the reflection \
         and refraction rays and the shadow rays from their hits. A marginal rate charges each ray \
         with the shading work it brings (light loops, Phong terms, mixing), not the \
         traversal alone; it is \"–\" where the difference of times is not positive or there are no \
         such rays. The whole rate is all of C's rays over C's time. On the CPU the time of a render \
         includes, with packets, preparing the MLRTA packets' occluder data; on the GPU it is the \
         kernels' time from timestamp queries where the adapter has them, else wall time (dispatch, \
         kernels and read-back); the timing column says which. Speedup: the time of C on CPU with 1 \
         thread and single rays over this row's time of C.\n"
    )
    .unwrap();
    writeln!(
        md,
        "| scene | device | pixels | primary | shadow | reflection | refraction | total | time C (ms) | \
         primary Mrays/s | shadow Mrays/s | secondary Mrays/s | whole Mrays/s | speedup | timing |"
    )
    .unwrap();
    writeln!(
        md,
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"
    )
    .unwrap();
    for r in rows {
        let baseline = rows.iter().find(|b| b.scene == r.scene && b.baseline).map(|b| b.c.ms);
        let rc = r.c.rays;
        let primary = if r.a.ms > 0.0 {
            format!("{:.2}", mrays(r.a.rays.primary, r.a.ms))
        } else {
            "–".to_string()
        };
        let whole = if r.c.ms > 0.0 {
            format!("{:.2}", mrays(rc.total(), r.c.ms))
        } else {
            "–".to_string()
        };
        let speedup = match baseline {
            Some(ms) if r.c.ms > 0.0 => format!("{:.2}x", ms / r.c.ms),
            _ => "–".to_string(),
        };
        let timing = match (r.a.timing, r.b.timing, r.c.timing) {
            (Timing::GpuTimestamps, Timing::GpuTimestamps, Timing::GpuTimestamps) => "kernels",
            (Timing::Wall, Timing::Wall, Timing::Wall) => "wall",
            _ => "mixed",
        };
        writeln!(
            md,
            "| {} | {} | {size}x{size} | {} | {} | {} | {} | {} | {:.1} | {primary} | {} | {} | {whole} | {speedup} | {timing} |",
            r.scene,
            r.config,
            rc.primary,
            rc.shadow,
            rc.reflection,
            rc.refraction,
            rc.total(),
            r.c.ms,
            marginal(r.b.rays.shadow, r.b.ms - r.a.ms),
            marginal(rc.total().saturating_sub(r.b.rays.total()), r.c.ms - r.b.ms),
        )
        .unwrap();
    }
    md
}
