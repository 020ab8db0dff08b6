//! Mean FLIP (NVIDIA's perceptual difference, through `nv_flip`) of two 8-bit images,
//! computed only around the pixels where they differ.
//!
//! FLIP's error at a pixel depends on the two images only within a few pixels of it: it
//! filters both with separable kernels of fixed radius (colour, then edges and points) and
//! combines the filtered values pixel by pixel. Where the images agree over that reach, both
//! filter to the same bits and the error is exactly 0. A matrix cell mostly differs from its
//! reference in a handful of pixels, so FLIP runs on the tiles around those pixels, each with
//! a border as wide as the reach, and the mean is summed as FLIP's own pool sums it: in f32,
//! in row-major order, where the zeros left out add nothing. The result is the whole-image
//! FLIP's, bit for bit (`tests` below).

/// Pixels, along either axis, over which a difference reaches FLIP's error at the default
/// 67.02 pixels per degree: the colour filters' radius is ceil(3 sqrt(0.04 / (2 pi^2)) 67.02)
/// = 10, the edge and point filters' ceil(3 x 0.5 x 0.082 x 67.02) = 9 (FLIP's
/// `calculateSpatialFilterRadius` and `setFeatureFilter`).
pub const REACH: usize = 10;

/// Side of the tiles FLIP runs on, in pixels (each with `REACH` around it).
const TILE: usize = 64;

/// Mean FLIP of `test` against `reference`, both packed RGB8 of `w` x `h` pixels, row-major.
pub fn mean_rgb8(w: u32, h: u32, test: &[u8], reference: &[u8]) -> f64 {
    let (wu, hu) = (w as usize, h as usize);
    let (tiles_x, tiles_y) = (wu.div_ceil(TILE), hu.div_ceil(TILE));
    // Tiles holding a pixel within the reach of a difference.
    let mut marked = vec![false; tiles_x * tiles_y];
    let mut any = false;
    for (i, (a, b)) in test
        .chunks_exact(3)
        .zip(reference.chunks_exact(3))
        .enumerate()
    {
        if a != b {
            any = true;
            let (x, y) = (i % wu, i / wu);
            let (x0, x1) = (x.saturating_sub(REACH), (x + REACH).min(wu - 1));
            let (y0, y1) = (y.saturating_sub(REACH), (y + REACH).min(hu - 1));
            for ty in y0 / TILE..=y1 / TILE {
                for tx in x0 / TILE..=x1 / TILE {
                    marked[tx + tiles_x * ty] = true;
                }
            }
        }
    }
    if !any {
        return 0.0;
    }
    let crops: Vec<Crop> = (0..tiles_x * tiles_y)
        .filter(|&t| marked[t])
        .map(|t| Crop::around_tile(t % tiles_x, t / tiles_x, wu, hu))
        .collect();
    if crops.iter().map(Crop::area).sum::<usize>() >= wu * hu {
        return whole_image(w, h, test, reference);
    }
    let mut errors: Vec<(usize, f32)> = Vec::new();
    for c in &crops {
        let map = flip_map(
            c.w as u32,
            c.h as u32,
            &c.cut(test, wu),
            &c.cut(reference, wu),
        );
        for y in c.tile_y.clone() {
            for x in c.tile_x.clone() {
                let e = map[(y - c.y) * c.w + (x - c.x)];
                if e != 0.0 {
                    errors.push((y * wu + x, e));
                }
            }
        }
    }
    errors.sort_unstable_by_key(|&(i, _)| i);
    let sum = errors.iter().fold(0.0f32, |s, &(_, e)| s + e);
    (sum / (wu * hu) as f32) as f64
}

/// FLIP over the whole image, as `nv_flip` pools it.
fn whole_image(w: u32, h: u32, test: &[u8], reference: &[u8]) -> f64 {
    let map = nv_flip::FlipImageFloat::with_data(w, h, &flip_map(w, h, test, reference));
    nv_flip::FlipPool::from_image(&map).mean() as f64
}

/// FLIP's per-pixel error map, row-major.
fn flip_map(w: u32, h: u32, test: &[u8], reference: &[u8]) -> Vec<f32> {
    let test = nv_flip::FlipImageRgb8::with_data(w, h, test);
    let reference = nv_flip::FlipImageRgb8::with_data(w, h, reference);
    nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec()
}

