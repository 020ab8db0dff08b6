//! `clusterlab study sampling`: time against error for the sampled light loops beside the
//! exact ones, on the atrium where lists grow long: per light count and radius range, the
//! fastest exact variant, each sampler's frame at its error (RMSE, relative MSE, mean FLIP
//! against the f64 reference), the candidates (RIS) or threshold (stochastic culling) each
//! needs to reach `TARGET_RMSE_8BIT`, and with temporal reuse after how many frames of a
//! still camera it gets there. Beside ReSTIR (Bitterli et al. 2020: 6-60x faster than the
//! earlier state of the art at equal error) and stochastic light culling (Tokuyoshi and
//! Harada 2016).

use std::sync::Arc;

use serde::Serialize;

use super::{Reads, StudyError, StudyOptions};
use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::metrics;
use crate::reference::ReferenceCache;
use crate::render::Renderer;
use crate::scene::{Motion, Scene, SceneParams};
use crate::table::Table;
use crate::variant::{Lights, LoadedVariant, Sampler};

/// The scene the study runs on.
pub const SCENE: &str = "atrium";
/// Light counts unless `--lights` says otherwise.
pub const LIGHT_COUNTS: [u32; 3] = [1024, 4096, 16384];
/// Light radius ranges, world units: the atrium's own lists of tens, and long ones.
pub const RADII: [(f32, f32); 2] = [(2.0, 4.0), (4.0, 8.0)];
/// The exact variants the samplers are set beside.
pub const EXACT: [&str; 4] = [
    "forward_plus",
    "forward_plus_zbinning",
    "clustered_deferred_16x16x24",
    "clustered_deferred_two_level",
];
/// The shipped samplers (each also swept over its sample count).
pub const SAMPLERS: [&str; 5] = [
    "forward_plus_uniform_8",
    "forward_plus_ris_8",
    "clustered_deferred_ris_4",
    "forward_plus_ris_32_kept_4",
    "forward_plus_stochastic_culling",
];
/// The samplers that reuse earlier frames' reservoirs, each run as a still sequence:
/// temporal reuse, and spatiotemporal with the balance heuristic and with 1/M.
pub const TEMPORAL: [&str; 3] = [
    "clustered_deferred_restir_temporal",
    "clustered_deferred_restir_spatiotemporal",
    "clustered_deferred_restir_spatiotemporal_1m",
];
/// The error each sampler is asked to reach, 8-bit RMSE.
pub const TARGET_RMSE_8BIT: f64 = 2.0;
/// RIS candidates the sweep tries, and stochastic culling's thresholds (each a quarter of
/// the one before, from the shipped variant's).
pub const CANDIDATES: [u32; 7] = [1, 4, 16, 32, 64, 128, 256];
pub const THRESHOLD_STEPS: u32 = 6;
/// Most frames of the temporal sequence.
pub const TEMPORAL_FRAMES: u32 = 30;

/// One variant (or sweep point) at one light count and radius.
#[derive(Clone, Debug, Serialize)]
pub struct SamplingRow {
    pub lights: u32,
    /// The lights' radius range, world units.
    pub radius_min: f32,
    pub radius_max: f32,
    pub variant: String,
    /// "exact", or the sampler's label and bias.
    pub sampler: String,
    /// The shipped variant, or a point of its sweep.
    pub sweep: bool,
    /// Median frame, ms, and [min, max]; list passes and shading, ms.
    pub frame_ms: f64,
    pub frame_min_ms: f64,
    pub frame_max_ms: f64,
    pub lists_ms: f64,
    pub shading_ms: f64,
    /// The fastest exact variant's frame over this one's.
    pub speedup_vs_exact: Option<f64>,
    pub max_abs_8bit: u32,
    pub rmse_8bit: f64,
    pub relative_mse: f64,
    pub flip_mean: f64,
    /// On the time-RMSE Pareto front of its point.
    pub pareto: bool,
    pub candidates: u64,
    pub evaluations: u64,
    pub useful: u64,
    /// Temporal reuse: frames of a still camera until RMSE reached the target (None: not
    /// within `TEMPORAL_FRAMES`), and the last frame's RMSE.
    pub frames_to_target: Option<u32>,
    pub last_rmse_8bit: Option<f64>,
    pub error: Option<String>,
}

