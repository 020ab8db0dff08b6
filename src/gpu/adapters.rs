//! Which adapters wgpu sees, what each offers clusterlab, and which one a run picks and why:
//! the choice `Gpu::new` makes, and the survey `clusterlab adapters` prints.

use serde::Serialize;

use super::deviations::DEVIATIONS;
use super::error::GpuError;

/// What the adapter is, as reports print it.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub driver: String,
    /// Optional features the adapter has that `CLUSTERLAB_WITHOUT` masked from the device.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub without: Vec<String>,
}

/// The variable that sets how many threads Mesa's software GPU (llvmpipe, lavapipe) splits
/// each pass among (`clusterlab` sets twice the cores unless it is set).
pub const SOFTWARE_GPU_THREADS: &str = "LP_NUM_THREADS";

/// The software GPU's thread count as this process has it, for the record: the variable's
/// value, or None when unset (one thread per core).
pub fn software_gpu_threads() -> Option<String> {
    crate::environment::var(SOFTWARE_GPU_THREADS)
}

/// Why a multisampled frame cannot run on wgpu 30's OpenGL backend, though the driver
/// offers the sample counts.
pub const MSAA_ON_GL: &str = "wgpu's OpenGL backend creates a multisampled texture that shaders read with the target GL_TEXTURE_2D, which OpenGL rejects (GL_INVALID_ENUM; gfx-rs/wgpu#6084), so nothing renders into it and no pass can read its samples";

/// The driver's name and version, as one line.
pub(super) fn driver_string(info: &wgpu::AdapterInfo) -> String {
    [info.driver.trim(), info.driver_info.trim()]
        .into_iter()
        .filter(|s| !s.is_empty())
        .collect::<Vec<_>>()
        .join(" ")
}

/// Where the backends to try came from.
#[derive(Clone, Debug)]
pub enum Request {
    /// `--backend` (or a library caller).
    Flag(String, wgpu::Backends),
    /// The `WGPU_BACKEND` environment variable.
    Env(String, wgpu::Backends),
    /// Neither: Vulkan first, then any backend.
    Default,
}

impl Request {
    /// `backend` if given, else `WGPU_BACKEND` if set, else the default order.
    pub fn new(backend: Option<&str>) -> Result<Request, GpuError> {
        if let Some(b) = backend {
            return Ok(Request::Flag(
                b.to_string(),
                parse_backends(b, "--backend")?,
            ));
        }
        match crate::environment::var("WGPU_BACKEND") {
            Some(b) if !b.trim().is_empty() => {
                let backends = parse_backends(&b, "WGPU_BACKEND")?;
                Ok(Request::Env(b, backends))
            }
            _ => Ok(Request::Default),
        }
    }

    /// The backend sets to try, in order; the first that has an adapter is used.
    pub fn tries(&self) -> Vec<wgpu::Backends> {
        match self {
            Request::Flag(_, b) | Request::Env(_, b) => vec![*b],
            Request::Default => vec![wgpu::Backends::VULKAN, wgpu::Backends::all()],
        }
    }

    fn describe(&self) -> String {
        match self {
            Request::Flag(b, _) => format!("--backend {b}: only those backends"),
            Request::Env(b, _) => format!("WGPU_BACKEND={b}: only those backends"),
            Request::Default => {
                "no --backend and no WGPU_BACKEND: Vulkan adapters first, any backend when \
                 there is none"
                    .into()
            }
        }
    }
}

/// Parse a comma list of backend names, refusing any name wgpu does not know (wgpu itself
/// skips them silently).
fn parse_backends(list: &str, from: &'static str) -> Result<wgpu::Backends, GpuError> {
    let mut all = wgpu::Backends::empty();
    for name in list.split(',') {
        let b = wgpu::Backends::from_comma_list(name);
        if b.is_empty() {
            return Err(GpuError::UnknownBackend {
                value: name.trim().to_string(),
                from,
            });
        }
        all |= b;
    }
    Ok(all)
}

