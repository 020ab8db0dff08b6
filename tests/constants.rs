//! Each number is written once: a constant the Rust side and the shaders share is defined in
//! Rust and generated into the shaders' `constants` module (`compose::constants_module`),
//! never written as a literal in both. Grep-level: the names of literal `const`s in
//! `shaders/` and `src/` must not meet.

use std::collections::BTreeSet;
use std::path::Path;

/// Names of `const NAME: TYPE = LITERAL;` definitions in `text` whose value is a number.
fn literal_consts(text: &str) -> BTreeSet<String> {
    text.lines()
        .filter_map(|line| {
            let line = line.trim_start();
            let line = line.strip_prefix("pub ").unwrap_or(line);
            let (name, rest) = line.strip_prefix("const ")?.split_once(':')?;
            let value = rest.split_once('=')?.1.trim().trim_end_matches(';');
            let number = value
                .chars()
                .next()
                .is_some_and(|c| c.is_ascii_digit() || c == '-');
            number.then(|| name.trim().to_string())
        })
        .collect()
}

/// Every file under `dir` whose name ends with `ext`, read whole.
fn sources(dir: &Path, ext: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).expect("source folder") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            out.extend(sources(&path, ext));
        } else if path.to_string_lossy().ends_with(ext) {
            let text = std::fs::read_to_string(&path).expect("source file");
            out.push((path.display().to_string(), text));
        }
    }
    out
}

/// The names defined as literals on both sides, each with the files that define it.
fn written_twice(rust: &[(String, String)], wgsl: &[(String, String)]) -> Vec<String> {
    let defined = |files: &[(String, String)]| -> Vec<(String, String)> {
        files
            .iter()
            .flat_map(|(file, text)| {
                literal_consts(text)
                    .into_iter()
                    .map(move |name| (name, file.clone()))
            })
            .collect()
    };
    let (rust, wgsl) = (defined(rust), defined(wgsl));
    let mut twice = Vec::new();
    for (name, file) in &rust {
        for (other, shader) in &wgsl {
            if name == other {
                twice.push(format!("{name}: {file} and {shader}"));
            }
        }
    }
    twice
}

#[test]
fn no_number_is_written_in_rust_and_in_a_shader() {
    let twice = written_twice(
        &sources(Path::new("src"), ".rs"),
        &sources(Path::new("shaders"), ".wesl"),
    );
    assert!(
        twice.is_empty(),
        "written in Rust and in a shader (define it in Rust and generate it into the \
         `constants` module): {twice:?}"
    );
}

/// The check sees a mirror: a shader that writes out a number the Rust side also defines
/// (as `light_assign.wesl` wrote `LIGHTS_PER_ROW` beside `render/clustering.rs`).
#[test]
fn the_constant_check_sees_a_number_written_twice() {
    let rust = [(
        "render.rs".to_string(),
        "/// Lights a row.\nconst LIGHTS_PER_ROW: u32 = 32768;\npub const NAME: &str = \"x\";\n"
            .to_string(),
    )];
    let wgsl = [(
        "assign.wesl".to_string(),
        "const LIGHTS_PER_ROW: u32 = 32768u;\nconst SCALE: f32 = 0.5;\n".to_string(),
    )];
    assert_eq!(
        written_twice(&rust, &wgsl),
        ["LIGHTS_PER_ROW: render.rs and assign.wesl"]
    );
}
