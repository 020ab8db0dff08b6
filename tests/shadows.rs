//! Exact shadows against the f64 reference: every shipped shadowed variant, Forward+ and
//! deferred, on the built-in scenes with occluders and a glTF file, within 1 LSB outside
//! the ambiguous pairs, which stay under 0.1% of the pairs; a ray without its offset (its
//! surface then shadows itself) fails; what cannot shadow is refused.

use crate::common::{self, EditedShaders, gpu, load, small};
use clusterlab::compose::Composer;
use clusterlab::metrics::ShadowError;
use clusterlab::run::{CellOptions, EXACT_LSB, MAX_AMBIGUOUS_SHARE, run_scene};
use clusterlab::scene::{self, Scene};
use clusterlab::variant::LoadedVariant;

/// The shipped variants with exact shadows: one Forward+, one deferred.
const SHADOWED: [&str; 2] = ["forward_plus_shadows", "clustered_deferred_shadows"];

/// The shadow figures of `v` on `scene`, shaded by `composer`'s shaders.
fn shadow_error(composer: &Composer, v: &LoadedVariant, scene: &Scene) -> ShadowError {
    let r = run_scene(&gpu(), composer, v, scene, CellOptions::default())
        .unwrap_or_else(|e| panic!("{} on {}: {e}", v.name, scene.name));
    let error = r.report.error.expect("an error against the reference");
    error.shadows.expect("a shadowed frame's figures")
}

/// A scene's defaults at 160x90: small enough for a debug build, large enough for shadows.
fn built_in(name: &str) -> Scene {
    scene::generate(name, small(name, 160, 90, None)).expect("built-in scene")
}

/// Each occluder scene and a glTF file (the stage, exported: plinths and statues under
/// spots): some rays blocked, every pixel within 1 LSB of the reference or of the range its
/// ambiguous pairs allow, and few pairs ambiguous.
#[test]
fn exact_shadows_are_within_1_lsb_outside_ambiguous_pairs() {
    let dir = common::scratch("gltf");
    let glb = dir.join("stage.glb");
    let stage = built_in("stage");
    std::fs::write(&glb, scene::export::to_glb(&stage).expect("export")).expect("write");
    let file = glb.to_str().expect("utf-8 path");
    let mut params = scene::defaults(file).expect("load");
    (params.width, params.height) = (160, 90);
    let from_file = scene::generate(file, params).expect("load");
    let scenes = [built_in("atrium"), stage, built_in("spheres"), from_file];
    let composer = Composer::default();
    for name in SHADOWED {
        let v = load(name);
        for scene in &scenes {
            let s = shadow_error(&composer, &v, scene);
            let at = format!("{name} on {}: {s:?}", scene.name);
            // A test that could not fail: some rays must be blocked.
            assert!(s.blocked * 100 >= s.pairs, "under 1% of rays blocked, {at}");
            assert!(s.max_outside_ambiguity_8bit <= EXACT_LSB, "{at}");
            assert!(s.ambiguous_share <= MAX_AMBIGUOUS_SHARE, "{at}");
        }
    }
}

/// The deliberate break: without its offset a ray starts on its own surface, which then
/// shadows it where f32 puts the start below the surface.
#[test]
fn a_ray_without_its_offset_shadows_its_own_surface() {
    let v = load("forward_plus_shadows");
    let scene = built_in("atrium");
    let fine = shadow_error(&Composer::default(), &v, &scene);
    assert!(fine.max_outside_ambiguity_8bit <= EXACT_LSB, "{fine:?}");
    let no_offset = EditedShaders::of(
        "shading/shadows.wesl",
        "no-offset",
        &[(
            "s.normal * (SHADOW_OFFSET * scale)",
            "s.normal * (0.0 * scale)",
        )],
    );
    let broken = shadow_error(&no_offset.composer, &v, &scene);
    assert!(
        broken.max_outside_ambiguity_8bit > EXACT_LSB,
        "self-shadowing went unseen: {broken:?}"
    );
}

