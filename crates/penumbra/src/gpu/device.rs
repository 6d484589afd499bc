//! The device a method runs on: a GPU, where its WGSL kernels run, or the
//! CPU, where their twins run. Every method runner takes one `&Device`; the
//! "upload, record, read back, or time the CPU" branching is written here
//! once (`OnDevice::run`), not in each method.
//!
//! A device is opened from a user's choice (`Device::open`, what `--device`
//! means), adopted from a host engine's own `wgpu::Device` and `Queue`
//! (`Device::from_host`), or made for the CPU alone (`Device::cpu`).

use std::time::Instant;

use crate::error::{Error, Result};
use crate::gpu::AdapterKinds;
use crate::gpu::GpuContext;

pub use crate::gpu::{AdapterSettings, AdapterSummary, LimitsChoice, enumerate_adapters};

/// Which device a user asks for.
///
/// | choice | hardware GPU | only a software GPU (lavapipe) | no adapter |
/// |---|---|---|---|
/// | `Auto` | the GPU | the CPU | the CPU |
/// | `GpuIfAny` | the GPU | the software GPU | the CPU |
/// | `Gpu` | the GPU | the software GPU | an error |
/// | `Cpu` | the CPU | the CPU | the CPU |
///
/// `Auto` and `GpuIfAny` are automatic choices: a method whose GPU path the
/// adapter cannot run moves to the CPU (`Device::require`). The CLI's
/// `--device` offers `auto`, `gpu` and `cpu`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum DeviceChoice {
    /// A hardware GPU adapter if there is one, else the CPU (a software
    /// adapter such as lavapipe is slower than the CPU path on the same cores).
    #[default]
    Auto,
    /// Any GPU adapter, software ones included, else the CPU: for a host
    /// that wants its work on "the GPU if there is one" (e.g. to test its
    /// GPU path on a machine with lavapipe only) without failing where
    /// there is none.
    #[cfg_attr(feature = "clap", value(skip))]
    GpuIfAny,
    /// The best GPU adapter, software ones included; an error if there is none.
    Gpu,
    /// The CPU reference path.
    Cpu,
}

/// A device to run methods on.
#[derive(Debug, Clone)]
pub struct Device {
    gpu: Option<GpuContext>,
    /// Chosen automatically: a method may move work its GPU path cannot do
    /// to the CPU instead of failing.
    automatic: bool,
    /// Why an automatic choice fell back to the CPU.
    fallback: Option<Error>,
}

/// What a method's GPU path needs of a device beyond compute shaders: what
/// its kernels' pipeline layouts bind and their entry points use (storage
/// buffers and textures per stage, workgroup memory and size, read from
/// their WGSL against `wgpu::Limits`) and the texture formats it renders
/// to. Checked when the device is opened (`Device::require`), before any
/// work.
pub struct Needs {
    /// The method, for messages.
    pub what: &'static str,
    /// The WGSL modules its kernels are composed of, whose bindings and
    /// entry points are checked against the device's limits.
    pub modules: &'static [crate::gpu::wgsl::Composition],
    /// Formats rendered to, and what for.
    pub render_targets: &'static [(wgpu::TextureFormat, &'static str)],
}

impl Needs {
    /// Every compute kernel penumbra has: what any command's GPU path may use.
    pub const COMPUTE: Needs = Needs {
        what: "its compute kernels",
        modules: crate::gpu::wgsl::MODULES,
        render_targets: &[],
    };

    /// SSAO: its compute kernels and a G-buffer rendered as Rgba32Float
    /// with a Depth32Float depth buffer.
    pub const SSAO: Needs = Needs {
        what: "SSAO",
        modules: crate::gpu::wgsl::MODULES,
        render_targets: &[
            (wgpu::TextureFormat::Rgba32Float, "the G-buffer"),
            (wgpu::TextureFormat::Depth32Float, "the G-buffer's depth"),
        ],
    };

    /// The limits of `limits` the modules exceed: per limit the largest
    /// need (the first module with it), in the order `Demands::exceeded`
    /// checks them.
    pub fn exceeded(&self, limits: &wgpu::Limits) -> Vec<crate::gpu::wgsl::Exceeded> {
        let mut worst: Vec<crate::gpu::wgsl::Exceeded> = Vec::new();
        for e in self.modules.iter().flat_map(|m| m.exceeded(limits)) {
            match worst.iter_mut().find(|w| w.limit == e.limit) {
                Some(w) if w.needs < e.needs => *w = e,
                Some(_) => {}
                None => worst.push(e),
            }
        }
        worst
    }
}

