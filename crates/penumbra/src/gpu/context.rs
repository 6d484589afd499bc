//! The GPU context: a device and queue, either created headless here (the
//! CLI's convenience) or adopted from a host engine, plus what penumbra needs
//! to know about them (limits, timestamp support, a name for reports).

use crate::gpu::capabilities::Capabilities;
use std::sync::Arc;

use crate::error::{Error, Result};

/// One adapter as `penumbra info` reports it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AdapterSummary {
    /// The adapter's name, as the driver gives it.
    pub name: String,
    /// The backend, lower case (`vulkan`, `gl`, `metal`, `dx12`, ...).
    pub backend: String,
    /// The kind of device, lower case (`discretegpu`, `integratedgpu`,
    /// `virtualgpu`, `cpu`, `other`).
    pub device_type: String,
    /// The driver's name and its version text, space-separated; empty where
    /// the driver gives neither.
    pub driver_info: String,
}

impl AdapterSummary {
    /// The summary of an adapter wgpu describes.
    pub fn from_info(info: &wgpu::AdapterInfo) -> Self {
        let driver_info = [info.driver.as_str(), info.driver_info.as_str()]
            .iter()
            .filter(|s| !s.is_empty())
            .copied()
            .collect::<Vec<_>>()
            .join(" ");
        AdapterSummary {
            name: info.name.clone(),
            backend: format!("{:?}", info.backend).to_lowercase(),
            device_type: format!("{:?}", info.device_type).to_lowercase(),
            driver_info,
        }
    }
}

/// A device and queue penumbra's passes run on.
///
/// Passes never create devices themselves: they take `&wgpu::Device` and
/// record into a caller's `CommandEncoder`. `GpuContext` bundles what the
/// convenience entry points (CLI, tests) need on top of that.
#[derive(Clone)]
pub struct GpuContext {
    /// The device every pass is built for and records on.
    pub device: wgpu::Device,
    /// The device's queue, which the blocking helpers submit to.
    pub queue: wgpu::Queue,
    /// Adapter name for reports ("host device" when adopted).
    pub name: String,
    /// The adapter's backend ("vulkan", "gl", ...; "host" when adopted):
    /// lavapipe shows up as two adapters of one name, Vulkan and GL.
    pub backend: String,
    /// Whether compute passes can carry timestamp queries.
    pub timestamps: bool,
    /// What methods need that the adapter may lack (checked up front).
    pub capabilities: crate::gpu::capabilities::Capabilities,
    pub(crate) kernels: Arc<crate::gpu::kernels::KernelCache>,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext").field("name", &self.name).finish()
    }
}

/// Which adapter a headless device is opened on, and with which limits.
/// `Default`: any backend (native ones first, GL only without one), any
/// adapter name, everything the adapter allows.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AdapterSettings {
    /// The backends to look at, as wgpu names them, comma-separated
    /// (`vulkan`, `gl`, `metal`, `dx12`; the spelling of wgpu's
    /// `WGPU_BACKEND`). `None`: the native APIs first, GL only if they have
    /// no adapter.
    pub backends: Option<String>,
    /// Only adapters whose name contains this, ignoring case (as wgpu's
    /// `WGPU_ADAPTER_NAME`).
    pub adapter_name: Option<String>,
    /// The limits the device is created with.
    pub limits: LimitsChoice,
}

/// The limits a headless device asks for.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum LimitsChoice {
    /// Everything the adapter allows (lavapipe: 128 MiB storage bindings,
    /// 4096-texel 3D textures, 32 KiB of workgroup memory).
    #[default]
    Adapter,
    /// WebGPU's portable defaults (`wgpu::Limits::default()`: 8 storage
    /// buffers per stage, 16 KiB of workgroup memory, 2048-texel 3D
    /// textures, 128 MiB storage bindings): what a host that asks for no
    /// more gives penumbra.
    Portable,
}

impl AdapterSettings {
    /// Backend sets to look at, in order: `backends` if given; otherwise
    /// the native APIs first and GL only if they have no adapter (probing
    /// GL on a headless machine costs time and prints EGL warnings, and
    /// lavapipe's GL adapter lacks what the Vulkan one has).
    fn backend_sets(&self) -> Result<Vec<wgpu::Backends>> {
        Ok(match self.backends()? {
            Some(b) => vec![b],
            None => vec![wgpu::Backends::all() - wgpu::Backends::GL, wgpu::Backends::GL],
        })
    }

