//! Multisampling: every exact variant at 4 samples within its bound of naive forward at 4
//! samples and of the reference, which shades every sample in f64 and resolves it the
//! variant's way; culling reads every sample (marking from sample 0 only fails); the
//! deferred resolve shades a pixel once per distinct surface; adapters that cannot
//! multisample refuse with the reason.

use super::*;

/// `v` with `samples` samples a pixel, resolved `resolve`'s way.
fn multisampled(v: &LoadedVariant, samples: u32, resolve: MsaaResolve) -> LoadedVariant {
    let mut m = v.variant.clone();
    m.msaa = Msaa { samples, resolve };
    loaded(&format!("{} at {samples}x, {resolve:?}", v.name), m)
}

/// Every exact variant with the box resolve; Forward+ and clustered deferred with the
/// tonemapped one too.
fn multisampled_variants(spots: bool) -> Vec<LoadedVariant> {
    let mut plain = exact_variants();
    if spots {
        plain.extend(spot_variants());
    }
    let mut out = Vec::new();
    for v in plain
        .iter()
        .filter(|v| v.variant.pipeline != Pipeline::DeferredScissor)
    {
        out.push(multisampled(v, 4, MsaaResolve::Box));
    }
    for pipeline in [Pipeline::ClusteredForward, Pipeline::ClusteredDeferred] {
        let v = loaded("plain", clustered(pipeline, ZSlicing::Exponential));
        out.push(multisampled(&v, 4, MsaaResolve::Tonemapped));
    }
    out
}

/// Where the adapter multisamples: each variant within its bound on every scene, at a
/// size no grid divides. Where it cannot (wgpu's OpenGL backend), every frame is refused
/// naming why.
#[test]
fn every_exact_variant_at_four_samples_is_within_its_bound() {
    let gpu = gpu();
    for scene_name in ["atrium", "stage"] {
        let scene = scene::generate(scene_name, small(scene_name, 100, 57, None)).unwrap();
        let spots = scene.lights.iter().any(|l| l.is_spot());
        let mut baselines = Baselines::new(&gpu, &scene);
        for v in multisampled_variants(spots) {
            assert!(check(&v.variant).is_empty(), "{}", v.name);
            let what = format!("{} on {scene_name}", v.name);
            if !gpu.multisample_counts().contains(&4) {
                let refused = Renderer::new(&gpu, &Composer::default(), &v.variant, &scene)
                    .err()
                    .unwrap_or_else(|| panic!("{what}: multisampled without 4 samples"))
                    .to_string();
                // OpenGL through wgpu; formats held to WebGPU's guarantees
                // (`CLUSTERLAB_WITHOUT=format-features`: no multisampled rgba32uint).
                let why = if gpu.backend == wgpu::Backend::Gl {
                    "gfx-rs/wgpu#6084"
                } else {
                    "samples a pixel only"
                };
                assert!(refused.contains(why), "{what}: {refused}");
                continue;
            }
            // Two frames, so previous-frame z-ranges are in use.
            let frame = render(&gpu, &v.variant, &scene, 2);
            let (naive, reference) = baselines.of(&v);
            let e = clusterlab::metrics::compare(&frame, &reference);
            assert_eq!(e.nan_pixels, 0, "{what}");
            assert_within_bound(
                &gpu, &v.variant, &naive.1, &frame, &naive.0, &reference, &what,
            );
        }
    }
}

