//! Post-processing: every effect's GPU output against its CPU f64 twin fed the GPU's own
//! input, naive and separable bloom against each other, the whole chain against the
//! reference, and no pass or code for an effect a variant does not have.

mod common;

use std::path::Path;

use clusterlab::compose::{self, Composer};
use clusterlab::cpu::post::{self, CameraPair, Geometry, Image, PostParams};
use clusterlab::gpu::Gpu;
use clusterlab::render::Renderer;
use clusterlab::scene::{self, Scene};
use clusterlab::twins;
use clusterlab::variant::*;
use common::{cell, gpu, load, small};
use glam::DVec3;

/// The post variants in variants/, each with one effect or the write-ups' combinations.
const POST_VARIANTS: [&str; 7] = [
    "clustered_deferred_toon_post",
    "clustered_deferred_toon_outlines",
    "clustered_deferred_bloom_naive",
    "clustered_deferred_bloom_separable",
    "clustered_deferred_motion_blur",
    "clustered_deferred_toon_bloom",
    "forward_plus_toon_per_light",
];

fn atrium() -> Scene {
    scene::generate("atrium", small("atrium", 160, 90, Some(128))).expect("atrium")
}

/// The GPU's input to the post chain (shaded HDR and depth) and its output.
struct ChainRun {
    input: Image,
    depth: Vec<f32>,
    output: Image,
}

fn run_chain(gpu: &Gpu, v: &Variant, scene: &Scene) -> ChainRun {
    let mut v = v.clone();
    // 32-bit float depth: the twins take the stored values as they are, unrounded.
    v.depth.format = DepthFormat::Float32;
    let composer = Composer::default();
    let mut r = Renderer::new(gpu, &composer, &v, scene).expect("renderer");
    let frame = r.render().expect("frame");
    let (w, h) = (frame.width, frame.height);
    // Read by a compute pass: OpenGL cannot copy a depth texture to a buffer.
    let cam = &scene.camera;
    let depth = twins::gpu_depth_samples(
        gpu,
        &composer,
        &v,
        r.depth_texture(),
        cam.near as f32,
        cam.far as f32,
    )
    .expect("depth");
    ChainRun {
        input: Image::from_rgba(w, h, &r.read_shaded().expect("shaded")),
        depth: depth.device,
        output: Image::from_rgba(w, h, &frame.hdr),
    }
}

/// How far a GPU image is from the twin's: the largest error relative to max(1, |value|)
/// over the pixels that agree, and how many pixels do not (error above `agree`).
fn compare(gpu_out: &Image, twin: &Image, agree: f64) -> (f64, usize) {
    let mut worst: f64 = 0.0;
    let mut disagree = 0;
    for (g, t) in gpu_out.pixels.iter().zip(&twin.pixels) {
        let e = ((*g - *t).abs() / t.abs().max(DVec3::ONE)).max_element();
        if e > agree {
            disagree += 1;
        } else {
            worst = worst.max(e);
        }
    }
    (worst, disagree)
}

#[test]
fn every_effect_matches_its_cpu_twin_on_the_gpu_input() {
    let gpu = gpu();
    let scene = atrium();
    let pixels = (scene.params.width * scene.params.height) as usize;
    for name in POST_VARIANTS {
        let v = load(name).variant;
        let params = PostParams::of(&v);
        let run = run_chain(&gpu, &v, &scene);
        let cams = CameraPair::of(&scene, v.depth.mapping());
        let g =
            Geometry::from_device_depth(scene.params.width, scene.params.height, &run.depth, &cams);
        let twin = post::apply(&params, &run.input, &g);
        let (worst, disagree) = compare(&run.output, &twin, 1e-4);
        eprintln!("{name}: worst relative error {worst:.2e}, {disagree} of {pixels} pixels differ");
        // f32 arithmetic against f64: a few ulps, accumulated over the blur window.
        assert!(worst < 2e-5, "{name}: worst relative error {worst:e}");
        // Band edges, outline thresholds and rounded motion samples are decisions; f32 and
        // f64 may decide a pixel that sits on the edge differently, and only such pixels.
        let decisions = params.toon_bands.is_some()
            || params.outline_threshold.is_some()
            || params.motion_blur_samples.is_some();
        let allowed = if decisions { pixels / 1000 } else { 0 };
        assert!(
            disagree <= allowed,
            "{name}: {disagree} pixels differ from the twin (at most {allowed})"
        );
        if params.any() {
            let (_, changed) = compare(&run.output, &run.input, 1e-3);
            assert!(
                changed > pixels / 100,
                "{name}: the effect changed {changed} pixels"
            );
        }
    }
}

