//! The bias of a sampled light loop: the same frame drawn with S independent seeds, the
//! mean of their images against the f64 reference. For an unbiased estimator the mean
//! converges to the reference, its RMSE falling as 1/sqrt(S); a z-test on the image mean and
//! on a few hundred pixel means, at a stated false-alarm rate, decides whether it does.

use serde::Serialize;

use crate::compose::Composer;
use crate::cpu::frame::ReferenceFrame;
use crate::gpu::Gpu;
use crate::render::{RenderError, Renderer};
use crate::scene::Scene;
use crate::variant::LoadedVariant;

/// False-alarm rate of the image-mean test: |z| beyond 3.89.
pub const IMAGE_ALPHA: f64 = 1e-4;
/// False-alarm rate of the pixel tests together (Bonferroni: each pixel at this over the
/// number tested).
pub const PIXELS_ALPHA: f64 = 1e-3;
/// Most pixels tested, spread evenly over those whose estimate varies.
pub const TESTED_PIXELS: usize = 256;

/// What S seeds of a frame add up to.
#[derive(Clone, Debug)]
pub struct SeedRuns {
    pub seeds: u32,
    /// Per pixel and channel, the sum and the sum of squares over the seeds.
    sum: Vec<[f64; 3]>,
    sum_sq: Vec<[f64; 3]>,
    /// Each seed's image mean (over pixels and channels).
    image_means: Vec<f64>,
    /// RMSE of the mean image against the reference (linear HDR) after 1, 2, 4, ... seeds.
    pub rmse_of_mean: Vec<(u32, f64)>,
}

/// Draw the frames `frames` (the last is the one measured; with temporal reuse the ones
/// before it are its history) once per seed in 1..=seeds, and add up the last frame's
/// images. A variant that reuses frames gets a renderer per seed (no history from another
/// seed); the others one renderer, reseeded.
pub fn seed_runs(
    gpu: &Gpu,
    composer: &Composer,
    variant: &LoadedVariant,
    frames: &[Scene],
    seeds: u32,
    reference: &ReferenceFrame,
) -> Result<SeedRuns, RenderError> {
    let first = frames.first().expect("a frame");
    let pixels = (first.params.width * first.params.height) as usize;
    let mut runs = SeedRuns {
        seeds,
        sum: vec![[0.0; 3]; pixels],
        sum_sq: vec![[0.0; 3]; pixels],
        image_means: Vec::with_capacity(seeds as usize),
        rmse_of_mean: Vec::new(),
    };
    let last = frames.last().expect("a frame");
    let history = variant
        .variant
        .shading
        .lights
        .sampling()
        .is_some_and(|s| s.reuses_frames());
    let mut shared = (!history)
        .then(|| Renderer::new(gpu, composer, &variant.variant, last))
        .transpose()?;
    for seed in 1..=seeds {
        let image = match &mut shared {
            Some(renderer) => {
                renderer.reseed(seed);
                renderer.render()?
            }
            None => {
                let mut renderer = Renderer::new(gpu, composer, &variant.variant, first)?;
                renderer.reseed(seed);
                let mut image = renderer.render()?;
                for scene in &frames[1..] {
                    renderer.advance(scene)?;
                    image = renderer.render()?;
                }
                image
            }
        };
        let mut total = 0.0;
        for (i, p) in image.hdr.iter().enumerate() {
            for (c, &x) in p[..3].iter().enumerate() {
                let x = x as f64;
                runs.sum[i][c] += x;
                runs.sum_sq[i][c] += x * x;
                total += x;
            }
        }
        runs.image_means.push(total / (3 * pixels) as f64);
        if seed.is_power_of_two() {
            runs.rmse_of_mean
                .push((seed, runs.mean_rmse(reference, seed)));
        }
    }
    Ok(runs)
}

impl SeedRuns {
    fn mean_rmse(&self, reference: &ReferenceFrame, seeds: u32) -> f64 {
        let n = seeds as f64;
        let sq: f64 = self
            .sum
            .iter()
            .zip(&reference.hdr)
            .flat_map(|(s, r)| (0..3).map(move |c| (s[c] / n - r[c]).powi(2)))
            .sum();
        (sq / (3 * self.sum.len()).max(1) as f64).sqrt()
    }
}

/// The z-tests of an estimator's mean against the reference.
#[derive(Clone, Debug, Serialize)]
pub struct BiasTest {
    pub seeds: u32,
    /// z of the image mean.
    pub image_z: f64,
    /// The largest |z| of the tested pixels' means (channels summed), and where.
    pub worst_pixel_z: f64,
    pub worst_pixel: Option<[u32; 2]>,
    pub pixels_tested: usize,
    /// Two-sided p of the image test, and the smallest of the pixels' (before Bonferroni).
    pub image_p: f64,
    pub worst_pixel_p: f64,
    /// RMSE of the mean image after 1, 2, 4, ... seeds (linear HDR).
    pub rmse_of_mean: Vec<(u32, f64)>,
}

