//! One cell of work: a variant on a scene, rendered, measured against the CPU reference,
//! reported and written out.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;
use serde_json::{Map, Value};

use crate::compose::Composer;
use crate::cpu::frame::ReferenceFrame;
use crate::efficiency::Efficiency;
use crate::gpu::{AdapterSummary, Gpu, Timings};
use crate::measure::{
    CpuClock, DISTURBED_RETRIES, DISTURBED_SHARE, FrameCount, Frames, JUDGED_FRAME_MS, Stop,
    median, median_interval,
};
use crate::metrics::{self, ErrorMetrics};
use crate::reference::{ReferenceCache, ReferenceError, ReferenceJob};
use crate::render::{FrameOutput, FrameStats, RenderError, Renderer};
use crate::scene::{Scene, SceneError, SceneParams};
use crate::variant::{LoadedVariant, Variant};

/// What `clusterlab render --json` prints.
#[derive(Clone, Debug, Serialize)]
pub struct RenderReport {
    pub variant: String,
    pub scene: String,
    /// The file of a file scene and its SHA-256 (absent for a built-in scene).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scene_file: Option<crate::scene::SceneFile>,
    /// What the scene's loader left out or chose, and where the depth margin blunts
    /// z-culling (`margin_note`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub scene_notes: Vec<String>,
    pub adapter: AdapterSummary,
    pub size: [u32; 2],
    pub lights: u32,
    pub seed: u64,
    /// Milliseconds per pass (median over the timed frames), with their sum as `total`.
    pub gpu_ms: Map<String, Value>,
    /// [min, max] milliseconds per pass over the timed frames, `total` included.
    pub gpu_ms_spread: Map<String, Value>,
    /// [lo, hi]: each pass's confidence interval for its median, `total` included, at
    /// `interval_level` (`measure::median_interval`); empty with too few frames for one.
    pub gpu_ms_interval: Map<String, Value>,
    /// The probability that each interval holds its median (at least `measure::LEVEL`).
    pub interval_level: Option<f64>,
    /// "gpu timestamps", or "wall clock" (each pass submitted alone and waited for) on
    /// adapters without timestamp queries and on software adapters (see `gpu`).
    pub timing_source: &'static str,
    pub frames: u32,
    /// Untimed frames first, and whether the one timed frame was also a first draw.
    pub frame_count: FrameCount,
    /// Format of the HDR colour target (rgba32float, or rgba16float where not renderable).
    pub hdr_format: String,
    /// Wall-clock milliseconds of one frame, submission to completion (median).
    pub wall_ms: f64,
    /// Wall-clock milliseconds of the CPU f64 reference.
    pub reference_ms: f64,
    /// Error against the reference; `None` (not applicable) for a debug view, which shows
    /// no shaded scene to compare.
    pub error: Option<ErrorMetrics>,
    /// Exact counters from an instrumented run of the frame (absent with `stats: false`).
    pub stats: Option<FrameStats>,
    /// Distance from perfect culling, from the frame without lights, the frame and the
    /// counters (absent without counters).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub efficiency: Option<Efficiency>,
    /// CPU milliseconds spent in the frame outside the GPU (light assignment on the CPU).
    pub cpu_ms: Map<String, Value>,
    /// Passes of the variant the last timed frame did not need and did not run (bloom_blur
    /// there ran no workgroup: no pixel passed the threshold).
    pub skipped_passes: Vec<String>,
    /// Files written, when an output folder was given.
    pub images: Vec<PathBuf>,
    /// Where the cell's wall-clock time went.
    pub cost_ms: CellCost,
    /// The variant claims to be within `EXACT_LSB` of the reference on this adapter
    /// (`exact_claim`): a frame over it fails.
    pub exact_claim: bool,
    /// Why the frame means nothing, when it does not (NaN pixels, no geometry in view, no
    /// light evaluated where the reference is lit): the cell fails, whatever its error figures.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
}

/// Wall-clock milliseconds of each part of a cell: what a run spends, and where.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, serde::Deserialize)]
pub struct CellCost {
    /// Composing, compiling (or finding compiled) and allocating: the renderer's set-up.
    pub setup: f64,
    /// Every frame rendered for timing, untimed ones included, with their read-backs.
    pub frames: f64,
    /// The instrumented frame and its counters.
    pub counters: f64,
    /// The CPU reference and its raster truth (0 when an earlier cell computed it).
    pub reference: f64,
    /// Error metrics, images and debug views.
    pub images: f64,
}

