//! Distance from perfect culling: what a cell's frame would cost if its shading evaluated
//! only the useful lights (the pairs where the light reaches the surface) at the cell's own
//! cost per evaluation, over what it costs. A ratio inside one cell, so it carries across
//! machines where a time or a speed-up over another cell's frame does not.
//!
//! From a timed frame without lights (`Renderer::draw_without_lights`: every pass runs,
//! nothing is shaded), the cell's frame and its counters:
//!   cost per evaluation  c = (shading passes' time - theirs without lights) / evaluations
//!   bound                B = frame without lights + useful evaluations x c
//!   efficiency           E = B / frame
//!   cost per useful evaluation = (frame - frame without lights) / useful evaluations
//! E is 1 for a frame that spends nothing on lights but useful evaluations; what culling
//! costs (light assignment, list walks) and the evaluations it did not cull lower it.
//!
//! The frame without lights and the frame are timed apart, so their noise (or work only one
//! of them does) can put B past the frame. E is never clamped: a bound past the frame but
//! inside the frame's confidence interval (`measure::median_interval`) is within noise; one
//! past the interval (or past a frame timed too few times for one) is a bound above its
//! frame, shown with both numbers: the bound's inputs were mistimed, and E means nothing.

use serde::{Deserialize, Serialize};

use crate::gpu::Timings;
use crate::measure::Interval;

/// A cell's distance from perfect culling (see the module).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Efficiency {
    /// The frame without lights, milliseconds.
    pub frame_without_lights_ms: f64,
    /// The shading passes' time per evaluation, nanoseconds.
    pub ns_per_evaluation: f64,
    /// The frame's time over the frame without lights per useful evaluation, nanoseconds.
    pub ns_per_useful_evaluation: f64,
    /// The perfect-culling bound, milliseconds.
    pub bound_ms: f64,
    /// Bound over frame (above 1 where the bound came out past the frame).
    pub efficiency: f64,
    /// Bound over the frame interval's ends (hi, then lo; the frame itself without one).
    #[serde(default)]
    pub spread: [f64; 2],
    /// The bound came out at or past the frame, inside the frame's interval: what
    /// separates them is within the timings' noise.
    #[serde(default)]
    pub within_noise: bool,
    /// The bound came out past the frame's interval (or past a frame without one): a
    /// mistimed bound, not a culling better than perfect.
    #[serde(default)]
    pub bound_above_frame: bool,
}

impl Efficiency {
    /// From the frame's median total and its interval, its passes' medians, the frame
    /// without lights, the names of the shading passes and the counters; None where a ratio
    /// would mean nothing (no evaluation, no useful one). Shading passes no slower than
    /// without lights are within noise: their lights cost less than the timings can tell.
    pub fn of(
        (frame_ms, interval): (f64, Option<Interval>),
        frame: &Timings,
        without_lights: &Timings,
        shading_passes: &[&str],
        (evaluations, useful): (u64, u64),
    ) -> Option<Efficiency> {
        let empty_ms = without_lights.total_ms();
        let shading_ms: f64 = shading_passes
            .iter()
            .map(|p| frame.get(p) - without_lights.get(p))
            .sum();
        if evaluations == 0 || useful == 0 || frame_ms <= 0.0 {
            return None;
        }
        let per_evaluation_ms = shading_ms.max(0.0) / evaluations as f64;
        let bound_ms = empty_ms + useful as f64 * per_evaluation_ms;
        let ratio = bound_ms / frame_ms;
        let frame_hi = interval.map_or(frame_ms, |i| i.hi.max(frame_ms));
        let bound_above_frame = bound_ms > frame_hi;
        let within_noise = !bound_above_frame && (ratio >= 1.0 || shading_ms <= 0.0);
        let (fastest_ms, slowest_ms) = interval.map_or((frame_ms, frame_ms), |i| (i.lo, i.hi));
        Some(Efficiency {
            frame_without_lights_ms: round(empty_ms, 1e3),
            ns_per_evaluation: round(per_evaluation_ms * 1e6, 1e3),
            ns_per_useful_evaluation: round(
                (frame_ms - empty_ms).max(0.0) * 1e6 / useful as f64,
                1e3,
            ),
            bound_ms: round(bound_ms, 1e3),
            efficiency: round(ratio, 1e4),
            spread: [
                round(bound_ms / slowest_ms.max(frame_ms), 1e4),
                round(bound_ms / fastest_ms.min(frame_ms), 1e4),
            ],
            within_noise,
            bound_above_frame,
        })
    }
}

fn round(x: f64, scale: f64) -> f64 {
    (x * scale).round() / scale
}

#[cfg(test)]
mod tests {
    use super::*;