super::outcome_in_error_field!(SamplingRow);

impl SamplingRow {
    fn radius(&self) -> [f32; 2] {
        [self.radius_min, self.radius_max]
    }
}

/// The study: at each light count and radius range, the exact variants, each sampler and
/// its sweep, and the temporal samplers over a still sequence.
pub struct SamplingStudy {
    frames: u32,
}

/// One variant at one light count and radius range.
pub enum Point {
    /// The scene's own frame (its camera walking, its lights moving: every frame builds its
    /// lists, as a frame of a running demo does); a sampler's sweep with it, cheapest first.
    Frame {
        variant: LoadedVariant,
        scene: Arc<Scene>,
        references: Arc<ReferenceCache>,
        sweep: bool,
    },
    /// A sampler that reuses earlier frames: the same frame held still, the camera and
    /// lights where they are at its time.
    Still {
        variant: LoadedVariant,
        params: SceneParams,
    },
}

impl Point {
    fn variant(&self) -> &LoadedVariant {
        match self {
            Point::Frame { variant, .. } | Point::Still { variant, .. } => variant,
        }
    }

    fn params(&self) -> &SceneParams {
        match self {
            Point::Frame { scene, .. } => &scene.params,
            Point::Still { params, .. } => params,
        }
    }
}

impl super::Study for SamplingStudy {
    const NAME: &'static str = "sampling";
    const READS: &'static [Reads] = &[Reads::Size, Reads::Lights, Reads::Frames];
    const ABOUT: &'static str = "Time against error: the sampled light loops (uniform, RIS, \
        stochastic light culling, ReSTIR's temporal and spatiotemporal reuse) beside the \
        fastest exact variants on the atrium at 1024, 4096 and 16384 lights, radius 2..4 and \
        4..8: each sampler's error, the candidates each needs for 2 LSB RMSE, and the frames \
        temporal reuse needs (--size, --lights, --frames)";
    type Point = Point;
    type Row = SamplingRow;

    fn plan(_gpu: &Gpu, options: &StudyOptions) -> Result<(Self, Vec<Point>), StudyError> {
        let exact = super::shipped(&EXACT)?;
        let samplers = super::shipped(&SAMPLERS)?;
        let temporal = super::shipped(&TEMPORAL)?;
        let mut points = Vec::new();
        for at_count in options.params_for(SCENE, &LIGHT_COUNTS)? {
            for &radius_range in &RADII {
                let params = SceneParams {
                    radius_range,
                    ..at_count
                };
                let scene = Arc::new(super::generate(SCENE, params)?);
                let references = Arc::new(ReferenceCache::default());
                for (v, sweep) in exact
                    .iter()
                    .map(|v| (v, false))
                    .chain(samplers.iter().map(|v| (v, true)))
                {
                    points.push(Point::Frame {
                        variant: v.clone(),
                        scene: scene.clone(),
                        references: references.clone(),
                        sweep,
                    });
                }
                let still = SceneParams {
                    motion: Motion {
                        lights: 0.0,
                        camera: false,
                        still_at: params.time,
                    },
                    ..params
                };
                for v in &temporal {
                    points.push(Point::Still {
                        variant: v.clone(),
                        params: still,
                    });
                }
            }
        }
        let frames = options.frames;
        Ok((SamplingStudy { frames }, points))
    }

    fn label(&self, p: &Point) -> String {
        let params = p.params();
        let (lights, (lo, hi)) = (params.lights, params.radius_range);
        let name = &p.variant().name;
        format!("{lights} lights, radius {lo}..{hi}: {name}")
    }

    fn run(
        &self,
        gpu: &Gpu,
        composer: &Composer,
        p: &Point,
    ) -> Result<Vec<SamplingRow>, StudyError> {
        match p {
            Point::Frame {
                variant,
                scene,
                references,
                sweep,
            } => {
                let measure_here = |v: &LoadedVariant, swept: bool| {
                    measure(gpu, composer, v, scene, references, self.frames, swept)
                };
                let mut rows = vec![measure_here(variant, false)?];
                if *sweep {
                    // Cheapest first: past the first point at the target, dearer ones say
                    // nothing. A swept variant that fails leaves its row; the sweep goes on.
                    for swept in sweep_of(variant) {
                        // Each swept variant has the cell's time limit to itself.
                        gpu.begin_cell();
                        let row = measure_here(&swept, true).unwrap_or_else(|e| SamplingRow {
                            error: Some(e.to_string()),
                            ..empty_row(&swept, &scene.params, true)
                        });
                        let reached = row.error.is_none() && row.rmse_8bit <= TARGET_RMSE_8BIT;
                        rows.push(row);
                        if reached {
                            break;
                        }
                    }
                }
                Ok(rows)
            }
            Point::Still { variant, params } => {
                let references = ReferenceCache::default();
                Ok(vec![temporal_point(
                    gpu,
                    composer,
                    variant,
                    *params,
                    &references,
                )?])
            }
        }
    }

    fn named(&self, p: &Point) -> SamplingRow {
        empty_row(p.variant(), p.params(), false)
    }

    /// Each row's speed-up and place on the front, among the rows of its light count and
    /// radius range.
    fn relate(&self, rows: &mut [SamplingRow]) {
        let mut start = 0;
        while start < rows.len() {
            let key = (rows[start].lights, rows[start].radius());
            let len = rows[start..]
                .iter()
                .take_while(|r| (r.lights, r.radius()) == key)
                .count();
            finish(&mut rows[start..start + len]);
            start += len;
        }
    }

    fn table(&self, rows: &[SamplingRow]) -> Table {
        table(rows)
    }

    fn plot(&self, rows: &[SamplingRow]) -> Option<crate::plot::Plot> {
        plot(rows)
    }
}

