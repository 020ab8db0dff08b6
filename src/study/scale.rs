//! `clusterlab study scale`: the shipped exact culling methods from 4096 lights to a
//! million on the atrium, each light's radius scaled with the count so that a pixel keeps
//! about as many useful lights at every count (1..3 at 1024 lights, times (1024 / N)^(1/3)):
//! frame and per-pass times, evaluations and useful ones, list bytes, and each frame's
//! error against the f64 reference. On a software adapter it runs 640x360 and up to 262,144
//! lights unless told otherwise (`--size`, `--lights`), and says so.

use serde::Serialize;

use super::table::{Table, sig};
use super::{StudyError, StudyOptions};
use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::measure::Frames;
use crate::plot::Plot;
use crate::reference::ReferenceCache;
use crate::run::{CellOptions, run_scene_keeping_renderer};
use crate::scene::SceneParams;

/// The methods, as shipped variant files, and their labels.
pub const METHODS: [(&str, &str); 7] = [
    ("forward_plus_one_level", "FP one-level"),
    ("forward_plus_two_level", "FP two-level"),
    ("forward_plus_two_level_fine", "FP two-level fine"),
    ("forward_plus_zbinning", "FP z-binning"),
    ("forward_plus_bvh", "FP BVH"),
    ("forward_plus_tiled", "FP tiled"),
    ("clustered_deferred_two_level", "CD two-level"),
];

/// Light counts on a hardware GPU, and on a software one.
pub const GPU_COUNTS: [u32; 5] = [4096, 16384, 65536, 262_144, 1_048_576];
pub const SOFTWARE_COUNTS: [u32; 4] = [4096, 16384, 65536, 262_144];
/// Image sizes on a hardware GPU, and on a software one.
pub const GPU_SIZE: (u32, u32) = (1920, 1080);
pub const SOFTWARE_SIZE: (u32, u32) = (640, 360);

/// The light radius range at `lights` lights: 1..3 at 1024, scaled by (1024 / N)^(1/3), so
/// that the lights' volume over the scene, and so the useful lights a pixel keeps, stays
/// about the same at every count.
pub fn radius_range(lights: u32) -> (f32, f32) {
    let scale = (1024.0 / lights.max(1) as f64).cbrt();
    ((1.0 * scale) as f32, (3.0 * scale) as f32)
}

/// One method at one light count.
#[derive(Clone, Debug, Serialize)]
pub struct ScaleRow {
    pub lights: u32,
    pub method: String,
    pub variant: String,
    pub width: u32,
    pub height: u32,
    pub radius_min: f32,
    pub radius_max: f32,
    /// Median of the timed frames, ms.
    pub frame_ms: f64,
    /// The passes that build the lists (depth range, marking, boxes, assignment), ms.
    pub assignment_ms: f64,
    /// The shading passes (forward, resolve), ms.
    pub shading_ms: f64,
    pub evaluations: u64,
    pub useful_evaluations: u64,
    /// Evaluations per useful one (1 for perfect culling).
    pub evaluations_per_useful: f64,
    /// Bytes of every culling buffer.
    pub list_bytes: u64,
    /// Light assignment's work counters (`render::AssignmentWork`), one column each.
    pub light_tests: u64,
    pub node_tests: u64,
    pub entries_written: u64,
    pub lights_rejected: u64,
    /// Its light and node tests per light.
    pub tests_per_light: f64,
    /// Largest 8-bit error against the reference.
    pub max_abs_8bit: u32,
    pub timing_source: String,
    /// Why the run failed, or was not exact; the figures are then what it measured, if any.
    pub error: Option<String>,
}

