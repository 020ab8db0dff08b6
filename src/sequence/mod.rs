//! Sequences (`clusterlab sequence`, `matrix --sequence`): frames that follow each other at
//! the scene's frame step (`scene::FRAME_DT`), the camera on its path or still, a fraction
//! of the lights moving. One renderer draws them all (`Renderer::advance`), reusing what did
//! not change (`Variant::reuse_unchanged`) and following the moving lights as
//! `clusters.update` says. Every frame is timed per pass; every k-th (and the first and
//! last) is checked: against its f64 reference, its change from the frame before against
//! the reference's change (popping and flicker), and against the same frame rendered from
//! scratch by a new renderer (bit for bit, and its light lists as sets), which no reuse may
//! change.

pub mod animation;
pub mod output;

use std::collections::BTreeSet;
use std::sync::Arc;
use std::time::Instant;

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use crate::compose::Composer;
use crate::cpu::frame::ReferenceFrame;
use crate::gpu::{AdapterSummary, Gpu};
use crate::measure::median;
use crate::metrics::{self, ErrorMetrics, TemporalError};
use crate::reference::ReferenceCache;
use crate::render::{FrameChange, FrameOutput, FrameStats, RenderError, Renderer};
use crate::run::{RunError, round3};
use crate::scene::{FRAME_DT, Scene, SceneError};
use crate::variant::{ListUpdate, LoadedVariant, Variant};

/// How long a sequence is and which of its frames are checked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SequenceSpec {
    /// Frames, at least 1, `FRAME_DT` apart.
    pub frames: u32,
    /// Every k-th frame (at least 1) is checked, and always the first and the last.
    pub check_every: u32,
}

impl SequenceSpec {
    /// Whether frame `i` is checked.
    pub fn checks(&self, i: u32) -> bool {
        i == 0 || i + 1 == self.frames || i.is_multiple_of(self.check_every.max(1))
    }

    /// Why the spec cannot run, if it cannot.
    pub fn problem(&self) -> Option<String> {
        if self.frames == 0 || self.frames > MAX_FRAMES {
            return Some(format!(
                "{} frames: a sequence has 1 to {MAX_FRAMES}",
                self.frames
            ));
        }
        (self.check_every == 0).then(|| "--check-every 0: check every k-th frame, k >= 1".into())
    }
}

/// Most frames a sequence may have (two minutes at the frame step).
pub const MAX_FRAMES: u32 = 3600;

/// Frame `i` of a sequence's scenes.
pub type Frames<'a> = dyn Fn(u32) -> Result<Scene, SceneError> + 'a;

/// The frames of scene `name` (built-in or a glTF file) from `params`: frame `i` at time
/// `params.time + i FRAME_DT`, what stands still where it was at the first frame.
pub fn scene_frames(
    name: &str,
    params: crate::scene::SceneParams,
) -> impl Fn(u32) -> Result<Scene, SceneError> + '_ {
    move |i| {
        let mut p = params;
        p.motion.still_at = params.time;
        p.time = params.time + i as f64 * FRAME_DT;
        crate::scene::generate(name, p)
    }
}

/// One frame of a sequence.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameRecord {
    pub frame: u32,
    /// Seconds.
    pub time: f64,
    /// Milliseconds of each pass the frame ran, and their sum as `total`.
    pub gpu_ms: Map<String, Value>,
    /// Passes it did not run: those no frame of the variant on this scene needs, and those
    /// whose work the frame before left valid.
    pub skipped: Vec<String>,
    /// Lights that moved since the frame before.
    pub moved_lights: u32,
    pub camera_moved: bool,
    /// CPU milliseconds of finding what changed and uploading it (`Renderer::advance`).
    pub advance_ms: f64,
    /// Checked frames: what the checks found.
    pub check: Option<FrameCheck>,
}

impl FrameRecord {
    pub fn total_ms(&self) -> f64 {
        self.gpu_ms
            .get("total")
            .and_then(Value::as_f64)
            .unwrap_or(0.0)
    }
}

