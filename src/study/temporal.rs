//! `clusterlab study temporal`: what a frame costs when lights move, by list strategy
//! (`clusters.update`): every strategy against the fraction of the lights that move, with
//! the camera still and moving, at 1024 and 16384 lights (or `--lights`) on the atrium:
//! the frame, the list passes, the shading, the lists' bytes and whether every checked
//! frame stayed exact. Beside Moreau, Pharr and Clarberg (HPG 2019: a refitted light BVH
//! about 100x faster to update than a rebuilt one, under 1 ms a frame) and Bevy (PR #22874:
//! reusing the last frame's cluster statistics made assignment 28% faster).

use std::sync::Arc;

use serde::Serialize;

use super::{Reads, StudyError, StudyOptions};
use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::reference::ReferenceCache;
use crate::scene::{Motion, SceneParams};
use crate::sequence::{SequenceSpec, scene_frames};
use crate::table::Table;
use crate::variant::LoadedVariant;

/// The scene the study runs on.
pub const SCENE: &str = "atrium";
/// Light counts unless `--lights` says otherwise.
pub const LIGHT_COUNTS: [u32; 2] = [1024, 16384];
/// Fractions of the lights that move.
pub const MOVING: [f32; 5] = [0.0, 0.01, 0.1, 0.5, 1.0];

/// Each strategy's variant and the rebuilding variant it is compared with: the sequence
/// group's (`matrix::SEQUENCE_REBUILDS`) and every shipped variant with another strategy.
pub const VARIANTS: [(&str, &str); 5] = [
    ("forward_plus", "forward_plus"),
    ("forward_plus_static_dynamic", "forward_plus"),
    ("forward_plus_patch", "forward_plus"),
    ("forward_plus_bvh", "forward_plus_bvh"),
    ("forward_plus_bvh_refit", "forward_plus_bvh"),
];

/// One strategy's sequence at one light count, camera and moving fraction.
#[derive(Clone, Debug, Default, Serialize)]
pub struct TemporalRow {
    pub lights: u32,
    pub camera_moves: bool,
    pub moving: f32,
    pub variant: String,
    pub update: String,
    /// The first frame (it builds everything), ms.
    pub first_ms: f64,
    /// The median frame after the first, ms, and [min, max].
    pub frame_ms: f64,
    pub frame_min_ms: f64,
    pub frame_max_ms: f64,
    /// Median list passes (assignment, moving lists, patch), ms.
    pub lists_ms: f64,
    /// Median shading passes (forward, the still image), ms.
    pub shading_ms: f64,
    /// This frame over the rebuilding variant's at the same point.
    pub vs_rebuild: Option<f64>,
    /// Bytes of cluster data on the GPU (lists, boxes, the strategy's own).
    pub list_bytes: u64,
    /// Frames after the first that ran no pass.
    pub frames_reused: u32,
    pub patch_rebuilds: u32,
    /// Every checked frame within 1 LSB and equal to the frame rendered from scratch.
    pub exact: bool,
    pub max_abs_8bit: u32,
    /// The worst checked frame's change against the reference's change, LSB.
    pub max_temporal_8bit: u32,
    pub error: Option<String>,
}

super::outcome_in_error_field!(TemporalRow);

/// The study: every strategy at every light count, camera and moving fraction, `frames`
/// frames after the first, the first and last checked.
pub struct TemporalStudy {
    spec: SequenceSpec,
}

/// One strategy's sequence at one point; the point's references serve every strategy.
pub struct Point {
    variant: LoadedVariant,
    params: SceneParams,
    references: Arc<ReferenceCache>,
}

/// The row of a point, with no figures yet.
fn named(p: &Point) -> TemporalRow {
    TemporalRow {
        lights: p.params.lights,
        camera_moves: p.params.motion.camera,
        moving: p.params.motion.lights,
        variant: p.variant.name.clone(),
        update: p.variant.variant.clusters().update.label().into(),
        ..Default::default()
    }
}

impl super::Study for TemporalStudy {
    const NAME: &'static str = "temporal";
    const READS: &'static [Reads] = &[Reads::Size, Reads::Lights, Reads::Frames];
    const ABOUT: &'static str = "Every list strategy for moving lights (rebuild, static and \
        dynamic lists, patch, BVH refit) against the fraction of lights moving (0 to 100%), \
        camera still and moving, at 1024 and 16384 lights on the atrium: a sequence of \
        --frames frames after the first for each, every checked frame exact (--size, \
        --lights, --frames)";
    type Point = Point;
    type Row = TemporalRow;

