//! How many frames a cell times: an exact count, or frames by budget, in the spirit of
//! criterion and hyperfine: frames until the median is known to a stated precision or the
//! cell's time budget is spent.

use serde::{Deserialize, Serialize};

/// Frames of a cell, before and while timing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Frames {
    /// `warmup` untimed frames, then exactly `timed` timed ones (at least 1).
    Exact { warmup: u32, timed: u32 },
    /// Timed frames until `Budget::enough`.
    Budget(Budget),
}

impl Frames {
    pub const fn exact(warmup: u32, timed: u32) -> Self {
        Frames::Exact { warmup, timed }
    }
}

/// How far a cell's timing may go while its verdict is open: the matrix times a group's
/// cells in interleaved rounds and stops each once its verdict against the leader is
/// decided (`matrix::verdicts`), or once it has spent `budget_ms` or taken `max_frames`.
///
/// A cell's first frame would pay for first use: software rasterisers compile a pipeline's
/// shader variants on its first draw, and every new image is touched for the first time.
/// So a cell first draws one frame without its lights, untimed
/// (`Renderer::draw_without_lights`), which pays that for about what a frame with nothing
/// to shade costs, and times frames from its first whole one on.
///
/// Measured on lavapipe over the 195 cells of the default matrix that are not naive forward
/// (`matrix --frames 4 --warmup 0`, the first frame against the median of the other
/// three): without the frame without lights, first frames are 8.6% longer at the median
/// and 25.8% at the 90th percentile where the cell made new pipelines, 7.5% and 26.6%
/// where it found them made; after it, -1.7% and 8.9%, 0.0% and 12.1%. It costs 22 ms on
/// average with new pipelines and 15 ms without, where a whole first frame costs 97 and
/// 26 ms.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Budget {
    /// Milliseconds of frames (their summed pass times, the untimed frames included) a
    /// cell may spend while its verdict is open.
    pub budget_ms: f64,
    /// The most frames (rounds) a cell takes while its verdict is open.
    pub max_frames: u32,
}

/// The confidence level of every time's interval ([`median_interval`]).
pub const LEVEL: f64 = 0.95;

/// The fewest frames whose order statistics bracket the median at [`LEVEL`]: [min, max] of
/// 6 frames holds it with probability 1 - 2^-5 = 96.9%, of 5 only 93.75%.
pub const MIN_FRAMES: usize = 6;

/// A confidence interval for the median time, in milliseconds: the distribution-free
/// order-statistic interval [x(k), x(n+1-k)] of n frames sorted (David and Nagaraja, Order
/// Statistics, section 7.1), with the largest k whose coverage, 1 - 2 P(Binomial(n, 1/2) <
/// k), is still at least [`LEVEL`]. It assumes only that the frames are drawn alike; the
/// matrix times a group's cells in interleaved rounds, so drift of the machine moves each
/// alike.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    pub lo: f64,
    pub hi: f64,
    /// The probability that the interval holds the median (at least [`LEVEL`]).
    pub level: f64,
}

/// Two times are a tie when their ratio is known (at [`LEVEL`]) to lie within
/// [1 / (1 + TIE_WITHIN), 1 + TIE_WITHIN]: closer than that, which is faster is not a
/// difference worth a verdict. 10% because a software adapter's round-to-round ratio of two
/// copies of one variant spreads about +-15% (quartiles; `docs/measurement.md`, "Verdicts"), so
/// a tie is decided in about 20 rounds; a narrower margin would need hundreds.
pub const TIE_WITHIN: f64 = 0.10;

/// How one time compares with another. Faster and slower are told apart only where the
/// interval of their ratio (or their two intervals) lies wholly on one side of 1; a tie is
/// decided only where it lies within [`TIE_WITHIN`] of 1; otherwise the measurement has
/// not decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    Faster,
    Slower,
    /// Within [`TIE_WITHIN`] of each other, at [`LEVEL`].
    Tie,
    /// The interval holds 1 and reaches past the tie margin, or there is none (too few
    /// rounds): more rounds would decide.
    Undecided,
}

impl Verdict {
    /// Whether the measurement decided (faster, slower or a tie).
    pub fn decided(self) -> bool {
        self != Verdict::Undecided
    }

