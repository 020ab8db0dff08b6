//! Adapters without the optional features, and devices held to WebGPU's limits: the
//! instrumented passes that test depth themselves (no SHADER_EARLY_DEPTH_TEST, as on Metal
//! and DX12) count, pixel by pixel, what the forced early test lets through; every masked
//! feature changes what it should; every shipped variant runs within WebGPU's and the
//! downlevel limits or is refused naming the limit and its need, and wgpu enforces the
//! limit at the value the refusal names.

use std::path::Path;

use crate::common::{cli, load, small};
use clusterlab::compose::Composer;
use clusterlab::gpu::Gpu;
use clusterlab::gpu::adapters::{DeviceRequest, LimitSet};
use clusterlab::render::{PixelCounters, RenderError, Renderer, variant_needs};
use clusterlab::scene::{self, Scene};
use clusterlab::stress::{TIES_CASE, coplanar_ties};
use clusterlab::variant::{DepthFormat, Msaa, MsaaResolve, Variant};

fn device(limits: LimitSet, without: wgpu::Features) -> Gpu {
    Gpu::with_request(None, DeviceRequest { limits, without }).unwrap_or_else(|e| panic!("{e}"))
}

/// The per-pixel counters of one frame of `v` on `scene`.
fn counters(gpu: &Gpu, v: &Variant, scene: &Scene) -> PixelCounters {
    let composer = Composer::default();
    let mut r = Renderer::new(gpu, &composer, v, scene).unwrap_or_else(|e| panic!("{e}"));
    r.render().unwrap_or_else(|e| panic!("{e}"));
    r.prepare_counting(&composer, scene);
    r.stats().unwrap_or_else(|e| panic!("{e}"));
    r.pixel_counters().unwrap_or_else(|e| panic!("{e}"))
}

/// Forward passes after a pre-pass (opaque, masked, multisampled where the adapter can) and
/// the transparent pass of every pipeline: the same evaluations and useful ones at every
/// pixel with the feature and without it. Forward without a pre-pass is the deliberate
/// break: a pass with nothing to test against counts the fragments later drawn over too.
#[test]
fn passes_that_test_depth_themselves_count_what_the_early_test_lets_through() {
    // Not `gpu()`: CI runs this file with CLUSTERLAB_WITHOUT set, which that device obeys.
    let with = device(LimitSet::Adapter, wgpu::Features::empty());
    if !with.early_depth {
        eprintln!(
            "skipped: {} has no forced early depth tests to compare with",
            with.adapter.name
        );
        return;
    }
    let without = device(LimitSet::Adapter, wgpu::Features::SHADER_EARLY_DEPTH_TEST);
    assert!(!without.early_depth);
    assert_eq!(without.adapter.without, ["early-depth"]);
    let atrium = scene::generate("atrium", small("atrium", 96, 54, Some(64))).unwrap();
    // Masked fence and bushes, blended panes, spots.
    let glass = scene::generate("glass", small("glass", 96, 54, Some(64))).unwrap();
    let ties = coplanar_ties();
    let mut cases: Vec<(String, Variant, &Scene)> = Vec::new();
    for name in [
        "forward_plus",
        "forward_plus_ggx",
        "clustered_deferred_16x16x24",
    ] {
        let v = load(name).variant;
        cases.push((format!("{name} on atrium"), v.clone(), &atrium));
        cases.push((format!("{name} on glass"), v, &glass));
    }
    cases.push((
        "deferred_scissor on glass".into(),
        load("deferred_scissor").variant,
        &glass,
    ));
    // 24-bit depth, standard and reversed: its Equal test is within half a step.
    for reversed_z in [false, true] {
        let mut v = load("forward_plus").variant;
        v.depth.format = DepthFormat::Unorm24;
        v.depth.reversed_z = reversed_z;
        cases.push((
            format!("forward_plus, 24-bit depth, reversed {reversed_z}, on glass"),
            v,
            &glass,
        ));
    }
    if with.multisample_counts().contains(&4) {
        let mut v = load("forward_plus").variant;
        v.msaa = Msaa {
            samples: 4,
            resolve: MsaaResolve::Box,
        };
        cases.push((
            "forward_plus at 4 samples on atrium".into(),
            v.clone(),
            &atrium,
        ));
        // Samples where two coplanar floors tie: the forced Equal test lets both through
        // there, and only the one the pre-pass kept may shade. Without that rule (the
        // forced pass shading whatever passes, the self-testing one comparing the centre
        // depth alone) 105 pixels of this scene count differently on lavapipe.
        cases.push((
            format!("forward_plus at 4 samples on {TIES_CASE}"),
            v,
            &ties,
        ));
    }
    for (what, v, scene) in &cases {
        let (a, b) = (counters(&with, v, scene), counters(&without, v, scene));
        assert!(a.evals.iter().any(|&n| n > 0), "{what}: nothing counted");
        let diff: Vec<(usize, u32, u32)> = a
            .evals
            .iter()
            .zip(&b.evals)
            .enumerate()
            .filter(|(_, (x, y))| x != y)
            .map(|(i, (x, y))| (i, *x, *y))
            .collect();
        assert!(
            a.evals == b.evals,
            "{what}: evaluations differ without early depth: {} pixels {:?}",
            diff.len(),
            &diff[..diff.len().min(8)]
        );
        assert!(
            a.useful == b.useful,
            "{what}: useful evaluations differ without early depth"
        );
        assert!(
            a.shadings == b.shadings,
            "{what}: shadings differ without early depth"
        );
    }
    let v = load("forward_plus_no_prepass").variant;
    let (a, b) = (
        counters(&with, &v, &atrium),
        counters(&without, &v, &atrium),
    );
    let sum = |c: &[u32]| c.iter().map(|&n| n as u64).sum::<u64>();
    assert!(
        sum(&b.evals) > sum(&a.evals),
        "without a pre-pass or an early test the hidden fragments should count too"
    );
}

