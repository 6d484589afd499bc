//! CPU against GPU on the user's scene (`penumbra bench`): each method at
//! its defaults (or the settings given) on each device and CPU thread
//! count, warm-up runs then measured ones (min / median / max of the
//! method's own timed work), what the first run cost apart from that work
//! (loading, building, the truth, pipeline compilation), the throughput
//! each method is judged by and its error against its truth where it has
//! one. The same seeds every run.
//!
//! The methods with a truth are driven through their sweeps (one setting,
//! `crate::sweep::with_method`), so a bench row's error is the sweep's;
//! ray-cast AO, random rays and Whitted are the references themselves and
//! report none. Like `crate::sweep`, this module sits above every method.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use crate::accel::Structure;
use crate::choice::Choice;
use crate::error::{Error, Result};
use crate::geom::ray::Ray;
use crate::gpu::device::{Device, elapsed_ms};
use crate::gpu::{AdapterKinds, AdapterSettings, GpuContext, enumerate_adapters};
use crate::progress::Reporter;
use crate::prt::hierarchy::NearField;
use crate::prt::probe::{Probe, probe as probe_prt};
use crate::prt::tune::PrtSweep;
use crate::raycast::tracer::Tracer;
use crate::raycast::{AmbientOcclusion, AoSettings};
use crate::report::repeats::{Repeats, RunTimes};
use crate::scene::{Mesh, load_input_in, load_mesh, load_shaded_input_in};
use crate::sweep::{SweepInputs, SweepKind, with_method};
use crate::tune::{Given, Knob, Setting};
use crate::whitted::{LightingSettings, RenderScene, WhittedRenderer, WhittedSettings};
use glam::Vec3;

/// The methods a bench runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum BenchMethod {
    /// Primary rays from the camera through MLRTA (error: hits that differ
    /// from single rays).
    Primary,
    /// Ray-cast AO at every vertex (the reference: no error).
    Ao,
    /// Random rays aimed at the mesh, closest hits (exact: no error).
    RandomRays,
    /// Displacement-field AO against ray casting.
    Field,
    /// Screen-space AO against ray-traced AO.
    Ssao,
    /// Precomputed radiance transfer against ray-traced transfer.
    Prt,
    /// Whitted ray tracing (exact: no error).
    Whitted,
    /// Bounded-error ray tracing against Whitted.
    Bounded,
}

crate::choice!(BenchMethod {
    Primary = "primary",
    Ao = "ao",
    RandomRays = "random-rays",
    Field = "field",
    Ssao = "ssao",
    Prt = "prt",
    Whitted = "whitted",
    Bounded = "bounded"
});

impl BenchMethod {
    /// The method's name, as `--methods` and the reports spell it.
    pub fn name(self) -> &'static str {
        Choice::name(self)
    }

    /// Every method, cheapest first.
    pub const ALL: [BenchMethod; 8] = [
        BenchMethod::Primary,
        BenchMethod::RandomRays,
        BenchMethod::Ao,
        BenchMethod::Ssao,
        BenchMethod::Field,
        BenchMethod::Prt,
        BenchMethod::Whitted,
        BenchMethod::Bounded,
    ];

    /// The sweep that drives a method with a truth.
    fn sweep(self) -> Option<SweepKind> {
        match self {
            BenchMethod::Primary => Some(SweepKind::Trace),
            BenchMethod::Field => Some(SweepKind::Field),
            BenchMethod::Ssao => Some(SweepKind::Ssao),
            BenchMethod::Prt => Some(SweepKind::Prt),
            BenchMethod::Bounded => Some(SweepKind::Bounded),
            _ => None,
        }
    }

    /// What the method is judged by: rays a second for ray casting, frames
    /// a second for the others.
    pub fn unit(self) -> &'static str {
        match self {
            BenchMethod::Primary | BenchMethod::Ao | BenchMethod::RandomRays => "Mrays/s",
            _ => "fps",
        }
    }

    /// The knobs `BenchSettings::set` may give this method.
    fn own_knobs(self) -> &'static [Knob] {
        const AO: &[Knob] = &[
            Knob::new::<u32>("rays", "rays per vertex", &[]),
            Knob::new::<f32>("radius", "AO radius", &[]),
        ];
        const RAYS: &[Knob] = &[
            Knob::new::<u32>("rays", "random rays", &[]),
            Knob::new::<Structure>("accel", "what single rays walk on the CPU", &[]),
        ];
        const WHITTED: &[Knob] = &[
            Knob::new::<u32>("spp", "samples per pixel", &[]),
            Knob::new::<u32>("max-depth", "deepest reflection/refraction", &[]),
        ];
        match self {
            BenchMethod::Ao => AO,
            BenchMethod::RandomRays => RAYS,
            BenchMethod::Whitted => WHITTED,
            _ => &[],
        }
    }
}

