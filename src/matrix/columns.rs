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
    /// [lo, hi] milliseconds per pass: the median's interval at `interval_level`.
    pub gpu_ms_interval: &'a Map<String, Value>,
    pub interval_level: Option<f64>,
    pub speedup_vs_naive: Option<f64>,
    pub speedup_interval: Option<[f64; 2]>,
    pub speedup_least: Option<(f64, usize)>,
    pub front: Option<super::Front>,
    pub rank: Option<super::Rank>,
    pub against_leader: Option<&'a super::AgainstLeader>,
    /// The earlier run a reused cell was taken from.
    pub reused_from: Option<&'a str>,
    /// Depths moved by this many units in the last place (a test mode; 0: stock).
    pub perturbed_depth_ulps: u32,
    pub error: Option<&'a ErrorMetrics>,
    pub fidelity: Option<&'a super::Fidelity>,
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

    /// The total's interval: its low (0) or high (1) end.
    fn interval(&self, i: usize) -> Option<f64> {
        self.gpu_ms_interval
            .get("total")?
            .as_array()?
            .get(i)?
            .as_f64()
    }

    /// The speed-up over naive forward, round by round: its interval where there is one
    /// ("no gain" where it holds 1), else the least speed-up of any round measured, as a
    /// bound ("x12.3, >= 11.0 each of 1 round").
    pub(crate) fn speedup_text(&self) -> String {
        or_dash(self.speedup_vs_naive, |x| {
            match (self.speedup_interval, self.speedup_least) {
                // Naive forward against itself.
                (Some([1.0, 1.0]), _) => format!("{x:.1}x"),
                (Some([lo, hi]), _) if lo <= 1.0 && 1.0 <= hi => format!("{x:.1}x no gain"),
                (Some([lo, hi]), _) => format!("{x:.1}x ({lo:.1}-{hi:.1})"),
                (None, Some((least, n))) => {
                    format!(
                        "{x:.1}x (>= {least:.1} each of {})",
                        crate::measure::rounds(n)
                    )
                }
                (None, None) => format!("{x:.1}x ?"),
            }
        })
    }
}

impl CellRecord {
    pub fn measured(&self) -> Measured<'_> {
        Measured {
            gpu_ms: &self.gpu_ms,
            gpu_ms_spread: &self.gpu_ms_spread,
            gpu_ms_interval: &self.gpu_ms_interval,
            interval_level: self.interval_level,
            speedup_vs_naive: self.speedup_vs_naive,
            speedup_interval: self.speedup_interval,
            speedup_least: self.speedup_least,
            front: self.front,
            rank: self.rank,
            against_leader: self.against_leader.as_ref(),
            reused_from: self.reused_from.as_deref(),
            perturbed_depth_ulps: self.perturbed_depth_ulps,
            error: self.error.as_ref(),
            fidelity: self.fidelity.as_ref(),
            stats: self.stats.as_ref(),
            efficiency: self.efficiency.as_ref(),
            skipped_passes: &self.skipped_passes,
            vs_baseline: self.vs_baseline.as_ref(),
            frames: self.ok().then_some(crate::measure::FrameCount {
                warmup: self.warmup_frames,
                timed: self.frames,
                frame_without_lights: self.frame_without_lights,
                disturbed: self.disturbed_frames,
                stop: self.timing_stop,
            }),
        }
    }
}

impl RenderReport {
    pub fn measured(&self) -> Measured<'_> {
        Measured {
            gpu_ms: &self.gpu_ms,
            gpu_ms_spread: &self.gpu_ms_spread,
            gpu_ms_interval: &self.gpu_ms_interval,
            interval_level: self.interval_level,
            speedup_vs_naive: None,
            speedup_interval: None,
            speedup_least: None,
            front: None,
            rank: None,
            against_leader: None,
            reused_from: None,
            perturbed_depth_ulps: crate::compose::perturbed_depth_ulps(),
            error: self.error.as_ref(),
            fidelity: None,
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
    /// What the figure is, for the page's glossary.
    pub meaning: &'static str,
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

/// A cell's shadow rays, where its frame traced them.
fn rays(m: &Measured) -> Option<crate::render::ShadowRays> {
    m.stats.and_then(|s| s.shadow_rays)
}

/// A shadowed cell's error outside its ambiguous pairs.
fn shadow_error<'a>(m: &Measured<'a>) -> Option<&'a crate::metrics::ShadowError> {
    m.error.and_then(|e| e.shadows.as_ref())
}

