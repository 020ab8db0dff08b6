//! What makes a run cheap without changing its figures: pipelines compiled once per device
//! and shared by every cell whose passes compose alike, the debug view drawn from the timed
//! frame instead of a frame of its own, and instrumented frames that only count, on the
//! timed frame's depth and lists.

use crate::common::{gpu, load, small};
use clusterlab::compose::Composer;
use clusterlab::measure::Frames;
use clusterlab::render::Renderer;
use clusterlab::run::{CellOptions, run_cell};
use clusterlab::scene;
use clusterlab::variant::{DebugView, DepthRangeSource, ZSlicing};

#[test]
fn a_second_renderer_of_the_same_passes_compiles_nothing_and_renders_the_same() {
    let gpu = gpu();
    let composer = Composer::default();
    let v = load("clustered_deferred_16x16x24");
    let scene = scene::generate("atrium", small("atrium", 64, 36, Some(64))).unwrap();
    let before = gpu.pipeline_stats();
    let mut first = Renderer::new(&gpu, &composer, &v.variant, &scene).unwrap();
    let made = gpu.pipeline_stats();
    assert!(made.created > before.created, "{made:?}");
    assert!(first.cold(), "fresh pipelines: the first frame compiles");
    let a = first.render().unwrap();
    assert!(!first.cold());

    // Another light count composes to the same WGSL: every pipeline is found, none made.
    let other = scene::generate("atrium", small("atrium", 64, 36, Some(32))).unwrap();
    let mut second = Renderer::new(&gpu, &composer, &v.variant, &other).unwrap();
    let after = gpu.pipeline_stats();
    assert_eq!(after.created, made.created, "{after:?}");
    assert!(after.reused > made.reused);
    assert!(!second.cold(), "pipelines drawn with before are warm");
    second.render().unwrap();

    // And the shared pipelines render the first scene exactly as before.
    let mut third = Renderer::new(&gpu, &composer, &v.variant, &scene).unwrap();
    let b = third.render().unwrap();
    assert_eq!(a.ldr, b.ldr);
    assert_eq!(a.hdr, b.hdr);
    assert_eq!(first.stats().unwrap(), third.stats().unwrap());
}

#[test]
fn the_debug_view_of_the_timed_frame_is_the_debug_variants_own_frame() {
    let gpu = gpu();
    let composer = Composer::default();
    let scene = scene::generate("atrium", small("atrium", 96, 54, Some(128))).unwrap();
    for name in [
        "forward_plus",
        "forward_plus_no_prepass",
        "clustered_deferred_16x16x24",
        "clustered_deferred_olsson",
        "clustered_deferred_toon_bloom",
    ] {
        let v = load(name);
        let cell = run_cell(
            &gpu,
            &composer,
            &v,
            "atrium",
            scene.params,
            CellOptions {
                frames: Frames::exact(0, 2),
                debug_view: Some(DebugView::LightsPerCluster),
                ..Default::default()
            },
        )
        .unwrap();
        let from_timed = cell.debug.expect("asked for");
        // The variant with the view on, its own frames (two: previous-frame ranges settle).
        let mut debug = v.variant.clone();
        debug.debug_view = DebugView::LightsPerCluster;
        debug.post = Default::default();
        let mut r = Renderer::new(&gpu, &composer, &debug, &scene).unwrap();
        r.render().unwrap();
        let own = r.render().unwrap();
        let differing = own
            .ldr
            .iter()
            .zip(&from_timed)
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(differing, 0, "{name}: {differing} pixels differ");
        // The view shows something: lit clusters are not black.
        assert!(from_timed.iter().any(|p| p[..3] != [0, 0, 0]), "{name}");
    }
}

/// A cell timed alone by budget (no group to decide against): its budget or frame cap
/// ends it.
#[test]
fn frames_by_budget_time_a_long_frame_once_and_short_ones_to_the_cap() {
    use clusterlab::measure::Budget;
    let gpu = gpu();
    let composer = Composer::default();
    let v = load("forward_plus");
    let params = small("atrium", 64, 36, Some(32));
    let run = |budget: Budget| {
        run_cell(
            &gpu,
            &composer,
            &v,
            "atrium",
            params,
            CellOptions {
                frames: Frames::Budget(budget),
                stats: false,
                ..Default::default()
            },
        )
        .unwrap()
        .report
    };
    // A budget the frame without lights spends alone: still one timed frame, and no warm-up.
    let once = run(Budget {
        budget_ms: 1e-6,
        max_frames: 20,
    });
    assert_eq!(once.frames, 1);
    assert_eq!(once.frame_count.warmup, 0);
    assert!(once.frame_count.frame_without_lights);
    assert_eq!(
        once.frame_count.stop,
        Some(clusterlab::measure::Stop::Budget)
    );
    // A budget no frame spends: the frame cap.
    let capped = run(Budget {
        budget_ms: 1e9,
        max_frames: 5,
    });
    assert_eq!(capped.frames, 5);
    assert_eq!(
        capped.frame_count.stop,
        Some(clusterlab::measure::Stop::MaxFrames)
    );
    let [lo, hi] = [0, 1].map(|i| capped.gpu_ms_spread["total"][i].as_f64().unwrap());
    let median = capped.gpu_ms["total"].as_f64().unwrap();
    assert!(lo <= median && median <= hi, "{lo} {median} {hi}");
}

