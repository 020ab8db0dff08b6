//! `clusterlab study msaa`: the default matrix's MSAA group (naive forward, Forward+ and
//! clustered deferred, tiled and two-level both ways) at every sample count the adapter
//! multisamples: frame and shading time, memory, light evaluations, edge pixels and error;
//! the deferred/forward time ratio per sample count beside Billeter, Olsson and Assarsson's
//! (GPU Pro 4, 2013: deferred about 0.8 of forward at 1x, forward 1.5-2x faster at 4x); and
//! the classified deferred resolve's evaluations against the (1 + 3e) bound.

use std::sync::Arc;

use serde::Serialize;

use super::{Reads, StudyError, StudyOptions};
use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::measure::Frames;
use crate::run::{CellOptions, run_scene};
use crate::scene::Scene;
use crate::table::Table;
use crate::variant::LoadedVariant;

/// Lights in every scene unless `--lights` says otherwise (GPU Pro 4 measured 1024).
pub const DEFAULT_LIGHTS: u32 = 1024;

/// The forward and deferred variant of each pair the ratio compares.
pub const PAIRS: [(&str, &str); 3] = [
    ("forward_plus", "clustered_deferred_16x16x24"),
    ("forward_plus_tiled", "clustered_deferred_tiled"),
    ("forward_plus_two_level", "clustered_deferred_two_level"),
];

/// One variant on one scene at one sample count.
#[derive(Clone, Debug, Default, Serialize)]
pub struct MsaaRow {
    pub scene: String,
    pub lights: u32,
    pub variant: String,
    pub samples: u32,
    /// Median whole frame, ms.
    pub frame_ms: f64,
    /// Median of the shading pass (forward, or the deferred resolve), ms.
    pub shading_ms: f64,
    /// Median of the raster passes (pre-pass, G-buffer, forward) and the sample resolve.
    pub raster_ms: f64,
    pub bytes_per_pixel: u32,
    pub evaluations: u64,
    /// Evaluations over those of the same variant with one sample.
    pub over_one_sample: Option<f64>,
    pub edge_fraction: f64,
    pub max_abs_8bit: u32,
    pub error: Option<String>,
}

super::outcome_in_error_field!(MsaaRow);

/// The study: every variant of the group at every sample count the adapter has, on each
/// scene.
pub struct MsaaStudy {
    /// The sample counts the adapter multisamples.
    counts: Vec<u32>,
    frames: u32,
}

/// One variant at one sample count on one scene.
pub struct Point {
    name: String,
    scene: Arc<Scene>,
    variant: LoadedVariant,
    samples: u32,
}

/// The row of a point, with no figures yet.
fn named(p: &Point) -> MsaaRow {
    MsaaRow {
        scene: p.name.clone(),
        lights: p.scene.params.lights,
        variant: p.variant.name.clone(),
        samples: p.samples,
        ..Default::default()
    }
}

impl super::Study for MsaaStudy {
    const NAME: &'static str = "msaa";
    const READS: &'static [Reads] = &[
        Reads::Scenes,
        Reads::Size,
        Reads::Lights,
        Reads::Frames,
        Reads::Variants,
    ];
    const ABOUT: &'static str = "Naive forward, Forward+ and clustered deferred (tiled and \
        two-level both ways) at every sample count the adapter multisamples, 1024 lights: \
        time, memory, edge pixels, and where deferred and forward cross over; every run \
        within 1 LSB (--scenes, --size, --lights, --frames; --variants: yours beside them)";
    type Point = Point;
    type Row = MsaaRow;

    fn plan(gpu: &Gpu, options: &StudyOptions) -> Result<(Self, Vec<Point>), StudyError> {
        let counts = gpu.multisample_counts();
        let mut variants = super::shipped(&crate::matrix::MSAA_GROUP)?;
        variants.extend(options.variants.iter().cloned());
        let mut points = Vec::new();
        for name in &options.scenes {
            for params in options.params_for(name, &[DEFAULT_LIGHTS])? {
                let scene = Arc::new(super::generate(name, params)?);
                for v in &variants {
                    for &samples in &counts {
                        let mut variant = v.clone();
                        variant.variant.msaa.samples = samples;
                        points.push(Point {
                            name: name.clone(),
                            scene: scene.clone(),
                            variant,
                            samples,
                        });
                    }
                }
            }
        }
        let frames = options.frames;
        Ok((MsaaStudy { counts, frames }, points))
    }

    fn label(&self, p: &Point) -> String {
        let lights = p.scene.params.lights;
        let (variant, samples) = (&p.variant.name, p.samples);
        format!("{} {lights} lights: {variant} at {samples} samples", p.name)
    }

    fn run(&self, gpu: &Gpu, composer: &Composer, p: &Point) -> Result<Vec<MsaaRow>, StudyError> {
        let options = CellOptions {
            frames: Frames::exact(1, self.frames),
            stats: true,
            ..Default::default()
        };
        let cell = run_scene(gpu, composer, &p.variant, &p.scene, options)?;
        let r = &cell.report;
        let ms = |pass: &str| r.gpu_ms.get(pass).and_then(|v| v.as_f64());
        let mut row = named(p);
        row.frame_ms = ms("total").unwrap_or(0.0);
        row.shading_ms = ms("forward").or(ms("resolve")).unwrap_or(0.0);
        row.raster_ms = ["depth_prepass", "gbuffer", "forward", "sample_resolve"]
            .iter()
            .filter_map(|p| ms(p))
            .sum();
        if let Some(s) = &r.stats {
            row.bytes_per_pixel = s.frame_bytes_per_pixel;
            row.evaluations = s.light_evals;
            row.edge_fraction = s.edge_fraction;
        }
        row.max_abs_8bit = r.error.as_ref().map_or(0, |e| e.max_abs_8bit);
        row.error = r.failure.clone();
        Ok(vec![row])
    }

    fn named(&self, p: &Point) -> MsaaRow {
        named(p)
    }

    /// Each run's evaluations over the same variant's with one sample.
    fn relate(&self, rows: &mut [MsaaRow]) {
        for i in 0..rows.len() {
            let one = rows
                .iter()
                .find(|o| {
                    let r = &rows[i];
                    (&o.scene, o.lights, &o.variant, o.samples)
                        == (&r.scene, r.lights, &r.variant, 1)
                        && o.error.is_none()
                })
                .map(|o| o.evaluations)
                .filter(|&n| n > 0);
            if rows[i].error.is_none() {
                rows[i].over_one_sample = one.map(|n| rows[i].evaluations as f64 / n as f64);
            }
        }
    }

    /// Within 1 LSB of its reference.
    fn keeps(&self, row: &MsaaRow, _: &[MsaaRow]) -> bool {
        row.max_abs_8bit <= 1
    }

    fn table(&self, rows: &[MsaaRow]) -> Table {
        table(rows, &self.counts)
    }
}

