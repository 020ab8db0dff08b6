//! A user's own variant through the whole loop, as README's quick start takes it: validate,
//! stress, matrix beside shipped variants, snapshots reviewed and accepted; a variant added
//! to the tree's `variants/` needs no other edit; a numerical fault fails `stress`, naming
//! the case; long commands say how far they are off a terminal; names suggest the nearest.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::{binary, cli, copy_tree, scratch};

/// Everything a finished process printed: standard output, then standard error.
fn printed(out: &std::process::Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// The lines of README's quick start: the `sh` block under its heading.
fn quick_start() -> Vec<String> {
    let readme = std::fs::read_to_string("README.md").expect("README.md");
    let section = readme
        .split("## Your own variant, through the whole loop")
        .nth(1)
        .expect("README's quick start section");
    let block = section
        .split("```sh\n")
        .nth(1)
        .and_then(|b| b.split("```").next())
        .expect("the quick start's sh block");
    block.lines().map(str::to_string).collect()
}

/// README's quick start, every step, on a new variant in a home folder outside the tree:
/// the binary under test on the PATH in place of `cargo install`, the matrix at a small
/// size. Every step exits 0, and snapshots taken in leave nothing pending.
#[test]
fn readme_quick_start_runs_on_a_new_variant_outside_the_tree() {
    let home = scratch("quick-start");
    let lines = quick_start();
    assert!(lines[0].starts_with("cargo install --path ."), "{lines:?}");
    let mut script = vec!["set -eu".to_string()];
    for line in &lines[1..] {
        // Small: 96x54 frames, where the quick start leaves the matrix its own sizes.
        if line.starts_with("clusterlab matrix") {
            script.push(format!("{line} --size 96x54"));
        } else {
            script.push(line.clone());
        }
        script.push(format!("echo 'step done: {}' >&2", line.replace('\'', "")));
    }
    let bin = binary();
    let path = format!(
        "{}:{}",
        bin.parent().unwrap().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let out = Command::new("sh")
        .arg("-c")
        .arg(script.join("\n"))
        .env("HOME", &home)
        .env("PATH", path)
        .env(clusterlab::gpu::disk_cache::CACHE_VAR, "off")
        .output()
        .expect("sh");
    let printed = printed(&out);
    assert!(out.status.success(), "{printed}");
    assert_eq!(
        printed.matches("step done: ").count(),
        lines.len() - 1,
        "{printed}"
    );
    let study = home.join("my-study");
    for made in [
        "out/matrix/index.html",
        "snapshots/images/my_variant@atrium.snap.png",
        "snapshots/wgsl/users.txt",
    ] {
        assert!(study.join(made).is_file(), "{made} missing:\n{printed}");
    }
    // Taken in, the snapshots stand: a second run finds every one unchanged.
    let again = cli(["snapshot", "--variants", "variants"])
        .dir(&study)
        .run();
    assert_eq!(again.code, Some(0), "{}", again.printed());
    assert!(again.stdout.contains(" 0 pending"), "{}", again.stdout);
    let _ = std::fs::remove_dir_all(&home);
}

/// The tree's snapshot, README and completeness tests, run by this test binary in `tree`.
fn suite_in(tree: &Path) -> (bool, String) {
    let out = Command::new(std::env::current_exe().unwrap())
        .args([
            "compose::composed_wgsl_of_every_distinct_pass",
            "images::every_variant_matches_its_reviewed_image",
            "readme::",
            "completeness::",
        ])
        .current_dir(tree)
        .env("INSTA_WORKSPACE_ROOT", tree)
        .env("INSTA_UPDATE", "no")
        .env(clusterlab::gpu::disk_cache::CACHE_VAR, "off")
        .output()
        .expect("the test binary");
    let printed = printed(&out);
    (
        out.status.success() && printed.contains("test result: ok"),
        printed,
    )
}

/// A copy of the tree gets a new variant file in `variants/` (a shipped one on another grid
/// and slicing, under a new name). The suite fails on it until `clusterlab snapshot` writes
/// its snapshots and regenerates the lists and `--accept` takes them in; then it passes,
/// with no other edit.
#[test]
fn a_variant_added_to_the_tree_needs_only_the_snapshot_flow() {
    let tree = scratch("tree");
    for part in [
        "Cargo.toml",
        "README.md",
        "docs",
        "shaders",
        "snapshots",
        "src",
        "tests",
        "variants",
    ] {
        let from = Path::new(part);
        if from.is_dir() {
            copy_tree(from, &tree.join(part));
        } else {
            std::fs::copy(from, tree.join(part)).unwrap();
        }
    }
    let shipped = std::fs::read_to_string("variants/forward_plus.ron").unwrap();
    let edited = shipped
        .replace("grid: (16, 9, 24)", "grid: (12, 8, 20)")
        .replace("slicing: Exponential", "slicing: Linear");
    assert_ne!(
        edited, shipped,
        "variants/forward_plus.ron changed: edit another field"
    );
    std::fs::write(tree.join("variants/my_forward_plus.ron"), edited).unwrap();
    // The break: the new file alone fails the suite.
    let (ok, printed) = suite_in(&tree);
    assert!(
        !ok,
        "the suite passes with a variant it has no snapshots of:\n{printed}"
    );
    let flow = cli(["snapshot"]).dir(&tree).run();
    assert_eq!(flow.code, Some(0), "{}", flow.printed());
    for pending in [
        "my_forward_plus@atrium.snap.new.png",
        "users.txt",
        "docs/variants.md",
    ] {
        assert!(flow.stdout.contains(pending), "{pending}: {}", flow.stdout);
    }
    let accepted = cli(["snapshot", "--accept"]).dir(&tree).run();
    assert_eq!(accepted.code, Some(0), "{}", accepted.printed());
    let (ok, printed) = suite_in(&tree);
    assert!(ok, "{printed}");
    let _ = std::fs::remove_dir_all(&tree);
}

/// A folder of the user's: a copy of a shipped variant in `variants/`, and a copy of the
/// shaders in `shaders/` (found there at run time) with `edit` made to z-slicing.
fn user_folder(name: &str, edit: Option<(&str, &str)>) -> PathBuf {
    let dir = scratch(name);
    std::fs::create_dir_all(dir.join("variants")).unwrap();
    std::fs::copy(
        "variants/forward_plus.ron",
        dir.join("variants/my_forward_plus.ron"),
    )
    .unwrap();
    copy_tree(Path::new("shaders"), &dir.join("shaders"));
    if let Some((from, to)) = edit {
        let file = dir.join("shaders/clustering/zslice.wesl");
        let text = std::fs::read_to_string(&file).unwrap();
        assert!(text.contains(from), "zslice.wesl no longer has `{from}`");
        std::fs::write(&file, text.replace(from, to)).unwrap();
    }
    dir
}

/// Slices that lose the nearest depths (every depth in slice 0 looked up, and listed, in
/// slice 1) fail `stress --variants`, which names each case and check that caught it and
/// says where it found the shaders; the same variant on the unedited shaders passes. Off a
/// terminal a line per case says how far the run is.
#[test]
fn a_variant_that_loses_the_nearest_slices_fails_stress_naming_the_case() {
    let clamp = "return u32(clamp(k, 0.0, f32(slices - 1u)));";
    let stress = ["stress", "--variants", "variants", "--cases", "near_plane"];
    let sound = user_folder("sound", None);
    let ran = cli(stress).dir(&sound).run();
    assert_eq!(ran.code, Some(0), "{}", ran.printed());
    let faulty = user_folder(
        "faulty",
        Some((clamp, "return u32(clamp(k, 1.0, f32(slices - 1u)));")),
    );
    let ran = cli(stress).dir(&faulty).run();
    assert_eq!(ran.code, Some(1), "{}", ran.printed());
    assert!(
        ran.stderr
            .contains("shaders: shaders (the working folder's shaders/)"),
        "{}",
        ran.stderr
    );
    assert!(
        ran.stdout.contains("lights_straddling_near_plane: light centres on the near plane\n  FAILED my_forward_plus\n         no dropped light:"),
        "{}",
        ran.stdout
    );
    // A line per case, as each ends, with the count and the time left.
    let cases = ran.stderr.lines().filter(|l| l.starts_with('[')).count();
    assert!(cases >= 3, "{}", ran.stderr);
    assert!(
        ran.stderr.contains(&format!("[{cases}/{cases}] ")),
        "{}",
        ran.stderr
    );
    assert!(
        ran.stderr.contains(" left") && ran.stderr.contains("runs, done"),
        "{}",
        ran.stderr
    );
    for dir in [sound, faulty] {
        let _ = std::fs::remove_dir_all(dir);
    }
}

/// `--list` says which cases run a variant and why the others do not: naive forward has no
/// cluster lists for the grid, slicing and boundary cases to check.
#[test]
fn stress_lists_the_runs_a_variant_makes_and_why_others_do_not_apply() {
    let ran = cli([
        "stress",
        "--variants",
        "naive_forward",
        "forward_plus",
        "--list",
    ])
    .run();
    assert_eq!(ran.code, Some(0), "{}", ran.printed());
    let out = ran.stdout;
    assert!(out.contains("grid_1x1x1: one cluster holding every light\n  n/a    naive_forward_1x1x1: the case checks cluster lists: it needs a clustered pipeline\n  runs   forward_plus_1x1x1\n"), "{out}");
    assert!(out.contains("  runs   naive_forward_reversed_z\n"), "{out}");
    let unknown = cli(["stress", "--cases", "no_such_case"]).run();
    assert_eq!(unknown.code, Some(1));
    assert!(
        unknown
            .stderr
            .contains("`clusterlab stress --list` lists them"),
        "{}",
        unknown.stderr
    );
}

/// Off a terminal (a log, CI) the matrix and a study print a line per unit as it ends, with
/// the count and the time left.
#[test]
fn matrix_and_study_print_a_line_per_unit_off_a_terminal() {
    let out = scratch("progress");
    let ran = cli([
        "matrix",
        "--variants",
        "naive_forward",
        "forward_plus",
        "--scenes",
        "one_light",
        "--size",
        "48x27",
        "--frames",
        "1",
        "--out",
    ])
    .arg(out.join("matrix"))
    .run();
    assert_eq!(ran.code, Some(0), "{}", ran.printed());
    assert!(
        ran.stderr.contains("[1/2] naive_forward@one_light"),
        "{}",
        ran.stderr
    );
    assert!(
        ran.stderr.contains("? left") || ran.stderr.contains(" left"),
        "{}",
        ran.stderr
    );
    assert!(
        ran.stderr.contains("[2/2] forward_plus@one_light"),
        "{}",
        ran.stderr
    );
    let ran = cli([
        "study", "cones", "--lights", "16", "--size", "32x18", "--frames", "1", "--out",
    ])
    .arg(out.join("study"))
    .run();
    assert!(ran.stderr.contains("[1/"), "{}", ran.stderr);
    assert!(ran.stderr.contains("; done"), "{}", ran.stderr);
    let _ = std::fs::remove_dir_all(out);
}

/// An unknown variant or scene says where it was looked for and suggests the nearest.
#[test]
fn unknown_names_say_where_they_were_looked_for_and_the_nearest() {
    let ran = cli(["render", "--variant", "forward_plu", "--scene", "atrium"]).run();
    assert_eq!(ran.code, Some(1));
    assert!(
        ran.stderr.contains("no variant `forward_plu`: no file or folder forward_plu, and no forward_plu.ron in variants or ")
            && ran.stderr.contains("nearest: `forward_plus`"),
        "{}",
        ran.stderr
    );
    let ran = cli(["render", "--variant", "forward_plus", "--scene", "atrum"]).run();
    assert_eq!(ran.code, Some(1));
    assert!(
        ran.stderr
            .contains("unknown scene `atrum`; nearest: `atrium`"),
        "{}",
        ran.stderr
    );
}

/// The studies that compare variants run the user's beside their own, named; one that does
/// not compare variants refuses `--variants` rather than ignore it.
#[test]
fn studies_that_compare_variants_run_the_users_beside_their_own() {
    let dir = user_folder("study", None);
    let ran = cli([
        "study",
        "scale",
        "--variants",
        "variants",
        "--lights",
        "64,256",
        "--size",
        "32x18",
        "--frames",
        "1",
        "--out",
        "out",
    ])
    .dir(&dir)
    .run();
    assert_eq!(ran.code, Some(0), "{}", ran.printed());
    let csv = std::fs::read_to_string(dir.join("out/scale.csv")).unwrap();
    let mine = csv
        .lines()
        .filter(|l| l.contains(",my_forward_plus,"))
        .count();
    assert_eq!(mine, 2, "{csv}");
    let refused = cli(["study", "codecs", "--variants", "variants"])
        .dir(&dir)
        .run();
    assert_eq!(refused.code, Some(1));
    assert!(refused.stderr.contains("--variants"), "{}", refused.stderr);
    let _ = std::fs::remove_dir_all(dir);
}

/// Outside the tree, `variants` (the default of `validate` and `matrix`) is the tree's
/// folder: a newcomer's first commands work from any folder.
#[test]
fn the_shipped_variants_are_found_from_any_folder() {
    let dir = scratch("anywhere");
    let ran = cli(["validate"]).dir(&dir).run();
    assert_eq!(ran.code, Some(0), "{}", ran.printed());
    let shipped = clusterlab::variant::find_files(Path::new("variants"))
        .unwrap()
        .len();
    assert!(
        ran.stdout
            .contains(&format!("{shipped} variants: {shipped} ok, 0 failed")),
        "{}",
        ran.stdout
    );
    let _ = std::fs::remove_dir_all(dir);
}