/// Which devices a bench runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum DeviceSet {
    /// The CPU path only.
    Cpu,
    /// Every GPU adapter wgpu lists (software ones included and marked).
    Gpu,
    /// The CPU and every GPU adapter.
    #[default]
    All,
}

/// What a bench runs, and how often.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchSettings {
    /// The methods, in the order the rows come.
    pub methods: Vec<BenchMethod>,
    /// CPU thread counts (the CPU device runs each; a GPU runs once, with
    /// the most).
    pub threads: Vec<usize>,
    /// Untimed and measured runs of each row.
    pub runs: Repeats,
    /// Settings away from the defaults: `method.knob=value` each.
    pub set: Vec<String>,
    /// Random rays traced by `random-rays` (its `rays` knob).
    pub random_rays: u32,
    /// Rays per vertex of `ao` (its `rays` knob).
    pub ao_rays: u32,
}

impl Default for BenchSettings {
    fn default() -> Self {
        BenchSettings {
            methods: BenchMethod::ALL.to_vec(),
            threads: vec![std::thread::available_parallelism().map_or(1, |n| n.get())],
            runs: Repeats { warmup: 1, repeat: 5 },
            set: Vec::new(),
            random_rays: 1 << 20,
            ao_rays: 64,
        }
    }
}

/// A device a bench runs on, as its rows name it.
#[derive(Debug, Clone)]
pub struct BenchDevice {
    /// The device.
    pub device: Device,
    /// `cpu`, or the adapter's name and backend.
    pub name: String,
    /// A software adapter (lavapipe, llvmpipe): on the CPU's own cores.
    pub software: bool,
}

/// The devices `set` names: the CPU, and each GPU adapter wgpu lists
/// (each opened on its own; one that cannot be opened is left out, saying
/// why in the second list).
pub fn bench_devices(set: DeviceSet) -> (Vec<BenchDevice>, Vec<String>) {
    let mut devices = Vec::new();
    let mut refused = Vec::new();
    if set != DeviceSet::Gpu {
        devices.push(BenchDevice {
            device: Device::cpu(),
            name: "cpu".into(),
            software: false,
        });
    }
    if set == DeviceSet::Cpu {
        return (devices, refused);
    }
    for adapter in enumerate_adapters(&AdapterSettings::default()) {
        let name = format!("{} ({})", adapter.name, adapter.backend);
        let options = AdapterSettings {
            backends: Some(adapter.backend.clone()),
            adapter_name: Some(adapter.name.clone()),
            ..AdapterSettings::default()
        };
        match GpuContext::headless_on(AdapterKinds::Any, &options) {
            Ok(ctx) => devices.push(BenchDevice {
                device: Device::gpu(ctx),
                software: matches!(adapter.device_type.as_str(), "cpu" | "other"),
                name,
            }),
            Err(e) => refused.push(format!("{name}: {e}")),
        }
    }
    (devices, refused)
}

