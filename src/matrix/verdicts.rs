//! Which cell of a group is fastest, decided by the timing itself: cells timed in the same
//! interleaved rounds are compared round by round (`measure::Paired`), so that drift of the
//! machine cancels; the rounds go on only for cells whose verdict is still open; a cell
//! timed in another run or another batch is not compared (`Rank::NotCompared`).

use super::record::{CellRecord, Rank, label};
use crate::measure::{MIN_FRAMES, Paired, TIE_WITHIN, Verdict, median};

/// The cell of `rounds` (frame times per round, None where a cell kept none) that leads:
/// the lowest median time, then any cell the round-by-round comparison finds faster than
/// it (a median of ratios can disagree with the ratio of medians), at most once per cell.
pub fn leader(rounds: &[&[Option<f64>]]) -> Option<usize> {
    let median_of = |r: &[Option<f64>]| {
        let kept: Vec<f64> = r.iter().flatten().copied().collect();
        (!kept.is_empty()).then(|| median(kept))
    };
    let mut lead = (0..rounds.len())
        .filter_map(|i| Some((i, median_of(rounds[i])?)))
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))?
        .0;
    for _ in 0..rounds.len() {
        let faster = (0..rounds.len()).find(|&j| {
            j != lead
                && Paired::of(rounds[j], rounds[lead]).is_some_and(|p| p.verdict == Verdict::Faster)
        });
        match faster {
            Some(j) => lead = j,
            None => break,
        }
    }
    Some(lead)
}

/// After a round: which of the cells still timing (`open`) may stop, their verdict against
/// the leader decided (slower, or a tie) over at least [`MIN_FRAMES`] shared rounds; the
/// leader stops once no other cell is open. Cells with no frame yet stay open.
pub fn decided_after_round(rounds: &[&[Option<f64>]], open: &[bool]) -> Vec<bool> {
    let mut stop = vec![false; rounds.len()];
    let Some(lead) = leader(rounds) else {
        return stop;
    };
    for i in (0..rounds.len()).filter(|&i| open[i] && i != lead) {
        stop[i] = Paired::of(rounds[i], rounds[lead])
            .is_some_and(|p| p.rounds >= MIN_FRAMES && p.verdict.decided());
    }
    stop[lead] = open[lead] && (0..rounds.len()).all(|i| i == lead || !open[i] || stop[i]);
    stop
}

/// What more rounds would decide a pair whose ratio's interval, over `rounds` shared rounds,
/// holds 1: the rounds at which the interval, narrowing as 1 / sqrt(rounds), would either
/// leave 1 or fit within the tie margin, whichever comes first (at least one more round).
pub fn rounds_to_decide(p: &Paired) -> usize {
    let Some(i) = p.interval else {
        return MIN_FRAMES.max(p.rounds + 1);
    };
    let half = (i.hi - i.lo) / 2.0;
    let off = (p.ratio - 1.0).abs();
    // Apart from 1: half-width under `off`; a tie: `off` plus the half-width within the margin.
    let needed = off.max(TIE_WITHIN - off).max(1e-6);
    let scale = (half / needed).powi(2);
    ((p.rounds as f64 * scale).ceil() as usize).max(p.rounds + 1)
}

/// Rounds past which a pair is called a near tie this machine cannot split, rather than
/// given a flag to split it.
pub const MOST_ROUNDS_SUGGESTED: usize = 1000;