/// The sweep of a shipped sampler, cheapest first: RIS and uniform sampling over
/// `CANDIDATES` (but its own), stochastic culling over thresholds a quarter apart.
fn sweep_of(v: &LoadedVariant) -> Vec<LoadedVariant> {
    let Some(s) = v.variant.shading.lights.sampling() else {
        return Vec::new();
    };
    let with = |method: Sampler, tag: String| {
        let mut out = v.clone();
        out.name = format!("{}@{tag}", v.name);
        let mut sampling = *s;
        sampling.method = method;
        out.variant.shading.lights = Lights::Sampled(sampling);
        out
    };
    match s.method {
        Sampler::Ris {
            candidates,
            kept,
            temporal,
            spatial,
        } => CANDIDATES
            .iter()
            .filter(|&&m| m != candidates && m >= kept)
            .map(|&m| {
                let method = Sampler::Ris {
                    candidates: m,
                    kept,
                    temporal,
                    spatial,
                };
                with(method, format!("M={m}"))
            })
            .collect(),
        Sampler::Uniform { candidates } => CANDIDATES
            .iter()
            .filter(|&&m| m != candidates)
            .map(|&m| with(Sampler::Uniform { candidates: m }, format!("M={m}")))
            .collect(),
        Sampler::StochasticCulling { threshold } => (1..=THRESHOLD_STEPS)
            .map(|i| {
                let t = threshold / 4f32.powi(i as i32);
                with(
                    Sampler::StochasticCulling { threshold: t },
                    format!("t={t}"),
                )
            })
            .collect(),
    }
}

fn empty_row(v: &LoadedVariant, scene_params: &SceneParams, sweep: bool) -> SamplingRow {
    SamplingRow {
        lights: scene_params.lights,
        radius_min: scene_params.radius_range.0,
        radius_max: scene_params.radius_range.1,
        variant: v.name.clone(),
        sampler: v
            .variant
            .shading
            .lights
            .sampling()
            .map_or("exact".into(), |s| {
                format!("{} ({})", s.label(), s.bias_label())
            }),
        sweep,
        frame_ms: 0.0,
        frame_min_ms: 0.0,
        frame_max_ms: 0.0,
        lists_ms: 0.0,
        shading_ms: 0.0,
        speedup_vs_exact: None,
        max_abs_8bit: 0,
        rmse_8bit: 0.0,
        relative_mse: 0.0,
        flip_mean: 0.0,
        pareto: false,
        candidates: 0,
        evaluations: 0,
        useful: 0,
        frames_to_target: None,
        last_rmse_8bit: None,
        error: None,
    }
}

