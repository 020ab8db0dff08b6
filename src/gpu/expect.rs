//! Where an adapter legitimately differs from the results reviewed on lavapipe (Vulkan),
//! declared once, per check and per backend or HDR format, as wgpu's own test harness lists
//! its per-adapter failure cases. Checks ask [`allowance`] instead of widening a tolerance
//! for every adapter; each entry says why the difference is not a defect.

use super::Gpu;

pub use super::deviations::{Allowance, Check, DEVIATIONS, Deviation, On};

/// The declared difference of `check` on this adapter, if any.
pub fn allowance(gpu: &Gpu, check: Check<'_>) -> Option<&'static Deviation> {
    DEVIATIONS
        .iter()
        .find(|d| d.check == check && d.on.holds_for(gpu.backend, gpu.hdr_format))
}

/// Iterations Mesa's llvmpipe (lavapipe and its OpenGL driver) lets one shader invocation
/// loop in all, over every loop together (`LP_MAX_TGSI_LOOP_ITERATIONS`); past it the loops
/// end early without a word. Measured: naive forward with 65536 lights leaves the last one
/// out.
pub const LLVMPIPE_LOOP_ITERATIONS: u32 = 65535;

/// Iterations kept for the other loops of a shading invocation (a codec's neighbour
/// search, the list lookup), which share the cap with its light loop.
const OTHER_LOOPS: u32 = 1024;

/// The most lights a per-pixel light loop may visit on this adapter, where its driver caps
/// a shader's loop iterations; None where it does not.
pub fn max_lights_per_pixel(gpu: &Gpu) -> Option<u32> {
    gpu.adapter
        .name
        .contains("llvmpipe")
        .then_some(LLVMPIPE_LOOP_ITERATIONS - OTHER_LOOPS)
}

/// The most a sum of `lights` non-negative contributions that add up to `sum` can be off
/// when each is rounded to a float of `mantissa_bits` stored bits and then added into a
/// running sum in that float (round to nearest): with the unit roundoff u = 2^-(bits + 1),
/// recursive summation is off by at most gamma_(n-1) * sum (Higham, "Accuracy and Stability
/// of Numerical Algorithms", 2nd ed., section 4.2, for terms of one sign) and rounding the
/// terms on the way in adds u * sum: gamma_n = n u / (1 - n u) in all. None when n u >= 1,
/// where the bound says nothing (2048 lights and more at one pixel for a 16-bit float).
pub fn blended_sum_error(sum: f64, lights: u32, mantissa_bits: u32) -> Option<f64> {
    let u = 2f64.powi(-(mantissa_bits as i32 + 1));
    let nu = lights as f64 * u;
    (nu < 1.0).then(|| nu / (1.0 - nu) * sum)
}