/// Why a cell could not run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("{0}")]
    Scene(#[from] SceneError),
    #[error("{0}")]
    Render(#[from] RenderError),
    #[error("{0}")]
    Io(String),
    #[error("{0}")]
    Reference(ReferenceError),
}

impl From<ReferenceError> for RunError {
    /// A raster truth that could not be rendered fails (or is refused) as a frame does.
    fn from(e: ReferenceError) -> Self {
        match e {
            ReferenceError::Truth(e) => RunError::Render(e),
            shared => RunError::Reference(shared),
        }
    }
}

impl RunError {
    /// The adapter, or the limits chosen for it, lacks what the frame needs: a capability
    /// or a size, not a fault of the variant, the scene or the renderer.
    pub fn refused(&self) -> bool {
        matches!(
            self,
            RunError::Render(RenderError::Gpu(crate::gpu::GpuError::TooLarge(_)))
                | RunError::Render(RenderError::Limits(_))
        )
    }
}

impl From<crate::gpu::GpuError> for RunError {
    fn from(e: crate::gpu::GpuError) -> Self {
        RunError::Render(RenderError::Gpu(e))
    }
}

/// Everything a cell produced.
pub struct CellResult {
    pub report: RenderReport,
    pub frame: FrameOutput,
    pub reference: Arc<ReferenceFrame>,
    /// The debug view asked for in `CellOptions::debug_view`, 8-bit RGBA.
    pub debug: Option<Vec<[u8; 4]>>,
}

/// How to run a cell.
#[derive(Clone, Copy, Debug)]
pub struct CellOptions<'a> {
    /// Untimed and timed frames (an exact count, or by budget); pass times are medians
    /// over the timed ones.
    pub frames: Frames,
    /// Also run an instrumented frame for the exact counters.
    pub stats: bool,
    /// Folder for the image and its heat map.
    pub out: Option<&'a Path>,
    /// Share reference frames between cells that would compute the same one.
    pub references: Option<&'a ReferenceCache>,
    /// Also draw this debug view of the last timed frame (`CellResult::debug`).
    pub debug_view: Option<crate::variant::DebugView>,
}

impl Default for CellOptions<'_> {
    fn default() -> Self {
        Self {
            frames: Frames::exact(1, 1),
            stats: true,
            out: None,
            references: None,
            debug_view: None,
        }
    }
}

/// Render `variant` on scene `scene_name`, compare the last frame with the CPU reference,
/// count, and write its images.
pub fn run_cell(
    gpu: &Gpu,
    composer: &Composer,
    variant: &LoadedVariant,
    scene_name: &str,
    params: SceneParams,
    options: CellOptions<'_>,
) -> Result<CellResult, RunError> {
    gpu.check_size(params.width, params.height)?;
    let scene = crate::scene::generate(scene_name, params).map_err(RunError::Scene)?;
    run_scene(gpu, composer, variant, &scene, options)
}

/// Render `variant` on a scene made elsewhere (the stress cases build their own), compare
/// the last frame with the CPU reference, count, and write its images.
pub fn run_scene(
    gpu: &Gpu,
    composer: &Composer,
    variant: &LoadedVariant,
    scene: &Scene,
    options: CellOptions<'_>,
) -> Result<CellResult, RunError> {
    Ok(run_scene_keeping_renderer(gpu, composer, variant, scene, options)?.0)
}

/// [`run_scene`], and the renderer it ran, for checks that read what its frames left on
/// the GPU (the stress suite's lists and per-pixel counters).
pub fn run_scene_keeping_renderer<'g>(
    gpu: &'g Gpu,
    composer: &Composer,
    variant: &LoadedVariant,
    scene: &Scene,
    options: CellOptions<'_>,
) -> Result<(CellResult, Renderer<'g>), RunError> {
    let own_cache = ReferenceCache::default();
    let references = options.references.unwrap_or(&own_cache);
    let (half, renderer) = gpu_half(gpu, composer, variant, scene, options, references)?;
    let cell = finish_cell(half, references, variant, scene, options.out)?;
    Ok((cell, renderer))
}