/// The passes that build lists, and those that shade.
const LIST_PASSES: [&str; 5] = [
    "depth_range",
    "mark_active",
    "cluster_bounds",
    "light_assign",
    "zbin_assign",
];
const SHADING_PASSES: [&str; 2] = ["forward", "resolve"];

/// One variant on `scene`: an untimed frame, `frames` timed, the error of the last, the
/// counters.
fn measure(
    gpu: &Gpu,
    composer: &Composer,
    v: &LoadedVariant,
    scene: &Scene,
    references: &ReferenceCache,
    frames: u32,
    sweep: bool,
) -> Result<SamplingRow, StudyError> {
    let mut row = empty_row(v, &scene.params, sweep);
    let mut renderer = Renderer::new(gpu, composer, &v.variant, scene)?;
    renderer.render()?;
    let (mut totals, mut lists, mut shading) = (Vec::new(), Vec::new(), Vec::new());
    let mut last = None;
    for _ in 0..frames.max(1) {
        let f = renderer.render()?;
        totals.push(f.timings.total_ms());
        lists.push(LIST_PASSES.iter().map(|p| f.timings.get(p)).sum());
        shading.push(SHADING_PASSES.iter().map(|p| f.timings.get(p)).sum());
        last = Some(f);
    }
    let last = last.expect("a timed frame");
    let (reference, _) = references
        .get_or_compute(gpu, composer, v, scene)
        .map_err(|e| StudyError::Usage(e.to_string()))?;
    let e = metrics::compare(&last, &reference);
    if let Some(why) = crate::run::meaningless(&reference, Some(&last), None, Some(&e)) {
        return Err(StudyError::Usage(why));
    }
    let stats = renderer.stats()?;
    row.frame_min_ms = totals.iter().copied().fold(f64::INFINITY, f64::min);
    row.frame_max_ms = totals.iter().copied().fold(0.0, f64::max);
    row.frame_ms = crate::measure::median(totals);
    row.lists_ms = crate::measure::median(lists);
    row.shading_ms = crate::measure::median(shading);
    row.max_abs_8bit = e.max_abs_8bit;
    row.rmse_8bit = e.rmse_8bit;
    row.relative_mse = e.relative_mse;
    row.flip_mean = e.flip_mean;
    row.candidates = stats.light_candidates;
    row.evaluations = stats.light_evals;
    row.useful = stats.useful_light_evals;
    Ok(row)
}

/// The temporal sampler over a still sequence: each frame's RMSE until it reaches the
/// target or `TEMPORAL_FRAMES` pass; its time is the median frame after the first.
fn temporal_point(
    gpu: &Gpu,
    composer: &Composer,
    v: &LoadedVariant,
    params: SceneParams,
    references: &ReferenceCache,
) -> Result<SamplingRow, StudyError> {
    let mut row = empty_row(v, &params, false);
    let at = crate::sequence::scene_frames(SCENE, params);
    let scene_at = |i| at(i).map_err(|e| StudyError::Usage(e.to_string()));
    let first = scene_at(0)?;
    let (reference, _) = references
        .get_or_compute(gpu, composer, v, &first)
        .map_err(|e| StudyError::Usage(e.to_string()))?;
    let mut renderer = Renderer::new(gpu, composer, &v.variant, &first)?;
    let mut totals = Vec::new();
    let mut frame = renderer.render()?;
    let first_error = metrics::compare(&frame, &reference);
    row.max_abs_8bit = first_error.max_abs_8bit;
    row.rmse_8bit = first_error.rmse_8bit;
    row.relative_mse = first_error.relative_mse;
    row.flip_mean = first_error.flip_mean;
    let mut rmse = first_error.rmse_8bit;
    for i in 1..TEMPORAL_FRAMES {
        if rmse <= TARGET_RMSE_8BIT {
            row.frames_to_target = Some(i);
            break;
        }
        // A still scene: every frame's reference is the first's.
        renderer.advance(&scene_at(i)?)?;
        frame = renderer.render()?;
        totals.push(frame.timings.total_ms());
        rmse = metrics::rmse_8bit(&frame, &reference);
    }
    if row.frames_to_target.is_none() && rmse <= TARGET_RMSE_8BIT {
        row.frames_to_target = Some(TEMPORAL_FRAMES);
    }
    row.last_rmse_8bit = Some(rmse);
    let stats = renderer.stats()?;
    row.candidates = stats.light_candidates;
    row.evaluations = stats.light_evals;
    row.useful = stats.useful_light_evals;
    row.frame_min_ms = totals.iter().copied().fold(f64::INFINITY, f64::min);
    row.frame_max_ms = totals.iter().copied().fold(0.0, f64::max);
    row.frame_ms = crate::measure::median(totals);
    Ok(row)
}

