//! The report's plots, as SVG (plotters): time against fidelity with the Pareto front and
//! interval bars, time against light count per pipeline, time against cluster count, and
//! time per pass.

use plotters::prelude::*;

use super::record::{grouped, label};
use super::{CellRecord, Results};
use crate::measure::Front;
use crate::plot::{self, Area, FONT, Plot, log_axis, numbered_key, series_color, tick_label};

const SIZE: (u32, u32) = (880 + plot::LEGEND_WIDTH, 520);

/// The marker index of a square (`plot::marker`): a bar's legend entry.
const SQUARE: usize = 10;
/// Width of the plot beside a numbered key.
const KEY_SPLIT: u32 = 560 + plot::LEGEND_WIDTH / 2;

fn pipeline_color(c: &CellRecord) -> RGBColor {
    match c.spec.pipeline.as_deref() {
        Some("NaiveForward") => RGBColor(214, 39, 40),
        Some("ClusteredForward") => RGBColor(31, 119, 180),
        Some("ClusteredDeferred") => RGBColor(44, 160, 44),
        Some("DeferredScissor") => RGBColor(255, 127, 14),
        _ => RGBColor(127, 127, 127),
    }
}

/// Every plot the results support.
pub fn all(results: &Results) -> Vec<Plot> {
    let mut plots = Vec::new();
    for (n, (group, cells)) in grouped(results).into_iter().enumerate() {
        let shown: Vec<&CellRecord> = cells
            .into_iter()
            .filter(|c| c.ok() && !c.spec.debug_view && c.total_ms().is_some())
            .collect();
        // Light-count sweeps make many small groups; their story is the lights plot.
        if shown.len() < 4 {
            continue;
        }
        let mut add = |kind: &str, title: String, size, draw: &dyn Fn(&Area) -> Drawn| {
            let file = format!("{kind}_{n}.svg");
            if let Some(p) = plot::svg(&file, &title, size, |a| drawn(draw(a))) {
                plots.push(p);
            }
        };
        add(
            "time_error",
            format!("GPU time against fidelity (RMSE against the group's truth): {group}"),
            time_error_size(&shown),
            &|a| time_error(a, &shown),
        );
        add(
            "time_clusters",
            format!("GPU time against cluster count: {group}"),
            time_clusters_size(&shown),
            &|a| time_clusters(a, &shown),
        );
        // Naive forward's light loop would flatten every other bar; the table has it.
        let fast: Vec<&CellRecord> = shown
            .iter()
            .copied()
            .filter(|c| c.spec.pipeline.as_deref() != Some("NaiveForward"))
            .collect();
        add(
            "passes",
            format!("GPU time per pass (naive forward left out): {group}"),
            SIZE,
            &|a| passes(a, &fast),
        );
    }
    let lights = plot::svg(
        "time_lights.svg",
        "GPU time against light count",
        SIZE,
        |a| drawn(time_lights(a, results)),
    );
    plots.extend(lights);
    plots
}

type Drawn = Result<bool, Box<dyn std::error::Error>>;

/// Some(()) when a drawing drew something without error.
fn drawn(d: Drawn) -> Option<()> {
    d.ok().filter(|&d| d).map(|_| ())
}

fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, 0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
    (lo.max(1e-4) / 1.5, hi.max(1e-3) * 1.5)
}

/// The cells the time-fidelity plot shows, as its points: each cell's median and
/// interval, its fidelity RMSE, its name with its front mark, its pipeline's colour.
fn time_error_points(cells: &[&CellRecord]) -> Vec<plot::TimeErrorPoint> {
    cells
        .iter()
        .filter_map(|c| {
            let mark = match c.front {
                Some(Front::On) => "* ",
                Some(Front::Undecided) => "? ",
                _ => "",
            };
            Some(plot::TimeErrorPoint {
                ms: c.total_ms()?,
                interval: c.total_interval().map(|i| [i.lo, i.hi]),
                error: c.fidelity_rmse()?,
                name: format!("{mark}{}", label(c)),
                color: pipeline_color(c),
                on_front: c.on_front(),
            })
        })
        .collect()
}