/// A cell whose GPU work is done: its frames timed and counted, its reference's raster
/// truth read back. What remains (`finish_cell`) needs only the CPU, so a matrix runs it
/// beside the next cell's GPU work.
pub struct GpuHalf {
    /// Everything but the error, the judgement and the images.
    report: RenderReport,
    frame: FrameOutput,
    debug: Option<Vec<[u8; 4]>>,
    reference: ReferenceJob,
    /// The variant claims to be exact on this adapter (`exact_claim`).
    exact: bool,
}

/// The GPU half of a cell: set-up, timed frames, the debug view, the counters and the
/// reference's raster truth. `references` must finish this cell's job (`finish_cell`)
/// before any job begun after it.
pub fn gpu_half<'g>(
    gpu: &'g Gpu,
    composer: &Composer,
    variant: &LoadedVariant,
    scene: &Scene,
    options: CellOptions<'_>,
    references: &ReferenceCache,
) -> Result<(GpuHalf, Renderer<'g>), RunError> {
    let mut timing = Timing::start(gpu, composer, variant, scene, options.frames)?;
    while !timing.done() {
        timing.next_frame()?;
        // Alone, a cell has no verdict to wait for: its budget or frame cap ends it.
        if let Frames::Budget(budget) = options.frames
            && let Some(stop) = timing.spent(&budget)
        {
            timing.end(stop);
        }
    }
    timing.finish(composer, variant, scene, options, references)
}

/// A cell between its set-up and its counters: a renderer timing frames, one at a time, so
/// that the matrix can time a group's cells in interleaved rounds (`next_frame` on each in
/// turn) and drift of the machine hits each alike.
pub struct Timing<'g> {
    gpu: &'g Gpu,
    renderer: Renderer<'g>,
    policy: Frames,
    count: FrameCount,
    runs: Vec<FrameOutput>,
    /// Frames set aside as disturbed by other processes (`judged_frame`).
    disturbed: Vec<FrameOutput>,
    /// The frame without lights the efficiency is measured from (`efficiency`), timed after
    /// a first draw has compiled and touched what the frame uses.
    without_lights: Timings,
    untimed_ms: f64,
    cost: CellCost,
    /// The total of the last frame taken, kept or set aside.
    last_ms: Option<f64>,
}

impl<'g> Timing<'g> {
    /// Set the cell up and draw its untimed frames: `warmup` frames, or with frames by
    /// budget one without lights (`measure::Budget`); then the frame without lights.
    pub fn start(
        gpu: &'g Gpu,
        composer: &Composer,
        variant: &LoadedVariant,
        scene: &Scene,
        policy: Frames,
    ) -> Result<Self, RunError> {
        let params = scene.params;
        gpu.check_size(params.width, params.height)?;
        scene.check()?;
        let clock = Instant::now();
        let mut renderer = Renderer::new(gpu, composer, &variant.variant, scene)?;
        let mut cost = CellCost {
            setup: round3(clock.elapsed().as_secs_f64() * 1e3),
            ..Default::default()
        };
        let clock = Instant::now();
        let mut count = FrameCount::default();
        let mut untimed_ms = 0.0;
        match policy {
            Frames::Exact { warmup, .. } => {
                for _ in 0..warmup {
                    renderer.render()?;
                }
                count.warmup = warmup;
            }
            Frames::Budget(_) => {
                untimed_ms += renderer.draw_without_lights()?.total_ms();
                count.frame_without_lights = true;
            }
        }
        let without_lights = renderer.draw_without_lights()?;
        if count.frame_without_lights {
            untimed_ms += without_lights.total_ms();
        }
        cost.frames = clock.elapsed().as_secs_f64() * 1e3;
        Ok(Self {
            gpu,
            renderer,
            policy,
            count,
            runs: Vec::new(),
            disturbed: Vec::new(),
            without_lights,
            untimed_ms,
            cost,
            last_ms: None,
        })
    }

    /// Stop timing, for `why`. Every frame set aside as disturbed is kept when none was
    /// not (at least one frame is).
    pub fn end(&mut self, why: Stop) {
        if self.runs.is_empty() {
            self.runs = std::mem::take(&mut self.disturbed);
        }
        self.count.stop = Some(why);
    }

    /// Time again after `end`: a matrix group's leader changed, and this cell's verdict
    /// against the new one is open.
    pub fn resume(&mut self) {
        self.count.stop = None;
    }

    /// The last frame's total milliseconds, whether kept or set aside as disturbed: a
    /// round's frames are compared with each other, so a load that slows them all cancels.
    pub fn last_frame_ms(&self) -> Option<f64> {
        self.last_ms
    }