/// The far light: range 6 at (1e6, 5e5, -1e6), beside the atrium's own. It lights
/// no surface, so it leaves every ray's reach (the GPU's error, from the coordinates each
/// test handles) as it was: the ambiguous share stays under the cap, and a shader with its
/// occlusion removed fails the exactness check, in-process, in `render` and in `matrix`
/// (the scene exported to glTF). Before, the scene's largest coordinate was every ray's
/// reach: every ray was ambiguous and that shader passed (`cpu::occlusion`'s test of
/// `Reach` holds the break).
#[test]
fn a_far_light_leaves_shadows_checkable_and_an_occlusion_free_shader_fails() {
    let mut scene = built_in("atrium");
    scene.lights.push(clusterlab::common::Light {
        position: [1e6, 5e5, -1e6],
        radius: 6.0,
        color: [1.0; 3],
        cos_outer: -1.0,
        direction: [0.0; 3],
        cos_inner: -1.0,
    });
    let v = load("forward_plus_shadows");
    let fine = shadow_error(&Composer::default(), &v, &scene);
    assert!(fine.ambiguous_share <= MAX_AMBIGUOUS_SHARE, "{fine:?}");
    let no_occlusion = EditedShaders::of(
        "shading/occlusion.wesl",
        "no-occlusion",
        &[("return true;", "return false;")],
    );
    let r = run_scene(
        &gpu(),
        &no_occlusion.composer,
        &v,
        &scene,
        CellOptions::default(),
    )
    .expect("a frame");
    let why = r.report.failure.expect("an occlusion-free shader fails");
    assert!(why.contains("LSB against the reference outside"), "{why}");
    // The same through the commands, on the scene as a glTF file.
    let dir = common::scratch("far-light");
    let glb = dir.join("far_light.glb");
    std::fs::write(&glb, scene::export::to_glb(&scene).expect("export")).expect("write");
    let file = glb.to_str().unwrap();
    let shaders = ("CLUSTERLAB_SHADERS", no_occlusion.root().to_str().unwrap());
    let (render_out, matrix_out) = (dir.join("render"), dir.join("matrix"));
    let (render_out, matrix_out) = (render_out.to_str().unwrap(), matrix_out.to_str().unwrap());
    let commands: [&[&str]; 2] = [
        &[
            "render",
            "--variant",
            "forward_plus_shadows",
            "--scene",
            file,
            "--size",
            "160x90",
            "--out",
            render_out,
        ],
        &[
            "matrix",
            "--variants",
            "forward_plus_shadows",
            "--scenes",
            file,
            "--size",
            "160x90",
            "--frames",
            "1",
            "--out",
            matrix_out,
        ],
    ];
    for args in commands {
        let (ok, text) = common::cli(args).envs(&[shaders]).run().succeeded();
        assert!(
            !ok && text.contains("LSB against the reference outside"),
            "{args:?}: {text}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A scene with no opaque triangle to cast a shadow is refused for a shadowed variant, with
/// the reason; so is a variant whose lights or pipeline cannot trace them.
#[test]
fn shadows_that_would_do_nothing_are_refused() {
    let v = load("forward_plus_shadows");
    let mut scene = built_in("glass");
    scene.blended.extend(std::mem::take(&mut scene.indices));
    let error = clusterlab::render::Renderer::new(&gpu(), &Composer::default(), &v.variant, &scene)
        .err()
        .expect("refused")
        .to_string();
    assert!(
        error.contains("shading.shadows") && error.contains("no opaque triangle"),
        "{error}"
    );
    let mut sampled = v.variant.clone();
    sampled.shading.lights =
        clusterlab::variant::Lights::Sampled(clusterlab::variant::Sampling::default());
    let problems = clusterlab::variant::check(&sampled);
    assert!(
        problems.iter().any(|p| p.field == "shading.shadows"),
        "{problems:?}"
    );
}

/// The instrumented frame counts the rays the reference traces: one per pixel and light
/// above 0, the blocked ones among them. The two sides differ only where a light's f32
/// contribution and its f64 one fall on either side of 0 (at the radius, or n.l = 0; 19 of
/// 1.36M rays on the stage at 640x360) and, for the blocked ones, at ambiguous pairs; a
/// walk tests at least its root, at most every node.
#[test]
fn the_gpu_counts_the_rays_the_reference_traces() {
    let gpu = gpu();
    let scene = built_in("spheres");
    for name in SHADOWED {
        let v = load(name);
        let r = run_scene(
            &gpu,
            &Composer::default(),
            &v,
            &scene,
            CellOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        let rays = r.report.stats.as_ref().and_then(|s| s.shadow_rays);
        let rays = rays.expect("ray counters");
        let s = r.report.error.and_then(|e| e.shadows).expect("figures");
        let near_zero = s.pairs / 10_000;
        assert!(
            rays.traced.abs_diff(s.pairs) <= near_zero,
            "{name}: {rays:?} {s:?}"
        );
        assert!(
            rays.blocked.abs_diff(s.blocked) <= near_zero + s.ambiguous,
            "{name}: {rays:?} {s:?}"
        );
        assert!(rays.blocked > 0, "{name}: no ray blocked");
        let nodes = clusterlab::render::shadows::Occluders::of(&scene)
            .bvh
            .nodes
            .len() as u64;
        assert!(
            (rays.traced..=rays.traced * nodes).contains(&rays.node_visits),
            "{name}: {rays:?}"
        );
    }
}