#[test]
fn naive_and_separable_bloom_agree_within_rounding() {
    let gpu = gpu();
    let scene = atrium();
    let naive = load("clustered_deferred_bloom_naive").variant;
    let mut separable = naive.clone();
    separable.post.bloom.as_mut().expect("bloom").kernel = BloomKernel::Separable;
    let a = run_chain(&gpu, &naive, &scene);
    let b = run_chain(&gpu, &separable, &scene);
    assert_eq!(a.input, b.input);
    let (worst, disagree) = compare(&a.output, &b.output, 1e-4);
    eprintln!("naive against separable: worst relative difference {worst:.2e}");
    assert_eq!(disagree, 0);
    assert!(worst < 2e-5, "{worst:e}");
}

#[test]
fn the_whole_chain_is_close_to_the_reference() {
    let gpu = gpu();
    for name in POST_VARIANTS {
        let v = load(name);
        let c = cell(&gpu, &v, "atrium", small("atrium", 160, 90, Some(128)));
        let e = c.report.error.as_ref().expect("a shaded image");
        let pixels = 160 * 90;
        eprintln!(
            "{name}: max 8-bit {}, {} pixels over 1 LSB, PSNR {:?}",
            e.max_abs_8bit, e.pixels_over_1lsb, e.psnr_db
        );
        assert_eq!(e.nan_pixels, 0, "{name}");
        // Off by more than 1 LSB only where a decision (band, outline, motion sample)
        // fell the other way on the reference's exact geometry.
        assert!(
            e.pixels_over_1lsb <= pixels / 200,
            "{name}: {} pixels over 1 LSB",
            e.pixels_over_1lsb
        );
    }
}

/// Words that only an effect's code contains.
fn effect_markers(effect: &str) -> &'static [&'static str] {
    match effect {
        "toon" => &["toon_ramp", "toon_post_ramp", "TOON_BANDS"],
        "outlines" => &["OUTLINE_THRESHOLD"],
        "bloom" => &["BLOOM_", "gaussian"],
        "motion_blur" => &["MOTION_BLUR_SAMPLES", "fn motion("],
        _ => unreachable!(),
    }
}

#[test]
fn a_variant_without_an_effect_has_no_pass_and_no_code_for_it() {
    let composer = Composer::default();
    let files = clusterlab::variant::find_files(Path::new("variants")).expect("variants/");
    for file in files {
        let v = clusterlab::variant::load(&file).expect("variant loads");
        let post = &v.variant.post;
        let toon = post.toon.as_ref();
        let has = |effect: &str| match effect {
            "toon" => toon.is_some(),
            "outlines" => toon.is_some_and(|t| t.outlines.is_some()),
            "bloom" => post.bloom.is_some(),
            "motion_blur" => post.motion_blur.is_some(),
            _ => unreachable!(),
        };
        let passes = compose::passes(&v.variant);
        let names: Vec<&str> = passes.iter().map(|p| p.name()).collect();
        let wgsl: Vec<String> = passes
            .iter()
            .map(|p| composer.compose(&v.variant, p).expect("composes").wgsl)
            .collect();
        for effect in ["toon", "outlines", "bloom", "motion_blur"] {
            if has(effect) {
                continue;
            }
            for marker in effect_markers(effect) {
                for (pass, text) in names.iter().zip(&wgsl) {
                    assert!(
                        !text.contains(marker),
                        "{}: pass {pass} has `{marker}` without {effect}",
                        v.name
                    );
                }
            }
            let pass_names: &[&str] = match effect {
                "bloom" => &["bloom_threshold", "bloom_blur", "bloom_composite"],
                "motion_blur" => &["motion_blur"],
                _ => &[],
            };
            for p in pass_names {
                assert!(!names.contains(p), "{}: has pass {p}", v.name);
            }
        }
        let toon_pass =
            toon.is_some_and(|t| t.mode == ToonMode::PostProcess || t.outlines.is_some());
        assert_eq!(names.contains(&"toon"), toon_pass, "{}", v.name);
    }
}

#[test]
fn gpu_times_name_exactly_the_passes_that_ran() {
    let gpu = gpu();
    let p = small("atrium", 64, 36, Some(16));
    let post_keys = [
        "toon",
        "bloom_threshold",
        "bloom_blur",
        "bloom_composite",
        "motion_blur",
    ];
    for (name, expected) in [
        ("clustered_deferred_16x16x24", &[][..]),
        ("forward_plus_toon_per_light", &[][..]),
        (
            "clustered_deferred_toon_bloom",
            &["toon", "bloom_threshold", "bloom_blur", "bloom_composite"][..],
        ),
        ("clustered_deferred_motion_blur", &["motion_blur"][..]),
    ] {
        let c = cell(&gpu, &load(name), "atrium", p);
        let present: Vec<&str> = post_keys
            .into_iter()
            .filter(|k| c.report.gpu_ms.contains_key(*k))
            .collect();
        assert_eq!(present, expected, "{name}");
    }
}
