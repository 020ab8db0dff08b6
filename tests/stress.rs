//! The stress suite at its small sizes (as CI runs it): every adversarial case on every
//! pipeline it applies to passes every check.

use crate::common;
use clusterlab::compose::Composer;
use clusterlab::stress;

#[test]
fn the_stress_suite_passes() {
    let mut gpu = common::gpu();
    let counts = gpu.multisample_counts();
    let listed = stress::cases();
    let runs = stress::run(
        &mut gpu,
        &Composer::default(),
        &listed,
        stress::Subjects::BuiltIn,
        &mut |_| {},
    );
    // Every case of the list ran, on every variant it lists but those with a sample count the
    // adapter lacks (through OpenGL, all multisampled ones), which say so, and the guide
    // states those counts.
    let ran: Vec<(&str, &str)> = runs
        .iter()
        .filter(|r| r.not_applicable.is_none())
        .map(|r| (r.case.as_str(), r.variant.as_str()))
        .collect();
    assert!(
        runs.iter()
            .filter_map(|r| r.not_applicable.as_deref())
            .all(|why| why.contains("does not multisample"))
    );
    let expected: Vec<(&str, &str)> = listed
        .iter()
        .flat_map(|c| {
            c.variants
                .iter()
                .filter(|(_, v)| counts.contains(&v.msaa.samples))
                .map(|(v, _)| (c.name.as_str(), v.as_str()))
        })
        .collect();
    assert_eq!(ran, expected);
    let guide = std::fs::read_to_string("docs/guide.md").expect("docs/guide.md");
    let guide = guide.split_whitespace().collect::<Vec<_>>().join(" ");
    // The case count, not the runs': a new culling method adds runs and leaves the guide.
    let claim = format!(
        "runs {} adversarial cases on every pipeline each applies to",
        listed.len()
    );
    assert!(
        guide.contains(&claim),
        "docs/guide.md does not say `{claim}`"
    );
    for pipeline in [
        "naive_forward",
        "forward_plus",
        "clustered_deferred",
        "deferred_scissor",
    ] {
        assert!(runs.iter().any(|r| r.variant == pipeline), "{pipeline}");
    }
    let report = stress::report(&runs);
    assert!(runs.iter().all(|r| r.ok), "{report}");
}

#[test]
fn a_failed_check_names_the_case_and_where() {
    // Lists capped at one light, where a thousand lights share a point: lights are left out.
    let gpu = common::gpu();
    let case = stress::cases()
        .into_iter()
        .find(|c| c.name == "many_lights_at_one_point")
        .expect("case");
    let mut v = case
        .variants
        .iter()
        .find(|(n, _)| n == "forward_plus")
        .unwrap()
        .1
        .clone();
    v.clusters.as_mut().unwrap().lists =
        clusterlab::variant::LightLists::Capped { max_per_cluster: 1 };
    let references = clusterlab::reference::ReferenceCache::default();
    let run = stress::run_case(&gpu, &Composer::default(), &references, &case, "capped", &v);
    assert!(!run.ok);
    let dropped = run
        .checks
        .iter()
        .find(|c| c.check == "no dropped light")
        .unwrap();
    assert!(!dropped.ok);
    assert!(
        dropped.detail.contains("touches cluster") && dropped.detail.contains("light "),
        "{}",
        dropped.detail
    );
    let error = run
        .checks
        .iter()
        .find(|c| c.check == "error within bound")
        .unwrap();
    assert!(
        !error.ok && error.detail.contains("worst at pixel ("),
        "{}",
        error.detail
    );
    assert!(stress::report(&[run]).contains("many_lights_at_one_point"));
}

