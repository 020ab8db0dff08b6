//! Accuracy studies against published numbers (`clusterlab study NAME`): normal codecs,
//! depth reconstruction, z-slicing efficiency. Each writes a table (terminal, Markdown, CSV,
//! JSON) and a plot, from the same code that renders the frames.

pub mod codecs;
pub mod cones;
pub mod culling;
pub mod depth;
pub mod msaa;
pub mod sampling;
pub mod scale;
pub mod slicing;
pub mod table;
pub mod temporal;
pub mod transparency;

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::compose::Composer;
use crate::gpu::{AdapterSummary, Gpu, GpuError};
use crate::render::RenderError;
pub use table::Table;

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

/// The studies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum StudyName {
    /// Angular error of every normal codec at every bit count, GPU and CPU.
    Codecs,
    /// Relative error of view depth rebuilt from the depth buffer.
    Depth,
    /// Culling efficiency of each z-slicing scheme and grid on each built-in scene.
    Slicing,
    /// Spot lights culled by their bounding sphere against the cone test, at spot fractions
    /// 0, 0.5 and 1 on each built-in scene; lights missed (must be 0).
    Cones,
    /// Every culling method (clusters, tiled, 2.5D, Olsson, z-binning, rasterised binning,
    /// two-level) on each built-in scene at 64 to 16384 lights (or `--lights`), spot
    /// fractions 0 and 0.5.
    Culling,
    /// Naive forward, Forward+ and clustered deferred (tiled and two-level both ways) at
    /// every sample count the adapter multisamples, 1024 lights (or `--lights`): time,
    /// memory, edge pixels, and where deferred and forward cross over.
    Msaa,
    /// Every pipeline and culling method on the glass scene with its blended panes and
    /// without: the transparent pass, the blended depths pass, and what the panes cost the
    /// opaque frame through shared list bounds.
    Transparency,
    /// Every list strategy for moving lights (rebuild, static and dynamic lists, patch,
    /// BVH refit) against the fraction of lights moving (0 to 100%), camera still and
    /// moving, at 1024 and 16384 lights (or `--lights`) on the atrium: a sequence of
    /// `--frames` frames after the first for each.
    Temporal,
    /// Time against error: the sampled light loops (RIS, stochastic light culling, ReSTIR's
    /// temporal reuse) beside the fastest exact variants on the atrium at 1024, 4096 and
    /// 16384 lights (or `--lights`), radius 2..4 and 4..8: each sampler's error, the
    /// candidates each needs for 2 LSB RMSE, and the frames temporal reuse needs.
    Sampling,
    /// The exact culling methods from 4096 lights to a million on the atrium (radius scaled
    /// with the count): frame, assignment and shading time, evaluations per useful one,
    /// list bytes and exactness; 640x360 and up to 262144 lights on a software adapter.
    Scale,
}

impl StudyName {
    pub fn as_str(self) -> &'static str {
        match self {
            StudyName::Codecs => "codecs",
            StudyName::Depth => "depth",
            StudyName::Slicing => "slicing",
            StudyName::Cones => "cones",
            StudyName::Culling => "culling",
            StudyName::Msaa => "msaa",
            StudyName::Transparency => "transparency",
            StudyName::Temporal => "temporal",
            StudyName::Sampling => "sampling",
            StudyName::Scale => "scale",
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error("{0}")]
    Render(#[from] RenderError),
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

/// What a study may be asked for.
#[derive(Clone, Debug)]
pub struct StudyOptions {
    /// Codecs: uniform unit vectors (at least 1M for the published comparison).
    pub samples: usize,
    pub seed: u64,
    /// Slicing: scenes and image size, timed frames per run.
    pub scenes: Vec<String>,
    pub size: (u32, u32),
    /// The size given on the command line, if one was (scale chooses its own otherwise).
    pub explicit_size: Option<(u32, u32)>,
    /// Slicing: lights in every scene instead of each scene's default.
    pub lights: Option<u32>,
    pub frames: u32,
    /// Depth: pixel columns (one distance each) and rows of the frame.
    pub depth_columns: u32,
    pub depth_rows: u32,
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
            size: (640, 360),
            explicit_size: None,
            lights: None,
            frames: 3,
            depth_columns: 1000,
            depth_rows: 4,
        }
    }
}

