//! Sequences: frames that follow each other change the cost, never the picture. Every list
//! strategy stays exact on every frame (within 1 LSB of the f64 reference, and equal bit
//! for bit to the frame rendered from scratch, its lists as sets) while doing its own work,
//! not a rebuild; a frame reuses what did not change; the outputs land; and a patch that
//! forgets to remove a moved light fails.

use std::path::Path;

use crate::common::{EditedShaders, cli, gpu, load, scratch, small};
use clusterlab::compose::Composer;
use clusterlab::reference::ReferenceCache;
use clusterlab::render::Renderer;
use clusterlab::scene::{self, FRAME_DT, Motion, SceneParams};
use clusterlab::sequence::{self, SequenceReport, SequenceSpec};
use clusterlab::variant::{ListUpdate, LoadedVariant};

/// The atrium small, with `moving` of its 256 lights moving and the camera still or not.
fn atrium(moving: f32, camera: bool) -> SceneParams {
    let mut p = small("atrium", 96, 54, Some(256));
    p.motion = Motion {
        lights: moving,
        camera,
        still_at: p.time,
    };
    p
}

fn run_with(
    composer: &Composer,
    v: &LoadedVariant,
    name: &str,
    params: SceneParams,
    frames: u32,
) -> SequenceReport {
    let gpu = gpu();
    let scenes = sequence::scene_frames(name, params);
    let spec = SequenceSpec {
        frames,
        check_every: 1,
    };
    sequence::run(&gpu, composer, v, spec, &scenes, &ReferenceCache::default())
        .unwrap_or_else(|e| panic!("{}: {e}", v.name))
        .report
}

fn run(v: &LoadedVariant, params: SceneParams, frames: u32) -> SequenceReport {
    run_with(&Composer::default(), v, "atrium", params, frames)
}

/// The sequence group's variants: the rebuilding ones and every shipped strategy.
fn strategies() -> Vec<LoadedVariant> {
    let mut out: Vec<LoadedVariant> = clusterlab::matrix::SEQUENCE_REBUILDS
        .iter()
        .map(|n| load(n))
        .collect();
    for file in clusterlab::variant::find_files(Path::new("variants")).unwrap() {
        let v = clusterlab::variant::load(&file).unwrap();
        if v.variant.pipeline.is_clustered() && v.variant.clusters().update != ListUpdate::Rebuild {
            out.push(v);
        }
    }
    out
}

fn passes(r: &SequenceReport, frame: usize) -> Vec<&str> {
    r.frames[frame]
        .gpu_ms
        .keys()
        .map(String::as_str)
        .filter(|n| *n != "total")
        .collect()
}

#[test]
fn every_strategy_is_exact_on_every_frame_and_does_its_own_work() {
    let variants = strategies();
    let updates: Vec<ListUpdate> = variants
        .iter()
        .map(|v| v.variant.clusters().update)
        .collect();
    for u in [
        ListUpdate::StaticDynamic,
        ListUpdate::Patch,
        ListUpdate::Refit,
    ] {
        assert!(updates.contains(&u), "no shipped variant with {u:?}");
    }
    for (moving, camera) in [(0.1, false), (1.0, false), (0.1, true)] {
        let movers = scene::generate("atrium", atrium(moving, camera))
            .unwrap()
            .moving_lights
            .len() as u32;
        assert!(movers > 0);
        for v in &variants {
            let r = run(v, atrium(moving, camera), 4);
            let what = format!("{} with {moving} moving, camera moving {camera}", v.name);
            assert!(r.failure.is_none(), "{what}: {:?}", r.failure);
            assert!(r.summary.exact, "{what}: {:#?}", r.frames);
            assert_eq!(r.summary.checked_frames, 4, "{what}");
            let (followed, how) = sequence::followed(&v.variant, &r);
            assert!(followed, "{what}: {how}");
            // Every moving light moved in every frame after the first.
            assert!(
                r.frames[1..].iter().all(|f| f.moved_lights == movers),
                "{what}"
            );
        }
    }
}