    fn plan(_gpu: &Gpu, options: &StudyOptions) -> Result<(Self, Vec<Point>), StudyError> {
        let names: Vec<&str> = VARIANTS.iter().map(|(v, _)| *v).collect();
        let variants = super::shipped(&names)?;
        let mut points = Vec::new();
        for at_count in options.params_for(SCENE, &LIGHT_COUNTS)? {
            for camera_moves in [false, true] {
                for &moving in &MOVING {
                    let references = Arc::new(ReferenceCache::default());
                    let params = SceneParams {
                        motion: Motion {
                            lights: moving,
                            camera: camera_moves,
                            still_at: at_count.time,
                        },
                        ..at_count
                    };
                    for v in &variants {
                        points.push(Point {
                            variant: v.clone(),
                            params,
                            references: references.clone(),
                        });
                    }
                }
            }
        }
        let frames = options.frames;
        let spec = SequenceSpec {
            frames: frames + 1,
            check_every: frames.max(1),
        };
        Ok((TemporalStudy { spec }, points))
    }

    fn label(&self, p: &Point) -> String {
        let (lights, motion) = (p.params.lights, p.params.motion);
        let camera = if motion.camera { "moving" } else { "still" };
        let moving = motion.lights * 100.0;
        format!(
            "{lights} lights, camera {camera}, {moving}% moving: {}",
            p.variant.name
        )
    }

    fn run(
        &self,
        gpu: &Gpu,
        composer: &Composer,
        p: &Point,
    ) -> Result<Vec<TemporalRow>, StudyError> {
        let frames = scene_frames(SCENE, p.params);
        let references = &p.references;
        let run = crate::sequence::run(gpu, composer, &p.variant, self.spec, &frames, references)?;
        let s = &run.report.summary;
        let ms = |passes: &[&str]| -> f64 {
            passes
                .iter()
                .filter_map(|p| s.pass_ms.get(*p).and_then(|v| v.as_f64()))
                .fold(0.0, |sum, ms| sum + ms)
        };
        let mut row = named(p);
        row.first_ms = s.first_ms;
        row.frame_ms = s.frame_ms;
        [row.frame_min_ms, row.frame_max_ms] = s.frame_ms_spread;
        row.lists_ms = ms(&["light_assign", "moving_assign", "list_patch"]);
        row.shading_ms = ms(&["forward", "still_shading"]);
        row.list_bytes = run.report.stats.as_ref().map_or(0, |st| st.cluster_bytes);
        row.frames_reused = s.frames_reused;
        row.patch_rebuilds = s.patch_rebuilds;
        row.exact = s.exact;
        row.max_abs_8bit = s.max_abs_8bit;
        row.max_temporal_8bit = s.max_temporal_8bit;
        row.error = run.report.failure.clone();
        Ok(vec![row])
    }

    fn named(&self, p: &Point) -> TemporalRow {
        named(p)
    }

    /// Each frame over its rebuilding variant's at the same point.
    fn relate(&self, rows: &mut [TemporalRow]) {
        for i in 0..rows.len() {
            let r = &rows[i];
            let base = VARIANTS
                .iter()
                .find(|(v, _)| *v == r.variant)
                .map(|(_, b)| *b);
            let rebuild = rows.iter().find(|o| {
                Some(o.variant.as_str()) == base
                    && (o.lights, o.camera_moves, o.moving) == (r.lights, r.camera_moves, r.moving)
                    && o.error.is_none()
                    && o.frame_ms > 0.0
            });
            rows[i].vs_rebuild = rebuild
                .filter(|_| rows[i].error.is_none())
                .map(|o| rows[i].frame_ms / o.frame_ms);
        }
    }

    /// Every checked frame exact.
    fn keeps(&self, row: &TemporalRow, _: &[TemporalRow]) -> bool {
        row.exact
    }

    fn table(&self, rows: &[TemporalRow]) -> Table {
        table(rows)
    }

    fn plot(&self, rows: &[TemporalRow]) -> Option<crate::plot::Plot> {
        plot(rows)
    }
}

/// The strategy with the fastest frame at each point where some light moves and the
/// camera is still, with its ratio to its rebuilding variant's.
pub fn best(rows: &[TemporalRow], lights: u32, moving: f32) -> Option<&TemporalRow> {
    rows.iter()
        .filter(|r| {
            r.error.is_none()
                && r.exact
                && !r.camera_moves
                && r.lights == lights
                && r.moving == moving
        })
        .min_by(|a, b| a.frame_ms.total_cmp(&b.frame_ms))
}

