//! Twin of the post-processing passes (`shaders/passes/{toon,bloom_*,motion_blur}.wesl`,
//! `shaders/common/post.wesl`) in f64: toon bands on the colour's norm, depth-edge outlines,
//! bloom (bright pass, Gaussian blur, add back) and motion blur along reprojected motion.
//!
//! Every function takes its inputs explicitly, so a test can feed it the GPU's own input to
//! a pass (twin check) or the f64 reference frame (accuracy of the whole chain).

use glam::{DMat4, DVec2, DVec3, DVec4};

use super::depth::DepthMapping;
use strum::IntoEnumIterator;

use super::truth::RasterTruth;
use crate::common::PostEffect;

/// A linear HDR image, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<DVec3>,
}

impl Image {
    pub fn new(width: u32, height: u32, pixels: Vec<DVec3>) -> Self {
        assert_eq!(pixels.len(), width as usize * height as usize);
        Self {
            width,
            height,
            pixels,
        }
    }

    /// An f32 RGBA image (as read back from the GPU), alpha dropped.
    pub fn from_rgba(width: u32, height: u32, rgba: &[[f32; 4]]) -> Self {
        let pixels = rgba
            .iter()
            .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            .collect();
        Self::new(width, height, pixels)
    }

    /// The pixel at `(x, y)` clamped to the image (clamp-to-edge addressing).
    pub fn at(&self, x: i64, y: i64) -> DVec3 {
        let x = x.clamp(0, self.width as i64 - 1) as usize;
        let y = y.clamp(0, self.height as i64 - 1) as usize;
        self.pixels[y * self.width as usize + x]
    }

    fn map_pixels(&self, f: impl Fn(i64, i64, DVec3) -> DVec3) -> Image {
        let w = self.width as usize;
        let pixels = self
            .pixels
            .iter()
            .enumerate()
            .map(|(i, &c)| f((i % w) as i64, (i / w) as i64, c))
            .collect();
        Image::new(self.width, self.height, pixels)
    }
}

/// The post effects of a variant, in f64.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PostParams {
    /// Bands of the post-process toon pass.
    pub toon_bands: Option<u32>,
    /// Relative depth step that makes an outline.
    pub outline_threshold: Option<f64>,
    /// Bloom threshold and radius.
    pub bloom: Option<(f64, u32)>,
    /// Motion blur samples.
    pub motion_blur_samples: Option<u32>,
}

impl PostParams {
    /// Whether any effect is on.
    pub fn any(&self) -> bool {
        *self != Self::default()
    }
}

/// What the post passes know of the geometry, per pixel: view depth (the far plane where
/// there is no geometry) and the screen motion since the previous frame, in pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct Geometry {
    pub width: u32,
    pub height: u32,
    pub view_depth: Vec<f64>,
    pub motion: Vec<DVec2>,
}

/// The two cameras a frame's motion comes from, as the GPU sees them.
#[derive(Clone, Copy, Debug)]
pub struct CameraPair {
    pub near: f64,
    pub far: f64,
    pub tan_half_fov_y: f64,
    pub aspect: f64,
    pub world_from_view: DMat4,
    pub prev_clip_from_world: DMat4,
    pub mapping: DepthMapping,
}

impl CameraPair {
    /// Positive view depth of a depth-buffer value (twin of `view_depth_from_device`);
    /// None for the clear value.
    pub fn view_depth_from_device(&self, d: f64) -> Option<f64> {
        self.mapping.view_depth(d, self.near, self.far)
    }

    /// Pixels that the world point seen at pixel centre `xy` moved since the previous frame.
    fn motion(&self, xy: DVec2, world: DVec3, size: DVec2) -> DVec2 {
        let prev_clip = self.prev_clip_from_world * world.extend(1.0);
        let prev_ndc = prev_clip.truncate().truncate() / prev_clip.w;
        let prev_xy = DVec2::new(prev_ndc.x * 0.5 + 0.5, 0.5 - prev_ndc.y * 0.5) * size;
        xy - prev_xy
    }
}

