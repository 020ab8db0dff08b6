//! An open device: its features and limits checked, errors captured, waits bounded by the
//! cell's time limit, its health checked and a lost one replaced.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::adapters::{self, AdapterSummary, MSAA_ON_GL, driver_string};
use super::disk_cache::DiskCache;
use super::error::GpuError;
use super::pipeline_store::PipelineCache;

/// Bytes per pixel of the largest per-pixel storage buffer a frame binds: the counters of
/// instrumented frames, a u32 each.
const COUNTER_BYTES_PER_PIXEL: u64 = 4;
/// Bytes per pixel of the widest image a frame reads back: rgba32float (the HDR target, the
/// raster truth's positions).
const READBACK_BYTES_PER_PIXEL: u64 = 16;

/// How long one cell's GPU work may take by default (`--cell-timeout`).
pub const DEFAULT_CELL_TIMEOUT: Duration = Duration::from_secs(600);

/// An open device and what it can do.
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: AdapterSummary,
    pub backend: wgpu::Backend,
    /// Pass times come from timestamp queries (hardware adapters that have them); otherwise
    /// each pass is submitted alone and timed by the wall clock.
    pub timestamps: bool,
    /// Fragment shaders may force early depth tests (SHADER_EARLY_DEPTH_TEST); without it
    /// the instrumented passes test depth themselves (`render::raster::tests_depth_itself`).
    pub early_depth: bool,
    /// A software adapter (lavapipe, llvmpipe): it shades on the CPU cores this process
    /// shares with every other.
    pub software: bool,
    /// Format of HDR colour targets: rgba32float where the adapter can render (and blend)
    /// it, else rgba16float (OpenGL through wgpu).
    pub hdr_format: wgpu::TextureFormat,
    pub limits: wgpu::Limits,
    /// The sample counts the adapter renders each of `adapters::MULTISAMPLED_FORMATS` with.
    sample_counts: Vec<(wgpu::TextureFormat, Vec<u32>)>,
    uncaptured: Arc<Mutex<Vec<String>>>,
    /// Why the device was lost, once it was (set by wgpu's device-lost callback).
    lost: Arc<Mutex<Option<String>>>,
    /// A wait ran past the cell limit: the queue may still hold that work.
    pub(super) overran: AtomicBool,
    /// The backends asked for, so `reopen` asks for the same.
    requested: Option<String>,
    /// The limits and masked features asked for, so `reopen` asks for the same.
    pub request: adapters::DeviceRequest,
    /// Nanoseconds one cell's GPU work may take (`--cell-timeout`).
    cell_timeout_ns: AtomicU64,
    /// When the current cell began (`begin_cell`); its waits share the limit.
    cell_started: Mutex<Option<Instant>>,
    /// Shader modules, layouts and pipelines made on this device, by what determines them.
    pub(super) pipelines: PipelineCache,
    /// Who the adapter is, for the pipeline cache on disk: wgpu's key (None where wgpu
    /// keeps no cache, all but Vulkan) and what names it (`disk_cache`).
    cache_identity: (Option<String>, String),
    /// Compiled pipelines kept on disk between runs (`disk_cache`), once attached.
    disk_cache: Option<DiskCache>,
}

impl Gpu {
    /// Open the best adapter of `backend` (e.g. "vulkan", "gl"); `None` honours
    /// `WGPU_BACKEND`, else prefers Vulkan and falls back to any backend. The device gets
    /// the adapter's limits and every optional feature `CLUSTERLAB_WITHOUT` does not mask.
    pub fn new(backend: Option<&str>) -> Result<Gpu, GpuError> {
        Self::with_request(backend, adapters::DeviceRequest::from_env()?)
    }

    /// [`Gpu::new`] with the device's limits and masked features given.
    pub fn with_request(
        backend: Option<&str>,
        request: adapters::DeviceRequest,
    ) -> Result<Gpu, GpuError> {
        adapters::timing_override().map_err(GpuError::Setting)?;
        let adapter = adapters::pick(&adapters::Request::new(backend)?)?;
        let mut gpu = Self::open(adapter, request)?;
        gpu.requested = backend.map(str::to_string);
        Ok(gpu)
    }

    /// A new device on the same backends, with the same request and cell limit: what a run
    /// uses in place of a device that became unusable.
    pub fn reopen(&self) -> Result<Gpu, GpuError> {
        let gpu = Self::with_request(self.requested.as_deref(), self.request)?;
        gpu.set_cell_timeout(self.cell_timeout());
        Ok(gpu)
    }