    fn timings(passes: &[(&str, f64)]) -> Timings {
        Timings {
            passes: passes.iter().map(|(n, t)| (n.to_string(), *t)).collect(),
            gpu_timestamps: false,
        }
    }

    /// The figures (llvmpipe, atrium 640x360, 4096 lights): a 66 ms frame, 26.9 ms
    /// without lights, a resolve 24.2 ms longer for 7,566,912 evaluations (3.2 ns each),
    /// 5,066,433 useful: a bound of 26.9 + 5,066,433 x 3.2 ns = 43.1 ms, 65%.
    #[test]
    fn the_bound_is_the_frame_without_lights_plus_the_useful_evaluations() {
        let frame = timings(&[("light_assign", 19.0), ("resolve", 30.2), ("rest", 16.8)]);
        let empty = timings(&[("light_assign", 0.1), ("resolve", 6.0), ("rest", 20.8)]);
        let e = Efficiency::of(
            (66.0, None),
            &frame,
            &empty,
            &["resolve"],
            (7_566_912, 5_066_433),
        )
        .expect("a ratio");
        let per_eval = 24.2 / 7_566_912.0;
        assert!((e.ns_per_evaluation - per_eval * 1e6).abs() < 1e-3);
        let bound = 26.9 + 5_066_433.0 * per_eval;
        assert!((e.bound_ms - bound).abs() < 1e-3, "{e:?}");
        assert!((e.efficiency - bound / 66.0).abs() < 1e-4, "{e:?}");
        // Counting the assignment as shading (a wrong pass list) would move the figure.
        let wrong = Efficiency::of(
            (66.0, None),
            &frame,
            &empty,
            &["resolve", "light_assign"],
            (7_566_912, 5_066_433),
        )
        .unwrap();
        assert!((wrong.efficiency - e.efficiency).abs() > 0.1);
    }

    /// No useful evaluation: no ratio. Shading passes no slower than without lights:
    /// within noise, the bound equal to the frame.
    #[test]
    fn a_frame_without_work_on_lights_has_no_efficiency() {
        let t = timings(&[("resolve", 5.0)]);
        let same = Efficiency::of((5.0, None), &t, &t, &["resolve"], (10, 5)).unwrap();
        assert!(same.within_noise && same.efficiency == 1.0, "{same:?}");
        assert_eq!(
            Efficiency::of(
                (9.0, None),
                &timings(&[("resolve", 9.0)]),
                &t,
                &["resolve"],
                (10, 0)
            ),
            None
        );
    }

    fn interval(lo: f64, hi: f64) -> Option<Interval> {
        Some(Interval {
            lo,
            hi,
            level: crate::measure::LEVEL,
        })
    }

    /// A frame a little longer than its frame without lights, whose shading pass was timed
    /// slower than in the frame (noise): the bound (10.0 + 10 x 0.1 = 11.0 ms) lies past the
    /// 10.5 ms frame, inside its interval [10.2, 11.4]: within noise, and shown as it is,
    /// 11.0 / 10.5 = 1.0476, never clamped; over the interval's ends 0.9649 to 1.0784.
    #[test]
    fn a_bound_past_the_frame_inside_its_interval_is_within_noise_and_not_clamped() {
        let frame = timings(&[("resolve", 4.0), ("rest", 6.5)]);
        let empty = timings(&[("resolve", 3.0), ("rest", 7.0)]);
        let e = Efficiency::of(
            (10.5, interval(10.2, 11.4)),
            &frame,
            &empty,
            &["resolve"],
            (10, 10),
        )
        .expect("a ratio");
        assert!((e.bound_ms - 11.0).abs() < 1e-9, "{e:?}");
        assert_eq!(e.efficiency, 1.0476);
        assert!(e.within_noise && !e.bound_above_frame, "{e:?}");
        assert_eq!(e.spread, [0.9649, 1.0784]);
        // Past the interval ([10.2, 10.8]): a bound above its frame, shown as such.
        let above = Efficiency::of(
            (10.5, interval(10.2, 10.8)),
            &frame,
            &empty,
            &["resolve"],
            (10, 10),
        )
        .unwrap();
        assert!(above.bound_above_frame && !above.within_noise, "{above:?}");
        // A frame timed too few times for an interval has no noise to hide the bound in.
        let few = Efficiency::of((10.5, None), &frame, &empty, &["resolve"], (10, 10)).unwrap();
        assert!(few.bound_above_frame, "{few:?}");
        // The deliberate break: the same cells timed cleanly stay a plain ratio.
        let clean = Efficiency::of(
            (12.0, interval(11.9, 12.1)),
            &frame,
            &empty,
            &["resolve"],
            (10, 10),
        )
        .unwrap();
        assert!(!clean.within_noise && !clean.bound_above_frame);
        assert!((clean.efficiency - 11.0 / 12.0).abs() < 1e-4);
    }
}
