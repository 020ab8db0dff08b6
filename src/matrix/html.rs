//! index.html: a self-contained page (images and plots by relative path, no scripts, no
//! network) that opens from disk.

use std::fmt::Write as _;

use super::columns::{self, Measured};
use super::record::{grouped, label};
use super::verdicts;
use super::{CellRecord, Fidelity, Results};
use crate::plot::Plot;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

const STYLE: &str = "
body { font-family: system-ui, sans-serif; margin: 24px; color: #222; max-width: 1500px; }
.wide { max-width: 100%; overflow-x: auto; }
th a { color: inherit; text-decoration: none; border-bottom: 1px dotted #888; }
h1 { margin-bottom: 4px; } h2 { margin-top: 36px; border-bottom: 1px solid #ccc; }
h3 { margin-top: 24px; }
table { border-collapse: collapse; font-size: 13px; margin: 8px 0; }
th, td { padding: 3px 8px; border-bottom: 1px solid #e4e4e4; text-align: right; }
td { white-space: nowrap; }
.meta td { white-space: normal; }
th { background: #f3f3f3; position: sticky; top: 0; }
td.name, th.name { text-align: left; }
tr.pareto td { background: #eef8ee; font-weight: 600; }
tr.failed td { background: #fdecec; color: #900; }
.meta td { text-align: left; }
.plots { display: flex; flex-wrap: wrap; gap: 16px; }
figure { margin: 0; }
figure img.plot { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: 13px; color: #555; max-width: 880px; }
.scale { font-size: 10px; color: #444; margin: 2px 0 4px; }
.scale .bar { height: 8px; border: 1px solid #aaa; }
.scale .ticks { position: relative; height: 12px; }
.scale .ticks span { position: absolute; transform: translateX(-50%); }
.cards { display: flex; flex-wrap: wrap; gap: 14px; }
.card { border: 1px solid #ddd; padding: 6px; font-size: 12px; width: 330px; }
.card img { width: 320px; display: block; margin-bottom: 4px; image-rendering: pixelated; }
.card .row { display: flex; gap: 4px; }
.card .row img { width: 158px; }
.seq { width: 640px; }
.seq img.anim { width: 320px; }
.seq img.plot { width: 630px; border: 1px solid #ddd; }
.failure { color: #900; white-space: pre-wrap; font-family: monospace; font-size: 12px; }
";

/// The report page.
pub fn page(results: &Results, plots: &[Plot]) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>clusterlab matrix</title><style>{STYLE}</style></head><body>"
    );
    let _ = write!(
        h,
        "<h1>clusterlab variant matrix</h1><p>{}. Times are medians over \
         the timed frames, each with its 95% confidence interval. A group's cells are timed \
         in interleaved rounds and compared <b>round by round</b> (a cell's frame over the \
         leader's in each round both took, so that drift of the machine cancels): \
         <b>slower</b> where the 95% interval of that ratio lies above 1, a <b>tie</b> where \
         it lies within {:.0}% of 1, <b>undecided</b> otherwise (and the verdict says which \
         flags would decide it); a cell stops once its verdict is decided. Speed-up is naive \
         forward's frame over the cell's, round by round. <b>max8</b> is against the cell's \
         own f64 reference (correctness: does the GPU compute what the variant claims); \
         <b>truth</b> figures are against the group's truth, the f64 reference of the most \
         complete lighting any cell of the group computes (fidelity). Highlighted rows are on \
         the time-fidelity Pareto front of their group, decided. The glossary below says what \
         each column holds.</p>",
        results.tally(),
        crate::measure::TIE_WITHIN * 100.0
    );
    at_a_glance(&mut h, results);
    if !plots.is_empty() {
        let _ = write!(h, "<h2>Plots</h2><div class=\"plots\">");
        for p in plots {
            let _ = write!(
                h,
                "<figure><a href=\"plots/{0}\"><img class=\"plot\" src=\"plots/{0}\" alt=\"{1}\" width=\"{2}\" height=\"{3}\"></a><figcaption>{1}</figcaption></figure>",
                esc(&p.file),
                esc(&p.title),
                p.size.0,
                p.size.1
            );
        }
        let _ = write!(h, "</div>");
    }
    summary(&mut h, results);
    glossary(&mut h);
    sequences(&mut h, results);
    images(&mut h, results);
    provenance(&mut h, results);
    let _ = writeln!(h, "</body></html>");
    // Every table in a box of its own that scrolls when the table is wider than the window:
    // the page itself never is.
    h.replace("<table", "<div class=\"wide\"><table")
        .replace("</table>", "</table></div>")
}

/// Every column of the tables and the CSV, with what it holds.
fn glossary(h: &mut String) {
    let _ = write!(
        h,
        "<h2 id=\"glossary\">Glossary</h2><p>Each column's heading links here.</p>\
         <table class=\"meta\"><tr><th class=\"name\">column</th>\
         <th class=\"name\">CSV</th><th class=\"name\">what it holds</th></tr>"
    );
    for c in columns::COLUMNS {
        let _ = write!(
            h,
            "<tr id=\"{}\"><td>{}</td><td><code>{}</code></td><td>{}</td></tr>",
            glossary_id(c),
            esc(c.heading),
            if c.shown.csv { c.key } else { "-" },
            esc(c.meaning)
        );
    }
    let _ = write!(h, "</table>");
}

/// The glossary row of column `c`: what its heading links to.
fn glossary_id(c: &columns::Column) -> String {
    format!("column-{}", c.key)
}

fn provenance(h: &mut String, results: &Results) {
    let _ = write!(h, "<h2>Provenance</h2>");
    for p in &results.provenance {
        let _ = write!(h, "<table class=\"meta\">");
        let rows = [
            ("adapter", p.adapter.name.clone()),
            ("backend", p.adapter.backend.clone()),
            ("driver", p.adapter.driver.clone()),
            ("timing", p.timing_source.clone()),
            ("HDR format", p.hdr_format.clone()),
            ("date", p.date.clone()),
            (
                "git revision",
                format!(
                    "{}{}",
                    p.git_revision,
                    if p.git_dirty {
                        " (uncommitted changes)"
                    } else {
                        ""
                    }
                ),
            ),
            ("tool", p.tool.clone()),
            ("command", p.command.join(" ")),
            ("shard", p.shard.clone().unwrap_or_else(|| "all".into())),
            ("frames", p.frames.clone()),
            ("shaders", p.shaders.describe()),
            ("environment", p.environment.join(", ")),
            (
                "perturbed depths",
                match p.perturbed_depth_ulps {
                    0 => "no".into(),
                    n => format!(
                        "{n} units in the last place (a test mode: figures are not a stock run's)"
                    ),
                },
            ),
            (
                "run cost",
                p.cost.as_ref().map_or_else(|| "-".into(), |c| c.line()),
            ),
        ];
        for (k, v) in rows {
            let _ = write!(h, "<tr><th>{k}</th><td>{}</td></tr>", esc(&v));
        }
        let _ = write!(
            h,
            "</table><details><summary>variant files (SHA-256)</summary><table class=\"meta\">"
        );
        for (name, f) in &p.variant_files {
            let _ = write!(
                h,
                "<tr><td>{}</td><td>{}</td><td><code>{}</code></td></tr>",
                esc(name),
                esc(&f.path.display().to_string()),
                esc(&f.sha256)
            );
        }
        let _ = write!(h, "</table></details>");
    }
}

/// Per scene and parameters: the group's verdict (decided by the rounds themselves, or what
/// would decide it), the fastest exact variant, the most efficient exact one (nearest its
/// perfect-culling bound, `efficiency`), the most accurate lossy one, and what failed.
fn at_a_glance(h: &mut String, results: &Results) {
    let _ = write!(
        h,
        "<h2>At a glance</h2><table class=\"meta\"><tr><th class=\"name\">scene</th>\
         <th class=\"name\">verdict (round by round, 95%)</th>\
         <th class=\"name\">fastest exact (within 1 LSB of the group's truth, no light dropped)</th>\
         <th class=\"name\">most efficient exact (bound over frame)</th>\
         <th class=\"name\">most accurate lossy</th><th class=\"name\">failed</th></tr>"
    );
    for (group, cells) in grouped(results) {
        let shown = |c: &CellRecord| c.ok() && !c.spec.debug_view;
        let exact = |c: &CellRecord| c.exact_to_truth();
        let verdict = verdicts::group_verdict(&cells);
        let fastest = verdicts::fastest_among(&cells, |c| shown(c) && exact(c));
        let truth = match cells.iter().find_map(|c| c.fidelity.as_ref()) {
            Some(f) if f.truth == Fidelity::SHADOWED => " (truth: exact shadows)",
            _ => "",
        };
        let efficient = cells
            .iter()
            .filter(|c| shown(c) && exact(c))
            // A bound within noise or above its frame says nothing about which culls best.
            .filter_map(|c| {
                let e = c
                    .efficiency
                    .filter(|e| !e.within_noise && !e.bound_above_frame)?;
                Some((e, c))
            })
            .max_by(|a, b| a.0.efficiency.total_cmp(&b.0.efficiency))
            .map_or("-".into(), |(e, c)| {
                format!(
                    "{} ({:.0}%, {:.2} ns a useful evaluation)",
                    label(c),
                    e.efficiency * 100.0,
                    e.ns_per_useful_evaluation
                )
            });
        let lossy = cells
            .iter()
            .filter(|c| shown(c) && !exact(c))
            .filter_map(|c| Some((c.fidelity_rmse()?, c)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map_or("-".into(), |(rmse, c)| {
                format!("{} (RMSE {rmse:.3} LSB)", label(c))
            });
        let failed: Vec<String> = cells.iter().filter(|c| !c.ok()).map(|c| label(c)).collect();
        let failed = if failed.is_empty() {
            "none".to_string()
        } else {
            format!("{}: {}", failed.len(), failed.join(", "))
        };
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&format!("{group}{truth}")),
            esc(&verdict),
            esc(&fastest),
            esc(&efficient),
            esc(&lossy),
            esc(&failed)
        );
    }
    let _ = write!(h, "</table>");
}

fn summary(h: &mut String, results: &Results) {
    let _ = write!(h, "<h2>Results</h2>");
    let rows: Vec<Measured> = results.cells.iter().map(CellRecord::measured).collect();
    let cols = columns::table_columns(&rows, |s| s.html);
    for (group, cells) in grouped(results) {
        let _ = write!(
            h,
            "<h3>{}</h3><table><tr><th class=\"name\">variant</th>",
            esc(&group)
        );
        for c in &cols {
            let _ = write!(
                h,
                "<th><a href=\"#{}\" title=\"{}\">{}</a></th>",
                glossary_id(c),
                esc(c.meaning),
                esc(c.heading)
            );
        }
        let _ = write!(h, "</tr>");
        for c in cells {
            let name = esc(&label(c));
            let failure = |h: &mut String| {
                if let Some(why) = &c.failure {
                    let verdict = if c.refused {
                        "refused by the adapter: "
                    } else {
                        ""
                    };
                    let _ = write!(
                        h,
                        "<tr class=\"failed\"><td class=\"name\">{name}</td><td colspan=\"{}\" class=\"name\"><span class=\"failure\">{verdict}{}</span></td></tr>",
                        cols.len(),
                        esc(why)
                    );
                }
            };
            if c.failure.is_some() && c.total_ms().is_none() {
                failure(h);
                continue;
            }
            // A frame that rendered and means nothing: its figures, then why it failed.
            let class = if c.failure.is_some() {
                " class=\"failed\""
            } else if c.on_front() {
                " class=\"pareto\""
            } else {
                ""
            };
            let m = c.measured();
            let _ = write!(h, "<tr{class}><td class=\"name\">{name}</td>");
            for col in &cols {
                let _ = write!(h, "<td>{}</td>", esc(&(col.text)(&m)));
            }
            let _ = write!(h, "</tr>");
            failure(h);
        }
        let _ = write!(h, "</table>");
    }
}

fn images(h: &mut String, results: &Results) {
    let _ = write!(
        h,
        "<h2>Images</h2><p>Each card: the image, its error heat map against the reference \
         and, for clustered variants, the lights per cluster, each with its colour scale; \
         every image links to its full size.</p>"
    );
    for (group, cells) in grouped(results) {
        let with_images: Vec<&CellRecord> = cells
            .into_iter()
            .filter(|c| c.images.image.is_some())
            .collect();
        if with_images.is_empty() {
            continue;
        }
        let _ = write!(h, "<h3>{}</h3><div class=\"cards\">", esc(&group));
        for c in with_images {
            let img = |p: &Option<String>, alt: &str, scale: Option<&str>| {
                p.as_ref().map_or(String::new(), |p| {
                    let linked = format!(
                        "<a href=\"{0}\"><img src=\"{0}\" alt=\"{alt}\" title=\"{alt}\"></a>",
                        esc(p)
                    );
                    match scale {
                        Some(scale) => format!("<div>{linked}{scale}</div>"),
                        None => linked,
                    }
                })
            };
            let e = c.error.as_ref();
            let _ = write!(
                h,
                "<div class=\"card\">{}<div class=\"row\">{}{}</div><b>{}</b><br>{:.2} ms{}, max {} LSB, PSNR {}</div>",
                img(&c.images.image, "image", None),
                img(&c.images.heat, "error heat map", Some(&heat_scale())),
                img(&c.images.debug, "lights per cluster", Some(&lights_scale())),
                esc(&label(c)),
                c.total_ms().unwrap_or(f64::NAN),
                c.speedup_vs_naive
                    .map_or(String::new(), |x| format!(" ({x:.1}× naive)")),
                e.map_or("–".into(), |e| e.max_abs_8bit.to_string()),
                e.map_or("–".into(), |e| e
                    .psnr_db
                    .map_or("∞".into(), |p| format!("{p:.1} dB"))),
            );
        }
        let _ = write!(h, "</div>");
    }
}

/// A colour scale under an image: a bar through `stops` (colour, position 0..1) and the
/// values at `ticks` (label, position), with what the values are.
fn scale(kind: &str, unit: &str, stops: &[([u8; 3], f64)], ticks: &[(String, f64)]) -> String {
    let gradient: Vec<String> = stops
        .iter()
        .map(|([r, g, b], t)| format!("rgb({r},{g},{b}) {:.1}%", t * 100.0))
        .collect();
    let labels: String = ticks
        .iter()
        .map(|(label, t)| format!("<span style=\"left:{:.1}%\">{label}</span>", t * 100.0))
        .collect();
    format!(
        "<div class=\"scale\" data-scale=\"{kind}\"><div class=\"bar\" style=\"background:linear-gradient(to right,{})\"></div><div class=\"ticks\">{labels}</div>{unit}</div>",
        gradient.join(",")
    )
}

/// The error heat map's scale (`metrics::heat_map`): the magma map of log2(1 + d) / 8 for
/// an error of d 8-bit LSB, 0 black to 255 white.
fn heat_scale() -> String {
    let lut = nv_flip::magma_lut().to_vec();
    let colour = |t: f64| {
        let i = ((t * 255.0).round() as usize).min(255) * 3;
        [lut[i], lut[i + 1], lut[i + 2]]
    };
    let stops: Vec<([u8; 3], f64)> = (0..=8)
        .map(|k| (colour(k as f64 / 8.0), k as f64 / 8.0))
        .collect();
    let ticks: Vec<(String, f64)> = [0u32, 1, 7, 31, 255]
        .iter()
        .map(|&d| (d.to_string(), crate::metrics::heat_value(d) as f64))
        .collect();
    scale("error", "error, 8-bit LSB", &stops, &ticks)
}

/// The lights-per-cluster view's scale (`heat` in `shaders/passes/debug_view.wesl`): black
/// for none, then blue, green, yellow, red and white at 1, 4, 16, 64 and 256 lights and
/// more, on log2(n) / 8.
fn lights_scale() -> String {
    let stops = [
        ([0, 0, 255], 0.0),
        ([0, 255, 0], 0.25),
        ([255, 255, 0], 0.5),
        ([255, 0, 0], 0.75),
        ([255, 255, 255], 1.0),
    ];
    let ticks: Vec<(String, f64)> = [1u32, 4, 16, 64, 256]
        .iter()
        .map(|&n| (n.to_string(), (n as f64).log2() / 8.0))
        .collect();
    scale(
        "lights",
        "lights in the cluster's list (black: none)",
        &stops,
        &ticks,
    )
}

/// The sequence cells: per group, how each variant's frames went (the first, the later
/// ones against the same variant rebuilding its lists, what was reused, the checks), then
/// each one's animation and time per pass over its frames.
fn sequences(h: &mut String, results: &Results) {
    let groups: Vec<(String, Vec<&CellRecord>)> = grouped(results)
        .into_iter()
        .filter(|(_, cells)| cells.iter().any(|c| c.sequence_summary.is_some()))
        .collect();
    if groups.is_empty() {
        return;
    }
    let _ = write!(
        h,
        "<h2>Sequences</h2><p>Each cell is a sequence of frames a frame step apart, drawn by one \
         renderer that reuses what did not change. Frame times are medians of the frames \
         after the first; <i>vs rebuild</i> is that over the same variant's when it rebuilds \
         its lists; <i>reused</i> counts frames that ran no pass. Checked frames are compared \
         with their reference (max LSB), their change from the frame before with the \
         reference's (change LSB), and with the same frame rendered from scratch \
         (<i>exact</i>: within 1 LSB and equal bit for bit).</p>"
    );
    let ms = |c: &CellRecord| c.total_ms().unwrap_or(f64::NAN);
    for (group, cells) in groups {
        let _ = write!(
            h,
            "<h3>{}</h3><table><tr><th class=\"name\">variant</th><th>first frame ms</th>\
             <th>frame ms</th><th>[min, max]</th><th>vs rebuild</th><th>reused</th>\
             <th>checked</th><th>max LSB</th><th>change LSB</th><th>exact</th>\
             <th>patch rebuilds</th></tr>",
            esc(&group)
        );
        for c in &cells {
            let Some(s) = &c.sequence_summary else {
                continue;
            };
            let rebuild = c
                .spec
                .rebuild_cell
                .as_ref()
                .and_then(|id| results.cells.iter().find(|o| &o.spec.id == id))
                .map_or("-".into(), |o| format!("{:.2}", ms(c) / ms(o)));
            let class = if c.failure.is_some() {
                " class=\"failed\""
            } else {
                ""
            };
            let _ = write!(
                h,
                "<tr{class}><td class=\"name\">{}</td><td>{:.2}</td><td>{:.2}</td>\
                 <td>[{:.2}, {:.2}]</td><td>{rebuild}</td><td>{}</td><td>{}</td><td>{}</td>\
                 <td>{}</td><td>{}</td><td>{}</td></tr>",
                esc(&label(c)),
                s.first_ms,
                s.frame_ms,
                s.frame_ms_spread[0],
                s.frame_ms_spread[1],
                s.frames_reused,
                s.checked_frames,
                s.max_abs_8bit,
                s.max_temporal_8bit,
                if s.exact { "yes" } else { "no" },
                s.patch_rebuilds
            );
        }
        let _ = write!(h, "</table><div class=\"cards\">");
        for c in &cells {
            let i = &c.images;
            let img = |p: &Option<String>, class: &str, alt: &str| {
                p.as_ref().map_or(String::new(), |p| {
                    format!("<img class=\"{class}\" src=\"{}\" alt=\"{alt}\">", esc(p))
                })
            };
            let _ = write!(
                h,
                "<div class=\"card seq\">{}{}<br><b>{}</b></div>",
                img(&i.animation, "anim", "animation"),
                img(&i.frames_plot, "plot", "time per pass over the frames"),
                esc(&label(c))
            );
        }
        let _ = write!(h, "</div>");
    }
}
