//! Fuzzing the variant parser on stable Rust: the shipped variant files' bytes mutated by
//! proptest (bit flips, truncations, insertions of bytes and of RON punctuation, splices of
//! two files). No input may panic or hang, and every error must be located: the file and
//! `line:column`, or the field it is about.
//!
//! `cargo test --test fuzz` runs 20,000 cases; `CLUSTERLAB_FUZZ_CASES=1000000 cargo test
//! --release --test fuzz -- --nocapture` runs many more and prints the rate. Inputs that ever
//! failed are kept in `tests/fuzz.proptest-regressions` and run first.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use clusterlab::variant::{self, VariantError};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

fn shipped() -> Vec<(PathBuf, Vec<u8>)> {
    variant::find_files(Path::new("variants"))
        .expect("variants/")
        .into_iter()
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect()
}

/// One way to damage a file.
#[derive(Clone, Debug)]
enum Mutation {
    Flip {
        at: usize,
        bit: u8,
    },
    Truncate {
        at: usize,
    },
    Insert {
        at: usize,
        bytes: Vec<u8>,
    },
    Remove {
        at: usize,
        len: usize,
    },
    /// The head of this file and the tail of another.
    Splice {
        at: usize,
        other: usize,
        from: usize,
    },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    // Punctuation and words RON and the schema care about, as well as any byte.
    let token = prop_oneof![
        Just(b"(".to_vec()),
        Just(b")".to_vec()),
        Just(b",".to_vec()),
        Just(b":".to_vec()),
        Just(b"\"".to_vec()),
        Just(b"Some(".to_vec()),
        Just(b"-1e39".to_vec()),
        Just(b"NaN".to_vec()),
        Just(b"4294967296".to_vec()),
        Just(b"pipeline: ".to_vec()),
        Just(b"//".to_vec()),
        Just(b"/*".to_vec()),
        Just("\u{fffd}".as_bytes().to_vec()),
        proptest::collection::vec(any::<u8>(), 1..8),
    ];
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(at, bit)| Mutation::Flip { at, bit }),
        any::<usize>().prop_map(|at| Mutation::Truncate { at }),
        (any::<usize>(), token).prop_map(|(at, bytes)| Mutation::Insert { at, bytes }),
        (any::<usize>(), 1usize..40).prop_map(|(at, len)| Mutation::Remove { at, len }),
        (any::<usize>(), any::<usize>(), any::<usize>())
            .prop_map(|(at, other, from)| Mutation::Splice { at, other, from }),
    ]
}

fn apply(bytes: &[u8], m: &Mutation, files: &[(PathBuf, Vec<u8>)]) -> Vec<u8> {
    let n = bytes.len().max(1);
    let mut out = bytes.to_vec();
    match m {
        Mutation::Flip { at, bit } => {
            if let Some(b) = out.get_mut(at % n) {
                *b ^= 1 << bit;
            }
        }
        Mutation::Truncate { at } => out.truncate(at % n),
        Mutation::Insert { at, bytes } => {
            let at = at % (out.len() + 1);
            out.splice(at..at, bytes.iter().copied());
        }
        Mutation::Remove { at, len } => {
            let at = at % n;
            let end = (at + len).min(out.len());
            out.drain(at.min(end)..end);
        }
        Mutation::Splice { at, other, from } => {
            let other = &files[other % files.len()].1;
            out.truncate(at % n);
            out.extend_from_slice(&other[from % other.len().max(1)..]);
        }
    }
    out
}

/// Whether an error names where the problem is.
fn located(e: &VariantError, path: &Path) -> bool {
    let text = e.to_string();
    let named = text.starts_with(&path.display().to_string());
    let place = match e {
        VariantError::Syntax { line, column, .. } => *line >= 1 && *column >= 1,
        VariantError::Invalid { problems, .. } => {
            problems.iter().all(|p| !p.problem.field.is_empty())
        }
        VariantError::Io { .. } | VariantError::NotAVariantFile { .. } => true,
    };
    named && place
}

/// What became of the inputs: parsed, syntax errors, invalid values.
#[derive(Debug, Default)]
struct Tally {
    ok: u32,
    syntax: u32,
    invalid: u32,
}

/// Parse `bytes` as `path` (bytes that are not UTF-8, which the loader refuses before
/// parsing, are parsed with replacement characters, to reach the parser anyway).
fn check(path: &Path, bytes: &[u8], tally: &std::cell::RefCell<Tally>) -> Result<(), String> {
    let text = String::from_utf8_lossy(bytes);
    let start = Instant::now();
    let outcome = std::panic::catch_unwind(|| variant::parse(path, &text));
    let took = start.elapsed();
    if took > Duration::from_secs(1) {
        return Err(format!("took {took:?}"));
    }
    let mut t = tally.borrow_mut();
    match outcome {
        Err(_) => Err("panicked".into()),
        Ok(Ok(_)) => {
            t.ok += 1;
            Ok(())
        }
        Ok(Err(e)) if located(&e, path) => {
            match e {
                VariantError::Syntax { .. } => t.syntax += 1,
                _ => t.invalid += 1,
            }
            Ok(())
        }
        Ok(Err(e)) => Err(format!("error without a place: {e}")),
    }
}

#[test]
fn mutated_variant_files_never_panic_hang_or_give_unlocated_errors() {
    let files = shipped();
    let cases: u32 = std::env::var("CLUSTERLAB_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20_000);
    let mut runner = TestRunner::new(Config {
        cases,
        failure_persistence: Some(Box::new(
            proptest::test_runner::FileFailurePersistence::Direct(
                "tests/fuzz.proptest-regressions",
            ),
        )),
        ..Config::default()
    });
    let tally = std::cell::RefCell::new(Tally::default());
    let start = Instant::now();
    let strategy = (0..files.len(), proptest::collection::vec(mutation(), 1..4));
    runner
        .run(&strategy, |(file, mutations)| {
            let (path, bytes) = &files[file];
            let damaged = mutations
                .iter()
                .fold(bytes.clone(), |b, m| apply(&b, m, &files));
            check(path, &damaged, &tally).map_err(|e| {
                TestCaseError::fail(format!(
                    "{} after {mutations:?}: {e}\n--- input ---\n{}",
                    path.display(),
                    String::from_utf8_lossy(&damaged)
                ))
            })
        })
        .unwrap();
    let s = start.elapsed().as_secs_f64();
    let t = tally.into_inner();
    eprintln!(
        "{cases} mutated variant files in {s:.2} s ({:.0} a second): {t:?}",
        cases as f64 / s
    );
    // The mutations reach every outcome: the parser, the checks, and valid files.
    assert!(t.ok > 0 && t.syntax > 0 && t.invalid > 0, "{t:?}");
}

/// The shipped files themselves parse: the mutations start from valid input.
#[test]
fn the_fuzzed_files_are_valid_to_begin_with() {
    for (path, bytes) in shipped() {
        let text = std::str::from_utf8(&bytes).unwrap();
        variant::parse(&path, text).unwrap_or_else(|e| panic!("{e}"));
    }
}
