//! The report page in a real browser (headless Chromium): at 1024 px nothing is wider than
//! the window (a wide table scrolls in its own box), no number wraps, every heat map has its
//! colour scale and every image links to its full size; and no two tick labels overlap in
//! the matrix's and the studies' plots.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::{cli, scratch};

/// The headless browser, if there is one: Chromium by its Debian or its upstream name. CI
/// installs it and sets `CLUSTERLAB_REQUIRE_BROWSER` (`.ci/run`), so there a missing one
/// fails.
fn browser() -> Option<&'static str> {
    let found = ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|b| {
            Command::new(b)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        });
    if found.is_none() {
        assert!(
            std::env::var_os("CLUSTERLAB_REQUIRE_BROWSER").is_none(),
            "no chromium: CI installs it (.ci/run)"
        );
        eprintln!("skipped: no chromium here (CI installs it)");
    }
    found
}

/// What the page measures of itself in the browser at a 1024 px window.
const MEASURE: &str = r##"<script>
const px = (e) => e.getBoundingClientRect();
const heat = [...document.querySelectorAll('img[alt="error heat map"]')];
const lights = [...document.querySelectorAll('img[alt="lights per cluster"]')];
const scaled = (imgs, kind) => imgs.filter(i => i.closest('div').querySelector('.scale[data-scale="' + kind + '"]')).length;
const cells = [...document.querySelectorAll('table:not(.meta) td:not(.name)')];
const wrapped = cells.filter(td => td.getClientRects().length && td.offsetHeight > 2.2 * parseFloat(getComputedStyle(td).fontSize)).map(td => td.textContent);
const images = [...document.querySelectorAll('img')];
const result = {
  window: window.innerWidth,
  page: document.documentElement.scrollWidth,
  client: document.documentElement.clientWidth,
  widest_table_box: Math.max(0, ...[...document.querySelectorAll('table')].map(t => px(t.closest('.wide') || t).right)),
  heat: heat.length, heat_scaled: scaled(heat, 'error'),
  lights: lights.length, lights_scaled: scaled(lights, 'lights'),
  images: images.length, linked: images.filter(i => i.closest('a') && i.closest('a').getAttribute('href') === i.getAttribute('src')).length,
  headings: document.querySelectorAll('.wide th a[href^="#column-"]').length,
  glossary_rows: [...document.querySelectorAll('.wide th a')].filter(a => document.getElementById(a.getAttribute('href').slice(1))).length,
  wrapped: wrapped,
};
document.body.insertAdjacentHTML('beforeend', '<pre id="meas' + 'ured">' + JSON.stringify(result) + '</pre>');
</script>"##;

/// The page `html` laid out by `browser` at 1024 px, as it measured itself.
fn measured(browser: &str, dir: &Path, html: &str) -> serde_json::Value {
    let page = dir.join("measured.html");
    std::fs::write(&page, html.replace("</body>", &format!("{MEASURE}</body>"))).unwrap();
    let out = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--window-size=1024,768",
            "--dump-dom",
        ])
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("the browser runs");
    let dom = String::from_utf8_lossy(&out.stdout);
    let json = dom
        .split("<pre id=\"measured\">")
        .nth(1)
        .and_then(|s| s.split("</pre>").next())
        .unwrap_or_else(|| panic!("the page measured nothing: {dom:.2000}"));
    serde_json::from_str(&json.replace("&quot;", "\"").replace("&amp;", "&")).unwrap()
}

/// A small matrix with images of every kind: heat maps, and the lights per cluster of the
/// clustered variants (a group without a sweep).
fn small_matrix(dir: &Path) -> PathBuf {
    let out = dir.join("matrix");
    let variants = [
        "naive_forward",
        "forward_plus",
        "forward_plus_bvh",
        "clustered_deferred_compact",
        "clustered_deferred_16x16x24",
    ];
    let ran = cli(["matrix", "--variants"])
        .args(variants)
        .args(["--scenes", "atrium", "--size", "96x54", "--out"])
        .arg(&out)
        .run();
    assert_eq!(ran.code, Some(0), "{}", ran.printed());
    out
}