    fn open(adapter: wgpu::Adapter, request: adapters::DeviceRequest) -> Result<Gpu, GpuError> {
        let info = adapter.get_info();
        let features = adapters::device_features(&adapter, request.without);
        let limits = request.limits.request(&adapter.limits());
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
        let lost = Arc::new(Mutex::new(None));
        let lost_sink = lost.clone();
        device.set_device_lost_callback(move |reason, message| {
            if let Ok(mut l) = lost_sink.lock() {
                *l = Some(format!("{reason:?}: {message}"));
            }
        });
        let hdr_format = adapters::hdr_format(&adapter, features);
        let driver = driver_string(&info);
        Ok(Gpu {
            device,
            queue,
            adapter: AdapterSummary {
                name: info.name.clone(),
                backend: info.backend.to_string(),
                driver,
                without: adapters::masked_names(&adapter, request.without),
            },
            backend: info.backend,
            early_depth: features.contains(wgpu::Features::SHADER_EARLY_DEPTH_TEST),
            software: info.device_type == wgpu::DeviceType::Cpu,
            timestamps: features.contains(wgpu::Features::TIMESTAMP_QUERY)
                && adapters::timestamps_are_per_pass(info.device_type),
            hdr_format,
            limits: with_buffer_cap(limits),
            sample_counts: adapters::MULTISAMPLED_FORMATS
                .iter()
                .map(|&f| (f, adapters::sample_counts(&adapter, f, features)))
                .collect(),
            uncaptured,
            lost,
            overran: AtomicBool::new(false),
            requested: None,
            request,
            cell_timeout_ns: AtomicU64::new(DEFAULT_CELL_TIMEOUT.as_nanos() as u64),
            cell_started: Mutex::new(None),
            pipelines: Default::default(),
            cache_identity: (
                features
                    .contains(wgpu::Features::PIPELINE_CACHE)
                    .then(|| wgpu::util::pipeline_cache_key(&info))
                    .flatten(),
                format!(
                    "{} ({}, vendor {:#x}, device {:#x}, {})",
                    info.name,
                    info.backend,
                    info.vendor,
                    info.device,
                    driver_string(&info)
                ),
            ),
            disk_cache: None,
        })
    }

