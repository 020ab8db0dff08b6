//! `matrix` and `merge`: the variant matrix, its shards and its report.

use super::args::{GpuArgs, parse_budget_ms, parse_fraction, parse_size};
use clusterlab::compose::Composer;
use clusterlab::measure::{Budget, Frames};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args)]
pub(crate) struct MatrixArgs {
    /// Variant files, folders of them, or names in variants/ (default: variants/).
    #[arg(long, num_args = 1..)]
    pub variants: Vec<String>,
    /// Comma-separated scenes: built-in names (see `clusterlab scenes`) or glTF files
    /// (.gltf or .glb) (default: every built-in scene).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// A swept parameter: lights=64,256,...  radius=1,2..4,...  grid=16x9x24,...
    /// spots=0,0.5,1  skipping=on,off  msaa=1,4. Repeat for a grid of sweeps.
    #[arg(long, value_parser = clusterlab::matrix::parse_sweep)]
    pub sweep: Vec<clusterlab::matrix::Sweep>,
    /// Image size of every cell, WIDTHxHEIGHT (default: each scene's).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Exactly N timed frames per cell (at least 1) after --warmup untimed ones, instead
    /// of frames by budget; pass times are medians over the timed frames.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub frames: Option<u32>,
    /// With --frames: untimed frames first (software rasterisers compile on first use).
    #[arg(long, default_value_t = 1, requires = "frames")]
    pub warmup: u32,
    /// Frames by budget: a group's cells are timed in interleaved rounds, each until its
    /// verdict against the fastest is decided (6 rounds at least), or it has spent this
    /// many milliseconds of frames (the untimed frame without lights it draws first
    /// included), or taken --max-frames. A first timed frame longer than this is the only
    /// one. A group left undecided says which values would decide it.
    #[arg(long, default_value_t = Budget::DEFAULT.budget_ms, value_parser = parse_budget_ms, conflicts_with = "frames")]
    pub budget_ms: f64,
    /// Frames by budget: most rounds (timed frames) per cell while its verdict is open.
    #[arg(long, default_value_t = Budget::DEFAULT.max_frames, value_parser = clap::value_parser!(u32).range(1..=1000), conflicts_with = "frames")]
    pub max_frames: u32,
    /// Folder for results.json, results.csv, images/, plots/ and index.html.
    #[arg(long, default_value = "out/matrix")]
    pub out: PathBuf,
    /// Print results.json to stdout (the table goes to stderr).
    #[arg(long)]
    pub json: bool,
    /// Run only shard K of N (1-based): every N-th cell from the K-th.
    #[arg(long, value_parser = clusterlab::matrix::parse_shard)]
    pub shard: Option<(u32, u32)>,
    /// An earlier results.json (or its folder): show each cell's change against it.
    #[arg(long)]
    pub baseline: Option<PathBuf>,
    /// An earlier matrix's result folder (it may be --out itself): take each cell whose
    /// variant file, composed WGSL, scene, parameters, adapter and clusterlab build are all
    /// unchanged from there, images and all, and run only the others.
    #[arg(long)]
    pub reuse: Option<PathBuf>,
    /// Run each cell's CPU work (the f64 reference, error figures, images) on a thread of
    /// its own while the next cells render: `auto` does so on a hardware GPU and not on a
    /// software one, whose frames are the CPU's own work and would be slowed.
    #[arg(long, value_enum, default_value_t = Overlap::Auto)]
    pub overlap: Overlap,
    /// Run every cell as a sequence of N frames (1 to 3600) instead of one frame rendered
    /// again: a fraction of the lights moving (`--moving`, or a `moving=` sweep), the
    /// camera on its path or still; each cell's times are of the frames after the first.
    /// A sequence times all its frames: the options that choose frames do not apply.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=clusterlab::sequence::MAX_FRAMES as i64), conflicts_with_all = ["frames", "budget_ms", "max_frames"])]
    pub sequence: Option<u32>,
    /// With --sequence: fraction of the lights that move, in 0..=1 (default: all of them,
    /// none of a glTF file's own lights, which cannot move).
    #[arg(long, value_parser = parse_fraction, requires = "sequence")]
    pub moving: Option<f32>,
    /// With --sequence: keep the camera where it is at the first frame.
    #[arg(long, requires = "sequence")]
    pub still_camera: bool,
    /// With --sequence: check every K-th frame (and the first and last), K >= 1.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..), requires = "sequence")]
    pub check_every: u32,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Overlap {
    Auto,
    On,
    Off,
}

/// `merge`: result folders into one report.
#[derive(clap::Args)]
pub(crate) struct MergeArgs {
    /// Result folders (each with a results.json).
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    /// Folder for the combined report.
    #[arg(long, default_value = "out/matrix")]
    pub out: PathBuf,
    /// Print results.json to stdout (the table goes to stderr).
    #[arg(long)]
    pub json: bool,
    /// Merge folders from different adapters, or whose variant files differ.
    #[arg(long)]
    pub allow_mixed: bool,
    /// Folders that hold the same cell are refused; keep the copy from the `first` or
    /// the `last` folder that has it instead.
    #[arg(long, value_enum)]
    pub prefer: Option<clusterlab::matrix::Prefer>,
}

pub(crate) fn matrix(args: &MatrixArgs) -> Result<bool, String> {
    use clusterlab::matrix::{self, Group, MatrixOptions};
    let custom = !args.variants.is_empty() || !args.scenes.is_empty() || !args.sweep.is_empty();
    let mut groups = if custom {
        let variants = if args.variants.is_empty() {
            vec!["variants".to_string()]
        } else {
            args.variants.clone()
        };
        let scenes = if args.scenes.is_empty() {
            clusterlab::scene::SCENES
                .iter()
                .map(|s| s.name.to_string())
                .collect()
        } else {
            args.scenes.clone()
        };
        vec![Group {
            name: "custom".into(),
            variants: matrix::find_variants(&variants)?,
            scenes,
            sweeps: args.sweep.clone(),
            size: None,
            sequence: None,
        }]
    } else {
        matrix::default_groups()?
    };
    for g in &mut groups {
        if let Some(size) = args.size {
            g.size = Some(size);
        }
        if let Some(frames) = args.sequence {
            g.sequence = Some(matrix::GroupSequence {
                spec: clusterlab::sequence::SequenceSpec {
                    frames,
                    check_every: args.check_every,
                },
                moving: args.moving,
                still_camera: args.still_camera,
            });
        }
    }
    let baseline = args
        .baseline
        .as_deref()
        .map(matrix::Results::load)
        .transpose()?;
    let previous = args
        .reuse
        .as_deref()
        .map(matrix::Previous::load)
        .transpose()?
        .map(std::sync::Arc::new);
    let mut cells = matrix::expand(&groups)?;
    let variant_files = matrix::variant_files(&cells);
    if let Some(shard) = args.shard {
        let planned = cells.len();
        cells = matrix::shard(cells, shard);
        if cells.is_empty() {
            return Err(format!(
                "--shard {}/{}: the matrix has {planned} cells, so shard {} holds none; split it into at most {planned} shards",
                shard.0, shard.1, shard.0
            ));
        }
    }
    // The run writes into a staging folder and swaps it in whole when it is done.
    let folder = clusterlab::files::ResultFolder::acquire(&args.out)?;
    let mut gpu = args.gpu.open()?;
    eprintln!(
        "{} cells on {} ({}, {}); writing to {}; {}",
        cells.len(),
        gpu.adapter.name,
        gpu.adapter.backend,
        gpu.adapter.driver,
        args.out.display(),
        clusterlab::compose::shaders_line()
    );
    if let Some(folder) = clusterlab::gpu::disk_cache::folder() {
        eprintln!("{}", gpu.attach_disk_cache(&folder));
    }
    if let Some(old) = &baseline
        && let Some(other) = old.provenance.iter().find(|p| p.adapter != gpu.adapter)
    {
        eprintln!(
            "warning: the baseline ran on {} ({}, {}), this run on {} ({}, {}): its time ratios compare different adapters",
            other.adapter.name,
            other.adapter.backend,
            other.adapter.driver,
            gpu.adapter.name,
            gpu.adapter.backend,
            gpu.adapter.driver
        );
    }
    let frames = match args.frames {
        Some(timed) => Frames::exact(args.warmup, timed),
        None => Frames::Budget(Budget {
            budget_ms: args.budget_ms,
            max_frames: args.max_frames,
        }),
    };
    let options = MatrixOptions {
        frames,
        out: folder.staging.clone(),
        progress: true,
        shard: args.shard,
        command: std::env::args().collect(),
        variant_files,
        before_cell: None,
        reuse: previous.clone(),
        overlap: match args.overlap {
            Overlap::Auto => !gpu.software,
            Overlap::On => true,
            Overlap::Off => false,
        },
    };
    let start = Instant::now();
    let mut results = matrix::run(&mut gpu, &Composer::default(), &cells, &options);
    if let Err(e) = gpu.save_disk_cache() {
        eprintln!("warning: the pipeline cache was not saved: {e}");
    }
    if let Some(old) = &baseline {
        matrix::derive(&mut results.cells, Some(old));
    }
    matrix::write_report(&folder.staging, &results)?;
    folder.commit()?;
    report(&results, args.json, &args.out)?;
    if let Some(previous) = &previous {
        eprintln!("{}", matrix::reuse_summary(&results, &previous.dir));
    }
    if let Some(old) = &baseline {
        eprint!("{}", matrix::compare_runs(&results, old));
    }
    eprintln!("finished in {:.0} s", start.elapsed().as_secs_f64());
    Ok(results.failed() == 0)
}

pub(crate) fn merge(args: &MergeArgs) -> Result<bool, String> {
    let folder = clusterlab::files::ResultFolder::acquire(&args.out)?;
    let results =
        clusterlab::matrix::merge(&args.dirs, &folder.staging, args.allow_mixed, args.prefer)?;
    clusterlab::matrix::write_report(&folder.staging, &results)?;
    folder.commit()?;
    report(&results, args.json, &args.out)?;
    Ok(results.failed() == 0)
}

/// Print the table (stdout, or stderr when stdout carries the JSON).
fn report(results: &clusterlab::matrix::Results, json: bool, out: &Path) -> Result<(), String> {
    let table = clusterlab::matrix::table(results);
    if json {
        eprint!("{table}");
        println!(
            "{}",
            serde_json::to_string_pretty(results).map_err(|e| e.to_string())?
        );
    } else {
        print!("{table}");
        println!("report: {}", out.join("index.html").display());
    }
    for cost in results.provenance.iter().filter_map(|p| p.cost.as_ref()) {
        eprintln!("run: {}", cost.line());
    }
    Ok(())
}
