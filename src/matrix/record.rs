//! What a matrix run records: each cell (its spec, figures, images and rank), the run's
//! provenance and cost, and the results file that holds them.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use crate::gpu::{AdapterSummary, PipelineStats};
use crate::measure::{Front, Interval, Paired, Stop};
use crate::metrics::ErrorMetrics;
use crate::render::FrameStats;
use crate::run::{CellCost, RunError};
use crate::sequence::SequenceSummary;

use super::plan::{CellSpec, ParamsRecord};

/// Everything a matrix run wrote about one cell.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CellRecord {
    #[serde(flatten)]
    pub spec: CellSpec,
    /// Why the cell failed; absent when it ran.
    pub failure: Option<String>,
    /// The adapter, or the limits `--limits` chose, lacks what the cell needs (`failure`
    /// names what): the cell is counted as refused, not failed, and the run still succeeds.
    #[serde(default)]
    pub refused: bool,
    /// Median milliseconds per pass over the timed frames, with `total`.
    pub gpu_ms: Map<String, Value>,
    /// [min, max] milliseconds per pass over the timed frames.
    pub gpu_ms_spread: Map<String, Value>,
    /// [lo, hi] milliseconds per pass: the median's confidence interval at
    /// `interval_level` (`measure::median_interval`); empty with too few frames for one.
    #[serde(default)]
    pub gpu_ms_interval: Map<String, Value>,
    /// The probability that each interval holds its median (at least `measure::LEVEL`).
    #[serde(default)]
    pub interval_level: Option<f64>,
    /// Why the cell stopped timing frames.
    #[serde(default)]
    pub timing_stop: Option<Stop>,
    pub timing_source: Option<String>,
    pub frames: u32,
    pub wall_ms: Option<f64>,
    pub reference_ms: Option<f64>,
    pub error: Option<ErrorMetrics>,
    pub stats: Option<FrameStats>,
    /// Distance from perfect culling (`efficiency`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub efficiency: Option<crate::efficiency::Efficiency>,
    /// Its image against its group's truth (`Fidelity`): what the time-error front and
    /// "most accurate" read. `error` is against its own reference: what its claim is
    /// checked by.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fidelity: Option<Fidelity>,
    /// Image files, relative to the results folder.
    pub images: Images,
    /// Naive forward's frame over this cell's, the median over the rounds both were timed
    /// in (same scene and parameters, same batch).
    pub speedup_vs_naive: Option<f64>,
    /// [lo, hi]: that median's interval at `interval_level` (absent under 6 shared
    /// rounds); a range holding 1 is no speed-up.
    #[serde(default)]
    pub speedup_interval: Option<[f64; 2]>,
    /// The smallest speed-up of any shared round, and how many rounds there were: a bound
    /// that holds for every round measured, where there are too few for an interval.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speedup_least: Option<(f64, usize)>,
    /// Where it stands on its group's time-error front (absent when not timed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub front: Option<Front>,
    /// Where its time stands in its group: the fastest, tied with it, slower, undecided,
    /// or not compared.
    #[serde(default)]
    pub rank: Option<Rank>,
    /// The batch of its run it was timed in: cells compare only with cells of the same run
    /// and batch (timed in the same interleaved rounds).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub batch: Option<usize>,
    /// Its frame's total milliseconds in each round of its batch (null where it took none:
    /// not yet started, or stopped). Verdicts and speed-ups compare these round by round.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub round_ms: Vec<Option<f64>>,
    /// Its frame over the group leader's, round by round (absent for the leader itself).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub against_leader: Option<AgainstLeader>,
    /// The run that made this record: its index in `provenance` (0 for this run's own
    /// cells; a reused or merged cell keeps its own run's).
    #[serde(default)]
    pub run: usize,
    /// The variant claimed to be within 1 LSB of the reference on its adapter
    /// (`run::exact_claim`): a record over it that says it passed is refused.
    #[serde(default)]
    pub exact_claim: bool,
    /// What the scene's loader left out or chose, and where the depth margin blunts
    /// z-culling (`run::margin_note`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    /// Made with every depth marking read moved this many units in the last place
    /// (`CLUSTERLAB_PERTURB_DEPTH_ULPS`, a test mode; 0 for a stock run).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub perturbed_depth_ulps: u32,
    /// Taken unchanged from an earlier run (`--reuse`): that run's date and revision.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reused_from: Option<String>,
    /// Change against `--baseline` (a cell with the same id there).
    pub vs_baseline: Option<BaselineChange>,
    /// Passes the last timed frame skipped (not needed by this scene and variant).
    #[serde(default)]
    pub skipped_passes: Vec<String>,
    /// Untimed frames run before the timed ones.
    #[serde(default)]
    pub warmup_frames: u32,
    /// A frame without lights was drawn first, untimed (frames by budget; see
    /// `measure::Budget`).
    #[serde(default)]
    pub frame_without_lights: bool,
    /// Frames set aside because other processes took the cores (`measure::CpuClock`).
    #[serde(default)]
    pub disturbed_frames: u32,
    /// Where the cell's wall-clock time went (absent for a failed cell).
    #[serde(default)]
    pub cost_ms: Option<CellCost>,
    /// A sequence cell's figures (its times are of the frames after the first, its error
    /// the worst checked frame's, its counters and images the last frame's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sequence_summary: Option<SequenceSummary>,
}

