//! What every study uses: the `Study` trait, its options and errors, running its points,
//! and writing its files.

use serde::Serialize;

use crate::compose::Composer;
use crate::gpu::{AdapterSummary, Gpu, GpuError};
use crate::render::RenderError;
use crate::table::Table;

use crate::plot::Plot;

/// A Forward+ variant measured on a scene: its counters and the medians of its timed frames.
pub(crate) struct Measured {
    pub stats: crate::render::FrameStats,
    /// The whole frame, ms.
    pub frame_ms: f64,
    /// The shading pass (the light loop), ms.
    pub shading_ms: f64,
    /// Every pass that builds the light lists (depth range, marking, boxes, assignment), ms.
    pub assignment_ms: f64,
    /// "timestamps" or "wall clock".
    pub timing_source: &'static str,
}

/// Render `variant` on `scene`: one untimed frame, `frames` timed ones (at least one), then
/// the instrumented frame's counters.
pub(crate) fn measure(
    gpu: &Gpu,
    composer: &Composer,
    variant: &crate::variant::Variant,
    scene: &crate::scene::Scene,
    frames: u32,
) -> Result<Measured, StudyError> {
    use strum::IntoEnumIterator;
    let mut renderer = crate::render::Renderer::new(gpu, composer, variant, scene)?;
    renderer.render()?;
    let (mut frame, mut shading, mut assignment) = (Vec::new(), Vec::new(), Vec::new());
    let mut timestamps = false;
    for _ in 0..frames.max(1) {
        let f = renderer.render()?;
        timestamps = f.timings.gpu_timestamps;
        frame.push(f.timings.total_ms());
        shading.push(f.timings.get("forward"));
        assignment.push(
            crate::compose::ClusterPass::iter()
                .map(|p| f.timings.get(<&str>::from(p)))
                .sum(),
        );
    }
    Ok(Measured {
        stats: renderer.stats()?,
        frame_ms: crate::measure::median(frame),
        shading_ms: crate::measure::median(shading),
        assignment_ms: crate::measure::median(assignment),
        timing_source: if timestamps {
            "timestamps"
        } else {
            "wall clock"
        },
    })
}

