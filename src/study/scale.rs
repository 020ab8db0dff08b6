//! `clusterlab study scale`: the shipped exact culling methods from 4096 lights to a
//! million on the atrium, each light's radius scaled with the count so that a pixel keeps
//! about as many useful lights at every count (1..3 at 1024 lights, times (1024 / N)^(1/3)):
//! frame and per-pass times, evaluations and useful ones, list bytes, and each frame's
//! error against the f64 reference. On a software adapter it runs 640x360 and up to 262,144
//! lights unless told otherwise (`--size`, `--lights`), and says so.

use std::sync::Arc;

use serde::Serialize;

use super::{Reads, StudyError, StudyOptions};
use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::measure::Frames;
use crate::plot::Plot;
use crate::reference::ReferenceCache;
use crate::render::Renderer;
use crate::run::{CellOptions, run_scene_keeping_renderer};
use crate::scene::{Scene, SceneParams};
use crate::table::{Table, sig};
use crate::variant::LoadedVariant;

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
#[derive(Clone, Debug, Default, Serialize)]
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
    /// The light BVH's build alone (`Renderer::time_light_bvh_build`), median of `--frames`
    /// runs, ms; None for the other methods.
    pub build_ms: Option<f64>,
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

super::outcome_in_error_field!(ScaleRow);

/// The study: every method at every count, each count's references shared by its methods.
pub struct ScaleStudy {
    frames: u32,
    /// Why the counts and size are smaller than a GPU's, on a software adapter.
    note: Option<String>,
}

/// One method at one light count.
pub struct Point {
    variant: LoadedVariant,
    method: String,
    scene: Arc<Scene>,
    references: Arc<ReferenceCache>,
}

/// The row of a point, with no figures yet.
fn named(p: &Point) -> ScaleRow {
    let params = &p.scene.params;
    ScaleRow {
        lights: params.lights,
        method: p.method.clone(),
        variant: p.variant.name.clone(),
        width: params.width,
        height: params.height,
        radius_min: params.radius_range.0,
        radius_max: params.radius_range.1,
        ..Default::default()
    }
}