/// A group's verdict in one line: the fastest, what ties with it and how many are slower;
/// or, where the timing did not decide, who leads, what is open against it, and the flags
/// (and time) that would decide it.
pub fn group_verdict(cells: &[&CellRecord]) -> String {
    let ms = |c: &CellRecord| c.total_ms().unwrap_or(f64::NAN);
    let with = |r: Rank| -> Vec<&CellRecord> {
        cells
            .iter()
            .copied()
            .filter(|c| c.rank == Some(r))
            .collect()
    };
    let names = |v: &[&CellRecord]| -> String {
        let shown: Vec<String> = v.iter().take(4).map(|c| label(c)).collect();
        match v.len() {
            0..=4 => shown.join(", "),
            n => format!("{} and {} more", shown.join(", "), n - 4),
        }
    };
    let Some(lead) = cells
        .iter()
        .find(|c| matches!(c.rank, Some(Rank::Fastest | Rank::Leads)))
    else {
        if cells.iter().any(|c| c.spec.sequence.is_some()) {
            return "not compared: sequence cells run one after another, not in rounds (their frames differ by design)".into();
        }
        return "no verdict: no cell was timed in rounds".into();
    };
    let tied = with(Rank::TiedWithFastest);
    let slower = with(Rank::Slower).len();
    let bound = with(Rank::SlowerEachRound);
    let mut parts = Vec::new();
    if !tied.is_empty() {
        let within = (crate::measure::TIE_WITHIN * 100.0).round();
        parts.push(format!("tied within {within}%: {}", names(&tied)));
    }
    if slower > 0 {
        parts.push(format!("{slower} slower"));
    }
    if !bound.is_empty() {
        parts.push(format!(
            "too slow for an interval in its budget, slower in each round it took: {}",
            names(&bound)
        ));
    }
    let other = with(Rank::NotCompared);
    if !other.is_empty() {
        parts.push(format!(
            "timed in another run or batch, not compared: {}",
            names(&other)
        ));
    }
    let head = if lead.rank == Some(Rank::Fastest) {
        format!("fastest: {} ({:.2} ms)", label(lead), ms(lead))
    } else {
        let open = with(Rank::Undecided);
        let listed: Vec<String> = open
            .iter()
            .take(3)
            .map(|c| match c.against_leader.as_ref().map(|a| a.paired) {
                Some(p) => match p.interval {
                    Some(i) => format!(
                        "{} (x{:.2}-{:.2} over {})",
                        label(c),
                        i.lo,
                        i.hi,
                        crate::measure::rounds(p.rounds)
                    ),
                    None => format!("{} ({} shared)", label(c), crate::measure::rounds(p.rounds)),
                },
                None => format!("{} (no shared round)", label(c)),
            })
            .collect();
        let more = match open.len() {
            0..=3 => String::new(),
            n => format!(" and {} more", n - 3),
        };
        format!(
            "undecided: {} leads ({:.2} ms), open against {}{more}; {}",
            label(lead),
            ms(lead),
            listed.join(", "),
            what_would_decide(lead, &open)
        )
    };
    std::iter::once(head)
        .chain(parts)
        .collect::<Vec<_>>()
        .join("; ")
}

/// The flags that would give the open cells and the leader the rounds their verdicts
/// need (`rounds_to_decide`), and about how long those frames would take.
fn what_would_decide(lead: &CellRecord, open: &[&CellRecord]) -> String {
    let needed = open
        .iter()
        .map(|c| {
            c.against_leader
                .as_ref()
                .and_then(|a| a.rounds_to_decide)
                .unwrap_or(MIN_FRAMES)
        })
        .max()
        .unwrap_or(MIN_FRAMES);
    if needed > MOST_ROUNDS_SUGGESTED {
        return format!(
            "a near tie: over {MOST_ROUNDS_SUGGESTED} rounds would be needed to split it on this machine"
        );
    }
    let ms = |c: &CellRecord| c.total_ms().unwrap_or(0.0);
    let slowest = open.iter().map(|c| ms(c)).fold(ms(lead), f64::max);
    // A cell's budget counts its untimed frame without lights too: a fifth more; never
    // below the default, which a suggestion must not lower.
    let budget_ms = ((needed as f64 * slowest * 1.2 / 100.0).ceil() * 100.0)
        .max(crate::measure::Budget::DEFAULT.budget_ms);
    let taken = lead.frames as usize;
    let more_s: f64 = std::iter::once(lead)
        .chain(open.iter().copied())
        .map(|c| needed.saturating_sub(taken.min(c.frames as usize)) as f64 * ms(c))
        .sum::<f64>()
        / 1e3;
    format!(
        "about {needed} rounds would decide it: `--max-frames {needed} --budget-ms {budget_ms:.0}` (about {more_s:.0} s more of frames for this group)"
    )
}

