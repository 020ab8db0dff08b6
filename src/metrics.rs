//! Error of a frame against the CPU reference, and an error heat map.

use serde::{Deserialize, Serialize};

use crate::cpu::frame::ReferenceFrame;
use crate::render::FrameOutput;

/// How far a frame is from the reference. HDR figures are in linear radiance; 8-bit figures
/// in display code values (LSB).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorMetrics {
    /// Largest per-channel difference of the displayed 8-bit images.
    pub max_abs_8bit: u32,
    /// Root mean square per-channel difference of the linear HDR images.
    pub rmse: f64,
    pub rmse_8bit: f64,
    pub max_abs_hdr: f64,
    /// PSNR of the 8-bit image in dB; null when the images are identical (infinite).
    pub psnr_db: Option<f64>,
    /// Mean FLIP (NVIDIA's perceptual difference, 0 = identical, 1 = maximal).
    pub flip_mean: f64,
    /// Pixels whose displayed value differs by more than 1 LSB in some channel.
    pub pixels_over_1lsb: u64,
    /// Pixels whose HDR value is NaN or infinite in some channel.
    pub nan_pixels: u64,
    /// Relative MSE of the linear HDR images, as the many-light sampling literature reports
    /// it: the mean of (x - r)^2 / (r^2 + RELATIVE_MSE_OFFSET) per channel.
    #[serde(default)]
    pub relative_mse: f64,
    /// With shadows: what the reference's rays found, and the error beside the pixels
    /// whose ambiguous pairs allow more.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shadows: Option<ShadowError>,
}

/// A shadowed frame's error where the reference allows only rounding.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShadowError {
    /// Pairs (sample, light) the reference traced a ray for, those it found blocked, and
    /// those within the GPU's error of an occluder (either answer right).
    pub pairs: u64,
    pub blocked: u64,
    pub ambiguous: u64,
    /// The ambiguous pairs' share of the pairs.
    pub ambiguous_share: f64,
    /// Pixels with an ambiguous pair.
    pub ambiguous_pixels: u64,
    /// The largest difference of the displayed images outside the range a pixel's
    /// ambiguous pairs allow (each ambiguous light in or out): what an exact variant holds
    /// to 1 LSB.
    pub max_outside_ambiguity_8bit: u32,
}

/// What relative MSE adds to the reference's square, so that black pixels do not divide by
/// zero (Rousselle et al. 2011 use 1e-2 or 1e-3; radiance here is near 1 where lit).
pub const RELATIVE_MSE_OFFSET: f64 = 1e-2;

/// Compare `frame` with `reference` (same size).
pub fn compare(frame: &FrameOutput, reference: &ReferenceFrame) -> ErrorMetrics {
    let n = frame.ldr.len().min(reference.ldr.len());
    let (mut max8, mut sq8, mut over1, mut nan) = (0u32, 0f64, 0u64, 0u64);
    let (mut max_hdr, mut sq_hdr, mut relative) = (0f64, 0f64, 0f64);
    for i in 0..n {
        let mut pixel_max = 0;
        for c in 0..3 {
            let d = (frame.ldr[i][c] as i32 - reference.ldr[i][c] as i32).unsigned_abs();
            pixel_max = pixel_max.max(d);
            sq8 += (d * d) as f64;
        }
        max8 = max8.max(pixel_max);
        if pixel_max > 1 {
            over1 += 1;
        }
        let hdr = &frame.hdr[i];
        if hdr[..3].iter().any(|v| !v.is_finite()) {
            nan += 1;
            continue;
        }
        for (h, r) in hdr[..3].iter().zip(reference.hdr[i]) {
            let d = (*h as f64 - r).abs();
            max_hdr = max_hdr.max(d);
            sq_hdr += d * d;
            relative += d * d / (r * r + RELATIVE_MSE_OFFSET);
        }
    }
    let samples = (3 * n.max(1)) as f64;
    let mse8 = sq8 / samples;
    let shadows = reference
        .shadows
        .as_ref()
        .map(|f| shadow_error(frame, reference, f));
    ErrorMetrics {
        max_abs_8bit: max8,
        rmse: (sq_hdr / samples).sqrt(),
        rmse_8bit: mse8.sqrt(),
        max_abs_hdr: max_hdr,
        psnr_db: (mse8 > 0.0).then(|| 10.0 * (255.0 * 255.0 / mse8).log10()),
        flip_mean: flip_mean(frame, reference),
        pixels_over_1lsb: over1,
        nan_pixels: nan,
        relative_mse: relative / samples,
        shadows,
    }
}