    /// Run `work` with validation, out-of-memory and internal errors captured; any error
    /// becomes `GpuError::Captured` naming `what`.
    pub fn scoped<T>(&self, what: &str, work: impl FnOnce() -> T) -> Result<T, GpuError> {
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = work();
        let v = pollster::block_on(validation.pop());
        let o = pollster::block_on(oom.pop());
        // Internal errors carry why a backend rejected a shader (OpenGL: no GLSL for it).
        let i = pollster::block_on(internal.pop());
        if let Some(e) = i.or(v).or(o) {
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

    /// Check that a scene's buffers and textures fit the adapter's limits (a file scene may
    /// be any size).
    pub fn check_scene(&self, scene: &crate::scene::Scene) -> Result<(), GpuError> {
        let l = &self.limits;
        let name = &scene.name;
        let adapter = &self.adapter.name;
        let buffers = [
            (
                "vertices",
                scene.vertices.len(),
                std::mem::size_of::<crate::common::Vertex>(),
                l.max_buffer_size,
            ),
            ("indices", scene.indices.len(), 4, l.max_buffer_size),
            (
                "lights",
                scene.lights.len(),
                std::mem::size_of::<crate::common::Light>(),
                self.max_storage_bytes(),
            ),
        ];
        for (what, count, size, max) in buffers {
            let bytes = count as u64 * size as u64;
            if bytes > max {
                return Err(GpuError::TooLarge(format!(
                    "scene `{name}`: its {count} {what} take {bytes} bytes, more than the {max} bytes adapter `{adapter}` allows in one buffer; use a smaller scene (at most {} {what}) or an adapter with larger buffers",
                    max / size as u64
                )));
            }
        }
        if let Some(t) = &scene.textures
            && (t.size > l.max_texture_dimension_2d || t.layers > l.max_texture_array_layers)
        {
            return Err(GpuError::TooLarge(format!(
                "scene `{name}`: its {} base colour textures of {}x{} exceed adapter `{adapter}` (at most {} layers of {}x{})",
                t.layers,
                t.size,
                t.size,
                l.max_texture_array_layers,
                l.max_texture_dimension_2d,
                l.max_texture_dimension_2d
            )));
        }
        Ok(())
    }

    /// The most bytes one buffer bound whole as storage may hold on this adapter.
    pub fn max_storage_bytes(&self) -> u64 {
        let l = &self.limits;
        l.max_buffer_size.min(l.max_storage_buffer_binding_size)
    }

    /// Check that a cluster grid of `grid` fits the adapter's buffers: its largest per-cluster
    /// buffer is the boxes, 32 bytes a cluster, bound whole as storage.
    pub fn check_grid(&self, grid: (u32, u32, u32)) -> Result<(), GpuError> {
        let max = self.max_storage_bytes();
        let clusters = grid.0 as u64 * grid.1 as u64 * grid.2 as u64;
        let bytes = clusters * 32;
        if bytes > max {
            return Err(GpuError::TooLarge(format!(
                "grid {}x{}x{}: its {clusters} cluster boxes take {bytes} bytes, more than the {max} bytes adapter `{}` allows in one buffer; use a coarser grid (at most {} clusters)",
                grid.0,
                grid.1,
                grid.2,
                self.adapter.name,
                max / 32
            )));
        }
        Ok(())
    }

    /// Check that a `width` x `height` frame fits the adapter's limits: each side within its
    /// largest texture, the per-pixel counters within one storage binding, and the widest
    /// image read back (the HDR target or the raster truth, rgba32float) within one buffer.
    pub fn check_size(&self, width: u32, height: u32) -> Result<(), GpuError> {
        let max = self.limits.max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(GpuError::TooLarge(format!(
                "size {width}x{height} (`--size`) is outside what adapter `{}` can render: each side must be in 1..={max}",
                self.adapter.name
            )));
        }
        let storage = self.max_storage_bytes();
        let buffer = self.limits.max_buffer_size;
        let fits = |w: u64, h: u64| {
            let row = (w * READBACK_BYTES_PER_PIXEL)
                .next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as u64);
            w * h * COUNTER_BYTES_PER_PIXEL <= storage && row * h <= buffer
        };
        let (w, h) = (width as u64, height as u64);
        if fits(w, h) {
            return Ok(());
        }
        // The largest frame of the same shape that fits.
        let scale = ((storage / COUNTER_BYTES_PER_PIXEL).min(buffer / READBACK_BYTES_PER_PIXEL)
            as f64
            / (w * h) as f64)
            .sqrt();
        let (mut fw, mut fh) = ((w as f64 * scale) as u64, (h as f64 * scale) as u64);
        while fw > 1 && fh > 1 && !fits(fw, fh) {
            (fw, fh) = (fw - fw.div_ceil(100), fh - fh.div_ceil(100));
        }
        Err(GpuError::TooLarge(format!(
            "size {width}x{height} (`--size`) is more than adapter `{}` can hold: its {} pixels need per-pixel counters of {} bytes in one storage binding (at most {storage}) and a read-back of {} bytes per pixel in one buffer (at most {buffer}); the largest frame of this shape that fits is {fw}x{fh}",
            self.adapter.name,
            w * h,
            w * h * COUNTER_BYTES_PER_PIXEL,
            READBACK_BYTES_PER_PIXEL
        )))
    }

    /// Check that the adapter renders every target of `targets` (what it is, its format)
    /// with `samples` samples a pixel (`msaa.samples`).
    pub fn check_samples(
        &self,
        samples: u32,
        targets: &[(&str, wgpu::TextureFormat)],
    ) -> Result<(), GpuError> {
        if samples > 1 && self.backend == wgpu::Backend::Gl {
            return Err(GpuError::TooLarge(format!(
                "msaa.samples {samples}: {MSAA_ON_GL}; use samples: 1 on adapter `{}`, or Vulkan (lavapipe) for multisampling",
                self.adapter.name
            )));
        }
        for &(what, format) in targets {
            let counts = self
                .sample_counts
                .iter()
                .find(|(f, _)| *f == format)
                .map_or(&[1][..], |(_, c)| c.as_slice());
            if !counts.contains(&samples) {
                return Err(GpuError::TooLarge(format!(
                    "msaa.samples {samples}: adapter `{}` renders the {what} ({}) with {counts:?} samples a pixel only; use one of those (`clusterlab adapters` lists every format's counts)",
                    self.adapter.name,
                    format!("{format:?}").to_lowercase(),
                )));
            }
        }
        Ok(())
    }

    /// The sample counts (of 1, 2, 4, 8) every multisampled target renders with here.
    pub fn multisample_counts(&self) -> Vec<u32> {
        let every: Vec<(&str, wgpu::TextureFormat)> = adapters::MULTISAMPLED_FORMATS
            .iter()
            .map(|&f| ("target", f))
            .filter(|&(_, f)| f != wgpu::TextureFormat::Rgba32Float || self.hdr_format == f)
            .collect();
        [1, 2, 4, 8]
            .into_iter()
            .filter(|&n| self.check_samples(n, &every).is_ok())
            .collect()
    }