/// Every adapter of `backends`, best first: real GPUs before software ones, Vulkan before
/// other backends of the same kind.
///
/// Each call makes its own instance, so each device has its own OpenGL context (devices of
/// one GL instance share its context, and their state mixes: frames came out wrong). An
/// instance with OpenGL among its backends is never dropped: wgpu's GL instance dropped off
/// the main thread, as a test harness's threads do, crashed llvmpipe now and then
/// (gfx-rs/wgpu#4293, open upstream; gfx-rs/wgpu-rs#770 before it). Each one kept holds
/// an EGL context: one per device a process opens, a few in a command, hundreds in tests.
pub fn enumerate(backends: wgpu::Backends) -> Vec<wgpu::Adapter> {
    static KEPT: std::sync::Mutex<Vec<wgpu::Instance>> = std::sync::Mutex::new(Vec::new());
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backends;
    desc.flags = wgpu::InstanceFlags::empty().with_env();
    let instance = wgpu::Instance::new(desc);
    let mut adapters = pollster::block_on(instance.enumerate_adapters(backends));
    adapters.sort_by_key(|a| rank(&a.get_info()));
    if backends.contains(wgpu::Backends::GL) {
        KEPT.lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(instance);
    }
    adapters
}

const RANKING: &str = "real GPUs before software ones (discrete, integrated, virtual, CPU, \
                       other), Vulkan before other backends of the same kind";

fn rank(info: &wgpu::AdapterInfo) -> (u8, bool) {
    let kind = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    (kind, info.backend != wgpu::Backend::Vulkan)
}

/// The adapter a run uses for `request` (the best of those that can run clusterlab's
/// pipelines), or why there is none.
pub fn pick(request: &Request) -> Result<wgpu::Adapter, GpuError> {
    let tries = request.tries();
    let mut unusable = Vec::new();
    for backends in &tries {
        for adapter in enumerate(*backends) {
            match missing_requirements(&adapter) {
                None => return Ok(adapter),
                Some(why) => unusable.push(format!("{}: {why}", adapter.get_info().name)),
            }
        }
    }
    if !unusable.is_empty() {
        unusable.dedup();
        return Err(GpuError::Device(format!(
            "no adapter here can run clusterlab's pipelines ({}); `clusterlab adapters` lists what each has",
            unusable.join("; ")
        )));
    }
    let backends = tries.last().map(|b| format!("{b:?}")).unwrap_or_default();
    Err(GpuError::NoAdapter { backends })
}

/// What `adapter` lacks of what every frame needs, if anything (an OpenGL 3.3 adapter has
/// no storage buffers: wgpu refused its pipelines with a raw error). See [`lacks`].
pub fn missing_requirements(adapter: &wgpu::Adapter) -> Option<String> {
    lacks(
        adapter.get_downlevel_capabilities().flags,
        &adapter.limits(),
    )
}

/// What an adapter with downlevel `flags` and `limits` lacks: compute shaders (cluster
/// bounds, light assignment, post effects), storage writes in fragment shaders (the
/// counters), indirect dispatch (bloom), and the storage buffers a stage binds (wgpu's
/// downlevel default of 4, which the smallest pipeline needs: naive forward binds 3).
pub fn lacks(flags: wgpu::DownlevelFlags, limits: &wgpu::Limits) -> Option<String> {
    use wgpu::DownlevelFlags as F;
    let needed = wgpu::Limits::downlevel_defaults().max_storage_buffers_per_shader_stage;
    let mut missing: Vec<String> = [
        (F::COMPUTE_SHADERS, "compute shaders"),
        (
            F::FRAGMENT_WRITABLE_STORAGE,
            "storage writes in fragment shaders",
        ),
        (F::INDIRECT_EXECUTION, "indirect dispatch"),
    ]
    .into_iter()
    .filter(|(f, _)| !flags.contains(*f))
    .map(|(_, what)| what.to_string())
    .collect();
    if limits.max_storage_buffers_per_shader_stage < needed {
        missing.push(format!(
            "{} storage buffers a stage of the {needed} needed",
            limits.max_storage_buffers_per_shader_stage
        ));
    }
    (!missing.is_empty()).then(|| format!("unusable: no {}", missing.join(", no ")))
}

/// The variable that masks optional features from the device request, so a machine that
/// has them runs as one without would (a Mac has no forced early depth tests).
pub const WITHOUT: &str = "CLUSTERLAB_WITHOUT";

