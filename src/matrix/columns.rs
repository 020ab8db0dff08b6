//! The result columns: one table, read by the CSV, the terminal table, the HTML report and
//! `clusterlab render`'s summary. A new metric is one entry here.

use serde::Serialize;
use serde_json::{Map, Value};

use super::{BaselineChange, CellRecord};
use crate::metrics::ErrorMetrics;
use crate::render::FrameStats;
use crate::run::RenderReport;

/// What the columns read: the measurements of one run of a variant on a scene.
pub struct Measured<'a> {
    /// Median milliseconds per pass, with `total`.
    pub gpu_ms: &'a Map<String, Value>,
    /// [min, max] milliseconds per pass over the timed frames, with `total`.
    pub gpu_ms_spread: &'a Map<String, Value>,
    pub speedup_vs_naive: Option<f64>,
    pub pareto: bool,
    pub error: Option<&'a ErrorMetrics>,
    pub stats: Option<&'a FrameStats>,
    pub efficiency: Option<&'a crate::efficiency::Efficiency>,
    pub skipped_passes: &'a [String],
    pub vs_baseline: Option<&'a BaselineChange>,
    /// Timed frames, untimed ones before them, and whether the one timed frame was a
    /// first draw (`None` for a failed cell).
    pub frames: Option<crate::measure::FrameCount>,
}

impl Measured<'_> {
    fn total_ms(&self) -> Option<f64> {
        self.gpu_ms.get("total").and_then(Value::as_f64)
    }

    fn spread(&self, i: usize) -> Option<f64> {
        self.gpu_ms_spread
            .get("total")?
            .as_array()?
            .get(i)?
            .as_f64()
    }
}

impl CellRecord {
    pub fn measured(&self) -> Measured<'_> {
        Measured {
            gpu_ms: &self.gpu_ms,
            gpu_ms_spread: &self.gpu_ms_spread,
            speedup_vs_naive: self.speedup_vs_naive,
            pareto: self.pareto,
            error: self.error.as_ref(),
            stats: self.stats.as_ref(),
            efficiency: self.efficiency.as_ref(),
            skipped_passes: &self.skipped_passes,
            vs_baseline: self.vs_baseline.as_ref(),
            frames: self.ok().then_some(crate::measure::FrameCount {
                warmup: self.warmup_frames,
                timed: self.frames,
                frame_without_lights: self.frame_without_lights,
                disturbed: self.disturbed_frames,
            }),
        }
    }
}

impl RenderReport {
    pub fn measured(&self) -> Measured<'_> {
        Measured {
            gpu_ms: &self.gpu_ms,
            gpu_ms_spread: &self.gpu_ms_spread,
            speedup_vs_naive: None,
            pareto: false,
            error: self.error.as_ref(),
            stats: self.stats.as_ref(),
            efficiency: self.efficiency.as_ref(),
            skipped_passes: &self.skipped_passes,
            vs_baseline: None,
            frames: Some(self.frame_count),
        }
    }
}

/// A value as the CSV writes it (empty when absent).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Cell {
    Text(String),
    Int(u64),
    Float(f64),
    Bool(bool),
    Missing,
}

impl<T: Into<Cell>> From<Option<T>> for Cell {
    fn from(v: Option<T>) -> Self {
        v.map_or(Cell::Missing, Into::into)
    }
}

impl From<f64> for Cell {
    fn from(v: f64) -> Self {
        Cell::Float(v)
    }
}

impl From<u64> for Cell {
    fn from(v: u64) -> Self {
        Cell::Int(v)
    }
}

impl From<u32> for Cell {
    fn from(v: u32) -> Self {
        Cell::Int(v as u64)
    }
}

impl From<bool> for Cell {
    fn from(v: bool) -> Self {
        Cell::Bool(v)
    }
}

impl From<String> for Cell {
    fn from(v: String) -> Self {
        Cell::Text(v)
    }
}

