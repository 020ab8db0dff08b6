//! The declared differences between adapters, one entry each with why it is not a defect
//! (`expect` answers checks from them).

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
    /// `mantissa_bits` stored bits: see `expect::blended_sum_error`.
    BlendRounding { mantissa_bits: u32 },
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