impl BiasTest {
    /// Whether the mean is consistent with the reference at the stated false-alarm rates.
    pub fn unbiased(&self) -> bool {
        self.image_p >= IMAGE_ALPHA
            && self.worst_pixel_p >= PIXELS_ALPHA / self.pixels_tested.max(1) as f64
    }
}

/// Two-sided p of a standard normal z.
fn two_sided_p(z: f64) -> f64 {
    libm::erfc(z.abs() / std::f64::consts::SQRT_2)
}

/// How far a deterministic frame may sit from the reference without any bias: the f32
/// shading against the f64 reference (1e-5 relative, a few roundings of a light's terms)
/// plus the HDR target's rounding (`hdr_rounding` relative: 2^-23 for 32-bit floats, 2^-10
/// for 16-bit ones). It is taken off |mean - reference| before dividing by the standard
/// error, so a frame that is exact but for rounding never fails.
fn allowance(reference: f64, hdr_rounding: f64) -> f64 {
    (1e-5 + hdr_rounding) * reference.abs()
}

/// Test `runs` against `reference`.
pub fn test(runs: &SeedRuns, reference: &ReferenceFrame, hdr_rounding: f64) -> BiasTest {
    let n = runs.seeds as f64;
    let width = reference.width;
    // The image mean: one number per seed.
    let m = runs.image_means.iter().sum::<f64>() / n;
    let var = runs
        .image_means
        .iter()
        .map(|x| (x - m).powi(2))
        .sum::<f64>()
        / (n - 1.0);
    let pixels = reference.hdr.len().max(1) as f64;
    let truth = reference.hdr.iter().flatten().sum::<f64>() / (3.0 * pixels);
    let z = |mean: f64, truth: f64, var: f64| {
        let off = ((mean - truth).abs() - allowance(truth, hdr_rounding)).max(0.0);
        if off == 0.0 {
            0.0
        } else if var <= 0.0 {
            f64::INFINITY
        } else {
            off / (var / n).sqrt()
        }
    };
    let image_z = z(m, truth, var);
    // Each pixel's brightest channel (one number a pixel, its variance from its own
    // moments), at the pixels whose estimate varies, every k-th of them.
    let pixel_var = |i: usize| {
        let c = brightest(&runs.sum[i]);
        let mean = runs.sum[i][c] / n;
        (c, (runs.sum_sq[i][c] / n - mean * mean) * n / (n - 1.0))
    };
    let varying: Vec<usize> = (0..runs.sum.len())
        .filter(|&i| pixel_var(i).1 > 0.0)
        .collect();
    let step = varying.len().div_ceil(TESTED_PIXELS).max(1);
    let tested: Vec<usize> = varying.iter().copied().step_by(step).collect();
    let mut worst = (0.0, None);
    for &i in &tested {
        let (c, v) = pixel_var(i);
        let zi = z(runs.sum[i][c] / n, reference.hdr[i][c], v);
        if zi > worst.0 {
            worst = (zi, Some([i as u32 % width, i as u32 / width]));
        }
    }
    BiasTest {
        seeds: runs.seeds,
        image_z,
        worst_pixel_z: worst.0,
        worst_pixel: worst.1,
        pixels_tested: tested.len(),
        image_p: two_sided_p(image_z),
        worst_pixel_p: two_sided_p(worst.0),
        rmse_of_mean: runs.rmse_of_mean.clone(),
    }
}

/// The channel of the largest sum.
fn brightest(s: &[f64; 3]) -> usize {
    (0..3).max_by(|&a, &b| s[a].total_cmp(&s[b])).unwrap_or(0)
}

/// The relative rounding of an HDR target of `format`: one unit in the last place, as a
/// conversion may truncate rather than round to nearest (llvmpipe through OpenGL writes
/// 2.0780089 to a 16-bit float target as 2.0761719, 0.9 units below it).
pub fn hdr_rounding(format: wgpu::TextureFormat) -> f64 {
    if format == wgpu::TextureFormat::Rgba32Float {
        2f64.powi(-23)
    } else {
        2f64.powi(-10)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_sided_p_is_the_normal_tail() {
        assert!((two_sided_p(1.959964) - 0.05).abs() < 1e-6);
        assert!((two_sided_p(-3.890592) - 1e-4).abs() < 1e-8);
    }
}