/// Every result column, in table order.
pub const COLUMNS: &[Column] = &[
    Column {
        key: "gpu_ms",
        heading: "GPU ms",
        meaning: "median GPU milliseconds of the cell's timed frames, every pass summed (the median of the frames' totals)",
        shown: EVERYWHERE,
        value: |m| m.total_ms().into(),
        text: |m| or_dash(m.total_ms(), |t| format!("{t:.2}")),
    },
    Column {
        key: "gpu_ms_interval",
        heading: "95% CI ms",
        meaning: "the confidence interval of the median frame: the order statistics [x(k), x(n+1-k)] of the n timed frames that hold the true median with probability at least 95% (the exact level is in `interval_level`); a cell needs 6 frames for one. Two cells whose intervals overlap cannot be told apart",
        shown: TABLES_ONLY,
        value: |_| Cell::Missing,
        text: |m| match (m.interval(0), m.interval(1)) {
            (Some(a), Some(b)) => format!("{a:.2}-{b:.2}"),
            _ => "-".into(),
        },
    },
    Column {
        key: "gpu_ms_lo",
        heading: "CI lo ms",
        meaning: "the low end of the median frame's confidence interval",
        shown: CSV_ONLY,
        value: |m| m.interval(0).into(),
        text: |m| or_dash(m.interval(0), |t| format!("{t:.2}")),
    },
    Column {
        key: "gpu_ms_hi",
        heading: "CI hi ms",
        meaning: "the high end of the median frame's confidence interval",
        shown: CSV_ONLY,
        value: |m| m.interval(1).into(),
        text: |m| or_dash(m.interval(1), |t| format!("{t:.2}")),
    },
    Column {
        key: "interval_level",
        heading: "CI level",
        meaning: "the probability that the confidence interval holds the median (at least 0.95)",
        shown: CSV_ONLY,
        value: |m| m.interval_level.into(),
        text: |m| or_dash(m.interval_level, |l| format!("{:.1}%", l * 100.0)),
    },
    Column {
        key: "rank",
        heading: "vs fastest",
        meaning: "where the cell's time stands in its group, from its frame over the leader's (the lowest time) in each round both were timed in, so that drift of the machine cancels: `fastest` (the leader, every other cell decided), `leads` (the leader, some cell undecided), `tie` (the 95% interval of the ratio within 10% of 1), `slower` (the interval above 1), `slower each round` (too slow for an interval in its budget, slower by over 10% in each round it took: a bound, not a 95% verdict), `undecided` (the interval holds 1 and reaches past 10%, or under 6 shared rounds) or `other run` (timed in another run or batch: not compared)",
        shown: EVERYWHERE,
        value: |m| m.rank.map(|r| r.label().to_string()).into(),
        text: |m| or_dash(m.rank, |r| r.label().to_string()),
    },
    Column {
        key: "vs_leader",
        heading: "x leader",
        meaning: "the cell's frame over the leader's, the median over the rounds both took, with its 95% interval (absent under 6 shared rounds)",
        shown: EVERYWHERE,
        value: |m| m.against_leader.map(|a| a.paired.ratio).into(),
        text: |m| {
            or_dash(m.against_leader, |a| match a.paired.interval {
                Some(i) => format!("{:.2} ({:.2}-{:.2})", a.paired.ratio, i.lo, i.hi),
                None => format!(
                    "{:.2} ({})",
                    a.paired.ratio,
                    crate::measure::rounds(a.paired.rounds)
                ),
            })
        },
    },
    Column {
        key: "vs_leader_lo",
        heading: "x leader lo",
        meaning: "the low end of that ratio's 95% interval",
        shown: CSV_ONLY,
        value: |m| {
            m.against_leader
                .and_then(|a| a.paired.interval)
                .map(|i| i.lo)
                .into()
        },
        text: |m| {
            or_dash(m.against_leader.and_then(|a| a.paired.interval), |i| {
                format!("{:.3}", i.lo)
            })
        },
    },
    Column {
        key: "vs_leader_hi",
        heading: "x leader hi",
        meaning: "the high end of that ratio's 95% interval",
        shown: CSV_ONLY,
        value: |m| {
            m.against_leader
                .and_then(|a| a.paired.interval)
                .map(|i| i.hi)
                .into()
        },
        text: |m| {
            or_dash(m.against_leader.and_then(|a| a.paired.interval), |i| {
                format!("{:.3}", i.hi)
            })
        },
    },
    Column {
        key: "gpu_ms_min",
        heading: "min ms",
        meaning: "the fastest timed frame, milliseconds",
        shown: CSV_ONLY,
        value: |m| m.spread(0).into(),
        text: |m| or_dash(m.spread(0), |t| format!("{t:.2}")),
    },
    Column {
        key: "gpu_ms_max",
        heading: "max ms",
        meaning: "the slowest timed frame, milliseconds",
        shown: CSV_ONLY,
        value: |m| m.spread(1).into(),
        text: |m| or_dash(m.spread(1), |t| format!("{t:.2}")),
    },
    Column {
        key: "gpu_ms_spread",
        heading: "spread",
        meaning: "the fastest and the slowest timed frame, milliseconds",
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
        meaning: "timed frames (untimed ones first as U+T), why timing stopped (`decided`: its verdict against the leader, `budget`, `max frames`, `count`; `precise` in results written before verdicts decided the rounds), and how many frames were set aside as disturbed: frames of 250 ms or more during which other processes took over 25% of the machine's CPU time (software GPUs only), each replaced by another",
        shown: CSV_AND_HTML,
        value: |m| m.frames.map(|f| f.timed).into(),
        text: |m| {
            or_dash(m.frames, |f| {
                let timed = match f.warmup {
                    0 => f.timed.to_string(),
                    w => format!("{w}+{}", f.timed),
                };
                let stop = f.stop.map_or(String::new(), |s| format!(" {}", s.label()));
                match f.disturbed {
                    0 => format!("{timed}{stop}"),
                    d => format!("{timed}{stop} ({d} disturbed)"),
                }
            })
        },
    },
    Column {
        key: "speedup_vs_naive",
        heading: "x naive",
        meaning: "naive forward's frame over the cell's, the median over the rounds both were timed in, with its 95% interval; `no gain` where the interval holds 1; where naive forward took too few rounds for an interval (frames of a second or more), the least speed-up of any round as a bound (`>= X each of N rounds`)",
        shown: EVERYWHERE,
        value: |m| m.speedup_vs_naive.into(),
        text: |m| m.speedup_text(),
    },
    Column {
        key: "speedup_lo",
        heading: "x naive lo",
        meaning: "the low end of the speed-up's 95% interval (round by round)",
        shown: CSV_ONLY,
        value: |m| m.speedup_interval.map(|r| r[0]).into(),
        text: |m| or_dash(m.speedup_interval, |r| format!("{:.2}", r[0])),
    },
    Column {
        key: "speedup_hi",
        heading: "x naive hi",
        meaning: "the high end of the speed-up's 95% interval (round by round)",
        shown: CSV_ONLY,
        value: |m| m.speedup_interval.map(|r| r[1]).into(),
        text: |m| or_dash(m.speedup_interval, |r| format!("{:.2}", r[1])),
    },
    Column {
        key: "efficiency",
        heading: "efficiency",
        meaning: "distance from perfect culling: the bound (the frame without lights plus the useful evaluations at the cell's cost per evaluation) over the frame. Never clamped: a bound past the frame inside its interval is `within noise`; past the interval, `bound above frame` (mistimed, means nothing)",
        shown: CSV_AND_HTML,
        value: |m| m.efficiency.map(|e| e.efficiency).into(),
        text: |m| {
            or_dash(m.efficiency, |e| {
                if e.bound_above_frame {
                    format!(
                        "bound above frame ({:.2} > {:.2} ms)",
                        e.bound_ms,
                        m.total_ms().unwrap_or(f64::NAN)
                    )
                } else if e.within_noise {
                    format!("{:.0}% (within noise)", e.efficiency * 100.0)
                } else {
                    format!("{:.0}%", e.efficiency * 100.0)
                }
            })
        },
    },
    Column {
        key: "ns_per_useful_evaluation",
        heading: "ns/useful",
        meaning: "nanoseconds of the frame over its frame without lights per useful evaluation (a pair where the light reaches the surface)",
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
        meaning: "the perfect-culling bound, milliseconds",
        shown: CSV_ONLY,
        value: |m| m.efficiency.map(|e| e.bound_ms).into(),
        text: |m| or_dash(m.efficiency, |e| format!("{:.2}", e.bound_ms)),
    },
    Column {
        key: "frame_without_lights_ms",
        heading: "no-light ms",
        meaning: "the frame drawn with no light, milliseconds: every pass runs, nothing is shaded",
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
        meaning: "nanoseconds of the shading passes per light evaluated",
        shown: CSV_ONLY,
        value: |m| m.efficiency.map(|e| e.ns_per_evaluation).into(),
        text: |m| or_dash(m.efficiency, |e| format!("{:.2}", e.ns_per_evaluation)),
    },
    Column {
        key: "pareto",
        heading: "Pareto",
        meaning: "the time-fidelity front of its group (GPU time against truth RMSE8): `*` on it (no cell decided faster and at least as accurate, or tied and more accurate, and none at least as accurate undecided against it), `?` undecided (not dominated, but a cell at least as accurate is undecided against it), empty: dominated",
        shown: CSV_ONLY,
        value: |m| m.front.map(|f| f.label().to_string()).into(),
        text: |m| m.front.map_or("", |f| f.label()).into(),
    },
    Column {
        key: "max_abs_8bit",
        heading: "max8",
        meaning: "max8: the largest 8-bit difference from the cell's own CPU f64 reference, in LSB (an exact variant is within 1: correctness)",
        shown: EVERYWHERE,
        value: |m| m.error.map(|e| e.max_abs_8bit).into(),
        text: |m| or_dash(m.error, |e| e.max_abs_8bit.to_string()),
    },
    Column {
        key: "rmse_8bit",
        heading: "RMSE8",
        meaning: "RMSE8: root mean square 8-bit difference from the cell's own reference (what its variant computes, in f64: correctness), LSB",
        shown: CSV_AND_HTML,
        value: |m| m.error.map(|e| e.rmse_8bit).into(),
        text: |m| or_dash(m.error, |e| format!("{:.3}", e.rmse_8bit)),
    },
    Column {
        key: "fidelity_rmse_8bit",
        heading: "truth RMSE8",
        meaning: "fidelity: root mean square 8-bit difference from the group's truth, the f64 reference of the most complete lighting any cell of the group computes (exact shadows where any cell traces shadow rays), LSB; what the time-error front and `most accurate` read",
        shown: EVERYWHERE,
        value: |m| m.fidelity.map(|f| f.rmse_8bit).into(),
        text: |m| or_dash(m.fidelity, |f| format!("{:.3}", f.rmse_8bit)),
    },
    Column {
        key: "fidelity_max_8bit",
        heading: "truth max8",
        meaning: "fidelity: the largest 8-bit difference from the group's truth (outside the range ambiguous shadow rays allow, where the truth is shadowed), LSB; `fastest exact` is within 1",
        shown: EVERYWHERE,
        value: |m| m.fidelity.map(|f| f.max_8bit).into(),
        text: |m| or_dash(m.fidelity, |f| f.max_8bit.to_string()),
    },
    Column {
        key: "fidelity_truth",
        heading: "truth",
        meaning: "which truth fidelity is measured against: `its own reference` (the group's truth is what the cell computes) or `exact shadows` (the cell traces no shadow ray, another cell of its group does)",
        shown: CSV_AND_HTML,
        value: |m| m.fidelity.map(|f| f.truth.clone()).into(),
        text: |m| or_dash(m.fidelity, |f| f.truth.clone()),
    },
    Column {
        key: "pixels_over_1lsb",
        heading: "px over 1 LSB",
        meaning: "pixels differing from the reference by more than 1 LSB",
        shown: CSV_ONLY,
        value: |m| m.error.map(|e| e.pixels_over_1lsb).into(),
        text: |m| or_dash(m.error, |e| e.pixels_over_1lsb.to_string()),
    },
    Column {
        key: "max_outside_ambiguity_8bit",
        heading: "max8 decided",
        meaning: "max8 decided: shadows, the largest 8-bit difference outside the range a pixel's ambiguous shadow rays allow (an exact variant is within 1)",
        shown: CSV_AND_HTML,
        value: |m| shadow_error(m).map(|s| s.max_outside_ambiguity_8bit).into(),
        text: |m| {
            or_dash(shadow_error(m), |s| {
                s.max_outside_ambiguity_8bit.to_string()
            })
        },
    },
    Column {
        key: "ambiguous_share",
        heading: "ambiguous",
        meaning: "ambiguous: shadows, the share of the reference's shadow rays within the GPU's error of an occluder's edge or surface (either answer right)",
        shown: CSV_AND_HTML,
        value: |m| shadow_error(m).map(|s| s.ambiguous_share).into(),
        text: |m| {
            or_dash(shadow_error(m), |s| {
                format!("{:.3}%", 100.0 * s.ambiguous_share)
            })
        },
    },
    Column {
        key: "relative_mse",
        heading: "relMSE",
        meaning: "relMSE: mean of (frame - reference)^2 / (reference^2 + 0.01) over HDR channels, the sampling literature's error",
        shown: CSV_AND_HTML,
        value: |m| m.error.map(|e| e.relative_mse).into(),
        text: |m| or_dash(m.error, |e| format!("{:.2e}", e.relative_mse)),
    },
    Column {
        key: "rmse_hdr",
        heading: "HDR RMSE",
        meaning: "root mean square difference from the reference in HDR (linear) units",
        shown: CSV_ONLY,
        value: |m| m.error.map(|e| e.rmse).into(),
        text: |m| or_dash(m.error, |e| format!("{:.3e}", e.rmse)),
    },
    Column {
        key: "psnr_db",
        heading: "PSNR",
        meaning: "peak signal-to-noise ratio of the 8-bit image against the reference, dB (inf: identical)",
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
        meaning: "mean FLIP (NVIDIA's perceptual difference, 0 to 1) against the reference",
        shown: EVERYWHERE,
        value: |m| m.error.map(|e| e.flip_mean).into(),
        text: |m| or_dash(m.error, |e| format!("{:.4}", e.flip_mean)),
    },
    Column {
        key: "nan_pixels",
        heading: "NaN px",
        meaning: "pixels that are NaN or infinite: any fails the cell",
        shown: EVERYWHERE,
        value: |m| m.error.map(|e| e.nan_pixels).into(),
        text: |m| or_dash(m.error, |e| e.nan_pixels.to_string()),
    },
    Column {
        key: "light_evals",
        heading: "evaluated",
        meaning: "light evaluations the shading performed (instrumented frame)",
        shown: CSV_ONLY,
        value: |m| m.stats.map(|s| s.light_evals).into(),
        text: |m| or_dash(m.stats, |s| count(s.light_evals)),
    },
    Column {
        key: "useful_light_evals",
        heading: "useful/evaluated",
        meaning: "useful evaluations (the surface inside the light's radius) over those performed",
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
        meaning: "lights looked at in the lists, performed or not",
        shown: CSV_ONLY,
        value: |m| m.stats.map(|s| s.light_candidates).into(),
        text: |m| or_dash(m.stats, |s| count(s.light_candidates)),
    },
    Column {
        key: "sampler",
        heading: "sampler",
        meaning: "the sampled light loop and whether it is unbiased",
        shown: CSV_AND_HTML,
        value: |m| Cell::Text(m.stats.and_then(|s| s.sampler.clone()).unwrap_or_default()),
        text: |m| m.stats.and_then(|s| s.sampler.clone()).unwrap_or_default(),
    },
    Column {
        key: "shadow_rays",
        heading: "rays",
        meaning: "rays: shadows, the shadow rays the frame traced (a pixel and a light above 0 each)",
        shown: CSV_AND_HTML,
        value: |m| rays(m).map(|r| r.traced).into(),
        text: |m| or_dash(rays(m), |r| count(r.traced)),
    },
    Column {
        key: "shadow_rays_blocked",
        heading: "blocked",
        meaning: "blocked: shadows, the rays an occluder blocked",
        shown: CSV_AND_HTML,
        value: |m| rays(m).map(|r| r.blocked).into(),
        text: |m| or_dash(rays(m), |r| count(r.blocked)),
    },
    Column {
        key: "nodes_per_ray",
        heading: "nodes/ray",
        meaning: "nodes/ray: shadows, the BVH nodes whose box a ray's walk tested, per ray",
        shown: CSV_AND_HTML,
        value: |m| rays(m).and_then(|r| r.nodes_per_ray()).into(),
        text: |m| {
            or_dash(rays(m).and_then(|r| r.nodes_per_ray()), |n| {
                format!("{n:.1}")
            })
        },
    },
    Column {
        key: "edge_fraction",
        heading: "edge px",
        meaning: "edge px: multisampled frames, the share of pixels shaded more than once (edge pixels)",
        shown: CSV_AND_HTML,
        value: |m| m.stats.map(|s| s.edge_fraction).into(),
        text: |m| or_dash(m.stats, |s| format!("{:.1}%", 100.0 * s.edge_fraction)),
    },
    Column {
        key: "frame_bytes_per_pixel",
        heading: "B/px",
        meaning: "B/px: bytes per pixel of every full-size image the frame keeps (depth, G-buffer, HDR colour, post images, the 8-bit output)",
        shown: EVERYWHERE,
        value: |m| m.stats.map(|s| s.frame_bytes_per_pixel).into(),
        text: |m| or_dash(m.stats, |s| s.frame_bytes_per_pixel.to_string()),
    },
    Column {
        key: "cluster_bytes",
        heading: "cluster KiB",
        meaning: "bytes of the cluster buffers (bounds, lists, indices), KiB",
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
        meaning: "assign tests: light-against-cluster tests of the light assignment",
        shown: CSV_AND_HTML,
        value: |m| work(m).map(|w| w.light_tests).into(),
        text: |m| or_dash(work(m), |w| count(w.light_tests)),
    },
    Column {
        key: "assign_node_tests",
        heading: "node tests",
        meaning: "tree or tile node tests of the light assignment",
        shown: CSV_ONLY,
        value: |m| work(m).map(|w| w.node_tests).into(),
        text: |m| or_dash(work(m), |w| count(w.node_tests)),
    },
    Column {
        key: "assign_entries_written",
        heading: "entries written",
        meaning: "list entries the assignment wrote",
        shown: CSV_ONLY,
        value: |m| work(m).map(|w| w.entries_written).into(),
        text: |m| or_dash(work(m), |w| count(w.entries_written)),
    },
    Column {
        key: "assign_lights_rejected",
        heading: "lights rejected",
        meaning: "lights whose range holds no cluster, rejected before any per-cluster work",
        shown: CSV_ONLY,
        value: |m| work(m).map(|w| w.lights_rejected).into(),
        text: |m| or_dash(work(m), |w| count(w.lights_rejected)),
    },
    Column {
        key: "dropped_lights",
        heading: "dropped",
        meaning: "lights a capped list dropped (counted, never silent)",
        shown: EVERYWHERE,
        value: |m| m.stats.map(|s| s.dropped_lights).into(),
        text: |m| or_dash(m.stats, |s| s.dropped_lights.to_string()),
    },
    Column {
        key: "passes",
        heading: "passes",
        meaning: "each pass's median milliseconds",
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
        meaning: "passes the frame did not need and did not run",
        shown: CSV_AND_HTML,
        value: |m| Cell::Text(m.skipped_passes.join(";")),
        text: |m| m.skipped_passes.join(", "),
    },
    Column {
        key: "reused_from",
        heading: "reused from",
        meaning: "the cell was taken unchanged from an earlier run (`--reuse`): that run's date and revision; its provenance is listed with this run's",
        shown: CSV_AND_HTML,
        value: |m| m.reused_from.map(str::to_string).into(),
        text: |m| m.reused_from.unwrap_or_default().to_string(),
    },
    Column {
        key: "perturbed_depth_ulps",
        heading: "perturbed",
        meaning: "a test mode: every depth the marking passes read was moved this many units in the last place (`CLUSTERLAB_PERTURB_DEPTH_ULPS`), as another rasteriser may store it; empty for a stock run",
        shown: CSV_AND_HTML,
        value: |m| match m.perturbed_depth_ulps {
            0 => Cell::Missing,
            n => n.into(),
        },
        text: |m| match m.perturbed_depth_ulps {
            0 => String::new(),
            n => format!("{n} ULP"),
        },
    },
    Column {
        key: "timing_stop",
        heading: "stopped by",
        meaning: "why the cell stopped timing frames: `precise` (its interval came within the precision asked), `max frames`, `budget` (its time budget was spent first) or `count` (`--frames`)",
        shown: CSV_ONLY,
        value: |m| {
            m.frames
                .and_then(|f| f.stop)
                .map(|s| s.label().to_string())
                .into()
        },
        text: |m| or_dash(m.frames.and_then(|f| f.stop), |s| s.label().to_string()),
    },
    Column {
        key: "vs_baseline",
        heading: "vs baseline",
        meaning: "change against `--baseline`: time ratio, max8 and RMSE8 differences",
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