    /// The limit on one cell's GPU work (`--cell-timeout`).
    pub fn cell_timeout(&self) -> Duration {
        Duration::from_nanos(self.cell_timeout_ns.load(Ordering::Relaxed))
    }

    pub fn set_cell_timeout(&self, limit: Duration) {
        let ns = u64::try_from(limit.as_nanos()).unwrap_or(u64::MAX);
        self.cell_timeout_ns.store(ns, Ordering::Relaxed);
    }

    /// Start the clock of a cell: its waits together may take up to the cell limit. Without
    /// it, each wait has the whole limit to itself.
    pub fn begin_cell(&self) {
        if let Ok(mut started) = self.cell_started.lock() {
            *started = Some(Instant::now());
        }
    }

    /// Block until all submitted work is done, or fail once the cell's limit is spent.
    ///
    /// A poll that times out means "not yet": wgpu's OpenGL backend clamps every fence wait
    /// to `i32::MAX` ns (about 2.1 s), even an indefinite one, so a long frame on a software
    /// GPU comes back as a timeout many times before it is done.
    pub fn wait(&self) -> Result<(), GpuError> {
        let started = self
            .cell_started
            .lock()
            .ok()
            .and_then(|s| *s)
            .unwrap_or_else(Instant::now);
        loop {
            self.check_lost()?;
            let limit = self.cell_timeout();
            let remaining = limit.saturating_sub(started.elapsed());
            if remaining.is_zero() {
                self.overran.store(true, Ordering::Relaxed);
                return Err(GpuError::TimedOut { limit });
            }
            match self.device.poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: Some(remaining),
            }) {
                Ok(_) => return Ok(()),
                Err(wgpu::PollError::Timeout) => continue,
                Err(e) => return Err(GpuError::Captured(e.to_string())),
            }
        }
    }

    pub(super) fn check_lost(&self) -> Result<(), GpuError> {
        match self.lost.lock().ok().and_then(|l| l.clone()) {
            Some(why) => Err(GpuError::Lost(why)),
            None => Ok(()),
        }
    }
}

/// The adapter's limits, with the largest buffer lowered to `CLUSTERLAB_MAX_BUFFER_SIZE`
/// bytes when that is set: to see what a scene needs of an adapter with smaller buffers
/// (and to test the error a too-large mesh gets without writing gigabytes).
fn with_buffer_cap(mut limits: wgpu::Limits) -> wgpu::Limits {
    if let Ok(Some(cap)) = buffer_cap() {
        limits.max_buffer_size = limits.max_buffer_size.min(cap);
    }
    limits
}

impl Gpu {
    /// Attach the pipeline cache of this adapter in `folder`, loading what an earlier run
    /// of this clusterlab version on this adapter saved there. Returns a note for the user:
    /// where the cache is, or why it was not loaded or is not kept.
    pub fn attach_disk_cache(&mut self, folder: &std::path::Path) -> String {
        let (kept, note) = DiskCache::attach(
            &self.device,
            folder,
            &self.cache_identity,
            &self.adapter.backend,
        );
        self.disk_cache = kept;
        note
    }

    /// The attached pipeline cache, for pipeline descriptors.
    pub fn pipeline_cache(&self) -> Option<&wgpu::PipelineCache> {
        self.disk_cache.as_ref().map(|d| &d.cache)
    }

    /// Save the attached cache (nothing when none is attached or the driver gives no data).
    pub fn save_disk_cache(&self) -> Result<(), String> {
        self.disk_cache.as_ref().map_or(Ok(()), DiskCache::save)
    }
}

/// The variable that lowers the largest buffer a device is asked for (see `with_buffer_cap`).
pub const MAX_BUFFER_SIZE_VAR: &str = "CLUSTERLAB_MAX_BUFFER_SIZE";

/// `CLUSTERLAB_MAX_BUFFER_SIZE` in bytes, when set.
pub(super) fn buffer_cap() -> Result<Option<u64>, String> {
    let Some(value) = crate::environment::var_os(MAX_BUFFER_SIZE_VAR) else {
        return Ok(None);
    };
    let value = value.to_string_lossy();
    value
        .trim()
        .parse::<u64>()
        .ok()
        .filter(|&n| n >= 4)
        .map(Some)
        .ok_or_else(|| {
            format!(
                "{MAX_BUFFER_SIZE_VAR}=`{value}` is not a number of bytes: give the largest buffer to allow, a whole number of at least 4 (e.g. 65536), or unset it"
            )
        })
}
