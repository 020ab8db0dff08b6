//! `clusterlab study shadows`: every shadow method on the atrium at several light counts,
//! Forward+ and deferred: exact shadows beside their unshadowed twins (what shadows cost,
//! which pipeline is faster with them, where the intervals decide it), and the sampled estimators at several ray budgets (time
//! against error, both against the shadowed f64 reference); rays traced, blocked, ms per
//! ray and BVH nodes per ray from the instrumented frame.

use serde::Serialize;

use super::{Reads, StudyError, StudyOptions};
use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::measure::{Frames, Front, Interval, Verdict};
use crate::plot::Plot;
use crate::run::{CellOptions, EXACT_LSB, run_scene};
use crate::scene::Scene;
use crate::table::Table;
use crate::variant::{LoadedVariant, Shadows};

/// The scene: a hall of columns, beams and galleries.
pub const SCENE: &str = "atrium";

/// Light counts unless `--lights` says otherwise.
pub const COUNTS: [u32; 3] = [256, 1024, 4096];

/// The shipped variants, each with the unshadowed twin its cost is measured against.
pub const VARIANTS: [(&str, &str); 6] = [
    ("forward_plus", "forward_plus"),
    ("deferred_3_targets", "deferred_3_targets"),
    ("forward_plus_shadows", "forward_plus"),
    ("clustered_deferred_shadows", "deferred_3_targets"),
    ("forward_plus_shadows_importance_1", "forward_plus"),
    ("forward_plus_shadows_ratio_1", "forward_plus"),
];

/// Three significant digits.
fn sig(x: f64) -> String {
    crate::table::sig(x, 3)
}

/// The ray budgets each sampled variant also runs at, beside its own.
pub const RAYS: [u32; 2] = [4, 16];

/// One variant at one light count.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ShadowRow {
    pub lights: u32,
    pub variant: String,
    /// The unshadowed variant its cost is measured against.
    pub twin: String,
    /// "unshadowed", "exact shadows", or the estimator with its rays and bias.
    pub method: String,
    pub frame_ms: f64,
    /// The frame's 95% interval, where enough frames were timed.
    pub frame_ms_lo: Option<f64>,
    pub frame_ms_hi: Option<f64>,
    /// Frame time over the unshadowed twin's.
    pub over_unshadowed: Option<f64>,
    pub rays: u64,
    pub blocked: u64,
    /// Nodes whose box a ray's walk tested, per ray.
    pub nodes_per_ray: Option<f64>,
    /// The frame time the rays added over the twin's, per ray, in ns.
    pub ns_per_ray: Option<f64>,
    /// 8-bit RMSE against the shadowed reference.
    pub rmse_8bit: f64,
    pub max_abs_8bit: u32,
    /// Exact shadows: the error outside ambiguous pairs, and their share.
    pub max_outside_ambiguity_8bit: Option<u32>,
    pub ambiguous_share: Option<f64>,
    pub error: Option<String>,
}

super::outcome_in_error_field!(ShadowRow);

pub struct ShadowStudy {
    frames: u32,
}

pub struct Point {
    scene: std::sync::Arc<Scene>,
    variant: LoadedVariant,
    twin: String,
}

fn named(p: &Point) -> ShadowRow {
    ShadowRow {
        lights: p.scene.params.lights,
        variant: p.variant.name.clone(),
        twin: p.twin.clone(),
        method: p.variant.variant.shading.shadows.label(),
        ..Default::default()
    }
}

/// `v` with `rays` rays a pixel, named after them.
fn with_rays(v: &LoadedVariant, rays: u32) -> Option<LoadedVariant> {
    let mut sampling = *v.variant.shading.shadows.sampling()?;
    sampling.rays = rays;
    let mut out = v.clone();
    out.name = format!("{}@{rays}rays", v.name);
    out.variant.shading.shadows = Shadows::Sampled(sampling);
    Some(out)
}

impl super::Study for ShadowStudy {
    const NAME: &'static str = "shadows";
    const READS: &'static [Reads] = &[Reads::Size, Reads::Lights, Reads::Frames];
    const ABOUT: &'static str = "Shadows on the atrium at 256, 1024 and 4096 lights: exact \
        shadows in Forward+ and deferred beside their unshadowed frames, and the sampled \
        estimators at 1, 4 and 16 rays a pixel; time against error (against the shadowed \
        f64 reference), rays, ms per ray and BVH nodes per ray (--size, --lights, --frames)";
    type Point = Point;
    type Row = ShadowRow;

