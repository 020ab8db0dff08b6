//! What a sequence leaves: its animation (an animated GIF through the `image` crate, each
//! frame made smaller), a plot of each pass's time over the frames, the per-frame table
//! (terminal and CSV), and the report as JSON; written through `files`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::animation::gif;
use super::{FrameRecord, SequenceReport, SequenceRun};
use crate::plot::{self, Plot};
use crate::run::RunError;

/// The names of the passes the frames ran, in the order they first ran.
fn pass_names(frames: &[FrameRecord]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for f in frames {
        for name in f.gpu_ms.keys() {
            if name != "total" && !names.contains(name) {
                names.push(name.clone());
            }
        }
    }
    names
}

fn pass_ms(f: &FrameRecord, name: &str) -> f64 {
    f.gpu_ms
        .get(name)
        .and_then(serde_json::Value::as_f64)
        .unwrap_or(0.0)
}

/// Each pass's time and the frame's over the frames of a sequence, as `file`.
pub fn frame_plot(report: &SequenceReport, file: &str) -> Option<Plot> {
    use plotters::prelude::*;
    let frames = &report.frames;
    let names = pass_names(frames);
    let top = frames.iter().map(FrameRecord::total_ms).fold(0.0, f64::max) * 1.1 + 1e-3;
    let last = frames.len().max(2) as f64 - 1.0;
    let title = format!(
        "{} on {}: time per pass over {} frames ({})",
        report.variant,
        report.scene,
        frames.len(),
        report.timing_source
    );
    plot::svg(file, &title, (880 + plot::LEGEND_WIDTH, 440), |area| {
        let mut chart = ChartBuilder::on(area)
            .caption(&title, (plot::FONT, 16))
            .margin(12)
            .margin_right(plot::LEGEND_WIDTH)
            .x_label_area_size(36)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..last, 0.0..top)
            .ok()?;
        chart
            .configure_mesh()
            .light_line_style(TRANSPARENT)
            .x_desc("frame")
            .y_desc("ms")
            .x_label_formatter(&plot::tick_label)
            .y_label_formatter(&plot::tick_label)
            .draw()
            .ok()?;
        let line = |values: Vec<(f64, f64)>, style: ShapeStyle| LineSeries::new(values, style);
        let total: Vec<(f64, f64)> = frames
            .iter()
            .map(|f| (f.frame as f64, f.total_ms()))
            .collect();
        chart.draw_series(line(total, BLACK.stroke_width(2))).ok()?;
        let mut legend = vec![("frame".to_string(), BLACK, None)];
        for (i, name) in names.iter().enumerate() {
            let color = plot::series_color(i);
            let values = frames
                .iter()
                .map(|f| (f.frame as f64, pass_ms(f, name)))
                .collect();
            chart
                .draw_series(line(values, color.stroke_width(1)))
                .ok()?;
            legend.push((name.clone(), color, None));
        }
        plot::legend(area, &legend)
    })
}

/// The per-frame table as CSV: times per pass, what moved, what was skipped, the checks.
pub fn csv(report: &SequenceReport) -> Result<String, String> {
    let names = pass_names(&report.frames);
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header = vec!["frame".to_string(), "time_s".into(), "total_ms".into()];
    header.extend(names.iter().map(|n| format!("{n}_ms")));
    header.extend(
        [
            "moved_lights",
            "camera_moved",
            "skipped",
            "checked",
            "max_abs_8bit",
            "rmse_8bit",
            "temporal_max_8bit",
            "temporal_rmse_8bit",
            "equals_fresh",
        ]
        .map(String::from),
    );
    w.write_record(&header).map_err(|e| e.to_string())?;
    for f in &report.frames {
        let mut row = vec![
            f.frame.to_string(),
            f.time.to_string(),
            f.total_ms().to_string(),
        ];
        row.extend(names.iter().map(|n| pass_ms(f, n).to_string()));
        let c = f.check.as_ref();
        let t = c.and_then(|c| c.temporal.as_ref());
        let or_empty = |v: Option<String>| v.unwrap_or_default();
        row.extend([
            f.moved_lights.to_string(),
            f.camera_moved.to_string(),
            f.skipped.join(" "),
            c.is_some().to_string(),
            or_empty(c.map(|c| c.error.max_abs_8bit.to_string())),
            or_empty(c.map(|c| c.error.rmse_8bit.to_string())),
            or_empty(t.map(|t| t.max_abs_8bit.to_string())),
            or_empty(t.map(|t| t.rmse_8bit.to_string())),
            or_empty(c.map(|c| c.equals_fresh.to_string())),
        ]);
        w.write_record(&row).map_err(|e| e.to_string())?;
    }
    let bytes = w.into_inner().map_err(|e| e.to_string())?;
    String::from_utf8(bytes).map_err(|e| e.to_string())
}

