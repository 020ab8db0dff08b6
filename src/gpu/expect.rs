//! Where an adapter legitimately differs from the results reviewed on lavapipe (Vulkan),
//! declared once, per check and per backend or HDR format, as wgpu's own test harness lists
//! its per-adapter failure cases. Checks ask [`allowance`] instead of widening a tolerance
//! for every adapter; each entry says why the difference is not a defect.

use super::Gpu;

/// A check whose expectation may depend on the adapter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Check<'a> {
    /// The reviewed image of a variant (by name) in `snapshots/images/`.
    ImageSnapshot { variant: &'a str },
    /// View depth rebuilt from a reversed-Z float32 depth buffer (`study depth`).
    ReversedFloatDepth,
    /// Scissor deferred's sum of lights, blended into the HDR target (stress suite).
    BlendedLightSum,
}

/// When an entry applies.
#[derive(Clone, Copy, Debug)]
pub enum On {
    Backend(wgpu::Backend),
    HdrFormat(wgpu::TextureFormat),
}

impl On {
    /// Whether it holds for an adapter of `backend` whose HDR target is `hdr_format`.
    pub fn holds_for(self, backend: wgpu::Backend, hdr_format: wgpu::TextureFormat) -> bool {
        match self {
            On::Backend(b) => backend == b,
            On::HdrFormat(f) => hdr_format == f,
        }
    }
}

/// How far the check may then go from its usual bound.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Allowance {
    /// Besides the usual tolerance, up to `pixels` pixels may differ by up to `lsb`.
    PixelsOff { pixels: usize, lsb: u8 },
    /// Depth is only as precise as a 24-bit unorm buffer (Reed's model for 24 bits).
    DepthAs24BitUnorm,
    /// Each blended light's contribution and the running sum are rounded to a float of
    /// `mantissa_bits` stored bits: see [`blended_sum_error`].
    BlendRounding { mantissa_bits: u32 },
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

/// One declared difference.
#[derive(Clone, Copy, Debug)]
pub struct Deviation {
    pub check: Check<'static>,
    pub on: On,
    pub allowance: Allowance,
    pub why: &'static str,
}

/// Every declared difference. Keep each as narrow as the measurement that justified it.
pub const DEVIATIONS: &[Deviation] = &[
    Deviation {
        check: Check::ImageSnapshot {
            variant: "clustered_deferred_toon_outlines",
        },
        on: On::HdrFormat(wgpu::TextureFormat::Rgba16Float),
        // Measured on llvmpipe (OpenGL): 1 pixel of 128x72, 106 LSB.
        allowance: Allowance::PixelsOff {
            pixels: 1,
            lsb: u8::MAX,
        },
        why: "a 16-bit float HDR target (OpenGL) rounds a light's shaded colour to 11 bits, \
              which moves a pixel that sits on a per-light toon band edge into the next band: \
              that light's contribution jumps by a whole band, any amount on screen",
    },
    Deviation {
        check: Check::ReversedFloatDepth,
        on: On::Backend(wgpu::Backend::Gl),
        allowance: Allowance::DepthAs24BitUnorm,
        why: "wgpu's OpenGL backend keeps OpenGL's clip space (naga writes z' = 2z - w and \
              the depth range maps [-1, 1] back to [0, 1]), so a reversed-Z depth near 0 is \
              rounded at the precision of values near 1: a step of 2^-24, as in a 24-bit \
              buffer, and the float format's reversed-Z gain is lost",
    },
    Deviation {
        check: Check::BlendedLightSum,
        on: On::HdrFormat(wgpu::TextureFormat::Rgba16Float),
        allowance: Allowance::BlendRounding { mantissa_bits: 10 },
        why: "a 16-bit float target rounds each blended light and the running sum to an \
              11-bit significand: a pixel that n lights reach may be off by the error bound \
              of that sum (`blended_sum_error`) carried through the tonemap (1000 lights at \
              one point measure 17 LSB)",
    },
];

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