/// The counts and size the study runs on `gpu` with `options`, and a note when a software
/// adapter chose smaller ones.
pub fn plan(gpu: &Gpu, options: &StudyOptions) -> (Vec<u32>, (u32, u32), Option<String>) {
    let (counts, size) = if gpu.software {
        (SOFTWARE_COUNTS.to_vec(), SOFTWARE_SIZE)
    } else {
        (GPU_COUNTS.to_vec(), GPU_SIZE)
    };
    let counts = options.lights.map_or(counts, |n| vec![n]);
    let size = options.explicit_size.unwrap_or(size);
    let note =
        (gpu.software && options.explicit_size.is_none() && options.lights.is_none()).then(|| {
            format!(
                "{} is a software adapter: {}x{} and up to {} lights (a GPU runs {}x{} to {})",
                gpu.adapter.name,
                size.0,
                size.1,
                SOFTWARE_COUNTS[SOFTWARE_COUNTS.len() - 1],
                GPU_SIZE.0,
                GPU_SIZE.1,
                GPU_COUNTS[GPU_COUNTS.len() - 1]
            )
        });
    (counts, size, note)
}

/// Run every method at every count. A failing run is reported in its row; the others go on.
pub fn run(
    gpu: &Gpu,
    composer: &Composer,
    options: &StudyOptions,
) -> Result<Vec<ScaleRow>, StudyError> {
    let (counts, size, note) = plan(gpu, options);
    if let Some(note) = note {
        eprintln!("{note}");
    }
    let variants: Vec<_> = METHODS
        .iter()
        .map(|(file, label)| {
            let path = std::path::Path::new("variants").join(format!("{file}.ron"));
            crate::variant::load(&path)
                .map(|v| (v, *label))
                .map_err(|e| {
                    StudyError::Usage(format!("{e} (run the study from the project folder)"))
                })
        })
        .collect::<Result<_, _>>()?;
    let defaults =
        crate::scene::defaults("atrium").map_err(|e| StudyError::Usage(e.to_string()))?;
    let mut rows = Vec::new();
    for &lights in &counts {
        let radius = radius_range(lights);
        let params = SceneParams {
            width: size.0,
            height: size.1,
            lights,
            radius_range: radius,
            ..defaults
        };
        let scene = crate::scene::generate("atrium", params)
            .map_err(|e| StudyError::Usage(e.to_string()))?;
        let references = ReferenceCache::default();
        for (loaded, label) in &variants {
            eprintln!("  {lights} lights: {label}");
            let mut row = ScaleRow {
                lights,
                method: label.to_string(),
                variant: loaded.name.clone(),
                width: size.0,
                height: size.1,
                radius_min: radius.0,
                radius_max: radius.1,
                frame_ms: 0.0,
                assignment_ms: 0.0,
                shading_ms: 0.0,
                evaluations: 0,
                useful_evaluations: 0,
                evaluations_per_useful: 0.0,
                list_bytes: 0,
                light_tests: 0,
                node_tests: 0,
                entries_written: 0,
                lights_rejected: 0,
                tests_per_light: 0.0,
                max_abs_8bit: 0,
                timing_source: String::new(),
                error: None,
            };
            let cell = CellOptions {
                frames: Frames::exact(1, options.frames),
                stats: true,
                out: None,
                references: Some(&references),
                debug_view: None,
            };
            match run_scene_keeping_renderer(gpu, composer, loaded, &scene, cell) {
                Ok((c, renderer)) => {
                    let r = &c.report;
                    let ms = |name: &str| r.gpu_ms.get(name).and_then(|v| v.as_f64());
                    row.frame_ms = ms("total").unwrap_or(0.0);
                    row.assignment_ms =
                        <crate::compose::ClusterPass as strum::IntoEnumIterator>::iter()
                            .filter_map(|p| ms(p.into()))
                            .sum();
                    row.shading_ms = renderer
                        .shading_pass_names()
                        .iter()
                        .filter_map(|p| ms(p))
                        .sum();
                    if let Some(s) = &r.stats {
                        row.evaluations = s.light_evals;
                        row.useful_evaluations = s.useful_light_evals;
                        row.evaluations_per_useful =
                            s.light_evals as f64 / s.useful_light_evals.max(1) as f64;
                        row.list_bytes = s.cluster_bytes;
                        let work = s.assignment_work.unwrap_or_default();
                        row.light_tests = work.light_tests;
                        row.node_tests = work.node_tests;
                        row.entries_written = work.entries_written;
                        row.lights_rejected = work.lights_rejected;
                        row.tests_per_light = work.tests_per_light(lights as usize);
                    }
                    row.max_abs_8bit = r.error.as_ref().map_or(0, |e| e.max_abs_8bit);
                    row.timing_source = r.timing_source.into();
                    row.error = r.failure.clone();
                }
                Err(e) => row.error = Some(e.to_string()),
            }
            rows.push(row);
        }
    }
    Ok(rows)
}

