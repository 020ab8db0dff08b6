//! `study`: one study, its tables and plots.

use super::args::{GpuArgs, parse_size, parse_whole};
use clusterlab::compose::Composer;
use std::path::PathBuf;

/// `study`: which study, and what it may read of the options.
#[derive(clap::Args)]
pub(crate) struct StudyArgs {
    /// Which study.
    #[arg(value_parser = parse_study_name())]
    pub name: String,
    /// Print the rows as JSON (the table goes to stderr).
    #[arg(long)]
    pub json: bool,
    /// Folder for NAME.csv, NAME.json, NAME.md and the plot.
    #[arg(long, default_value = "out/study")]
    pub out: PathBuf,
    /// Codecs: uniform unit vectors to sample (1 to 67108864; default 1048576).
    #[arg(long, value_parser = parse_samples)]
    pub samples: Option<usize>,
    /// Image size, WIDTHxHEIGHT (default 640x360; scale: 1920x1080 on a GPU, 640x360 on
    /// a software adapter).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Slicing, cones, culling and msaa: comma-separated scenes, built-in names or glTF
    /// files (default: every built-in scene).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Comma-separated light counts, each run in every scene (default: the study's own,
    /// its help says which).
    #[arg(long, value_delimiter = ',')]
    pub lights: Vec<u32>,
    /// Variant files, folders of them, or names in variants/: msaa and scale run them
    /// beside their own.
    #[arg(long, num_args = 1..)]
    pub variants: Vec<String>,
    /// Timed frames per run, at least 1 (default 3; the median is reported; temporal:
    /// the frames of each sequence after the first).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub frames: Option<u32>,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

/// The studies' names, each with what it measures.
fn parse_study_name() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(
        clusterlab::study::STUDIES
            .iter()
            .map(|e| clap::builder::PossibleValue::new(e.name).help(e.about)),
    )
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

pub(crate) fn study(args: &StudyArgs) -> Result<bool, String> {
    use clusterlab::study::Reads;
    let given: Vec<Reads> = [
        (args.samples.is_some(), Reads::Samples),
        (args.size.is_some(), Reads::Size),
        (!args.scenes.is_empty(), Reads::Scenes),
        (!args.lights.is_empty(), Reads::Lights),
        (args.frames.is_some(), Reads::Frames),
        (!args.variants.is_empty(), Reads::Variants),
    ]
    .into_iter()
    .filter_map(|(given, option)| given.then_some(option))
    .collect();
    let defaults = clusterlab::study::StudyOptions::default();
    let mut options = clusterlab::study::StudyOptions {
        samples: args.samples.unwrap_or(defaults.samples),
        size: args.size,
        lights: args.lights.clone(),
        frames: args.frames.unwrap_or(defaults.frames),
        variants: clusterlab::variant::load_args(&args.variants)?,
        ..defaults
    };
    if !args.scenes.is_empty() {
        options.scenes = args.scenes.clone();
    }
    let (name, options, json, out, gpu) = (&args.name, &options, args.json, &args.out, &args.gpu);
    let study = clusterlab::study::find(name).map_err(|e| e.to_string())?;
    study
        .check_given(&given, &options.lights)
        .map_err(|e| e.to_string())?;
    clusterlab::study::check_folder(out, name)?;
    let gpu = gpu.open()?;
    eprintln!(
        "study {name} on {} ({}, {}); {}",
        gpu.adapter.name,
        gpu.adapter.backend,
        gpu.adapter.driver,
        clusterlab::compose::shaders_line()
    );
    let started = std::time::Instant::now();
    let result = study
        .run(&gpu, &Composer::default(), options, &mut |line| {
            eprintln!("  {line}")
        })
        .map_err(|e| e.to_string())?;
    let command: Vec<String> = std::env::args().collect();
    let command = format!("clusterlab {}", command[1..].join(" "));
    let files = clusterlab::study::write(out, &result, &gpu.adapter, &command)
        .map_err(|e| e.to_string())?;
    if json {
        eprint!("{}", result.table.terminal());
        let doc = clusterlab::study::json(&result, &gpu.adapter, &command);
        println!(
            "{}",
            serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?
        );
    } else {
        print!("{}", result.table.terminal());
    }
    eprintln!(
        "\n{} in {:.1} s; wrote {}",
        if result.ok { "done" } else { "FAILED" },
        started.elapsed().as_secs_f64(),
        files
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(result.ok)
}