/// One method on one device with one thread count.
#[derive(Debug, Clone, Serialize)]
pub struct BenchRow {
    /// The method.
    pub method: BenchMethod,
    /// The device's name (`cpu`, or the adapter and its backend).
    pub device: String,
    /// A software adapter (on the CPU's own cores).
    pub software: bool,
    /// CPU threads (the most given, on a GPU).
    pub threads: usize,
    /// The settings away from the defaults, `knob=value` each.
    pub settings: BTreeMap<String, String>,
    /// What the times measure: the method's own timed work (a sweep's
    /// time measure), without what a run rebuilds (reported in
    /// `setup_ms`). On a GPU, timestamps where the adapter has them: a
    /// software adapter's can leave out most of its work (lavapipe's for
    /// field lookups and Whitted), which the wall times then show.
    pub measure: &'static str,
    /// The fastest measured run's timed work, ms.
    pub min_ms: f64,
    /// The median measured run's timed work, ms (the throughput's).
    pub median_ms: f64,
    /// The slowest measured run's timed work, ms.
    pub max_ms: f64,
    /// Every measured run's timed work, ms.
    pub ms: Vec<f64>,
    /// The fastest measured run by the wall clock around the whole call,
    /// ms: from its start until its results are back on the CPU, with
    /// whatever the method's run rebuilds each time (the primary-ray
    /// sweep its kd-tree, SSAO its G-buffer).
    pub wall_min_ms: f64,
    /// The median measured run by the wall clock, ms.
    pub wall_median_ms: f64,
    /// The slowest measured run by the wall clock, ms.
    pub wall_max_ms: f64,
    /// Rays a run traces (ray-casting methods), else 0.
    pub rays: u64,
    /// The throughput at the median: rays or frames a second.
    pub throughput: f64,
    /// Its unit: `Mrays/s` or `fps`.
    pub unit: &'static str,
    /// What the row cost apart from the timed work, ms: `load` (reading
    /// the input), `build` (acceleration structures), `truth` (the
    /// reference the error is against), `compile` (GPU pipelines, where
    /// the device compiled any), and the methods' own first-run phases.
    pub setup_ms: BTreeMap<String, f64>,
    /// The error against the truth (`None`: the method is its own truth).
    pub error: Option<f64>,
    /// What `error` measures.
    pub error_measure: Option<&'static str>,
    /// Why the row did not run (a device that lacks what the method
    /// needs); its times are then NaN.
    pub skipped: Option<String>,
}

/// What a bench reports (`bench.json`).
#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    /// Warm-up runs per row.
    pub warmup: u32,
    /// Measured runs per row.
    pub repeat: u32,
    /// The seed of every sample sequence.
    pub seed: u32,
    /// One row per method, device and thread count.
    pub rows: Vec<BenchRow>,
    /// Devices that could not be opened, and why.
    pub devices_refused: Vec<String>,
}

/// Runs every method of `settings` on every device and thread count.
pub fn bench(
    inputs: &SweepInputs,
    devices: &[BenchDevice],
    refused: Vec<String>,
    settings: &BenchSettings,
    bars: &Reporter,
) -> Result<BenchReport> {
    settings.check()?;
    let mut rows = Vec::new();
    for &method in &settings.methods {
        let mut given = given_for(method, &settings.set)?;
        // PRT's defaults are the probe's choice, as `prt` makes it: made
        // once (its counted work is the same on every device and thread
        // count), its choice a row's settings, its time a setup phase.
        let probe_ms = match (method, inputs.mesh) {
            (BenchMethod::Prt, Some(mesh)) => prt_probe(mesh, inputs, &mut given)?,
            _ => None,
        };
        for dev in devices {
            let threads: Vec<usize> = match dev.device.is_gpu() {
                true => vec![settings.threads.iter().copied().max().unwrap_or(1)],
                false => settings.threads.clone(),
            };
            // Random rays and PRT take one mesh; a scene file's bench says
            // so in their rows and runs the rest.
            if inputs.mesh.is_none() && matches!(method, BenchMethod::RandomRays | BenchMethod::Prt) {
                let why = format!("{} takes a mesh (`mesh`), not a scene file", method.name());
                rows.push(Measured::skipped(threads[0], why).row(method, dev, &given));
                continue;
            }
            let out = match method.sweep() {
                Some(kind) => swept(kind, inputs, dev, &threads, &given, settings.runs, bars),
                None => own(method, inputs, dev, &threads, &given, settings, bars),
            };
            let measured = match out {
                Ok(measured) => measured,
                // A device that lacks what the method needs is a row that
                // says so; every other error ends the bench.
                Err(Error::Device(why)) => vec![Measured::skipped(threads[0], why)],
                Err(e) => return Err(e),
            };
            for m in measured {
                let mut row = m.row(method, dev, &given);
                if let Some(ms) = probe_ms {
                    row.setup_ms.insert("probe".into(), ms);
                }
                rows.push(row);
            }
        }
    }
    Ok(BenchReport {
        warmup: settings.runs.warmup,
        repeat: settings.runs.repeat,
        seed: inputs.seed,
        rows,
        devices_refused: refused,
    })
}