/// The optional features clusterlab asks for when the adapter has them, by the names
/// `CLUSTERLAB_WITHOUT` masks them with, and what a device without each does instead.
pub const OPTIONAL_FEATURES: [(&str, wgpu::Features, &str); 4] = [
    (
        "early-depth",
        wgpu::Features::SHADER_EARLY_DEPTH_TEST,
        "instrumented forward and transparent passes test depth in the shader, with no depth attached",
    ),
    (
        "timestamps",
        wgpu::Features::TIMESTAMP_QUERY,
        "each pass is submitted alone and timed by the wall clock",
    ),
    (
        "float32-blend",
        wgpu::Features::FLOAT32_BLENDABLE,
        "the HDR target is rgba16float",
    ),
    (
        "format-features",
        wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES,
        "formats do only what WebGPU guarantees: sample counts 1 and 4 where multisampling is allowed at all, no rgba32float target on OpenGL",
    ),
];

/// The features `CLUSTERLAB_WITHOUT` (a comma list of `OPTIONAL_FEATURES`' names) masks;
/// an unknown name is an error that lists the valid ones (`Gpu::new` refuses it).
pub fn masked_features() -> Result<wgpu::Features, String> {
    let Some(list) = crate::environment::var(WITHOUT) else {
        return Ok(wgpu::Features::empty());
    };
    let mut masked = wgpu::Features::empty();
    for name in list.split(',').map(str::trim).filter(|n| !n.is_empty()) {
        match OPTIONAL_FEATURES.iter().find(|(n, _, _)| *n == name) {
            Some((_, f, _)) => masked |= *f,
            None => {
                let valid: Vec<&str> = OPTIONAL_FEATURES.iter().map(|(n, _, _)| *n).collect();
                return Err(format!(
                    "`{name}` (from {WITHOUT}) is not an optional feature; use a comma list of {}",
                    valid.join(", ")
                ));
            }
        }
    }
    Ok(masked)
}

/// The optional features clusterlab asks for when the adapter has them, less `without`.
pub fn wanted_features(without: wgpu::Features) -> wgpu::Features {
    // Adapter-specific format features: OpenGL reports rgba32float as renderable only here.
    // Forced early depth tests let instrumented passes count what early-Z shades.
    // A pipeline cache keeps compiled pipelines between runs (`gpu::disk_cache`).
    let all = OPTIONAL_FEATURES
        .iter()
        .fold(wgpu::Features::PIPELINE_CACHE, |a, (_, f, _)| a | *f);
    all - without
}

/// What a device with `features` may do with `format`: the adapter's own format features
/// where it asked for them, else only what WebGPU guarantees.
pub fn format_features(
    adapter: &wgpu::Adapter,
    format: wgpu::TextureFormat,
    features: wgpu::Features,
) -> wgpu::TextureFormatFeatures {
    if features.contains(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES) {
        adapter.get_texture_format_features(format)
    } else {
        format.guaranteed_format_features(features)
    }
}

/// Whether rgba32float can be rendered to and blended.
fn float32_target(adapter: &wgpu::Adapter, features: wgpu::Features) -> bool {
    let usages =
        format_features(adapter, wgpu::TextureFormat::Rgba32Float, features).allowed_usages;
    usages.contains(wgpu::TextureUsages::RENDER_ATTACHMENT)
        && features.contains(wgpu::Features::FLOAT32_BLENDABLE)
}

/// The features a device on `adapter` is opened with, `without` masked.
pub fn device_features(adapter: &wgpu::Adapter, without: wgpu::Features) -> wgpu::Features {
    adapter.features() & wanted_features(without)
}

/// The HDR colour target's format for a device with `features`: rgba32float where it can
/// render and blend it, else rgba16float (OpenGL through wgpu).
pub fn hdr_format(adapter: &wgpu::Adapter, features: wgpu::Features) -> wgpu::TextureFormat {
    if float32_target(adapter, features) {
        wgpu::TextureFormat::Rgba32Float
    } else {
        wgpu::TextureFormat::Rgba16Float
    }
}