/// Whether every run succeeded within its exactness claim.
pub fn all_exact(rows: &[ScaleRow]) -> bool {
    rows.iter().all(|r| r.error.is_none())
}

pub fn table(rows: &[ScaleRow]) -> Table {
    let title = match rows.first() {
        Some(r) => format!(
            "Scale: the atrium at {}x{}, radius 1..3 x (1024 / lights)^(1/3)",
            r.width, r.height
        ),
        None => "Scale".into(),
    };
    let mut t = Table::new(
        &title,
        &[
            "lights",
            "method",
            "frame ms",
            "assignment ms",
            "shading ms",
            "evaluations",
            "useful",
            "evaluations / useful",
            "tests / light",
            "entries written",
            "rejected",
            "list MiB",
            "max8",
        ],
    );
    for r in rows {
        let key = vec![r.lights.to_string(), r.method.clone()];
        if let Some(e) = &r.error {
            t.failed_row(key, e);
            continue;
        }
        t.row(vec![
            r.lights.to_string(),
            r.method.clone(),
            sig(r.frame_ms, 3),
            sig(r.assignment_ms, 3),
            sig(r.shading_ms, 3),
            r.evaluations.to_string(),
            r.useful_evaluations.to_string(),
            format!("{:.2}", r.evaluations_per_useful),
            format!("{:.1}", r.tests_per_light),
            r.entries_written.to_string(),
            r.lights_rejected.to_string(),
            format!("{:.2}", r.list_bytes as f64 / (1 << 20) as f64),
            r.max_abs_8bit.to_string(),
        ]);
    }
    t
}

type Measure = fn(&ScaleRow) -> f64;

/// Frame and assignment time against the light count, log-log, one line per method.
pub fn plot(rows: &[ScaleRow]) -> Option<Plot> {
    let ok: Vec<&ScaleRow> = rows.iter().filter(|r| r.error.is_none()).collect();
    let mut counts: Vec<u32> = ok.iter().map(|r| r.lights).collect();
    counts.sort_unstable();
    counts.dedup();
    if counts.len() < 2 {
        return None;
    }
    let panel = |label, value: Measure| crate::plot::Panel {
        label,
        values: ok.iter().map(|r| value(r)).collect(),
        series: METHODS
            .iter()
            .map(|(_, method)| {
                let points = ok
                    .iter()
                    .filter(|r| r.method == *method && value(r) > 0.0)
                    .map(|r| (r.lights as f64, value(r)))
                    .collect();
                (*method, points)
            })
            .collect(),
    };
    crate::plot::against_lights(
        "scale.svg",
        "Scale: frame and assignment time against light count",
        (counts[0], *counts.last()?),
        &[
            panel("frame, ms", |r| r.frame_ms),
            panel("light assignment, ms", |r| r.assignment_ms),
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rule keeps the lights' total volume, N r^3, what it is at 1024 lights.
    #[test]
    fn the_radius_rule_keeps_the_lights_volume() {
        assert_eq!(radius_range(1024), (1.0, 3.0));
        for n in [4096u32, 262_144, 1_048_576] {
            let (lo, hi) = radius_range(n);
            let volume = n as f64 * (hi as f64).powi(3);
            assert!(
                (volume / (1024.0 * 27.0) - 1.0).abs() < 1e-5,
                "{n}: {volume}"
            );
            assert!((hi / lo - 3.0).abs() < 1e-5);
        }
    }
}
