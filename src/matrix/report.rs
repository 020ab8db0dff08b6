//! Writing results: results.json, results.csv, the HTML report and its plots (each file
//! written to a temporary name and renamed, so an interrupted run leaves no half file), and
//! the terminal table.

use std::fmt::Write as _;
use std::path::Path;

use super::{CellRecord, Results, html, plots};

fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), String> {
    crate::run::write_atomic(path, bytes).map_err(|e| e.to_string())
}

/// Write results.json, results.csv, the plots and index.html into `dir`.
pub fn write_report(dir: &Path, results: &Results) -> Result<(), String> {
    let plot_dir = dir.join("plots");
    std::fs::create_dir_all(&plot_dir)
        .map_err(|e| format!("{}: cannot create folder: {e}", plot_dir.display()))?;
    let json = serde_json::to_string_pretty(results).map_err(|e| e.to_string())?;
    write_atomic(&dir.join("results.json"), json.as_bytes())?;
    write_atomic(&dir.join("results.csv"), &csv(results)?)?;
    let plots = plots::all(results);
    for plot in &plots {
        write_atomic(&plot_dir.join(&plot.file), plot.svg.as_bytes())?;
    }
    let page = html::page(results, &plots);
    write_atomic(&dir.join("index.html"), page.as_bytes())
}

fn csv(results: &Results) -> Result<Vec<u8>, String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let header = [
        "id",
        "study",
        "variant",
        "scene",
        "width",
        "height",
        "lights",
        "radius_min",
        "radius_max",
        "seed",
        "grid",
        "pipeline",
        "ok",
        "failure",
        "gpu_ms",
        "gpu_ms_min",
        "gpu_ms_max",
        "speedup_vs_naive",
        "pareto",
        "max_abs_8bit",
        "rmse_8bit",
        "psnr_db",
        "flip_mean",
        "nan_pixels",
        "light_evals",
        "useful_light_evals",
        "dropped_lights",
        "frame_bytes_per_pixel",
        "cluster_bytes",
        "passes",
        "skipped_passes",
    ];
    w.write_record(header).map_err(|e| e.to_string())?;
    for c in &results.cells {
        let s = &c.spec;
        let p = &s.params;
        let spread = c.gpu_ms_spread.get("total").and_then(|v| v.as_array());
        let at = |i: usize| {
            spread
                .and_then(|a| a.get(i))
                .and_then(|v| v.as_f64())
                .map_or(String::new(), |v| v.to_string())
        };
        let opt = |v: Option<String>| v.unwrap_or_default();
        let e = c.error.as_ref();
        let st = c.stats.as_ref();
        let passes: Vec<String> = c
            .gpu_ms
            .iter()
            .filter(|(k, _)| *k != "total")
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        let row = [
            s.id.clone(),
            s.study.clone(),
            s.variant.clone(),
            s.scene.clone(),
            p.width.to_string(),
            p.height.to_string(),
            p.lights.to_string(),
            p.radius[0].to_string(),
            p.radius[1].to_string(),
            p.seed.to_string(),
            opt(s.grid.map(|g| format!("{}x{}x{}", g[0], g[1], g[2]))),
            opt(s.pipeline.clone()),
            c.ok().to_string(),
            opt(c.failure.clone()),
            opt(c.total_ms().map(|t| t.to_string())),
            at(0),
            at(1),
            opt(c.speedup_vs_naive.map(|x| x.to_string())),
            c.pareto.to_string(),
            opt(e.map(|e| e.max_abs_8bit.to_string())),
            opt(e.map(|e| e.rmse_8bit.to_string())),
            opt(e.map(|e| e.psnr_db.map_or("inf".into(), |p| p.to_string()))),
            opt(e.map(|e| e.flip_mean.to_string())),
            opt(e.map(|e| e.nan_pixels.to_string())),
            opt(st.map(|s| s.light_evals.to_string())),
            opt(st.map(|s| s.useful_light_evals.to_string())),
            opt(st.map(|s| s.dropped_lights.to_string())),
            opt(st.map(|s| s.frame_bytes_per_pixel.to_string())),
            opt(st.map(|s| s.cluster_bytes.to_string())),
            passes.join(";"),
            c.skipped_passes.join(";"),
        ];
        w.write_record(&row).map_err(|e| e.to_string())?;
    }
    w.into_inner().map_err(|e| e.to_string())
}

