//! A run against `--baseline` as a whole: which cells both ran, in how many of them the
//! error figures and the counters are the same, how the cells' times compare, and the two
//! runs' wall times. Each cell's own change is `BaselineChange`, in the tables.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;

use serde::Serialize;
use serde_json::Value;

use super::{CellRecord, Results};

/// The whole-run comparison of a matrix run with its baseline.
#[derive(Clone, Debug, Default)]
pub struct RunComparison {
    /// Cells (by id) that ran in both runs, only in this one, only in the baseline.
    pub common: usize,
    pub only_here: usize,
    pub only_there: usize,
    /// Cells with error figures in both runs.
    pub with_errors: usize,
    /// Of those, the ids of the cells whose figures differ in any way.
    pub errors_changed: Vec<String>,
    /// Cells with counters in both runs.
    pub with_counters: usize,
    /// Cells whose counters are the same in every field.
    pub counters_same: usize,
    /// Each counter that differs somewhere, and in how many cells.
    pub counters_changed: BTreeMap<String, usize>,
    /// Cells timed in both runs, this run's total over the baseline's per cell (sorted).
    pub time_ratios: Vec<f64>,
    /// Of those, the cells whose [min, max] frame times overlap.
    pub spreads_overlap: usize,
    /// Pairs of cells of one group that both runs timed, as each run calls them: told
    /// apart in both, of those the pairs called in opposite order (a faster one in one run
    /// that is the slower in the other: the verdict did not repeat), and the pairs a run
    /// called a tie (in this run, in the baseline).
    pub pairs_apart_in_both: usize,
    pub pairs_flipped: Vec<(String, String)>,
    pub pairs_tied: (usize, usize),
    pub pairs: usize,
    /// Wall seconds of this run and of the baseline, where one run recorded it.
    pub wall_s: Option<f64>,
    pub baseline_wall_s: Option<f64>,
}

/// Compare run `new` with `baseline`, cell by cell.
pub fn compare_runs(new: &Results, baseline: &Results) -> RunComparison {
    let old: BTreeMap<Key, &CellRecord> = baseline.cells.iter().map(|c| (key(c), c)).collect();
    let mut out = RunComparison {
        wall_s: run_wall_s(new),
        baseline_wall_s: run_wall_s(baseline),
        ..RunComparison::default()
    };
    for cell in &new.cells {
        let Some(before) = old.get(&key(cell)) else {
            out.only_here += 1;
            continue;
        };
        out.common += 1;
        if let (Some(a), Some(b)) = (&cell.error, &before.error) {
            out.with_errors += 1;
            if a != b {
                out.errors_changed.push(cell.spec.id.clone());
            }
        }
        if let (Some(a), Some(b)) = (&cell.stats, &before.stats) {
            out.with_counters += 1;
            let changed = changed_fields(&as_value(a), &as_value(b));
            if changed.is_empty() {
                out.counters_same += 1;
            }
            for field in changed {
                *out.counters_changed.entry(field).or_default() += 1;
            }
        }
        if let (Some(t), Some(t_old)) = (cell.total_ms(), before.total_ms())
            && t_old > 0.0
        {
            out.time_ratios.push(t / t_old);
            if let (Some((lo, hi)), Some((lo_old, hi_old))) =
                (total_spread(cell), total_spread(before))
                && lo <= hi_old
                && lo_old <= hi
            {
                out.spreads_overlap += 1;
            }
        }
    }
    compare_verdicts(new, &old, &mut out);
    let here: BTreeSet<Key> = new.cells.iter().map(key).collect();
    out.only_there = old.keys().filter(|k| !here.contains(*k)).count();
    out.time_ratios.sort_by(f64::total_cmp);
    out
}

/// How each pair of one group's cells compares in the two runs (`measure::Interval::compare`).
fn compare_verdicts(new: &Results, old: &BTreeMap<Key, &CellRecord>, out: &mut RunComparison) {
    use crate::measure::{Interval, Verdict};
    let both: Vec<(&CellRecord, &CellRecord)> = new
        .cells
        .iter()
        .filter(|c| c.ok() && c.total_ms().is_some())
        .filter_map(|c| Some((c, *old.get(&key(c))?)))
        .filter(|(_, b)| b.ok() && b.total_ms().is_some())
        .collect();
    for (i, (a, a_old)) in both.iter().enumerate() {
        for (b, b_old) in &both[i + 1..] {
            if a.spec.group() != b.spec.group() {
                continue;
            }
            out.pairs += 1;
            let now = Interval::compare(a.total_interval().as_ref(), b.total_interval().as_ref());
            let then = Interval::compare(
                a_old.total_interval().as_ref(),
                b_old.total_interval().as_ref(),
            );
            out.pairs_tied.0 += usize::from(now == Verdict::Tie);
            out.pairs_tied.1 += usize::from(then == Verdict::Tie);
            let apart = |v: Verdict| matches!(v, Verdict::Faster | Verdict::Slower);
            if apart(now) && apart(then) {
                out.pairs_apart_in_both += 1;
                if now != then {
                    out.pairs_flipped
                        .push((a.spec.id.clone(), b.spec.id.clone()));
                }
            }
        }
    }
}

/// What makes two cells the same cell: its id and, for a file scene, the file's hash (an
/// edited file is another scene). Each cell's own change (`derive`) matches by it too.
pub(super) type Key<'a> = (&'a str, Option<&'a str>);