#[test]
fn a_patch_that_forgets_to_remove_a_moved_light_fails() {
    // Every light a frame moved stays in every list it was in.
    let forgetful = EditedShaders::of(
        "passes/patch_lists.wesl",
        "forgetful_patch",
        &[(
            "return !is_moving(i) || touches_at(i, c, x, y);",
            "return true;",
        )],
    );
    let v = load("forward_plus_patch");
    let params = atrium(1.0, false);
    let good = run(&v, params, 3);
    assert!(good.summary.exact, "{:?}", good.failure);
    let broken = run_with(&forgetful.composer, &v, "atrium", params, 3);
    assert!(!broken.summary.exact);
    let why = broken.failure.expect("a failure");
    assert!(
        why.contains("holds lights [") && why.contains("that a list built from scratch does not"),
        "{why}"
    );
}

#[test]
fn still_lists_that_keep_the_moving_lights_fail_against_the_reference() {
    // The moving lights in both sets of lists: shaded twice. The frame from scratch is as
    // wrong (the same shaders), so the reference is what catches it.
    let both = EditedShaders::of(
        "clustering/assignment.wesl",
        "moving_lights_twice",
        &[("if (is_moving(i)) {", "if (false) {")],
    );
    let v = load("forward_plus_static_dynamic");
    let r = run_with(&both.composer, &v, "atrium", atrium(0.5, false), 2);
    assert!(
        !r.summary.exact && r.summary.max_abs_8bit > 1,
        "{:?}",
        r.summary
    );
}

#[test]
fn a_frame_with_nothing_changed_runs_no_pass() {
    for name in [
        "forward_plus",
        "clustered_deferred_static_dynamic",
        "naive_forward",
    ] {
        let mut v = load(name);
        let r = run(&v, atrium(0.0, false), 3);
        assert!(r.summary.exact, "{name}");
        assert_eq!(r.summary.frames_reused, 2, "{name}");
        assert!(
            passes(&r, 1).is_empty() && passes(&r, 2).is_empty(),
            "{name}"
        );
        // Without reuse the frame is drawn again, on the lists it has.
        v.variant.reuse_unchanged = false;
        let r = run(&v, atrium(0.0, false), 3);
        assert!(r.summary.exact, "{name}");
        assert_eq!(r.summary.frames_reused, 0, "{name}");
        let ran = passes(&r, 2);
        assert!(
            ran.contains(&"tonemap") && !ran.contains(&"light_assign"),
            "{name}: {ran:?}"
        );
    }
}

#[test]
fn a_still_camera_reuses_the_surfaces_and_a_moving_one_draws_them() {
    let v = load("forward_plus");
    let still = run(&v, atrium(0.1, false), 3);
    for f in 1..3 {
        let ran = passes(&still, f);
        assert!(
            ran.contains(&"light_assign") && ran.contains(&"forward"),
            "{ran:?}"
        );
        assert!(!ran.contains(&"depth_prepass"), "{ran:?}");
        assert!(still.frames[f].skipped.iter().any(|s| s == "depth_prepass"));
    }
    let moving = run(&v, atrium(0.1, true), 3);
    assert!(moving.summary.exact);
    assert!((1..3).all(|f| passes(&moving, f).contains(&"depth_prepass")));
    // Lists built on the CPU follow the lights and the camera too.
    for camera in [false, true] {
        let cpu = run(&load("forward_plus_cpu_assignment"), atrium(0.1, camera), 3);
        assert!(cpu.summary.exact, "{:?}", cpu.failure);
    }
    // The light BVH refits with the camera moving too.
    let refit = run(&load("forward_plus_bvh_refit"), atrium(0.1, true), 3);
    assert!(refit.summary.exact);
    assert!((1..3).all(|f| passes(&refit, f).contains(&"light_assign")));
}