    /// Milliseconds of frames spent so far: untimed, kept and set aside.
    pub fn spent_ms(&self) -> f64 {
        let total = |f: &FrameOutput| f.timings.total_ms();
        self.untimed_ms
            + self.runs.iter().map(total).sum::<f64>()
            + self.disturbed.iter().map(total).sum::<f64>()
    }

    /// Frames timed so far (kept and set aside).
    pub fn frames_taken(&self) -> usize {
        self.runs.len() + self.disturbed.len()
    }

    /// Whether this cell has reached `budget`'s frame cap or budget (`Budget::spent`).
    pub fn spent(&self, budget: &crate::measure::Budget) -> Option<Stop> {
        let frames: Vec<f64> = self.runs.iter().map(|f| f.timings.total_ms()).collect();
        budget.spent(self.frames_taken(), median(frames), self.spent_ms())
    }

    /// Whether the cell has timed enough frames (`count.stop` says why).
    pub fn done(&self) -> bool {
        self.count.stop.is_some()
    }

    /// The device it times on.
    pub fn gpu(&self) -> &'g Gpu {
        self.gpu
    }

    /// Why it stopped timing, once it has.
    pub fn stop(&self) -> Option<Stop> {
        self.count.stop
    }

    /// Time one more frame. On a software adapter a long frame that other processes
    /// disturbed (`measure::CpuClock`) is set aside and another taken, up to
    /// `DISTURBED_RETRIES` more in all.
    pub fn next_frame(&mut self) -> Result<(), RenderError> {
        if self.done() {
            return Ok(());
        }
        let clock = Instant::now();
        let (frame, disturbed) = judged_frame(&mut self.renderer, self.gpu.software)?;
        self.cost.frames += clock.elapsed().as_secs_f64() * 1e3;
        self.last_ms = Some(frame.timings.total_ms());
        let retries = DISTURBED_RETRIES as usize;
        match self.policy {
            Frames::Exact { timed, .. } => {
                if disturbed && self.disturbed.len() < retries {
                    self.disturbed.push(frame);
                } else {
                    self.runs.push(frame);
                }
                if self.runs.len() >= timed.max(1) as usize {
                    self.count.stop = Some(Stop::Count);
                }
            }
            // The caller decides when a cell timed by budget stops (`end`): the matrix
            // by its group's verdicts, `gpu_half` by the budget alone.
            Frames::Budget(_) => {
                if disturbed {
                    self.disturbed.push(frame);
                } else {
                    self.runs.push(frame);
                }
            }
        }
        self.count.disturbed = self.disturbed.len() as u32;
        // Only the last frame's images are used (the error, the debug view): a group's
        // cells time side by side, so earlier frames keep their times alone.
        for frames in [&mut self.runs, &mut self.disturbed] {
            if let Some((_, earlier)) = frames.split_last_mut() {
                for f in earlier {
                    f.hdr = Vec::new();
                    f.ldr = Vec::new();
                }
            }
        }
        Ok(())
    }

    /// After the timed frames: the debug view, the counters and the reference's raster
    /// truth. `references` must finish this cell's job (`finish_cell`) before any job
    /// begun after it.
    pub fn finish(
        self,
        composer: &Composer,
        variant: &LoadedVariant,
        scene: &Scene,
        options: CellOptions<'_>,
        references: &ReferenceCache,
    ) -> Result<(GpuHalf, Renderer<'g>), RunError> {
        let Timing {
            gpu,
            mut renderer,
            mut count,
            mut runs,
            without_lights,
            mut cost,
            ..
        } = self;
        count.timed = runs.len() as u32;
        let params = scene.params;
        let mut clock = Instant::now();
        let mut lap = || {
            let ms = clock.elapsed().as_secs_f64() * 1e3;
            clock = Instant::now();
            round3(ms)
        };
        cost.frames = round3(cost.frames);
        let frame_count = count;
        // A debug view is an extra: a cell whose view cannot be drawn still has its figures.
        let debug = options
            .debug_view
            .and_then(|view| renderer.debug_image(composer, view).ok());
        let wall_ms = median(runs.iter().map(|f| f.wall_ms).collect());
        let timings = median_timings(&runs);
        let gpu_ms_spread = spread(&runs, &timings);
        let (gpu_ms_interval, interval_level) = intervals(&runs, &timings);
        let runs_total_ms: Vec<f64> = runs.iter().map(|r| r.timings.total_ms()).collect();
        let frame = runs.pop().expect("at least one frame");
        let mut cpu_ms = Map::new();
        if let Some(ms) = frame.cpu_assign_ms {
            cpu_ms.insert("light_assign".into(), round3(ms).into());
        }
        let stats = options
            .stats
            .then(|| {
                renderer.prepare_counting(composer, scene);
                renderer.stats()
            })
            .transpose()?;
        cost.counters = lap();
        // Last: nothing after it may fail, so the job it begins is always finished.
        let reference = references.begin(gpu, composer, variant, scene)?;
        cost.reference = lap();
        let mut gpu_ms = Map::new();
        // The median of the frames' totals, not the sum of the passes' medians: a sum of
        // medians of different frames can lie outside every frame's total (it did: 6.9 ms
        // against frames of 7.6-13.2 ms), and the spread beside it is of the totals.
        let interval = median_interval(&runs_total_ms);
        let total = median(runs_total_ms);
        gpu_ms.insert("total".into(), round3(total).into());
        let efficiency = stats.as_ref().and_then(|s| {
            let shading = renderer.shading_pass_names();
            let counts = (s.light_evals, s.useful_light_evals);
            Efficiency::of(
                (total, interval),
                &timings,
                &without_lights,
                &shading,
                counts,
            )
        });
        for (name, ms) in &timings.passes {
            gpu_ms.insert(name.clone(), round3(*ms).into());
        }
        let report = RenderReport {
            variant: variant.name.clone(),
            scene: scene.name.clone(),
            scene_file: scene.file.clone(),
            scene_notes: scene
                .notes
                .iter()
                .cloned()
                .chain(margin_note(&variant.variant, scene))
                .collect(),
            adapter: gpu.adapter.clone(),
            size: [params.width, params.height],
            lights: scene.lights.len() as u32,
            seed: params.seed,
            gpu_ms,
            gpu_ms_spread,
            gpu_ms_interval,
            interval_level,
            timing_source: if timings.gpu_timestamps {
                "gpu timestamps"
            } else {
                "wall clock"
            },
            frames: frame_count.timed,
            frame_count,
            hdr_format: format!("{:?}", gpu.hdr_format).to_lowercase(),
            wall_ms: round3(wall_ms),
            reference_ms: 0.0,
            error: None,
            stats,
            efficiency,
            cpu_ms,
            skipped_passes: frame.skipped.clone(),
            images: Vec::new(),
            cost_ms: cost,
            exact_claim: exact_claim(&variant.variant, gpu),
            failure: None,
        };
        let half = GpuHalf {
            exact: report.exact_claim,
            report,
            frame,
            debug,
            reference,
        };
        Ok((half, renderer))
    }
}