impl super::Study for ScaleStudy {
    const NAME: &'static str = "scale";
    const READS: &'static [Reads] = &[Reads::Size, Reads::Lights, Reads::Frames, Reads::Variants];
    const ABOUT: &'static str = "The exact culling methods from 4096 lights to a million on \
        the atrium (radius scaled with the count): frame, assignment (and of it the light \
        BVH's build) and shading time, \
        evaluations per useful one, the assignment's work, list bytes and exactness; \
        1920x1080, or 640x360 and up to 262144 lights on a software adapter (--size, \
        --lights, --frames; --variants: yours beside them)";
    type Point = Point;
    type Row = ScaleRow;

    fn plan(gpu: &Gpu, options: &StudyOptions) -> Result<(Self, Vec<Point>), StudyError> {
        let (counts, size) = if gpu.software {
            (SOFTWARE_COUNTS.to_vec(), SOFTWARE_SIZE)
        } else {
            (GPU_COUNTS.to_vec(), GPU_SIZE)
        };
        let chosen = options.size.is_none() && options.lights.is_empty();
        let note = (gpu.software && chosen).then(|| {
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
        let size = options.size.unwrap_or(size);
        let files: Vec<&str> = METHODS.iter().map(|(file, _)| *file).collect();
        // The shipped methods by their labels, then the user's by their names.
        let methods: Vec<(LoadedVariant, String)> = super::shipped(&files)?
            .into_iter()
            .zip(METHODS.iter().map(|(_, label)| label.to_string()))
            .chain(options.variants.iter().map(|v| (v.clone(), v.name.clone())))
            .collect();
        let defaults = super::scene_defaults("atrium")?;
        let mut points = Vec::new();
        for lights in options.lights_or(&counts) {
            let params = SceneParams {
                width: size.0,
                height: size.1,
                lights,
                radius_range: radius_range(lights),
                ..defaults
            };
            let scene = Arc::new(super::generate("atrium", params)?);
            let references = Arc::new(ReferenceCache::default());
            for (variant, method) in &methods {
                points.push(Point {
                    variant: variant.clone(),
                    method: method.clone(),
                    scene: scene.clone(),
                    references: references.clone(),
                });
            }
        }
        let frames = options.frames;
        Ok((ScaleStudy { frames, note }, points))
    }

    fn label(&self, p: &Point) -> String {
        format!("{} lights: {}", p.scene.params.lights, p.method)
    }

    fn run(&self, gpu: &Gpu, composer: &Composer, p: &Point) -> Result<Vec<ScaleRow>, StudyError> {
        let cell = CellOptions {
            frames: Frames::exact(1, self.frames),
            stats: true,
            out: None,
            references: Some(&p.references),
            debug_view: None,
        };
        let (c, renderer) = run_scene_keeping_renderer(gpu, composer, &p.variant, &p.scene, cell)?;
        let r = &c.report;
        let ms = |name: &str| r.gpu_ms.get(name).and_then(|v| v.as_f64());
        let mut row = named(p);
        row.frame_ms = ms("total").unwrap_or(0.0);
        row.build_ms = build_ms(&renderer, self.frames)?;
        // `+ 0.0`: a sum of no passes is -0.0 (Rust's float sum starts there), shown "-0.0".
        row.assignment_ms = <crate::compose::ClusterPass as strum::IntoEnumIterator>::iter()
            .filter_map(|p| ms(p.into()))
            .sum::<f64>()
            + 0.0;
        row.shading_ms = renderer
            .shading_pass_names()
            .iter()
            .filter_map(|p| ms(p))
            .sum::<f64>()
            + 0.0;
        if let Some(s) = &r.stats {
            row.evaluations = s.light_evals;
            row.useful_evaluations = s.useful_light_evals;
            row.evaluations_per_useful = s.light_evals as f64 / s.useful_light_evals.max(1) as f64;
            row.list_bytes = s.cluster_bytes;
            let work = s.assignment_work.unwrap_or_default();
            row.light_tests = work.light_tests;
            row.node_tests = work.node_tests;
            row.entries_written = work.entries_written;
            row.lights_rejected = work.lights_rejected;
            row.tests_per_light = work.tests_per_light(row.lights as usize);
        }
        row.max_abs_8bit = r.error.as_ref().map_or(0, |e| e.max_abs_8bit);
        row.timing_source = r.timing_source.into();
        row.error = r.failure.clone();
        Ok(vec![row])
    }

    fn named(&self, p: &Point) -> ScaleRow {
        named(p)
    }

    fn table(&self, rows: &[ScaleRow]) -> Table {
        let mut t = table(rows);
        t.notes.extend(self.note.clone());
        t
    }

    fn plot(&self, rows: &[ScaleRow]) -> Option<Plot> {
        plot(rows)
    }
}

fn table(rows: &[ScaleRow]) -> Table {
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
            "of it BVH build",
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
            r.build_ms.map_or("-".into(), |b| sig(b, 3)),
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

/// The light BVH's build time, the median of `runs` (None for another method).
fn build_ms(renderer: &Renderer, runs: u32) -> Result<Option<f64>, StudyError> {
    let mut times = Vec::new();
    for _ in 0..runs.max(1) {
        match renderer.time_light_bvh_build()? {
            Some(ms) => times.push(ms),
            None => return Ok(None),
        }
    }
    Ok(Some(crate::measure::median(times)))
}

type Measure = fn(&ScaleRow) -> f64;

/// Frame and assignment time against the light count, log-log, one line per method.
fn plot(rows: &[ScaleRow]) -> Option<Plot> {
    let ok: Vec<&ScaleRow> = rows.iter().filter(|r| r.error.is_none()).collect();
    let mut counts: Vec<u32> = ok.iter().map(|r| r.lights).collect();
    counts.sort_unstable();
    counts.dedup();
    if counts.len() < 2 {
        return None;
    }
    // Every method in the order the rows first name it.
    let mut methods: Vec<String> = Vec::new();
    for r in &ok {
        if !methods.contains(&r.method) {
            methods.push(r.method.clone());
        }
    }
    let panel = |label, value: Measure| crate::plot::Panel {
        label,
        values: ok.iter().map(|r| value(r)).collect(),
        series: methods
            .iter()
            .map(|method| {
                let points = ok
                    .iter()
                    .filter(|r| r.method == *method && value(r) > 0.0)
                    .map(|r| (r.lights as f64, value(r)))
                    .collect();
                (method.as_str(), points)
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