/// Where a column appears.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shown {
    pub csv: bool,
    pub terminal: bool,
    pub html: bool,
}

const EVERYWHERE: Shown = Shown {
    csv: true,
    terminal: true,
    html: true,
};
const CSV_ONLY: Shown = Shown {
    csv: true,
    terminal: false,
    html: false,
};
const CSV_AND_HTML: Shown = Shown {
    csv: true,
    terminal: false,
    html: true,
};
const TABLES_ONLY: Shown = Shown {
    csv: false,
    terminal: true,
    html: true,
};
const HTML_ONLY: Shown = Shown {
    csv: false,
    terminal: false,
    html: true,
};

/// One result column.
pub struct Column {
    /// The CSV header, and the name in `render`'s summary.
    pub key: &'static str,
    /// The heading of the terminal and HTML tables.
    pub heading: &'static str,
    pub shown: Shown,
    /// The value the CSV holds.
    pub value: fn(&Measured) -> Cell,
    /// The value as the tables show it ("-" when absent).
    pub text: fn(&Measured) -> String,
}

/// A count with a k/M/G suffix.
pub fn count(n: u64) -> String {
    match n {
        0..1_000 => n.to_string(),
        1_000..1_000_000 => format!("{:.1}k", n as f64 / 1e3),
        1_000_000..1_000_000_000 => format!("{:.1}M", n as f64 / 1e6),
        _ => format!("{:.1}G", n as f64 / 1e9),
    }
}

fn or_dash<T>(v: Option<T>, f: impl Fn(T) -> String) -> String {
    v.map_or_else(|| "-".to_string(), f)
}

/// A cell's light-assignment work, where its frame assigned lights on the GPU.
fn work(m: &Measured) -> Option<crate::render::AssignmentWork> {
    m.stats.and_then(|s| s.assignment_work)
}