fn table(rows: &[TemporalRow]) -> Table {
    let mut t = Table::new(
        "Temporal: each list strategy's frame against the fraction of the lights that move",
        &[
            "lights",
            "camera",
            "moving",
            "variant",
            "update",
            "first ms",
            "frame ms",
            "[min, max]",
            "lists ms",
            "shading ms",
            "vs rebuild",
            "list KiB",
            "reused",
            "max8",
            "change8",
            "exact",
        ],
    );
    for r in rows {
        let names = vec![
            r.lights.to_string(),
            if r.camera_moves { "moving" } else { "still" }.into(),
            format!("{}%", r.moving * 100.0),
            r.variant.clone(),
            r.update.clone(),
        ];
        if let Some(e) = &r.error {
            t.failed_row(names, e);
            continue;
        }
        let mut cells = names;
        cells.extend([
            format!("{:.1}", r.first_ms),
            format!("{:.2}", r.frame_ms),
            format!("[{:.2}, {:.2}]", r.frame_min_ms, r.frame_max_ms),
            format!("{:.2}", r.lists_ms),
            format!("{:.2}", r.shading_ms),
            r.vs_rebuild.map_or("-".into(), |x| format!("{x:.2}")),
            (r.list_bytes / 1024).to_string(),
            r.frames_reused.to_string(),
            r.max_abs_8bit.to_string(),
            r.max_temporal_8bit.to_string(),
            if r.exact { "yes" } else { "no" }.into(),
        ]);
        t.row(cells);
    }
    let mut counts: Vec<u32> = rows.iter().map(|r| r.lights).collect();
    counts.dedup();
    for lights in counts {
        if let Some(b) = best(rows, lights, 0.1) {
            t.notes.push(format!(
                "{lights} lights, 10% moving, camera still: {} ({}) has the lowest median frame (points timed apart, no verdict), {:.2} ms, {} of its rebuilding variant's",
                b.variant,
                b.update,
                b.frame_ms,
                b.vs_rebuild.map_or("-".into(), |x| format!("{x:.2}"))
            ));
        }
    }
    t.notes.push(
        "Moreau, Pharr and Clarberg (HPG 2019) refit a light BVH about 100x faster than they rebuild it, within 6% of its error and under 1 ms a frame; Bevy (PR #22874) made cluster assignment 28% faster by reusing the last frame's statistics, then found it flickering with GPU clustering (PR #23439). No published figure patches a rasterised renderer's clusters against a rebuild: these are clusterlab's.".into(),
    );
    t.notes.push(
        "Times are medians of the frames after the first; frames on a software GPU measure CPU work: compare strategies within one run.".into(),
    );
    t
}

/// Frame time against the moving fraction, a series per strategy, a panel per light count
/// and camera.
fn plot(rows: &[TemporalRow]) -> Option<crate::plot::Plot> {
    use plotters::prelude::*;
    let ok: Vec<&TemporalRow> = rows.iter().filter(|r| r.error.is_none()).collect();
    let mut panels: Vec<(u32, bool)> = ok.iter().map(|r| (r.lights, r.camera_moves)).collect();
    panels.dedup();
    if panels.is_empty() {
        return None;
    }
    let names: Vec<&str> = VARIANTS.iter().map(|(v, _)| *v).collect();
    crate::plot::svg(
        "temporal.svg",
        "Temporal: frame time against the fraction of moving lights",
        (
            1100 + 2 * crate::plot::LEGEND_WIDTH,
            420 * panels.len().div_ceil(2) as u32,
        ),
        |area| {
            let cells = area.split_evenly((panels.len().div_ceil(2), 2));
            for (&(lights, camera_moves), cell) in panels.iter().zip(cells.iter()) {
                let here: Vec<&&TemporalRow> = ok
                    .iter()
                    .filter(|r| r.lights == lights && r.camera_moves == camera_moves)
                    .collect();
                let top = here.iter().map(|r| r.frame_ms).fold(0.0, f64::max) * 1.1 + 1e-3;
                let caption = format!(
                    "{lights} lights, camera {}",
                    if camera_moves { "moving" } else { "still" }
                );
                let mut chart = ChartBuilder::on(cell)
                    .caption(caption, (crate::plot::FONT, 16))
                    .margin(10)
                    .margin_right(crate::plot::LEGEND_WIDTH)
                    .x_label_area_size(36)
                    .y_label_area_size(60)
                    .build_cartesian_2d(0.0..100.0, 0.0..top)
                    .ok()?;
                chart
                    .configure_mesh()
                    .light_line_style(TRANSPARENT)
                    .x_desc("% of the lights moving")
                    .y_desc("frame ms")
                    .x_label_formatter(&crate::plot::tick_label)
                    .y_label_formatter(&crate::plot::tick_label)
                    .draw()
                    .ok()?;
                for (i, name) in names.iter().enumerate() {
                    let points = here
                        .iter()
                        .filter(|r| r.variant == *name)
                        .map(|r| (r.moving as f64 * 100.0, r.frame_ms))
                        .collect();
                    crate::plot::line_with_points(&mut chart, points, i)?;
                }
                crate::plot::legend(cell, &crate::plot::series_legend(&names))?;
            }
            Some(())
        },
    )
}