#[test]
fn the_page_fits_1024_px_and_every_heat_map_has_its_scale() {
    let Some(browser) = browser() else { return };
    let dir = scratch("page");
    let out = small_matrix(&dir);
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let m = measured(browser, &out, &html);
    assert_eq!(m["window"], 1024, "{m}");
    assert!(
        m["page"].as_f64().unwrap() <= 1024.0,
        "the page is wider than the window: {m}"
    );
    assert!(
        m["widest_table_box"].as_f64().unwrap() <= m["client"].as_f64().unwrap(),
        "a table is wider than the page: {m}"
    );
    assert_eq!(m["wrapped"], serde_json::json!([]), "numbers wrap: {m}");
    assert!(
        m["heat"].as_u64().unwrap() >= 4 && m["heat"] == m["heat_scaled"],
        "{m}"
    );
    assert!(
        m["lights"].as_u64().unwrap() >= 1 && m["lights"] == m["lights_scaled"],
        "{m}"
    );
    assert_eq!(m["images"], m["linked"], "{m}");
    assert!(
        m["headings"].as_u64().unwrap() > 10 && m["headings"] == m["glossary_rows"],
        "{m}"
    );
    // The break: without the table's own scrolling box and unwrapped cells the page is wider
    // than the window, and numbers wrap.
    let broken = html
        .replace(".wide { max-width: 100%; overflow-x: auto; }", "")
        .replace("td { white-space: nowrap; }", "");
    assert_ne!(
        broken, html,
        "the page's style changed: break it another way"
    );
    let m = measured(browser, &out, &broken);
    assert!(m["page"].as_f64().unwrap() > 1024.0, "{m}");
    let _ = std::fs::remove_dir_all(dir);
}

/// A text element of an SVG plotters wrote: where it is, how it is anchored, its size.
struct Label {
    text: String,
    x: f64,
    y: f64,
    dy_em: f64,
    anchor: String,
    size: f64,
}

fn attr(tag: &str, name: &str) -> Option<String> {
    let start = tag.find(&format!(" {name}=\""))? + name.len() + 3;
    Some(tag[start..].split('"').next()?.to_string())
}

/// The tick labels of `svg`: unrotated numbers centred under or right-aligned beside an
/// axis (a point's number is left-aligned, a title is not a number).
fn tick_labels(svg: &str) -> Vec<Label> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let (tag, rest) = t.split_once('>')?;
            let text = rest.split("</text>").next()?.trim().to_string();
            let anchor = attr(tag, "text-anchor").unwrap_or_default();
            let numeric = text.parse::<f64>().is_ok();
            if !numeric || tag.contains("transform") || !(anchor == "middle" || anchor == "end") {
                return None;
            }
            let dy = attr(tag, "dy").unwrap_or_default();
            let dy_em = match dy.as_str() {
                d if d.ends_with("em") => d.trim_end_matches("em").parse().ok()?,
                d if d.ends_with("ex") => d.trim_end_matches("ex").parse::<f64>().ok()? / 2.0,
                _ => 0.0,
            };
            Some(Label {
                text,
                x: attr(tag, "x")?.parse().ok()?,
                y: attr(tag, "y")?.parse().ok()?,
                dy_em,
                anchor,
                size: attr(tag, "font-size")?.parse().ok()?,
            })
        })
        .collect()
}

/// Pairs of tick labels whose boxes overlap: a label is 0.6 of its size wide a character
/// (a sans-serif digit is 0.55), one size tall from the baseline `y + dy` up.
fn overlapping(svg: &str) -> Vec<(String, String)> {
    let boxes: Vec<(String, [f64; 4])> = tick_labels(svg)
        .into_iter()
        .map(|l| {
            let w = 0.6 * l.size * l.text.len() as f64;
            let x0 = match l.anchor.as_str() {
                "middle" => l.x - w / 2.0,
                _ => l.x - w,
            };
            let base = l.y + l.dy_em * l.size;
            (
                l.text,
                [x0, base - 0.8 * l.size, x0 + w, base + 0.2 * l.size],
            )
        })
        .collect();
    let mut out = Vec::new();
    for (i, (a, p)) in boxes.iter().enumerate() {
        for (b, q) in &boxes[i + 1..] {
            if p[0] < q[2] && q[0] < p[2] && p[1] < q[3] && q[1] < p[3] {
                out.push((a.clone(), b.clone()));
            }
        }
    }
    out
}