/// A count with a k/M/G suffix.
pub(crate) fn count(n: u64) -> String {
    match n {
        0..1_000 => n.to_string(),
        1_000..1_000_000 => format!("{:.1}k", n as f64 / 1e3),
        1_000_000..1_000_000_000 => format!("{:.1}M", n as f64 / 1e6),
        _ => format!("{:.1}G", n as f64 / 1e9),
    }
}

/// The variant with what was swept, apart from the light count (a column of its own).
pub(crate) fn label(c: &CellRecord) -> String {
    let extra: Vec<String> = c
        .spec
        .sweep
        .iter()
        .filter(|(k, _)| *k != "lights")
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    if extra.is_empty() {
        c.spec.variant.clone()
    } else {
        format!("{}[{}]", c.spec.variant, extra.join(","))
    }
}

/// Cells grouped by scene and parameters (in order of first appearance), each group
/// fastest first, failed cells last.
pub(crate) fn grouped(results: &Results) -> Vec<(String, Vec<&CellRecord>)> {
    let mut groups: Vec<(String, Vec<&CellRecord>)> = Vec::new();
    for c in &results.cells {
        let g = c.spec.group();
        match groups.iter_mut().find(|(k, _)| *k == g) {
            Some((_, v)) => v.push(c),
            None => groups.push((g, vec![c])),
        }
    }
    for (_, cells) in &mut groups {
        cells.sort_by(|a, b| {
            let key = |c: &CellRecord| c.total_ms().unwrap_or(f64::INFINITY);
            key(a).total_cmp(&key(b))
        });
    }
    groups
}

/// The terminal table: one row per cell, grouped by scene and parameters; `*` marks the
/// time-error Pareto front.
pub fn table(results: &Results) -> String {
    let mut out = String::new();
    for (group, cells) in grouped(results) {
        let _ = writeln!(out, "\n{group}");
        let _ = writeln!(
            out,
            "  {:<40} {:>9} {:>8} {:>5} {:>7} {:>7} {:>20} {:>5} {:>7}",
            "variant",
            "GPU ms",
            "x naive",
            "max8",
            "PSNR",
            "FLIP",
            "useful/evaluated",
            "B/px",
            "dropped"
        );
        for c in cells {
            let mark = if c.pareto { '*' } else { ' ' };
            let name = label(c);
            if let Some(why) = &c.failure {
                let first = why.lines().next().unwrap_or("");
                let _ = writeln!(out, "  {name:<40} FAILED: {first}");
                continue;
            }
            let e = c.error.as_ref();
            let s = c.stats.as_ref();
            let evals = s.map_or("-".into(), |s| {
                format!(
                    "{}/{} ({:.0}%)",
                    count(s.useful_light_evals),
                    count(s.light_evals),
                    100.0 * s.useful_light_evals as f64 / s.light_evals.max(1) as f64
                )
            });
            let _ = writeln!(
                out,
                "{mark} {name:<40} {:>9.2} {:>8} {:>5} {:>7} {:>7.4} {:>20} {:>5} {:>7}",
                c.total_ms().unwrap_or(f64::NAN),
                c.speedup_vs_naive
                    .map_or("-".into(), |x| format!("{x:.1}x")),
                e.map_or("-".into(), |e| e.max_abs_8bit.to_string()),
                e.map_or("-".into(), |e| e
                    .psnr_db
                    .map_or("inf".into(), |p| format!("{p:.1}"))),
                e.map_or(f64::NAN, |e| e.flip_mean),
                evals,
                s.map_or("-".into(), |s| s.frame_bytes_per_pixel.to_string()),
                s.map_or("-".into(), |s| s.dropped_lights.to_string()),
            );
            if let Some(b) = &c.vs_baseline {
                let _ = writeln!(
                    out,
                    "    vs baseline: time x{:.2}, max8 {:+}, RMSE8 {:+.3}",
                    b.time_ratio, b.max_abs_8bit_change, b.rmse_8bit_change
                );
            }
        }
    }
    let failed = results.failed();
    let _ = writeln!(
        out,
        "\n{} cells, {} failed; * = on the time-error (RMSE) Pareto front of its group",
        results.cells.len(),
        failed
    );
    out
}
