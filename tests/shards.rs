//! The sharding examples run as their users would: the Slurm array script once per task
//! (as Slurm would start it) and then the merge script, the same scripts the CI workflow
//! calls. The merge must equal one unsharded run of the same matrix, times aside, and merge
//! must refuse shards from different adapters or variant files unless told to mix them.

use std::path::Path;
use std::process::Command;

use crate::common::{self, cli, scratch};

use clusterlab::matrix::Results;

/// The matrix every shard runs: 3 variants x 2 scenes x 2 light counts, 12 cells.
const MATRIX_ARGS: &str = "--variants naive_forward forward_plus clustered_deferred_16x16x24 \
                           --scenes one_light,spheres --size 64x36 --sweep lights=4,32 \
                           --frames 1 --warmup 0";

/// Run a script of examples/ with bash and the environment a user would set.
fn script(path: &str, out: &Path, env: &[(&str, String)]) -> (bool, String) {
    let run = Command::new("bash")
        .arg(path)
        .env("CLUSTERLAB", common::binary())
        .env("OUT", out)
        .env("CLUSTERLAB_MATRIX_ARGS", MATRIX_ARGS)
        .envs(env.iter().map(|(k, v)| (k, v)))
        .output()
        .expect("bash runs");
    let text =
        String::from_utf8_lossy(&run.stdout).into_owned() + &String::from_utf8_lossy(&run.stderr);
    (run.status.success(), text)
}

#[test]
fn the_examples_shard_and_merge_into_the_unsharded_run() {
    let dir = scratch("examples");
    let shards = dir.join("shards");
    let here = std::env::current_dir().unwrap();
    for k in 1..=3 {
        let (ok, text) = script(
            "examples/slurm/matrix-shard.sbatch",
            &shards,
            &[
                ("SLURM_SUBMIT_DIR", here.display().to_string()),
                ("SLURM_ARRAY_TASK_ID", k.to_string()),
                ("SLURM_ARRAY_TASK_COUNT", "3".into()),
            ],
        );
        assert!(ok, "shard {k}: {text}");
    }
    let (ok, text) = script(
        "examples/slurm/merge.sbatch",
        &shards,
        &[("SLURM_SUBMIT_DIR", here.display().to_string())],
    );
    assert!(ok, "merge: {text}");
    let whole = dir.join("whole");
    let mut args = vec!["matrix", "--out", whole.to_str().unwrap()];
    args.extend(MATRIX_ARGS.split_whitespace());
    let (ok, text) = cli(&args).run().succeeded();
    assert!(ok, "unsharded: {text}");

    let merged = Results::load(&shards.join("merged")).expect("merged results");
    let whole_results = Results::load(&whole).expect("unsharded results");
    assert_eq!(merged.provenance.len(), 3, "one provenance per shard");
    assert_eq!(merged.cells.len(), 12);
    assert_eq!(whole_results.cells.len(), 12);
    for w in &whole_results.cells {
        let m = merged
            .cells
            .iter()
            .find(|m| m.spec.id == w.spec.id)
            .unwrap_or_else(|| panic!("{} is missing from the merge", w.spec.id));
        let id = &w.spec.id;
        assert!(w.ok() && m.ok(), "{id}: {:?} {:?}", w.failure, m.failure);
        assert_eq!(m.spec, w.spec, "{id}");
        assert_eq!(m.error, w.error, "{id}: error metrics");
        assert_eq!(m.stats, w.stats, "{id}: counters");
        assert_eq!(m.frames, w.frames, "{id}");
        assert_eq!(m.skipped_passes, w.skipped_passes, "{id}");
        assert_eq!(m.images.image, w.images.image, "{id}");
        // Cells compare only within the rounds they were timed in: in the merge, a speed-up
        // needs the group's naive cell compared in the same shard.
        let compared = m.rank != Some(clusterlab::matrix::Rank::NotCompared);
        let naive_beside = merged.cells.iter().any(|n| {
            n.spec.variant == "naive_forward"
                && n.spec.group() == m.spec.group()
                && (n.run, n.batch) == (m.run, m.batch)
        });
        assert!(
            w.speedup_vs_naive.is_some(),
            "{id}: the unsharded run has them all"
        );
        assert_eq!(
            m.speedup_vs_naive.is_some(),
            compared && naive_beside,
            "{id}: speed-up against the naive cell of its own shard"
        );
        for (a, b) in [
            (&m.images.image, &w.images.image),
            (&m.images.heat, &w.images.heat),
        ] {
            let (a, b) = (a.as_ref().unwrap(), b.as_ref().unwrap());
            let bytes = |root: &Path, f: &str| std::fs::read(root.join(f)).expect("image");
            assert!(
                bytes(&shards.join("merged"), a) == bytes(&whole, b),
                "{id}: image {a} differs between the merge and the unsharded run"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Rewrite a shard's results.json with `edit`.
fn tamper(dir: &Path, edit: impl Fn(&mut Results)) {
    let mut r = Results::load(dir).expect("results");
    edit(&mut r);
    std::fs::write(
        dir.join("results.json"),
        serde_json::to_string_pretty(&r).unwrap(),
    )
    .unwrap();
}

#[test]
fn merge_refuses_mixed_adapters_and_variant_files_unless_told() {
    let dir = scratch("mixed");
    let (a, b) = (dir.join("a"), dir.join("b"));
    for (k, out) in [(1, &a), (2, &b)] {
        let shard = format!("{k}/2");
        let (ok, text) = cli([
            "matrix",
            "--variants",
            "forward_plus",
            "--scenes",
            "one_light",
            "--size",
            "32x18",
            "--warmup",
            "0",
            "--frames",
            "1",
            "--shard",
            &shard,
            "--out",
            out.to_str().unwrap(),
        ])
        .run()
        .succeeded();
        assert!(ok, "{text}");
    }
    let merge = |extra: &[&str]| {
        let out = dir.join("merged");
        let mut args = vec![
            "merge",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        cli(&args).run().succeeded()
    };
    assert!(merge(&[]).0, "same adapter and files merge");

    tamper(&b, |r| r.provenance[0].adapter.name = "another GPU".into());
    let (ok, text) = merge(&[]);
    assert!(!ok);
    assert!(
        text.contains("times from different adapters are not comparable")
            && text.contains("--allow-mixed"),
        "{text}"
    );
    assert!(merge(&["--allow-mixed"]).0);

    let adapter = Results::load(&a).unwrap().provenance[0].adapter.clone();
    tamper(&b, |r| {
        r.provenance[0].adapter = adapter.clone();
        for f in r.provenance[0].variant_files.values_mut() {
            f.sha256 = "0".repeat(64);
        }
    });
    let (ok, text) = merge(&[]);
    assert!(!ok);
    assert!(
        text.contains("variant `") && text.contains("differs") && text.contains("--allow-mixed"),
        "{text}"
    );
    assert!(merge(&["--allow-mixed"]).0);
    let _ = std::fs::remove_dir_all(&dir);
}
