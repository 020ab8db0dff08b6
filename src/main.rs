//! The `clusterlab` command line: this file parses the arguments and dispatches each
//! command to its body in `commands/`; the library does the work.

mod commands;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use clusterlab::measure::Budget;
use clusterlab::scene::MAX_TIME_S;
use clusterlab::variant::{self, DebugView};

#[derive(Parser)]
#[command(
    name = "clusterlab",
    version,
    about = "Measure many-light shading pipelines side by side"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Parse, check, compose and naga-validate every pass of variant files.
    Validate {
        /// Variant files or folders of them.
        #[arg(default_value = "variants")]
        paths: Vec<PathBuf>,
        /// Print one JSON object: each variant's passes, error, and needs of a device's
        /// limits (bindings per stage, bind groups, workgroup storage and size, colour
        /// attachment bytes) beside WebGPU's and wgpu's downlevel defaults.
        #[arg(long)]
        json: bool,
    },
    /// Write the pending snapshots of variants for review: the WGSL of every pass and a
    /// frame on a small scene, beside the reviewed ones in the working folder's snapshots/
    /// (images of an adapter other than llvmpipe in a folder of its own); and the lists
    /// generated from the variant files (snapshots/wgsl/users.txt, and in a clusterlab
    /// tree docs/variants.md). Review with `cargo insta review`, or take every pending one
    /// with --accept.
    Snapshot {
        /// Variant files, folders of them, or names in variants/ (default: variants/).
        #[arg(long, num_args = 1..)]
        variants: Vec<String>,
        /// Take every pending snapshot in: each replaces its reviewed one.
        #[arg(long, conflicts_with = "variants")]
        accept: bool,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Print the composed WGSL of a variant's passes.
    Wgsl {
        /// A variant file, or the name of one in variants/.
        variant: String,
        /// Only this pass (see the pass names in the output without it).
        #[arg(long)]
        pass: Option<String>,
    },
    /// Explain the variant schema: every field, its meaning, allowed values and default.
    Explain,
    /// List the built-in scenes and their default parameters, or write one as glTF.
    Scenes {
        /// Write built-in scene NAME (meshes, materials, lights, camera and its motion) to
        /// FILE as binary glTF (.glb); `--scene FILE` then loads it.
        #[arg(long, num_args = 2, value_names = ["NAME", "FILE"])]
        export: Option<Vec<String>>,
        /// With --export: number of lights (default: the scene's).
        #[arg(long, requires = "export")]
        lights: Option<u32>,
        /// With --export: seed of the scene generator.
        #[arg(long, requires = "export")]
        seed: Option<u64>,
        /// With --export: fraction of the lights that are spots, in 0..=1.
        #[arg(long, requires = "export", value_parser = parse_fraction)]
        spots: Option<f32>,
    },
    /// List every GPU adapter wgpu sees, what each offers clusterlab, and which one render,
    /// matrix, stress and study would use and why: the first thing to paste into a bug report.
    Adapters {
        /// Print one JSON object instead.
        #[arg(long)]
        json: bool,
        /// Show the choice for this backend (vulkan, gl, ...), as `--backend` would make it.
        #[arg(long)]
        backend: Option<String>,
    },
    /// Render one variant on one scene, measure it against the CPU f64 reference, and write
    /// the image and its error heat map.
    Render(RenderArgs),
    /// Render a sequence of frames: the camera on its path (or still), a fraction of the
    /// lights moving; every frame timed per pass, every k-th checked against its reference,
    /// its change against the reference's, and the same frame rendered from scratch. Writes
    /// the animation, a plot of time per pass, the per-frame table and the report.
    Sequence(SequenceArgs),
    /// Open a window on the renderer: change variant, scene, lights, time, debug view and
    /// samples on a panel; fly the camera (W A S D Q E, drag, wheel); shaders and variant
    /// files reload when saved; P writes what `render` writes, R records an animation.
    /// Needs a display (or `xvfb-run`).
    View(ViewArgs),
    /// Run the variant matrix: variants x scenes x sweeps, each cell timed and measured
    /// against the reference; writes results.json, results.csv, images and index.html.
    /// With no arguments: every variant in variants/ on every scene, plus a light-count
    /// sweep of naive forward, Forward+ and clustered deferred.
    Matrix(MatrixArgs),
    /// Run the stress suite: adversarial cameras, sizes, lights, geometry and grids on every
    /// pipeline they apply to; exit code 1 if any check fails.
    Stress {
        /// Only the cases whose name contains this (as --cases).
        filter: Option<String>,
        /// Only the cases whose name contains this.
        #[arg(long, conflicts_with = "filter")]
        cases: Option<String>,
        /// Variant files, folders of them, or names in variants/: every case that applies
        /// runs on these (with what the case sets: a grid, a slicing, a depth mapping, a
        /// sample count) instead of its own variants; one that cannot apply says why.
        #[arg(long, num_args = 1..)]
        variants: Vec<String>,
        /// List the cases, and with --variants the runs each makes, then stop.
        #[arg(long)]
        list: bool,
        /// Print the runs as JSON.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Run a study against published numbers (`--help` says what each measures and which
    /// options it reads).
    Study {
        /// Which study.
        #[arg(value_parser = parse_study_name())]
        name: String,
        /// Print the rows as JSON (the table goes to stderr).
        #[arg(long)]
        json: bool,
        /// Folder for NAME.csv, NAME.json, NAME.md and the plot.
        #[arg(long, default_value = "out/study")]
        out: PathBuf,
        /// Codecs: uniform unit vectors to sample (1 to 67108864; default 1048576).
        #[arg(long, value_parser = parse_samples)]
        samples: Option<usize>,
        /// Image size, WIDTHxHEIGHT (default 640x360; scale: 1920x1080 on a GPU, 640x360 on
        /// a software adapter).
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
        /// Slicing, cones, culling and msaa: comma-separated scenes, built-in names or glTF
        /// files (default: every built-in scene).
        #[arg(long, value_delimiter = ',')]
        scenes: Vec<String>,
        /// Comma-separated light counts, each run in every scene (default: the study's own,
        /// its help says which).
        #[arg(long, value_delimiter = ',')]
        lights: Vec<u32>,
        /// Variant files, folders of them, or names in variants/: msaa and scale run them
        /// beside their own.
        #[arg(long, num_args = 1..)]
        variants: Vec<String>,
        /// Timed frames per run, at least 1 (default 3; the median is reported; temporal:
        /// the frames of each sequence after the first).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
        frames: Option<u32>,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Combine matrix result folders (shards of one study) into one report.
    Merge {
        /// Result folders (each with a results.json).
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Folder for the combined report.
        #[arg(long, default_value = "out/matrix")]
        out: PathBuf,
        /// Print results.json to stdout (the table goes to stderr).
        #[arg(long)]
        json: bool,
        /// Merge folders from different adapters, or whose variant files differ.
        #[arg(long)]
        allow_mixed: bool,
        /// Folders that hold the same cell are refused; keep the copy from the `first` or
        /// the `last` folder that has it instead.
        #[arg(long, value_enum)]
        prefer: Option<clusterlab::matrix::Prefer>,
    },
}

/// Which GPU, and how long one cell's GPU work may take.
#[derive(clap::Args)]
struct GpuArgs {
    /// GPU backend: vulkan, gl, metal, dx12 (default: WGPU_BACKEND, else Vulkan first).
    #[arg(long)]
    backend: Option<String>,
    /// Seconds the GPU work of one cell (a render, a matrix cell, a stress run; in a study,
    /// one wait) may take before it fails; long frames are waited for until then.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = clusterlab::gpu::DEFAULT_CELL_TIMEOUT.as_secs_f64(),
        value_parser = parse_seconds
    )]
    cell_timeout: f64,
    /// Device limits to run within: the adapter's own, WebGPU's defaults (what a browser
    /// grants), or wgpu's downlevel defaults; a variant that needs more is refused, naming
    /// the limit (`validate --json` lists each variant's needs).
    #[arg(long, value_enum, default_value_t)]
    limits: clusterlab::gpu::adapters::LimitSet,
}