/// A tile and the rectangle around it that FLIP needs: the tile grown by `REACH`, clipped
/// to the image (at the image's own edges FLIP clamps alike either way).
struct Crop {
    tile_x: std::ops::Range<usize>,
    tile_y: std::ops::Range<usize>,
    x: usize,
    y: usize,
    w: usize,
    h: usize,
}

impl Crop {
    fn around_tile(tx: usize, ty: usize, wu: usize, hu: usize) -> Self {
        let tile_x = tx * TILE..((tx + 1) * TILE).min(wu);
        let tile_y = ty * TILE..((ty + 1) * TILE).min(hu);
        let x = tile_x.start.saturating_sub(REACH);
        let y = tile_y.start.saturating_sub(REACH);
        let w = (tile_x.end + REACH).min(wu) - x;
        let h = (tile_y.end + REACH).min(hu) - y;
        Crop {
            tile_x,
            tile_y,
            x,
            y,
            w,
            h,
        }
    }

    fn area(&self) -> usize {
        self.w * self.h
    }

    /// This rectangle of a packed RGB8 image `wu` pixels wide.
    fn cut(&self, image: &[u8], wu: usize) -> Vec<u8> {
        (self.y..self.y + self.h)
            .flat_map(|y| &image[3 * (y * wu + self.x)..3 * (y * wu + self.x + self.w)])
            .copied()
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const W: u32 = 150;
    const H: u32 = 100;

    /// Edges, gradients and noise, so that every stage of FLIP has something to see.
    fn textured() -> Vec<u8> {
        (0..W * H * 3)
            .map(|i: u32| (i.wrapping_mul(2654435761) >> 13) as u8 ^ (i / (3 * W) * 5) as u8)
            .collect()
    }

    fn with_changes(base: &[u8], pixels: &[(u32, u32)]) -> Vec<u8> {
        let mut image = base.to_vec();
        for (k, &(x, y)) in pixels.iter().enumerate() {
            let i = 3 * (y * W + x) as usize + k % 3;
            image[i] = image[i].wrapping_add(1 + 40 * (k as u8 % 3));
        }
        image
    }

    #[test]
    fn identical_images_score_zero() {
        let image = textured();
        assert_eq!(mean_rgb8(W, H, &image, &image), 0.0);
        assert_eq!(whole_image(W, H, &image, &image), 0.0);
    }

    /// The premise: FLIP's error is exactly 0 farther than `REACH` from every difference.
    #[test]
    fn a_difference_reaches_no_farther_than_reach() {
        let base = textured();
        let (cx, cy) = (70u32, 40u32);
        let map = flip_map(W, H, &with_changes(&base, &[(cx, cy)]), &base);
        for y in 0..H {
            for x in 0..W {
                let far = x.abs_diff(cx).max(y.abs_diff(cy)) as usize > REACH;
                let e = map[(y * W + x) as usize];
                assert!(!far || e == 0.0, "error {e} at ({x}, {y})");
            }
        }
        assert!(map[(cy * W + cx) as usize] > 0.0);
    }

    /// Differences one at a time, at corners, edges and tile borders, in clusters, spread
    /// over the image, and so many that the whole image is taken: the mean must be FLIP's
    /// own, bit for bit.
    #[test]
    fn the_mean_over_tiles_is_the_whole_images_bit_for_bit() {
        let base = textured();
        let spread: Vec<(u32, u32)> = (0..9).map(|k| (17 * k + 3, 11 * k + 2)).collect();
        let many: Vec<(u32, u32)> = (0..60).map(|k| ((37 * k) % W, (23 * k) % H)).collect();
        let cases: Vec<Vec<(u32, u32)>> = vec![
            vec![(70, 40)],
            vec![(0, 0)],
            vec![(W - 1, H - 1)],
            vec![(W - 1, 0), (0, H - 1)],
            vec![(63, 63), (64, 64), (63, 64)],
            vec![(74, 10), (53, 10)],
            (40..52).flat_map(|x| [(x, 30), (x, 31)]).collect(),
            spread,
            many,
        ];
        for pixels in cases {
            let test = with_changes(&base, &pixels);
            let tiled = mean_rgb8(W, H, &test, &base);
            let whole = whole_image(W, H, &test, &base);
            assert!(whole > 0.0);
            assert_eq!(
                tiled.to_bits(),
                whole.to_bits(),
                "{pixels:?}: {tiled} vs {whole}"
            );
        }
    }
}
