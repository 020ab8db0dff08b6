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
/// to shade costs, and times frames from its first whole one on: until `MIN_FRAMES` of them
/// lie within +-`precision` of their median, the budget is spent (the frame without lights
/// included), or `max_frames` are taken (`enough`).
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
    /// Relative half-width: (max - min) / 2 over the median.
    pub precision: f64,
    /// Milliseconds of frames (their summed pass times, the untimed frame without lights
    /// included) a cell may spend.
    pub budget_ms: f64,
    pub max_frames: u32,
}

/// Frames a precision can be judged on: with n frames, the chance that the true median
/// lies outside [min, max] is 2^(1-n), 25% at 3.
pub const MIN_FRAMES: usize = 3;

impl Default for Budget {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Budget {
    /// What the matrix uses unless told otherwise: a precision of 3%, at most 10 frames
    /// (hyperfine's default run count), and 150 ms, which a naive forward frame of the atrium
    /// at 640x360 (1.6-1.8 s on lavapipe) spends alone: like most naive forward cells, it is
    /// timed once.
    ///
    /// Why 150 and not more: a cell's time moves about 5% between two runs of the matrix
    /// (median over its 225 cells; 12-14% at the 90th percentile), whatever the budget, so
    /// frames past that buy no figure a second run would repeat. Measured on lavapipe, two
    /// runs each, 300 and 150 taken in turn: 300 ms against 300 ms, a cell's time differed
    /// by 5.1% at the median and 12.4% at the 90th percentile, 150 against 150 by 5.0% and
    /// 14.0%, 300 against 150 by 4.7-6.1% and 13.3-14.8%. Relative to the cells that took
    /// as many frames at 150, those that took fewer came out 1.0-2.8% faster, not slower.
    /// The run took 68 s instead of 81.
    pub const DEFAULT: Budget = Budget {
        precision: 0.03,
        budget_ms: 150.0,
        max_frames: 10,
    };

    /// Whether the frames timed so far (milliseconds each) are enough, after untimed frames
    /// of `untimed_ms` (part of the cell's budget too).
    pub fn enough(&self, times: &[f64], untimed_ms: f64) -> bool {
        let n = times.len();
        if n == 0 {
            return false;
        }
        let spent: f64 = untimed_ms + times.iter().sum::<f64>();
        n as u32 >= self.max_frames.max(1)
            || spent >= self.budget_ms
            || (n >= MIN_FRAMES && relative_half_range(times) <= self.precision)
    }
}

/// (max - min) / 2 over the median of `times` (0 for a single time or a zero median).
pub fn relative_half_range(times: &[f64]) -> f64 {
    let min = times.iter().copied().fold(f64::INFINITY, f64::min);
    let max = times.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let median = median(times.to_vec());
    if times.len() < 2 || median <= 0.0 {
        0.0
    } else {
        (max - min) / 2.0 / median
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
        assert!(!B.enough(&[], 0.0));
        assert!(!B.enough(&[], 1e9), "at least one timed frame");
        assert!(
            B.enough(&[100.0], 400.0),
            "untimed frames spend the budget too"
        );
        assert!(B.enough(&[500.0], 0.0));
        assert!(!B.enough(&[499.0], 0.0));
        assert!(B.enough(&[300.0, 200.0], 0.0));
    }

    #[test]
    fn precision_needs_three_frames_within_it() {
        assert!(!B.enough(&[10.0, 10.0], 0.0));
        assert!(B.enough(&[10.0, 10.2, 10.5], 0.0));
        // Range 1.0 over median 10.0: +-5%, not within 3%.
        assert!(!B.enough(&[10.0, 11.0, 10.0], 0.0));
        assert!(!B.enough(&[10.0, 11.0, 10.0, 10.1, 10.2, 10.3, 10.0, 10.4, 10.2], 0.0));
    }

    #[test]
    fn noisy_frames_stop_at_the_budget_or_the_frame_cap() {
        let noisy: Vec<f64> = (0..19)
            .map(|i| if i % 2 == 0 { 10.0 } else { 20.0 })
            .collect();
        assert!(!B.enough(&noisy, 0.0));
        let mut capped = noisy.clone();
        capped.push(10.0);
        assert!(B.enough(&capped, 0.0));
        assert!(!B.enough(&[100.0, 200.0, 100.0], 0.0));
        assert!(B.enough(&[100.0, 200.0, 100.0, 100.0], 0.0));
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

    #[test]
    fn half_range() {
        assert_eq!(relative_half_range(&[5.0]), 0.0);
        assert!((relative_half_range(&[9.0, 10.0, 11.0]) - 0.1).abs() < 1e-12);
    }
}
