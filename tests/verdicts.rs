//! A verdict in every run: a group's cells compared round by round decide that copies of
//! one variant tie and that a clearly slower variant is slower; where the rounds do not
//! decide, the run says which flags would; a machine starved of CPU still decides or says
//! so; and a cell timed in another run is never ranked against this run's.

use std::path::{Path, PathBuf};

use crate::common::{cli, scratch};
use clusterlab::matrix::{CellRecord, Rank, Results};

/// Two copies of forward_plus and one made clearly slower (one cluster: every light in
/// every pixel's list, 46 times the evaluations, a frame 3 to 6 times as long at 64x36),
/// in `dir`.
fn variants(dir: &Path) -> Vec<PathBuf> {
    let fast = std::fs::read_to_string("variants/forward_plus.ron").unwrap();
    let slow = fast.replace("grid: (16, 9, 24)", "grid: (1, 1, 1)");
    assert_ne!(slow, fast, "forward_plus.ron no longer names its grid");
    let files = [("twin_a", &fast), ("twin_b", &fast), ("one_cluster", &slow)];
    files
        .iter()
        .map(|(name, text)| {
            let path = dir.join(format!("{name}.ron"));
            std::fs::write(&path, text).unwrap();
            path
        })
        .collect()
}

/// `matrix` on the atrium at 64x36 with `extra` flags; its results and what it printed.
fn matrix(dir: &Path, out: &str, extra: &[&str]) -> (Results, String) {
    let files = variants(dir);
    let out = dir.join(out);
    let mut args: Vec<String> = vec!["matrix".into(), "--variants".into()];
    args.extend(files.iter().map(|f| f.to_string_lossy().into_owned()));
    args.extend(
        ["--scenes", "atrium", "--size", "64x36", "--out"]
            .iter()
            .map(|s| s.to_string()),
    );
    args.push(out.to_string_lossy().into_owned());
    args.extend(extra.iter().map(|s| s.to_string()));
    let (ok, text) = cli(&args).run().succeeded();
    assert!(ok, "{text}");
    (Results::load(&out).unwrap(), text)
}

fn cell<'a>(r: &'a Results, variant: &str) -> &'a CellRecord {
    r.cells
        .iter()
        .find(|c| c.spec.variant == variant)
        .unwrap_or_else(|| panic!("no {variant} cell"))
}

/// The verdict lines a run printed, one per group.
fn verdicts(text: &str) -> Vec<&str> {
    text.lines()
        .filter(|l| l.starts_with("verdict: "))
        .collect()
}

