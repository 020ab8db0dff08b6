//! Skipping what a frame does not need changes the cost, never the picture: each skip is
//! taken where it applies, listed in the frame, and the image equals the one rendered with
//! `skip_unneeded: false`.

use crate::common::{cli, gpu, load, scratch, small};
use clusterlab::compose::Composer;
use clusterlab::render::{FrameOutput, Renderer};
use clusterlab::scene::{self, Scene};
use clusterlab::variant::*;

/// The third frame (skips that wait for a settled frame have begun), with skipping on and
/// off.
fn both(gpu: &clusterlab::gpu::Gpu, v: &Variant, scene: &Scene) -> (FrameOutput, FrameOutput) {
    let run = |skip: bool| {
        let mut v = v.clone();
        v.skip_unneeded = skip;
        let mut r = Renderer::new(gpu, &Composer::default(), &v, scene).expect("renderer");
        r.render().unwrap();
        r.render().unwrap();
        r.render().unwrap()
    };
    (run(true), run(false))
}

/// Equal within f32 rounding: a motion blur of a still pixel averages N copies of it, which
/// may round in the last place.
fn assert_same_image(a: &FrameOutput, b: &FrameOutput, what: &str) {
    let close = |x: &[f32; 4], y: &[f32; 4]| {
        x.iter()
            .zip(y)
            .all(|(p, q)| (p - q).abs() <= 1e-6 * p.abs().max(q.abs()))
    };
    let differ: Vec<usize> = (0..a.hdr.len())
        .filter(|&i| !close(&a.hdr[i], &b.hdr[i]))
        .collect();
    assert!(
        differ.is_empty(),
        "{what}: skipping changed {} pixels, first {:?}: {:?} against {:?}",
        differ.len(),
        differ.first(),
        differ.first().map(|&i| a.hdr[i]),
        differ.first().map(|&i| b.hdr[i])
    );
}

fn skipped(f: &FrameOutput) -> Vec<&str> {
    f.skipped.iter().map(String::as_str).collect()
}

fn static_scene(name: &str) -> Scene {
    clusterlab::stress::cases()
        .into_iter()
        .find(|c| c.name == name)
        .expect("stress case")
        .scene
}

#[test]
fn no_lights_means_no_clustering() {
    let gpu = gpu();
    let scene = scene::generate("empty", small("empty", 64, 36, None)).unwrap();
    for name in [
        "forward_plus",
        "clustered_deferred_16x16x24",
        "forward_plus_cpu_assignment",
    ] {
        let v = load(name).variant;
        let (on, off) = both(&gpu, &v, &scene);
        assert_same_image(&on, &off, name);
        assert!(
            skipped(&on).contains(&"light_assign"),
            "{name}: {:?}",
            on.skipped
        );
        assert!(on.timings.get("light_assign") == 0.0 && on.cpu_assign_ms.is_none());
        assert!(off.skipped.is_empty(), "{name}: {:?}", off.skipped);
    }
}

#[test]
fn a_still_scene_keeps_its_lists_and_a_moving_one_rebuilds_them() {
    let gpu = gpu();
    let still = static_scene("one_light");
    let v = load("clustered_deferred_16x16x24").variant;
    let (on, off) = both(&gpu, &v, &still);
    assert_same_image(&on, &off, "still");
    assert!(skipped(&on).contains(&"light_assign"), "{:?}", on.skipped);
    // Without skipping the still frame assigns again.
    assert!(off.timings.passes.iter().any(|(n, _)| n == "light_assign"));

    let moving = scene::generate("atrium", small("atrium", 64, 36, Some(32))).unwrap();
    let (on, _) = both(&gpu, &v, &moving);
    assert!(!skipped(&on).contains(&"light_assign"), "{:?}", on.skipped);
}

#[test]
fn bloom_blur_runs_only_when_a_pixel_is_bright() {
    let gpu = gpu();
    let scene = scene::generate("atrium", small("atrium", 64, 36, Some(32))).unwrap();
    let mut v = load("clustered_deferred_bloom_separable").variant;
    let (on, off) = both(&gpu, &v, &scene);
    assert!(
        !skipped(&on).contains(&"bloom_blur"),
        "atrium has bright pixels"
    );
    assert_same_image(&on, &off, "bright");
    v.post.bloom.as_mut().unwrap().threshold = 1e9;
    let (on, off) = both(&gpu, &v, &scene);
    assert!(skipped(&on).contains(&"bloom_blur"), "{:?}", on.skipped);
    assert!(!skipped(&off).contains(&"bloom_blur"));
    assert_same_image(&on, &off, "nothing bright");
}

