//! The command line as README describes it: `validate` (one line per variant, exit code 1
//! on any failure), `explain` (every field and choice of the schema), `wgsl --pass` (that
//! pass, as the library composes it), `scenes` (every built-in scene with its defaults) and
//! `stress FILTER --json` (exit code 1 when a check fails), and `CLUSTERLAB_TIMING` with the
//! `timing_source` it chooses.

use std::path::Path;

use crate::common::{Ran, cli};

use clusterlab::compose::{self, Composer};

#[test]
fn validate_prints_one_line_per_variant_and_fails_on_any_bad_one() {
    let files = clusterlab::variant::find_files(Path::new("variants")).expect("variants/");
    let Ran {
        code,
        stdout: out,
        stderr: err,
    } = cli(["validate"]).run();
    assert_eq!(code, Some(0), "{out}{err}");
    let lines: Vec<&str> = out.lines().collect();
    // One `ok` line per file, then the summary.
    assert_eq!(lines.len(), files.len() + 1, "{out}");
    for file in &files {
        let name = file.file_stem().unwrap().to_string_lossy();
        let line = lines
            .iter()
            .find(|l| l.split_whitespace().nth(1) == Some(&*name))
            .unwrap_or_else(|| panic!("no line for {name}: {out}"));
        assert!(line.starts_with("ok "), "{line}");
    }
    assert_eq!(
        lines.last().copied(),
        Some(format!("{n} variants: {n} ok, 0 failed", n = files.len()).as_str())
    );

    // A bad file among good ones: the good one is still validated, the bad one is named
    // with its place, and the exit code is 1.
    let bad = "tests/bad_variants/unknown_field.ron";
    let Ran {
        code, stdout: out, ..
    } = cli(["validate", "variants/forward_plus.ron", bad]).run();
    assert_eq!(code, Some(1), "{out}");
    assert!(
        out.lines().any(|l| l.starts_with("ok    forward_plus")),
        "{out}"
    );
    assert!(out.contains(&format!("FAIL  {bad}")), "{out}");
    assert!(out.contains(&format!("{bad}:")), "no place in {out}");
    assert!(out.ends_with("2 variants: 1 ok, 1 failed\n"), "{out}");
}

/// Every property name and every enum choice the schema holds, at any depth.
fn schema_words(v: &serde_json::Value, fields: &mut Vec<String>, choices: &mut Vec<String>) {
    match v {
        serde_json::Value::Object(m) => {
            if let Some(serde_json::Value::Object(props)) = m.get("properties") {
                fields.extend(props.keys().cloned());
            }
            for key in ["enum", "const"] {
                match m.get(key) {
                    Some(serde_json::Value::Array(a)) => {
                        choices.extend(a.iter().filter_map(|c| c.as_str().map(String::from)))
                    }
                    Some(serde_json::Value::String(c)) => choices.push(c.clone()),
                    _ => {}
                }
            }
            for child in m.values() {
                schema_words(child, fields, choices);
            }
        }
        serde_json::Value::Array(a) => {
            for child in a {
                schema_words(child, fields, choices);
            }
        }
        _ => {}
    }
}

#[test]
fn explain_names_every_field_and_every_choice_of_the_schema() {
    let Ran {
        code,
        stdout: out,
        stderr: err,
    } = cli(["explain"]).run();
    assert_eq!(code, Some(0), "{err}");
    let (mut fields, mut choices) = (Vec::new(), Vec::new());
    schema_words(&clusterlab::explain::schema(), &mut fields, &mut choices);
    assert!(!fields.is_empty() && !choices.is_empty());
    // A field is explained as `name: Type`; a property that is an enum choice with fields
    // (externally tagged) as `Name(field: Type)`.
    for f in &fields {
        assert!(
            out.contains(&format!("{f}:")) || out.contains(&format!("{f}(")),
            "explain does not explain `{f}`"
        );
    }
    for c in &choices {
        assert!(out.contains(c.as_str()), "explain does not list `{c}`");
    }
}

#[test]
fn wgsl_pass_prints_that_pass_as_the_library_composes_it() {
    let path = "variants/forward_plus.ron";
    let v = clusterlab::variant::load(Path::new(path)).expect("variant");
    let composer = Composer::default();
    let passes = compose::passes(&v.variant);
    for pass in &passes {
        let Ran {
            code,
            stdout: out,
            stderr: err,
        } = cli(["wgsl", path, "--pass", pass.name()]).run();
        assert_eq!(code, Some(0), "{err}");
        let want = composer.compose(&v.variant, pass).expect("composes").wgsl;
        let header = format!(
            "// ---- variant `forward_plus`, pass `{}` ----",
            pass.name()
        );
        assert_eq!(out, format!("{header}\n{want}\n"), "{}", pass.name());
    }
    // Without --pass: every pass, in order.
    let Ran { stdout: all, .. } = cli(["wgsl", path]).run();
    let headers: Vec<&str> = all.lines().filter(|l| l.starts_with("// ---- ")).collect();
    assert_eq!(headers.len(), passes.len(), "{headers:?}");
    // A pass the variant does not have: an error that lists the ones it has.
    let Ran {
        code, stderr: err, ..
    } = cli(["wgsl", path, "--pass", "resolve"]).run();
    assert_eq!(code, Some(1));
    let names: Vec<&str> = passes.iter().map(|p| p.name()).collect();
    assert!(err.contains(&names.join(", ")), "{err}");
}