/// The pipelines the cells hold, as a legend.
fn pipeline_legend(cells: &[&CellRecord]) -> Vec<plot::Entry> {
    [
        ("naive forward", "NaiveForward"),
        ("clustered forward", "ClusteredForward"),
        ("clustered deferred", "ClusteredDeferred"),
        ("scissor deferred", "DeferredScissor"),
    ]
    .into_iter()
    .filter_map(|(name, pipeline)| {
        let c = cells
            .iter()
            .find(|c| c.spec.pipeline.as_deref() == Some(pipeline))?;
        Some((name.to_string(), pipeline_color(c), Some(0)))
    })
    .collect()
}

fn time_error_size(cells: &[&CellRecord]) -> (u32, u32) {
    plot::time_error_size(&time_error_points(cells), pipeline_legend(cells).len())
}

/// GPU time against fidelity (RMSE against the group's truth): `plot::time_error`.
fn time_error(area: &Area, cells: &[&CellRecord]) -> Drawn {
    plot::time_error(
        area,
        &time_error_points(cells),
        &pipeline_legend(cells),
        "RMSE against the group's truth, 8-bit LSB (log)",
    )
}

/// The cells the time-cluster plot shows: (clusters, median ms, the cell).
fn time_clusters_points<'a>(cells: &[&'a CellRecord]) -> Vec<(f64, f64, &'a CellRecord)> {
    cells
        .iter()
        .filter(|c| !c.spec.post)
        .filter_map(|c| {
            let g = c.spec.grid?;
            Some(((g[0] * g[1] * g[2]) as f64, c.total_ms()?, *c))
        })
        .collect()
}

fn time_clusters_key(points: &[(f64, f64, &CellRecord)]) -> Vec<(String, RGBColor)> {
    points
        .iter()
        .map(|p| {
            let g = p.2.spec.grid.unwrap_or_default();
            (
                format!("{} ({}x{}x{})", label(p.2), g[0], g[1], g[2]),
                pipeline_color(p.2),
            )
        })
        .collect()
}

/// The time-cluster plot's size: its data area and a key that holds every name whole.
fn time_clusters_size(cells: &[&CellRecord]) -> (u32, u32) {
    let (kw, kh) = plot::key_size(&time_clusters_key(&time_clusters_points(cells)));
    (KEY_SPLIT + kw, SIZE.1.max(kh))
}

fn time_clusters(area: &Area, cells: &[&CellRecord]) -> Drawn {
    let points = time_clusters_points(cells);
    if points.len() < 2 {
        return Ok(false);
    }
    let (plot_area, key_area) = area.split_horizontally(KEY_SPLIT);
    let (plot_area, _) = plot_area.split_vertically(SIZE.1);
    let c1 = points.iter().map(|p| p.0).fold(0.0, f64::max) * 1.25;
    let t1 = points.iter().map(|p| p.1).fold(0.0, f64::max) * 1.15;
    let mut chart = ChartBuilder::on(&plot_area)
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(0.0..c1, 0.0..t1)?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_desc("clusters in the grid")
        .y_desc("GPU time per frame, ms")
        .x_label_formatter(&tick_label)
        .y_label_formatter(&tick_label)
        .label_style((FONT, 13))
        .draw()?;
    chart.draw_series(
        points
            .iter()
            .map(|p| Circle::new((p.0, p.1), 5, pipeline_color(p.2).filled())),
    )?;
    let at: Vec<(f64, f64)> = points.iter().map(|p| (p.0, p.1)).collect();
    plot::number_points(&mut chart, &at).ok_or("the point numbers did not draw")?;
    numbered_key(&key_area, "variant (grid)", &time_clusters_key(&points));
    Ok(true)
}