impl GpuArgs {
    fn open(&self) -> Result<clusterlab::gpu::Gpu, String> {
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

fn parse_seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 1e9 => Ok(v),
        Ok(_) => Err(format!(
            "`{s}` is not a usable number of seconds: give a positive number up to 1e9"
        )),
        Err(_) => Err(format!("`{s}` is not a number of seconds, e.g. 600")),
    }
}

#[derive(clap::Args)]
struct MatrixArgs {
    /// Variant files, folders of them, or names in variants/ (default: variants/).
    #[arg(long, num_args = 1..)]
    variants: Vec<String>,
    /// Comma-separated scenes: built-in names (see `clusterlab scenes`) or glTF files
    /// (.gltf or .glb) (default: every built-in scene).
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    /// A swept parameter: lights=64,256,...  radius=1,2..4,...  grid=16x9x24,...
    /// spots=0,0.5,1  skipping=on,off  msaa=1,4. Repeat for a grid of sweeps.
    #[arg(long, value_parser = clusterlab::matrix::parse_sweep)]
    sweep: Vec<clusterlab::matrix::Sweep>,
    /// Image size of every cell, WIDTHxHEIGHT (default: each scene's).
    #[arg(long, value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Exactly N timed frames per cell (at least 1) after --warmup untimed ones, instead
    /// of frames by budget; pass times are medians over the timed frames.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    frames: Option<u32>,
    /// With --frames: untimed frames first (software rasterisers compile on first use).
    #[arg(long, default_value_t = 1, requires = "frames")]
    warmup: u32,
    /// Frames by budget: a cell stops once the 95% interval of its median (6 frames at
    /// least) lies within +-PERCENT of it (or its budget is spent).
    #[arg(long, default_value_t = Budget::DEFAULT.precision * 100.0, value_parser = parse_percent, conflicts_with = "frames")]
    precision: f64,
    /// Frames by budget: milliseconds of frames one cell may spend, counting the untimed
    /// frame without lights it draws first (which compiles what is new); a first timed
    /// frame longer than this is the only one.
    #[arg(long, default_value_t = Budget::DEFAULT.budget_ms, value_parser = parse_budget_ms, conflicts_with = "frames")]
    budget_ms: f64,
    /// Frames by budget: most timed frames per cell.
    #[arg(long, default_value_t = Budget::DEFAULT.max_frames, value_parser = clap::value_parser!(u32).range(1..=1000), conflicts_with = "frames")]
    max_frames: u32,
    /// Folder for results.json, results.csv, images/, plots/ and index.html.
    #[arg(long, default_value = "out/matrix")]
    out: PathBuf,
    /// Print results.json to stdout (the table goes to stderr).
    #[arg(long)]
    json: bool,
    /// Run only shard K of N (1-based): every N-th cell from the K-th.
    #[arg(long, value_parser = clusterlab::matrix::parse_shard)]
    shard: Option<(u32, u32)>,
    /// An earlier results.json (or its folder): show each cell's change against it.
    #[arg(long)]
    baseline: Option<PathBuf>,
    /// An earlier matrix's result folder (it may be --out itself): take each cell whose
    /// variant file, composed WGSL, scene, parameters, adapter and clusterlab build are all
    /// unchanged from there, images and all, and run only the others.
    #[arg(long)]
    reuse: Option<PathBuf>,
    /// Run each cell's CPU work (the f64 reference, error figures, images) on a thread of
    /// its own while the next cells render: `auto` does so on a hardware GPU and not on a
    /// software one, whose frames are the CPU's own work and would be slowed.
    #[arg(long, value_enum, default_value_t = Overlap::Auto)]
    overlap: Overlap,
    /// Run every cell as a sequence of N frames (1 to 3600) instead of one frame rendered
    /// again: a fraction of the lights moving (`--moving`, or a `moving=` sweep), the
    /// camera on its path or still; each cell's times are of the frames after the first.
    /// A sequence times all its frames: the options that choose frames do not apply.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=clusterlab::sequence::MAX_FRAMES as i64), conflicts_with_all = ["frames", "precision", "budget_ms", "max_frames"])]
    sequence: Option<u32>,
    /// With --sequence: fraction of the lights that move, in 0..=1 (default: all of them,
    /// none of a glTF file's own lights, which cannot move).
    #[arg(long, value_parser = parse_fraction, requires = "sequence")]
    moving: Option<f32>,
    /// With --sequence: keep the camera where it is at the first frame.
    #[arg(long, requires = "sequence")]
    still_camera: bool,
    /// With --sequence: check every K-th frame (and the first and last), K >= 1.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..), requires = "sequence")]
    check_every: u32,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum Overlap {
    Auto,
    On,
    Off,
}

/// A variant and the scene it renders, with the scene's parameters (`render`, `sequence`).
#[derive(clap::Args)]
struct CellArgs {
    /// A variant file, or the name of one in variants/.
    #[arg(long)]
    variant: String,
    /// A built-in scene (see `clusterlab scenes`), or a glTF file (.gltf or .glb).
    #[arg(long)]
    scene: String,
    #[command(flatten)]
    options: SceneOptions,
}

/// What a command may change of a scene's defaults.
#[derive(clap::Args)]
struct SceneOptions {
    /// Number of lights (default: the scene's).
    #[arg(long)]
    lights: Option<u32>,
    /// Image size, WIDTHxHEIGHT (default: the scene's).
    #[arg(long, value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Seed of the scene generator.
    #[arg(long)]
    seed: Option<u64>,
    /// Light radius range MIN,MAX in world units (default: the scene's).
    #[arg(long, value_parser = parse_range)]
    radius: Option<(f32, f32)>,
    /// Time of the (first) frame in seconds, 0..=3600 (lights and camera move with it).
    #[arg(long, value_parser = parse_time)]
    time: Option<f64>,
    /// Fraction of the lights that are spots, in 0..=1 (default: the scene's).
    #[arg(long, value_parser = parse_fraction)]
    spots: Option<f32>,
}

impl SceneOptions {
    /// Scene `name`'s defaults with what was given.
    fn params(&self, name: &str) -> Result<clusterlab::scene::SceneParams, String> {
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
    fn variant(&self) -> Result<variant::LoadedVariant, String> {
        variant::load(&variant::locate(&self.variant)?).map_err(|e| e.to_string())
    }

    /// The scene's defaults with what was given.
    fn params(&self) -> Result<clusterlab::scene::SceneParams, String> {
        self.options.params(&self.scene)
    }
}

#[derive(clap::Args)]
struct RenderArgs {
    #[command(flatten)]
    cell: CellArgs,
    /// Frames to render (at least 1); times are the median per pass.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    frames: u32,
    /// Untimed frames before them (software rasterisers compile on first use).
    #[arg(long, default_value_t = 1)]
    warmup: u32,
    /// Show a debug view instead of the shaded image: cluster-index, lights-per-cluster,
    /// z-slice, gbuffer-position, gbuffer-normal, gbuffer-albedo or gbuffer-depth.
    #[arg(long, value_parser = parse_debug_view)]
    debug_view: Option<DebugView>,
    /// Skip the instrumented frame that counts light evaluations.
    #[arg(long)]
    no_stats: bool,
    /// Samples per pixel instead of the variant's msaa.samples: 1, 2, 4 or 8.
    #[arg(long)]
    samples: Option<u32>,
    /// Place the camera instead of the scene's own: EX,EY,EZ,TX,TY,TZ, its eye and the
    /// point it looks at (+Y up; the scene's field of view and near plane; still). The
    /// viewer shows its flown camera as this argument.
    #[arg(long, value_parser = clusterlab::scene::CameraPose::parse)]
    camera: Option<clusterlab::scene::CameraPose>,
    /// Folder for the PNG and its heat map.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
    /// Print one JSON object instead of a summary.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args)]
struct ViewArgs {
    /// Variant files or names to offer beside those in variants/; the first is shown first
    /// (default: forward_plus).
    #[arg(long)]
    variant: Vec<String>,
    /// A built-in scene (see `clusterlab scenes`), or a glTF file (.gltf or .glb).
    #[arg(long, default_value = "atrium")]
    scene: String,
    #[command(flatten)]
    options: SceneOptions,
    /// Start on this camera, EX,EY,EZ,TX,TY,TZ (as `render --camera`).
    #[arg(long, value_parser = clusterlab::scene::CameraPose::parse)]
    camera: Option<clusterlab::scene::CameraPose>,
    /// Folder for screenshots and recordings.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Play the timed inputs of this RON file, then exit (non-zero if a step failed).
    #[arg(long)]
    script: Option<PathBuf>,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(clap::Args)]
struct SequenceArgs {
    #[command(flatten)]
    cell: CellArgs,
    /// Frames, 1 to 3600, one frame step (1/30 s) apart.
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u32).range(1..=clusterlab::sequence::MAX_FRAMES as i64))]
    frames: u32,
    /// Fraction of the lights that move, in 0..=1 (the rest stand where they were at the
    /// first frame; default: all of them, none of a glTF file's own lights, which cannot
    /// move).
    #[arg(long, value_parser = parse_fraction)]
    moving: Option<f32>,
    /// Keep the camera where it is at the first frame.
    #[arg(long)]
    still_camera: bool,
    /// Check every K-th frame (and the first and last) against its reference, K >= 1.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..))]
    check_every: u32,
    /// Folder for the animation, plot, table, report and the last frame's image.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
    /// Print the report as JSON instead of the table.
    #[arg(long)]
    json: bool,
}