    /// The verdict on `a` against `b` from the interval of the ratio a / b.
    pub fn of_ratio(ratio: Option<&Interval>) -> Verdict {
        Self::of_ratio_within(ratio, TIE_WITHIN)
    }

    /// [`Verdict::of_ratio`] with a tie margin of `margin` (tests break it with 0).
    pub fn of_ratio_within(ratio: Option<&Interval>, margin: f64) -> Verdict {
        let tie = 1.0 + margin;
        match ratio {
            Some(r) if r.hi < 1.0 => Verdict::Faster,
            Some(r) if r.lo > 1.0 => Verdict::Slower,
            Some(r) if r.lo >= 1.0 / tie && r.hi <= tie => Verdict::Tie,
            _ => Verdict::Undecided,
        }
    }

    pub fn label(self) -> &'static str {
        match self {
            Verdict::Faster => "faster",
            Verdict::Slower => "slower",
            Verdict::Tie => "tie",
            Verdict::Undecided => "undecided",
        }
    }
}

impl Interval {
    /// How a time with interval `this` compares with one with `other`, timed apart (not in
    /// the same rounds): the ratio of the two medians lies in [this.lo / other.hi,
    /// this.hi / other.lo] when both intervals hold their medians. Without an interval,
    /// undecided.
    pub fn compare(this: Option<&Interval>, other: Option<&Interval>) -> Verdict {
        match (this, other) {
            (Some(a), Some(b)) if b.lo > 0.0 && a.lo > 0.0 => Verdict::of_ratio(Some(&Interval {
                lo: a.lo / b.hi,
                hi: a.hi / b.lo,
                level: a.level.min(b.level),
            })),
            _ => Verdict::Undecided,
        }
    }
}

/// The probability that [x(k), x(n+1-k)] (1-based order statistics of n independent draws
/// of one continuous distribution) holds the median: 1 - 2 P(Binomial(n, 1/2) <= k - 1).
pub fn coverage(n: usize, k: usize) -> f64 {
    if k == 0 || 2 * k > n + 1 {
        return 0.0;
    }
    // P(B <= k - 1) = sum over i < k of C(n, i) / 2^n, each term from the one before.
    let mut term = 0.5f64.powi(n as i32);
    let mut tail = 0.0;
    for i in 0..k {
        tail += term;
        term *= (n - i) as f64 / (i + 1) as f64;
    }
    (1.0 - 2.0 * tail).max(0.0)
}

/// The order-statistic interval of `times` at [`LEVEL`] (see [`Interval`]); None with fewer
/// than [`MIN_FRAMES`] times, whose widest interval, [min, max], holds the median less often.
pub fn median_interval(times: &[f64]) -> Option<Interval> {
    let n = times.len();
    let k = (1..=n.div_ceil(2))
        .take_while(|&k| coverage(n, k) >= LEVEL)
        .last()?;
    let mut sorted = times.to_vec();
    sorted.sort_by(f64::total_cmp);
    Some(Interval {
        lo: sorted[k - 1],
        hi: sorted[n - k],
        level: coverage(n, k),
    })
}

/// Where a point stands on the time-error front of the points it is compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Front {
    /// No other point dominates it, and every point at least as accurate is decided
    /// against it.
    On,
    /// Another point is decided faster and at least as accurate, or tied and more
    /// accurate.
    Dominated,
    /// Not dominated, but a point at least as accurate is undecided against it: it may be.
    Undecided,
}

impl Front {
    pub fn label(self) -> &'static str {
        match self {
            Front::On => "*",
            Front::Dominated => "",
            Front::Undecided => "?",
        }
    }
}

/// Where point `k` of `n` stands on their time-error front: `error(j)` is point j's error
/// (None: it takes no part), `verdict(j, k)` how j's time compares with k's. The one rule
/// of the matrix and the studies.
pub fn front(
    k: usize,
    n: usize,
    error: impl Fn(usize) -> Option<f64>,
    verdict: impl Fn(usize, usize) -> Verdict,
) -> Option<Front> {
    let e = error(k)?;
    let mut standing = Front::On;
    for j in (0..n).filter(|&j| j != k) {
        let Some(ej) = error(j) else { continue };
        let v = verdict(j, k);
        if (v == Verdict::Faster && ej <= e) || (v == Verdict::Tie && ej < e) {
            return Some(Front::Dominated);
        }
        if v == Verdict::Undecided && ej <= e {
            standing = Front::Undecided;
        }
    }
    Some(standing)
}