/// The deliberate break: active clusters and sample bounds marked from sample 0 of each
/// pixel only leave out lights that reach only the other samples of edge pixels, and the
/// picture is no longer within 1 LSB of the reference.
#[test]
fn marking_from_sample_zero_only_fails_the_exactness_check() {
    let gpu = gpu();
    if !gpu.multisample_counts().contains(&4) {
        return; // refused above
    }
    let scene = scene::generate("atrium", small("atrium", 100, 57, None)).unwrap();
    let mut v = clustered(Pipeline::ClusteredForward, ZSlicing::Exponential);
    let c = v.clusters.as_mut().unwrap();
    c.active_clusters = true;
    c.sample_bounds = true;
    let v = multisampled(&loaded("sample bounds", v), 4, MsaaResolve::Box);
    let worst = |composer: &Composer| {
        let r = clusterlab::run::run_scene(
            &gpu,
            composer,
            &v,
            &scene,
            clusterlab::run::CellOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        r.report.error.expect("an error").max_abs_8bit
    };
    assert!(worst(&Composer::default()) <= 1);
    let sample_zero = EditedShaders::of(
        "passes/mark_active.wesl",
        "msaa-sample-zero",
        &[(
            "    let tile = tile_of_pixel(vec2<f32>(id.xy) + 0.5, view.viewport_size);\n    for (var s = 0u; s < MSAA_SAMPLES; s++) {",
            "    let tile = tile_of_pixel(vec2<f32>(id.xy) + 0.5, view.viewport_size);\n    for (var s = 0u; s < 1u; s++) {",
        )],
    );
    let broken = worst(&sample_zero.composer);
    assert!(
        broken > 1,
        "marking sample 0 only went unseen: {broken} LSB"
    );
}

/// The classified deferred resolve shades a pixel once per distinct surface among its
/// samples (the raster truth's), never per sample: so at 4 samples a pixel costs at most 4
/// shadings, and only its edge pixels more than one. Edges exist and do not cover the frame.
#[test]
fn the_deferred_resolve_shades_each_distinct_surface_once() {
    let gpu = gpu();
    if !gpu.multisample_counts().contains(&4) {
        return; // refused above
    }
    let scene = scene::generate("atrium", small("atrium", 100, 57, None)).unwrap();
    let v = loaded(
        "deferred",
        clustered(Pipeline::ClusteredDeferred, ZSlicing::Exponential),
    );
    let v = multisampled(&v, 4, MsaaResolve::Box);
    let composer = Composer::default();
    let mut r = Renderer::new(&gpu, &composer, &v.variant, &scene).unwrap();
    r.render().unwrap();
    let stats = r.stats().unwrap();
    let pixels = r.pixel_counters().unwrap();
    let truth = raster_truth(&gpu, &composer, &v.variant, &scene).unwrap();
    let n = 4;
    for (p, &shadings) in pixels.shadings.iter().enumerate() {
        // The distinct covered surfaces among the pixel's samples, by their truth.
        let mut surfaces: Vec<[u32; 12]> = (0..n)
            .map(|s| p * n + s)
            .filter(|&i| truth.covered(i))
            .map(|i| bytemuck::cast([truth.position[i], truth.normal[i], truth.albedo[i]]))
            .collect();
        surfaces.sort();
        surfaces.dedup();
        assert_eq!(shadings as usize, surfaces.len(), "pixel {p}");
    }
    let e = stats.edge_fraction;
    assert!(e > 0.0 && e < 1.0, "edge fraction {e}");
}

/// Counts the adapter lacks are refused naming those it has; a count outside 1, 2, 4, 8 is
/// refused by the variant check.
#[test]
fn sample_counts_the_adapter_lacks_are_refused_naming_what_it_has() {
    let gpu = gpu();
    let scene = scene::generate("atrium", small("atrium", 16, 9, None)).unwrap();
    let plain = loaded(
        "plain",
        clustered(Pipeline::ClusteredForward, ZSlicing::Exponential),
    );
    // A count this adapter lacks (lavapipe: 2 and 8; OpenGL: all but 1); a GPU that renders
    // every count has none to refuse, and this part is skipped, saying so.
    let counts = gpu.multisample_counts();
    match [2u32, 4, 8].into_iter().find(|n| !counts.contains(n)) {
        Some(n) => {
            let v = multisampled(&plain, n, MsaaResolve::Box);
            let refused = Renderer::new(&gpu, &Composer::default(), &v.variant, &scene)
                .err()
                .unwrap_or_else(|| panic!("{n} samples, which the adapter lacks, refused"))
                .to_string();
            let named = format!("msaa.samples {n}");
            assert!(
                refused.contains(&named)
                    && (refused.contains("samples a pixel only")
                        || refused.contains("gfx-rs/wgpu#6084")),
                "{refused}"
            );
        }
        None => eprintln!("skipped: this adapter renders 2, 4 and 8 samples: none to refuse"),
    }
    let mut three = plain.variant.clone();
    three.msaa.samples = 3;
    let problems = check(&three);
    assert!(
        problems
            .iter()
            .any(|p| p.field == "msaa.samples" && p.message.contains("[1, 2, 4, 8]")),
        "{problems:?}"
    );
}
