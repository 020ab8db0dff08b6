//! `stress`: the adversarial cases.

use crate::GpuArgs;
use clusterlab::compose::Composer;

pub(crate) fn stress(filter: Option<&str>, json: bool, gpu: &GpuArgs) -> Result<bool, String> {
    let mut gpu = gpu.open()?;
    eprintln!(
        "stress suite on {} ({}, {})",
        gpu.adapter.name, gpu.adapter.backend, gpu.adapter.driver
    );
    let bar = indicatif::ProgressBar::new_spinner();
    let runs = clusterlab::stress::run(&mut gpu, &Composer::default(), filter, &|what| {
        bar.set_message(what.to_string());
        bar.tick();
    });
    bar.finish_and_clear();
    if runs.is_empty() {
        return Err(format!(
            "no stress case matches `{}`",
            filter.unwrap_or_default()
        ));
    }
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&runs).map_err(|e| e.to_string())?
        );
    } else {
        print!("{}", clusterlab::stress::report(&runs));
    }
    Ok(runs.iter().all(|r| r.ok))
}