impl Geometry {
    /// From a depth buffer, reconstructing each pixel's surface as the motion blur pass does.
    pub fn from_device_depth(width: u32, height: u32, depth: &[f32], cams: &CameraPair) -> Self {
        let size = DVec2::new(width as f64, height as f64);
        let mut view_depth = Vec::with_capacity(depth.len());
        let mut motion = Vec::with_capacity(depth.len());
        for (i, &d) in depth.iter().enumerate() {
            let (x, y) = ((i % width as usize) as f64, (i / width as usize) as f64);
            match cams.view_depth_from_device(d as f64) {
                None => {
                    view_depth.push(cams.far);
                    motion.push(DVec2::ZERO);
                }
                Some(z) => {
                    let xy = DVec2::new(x + 0.5, y + 0.5);
                    let uv = xy / size;
                    let ndc = DVec2::new(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
                    let ray = DVec3::new(
                        ndc.x * cams.tan_half_fov_y * cams.aspect,
                        ndc.y * cams.tan_half_fov_y,
                        -1.0,
                    );
                    let world = (cams.world_from_view * DVec4::from((ray * z, 1.0))).truncate();
                    view_depth.push(z);
                    motion.push(cams.motion(xy, world, size));
                }
            }
        }
        Self {
            width,
            height,
            view_depth,
            motion,
        }
    }

    /// From the raster truth's exact world positions (for the reference frame).
    pub fn from_truth(truth: &RasterTruth, cams: &CameraPair) -> Self {
        let size = DVec2::new(truth.width as f64, truth.height as f64);
        let view_from_world = cams.world_from_view.inverse();
        let mut view_depth = Vec::with_capacity(truth.position.len());
        let mut motion = Vec::with_capacity(truth.position.len());
        for i in 0..truth.position.len() {
            if !truth.covered(i) {
                view_depth.push(cams.far);
                motion.push(DVec2::ZERO);
                continue;
            }
            let world = truth.surface(i).position;
            let (x, y) = (i % truth.width as usize, i / truth.width as usize);
            let xy = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
            view_depth.push(-view_from_world.transform_point3(world).z);
            motion.push(cams.motion(xy, world, size));
        }
        Self {
            width: truth.width,
            height: truth.height,
            view_depth,
            motion,
        }
    }

    fn depth_at(&self, x: i64, y: i64) -> f64 {
        let x = x.clamp(0, self.width as i64 - 1) as usize;
        let y = y.clamp(0, self.height as i64 - 1) as usize;
        self.view_depth[y * self.width as usize + x]
    }

    /// Largest view-depth step from pixel `(x, y)` to its four neighbours.
    pub fn depth_step(&self, x: i64, y: i64) -> f64 {
        let z = self.depth_at(x, y);
        [(1, 0), (-1, 0), (0, 1), (0, -1)]
            .iter()
            .map(|(dx, dy)| (self.depth_at(x + dx, y + dy) - z).abs())
            .fold(0.0, f64::max)
    }
}

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: DVec3) -> f64 {
    c.dot(DVec3::new(0.2126, 0.7152, 0.0722))
}

/// Middle of the band of a display value in [0, 1): (k + 1/2) / bands.
pub fn toon_post_ramp(x: f64, bands: u32) -> f64 {
    let b = bands as f64;
    ((x * b).floor().min(b - 1.0) + 0.5) / b
}

/// The toon pass on one colour: its norm n banded on the display scale n / (1 + n).
pub fn toon(c: DVec3, bands: u32) -> DVec3 {
    let n = c.length();
    if n <= 0.0 {
        return c;
    }
    let banded = toon_post_ramp(n / (1.0 + n), bands);
    c * (banded / (1.0 - banded) / n)
}

/// Whether the pixel is on a depth edge: a neighbour's view depth differs by more than
/// `threshold` times its own.
pub fn is_outline(g: &Geometry, x: i64, y: i64, threshold: f64) -> bool {
    g.depth_step(x, y) > threshold * g.depth_at(x, y)
}

/// The toon pass: bands (when `bands` is given), then outlines (when `threshold` is).
pub fn toon_pass(image: &Image, g: &Geometry, bands: Option<u32>, threshold: Option<f64>) -> Image {
    image.map_pixels(|x, y, c| {
        let c = bands.map_or(c, |b| toon(c, b));
        match threshold {
            Some(t) if is_outline(g, x, y, t) => DVec3::ZERO,
            _ => c,
        }
    })
}

