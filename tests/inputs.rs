//! Bad input on the command line: each case exits with an error that names the bad value,
//! where it came from and what would be valid (snapshotted in `snapshots/errors/input_*`),
//! and no case gives a wrong answer with exit 0.

use crate::common::{cli, scratch};

#[test]
fn bad_values_are_refused_with_what_would_be_valid() {
    let dir = scratch("values");
    let variant = std::fs::canonicalize("variants/forward_plus.ron").unwrap();
    let variant = variant.to_str().unwrap();
    // A variant file of 100 KB (a long description), and one whose near slice ends past
    // the one_light scene's far plane.
    let big = format!(
        "(description: \"{}\", pipeline: NaiveForward)",
        "x".repeat(100_000)
    );
    std::fs::write(dir.join("big.ron"), big).unwrap();
    std::fs::write(
        dir.join("far_near_slice.ron"),
        "(description: \"a near slice that ends past the far plane\", \
         pipeline: ClusteredForward, depth_prepass: true, \
         clusters: (slicing: NearSliceThenExponential(near_slice_end: 1e6)))",
    )
    .unwrap();
    let render = |extra: &[&str]| {
        let mut args = vec!["render", "--scene", "one_light", "--variant", variant];
        if !extra.contains(&"--size") {
            args.extend(["--size", "32x18"]);
        }
        args.extend_from_slice(extra);
        args.iter().map(|s| s.to_string()).collect::<Vec<_>>()
    };
    let cases: Vec<(&str, Vec<String>, i32)> = vec![
        ("size_too_large", render(&["--size", "99999999999x18"]), 2),
        ("radius_infinite", render(&["--radius", "inf,inf"]), 2),
        ("time_nan", render(&["--time", "nan"]), 2),
        ("time_absurd", render(&["--time", "1e10"]), 2),
        ("frames_zero", render(&["--frames", "0"]), 2),
        (
            "matrix_frames_zero",
            vec!["matrix".into(), "--frames".into(), "0".into()],
            2,
        ),
        (
            "sweep_lights_too_many",
            vec![
                "matrix".into(),
                "--sweep".into(),
                "lights=99999999999999999999999".into(),
            ],
            2,
        ),
        (
            "samples_too_many",
            vec![
                "study".into(),
                "codecs".into(),
                "--samples".into(),
                "10000000000".into(),
            ],
            2,
        ),
        (
            "validate_device",
            vec!["validate".into(), "/dev/zero".into()],
            1,
        ),
        (
            "variant_device",
            vec![
                "render".into(),
                "--scene".into(),
                "one_light".into(),
                "--variant".into(),
                "/dev/zero".into(),
            ],
            1,
        ),
        (
            "variant_too_large",
            vec!["validate".into(), "big.ron".into()],
            1,
        ),
        (
            "out_not_a_folder_of_its_own",
            vec![
                "matrix".into(),
                "--variants".into(),
                variant.into(),
                "--scenes".into(),
                "one_light".into(),
                "--out".into(),
                ".".into(),
            ],
            1,
        ),
        (
            "near_slice_past_far",
            vec![
                "render".into(),
                "--scene".into(),
                "one_light".into(),
                "--size".into(),
                "32x18".into(),
                "--variant".into(),
                "far_near_slice.ron".into(),
            ],
            1,
        ),
    ];
    let mut settings = insta::Settings::clone_current();
    settings.set_snapshot_path("../snapshots/errors");
    settings.set_prepend_module_to_snapshot(false);
    settings.bind(|| {
        for (name, args, code) in &cases {
            let (got, text) = cli(args).dir(&dir).run().outcome();
            assert_eq!(got, Some(*code), "{name}: {text}");
            insta::assert_snapshot!(format!("input_{name}"), text.replace(variant, "VARIANT"));
        }
    });
}

#[test]
fn a_debug_view_reports_no_error_figure() {
    let dir = scratch("debug");
    let variant = std::fs::canonicalize("variants/forward_plus.ron").unwrap();
    let render = |extra: &[&str]| {
        let mut args = vec!["render", "--scene", "one_light", "--size", "32x18"];
        args.extend(["--debug-view", "lights-per-cluster"]);
        args.extend(extra);
        cli(args).arg("--variant").arg(&variant).dir(&dir).run()
    };
    let out = render(&["--json"]);
    assert_eq!(out.code, Some(0), "{}", out.stderr);
    let report: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
    assert!(report["error"].is_null(), "{}", report["error"]);
    // And the summary shows no error columns for it.
    let out = render(&[]);
    let text = &out.stdout;
    assert_eq!(out.code, Some(0), "{}", out.stderr);
    assert!(!text.contains("PSNR") && !text.contains("max8"), "{text}");
}