/// PRT's probe of the knobs `given` leaves open (mask, hierarchy, near) on
/// `mesh`, its choice added to `given`; the probe's milliseconds, or `None`
/// when every one is given.
fn prt_probe(mesh: &Path, inputs: &SweepInputs, given: &mut Vec<(String, String)>) -> Result<Option<f64>> {
    let is = |k: &str| given.iter().any(|(n, _)| n == k);
    if is("mask") && is("hierarchy") && is("near") {
        return Ok(None);
    }
    let mut probe = Probe::default();
    let setting = setting_of(BenchMethod::Prt, crate::prt::tune::KNOBS, given)?;
    // The other settings given (bands, LUT, ...) are the probe's base.
    let base = PrtSweep::settings(&setting)?;
    if let Some(m) = setting.get::<usize>("mask") {
        probe.masks = vec![m];
    }
    if let Some(h) = setting.get::<bool>("hierarchy") {
        probe.hierarchy = vec![h];
    }
    if let Some(n) = setting.get::<NearField>("near") {
        probe.near = vec![n];
    }
    let loaded = load_mesh(mesh)?;
    let eye = inputs.view.camera.resolve(None, &loaded.bounds(), loaded.origin)?.eye;
    let report = probe_prt(
        &loaded.positions,
        &loaded.triangles,
        &base,
        Some(eye),
        &probe,
        inputs.seed,
    )?;
    let c = report.choice();
    for (knob, value) in [
        ("mask", c.mask.to_string()),
        ("hierarchy", if c.hierarchy { "on" } else { "off" }.to_string()),
        ("near", c.near.unwrap_or(base.hierarchy.near).name().to_string()),
    ] {
        if !given.iter().any(|(n, _)| n == knob) {
            given.push((knob.to_string(), value));
        }
    }
    Ok(Some(report.ms))
}

impl BenchSettings {
    /// Checks the settings before any device is opened: methods named,
    /// thread counts within 8 a core, runs within `MAX_RUNS`, and every
    /// `set` entry naming a method and one of its knobs with a value it
    /// reads (the sweeps' knobs are checked when their method runs).
    pub fn check(&self) -> Result<()> {
        check(self)?;
        for &m in &self.methods {
            let given = given_for(m, &self.set)?;
            if m.sweep().is_none() {
                setting_of(m, m.own_knobs(), &given)?;
            }
        }
        Ok(())
    }
}

fn check(settings: &BenchSettings) -> Result<()> {
    if settings.methods.is_empty() {
        return Err(Error::param("methods", "names no method"));
    }
    let most = 8 * std::thread::available_parallelism().map_or(1, |n| n.get());
    if settings.threads.is_empty() || settings.threads.iter().any(|&t| t == 0 || t > most) {
        let problem = format!("must each be between 1 and {most}, got {:?}", settings.threads);
        return Err(Error::param("threads", problem));
    }
    let most_runs = crate::report::repeats::MAX_RUNS;
    if settings.runs.warmup > most_runs || !(1..=most_runs).contains(&settings.runs.repeat) {
        let problem = format!("must be between 1 and {most_runs} (warm-up: 0 to {most_runs})");
        return Err(Error::param("repeat", problem));
    }
    Ok(())
}