    fn plan(gpu: &Gpu, options: &StudyOptions) -> Result<(Self, Vec<Point>), StudyError> {
        let _ = gpu;
        let names: Vec<&str> = VARIANTS.iter().map(|(v, _)| *v).collect();
        let shipped = super::shipped(&names)?;
        let mut points = Vec::new();
        for params in options.params_for(SCENE, &COUNTS)? {
            let scene = std::sync::Arc::new(super::generate(SCENE, params)?);
            for (v, (_, twin)) in shipped.iter().zip(VARIANTS) {
                let budgets = RAYS.iter().filter_map(|&r| with_rays(v, r));
                for variant in std::iter::once(v.clone()).chain(budgets) {
                    points.push(Point {
                        scene: scene.clone(),
                        variant,
                        twin: twin.to_string(),
                    });
                }
            }
        }
        let frames = options.frames;
        Ok((ShadowStudy { frames }, points))
    }

    fn label(&self, p: &Point) -> String {
        format!("{} lights: {}", p.scene.params.lights, p.variant.name)
    }

    fn run(&self, gpu: &Gpu, composer: &Composer, p: &Point) -> Result<Vec<ShadowRow>, StudyError> {
        let options = CellOptions {
            frames: Frames::exact(1, self.frames),
            stats: true,
            ..Default::default()
        };
        let cell = run_scene(gpu, composer, &p.variant, &p.scene, options)?;
        let r = &cell.report;
        let mut row = named(p);
        row.frame_ms = r
            .gpu_ms
            .get("total")
            .and_then(|v| v.as_f64())
            .unwrap_or(0.0);
        let interval: Option<[f64; 2]> = r
            .gpu_ms_interval
            .get("total")
            .and_then(|v| serde_json::from_value(v.clone()).ok());
        (row.frame_ms_lo, row.frame_ms_hi) = (interval.map(|i| i[0]), interval.map(|i| i[1]));
        if let Some(rays) = r.stats.as_ref().and_then(|s| s.shadow_rays) {
            row.rays = rays.traced;
            row.blocked = rays.blocked;
            row.nodes_per_ray = rays.nodes_per_ray();
        }
        if let Some(e) = &r.error {
            row.rmse_8bit = e.rmse_8bit;
            row.max_abs_8bit = e.max_abs_8bit;
            row.max_outside_ambiguity_8bit =
                e.shadows.as_ref().map(|s| s.max_outside_ambiguity_8bit);
            row.ambiguous_share = e.shadows.as_ref().map(|s| s.ambiguous_share);
        }
        row.error = r.failure.clone();
        Ok(vec![row])
    }

    fn named(&self, p: &Point) -> ShadowRow {
        named(p)
    }

    /// Each row's frame over its unshadowed twin's, and the time its rays added per ray.
    fn relate(&self, rows: &mut [ShadowRow]) {
        for i in 0..rows.len() {
            let r = &rows[i];
            let twin = rows
                .iter()
                .find(|o| o.lights == r.lights && o.variant == r.twin && o.error.is_none())
                .map(|o| o.frame_ms)
                .filter(|&ms| ms > 0.0);
            if let Some(twin) = twin
                && rows[i].error.is_none()
            {
                let r = &mut rows[i];
                r.over_unshadowed = Some(r.frame_ms / twin);
                r.ns_per_ray = (r.rays > 0).then(|| (r.frame_ms - twin) * 1e6 / r.rays as f64);
            }
        }
    }

    /// Unshadowed and exact frames within 1 LSB (exact shadows outside ambiguous pairs).
    fn keeps(&self, row: &ShadowRow, _: &[ShadowRow]) -> bool {
        let exact = !row.method.contains("ray");
        !exact || row.max_outside_ambiguity_8bit.unwrap_or(row.max_abs_8bit) <= EXACT_LSB
    }

    fn table(&self, rows: &[ShadowRow]) -> Table {
        table(rows)
    }

    fn plot(&self, rows: &[ShadowRow]) -> Option<Plot> {
        plot(rows)
    }
}