/// Each masked feature is gone from the device and does what `OPTIONAL_FEATURES` says the
/// device does without it; `adapters` shows the mask, and a name it does not know is
/// refused naming the valid ones.
#[test]
fn each_masked_feature_is_gone_and_its_fallback_is_used() {
    use clusterlab::gpu::adapters::OPTIONAL_FEATURES;
    let plain = device(LimitSet::Adapter, wgpu::Features::empty());
    for (name, feature, _) in OPTIONAL_FEATURES {
        let masked = device(LimitSet::Adapter, feature);
        assert!(!masked.device.features().contains(feature), "{name}");
        match name {
            "early-depth" => assert!(!masked.early_depth),
            "timestamps" => assert!(!masked.timestamps),
            "float32-blend" => {
                assert_eq!(masked.hdr_format, wgpu::TextureFormat::Rgba16Float)
            }
            // Only WebGPU's guaranteed sample counts (1 and 4) remain, at most.
            "format-features" => {
                for n in masked.multisample_counts() {
                    assert!([1, 4].contains(&n), "{name}: {n} samples");
                }
            }
            other => panic!("no check for `{other}`"),
        }
    }
    // The plain device has what the adapter has (lavapipe and llvmpipe have them all).
    assert_eq!(plain.adapter.without, Vec::<String>::new());
    let (ok, text) = cli(["adapters"])
        .env("CLUSTERLAB_WITHOUT", "early-depth")
        .run()
        .succeeded();
    assert!(ok, "{text}");
    assert!(
        !plain.early_depth
            || text.contains(
                "[-] early depth test (SHADER_EARLY_DEPTH_TEST) (masked by CLUSTERLAB_WITHOUT)"
            ),
        "{text}"
    );
    let (ok, text) = cli([
        "render",
        "--variant",
        "forward_plus",
        "--scene",
        "one_light",
    ])
    .env("CLUSTERLAB_WITHOUT", "early-depth,shadows")
    .run()
    .succeeded();
    assert!(!ok);
    assert!(
        text.contains("`shadows` (from CLUSTERLAB_WITHOUT) is not an optional feature; use a comma list of early-depth, timestamps, float32-blend, format-features"),
        "{text}"
    );
}

/// Every shipped variant, under WebGPU's default limits and wgpu's downlevel ones: it runs
/// a frame, or it is refused before anything is made, naming each limit it exceeds, and
/// exactly where `variant_needs` (what `validate --json` reports) exceeds that limit.
#[test]
fn every_shipped_variant_runs_or_is_refused_within_webgpu_and_downlevel_limits() {
    let composer = Composer::default();
    let scene = scene::generate("atrium", small("atrium", 64, 36, Some(32))).unwrap();
    for limits in [LimitSet::Webgpu, LimitSet::Downlevel] {
        let gpu = device(limits, wgpu::Features::empty());
        let (mut ran, mut refused) = (0, 0);
        for file in clusterlab::variant::find_files(Path::new("variants")).unwrap() {
            let v = clusterlab::variant::load(&file).unwrap().variant;
            let what = format!("{} under {} limits", file.display(), limits.name());
            let needs = variant_needs(&composer, &v).unwrap();
            let over: Vec<&str> = needs
                .against(&gpu.limits)
                .into_iter()
                .filter(|(_, need, allowed)| need.value > *allowed)
                .map(|(limit, _, _)| limit)
                .collect();
            match Renderer::new(&gpu, &composer, &v, &scene).and_then(|mut r| r.render()) {
                Ok(_) => {
                    assert!(over.is_empty(), "{what}: ran, yet needs more of {over:?}");
                    ran += 1;
                }
                Err(RenderError::Limits(message)) => {
                    assert!(
                        !over.is_empty(),
                        "{what}: refused within its needs: {message}"
                    );
                    for limit in &over {
                        assert!(
                            message.contains(limit),
                            "{what}: {message} names no {limit}"
                        );
                    }
                    assert!(message.contains(limits.name()), "{what}: {message}");
                    refused += 1;
                }
                Err(e) => panic!("{what}: {e}"),
            }
        }
        // Naive forward fits both (3 storage buffers a stage).
        assert!(ran >= 3, "{}: {ran} ran, {refused} refused", limits.name());
    }
}

/// wgpu enforces the storage buffer limit at the count the refusal compares: a layout with
/// as many storage buffers in one stage as WebGPU allows is made, one more is an error.
#[test]
fn wgpu_refuses_one_storage_buffer_past_the_limit_the_refusal_names() {
    let gpu = device(LimitSet::Webgpu, wgpu::Features::empty());
    let allowed = gpu.limits.max_storage_buffers_per_shader_stage;
    assert_eq!(allowed, 8, "WebGPU's default");
    let layout = |n: u32| {
        let entries: Vec<_> = (0..n)
            .map(|binding| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: true },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            })
            .collect();
        gpu.scoped("a layout", || {
            gpu.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: None,
                    entries: &entries,
                })
        })
    };
    assert!(layout(allowed).is_ok());
    assert!(layout(allowed + 1).is_err());
}
