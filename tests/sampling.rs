//! Sampled light loops: each sampler claimed unbiased has a mean over independent seeds
//! that the z-tests cannot tell from the f64 reference, and each deliberate break (a
//! candidate of target 0 not counted, a kept light not reweighted, a reused reservoir's
//! count left out) is told apart; seeds reproduce; the counters count what the loops do.

use crate::common::{EditedShaders, gpu, load, small};
use clusterlab::bias::{self, BiasTest};
use clusterlab::compose::Composer;
use clusterlab::gpu::Gpu;
use clusterlab::reference::reference_frame;
use clusterlab::render::Renderer;
use clusterlab::scene::{self, Light, Motion, Scene, SceneParams};
use clusterlab::variant::LoadedVariant;

/// Independent seeds per test: at 256 a mean's standard error is 1/16 of one draw's.
const SEEDS: u32 = 256;

/// The atrium small and still, 1024 lights: lists of about 25, a quarter of them in range, and stochastic culling's roulette deciding most of them.
fn params() -> SceneParams {
    let mut p = small("atrium", 48, 27, Some(1024));
    p.motion = Motion {
        lights: 0.0,
        camera: false,
        still_at: p.time,
    };
    p
}

/// `frames` still frames of the atrium (a sequence's, for temporal reuse).
fn frames(count: u32) -> Vec<Scene> {
    let at = clusterlab::sequence::scene_frames("atrium", params());
    (0..count).map(|i| at(i).unwrap()).collect()
}

fn bias_of(gpu: &Gpu, composer: &Composer, v: &LoadedVariant, frames: &[Scene]) -> BiasTest {
    let last = frames.last().unwrap();
    let (reference, _) = reference_frame(gpu, composer, v, last).unwrap();
    let runs = bias::seed_runs(gpu, composer, v, frames, SEEDS, &reference)
        .unwrap_or_else(|e| panic!("{}: {e}", v.name));
    bias::test(&runs, &reference, bias::hdr_rounding(gpu.hdr_format))
}

/// Each shipped sampler claimed unbiased, with the frames it is measured on (temporal
/// reuse: its fourth still frame, three frames of history).
pub(crate) fn unbiased_samplers() -> Vec<(LoadedVariant, u32)> {
    vec![
        (load("forward_plus_ris_8"), 1),
        (load("forward_plus_ris_32_kept_4"), 1),
        (load("clustered_deferred_ris_4"), 1),
        (load("forward_plus_stochastic_culling"), 1),
        (load("forward_plus_uniform_8"), 1),
        (load("clustered_deferred_restir_temporal"), 4),
        (load("clustered_deferred_restir_spatiotemporal"), 4),
    ]
}

/// Each shipped shadow estimator claimed unbiased (measured on one still frame).
pub(crate) fn unbiased_shadow_samplers() -> Vec<LoadedVariant> {
    vec![load("forward_plus_shadows_importance_1")]
}

/// Each shipped shadow estimator biased by design, with what its label must say.
pub(crate) fn labelled_biased_shadow_samplers() -> Vec<(LoadedVariant, &'static str)> {
    vec![(
        load("forward_plus_shadows_ratio_1"),
        "biased: a ratio of estimates",
    )]
}

/// Each shipped sampler that is biased by design, with what its label must say.
pub(crate) fn labelled_biased_samplers() -> Vec<(LoadedVariant, &'static str)> {
    vec![(
        load("clustered_deferred_restir_spatiotemporal_1m"),
        "biased: 1/M across surfaces",
    )]
}

/// A sampler biased by design says so wherever its figures are shown, and its unbiased
/// twin does not.
#[test]
fn biased_samplers_are_labelled_biased() {
    for (v, label) in labelled_biased_samplers() {
        let s = v.variant.shading.lights.sampling().unwrap();
        assert!(!s.unbiased(), "{}", v.name);
        assert_eq!(s.bias_label(), label, "{}", v.name);
    }
    for (v, label) in labelled_biased_shadow_samplers() {
        let s = v.variant.shading.shadows.sampling().unwrap();
        assert!(!s.unbiased(), "{}", v.name);
        assert_eq!(s.bias_label(), label, "{}", v.name);
    }
    for v in unbiased_shadow_samplers() {
        let s = v.variant.shading.shadows.sampling().unwrap();
        assert!(s.unbiased(), "{}", v.name);
    }
    let twin = load("clustered_deferred_restir_spatiotemporal");
    let s = twin.variant.shading.lights.sampling().unwrap();
    assert_eq!(s.bias_label(), "unbiased while still, biased in motion");
}