fn table(rows: &[ShadowRow]) -> Table {
    let mut t = Table::new(
        "Shadows: time against error of every shadow method (atrium)",
        &[
            "lights",
            "variant",
            "method",
            "frame ms",
            "95% CI ms",
            "x unshadowed",
            "rays",
            "blocked",
            "ns/ray",
            "nodes/ray",
            "RMSE8",
            "max8",
            "max8 decided",
            "ambiguous",
        ],
    );
    for r in rows {
        let names = vec![r.lights.to_string(), r.variant.clone(), r.method.clone()];
        if let Some(e) = &r.error {
            t.failed_row(names, e);
            continue;
        }
        let or_dash = |v: Option<String>| v.unwrap_or_else(|| "-".into());
        let mut cells = names;
        cells.extend([
            sig(r.frame_ms),
            or_dash(
                r.frame_ms_lo
                    .zip(r.frame_ms_hi)
                    .map(|(lo, hi)| format!("{}-{}", sig(lo), sig(hi))),
            ),
            or_dash(r.over_unshadowed.map(|x| format!("{x:.2}"))),
            r.rays.to_string(),
            r.blocked.to_string(),
            or_dash(r.ns_per_ray.map(sig)),
            or_dash(r.nodes_per_ray.map(|n| format!("{n:.1}"))),
            format!("{:.3}", r.rmse_8bit),
            r.max_abs_8bit.to_string(),
            or_dash(r.max_outside_ambiguity_8bit.map(|m| m.to_string())),
            or_dash(r.ambiguous_share.map(|s| format!("{:.3}%", 100.0 * s))),
        ]);
        t.row(cells);
    }
    t.notes.extend(findings(rows));
    t
}

/// A row's frame interval, where enough frames were timed for one.
fn interval(r: &ShadowRow) -> Option<Interval> {
    Some(Interval {
        lo: r.frame_ms_lo?,
        hi: r.frame_ms_hi?,
        level: crate::measure::LEVEL,
    })
}

/// How `a`'s frame compares with `b`'s, by their intervals (`Interval::compare`: apart,
/// a tie within the margin, or undecided).
fn verdict(a: &ShadowRow, b: &ShadowRow) -> Verdict {
    Interval::compare(interval(a).as_ref(), interval(b).as_ref())
}

/// The study's answers, per light count: which pipeline is faster with exact shadows, and
/// how the first sampled method at 1 ray compares with exact in time and in error. A word
/// of speed (faster, slower, fastest) is written only where the intervals decide it.
fn findings(rows: &[ShadowRow]) -> Vec<String> {
    let ok = |variant: &str, lights: u32| {
        rows.iter()
            .find(|r| r.variant == variant && r.lights == lights && r.error.is_none())
    };
    let mut counts: Vec<u32> = rows.iter().map(|r| r.lights).collect();
    counts.dedup();
    let mut notes = Vec::new();
    let within = (crate::measure::TIE_WITHIN * 100.0).round();
    for n in counts {
        if let (Some(f), Some(d)) = (
            ok("forward_plus_shadows", n),
            ok("clustered_deferred_shadows", n),
        ) {
            let said = match verdict(d, f) {
                Verdict::Faster => format!("deferred is faster, Forward+ takes {:.2} of its frame", f.frame_ms / d.frame_ms),
                Verdict::Slower => format!("Forward+ is faster, deferred takes {:.2} of its frame", d.frame_ms / f.frame_ms),
                Verdict::Tie => format!("a tie (within {within}%)"),
                Verdict::Undecided => "undecided (their intervals overlap past the tie margin, or one has none: more --frames would decide)".into(),
            };
            notes.push(format!(
                "{n} lights, exact shadows: {said} ({} ms Forward+, {} ms deferred; x unshadowed {} and {})",
                sig(f.frame_ms),
                sig(d.frame_ms),
                f.over_unshadowed.map_or("-".into(), |x| format!("{x:.2}")),
                d.over_unshadowed.map_or("-".into(), |x| format!("{x:.2}")),
            ));
        }
        if let (Some(exact), Some(s)) = (
            ok("forward_plus_shadows", n),
            ok("forward_plus_shadows_importance_1", n),
        ) {
            let as_good = s.rmse_8bit <= exact.rmse_8bit;
            notes.push(format!(
                "{n} lights, importance-sampled at 1 ray against exact (Forward+): {} ms against {} ms ({}), RMSE {:.3} against {:.3} LSB ({})",
                sig(s.frame_ms),
                sig(exact.frame_ms),
                verdict(s, exact).label(),
                s.rmse_8bit,
                exact.rmse_8bit,
                if as_good { "as good" } else { "worse: one ray a pixel is noisy where its lights disagree" },
            ));
        }
        let candidates: Vec<&ShadowRow> = rows
            .iter()
            .filter(|r| r.lights == n && r.error.is_none() && r.method.contains("ray"))
            .filter(|r| r.rmse_8bit <= SAMPLED_RMSE)
            .collect();
        let lowest = candidates
            .iter()
            .min_by(|a, b| a.frame_ms.total_cmp(&b.frame_ms));
        if let (Some(s), Some(exact)) = (lowest, ok("forward_plus_shadows", n)) {
            let open: Vec<&str> = candidates
                .iter()
                .filter(|o| o.variant != s.variant && verdict(o, s) != Verdict::Slower)
                .map(|o| o.variant.as_str())
                .collect();
            let head = if open.is_empty() {
                format!("the fastest sampled run within {SAMPLED_RMSE} LSB RMSE")
            } else {
                format!(
                    "the lowest median of the sampled runs within {SAMPLED_RMSE} LSB RMSE (not decided against {})",
                    open.join(", ")
                )
            };
            notes.push(format!(
                "{n} lights, {head}: {} ({}), {} ms, {:.2} of exact Forward+'s frame ({} against it)",
                s.variant,
                s.method,
                sig(s.frame_ms),
                s.frame_ms / exact.frame_ms,
                verdict(s, exact).label()
            ));
        }
    }
    notes
}