#[test]
fn a_frame_that_does_not_follow_is_refused() {
    let gpu = gpu();
    let v = load("forward_plus_patch").variant;
    let first = scene::generate("atrium", atrium(0.1, false)).unwrap();
    let mut r = Renderer::new(&gpu, &Composer::default(), &v, &first).unwrap();
    r.render().unwrap();
    let mut bigger = atrium(0.1, false);
    bigger.width += 1;
    let e = r
        .advance(&scene::generate("atrium", bigger).unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("its size is 97x54, the sequence's 96x54"), "{e}");
    let other = scene::generate("spheres", small("spheres", 96, 54, Some(256))).unwrap();
    let e = r.advance(&other).unwrap_err().to_string();
    assert!(e.contains("its geometry differs"), "{e}");
    let mut fewer = atrium(0.1, false);
    fewer.lights = 255;
    let e = r
        .advance(&scene::generate("atrium", fewer).unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("it has 255 lights, the sequence 256"), "{e}");
}

#[test]
fn a_moving_fraction_moves_nested_sets_of_lights_and_the_rest_stand_still() {
    let at = |moving: f32, camera: bool, frame: u32| {
        let mut p = atrium(moving, camera);
        p.time += frame as f64 * FRAME_DT;
        scene::generate("atrium", p).unwrap()
    };
    let everything = at(1.0, true, 0);
    // All moving is the scene as it always was.
    let plain = scene::generate("atrium", small("atrium", 96, 54, Some(256))).unwrap();
    assert_eq!(everything.lights, plain.lights);
    assert_eq!(everything.camera, plain.camera);
    assert_eq!(everything.moving_lights.len(), 256);
    let tenth = at(0.1, false, 0).moving_lights;
    let half = at(0.5, false, 0).moving_lights;
    assert!(tenth.len() > 10 && tenth.len() < 45, "{}", tenth.len());
    assert!(half.len() > 100 && half.len() < 156, "{}", half.len());
    assert!(tenth.iter().all(|i| half.contains(i)), "not nested");
    let (a, b) = (at(0.1, false, 0), at(0.1, false, 5));
    assert_eq!(a.camera, b.camera);
    assert_eq!(b.camera, b.prev_camera);
    for i in 0..256u32 {
        let same = a.lights[i as usize] == b.lights[i as usize];
        assert_eq!(same, !tenth.contains(&i), "light {i}");
    }
    assert!(at(0.0, false, 0).moving_lights.is_empty());
}

#[test]
fn sequence_writes_its_animation_plot_table_and_report() {
    let out = scratch("sequence_outputs");
    let ran = cli([
        "sequence",
        "--variant",
        "forward_plus_patch",
        "--scene",
        "one_light",
        "--lights",
        "16",
        "--size",
        "64x36",
        "--frames",
        "3",
        "--moving",
        "1",
        "--still-camera",
        "--check-every",
        "1",
    ])
    .arg("--out")
    .arg(&out)
    .run();
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
    assert!(
        ran.stdout.contains("list_patch") && ran.stdout.contains("exact"),
        "{}",
        ran.stdout
    );
    let stem = "forward_plus_patch@one_light";
    let gif = std::fs::read(out.join(format!("{stem}.gif"))).unwrap();
    let frames = image::AnimationDecoder::into_frames(
        image::codecs::gif::GifDecoder::new(std::io::Cursor::new(gif)).unwrap(),
    )
    .count();
    assert_eq!(frames, 3);
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join(format!("{stem}.sequence.json"))).unwrap())
            .unwrap();
    assert_eq!(json["frames"].as_array().unwrap().len(), 3);
    assert_eq!(json["summary"]["exact"], true);
    let csv = std::fs::read_to_string(out.join(format!("{stem}.frames.csv"))).unwrap();
    assert_eq!(csv.lines().count(), 4, "{csv}");
    let svg = std::fs::read_to_string(out.join(format!("{stem}.frames.svg"))).unwrap();
    assert!(svg.contains("list_patch"));
    for (args, says) in [
        (&["--frames", "0"][..], "0 is not in 1..=3600"),
        (&["--moving", "1.5"][..], "`1.5` is not a fraction in 0..=1"),
        (&["--check-every", "0"][..], "0 is not in 1.."),
    ] {
        let ran = cli([
            "sequence",
            "--variant",
            "forward_plus",
            "--scene",
            "one_light",
        ])
        .args(args)
        .run();
        assert_eq!(ran.code, Some(2), "{args:?}");
        assert!(ran.stderr.contains(says), "{args:?}: {}", ran.stderr);
    }
}

