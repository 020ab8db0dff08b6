//! The GPU: adapter choice, device with checked features and limits, captured errors,
//! per-pass timing and read-back.

mod readback;
mod timing;

pub use readback::{read_buffer, read_texture};
pub use timing::{PassTimer, TimestampSlot, Timings};

use std::fmt;
use std::sync::{Arc, Mutex};

/// What the adapter is, as reports print it.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub driver: String,
}

/// Why the GPU could not be used.
#[derive(Debug)]
pub enum GpuError {
    NoAdapter {
        backends: String,
    },
    UnknownBackend(String),
    Device(String),
    /// A wgpu validation or out-of-memory error captured while running a pass.
    Captured(String),
    TooLarge(String),
}

impl fmt::Display for GpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GpuError::NoAdapter { backends } => write!(
                f,
                "no GPU adapter found (backends tried: {backends}). Without a GPU, install Mesa's \
                 software Vulkan driver (lavapipe): `apt-get install mesa-vulkan-drivers`; or try \
                 OpenGL (llvmpipe) with `--backend gl` or `WGPU_BACKEND=gl`"
            ),
            GpuError::UnknownBackend(b) => write!(
                f,
                "unknown backend `{b}`; use vulkan, gl, metal or dx12 (or a comma list)"
            ),
            GpuError::Device(e) => write!(f, "could not open the GPU device: {e}"),
            GpuError::Captured(e) => write!(f, "GPU error: {e}"),
            GpuError::TooLarge(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for GpuError {}

/// An open device and what it can do.
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: AdapterSummary,
    /// Pass times come from timestamp queries (hardware adapters that have them); otherwise
    /// each pass is submitted alone and timed by the wall clock.
    pub timestamps: bool,
    /// Format of HDR colour targets: rgba32float where the adapter can render (and blend)
    /// it, else rgba16float (OpenGL through wgpu).
    pub hdr_format: wgpu::TextureFormat,
    pub limits: wgpu::Limits,
    uncaptured: Arc<Mutex<Vec<String>>>,
}

impl Gpu {
    /// Open the best adapter of `backend` (e.g. "vulkan", "gl"); `None` honours
    /// `WGPU_BACKEND`, else prefers Vulkan and falls back to any backend.
    pub fn new(backend: Option<&str>) -> Result<Gpu, GpuError> {
        let requested = match backend {
            Some(b) => Some(parse_backends(b)?),
            None => wgpu::Backends::from_env(),
        };
        let tries: Vec<wgpu::Backends> = match requested {
            Some(b) => vec![b],
            None => vec![wgpu::Backends::VULKAN, wgpu::Backends::all()],
        };
        for backends in &tries {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
            desc.backends = *backends;
            desc.flags = wgpu::InstanceFlags::empty().with_env();
            let instance = wgpu::Instance::new(desc);
            let mut adapters = pollster::block_on(instance.enumerate_adapters(*backends));
            // Real GPUs before software ones; Vulkan before other backends.
            adapters.sort_by_key(|a| {
                let info = a.get_info();
                let kind = match info.device_type {
                    wgpu::DeviceType::DiscreteGpu => 0,
                    wgpu::DeviceType::IntegratedGpu => 1,
                    wgpu::DeviceType::VirtualGpu => 2,
                    wgpu::DeviceType::Cpu => 3,
                    wgpu::DeviceType::Other => 4,
                };
                (kind, info.backend != wgpu::Backend::Vulkan)
            });
            if let Some(adapter) = adapters.into_iter().next() {
                return Self::open(adapter);
            }
        }
        let backends = tries.last().map(|b| format!("{b:?}")).unwrap_or_default();
        Err(GpuError::NoAdapter { backends })
    }