/// Gaussian sigma of a bloom radius (as in `common/post.wesl`).
pub fn bloom_sigma(radius: u32) -> f64 {
    (radius as f64 * 0.5).max(0.5)
}

/// Unnormalised 1D Gaussian weights of offsets -radius..=radius.
fn gaussian_weights(radius: u32) -> Vec<f64> {
    let sigma = bloom_sigma(radius);
    let r = radius as i64;
    (-r..=r)
        .map(|i| (-0.5 * (i as f64 / sigma).powi(2)).exp())
        .collect()
}

/// Sum of the unnormalised weights: the blur divides by it.
pub fn bloom_weight_sum(radius: u32) -> f64 {
    gaussian_weights(radius).iter().sum()
}

/// The bloom bright pass: the part of each pixel's luminance above `threshold`.
pub fn bright_pass(image: &Image, threshold: f64) -> Image {
    image.map_pixels(|_, _, c| {
        let l = luminance(c);
        if l > threshold {
            c * ((l - threshold) / l)
        } else {
            DVec3::ZERO
        }
    })
}

/// The normalised Gaussian blur of `radius` with clamp-to-edge addressing. Computed as two
/// 1D passes: with per-axis clamping that is exactly the d x d window of the naive kernel.
pub fn blur(image: &Image, radius: u32) -> Image {
    let weights: Vec<f64> = {
        let w = gaussian_weights(radius);
        let sum: f64 = w.iter().sum();
        w.iter().map(|x| x / sum).collect()
    };
    let r = radius as i64;
    let along = |img: &Image, axis: (i64, i64)| {
        img.map_pixels(|x, y, _| {
            (-r..=r)
                .zip(&weights)
                .map(|(i, w)| img.at(x + axis.0 * i, y + axis.1 * i) * *w)
                .sum()
        })
    };
    along(&along(image, (1, 0)), (0, 1))
}

/// Bloom: the blurred bright part added back to the image.
pub fn bloom(image: &Image, threshold: f64, radius: u32) -> Image {
    let blurred = blur(&bright_pass(image, threshold), radius);
    image.map_pixels(|x, y, c| c + blurred.pixels[(y * image.width as i64 + x) as usize])
}

/// Where motion blur sample `i` of `n` lands for pixel `(x, y)` moving `m`: spread over the
/// motion, centred on the pixel, rounded half to even as WGSL's `round` does, clamped.
pub fn motion_sample(x: i64, y: i64, m: DVec2, i: u32, n: u32) -> (i64, i64) {
    let t = (i as f64 + 0.5) / n as f64 - 0.5;
    let q = DVec2::new(x as f64, y as f64) + m * t;
    (q.x.round_ties_even() as i64, q.y.round_ties_even() as i64)
}

/// Motion blur: the mean of `samples` pixels along each pixel's motion.
pub fn motion_blur(image: &Image, g: &Geometry, samples: u32) -> Image {
    image.map_pixels(|x, y, _| {
        let m = g.motion[(y * image.width as i64 + x) as usize];
        let sum: DVec3 = (0..samples)
            .map(|i| {
                let (qx, qy) = motion_sample(x, y, m, i, samples);
                image.at(qx, qy)
            })
            .sum();
        sum / samples as f64
    })
}

