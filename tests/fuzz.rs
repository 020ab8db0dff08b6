//! Fuzzing on stable Rust, with proptest. The variant parser: the shipped variant files'
//! bytes mutated (bit flips, truncations, insertions of bytes and of RON punctuation, splices
//! of two files). The glTF reader: an exported scene (a spot light, a moving camera) as .glb
//! and as .gltf with a .bin, its JSON values replaced or removed and its bytes damaged as the
//! variant files' are. No input may panic or hang, and every error must be located: the file
//! and `line:column`, or the field, object or accessor it is about; a glTF file must never
//! reach a panic inside the gltf crate (clusterlab checks what it would panic on first).
//!
//! `cargo test fuzz::` runs 20,000 variant cases and 3,000 glTF cases;
//! `CLUSTERLAB_FUZZ_CASES=1000000 cargo test --release fuzz:: -- --nocapture` runs a
//! million and a fifth of that and prints the rates. Inputs that ever failed are kept in
//! `tests/fuzz.proptest-regressions` and run first.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::common;
use clusterlab::scene::export::glb;
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
        VariantError::NotAVariantFile { .. } => true,
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

/// A runner of `cases` cases that runs the inputs that ever failed first and keeps new ones.
fn runner(cases: u32) -> TestRunner {
    TestRunner::new(Config {
        cases,
        failure_persistence: Some(Box::new(
            proptest::test_runner::FileFailurePersistence::Direct(
                "tests/fuzz.proptest-regressions",
            ),
        )),
        ..Config::default()
    })
}