/// What a checked frame's checks found.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameCheck {
    /// Against the frame's own f64 reference.
    pub error: ErrorMetrics,
    /// The change from the frame before against the reference's change (not for the first).
    pub temporal: Option<TemporalError>,
    /// The same frame rendered from scratch by a new renderer has the same HDR image bit for
    /// bit, and the same light lists as sets.
    pub equals_fresh: bool,
    /// The first difference from the fresh frame, when there is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub difference: Option<String>,
    /// The frame carries earlier frames' reservoirs (temporal reuse): a fresh renderer has
    /// none, so it is not compared with one (`equals_fresh` is then false, and no failure).
    #[serde(default)]
    pub carries_history: bool,
    /// Why the frame means nothing (NaN pixels, nothing in view), when it does not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
}

/// A sequence in figures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SequenceSummary {
    pub frames: u32,
    pub check_every: u32,
    /// Fraction of the lights that move, and whether the camera does.
    pub moving: f32,
    pub camera_moves: bool,
    /// The first frame's milliseconds (it builds everything).
    pub first_ms: f64,
    /// The median frame after the first, milliseconds, and [min, max].
    pub frame_ms: f64,
    pub frame_ms_spread: [f64; 2],
    /// Each pass's median over the frames after the first (0 in a frame that reused it).
    pub pass_ms: Map<String, Value>,
    /// Every frame's total milliseconds.
    pub totals_ms: Vec<f64>,
    /// Frames after the first that ran no pass: the frame before was still right.
    pub frames_reused: u32,
    pub checked_frames: u32,
    /// The worst checked frame's 8-bit error and temporal error.
    pub max_abs_8bit: u32,
    pub max_temporal_8bit: u32,
    /// The 8-bit RMSE of the first and last checked frames (a sampled loop's error, and
    /// with temporal reuse how far the frames took it).
    #[serde(default)]
    pub first_rmse_8bit: f64,
    #[serde(default)]
    pub last_rmse_8bit: f64,
    /// Every checked frame within 1 LSB of its reference and equal to its fresh frame.
    pub exact: bool,
    /// Patch frames that found no room and rebuilt every list instead.
    pub patch_rebuilds: u32,
}

/// What `clusterlab sequence --json` prints.
#[derive(Clone, Debug, Serialize)]
pub struct SequenceReport {
    pub variant: String,
    pub scene: String,
    pub adapter: AdapterSummary,
    pub size: [u32; 2],
    pub lights: u32,
    pub seed: u64,
    /// The first frame's time and the step between frames, seconds.
    pub start_s: f64,
    pub frame_step_s: f64,
    /// How the variant's lists follow the lights (`clusters.update`; none without clusters).
    pub update: Option<String>,
    /// Whether it reuses what did not change (`reuse_unchanged`).
    pub reuse_unchanged: bool,
    pub timing_source: &'static str,
    pub summary: SequenceSummary,
    pub frames: Vec<FrameRecord>,
    /// The last frame's exact counters.
    pub stats: Option<FrameStats>,
    /// The first checked frame that means nothing, or does not equal its fresh frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
}

/// A sequence's report, and what its outputs are made from.
pub struct SequenceRun {
    pub report: SequenceReport,
    /// The frames of the animation (at most `animation::ANIMATION_FRAMES`, evenly spread),
    /// each the 8-bit image made smaller (`animation::thumbnail`).
    pub animation: Vec<animation::Thumbnail>,
    /// The last frame and its reference.
    pub last: FrameOutput,
    pub last_reference: Arc<ReferenceFrame>,
    /// Milliseconds of the run: set-up and frames, checks (references and fresh frames).
    pub frames_ms: f64,
    pub checks_ms: f64,
}