#[test]
fn the_default_matrix_runs_every_strategy_in_a_sequence_group() {
    let groups = clusterlab::matrix::default_groups().unwrap();
    let cells = clusterlab::matrix::expand(&groups).unwrap();
    let sequences: Vec<_> = cells.iter().filter(|c| c.spec.sequence.is_some()).collect();
    let strategies = strategies();
    assert_eq!(sequences.len(), 2 * strategies.len());
    for v in &strategies {
        for moving in ["0.1", "1"] {
            let id = format!(
                "{}@atrium[lights=1024,moving={moving},frames=30,camera=still]",
                v.name
            );
            let cell = sequences
                .iter()
                .find(|c| c.spec.id == id)
                .unwrap_or_else(|| panic!("no cell {id}"));
            assert!(
                !cell.spec.params.camera_moves && cell.spec.params.moving.to_string() == moving
            );
            // A strategy's frames are compared with its rebuilding twin's.
            let updates = v.variant.clusters().update != ListUpdate::Rebuild;
            assert_eq!(cell.spec.rebuild_cell.is_some(), updates, "{id}");
        }
    }
    // Strategies only sequences tell apart are in no single-frame group.
    assert!(cells.iter().all(|c| {
        c.spec.sequence.is_some()
            || c.variant.as_ref().is_ok_and(|v| {
                !v.variant.pipeline.is_clustered()
                    || v.variant.clusters().update == ListUpdate::Rebuild
            })
    }));
}

#[test]
fn a_sequence_matrix_reports_its_animations_and_merges_them() {
    let out = scratch("sequence_matrix");
    let dir = out.join("run");
    let ran = cli([
        "matrix",
        "--variants",
        "forward_plus",
        "forward_plus_static_dynamic",
        "--scenes",
        "one_light",
        "--size",
        "64x36",
        "--sweep",
        "lights=16",
        "--sequence",
        "3",
        "--moving",
        "0.5",
        "--still-camera",
    ])
    .arg("--out")
    .arg(&dir)
    .run();
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
    let results = clusterlab::matrix::Results::load(&dir).unwrap();
    assert_eq!(results.cells.len(), 2, "no naive baseline for sequences");
    let sd = results
        .cells
        .iter()
        .find(|c| c.spec.variant == "forward_plus_static_dynamic")
        .unwrap();
    let summary = sd.sequence_summary.as_ref().expect("a sequence summary");
    assert!(summary.exact && summary.frames == 3);
    assert!(
        sd.spec
            .rebuild_cell
            .as_deref()
            .is_some_and(|id| id.starts_with("forward_plus@"))
    );
    let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
    assert!(html.contains("<h2>Sequences</h2>"));
    for c in &results.cells {
        for file in [&c.images.animation, &c.images.frames_plot] {
            let file = file.as_ref().expect("written");
            assert!(
                dir.join(file).is_file() && html.contains(file.as_str()),
                "{file}"
            );
        }
    }
    let merged = out.join("merged");
    let ran = cli(["merge"]).arg(&dir).arg("--out").arg(&merged).run();
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
    let animation = sd.images.animation.as_ref().unwrap();
    assert_eq!(
        std::fs::read(merged.join(animation)).unwrap(),
        std::fs::read(dir.join(animation)).unwrap()
    );
}