#[test]
fn mutated_variant_files_never_panic_hang_or_give_unlocated_errors() {
    let files = shipped();
    let cases: u32 = std::env::var("CLUSTERLAB_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20_000);
    let mut runner = runner(cases);
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

/// One way to damage a glTF scene: a value of its JSON replaced or removed (by the index of
/// the value in a walk of the document), or the bytes of the whole file damaged as above.
#[derive(Clone, Debug)]
enum GltfMutation {
    Value { at: usize, with: usize },
    Bytes(Mutation),
}

/// What a JSON value is replaced with; the last entry removes it.
fn json_tokens() -> Vec<serde_json::Value> {
    use serde_json::json;
    vec![
        json!(-1),
        json!(0),
        json!(1),
        json!(3),
        json!(4294967296u64),
        json!(1e38),
        json!(-1e38),
        json!(0.5),
        json!("x"),
        json!("../x.bin"),
        json!(null),
        json!(true),
        json!([]),
        json!({}),
        json!([0, 0, 0, 0]),
    ]
}

fn gltf_mutation() -> impl Strategy<Value = GltfMutation> {
    let tokens = json_tokens().len() + 1;
    prop_oneof![
        3 => (any::<usize>(), 0..tokens).prop_map(|(at, with)| GltfMutation::Value { at, with }),
        1 => mutation().prop_map(GltfMutation::Bytes),
    ]
}

/// Every value of `v` with the path to it, depth first.
fn value_paths(v: &serde_json::Value, path: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    out.push(path.clone());
    let children: Vec<(String, &serde_json::Value)> = match v {
        serde_json::Value::Object(m) => m.iter().map(|(k, v)| (k.clone(), v)).collect(),
        serde_json::Value::Array(a) => a
            .iter()
            .enumerate()
            .map(|(i, v)| (i.to_string(), v))
            .collect(),
        _ => Vec::new(),
    };
    for (key, child) in children {
        path.push(key);
        value_paths(child, path, out);
        path.pop();
    }
}

/// `json` with the value at `path` replaced by `with` (None removes it).
fn replace_at(json: &mut serde_json::Value, path: &[String], with: Option<serde_json::Value>) {
    let Some((last, parents)) = path.split_last() else {
        if let Some(w) = with {
            *json = w;
        }
        return;
    };
    let parent = parents.iter().fold(json, |v, k| match v {
        serde_json::Value::Array(a) => &mut a[k.parse::<usize>().unwrap()],
        other => &mut other[k.as_str()],
    });
    match (parent, with) {
        (serde_json::Value::Object(m), Some(w)) => {
            m.insert(last.clone(), w);
        }
        (serde_json::Value::Object(m), None) => {
            m.remove(last);
        }
        (serde_json::Value::Array(a), Some(w)) => a[last.parse::<usize>().unwrap()] = w,
        (serde_json::Value::Array(a), None) => {
            a.remove(last.parse::<usize>().unwrap());
        }
        _ => {}
    }
}

/// The scene the glTF fuzzer damages: one_light with its light a spot (cone, rotation and
/// clusterlab's extras), its moving camera (an animation) and a base colour texture (a 2x2
/// PNG in a data URI), as JSON and binary chunk.
fn gltf_seed() -> (serde_json::Value, Vec<u8>) {
    use base64::Engine;
    let mut params = clusterlab::scene::find_scene("one_light").unwrap().defaults;
    params.spots = 1.0;
    let scene = clusterlab::scene::generate("one_light", params).unwrap();
    let (mut json, bin) = common::split_glb(&clusterlab::scene::export::to_glb(&scene).unwrap());
    let mut png = Vec::new();
    image::RgbaImage::from_pixel(2, 2, image::Rgba([200, 100, 50, 255]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let uri = format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(png)
    );
    json["images"] = serde_json::json!([{ "uri": uri }]);
    json["textures"] = serde_json::json!([{ "source": 0 }]);
    json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] =
        serde_json::json!({ "index": 0 });
    (json, bin)
}

/// Whether a glTF error says where the problem is: the object, accessor or field it is about,
/// or the file's own structure (its JSON's line and column, its GLB container, its size).
fn gltf_located(message: &str) -> bool {
    const PLACES: [&str; 20] = [
        "accessor",
        "buffer",
        "mesh ",
        "node",
        "camera",
        "light",
        "animation",
        "image",
        "texture",
        "material",
        "scene",
        "`",
        "line ",
        "GLB",
        "glb",
        "chunk",
        "bytes",
        "extension",
        "UTF-8",
        "sampler",
    ];
    PLACES.iter().any(|p| message.contains(p))
}

/// What became of the damaged glTF files.
#[derive(Debug, Default)]
struct GltfTally {
    loaded: u32,
    refused: u32,
}

#[test]
fn mutated_gltf_files_never_panic_hang_or_give_unlocated_errors() {
    let cases: u32 = std::env::var("CLUSTERLAB_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .map_or(3000, |n: u32| n / 5);
    let dir = common::scratch("gltf");
    let (seed_json, seed_bin) = gltf_seed();
    let tokens = json_tokens();
    let mut runner = runner(cases);
    let tally = std::cell::RefCell::new(GltfTally::default());
    let next = std::cell::Cell::new(0u32);
    let start = Instant::now();
    let strategy = (
        any::<bool>(),
        proptest::collection::vec(gltf_mutation(), 1..4),
    );
    runner
        .run(&strategy, |(as_glb, mutations)| {
            let mut json = seed_json.clone();
            let mut byte_mutations = Vec::new();
            for m in &mutations {
                match m {
                    GltfMutation::Value { at, with } => {
                        let mut now = Vec::new();
                        value_paths(&json, &mut Vec::new(), &mut now);
                        let path = &now[at % now.len()];
                        replace_at(&mut json, path, tokens.get(*with).cloned());
                    }
                    GltfMutation::Bytes(b) => byte_mutations.push(b.clone()),
                }
            }
            // A new name for every case: the loader keeps files by path, size and time.
            let n = next.get();
            next.set(n + 1);
            let (path, mut bytes) = if as_glb {
                let bytes = glb(serde_json::to_vec(&json).unwrap(), seed_bin.clone()).unwrap();
                (dir.join(format!("case-{n}.glb")), bytes)
            } else {
                let buffer = json.get_mut("buffers").and_then(|b| b.get_mut(0));
                if let Some(b) = buffer.and_then(|b| b.as_object_mut()) {
                    b.insert("uri".into(), format!("case-{n}.bin").into());
                }
                std::fs::write(dir.join(format!("case-{n}.bin")), &seed_bin).unwrap();
                (
                    dir.join(format!("case-{n}.gltf")),
                    serde_json::to_vec(&json).unwrap(),
                )
            };
            let files = vec![(path.clone(), bytes.clone())];
            for m in &byte_mutations {
                bytes = apply(&bytes, m, &files);
            }
            std::fs::write(&path, &bytes).unwrap();
            let name = path.to_str().unwrap();
            let began = Instant::now();
            let outcome =
                std::panic::catch_unwind(|| clusterlab::scene::file::load(name).map(|_| ()));
            let took = began.elapsed();
            let _ = std::fs::remove_file(&path);
            let fail = |why: String| {
                Err(TestCaseError::fail(format!(
                    "{} after {mutations:?}: {why}",
                    path.display()
                )))
            };
            if took > Duration::from_secs(5) {
                return fail(format!("took {took:?}"));
            }
            let mut t = tally.borrow_mut();
            match outcome {
                Err(_) => fail("panicked".into()),
                Ok(Ok(())) => {
                    t.loaded += 1;
                    Ok(())
                }
                Ok(Err(e)) => {
                    let message = e.to_string();
                    if message.contains("the glTF reader (the gltf crate) failed") {
                        return fail(format!("reached a panic inside the gltf crate: {message}"));
                    }
                    if !message.starts_with(name) || !gltf_located(&message[name.len()..]) {
                        return fail(format!("error without a place: {message}"));
                    }
                    t.refused += 1;
                    Ok(())
                }
            }
        })
        .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let s = start.elapsed().as_secs_f64();
    let t = tally.into_inner();
    eprintln!(
        "{cases} mutated glTF files in {s:.2} s ({:.0} a second): {t:?}",
        cases as f64 / s
    );
    // The mutations reach both outcomes: files that still load, and refusals.
    assert!(t.loaded > 0 && t.refused > 0, "{t:?}");
}
