//! `render` and `view`: one variant on one scene, measured, or in a window.

use super::args::{CellArgs, GpuArgs, SceneOptions};
use clusterlab::compose::Composer;
use clusterlab::measure::Frames;
use clusterlab::variant;
use clusterlab::variant::DebugView;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub(crate) struct RenderArgs {
    #[command(flatten)]
    pub cell: CellArgs,
    /// Frames to render (at least 1); times are the median per pass.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub frames: u32,
    /// Untimed frames before them (software rasterisers compile on first use).
    #[arg(long, default_value_t = 1)]
    pub warmup: u32,
    /// Show a debug view instead of the shaded image: cluster-index, lights-per-cluster,
    /// z-slice, gbuffer-position, gbuffer-normal, gbuffer-albedo or gbuffer-depth.
    #[arg(long, value_parser = parse_debug_view)]
    pub debug_view: Option<DebugView>,
    /// Skip the instrumented frame that counts light evaluations.
    #[arg(long)]
    pub no_stats: bool,
    /// Samples per pixel instead of the variant's msaa.samples: 1, 2, 4 or 8.
    #[arg(long)]
    pub samples: Option<u32>,
    /// Place the camera instead of the scene's own: EX,EY,EZ,TX,TY,TZ, its eye and the
    /// point it looks at (+Y up; the scene's field of view and near plane; still). The
    /// viewer shows its flown camera as this argument.
    #[arg(long, value_parser = clusterlab::scene::CameraPose::parse)]
    pub camera: Option<clusterlab::scene::CameraPose>,
    /// Folder for the PNG and its heat map.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    #[command(flatten)]
    pub gpu: GpuArgs,
    /// Print one JSON object instead of a summary.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args)]
pub(crate) struct ViewArgs {
    /// Variant files or names to offer beside those in variants/; the first is shown first
    /// (default: forward_plus).
    #[arg(long)]
    pub variant: Vec<String>,
    /// A built-in scene (see `clusterlab scenes`), or a glTF file (.gltf or .glb).
    #[arg(long, default_value = "atrium")]
    pub scene: String,
    #[command(flatten)]
    pub options: SceneOptions,
    /// Start on this camera, EX,EY,EZ,TX,TY,TZ (as `render --camera`).
    #[arg(long, value_parser = clusterlab::scene::CameraPose::parse)]
    pub camera: Option<clusterlab::scene::CameraPose>,
    /// Folder for screenshots and recordings.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Play the timed inputs of this RON file, then exit (non-zero if a step failed).
    #[arg(long)]
    pub script: Option<PathBuf>,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

fn parse_debug_view(s: &str) -> Result<DebugView, String> {
    DebugView::named(s).ok_or_else(|| {
        let names: Vec<String> = DebugView::every()
            .into_iter()
            .map(DebugView::name)
            .collect();
        format!("`{s}` is not a debug view; use one of {}", names.join(", "))
    })
}

pub(crate) fn view(args: &ViewArgs) -> Result<bool, String> {
    clusterlab::files::write::check_folder(&args.out, "--out")?;
    // Said before anything slow: without a display there is nothing to wait for.
    if let Some(why) = clusterlab::view::missing_display() {
        return Err(why);
    }
    let given: Vec<PathBuf> = args
        .variant
        .iter()
        .map(|v| variant::locate(v))
        .collect::<Result<_, _>>()?;
    let mut variants = variant::find_files(Path::new(variant::FOLDER)).unwrap_or_default();
    for v in &given {
        if !variants.contains(v) {
            variants.push(v.clone());
        }
    }
    let first = given
        .first()
        .cloned()
        .map_or_else(|| variant::locate("forward_plus"), Ok)?;
    let params = args.options.params(&args.scene)?;
    let gpu = args.gpu.open()?;
    clusterlab::view::run(
        clusterlab::view::ViewOptions {
            variant: first,
            variants,
            scene: args.scene.clone(),
            params,
            camera: args.camera,
            out: args.out.clone(),
            script: args.script.clone(),
        },
        &gpu,
    )
}

pub(crate) fn render(args: &RenderArgs) -> Result<bool, String> {
    clusterlab::files::write::check_folder(&args.out, "--out")?;
    let mut loaded = args.cell.variant()?;
    if let Some(view) = args.debug_view {
        loaded.variant.debug_view = view;
        let problems = variant::check(&loaded.variant);
        if let Some(p) = problems.first() {
            return Err(format!("--debug-view: {} {}", p.field, p.message));
        }
        loaded.name = format!("{}+{}", loaded.name, view.name());
    }
    if let Some(n) = args.samples {
        loaded.variant.msaa.samples = n;
        let problems = variant::check(&loaded.variant);
        if let Some(p) = problems.first() {
            return Err(format!("--samples: {} {}", p.field, p.message));
        }
    }
    let params = args.cell.params()?;
    let scene = &args.cell.scene;
    let gpu = args.gpu.open()?;
    let failed =
        |e: &dyn std::fmt::Display| format!("variant `{}` on scene `{scene}`: {e}", loaded.name);
    gpu.check_size(params.width, params.height)
        .map_err(|e| failed(&e))?;
    let mut made = clusterlab::scene::generate(scene, params).map_err(|e| failed(&e))?;
    if let Some(pose) = args.camera {
        made.place_camera(pose)
            .map_err(|e| format!("--camera {}: {e}", pose.argument()))?;
    }
    gpu.begin_cell();
    let cell = clusterlab::run::run_scene(
        &gpu,
        &Composer::default(),
        &loaded,
        &made,
        clusterlab::run::CellOptions {
            frames: Frames::exact(args.warmup, args.frames),
            stats: !args.no_stats,
            out: Some(&args.out),
            references: None,
            debug_view: None,
        },
    )
    .map_err(|e| format!("variant `{}` on scene `{scene}`: {e}", loaded.name))?;
    let r = &cell.report;
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(r).map_err(|e| e.to_string())?
        );
    } else {
        println!(
            "{} on {} ({}x{}, {} lights) with {} ({}, {})",
            r.variant,
            r.scene,
            r.size[0],
            r.size[1],
            r.lights,
            r.adapter.name,
            r.adapter.backend,
            r.adapter.driver
        );
        if let Some(file) = &r.scene_file {
            println!("  scene file: {} (sha256 {})", file.path, file.sha256);
        }
        for note in &r.scene_notes {
            println!("  note: {note}");
        }
        println!("  timing: {}", r.timing_source);
        println!("  {}", clusterlab::compose::shaders_line());
        // The result columns, as the matrix table and CSV have them.
        let m = r.measured();
        for col in clusterlab::matrix::COLUMNS {
            let text = (col.text)(&m);
            if !text.is_empty() && text != "-" && (col.shown.terminal || col.shown.csv) {
                println!("  {:<17} {text}", col.heading);
            }
        }
        for image in &r.images {
            println!("  wrote {}", image.display());
        }
    }
    if let Some(why) = &r.failure {
        eprintln!(
            "FAILED: variant `{}` on scene `{scene}`: {why}",
            loaded.name
        );
        return Ok(false);
    }
    Ok(true)
}