/// Every post effect of `p`, in the order of the passes.
pub fn apply(p: &PostParams, image: &Image, g: &Geometry) -> Image {
    let mut out = image.clone();
    for effect in PostEffect::iter() {
        match effect {
            PostEffect::Toon => {
                if p.toon_bands.is_some() || p.outline_threshold.is_some() {
                    out = toon_pass(&out, g, p.toon_bands, p.outline_threshold);
                }
            }
            PostEffect::Bloom => {
                if let Some((threshold, radius)) = p.bloom {
                    out = bloom(&out, threshold, radius);
                }
            }
            PostEffect::MotionBlur => {
                if let Some(samples) = p.motion_blur_samples {
                    out = motion_blur(&out, g, samples);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn impulse(w: u32, h: u32, at: (u32, u32), value: f64) -> Image {
        let mut px = vec![DVec3::ZERO; (w * h) as usize];
        px[(at.1 * w + at.0) as usize] = DVec3::splat(value);
        Image::new(w, h, px)
    }

    #[test]
    fn blur_of_an_impulse_is_the_normalised_gaussian_and_keeps_energy() {
        let r = 3;
        let b = blur(&impulse(15, 15, (7, 7), 1.0), r);
        let total: f64 = b.pixels.iter().map(|p| p.x).sum();
        assert!((total - 1.0).abs() < 1e-12, "{total}");
        let w = gaussian_weights(r);
        let s = bloom_weight_sum(r);
        let expected = w[3 + 2] * w[3 - 1] / (s * s); // offset (+2, -1)
        assert!((b.at(9, 6).x - expected).abs() < 1e-15);
        // Symmetric.
        assert_eq!(b.at(9, 6), b.at(5, 8));
    }

    #[test]
    fn blur_at_the_edge_is_a_naive_window_with_clamped_taps() {
        let img = Image::new(
            5,
            4,
            (0..20).map(|i| DVec3::splat((i * i % 7) as f64)).collect(),
        );
        let r = 2;
        let w = gaussian_weights(r);
        let s = bloom_weight_sum(r);
        let naive = |x: i64, y: i64| -> DVec3 {
            let mut sum = DVec3::ZERO;
            for dy in -2..=2i64 {
                for dx in -2..=2i64 {
                    sum += img.at(x + dx, y + dy) * (w[(dx + 2) as usize] * w[(dy + 2) as usize]);
                }
            }
            sum / (s * s)
        };
        let b = blur(&img, r);
        for (x, y) in [(0, 0), (4, 3), (2, 1), (0, 3)] {
            assert!((b.at(x, y) - naive(x, y)).abs().max_element() < 1e-12);
        }
    }

    #[test]
    fn bright_pass_keeps_only_the_luminance_above_the_threshold() {
        let c = DVec3::new(2.0, 1.0, 0.5);
        let img = Image::new(2, 1, vec![c, DVec3::splat(0.5)]);
        let b = bright_pass(&img, 1.0);
        assert!((luminance(b.pixels[0]) - (luminance(c) - 1.0)).abs() < 1e-12);
        assert_eq!(b.pixels[1], DVec3::ZERO);
    }

    #[test]
    fn toon_bands_the_norm_and_keeps_the_hue() {
        let bands = 4;
        for n in [0.05, 0.2, 0.9, 3.0, 100.0] {
            let c = DVec3::new(3.0, 2.0, 1.0).normalize() * n;
            let t = toon(c, bands);
            let display = t.length() / (1.0 + t.length());
            let k = (display * 4.0 - 0.5).round();
            assert!((display - (k + 0.5) / 4.0).abs() < 1e-12, "{n}: {display}");
            assert!((t.normalize() - c.normalize()).length() < 1e-12);
        }
        assert_eq!(toon(DVec3::ZERO, bands), DVec3::ZERO);
    }

    #[test]
    fn outlines_mark_both_sides_of_a_depth_jump_only() {
        let (w, h) = (6, 3);
        let view_depth = (0..w * h)
            .map(|i| if i % w < 3 { 2.0 } else { 10.0 })
            .collect();
        let g = Geometry {
            width: w as u32,
            height: h as u32,
            view_depth,
            motion: vec![DVec2::ZERO; (w * h) as usize],
        };
        let marked: Vec<i64> = (0..w as i64)
            .filter(|&x| is_outline(&g, x, 1, 0.1))
            .collect();
        assert_eq!(marked, [2, 3]);
    }

    #[test]
    fn motion_blur_of_a_static_frame_is_the_identity_and_a_moving_pixel_averages_its_path() {
        let img = Image::new(8, 1, (0..8).map(|i| DVec3::splat(i as f64)).collect());
        let mut g = Geometry {
            width: 8,
            height: 1,
            view_depth: vec![1.0; 8],
            motion: vec![DVec2::ZERO; 8],
        };
        assert_eq!(motion_blur(&img, &g, 4), img);
        g.motion[4] = DVec2::new(4.0, 0.0);
        // Samples at 4 + 4 * (-3/8, -1/8, 1/8, 3/8) = 2.5, 3.5, 4.5, 5.5 -> 2, 4, 4, 6.
        let b = motion_blur(&img, &g, 4);
        assert_eq!(b.pixels[4].x, (2.0 + 4.0 + 4.0 + 6.0) / 4.0);
    }
}
