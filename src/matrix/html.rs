//! index.html: a self-contained page (images and plots by relative path, no scripts, no
//! network) that opens from disk.

use std::fmt::Write as _;

use super::plots::Plot;
use super::report::{count, grouped, label};
use super::{CellRecord, Results};

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

const STYLE: &str = "
body { font-family: system-ui, sans-serif; margin: 24px; color: #222; max-width: 1500px; }
h1 { margin-bottom: 4px; } h2 { margin-top: 36px; border-bottom: 1px solid #ccc; }
h3 { margin-top: 24px; }
table { border-collapse: collapse; font-size: 13px; margin: 8px 0; }
th, td { padding: 3px 8px; border-bottom: 1px solid #e4e4e4; text-align: right; }
th { background: #f3f3f3; position: sticky; top: 0; }
td.name, th.name { text-align: left; }
tr.pareto td { background: #eef8ee; font-weight: 600; }
tr.failed td { background: #fdecec; color: #900; }
.meta td { text-align: left; }
.plots { display: flex; flex-wrap: wrap; gap: 16px; }
figure { margin: 0; }
figure img.plot { width: 660px; border: 1px solid #ddd; }
figcaption { font-size: 13px; color: #555; max-width: 660px; }
.cards { display: flex; flex-wrap: wrap; gap: 14px; }
.card { border: 1px solid #ddd; padding: 6px; font-size: 12px; width: 330px; }
.card img { width: 320px; display: block; margin-bottom: 4px; image-rendering: pixelated; }
.card .row { display: flex; gap: 4px; }
.card .row img { width: 158px; }
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
        "<h1>clusterlab variant matrix</h1><p>{} cells, {} failed. Times are medians over \
         the timed frames; speed-up is naive forward's time over the cell's, on the same scene \
         and parameters; error is against the CPU f64 reference. Highlighted rows are on the \
         time-error (RMSE) Pareto front of their group.</p>",
        results.cells.len(),
        results.failed()
    );
    if !plots.is_empty() {
        let _ = write!(h, "<h2>Plots</h2><div class=\"plots\">");
        for p in plots {
            let _ = write!(
                h,
                "<figure><img class=\"plot\" src=\"plots/{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>",
                esc(&p.file),
                esc(&p.title),
                esc(&p.title)
            );
        }
        let _ = write!(h, "</div>");
    }
    summary(&mut h, results);
    images(&mut h, results);
    provenance(&mut h, results);
    let _ = writeln!(h, "</body></html>");
    h
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

fn summary(h: &mut String, results: &Results) {
    let _ = write!(h, "<h2>Results</h2>");
    for (group, cells) in grouped(results) {
        let _ = write!(
            h,
            "<h3>{}</h3><table><tr><th class=\"name\">variant</th><th>GPU ms</th><th>spread</th>\
             <th>× naive</th><th>max 8-bit</th><th>PSNR dB</th><th>mean FLIP</th>\
             <th>useful / evaluated</th><th>bytes/px</th><th>cluster KiB</th><th>dropped</th>\
             <th class=\"name\">skipped</th><th class=\"name\">vs baseline</th></tr>",
            esc(&group)
        );
        for c in cells {
            row(h, c);
        }
        let _ = write!(h, "</table>");
    }
}

fn row(h: &mut String, c: &CellRecord) {
    let name = esc(&label(c));
    if let Some(why) = &c.failure {
        let _ = write!(
            h,
            "<tr class=\"failed\"><td class=\"name\">{name}</td><td colspan=\"12\" class=\"name\"><span class=\"failure\">{}</span></td></tr>",
            esc(why)
        );
        return;
    }
    let class = if c.pareto { " class=\"pareto\"" } else { "" };
    let spread = c
        .gpu_ms_spread
        .get("total")
        .and_then(|v| v.as_array())
        .map_or(String::new(), |a| {
            let f = |i: usize| a.get(i).and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
            format!("{:.2}–{:.2}", f(0), f(1))
        });
    let e = c.error.as_ref();
    let s = c.stats.as_ref();
    let _ = write!(
        h,
        "<tr{class}><td class=\"name\">{name}</td><td>{:.2}</td><td>{spread}</td><td>{}</td>\
         <td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"name\">{}</td><td class=\"name\">{}</td></tr>",
        c.total_ms().unwrap_or(f64::NAN),
        c.speedup_vs_naive
            .map_or("–".into(), |x| format!("{x:.1}×")),
        e.map_or("–".into(), |e| e.max_abs_8bit.to_string()),
        e.map_or("–".into(), |e| e
            .psnr_db
            .map_or("∞".into(), |p| format!("{p:.1}"))),
        e.map_or("–".into(), |e| format!("{:.4}", e.flip_mean)),
        s.map_or("–".into(), |s| format!(
            "{} / {}",
            count(s.useful_light_evals),
            count(s.light_evals)
        )),
        s.map_or("–".into(), |s| s.frame_bytes_per_pixel.to_string()),
        s.map_or("–".into(), |s| format!(
            "{:.0}",
            s.cluster_bytes as f64 / 1024.0
        )),
        s.map_or("–".into(), |s| s.dropped_lights.to_string()),
        esc(&c.skipped_passes.join(", ")),
        c.vs_baseline.as_ref().map_or(String::new(), |b| format!(
            "time ×{:.2}, max8 {:+}, RMSE8 {:+.3}",
            b.time_ratio, b.max_abs_8bit_change, b.rmse_8bit_change
        )),
    );
}

fn images(h: &mut String, results: &Results) {
    let _ = write!(
        h,
        "<h2>Images</h2><p>Each card: the image, its error heat map against the reference \
         (magma, brighter is worse) and, for clustered variants, the lights per cluster.</p>"
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
            let img = |p: &Option<String>, alt: &str| {
                p.as_ref().map_or(String::new(), |p| {
                    format!("<img src=\"{}\" alt=\"{alt}\" title=\"{alt}\">", esc(p))
                })
            };
            let e = c.error.as_ref();
            let _ = write!(
                h,
                "<div class=\"card\">{}<div class=\"row\">{}{}</div><b>{}</b><br>{:.2} ms{}, max {} LSB, PSNR {}</div>",
                img(&c.images.image, "image"),
                img(&c.images.heat, "error heat map"),
                img(&c.images.debug, "lights per cluster"),
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
