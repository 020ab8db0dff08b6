//! Image snapshots (`clusterlab::snapshot::images`): every variant in variants/ on a small
//! scene, compared with the reviewed PNG of the adapter it runs on: every pixel within 1 LSB
//! per channel, and at most `MAX_SHARE_OFF` of them off at all (see `judge`). The shipped
//! set was reviewed on lavapipe; `clusterlab snapshot` writes another adapter's set in a
//! folder of its own. Where an adapter has no set, the bytes are not the point: an exact
//! variant is held to the f64 reference instead (within 1 LSB), and the others are skipped,
//! saying so. A failing image leaves `NAME.snap.new.png` (review it with `cargo insta
//! review`) and `NAME.diff.png` (where it differs) beside the reviewed one.

use std::path::{Path, PathBuf};

use crate::common::gpu;
use clusterlab::compose::Composer;
use clusterlab::gpu::expect::{self, Allowance, Check};
use clusterlab::snapshot::images::{self, Image, judge};

/// Compare with the stored snapshot in `folder`; returns an error message when out of
/// tolerance (and out of the adapter's declared `allowed` difference, if any).
fn check_image(
    folder: &Path,
    name: &str,
    new: &Image,
    allowed: Option<Allowance>,
) -> Result<(), String> {
    let stored_path = folder.join(format!("{name}.snap.png"));
    let stored = std::fs::read(&stored_path)
        .ok()
        .and_then(|b| images::decode_png(&b));
    let verdict = match &stored {
        Some(old) if (old.width, old.height) == (new.width, new.height) => {
            judge(&old.rgb, &new.rgb, allowed)
        }
        _ => Err(format!(
            "no reviewed image of this size in {}",
            folder.display()
        )),
    };
    let within = verdict.is_ok();
    // Within tolerance, assert the stored bytes themselves so insta sees no change.
    let bytes = if within {
        std::fs::read(&stored_path).expect("stored snapshot reads")
    } else {
        if let Some(old) = stored.filter(|o| (o.width, o.height) == (new.width, new.height)) {
            let diff_path = folder.join(format!("{name}.diff.png"));
            let _ = std::fs::write(
                &diff_path,
                images::encode_png(&images::difference(&old, new)),
            );
        }
        images::encode_png(new)
    };
    let mut settings = insta::Settings::clone_current();
    settings.set_snapshot_path(Path::new("..").join(folder));
    settings.set_prepend_module_to_snapshot(false);
    settings
        .bind(|| {
            std::panic::catch_unwind(|| {
                insta::assert_binary_snapshot!(&format!("{name}.png"), bytes);
            })
        })
        .map_err(|_| {
            format!(
                "{name}: {} ({}/{name}.snap.png; see {name}.diff.png)",
                verdict.err().unwrap_or_default(),
                folder.display()
            )
        })
}

#[test]
fn every_variant_matches_its_reviewed_image() {
    let gpu = gpu();
    let composer = Composer::default();
    let folder = Path::new("snapshots").join(images::folder(&gpu.adapter.name));
    let reviewed_here = folder.is_dir();
    let mut failures = Vec::new();
    let mut skipped = Vec::new();
    let files = clusterlab::variant::find_files(Path::new("variants")).expect("variants/");
    assert!(!files.is_empty());
    for file in files {
        let v = clusterlab::variant::load(&file).unwrap_or_else(|e| panic!("{e}"));
        // Without a reviewed set of this adapter's, an exact variant must be within 1 LSB
        // of the f64 reference (`run::exact_claim`, judged in the cell's `failure`), and a
        // variant that claims no exactness has nothing to hold its image to.
        if !reviewed_here {
            if !clusterlab::run::exact_claim(&v.variant, &gpu) {
                skipped.push(v.name.clone());
                continue;
            }
            let params = {
                let mut p = clusterlab::scene::defaults(images::SCENE).unwrap();
                (p.width, p.height, p.lights) = (images::SIZE.0, images::SIZE.1, images::LIGHTS);
                p
            };
            let cell = clusterlab::run::run_cell(
                &gpu,
                &composer,
                &v,
                images::SCENE,
                params,
                clusterlab::run::CellOptions {
                    frames: clusterlab::measure::Frames::exact(0, 1),
                    stats: false,
                    ..Default::default()
                },
            );
            match cell {
                Ok(cell) => {
                    if let Some(why) = &cell.report.failure {
                        failures.push(format!("{}: {why}", v.name));
                    }
                }
                Err(e) => failures.push(format!("{}: {e}", v.name)),
            }
            continue;
        }
        let image = match images::render(&gpu, &composer, &v) {
            Ok(image) => image,
            Err(e) => {
                failures.push(e);
                continue;
            }
        };
        let allowed = expect::allowance(&gpu, Check::ImageSnapshot { variant: &v.name });
        let name = images::name(&v.name);
        if let Err(e) = check_image(&folder, &name, &image, allowed.map(|d| d.allowance)) {
            failures.push(e);
        }
    }
    if !skipped.is_empty() {
        eprintln!(
            "skipped on {} (no reviewed image set, no exactness claimed): {}",
            gpu.adapter.name,
            skipped.join(", ")
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The breaks the judgement exists for, on a reviewed image: one pixel 3 LSB off, every
/// pixel 2 LSB off, and 1 LSB on 3% of the pixels each fail it; the image itself passes.
#[test]
fn the_image_judgement_rejects_a_shifted_image() {
    let path = PathBuf::from("snapshots")
        .join(images::FOLDER)
        .join("forward_plus@atrium.snap.png");
    let old = images::decode_png(&std::fs::read(&path).expect("a reviewed image"))
        .expect("a PNG")
        .rgb;
    let shifted = |lsb: u8, every: usize, limit: usize| -> Vec<u8> {
        let mut new = old.clone();
        for (i, p) in new.chunks_mut(3).enumerate() {
            if i % every == 0 && i / every < limit {
                p[0] = if p[0] >= 128 { p[0] - lsb } else { p[0] + lsb };
            }
        }
        new
    };
    assert_eq!(judge(&old, &old, None), Ok(()));
    let one_pixel_3_lsb = shifted(3, 1, 1);
    let all_2_lsb = shifted(2, 1, usize::MAX);
    let three_percent_1_lsb = shifted(1, 33, usize::MAX);
    let share_1_lsb = shifted(1, 50, usize::MAX);
    for (what, new) in [
        ("one pixel 3 LSB off", &one_pixel_3_lsb),
        ("every pixel 2 LSB off", &all_2_lsb),
        ("3% of pixels 1 LSB off", &three_percent_1_lsb),
    ] {
        assert!(judge(&old, new, None).is_err(), "{what} passes");
    }
    // Within the derived share: 2% of pixels 1 LSB off.
    assert_eq!(judge(&old, &share_1_lsb, None), Ok(()));
}