/// Two cells timed in the same interleaved rounds, compared round by round: the ratio of
/// their frames in each round both kept, so that drift of the machine (which moves both
/// frames of a round alike) cancels. Its median and that median's interval
/// ([`median_interval`] over the rounds' ratios) decide the verdict.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Paired {
    /// Median over the shared rounds of a / b.
    pub ratio: f64,
    /// The median ratio's interval at [`LEVEL`] (None under [`MIN_FRAMES`] shared rounds).
    pub interval: Option<Interval>,
    /// The smallest and largest ratio of any shared round.
    pub range: [f64; 2],
    /// Rounds in which both kept a frame.
    pub rounds: usize,
    pub verdict: Verdict,
}

impl Paired {
    /// `a` against `b`, each a frame time (ms) per round, None where it kept none. None
    /// when they share no round.
    pub fn of(a: &[Option<f64>], b: &[Option<f64>]) -> Option<Paired> {
        let ratios: Vec<f64> = a
            .iter()
            .zip(b)
            .filter_map(|(x, y)| match (x, y) {
                (Some(x), Some(y)) if *y > 0.0 => Some(x / y),
                _ => None,
            })
            .collect();
        if ratios.is_empty() {
            return None;
        }
        let interval = median_interval(&ratios);
        let min = ratios.iter().copied().fold(f64::INFINITY, f64::min);
        let max = ratios.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Some(Paired {
            ratio: median(ratios.clone()),
            interval,
            range: [min, max],
            rounds: ratios.len(),
            verdict: Verdict::of_ratio(interval.as_ref()),
        })
    }
}

/// "1 round", "6 rounds".
pub fn rounds(n: usize) -> String {
    match n {
        1 => "1 round".into(),
        n => format!("{n} rounds"),
    }
}

/// Why a cell stopped timing frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stop {
    /// Its interval came within the precision asked (results written before a group's
    /// verdicts decided its rounds).
    Precise,
    /// It took the most frames allowed first.
    MaxFrames,
    /// Its time budget was spent first.
    Budget,
    /// An exact number of frames was asked (`--frames`).
    Count,
    /// Its verdict against the group's fastest was decided (slower, or a tie), or it is
    /// the fastest and every other cell's was.
    Decided,
}

impl Stop {
    pub fn label(self) -> &'static str {
        match self {
            Stop::Precise => "precise",
            Stop::MaxFrames => "max frames",
            Stop::Budget => "budget",
            Stop::Count => "count",
            Stop::Decided => "decided",
        }
    }
}

impl Default for Budget {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Budget {
    /// What the matrix uses unless told otherwise (`docs/measurement.md`, "Verdicts"):
    /// up to 40 rounds, enough for a tie within [`TIE_WITHIN`] at the spread two copies
    /// of one variant show on lavapipe, and 2000 ms, which gives a cell of up to 300 ms a
    /// frame the 6 rounds an interval needs. Naive forward's frames of a second or more
    /// take a round or two: their speed-ups carry the least ratio of any round as a bound.
    pub const DEFAULT: Budget = Budget {
        budget_ms: 2000.0,
        max_frames: 40,
    };

    /// Whether a cell that took `frames` frames of `frame_ms` each (their median) and spent
    /// `spent_ms` of frames (untimed ones included) has reached its frame cap or its budget,
    /// and which: None while it may go on (and before its first frame). A cell whose budget
    /// cannot hold the [`MIN_FRAMES`] an interval needs stops at once: more frames would
    /// buy no verdict.
    pub fn spent(&self, frames: usize, frame_ms: f64, spent_ms: f64) -> Option<Stop> {
        let short = MIN_FRAMES.saturating_sub(frames) as f64 * frame_ms;
        if frames == 0 {
            None
        } else if frames as u32 >= self.max_frames.max(1) {
            Some(Stop::MaxFrames)
        } else if spent_ms >= self.budget_ms || spent_ms + short > self.budget_ms {
            Some(Stop::Budget)
        } else {
            None
        }
    }
}

/// How a cell's frames went, as reports give it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameCount {
    /// Frames run untimed first.
    pub warmup: u32,
    /// Timed frames.
    pub timed: u32,
    /// A frame without lights was drawn first, untimed (frames by budget).
    pub frame_without_lights: bool,
    /// Frames set aside because other processes took the cores while they ran
    /// (`CpuClock`); when every frame was, they are the timed ones and this says so.
    #[serde(default)]
    pub disturbed: u32,
    /// Why timing stopped (absent before the first frame, and in results written before
    /// it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stop: Option<Stop>,
}