/// Run `spec.frames` frames of `frames` with `variant`; the references come from (and go
/// into) `references`.
pub fn run(
    gpu: &Gpu,
    composer: &Composer,
    variant: &LoadedVariant,
    spec: SequenceSpec,
    frames: &Frames,
    references: &ReferenceCache,
) -> Result<SequenceRun, RunError> {
    if let Some(p) = spec.problem() {
        return Err(RunError::Scene(SceneError::BadParam(p)));
    }
    let first = frames(0)?;
    gpu.check_size(first.params.width, first.params.height)?;
    first.check()?;
    let v = &variant.variant;
    let (mut frames_ms, mut checks_ms) = (0.0, 0.0);
    let mut clock = Instant::now();
    let mut lap = |into: &mut f64| {
        *into += clock.elapsed().as_secs_f64() * 1e3;
        clock = Instant::now();
    };
    let mut renderer = Renderer::new(gpu, composer, v, &first)?;
    // Compiles what is new, untimed, and leaves no trace (`draw_without_lights`).
    renderer.draw_without_lights()?;
    let every = spec.frames.div_ceil(animation::ANIMATION_FRAMES).max(1);
    let mut records = Vec::with_capacity(spec.frames as usize);
    let mut animation = Vec::new();
    let mut timestamps = false;
    let mut failure = None;
    // The frame before: its scene and image.
    let mut before: Option<(Scene, FrameOutput)> = None;
    let mut last_reference = None;
    for i in 0..spec.frames {
        let scene = if i == 0 { first.clone() } else { frames(i)? };
        let started = Instant::now();
        let change = match &before {
            Some(_) => renderer.advance(&scene)?,
            None => FrameChange::default(),
        };
        let advance_ms = started.elapsed().as_secs_f64() * 1e3;
        let frame = renderer.render()?;
        // A frame that ran no pass has no timing source of its own.
        if !frame.timings.passes.is_empty() {
            timestamps = frame.timings.gpu_timestamps;
        }
        if i % every == 0 || i + 1 == spec.frames {
            animation.push(animation::thumbnail(&frame));
        }
        lap(&mut frames_ms);
        let check = if spec.checks(i) {
            let (reference, _) = references.get_or_compute(gpu, composer, variant, &scene)?;
            let check = check_frame(
                gpu,
                composer,
                variant,
                (&scene, &frame, &reference),
                before.as_ref(),
                &renderer,
                references,
            )?;
            last_reference = Some(reference);
            lap(&mut checks_ms);
            Some(check)
        } else {
            None
        };
        if failure.is_none()
            && let Some(c) = &check
        {
            failure = c
                .failure
                .clone()
                .or_else(|| c.difference.clone().filter(|_| !c.equals_fresh))
                .map(|why| format!("frame {i}: {why}"));
        }
        let mut gpu_ms = Map::new();
        gpu_ms.insert("total".into(), round3(frame.timings.total_ms()).into());
        for (name, ms) in &frame.timings.passes {
            gpu_ms.insert(name.clone(), round3(*ms).into());
        }
        records.push(FrameRecord {
            frame: i,
            time: scene.params.time,
            gpu_ms,
            skipped: frame.skipped.clone(),
            moved_lights: change.moved_lights.len() as u32,
            camera_moved: change.camera_moved,
            advance_ms: round3(advance_ms),
            check,
        });
        before = Some((scene, frame));
    }
    let (last_scene, last) = before.expect("a sequence has a frame");
    let last_reference = last_reference.expect("the last frame is checked");
    renderer.prepare_counting(composer, &last_scene);
    let stats = renderer.stats()?;
    lap(&mut checks_ms);
    let summary = summarize(&records, spec, &first, renderer.patch_rebuilds());
    let p = &first.params;
    let report = SequenceReport {
        variant: variant.name.clone(),
        scene: first.name.clone(),
        adapter: gpu.adapter.clone(),
        size: [p.width, p.height],
        lights: first.lights.len() as u32,
        seed: p.seed,
        start_s: p.time,
        frame_step_s: FRAME_DT,
        update: v
            .pipeline
            .is_clustered()
            .then(|| v.clusters().update.label().to_string()),
        reuse_unchanged: v.reuse_unchanged,
        timing_source: if timestamps {
            "gpu timestamps"
        } else {
            "wall clock"
        },
        summary,
        frames: records,
        stats: Some(stats),
        failure,
    };
    Ok(SequenceRun {
        report,
        animation,
        last,
        last_reference,
        frames_ms,
        checks_ms,
    })
}