/// Whether pass timestamps measure each pass's own work. Software adapters (lavapipe,
/// llvmpipe) record a compute pass's timestamps without waiting for its dispatches, whose
/// work then lands in whichever pass comes next; there each pass is submitted alone and
/// timed by the wall clock instead, which on a CPU device is exactly its cost.
/// `CLUSTERLAB_TIMING=timestamps` or `=wall` overrides the choice.
pub fn timestamps_are_per_pass(device: wgpu::DeviceType) -> bool {
    timing_override()
        .ok()
        .flatten()
        .unwrap_or(device != wgpu::DeviceType::Cpu)
}

/// `CLUSTERLAB_TIMING`: Some(true) for `timestamps`, Some(false) for `wall`, None when
/// unset; any other value is an error that names it (`Gpu::new` refuses it).
pub fn timing_override() -> Result<Option<bool>, String> {
    match crate::environment::var("CLUSTERLAB_TIMING") {
        None => Ok(None),
        Some(v) => match v.as_str() {
            "timestamps" => Ok(Some(true)),
            "wall" => Ok(Some(false)),
            other => Err(format!(
                "`{other}` (from CLUSTERLAB_TIMING) is not a way to time passes; use \
                 `timestamps` or `wall`, or leave it unset"
            )),
        },
    }
}

/// The formats a multisampled frame may render to: HDR targets, the G-buffers' targets,
/// the truth pass's, depth.
pub const MULTISAMPLED_FORMATS: [wgpu::TextureFormat; 8] = [
    wgpu::TextureFormat::Rgba32Float,
    wgpu::TextureFormat::Rgba16Float,
    wgpu::TextureFormat::Rgba32Uint,
    wgpu::TextureFormat::Rgba8Unorm,
    wgpu::TextureFormat::R32Uint,
    wgpu::TextureFormat::Rg8Unorm,
    wgpu::TextureFormat::Depth32Float,
    wgpu::TextureFormat::Depth24Plus,
];

/// The sample counts (of 1, 2, 4, 8) a device with `features` can render `format` with.
pub fn sample_counts(
    adapter: &wgpu::Adapter,
    format: wgpu::TextureFormat,
    features: wgpu::Features,
) -> Vec<u32> {
    let flags = format_features(adapter, format, features).flags;
    [1, 2, 4, 8]
        .into_iter()
        .filter(|&n| flags.sample_count_supported(n))
        .collect()
}

/// A format and the sample counts an adapter renders it with.
#[derive(Clone, Debug, Serialize)]
pub struct FormatSamples {
    pub format: String,
    pub samples: Vec<u32>,
}

/// One capability clusterlab uses, and whether an adapter has it.
#[derive(Clone, Debug, Serialize)]
pub struct Capability {
    pub name: &'static str,
    pub present: bool,
    /// The adapter has it, but `CLUSTERLAB_WITHOUT` masks it from the device.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub masked: bool,
    /// What clusterlab does with it, and without it.
    #[serde(rename = "use")]
    pub use_: &'static str,
}

/// An adapter as `clusterlab adapters` reports it.
#[derive(Clone, Debug, Serialize)]
pub struct AdapterReport {
    pub name: String,
    /// Why clusterlab cannot run its pipelines here, when it cannot (`lacks`).
    pub unusable: Option<String>,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
    pub vendor_id: u32,
    pub device_id: u32,
    pub capabilities: Vec<Capability>,
    /// Sample counts per format (`msaa.samples`).
    pub multisampling: Vec<FormatSamples>,
    pub hdr_format: String,
    pub timing: String,
    pub max_texture_side: u32,
    pub max_storage_buffer_bytes: u64,
    pub max_buffer_bytes: u64,
    /// Where this adapter's results legitimately differ from the reviewed ones (see
    /// `gpu::expect`).
    pub declared_differences: Vec<&'static str>,
    /// Whether `render`, `matrix`, `stress` and `study` would use this adapter.
    pub chosen: bool,
}

/// What `clusterlab adapters` prints.
#[derive(Clone, Debug, Serialize)]
pub struct Survey {
    pub tool: String,
    pub adapters: Vec<AdapterReport>,
    /// How the adapter is chosen.
    pub rule: String,
    /// The chosen adapter's index in `adapters`.
    pub chosen: Option<usize>,
    /// Why no adapter can be used, when none can.
    pub problem: Option<String>,
    /// Hints and the environment variables that change the choice.
    pub notes: Vec<String>,
}

