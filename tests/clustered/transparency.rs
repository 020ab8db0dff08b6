//! Masked and blended materials (the `glass` scene; its exactness on every exact variant is
//! `clustered_output_equals_naive_output`'s, which runs every built-in scene): the deliberate
//! breaks of what keeps them exact, the order they are blended in, and what is refused.

use super::*;
use clusterlab::common::AlphaMode;
use clusterlab::run::{CellOptions, run_scene};
use clusterlab::scene::MeshBuilder;

fn glass() -> Scene {
    scene::generate("glass", small("glass", 100, 57, None)).unwrap()
}

/// The worst 8-bit error of `v` on `scene` against the reference, composed by `composer`.
fn worst(gpu: &Gpu, composer: &Composer, v: &LoadedVariant, scene: &Scene) -> u32 {
    let r = run_scene(gpu, composer, v, scene, CellOptions::default())
        .unwrap_or_else(|e| panic!("{}: {e}", v.name));
    r.report.error.expect("an error").max_abs_8bit
}

/// The deliberate break: active clusters (with sample bounds) that mark only the opaque
/// samples leave out lights that reach a pane but no opaque surface of its clusters, and the
/// picture is no longer within 1 LSB; with the panes' depths marked it is.
#[test]
fn active_clusters_without_transparent_lists_fail_on_blended_panes() {
    let gpu = gpu();
    let scene = glass();
    for pipeline in [Pipeline::ClusteredForward, Pipeline::ClusteredDeferred] {
        let mut v = clustered(pipeline, ZSlicing::Exponential);
        let c = v.clusters.as_mut().unwrap();
        c.active_clusters = true;
        c.sample_bounds = true;
        let v = loaded(&format!("{pipeline:?} sample bounds"), v);
        assert!(
            worst(&gpu, &Composer::default(), &v, &scene) <= 1,
            "{}",
            v.name
        );
        let opaque_only = EditedShaders::of(
            "passes/mark_active.wesl",
            "opaque-marking-only",
            &[("        mark_transparent(id.xy);\n", "")],
        );
        let broken = worst(&gpu, &opaque_only.composer, &v, &scene);
        assert!(
            broken > 1,
            "{}: marking only the opaque samples went unseen: {broken} LSB",
            v.name
        );
    }
}

/// The deliberate breaks of masks: a G-buffer pass or a forward pass (without a pre-pass)
/// that keeps what the mask discards draws the cut-outs' gaps. (A pre-pass is composed by
/// the same composer for the variant and its raster truth, so its break would move both.)
#[test]
fn a_raster_pass_that_ignores_the_mask_fails() {
    let gpu = gpu();
    let scene = glass();
    let cases = [
        (Pipeline::ClusteredDeferred, "passes/gbuffer.wesl"),
        (Pipeline::ClusteredForward, "passes/forward.wesl"),
    ];
    for (pipeline, module) in cases {
        let mut v = clustered(pipeline, ZSlicing::Exponential);
        v.depth_prepass = false;
        let v = loaded(&format!("{pipeline:?}"), v);
        assert!(
            worst(&gpu, &Composer::default(), &v, &scene) <= 1,
            "{}",
            v.name
        );
        let unmasked = EditedShaders::of(
            module,
            "unmasked",
            &[("if (masked_out(in)) {\n", "if (false) {\n")],
        );
        let broken = worst(&gpu, &unmasked.composer, &v, &scene);
        assert!(
            broken > 1,
            "{module} without its mask went unseen: {broken} LSB"
        );
    }
}

/// The deliberate break of blending: panes written opaque (alpha 1) instead of laid over
/// what is behind them fail every pipeline's exactness check.
#[test]
fn panes_written_opaque_fail() {
    let gpu = gpu();
    let scene = glass();
    let opaque = EditedShaders::of(
        "passes/forward.wesl",
        "opaque-panes",
        &[(
            "    let alpha = base_alpha(in);\n",
            "    let alpha = 1.0;\n",
        )],
    );
    for v in [
        "naive_forward",
        "forward_plus",
        "clustered_deferred_16x16x24",
        "deferred_scissor",
    ] {
        let v = common::load(v);
        assert!(
            worst(&gpu, &Composer::default(), &v, &scene) <= 1,
            "{}",
            v.name
        );
        let broken = worst(&gpu, &opaque.composer, &v, &scene);
        assert!(
            broken > 1,
            "{}: opaque panes went unseen: {broken} LSB",
            v.name
        );
    }
}