/// The CPU half of a cell: its reference shaded in f64 (or taken from the cell that
/// shaded it), the error against it, the judgement and, with `out`, its images.
pub fn finish_cell(
    half: GpuHalf,
    references: &ReferenceCache,
    variant: &LoadedVariant,
    scene: &Scene,
    out: Option<&Path>,
) -> Result<CellResult, RunError> {
    let GpuHalf {
        mut report,
        frame,
        debug,
        reference,
        exact,
    } = half;
    let start = Instant::now();
    let (reference, reference_ms) = references.finish(reference, variant, scene)?;
    report.reference_ms = round3(reference_ms);
    report.cost_ms.reference += round3(start.elapsed().as_secs_f64() * 1e3);
    let start = Instant::now();
    let shaded = variant.variant.debug_view == crate::variant::DebugView::Off;
    report.error = shaded.then(|| metrics::compare(&frame, &reference));
    let error = report.error.as_ref();
    report.failure = meaningless(&reference, Some(&frame), report.stats.as_ref(), error)
        .or_else(|| inexact_figures(exact, error));
    if let Some(dir) = out {
        report.images = write_images(
            dir,
            &safe_file_name(&format!("{}@{}", variant.name, scene.name)),
            &frame,
            &reference,
        )?;
    }
    report.cost_ms.images = round3(start.elapsed().as_secs_f64() * 1e3);
    Ok(CellResult {
        report,
        frame,
        reference,
        debug,
    })
}

/// A margin over which the note below speaks: a sample at the far plane marks its depth
/// +-10%, more than an exponential slice of a 24-slice grid over a far/near of 1000 (29%
/// per slice there, but 3% at 256 slices).
pub const WIDE_MARGIN: f64 = 0.1;