#[test]
fn no_tick_labels_overlap_in_the_matrix_and_study_plots() {
    let dir = scratch("plots");
    let mut svgs: Vec<PathBuf> = Vec::new();
    let plots = small_matrix(&dir).join("plots");
    svgs.extend(std::fs::read_dir(plots).unwrap().map(|e| e.unwrap().path()));
    let study = dir.join("study");
    for args in [
        &["depth"][..],
        &["codecs", "--samples", "4000"],
        &[
            "slicing", "--scenes", "atrium", "--size", "64x36", "--lights", "64", "--frames", "1",
        ],
        &[
            "temporal", "--size", "64x36", "--lights", "64", "--frames", "1",
        ],
        &[
            "sampling", "--size", "64x36", "--lights", "64", "--frames", "1",
        ],
        &[
            "scale", "--size", "64x36", "--lights", "64,256", "--frames", "1",
        ],
    ] {
        let ran = cli(["study"]).args(args).arg("--out").arg(&study).run();
        assert!(ran.code.is_some(), "{}", ran.printed());
        let svg = study.join(format!("{}.svg", args[0]));
        assert!(
            svg.is_file(),
            "study {} drew no plot: {}",
            args[0],
            ran.printed()
        );
        svgs.push(svg);
    }
    svgs.extend(
        std::fs::read_dir("docs/studies")
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "svg")),
    );
    for svg in &svgs {
        let text = std::fs::read_to_string(svg).unwrap();
        assert!(
            tick_labels(&text).len() >= 4,
            "{}: no tick labels found",
            svg.display()
        );
        let over = overlapping(&text);
        assert!(
            over.is_empty(),
            "{}: tick labels overlap: {over:?}",
            svg.display()
        );
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// The break: plotters' own log axis on a narrow plot, labels at every light key point and
/// printed as "10000.0", overprints; the shared one (`plot::log_axis`) does not.
#[test]
fn the_overlap_check_finds_plotters_own_dense_log_labels() {
    use plotters::prelude::*;
    let draw = |shared: bool| {
        let mut svg = String::new();
        {
            let area = SVGBackend::with_string(&mut svg, (320, 200)).into_drawing_area();
            let mut chart = ChartBuilder::on(&area)
                .x_label_area_size(30)
                .y_label_area_size(50)
                .build_cartesian_2d(
                    clusterlab::plot::log_axis(0.8, 12500.0),
                    clusterlab::plot::log_axis(1.0, 100.0),
                )
                .unwrap();
            if shared {
                chart
                    .configure_mesh()
                    .x_label_formatter(&clusterlab::plot::tick_label)
                    .draw()
                    .unwrap();
            } else {
                let mut plain = ChartBuilder::on(&area)
                    .x_label_area_size(30)
                    .y_label_area_size(50)
                    .build_cartesian_2d((0.8f64..12500.0).log_scale(), (1.0f64..100.0).log_scale())
                    .unwrap();
                plain.configure_mesh().x_labels(40).draw().unwrap();
            }
        }
        svg
    };
    assert!(!overlapping(&draw(false)).is_empty(), "{}", draw(false));
    assert_eq!(overlapping(&draw(true)), Vec::<(String, String)>::new());
}

/// Every text of an SVG plotters wrote: its content (whitespace as written), x, y, size.
fn texts(svg: &str) -> Vec<(String, f64, f64, f64)> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let (tag, rest) = t.split_once('>')?;
            let text = rest.split("</text>").next()?.to_string();
            Some((
                text,
                attr(tag, "x")?.parse().ok()?,
                attr(tag, "y")?.parse().ok()?,
                attr(tag, "font-size")?.parse().ok()?,
            ))
        })
        .collect()
}

/// Why a time-fidelity plot shown at `scale` (page pixels per SVG pixel) does not read, if
/// it does not: text under 11 px on the page, a key that names fewer entries than the
/// `points` plotted, or a key line past the plot's edge (cut).
fn plot_reads(svg: &str, scale: f64, points: usize) -> Result<(), String> {
    let size = |name: &str| -> f64 {
        let head = svg.split('>').next().unwrap_or_default();
        attr(head, name).and_then(|v| v.parse().ok()).unwrap_or(0.0)
    };
    let (width, height) = (size("width"), size("height"));
    let all = texts(svg);
    let smallest = all.iter().map(|t| t.3).fold(f64::INFINITY, f64::min);
    if smallest * scale < 11.0 {
        return Err(format!(
            "text of {smallest} px at a scale of {scale:.2}: {:.1} px on the page",
            smallest * scale
        ));
    }
    // A key entry's first line: its number, two spaces, its name.
    let entries: Vec<_> = all
        .iter()
        .filter(|t| {
            let (n, rest) = t.0.trim_start().split_once("  ").unwrap_or_default();
            n.parse::<usize>().is_ok() && !rest.is_empty()
        })
        .collect();
    if entries.len() != points {
        return Err(format!("{} key entries for {points} points", entries.len()));
    }
    for (text, x, y, size) in &all {
        let right = x + 0.6 * size * text.chars().count() as f64;
        if right > width + 1.0 || *y > height {
            return Err(format!(
                "`{text}` runs past the plot ({right:.0} > {width}, {y} > {height})"
            ));
        }
    }
    Ok(())
}