#[test]
fn unbiased_samplers_pass_the_z_tests() {
    let gpu = gpu();
    let composer = Composer::default();
    let mut failures = Vec::new();
    let shadows = unbiased_shadow_samplers().into_iter().map(|v| (v, 1));
    for (v, count) in unbiased_samplers().into_iter().chain(shadows) {
        let t = bias_of(&gpu, &composer, &v, &frames(count));
        eprintln!("{}: {t:?}", v.name);
        // The RMSE of the mean image falls as 1/sqrt(S) for an unbiased estimator: from 1
        // to 256 seeds by 16x; a mean stuck at a bias would not fall below it. Half that
        // (8x) leaves room for the one-seed figure's own noise.
        let rmse = |s: u32| t.rmse_of_mean.iter().find(|r| r.0 == s).unwrap().1;
        if !t.unbiased() || rmse(SEEDS) > rmse(1) / 8.0 {
            failures.push(format!("{}: {t:?}", v.name));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A deliberate break: the variant, the shading module edited (under `shading/`), what
/// the edit does, the edit, and the frames the z-tests take.
type Break = (
    &'static str,
    &'static str,
    &'static str,
    (&'static str, &'static str),
    u32,
);

/// The breaks the tests exist for, each a one-line edit of a light loop's unit.
#[test]
fn each_deliberate_break_fails_the_z_tests() {
    let gpu = gpu();
    let breaks: [Break; 5] = [
        (
            "forward_plus_ris_8",
            "light_loop/ris",
            "zero-target candidates skipped (one public port's bias)",
            (
                "let w = goal * f32(list.count);",
                "let w = goal * f32(list.count);\n                if (goal == 0.0) { continue; }",
            ),
            1,
        ),
        (
            "forward_plus_stochastic_culling",
            "light_loop/stochastic_culling",
            "kept lights not reweighted",
            (" / keep_probability(light, d2);", ";"),
            1,
        ),
        (
            "clustered_deferred_restir_temporal",
            "light_loop/reservoir",
            "the reused reservoir's count left out of M",
            ("out.count += count;", "out.count += 1.0;"),
            4,
        ),
        (
            "clustered_deferred_restir_spatiotemporal",
            "light_loop/restir_spatiotemporal",
            "neighbours merged without their M",
            (
                "let own = count[k] * target_at(surface[k], y);",
                "let own = select(count[k], 1.0, k > 1u) * target_at(surface[k], y);",
            ),
            4,
        ),
        (
            "forward_plus_shadows_importance_1",
            "shadows/sampled",
            "a drawn light not weighted by its probability",
            ("f32(draws) * total / (lum * rays)", "f32(draws) / rays"),
            1,
        ),
    ];
    let mut passed = Vec::new();
    for (name, unit, what, edit, count) in breaks {
        let module = format!("shading/{unit}.wesl");
        let edited = EditedShaders::of(&module, &format!("bias-{name}"), &[edit]);
        let t = bias_of(&gpu, &edited.composer, &load(name), &frames(count));
        eprintln!("{name}, {what}: {t:?}");
        if t.unbiased() {
            passed.push(format!("{name} with {what}: {t:?}"));
        }
    }
    assert!(
        passed.is_empty(),
        "breaks the tests did not catch:\n{}",
        passed.join("\n")
    );
}

#[test]
fn a_seed_draws_the_same_frame_again_and_another_seed_another() {
    let gpu = gpu();
    let composer = Composer::default();
    let scene = scene::generate("atrium", params()).unwrap();
    for v in unbiased_samplers().into_iter().map(|(v, _)| v) {
        let mut r = Renderer::new(&gpu, &composer, &v.variant, &scene).unwrap();
        let first = r.render().unwrap().hdr;
        let again = r.render().unwrap().hdr;
        let fresh = Renderer::new(&gpu, &composer, &v.variant, &scene)
            .unwrap()
            .render()
            .unwrap()
            .hdr;
        r.reseed(v.variant.shading.lights.sampling().unwrap().seed + 1);
        let other = r.render().unwrap().hdr;
        let bits = |h: &[[f32; 4]]| h.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&first), bits(&again), "{}: drawn again", v.name);
        assert_eq!(bits(&first), bits(&fresh), "{}: a fresh renderer", v.name);
        assert_ne!(bits(&first), bits(&other), "{}: another seed", v.name);
    }
}

/// RIS draws its candidates at every pixel with a list and evaluates each; stochastic
/// culling walks its list (drawn with the frame's ranges) and evaluates the lights its
/// roulette keeps, never more; useful evaluations are among the evaluated.
#[test]
fn the_counters_count_candidates_evaluations_and_useful_ones() {
    let gpu = gpu();
    let composer = Composer::default();
    let scene = scene::generate("atrium", params()).unwrap();
    for (name, candidates) in [
        ("forward_plus_ris_8", Some(8)),
        ("forward_plus_ris_32_kept_4", Some(32)),
    ]
    .into_iter()
    .chain([("forward_plus_stochastic_culling", None)])
    {
        let v = load(name);
        let mut r = Renderer::new(&gpu, &composer, &v.variant, &scene).unwrap();
        r.render().unwrap();
        let stats = r.stats().unwrap();
        let pixels = r.pixel_counters().unwrap();
        assert_eq!(
            stats.light_candidates,
            pixels.candidates.iter().map(|&n| n as u64).sum::<u64>()
        );
        for i in 0..pixels.evals.len() {
            let (c, e, u) = (pixels.candidates[i], pixels.evals[i], pixels.useful[i]);
            assert!(u <= e, "{name}: pixel {i}: {u} useful of {e} evaluated");
            match candidates {
                Some(m) => assert!(
                    c == e && (c == 0 || c == m),
                    "{name}: pixel {i}: {c} candidates, {e} evaluated"
                ),
                None => assert!(e <= c, "{name}: pixel {i}: {e} evaluated of {c} walked"),
            }
        }
        assert!(stats.useful_light_evals > 0, "{name}: nothing useful");
    }
}

/// Every shipped sampled variant (RIS, uniform, stochastic culling, temporal reuse): all
/// are claimed unbiased (`unbiased_samplers`; `tests/completeness.rs` holds the list to
/// the shipped files).
fn every_sampler() -> Vec<LoadedVariant> {
    unbiased_samplers().into_iter().map(|(v, _)| v).collect()
}

/// The plane of `one_light` at the test size, with `lights` instead of its own.
fn plane_with(lights: Vec<Light>) -> Scene {
    let mut scene = scene::generate("one_light", small("one_light", 48, 27, Some(1))).unwrap();
    scene.lights = lights;
    scene.moving_lights.clear();
    scene
}

/// Render `v` on `scene` once and compare with the reference: the frame's 8-bit error and
/// its non-finite pixels.
fn error_on(gpu: &Gpu, v: &LoadedVariant, scene: &Scene) -> clusterlab::metrics::ErrorMetrics {
    let composer = Composer::default();
    let frame = Renderer::new(gpu, &composer, &v.variant, scene)
        .and_then(|mut r| r.render())
        .unwrap_or_else(|e| panic!("{}: {e}", v.name));
    let (reference, _) = reference_frame(gpu, &composer, v, scene).unwrap();
    clusterlab::metrics::compare(&frame, &reference)
}

/// Where a sampler is exact by construction the frame is within the exact variants' 1 LSB:
/// a list of one light (every draw is that light: RIS's estimate is its contribution over
/// its luminance times its luminance, uniform's the contribution, culling keeps a light
/// whose probability is 1), a list of lights of no weight (nothing to choose: ambient, no
/// 0/0) and an empty list (ambient).
#[test]
fn samplers_are_exact_where_their_lists_leave_nothing_to_chance() {
    let gpu = gpu();
    let bright = |x: f32| Light::point([x, 1.5, 0.0], 2.5, [1.0, 0.9, 0.8], 40.0);
    // One light among 65536: the others far outside the view, a list finds the one.
    let mut needle = vec![bright(0.0)];
    needle.extend((1..65536).map(|i| {
        Light::point(
            [1000.0 + (i % 256) as f32, -500.0, (i / 256) as f32],
            0.5,
            [1.0; 3],
            1.0,
        )
    }));
    // Lights of zero colour over the whole plane: every target is 0.
    let dark: Vec<Light> = (0..64)
        .map(|i| {
            Light::point(
                [(i % 8) as f32 - 3.5, 1.0, (i / 8) as f32 - 3.5],
                4.0,
                [0.0; 3],
                1.0,
            )
        })
        .collect();
    // One small light: most pixels' lists are empty.
    let corner = vec![Light::point([-2.5, 0.3, -2.5], 1.0, [1.0; 3], 20.0)];
    let cases = [
        ("one light among 65536", needle),
        ("every weight zero", dark),
        ("empty lists", corner),
    ];
    let mut failures = Vec::new();
    for (what, lights) in cases {
        let scene = plane_with(lights);
        for v in every_sampler()
            .into_iter()
            .filter(|v| v.variant.pipeline.is_clustered())
        {
            let e = error_on(&gpu, &v, &scene);
            if e.max_abs_8bit > 1 || e.nan_pixels > 0 {
                failures.push(format!(
                    "{what}, {}: max {} LSB, {} NaN pixels",
                    v.name, e.max_abs_8bit, e.nan_pixels
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Two overlapping lights a million times apart in intensity: every estimate stays finite,
/// and its mean over the seeds stays the reference's (the dim light's part is not lost to
/// rounding in a weight sum the bright one dominates).
#[test]
fn a_million_to_one_in_intensity_stays_finite_and_unbiased() {
    let gpu = gpu();
    let composer = Composer::default();
    let scene = plane_with(vec![
        Light::point([-1.0, 1.0, 0.0], 6.0, [1.0, 0.5, 0.2], 1e4),
        Light::point([1.0, 1.0, 0.0], 6.0, [0.2, 0.5, 1.0], 1e-2),
        Light::point([0.0, 1.0, 1.0], 6.0, [0.5, 1.0, 0.5], 1.0),
    ]);
    let frames = [scene];
    for v in every_sampler()
        .into_iter()
        .filter(|v| !v.variant.shading.lights.sampling().unwrap().reuses_frames())
    {
        let (reference, _) = reference_frame(&gpu, &composer, &v, &frames[0]).unwrap();
        let runs = bias::seed_runs(&gpu, &composer, &v, &frames, 64, &reference).unwrap();
        let t = bias::test(&runs, &reference, bias::hdr_rounding(gpu.hdr_format));
        assert!(t.unbiased(), "{}: {t:?}", v.name);
        let e = error_on(&gpu, &v, &frames[0]);
        assert_eq!(e.nan_pixels, 0, "{}", v.name);
    }
}