/// Where the depth margin the marking passes must allow (`cpu::clusters::depth_margin`)
/// blunts z-culling for `variant` on `scene`: with standard depth it grows as (far -
/// near) / near, so a sample at the far plane marks every slice of [z (1 - m), z (1 + m)],
/// all of them from the near plane once m reaches 1. Says how wide, and that reversed depth
/// keeps the margin under 0.2% whatever the planes; None where the variant reads no depth
/// to mark or the margin stays under [`WIDE_MARGIN`].
pub fn margin_note(variant: &Variant, scene: &Scene) -> Option<String> {
    let v = variant;
    let marks = crate::compose::reads_visible_depths(v)
        || (v.pipeline.is_clustered() && v.clusters().culling.marks_depth_cells());
    if !marks {
        return None;
    }
    let (near, far) = (scene.camera.near, scene.camera.far);
    let reversed = v.depth.mapping().reversed;
    let unorm24 = v.depth.format == crate::common::DepthFormat::Unorm24;
    let m = crate::cpu::clusters::depth_margin(far, near, reversed, unorm24);
    (m >= WIDE_MARGIN).then(|| {
        let reach = if m >= 1.0 {
            "every slice from the near plane to there: z-culling is off for it".to_string()
        } else {
            format!("every slice from {:.3} to {:.3} of its depth", 1.0 - m, 1.0 + m)
        };
        let remedy = match (reversed, unorm24) {
            (false, false) => "reversed depth (`depth: (reversed_z: true)`)",
            (false, true) => "reversed 32-bit float depth (`depth: (format: Float32, reversed_z: true)`)",
            (true, _) => "32-bit float depth (`depth: (format: Float32)`)",
        };
        let size = if m < 1.0 {
            format!("{:.0}% of the depth", m * 100.0)
        } else {
            format!("{m:.1e} times the depth")
        };
        format!(
            "the depth margin at the far plane is {size} ({} depth, {}, far/near = {:.1e}): a sample there marks {reach}; {remedy} keeps the margin under 0.2% whatever the planes",
            if reversed { "reversed" } else { "standard" },
            if unorm24 { "24-bit" } else { "32-bit float" },
            far / near,
        )
    })
}

/// Why a frame measures nothing, if it does not: a score for it would look perfect or
/// plausible and mean nothing. Pixels that are not finite; a view with no geometry in it (a
/// camera looking away, a near plane beyond the scene); an image all black where the
/// reference shows something (whatever lost the light: a list, a skipped pass, a pipeline);
/// and no light evaluated at all where the reference is lit (light lists that lost every
/// light). `frame` and `error` are absent for a debug view, which shades no scene.
pub fn meaningless(
    reference: &ReferenceFrame,
    frame: Option<&FrameOutput>,
    stats: Option<&FrameStats>,
    error: Option<&ErrorMetrics>,
) -> Option<String> {
    if let Some(e) = error
        && e.nan_pixels > 0
    {
        return Some(format!(
            "{} pixels of the image are NaN or infinite",
            e.nan_pixels
        ));
    }
    if reference.covered == 0 {
        return Some(
            "no geometry is in view (the camera looks away from the scene, or its near plane lies beyond it): a frame of nothing measures nothing"
                .into(),
        );
    }
    let shown = |rgb: &[u8]| rgb.iter().any(|&c| c > 0);
    let reference_shown = reference.ldr.iter().filter(|p| shown(&p[..])).count();
    if let Some(f) = frame
        && error.is_some()
        && reference_shown > 0
        && !f.ldr.iter().any(|p| shown(&p[..3]))
    {
        return Some(format!(
            "the image is all black, yet {reference_shown} pixels of the reference are not: the frame lost what lights it"
        ));
    }
    if let Some(s) = stats
        && s.light_evals == 0
        && reference.lit > 0
    {
        return Some(format!(
            "no light was evaluated, yet {} pixels are lit in the reference: the frame lost every light",
            reference.lit
        ));
    }
    None
}

/// Why an exact variant's frame is not exact, if it is not: an 8-bit error over the 1 LSB
/// that single-precision shading and rounding allow (`exact_claim`).
pub fn inexact(variant: &Variant, gpu: &Gpu, error: Option<&ErrorMetrics>) -> Option<String> {
    inexact_figures(exact_claim(variant, gpu), error)
}