/// Blended triangles are drawn farthest first by their centroids' view depth, ties in the
/// scene's order; every triangle once.
#[test]
fn blended_triangles_are_ordered_back_to_front() {
    let scene = glass();
    let order = scene.blend_order();
    let view = scene.camera.view();
    let depth = |t: &[u32]| {
        let c = t
            .iter()
            .map(|&i| DVec3::from(scene.vertices[i as usize].position.map(f64::from)))
            .sum::<DVec3>()
            / 3.0;
        -view.transform_point3(c).z
    };
    let depths: Vec<f64> = order.chunks(3).map(depth).collect();
    assert!(depths.len() >= 12, "{} blended triangles", depths.len());
    assert!(depths.windows(2).all(|d| d[0] >= d[1]), "{depths:?}");
    let mut sorted: Vec<&[u32]> = order.chunks(3).collect();
    let mut original: Vec<&[u32]> = scene.blended.chunks(3).collect();
    sorted.sort();
    original.sort();
    assert_eq!(sorted, original);
}

/// Blended materials are drawn at one sample a pixel: a multisampled variant on a scene with
/// them is refused, naming the field and why; masked materials multisample.
#[test]
fn multisampling_a_scene_with_blended_materials_is_refused() {
    let gpu = gpu();
    let mut v = common::load("forward_plus").variant;
    v.msaa.samples = 4;
    let error = match Renderer::new(&gpu, &Composer::default(), &v, &glass()) {
        Ok(_) => panic!("not refused"),
        Err(e) => e.to_string(),
    };
    assert!(
        error.contains("msaa.samples") && error.contains("blended"),
        "{error}"
    );
}

/// A pixel with more blended fragments than the reference records is refused, naming the
/// pixel and the limit; one with exactly that many is measured.
#[test]
fn more_blended_fragments_than_the_reference_records_are_refused() {
    let gpu = gpu();
    let limit = clusterlab::cpu::truth::MAX_BLENDED_FRAGMENTS;
    let panes = |count: u32| {
        let mut m = MeshBuilder::default();
        m.set_material(0.5, 0.0);
        m.axis_rect(2, -20.0, [-50.0, -50.0], [50.0, 50.0], true, [0.5; 3]);
        m.set_alpha(0.02, AlphaMode::Blend);
        for i in 0..count {
            let z = -1.0 - 10.0 * i as f64 / count as f64;
            m.axis_rect(2, z, [-1.0, -1.0], [1.0, 1.0], true, [0.8, 0.6, 0.4]);
        }
        let mut scene = scene::generate("one_light", small("one_light", 8, 8, None)).unwrap();
        scene.vertices = m.vertices;
        scene.indices = m.indices;
        scene.blended = m.blended;
        scene.camera = scene::Camera {
            eye: DVec3::ZERO,
            target: DVec3::NEG_Z,
            up: DVec3::Y,
            fov_y: 0.5,
            near: 0.5,
            far: 30.0,
        };
        scene.prev_camera = scene.camera;
        scene.lights = vec![Light::point([0.0, 0.0, -0.5], 30.0, [1.0; 3], 4.0)];
        scene
    };
    let v = common::load("naive_forward");
    // Measured, whatever its error (256 roundings of a 16-bit float target add up).
    worst(&gpu, &Composer::default(), &v, &panes(limit));
    let error =
        clusterlab::render::raster_truth(&gpu, &Composer::default(), &v.variant, &panes(limit + 1))
            .expect_err("refused")
            .to_string();
    assert!(
        error.contains(&format!("{} blended fragments", limit + 1))
            && error.contains(&format!("at most {limit}")),
        "{error}"
    );
}