impl Device {
    /// This device if it can run a method with `needs`; an automatic choice
    /// that cannot falls back to the CPU (saying why), `--device gpu` is a
    /// device error naming the adapter, its backend and what it lacks.
    pub fn require(self, needs: &Needs) -> Result<Device> {
        let Some(Err(why)) = self.gpu.as_ref().map(|ctx| ctx.check(needs)) else {
            return Ok(self);
        };
        match self.automatic {
            true => Ok(Device {
                fallback: Some(why),
                ..self.cpu_instead()
            }),
            false => Err(why),
        }
    }

    /// The CPU reference path.
    pub fn cpu() -> Device {
        Device {
            gpu: None,
            automatic: false,
            fallback: None,
        }
    }

    /// A GPU context made elsewhere (e.g. `GpuContext::headless`).
    pub fn gpu(ctx: GpuContext) -> Device {
        Device {
            gpu: Some(ctx),
            automatic: false,
            fallback: None,
        }
    }

    /// A host engine's device and queue: methods build their pipelines for
    /// it and run their kernels on its queue.
    pub fn from_host(device: &wgpu::Device, queue: &wgpu::Queue) -> Device {
        Device::gpu(GpuContext::from_host(device, queue))
    }

    /// Opens what `choice` names: `Gpu` fails without an adapter, `Auto`
    /// (hardware adapters only) and `GpuIfAny` (software ones too) fall
    /// back to the CPU (see `fallback_reason`), `Cpu` never touches the GPU.
    pub fn open(choice: DeviceChoice) -> Result<Device> {
        Device::open_with(choice, &AdapterSettings::default())
    }

    /// Opens what `choice` names on an adapter `options` allow, with the
    /// limits they ask for.
    pub fn open_with(choice: DeviceChoice, options: &AdapterSettings) -> Result<Device> {
        match choice {
            DeviceChoice::Cpu => Ok(Device::cpu()),
            DeviceChoice::Gpu => GpuContext::headless_on(AdapterKinds::Any, options).map(Device::gpu),
            DeviceChoice::Auto => Ok(Device::automatic(GpuContext::headless_on(
                AdapterKinds::Hardware,
                options,
            ))),
            DeviceChoice::GpuIfAny => Ok(Device::automatic(GpuContext::headless_on(AdapterKinds::Any, options))),
        }
    }

    /// An automatic choice's device: the adapter opened, else the CPU
    /// with the reason.
    fn automatic(opened: Result<GpuContext>) -> Device {
        match opened {
            Ok(ctx) => Device {
                automatic: true,
                ..Device::gpu(ctx)
            },
            Err(e) => Device {
                automatic: true,
                fallback: Some(e),
                ..Device::cpu()
            },
        }
    }

    /// The GPU context, or `None` on the CPU.
    pub fn context(&self) -> Option<&GpuContext> {
        self.gpu.as_ref()
    }

    /// Whether methods run their WGSL kernels (`false`: their CPU twins).
    pub fn is_gpu(&self) -> bool {
        self.gpu.is_some()
    }

    /// "gpu" or "cpu", as reports name the device.
    pub fn kind(&self) -> &'static str {
        if self.is_gpu() { "gpu" } else { "cpu" }
    }

    /// The adapter's name and backend, "name (backend)", or `None` on the CPU.
    pub fn adapter(&self) -> Option<String> {
        self.gpu.as_ref().map(GpuContext::label)
    }

    /// The pipelines this device's passes compiled so far, what that cost,
    /// and those their kernel sets declared but never needed; `None` on
    /// the CPU.
    pub fn pipelines(&self) -> Option<crate::gpu::kernels::PipelineReport> {
        self.gpu.as_ref().map(|ctx| ctx.kernels.log.report())
    }

    /// Whether the device was chosen automatically.
    pub fn is_automatic(&self) -> bool {
        self.automatic
    }

    /// Why an automatic choice runs on the CPU (no usable adapter).
    pub fn fallback_reason(&self) -> Option<&Error> {
        self.fallback.as_ref()
    }

    /// The CPU path, for work this device's GPU path cannot do; still
    /// counted as chosen automatically.
    pub fn cpu_instead(&self) -> Device {
        Device {
            automatic: self.automatic,
            ..Device::cpu()
        }
    }

    /// Runs a method that keeps nothing on the device: `gpu` on a GPU, the
    /// CPU twin `cpu` otherwise, timed as `OnDevice::run` times them.
    pub fn run<T>(
        &self,
        gpu: impl FnOnce(&GpuContext) -> Result<GpuOutput<T>>,
        cpu: impl FnOnce() -> Result<T>,
    ) -> Result<Timed<T>> {
        self.prepare(|_| Ok(()))?.run(|ctx, _| gpu(ctx), cpu)
    }

    /// What a method keeps on this device: `upload`'s state on a GPU,
    /// nothing on the CPU.
    pub fn prepare<G>(&self, upload: impl FnOnce(&GpuContext) -> Result<G>) -> Result<OnDevice<G>> {
        Ok(match &self.gpu {
            Some(ctx) => OnDevice::Gpu {
                state: upload(ctx)?,
                ctx: ctx.clone(),
            },
            None => OnDevice::Cpu,
        })
    }
}