    /// The backends named, checked: wgpu's `Backends::from_comma_list`
    /// skips unknown names silently, and "no adapter" would then blame the
    /// machine instead of the spelling.
    fn backends(&self) -> Result<Option<wgpu::Backends>> {
        let Some(value) = &self.backends else {
            return Ok(None);
        };
        let lower = value.to_lowercase();
        match lower.split(',').map(str::trim).find(|b| !BACKEND_NAMES.contains(b)) {
            Some(unknown) => Err(Error::Device(format!(
                "`backends`={value:?}: {unknown:?} is not a backend wgpu knows (one or more of vulkan, gl, metal, \
                 dx12, separated by commas)"
            ))),
            None => Ok(Some(wgpu::Backends::from_comma_list(&lower))),
        }
    }
}

/// The names `AdapterSettings::backends` may list.
const BACKEND_NAMES: [&str; 10] = [
    "vulkan", "vk", "dx12", "d3d12", "metal", "mtl", "opengl", "gles", "gl", "webgpu",
];

fn instance(backends: wgpu::Backends) -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backends;
    wgpu::Instance::new(desc)
}

/// Lists the adapters wgpu finds on the backends `options` name (all
/// backends, GL included, when it names none).
pub fn enumerate_adapters(options: &AdapterSettings) -> Vec<AdapterSummary> {
    let backends = match &options.backends {
        Some(names) => wgpu::Backends::from_comma_list(&names.to_lowercase()),
        None => wgpu::Backends::all(),
    };
    let adapters = pollster::block_on(instance(backends).enumerate_adapters(backends));
    adapters
        .iter()
        .map(|a| AdapterSummary::from_info(&a.get_info()))
        .collect()
}

/// Preference order: Vulkan before other backends (lavapipe shows up as both
/// a Vulkan and a GL adapter, and only Vulkan has everything we use), then
/// discrete, integrated, virtual, CPU devices.
fn rank(info: &wgpu::AdapterInfo) -> (u8, u8) {
    let backend = match info.backend {
        wgpu::Backend::Vulkan => 0,
        wgpu::Backend::Metal | wgpu::Backend::Dx12 => 1,
        wgpu::Backend::Gl => 2,
        _ => 3,
    };
    let kind = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    (backend, kind)
}

/// Which adapters a choice may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AdapterKinds {
    /// Any adapter, software ones (lavapipe, llvmpipe GL) included.
    Any,
    /// Hardware (discrete, integrated, virtual) adapters only: on the same
    /// cores a software adapter is slower than the CPU path.
    Hardware,
}

fn is_software(info: &wgpu::AdapterInfo) -> bool {
    matches!(info.device_type, wgpu::DeviceType::Cpu | wgpu::DeviceType::Other)
}

/// "name (backend)", as reports name an adapter.
fn label(info: &wgpu::AdapterInfo) -> String {
    format!("{} ({})", info.name, format!("{:?}", info.backend).to_lowercase())
}

fn pick_adapter(kinds: AdapterKinds, options: &AdapterSettings) -> Result<wgpu::Adapter> {
    let mut adapters = Vec::new();
    for backends in options.backend_sets()? {
        adapters = pollster::block_on(instance(backends).enumerate_adapters(backends));
        if let Some(wanted) = &options.adapter_name {
            let wanted = wanted.to_lowercase();
            adapters.retain(|a| a.get_info().name.to_lowercase().contains(&wanted));
        }
        if !adapters.is_empty() {
            break;
        }
    }
    if let Some(wanted) = &options.adapter_name
        && adapters.is_empty()
    {
        let names: Vec<String> = enumerate_adapters(options).into_iter().map(|a| a.name).collect();
        let found = if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        };
        return Err(Error::Device(format!(
            "`adapter_name`={wanted:?} matches no adapter (found: {found})"
        )));
    }
    adapters.sort_by_key(|a| rank(&a.get_info()));
    if kinds == AdapterKinds::Hardware && !adapters.is_empty() && adapters.iter().all(|a| is_software(&a.get_info())) {
        let names: Vec<String> = adapters.iter().map(|a| label(&a.get_info())).collect();
        return Err(Error::Device(format!(
            "only software adapters ({}), which are slower than the CPU path on the same cores; \
             `device` gpu uses them",
            names.join(", ")
        )));
    }
    adapters.retain(|a| kinds == AdapterKinds::Any || !is_software(&a.get_info()));
    adapters.into_iter().next().ok_or_else(|| {
        Error::Device(
            "no GPU adapter found (on Debian, `apt-get install mesa-vulkan-drivers` provides \
             lavapipe); use `device` cpu for the CPU reference path"
                .into(),
        )
    })
}