/// Whether each frame after the first did what `v` does with what changed, and what each
/// ran: with the camera moved every list is built (Refit refits the BVH); with lights moved
/// and the camera still, Rebuild and Refit run light assignment, Patch patches (light
/// assignment only in the frames it found no room in, `patch_rebuilds`) and StaticDynamic
/// builds only the moving lists; with nothing changed and `reuse_unchanged`, no pass runs.
/// The test that a sequence's exactness is not a rebuild's.
pub fn followed(v: &Variant, r: &SequenceReport) -> (bool, String) {
    let ran = |f: &FrameRecord, pass: &str| f.gpu_ms.contains_key(pass);
    let update = v.pipeline.is_clustered().then(|| v.clusters().update);
    let later: Vec<&FrameRecord> = r.frames.iter().skip(1).collect();
    let assigned = later
        .iter()
        .filter(|f| !f.camera_moved && f.moved_lights > 0 && ran(f, "light_assign"))
        .count() as u32;
    let frame_ok = |f: &FrameRecord| {
        let changed = f.camera_moved || f.moved_lights > 0;
        if !changed {
            return !v.reuse_unchanged || f.gpu_ms.len() == 1;
        }
        match update {
            None => true,
            Some(_) if f.camera_moved => ran(f, "light_assign") && !ran(f, "list_patch"),
            Some(ListUpdate::Rebuild | ListUpdate::Refit) => ran(f, "light_assign"),
            Some(ListUpdate::Patch) => ran(f, "list_patch"),
            Some(ListUpdate::StaticDynamic) => ran(f, "moving_assign") && !ran(f, "light_assign"),
        }
    };
    let patched_alone = update != Some(ListUpdate::Patch) || assigned == r.summary.patch_rebuilds;
    let ok = later.iter().all(|f| frame_ok(f)) && patched_alone;
    let frames: Vec<String> = later
        .iter()
        .map(|f| {
            let names: Vec<&str> = f
                .gpu_ms
                .keys()
                .map(String::as_str)
                .filter(|n| *n != "total")
                .collect();
            let what = match (f.camera_moved, f.moved_lights) {
                (true, n) => format!("camera and {n} lights moved"),
                (false, 0) => "nothing moved".to_string(),
                (false, n) => format!("{n} lights moved"),
            };
            format!("frame {} ({what}): {}", f.frame, names.join(" "))
        })
        .collect();
    (
        ok,
        format!(
            "{} patch frames rebuilt for room; {}",
            r.summary.patch_rebuilds,
            frames.join("; ")
        ),
    )
}

/// Check a frame (its scene, image and reference) against its reference, its change from
/// the frame before against the reference's, and the frame rendered from scratch.
fn check_frame(
    gpu: &Gpu,
    composer: &Composer,
    variant: &LoadedVariant,
    (scene, frame, reference): (&Scene, &FrameOutput, &ReferenceFrame),
    before: Option<&(Scene, FrameOutput)>,
    renderer: &Renderer,
    references: &ReferenceCache,
) -> Result<FrameCheck, RunError> {
    let error = metrics::compare(frame, reference);
    let temporal = match before {
        Some((scene_before, frame_before)) => {
            let (reference_before, _) =
                references.get_or_compute(gpu, composer, variant, scene_before)?;
            Some(metrics::temporal(
                frame_before,
                frame,
                &reference_before,
                reference,
            ))
        }
        None => None,
    };
    let carries_history = variant
        .variant
        .shading
        .lights
        .sampling()
        .is_some_and(|s| s.reuses_frames())
        && before.is_some();
    let difference = if carries_history {
        None
    } else {
        fresh_difference(gpu, composer, variant, scene, frame, renderer)?
    };
    Ok(FrameCheck {
        failure: crate::run::meaningless(reference, Some(frame), None, Some(&error))
            .or_else(|| crate::run::inexact(&variant.variant, gpu, Some(&error))),
        error,
        temporal,
        equals_fresh: difference.is_none() && !carries_history,
        difference,
        carries_history,
    })
}

