//! `snapshot`: write the pending WGSL and image snapshots of variants, or take them in.

use std::path::Path;

use super::args::GpuArgs;
use clusterlab::compose::Composer;
use clusterlab::snapshot;
use clusterlab::variant::{self, LoadedVariant};

/// `snapshot`: which variants, or take the pending snapshots in.
#[derive(clap::Args)]
pub(crate) struct SnapshotArgs {
    /// Variant files, folders of them, or names in variants/ (default: variants/).
    #[arg(long, num_args = 1..)]
    pub variants: Vec<String>,
    /// Take every pending snapshot in: each replaces its reviewed one.
    #[arg(long, conflicts_with = "variants")]
    pub accept: bool,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

pub(crate) fn snapshot(args: &SnapshotArgs) -> Result<bool, String> {
    let (variants, gpu) = (&args.variants, &args.gpu);
    let root = Path::new("");
    if args.accept {
        let taken = snapshot::accept(root)?;
        for path in &taken {
            println!("accepted {}", path.display());
        }
        println!("{} snapshots accepted", taken.len());
        return Ok(true);
    }
    // The index covers the working folder's variants/ and those given.
    let folder = Path::new(variant::FOLDER);
    let in_folder = if folder.is_dir() {
        variant::load_args(&[variant::FOLDER.to_string()])?
    } else {
        Vec::new()
    };
    let given: Vec<LoadedVariant> = if variants.is_empty() {
        if in_folder.is_empty() {
            return Err(format!(
                "no variants: give --variants FILES|FOLDERS, or run where a {}/ folder of .ron files is",
                variant::FOLDER
            ));
        }
        in_folder.clone()
    } else {
        variant::load_args(variants)?
    };
    // A tree's tests hold its snapshots to variants/ alone: one from elsewhere would be a
    // snapshot no test makes.
    if Path::new(snapshot::table::PAGE).is_file()
        && let Some(outside) = given.iter().find(|v| {
            let at = v.path.canonicalize().ok();
            !in_folder.iter().any(|f| f.path.canonicalize().ok() == at)
        })
    {
        return Err(format!(
            "{}: in a clusterlab tree the snapshots are those of {}/ alone (its tests check them): put the file there, or run `clusterlab snapshot` in a folder of your own",
            outside.path.display(),
            variant::FOLDER
        ));
    }
    let mut all = in_folder;
    for v in &given {
        match all.iter_mut().find(|a| a.name == v.name) {
            Some(a) => *a = v.clone(),
            None => all.push(v.clone()),
        }
    }
    all.sort_by(|a, b| a.name.cmp(&b.name));
    // The default matrix's size, for the page that states it (a tree's docs/variants.md).
    let cells = clusterlab::matrix::default_groups()
        .and_then(|g| clusterlab::matrix::expand(&g))
        .map(|cells| cells.len())
        .ok();
    let gpu = gpu.open()?;
    eprintln!(
        "snapshots of {} variants on {} ({}, {}) into {}/; {}",
        given.len(),
        gpu.adapter.name,
        gpu.adapter.backend,
        gpu.adapter.driver,
        snapshot::FOLDER,
        clusterlab::compose::shaders_line()
    );
    let outcome = snapshot::write(
        &gpu,
        &Composer::default(),
        root,
        &given,
        &all,
        cells,
        &mut |line| eprintln!("{line}"),
    )?;
    print!("{}", outcome.report());
    Ok(outcome.failed.is_empty())
}