/// The first error wgpu reported on a device penumbra created itself
/// (`headless`): without a handler wgpu panics on a validation error, e.g.
/// a texture usage llvmpipe's GL backend does not allow. Checked wherever
/// penumbra waits for the GPU (`take_device_error`), so such a run ends
/// with exit 2 naming what the adapter refused, never a panic. Host devices
/// keep their own handler.
static FIRST_DEVICE_ERROR: std::sync::Mutex<Option<String>> = std::sync::Mutex::new(None);

fn install_error_handler(device: &wgpu::Device, adapter: String) {
    device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
        let mut first = FIRST_DEVICE_ERROR.lock().unwrap_or_else(|p| p.into_inner());
        if first.is_none() {
            // wgpu's message: a title, then "Caused by:" and the details.
            let text = e.to_string();
            let detail: Vec<&str> = text
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty() && *l != "Caused by:")
                .collect();
            *first = Some(format!("{adapter} refused the work: {}", detail.join(": ")));
        }
    }));
}

/// The error wgpu reported since the last call, as a device error (exit 2).
pub fn take_device_error() -> Result<()> {
    let mut first = FIRST_DEVICE_ERROR.lock().unwrap_or_else(|p| p.into_inner());
    match first.take() {
        Some(e) => Err(Error::Device(format!(
            "{e} (a capability this adapter lacks; `device` cpu runs the CPU path)"
        ))),
        None => Ok(()),
    }
}

impl GpuContext {
    /// Creates a headless device on the preferred adapter, software ones
    /// included.
    pub fn headless() -> Result<GpuContext> {
        Self::headless_on(AdapterKinds::Any, &AdapterSettings::default())
    }

    /// Creates a headless device on the preferred adapter of `kinds` that
    /// `options` allow, with the limits they ask for.
    pub fn headless_on(kinds: AdapterKinds, options: &AdapterSettings) -> Result<GpuContext> {
        let adapter = pick_adapter(kinds, options)?;
        let info = adapter.get_info();
        let features = adapter.features() & wgpu::Features::TIMESTAMP_QUERY;
        // By default everything the adapter allows (lavapipe's 4096-texel 3D
        // textures and 32 KiB of workgroup memory); portable limits prove
        // that a host asking for no more than WebGPU's defaults is served.
        let limits = match options.limits {
            LimitsChoice::Adapter => adapter.limits(),
            LimitsChoice::Portable => wgpu::Limits::default(),
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("penumbra"),
            required_features: features,
            required_limits: limits,
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| Error::Device(format!("cannot create a device on {}: {e}", info.name)))?;
        let backend = format!("{:?}", info.backend).to_lowercase();
        install_error_handler(&device, format!("{} ({backend})", info.name));
        let capabilities = Capabilities::of_adapter(&adapter, &device);
        let ctx = GpuContext {
            capabilities,
            ..Self::adopt(device, queue, info.name.clone(), backend)
        };
        ctx.kernels.log.warm_up_on(&ctx.queue);
        Ok(ctx)
    }

    /// Adopts a host engine's device and queue. Passes are built for this
    /// device and record into the host's encoders.
    pub fn from_host(device: &wgpu::Device, queue: &wgpu::Queue) -> GpuContext {
        Self::adopt(device.clone(), queue.clone(), "host device".into(), "host".into())
    }

    fn adopt(device: wgpu::Device, queue: wgpu::Queue, name: String, backend: String) -> GpuContext {
        let timestamps = device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        GpuContext {
            capabilities: Capabilities::webgpu(),
            device,
            queue,
            name,
            backend,
            timestamps,
            kernels: Arc::new(Default::default()),
        }
    }

    /// Whether the device is a software adapter (lavapipe, llvmpipe GL):
    /// its kernels run on the CPU's own cores.
    pub fn is_software(&self) -> bool {
        is_software(&self.device.adapter_info())
    }

    /// "name (backend)", as reports name the adapter.
    pub fn label(&self) -> String {
        format!("{} ({})", self.name, self.backend)
    }

    /// `Ok` if this device can run a method with `needs`, else a device
    /// error naming what it lacks (before any work is requested).
    pub fn check(&self, needs: &crate::gpu::device::Needs) -> Result<()> {
        self.capabilities.check(needs, &self.device.limits(), &self.label())
    }

    /// The limits the device was created with.
    pub fn limits(&self) -> wgpu::Limits {
        self.device.limits()
    }

    /// Waits for all submitted work.
    pub fn wait(&self) -> Result<()> {
        let waited = self.device.poll(wgpu::PollType::wait_indefinitely());
        take_device_error()?;
        waited
            .map(|_| ())
            .map_err(|e| Error::internal(format!("waiting for the GPU failed: {e}")))
    }
}