#[test]
fn scenes_lists_every_built_in_scene_with_its_defaults() {
    let Ran {
        code,
        stdout: out,
        stderr: err,
    } = cli(["scenes"]).run();
    assert_eq!(code, Some(0), "{err}");
    for s in clusterlab::scene::SCENES {
        let d = &s.defaults;
        assert!(
            out.contains(&format!("{:<10} {}", s.name, s.description)),
            "{}",
            s.name
        );
        let defaults = format!(
            "default: {}x{}, {} lights (spot fraction {}), radius {}..{}, seed {}, time {}",
            d.width,
            d.height,
            d.lights,
            d.spots,
            d.radius_range.0,
            d.radius_range.1,
            d.seed,
            d.time
        );
        assert!(
            out.contains(&defaults),
            "{}: no `{defaults}` in {out}",
            s.name
        );
    }
}

#[test]
fn stress_json_exits_1_when_a_check_fails_and_0_when_all_pass() {
    let Ran {
        code,
        stdout: out,
        stderr: err,
    } = cli(["stress", "one_light", "--json"]).run();
    assert_eq!(code, Some(0), "{err}");
    let runs: serde_json::Value = serde_json::from_str(&out).expect("JSON on stdout");
    let runs = runs.as_array().expect("a list of runs");
    let listed = clusterlab::stress::cases()
        .into_iter()
        .find(|c| c.name == "one_light")
        .expect("case")
        .variants
        .len();
    assert_eq!(runs.len(), listed);
    assert!(runs.iter().all(|r| r["ok"] == true));
    // No GPU work finishes in a microsecond: every run fails its `renders` check.
    let Ran {
        code, stdout: out, ..
    } = cli(["stress", "one_light", "--json", "--cell-timeout", "1e-6"]).run();
    assert_eq!(code, Some(1));
    let runs: serde_json::Value = serde_json::from_str(&out).expect("JSON on stdout");
    for r in runs.as_array().expect("a list of runs") {
        assert_eq!(r["ok"], false, "{r}");
        assert_eq!(r["checks"][0]["check"], "renders", "{r}");
        assert!(
            r["checks"][0]["detail"]
                .as_str()
                .is_some_and(|d| d.contains("--cell-timeout")),
            "{r}"
        );
    }
}

#[test]
fn clusterlab_timing_chooses_the_timing_source_and_refuses_other_values() {
    let Ran { stdout: report, .. } = cli(["adapters", "--json"]).run();
    let report: serde_json::Value = serde_json::from_str(&report).expect("adapters JSON");
    let chosen = &report["adapters"][report["chosen"].as_u64().expect("an adapter") as usize];
    let software = chosen["device_type"] == "Cpu";
    let has_timestamps = chosen["capabilities"]
        .as_array()
        .expect("capabilities")
        .iter()
        .any(|c| {
            c["name"].as_str().is_some_and(|n| n.contains("timestamp")) && c["present"] == true
        });
    let render = [
        "render",
        "--variant",
        "forward_plus",
        "--scene",
        "one_light",
        "--size",
        "32x18",
        "--json",
    ];
    let source_and_passes = |timing: &str| {
        let Ran {
            code,
            stdout: out,
            stderr: err,
        } = cli(render).envs(&[("CLUSTERLAB_TIMING", timing)]).run();
        assert_eq!(code, Some(0), "CLUSTERLAB_TIMING={timing}: {err}");
        let r: serde_json::Value = serde_json::from_str(&out).expect("render JSON");
        let passes: Vec<String> = r["gpu_ms"]
            .as_object()
            .expect("gpu_ms")
            .keys()
            .cloned()
            .collect();
        (
            r["timing_source"]
                .as_str()
                .expect("timing_source")
                .to_string(),
            passes,
        )
    };
    let timestamps = if has_timestamps {
        "gpu timestamps"
    } else {
        "wall clock"
    };
    let (default, passes) = source_and_passes("");
    // Software adapters' timestamps do not wait for compute work: the wall clock there.
    assert_eq!(default, if software { "wall clock" } else { timestamps });
    let (wall, wall_passes) = source_and_passes("wall");
    assert_eq!(wall, "wall clock");
    let (forced, forced_passes) = source_and_passes("timestamps");
    assert_eq!(forced, timestamps);
    // Each way times the same passes.
    assert_eq!(passes, wall_passes);
    assert_eq!(passes, forced_passes);
    let Ran {
        code, stderr: err, ..
    } = cli(render)
        .envs(&[("CLUSTERLAB_TIMING", "sometimes")])
        .run();
    assert_eq!(code, Some(1));
    assert!(
        err.contains("`sometimes` (from CLUSTERLAB_TIMING)")
            && err.contains("`timestamps` or `wall`"),
        "{err}"
    );
}