#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error("{0}")]
    Render(#[from] RenderError),
    #[error("{0}")]
    Run(#[from] crate::run::RunError),
    #[error("{0}")]
    Usage(String),
    #[error("{0}")]
    Io(String),
}

impl From<GpuError> for StudyError {
    fn from(e: GpuError) -> Self {
        StudyError::Render(RenderError::Gpu(e))
    }
}

/// What a study may be asked for; each study reads the options it has and says in its
/// help which.
#[derive(Clone, Debug)]
pub struct StudyOptions {
    /// Codecs: uniform unit vectors (at least 1M for the published comparison).
    pub samples: usize,
    pub seed: u64,
    /// Scenes, built-in names or glTF files.
    pub scenes: Vec<String>,
    /// The image size (None: the study's own, `DEFAULT_SIZE` for most).
    pub size: Option<(u32, u32)>,
    /// Light counts (empty: each study's own).
    pub lights: Vec<u32>,
    /// Timed frames per run.
    pub frames: u32,
    /// Depth: pixel columns (one distance each) and rows of the frame.
    pub depth_columns: u32,
    /// The user's variants, run beside the study's own where it compares variants.
    pub variants: Vec<crate::variant::LoadedVariant>,
    pub depth_rows: u32,
}

/// The image size of the studies that render unless `--size` says otherwise.
pub const DEFAULT_SIZE: (u32, u32) = (640, 360);

impl StudyOptions {
    /// The size asked for, or `DEFAULT_SIZE`.
    pub fn size(&self) -> (u32, u32) {
        self.size.unwrap_or(DEFAULT_SIZE)
    }

    /// The light counts asked for, or the study's `own`.
    pub fn lights_or(&self, own: &[u32]) -> Vec<u32> {
        if self.lights.is_empty() {
            own.to_vec()
        } else {
            self.lights.clone()
        }
    }

    /// Scene `name`'s parameters at the size asked for, one set per light count asked for
    /// or, where none was, per count of `own` (empty: the scene's own count). A bad name
    /// fails here, before anything runs.
    pub fn params_for(
        &self,
        name: &str,
        own: &[u32],
    ) -> Result<Vec<crate::scene::SceneParams>, StudyError> {
        let defaults = scene_defaults(name)?;
        let own = if own.is_empty() {
            vec![defaults.lights]
        } else {
            own.to_vec()
        };
        let (width, height) = self.size();
        Ok(self
            .lights_or(&own)
            .into_iter()
            .map(|lights| crate::scene::SceneParams {
                width,
                height,
                lights,
                ..defaults
            })
            .collect())
    }
}

impl Default for StudyOptions {
    fn default() -> Self {
        Self {
            samples: 1 << 20,
            seed: 1,
            scenes: crate::scene::SCENES
                .iter()
                .map(|s| s.name.to_string())
                .collect(),
            size: None,
            lights: Vec::new(),
            frames: 3,
            depth_columns: 1000,
            depth_rows: 4,
            variants: Vec::new(),
        }
    }
}

/// A study: the points it runs, how one point runs, and how its rows read. Running every
/// point (a failed one leaves its named row with the error, and the others go on), the check that every row keeps
/// the study's promise, the files and the command's dispatch are written once (`conduct`,
/// `write`, `STUDIES`): adding a study is its file, its line in `STUDIES` and its page.
pub trait Study: Sized {
    /// Its name on the command line and in its files' names.
    const NAME: &'static str;
    /// What it measures, and the options it reads (the command's help).
    const ABOUT: &'static str;
    /// The options it reads: any other given is refused, as it would change nothing.
    const READS: &'static [Reads];
    /// One run: a variant on a scene at a light count, a codec on a set of normals, ...
    type Point;
    /// What a point's run gives; a failed point's row holds its error.
    type Row: Serialize + Outcome;

    /// The study for these options and its points, in the order they run. A bad option or
    /// scene fails here, before anything runs.
    fn plan(gpu: &Gpu, options: &StudyOptions) -> Result<(Self, Vec<Self::Point>), StudyError>;
    /// The point, as the progress line names it.
    fn label(&self, point: &Self::Point) -> String;
    /// Run one point: its row, or its rows.
    fn run(
        &self,
        gpu: &Gpu,
        composer: &Composer,
        point: &Self::Point,
    ) -> Result<Vec<Self::Row>, StudyError>;
    /// The row that names a point (its variant, scene, count...) with no figures yet: a
    /// failed point's row, with its error.
    fn named(&self, point: &Self::Point) -> Self::Row;
    /// Figures a row takes from the others (ratios, a front), once every point ran.
    fn relate(&self, _rows: &mut [Self::Row]) {}
    /// Whether a row that ran keeps the study's promise (exact, no light missed), seen
    /// beside the others; a failed row never does.
    fn keeps(&self, _row: &Self::Row, _rows: &[Self::Row]) -> bool {
        true
    }
    fn table(&self, rows: &[Self::Row]) -> Table;
    fn plot(&self, _rows: &[Self::Row]) -> Option<Plot> {
        None
    }
}

/// Whether a row's point failed, and why.
pub trait Outcome {
    fn failure(&self) -> Option<&str>;
    /// Mark the row failed, with why.
    fn fail(&mut self, error: String);
}

/// Implements `Outcome` for rows whose `error` field holds why their point failed.
macro_rules! outcome_in_error_field {
    ($($row:ty),*) => {$(
        impl $crate::study::Outcome for $row {
            fn failure(&self) -> Option<&str> {
                self.error.as_deref()
            }

            fn fail(&mut self, error: String) {
                self.error = Some(error);
            }
        }
    )*};
}
pub(crate) use outcome_in_error_field;

/// A study that ran: the study as planned, its rows, and whether every row kept its promise.
pub struct Finished<S: Study> {
    pub study: S,
    pub rows: Vec<S::Row>,
    pub ok: bool,
}

impl<S: Study> Finished<S> {
    pub fn table(&self) -> Table {
        self.study.table(&self.rows)
    }

    pub fn plot(&self) -> Option<Plot> {
        self.study.plot(&self.rows)
    }
}

/// Whether every row ran and keeps the study's promise.
pub fn all_kept<S: Study>(study: &S, rows: &[S::Row]) -> bool {
    rows.iter()
        .all(|r| r.failure().is_none() && study.keeps(r, rows))
}

/// Run every point of study `S`, each as one cell of the device's time limit; `progress`
/// hears of each point as it ends ("[3/28] 4096 lights: FP BVH, 1.2 s; 0:40 left").
pub fn run_points<S: Study>(
    gpu: &Gpu,
    composer: &Composer,
    options: &StudyOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<Finished<S>, StudyError> {
    let (study, points) = S::plan(gpu, options)?;
    let count = points.len();
    let study_started = std::time::Instant::now();
    let mut rows = Vec::new();
    // Each point is dropped once it ran: a scene and its references go with the last point
    // that shares them.
    for (i, point) in points.into_iter().enumerate() {
        let started = std::time::Instant::now();
        gpu.begin_cell();
        let outcome = match study.run(gpu, composer, &point) {
            Ok(ran) => {
                let failure = ran.iter().find_map(|r| r.failure().map(str::to_string));
                rows.extend(ran);
                failure
            }
            Err(e) => {
                let mut row = study.named(&point);
                row.fail(e.to_string());
                rows.push(row);
                Some(e.to_string())
            }
        };
        progress(&format!(
            "[{}/{count}] {}, {:.1} s{}; {}",
            i + 1,
            study.label(&point),
            started.elapsed().as_secs_f64(),
            outcome.map_or(String::new(), |e| format!(": FAILED: {e}")),
            crate::progress::eta(study_started.elapsed(), i + 1, count)
        ));
    }
    study.relate(&mut rows);
    let ok = all_kept(&study, &rows);
    Ok(Finished { study, rows, ok })
}

/// Run study `S` and lay out what it found.
pub(super) fn conduct<S: Study>(
    gpu: &Gpu,
    composer: &Composer,
    options: &StudyOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<StudyOutput, StudyError> {
    let done = run_points::<S>(gpu, composer, options, progress)?;
    Ok(StudyOutput {
        name: S::NAME,
        table: done.table(),
        rows: serde_json::to_value(&done.rows).map_err(|e| StudyError::Io(e.to_string()))?,
        csv: csv_of(&done.rows)?,
        plot: done.plot(),
        ok: done.ok,
    })
}

/// The options of `clusterlab study` a study may read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reads {
    Samples,
    Size,
    Scenes,
    Lights,
    Frames,
    Variants,
}

impl Reads {
    pub fn flag(self) -> &'static str {
        match self {
            Reads::Samples => "--samples",
            Reads::Size => "--size",
            Reads::Scenes => "--scenes",
            Reads::Lights => "--lights",
            Reads::Frames => "--frames",
            Reads::Variants => "--variants",
        }
    }
}

/// A study's results.
pub struct StudyOutput {
    pub name: &'static str,
    pub table: Table,
    /// The typed rows, as JSON.
    pub rows: serde_json::Value,
    pub csv: String,
    pub plot: Option<Plot>,
    /// False when a point failed or a row broke the promise the study keeps (`Study::keeps`).
    pub ok: bool,
}

fn csv_of<T: Serialize>(rows: &[T]) -> Result<String, StudyError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).map_err(|e| StudyError::Io(e.to_string()))?;
    }
    let bytes = w.into_inner().map_err(|e| StudyError::Io(e.to_string()))?;
    String::from_utf8(bytes).map_err(|e| StudyError::Io(e.to_string()))
}