fn capabilities(adapter: &wgpu::Adapter) -> Vec<Capability> {
    let f = adapter.features();
    let down = adapter.get_downlevel_capabilities().flags;
    let masked = masked_features().unwrap_or_default();
    let has = |x: wgpu::Features| f.contains(x);
    let d = |x: wgpu::DownlevelFlags| down.contains(x);
    let feature = |name, x: wgpu::Features, use_| Capability {
        name,
        present: has(x),
        masked: has(x) && masked.contains(x),
        use_,
    };
    vec![
        Capability {
            name: "compute shaders",
            masked: false,
            present: d(wgpu::DownlevelFlags::COMPUTE_SHADERS),
            use_: "required: cluster bounds, light assignment, post effects",
        },
        Capability {
            name: "storage writes in fragment shaders",
            masked: false,
            present: d(wgpu::DownlevelFlags::FRAGMENT_WRITABLE_STORAGE),
            use_: "required: the counters of instrumented frames",
        },
        Capability {
            name: "per-sample shading",
            masked: false,
            present: d(wgpu::DownlevelFlags::MULTISAMPLED_SHADING),
            use_: "multisampled scissor deferred, which shades every sample",
        },
        Capability {
            name: "indirect dispatch",
            masked: false,
            present: d(wgpu::DownlevelFlags::INDIRECT_EXECUTION),
            use_: "required: bloom's blur sized by its bright pass",
        },
        feature(
            "early depth test (SHADER_EARLY_DEPTH_TEST)",
            wgpu::Features::SHADER_EARLY_DEPTH_TEST,
            "instrumented forward passes count only what early-Z shades; without it they test depth in the shader",
        ),
        feature(
            "timestamp queries (TIMESTAMP_QUERY)",
            wgpu::Features::TIMESTAMP_QUERY,
            "per-pass GPU times on hardware adapters; without them each pass is timed by the wall clock",
        ),
        feature(
            "float32 blending (FLOAT32_BLENDABLE)",
            wgpu::Features::FLOAT32_BLENDABLE,
            "with a renderable rgba32float: a 32-bit HDR target; else rgba16float",
        ),
        Capability {
            name: "rgba32float render target",
            masked: false,
            present: adapter
                .get_texture_format_features(wgpu::TextureFormat::Rgba32Float)
                .allowed_usages
                .contains(wgpu::TextureUsages::RENDER_ATTACHMENT),
            use_: "with float32 blending: a 32-bit HDR target; else rgba16float",
        },
        feature(
            "adapter-specific format features",
            wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES,
            "OpenGL reports rgba32float as renderable only through it",
        ),
    ]
}

fn report(adapter: &wgpu::Adapter, chosen: bool) -> AdapterReport {
    let info = adapter.get_info();
    let limits = adapter.limits();
    let features = device_features(adapter, masked_features().unwrap_or_default());
    let hdr = hdr_format(adapter, features);
    let timestamps = features.contains(wgpu::Features::TIMESTAMP_QUERY)
        && timestamps_are_per_pass(info.device_type);
    AdapterReport {
        name: info.name.clone(),
        unusable: missing_requirements(adapter),
        backend: info.backend.to_string(),
        device_type: format!("{:?}", info.device_type),
        driver: driver_string(&info),
        vendor_id: info.vendor,
        device_id: info.device,
        capabilities: capabilities(adapter),
        multisampling: MULTISAMPLED_FORMATS
            .iter()
            .map(|&f| FormatSamples {
                format: format!("{f:?}").to_lowercase(),
                samples: sample_counts(adapter, f, features),
            })
            .collect(),
        hdr_format: format!("{hdr:?}").to_lowercase(),
        timing: if timestamps {
            "gpu timestamps".into()
        } else if info.device_type == wgpu::DeviceType::Cpu {
            "wall clock per pass (software adapter: timestamps do not wait for compute work)".into()
        } else {
            "wall clock per pass (no timestamp queries, or CLUSTERLAB_TIMING=wall)".into()
        },
        max_texture_side: limits.max_texture_dimension_2d,
        max_storage_buffer_bytes: limits.max_storage_buffer_binding_size,
        max_buffer_bytes: limits.max_buffer_size,
        declared_differences: DEVIATIONS
            .iter()
            .filter(|d| d.on.holds_for(info.backend, hdr))
            .map(|d| d.why)
            .collect(),
        chosen,
    }
}