/// What the page measures of its time-fidelity plots at 1024 px: each one's shown width
/// over its own (the `width` the page gives it, the SVG's: checked).
const PLOT_SCALE: &str = r##"<script>
const plots = [...document.querySelectorAll('img.plot')].filter(i => i.getAttribute('src').includes('time_error'));
const result = plots.map(i => [i.getAttribute('src'), i.getBoundingClientRect().width / Number(i.getAttribute('width'))]);
document.body.insertAdjacentHTML('beforeend', '<pre id="meas' + 'ured">' + JSON.stringify(result) + '</pre>');
</script>"##;

/// The time-fidelity plot reads on a page 1024 px wide: shown at a scale that keeps every
/// text at 11 px or more, its key naming every point, no key line cut. The breaks: the plot
/// squeezed into 600 px (text under 11 px), and its key's entries taken out.
#[test]
fn the_time_fidelity_plot_reads_at_1024_px() {
    let Some(browser) = browser() else { return };
    let dir = scratch("plot-reads");
    let out = small_matrix(&dir);
    let results = clusterlab::matrix::Results::load(&out).unwrap();
    let points = results
        .cells
        .iter()
        .filter(|c| c.ok() && c.total_ms().is_some())
        .count();
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let scales = |html: &str| -> Vec<(String, f64)> {
        let page = out.join("scaled.html");
        std::fs::write(
            &page,
            html.replace("</body>", &format!("{PLOT_SCALE}</body>")),
        )
        .unwrap();
        let run = Command::new(browser)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--window-size=1024,768",
                "--virtual-time-budget=5000",
                "--dump-dom",
            ])
            .arg(format!("file://{}", page.display()))
            .output()
            .expect("the browser runs");
        let dom = String::from_utf8_lossy(&run.stdout);
        let json = dom
            .split("<pre id=\"measured\">")
            .nth(1)
            .and_then(|s| s.split("</pre>").next())
            .unwrap_or_else(|| panic!("the page measured nothing: {dom:.2000}"));
        serde_json::from_str(&json.replace("&quot;", "\"")).unwrap()
    };
    let shown = scales(&html);
    assert_eq!(
        shown.len(),
        1,
        "one time-fidelity plot for the one group: {shown:?}"
    );
    let (src, scale) = &shown[0];
    let svg = std::fs::read_to_string(out.join(src)).unwrap();
    let own = attr(svg.split('>').next().unwrap(), "width").unwrap();
    assert!(
        html.contains(&format!("src=\"{src}\" alt=")) && html.contains(&format!("width=\"{own}\"")),
        "the page gives the plot its own width, {own}"
    );
    plot_reads(&svg, *scale, points).unwrap();
    // The breaks.
    let squeezed = html.replace(
        "figure img.plot { max-width: 100%;",
        "figure img.plot { width: 600px !important; max-width: 100%;",
    );
    assert_ne!(
        squeezed, html,
        "the page's style changed: break it another way"
    );
    let (_, small) = scales(&squeezed)[0].clone();
    assert!(
        plot_reads(&svg, small, points).is_err(),
        "600 px reads at {small}"
    );
    let keyless: String = svg
        .split("<text")
        .enumerate()
        .filter(|(k, t)| {
            *k == 0
                || !t.split_once('>').is_some_and(|(_, r)| {
                    r.trim_start()
                        .split_once("  ")
                        .is_some_and(|(n, _)| n.parse::<usize>().is_ok())
                })
        })
        .map(|(k, t)| {
            if k == 0 {
                t.to_string()
            } else {
                format!("<text{t}")
            }
        })
        .collect();
    assert!(
        plot_reads(&keyless, *scale, points).is_err(),
        "a plot without its key"
    );
    let _ = std::fs::remove_dir_all(dir);
}
