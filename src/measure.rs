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
    /// A frame without lights was drawn first, untimed (frames by budget).
    pub frame_without_lights: bool,
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

    #[test]
    fn half_range() {
        assert_eq!(relative_half_range(&[5.0]), 0.0);
        assert!((relative_half_range(&[9.0, 10.0, 11.0]) - 0.1).abs() < 1e-12);
    }
}