/// The error of a shadowed frame outside what its ambiguous pairs allow: at a pixel with
/// one, the distance from the range between its lowest and highest display values (and the
/// reference's own); elsewhere the plain difference.
fn shadow_error(
    frame: &FrameOutput,
    reference: &ReferenceFrame,
    f: &crate::cpu::frame::ShadowFigures,
) -> ShadowError {
    let n = frame.ldr.len().min(reference.ldr.len());
    let mut ranges = f.ranges.iter().peekable();
    let mut worst = 0u32;
    for i in 0..n {
        let range = ranges.next_if(|(at, _, _)| *at as usize == i);
        for c in 0..3 {
            let (got, own) = (frame.ldr[i][c] as i32, reference.ldr[i][c] as i32);
            let (lo, hi) = match range {
                Some((_, lo, hi)) => ((lo[c] as i32).min(own), (hi[c] as i32).max(own)),
                None => (own, own),
            };
            worst = worst.max((lo - got).max(got - hi).max(0) as u32);
        }
    }
    ShadowError {
        pairs: f.pairs,
        blocked: f.blocked,
        ambiguous: f.ambiguous,
        ambiguous_share: f.ambiguous as f64 / f.pairs.max(1) as f64,
        ambiguous_pixels: f.ranges.len() as u64,
        max_outside_ambiguity_8bit: worst,
    }
}

/// The 8-bit RMSE of `frame` against `reference` alone (what a sequence of many frames
/// checks each frame by; `compare` gives every figure).
pub fn rmse_8bit(frame: &FrameOutput, reference: &ReferenceFrame) -> f64 {
    let n = frame.ldr.len().min(reference.ldr.len());
    let sq: f64 = (0..n)
        .flat_map(|i| (0..3).map(move |c| (i, c)))
        .map(|(i, c)| (frame.ldr[i][c] as f64 - reference.ldr[i][c] as f64).powi(2))
        .sum();
    (sq / (3 * n.max(1)) as f64).sqrt()
}

fn rgb8(pixels: impl Iterator<Item = [u8; 3]>) -> Vec<u8> {
    pixels.flatten().collect()
}

/// Mean FLIP of the displayed images, computed around the pixels where they differ.
fn flip_mean(frame: &FrameOutput, reference: &ReferenceFrame) -> f64 {
    crate::flip::mean_rgb8(
        frame.width,
        frame.height,
        &rgb8(frame.ldr.iter().map(|p| [p[0], p[1], p[2]])),
        &rgb8(reference.ldr.iter().copied()),
    )
}

/// Where an error of `d` 8-bit LSB falls on the heat map's scale: log2(1 + d) / 8, so 1 LSB
/// is faint and 255 LSB is white.
pub fn heat_value(d: u32) -> f32 {
    ((1.0 + d as f32).log2() / 8.0).min(1.0)
}

/// Per-pixel error as an RGB8 heat map (magma) of [`heat_value`]: the largest 8-bit channel
/// difference.
pub fn heat_map(frame: &FrameOutput, reference: &ReferenceFrame) -> Vec<u8> {
    let values: Vec<f32> = frame
        .ldr
        .iter()
        .zip(&reference.ldr)
        .map(|(a, b)| {
            let d = (0..3)
                .map(|c| (a[c] as i32 - b[c] as i32).unsigned_abs())
                .max()
                .unwrap_or(0);
            heat_value(d)
        })
        .collect();
    let map = nv_flip::FlipImageFloat::with_data(frame.width, frame.height, &values);
    map.apply_color_lut(&nv_flip::magma_lut()).to_vec()
}

/// How far a frame-to-frame change is from the reference's change between the same two
/// frames, in displayed 8-bit code values: popping and flicker that the still frames'
/// errors do not show. An exact variant, within 1 LSB of each reference, is within 2 here.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TemporalError {
    /// Largest per-channel difference of the two changes.
    pub max_abs_8bit: u32,
    /// Root mean square per-channel difference of the two changes.
    pub rmse_8bit: f64,
    /// Pixels whose change differs from the reference's by more than 2 LSB in some channel.
    pub pixels_over_2lsb: u64,
}

/// The change from `before` to `frame` against the reference's, `reference_before` to
/// `reference` (all the same size).
pub fn temporal(
    before: &FrameOutput,
    frame: &FrameOutput,
    reference_before: &ReferenceFrame,
    reference: &ReferenceFrame,
) -> TemporalError {
    let n = frame.ldr.len().min(before.ldr.len());
    let (mut max, mut sq, mut over) = (0u32, 0f64, 0u64);
    for i in 0..n {
        let mut pixel_max = 0;
        for c in 0..3 {
            let gpu = frame.ldr[i][c] as i32 - before.ldr[i][c] as i32;
            let truth = reference.ldr[i][c] as i32 - reference_before.ldr[i][c] as i32;
            let d = (gpu - truth).unsigned_abs();
            pixel_max = pixel_max.max(d);
            sq += (d * d) as f64;
        }
        max = max.max(pixel_max);
        over += u64::from(pixel_max > 2);
    }
    TemporalError {
        max_abs_8bit: max,
        rmse_8bit: (sq / (3 * n.max(1)) as f64).sqrt(),
        pixels_over_2lsb: over,
    }
}