    fn open(adapter: wgpu::Adapter) -> Result<Gpu, GpuError> {
        let info = adapter.get_info();
        let available = adapter.features();
        // Adapter-specific format features: OpenGL reports rgba32float as renderable only here.
        // Forced early depth tests let instrumented passes count what early-Z shades.
        let wanted = wgpu::Features::TIMESTAMP_QUERY
            | wgpu::Features::SHADER_EARLY_DEPTH_TEST
            | wgpu::Features::FLOAT32_BLENDABLE
            | wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES;
        let features = available & wanted;
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("clusterlab"),
            required_features: features,
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        // wgpu's default handler panics; keep errors that escape every scope and report them.
        let uncaptured = Arc::new(Mutex::new(Vec::new()));
        let sink = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        let f32_usages = adapter
            .get_texture_format_features(wgpu::TextureFormat::Rgba32Float)
            .allowed_usages;
        let hdr_format = if f32_usages.contains(wgpu::TextureUsages::RENDER_ATTACHMENT)
            && features.contains(wgpu::Features::FLOAT32_BLENDABLE)
        {
            wgpu::TextureFormat::Rgba32Float
        } else {
            wgpu::TextureFormat::Rgba16Float
        };
        let driver = [info.driver.trim(), info.driver_info.trim()]
            .into_iter()
            .filter(|s| !s.is_empty())
            .collect::<Vec<_>>()
            .join(" ");
        Ok(Gpu {
            device,
            queue,
            adapter: AdapterSummary {
                name: info.name.clone(),
                backend: info.backend.to_string(),
                driver,
            },
            timestamps: features.contains(wgpu::Features::TIMESTAMP_QUERY)
                && timestamps_are_per_pass(info.device_type),
            hdr_format,
            limits,
            uncaptured,
        })
    }

    /// Run `work` with validation and out-of-memory errors captured; any error becomes
    /// `GpuError::Captured` naming `what`.
    pub fn scoped<T>(&self, what: &str, work: impl FnOnce() -> T) -> Result<T, GpuError> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = work();
        let v = pollster::block_on(validation.pop());
        let o = pollster::block_on(oom.pop());
        if let Some(e) = v.or(o) {
            return Err(GpuError::Captured(format!("{what}: {e}")));
        }
        self.take_uncaptured(what)?;
        Ok(out)
    }

    /// Fail with any error reported outside a scope since the last call.
    pub fn take_uncaptured(&self, what: &str) -> Result<(), GpuError> {
        let errors: Vec<String> = self
            .uncaptured
            .lock()
            .map(|mut v| std::mem::take(&mut *v))
            .unwrap_or_default();
        if errors.is_empty() {
            Ok(())
        } else {
            Err(GpuError::Captured(format!("{what}: {}", errors.join("; "))))
        }
    }

    /// Check that a `width` x `height` frame fits the adapter's limits.
    pub fn check_size(&self, width: u32, height: u32) -> Result<(), GpuError> {
        let max = self.limits.max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(GpuError::TooLarge(format!(
                "size {width}x{height} is outside what adapter `{}` can render: each side must be in 1..={max}",
                self.adapter.name
            )));
        }
        Ok(())
    }

    /// Block until all submitted work is done.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| GpuError::Captured(e.to_string()))
    }
}

fn parse_backends(name: &str) -> Result<wgpu::Backends, GpuError> {
    let b = wgpu::Backends::from_comma_list(name);
    if b.is_empty() {
        Err(GpuError::UnknownBackend(name.to_string()))
    } else {
        Ok(b)
    }
}

/// Whether pass timestamps measure each pass's own work. Software adapters (lavapipe,
/// llvmpipe) record a compute pass's timestamps without waiting for its dispatches, whose
/// work then lands in whichever pass comes next; there each pass is submitted alone and
/// timed by the wall clock instead, which on a CPU device is exactly its cost.
/// `CLUSTERLAB_TIMING=timestamps` or `=wall` overrides the choice.
fn timestamps_are_per_pass(device: wgpu::DeviceType) -> bool {
    match std::env::var("CLUSTERLAB_TIMING").as_deref() {
        Ok("timestamps") => true,
        Ok("wall") => false,
        _ => device != wgpu::DeviceType::Cpu,
    }
}