/// A software adapter shades on the CPU cores this process shares with every other one:
/// a frame during which another process took a core is slower by what it took (a naive
/// forward frame of several seconds, timed once, doubled so). A frame is disturbed when
/// other processes used more than this share of the machine's CPU time while it ran.
pub const DISTURBED_SHARE: f64 = 0.25;
/// Frames shorter than this are not judged: the kernel counts CPU time in ticks of 10 ms,
/// so over 250 ms on 2 cores a share is known to about 4%; shorter frames are many, and
/// their median already leaves a disturbed one out.
pub const JUDGED_FRAME_MS: f64 = 250.0;
/// Frames a cell takes past its budget to find one that no other process disturbed.
pub const DISTURBED_RETRIES: u32 = 2;

/// The machine's and this process's CPU time at one moment (Linux: `/proc/stat` and
/// `getrusage`; elsewhere there is none, and no frame is judged).
#[derive(Clone, Copy, Debug)]
pub struct CpuClock {
    /// Seconds of CPU time the machine spent busy (steal included: the host took it) and in
    /// all.
    machine_busy_s: f64,
    machine_total_s: f64,
    /// Seconds of CPU time this process used, every thread (the software GPU's) included.
    own_s: f64,
}

impl CpuClock {
    #[cfg(target_os = "linux")]
    pub fn now() -> Option<CpuClock> {
        use std::io::Read;
        let mut text = String::new();
        // The first line only: "cpu  user nice system idle iowait irq softirq steal ...".
        std::fs::File::open("/proc/stat")
            .ok()?
            .take(4096)
            .read_to_string(&mut text)
            .ok()?;
        let ticks: Vec<f64> = text
            .lines()
            .next()?
            .split_whitespace()
            .skip(1)
            .take(8)
            .map(|t| t.parse().ok())
            .collect::<Option<_>>()?;
        let [user, nice, system, idle, iowait, irq, softirq, steal] = ticks[..] else {
            return None;
        };
        // SAFETY: sysconf and getrusage only write the value and the struct they are given.
        let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64;
        let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
        if hz <= 0.0 || unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
            return None;
        }
        let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
        let busy = user + nice + system + irq + softirq + steal;
        Some(CpuClock {
            machine_busy_s: busy / hz,
            machine_total_s: (busy + idle + iowait) / hz,
            own_s: seconds(usage.ru_utime) + seconds(usage.ru_stime),
        })
    }

    #[cfg(not(target_os = "linux"))]
    pub fn now() -> Option<CpuClock> {
        None
    }

    /// The share of the machine's CPU time from `self` to `later` that other processes
    /// (and the host, as steal) used, in [0, 1].
    pub fn others_share(&self, later: &CpuClock) -> Option<f64> {
        let total = later.machine_total_s - self.machine_total_s;
        let others = (later.machine_busy_s - self.machine_busy_s) - (later.own_s - self.own_s);
        (total > 0.0).then(|| (others / total).clamp(0.0, 1.0))
    }
}