/// The `method.knob=value` entries of `set` for `method`, checked against
/// its knobs (every entry must name a benched method's knob).
fn given_for(method: BenchMethod, set: &[String]) -> Result<Vec<(String, String)>> {
    let mut out = Vec::new();
    for spec in set {
        let (key, value) = spec
            .split_once('=')
            .ok_or_else(|| Error::param("set", format!("'{spec}' is not METHOD.KNOB=VALUE")))?;
        let (name, knob) = key
            .split_once('.')
            .ok_or_else(|| Error::param("set", format!("'{spec}' is not METHOD.KNOB=VALUE")))?;
        let Some(m) = BenchMethod::ALL.iter().find(|m| m.name() == name) else {
            let names: Vec<&str> = BenchMethod::ALL.iter().map(|m| m.name()).collect();
            let problem = format!("'{spec}': no method '{name}' (one of {})", names.join(", "));
            return Err(Error::param("set", problem));
        };
        if *m == method {
            out.push((knob.trim().to_string(), value.trim().to_string()));
        }
    }
    Ok(out)
}

/// `given` read against `knobs` as one setting.
fn setting_of(method: BenchMethod, knobs: &[Knob], given: &[(String, String)]) -> Result<Setting> {
    let mut setting = Setting::default();
    for (name, text) in given {
        let Some(knob) = knobs.iter().find(|k| k.name == name) else {
            let known: Vec<&str> = knobs.iter().map(|k| k.name).collect();
            let problem = format!(
                "{}: unknown knob '{name}'; its knobs: {}",
                method.name(),
                known.join(", ")
            );
            return Err(Error::param("set", problem));
        };
        let value = Given::read(knob, text)
            .map_err(|e| Error::param("set", format!("{}.{name}={text}: {e}", method.name())))?;
        setting = setting.with_given(knob.name, value);
    }
    Ok(setting)
}

/// One row's measurements, before the method and device are attached.
struct Measured {
    threads: usize,
    measure: &'static str,
    /// Wall-clock time of each measured run.
    runs: Option<RunTimes>,
    /// The method's own timed work of each measured run.
    work: Option<RunTimes>,
    rays: u64,
    setup_ms: BTreeMap<String, f64>,
    error: Option<(f64, &'static str)>,
    skipped: Option<String>,
}

impl Measured {
    fn skipped(threads: usize, why: String) -> Measured {
        Measured {
            threads,
            measure: "",
            runs: None,
            work: None,
            rays: 0,
            setup_ms: BTreeMap::new(),
            error: None,
            skipped: Some(why),
        }
    }

    fn row(self, method: BenchMethod, dev: &BenchDevice, given: &[(String, String)]) -> BenchRow {
        let runs = self.runs.unwrap_or_else(|| RunTimes::of("", 0, Vec::new()));
        let work = self.work.unwrap_or_else(|| RunTimes::of("", 0, Vec::new()));
        let median_s = work.median_ms / 1000.0;
        let throughput = match method.unit() {
            "Mrays/s" => self.rays as f64 / median_s / 1e6,
            _ => 1.0 / median_s,
        };
        BenchRow {
            method,
            device: dev.name.clone(),
            software: dev.software,
            threads: self.threads,
            settings: given.iter().cloned().collect(),
            measure: self.measure,
            min_ms: work.min_ms,
            median_ms: work.median_ms,
            max_ms: work.max_ms,
            ms: work.ms,
            wall_min_ms: runs.min_ms,
            wall_median_ms: runs.median_ms,
            wall_max_ms: runs.max_ms,
            rays: self.rays,
            throughput,
            unit: method.unit(),
            setup_ms: self.setup_ms,
            error: self.error.map(|e| e.0),
            error_measure: self.error.map(|e| e.1),
            skipped: self.skipped,
        }
    }
}

/// `runs.warmup` untimed calls of `once`, then `runs.repeat` measured
/// ones: the last result, each measured call's wall time and each one's
/// own timed work (`work` of its result).
fn timed<T>(
    runs: Repeats,
    mut once: impl FnMut() -> Result<T>,
    work: impl Fn(&T) -> f64,
) -> Result<(T, RunTimes, RunTimes)> {
    let mut wall = Vec::new();
    let timed_once = || {
        let start = Instant::now();
        let value = once()?;
        wall.push(elapsed_ms(start));
        Ok(value)
    };
    let (last, own) = runs.run("ms", timed_once, work)?;
    // The warm-up runs were timed too: the measured ones are the last.
    let measured = wall.split_off(runs.warmup as usize);
    Ok((last, RunTimes::of("wall_ms", runs.warmup, measured), own))
}

/// Runs `f` on a pool of `threads` CPU threads (rayon's work inside runs
/// there).
fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> Result<T> + Send) -> Result<T> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::internal(format!("cannot start {threads} threads: {e}")))?;
    pool.install(f)
}