/// Most frames the terminal table lists one by one; a longer sequence lists its checked
/// frames.
const TABLE_FRAMES: usize = 100;

/// The per-frame table for the terminal, then the summary.
pub fn table(report: &SequenceReport) -> String {
    let names = pass_names(&report.frames);
    let mut s = String::new();
    let _ = write!(s, "{:>5} {:>8} {:>9}", "frame", "time s", "total ms");
    for n in &names {
        let _ = write!(s, " {:>w$}", n, w = n.len().max(8));
    }
    let _ = writeln!(s, " {:>5}  check", "moved");
    let long = report.frames.len() > TABLE_FRAMES;
    for f in report.frames.iter().filter(|f| !long || f.check.is_some()) {
        let _ = write!(s, "{:>5} {:>8.3} {:>9.3}", f.frame, f.time, f.total_ms());
        for n in &names {
            let _ = write!(s, " {:>w$.3}", pass_ms(f, n), w = n.len().max(8));
        }
        let check = match &f.check {
            None => String::new(),
            Some(c) => format!(
                "max {} LSB, RMSE {:.2}{}{}",
                c.error.max_abs_8bit,
                c.error.rmse_8bit,
                c.temporal.as_ref().map_or(String::new(), |t| format!(
                    ", change {} LSB",
                    t.max_abs_8bit
                )),
                if c.equals_fresh {
                    ", equals a fresh frame"
                } else if c.carries_history {
                    ", carries earlier frames"
                } else {
                    ", DIFFERS from a fresh frame"
                }
            ),
        };
        let moved = if f.camera_moved {
            format!("{}+cam", f.moved_lights)
        } else {
            f.moved_lights.to_string()
        };
        let _ = writeln!(s, " {moved:>5}  {check}");
    }
    if long {
        let _ = writeln!(
            s,
            "({} frames; the checked ones are listed, every one is in the CSV)",
            report.frames.len()
        );
    }
    let m = &report.summary;
    let _ = writeln!(
        s,
        "first frame {:.3} ms; later frames median {:.3} ms [{:.3}, {:.3}], {} reused whole; checked {} frames: max {} LSB, RMSE {:.2} to {:.2}, change max {} LSB, {}{}",
        m.first_ms,
        m.frame_ms,
        m.frame_ms_spread[0],
        m.frame_ms_spread[1],
        m.frames_reused,
        m.checked_frames,
        m.max_abs_8bit,
        m.first_rmse_8bit,
        m.last_rmse_8bit,
        m.max_temporal_8bit,
        match (m.exact, m.max_abs_8bit <= crate::run::EXACT_LSB) {
            (true, _) => "exact",
            // Frames that reuse earlier ones (temporal reservoirs) need not equal a fresh
            // renderer's: within 1 LSB, that is not a loss of exactness.
            (false, true) => "within 1 LSB, a checked frame unlike the same frame rendered fresh",
            (false, false) => "NOT exact",
        },
        if m.patch_rebuilds > 0 {
            format!("; {} patch frames rebuilt for room", m.patch_rebuilds)
        } else {
            String::new()
        }
    );
    s
}

/// The files a sequence writes, with the stem `stem`, in `dir`: `STEM.png` and
/// `STEM.heat.png` (the last frame and its error), `STEM.gif` (the animation),
/// `STEM.frames.svg` (time per pass), `STEM.frames.csv` and `STEM.sequence.json`. Returns
/// their paths.
pub fn write(dir: &Path, stem: &str, run: &SequenceRun) -> Result<Vec<PathBuf>, RunError> {
    let io = RunError::Io;
    let mut paths = crate::run::write_images(dir, stem, &run.last, &run.last_reference)?;
    let report = &run.report;
    let plot_file = format!("{stem}.frames.svg");
    let mut files: Vec<(PathBuf, Vec<u8>)> = vec![(
        dir.join(format!("{stem}.gif")),
        gif(&run.animation, report.frame_step_s).map_err(io)?,
    )];
    if let Some(p) = frame_plot(report, &plot_file) {
        files.push((dir.join(plot_file), p.svg.into_bytes()));
    }
    files.push((
        dir.join(format!("{stem}.frames.csv")),
        csv(report).map_err(io)?.into_bytes(),
    ));
    let json = serde_json::to_string_pretty(report).map_err(|e| RunError::Io(e.to_string()))?;
    files.push((dir.join(format!("{stem}.sequence.json")), json.into_bytes()));
    for (path, bytes) in files {
        crate::files::write_file(&path, &bytes).map_err(RunError::Io)?;
        paths.push(path);
    }
    Ok(paths)
}