/// The shipped variants `names`, found as `variant::locate` finds a name (the working
/// folder's `variants/`, then the tree's).
pub(crate) fn shipped(names: &[&str]) -> Result<Vec<crate::variant::LoadedVariant>, StudyError> {
    names
        .iter()
        .map(|name| {
            let path = crate::variant::locate(name).map_err(StudyError::Usage)?;
            crate::variant::load(&path).map_err(|e| StudyError::Usage(e.to_string()))
        })
        .collect()
}

/// Scene `name`'s own parameters, or a usage error naming what is wrong.
pub(crate) fn scene_defaults(name: &str) -> Result<crate::scene::SceneParams, StudyError> {
    crate::scene::defaults(name).map_err(|e| StudyError::Usage(e.to_string()))
}

/// The scene `name` with `params`, or a usage error naming what is wrong.
pub(crate) fn generate(
    name: &str,
    params: crate::scene::SceneParams,
) -> Result<crate::scene::Scene, StudyError> {
    crate::scene::generate(name, params).map_err(|e| StudyError::Usage(e.to_string()))
}

/// The JSON document of a study: what ran where, and its rows.
pub fn json(out: &StudyOutput, adapter: &AdapterSummary, command: &str) -> serde_json::Value {
    serde_json::json!({
        "study": out.name,
        "ok": out.ok,
        "adapter": adapter,
        "command": command,
        "clusterlab": env!("CARGO_PKG_VERSION"),
        "notes": out.table.notes,
        "rows": out.rows,
    })
}