/// The marking passes' depth margin holds a depth stored as another rasteriser may store it
/// (`cpu::clusters::depth_margin`): with every depth marking reads moved 32 units in the last
/// place (1.9e-6 of it, inside the 1e-5 Vulkan and OpenGL ES allow; an edited copy of the
/// shaders, as `CLUSTERLAB_PERTURB_DEPTH_ULPS=32` does for the whole suite in CI), the case
/// with 10 decades of standard depth passes every check on the methods whose live clusters
/// the depth buffer decides; with the constant 1e-3 margin of before (which an NVIDIA H200
/// broke) in its place, lights go missing there.
#[test]
fn a_depth_stored_otherwise_keeps_every_light_in_the_lists() {
    let gpu = common::gpu();
    let case = stress::cases()
        .into_iter()
        .find(|c| c.name == "near_1e-4_far_1e6")
        .expect("case");
    let nudge = (
        "var d = textureLoad(depth_texture, p, 0).r;",
        "var d = bitcast<f32>(bitcast<u32>(textureLoad(depth_texture, p, 0).r) + 32u);",
    );
    let without_margin = ("let m = depth_margin(view, z);", "let m = MARK_MARGIN;");
    let nudged = common::EditedShaders::of("passes/mark_active.wesl", "nudged-depth", &[nudge]);
    let broken = common::EditedShaders::of(
        "passes/mark_active.wesl",
        "nudged-depth-no-margin",
        &[nudge, without_margin],
    );
    let references = clusterlab::reference::ReferenceCache::default();
    let mut missed = Vec::new();
    for name in [
        "forward_plus_depthmask",
        "forward_plus_active",
        "forward_plus_sample_bounds",
    ] {
        let v = &case
            .variants
            .iter()
            .find(|(n, _)| n == name)
            .unwrap_or_else(|| panic!("{name} in the case"))
            .1;
        let run = stress::run_case(&gpu, &nudged.composer, &references, &case, name, v);
        assert!(run.ok, "{}", stress::report(std::slice::from_ref(&run)));
        let run = stress::run_case(&gpu, &broken.composer, &references, &case, name, v);
        if !run.ok {
            missed.push(name);
        }
    }
    // The three the H200 failed, each for the same reason. Under CI's own perturbation
    // (`CLUSTERLAB_PERTURB_DEPTH_ULPS`, added to this test's nudge up and down in a
    // checkerboard) which samples cross a boundary changes, so only some may miss.
    let all = [
        "forward_plus_depthmask",
        "forward_plus_active",
        "forward_plus_sample_bounds",
    ];
    if clusterlab::compose::perturbed_depth_ulps() == 0 {
        assert_eq!(
            missed, all,
            "with the constant margin, the methods that should miss lights"
        );
    } else {
        assert!(
            !missed.is_empty(),
            "with the constant margin, no method missed a light"
        );
    }
}

/// Where the depth margin switches z-culling off, the run says so and names reversed depth:
/// the stress case with 10 decades of standard depth (far/near 1e10: the margin at the far
/// plane is 1e-5 x 1e10, far past 1) for a variant that marks the clusters its samples land
/// in; not for one that marks nothing, nor with reversed depth (1e-3 + 1e-5).
#[test]
fn a_margin_that_switches_z_culling_off_is_named() {
    let case = stress::cases()
        .into_iter()
        .find(|c| c.name == "near_1e-4_far_1e6")
        .expect("case");
    let marking = common::load("forward_plus_olsson").variant;
    let note = clusterlab::run::margin_note(&marking, &case.scene).expect("a note");
    assert!(
        note.contains("z-culling is off") && note.contains("reversed_z: true"),
        "{note}"
    );
    let plain = common::load("forward_plus").variant;
    assert_eq!(clusterlab::run::margin_note(&plain, &case.scene), None);
    let mut reversed = marking.clone();
    reversed.depth.reversed_z = true;
    assert_eq!(clusterlab::run::margin_note(&reversed, &case.scene), None);
    // The built-in scenes at their planes keep the margin under the note's threshold.
    for name in ["atrium", "stage", "spheres", "glass"] {
        let scene =
            clusterlab::scene::generate(name, common::small(name, 32, 18, Some(1))).unwrap();
        assert_eq!(
            clusterlab::run::margin_note(&marking, &scene),
            None,
            "{name}"
        );
    }
}
