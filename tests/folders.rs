//! A run owns its result folder: interrupted runs (SIGINT, SIGKILL, at several points) leave
//! the previous complete run as it was, two runs at once into one folder are not mixed (one
//! is refused, naming the other), and after every run the folder holds exactly the images its
//! `results.json` references, all of that run.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::Duration;

use crate::common::{cli, scratch};

/// A matrix of every variant on one_light at `size` into `out` (about 40 cells: long
/// enough to interrupt, short enough for a test).
fn start(dir: &Path, size: &str, out: &str) -> Child {
    start_timing(dir, size, out, "1")
}

/// A run with `frames` timed frames per cell (more: a longer run to interrupt).
fn start_timing(dir: &Path, size: &str, out: &str, frames: &str) -> Child {
    let variants = std::fs::canonicalize("variants").unwrap();
    cli([
        "matrix",
        "--scenes",
        "one_light",
        "--size",
        size,
        "--frames",
        frames,
        "--warmup",
        "0",
    ])
    .arg("--variants")
    .arg(&variants)
    .arg("--out")
    .arg(out)
    .dir(dir)
    .spawn()
}

/// Width and height of a PNG file.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let word = |at: usize| u32::from_be_bytes(bytes[at..at + 4].try_into().unwrap());
    (word(16), word(20))
}

/// Check that `out` holds one complete run of image size `size`: every image results.json
/// references exists and has that size, no image is unreferenced, and the report files are
/// there. Returns the number of cells.
fn check_complete(out: &Path, size: (u32, u32)) -> usize {
    let results: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("results.json")).expect("results.json"))
            .expect("valid JSON");
    let cells = results["cells"].as_array().expect("cells");
    let mut referenced = BTreeSet::new();
    for c in cells {
        assert_eq!(c["params"]["width"], size.0, "{}", c["id"]);
        for key in ["image", "heat", "debug"] {
            if let Some(file) = c["images"][key].as_str() {
                let path = out.join(file);
                assert_eq!(
                    png_size(&path),
                    size,
                    "{} is from another run",
                    path.display()
                );
                referenced.insert(PathBuf::from(file));
            }
        }
    }
    let present: BTreeSet<PathBuf> = std::fs::read_dir(out.join("images"))
        .expect("images/")
        .map(|e| Path::new("images").join(e.unwrap().file_name()))
        .collect();
    assert_eq!(
        present, referenced,
        "images nothing references, or referenced and missing"
    );
    for f in ["results.csv", "index.html"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    cells.len()
}

#[test]
fn interrupted_runs_leave_the_previous_run_whole() {
    let dir = scratch("interrupt");
    let out = dir.join("out");
    let status = start(&dir, "16x9", "out").wait().unwrap();
    assert!(status.success());
    let cells = check_complete(&out, (16, 9));
    // A bigger run into the same folder, stopped part way: by SIGINT and SIGKILL, early
    // (planning, first cells) and late (most cells written).
    for (signal, after_ms) in [("INT", 300), ("KILL", 300), ("INT", 2500), ("KILL", 2500)] {
        // Long enough (about 40 frames a cell) that the late signals land mid-run.
        let mut child = start_timing(&dir, "24x14", "out", "40");
        std::thread::sleep(Duration::from_millis(after_ms));
        let finished = child.try_wait().unwrap().is_some();
        Command::new("kill")
            .args([&format!("-{signal}"), &child.id().to_string()])
            .status()
            .unwrap();
        let output = child.wait_with_output().unwrap();
        assert!(
            !finished && !output.status.success(),
            "SIG{signal} after {after_ms} ms: the run ended first ({}); stderr: {}",
            output.status,
            String::from_utf8_lossy(&output.stderr)
        );
        assert_eq!(
            check_complete(&out, (16, 9)),
            cells,
            "after SIG{signal} at {after_ms} ms"
        );
    }
    // The next run takes over the killed runs' lock, removes their staging folders, and
    // replaces the folder whole.
    let status = start(&dir, "24x14", "out").wait().unwrap();
    assert!(status.success());
    check_complete(&out, (24, 14));
    let leftovers: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "out")
        .collect();
    assert!(
        leftovers.is_empty(),
        "left beside the folder: {leftovers:?}"
    );
}

#[test]
fn two_runs_at_once_into_one_folder_are_not_mixed() {
    let dir = scratch("concurrent");
    let out = dir.join("out");
    let first = start(&dir, "16x9", "out");
    std::thread::sleep(Duration::from_millis(200));
    let second = start(&dir, "24x14", "out").wait_with_output().unwrap();
    let first = first.wait_with_output().unwrap();
    assert!(
        first.status.success(),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );
    assert_eq!(second.status.code(), Some(1));
    let text = String::from_utf8_lossy(&second.stderr);
    assert!(
        text.contains("is in use by process") && text.contains("matrix"),
        "{text}"
    );
    check_complete(&out, (16, 9));
}
