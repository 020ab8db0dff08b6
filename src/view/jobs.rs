//! The viewer's slow work, on a thread of its own so the window stays live: the shown
//! frame's error against the CPU f64 reference, and screenshots, which write what `render`
//! writes for the shown state.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::thread::Scope;
use std::time::Instant;

use serde::Serialize;

use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::measure::Frames;
use crate::metrics::{self, ErrorMetrics};
use crate::render::FrameOutput;
use crate::run::{self, CellOptions, RenderReport};
use crate::scene::Scene;
use crate::variant::LoadedVariant;

/// What a job works on: the shown frame and what it was drawn from.
#[derive(Clone)]
pub struct Subject {
    pub frame: FrameOutput,
    pub variant: LoadedVariant,
    pub scene: Scene,
    pub composer: Composer,
    /// The `render` command that draws the same frame.
    pub command: String,
}

/// What a finished job found.
pub enum Done {
    /// The shown frame against its reference.
    Error(ErrorMetrics),
    /// Files written for a screenshot.
    Screenshot(Vec<PathBuf>),
}

/// A job under way or finished.
pub struct Job {
    pub what: &'static str,
    started: Instant,
    /// Samples the reference shades, and the process's count of shaded samples at the start.
    samples: u64,
    shaded_before: u64,
    result: Arc<Mutex<Option<Result<Done, String>>>>,
}

/// What a screenshot writes beside `render`'s files: how the viewer drew the frame.
#[derive(Serialize)]
struct ViewRecord<'a> {
    /// The `render` command that draws this frame (its PNG is the same, byte for byte,
    /// when `shown_equals_render`).
    render_command: &'a str,
    /// The shown frame is the one a fresh `render` of the same state draws, pixel for pixel
    /// (a sampled variant with history differs: the viewer's frames follow each other).
    shown_equals_render: bool,
    /// Pixels whose 8-bit colour differs between the shown frame and `render`'s.
    differing_pixels: u64,
    /// The shown frame's error against the reference (`render`'s JSON has the fresh frame's).
    shown_error: Option<ErrorMetrics>,
}

impl Job {
    /// Start measuring the shown frame's error.
    pub fn error<'s, 'e: 's>(scope: &'s Scope<'s, 'e>, gpu: &'e Gpu, subject: Subject) -> Job {
        let samples = Self::samples(&subject);
        Self::start(
            scope,
            "error against the f64 reference",
            samples,
            move || {
                let (reference, _) = crate::reference::reference_frame(
                    gpu,
                    &subject.composer,
                    &subject.variant,
                    &subject.scene,
                )
                .map_err(|e| e.to_string())?;
                Ok(Done::Error(metrics::compare(&subject.frame, &reference)))
            },
        )
    }

    /// Start a screenshot into `out`: the shown frame as `STEM.png`, its heat map, `render`'s
    /// JSON for the same state as `STEM.json` (a fresh renderer, as `render` runs it), and
    /// how the viewer drew it as `STEM.view.json`.
    pub fn screenshot<'s, 'e: 's>(
        scope: &'s Scope<'s, 'e>,
        gpu: &'e Gpu,
        subject: Subject,
        out: PathBuf,
    ) -> Job {
        let samples = Self::samples(&subject);
        Self::start(scope, "screenshot", samples, move || {
            screenshot(gpu, &subject, &out).map(Done::Screenshot)
        })
    }

    /// Samples the subject's reference shades.
    fn samples(subject: &Subject) -> u64 {
        subject.frame.width as u64
            * subject.frame.height as u64
            * subject.variant.variant.msaa.samples as u64
    }

    fn start<'s, 'e: 's>(
        scope: &'s Scope<'s, 'e>,
        what: &'static str,
        samples: u64,
        work: impl FnOnce() -> Result<Done, String> + Send + 's,
    ) -> Job {
        let result = Arc::new(Mutex::new(None));
        let slot = Arc::clone(&result);
        let job = Job {
            what,
            started: Instant::now(),
            samples,
            shaded_before: crate::cpu::frame::shaded_samples(),
            result,
        };
        scope.spawn(move || {
            let done = work();
            *slot.lock().expect("a job's slot is not poisoned") = Some(done);
        });
        job
    }

    /// How far the reference has got, 0..=1, and seconds since the start.
    pub fn progress(&self) -> (f32, f64) {
        let shaded = crate::cpu::frame::shaded_samples() - self.shaded_before;
        let fraction = (shaded as f64 / self.samples.max(1) as f64).min(1.0) as f32;
        (fraction, self.started.elapsed().as_secs_f64())
    }

    /// The result, once the job has finished.
    pub fn take(&self) -> Option<Result<Done, String>> {
        self.result
            .lock()
            .expect("a job's slot is not poisoned")
            .take()
    }
}

fn screenshot(gpu: &Gpu, subject: &Subject, out: &Path) -> Result<Vec<PathBuf>, String> {
    gpu.begin_cell();
    let options = CellOptions {
        frames: Frames::exact(1, 1),
        ..CellOptions::default()
    };
    let cell = run::run_scene(
        gpu,
        &subject.composer,
        &subject.variant,
        &subject.scene,
        options,
    )
    .map_err(|e| e.to_string())?;
    let stem = run::safe_file_name(&format!("{}@{}", subject.variant.name, subject.scene.name));
    let mut files = run::write_images(out, &stem, &subject.frame, &cell.reference)
        .map_err(|e| e.to_string())?;
    let differing = subject
        .frame
        .ldr
        .iter()
        .zip(&cell.frame.ldr)
        .filter(|(a, b)| a[..3] != b[..3])
        .count() as u64;
    let shaded = subject.variant.variant.debug_view == crate::variant::DebugView::Off;
    let report = RenderReport {
        images: files.clone(),
        ..cell.report
    };
    let record = ViewRecord {
        render_command: &subject.command,
        shown_equals_render: differing == 0,
        differing_pixels: differing,
        shown_error: shaded.then(|| metrics::compare(&subject.frame, &cell.reference)),
    };
    for (name, json) in [
        (
            format!("{stem}.json"),
            serde_json::to_string_pretty(&report),
        ),
        (
            format!("{stem}.view.json"),
            serde_json::to_string_pretty(&record),
        ),
    ] {
        let path = out.join(name);
        let text = json.map_err(|e| e.to_string())?;
        crate::files::write_file(&path, text.as_bytes())?;
        files.push(path);
    }
    Ok(files)
}

/// The `render` command that draws the frame of `setup`; `file` is the variant as its file
/// says (the panel's debug view and samples are written where they differ from it).
pub fn render_command(
    setup: &super::session::Setup,
    file: Option<&crate::variant::Variant>,
) -> String {
    let p = &setup.params;
    let mut args = vec![
        "clusterlab render".to_string(),
        format!("--variant {}", setup.variant.display()),
        format!("--scene {}", setup.scene),
        format!("--size {}x{}", p.width, p.height),
        format!("--lights {}", p.lights),
        format!("--radius {},{}", p.radius_range.0, p.radius_range.1),
        format!("--spots {}", p.spots),
        format!("--seed {}", p.seed),
        format!("--time {}", p.time),
    ];
    if file.is_none_or(|v| v.debug_view != setup.debug_view) {
        args.push(format!("--debug-view {}", setup.debug_view.name()));
    }
    if file.is_none_or(|v| v.msaa.samples != setup.samples) {
        args.push(format!("--samples {}", setup.samples));
    }
    if let Some(pose) = setup.camera {
        args.push(format!("--camera={}", pose.argument()));
    }
    args.join(" ")
}