/// Every result column, in table order.
pub const COLUMNS: &[Column] = &[
    Column {
        key: "gpu_ms",
        heading: "GPU ms",
        shown: EVERYWHERE,
        value: |m| m.total_ms().into(),
        text: |m| or_dash(m.total_ms(), |t| format!("{t:.2}")),
    },
    Column {
        key: "gpu_ms_min",
        heading: "min ms",
        shown: CSV_ONLY,
        value: |m| m.spread(0).into(),
        text: |m| or_dash(m.spread(0), |t| format!("{t:.2}")),
    },
    Column {
        key: "gpu_ms_max",
        heading: "max ms",
        shown: CSV_ONLY,
        value: |m| m.spread(1).into(),
        text: |m| or_dash(m.spread(1), |t| format!("{t:.2}")),
    },
    Column {
        key: "gpu_ms_spread",
        heading: "spread",
        shown: HTML_ONLY,
        value: |_| Cell::Missing,
        text: |m| match (m.spread(0), m.spread(1)) {
            (Some(a), Some(b)) => format!("{a:.2}-{b:.2}"),
            _ => "-".into(),
        },
    },
    Column {
        key: "frames",
        heading: "frames",
        shown: CSV_AND_HTML,
        value: |m| m.frames.map(|f| f.timed).into(),
        text: |m| {
            or_dash(m.frames, |f| {
                let timed = match f.warmup {
                    0 => f.timed.to_string(),
                    w => format!("{w}+{}", f.timed),
                };
                match f.disturbed {
                    0 => timed,
                    d => format!("{timed} ({d} disturbed)"),
                }
            })
        },
    },
    Column {
        key: "speedup_vs_naive",
        heading: "x naive",
        shown: EVERYWHERE,
        value: |m| m.speedup_vs_naive.into(),
        text: |m| or_dash(m.speedup_vs_naive, |x| format!("{x:.1}x")),
    },
    Column {
        key: "efficiency",
        heading: "efficiency",
        shown: CSV_AND_HTML,
        value: |m| m.efficiency.map(|e| e.efficiency).into(),
        text: |m| {
            or_dash(m.efficiency, |e| match e.within_noise {
                true => "100% (within noise)".into(),
                false => format!("{:.0}%", e.efficiency * 100.0),
            })
        },
    },
    Column {
        key: "ns_per_useful_evaluation",
        heading: "ns/useful",
        shown: CSV_AND_HTML,
        value: |m| m.efficiency.map(|e| e.ns_per_useful_evaluation).into(),
        text: |m| {
            or_dash(m.efficiency, |e| {
                format!("{:.2}", e.ns_per_useful_evaluation)
            })
        },
    },
    Column {
        key: "bound_ms",
        heading: "bound ms",
        shown: CSV_ONLY,
        value: |m| m.efficiency.map(|e| e.bound_ms).into(),
        text: |m| or_dash(m.efficiency, |e| format!("{:.2}", e.bound_ms)),
    },
    Column {
        key: "frame_without_lights_ms",
        heading: "no-light ms",
        shown: CSV_ONLY,
        value: |m| m.efficiency.map(|e| e.frame_without_lights_ms).into(),
        text: |m| {
            or_dash(m.efficiency, |e| {
                format!("{:.2}", e.frame_without_lights_ms)
            })
        },
    },
    Column {
        key: "ns_per_evaluation",
        heading: "ns/eval",
        shown: CSV_ONLY,
        value: |m| m.efficiency.map(|e| e.ns_per_evaluation).into(),
        text: |m| or_dash(m.efficiency, |e| format!("{:.2}", e.ns_per_evaluation)),
    },
    Column {
        key: "pareto",
        heading: "Pareto",
        shown: CSV_ONLY,
        value: |m| m.pareto.into(),
        text: |m| if m.pareto { "*" } else { "" }.into(),
    },
    Column {
        key: "max_abs_8bit",
        heading: "max8",
        shown: EVERYWHERE,
        value: |m| m.error.map(|e| e.max_abs_8bit).into(),
        text: |m| or_dash(m.error, |e| e.max_abs_8bit.to_string()),
    },
    Column {
        key: "rmse_8bit",
        heading: "RMSE8",
        shown: CSV_AND_HTML,
        value: |m| m.error.map(|e| e.rmse_8bit).into(),
        text: |m| or_dash(m.error, |e| format!("{:.3}", e.rmse_8bit)),
    },
    Column {
        key: "pixels_over_1lsb",
        heading: "px over 1 LSB",
        shown: CSV_ONLY,
        value: |m| m.error.map(|e| e.pixels_over_1lsb).into(),
        text: |m| or_dash(m.error, |e| e.pixels_over_1lsb.to_string()),
    },
    Column {
        key: "relative_mse",
        heading: "relMSE",
        shown: CSV_AND_HTML,
        value: |m| m.error.map(|e| e.relative_mse).into(),
        text: |m| or_dash(m.error, |e| format!("{:.2e}", e.relative_mse)),
    },
    Column {
        key: "rmse_hdr",
        heading: "HDR RMSE",
        shown: CSV_ONLY,
        value: |m| m.error.map(|e| e.rmse).into(),
        text: |m| or_dash(m.error, |e| format!("{:.3e}", e.rmse)),
    },
    Column {
        key: "psnr_db",
        heading: "PSNR",
        shown: EVERYWHERE,
        value: |m| match m.error {
            Some(e) => e.psnr_db.map_or(Cell::Text("inf".into()), Cell::Float),
            None => Cell::Missing,
        },
        text: |m| {
            or_dash(m.error, |e| {
                e.psnr_db.map_or("inf".into(), |p| format!("{p:.1}"))
            })
        },
    },
    Column {
        key: "flip_mean",
        heading: "FLIP",
        shown: EVERYWHERE,
        value: |m| m.error.map(|e| e.flip_mean).into(),
        text: |m| or_dash(m.error, |e| format!("{:.4}", e.flip_mean)),
    },
    Column {
        key: "nan_pixels",
        heading: "NaN px",
        shown: EVERYWHERE,
        value: |m| m.error.map(|e| e.nan_pixels).into(),
        text: |m| or_dash(m.error, |e| e.nan_pixels.to_string()),
    },
    Column {
        key: "light_evals",
        heading: "evaluated",
        shown: CSV_ONLY,
        value: |m| m.stats.map(|s| s.light_evals).into(),
        text: |m| or_dash(m.stats, |s| count(s.light_evals)),
    },
    Column {
        key: "useful_light_evals",
        heading: "useful/evaluated",
        shown: EVERYWHERE,
        value: |m| m.stats.map(|s| s.useful_light_evals).into(),
        text: |m| {
            or_dash(m.stats, |s| {
                format!(
                    "{}/{} ({:.0}%)",
                    count(s.useful_light_evals),
                    count(s.light_evals),
                    100.0 * s.useful_light_evals as f64 / s.light_evals.max(1) as f64
                )
            })
        },
    },
    Column {
        key: "light_candidates",
        heading: "candidates",
        shown: CSV_ONLY,
        value: |m| m.stats.map(|s| s.light_candidates).into(),
        text: |m| or_dash(m.stats, |s| count(s.light_candidates)),
    },
    Column {
        key: "sampler",
        heading: "sampler",
        shown: CSV_AND_HTML,
        value: |m| Cell::Text(m.stats.and_then(|s| s.sampler.clone()).unwrap_or_default()),
        text: |m| m.stats.and_then(|s| s.sampler.clone()).unwrap_or_default(),
    },
    Column {
        key: "edge_fraction",
        heading: "edge px",
        shown: CSV_AND_HTML,
        value: |m| m.stats.map(|s| s.edge_fraction).into(),
        text: |m| or_dash(m.stats, |s| format!("{:.1}%", 100.0 * s.edge_fraction)),
    },
    Column {
        key: "frame_bytes_per_pixel",
        heading: "B/px",
        shown: EVERYWHERE,
        value: |m| m.stats.map(|s| s.frame_bytes_per_pixel).into(),
        text: |m| or_dash(m.stats, |s| s.frame_bytes_per_pixel.to_string()),
    },
    Column {
        key: "cluster_bytes",
        heading: "cluster KiB",
        shown: CSV_AND_HTML,
        value: |m| m.stats.map(|s| s.cluster_bytes).into(),
        text: |m| {
            or_dash(m.stats, |s| {
                format!("{:.0}", s.cluster_bytes as f64 / 1024.0)
            })
        },
    },
    Column {
        key: "assign_light_tests",
        heading: "assign tests",
        shown: CSV_AND_HTML,
        value: |m| work(m).map(|w| w.light_tests).into(),
        text: |m| or_dash(work(m), |w| count(w.light_tests)),
    },
    Column {
        key: "assign_node_tests",
        heading: "node tests",
        shown: CSV_ONLY,
        value: |m| work(m).map(|w| w.node_tests).into(),
        text: |m| or_dash(work(m), |w| count(w.node_tests)),
    },
    Column {
        key: "assign_entries_written",
        heading: "entries written",
        shown: CSV_ONLY,
        value: |m| work(m).map(|w| w.entries_written).into(),
        text: |m| or_dash(work(m), |w| count(w.entries_written)),
    },
    Column {
        key: "assign_lights_rejected",
        heading: "lights rejected",
        shown: CSV_ONLY,
        value: |m| work(m).map(|w| w.lights_rejected).into(),
        text: |m| or_dash(work(m), |w| count(w.lights_rejected)),
    },
    Column {
        key: "dropped_lights",
        heading: "dropped",
        shown: EVERYWHERE,
        value: |m| m.stats.map(|s| s.dropped_lights).into(),
        text: |m| or_dash(m.stats, |s| s.dropped_lights.to_string()),
    },
    Column {
        key: "passes",
        heading: "passes",
        shown: CSV_ONLY,
        value: |m| {
            let passes: Vec<String> = m
                .gpu_ms
                .iter()
                .filter(|(k, _)| *k != "total")
                .map(|(k, v)| format!("{k}={v}"))
                .collect();
            Cell::Text(passes.join(";"))
        },
        text: |m| {
            let passes: Vec<String> = m
                .gpu_ms
                .iter()
                .filter(|(k, _)| *k != "total")
                .map(|(k, v)| format!("{k} {v} ms"))
                .collect();
            passes.join(", ")
        },
    },
    Column {
        key: "skipped_passes",
        heading: "skipped",
        shown: CSV_AND_HTML,
        value: |m| Cell::Text(m.skipped_passes.join(";")),
        text: |m| m.skipped_passes.join(", "),
    },
    Column {
        key: "vs_baseline",
        heading: "vs baseline",
        shown: TABLES_ONLY,
        value: |_| Cell::Missing,
        text: |m| {
            m.vs_baseline.map_or(String::new(), |b| {
                format!(
                    "time x{:.2}, max8 {:+}, RMSE8 {:+.3}",
                    b.time_ratio, b.max_abs_8bit_change, b.rmse_8bit_change
                )
            })
        },
    },
];