/// The device's pipeline compilation so far, ms (0 on the CPU).
fn compile_ms(device: &Device) -> f64 {
    device.pipelines().map_or(0.0, |p| p.compile_ms)
}

/// A method with a truth, through its sweep: per thread count, the sweep
/// built on a pool of that many threads (a sweep stays on the thread that
/// made it), its truth, then warm-up and measured runs of the one setting.
fn swept(
    kind: SweepKind,
    inputs: &SweepInputs,
    dev: &BenchDevice,
    threads: &[usize],
    given: &[(String, String)],
    runs: Repeats,
    bars: &Reporter,
) -> Result<Vec<Measured>> {
    let device = dev.device.clone().require(kind.gpu_needs())?;
    let method = BenchMethod::ALL
        .into_iter()
        .find(|m| m.sweep() == Some(kind))
        .expect("every sweep is benched");
    let mut out = Vec::new();
    for &t in threads {
        let compiled = compile_ms(&device);
        let start = Instant::now();
        let measured = on_threads(t, || {
            with_method(kind, inputs, &device, bars, |sweep| {
                let load_ms = elapsed_ms(start);
                let setting = setting_of(method, sweep.knobs(), given)?;
                sweep.check(&setting)?;
                let truth_start = Instant::now();
                sweep.truth(bars)?;
                let truth_ms = elapsed_ms(truth_start);
                let mut first = None;
                let mut once = || {
                    let run = sweep.run(&setting)?;
                    first.get_or_insert(run.phases.clone());
                    Ok(run)
                };
                let (last, wall, work) = timed(runs, &mut once, |r| r.time_ms)?;
                let error = last.error;
                let mut setup_ms: BTreeMap<String, f64> = first
                    .unwrap_or_default()
                    .into_iter()
                    .map(|(k, v)| (k.to_string(), v))
                    .collect();
                setup_ms.insert("load".into(), load_ms);
                setup_ms.insert("truth".into(), truth_ms);
                Ok(Measured {
                    threads: t,
                    measure: sweep.time_measure(),
                    runs: Some(wall),
                    work: Some(work),
                    rays: match kind {
                        SweepKind::Trace => inputs.view.width as u64 * inputs.view.height as u64,
                        _ => 0,
                    },
                    setup_ms,
                    error: Some((error, sweep.error_measure())),
                    skipped: None,
                })
            })
        })?;
        let mut measured = measured;
        measured
            .setup_ms
            .insert("compile".into(), compile_ms(&device) - compiled);
        out.push(measured);
    }
    Ok(out)
}

