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

/// When a cell has timed enough frames.
///
/// A cell's first frame would pay for first use: software rasterisers compile a pipeline's
/// shader variants on its first draw, and every new image is touched for the first time.
/// So a cell first draws one frame without its lights, untimed
/// (`Renderer::draw_without_lights`), which pays that for about what a frame with nothing
/// to shade costs, and times frames from its first whole one on: until the median's
/// interval at [`LEVEL`] ([`median_interval`]) is within +-`precision` of it, the budget is
/// spent (the frame without lights included), or `max_frames` are taken (`enough`).
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
    /// Relative half-width of the median's interval at [`LEVEL`]: (hi - lo) / 2 over the
    /// median.
    pub precision: f64,
    /// Milliseconds of frames (their summed pass times, the untimed frame without lights
    /// included) a cell may spend.
    pub budget_ms: f64,
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

/// How one time compares with another: told apart only where their intervals separate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    Faster,
    Slower,
    /// The intervals overlap, or a time has none: the two cannot be told apart.
    Tie,
}

impl Interval {
    /// How a time with interval `this` compares with one with `other` (a time without an
    /// interval ties with every other).
    pub fn compare(this: Option<&Interval>, other: Option<&Interval>) -> Verdict {
        match (this, other) {
            (Some(a), Some(b)) if a.hi < b.lo => Verdict::Faster,
            (Some(a), Some(b)) if b.hi < a.lo => Verdict::Slower,
            _ => Verdict::Tie,
        }
    }

    /// Half the interval's width over `median`.
    pub fn relative_half_width(&self, median: f64) -> f64 {
        if median > 0.0 {
            (self.hi - self.lo) / 2.0 / median
        } else {
            f64::INFINITY
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

/// Why a cell stopped timing frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stop {
    /// Its interval came within the precision asked.
    Precise,
    /// It took the most frames allowed first.
    MaxFrames,
    /// Its time budget was spent first.
    Budget,
    /// An exact number of frames was asked (`--frames`).
    Count,
}

impl Stop {
    pub fn label(self) -> &'static str {
        match self {
            Stop::Precise => "precise",
            Stop::MaxFrames => "max frames",
            Stop::Budget => "budget",
            Stop::Count => "count",
        }
    }
}

impl Default for Budget {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Budget {
    /// What the matrix uses unless told otherwise: a precision of 3%, at most 9 frames (9
    /// and 10 frames give the same trimmed interval, [x(2), x(n-1)]) and 300 ms, which
    /// gives a cell of up to 43 ms a frame the 6 frames an interval needs ([`MIN_FRAMES`],
    /// with the two untimed frames first). Naive forward's frames of a second or more are
    /// timed once, with no interval: they tie with every other time.
    ///
    /// Measured on lavapipe over the default matrix (294 cells, its first group at
    /// 320x180): at 150 ms and 10 frames, 106 cells had an interval (91 were timed once);
    /// at 400 ms, 258, in 150 s; at 300 ms and 9 frames, by the same cells' frame times,
    /// 220 in about 8 s less. A cell's time moved about 5% between two runs of the matrix
    /// (median over its cells; 12-14% at the 90th percentile) with 150 or 300 ms alike, so
    /// the budget buys intervals, not steadier medians.
    pub const DEFAULT: Budget = Budget {
        precision: 0.03,
        budget_ms: 300.0,
        max_frames: 9,
    };

    /// Whether the frames timed so far (milliseconds each) are enough, after untimed frames
    /// of `untimed_ms` (part of the cell's budget too), and why: None while more are needed.
    pub fn enough(&self, times: &[f64], untimed_ms: f64) -> Option<Stop> {
        let n = times.len();
        if n == 0 {
            return None;
        }
        let spent: f64 = untimed_ms + times.iter().sum::<f64>();
        let precise = median_interval(times)
            .is_some_and(|i| i.relative_half_width(median(times.to_vec())) <= self.precision);
        if precise {
            Some(Stop::Precise)
        } else if n as u32 >= self.max_frames.max(1) {
            Some(Stop::MaxFrames)
        } else if spent >= self.budget_ms {
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
        precision: 0.03,
        budget_ms: 500.0,
        max_frames: 20,
    };

    #[test]
    fn a_frame_that_spends_the_budget_is_enough() {
        assert_eq!(B.enough(&[], 0.0), None);
        assert_eq!(B.enough(&[], 1e9), None, "at least one timed frame");
        assert_eq!(
            B.enough(&[100.0], 400.0),
            Some(Stop::Budget),
            "untimed frames spend the budget too"
        );
        assert_eq!(B.enough(&[500.0], 0.0), Some(Stop::Budget));
        assert_eq!(B.enough(&[499.0], 0.0), None);
        assert_eq!(B.enough(&[300.0, 200.0], 0.0), Some(Stop::Budget));
    }

    #[test]
    fn precision_needs_an_interval_within_it() {
        // Five frames, however close, have no interval at 95%.
        assert_eq!(B.enough(&[10.0; 5], 0.0), None);
        // Six within +-2.5% of their median (10.0): [min, max] = [9.75, 10.25].
        let six = [10.0, 10.25, 9.75, 10.0, 10.1, 9.9];
        assert_eq!(B.enough(&six, 0.0), Some(Stop::Precise));
        // [9.5, 10.5] is +-5%: not within 3%.
        let wide = [10.0, 10.5, 9.5, 10.0, 10.1, 9.9];
        assert_eq!(B.enough(&wide, 0.0), None);
        // Ten: the interval drops the extremes ([x(2), x(9)]), so one outlier on each side
        // leaves it within 3%.
        let ten = [5.0, 10.0, 10.1, 10.2, 9.9, 9.8, 10.0, 10.1, 9.9, 20.0];
        assert_eq!(B.enough(&ten, 0.0), Some(Stop::Precise));
    }

    #[test]
    fn noisy_frames_stop_at_the_budget_or_the_frame_cap() {
        let noisy: Vec<f64> = (0..19)
            .map(|i| if i % 2 == 0 { 10.0 } else { 20.0 })
            .collect();
        assert_eq!(B.enough(&noisy, 0.0), None);
        let mut capped = noisy.clone();
        capped.push(10.0);
        assert_eq!(B.enough(&capped, 0.0), Some(Stop::MaxFrames));
        assert_eq!(B.enough(&[100.0, 200.0, 100.0], 0.0), None);
        assert_eq!(
            B.enough(&[100.0, 200.0, 100.0, 100.0], 0.0),
            Some(Stop::Budget)
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
        assert_eq!(
            Interval::compare(i(1.0, 2.5).as_ref(), i(2.5, 3.0).as_ref()),
            Verdict::Tie
        );
        assert_eq!(Interval::compare(None, i(2.5, 3.0).as_ref()), Verdict::Tie);
        assert_eq!(coverage(10, 6), 0.0, "k past the middle brackets nothing");
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