/// The columns of a table (`pick` says which), leaving out those no row has a value in.
pub fn table_columns<'a>(rows: &[Measured], pick: impl Fn(&Shown) -> bool) -> Vec<&'a Column> {
    COLUMNS
        .iter()
        .filter(|c| pick(&c.shown))
        .filter(|c| {
            rows.iter().any(|m| {
                let t = (c.text)(m);
                !t.is_empty() && t != "-"
            })
        })
        .collect()
}

/// The CSV: what identifies each cell, then every CSV column of the table.
pub fn csv(cells: &[CellRecord]) -> Result<Vec<u8>, String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let results: Vec<&Column> = COLUMNS.iter().filter(|c| c.shown.csv).collect();
    let header: Vec<&str> = IDENTITY
        .iter()
        .map(|(k, _)| *k)
        .chain(results.iter().map(|c| c.key))
        .collect();
    w.write_record(&header).map_err(|e| e.to_string())?;
    for c in cells {
        let m = c.measured();
        let row: Vec<Cell> = IDENTITY
            .iter()
            .map(|(_, f)| f(c))
            .chain(results.iter().map(|col| (col.value)(&m)))
            .collect();
        w.serialize(row).map_err(|e| e.to_string())?;
    }
    w.into_inner().map_err(|e| e.to_string())
}

/// What identifies a cell in the CSV.
type Identity = (&'static str, fn(&CellRecord) -> Cell);

const IDENTITY: &[Identity] = &[
    ("id", |c| Cell::Text(c.spec.id.clone())),
    ("group", |c| Cell::Text(c.spec.group.clone())),
    ("variant", |c| Cell::Text(c.spec.variant.clone())),
    ("scene", |c| Cell::Text(c.spec.scene.clone())),
    ("width", |c| c.spec.params.width.into()),
    ("height", |c| c.spec.params.height.into()),
    ("lights", |c| c.spec.params.lights.into()),
    ("radius_min", |c| {
        Cell::Text(c.spec.params.radius[0].to_string())
    }),
    ("radius_max", |c| {
        Cell::Text(c.spec.params.radius[1].to_string())
    }),
    ("seed", |c| c.spec.params.seed.into()),
    ("grid", |c| {
        c.spec
            .grid
            .map(|g| format!("{}x{}x{}", g[0], g[1], g[2]))
            .into()
    }),
    ("pipeline", |c| c.spec.pipeline.clone().into()),
    ("ok", |c| c.ok().into()),
    ("failure", |c| c.failure.clone().into()),
];