/// A percentage in (0, 100].
fn parse_percent(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(p) if p > 0.0 && p <= 100.0 => Ok(p),
        _ => Err(format!(
            "`{s}` is not a percentage; give a number in (0, 100], e.g. 3"
        )),
    }
}

/// Milliseconds of a cell's budget: a number in [1, 3600000].
fn parse_budget_ms(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(ms) if (1.0..=3_600_000.0).contains(&ms) => Ok(ms),
        _ => Err(format!(
            "`{s}` is not a budget; give milliseconds in [1, 3600000], e.g. 500"
        )),
    }
}

/// A fraction in 0..=1.
fn parse_fraction(s: &str) -> Result<f32, String> {
    s.trim()
        .parse::<f32>()
        .ok()
        .filter(|f| (0.0..=1.0).contains(f))
        .ok_or_else(|| format!("`{s}` is not a fraction in 0..=1 (e.g. 0.5)"))
}

/// The studies' names, each with what it measures.
fn parse_study_name() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(
        clusterlab::study::STUDIES
            .iter()
            .map(|e| clap::builder::PossibleValue::new(e.name).help(e.about)),
    )
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
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
fn parse_whole(v: &str, arg: &str, max: u64) -> Result<u64, String> {
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
fn parse_time(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(t) if t.is_finite() && (0.0..=MAX_TIME_S).contains(&t) => Ok(t),
        Ok(_) => Err(format!(
            "`{s}` is not a usable time: give seconds in 0..={MAX_TIME_S} (the scenes' cameras and lights move with it)"
        )),
        Err(_) => Err(format!("`{s}` is not a number of seconds, e.g. 1.5")),
    }
}