/// [`inexact`] for a variant whose claim is known.
fn inexact_figures(exact: bool, error: Option<&ErrorMetrics>) -> Option<String> {
    let e = error?;
    // With shadows, a pixel's ambiguous pairs widen its range (`metrics::ShadowError`);
    // past a small share of them the check would pass a frame whatever its shadows.
    if let Some(s) = &e.shadows {
        if exact && s.ambiguous_share > MAX_AMBIGUOUS_SHARE {
            return Some(format!(
                "too ambiguous to check: {:.3}% of its shadow rays ({} of {}) lie within the GPU's error of an occluder's edge or surface, over the {:.1}% an exactness check allows (either answer would pass there)",
                100.0 * s.ambiguous_share,
                s.ambiguous,
                s.pairs,
                100.0 * MAX_AMBIGUOUS_SHARE
            ));
        }
        return (exact && s.max_outside_ambiguity_8bit > EXACT_LSB).then(|| {
            format!(
                "max {} LSB against the reference outside the {} pixels its {} ambiguous shadow rays allow more: an exact variant is within {EXACT_LSB} LSB there",
                s.max_outside_ambiguity_8bit, s.ambiguous_pixels, s.ambiguous
            )
        });
    }
    (exact && e.max_abs_8bit > EXACT_LSB).then(|| {
        format!(
            "max {} LSB against the reference, {} pixels over {EXACT_LSB} LSB: an exact variant is within {EXACT_LSB} LSB",
            e.max_abs_8bit, e.pixels_over_1lsb
        )
    })
}

/// The most ambiguous shadow rays an exact variant's frame may have, as a share of its
/// rays, for its exactness to be checked at all: an ambiguous pair's pixel passes with the
/// light in or out, so a frame whose rays are all ambiguous passes with no occlusion. The
/// built-in scenes and an exported glTF stay under it (`tests/shadows.rs`).
pub const MAX_AMBIGUOUS_SHARE: f64 = 1e-3;

/// The 8-bit error an exact variant's frame may have: one step of rounding (the f32
/// shading's against the f64 reference's, both then rounded to 8 bits).
pub const EXACT_LSB: u32 = 1;

/// Whether `variant` claims to be exact on `gpu`, within [`EXACT_LSB`] of the reference:
/// every light of every list evaluated and every shadow ray traced (not sampled, no cap that drops lights and counts
/// them), a shaded image (not a debug view), normals packed in 32 bits or more where a
/// G-buffer holds them, and no Compact layout multisampled (it shades a sample on the pixel
/// centre's ray) or with GGX (roughness and metallic in 8 bits move a highlight: 3 LSB on
/// the stage); scissor deferred's blended sum only where the adapter adds without rounding
/// (`gpu::expect`). Motion blur is not claimed either: each tap's texel is chosen from a
/// velocity in single precision, and one that lands beside the reference's changes the
/// pixel (6 LSB on one pixel of the atrium in the default matrix); nor toon post-processing
/// where the HDR target is not 32-bit float: its bands cut a value the target rounded to
/// 11 bits (48 and 57 LSB through OpenGL's 16-bit target).
pub fn exact_claim(variant: &Variant, gpu: &Gpu) -> bool {
    use crate::gpu::expect;
    use crate::variant::{DebugView, GBufferLayout, LightLists, Pipeline, ShadingModel};
    let v = variant;
    let capped =
        v.pipeline.is_clustered() && matches!(v.clusters().lists, LightLists::Capped { .. });
    let deferred = v.pipeline.is_deferred();
    let compact = deferred && v.gbuffer().layout == GBufferLayout::Compact;
    let compact_lossy = compact && (v.msaa.on() || v.shading.model == ShadingModel::Ggx);
    let lossy_normals = deferred && v.normal_codec().bits() < 32;
    let rounded_sum = v.pipeline == Pipeline::DeferredScissor
        && expect::allowance(gpu, expect::Check::BlendedLightSum).is_some();
    let toon_on_rounded =
        v.post.toon.is_some() && gpu.hdr_format != wgpu::TextureFormat::Rgba32Float;
    v.shading.lights.sampling().is_none()
        && v.shading.shadows.sampling().is_none()
        && !capped
        && v.debug_view == DebugView::Off
        && !compact_lossy
        && v.post.motion_blur.is_none()
        && !lossy_normals
        && !rounded_sum
        && !toon_on_rounded
}