/// Deferred frame time over forward's, per scene, light count, pair and sample count.
pub fn ratios(rows: &[MsaaRow]) -> Vec<(String, u32, String, u32, f64)> {
    let frame = |of: &MsaaRow, variant: &str| {
        rows.iter()
            .find(|r| {
                (&r.scene, r.lights, r.variant.as_str(), r.samples)
                    == (&of.scene, of.lights, variant, of.samples)
            })
            .filter(|r| r.error.is_none() && r.frame_ms > 0.0)
            .map(|r| r.frame_ms)
    };
    let mut out = Vec::new();
    for r in rows.iter().filter(|r| r.variant == PAIRS[0].0) {
        for (forward, deferred) in PAIRS {
            if let (Some(f), Some(d)) = (frame(r, forward), frame(r, deferred)) {
                let (scene, deferred) = (r.scene.clone(), deferred.to_string());
                out.push((scene, r.lights, deferred, r.samples, d / f));
            }
        }
    }
    out
}

fn table(rows: &[MsaaRow], counts: &[u32]) -> Table {
    let mut t = Table::new(
        "MSAA: time, memory and evaluations of each pipeline per sample count",
        &[
            "scene",
            "lights",
            "variant",
            "samples",
            "frame ms",
            "shading ms",
            "raster ms",
            "B/px",
            "evaluations",
            "evals / 1x",
            "edge px",
            "1 + 3e",
            "max8",
        ],
    );
    for r in rows {
        let names = vec![
            r.scene.clone(),
            r.lights.to_string(),
            r.variant.clone(),
            r.samples.to_string(),
        ];
        if let Some(e) = &r.error {
            t.failed_row(names, e);
            continue;
        }
        let mut cells = names;
        cells.extend([
            format!("{:.1}", r.frame_ms),
            format!("{:.1}", r.shading_ms),
            format!("{:.1}", r.raster_ms),
            r.bytes_per_pixel.to_string(),
            r.evaluations.to_string(),
            r.over_one_sample.map_or("-".into(), |x| format!("{x:.3}")),
            format!("{:.1}%", 100.0 * r.edge_fraction),
            format!("{:.3}", 1.0 + 3.0 * r.edge_fraction),
            r.max_abs_8bit.to_string(),
        ]);
        t.row(cells);
    }
    for (scene, lights, deferred, samples, ratio) in ratios(rows) {
        t.notes.push(format!(
            "{scene}, {lights} lights, {deferred} / its forward pair at {samples}x: {ratio:.2} of the frame time (GPU Pro 4, GTX 480, 1024 lights: about 0.8 at 1x, 1.5-2 at 4x)"
        ));
    }
    t.notes.push(format!(
        "sample counts this adapter multisamples every target with: {counts:?}; evals / 1x of a deferred variant at 4 samples is its classified resolve's cost, bounded by 1 + 3e (e: edge pixels, shaded more than once)"
    ));
    t
}