/// Every adapter wgpu sees on any backend, and the one `backend` (or `WGPU_BACKEND`, or the
/// default order) picks.
pub fn survey(backend: Option<&str>) -> Survey {
    let request = Request::new(backend);
    let picked = request
        .as_ref()
        .map_err(|e| e.to_string())
        .and_then(|r| pick(r).map(|a| a.get_info()).map_err(|e| e.to_string()));
    let adapters: Vec<AdapterReport> = enumerate(wgpu::Backends::all())
        .iter()
        .map(|a| {
            let info = a.get_info();
            let chosen = picked.as_ref().is_ok_and(|p| same_adapter(p, &info));
            report(a, chosen)
        })
        .collect();
    let chosen = adapters.iter().position(|a| a.chosen);
    let problem = match (&picked, chosen) {
        (Err(e), _) => Some(e.clone()),
        (Ok(p), None) => Some(format!(
            "the chosen adapter {} is not among those listed",
            p.name
        )),
        (Ok(_), Some(_)) => None,
    };
    let mut notes = Vec::new();
    if !adapters
        .iter()
        .any(|a| a.backend == wgpu::Backend::Vulkan.to_string())
    {
        notes.push(
            "no Vulkan adapter: on a machine without a GPU, `apt-get install \
             mesa-vulkan-drivers` adds lavapipe, which renders into a 32-bit float HDR target \
             (OpenGL through wgpu gets a 16-bit one) and is the adapter the image snapshots \
             were reviewed on"
                .to_string(),
        );
    }
    if let Err(e) = masked_features() {
        notes.push(e);
    }
    for var in [
        "WGPU_BACKEND",
        "CLUSTERLAB_TIMING",
        WITHOUT,
        "WGPU_ADAPTER_NAME",
    ] {
        if let Some(v) = crate::environment::var(var) {
            notes.push(format!("{var}={v}"));
        }
    }
    Survey {
        tool: format!("clusterlab {}", env!("CARGO_PKG_VERSION")),
        adapters,
        rule: match &request {
            Ok(r) => format!("{}; among them {RANKING}", r.describe()),
            Err(_) => "none: the backend request is invalid".into(),
        },
        chosen,
        problem,
        notes,
    }
}

fn same_adapter(a: &wgpu::AdapterInfo, b: &wgpu::AdapterInfo) -> bool {
    a.name == b.name
        && a.backend == b.backend
        && a.device_type == b.device_type
        && a.vendor == b.vendor
        && a.device == b.device
        && a.driver == b.driver
}

impl Survey {
    /// The survey as text, to paste into a bug report.
    pub fn text(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{}: {} adapters wgpu sees",
            self.tool,
            self.adapters.len()
        );
        for (i, a) in self.adapters.iter().enumerate() {
            let _ = writeln!(
                s,
                "\n{}. {} ({}, {}){}",
                i + 1,
                a.name,
                a.backend,
                a.device_type,
                if a.chosen {
                    "  <- render, matrix, stress and study use this one"
                } else {
                    ""
                }
            );
            let _ = writeln!(s, "   driver: {}", a.driver);
            if let Some(why) = &a.unusable {
                let _ = writeln!(s, "   {why}");
            }
            if a.name.starts_with("llvmpipe") {
                let threads = software_gpu_threads().unwrap_or_else(|| "one per core".into());
                let _ = writeln!(s, "   threads per pass: {threads} (LP_NUM_THREADS)");
            }
            let _ = writeln!(
                s,
                "   ids: vendor 0x{:04x}, device 0x{:04x}",
                a.vendor_id, a.device_id
            );
            let _ = writeln!(s, "   HDR target: {}", a.hdr_format);
            let counts: Vec<String> = a
                .multisampling
                .iter()
                .map(|f| format!("{} {:?}", f.format, f.samples))
                .collect();
            let _ = writeln!(s, "   sample counts: {}", counts.join(", "));
            if a.backend == wgpu::Backend::Gl.to_string() {
                let _ = writeln!(s, "   multisampling: refused: {}", MSAA_ON_GL);
            }
            let _ = writeln!(s, "   pass times: {}", a.timing);
            let _ = writeln!(
                s,
                "   limits: textures up to {} px a side, storage bindings up to {} MiB, buffers up to {} MiB",
                a.max_texture_side,
                a.max_storage_buffer_bytes >> 20,
                a.max_buffer_bytes >> 20
            );
            for c in &a.capabilities {
                let mark = match (c.present, c.masked) {
                    (_, true) => format!("[-] {} (masked by {WITHOUT})", c.name),
                    (true, false) => format!("[x] {}", c.name),
                    (false, false) => format!("[ ] {}", c.name),
                };
                let _ = writeln!(s, "   {mark}: {}", c.use_);
            }
            for why in &a.declared_differences {
                let _ = writeln!(s, "   differs (declared): {why}");
            }
        }
        let _ = writeln!(s, "\nchoice: {}", self.rule);
        match (self.chosen, &self.problem) {
            (Some(i), _) => {
                let a = &self.adapters[i];
                let _ = writeln!(s, "uses: {}. {} ({})", i + 1, a.name, a.backend);
            }
            (None, why) => {
                let _ = writeln!(s, "uses: none: {}", why.as_deref().unwrap_or("no adapter"));
            }
        }
        for note in &self.notes {
            let _ = writeln!(s, "note: {note}");
        }
        s
    }
}