/// A study's results.
pub struct StudyOutput {
    pub name: StudyName,
    pub table: Table,
    /// The typed rows, as JSON.
    pub rows: serde_json::Value,
    pub csv: String,
    pub plot: Option<Plot>,
    /// False when the study found a disagreement it exists to rule out (codecs: GPU and
    /// CPU differ at the printed precision; slicing: a run failed; cones: a run failed or
    /// missed a light; culling: a run failed or its useful evaluations differ from the other
    /// methods' on the same frame; msaa, transparency: a run failed or was over 1 LSB;
    /// temporal: a sequence failed or a checked frame was not exact; sampling: a run
    /// failed).
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

fn output<T: Serialize>(
    name: StudyName,
    table: Table,
    rows: &[T],
    plot: Option<Plot>,
    ok: bool,
) -> Result<StudyOutput, StudyError> {
    Ok(StudyOutput {
        name,
        table,
        rows: serde_json::to_value(rows).map_err(|e| StudyError::Io(e.to_string()))?,
        csv: csv_of(rows)?,
        plot,
        ok,
    })
}

/// Run study `name`.
pub fn run(
    name: StudyName,
    gpu: &Gpu,
    composer: &Composer,
    options: &StudyOptions,
) -> Result<StudyOutput, StudyError> {
    let scenes: Vec<&str> = options.scenes.iter().map(|s| s.as_str()).collect();
    match name {
        StudyName::Codecs => {
            if options.samples == 0 {
                return Err(StudyError::Usage("--samples must be at least 1".into()));
            }
            let rows = codecs::run(gpu, composer, options.samples, options.seed)?;
            let ok = codecs::all_agree(&rows);
            output(name, codecs::table(&rows), &rows, codecs::plot(&rows), ok)
        }
        StudyName::Depth => {
            if options.depth_columns < 2 || options.depth_rows == 0 {
                return Err(StudyError::Usage(
                    "the depth study needs at least 2 columns and 1 row".into(),
                ));
            }
            let study = depth::run(gpu, composer, options.depth_columns, options.depth_rows)?;
            let ok = study.rows.iter().all(|r| r.missing == 0);
            output(
                name,
                depth::table(&study),
                &study.rows,
                depth::plot(&study),
                ok,
            )
        }
        StudyName::Slicing => {
            let rows = slicing::run(
                gpu,
                composer,
                &scenes,
                options.size,
                options.lights,
                options.frames,
            )?;
            let ok = rows.iter().all(|r| r.error.is_none());
            output(name, slicing::table(&rows), &rows, slicing::plot(&rows), ok)
        }
        StudyName::Cones => {
            let rows = cones::run(
                gpu,
                composer,
                &scenes,
                options.size,
                options.lights,
                options.frames,
            )?;
            let ok = cones::all_exact(&rows);
            output(name, cones::table(&rows), &rows, None, ok)
        }
        StudyName::Culling => {
            let counts = match options.lights {
                Some(n) => vec![n],
                None => culling::LIGHT_COUNTS.to_vec(),
            };
            let rows = culling::run(
                gpu,
                composer,
                &scenes,
                options.size,
                &counts,
                options.frames,
            )?;
            let ok = culling::all_exact(&rows);
            output(name, culling::table(&rows), &rows, culling::plot(&rows), ok)
        }
        StudyName::Msaa => {
            let rows = msaa::run(
                gpu,
                composer,
                &scenes,
                options.size,
                options.lights,
                options.frames,
            )?;
            let ok = msaa::all_exact(&rows);
            let table = msaa::table(&rows, &gpu.multisample_counts());
            output(name, table, &rows, None, ok)
        }
        StudyName::Transparency => {
            let rows =
                transparency::run(gpu, composer, options.size, options.lights, options.frames)?;
            let ok = transparency::all_exact(&rows);
            output(name, transparency::table(&rows), &rows, None, ok)
        }
        StudyName::Temporal => {
            let counts = match options.lights {
                Some(n) => vec![n],
                None => temporal::LIGHT_COUNTS.to_vec(),
            };
            let rows = temporal::run(gpu, composer, options.size, &counts, options.frames)?;
            let ok = temporal::all_exact(&rows);
            output(
                name,
                temporal::table(&rows),
                &rows,
                temporal::plot(&rows),
                ok,
            )
        }
        StudyName::Sampling => {
            let counts = match options.lights {
                Some(n) => vec![n],
                None => sampling::LIGHT_COUNTS.to_vec(),
            };
            let rows = sampling::run(gpu, composer, options.size, &counts, options.frames)?;
            let ok = sampling::all_ran(&rows);
            output(
                name,
                sampling::table(&rows),
                &rows,
                sampling::plot(&rows),
                ok,
            )
        }
        StudyName::Scale => {
            let rows = scale::run(gpu, composer, options)?;
            let ok = scale::all_exact(&rows);
            output(name, scale::table(&rows), &rows, scale::plot(&rows), ok)
        }
    }
}

/// The JSON document of a study: what ran where, and its rows.
pub fn json(out: &StudyOutput, adapter: &AdapterSummary, command: &str) -> serde_json::Value {
    serde_json::json!({
        "study": out.name.as_str(),
        "ok": out.ok,
        "adapter": adapter,
        "command": command,
        "clusterlab": env!("CARGO_PKG_VERSION"),
        "notes": out.table.notes,
        "rows": out.rows,
    })
}

/// Write NAME.csv, NAME.json, NAME.md and the plot into `dir` (each file atomically).
pub fn write(
    dir: &Path,
    out: &StudyOutput,
    adapter: &AdapterSummary,
    command: &str,
) -> Result<Vec<PathBuf>, StudyError> {
    crate::files::write::create_folder(dir).map_err(StudyError::Io)?;
    let name = out.name.as_str();
    let doc = serde_json::to_string_pretty(&json(out, adapter, command))
        .map_err(|e| StudyError::Io(e.to_string()))?;
    let markdown = format!(
        "{}\nAdapter: {} ({}, {}). Command: `{command}`.\n",
        out.table.markdown(),
        adapter.name,
        adapter.backend,
        adapter.driver
    );
    let mut files = vec![
        (dir.join(format!("{name}.csv")), out.csv.clone()),
        (dir.join(format!("{name}.json")), doc),
        (dir.join(format!("{name}.md")), markdown),
    ];
    if let Some(p) = &out.plot {
        files.push((dir.join(&p.file), p.svg.clone()));
    }
    for (path, text) in &files {
        crate::files::write_file(path, text.as_bytes()).map_err(StudyError::Io)?;
    }
    Ok(files.into_iter().map(|(p, _)| p).collect())
}
