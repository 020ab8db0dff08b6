//! `matrix` and `merge`: the variant matrix, its shards and its report.

use crate::{MatrixArgs, Overlap};
use clusterlab::compose::Composer;
use clusterlab::measure::{Budget, Frames};
use std::path::{Path, PathBuf};
use std::time::Instant;

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
            precision: args.precision / 100.0,
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
        matrix::derive(&mut results.cells, &results.provenance, Some(old));
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

pub(crate) fn merge(
    dirs: &[PathBuf],
    out: &Path,
    json: bool,
    allow_mixed: bool,
    prefer: Option<clusterlab::matrix::Prefer>,
) -> Result<bool, String> {
    let folder = clusterlab::files::ResultFolder::acquire(out)?;
    let results = clusterlab::matrix::merge(dirs, &folder.staging, allow_mixed, prefer)?;
    clusterlab::matrix::write_report(&folder.staging, &results)?;
    folder.commit()?;
    report(&results, json, out)?;
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