#[test]
fn identities_are_unique_and_merges_refuse_what_they_would_lose() {
    let dir = scratch("identities");
    let text = std::fs::read_to_string("variants/naive_forward.ron").unwrap();
    for folder in ["a", "b"] {
        std::fs::create_dir_all(dir.join(folder)).unwrap();
        std::fs::write(dir.join(folder).join("dup.ron"), &text).unwrap();
    }
    let tiny = [
        "--scenes",
        "one_light",
        "--size",
        "16x9",
        "--frames",
        "1",
        "--warmup",
        "0",
    ];
    let matrix = |variants: &[&str], out: &str| {
        let mut args = vec!["matrix", "--variants"];
        args.extend_from_slice(variants);
        args.extend_from_slice(&tiny);
        args.extend(["--out", out]);
        cli(&args).dir(&dir).run().outcome()
    };
    let mut settings = insta::Settings::clone_current();
    settings.set_snapshot_path("../snapshots/errors");
    settings.set_prepend_module_to_snapshot(false);
    settings.bind(|| {
        // Two files named alike in two folders: refused, naming both.
        let (code, text) = matrix(&["a/dup.ron", "b/dup.ron"], "dup");
        assert_eq!(code, Some(1), "{text}");
        insta::assert_snapshot!("input_same_named_variants", text);
        // The same file twice is one variant.
        let (code, text) = matrix(&["a/dup.ron", "a/../a/dup.ron"], "one");
        assert_eq!(code, Some(0), "{text}");

        let (code, text) = matrix(&["a/dup.ron"], "first");
        assert_eq!(code, Some(0), "{text}");
        let (code, text) = matrix(&["a/dup.ron"], "second");
        assert_eq!(code, Some(0), "{text}");
        let (code, text) = cli(["merge", "first", "first/", "--out", "merged"])
            .dir(&dir)
            .run()
            .outcome();
        assert_eq!(code, Some(1), "{text}");
        insta::assert_snapshot!("input_merge_with_itself", text);
        let (code, text) = cli(["merge", "first", "second", "--out", "merged"])
            .dir(&dir)
            .run()
            .outcome();
        assert_eq!(code, Some(1), "{text}");
        insta::assert_snapshot!("input_merge_overlapping", text);
    });
    // Told which copy to keep, the merge keeps that one.
    let wall = |folder: &str| {
        let r: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join(folder).join("results.json")).unwrap())
                .unwrap();
        assert_eq!(r["cells"].as_array().unwrap().len(), 1, "{folder}");
        r["cells"][0]["wall_ms"].clone()
    };
    // Two runs' wall times can agree to the microsecond (they did through OpenGL): give the
    // second run's cell a wall time of its own, so the copies are told apart.
    let second = dir.join("second/results.json");
    let mut r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&second).unwrap()).unwrap();
    let ms = r["cells"][0]["wall_ms"].as_f64().unwrap();
    r["cells"][0]["wall_ms"] = serde_json::json!(ms + 1000.0);
    std::fs::write(&second, serde_json::to_vec(&r).unwrap()).unwrap();
    assert_ne!(wall("first"), wall("second"));
    for (prefer, from) in [("first", "first"), ("last", "second")] {
        let out = format!("merged-{prefer}");
        let (code, text) = cli([
            "merge", "first", "second", "--prefer", prefer, "--out", &out,
        ])
        .dir(&dir)
        .run()
        .outcome();
        assert_eq!(code, Some(0), "{text}");
        assert_eq!(wall(&out), wall(from), "--prefer {prefer}");
    }
}

#[test]
fn a_baseline_from_another_adapter_is_said_to_be_one() {
    let dir = scratch("baseline");
    let tiny = [
        "matrix",
        "--variants",
        "naive_forward",
        "--scenes",
        "one_light",
        "--size",
        "16x9",
        "--frames",
        "1",
        "--warmup",
        "0",
    ];
    let variants = std::fs::canonicalize("variants").unwrap();
    let with = |extra: &[&str]| {
        let mut args: Vec<String> = tiny.iter().map(|s| s.to_string()).collect();
        args[2] = variants.join("naive_forward.ron").display().to_string();
        args.extend(extra.iter().map(|s| s.to_string()));
        args
    };
    let args = with(&["--out", "base"]);
    let (code, text) = cli(&args).dir(&dir).run().outcome();
    assert_eq!(code, Some(0), "{text}");
    // The same adapter: no warning.
    let args = with(&["--out", "again", "--baseline", "base"]);
    let (code, text) = cli(&args).dir(&dir).run().outcome();
    assert_eq!(code, Some(0), "{text}");
    assert!(!text.contains("warning"), "{text}");
    // The baseline's adapter renamed, as if it ran elsewhere: the run says so.
    let path = dir.join("base").join("results.json");
    let mut r: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    r["provenance"][0]["adapter"]["name"] = "Another GPU".into();
    std::fs::write(&path, serde_json::to_vec(&r).unwrap()).unwrap();
    let args = with(&["--out", "again", "--baseline", "base"]);
    let (code, text) = cli(&args).dir(&dir).run().outcome();
    assert_eq!(code, Some(0), "{text}");
    assert!(
        text.contains("warning: the baseline ran on Another GPU")
            && text.contains("different adapters"),
        "{text}"
    );
}

/// A RON error on a very long line (a file written on one line) shows the place, not the
/// whole line: 60 characters either side.
#[test]
fn an_error_on_a_long_line_shows_the_place_not_the_line() {
    let dir = scratch("long-line");
    let text = format!(
        "(description: \"{}\", pipeline: NaiveForwardd)",
        "x".repeat(60_000)
    );
    let file = dir.join("long.ron");
    std::fs::write(&file, text).unwrap();
    let (ok, printed) = cli(["validate", file.to_str().unwrap()]).run().succeeded();
    assert!(!ok);
    assert!(printed.contains("NaiveForwardd"), "{printed}");
    assert!(printed.len() < 2000, "{} bytes printed", printed.len());
    let _ = std::fs::remove_dir_all(&dir);
}