pub(super) fn key(c: &CellRecord) -> Key<'_> {
    (c.spec.id.as_str(), c.spec.scene_sha256.as_deref())
}

/// The wall time a results file records, when it holds exactly one run that recorded it
/// (merged shards ran side by side: their walls do not add up to a run's).
fn run_wall_s(results: &Results) -> Option<f64> {
    match results.provenance.as_slice() {
        [one] => one.cost.as_ref().map(|c| c.wall_s),
        _ => None,
    }
}

fn as_value(v: &impl Serialize) -> Value {
    serde_json::to_value(v).unwrap_or(Value::Null)
}

/// The fields of two JSON objects that both hold and that differ (a field one run did not
/// record is not compared).
fn changed_fields(a: &Value, b: &Value) -> Vec<String> {
    let (Value::Object(a), Value::Object(b)) = (a, b) else {
        return if a == b {
            Vec::new()
        } else {
            vec!["(all)".into()]
        };
    };
    a.iter()
        .filter(|(k, v)| b.get(*k).is_some_and(|w| w != *v))
        .map(|(k, _)| k.clone())
        .collect()
}

/// A cell's [min, max] total frame time.
fn total_spread(cell: &CellRecord) -> Option<(f64, f64)> {
    let range = cell.gpu_ms_spread.get("total")?.as_array()?;
    Some((range.first()?.as_f64()?, range.get(1)?.as_f64()?))
}

/// The value at fraction `q` of sorted `v` (nearest rank below).
fn quantile(v: &[f64], q: f64) -> f64 {
    v[((v.len() - 1) as f64 * q) as usize]
}

/// Most cell ids named where error figures differ.
const NAMED: usize = 5;

impl fmt::Display for RunComparison {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "against the baseline: {} cells in both ({} only in this run, {} only in the baseline)",
            self.common, self.only_here, self.only_there
        )?;
        let changed = self.errors_changed.len();
        write!(
            f,
            "  error figures: the same in {} of {} cells",
            self.with_errors - changed,
            self.with_errors
        )?;
        if changed > 0 {
            let named: Vec<&str> = self
                .errors_changed
                .iter()
                .take(NAMED)
                .map(String::as_str)
                .collect();
            let more = changed.saturating_sub(NAMED);
            write!(f, "; different in {changed}: {}", named.join(", "))?;
            if more > 0 {
                write!(f, " and {more} more")?;
            }
        }
        writeln!(f)?;
        write!(
            f,
            "  counters: the same in {} of {} cells",
            self.counters_same, self.with_counters
        )?;
        if !self.counters_changed.is_empty() {
            let fields: Vec<String> = self
                .counters_changed
                .iter()
                .map(|(field, n)| format!("{field} in {n}"))
                .collect();
            write!(f, "; different: {}", fields.join(", "))?;
        }
        writeln!(f)?;
        if self.time_ratios.is_empty() {
            writeln!(f, "  time: no cell timed in both runs")?;
        } else {
            let r = &self.time_ratios;
            writeln!(
                f,
                "  time, this run over the baseline, per cell: median x{:.3} (10th-90th percentile x{:.3}-x{:.3}); [min, max] frame times overlap in {} of {} cells",
                quantile(r, 0.5),
                quantile(r, 0.1),
                quantile(r, 0.9),
                self.spreads_overlap,
                r.len()
            )?;
        }
        if self.pairs > 0 {
            write!(
                f,
                "  verdicts: of {} pairs of a group's cells, {} told apart (95% intervals apart) in both runs, {} called in opposite order; {} tied in this run, {} in the baseline",
                self.pairs,
                self.pairs_apart_in_both,
                self.pairs_flipped.len(),
                self.pairs_tied.0,
                self.pairs_tied.1
            )?;
            let named: Vec<String> = self
                .pairs_flipped
                .iter()
                .take(NAMED)
                .map(|(a, b)| format!("{a} / {b}"))
                .collect();
            if !named.is_empty() {
                write!(f, ": {}", named.join(", "))?;
            }
            writeln!(f)?;
        }
        match (self.wall_s, self.baseline_wall_s) {
            (Some(now), Some(then)) if then > 0.0 => writeln!(
                f,
                "  wall time over the cells: {now:.1} s against {then:.1} s (x{:.3})",
                now / then
            ),
            (Some(now), _) => writeln!(
                f,
                "  wall time over the cells: {now:.1} s (the baseline records no single run's wall time)"
            ),
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn changed_fields_names_each_shared_field_that_differs() {
        let a = serde_json::json!({"light_evals": 10, "cluster_bytes": 4, "same": 1});
        let b = serde_json::json!({"light_evals": 11, "same": 1, "extra": 0});
        assert_eq!(changed_fields(&a, &b), vec!["light_evals"]);
        assert!(changed_fields(&a, &a).is_empty());
        assert_eq!(changed_fields(&a, &Value::Null), vec!["(all)"]);
    }

    #[test]
    fn quantiles_pick_the_nearest_rank_below() {
        let v = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0];
        assert_eq!(quantile(&v, 0.5), 6.0);
        assert_eq!(quantile(&v, 0.1), 2.0);
        assert_eq!(quantile(&v, 0.9), 10.0);
        assert_eq!(quantile(&[3.0], 0.9), 3.0);
    }
}