/// A method's resources on its device: GPU state (uploaded data, passes
/// with their kept buffers), or nothing for the CPU path.
pub enum OnDevice<G> {
    /// The CPU path: nothing kept.
    Cpu,
    /// The GPU path.
    Gpu {
        /// The device the state lives on.
        ctx: GpuContext,
        /// What the method uploaded and built (`Device::prepare`'s `upload`).
        state: G,
    },
}

/// What a GPU path returns: its value and, where the device has timestamp
/// queries, its kernels' time.
pub struct GpuOutput<T> {
    /// What the kernels computed, read back.
    pub value: T,
    /// Milliseconds of the kernels' own work from GPU timestamps; `None`
    /// where the device has no timestamp queries (the caller then times
    /// the call on the wall clock).
    pub gpu_ms: Option<f64>,
}

/// How a time was measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Timing {
    /// The kernels' time from timestamp queries.
    #[serde(rename = "gpu-timestamps")]
    GpuTimestamps,
    /// Wall-clock time (the CPU path, or a GPU without timestamps: upload,
    /// kernels and read-back together).
    #[serde(rename = "wall")]
    Wall,
}

/// A value and the time it took.
#[derive(Debug, Clone)]
pub struct Timed<T> {
    /// What was computed.
    pub value: T,
    /// Milliseconds, measured as `timing` says.
    pub ms: f64,
    /// Whether `ms` is the kernels' timestamped time or wall-clock time.
    pub timing: Timing,
}

impl<T> Timed<T> {
    /// `f` timed on the wall clock.
    pub fn wall(f: impl FnOnce() -> Result<T>) -> Result<Timed<T>> {
        let start = Instant::now();
        let value = f()?;
        Ok(Timed {
            value,
            ms: elapsed_ms(start),
            timing: Timing::Wall,
        })
    }

    /// The value passed through `f`, with the same time.
    pub fn map<U>(self, f: impl FnOnce(T) -> U) -> Timed<U> {
        Timed {
            value: f(self.value),
            ms: self.ms,
            timing: self.timing,
        }
    }
}

impl<G> OnDevice<G> {
    /// Runs the GPU path on the device's state, or the CPU twin, and times
    /// each as it can be timed: the kernels' timestamps where the device has
    /// them, else the wall clock.
    pub fn run<T>(
        &mut self,
        gpu: impl FnOnce(&GpuContext, &mut G) -> Result<GpuOutput<T>>,
        cpu: impl FnOnce() -> Result<T>,
    ) -> Result<Timed<T>> {
        match self {
            OnDevice::Cpu => Timed::wall(cpu),
            OnDevice::Gpu { ctx, state } => {
                let start = Instant::now();
                let out = gpu(ctx, state)?;
                Ok(match out.gpu_ms {
                    Some(ms) => Timed {
                        value: out.value,
                        ms,
                        timing: Timing::GpuTimestamps,
                    },
                    None => Timed {
                        value: out.value,
                        ms: elapsed_ms(start),
                        timing: Timing::Wall,
                    },
                })
            }
        }
    }

    /// The GPU state, if any.
    pub fn state(&self) -> Option<&G> {
        match self {
            OnDevice::Gpu { state, .. } => Some(state),
            OnDevice::Cpu => None,
        }
    }
}

/// Milliseconds since `start`: every time penumbra reports is measured with this.
pub fn elapsed_ms(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}