/// The names of the optional features in `without` that `adapter` has, as reports record
/// them beside the adapter.
pub fn masked_names(adapter: &wgpu::Adapter, without: wgpu::Features) -> Vec<String> {
    let masked = without & adapter.features();
    OPTIONAL_FEATURES
        .iter()
        .filter(|(_, f, _)| masked.contains(*f))
        .map(|(n, _, _)| n.to_string())
        .collect()
}

/// Which limits the device is asked for (`--limits`): the adapter's own (the most it
/// offers), WebGPU's defaults (what a browser grants without asking), or wgpu's downlevel
/// defaults (WebGL2-class and older hardware). Each is lowered where the adapter offers less.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LimitSet {
    #[default]
    Adapter,
    Webgpu,
    Downlevel,
}

impl LimitSet {
    /// The name `--limits` gives it.
    pub fn name(self) -> &'static str {
        match self {
            LimitSet::Adapter => "adapter",
            LimitSet::Webgpu => "webgpu",
            LimitSet::Downlevel => "downlevel",
        }
    }

    /// The limits to request of an adapter that offers `offered`.
    pub fn request(self, offered: &wgpu::Limits) -> wgpu::Limits {
        match self {
            LimitSet::Adapter => offered.clone(),
            LimitSet::Webgpu => wgpu::Limits::defaults().or_worse_values_from(offered),
            LimitSet::Downlevel => wgpu::Limits::downlevel_defaults().or_worse_values_from(offered),
        }
    }
}

/// How to open a device: the limits to ask for and the optional features to go without.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeviceRequest {
    pub limits: LimitSet,
    pub without: wgpu::Features,
}

impl DeviceRequest {
    /// The adapter's limits, without what `CLUSTERLAB_WITHOUT` masks.
    pub fn from_env() -> Result<Self, GpuError> {
        Ok(DeviceRequest {
            limits: LimitSet::Adapter,
            without: masked_features().map_err(GpuError::Setting)?,
        })
    }
}

#[cfg(test)]
mod requirement_tests {
    use super::*;

    /// An OpenGL 3.3 adapter (WebGL 2's limits: no storage buffers, no compute) is named
    /// unusable with what it lacks; one with everything (lavapipe's flags, downlevel limits)
    /// is not.
    #[test]
    fn an_adapter_without_storage_buffers_is_unusable_and_says_why() {
        let gl33 = lacks(
            wgpu::DownlevelFlags::empty(),
            &wgpu::Limits::downlevel_webgl2_defaults(),
        )
        .expect("unusable");
        assert!(
            gl33.contains("no compute shaders")
                && gl33.contains("0 storage buffers a stage of the 4 needed"),
            "{gl33}"
        );
        assert_eq!(
            lacks(
                wgpu::DownlevelFlags::all(),
                &wgpu::Limits::downlevel_defaults()
            ),
            None
        );
    }
}
