//! Twin of `shaders/common/msaa.wesl`: a pixel's samples resolved to one HDR colour.

use crate::common::MsaaResolve;

/// The largest channel.
fn max3(c: [f64; 3]) -> f64 {
    c[0].max(c[1]).max(c[2])
}

/// The resolved colour of a pixel's `samples` (linear HDR, each channel >= 0).
pub fn resolve(samples: &[[f64; 3]], how: MsaaResolve) -> [f64; 3] {
    let n = samples.len() as f64;
    let mut mean = [0.0; 3];
    for &c in samples {
        // Box sums the colours; Tonemapped their reversible tonemap c / (1 + max(c)).
        let weight = match how {
            MsaaResolve::Box => 1.0,
            MsaaResolve::Tonemapped => 1.0 / (1.0 + max3(c)),
        };
        for (m, x) in mean.iter_mut().zip(c) {
            *m += x * weight / n;
        }
    }
    match how {
        MsaaResolve::Box => mean,
        // Back to HDR: every tonemapped channel is below 1, so their mean is too.
        MsaaResolve::Tonemapped => mean.map(|m| m / (1.0 - max3(mean))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_colour_resolves_to_itself_both_ways() {
        let c = [3.0, 0.5, 0.0];
        for how in [MsaaResolve::Box, MsaaResolve::Tonemapped] {
            let r = resolve(&[c; 4], how);
            for k in 0..3 {
                assert!(
                    (r[k] - c[k]).abs() <= 1e-12 * c[k].max(1.0),
                    "{how:?}: {r:?}"
                );
            }
        }
    }

    #[test]
    fn a_bright_sample_dominates_the_box_but_not_the_tonemapped_resolve() {
        // One sample of 100 beside three black ones: the box mean is 25, the tonemapped
        // mean of t = 100/101 and three 0 is 0.2475..., back to HDR 0.2475 / 0.7525.
        let samples = [[100.0; 3], [0.0; 3], [0.0; 3], [0.0; 3]];
        assert_eq!(resolve(&samples, MsaaResolve::Box), [25.0; 3]);
        let t = 100.0 / 101.0 / 4.0;
        let expected = t / (1.0 - t);
        let r = resolve(&samples, MsaaResolve::Tonemapped);
        assert!((r[0] - expected).abs() < 1e-12, "{r:?}");
        assert!(r[0] < 0.33);
    }
}
