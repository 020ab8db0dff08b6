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
/// A cell's first frame pays for first use: software rasterisers compile a pipeline's shader
/// variants on its first draw, and every new buffer and image is touched for the first
/// time. It is a warm-up frame, untimed, unless it alone spends the budget and that first
/// use is within the precision of it (`keep_first`). Then frames are timed until
/// `MIN_FRAMES` of them lie within +-`precision` of their median, the budget is spent (the
/// warm-up frame included), or `max_frames` are taken (`enough`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Budget {
    /// Relative half-width: (max - min) / 2 over the median.
    pub precision: f64,
    /// Milliseconds of frames (their summed pass times, a warm-up included) a cell may
    /// spend.
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

/// What a cell's first frame costs over a later one, at most, measured on lavapipe at
/// 640x360 (`matrix --frames 6 --warmup 0`, first frame against the others): 7-14 ms with
/// pipelines another cell drew with (first touch of new buffers and images), 16-45 ms with
/// pipelines made for this cell (compiling on first draw too).
pub const FIRST_USE_MS: f64 = 15.0;
pub const FIRST_USE_COLD_MS: f64 = 60.0;

impl Budget {
    /// What the matrix uses unless told otherwise: a precision of 3%, at most 10 frames
    /// (hyperfine's default run count), and 300 ms, about 3% of a naive forward frame of the
    /// atrium at 640x360 on lavapipe (which, like most naive forward cells, is then timed
    /// once).
    pub const DEFAULT: Budget = Budget {
        precision: 0.03,
        budget_ms: 300.0,
        max_frames: 10,
    };

    /// Whether a cell's first frame, `first_ms` long, is timed (and then the only one):
    /// when it spends the budget and its first-use cost is within the precision of it.
    /// `cold`: its pipelines were made for this cell.
    pub fn keep_first(&self, first_ms: f64, cold: bool) -> bool {
        let first_use = if cold {
            FIRST_USE_COLD_MS
        } else {
            FIRST_USE_MS
        };
        first_ms >= self.budget_ms && first_use <= self.precision * first_ms
    }

    /// Whether the frames timed so far (milliseconds each) are enough, after a warm-up of
    /// `warmup_ms` (part of the cell's budget too).
    pub fn enough(&self, times: &[f64], warmup_ms: f64) -> bool {
        let n = times.len();
        if n == 0 {
            return false;
        }
        let spent: f64 = warmup_ms + times.iter().sum::<f64>();
        n as u32 >= self.max_frames.max(1)
            || spent >= self.budget_ms
            || (n >= MIN_FRAMES && relative_half_range(times) <= self.precision)
    }
}

/// (max - min) / 2 over the median of `times` (0 for a single time or a zero median).
pub fn relative_half_range(times: &[f64]) -> f64 {
    let min = times.iter().copied().fold(f64::INFINITY, f64::min);
    let max = times.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let median = crate::run::median(times.to_vec());
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
    /// The one timed frame was also the first draw of pipelines made for this cell (kept
    /// because it spent the whole budget).
    pub cold_start: bool,
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
            "the warm-up spends the budget too"
        );
        assert!(B.enough(&[500.0], 0.0));
        assert!(!B.enough(&[499.0], 0.0));
        assert!(B.enough(&[300.0, 200.0], 0.0));
    }

    #[test]
    fn a_first_frame_is_timed_only_when_its_first_use_is_within_the_precision() {
        // 15 ms of first use is 3% of 500 ms; compiling too, 60 ms is 3% of 2 s.
        assert!(B.keep_first(501.0, false));
        assert!(!B.keep_first(499.0, false));
        assert!(!B.keep_first(1999.0, true));
        assert!(B.keep_first(2001.0, true));
        // And never below the budget.
        let loose = Budget {
            precision: 0.5,
            ..B
        };
        assert!(!loose.keep_first(499.0, true));
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

    #[test]
    fn half_range() {
        assert_eq!(relative_half_range(&[5.0]), 0.0);
        assert!((relative_half_range(&[9.0, 10.0, 11.0]) - 0.1).abs() < 1e-12);
    }
}
