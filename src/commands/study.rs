//! `study`: one study, its tables and plots.

use crate::GpuArgs;
use clusterlab::compose::Composer;
use std::path::Path;

pub(crate) fn study(
    name: &str,
    options: &clusterlab::study::StudyOptions,
    given: &[clusterlab::study::Reads],
    json: bool,
    out: &Path,
    gpu: &GpuArgs,
) -> Result<bool, String> {
    let study = clusterlab::study::find(name).map_err(|e| e.to_string())?;
    study
        .check_given(given, &options.lights)
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