/// `--samples` of the codec study: a whole number in 1..=MAX_SAMPLES.
fn parse_samples(s: &str) -> Result<usize, String> {
    let n = parse_whole(s.trim(), s, MAX_SAMPLES as u64)?;
    if n == 0 {
        return Err("0 samples: give at least 1".into());
    }
    Ok(n as usize)
}

/// Most unit vectors the codec study samples (about 1.6 GB of buffers on the GPU and as
/// much on the CPU at this count).
const MAX_SAMPLES: usize = 1 << 26;

fn parse_debug_view(s: &str) -> Result<DebugView, String> {
    DebugView::named(s).ok_or_else(|| {
        let names: Vec<String> = DebugView::every()
            .into_iter()
            .map(DebugView::name)
            .collect();
        format!("`{s}` is not a debug view; use one of {}", names.join(", "))
    })
}

fn parse_range(s: &str) -> Result<(f32, f32), String> {
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

use commands::*;

fn main() -> ExitCode {
    end_quietly_on_closed_pipe();
    quiet_mesa_wsi();
    let cli = Cli::parse();
    if let Err(message) =
        clusterlab::gpu::check_environment().and_then(|()| clusterlab::compose::check_environment())
    {
        eprintln!("error: {message}");
        return ExitCode::FAILURE;
    }
    if let Some(note) = clusterlab::compose::perturbation_note() {
        eprintln!("{note}");
    }
    spread_software_gpu_threads();
    let result = match cli.command {
        Command::Validate { paths, json } => validate(&paths, json),
        Command::Wgsl { variant, pass } => wgsl(&variant, pass.as_deref()),
        Command::Snapshot {
            variants,
            accept,
            gpu,
        } => snapshot(&variants, accept, &gpu),
        Command::Explain => {
            print!("{}", clusterlab::explain::explain());
            Ok(true)
        }
        Command::Scenes {
            export: Some(export),
            lights,
            seed,
            spots,
        } => export_scene(&export[0], Path::new(&export[1]), lights, seed, spots),
        Command::Scenes { .. } => {
            scenes();
            Ok(true)
        }
        Command::Adapters { json, backend } => adapters(json, backend.as_deref()),
        Command::Render(args) => render(&args),
        Command::View(args) => view(&args),
        Command::Sequence(args) => sequence(&args),
        Command::Matrix(args) => matrix(&args),
        Command::Merge {
            dirs,
            out,
            json,
            allow_mixed,
            prefer,
        } => merge(&dirs, &out, json, allow_mixed, prefer),
        Command::Stress {
            filter,
            cases,
            variants,
            list,
            json,
            gpu,
        } => stress(
            StressArgs {
                cases: cases.as_deref().or(filter.as_deref()),
                variants: &variants,
                list,
                json,
            },
            &gpu,
        ),
        Command::Study {
            name,
            json,
            out,
            samples,
            size,
            scenes,
            lights,
            variants,
            frames,
            gpu,
        } => {
            use clusterlab::study::Reads;
            let given: Vec<Reads> = [
                (samples.is_some(), Reads::Samples),
                (size.is_some(), Reads::Size),
                (!scenes.is_empty(), Reads::Scenes),
                (!lights.is_empty(), Reads::Lights),
                (frames.is_some(), Reads::Frames),
                (!variants.is_empty(), Reads::Variants),
            ]
            .into_iter()
            .filter_map(|(given, option)| given.then_some(option))
            .collect();
            let defaults = clusterlab::study::StudyOptions::default();
            clusterlab::variant::load_args(&variants).and_then(|variants| {
                let mut options = clusterlab::study::StudyOptions {
                    samples: samples.unwrap_or(defaults.samples),
                    size,
                    lights,
                    frames: frames.unwrap_or(defaults.frames),
                    variants,
                    ..defaults
                };
                if !scenes.is_empty() {
                    options.scenes = scenes;
                }
                study(&name, &options, &given, json, &out, &gpu)
            })
        }
    };
    match result {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}