/// The median of `v` (the mean of the middle two of an even count; 0 for none).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => 0.0,
        _ if n % 2 == 1 => v[n / 2],
        _ => (v[n / 2 - 1] + v[n / 2]) / 2.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const B: Budget = Budget {
        budget_ms: 500.0,
        max_frames: 20,
    };

    #[test]
    fn a_cell_stops_at_its_budget_or_its_frame_cap() {
        assert_eq!(B.spent(0, 1e9, 1e9), None, "at least one timed frame");
        // 1 frame of 10 ms, 50 spent: the 5 more an interval needs fit in 500.
        assert_eq!(B.spent(1, 10.0, 50.0), None);
        assert_eq!(B.spent(7, 10.0, 500.0), Some(Stop::Budget));
        // 1 frame of 100 ms, 150 spent: 5 more would reach 650, past 500.
        assert_eq!(B.spent(1, 100.0, 150.0), Some(Stop::Budget));
        // Past 6 frames, only the budget itself stops it.
        assert_eq!(B.spent(6, 100.0, 450.0), None);
        assert_eq!(B.spent(19, 10.0, 10.0), None);
        assert_eq!(B.spent(20, 10.0, 10.0), Some(Stop::MaxFrames));
        assert_eq!(
            B.spent(20, 10.0, 1e9),
            Some(Stop::MaxFrames),
            "the cap is named first"
        );
    }

    /// What an interval function must do, checked (a) on cases worked by hand and (b) on
    /// 4000 seeded sets of frames, whose true median it must hold at its stated level.
    fn holds_the_median(interval: fn(&[f64]) -> Option<Interval>) -> Result<(), String> {
        // (a) By hand. n = 10: P(B <= 0) = 1/1024, P(B <= 1) = 11/1024, P(B <= 2) =
        // 56/1024, so k = 2 covers 1 - 22/1024 = 0.978515625 >= 0.95 and k = 3 only
        // 1 - 112/1024 = 0.890625: [x(2), x(9)] of 1..=10 is [2, 9].
        let ten = [7.0, 2.0, 9.0, 1.0, 10.0, 4.0, 3.0, 8.0, 6.0, 5.0];
        let want = Interval {
            lo: 2.0,
            hi: 9.0,
            level: 0.978515625,
        };
        if interval(&ten) != Some(want) {
            return Err(format!("n = 10: {:?}, not {want:?}", interval(&ten)));
        }
        // n = 6: [min, max] at 1 - 2/64 = 0.96875; n = 5: [min, max] holds it with only
        // 1 - 2/32 = 0.9375 < 0.95, so no interval.
        let six = [3.0, 1.0, 6.0, 2.0, 5.0, 4.0];
        let want = Interval {
            lo: 1.0,
            hi: 6.0,
            level: 0.96875,
        };
        if interval(&six) != Some(want) {
            return Err(format!("n = 6: {:?}, not {want:?}", interval(&six)));
        }
        if let Some(i) = interval(&six[..5]) {
            return Err(format!("n = 5 has no interval at 95%, not {i:?}"));
        }
        // (b) Frames drawn from an exponential around 10 ms (median 10 + ln 2): each of
        // 4000 intervals holds it with probability level >= 0.95, so the count that miss
        // is Binomial(4000, <= 0.05): mean <= 200, sd <= 13.8; more than 200 + 5 sd = 269
        // misses happens with probability under 1e-6.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let true_median = 10.0 + std::f64::consts::LN_2;
        let mut missed = 0;
        for trial in 0..4000 {
            let n = 6 + trial % 15;
            let times: Vec<f64> = (0..n)
                .map(|_| 10.0 - (1.0 - rng.random::<f64>()).ln())
                .collect();
            let i = interval(&times).ok_or(format!("no interval of {n} frames"))?;
            if !(i.lo <= true_median && true_median <= i.hi) {
                missed += 1;
            }
        }
        if missed > 269 {
            return Err(format!("{missed} of 4000 intervals missed the median"));
        }
        Ok(())
    }

    #[test]
    fn the_interval_holds_the_median_at_its_level() {
        holds_the_median(median_interval).unwrap();
        // The deliberate break: an interval of zero width at the median (what a single
        // figure claims) is worked out wrong and misses the median nearly always.
        let zero_width = |t: &[f64]| {
            let m = median(t.to_vec());
            (t.len() >= MIN_FRAMES).then_some(Interval {
                lo: m,
                hi: m,
                level: LEVEL,
            })
        };
        assert!(holds_the_median(zero_width).is_err());
    }

    #[test]
    fn times_are_told_apart_only_where_their_intervals_separate() {
        let i = |lo, hi| {
            Some(Interval {
                lo,
                hi,
                level: LEVEL,
            })
        };
        assert_eq!(
            Interval::compare(i(1.0, 2.0).as_ref(), i(2.5, 3.0).as_ref()),
            Verdict::Faster
        );
        assert_eq!(
            Interval::compare(i(2.5, 3.0).as_ref(), i(1.0, 2.0).as_ref()),
            Verdict::Slower
        );
        // Overlapping, and the ratio may be anywhere in [1 / 3, 2.5]: not decided.
        assert_eq!(
            Interval::compare(i(1.0, 2.5).as_ref(), i(2.5, 3.0).as_ref()),
            Verdict::Undecided
        );
        // Both within [10, 10.4]: the ratio lies in [10 / 10.4, 10.4 / 10] = [0.96, 1.04],
        // within the 10% margin.
        assert_eq!(
            Interval::compare(i(10.0, 10.4).as_ref(), i(10.1, 10.3).as_ref()),
            Verdict::Tie
        );
        // 10.0-11.5 against 10.0-10.2: up to 1.15, past the margin.
        assert_eq!(
            Interval::compare(i(10.0, 11.5).as_ref(), i(10.0, 10.2).as_ref()),
            Verdict::Undecided
        );
        assert_eq!(
            Interval::compare(None, i(2.5, 3.0).as_ref()),
            Verdict::Undecided
        );
        assert_eq!(coverage(10, 6), 0.0, "k past the middle brackets nothing");
    }

    /// A ratio's verdict: apart from 1 on one side, within the margin, or neither.
    #[test]
    fn a_ratio_decides_by_its_interval() {
        let r = |lo, hi| Interval {
            lo,
            hi,
            level: LEVEL,
        };
        assert_eq!(Verdict::of_ratio(Some(&r(0.5, 0.99))), Verdict::Faster);
        assert_eq!(Verdict::of_ratio(Some(&r(1.01, 1.05))), Verdict::Slower);
        assert_eq!(Verdict::of_ratio(Some(&r(0.95, 1.05))), Verdict::Tie);
        assert_eq!(Verdict::of_ratio(Some(&r(0.95, 1.2))), Verdict::Undecided);
        assert_eq!(Verdict::of_ratio(None), Verdict::Undecided);
        // The margin's edges: 1 / 1.1 and 1.1 themselves are within it.
        let edge = r(1.0 / (1.0 + TIE_WITHIN), 1.0 + TIE_WITHIN);
        assert_eq!(Verdict::of_ratio(Some(&edge)), Verdict::Tie);
        let past = r(edge.lo, edge.hi * 1.001);
        assert_eq!(Verdict::of_ratio(Some(&past)), Verdict::Undecided);
    }

    /// Our own work is not another process's; busy processes on every core are.
    #[cfg(target_os = "linux")]
    #[test]
    fn the_clock_tells_other_processes_work_from_ours() {
        let spin = |ms: u64| {
            let start = std::time::Instant::now();
            let mut x = 0u64;
            while start.elapsed().as_millis() < ms as u128 {
                x = std::hint::black_box(x.wrapping_mul(31).wrapping_add(7));
            }
        };
        // What the rest of the machine does anyway (other programs may be running: the
        // test must not need an idle machine), measured while we sleep, then while we spin.
        let idle = CpuClock::now().expect("a clock on Linux");
        std::thread::sleep(std::time::Duration::from_millis(400));
        let a = CpuClock::now().unwrap();
        let baseline = idle.others_share(&a).unwrap();
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        // Every core busy in this process.
        std::thread::scope(|s| {
            for _ in 0..cores {
                s.spawn(|| spin(400));
            }
        });
        let ours = a.others_share(&CpuClock::now().unwrap()).unwrap();
        let mut busy: Vec<_> = (0..cores)
            .map(|_| {
                std::process::Command::new("sh")
                    .args(["-c", "while :; do :; done"])
                    .spawn()
                    .expect("sh")
            })
            .collect();
        std::thread::sleep(std::time::Duration::from_millis(100));
        let b = CpuClock::now().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(400));
        let theirs = b.others_share(&CpuClock::now().unwrap()).unwrap();
        for child in &mut busy {
            let _ = child.kill();
            let _ = child.wait();
        }
        // Our spin does not raise the others' share above what they take anyway: counted as
        // theirs, our threads on every core would make it nearly 1; counted as ours, the
        // others get less of the machine while we spin, not more.
        assert!(
            ours < baseline + DISTURBED_SHARE,
            "our own spin counted as others': {ours} (while we slept: {baseline})"
        );
        // Every core busy elsewhere while we sleep: nearly all of the machine.
        assert!(
            theirs > 1.0 - DISTURBED_SHARE,
            "busy processes not seen: {theirs}"
        );
    }
}