/// One timed frame, and whether other processes disturbed it: on a `software` adapter, a
/// frame of at least `JUDGED_FRAME_MS` during which they took more than `DISTURBED_SHARE`
/// of the machine's CPU time.
fn judged_frame(
    renderer: &mut Renderer<'_>,
    software: bool,
) -> Result<(FrameOutput, bool), RenderError> {
    let before = CpuClock::now();
    let frame = renderer.render()?;
    let others = before
        .zip(CpuClock::now())
        .and_then(|(a, b)| a.others_share(&b));
    let disturbed = software
        && frame.timings.total_ms() >= JUDGED_FRAME_MS
        && others.is_some_and(|s| s > DISTURBED_SHARE);
    Ok((frame, disturbed))
}

/// `text` as a file name: characters other than letters, digits and `_-.@=` become `_`
/// (a file scene's name is a path).
pub fn safe_file_name(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "_-.@=".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

pub fn round3(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}

/// [min, max] of each pass of `medians` (and of the total) over the frames.
fn spread(runs: &[FrameOutput], medians: &Timings) -> Map<String, Value> {
    let range = |samples: Vec<f64>| {
        let min = samples.iter().copied().fold(f64::INFINITY, f64::min);
        let max = samples.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Value::from(vec![round3(min), round3(max)])
    };
    let mut out = Map::new();
    out.insert(
        "total".into(),
        range(runs.iter().map(|r| r.timings.total_ms()).collect()),
    );
    for (name, _) in &medians.passes {
        out.insert(
            name.clone(),
            range(runs.iter().map(|r| r.timings.get(name)).collect()),
        );
    }
    out
}

/// The interval at `measure::LEVEL` of each pass of `medians` (and of the total) over the
/// frames, and its level; empty (and None) where the frames are too few for one.
fn intervals(runs: &[FrameOutput], medians: &Timings) -> (Map<String, Value>, Option<f64>) {
    let mut out = Map::new();
    let totals: Vec<f64> = runs.iter().map(|r| r.timings.total_ms()).collect();
    let Some(total) = median_interval(&totals) else {
        return (out, None);
    };
    let pair = |i: crate::measure::Interval| Value::from(vec![round3(i.lo), round3(i.hi)]);
    out.insert("total".into(), pair(total));
    for (name, _) in &medians.passes {
        let samples: Vec<f64> = runs.iter().map(|r| r.timings.get(name)).collect();
        if let Some(i) = median_interval(&samples) {
            out.insert(name.clone(), pair(i));
        }
    }
    (out, Some(total.level))
}

/// Per-pass medians over several frames, by pass name in order of first appearance. A pass
/// a frame skipped (cluster bounds that are still valid) counts as 0 ms in that frame.
fn median_timings(runs: &[FrameOutput]) -> Timings {
    let mut names: Vec<&str> = Vec::new();
    for r in runs {
        for (n, _) in &r.timings.passes {
            if !names.contains(&n.as_str()) {
                names.push(n);
            }
        }
    }
    let passes = names
        .iter()
        .map(|&name| {
            let samples = runs.iter().map(|r| r.timings.get(name)).collect();
            (name.to_string(), median(samples))
        })
        .collect();
    Timings {
        passes,
        gpu_timestamps: runs.first().is_some_and(|r| r.timings.gpu_timestamps),
    }
}

/// Write `STEM.png` (the image) and `STEM.heat.png` (its error heat map) into `dir`.
pub fn write_images(
    dir: &Path,
    stem: &str,
    frame: &FrameOutput,
    reference: &ReferenceFrame,
) -> Result<Vec<PathBuf>, RunError> {
    crate::files::write::create_folder(dir).map_err(RunError::Io)?;
    let rgb: Vec<u8> = frame.ldr.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
    let image_path = dir.join(format!("{stem}.png"));
    let heat_path = dir.join(format!("{stem}.heat.png"));
    write_png(&image_path, frame.width, frame.height, &rgb)?;
    write_png(
        &heat_path,
        frame.width,
        frame.height,
        &metrics::heat_map(frame, reference),
    )?;
    Ok(vec![image_path, heat_path])
}

/// Write an RGB8 PNG (through `files::write_file`: whole or not at all).
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), RunError> {
    use image::ImageEncoder;
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| RunError::Io(format!("{}: cannot encode: {e}", path.display())))?;
    crate::files::write_file(path, &png).map_err(RunError::Io)
}
