//! Image snapshots: a variant's frame on a small scene, held to the reviewed PNG of the
//! adapter it ran on. Every pixel within `TOLERANCE` per channel, and at most
//! `MAX_SHARE_OFF` of them off at all (`judge`). Where an adapter legitimately differs
//! further, the difference is declared once in `gpu::expect`, not widened here.
//!
//! The shipped set was reviewed on Mesa's llvmpipe (lavapipe) and lies in [`FOLDER`]; any
//! other adapter keeps a set of its own in a folder named after it (`folder`), so a user on
//! a GPU reviews images too.

use std::path::PathBuf;

use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::gpu::expect::Allowance;
use crate::run::{CellOptions, run_cell};
use crate::variant::LoadedVariant;

/// The folder of the image snapshots, under the snapshot folder.
pub const FOLDER: &str = "images";

/// The scene, size and light count every image snapshot renders.
pub const SCENE: &str = "atrium";
pub const SIZE: (u32, u32) = (128, 72);
pub const LIGHTS: u32 = 128;

/// The adapter whose images are the shipped set (those in [`FOLDER`] itself).
pub const REVIEWED_ON: &str = "llvmpipe";

/// Per-channel difference tolerated: two colours less than an LSB apart round to 8-bit
/// values at most 1 apart.
pub const TOLERANCE: u8 = 1;

/// The share of pixels that may differ at all. An HDR target of 16-bit floats (OpenGL)
/// rounds each colour by at most 2^-11 relative; through the tonemap and sRGB encoding that
/// moves a displayed value by at most 0.0232 LSB (the maximum of 255 * (D(x (1 + 2^-11)) -
/// D(x)) over x, at x = 0.42, for D = sRGB(x / (1 + x))). A value that moves by d LSB changes
/// its 8-bit rounding only if a rounding boundary lies within d of it: for values spread
/// over the LSBs, in a share d of the pixels. Measured (128x72, 30 variants): at most 155 of
/// 9216 pixels (1.7%) off by 1 on llvmpipe through OpenGL, 30 (0.3%) on lavapipe.
pub const MAX_SHARE_OFF: f64 = 0.0232;

/// An 8-bit RGB frame.
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
}

/// The image folder of `adapter`, under the snapshot folder: [`FOLDER`] for the adapter the
/// shipped set was reviewed on, `FOLDER/<adapter name>` for any other.
pub fn folder(adapter: &str) -> PathBuf {
    if adapter.contains(REVIEWED_ON) {
        return PathBuf::from(FOLDER);
    }
    let slug: String = adapter
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect();
    PathBuf::from(FOLDER).join(slug.trim_matches('_'))
}

/// The snapshot's name of variant `name`'s image.
pub fn name(variant: &str) -> String {
    format!("{variant}@{SCENE}")
}

/// Variant `v`'s frame on the snapshot scene, or why there is none (a failed render, or a
/// frame that is no result: NaN pixels, nothing lit).
pub fn render(gpu: &Gpu, composer: &Composer, v: &LoadedVariant) -> Result<Image, String> {
    let mut params = crate::scene::defaults(SCENE).map_err(|e| e.to_string())?;
    (params.width, params.height, params.lights) = (SIZE.0, SIZE.1, LIGHTS);
    let cell = run_cell(
        gpu,
        composer,
        v,
        SCENE,
        params,
        CellOptions {
            frames: crate::measure::Frames::exact(0, 1),
            stats: false,
            ..Default::default()
        },
    )
    .map_err(|e| format!("{}: {e}", v.name))?;
    let f = &cell.frame;
    Ok(Image {
        width: f.width,
        height: f.height,
        rgb: f.ldr.iter().flat_map(|p| [p[0], p[1], p[2]]).collect(),
    })
}

pub fn encode_png(image: &Image) -> Vec<u8> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(
            &image.rgb,
            image.width,
            image.height,
            image::ExtendedColorType::Rgb8,
        )
        .expect("an RGB image encodes as PNG");
    out
}

/// A PNG's pixels, if it decodes.
pub fn decode_png(bytes: &[u8]) -> Option<Image> {
    let decoded = image::load_from_memory(bytes).ok()?.to_rgb8();
    Some(Image {
        width: decoded.width(),
        height: decoded.height(),
        rgb: decoded.into_raw(),
    })
}

/// The largest per-channel difference of two RGB pixels.
fn pixel_diff(a: &[u8], b: &[u8]) -> u8 {
    a.iter()
        .zip(b)
        .map(|(x, y)| x.abs_diff(*y))
        .max()
        .unwrap_or(0)
}

/// Whether an image `new` matches the reviewed `old` (RGB bytes of one size): every pixel
/// within `TOLERANCE`, at most `MAX_SHARE_OFF` of them off at all, unless the adapter
/// declares `allowed` pixels further off.
pub fn judge(old: &[u8], new: &[u8], allowed: Option<Allowance>) -> Result<(), String> {
    let (over, worst, any) = old
        .chunks(3)
        .zip(new.chunks(3))
        .map(|(a, b)| pixel_diff(a, b))
        .filter(|&d| d > 0)
        .fold((0, 0, 0), |(n, worst, any), d| {
            (n + usize::from(d > TOLERANCE), worst.max(d), any + 1)
        });
    let pixels = old.len() / 3;
    let extra = match allowed {
        Some(Allowance::PixelsOff { pixels, lsb }) if worst <= lsb => pixels,
        _ => 0,
    };
    if over > extra {
        return Err(format!(
            "{over} pixels differ by more than {TOLERANCE} LSB, up to {worst} (allowed on this adapter: {allowed:?})"
        ));
    }
    if any as f64 > MAX_SHARE_OFF * pixels as f64 + extra as f64 {
        return Err(format!(
            "{any} of {pixels} pixels differ (at most {:.2}%)",
            MAX_SHARE_OFF * 100.0
        ));
    }
    Ok(())
}

/// Where `new` differs from `old` by more than the tolerance, in red (brighter the more),
/// over a darkened `new`.
pub fn difference(old: &Image, new: &Image) -> Image {
    let rgb = old
        .rgb
        .chunks(3)
        .zip(new.rgb.chunks(3))
        .flat_map(|(a, b)| {
            let d = pixel_diff(a, b);
            if d > TOLERANCE {
                [255, 0, d.saturating_mul(16)]
            } else {
                [b[0] / 4, b[1] / 4, b[2] / 4]
            }
        })
        .collect();
    Image {
        width: new.width,
        height: new.height,
        rgb,
    }
}

/// The metadata file insta keeps beside a PNG snapshot.
pub fn metadata() -> String {
    "---\nsource: tests/images.rs\nexpression: bytes\nextension: png\nsnapshot_kind: binary\n---\n"
        .into()
}