/// Each row's speed-up over the fastest exact variant of its point, and its place on the
/// time-RMSE front of the single frames (a temporal row's frame is a still sequence's,
/// which keeps the G-buffer and lists: it is set beside the front, not on it).
fn finish(point: &mut [SamplingRow]) {
    let fastest = point
        .iter()
        .filter(|r| r.error.is_none() && r.sampler == "exact")
        .map(|r| r.frame_ms)
        .fold(f64::INFINITY, f64::min);
    let single = |r: &SamplingRow| r.error.is_none() && r.last_rmse_8bit.is_none();
    let front: Vec<(f64, f64)> = point
        .iter()
        .filter(|r| single(r))
        .map(|r| (r.frame_ms, r.rmse_8bit))
        .collect();
    for r in point.iter_mut().filter(|r| r.error.is_none()) {
        if fastest.is_finite() && r.frame_ms > 0.0 {
            r.speedup_vs_exact = Some(fastest / r.frame_ms);
        }
        let (t, e) = (r.frame_ms, r.rmse_8bit);
        r.pareto = single(r)
            && !front
                .iter()
                .any(|&(t2, e2)| t2 <= t && e2 <= e && (t2 < t || e2 < e));
    }
}

/// The fewest candidates (or the largest threshold) of a shipped sampler's family that
/// reach the target at a point, as its label says.
fn reaching_target<'a>(
    rows: &'a [SamplingRow],
    base: &str,
    lights: u32,
    radius: [f32; 2],
) -> Option<&'a SamplingRow> {
    rows.iter()
        .filter(|r| {
            r.error.is_none()
                && r.lights == lights
                && r.radius() == radius
                && (r.variant == base || r.variant.starts_with(&format!("{base}@")))
                && r.rmse_8bit <= TARGET_RMSE_8BIT
        })
        .min_by(|a, b| a.frame_ms.total_cmp(&b.frame_ms))
}

