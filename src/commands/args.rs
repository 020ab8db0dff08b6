//! Arguments and value parsers shared by several commands: the GPU to use, a cell (a
//! variant and its scene), and numbers with their ranges.

use clusterlab::scene::MAX_TIME_S;
use clusterlab::variant;

/// Which GPU, and how long one cell's GPU work may take.
#[derive(clap::Args)]
pub(crate) struct GpuArgs {
    /// GPU backend: vulkan, gl, metal, dx12 (default: WGPU_BACKEND, else Vulkan first).
    #[arg(long)]
    pub backend: Option<String>,
    /// Seconds the GPU work of one cell (a render, a matrix cell, a stress run; in a study,
    /// one wait) may take before it fails; long frames are waited for until then.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = clusterlab::gpu::DEFAULT_CELL_TIMEOUT.as_secs_f64(),
        value_parser = parse_seconds
    )]
    pub cell_timeout: f64,
    /// Device limits to run within: the adapter's own, WebGPU's defaults (what a browser
    /// grants), or wgpu's downlevel defaults; a variant that needs more is refused, naming
    /// the limit (`validate --json` lists each variant's needs).
    #[arg(long, value_enum, default_value_t)]
    pub limits: clusterlab::gpu::adapters::LimitSet,
}

impl GpuArgs {
    pub(crate) fn open(&self) -> Result<clusterlab::gpu::Gpu, String> {
        let request = clusterlab::gpu::adapters::DeviceRequest {
            limits: self.limits,
            ..clusterlab::gpu::adapters::DeviceRequest::from_env().map_err(|e| e.to_string())?
        };
        let gpu = clusterlab::gpu::Gpu::with_request(self.backend.as_deref(), request)
            .map_err(|e| e.to_string())?;
        gpu.set_cell_timeout(std::time::Duration::from_secs_f64(self.cell_timeout));
        Ok(gpu)
    }
}

pub(crate) fn parse_seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 1e9 => Ok(v),
        Ok(_) => Err(format!(
            "`{s}` is not a usable number of seconds: give a positive number up to 1e9"
        )),
        Err(_) => Err(format!("`{s}` is not a number of seconds, e.g. 600")),
    }
}

/// A variant and the scene it renders, with the scene's parameters (`render`, `sequence`).
#[derive(clap::Args)]
pub(crate) struct CellArgs {
    /// A variant file, or the name of one in variants/.
    #[arg(long)]
    pub variant: String,
    /// A built-in scene (see `clusterlab scenes`), or a glTF file (.gltf or .glb).
    #[arg(long)]
    pub scene: String,
    #[command(flatten)]
    pub options: SceneOptions,
}

/// What a command may change of a scene's defaults.
#[derive(clap::Args)]
pub(crate) struct SceneOptions {
    /// Number of lights (default: the scene's).
    #[arg(long)]
    pub lights: Option<u32>,
    /// Image size, WIDTHxHEIGHT (default: the scene's).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Seed of the scene generator.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Light radius range MIN,MAX in world units (default: the scene's).
    #[arg(long, value_parser = parse_range)]
    pub radius: Option<(f32, f32)>,
    /// Time of the (first) frame in seconds, 0..=3600 (lights and camera move with it).
    #[arg(long, value_parser = parse_time)]
    pub time: Option<f64>,
    /// Fraction of the lights that are spots, in 0..=1 (default: the scene's).
    #[arg(long, value_parser = parse_fraction)]
    pub spots: Option<f32>,
}

impl SceneOptions {
    /// Scene `name`'s defaults with what was given.
    pub(crate) fn params(&self, name: &str) -> Result<clusterlab::scene::SceneParams, String> {
        let mut params = clusterlab::scene::defaults(name).map_err(|e| e.to_string())?;
        if let Some((w, h)) = self.size {
            (params.width, params.height) = (w, h);
        }
        params.lights = self.lights.unwrap_or(params.lights);
        params.seed = self.seed.unwrap_or(params.seed);
        params.radius_range = self.radius.unwrap_or(params.radius_range);
        params.time = self.time.unwrap_or(params.time);
        params.spots = self.spots.unwrap_or(params.spots);
        Ok(params)
    }
}

impl CellArgs {
    /// The variant, loaded.
    pub(crate) fn variant(&self) -> Result<variant::LoadedVariant, String> {
        variant::load(&variant::locate(&self.variant)?).map_err(|e| e.to_string())
    }

    /// The scene's defaults with what was given.
    pub(crate) fn params(&self) -> Result<clusterlab::scene::SceneParams, String> {
        self.options.params(&self.scene)
    }
}

/// Milliseconds of a cell's budget: a number in [1, 3600000].
pub(crate) fn parse_budget_ms(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(ms) if (1.0..=3_600_000.0).contains(&ms) => Ok(ms),
        _ => Err(format!(
            "`{s}` is not a budget; give milliseconds in [1, 3600000], e.g. 500"
        )),
    }
}

/// A fraction in 0..=1.
pub(crate) fn parse_fraction(s: &str) -> Result<f32, String> {
    s.trim()
        .parse::<f32>()
        .ok()
        .filter(|f| (0.0..=1.0).contains(f))
        .ok_or_else(|| format!("`{s}` is not a fraction in 0..=1 (e.g. 0.5)"))
}

pub(crate) fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{s}` is not WIDTHxHEIGHT, e.g. 640x360"))?;
    let n = |v: &str| parse_whole(v.trim(), s, u32::MAX as u64).map(|n| n as u32);
    let (w, h) = (n(w)?, n(h)?);
    if w == 0 || h == 0 {
        return Err(format!("`{s}`: width and height must be at least 1"));
    }
    Ok((w, h))
}

/// A whole number `v` (part of the argument `arg`) of at most `max`: an error says whether
/// it is not a whole number or too large.
pub(crate) fn parse_whole(v: &str, arg: &str, max: u64) -> Result<u64, String> {
    let in_arg = if v == arg {
        String::new()
    } else {
        format!(" in `{arg}`")
    };
    if !v.is_empty() && v.bytes().all(|b| b.is_ascii_digit()) {
        return v
            .parse::<u64>()
            .ok()
            .filter(|&n| n <= max)
            .ok_or_else(|| format!("`{v}`{in_arg} is too large: at most {max}"));
    }
    Err(format!("`{v}`{in_arg} is not a whole number"))
}

/// Seconds into the scene's animation: a finite time in 0..=3600.
pub(crate) fn parse_time(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(t) if t.is_finite() && (0.0..=MAX_TIME_S).contains(&t) => Ok(t),
        Ok(_) => Err(format!(
            "`{s}` is not a usable time: give seconds in 0..={MAX_TIME_S} (the scenes' cameras and lights move with it)"
        )),
        Err(_) => Err(format!("`{s}` is not a number of seconds, e.g. 1.5")),
    }
}

pub(crate) fn parse_range(s: &str) -> Result<(f32, f32), String> {
    let (a, b) = s
        .split_once(',')
        .ok_or_else(|| format!("`{s}` is not MIN,MAX, e.g. 1.0,3.0"))?;
    let n = |v: &str| match v.trim().parse::<f32>() {
        Ok(x) => match clusterlab::scene::radius_problem(x) {
            Some(p) => Err(format!("`{v}` in `{s}`: {p}")),
            None => Ok(x),
        },
        Err(_) => Err(format!("`{v}` in `{s}` is not a number")),
    };
    let (min, max) = (n(a)?, n(b)?);
    if min > max {
        return Err(format!("`{s}`: MIN is above MAX"));
    }
    Ok((min, max))
}