/// Where a cell's time stands in its group (scene and parameters), against the group's
/// leader round by round (`measure::Paired`, `verdicts::leader`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Rank {
    /// The leader, and every other cell compared is decided against it (slower or tied).
    Fastest,
    /// The lowest time, with some other cell still undecided against it.
    Leads,
    /// Within the tie margin of the leader (`measure::TIE_WITHIN`), at 95%.
    TiedWithFastest,
    /// Slower than the leader, at 95%.
    Slower,
    /// Too slow for an interval within its budget (naive forward's frames of a second or
    /// more), and slower than the leader by more than the tie margin in each round it
    /// took: a bound on the rounds measured, not a 95% verdict.
    SlowerEachRound,
    /// Not decided: too few shared rounds for an interval, or one that holds 1 and reaches
    /// past the tie margin (the leader too, while any other is undecided).
    #[serde(alias = "too_few_frames")]
    Undecided,
    /// Timed in another run or batch than the group's compared cells (reused, merged,
    /// or more cells than one batch holds): its times are not compared with theirs.
    NotCompared,
}

impl Rank {
    pub fn label(self) -> &'static str {
        match self {
            Rank::Fastest => "fastest",
            Rank::Leads => "leads",
            Rank::TiedWithFastest => "tie",
            Rank::Slower => "slower",
            Rank::SlowerEachRound => "slower each round",
            Rank::Undecided => "undecided",
            Rank::NotCompared => "other run",
        }
    }
}

/// A cell's standing against its group's leader.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AgainstLeader {
    /// This cell's frame time over the leader's, round by round.
    pub paired: Paired,
    /// Rounds that would decide it, where it is undecided (`verdicts::rounds_to_decide`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rounds_to_decide: Option<usize>,
}

/// How far a cell's image is from its group's truth: the f64 reference of the most
/// complete lighting any cell of the group computes (with exact shadows where any cell
/// traces shadow rays), shaded on the cell's own raster truth. A cell whose own reference
/// is that truth has its own error here.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fidelity {
    /// Which truth: `its own reference`, or `exact shadows` (the group's).
    pub truth: String,
    pub rmse_8bit: f64,
    /// The largest 8-bit difference; against a shadowed truth, outside the range its
    /// ambiguous shadow rays allow (`metrics::ShadowError`).
    pub max_8bit: u32,
}

impl Fidelity {
    pub const OWN: &str = "its own reference";
    pub const SHADOWED: &str = "exact shadows";

    pub fn of(e: &crate::metrics::ErrorMetrics, truth: &str) -> Fidelity {
        Fidelity {
            truth: truth.into(),
            rmse_8bit: e.rmse_8bit,
            max_8bit: e
                .shadows
                .as_ref()
                .map_or(e.max_abs_8bit, |s| s.max_outside_ambiguity_8bit),
        }
    }
}

#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Images {
    pub image: Option<String>,
    pub heat: Option<String>,
    /// Lights per cluster (clustered variants, cells without sweeps).
    pub debug: Option<String>,
    /// A sequence's animation (`images/NAME.gif`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub animation: Option<String>,
    /// A sequence's time per pass over its frames (`plots/NAME.frames.svg`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frames_plot: Option<String>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BaselineChange {
    /// This run's total GPU time over the baseline's.
    pub time_ratio: f64,
    pub max_abs_8bit_change: i64,
    pub rmse_8bit_change: f64,
}

