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
//! of them does) can put B past the frame. A bound is not beaten: E is then shown as 1 and
//! the cell as within noise, with the spread of E over the timed frames beside it.

use serde::{Deserialize, Serialize};

use crate::gpu::Timings;

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
    /// Bound over frame, at most 1.
    pub efficiency: f64,
    /// Bound over the slowest and the fastest timed frame.
    #[serde(default)]
    pub spread: [f64; 2],
    /// The bound came out at or past the frame (`efficiency` then says 1): what separates
    /// them is within the timings' noise.
    #[serde(default)]
    pub within_noise: bool,
}

impl Efficiency {
    /// From the frame's median total and the [fastest, slowest] timed frame's, its passes'
    /// medians, the frame without lights, the names of the shading passes and the
    /// counters; None where a ratio would mean nothing (no evaluation, no useful one). A
    /// frame no longer than its frame without lights, or shading passes no slower, is within
    /// noise: its lights cost less than the timings can tell.
    pub fn of(
        (frame_ms, fastest_ms, slowest_ms): (f64, f64, f64),
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
        let within_noise = ratio >= 1.0 || shading_ms <= 0.0;
        Some(Efficiency {
            frame_without_lights_ms: round(empty_ms, 1e3),
            ns_per_evaluation: round(per_evaluation_ms * 1e6, 1e3),
            ns_per_useful_evaluation: round(
                (frame_ms - empty_ms).max(0.0) * 1e6 / useful as f64,
                1e3,
            ),
            bound_ms: round(bound_ms, 1e3),
            efficiency: if within_noise { 1.0 } else { round(ratio, 1e4) },
            spread: [
                round(bound_ms / slowest_ms.max(frame_ms), 1e4),
                round(bound_ms / fastest_ms.min(frame_ms), 1e4),
            ],
            within_noise,
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
            (66.0, 66.0, 66.0),
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
            (66.0, 66.0, 66.0),
            &frame,
            &empty,
            &["resolve", "light_assign"],
            (7_566_912, 5_066_433),
        )
        .unwrap();
        assert!((wrong.efficiency - e.efficiency).abs() > 0.1);
    }

    /// No useful evaluation: no ratio. A frame timed no longer than its frame without
    /// lights: within noise, at 100%.
    #[test]
    fn a_frame_without_work_on_lights_has_no_efficiency() {
        let t = timings(&[("resolve", 5.0)]);
        let same = Efficiency::of((5.0, 5.0, 5.0), &t, &t, &["resolve"], (10, 5)).unwrap();
        assert!(same.within_noise && same.efficiency == 1.0, "{same:?}");
        assert_eq!(
            Efficiency::of(
                (9.0, 9.0, 9.0),
                &timings(&[("resolve", 9.0)]),
                &t,
                &["resolve"],
                (10, 0)
            ),
            None
        );
    }

    /// A frame a little longer than its frame without lights, whose shading pass was timed
    /// slower than in the frame (noise): the bound (10.0 + 10 x 0.1 = 11.0 ms) lies past the
    /// 10.5 ms frame. It is reported as within noise at 100%, never above, with its spread
    /// over frames of 10.2 to 11.4 ms (0.9649 to 1.0784).
    #[test]
    fn a_bound_past_the_frame_is_within_noise_never_above_100_percent() {
        let frame = timings(&[("resolve", 4.0), ("rest", 6.5)]);
        let empty = timings(&[("resolve", 3.0), ("rest", 7.0)]);
        let e = Efficiency::of((10.5, 10.2, 11.4), &frame, &empty, &["resolve"], (10, 10))
            .expect("a ratio");
        assert!((e.bound_ms - 11.0).abs() < 1e-9, "{e:?}");
        assert_eq!(e.efficiency, 1.0);
        assert!(e.within_noise);
        assert_eq!(e.spread, [0.9649, 1.0784]);
        // The deliberate break: the same cells timed cleanly stay a plain ratio.
        let clean =
            Efficiency::of((12.0, 11.9, 12.1), &frame, &empty, &["resolve"], (10, 10)).unwrap();
        assert!(!clean.within_noise && (clean.efficiency - 11.0 / 12.0).abs() < 1e-4);
    }
}