#[test]
fn naive_counters_from_the_clustered_stand_in_equal_naive_forwards_own() {
    let gpu = gpu();
    let composer = Composer::default();
    let mut prepass = load("naive_forward").variant;
    prepass.depth_prepass = true;
    let cases = [
        ("naive_forward", load("naive_forward").variant, "atrium"),
        ("naive_forward", load("naive_forward").variant, "stage"),
        (
            "naive_forward_ggx",
            load("naive_forward_ggx").variant,
            "spheres",
        ),
        ("naive_forward + pre-pass", prepass, "atrium"),
    ];
    for (name, v, scene_name) in cases {
        let scene = scene::generate(scene_name, small(scene_name, 96, 54, None)).unwrap();
        let mut r = Renderer::new(&gpu, &composer, &v, &scene).unwrap();
        r.render().unwrap();
        let own = r.stats().unwrap();
        r.prepare_counting(&composer, &scene);
        let twin = r.stats().unwrap();
        assert!(
            own.useful_light_evals > 0,
            "{name}@{scene_name}: nothing lit"
        );
        assert_eq!(twin, own, "{name}@{scene_name}");
    }
}

#[test]
fn a_frame_without_lights_leaves_no_trace_and_warms_the_pipelines() {
    let gpu = gpu();
    let composer = Composer::default();
    let scene = scene::generate("stage", small("stage", 64, 36, Some(48))).unwrap();
    // One variant of each way of building lists (on the GPU in one and two levels, by
    // z-binning, by drawing, on the CPU, none), a dynamic z-range and post effects.
    for name in [
        "naive_forward",
        "deferred_scissor",
        "forward_plus",
        "forward_plus_zbinning",
        "forward_plus_rasterised",
        "forward_plus_cpu_assignment",
        "clustered_deferred_compact",
        "clustered_deferred_two_level",
        "clustered_deferred_toon_bloom",
    ] {
        let v = load(name).variant;
        let plain = {
            let mut r = Renderer::new(&gpu, &composer, &v, &scene).unwrap();
            r.render().unwrap();
            (r.render().unwrap(), r.stats().unwrap())
        };
        let mut r = Renderer::new(&gpu, &composer, &v, &scene).unwrap();
        let ms = r.draw_without_lights().unwrap().total_ms();
        assert!(ms > 0.0, "{name}: {ms} ms");
        assert!(!r.cold(), "{name}: warm after it");
        r.render().unwrap();
        let after = (r.render().unwrap(), r.stats().unwrap());
        let differing =
            |a: &[[f32; 4]], b: &[[f32; 4]]| a.iter().zip(b).filter(|(x, y)| x != y).count();
        let hdr = differing(&after.0.hdr, &plain.0.hdr);
        assert_eq!(hdr, 0, "{name}: {hdr} HDR pixels differ");
        assert_eq!(after.0.ldr, plain.0.ldr, "{name}");
        assert_eq!(after.1, plain.1, "{name}");
    }
}

#[test]
fn an_instrumented_frame_after_a_whole_frame_counts_what_a_whole_one_counts() {
    let gpu = gpu();
    let composer = Composer::default();
    let scene = scene::generate("stage", small("stage", 64, 36, Some(48))).unwrap();
    // After a timed frame, the instrumented frame runs only the counting shading pass on
    // that frame's depth, G-buffer and lists; a renderer that drew nothing before runs
    // every pass. One variant of each way of making the depth and building lists.
    let mut late_range = load("forward_plus").variant;
    late_range.clusters.as_mut().unwrap().slicing = ZSlicing::DynamicRange {
        source: DepthRangeSource::PreviousFrame,
    };
    let variants = [
        "deferred_scissor",
        "forward_plus",
        "forward_plus_no_prepass",
        "forward_plus_tiled_2_5d",
        "forward_plus_zbinning",
        "forward_plus_rasterised",
        "forward_plus_cpu_assignment",
        "forward_plus_capped",
        "clustered_deferred_compact",
        "clustered_deferred_olsson_2_5d",
        "clustered_deferred_two_level",
        "clustered_deferred_toon_bloom",
    ]
    .map(|name| (name, load(name).variant));
    // A z-range from the previous frame: a renderer's first frame builds its lists on the
    // starting range and later ones on this picture's, so that variant's whole
    // instrumented frame is the one after a timed frame (which, for the lists to agree,
    // runs every pass too), and the frame after the second counts on it.
    let cases = variants.map(|(name, v)| (name, v, 0));
    for (name, v, first) in cases.into_iter().chain([("late range", late_range, 1)]) {
        let whole = {
            let mut r = Renderer::new(&gpu, &composer, &v, &scene).unwrap();
            for _ in 0..first {
                r.render().unwrap();
            }
            r.stats().unwrap()
        };
        for frames in 1..=2 {
            let mut r = Renderer::new(&gpu, &composer, &v, &scene).unwrap();
            for _ in 0..frames {
                r.render().unwrap();
            }
            assert_eq!(r.stats().unwrap(), whole, "{name}, after {frames} frames");
        }
        assert!(whole.light_evals > 0, "{name}: {whole:?}");
        // A frame without lights leaves no lists to count on: the instrumented frame after
        // it builds its own.
        let mut r = Renderer::new(&gpu, &composer, &v, &scene).unwrap();
        r.draw_without_lights().unwrap();
        assert_eq!(
            r.stats().unwrap(),
            whole,
            "{name}, after a frame without lights"
        );
    }
}