impl CellRecord {
    pub fn ok(&self) -> bool {
        self.failure.is_none()
    }

    /// On its group's time-error front, decided.
    pub fn on_front(&self) -> bool {
        self.front == Some(Front::On)
    }

    /// Its RMSE against its group's truth; None where it has none (a variant the truth
    /// cannot be shaded for, a sequence, results written before fidelity was recorded).
    pub fn fidelity_rmse(&self) -> Option<f64> {
        self.fidelity.as_ref().map(|f| f.rmse_8bit)
    }

    /// Exact against its group's truth: it passed, within 1 LSB of that truth (outside
    /// ambiguous shadow rays) and dropped no light. A cell without a truth is not.
    pub fn exact_to_truth(&self) -> bool {
        let within = self
            .fidelity
            .as_ref()
            .is_some_and(|f| f.max_8bit <= crate::run::EXACT_LSB);
        self.ok() && within && self.stats.as_ref().is_none_or(|s| s.dropped_lights == 0)
    }

    /// Median total GPU milliseconds.
    pub fn total_ms(&self) -> Option<f64> {
        self.gpu_ms.get("total").and_then(Value::as_f64)
    }

    /// The total's confidence interval (`gpu_ms_interval.total`).
    pub fn total_interval(&self) -> Option<Interval> {
        let pair = self.gpu_ms_interval.get("total")?.as_array()?;
        Some(Interval {
            lo: pair.first()?.as_f64()?,
            hi: pair.get(1)?.as_f64()?,
            level: self.interval_level?,
        })
    }

    /// A cell that did not run: refused when the adapter cannot run it (`RunError::refused`).
    pub(super) fn not_run(spec: CellSpec, e: &RunError) -> Self {
        let mut record = Self::failed(spec, e.to_string());
        record.refused = e.refused();
        record
    }

    pub(super) fn failed(spec: CellSpec, why: String) -> Self {
        Self {
            spec,
            failure: Some(why),
            refused: false,
            gpu_ms: Map::new(),
            gpu_ms_spread: Map::new(),
            gpu_ms_interval: Map::new(),
            interval_level: None,
            timing_stop: None,
            timing_source: None,
            frames: 0,
            wall_ms: None,
            reference_ms: None,
            error: None,
            stats: None,
            efficiency: None,
            fidelity: None,
            images: Images::default(),
            speedup_vs_naive: None,
            speedup_interval: None,
            speedup_least: None,
            front: None,
            rank: None,
            batch: None,
            round_ms: Vec::new(),
            against_leader: None,
            run: 0,
            reused_from: None,
            exact_claim: false,
            notes: Vec::new(),
            perturbed_depth_ulps: 0,
            vs_baseline: None,
            skipped_passes: Vec::new(),
            warmup_frames: 0,
            frame_without_lights: false,
            disturbed_frames: 0,
            cost_ms: None,
            sequence_summary: None,
        }
    }
}

/// Where and how results were made.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Provenance {
    pub tool: String,
    pub date: String,
    pub git_revision: String,
    /// The working tree had uncommitted changes.
    pub git_dirty: bool,
    pub adapter: AdapterSummary,
    pub hdr_format: String,
    pub timing_source: String,
    pub command: Vec<String>,
    /// `K/N` when the run was one shard of a study.
    pub shard: Option<String>,
    /// SHA-256 of each variant file's text, by variant name.
    pub variant_files: BTreeMap<String, VariantFile>,
    /// Built-in scene generators and their defaults, by name.
    pub scenes: BTreeMap<String, ParamsRecord>,
    /// How many frames each cell rendered: an exact count, or by budget.
    #[serde(default)]
    pub frames: String,
    /// What the run spent and where (absent in results written before it was recorded).
    #[serde(default)]
    pub cost: Option<RunCost>,
    /// LP_NUM_THREADS: the threads a software GPU split each pass among (absent when unset,
    /// one per core, and in results written before it was recorded).
    #[serde(default)]
    pub software_gpu_threads: Option<String>,
    /// The shader folder composed from and its content's hash.
    #[serde(default)]
    pub shaders: crate::compose::ShaderTree,
    /// Every environment variable that can change a figure, as it was
    /// (`environment::recorded`).
    #[serde(default)]
    pub environment: Vec<String>,
    /// `CLUSTERLAB_PERTURB_DEPTH_ULPS`: every depth marking read was moved by this many
    /// units in the last place (0: a stock run).
    #[serde(default)]
    pub perturbed_depth_ulps: u32,
}

