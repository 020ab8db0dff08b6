//! Base colour textures as the GPU samples them: every texture of a scene resampled to one
//! square size and stacked into the layers of one 2D array, with a full mip chain.
//!
//! One array instead of one binding per texture keeps the raster passes' bind groups fixed
//! (a vertex names its layer). The cost is resampling: each texture is scaled to the
//! largest side among them, rounded up to a power of two and capped at
//! [`MAX_TEXTURE_SIZE`], with a triangle filter in sRGB space (as image editors do); the
//! mip levels below are 2x2 box filters in linear space. Sampling is trilinear with
//! repeat, glTF's default sampler.

use crate::common::srgb_encode;

/// The largest side a layer may have: 1024 keeps Sponza's 25 textures at about 140 MB with
/// their mips, which a software rasteriser samples at a usable speed.
pub const MAX_TEXTURE_SIZE: u32 = 1024;

/// The scene's base colour textures.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureArray {
    /// Side of level 0.
    pub size: u32,
    pub layers: u32,
    /// RGBA8 sRGB texels, one entry per mip level (level 0 first); each holds every layer,
    /// layer after layer, rows top to bottom.
    pub levels: Vec<Vec<u8>>,
}

impl TextureArray {
    /// Stack `images` (RGBA8 sRGB, any sizes) into one array.
    pub fn new(images: &[image::RgbaImage]) -> TextureArray {
        let largest = images
            .iter()
            .map(|i| i.width().max(i.height()))
            .max()
            .unwrap_or(1);
        let size = largest.next_power_of_two().clamp(1, MAX_TEXTURE_SIZE);
        let mut levels = vec![Vec::with_capacity(
            images.len() * (size * size * 4) as usize,
        )];
        for img in images {
            let scaled = if img.dimensions() == (size, size) {
                img.clone()
            } else {
                image::imageops::resize(img, size, size, image::imageops::FilterType::Triangle)
            };
            levels[0].extend_from_slice(scaled.as_raw());
        }
        let mut side = size;
        while side > 1 {
            let below = halve(levels.last().expect("level 0"), side, images.len());
            levels.push(below);
            side /= 2;
        }
        TextureArray {
            size,
            layers: images.len() as u32,
            levels,
        }
    }

    pub fn mip_count(&self) -> u32 {
        self.levels.len() as u32
    }

    /// Bytes on the GPU, every level.
    pub fn bytes(&self) -> u64 {
        self.levels.iter().map(|l| l.len() as u64).sum()
    }
}

/// The next mip level of `layers` square layers of side `side`: each texel the mean of 2x2,
/// in linear space; alpha averaged as it is.
fn halve(level: &[u8], side: u32, layers: usize) -> Vec<u8> {
    let half = (side / 2) as usize;
    let side = side as usize;
    let to_linear = srgb_to_linear_table();
    let mut out = Vec::with_capacity(layers * half * half * 4);
    for layer in 0..layers {
        let base = layer * side * side * 4;
        for y in 0..half {
            for x in 0..half {
                let mut sum = [0.0f64; 4];
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let i = base + ((2 * y + dy) * side + 2 * x + dx) * 4;
                    for c in 0..3 {
                        sum[c] += to_linear[level[i + c] as usize];
                    }
                    sum[3] += level[i + 3] as f64 / 255.0;
                }
                for (c, s) in sum.iter().enumerate() {
                    let mean = s / 4.0;
                    let encoded = if c < 3 { srgb_encode(mean) } else { mean };
                    out.push((encoded.clamp(0.0, 1.0) * 255.0).round() as u8);
                }
            }
        }
    }
    out
}

/// Linear value of each 8-bit sRGB code.
fn srgb_to_linear_table() -> [f64; 256] {
    std::array::from_fn(|i| {
        let c = i as f64 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layers_are_resampled_to_the_largest_power_of_two_with_a_full_chain() {
        let a = image::RgbaImage::from_pixel(3, 5, image::Rgba([255, 0, 0, 255]));
        let b = image::RgbaImage::from_pixel(2, 2, image::Rgba([0, 0, 255, 255]));
        let t = TextureArray::new(&[a, b]);
        assert_eq!((t.size, t.layers, t.mip_count()), (8, 2, 4));
        for (level, side) in t.levels.iter().zip([8usize, 4, 2, 1]) {
            assert_eq!(level.len(), 2 * side * side * 4);
            // Uniform layers stay uniform at every level.
            assert_eq!(&level[..4], &[255, 0, 0, 255]);
            assert_eq!(
                &level[side * side * 4..side * side * 4 + 4],
                &[0, 0, 255, 255]
            );
        }
    }

    #[test]
    fn mips_average_in_linear_space() {
        // Black and white texels: the mean is linear 0.5, sRGB code 188, not 128.
        let mut img = image::RgbaImage::new(2, 2);
        for (x, y, p) in img.enumerate_pixels_mut() {
            let v = if (x + y) % 2 == 0 { 255 } else { 0 };
            *p = image::Rgba([v, v, v, 255]);
        }
        let t = TextureArray::new(&[img]);
        assert_eq!(&t.levels[1][..], &[188, 188, 188, 255]);
    }
}
