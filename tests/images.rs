//! Image snapshots: every variant in variants/ on a small scene, compared with the reviewed
//! PNG in snapshots/images/ (reviewed on lavapipe) within the 2 LSB per channel that
//! rasterisers may round differently. Where an adapter legitimately differs further, the
//! difference is declared once in `clusterlab::gpu::expect`, not widened here for everyone.
//! A failing image leaves `NAME.snap.new.png` (review it with `cargo insta review`) and
//! `NAME.diff.png` (where it differs) in snapshots/images/.

mod common;

use std::path::{Path, PathBuf};

use clusterlab::compose::Composer;
use clusterlab::gpu::expect::{self, Allowance, Check};
use clusterlab::run::{CellOptions, run_cell};
use common::{gpu, small};

/// Per-channel difference tolerated (rasteriser rounding).
const TOLERANCE: u8 = 2;
const FOLDER: &str = "snapshots/images";

fn encode_png(w: u32, h: u32, rgb: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(rgb, w, h, image::ExtendedColorType::Rgb8)
        .expect("PNG encodes");
    out
}

use image::ImageEncoder;

fn decode_png(path: &Path) -> Option<image::RgbImage> {
    image::open(path).ok().map(|i| i.to_rgb8())
}

/// The largest per-channel difference of two RGB pixels.
fn pixel_diff(a: &[u8], b: &[u8]) -> u8 {
    a.iter()
        .zip(b)
        .map(|(x, y)| x.abs_diff(*y))
        .max()
        .unwrap_or(0)
}

/// How many pixels differ from `old` by more than the tolerance, and the largest difference.
fn pixels_off(old: &[u8], new: &[u8]) -> (usize, u8) {
    old.chunks(3)
        .zip(new.chunks(3))
        .map(|(a, b)| pixel_diff(a, b))
        .filter(|&d| d > TOLERANCE)
        .fold((0, 0), |(n, worst), d| (n + 1, worst.max(d)))
}

/// Compare with the stored snapshot; returns an error message when out of tolerance (and
/// out of the adapter's declared `allowed` difference, if any).
fn check_image(
    name: &str,
    w: u32,
    h: u32,
    rgb: &[u8],
    allowed: Option<Allowance>,
) -> Result<(), String> {
    let stored_path = PathBuf::from(FOLDER).join(format!("{name}.snap.png"));
    let stored = decode_png(&stored_path);
    let off = stored
        .as_ref()
        .filter(|old| old.dimensions() == (w, h))
        .map(|old| pixels_off(old.as_raw(), rgb));
    let within = match (off, allowed) {
        (Some((0, _)), _) => true,
        (Some((n, worst)), Some(Allowance::PixelsOff { pixels, lsb })) => {
            n <= pixels && worst <= lsb
        }
        _ => false,
    };
    // Within tolerance, assert the stored bytes themselves so insta sees no change.
    let bytes = if within {
        std::fs::read(&stored_path).expect("stored snapshot reads")
    } else {
        if let Some(old) = &stored
            && old.dimensions() == (w, h)
        {
            let diff: Vec<u8> = old
                .as_raw()
                .chunks(3)
                .zip(rgb.chunks(3))
                .flat_map(|(a, b)| {
                    let d = pixel_diff(a, b);
                    if d > TOLERANCE {
                        [255, 0, d.saturating_mul(16)]
                    } else {
                        [b[0] / 4, b[1] / 4, b[2] / 4]
                    }
                })
                .collect();
            let diff_path = PathBuf::from(FOLDER).join(format!("{name}.diff.png"));
            let _ = std::fs::write(&diff_path, encode_png(w, h, &diff));
        }
        encode_png(w, h, rgb)
    };
    let mut settings = insta::Settings::clone_current();
    settings.set_snapshot_path("../snapshots/images");
    settings.set_prepend_module_to_snapshot(false);
    settings.bind(|| {
        std::panic::catch_unwind(|| {
            insta::assert_binary_snapshot!(&format!("{name}.png"), bytes);
        })
    })
    .map_err(|_| match off {
        Some((n, worst)) => format!(
            "{name}: {n} pixels differ from snapshots/images/{name}.snap.png by more than \
             {TOLERANCE} LSB, up to {worst} (allowed on this adapter: {allowed:?}; see {name}.diff.png)"
        ),
        None => format!("{name}: no reviewed image of this size in snapshots/images/"),
    })
}

#[test]
fn every_variant_matches_its_reviewed_image() {
    let gpu = gpu();
    let composer = Composer::default();
    let params = small("atrium", 128, 72, Some(128));
    let mut failures = Vec::new();
    let files = clusterlab::variant::find_files(Path::new("variants")).expect("variants/");
    assert!(!files.is_empty());
    for file in files {
        let v = clusterlab::variant::load(&file).unwrap_or_else(|e| panic!("{e}"));
        let cell = run_cell(
            &gpu,
            &composer,
            &v,
            "atrium",
            params,
            CellOptions {
                frames: clusterlab::measure::Frames::exact(0, 1),
                stats: false,
                ..Default::default()
            },
        );
        let cell = match cell {
            Ok(cell) => cell,
            Err(e) => {
                failures.push(format!("{}: {e}", v.name));
                continue;
            }
        };
        let f = &cell.frame;
        let rgb: Vec<u8> = f.ldr.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
        let allowed = expect::allowance(&gpu, Check::ImageSnapshot { variant: &v.name });
        let name = format!("{}@atrium", v.name);
        if let Err(e) = check_image(&name, f.width, f.height, &rgb, allowed.map(|d| d.allowance)) {
            failures.push(e);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