/// The RMSE, in 8-bit LSB, a sampled run must come within to stand beside exact shadows in
/// the notes: one step of the display.
const SAMPLED_RMSE: f64 = 1.0;

/// Time against error per light count, one plot under another: every shadow method and
/// ray budget a numbered point (the unshadowed twins are the cost's baseline, not a
/// method), its frame's interval a bar, the front of the points decided by their
/// intervals (`verdict`).
fn plot(rows: &[ShadowRow]) -> Option<Plot> {
    use crate::plot::{TimeErrorPoint, series_color, time_error, time_error_size};
    let shadowed: Vec<&ShadowRow> = rows
        .iter()
        .filter(|r| r.error.is_none() && r.method != Shadows::None.label())
        .collect();
    let mut counts: Vec<u32> = shadowed.iter().map(|r| r.lights).collect();
    counts.sort_unstable();
    counts.dedup();
    let methods: Vec<String> = {
        let mut m: Vec<String> = shadowed.iter().map(|r| family(r)).collect();
        m.sort();
        m.dedup();
        m
    };
    let color =
        |r: &ShadowRow| series_color(methods.iter().position(|m| *m == family(r)).unwrap_or(0));
    let legend: Vec<crate::plot::Entry> = methods
        .iter()
        .enumerate()
        .map(|(i, m)| (m.clone(), series_color(i), Some(0)))
        .collect();
    let panels: Vec<Vec<TimeErrorPoint>> = counts
        .iter()
        .map(|&n| {
            let here: Vec<&ShadowRow> =
                shadowed.iter().copied().filter(|r| r.lights == n).collect();
            let error = |j: usize| Some(here[j].rmse_8bit);
            let compare = |j: usize, k: usize| verdict(here[j], here[k]);
            here.iter()
                .enumerate()
                .map(|(k, r)| {
                    let front = crate::measure::front(k, here.len(), error, compare);
                    let mark = match front {
                        Some(Front::On) => "* ",
                        Some(Front::Undecided) => "? ",
                        _ => "",
                    };
                    TimeErrorPoint {
                        ms: r.frame_ms,
                        interval: r.frame_ms_lo.zip(r.frame_ms_hi).map(|(lo, hi)| [lo, hi]),
                        error: r.rmse_8bit,
                        name: format!("{mark}{n} lights: {}", r.variant),
                        color: color(r),
                        on_front: front == Some(Front::On),
                    }
                })
                .collect()
        })
        .collect();
    let sizes: Vec<(u32, u32)> = panels
        .iter()
        .map(|p| time_error_size(p, legend.len()))
        .collect();
    let width = sizes.iter().map(|s| s.0).max()?;
    let height: u32 = sizes.iter().map(|s| s.1).sum();
    crate::plot::svg(
        "shadows.svg",
        "Shadows on the atrium: frame time against error per light count, every method and ray budget",
        (width, height),
        |area| {
            let mut rest = area.clone();
            for (points, size) in panels.iter().zip(&sizes) {
                let (this, below) = rest.split_vertically(size.1);
                time_error(
                    &this,
                    points,
                    &legend,
                    "RMSE against the shadowed reference, 8-bit LSB (log)",
                )
                .ok()
                .filter(|&drawn| drawn)?;
                rest = below;
            }
            Some(())
        },
    )
}

/// A row's method family: exact (with its pipeline) or the estimator.
fn family(r: &ShadowRow) -> String {
    let name = r.variant.split('@').next().unwrap_or(&r.variant);
    name.strip_prefix("forward_plus_shadows_")
        .map(|e| e.trim_end_matches("_1").to_string())
        .unwrap_or_else(|| name.to_string())
}
