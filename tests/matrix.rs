//! The matrix command end to end, on tiny cells: a broken variant fails its cells and not
//! the others, every report file is written, shards merge back into the whole, and a
//! baseline run shows each cell's change.

use std::path::{Path, PathBuf};

use crate::common::{self, cli, scratch};

use clusterlab::compose::ShaderSource;
use clusterlab::matrix::{Results, compare_runs};

/// A folder with a good variant and a broken one.
fn variants(dir: &Path) -> PathBuf {
    let v = dir.join("variants");
    std::fs::create_dir_all(&v).unwrap();
    std::fs::copy("variants/forward_plus.ron", v.join("forward_plus.ron")).unwrap();
    std::fs::write(
        v.join("broken.ron"),
        "(\n    description: \"broken\",\n    pipeline: Sideways,\n)\n",
    )
    .unwrap();
    v
}

fn run(variants: &Path, out: &Path, extra: &[&str]) -> (Option<i32>, String) {
    let mut args = vec![
        "matrix",
        "--variants",
        variants.to_str().unwrap(),
        "--scenes",
        "one_light,empty",
        "--size",
        "48x27",
        "--sweep",
        "lights=1,3",
        "--frames",
        "2",
        "--warmup",
        "0",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    cli(&args).run().outcome()
}

fn ids(r: &Results) -> Vec<String> {
    let mut v: Vec<String> = r.cells.iter().map(|c| c.spec.id.clone()).collect();
    v.sort();
    v
}

#[test]
fn a_broken_variant_fails_its_cells_and_the_rest_run_and_report() {
    let dir = scratch("run");
    let v = variants(&dir);
    let out = dir.join("all");
    let (code, text) = run(&v, &out, &[]);
    assert_eq!(code, Some(1), "a failed cell makes exit code 1\n{text}");
    assert!(text.contains("FAILED"), "{text}");

    let r = Results::load(&out).expect("results.json");
    // 2 variants x 2 scenes x 2 light counts, plus a naive baseline for each of 4 groups.
    assert_eq!(r.cells.len(), 12, "{:?}", ids(&r));
    let broken: Vec<_> = r
        .cells
        .iter()
        .filter(|c| c.spec.variant == "broken")
        .collect();
    assert_eq!(broken.len(), 4);
    for c in &broken {
        let why = c.failure.as_deref().expect("broken cells fail");
        assert!(why.contains("broken.ron:3:15"), "{why}");
    }
    for c in r.cells.iter().filter(|c| c.spec.variant != "broken") {
        assert!(c.ok(), "{}: {:?}", c.spec.id, c.failure);
        assert!(c.speedup_vs_naive.is_some(), "{}", c.spec.id);
        let e = c.error.as_ref().unwrap();
        assert!(e.max_abs_8bit <= 1, "{}: {e:?}", c.spec.id);
        assert_eq!(
            (c.frames, c.warmup_frames, c.frame_without_lights),
            (2, 0, false)
        );
        for image in [&c.images.image, &c.images.heat].into_iter().flatten() {
            assert!(out.join(image).is_file(), "{image}");
        }
    }
    speedups_and_pareto_front_follow_from_the_cells(&r, &text);
    let p = &r.provenance[0];
    assert_eq!(p.variant_files["forward_plus"].sha256.len(), 64);
    assert!(!p.git_revision.is_empty() && !p.date.is_empty());
    for file in ["results.json", "results.csv", "index.html", "plots"] {
        assert!(out.join(file).exists(), "{file}");
    }
    let rows = csv::Reader::from_path(out.join("results.csv"))
        .unwrap()
        .records()
        .count();
    assert_eq!(rows, 12);
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(html.contains("forward_plus") && html.contains("Sideways"));
    at_a_glance_names_each_groups_fastest_exact_cell(&r, &html);
    let leftovers: Vec<_> = walk(&out)
        .into_iter()
        .filter(|p| p.to_string_lossy().contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The median of a cell's frames over its rounds.
fn round_median(c: &clusterlab::matrix::CellRecord) -> f64 {
    clusterlab::measure::median(c.round_ms.iter().flatten().copied().collect())
}

/// The verdict of `a` against `b`, round by round.
fn paired(
    a: &clusterlab::matrix::CellRecord,
    b: &clusterlab::matrix::CellRecord,
) -> clusterlab::measure::Verdict {
    use clusterlab::measure::{Paired, Verdict};
    Paired::of(&a.round_ms, &b.round_ms).map_or(Verdict::Undecided, |p| p.verdict)
}

/// The report's "fastest exact" of each group is the quickest of its cells within 1 LSB of
/// the group's truth with no light dropped, found here from the cells' own rounds: named
/// alone where every other exact cell is decided against it, as leading and undecided
/// otherwise.
fn at_a_glance_names_each_groups_fastest_exact_cell(r: &Results, html: &str) {
    use clusterlab::measure::Verdict;
    let glance = html
        .split("<h2>At a glance</h2>")
        .nth(1)
        .and_then(|t| t.split("</table>").next())
        .expect("an At a glance table");
    let mut groups: Vec<String> = r.cells.iter().map(|c| c.spec.group()).collect();
    groups.dedup();
    for group in groups {
        let exact: Vec<_> = r
            .cells
            .iter()
            .filter(|c| c.spec.group() == group && c.exact_to_truth())
            .collect();
        let row = glance
            .split("<tr>")
            .find(|row| row.starts_with(&format!("<td>{group}")))
            .unwrap_or_else(|| panic!("no row for {group}"));
        let picked = row.split("<td>").nth(3).unwrap_or_default();
        let Some(fastest) = exact
            .iter()
            .min_by(|a, b| round_median(a).total_cmp(&round_median(b)))
        else {
            assert!(picked.starts_with("-<"), "{group}: `{picked}`");
            continue;
        };
        let open = exact
            .iter()
            .any(|o| o.spec.id != fastest.spec.id && paired(o, fastest) == Verdict::Undecided);
        let want = if open {
            format!("undecided: {} leads (", fastest.spec.variant)
        } else {
            format!("{} (", fastest.spec.variant)
        };
        assert!(
            picked.starts_with(&want),
            "{group}: the report picks `{picked}`, not `{want}...`"
        );
    }
}

/// Each speed-up is the median over shared rounds of naive forward's frame over the cell's,
/// rounded to 3 decimals; the front is the group's cells that no other is decided faster
/// than and at least as faithful as (or tied with and more faithful than), undecided where
/// an undecided cell is at least as faithful; the printed table marks them `*` and `?`.
/// Recomputed here from the cells' own rounds and errors.
fn speedups_and_pareto_front_follow_from_the_cells(r: &Results, printed: &str) {
    use clusterlab::matrix::Front;
    use clusterlab::measure::{Paired, Verdict};
    let round3 = |x: f64| (x * 1000.0).round() / 1000.0;
    let groups: std::collections::BTreeSet<String> =
        r.cells.iter().map(|c| c.spec.group()).collect();
    assert_eq!(groups.len(), 4);
    for g in &groups {
        let cells: Vec<_> = r
            .cells
            .iter()
            .filter(|c| &c.spec.group() == g && c.ok())
            .collect();
        let naive = cells
            .iter()
            .find(|c| c.spec.variant == "naive_forward")
            .expect("a naive cell");
        for c in &cells {
            let p = Paired::of(&naive.round_ms, &c.round_ms).expect("shared rounds");
            assert_eq!(c.speedup_vs_naive, Some(round3(p.ratio)), "{}", c.spec.id);
            let e = c.fidelity_rmse().unwrap();
            let mut front = Front::On;
            for o in cells.iter().filter(|o| o.spec.id != c.spec.id) {
                let eo = o.fidelity_rmse().unwrap();
                let v = paired(o, c);
                if (v == Verdict::Faster && eo <= e) || (v == Verdict::Tie && eo < e) {
                    front = Front::Dominated;
                    break;
                }
                if v == Verdict::Undecided && eo <= e {
                    front = Front::Undecided;
                }
            }
            assert_eq!(c.front, Some(front), "{}", c.spec.id);
            // The table's row of the cell, under its group's heading.
            let section = printed
                .split(&format!("\n{g}\n"))
                .nth(1)
                .unwrap_or_else(|| panic!("no table for {g}"));
            let row = section
                .lines()
                .find(|l| {
                    // The mark's column, then the variant's name.
                    l.get(1..).is_some_and(|rest| {
                        rest.trim_start()
                            .starts_with(&format!("{} ", c.spec.variant))
                    })
                })
                .unwrap_or_else(|| panic!("no row for {} under {g}", c.spec.variant));
            let mark = match front {
                Front::On => '*',
                Front::Undecided => '?',
                Front::Dominated => ' ',
            };
            assert!(row.starts_with(mark), "{row}");
        }
        // Somebody is on the front or may be.
        assert!(
            cells
                .iter()
                .any(|c| matches!(c.front, Some(Front::On | Front::Undecided))),
            "{g}"
        );
    }
}

/// Run `matrix ARGS` on one_light (48x27, one frame) into `out` with `env` set: the exit
/// code is 1, the cells `fails` picks fail with a message holding every one of `says`, and
/// every other cell runs; with `refused`, the adapter refused them instead: they do not
/// count as failed and the exit code is 0. Returns the results.
fn only_some_cells_fail(
    args: &[&str],
    out: &Path,
    env: (&str, &str),
    fails: impl Fn(&clusterlab::matrix::CellRecord) -> bool,
    (says, refused): (&[&str], bool),
) -> Results {
    let mut all = vec!["matrix"];
    all.extend_from_slice(args);
    all.extend([
        "--scenes",
        "one_light",
        "--size",
        "48x27",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--out",
    ]);
    all.push(out.to_str().unwrap());
    let (code, text) = cli(&all).env(env.0, env.1).run().outcome();
    assert_eq!(code, Some(if refused { 0 } else { 1 }), "{text}");
    let r = Results::load(out).expect("results.json");
    for c in &r.cells {
        if fails(c) {
            let why = c
                .failure
                .as_deref()
                .unwrap_or_else(|| panic!("{} fails", c.spec.id));
            assert!(says.iter().all(|w| why.contains(w)), "{why}");
            assert_eq!(c.refused, refused, "{}: {why}", c.spec.id);
        } else {
            assert!(c.ok(), "{}: {:?}", c.spec.id, c.failure);
        }
    }
    r
}

#[test]
fn a_cell_that_fails_from_a_shader_error_fails_alone_and_one_over_an_adapter_limit_is_refused_alone()
 {
    let dir = scratch("failing");
    // A syntax error in the resolve pass, which only deferred variants compose.
    let shaders = dir.join("shaders");
    common::copy_tree(Path::new("shaders"), &shaders);
    let resolve = shaders.join("passes/resolve.wesl");
    let text = std::fs::read_to_string(&resolve).unwrap();
    std::fs::write(&resolve, text.replacen("fn ", "fn broken ", 1)).unwrap();
    only_some_cells_fail(
        &["--variants", "forward_plus", "clustered_deferred_16x16x24"],
        &dir.join("shader"),
        ("CLUSTERLAB_SHADERS", shaders.to_str().unwrap()),
        |c| c.spec.variant == "clustered_deferred_16x16x24",
        (&["pass `resolve`", "passes/resolve.wesl:"], false),
    );
    // A light buffer over the adapter's (lowered) buffer limit: only the cell with many
    // lights fails, naming the limit.
    let cap = ("CLUSTERLAB_MAX_BUFFER_SIZE", "131072");
    let r = only_some_cells_fail(
        &["--variants", "forward_plus", "--sweep", "lights=1,4096"],
        &dir.join("limit"),
        cap,
        |c| c.spec.params.lights == 4096,
        (&["4096 lights take", "131072 bytes"], true),
    );
    assert_eq!(
        r.cells.len(),
        4,
        "2 light counts x (forward_plus, naive baseline)"
    );
    // A grid whose cluster boxes pass the same limit: only its cell fails, naming it.
    only_some_cells_fail(
        &[
            "--variants",
            "forward_plus",
            "--sweep",
            "grid=4x4x4,64x64x64",
        ],
        &dir.join("grid"),
        cap,
        |c| c.spec.id.contains("64x64x64"),
        (&["grid 64x64x64", "131072 bytes"], true),
    );
    // Rasterised binning's proxies over the limit (8192 proxies of 16 bytes): 64 lights on
    // 64 slices make at most 4096 and fit; 2000 lights, each over several slices, do not,
    // and only that cell fails, naming the limit.
    only_some_cells_fail(
        &[
            "--variants",
            "forward_plus_rasterised",
            "--sweep",
            "lights=64,2000",
            "--sweep",
            "grid=4x4x64",
        ],
        &dir.join("proxies"),
        cap,
        |c| c.spec.variant == "forward_plus_rasterised" && c.spec.params.lights == 2000,
        (&["light proxies this frame take", "131072 bytes"], true),
    );
    // A sample count the adapter lacks (2 on lavapipe, every count above 1 through OpenGL):
    // refused where it would run, and the matrix exits 0.
    let counts = common::gpu().multisample_counts();
    match [2u32, 4, 8].into_iter().find(|n| !counts.contains(n)) {
        Some(n) => {
            let sweep = format!("msaa=1,{n}");
            let point = format!("msaa={n}");
            let r = only_some_cells_fail(
                &["--variants", "forward_plus", "--sweep", &sweep],
                &dir.join("samples"),
                ("CLUSTERLAB_UNUSED", ""),
                |c| c.spec.id.contains(&point),
                (&[&format!("msaa.samples {n}")], true),
            );
            let picked = r
                .cells
                .iter()
                .filter(|c| c.spec.id.contains(&point))
                .count();
            assert!(picked > 0 && r.refused() == picked, "{}", r.tally());
            let tally = format!("0 failed, {picked} refused by the adapter");
            assert!(r.tally().ends_with(&tally), "{}", r.tally());
        }
        None => {
            eprintln!("skipped: this adapter renders every sample count (2, 4, 8): none to refuse")
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

#[test]
fn shards_merge_into_the_whole_and_a_baseline_shows_changes() {
    let dir = scratch("shards");
    let v = dir.join("variants");
    std::fs::create_dir_all(&v).unwrap();
    std::fs::copy("variants/forward_plus.ron", v.join("forward_plus.ron")).unwrap();
    let (a, b, merged) = (dir.join("a"), dir.join("b"), dir.join("merged"));
    assert_eq!(run(&v, &a, &["--shard", "1/2"]).0, Some(0));
    assert_eq!(run(&v, &b, &["--shard", "2/2"]).0, Some(0));
    let (code, text) = cli([
        "merge",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
    ])
    .run()
    .outcome();
    assert_eq!(code, Some(0), "{text}");
    let (ra, rb, rm) = (
        Results::load(&a).unwrap(),
        Results::load(&b).unwrap(),
        Results::load(&merged).unwrap(),
    );
    assert_eq!(rm.cells.len(), 8);
    assert_eq!(ra.cells.len() + rb.cells.len(), 8);
    assert!(ids(&ra).iter().all(|id| !ids(&rb).contains(id)));
    assert_eq!(rm.provenance.len(), 2);
    // Cells compare only with the cells timed in their own rounds: a group split between
    // the shards is compared within one shard (the one with more of it), the others are
    // `other run`; a speed-up needs the group's naive cell among the compared.
    for c in &rm.cells {
        let compared_naive = rm.cells.iter().any(|n| {
            n.spec.variant == "naive_forward"
                && n.spec.group() == c.spec.group()
                && (n.run, n.batch) == (c.run, c.batch)
        });
        let compared = c.rank != Some(clusterlab::matrix::Rank::NotCompared);
        assert_eq!(
            c.speedup_vs_naive.is_some(),
            compared && compared_naive,
            "{}: {:?}",
            c.spec.id,
            c.rank
        );
    }
    let groups: std::collections::BTreeSet<String> =
        rm.cells.iter().map(|c| c.spec.group()).collect();
    for g in groups {
        let ranked: std::collections::BTreeSet<_> = rm
            .cells
            .iter()
            .filter(|c| c.spec.group() == g)
            .filter(|c| c.rank != Some(clusterlab::matrix::Rank::NotCompared))
            .map(|c| (c.run, c.batch))
            .collect();
        assert_eq!(ranked.len(), 1, "{g}: ranked across shards: {ranked:?}");
    }
    for c in &rm.cells {
        assert!(merged.join(c.images.image.as_ref().unwrap()).is_file());
    }

    let (code, text) = run(
        &v,
        &dir.join("again"),
        &["--baseline", merged.join("results.json").to_str().unwrap()],
    );
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("vs baseline"), "{text}");
    let again = Results::load(&dir.join("again")).unwrap();
    assert!(again.cells.iter().all(|c| c.vs_baseline.is_some()));
    // The whole run against it: same cells, same figures; merged shards ran side by side,
    // so the baseline has no one wall time.
    for line in [
        "against the baseline: 8 cells in both (0 only in this run, 0 only in the baseline)\n",
        "  error figures: the same in 8 of 8 cells\n",
        "  counters: the same in 8 of 8 cells\n",
        "  time, this run over the baseline, per cell: median x",
        "(the baseline records no single run's wall time)\n",
    ] {
        assert!(text.contains(line), "{line:?} in\n{text}");
    }
    // A changed error figure, a changed counter and a cell the baseline lacks are each named.
    let mut old = rm.clone();
    let gone = old.cells.pop().unwrap();
    old.cells[0].error.as_mut().unwrap().max_abs_8bit += 2;
    old.cells[1].stats.as_mut().unwrap().light_evals += 1;
    let cmp = compare_runs(&again, &old);
    assert_eq!((cmp.common, cmp.only_here, cmp.only_there), (7, 1, 0));
    assert_eq!(cmp.errors_changed, vec![old.cells[0].spec.id.clone()]);
    assert_eq!(
        cmp.counters_changed.iter().collect::<Vec<_>>(),
        [(&"light_evals".to_string(), &1)]
    );
    let shown = cmp.to_string();
    let different = format!(
        "error figures: the same in 6 of 7 cells; different in 1: {}\n",
        old.cells[0].spec.id
    );
    assert!(shown.contains(&different), "{shown}");
    assert!(
        shown.contains("counters: the same in 6 of 7 cells; different: light_evals in 1\n"),
        "{shown}"
    );
    // Two cells of one group, told apart in both runs: in the same order, then in opposite
    // orders (the verdict did not repeat), then tied in one run.
    let (x, y) = {
        let g = again.cells[0].spec.group();
        let other = again
            .cells
            .iter()
            .skip(1)
            .find(|c| c.spec.group() == g)
            .unwrap();
        (again.cells[0].spec.id.clone(), other.spec.id.clone())
    };
    let timed = |r: &Results, at: [(&str, [f64; 2]); 2]| {
        let mut r = r.clone();
        for c in &mut r.cells {
            c.gpu_ms_interval.clear();
            c.interval_level = None;
            if let Some((_, [lo, hi])) = at.iter().find(|(id, _)| *id == c.spec.id) {
                c.gpu_ms_interval
                    .insert("total".into(), serde_json::json!([lo, hi]));
                c.interval_level = Some(0.98);
            }
        }
        r
    };
    let now = timed(&again, [(&x, [1.0, 2.0]), (&y, [3.0, 4.0])]);
    let same = compare_runs(&now, &timed(&rm, [(&x, [1.5, 2.5]), (&y, [3.0, 4.0])]));
    assert_eq!((same.pairs_apart_in_both, same.pairs_flipped.len()), (1, 0));
    let flipped = compare_runs(&now, &timed(&rm, [(&x, [5.0, 6.0]), (&y, [3.0, 4.0])]));
    assert_eq!(flipped.pairs_flipped, vec![(x.clone(), y.clone())]);
    assert!(
        flipped.to_string().contains("1 called in opposite order"),
        "{flipped}"
    );
    // Within 10% of each other: [3.1 / 3.2, 3.25 / 3.0] = [0.97, 1.08].
    let tied = compare_runs(&now, &timed(&rm, [(&x, [3.1, 3.25]), (&y, [3.0, 3.2])]));
    assert_eq!(
        (tied.pairs_apart_in_both, tied.pairs_tied.1 >= 1),
        (0, true)
    );
    // A run against itself: every cell's [min, max] overlaps its own, and both walls are
    // one; a cell whose frames were far slower does not overlap.
    let itself = compare_runs(&again, &again);
    assert_eq!(itself.spreads_overlap, again.cells.len());
    assert!(itself.to_string().contains(" s (x1.000)\n"), "{itself}");
    let mut slower = again.clone();
    slower.cells[0]
        .gpu_ms_spread
        .insert("total".into(), serde_json::json!([1e6, 2e6]));
    assert_eq!(
        compare_runs(&again, &slower).spreads_overlap,
        again.cells.len() - 1
    );
    let swapped = compare_runs(&old, &again);
    assert_eq!(
        (swapped.only_here, swapped.only_there),
        (0, 1),
        "{}",
        gone.spec.id
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_arguments_are_named() {
    let (code, text) = cli(["matrix", "--sweep", "lights=lots"]).run().outcome();
    assert_eq!(code, Some(2), "{text}");
    assert!(
        text.contains("`lots` in `lights=lots` is not a whole number"),
        "{text}"
    );
    let (code, text) = cli(["matrix", "--scenes", "moon", "--out", "/nonexistent/x"])
        .run()
        .outcome();
    assert_eq!(code, Some(1));
    assert!(text.contains("unknown scene `moon`"), "{text}");
    let (code, text) = cli(["merge", "/nonexistent/results"]).run().outcome();
    assert_eq!(code, Some(1));
    assert!(
        text.contains("/nonexistent/results: no such results file"),
        "{text}"
    );
}

#[test]
fn frames_by_budget_are_the_default_and_every_cell_says_how_many_it_took() {
    let dir = scratch("budget");
    let v = dir.join("variants");
    std::fs::create_dir_all(&v).unwrap();
    std::fs::copy("variants/forward_plus.ron", v.join("forward_plus.ron")).unwrap();
    let out = dir.join("out");
    // A budget no frame spends: cells stop when decided (6 rounds at least) or at the cap.
    let (code, text) = cli([
        "matrix",
        "--variants",
        v.to_str().unwrap(),
        "--scenes",
        "one_light",
        "--size",
        "48x27",
        "--sweep",
        "lights=1,3",
        "--budget-ms",
        "3600000",
        "--max-frames",
        "6",
        "--out",
        out.to_str().unwrap(),
    ])
    .run()
    .outcome();
    assert_eq!(code, Some(0), "{text}");
    assert!(
        text.contains("run: ") && text.contains("pipelines compiled"),
        "{text}"
    );
    let r = Results::load(&out).expect("results.json");
    assert_eq!(r.cells.len(), 4, "{:?}", ids(&r));
    for c in &r.cells {
        assert_eq!(
            c.frames + c.disturbed_frames,
            6,
            "{}: {} frames",
            c.spec.id,
            c.frames
        );
        let cost = c.cost_ms.expect("a cell that ran has its cost");
        assert!(cost.frames > 0.0 && cost.setup > 0.0, "{cost:?}");
    }
    // Frames by budget: a frame without lights first, then no warm-up.
    for c in &r.cells {
        assert_eq!(
            (c.warmup_frames, c.frame_without_lights),
            (0, true),
            "{}",
            c.spec.id
        );
    }
    let p = &r.provenance[0];
    assert!(p.frames.starts_with("by budget"), "{}", p.frames);
    let cost = p.cost.as_ref().expect("the run's cost");
    assert!(
        cost.pipelines.created > 0 && cost.pipelines.reused > 0,
        "{cost:?}"
    );
    assert_eq!(
        cost.timed_frames,
        r.cells.iter().map(|c| c.frames).sum::<u32>()
    );
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    assert!(csv.lines().next().unwrap().contains("frames"), "{csv}");

    // --warmup belongs to exact counts; a budget is at least 1 ms.
    for bad in [&["--warmup", "1"][..], &["--budget-ms", "0"]] {
        let mut args = vec!["matrix", "--scenes", "one_light", "--out"];
        args.push(out.to_str().unwrap());
        args.extend_from_slice(bad);
        let (code, text) = cli(&args).run().outcome();
        assert_eq!(code, Some(2), "{bad:?}: {text}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--reuse`: a rerun on an unchanged tree runs no cell and writes the same results and
/// images; after an edit of the GGX term (in a copy of `shaders/`, which only the GGX
/// variants' composed WGSL holds) exactly the GGX cell runs again; after an edit of the
/// Lambert term exactly the two that shade with it.
#[test]
fn a_rerun_reuses_exactly_the_cells_no_change_touched() {
    let dir = scratch("reuse");
    let run = |shaders: &Path, out: &Path, reuse: Option<&Path>| {
        let mut args = vec![
            "matrix",
            "--variants",
            "forward_plus",
            "forward_plus_ggx",
            "--scenes",
            "atrium",
            "--size",
            "64x36",
            "--frames",
            "1",
            "--warmup",
            "0",
            "--out",
            out.to_str().unwrap(),
        ];
        if let Some(previous) = reuse {
            args.extend(["--reuse", previous.to_str().unwrap()]);
        }
        let (ok, text) = cli(&args)
            .env("CLUSTERLAB_SHADERS", shaders)
            .run()
            .succeeded();
        assert!(ok, "{text}");
        text
    };
    let shipped = common::EditedShaders::of("shading/brdf.wesl", "reuse-shipped", &[]);
    let first = dir.join("first");
    run(shipped.root(), &first, None);
    let again = dir.join("again");
    let text = run(shipped.root(), &again, Some(&first));
    let previous = first.display();
    assert!(
        text.contains(&format!("reused 3 of 3 cells from {previous}; ran 0")),
        "{text}"
    );
    let (a, b) = (
        Results::load(&first).unwrap(),
        Results::load(&again).unwrap(),
    );
    // The same records, each marked as taken from the first run, whose provenance the
    // second keeps beside its own.
    assert_eq!(b.provenance.len(), 2);
    assert_eq!(b.provenance[1].date, a.provenance[0].date);
    let unmarked = |r: &Results| {
        let mut cells = serde_json::to_value(&r.cells).unwrap();
        for cell in cells.as_array_mut().unwrap() {
            let cell = cell.as_object_mut().unwrap();
            cell.remove("run");
            cell.remove("reused_from");
        }
        cells
    };
    assert_eq!(unmarked(&a), unmarked(&b));
    assert!(
        b.cells
            .iter()
            .all(|c| c.run == 1 && c.reused_from.is_some())
    );
    for file in walk(&first.join("images")) {
        let copy = again.join(file.strip_prefix(&first).unwrap());
        assert!(
            std::fs::read(&file).unwrap() == std::fs::read(&copy).unwrap(),
            "{} differs",
            copy.display()
        );
    }
    // An edit of the GGX term: only the variant that shades with it runs. One of Lambert's:
    // the Blinn-Phong variants (the naive baseline too), not GGX.
    for (name, edit, ran) in [
        (
            "reuse-ggx",
            (
                "let f0 = mix(vec3<f32>(0.04), base, metallic);",
                "let f0 = mix(vec3<f32>(0.04), base, metallic) * 1.0;",
            ),
            "reused 2 of 3 cells from {previous}; ran 1: forward_plus_ggx@atrium",
        ),
        (
            "reuse-lambert",
            (
                "return max(dot(n, l), 0.0);",
                "return max(dot(n, l) * 1.0, 0.0);",
            ),
            "reused 1 of 3 cells from {previous}; ran 2: forward_plus@atrium, naive_forward@atrium",
        ),
    ] {
        let edited = common::EditedShaders::of("shading/brdf.wesl", name, &[edit]);
        let text = run(edited.root(), &dir.join(name), Some(&first));
        let expected = ran.replace("{previous}", &previous.to_string());
        assert!(text.contains(&expected), "{name}: {text}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The pipeline cache on disk: a run saves one for its adapter in `CLUSTERLAB_CACHE`; a file
/// there whose header names another adapter or another clusterlab version is ignored with
/// a note naming what wrote it, never loaded, and replaced by this run's; a file of that
/// name that is not clusterlab's is left alone, byte for byte.
#[test]
fn a_pipeline_cache_of_another_adapter_or_version_is_ignored() {
    let dir = scratch("pipeline-cache");
    let cache = dir.join("cache");
    let run = |out: &str| {
        let (ok, text) = cli([
            "matrix",
            "--variants",
            "forward_plus",
            "--scenes",
            "one_light",
            "--size",
            "32x18",
            "--frames",
            "1",
            "--warmup",
            "0",
            "--out",
            dir.join(out).to_str().unwrap(),
        ])
        .env("CLUSTERLAB_CACHE", &cache)
        .run()
        .succeeded();
        assert!(ok, "{text}");
        text
    };
    let text = run("first");
    if text.contains("pipeline cache: none on") {
        eprintln!(
            "skipped: {}",
            text.lines().find(|l| l.contains("none on")).unwrap()
        );
        return;
    }
    let files = walk(&cache);
    assert_eq!(files.len(), 1, "{files:?}");
    let file = &files[0];
    let ours = std::fs::read(file).unwrap();
    // The header is three lines: what the file is, the version, the adapter.
    let newlines = ours.iter().enumerate().filter(|&(_, &b)| b == b'\n');
    let header_end = newlines.map(|(i, _)| i + 1).nth(2).unwrap();
    let header = String::from_utf8(ours[..header_end].to_vec()).unwrap();
    let text = run("second");
    assert!(
        text.contains(&format!("pipeline cache: {}\n", file.display())),
        "{text}"
    );
    let lines: Vec<&str> = header.lines().collect();
    for (forged, named) in [
        (
            format!("{}\nclusterlab 0.0.1\n{}\n", lines[0], lines[2]),
            format!("clusterlab 0.0.1 on {}", lines[2]),
        ),
        (
            format!(
                "{}\n{}\nSome GPU (vulkan, vendor 0x1, device 0x2, 1.0)\n",
                lines[0], lines[1]
            ),
            format!(
                "{} on Some GPU (vulkan, vendor 0x1, device 0x2, 1.0)",
                lines[1]
            ),
        ),
    ] {
        let mut bytes = forged.into_bytes();
        bytes.extend_from_slice(&ours[header_end..]);
        std::fs::write(file, &bytes).unwrap();
        let text = run("forged");
        assert!(
            text.contains(&format!("was written by {named}; ignored")),
            "{text}"
        );
        // Replaced by this run's, under this run's header.
        assert!(std::fs::read(file).unwrap().starts_with(header.as_bytes()));
    }
    std::fs::write(file, b"the user's own bytes").unwrap();
    let text = run("foreign");
    assert!(text.contains("is not one clusterlab wrote"), "{text}");
    assert_eq!(std::fs::read(file).unwrap(), b"the user's own bytes");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The overlap moves a cell's CPU half (reference shading, error figures, images) beside the
/// next cells' GPU work; it changes when that runs, not what it computes. With it and
/// without, every cell's record but its times (and what follows from them: speed-ups, the
/// Pareto front, efficiency) and every image are the same byte for byte. The cells include
/// two that share one reference frame (the second waits for the first's) and one whose
/// reference is shaded with GGX.
#[test]
fn cells_are_the_same_with_and_without_the_overlap() {
    let dir = scratch("overlap");
    let run = |overlap: &str| {
        let out = dir.join(overlap);
        let (ok, text) = cli([
            "matrix",
            "--variants",
            "forward_plus",
            "forward_plus_one_level",
            "forward_plus_ggx",
            "--scenes",
            "atrium",
            "--size",
            "64x36",
            "--frames",
            "1",
            "--warmup",
            "0",
            "--overlap",
            overlap,
            "--out",
            out.to_str().unwrap(),
        ])
        .run()
        .succeeded();
        assert!(ok, "{text}");
        out
    };
    let (on, off) = (run("on"), run("off"));
    let figures = |dir: &Path| {
        let results = Results::load(dir).unwrap();
        let mut cells = serde_json::to_value(&results.cells).unwrap();
        for cell in cells.as_array_mut().unwrap() {
            let cell = cell.as_object_mut().unwrap();
            for timed in [
                "gpu_ms",
                "gpu_ms_spread",
                "gpu_ms_interval",
                "rank",
                "speedup_interval",
                "wall_ms",
                "reference_ms",
                "cost_ms",
                "speedup_vs_naive",
                "speedup_least",
                "front",
                "round_ms",
                "against_leader",
                "efficiency",
                "disturbed_frames",
            ] {
                cell.remove(timed);
            }
        }
        cells
    };
    assert_eq!(figures(&on), figures(&off));
    let images = walk(&on.join("images"));
    assert_eq!(images.len(), walk(&off.join("images")).len());
    for file in images {
        let other = off.join(file.strip_prefix(&on).unwrap());
        assert!(
            std::fs::read(&file).unwrap() == std::fs::read(&other).unwrap(),
            "{} differs",
            other.display()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// No cell is ever shown beating its perfect-culling bound, and none is clamped to it: on
/// `one_light`, where a frame is barely longer than its frame without lights, the two timed
/// apart put bounds past their frames; each such figure is flagged, within noise (inside the
/// frame's interval) or a bound above its frame, in results.json, the CSV and the page.
#[test]
fn an_efficiency_above_100_percent_is_flagged_never_clamped() {
    let dir = scratch("efficiency");
    let (ok, text) = cli([
        "matrix",
        "--variants",
        "forward_plus",
        "forward_plus_two_level",
        "clustered_deferred_16x16x24",
        "--scenes",
        "one_light",
        "--size",
        "64x36",
        "--out",
        dir.to_str().unwrap(),
    ])
    .run()
    .succeeded();
    assert!(ok, "{text}");
    let results = Results::load(&dir).unwrap();
    let cells: Vec<_> = results
        .cells
        .iter()
        .filter_map(|c| Some((c, c.efficiency?)))
        .collect();
    assert!(!cells.is_empty(), "no cell has an efficiency");
    for (c, e) in &cells {
        // Bound and frame are rounded to 0.0005 ms each, the ratio to 0.00005.
        let frame = c.total_ms().unwrap();
        let ratio = e.bound_ms / frame;
        let slack = ratio * (0.0005 / e.bound_ms + 0.0005 / frame) + 0.00005;
        assert!((e.efficiency - ratio).abs() <= slack, "clamped? {e:?}");
        assert!(
            e.efficiency <= 1.0 || e.within_noise || e.bound_above_frame,
            "{e:?}"
        );
    }
    let page = std::fs::read_to_string(dir.join("index.html")).unwrap();
    for (c, e) in &cells {
        if e.bound_above_frame {
            let shown = format!(
                "bound above frame ({:.2} &gt; {:.2} ms)",
                e.bound_ms,
                c.total_ms().unwrap()
            );
            assert!(page.contains(&shown), "{shown} not on the page");
        }
    }
    // The deliberate break: a record clamped to 100% as before, its bound past its frame, is
    // refused on reading.
    let (c, e) = cells[0];
    let mut broken = results.clone();
    let cell = broken
        .cells
        .iter_mut()
        .find(|x| x.spec.id == c.spec.id)
        .unwrap();
    let mut clamped = e;
    clamped.bound_ms = c.total_ms().unwrap() * 1.5;
    clamped.efficiency = 1.0;
    clamped.within_noise = false;
    clamped.bound_above_frame = false;
    cell.efficiency = Some(clamped);
    assert!(broken.check().is_err(), "a clamped bound passes the check");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--reuse` takes a cell only where every input that can change its figures is as it was:
/// each environment variable of `environment::VARIABLES` that changes figures, the frames
/// asked for, the variant file. Changed one at a time, each reruns the cell; unchanged, it
/// is reused (the control).
#[test]
fn every_input_that_changes_a_figure_reruns_the_cell() {
    use clusterlab::environment::{Effect, VARIABLES};
    let dir = scratch("reuse-inputs");
    let variant = dir.join("mine.ron");
    std::fs::copy("variants/forward_plus.ron", &variant).unwrap();
    let run = |out: &str, extra: &[&str], env: &[(&str, &str)]| {
        let mut args = vec![
            "matrix",
            "--variants",
            variant.to_str().unwrap(),
            "--scenes",
            "one_light",
            "--size",
            "16x9",
            "--warmup",
            "0",
            "--out",
        ];
        let out = dir.join(out);
        args.push(out.to_str().unwrap());
        args.extend_from_slice(extra);
        if !extra.contains(&"--frames") {
            args.extend(["--frames", "1"]);
        }
        // From a folder outside the tree, as a user's run would be.
        let (ok, text) = cli(&args).envs(env).dir(&dir).run().succeeded();
        assert!(ok, "{text}");
        text
    };
    run("first", &[], &[]);
    let first = dir.join("first");
    let reuse = ["--reuse", first.to_str().unwrap()];
    // The variant and the naive forward baseline the matrix adds.
    let reused = |text: &str| text.contains("reused 2 of 2 cells");
    assert!(
        reused(&run("same", &reuse, &[])),
        "the control: nothing changed"
    );
    // A value for each variable other than the one the test runs with.
    let value = |name: &str| -> &'static str {
        let now = std::env::var(name).unwrap_or_default();
        let candidates: &[&'static str] = match name {
            "CLUSTERLAB_PERTURB_DEPTH_ULPS" => &["32", "64"],
            "CLUSTERLAB_WITHOUT" => &["timestamps", "early-depth"],
            "CLUSTERLAB_TIMING" => &["wall", "timestamps"],
            "CLUSTERLAB_MAX_BUFFER_SIZE" => &["1073741824", "1073741825"],
            "WGPU_BACKEND" => &["vulkan", "gl"],
            "WGPU_ADAPTER_NAME" => &["llvmpipe", "lavapipe"],
            "LP_NUM_THREADS" => &["3", "5"],
            other => panic!("{other} changes figures: give the test a value for it"),
        };
        candidates.iter().find(|c| **c != now).unwrap()
    };
    for v in VARIABLES.iter().filter(|v| v.effect == Effect::Figures) {
        let text = run(v.name, &reuse, &[(v.name, value(v.name))]);
        assert!(
            !reused(&text),
            "{} changed and the cell was reused:\n{text}",
            v.name
        );
    }
    // A perturbed run says so, first thing, and records it in its provenance and each cell.
    let perturbed = "CLUSTERLAB_PERTURB_DEPTH_ULPS";
    let text = run(perturbed, &reuse, &[(perturbed, value(perturbed))]);
    let note = text.find(&format!("note: {perturbed}=")).expect("the note");
    assert!(
        note < text.find("2 cells on").unwrap(),
        "the note comes first: {text}"
    );
    let r = Results::load(&dir.join(perturbed)).unwrap();
    let n: u32 = value(perturbed).parse().unwrap();
    assert_eq!(r.provenance[0].perturbed_depth_ulps, n);
    assert!(r.cells.iter().all(|c| c.perturbed_depth_ulps == n));
    // Edited shaders are told from stock ones: the folder, where it came from, the hash.
    let stock = Results::load(&first).unwrap().provenance[0].shaders.clone();
    assert!(stock.source == ShaderSource::Built && stock.files > 0 && stock.sha256.len() == 64);
    let edited = common::EditedShaders::of(
        "shading/brdf.wesl",
        "reuse-inputs-edited",
        &[(
            "return max(dot(n, l), 0.0);",
            "return max(dot(n, l) * 1.0, 0.0);",
        )],
    );
    let folder = edited.root().to_str().unwrap().to_string();
    run("edited-shaders", &[], &[("CLUSTERLAB_SHADERS", &folder)]);
    let shaders = Results::load(&dir.join("edited-shaders"))
        .unwrap()
        .provenance[0]
        .shaders
        .clone();
    assert!(
        shaders.source == ShaderSource::Environment && shaders.sha256 != stock.sha256,
        "{shaders:?}"
    );
    // The revision is the build's, wherever the run is: this one ran in a scratch folder.
    assert_eq!(
        r.provenance[0].git_revision,
        env!("CLUSTERLAB_GIT_REVISION")
    );
    let text = run(
        "frames",
        &["--frames", "2", "--reuse", first.to_str().unwrap()],
        &[],
    );
    assert!(!reused(&text), "--frames 2: {text}");
    std::fs::write(
        &variant,
        std::fs::read_to_string(&variant)
            .unwrap()
            .replace("description: \"", "description: \"mine: "),
    )
    .unwrap();
    assert!(
        !reused(&run("edited", &reuse, &[])),
        "an edited variant file"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