#[test]
fn motion_blur_needs_a_moving_camera() {
    let gpu = gpu();
    let v = load("clustered_deferred_motion_blur").variant;
    let still = static_scene("one_light");
    let (on, off) = both(&gpu, &v, &still);
    assert!(skipped(&on).contains(&"motion_blur"));
    assert!(on.timings.passes.iter().all(|(n, _)| n != "motion_blur"));
    assert!(off.timings.passes.iter().any(|(n, _)| n == "motion_blur"));
    assert_same_image(&on, &off, "still camera");
    let moving = scene::generate("atrium", small("atrium", 64, 36, Some(32))).unwrap();
    let (on, _) = both(&gpu, &v, &moving);
    assert!(!skipped(&on).contains(&"motion_blur"));
}

#[test]
fn a_scene_without_spots_shades_without_the_cone() {
    let gpu = gpu();
    let cone = clusterlab::render::SPOT_CONE;
    for name in ["naive_forward", "forward_plus", "clustered_deferred_ggx"] {
        let v = load(name).variant;
        let points = scene::generate("atrium", small("atrium", 64, 36, Some(64))).unwrap();
        let (on, off) = both(&gpu, &v, &points);
        assert!(skipped(&on).contains(&cone), "{name}: {:?}", on.skipped);
        assert!(!skipped(&off).contains(&cone), "{name}: {:?}", off.skipped);
        assert_same_image(&on, &off, name);
        let spots = scene::generate("stage", small("stage", 64, 36, Some(64))).unwrap();
        let (on, _) = both(&gpu, &v, &spots);
        assert!(
            !skipped(&on).contains(&cone),
            "{name} with spots: {:?}",
            on.skipped
        );
    }
}

/// `matrix --sweep skipping=on,off`: both settings of every variant side by side on the
/// same frames, the same images and counters, and only the "on" cells skip passes: on a
/// scene without lights the clustering, and the bloom blur where no pixel is bright.
#[test]
fn the_skipping_sweep_puts_both_settings_side_by_side() {
    use clusterlab::matrix::Results;
    let dir = scratch("sweep");
    let out = dir.join("results");
    let ran = cli([
        "matrix",
        "--variants",
        "forward_plus",
        "clustered_deferred_bloom_separable",
        "--scenes",
        "empty,one_light",
        "--size",
        "48x27",
        "--sweep",
        "skipping=on,off",
        "--frames",
        "2",
        "--warmup",
        "0",
        "--out",
    ])
    .arg(&out)
    .run();
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
    let r = Results::load(&out).expect("results.json");
    for variant in ["forward_plus", "clustered_deferred_bloom_separable"] {
        for scene in ["empty", "one_light"] {
            let cell = |setting: &str| {
                r.cells
                    .iter()
                    .find(|c| {
                        c.spec.variant == variant
                            && c.spec.scene == scene
                            && c.spec
                                .sweep
                                .iter()
                                .any(|(k, v)| k == "skipping" && v == setting)
                    })
                    .unwrap_or_else(|| panic!("{variant} on {scene} with skipping={setting}"))
            };
            let (on, off) = (cell("on"), cell("off"));
            let what = format!("{variant} on {scene}");
            assert!(
                off.skipped_passes.is_empty(),
                "{what}: {:?}",
                off.skipped_passes
            );
            let image = |c: &clusterlab::matrix::CellRecord| {
                std::fs::read(out.join(c.images.image.as_ref().expect("an image"))).expect("PNG")
            };
            assert_eq!(image(on), image(off), "{what}: the images differ");
            assert_eq!(on.stats, off.stats, "{what}: the counters differ");
            let skipped = |p: &str| on.skipped_passes.iter().any(|s| s == p);
            assert_eq!(
                skipped("light_assign"),
                scene == "empty",
                "{what}: {:?}",
                on.skipped_passes
            );
            if variant.contains("bloom") {
                // The empty scene's ambient light is below the bloom threshold.
                assert_eq!(
                    skipped("bloom_blur"),
                    scene == "empty",
                    "{what}: {:?}",
                    on.skipped_passes
                );
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