/// The fastest of the cells `pick` keeps among a group's compared cells, decided round by
/// round against each of the others: "NAME (ms)" with what ties with it, or "undecided"
/// with what is open; "-" where none is kept.
pub fn fastest_among(cells: &[&CellRecord], pick: impl Fn(&CellRecord) -> bool) -> String {
    let kept: Vec<&CellRecord> = cells
        .iter()
        .copied()
        .filter(|c| pick(c) && !matches!(c.rank, None | Some(Rank::NotCompared)))
        .collect();
    let rounds: Vec<&[Option<f64>]> = kept.iter().map(|c| &c.round_ms[..]).collect();
    let Some(lead) = leader(&rounds) else {
        return "-".into();
    };
    let mut tied = Vec::new();
    let mut open = Vec::new();
    for k in (0..kept.len()).filter(|&k| k != lead) {
        match Paired::of(rounds[k], rounds[lead]).map(|p| p.verdict) {
            Some(Verdict::Tie) => tied.push(label(kept[k])),
            Some(Verdict::Slower) => {}
            _ if kept[k].rank == Some(Rank::SlowerEachRound) => {}
            _ => open.push(label(kept[k])),
        }
    }
    let few = |v: &[String]| match v.len() {
        0..=4 => v.join(", "),
        n => format!("{} and {} more", v[..4].join(", "), n - 4),
    };
    let ms = kept[lead].total_ms().unwrap_or(f64::NAN);
    let mut text = if open.is_empty() {
        format!("{} ({ms:.2} ms)", label(kept[lead]))
    } else {
        format!(
            "undecided: {} leads ({ms:.2} ms), open against {}",
            label(kept[lead]),
            few(&open)
        )
    };
    if !tied.is_empty() {
        text += &format!("; tied with it ({}): {}", tied.len(), few(&tied));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rounds(times: &[f64]) -> Vec<Option<f64>> {
        times.iter().map(|&t| Some(t)).collect()
    }

    /// Drift that moves every cell of a round alike cancels in the ratio: a cell 20% slower
    /// on a machine whose speed halves and recovers is slower after 6 rounds; an unpaired
    /// comparison of the two medians' intervals cannot tell them apart.
    #[test]
    fn paired_rounds_cancel_drift() {
        let drift = [1.0, 2.0, 1.5, 0.8, 2.5, 1.1];
        let a: Vec<f64> = drift.iter().map(|d| 10.0 * d).collect();
        let b: Vec<f64> = drift.iter().map(|d| 12.0 * d).collect();
        let p = Paired::of(&rounds(&b), &rounds(&a)).unwrap();
        assert_eq!(p.verdict, Verdict::Slower, "{p:?}");
        let unpaired = crate::measure::Interval::compare(
            crate::measure::median_interval(&b).as_ref(),
            crate::measure::median_interval(&a).as_ref(),
        );
        assert_eq!(unpaired, Verdict::Undecided);
    }

    #[test]
    fn the_clearly_slower_cell_stops_and_the_near_tie_goes_on() {
        let lead = rounds(&[10.0, 10.2, 9.9, 10.1, 10.0, 9.8]);
        let slow = rounds(&[20.0, 20.4, 19.8, 20.2, 20.0, 19.6]);
        // 4% faster to 16% slower round by round: the interval holds 1 and reaches past the
        // margin.
        let near = rounds(&[10.2, 11.8, 9.5, 11.5, 11.6, 9.6]);
        let all = [&lead[..], &slow[..], &near[..]];
        assert_eq!(leader(&all), Some(0));
        let stop = decided_after_round(&all, &[true, true, true]);
        assert_eq!(stop, [false, true, false]);
        // Five rounds are too few for an interval: nothing stops.
        let five = [&lead[..5], &slow[..5], &near[..5]];
        assert_eq!(decided_after_round(&five, &[true; 3]), [false; 3]);
        // With the near tie out of the rounds, the leader stops too.
        assert_eq!(
            decided_after_round(&all, &[true, true, false]),
            [true, true, false]
        );
        let p = Paired::of(&near, &lead).unwrap();
        assert_eq!(p.verdict, Verdict::Undecided);
        assert!(rounds_to_decide(&p) > 6, "{p:?}");
    }

    /// Two copies of one cell whose rounds differ by noise alone are a tie once the ratio's
    /// interval fits within the margin; the deliberate break, a margin of zero (what "the
    /// intervals overlap" claims), never decides them.
    #[test]
    fn copies_of_one_cell_are_a_tie() {
        let a = rounds(&[10.0, 10.3, 9.8, 10.1, 10.0, 9.9, 10.2, 10.0]);
        let b = rounds(&[10.1, 10.1, 10.0, 9.9, 10.2, 10.0, 10.0, 9.8]);
        let p = Paired::of(&a, &b).unwrap();
        assert_eq!(p.verdict, Verdict::Tie, "{p:?}");
        assert_eq!(
            Verdict::of_ratio_within(p.interval.as_ref(), 0.0),
            Verdict::Undecided,
            "with no margin a tie is never decided"
        );
    }
}
