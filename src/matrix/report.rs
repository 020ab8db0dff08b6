//! Writing results: results.json, results.csv, the HTML report and its plots (each file
//! written to a temporary name and renamed, so an interrupted run leaves no half file), and
//! the terminal table.

use std::fmt::Write as _;
use std::path::Path;

use super::columns::{self, Measured};
use super::record::{CellRecord, Results, grouped, label};
use super::{html, plots};

use crate::files::write_file;
use crate::table::Table;

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

/// The terminal table: per group of scene and parameters, one row per cell with the result
/// columns shown in the terminal (`columns::COLUMNS`); `*` marks the time-error Pareto
/// front. A cell without figures says why in their place; one whose figures stand but mean
/// nothing says why after them.
pub fn table(results: &Results) -> String {
    let rows: Vec<Measured> = results.cells.iter().map(CellRecord::measured).collect();
    let cols = columns::table_columns(&rows, |s| s.terminal);
    let headings: Vec<&str> = ["", "variant"]
        .into_iter()
        .chain(cols.iter().map(|c| c.heading))
        .collect();
    let mut out = String::new();
    for (group, cells) in grouped(results) {
        let mut t = Table::new(&group, &headings).left_aligned(2);
        for &c in &cells {
            let mark = c.front.map_or("", |f| f.label());
            let names = vec![mark.to_string(), label(c)];
            let failed = c
                .failure
                .as_deref()
                .map(|why| why.lines().next().unwrap_or(""));
            let m = c.measured();
            let figures = || {
                names
                    .iter()
                    .cloned()
                    .chain(cols.iter().map(|col| (col.text)(&m)))
            };
            match failed {
                Some(first) if c.total_ms().is_none() => {
                    let verdict = if c.refused { "REFUSED" } else { "FAILED" };
                    t.verdict_row(names, format!("{verdict}: {first}"));
                }
                Some(first) => t.row_then(figures().collect(), format!("FAILED: {first}")),
                None => t.row(figures().collect()),
            }
        }
        let _ = write!(out, "\n{}", t.terminal());
        let _ = writeln!(out, "verdict: {}", super::verdicts::group_verdict(&cells));
    }
    let _ = writeln!(
        out,
        "\n{}; * = on the time-fidelity (truth RMSE8) Pareto front of its group, ? = undecided (a cell at least as faithful is undecided against it)",
        results.tally()
    );
    out
}