/// How `frame` (and `renderer`'s lists) differ from `scene` rendered from scratch by a new
/// renderer: the first pixel whose HDR bits differ, or the first cluster whose lights do
/// (as sets); None when they are the same.
fn fresh_difference(
    gpu: &Gpu,
    composer: &Composer,
    variant: &LoadedVariant,
    scene: &Scene,
    frame: &FrameOutput,
    renderer: &Renderer,
) -> Result<Option<String>, RenderError> {
    let v = &variant.variant;
    let mut fresh = Renderer::new(gpu, composer, v, scene)?;
    // With a depth range from the previous frame, the second frame's lists are built on
    // this picture's range, as a sequence's are once its view holds.
    let mut image = fresh.render()?;
    if v.range_from_previous_frame() {
        image = fresh.render()?;
    }
    let bits = |p: &[f32; 4]| p.map(f32::to_bits);
    if let Some(i) = (0..frame.hdr.len()).find(|&i| bits(&frame.hdr[i]) != bits(&image.hdr[i])) {
        let w = frame.width as usize;
        return Ok(Some(format!(
            "pixel ({}, {}) is {:?}, and {:?} in the same frame rendered from scratch",
            i % w,
            i / w,
            &frame.hdr[i][..3],
            &image.hdr[i][..3]
        )));
    }
    let (Some(held), Some(built)) = (renderer.cluster_lists()?, fresh.cluster_lists()?) else {
        return Ok(None);
    };
    for c in 0..held.counts.len() {
        let set = |lists: &crate::cpu::clusters::ClusterLists| -> BTreeSet<u32> {
            let first = lists.offsets[c] as usize;
            let end = first + lists.counts[c] as usize;
            lists
                .indices
                .get(first..end)
                .unwrap_or_default()
                .iter()
                .copied()
                .collect()
        };
        let (a, b) = (set(&held), set(&built));
        if a != b {
            let lingering: Vec<u32> = a.difference(&b).copied().collect();
            let missing: Vec<u32> = b.difference(&a).copied().collect();
            return Ok(Some(format!(
                "cluster {c}'s list holds lights {lingering:?} that a list built from scratch does not, and lacks {missing:?}"
            )));
        }
    }
    Ok(None)
}

/// The figures of a sequence's frames.
fn summarize(
    records: &[FrameRecord],
    spec: SequenceSpec,
    first: &Scene,
    patch_rebuilds: u32,
) -> SequenceSummary {
    let later: Vec<&FrameRecord> = records.iter().skip(1).collect();
    // Without later frames, the first is all there is.
    let steady: Vec<&FrameRecord> = if later.is_empty() {
        records.iter().collect()
    } else {
        later.clone()
    };
    let totals: Vec<f64> = steady.iter().map(|r| r.total_ms()).collect();
    let mut names: Vec<&str> = Vec::new();
    for r in &steady {
        for name in r.gpu_ms.keys() {
            if name != "total" && !names.contains(&name.as_str()) {
                names.push(name);
            }
        }
    }
    let mut pass_ms = Map::new();
    for name in names {
        let ms = steady
            .iter()
            .map(|r| r.gpu_ms.get(name).and_then(Value::as_f64).unwrap_or(0.0))
            .collect();
        pass_ms.insert(name.to_string(), round3(median(ms)).into());
    }
    let checks: Vec<&FrameCheck> = records.iter().filter_map(|r| r.check.as_ref()).collect();
    let motion = first.params.motion;
    SequenceSummary {
        frames: spec.frames,
        check_every: spec.check_every,
        moving: motion.lights,
        camera_moves: motion.camera,
        first_ms: records.first().map_or(0.0, FrameRecord::total_ms),
        frame_ms: round3(median(totals.clone())),
        frame_ms_spread: [
            totals.iter().copied().fold(f64::INFINITY, f64::min),
            totals.iter().copied().fold(0.0, f64::max),
        ],
        pass_ms,
        totals_ms: records.iter().map(FrameRecord::total_ms).collect(),
        frames_reused: later.iter().filter(|r| r.gpu_ms.len() == 1).count() as u32,
        checked_frames: checks.len() as u32,
        max_abs_8bit: checks
            .iter()
            .map(|c| c.error.max_abs_8bit)
            .max()
            .unwrap_or(0),
        max_temporal_8bit: checks
            .iter()
            .filter_map(|c| c.temporal.as_ref())
            .map(|t| t.max_abs_8bit)
            .max()
            .unwrap_or(0),
        first_rmse_8bit: checks.first().map_or(0.0, |c| c.error.rmse_8bit),
        last_rmse_8bit: checks.last().map_or(0.0, |c| c.error.rmse_8bit),
        exact: checks
            .iter()
            .all(|c| c.error.max_abs_8bit <= 1 && c.equals_fresh && c.failure.is_none()),
        patch_rebuilds,
    }
}
