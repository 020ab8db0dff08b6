//! `sequence`: frames that follow each other, each measured.

use super::args::{CellArgs, GpuArgs, parse_fraction};
use clusterlab::compose::Composer;
use std::path::PathBuf;

#[derive(clap::Args)]
pub(crate) struct SequenceArgs {
    #[command(flatten)]
    pub cell: CellArgs,
    /// Frames, 1 to 3600, one frame step (1/30 s) apart.
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u32).range(1..=clusterlab::sequence::MAX_FRAMES as i64))]
    pub frames: u32,
    /// Fraction of the lights that move, in 0..=1 (the rest stand where they were at the
    /// first frame; default: all of them, none of a glTF file's own lights, which cannot
    /// move).
    #[arg(long, value_parser = parse_fraction)]
    pub moving: Option<f32>,
    /// Keep the camera where it is at the first frame.
    #[arg(long)]
    pub still_camera: bool,
    /// Check every K-th frame (and the first and last) against its reference, K >= 1.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..))]
    pub check_every: u32,
    /// Folder for the animation, plot, table, report and the last frame's image.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    #[command(flatten)]
    pub gpu: GpuArgs,
    /// Print the report as JSON instead of the table.
    #[arg(long)]
    pub json: bool,
}

pub(crate) fn sequence(args: &SequenceArgs) -> Result<bool, String> {
    clusterlab::files::write::check_folder(&args.out, "--out")?;
    let loaded = args.cell.variant()?;
    let mut params = args.cell.params()?;
    let fixed =
        clusterlab::scene::lights_fixed(&args.cell.scene, &params).map_err(|e| e.to_string())?;
    if fixed && args.moving.is_some_and(|m| m > 0.0) {
        return Err(format!(
            "--moving {}: the lights of `{}` are the file's own, which stand where it puts them; leave out --moving, or give --lights N for N seeded lights that move",
            args.moving.unwrap_or_default(),
            args.cell.scene
        ));
    }
    params.motion = clusterlab::scene::Motion {
        lights: args.moving.unwrap_or(if fixed { 0.0 } else { 1.0 }),
        camera: !args.still_camera,
        still_at: params.time,
    };
    let spec = clusterlab::sequence::SequenceSpec {
        frames: args.frames,
        check_every: args.check_every,
    };
    let gpu = args.gpu.open()?;
    gpu.begin_cell();
    let scene = &args.cell.scene;
    let frames = clusterlab::sequence::scene_frames(scene, params);
    let what = format!("variant `{}` on scene `{scene}`", loaded.name);
    let run = clusterlab::sequence::run(
        &gpu,
        &Composer::default(),
        &loaded,
        spec,
        &frames,
        &Default::default(),
    )
    .map_err(|e| format!("{what}: {e}"))?;
    let stem = clusterlab::run::safe_file_name(&format!("{}@{}", loaded.name, run.report.scene));
    let written = clusterlab::sequence::output::write(&args.out, &stem, &run)
        .map_err(|e| format!("{what}: {e}"))?;
    let r = &run.report;
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(r).map_err(|e| e.to_string())?
        );
    } else {
        println!(
            "{} on {} ({}x{}, {} lights, {:.0}% moving, camera {}) with {} ({}, {}); lists: {}; timing: {}",
            r.variant,
            r.scene,
            r.size[0],
            r.size[1],
            r.lights,
            r.summary.moving * 100.0,
            if r.summary.camera_moves {
                "moving"
            } else {
                "still"
            },
            r.adapter.name,
            r.adapter.backend,
            r.adapter.driver,
            r.update.as_deref().unwrap_or("-"),
            r.timing_source
        );
        print!("{}", clusterlab::sequence::output::table(r));
        for path in &written {
            println!("  wrote {}", path.display());
        }
    }
    if let Some(why) = &r.failure {
        eprintln!("FAILED: {what}: {why}");
        return Ok(false);
    }
    Ok(true)
}