fn table(rows: &[SamplingRow]) -> Table {
    let mut t = Table::new(
        "Sampling: each light loop's frame at its error against the f64 reference",
        &[
            "lights",
            "radius",
            "variant",
            "sampler",
            "frame ms",
            "[min, max]",
            "lists ms",
            "shading ms",
            "x fastest exact",
            "RMSE8",
            "relMSE",
            "FLIP",
            "max8",
            "Pareto",
            "candidates",
            "evaluated",
            "useful",
            "frames to 2 LSB",
        ],
    );
    for r in rows {
        let names = vec![
            r.lights.to_string(),
            format!("{}..{}", r.radius_min, r.radius_max),
            r.variant.clone(),
            r.sampler.clone(),
        ];
        if let Some(e) = &r.error {
            t.failed_row(names, e);
            continue;
        }
        let mut cells = names;
        cells.extend([
            format!("{:.2}", r.frame_ms),
            format!("[{:.2}, {:.2}]", r.frame_min_ms, r.frame_max_ms),
            format!("{:.2}", r.lists_ms),
            format!("{:.2}", r.shading_ms),
            r.speedup_vs_exact.map_or("-".into(), |x| format!("{x:.2}")),
            match r.last_rmse_8bit {
                Some(last) => format!("{:.2} to {last:.2}", r.rmse_8bit),
                None => format!("{:.3}", r.rmse_8bit),
            },
            format!("{:.2e}", r.relative_mse),
            format!("{:.4}", r.flip_mean),
            r.max_abs_8bit.to_string(),
            if r.pareto { "*" } else { "" }.into(),
            crate::matrix::count(r.candidates),
            crate::matrix::count(r.evaluations),
            crate::matrix::count(r.useful),
            match (r.last_rmse_8bit, r.frames_to_target) {
                (None, _) => "-".into(),
                (Some(_), Some(n)) => n.to_string(),
                (Some(_), None) => format!("over {TEMPORAL_FRAMES}"),
            },
        ]);
        t.row(cells);
    }
    let mut points: Vec<(u32, [f32; 2])> = rows.iter().map(|r| (r.lights, r.radius())).collect();
    points.dedup();
    for (lights, radius) in points {
        let here =
            |r: &&SamplingRow| r.lights == lights && r.radius() == radius && r.error.is_none();
        let Some(exact) = rows
            .iter()
            .filter(here)
            .filter(|r| r.sampler == "exact")
            .min_by(|a, b| a.frame_ms.total_cmp(&b.frame_ms))
        else {
            continue;
        };
        let mut note = format!(
            "{lights} lights, radius {}..{}: lowest-median exact {} at {:.1} ms (points timed apart, no verdict)",
            radius[0], radius[1], exact.variant, exact.frame_ms
        );
        // The samplers on the front at least 3x faster than the fastest exact frame: the
        // fastest, and the most accurate of them.
        let fast: Vec<&SamplingRow> = rows
            .iter()
            .filter(here)
            .filter(|r| r.sampler != "exact" && r.pareto)
            .filter(|r| r.speedup_vs_exact.is_some_and(|x| x >= 3.0))
            .collect();
        let fastest = fast.iter().min_by(|a, b| a.frame_ms.total_cmp(&b.frame_ms));
        let accurate = fast
            .iter()
            .min_by(|a, b| a.rmse_8bit.total_cmp(&b.rmse_8bit));
        for (what, r) in [("lowest-median", fastest), ("most accurate", accurate)] {
            if let Some(r) = r {
                note += &format!(
                    "; {what} sampler on the front at 3x or more: {} at {:.1} ms ({:.2}x), RMSE {:.2} LSB",
                    r.variant,
                    r.frame_ms,
                    r.speedup_vs_exact.unwrap_or(0.0),
                    r.rmse_8bit
                );
            }
        }
        for base in SAMPLERS {
            note += &match reaching_target(rows, base, lights, radius) {
                Some(r) => format!(
                    "; {base} reaches {TARGET_RMSE_8BIT} LSB as {} ({:.1} ms)",
                    r.variant, r.frame_ms
                ),
                None => format!("; {base} does not reach {TARGET_RMSE_8BIT} LSB in its sweep"),
            };
        }
        for r in rows
            .iter()
            .filter(here)
            .filter(|r| TEMPORAL.contains(&r.variant.as_str()))
        {
            note += &format!(
                "; {} over a still sequence: {} frames to {TARGET_RMSE_8BIT} LSB (RMSE {:.2} after the last), a frame {:.2} of the fastest exact frame",
                r.variant,
                r.frames_to_target
                    .map_or(format!("over {TEMPORAL_FRAMES}"), |n| n.to_string()),
                r.last_rmse_8bit.unwrap_or(r.rmse_8bit),
                r.frame_ms / exact.frame_ms
            );
        }
        t.notes.push(note);
    }
    t.notes.push(
        "Bitterli et al. (2020, ReSTIR) report 6-60x faster than the earlier state of the art at equal error, unbiased; Tokuyoshi and Harada (2016) stochastic light culling unbiased, compared by RMSE. RIS here draws uniformly from the pixel's list and its target is the contribution itself (no visibility to defer), so its cost no longer grows with the list but its list is still built; temporal reuse keeps one reservoir a pixel, whose luminance converges while its colour stays one light's.".into(),
    );
    t.notes.push(
        "Times are medians of the timed frames; frames on a software GPU measure CPU work: compare variants within one run.".into(),
    );
    t
}