/// The methods that are their own truth: ray-cast AO, random rays, Whitted.
fn own(
    method: BenchMethod,
    inputs: &SweepInputs,
    dev: &BenchDevice,
    threads: &[usize],
    given: &[(String, String)],
    settings: &BenchSettings,
    bars: &Reporter,
) -> Result<Vec<Measured>> {
    let setting = setting_of(method, method.own_knobs(), given)?;
    let device = dev.device.clone().require(&crate::gpu::device::Needs::COMPUTE)?;
    let compiled = compile_ms(&device);
    let start = Instant::now();
    let runs = settings.runs;
    let mut out = Vec::new();
    match method {
        BenchMethod::Ao => {
            let scene = load_input_in(inputs.mesh, inputs.scene, inputs.data_dir)?;
            let load_ms = elapsed_ms(start);
            let ao_settings = AoSettings {
                rays_per_point: setting.get::<u32>("rays").unwrap_or(settings.ao_rays),
                radius: setting.get::<f32>("radius").unwrap_or(f32::INFINITY),
                seed: inputs.seed,
            };
            for &t in threads {
                let (ao, times, build_ms) = on_threads(t, || {
                    let mut ao = AmbientOcclusion::for_scene(&device, &scene)?;
                    ao.prepare()?;
                    let (v, wall, work) = timed(runs, || ao.vertices(&ao_settings), |v| v.ms)?;
                    Ok((v, (wall, work), ao.build_ms()))
                })?;
                let rays = (ao.ao.len() - ao.without_normal) as u64 * ao_settings.rays_per_point as u64;
                let setup = [
                    ("load", load_ms),
                    ("build", build_ms),
                    ("compile", compile_ms(&device) - compiled),
                ];
                out.push(Measured::own(t, "ao_ms", times, rays, &setup));
            }
        }
        BenchMethod::RandomRays => {
            let mesh = crate::scene::load_mesh(
                inputs
                    .mesh
                    .ok_or_else(|| Error::param("mesh", "random-rays needs a mesh"))?,
            )?;
            let load_ms = elapsed_ms(start);
            let rays = random_rays(
                &mesh,
                setting.get::<u32>("rays").unwrap_or(settings.random_rays) as usize,
            );
            let structure = setting.get::<Structure>("accel").unwrap_or(Structure::Bvh);
            for &t in threads {
                let (times, build_ms) = on_threads(t, || {
                    let mut tracer = Tracer::build(&device, &mesh, bars)?.with_structure(structure);
                    let (_, wall, work) = timed(runs, || tracer.closest_incoherent(&rays), |t| t.ms)?;
                    let build_ms =
                        tracer.accel().kdtree().stats.build_ms + tracer.bvh_stats().map_or(0.0, |b| b.build_ms);
                    Ok(((wall, work), build_ms))
                })?;
                let setup = [
                    ("load", load_ms),
                    ("build", build_ms),
                    ("compile", compile_ms(&device) - compiled),
                ];
                out.push(Measured::own(t, "trace_ms", times, rays.len() as u64, &setup));
            }
        }
        BenchMethod::Whitted => {
            let scene = load_shaded_input_in(inputs.mesh, inputs.scene, inputs.data_dir)?;
            let load_ms = elapsed_ms(start);
            let whitted_settings = WhittedSettings {
                seed: inputs.seed,
                spp: setting.get::<u32>("spp").unwrap_or(WhittedSettings::default().spp),
                max_depth: setting
                    .get::<u32>("max-depth")
                    .unwrap_or(WhittedSettings::default().max_depth),
                ..WhittedSettings::default()
            };
            for &t in threads {
                let (times, build_ms, rays) = on_threads(t, || {
                    let build = Instant::now();
                    let render_scene = RenderScene::new(&scene, 0, &LightingSettings::default())?;
                    let mut renderer = WhittedRenderer::new(&device, render_scene, bars)?;
                    let build_ms = elapsed_ms(build);
                    let camera = inputs
                        .view
                        .camera
                        .resolve(scene.camera, &renderer.bounds(), scene.origin)?;
                    let (w, h) = (inputs.view.width, inputs.view.height);
                    let bar = bars.bar(0, "whitted");
                    let (r, wall, work) = timed(
                        runs,
                        || renderer.render(&camera, w, h, &whitted_settings, &bar),
                        |r| r.stats.render_ms,
                    )?;
                    Ok(((wall, work), build_ms, r.stats.rays.total()))
                })?;
                let setup = [
                    ("load", load_ms),
                    ("build", build_ms),
                    ("compile", compile_ms(&device) - compiled),
                ];
                out.push(Measured::own(t, "render_ms", times, rays, &setup));
            }
        }
        _ => unreachable!("{} has a sweep", method.name()),
    }
    Ok(out)
}

impl Measured {
    fn own(
        threads: usize,
        measure: &'static str,
        times: (RunTimes, RunTimes),
        rays: u64,
        setup: &[(&str, f64)],
    ) -> Measured {
        Measured {
            threads,
            measure,
            runs: Some(times.0),
            work: Some(times.1),
            rays,
            setup_ms: setup.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
            error: None,
            skipped: None,
        }
    }
}