/// Copies of one variant tie (their ratio's 95% interval within 10% of 1, round by round)
/// once enough rounds are allowed; the variant with one cluster is slower at the default
/// settings; with too few rounds for an interval (the deliberate break) nothing is decided
/// and the run names the flags that would decide it.
#[test]
fn copies_tie_a_slower_variant_is_slower_and_an_open_verdict_says_what_would_decide_it() {
    let dir = scratch("verdicts");
    // Default settings: the slow variant is decided slower.
    let (r, text) = matrix(&dir, "default", &[]);
    assert_eq!(cell(&r, "one_cluster").rank, Some(Rank::Slower), "{text}");
    // Naive forward, decided slower, or too slow for its budget's rounds on a busy machine.
    let naive = cell(&r, "naive_forward").rank;
    assert!(
        matches!(naive, Some(Rank::Slower | Rank::SlowerEachRound)),
        "{naive:?}: {text}"
    );
    assert_eq!(verdicts(&text).len(), 1, "{text}");

    // Rounds enough for the tie.
    let (r, text) = matrix(
        &dir,
        "long",
        &["--max-frames", "300", "--budget-ms", "60000"],
    );
    let mut twins = [cell(&r, "twin_a").rank, cell(&r, "twin_b").rank];
    twins.sort_by_key(|r| *r != Some(Rank::Fastest));
    assert_eq!(
        twins,
        [Some(Rank::Fastest), Some(Rank::TiedWithFastest)],
        "{text}"
    );
    let line = verdicts(&text)[0];
    assert!(
        line.starts_with("verdict: fastest: twin_") && line.contains("tied within 10%: twin_"),
        "{line}"
    );
    assert_eq!(cell(&r, "one_cluster").rank, Some(Rank::Slower));
    let page = std::fs::read_to_string(dir.join("long/index.html")).unwrap();
    assert!(
        page.contains("tied with it (1): twin_"),
        "At a glance names the tie"
    );

    // The break: five rounds hold no interval, so nothing is decided, and the run says
    // which flags would decide it.
    let (r, text) = matrix(&dir, "short", &["--max-frames", "5"]);
    for c in r.cells.iter().filter(|c| c.spec.variant != "naive_forward") {
        assert!(
            matches!(c.rank, Some(Rank::Leads | Rank::Undecided)),
            "{}: {:?}\n{text}",
            c.spec.id,
            c.rank
        );
    }
    let line = verdicts(&text)[0];
    assert!(
        line.starts_with("verdict: undecided: ")
            && line.contains("would decide it: `--max-frames "),
        "{line}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// With every core busy in other processes (three times oversubscribed), a small matrix at
/// the default settings still decides its group, or says which flags would.
#[test]
fn a_starved_machine_still_decides_or_says_what_would() {
    let dir = scratch("verdicts-starved");
    let cores = std::thread::available_parallelism().map_or(2, |n| n.get());
    let mut burners: Vec<_> = (0..2 * cores)
        .map(|_| {
            std::process::Command::new("sh")
                .args(["-c", "while :; do :; done"])
                .spawn()
                .expect("sh")
        })
        .collect();
    let (r, text) = matrix(&dir, "out", &[]);
    for b in &mut burners {
        let _ = b.kill();
        let _ = b.wait();
    }
    assert_eq!(r.failed(), 0, "{text}");
    for line in verdicts(&text) {
        assert!(
            line.starts_with("verdict: fastest: ")
                || line.contains("would decide it: `--max-frames ")
                || line.contains("a near tie: over"),
            "neither a verdict nor what would reach one: {line}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A cell taken from an earlier run (`--reuse`) is not ranked against this run's cells: the
/// cells ranked in a group all share one run and batch, the rest are `other run`.
#[test]
fn a_reused_cell_is_never_ranked_against_a_fresh_one() {
    let dir = scratch("verdicts-reuse");
    let (first, _) = matrix(&dir, "first", &["--frames", "6"]);
    assert!(
        first
            .cells
            .iter()
            .all(|c| c.rank != Some(Rank::NotCompared))
    );
    // An edit to one variant file: that cell runs again, the others are reused.
    let twin_a = dir.join("twin_a.ron");
    let files = variants(&dir);
    let text = std::fs::read_to_string(&twin_a).unwrap();
    std::fs::write(
        &twin_a,
        text.replace("description: \"", "description: \"edited: "),
    )
    .unwrap();
    let out = dir.join("second");
    let mut args: Vec<String> = vec!["matrix".into(), "--variants".into()];
    args.extend(files.iter().map(|f| f.to_string_lossy().into_owned()));
    for a in [
        "--scenes", "atrium", "--size", "64x36", "--frames", "6", "--out",
    ] {
        args.push(a.into());
    }
    args.push(out.to_string_lossy().into_owned());
    args.push("--reuse".into());
    args.push(dir.join("first").to_string_lossy().into_owned());
    let (ok, printed) = cli(&args).run().succeeded();
    assert!(ok, "{printed}");
    let r = Results::load(&out).unwrap();
    assert!(!r.reused.is_empty() || r.cells.iter().any(|c| c.reused_from.is_some()));
    let ranked: Vec<&CellRecord> = r
        .cells
        .iter()
        .filter(|c| !matches!(c.rank, None | Some(Rank::NotCompared)))
        .collect();
    let keys: std::collections::BTreeSet<_> = ranked.iter().map(|c| (c.run, c.batch)).collect();
    assert_eq!(
        keys.len(),
        1,
        "ranked across runs or batches: {keys:?}\n{printed}"
    );
    let fresh = cell(&r, "twin_a");
    assert!(fresh.reused_from.is_none());
    let reused: Vec<_> = r.cells.iter().filter(|c| c.reused_from.is_some()).collect();
    assert!(!reused.is_empty(), "{printed}");
    // The fresh cell and the reused ones are never both ranked.
    let fresh_ranked = fresh.rank != Some(Rank::NotCompared);
    let reused_ranked = reused.iter().any(|c| c.rank != Some(Rank::NotCompared));
    assert!(!(fresh_ranked && reused_ranked), "{printed}");
    assert!(printed.contains("not compared"), "{printed}");
    let _ = std::fs::remove_dir_all(&dir);
}