/// RMSE against frame time, a series per sampler family (its sweep) and the exact
/// variants, a panel per point.
fn plot(rows: &[SamplingRow]) -> Option<crate::plot::Plot> {
    use plotters::prelude::*;
    let ok: Vec<&SamplingRow> = rows.iter().filter(|r| r.error.is_none()).collect();
    let mut panels: Vec<(u32, [f32; 2])> = ok.iter().map(|r| (r.lights, r.radius())).collect();
    panels.dedup();
    if panels.is_empty() {
        return None;
    }
    let family = |r: &SamplingRow| r.variant.split('@').next().unwrap_or("").to_string();
    let mut families: Vec<String> = Vec::new();
    for r in &ok {
        let f = if r.sampler == "exact" {
            "exact".into()
        } else {
            family(r)
        };
        if !families.contains(&f) {
            families.push(f);
        }
    }
    // RMSE on a log axis: exact variants sit at their rounding, floored here.
    const FLOOR: f64 = 1e-2;
    crate::plot::svg(
        "sampling.svg",
        "Sampling: RMSE (8-bit) against frame time",
        (
            1100 + 2 * crate::plot::LEGEND_WIDTH,
            420 * panels.len().div_ceil(2) as u32,
        ),
        |area| {
            let cells = area.split_evenly((panels.len().div_ceil(2), 2));
            for (&(lights, radius), cell) in panels.iter().zip(cells.iter()) {
                let here: Vec<&&SamplingRow> = ok
                    .iter()
                    .filter(|r| r.lights == lights && r.radius() == radius)
                    .collect();
                let t_max = here.iter().map(|r| r.frame_ms).fold(1.0, f64::max) * 1.5;
                let t_min = here
                    .iter()
                    .map(|r| r.frame_ms)
                    .fold(f64::INFINITY, f64::min)
                    .max(1e-2)
                    / 1.5;
                let e_max = here.iter().map(|r| r.rmse_8bit).fold(FLOOR, f64::max) * 10.0;
                let caption = format!("{lights} lights, radius {}..{}", radius[0], radius[1]);
                let mut chart = ChartBuilder::on(cell)
                    .caption(caption, (crate::plot::FONT, 16))
                    .margin(10)
                    .margin_right(crate::plot::LEGEND_WIDTH)
                    .x_label_area_size(36)
                    .y_label_area_size(60)
                    .build_cartesian_2d(
                        crate::plot::log_axis(t_min, t_max),
                        crate::plot::log_axis(FLOOR, e_max),
                    )
                    .ok()?;
                chart
                    .configure_mesh()
                    .light_line_style(TRANSPARENT)
                    .x_desc("frame ms")
                    .y_desc("RMSE, 8-bit LSB")
                    .x_label_formatter(&crate::plot::tick_label)
                    .y_label_formatter(&crate::plot::tick_label)
                    .draw()
                    .ok()?;
                for (i, f) in families.iter().enumerate() {
                    let mut points: Vec<(f64, f64)> = here
                        .iter()
                        .filter(|r| {
                            if f == "exact" {
                                r.sampler == "exact"
                            } else {
                                family(r) == *f
                            }
                        })
                        .map(|r| {
                            (
                                r.frame_ms,
                                r.last_rmse_8bit.unwrap_or(r.rmse_8bit).max(FLOOR),
                            )
                        })
                        .collect();
                    points.sort_by(|a, b| a.0.total_cmp(&b.0));
                    crate::plot::line_with_points(&mut chart, points, i)?;
                }
                crate::plot::legend(cell, &crate::plot::series_legend(&families))?;
            }
            Some(())
        },
    )
}