fn passes(area: &Area, cells: &[&CellRecord]) -> Drawn {
    let mut names: Vec<String> = Vec::new();
    for c in cells {
        for k in c.gpu_ms.keys() {
            if k != "total" && !names.contains(k) {
                names.push(k.clone());
            }
        }
    }
    if names.is_empty() {
        return Ok(false);
    }
    let rows: Vec<&CellRecord> = cells.iter().rev().copied().collect();
    let longest = rows
        .iter()
        .filter_map(|c| c.total_ms())
        .fold(0.0, f64::max)
        .max(1e-3);
    let n = rows.len() as i32;
    let (area, legend_area) = plot::legend_column(area);
    let mut chart = ChartBuilder::on(&area)
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(250)
        .build_cartesian_2d(0.0..longest * 1.05, (0..n - 1).into_segmented())?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .disable_y_mesh()
        .y_labels(rows.len())
        .y_label_formatter(&|v| match v {
            SegmentValue::CenterOf(i) => rows.get(*i as usize).map_or(String::new(), |c| label(c)),
            _ => String::new(),
        })
        .x_desc("GPU time per frame, ms (median)")
        .x_label_formatter(&tick_label)
        .label_style((FONT, 12))
        .draw()?;
    let mut legend = Vec::new();
    for (k, name) in names.iter().enumerate() {
        let color = series_color(k);
        let bars = rows.iter().enumerate().filter_map(|(i, c)| {
            let ms = c.gpu_ms.get(name)?.as_f64()?;
            // Passes stack in the order they ran (the map's order).
            let before: f64 = c
                .gpu_ms
                .iter()
                .take_while(|(n, _)| *n != name)
                .filter(|(n, _)| *n != "total")
                .filter_map(|(_, v)| v.as_f64())
                .sum();
            let y = i as i32;
            Some(Rectangle::new(
                [
                    (before, SegmentValue::Exact(y)),
                    (before + ms, SegmentValue::Exact(y + 1)),
                ],
                color.filled(),
            ))
        });
        chart.draw_series(bars)?;
        legend.push((name.clone(), color, Some(SQUARE)));
    }
    plot::side_legend(&legend_area, "pass", &legend);
    Ok(true)
}

fn time_lights(area: &Area, results: &Results) -> Drawn {
    // One series per variant (and per scene and size, when a study has several).
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for c in &results.cells {
        if !c.ok() || !c.spec.sweep.contains_key("lights") {
            continue;
        }
        let Some(ms) = c.total_ms() else { continue };
        let p = &c.spec.params;
        let key = format!("{} ({} {}x{})", label(c), c.spec.scene, p.width, p.height);
        let point = (p.lights.max(1) as f64, ms);
        match series.iter_mut().find(|(k, _)| *k == key) {
            Some((_, pts)) => pts.push(point),
            None => series.push((key, vec![point])),
        }
    }
    series.retain(|(_, pts)| pts.len() >= 2);
    if series.is_empty() {
        return Ok(false);
    }
    let (l0, l1) = log_range(series.iter().flat_map(|s| s.1.iter().map(|p| p.0)));
    let (t0, t1) = log_range(series.iter().flat_map(|s| s.1.iter().map(|p| p.1)));
    let (area, legend_area) = plot::legend_column(area);
    let mut chart = ChartBuilder::on(&area)
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(log_axis(l0, l1), log_axis(t0, t1))?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_desc("lights (log)")
        .y_desc("GPU time per frame, ms (log)")
        .x_label_formatter(&tick_label)
        .y_label_formatter(&tick_label)
        .label_style((FONT, 14))
        .draw()?;
    let legend = plot::series_legend(series.iter().map(|(name, _)| name));
    for (i, (_, mut pts)) in series.into_iter().enumerate() {
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        plot::line_with_points(&mut chart, pts, i).ok_or("a series did not draw")?;
    }
    plot::side_legend(&legend_area, "variant", &legend);
    Ok(true)
}
