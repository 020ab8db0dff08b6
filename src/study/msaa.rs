//! `clusterlab study msaa`: the default matrix's MSAA group (naive forward, Forward+ and
//! clustered deferred, tiled and two-level both ways) at every sample count the adapter
//! multisamples: frame and shading time, memory, light evaluations, edge pixels and error;
//! the deferred/forward time ratio per sample count beside Billeter, Olsson and Assarsson's
//! (GPU Pro 4, 2013: deferred about 0.8 of forward at 1x, forward 1.5-2x faster at 4x); and
//! the classified deferred resolve's evaluations against the (1 + 3e) bound.

use serde::Serialize;

use super::{StudyError, Table};
use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::measure::Frames;
use crate::run::{CellOptions, run_scene};
use crate::scene::SceneParams;
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
#[derive(Clone, Debug, Serialize)]
pub struct MsaaRow {
    pub scene: String,
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

/// The shipped variants `names` (`variants/NAME.ron`).
pub(super) fn shipped(names: &[&str]) -> Result<Vec<LoadedVariant>, StudyError> {
    names
        .iter()
        .map(|name| {
            let path = std::path::PathBuf::from(format!("variants/{name}.ron"));
            crate::variant::load(&path).map_err(|e| StudyError::Usage(e.to_string()))
        })
        .collect()
}

/// Run every variant of the group at every sample count the adapter has, on each scene
/// (at `size`, with `lights` or `DEFAULT_LIGHTS`).
pub fn run(
    gpu: &Gpu,
    composer: &Composer,
    scenes: &[&str],
    size: (u32, u32),
    lights: Option<u32>,
    frames: u32,
) -> Result<Vec<MsaaRow>, StudyError> {
    let counts = gpu.multisample_counts();
    let variants = shipped(&crate::matrix::MSAA_GROUP)?;
    let mut rows = Vec::new();
    for &name in scenes {
        let defaults =
            crate::scene::defaults(name).map_err(|e| StudyError::Usage(e.to_string()))?;
        let params = SceneParams {
            width: size.0,
            height: size.1,
            lights: lights.unwrap_or(DEFAULT_LIGHTS),
            ..defaults
        };
        let scene =
            crate::scene::generate(name, params).map_err(|e| StudyError::Usage(e.to_string()))?;
        for v in &variants {
            let mut one_sample_evals = None;
            for &samples in &counts {
                let mut loaded = v.clone();
                loaded.variant.msaa.samples = samples;
                let mut row = MsaaRow {
                    scene: name.to_string(),
                    variant: v.name.clone(),
                    samples,
                    frame_ms: 0.0,
                    shading_ms: 0.0,
                    raster_ms: 0.0,
                    bytes_per_pixel: 0,
                    evaluations: 0,
                    over_one_sample: None,
                    edge_fraction: 0.0,
                    max_abs_8bit: 0,
                    error: None,
                };
                let options = CellOptions {
                    frames: Frames::exact(1, frames),
                    stats: true,
                    ..Default::default()
                };
                // One failing run is reported in its row; the others go on.
                match run_scene(gpu, composer, &loaded, &scene, options) {
                    Ok(cell) => {
                        let r = &cell.report;
                        let ms = |pass: &str| r.gpu_ms.get(pass).and_then(|v| v.as_f64());
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
                        if samples == 1 {
                            one_sample_evals = Some(row.evaluations);
                        }
                        row.over_one_sample = one_sample_evals
                            .filter(|&n| n > 0)
                            .map(|n| row.evaluations as f64 / n as f64);
                        row.max_abs_8bit = r.error.as_ref().map_or(0, |e| e.max_abs_8bit);
                        row.error = cell.report.failure.clone();
                    }
                    Err(e) => row.error = Some(e.to_string()),
                }
                rows.push(row);
            }
        }
    }
    Ok(rows)
}

/// True when every run finished within 1 LSB of its reference.
pub fn all_exact(rows: &[MsaaRow]) -> bool {
    rows.iter()
        .all(|r| r.error.is_none() && r.max_abs_8bit <= 1)
}

/// Deferred frame time over forward's, per scene, pair and sample count.
pub fn ratios(rows: &[MsaaRow]) -> Vec<(String, String, u32, f64)> {
    let frame = |scene: &str, variant: &str, samples: u32| {
        rows.iter()
            .find(|r| r.scene == scene && r.variant == variant && r.samples == samples)
            .filter(|r| r.error.is_none() && r.frame_ms > 0.0)
            .map(|r| r.frame_ms)
    };
    let mut out = Vec::new();
    for r in rows.iter().filter(|r| r.variant == PAIRS[0].0) {
        for (forward, deferred) in PAIRS {
            if let (Some(f), Some(d)) = (
                frame(&r.scene, forward, r.samples),
                frame(&r.scene, deferred, r.samples),
            ) {
                out.push((r.scene.clone(), deferred.to_string(), r.samples, d / f));
            }
        }
    }
    out
}

pub fn table(rows: &[MsaaRow], counts: &[u32]) -> Table {
    let mut t = Table::new(
        "MSAA: time, memory and evaluations of each pipeline per sample count",
        &[
            "scene",
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
        let names = vec![r.scene.clone(), r.variant.clone(), r.samples.to_string()];
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
    for (scene, deferred, samples, ratio) in ratios(rows) {
        t.notes.push(format!(
            "{scene}, {deferred} / its forward pair at {samples}x: {ratio:.2} of the frame time (GPU Pro 4, GTX 480, 1024 lights: about 0.8 at 1x, 1.5-2 at 4x)"
        ));
    }
    t.notes.push(format!(
        "sample counts this adapter multisamples every target with: {counts:?}; evals / 1x of a deferred variant at 4 samples is its classified resolve's cost, bounded by 1 + 3e (e: edge pixels, shaded more than once)"
    ));
    t
}
