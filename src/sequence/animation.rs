//! A sequence's animation: each frame made smaller (`thumbnail`), and the frames as an
//! animated GIF through the `image` crate.

use crate::render::FrameOutput;

/// Most frames an animation holds: longer sequences show every n-th frame.
pub const ANIMATION_FRAMES: u32 = 120;
/// Widest animation frame, pixels: a frame is made smaller by a whole factor to fit.
pub const ANIMATION_WIDTH: u32 = 320;

/// A frame made smaller for the animation: 8-bit RGBA, row-major.
#[derive(Clone, Debug)]
pub struct Thumbnail {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<u8>,
}

/// `frame`'s 8-bit image averaged over f x f blocks, the smallest whole f that makes it at
/// most `ANIMATION_WIDTH` wide (a partial block at the edge averages what it has).
pub fn thumbnail(frame: &FrameOutput) -> Thumbnail {
    let f = frame.width.div_ceil(ANIMATION_WIDTH).max(1);
    let (w, h) = (frame.width.div_ceil(f), frame.height.div_ceil(f));
    let mut rgba = Vec::with_capacity((w * h * 4) as usize);
    for ty in 0..h {
        for tx in 0..w {
            let (mut sum, mut n) = ([0u32; 3], 0u32);
            for y in ty * f..((ty + 1) * f).min(frame.height) {
                for x in tx * f..((tx + 1) * f).min(frame.width) {
                    let p = frame.ldr[(y * frame.width + x) as usize];
                    for c in 0..3 {
                        sum[c] += p[c] as u32;
                    }
                    n += 1;
                }
            }
            rgba.extend(sum.map(|s| ((s + n / 2) / n) as u8));
            rgba.push(255);
        }
    }
    Thumbnail {
        width: w,
        height: h,
        rgba,
    }
}

/// The animation as a looping GIF, each frame shown for `step_s` seconds (GIF keeps
/// hundredths: 1/30 s shows as 0.03 s).
pub fn gif(frames: &[Thumbnail], step_s: f64) -> Result<Vec<u8>, String> {
    use image::codecs::gif::{GifEncoder, Repeat};
    let mut bytes = Vec::new();
    {
        // Speed 10 of 1..=30: a palette per frame, quick enough for a report.
        let mut encoder = GifEncoder::new_with_speed(&mut bytes, 10);
        encoder
            .set_repeat(Repeat::Infinite)
            .map_err(|e| e.to_string())?;
        let delay = image::Delay::from_numer_denom_ms((step_s * 1e5).round() as u32, 100);
        for t in frames {
            let image = image::RgbaImage::from_raw(t.width, t.height, t.rgba.clone())
                .ok_or("a thumbnail's size does not match its pixels")?;
            encoder
                .encode_frame(image::Frame::from_parts(image, 0, 0, delay))
                .map_err(|e| e.to_string())?;
        }
    }
    Ok(bytes)
}