/// What a run spent: wall-clock seconds over its cells, split as each cell's cost is, and
/// what compiling pipelines once per run did.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct RunCost {
    pub wall_s: f64,
    /// Each cell's cost, summed.
    pub cells_ms: CellCost,
    pub pipelines: PipelineStats,
    pub warmup_frames: u32,
    pub timed_frames: u32,
    /// Distinct reference frames, and the f64 shadings they were made from (variants that
    /// differ only in post effects, or whose rasterisations agree bit for bit, share one).
    #[serde(default)]
    pub reference_frames: usize,
    #[serde(default)]
    pub reference_shadings: usize,
    /// Cells taken unchanged from an earlier run (`--reuse`); their costs are not counted.
    #[serde(default)]
    pub reused_cells: usize,
}

impl RunCost {
    /// One line for the terminal.
    pub fn line(&self) -> String {
        let c = &self.cells_ms;
        let s = |ms: f64| format!("{:.0} s", ms / 1e3);
        let reused = match self.reused_cells {
            0 => String::new(),
            n => format!(" ({n} cells reused from an earlier run)"),
        };
        format!(
            "{:.0} s over the cells{reused}: frames {} ({:.0}% of the run; {} timed, {} untimed), counters {}, reference {} ({} frames from {} shadings), images {}, set-up {}; {} pipelines compiled, {} reused ({:.1} s compiling)",
            self.wall_s,
            s(c.frames),
            100.0 * c.frames / (self.wall_s * 1e3).max(1e-9),
            self.timed_frames,
            self.warmup_frames,
            s(c.counters),
            s(c.reference),
            self.reference_frames,
            self.reference_shadings,
            s(c.images),
            s(c.setup),
            self.pipelines.created,
            self.pipelines.reused,
            self.pipelines.creation_ms / 1e3
        )
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct VariantFile {
    pub path: PathBuf,
    pub sha256: String,
}

/// The contents of results.json.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Results {
    /// One per run that contributed cells (several after `merge`).
    pub provenance: Vec<Provenance>,
    pub cells: Vec<CellRecord>,
    /// The cells this run took unchanged from an earlier one (`--reuse`), by id.
    #[serde(skip)]
    pub reused: Vec<String>,
}

impl Results {
    /// Cells that failed, leaving out those the adapter refused.
    pub fn failed(&self) -> usize {
        self.cells.iter().filter(|c| !c.ok() && !c.refused).count()
    }

    pub fn refused(&self) -> usize {
        self.cells.iter().filter(|c| c.refused).count()
    }

    /// "N cells, F failed" and, where the adapter refused some, "R refused by the adapter".
    pub fn tally(&self) -> String {
        let refused = match self.refused() {
            0 => String::new(),
            n => format!(", {n} refused by the adapter"),
        };
        format!(
            "{} cells, {} failed{refused}",
            self.cells.len(),
            self.failed()
        )
    }
}

/// The variant with what was swept, apart from the light count (a column of its own).
pub fn label(c: &CellRecord) -> String {
    let extra: Vec<String> = c
        .spec
        .sweep
        .iter()
        .filter(|(k, _)| *k != "lights")
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    if extra.is_empty() {
        c.spec.variant.clone()
    } else {
        format!("{}[{}]", c.spec.variant, extra.join(","))
    }
}

/// Cells grouped by scene and parameters (in order of first appearance), each group
/// fastest first, failed cells last.
pub fn grouped(results: &Results) -> Vec<(String, Vec<&CellRecord>)> {
    let mut groups: Vec<(String, Vec<&CellRecord>)> = Vec::new();
    for c in &results.cells {
        let g = c.spec.group();
        match groups.iter_mut().find(|(k, _)| *k == g) {
            Some((_, v)) => v.push(c),
            None => groups.push((g, vec![c])),
        }
    }
    for (_, cells) in &mut groups {
        cells.sort_by(|a, b| {
            let key = |c: &CellRecord| c.total_ms().unwrap_or(f64::INFINITY);
            key(a).total_cmp(&key(b))
        });
    }
    groups
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}
