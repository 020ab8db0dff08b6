//! The `clusterlab` command line: this file names the commands and dispatches each to its
//! body in `commands/`, where its arguments are declared; the library does the work.

mod commands;

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use commands::*;

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
    Validate(ValidateArgs),
    /// Write the pending snapshots of variants for review: the WGSL of every pass and a
    /// frame on a small scene, beside the reviewed ones in the working folder's snapshots/
    /// (images of an adapter other than llvmpipe in a folder of its own); and the lists
    /// generated from the variant files (snapshots/wgsl/users.txt, and in a clusterlab
    /// tree docs/variants.md). Review with `cargo insta review`, or take every pending one
    /// with --accept.
    Snapshot(SnapshotArgs),
    /// Print the composed WGSL of a variant's passes.
    Wgsl(WgslArgs),
    /// Explain the variant schema: every field, its meaning, allowed values and default.
    Explain,
    /// List the built-in scenes and their default parameters, or write one as glTF.
    Scenes(ScenesArgs),
    /// List every GPU adapter wgpu sees, what each offers clusterlab, and which one render,
    /// matrix, stress and study would use and why: the first thing to paste into a bug report.
    Adapters(AdaptersArgs),
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
    Stress(StressCommand),
    /// Run a study against published numbers (`--help` says what each measures and which
    /// options it reads).
    Study(StudyArgs),
    /// Combine matrix result folders (shards of one study) into one report.
    Merge(MergeArgs),
}

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
        Command::Validate(args) => validate(&args),
        Command::Wgsl(args) => wgsl(&args),
        Command::Snapshot(args) => snapshot(&args),
        Command::Explain => {
            print!("{}", clusterlab::explain::explain());
            Ok(true)
        }
        Command::Scenes(args) => scenes(&args),
        Command::Adapters(args) => adapters(&args),
        Command::Render(args) => render(&args),
        Command::View(args) => view(&args),
        Command::Sequence(args) => sequence(&args),
        Command::Matrix(args) => matrix(&args),
        Command::Merge(args) => merge(&args),
        Command::Stress(args) => stress(&args),
        Command::Study(args) => study(&args),
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
