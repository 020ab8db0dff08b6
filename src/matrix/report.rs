//! Writing results: results.json, results.csv, the HTML report and its plots (each file
//! written to a temporary name and renamed, so an interrupted run leaves no half file), and
//! the terminal table.

use std::fmt::Write as _;
use std::path::Path;

use super::columns::{self, Measured};
use super::record::{CellRecord, Results, grouped, label};
use super::{html, plots};

use crate::files::write_file;

/// Write results.json, results.csv, the plots and index.html into `dir`.
pub fn write_report(dir: &Path, results: &Results) -> Result<(), String> {
    let plot_dir = dir.join("plots");
    crate::files::write::create_folder(&plot_dir)?;
    let json = serde_json::to_string_pretty(results).map_err(|e| e.to_string())?;
    write_file(&dir.join("results.json"), json.as_bytes())?;
    write_file(&dir.join("results.csv"), &columns::csv(&results.cells)?)?;
    let plots = plots::all(results);
    for plot in &plots {
        write_file(&plot_dir.join(&plot.file), plot.svg.as_bytes())?;
    }
    let page = html::page(results, &plots);
    write_file(&dir.join("index.html"), page.as_bytes())
}

/// The terminal table: one row per cell, grouped by scene and parameters, with the result
/// columns shown in the terminal (`columns::COLUMNS`); `*` marks the time-error Pareto front.
pub fn table(results: &Results) -> String {
    let mut out = String::new();
    let rows: Vec<Measured> = results.cells.iter().map(CellRecord::measured).collect();
    let cols = columns::table_columns(&rows, |s| s.terminal);
    let names: Vec<String> = results.cells.iter().map(label).collect();
    let name_width = names.iter().map(|n| n.len()).max().unwrap_or(0).max(40);
    let widths: Vec<usize> = cols
        .iter()
        .map(|c| {
            rows.iter()
                .map(|m| (c.text)(m).chars().count())
                .chain([c.heading.len()])
                .max()
                .unwrap_or(0)
        })
        .collect();
    for (group, cells) in grouped(results) {
        let _ = writeln!(out, "\n{group}");
        let _ = write!(out, "  {:<name_width$}", "variant");
        for (c, w) in cols.iter().zip(&widths) {
            let _ = write!(out, " {:>w$}", c.heading);
        }
        let _ = writeln!(out);
        for c in cells {
            let mark = if c.pareto { '*' } else { ' ' };
            let name = label(c);
            let failed = c
                .failure
                .as_deref()
                .map(|why| why.lines().next().unwrap_or(""));
            if let Some(first) = failed
                && c.total_ms().is_none()
            {
                let verdict = if c.refused { "REFUSED" } else { "FAILED" };
                let _ = writeln!(out, "  {name:<name_width$} {verdict}: {first}");
                continue;
            }
            // A frame that rendered and means nothing: its figures, then why it failed.
            let m = c.measured();
            let _ = write!(out, "{mark} {name:<name_width$}");
            for (col, w) in cols.iter().zip(&widths) {
                let _ = write!(out, " {:>w$}", (col.text)(&m));
            }
            if let Some(first) = failed {
                let _ = write!(out, " FAILED: {first}");
            }
            let _ = writeln!(out);
        }
    }
    let _ = writeln!(
        out,
        "\n{}; * = on the time-error (RMSE) Pareto front of its group",
        results.tally()
    );
    out
}