/// `n` rays aimed at `mesh`, the same rays `embree_bench --gen-rays`
/// writes for the same mesh (the generator and its seed are that tool's):
/// origins on a sphere of 1.5 times the bounding radius around the box's
/// centre, each aimed at a random corner of a random triangle moved by a
/// Gaussian of 5% of the radius.
pub fn random_rays(mesh: &Mesh, n: usize) -> Vec<Ray> {
    let mut s: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut rnd = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0)
    };
    let gauss = {
        move |rnd: &mut dyn FnMut() -> f64| {
            let (u1, u2) = (rnd() + 1e-300, rnd());
            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        }
    };
    let bounds = mesh.bounds();
    let (lo, hi) = (bounds.min, bounds.max);
    let c = 0.5 * (lo + hi);
    let r = 0.5 * (hi - lo).length();
    let nt = mesh.triangles.len().max(1);
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let u = Vec3::new(gauss(&mut rnd) as f32, gauss(&mut rnd) as f32, gauss(&mut rnd) as f32).normalize();
        let o = c + u * (r * 1.5);
        let t = (rnd() * nt as f64) as usize % nt;
        let corner = (rnd() * 3.0) as usize % 3;
        let v = mesh
            .triangles
            .get(t)
            .map_or(c, |tri| mesh.positions[tri[corner] as usize]);
        let jitter = Vec3::new(gauss(&mut rnd) as f32, gauss(&mut rnd) as f32, gauss(&mut rnd) as f32);
        let target = v + jitter * (r * 0.05);
        out.push(Ray::new(o, (target - o).normalize()));
    }
    out
}

/// The report as CSV: one line per row (times in ms; setup phases joined
/// as `name=ms` with `;`).
pub fn csv_text(report: &BenchReport) -> String {
    let mut s = String::from(
        "method,device,software,threads,settings,min_ms,median_ms,max_ms,wall_median_ms,throughput,unit,error,error_measure,setup_ms,skipped\n",
    );
    for r in &report.rows {
        let settings: Vec<String> = r.settings.iter().map(|(k, v)| format!("{k}={v}")).collect();
        let setup: Vec<String> = r.setup_ms.iter().map(|(k, v)| format!("{k}={v:.3}")).collect();
        let field = |text: &str| match text.contains([',', '"', '\n']) {
            true => format!("\"{}\"", text.replace('"', "\"\"")),
            false => text.to_string(),
        };
        s.push_str(&format!(
            "{},{},{},{},{},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{},{},{}\n",
            r.method.name(),
            field(&r.device),
            r.software,
            r.threads,
            field(&settings.join(";")),
            r.min_ms,
            r.median_ms,
            r.max_ms,
            r.wall_median_ms,
            r.throughput,
            r.unit,
            r.error.map_or(String::new(), |e| format!("{e:.6e}")),
            r.error_measure.unwrap_or(""),
            field(&setup.join(";")),
            field(r.skipped.as_deref().unwrap_or("")),
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first rays `embree_bench assets/corner.obj --gen-rays 3 OUT`
    /// wrote (Embree 3.13.5's tool, its own OBJ loader): the bench's random
    /// rays are the ones the Embree baseline traces.
    #[test]
    fn random_rays_are_embree_benchs() {
        const EMBREE: [[f32; 6]; 3] = [
            [
                0.168_229_85,
                0.847_273_9,
                -0.706_991_8,
                -0.105_705_72,
                -0.428_723_45,
                0.897_230_5,
            ],
            [
                0.619_844_9,
                -0.782_419_7,
                0.331_071_7,
                0.290_216_06,
                0.922_929_5,
                0.252_934_7,
            ],
            [
                -0.667_151_1,
                0.926_586_03,
                0.121_473_31,
                0.898_930_55,
                -0.423_114_15,
                -0.113_570_43,
            ],
        ];
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/corner.obj");
        let mesh = crate::scene::load_mesh(&path).unwrap();
        let rays = random_rays(&mesh, 3);
        for (ray, want) in rays.iter().zip(EMBREE) {
            let [o, d] = [ray.origin, ray.dir];
            let got = [o[0], o[1], o[2], d[0], d[1], d[2]];
            let worst = got.iter().zip(want).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
            println!("worst component difference {worst:e}");
            assert!(worst < 1e-6, "{got:?} != {want:?}");
        }
    }
}
