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

/// Sizes and offsets of GPU buffers written as numbers in the renderer (`size: 12`, a clear
/// or read at byte 8 of 4 bytes): each must come from a type (`size_of`, `offset_of!`) or
/// the shader's declaration instead. Offset 0 (a buffer's start) is not a hand size.
fn hand_sizes(text: &str) -> Vec<String> {
    let literal = |s: &str| {
        let s = s.trim().trim_end_matches([')', ';', ',', '?']);
        s.parse::<u64>().is_ok_and(|n| n > 0)
    };
    let calls = [
        "clear_buffer(",
        "read_buffer(",
        "read_texture(",
        "write_buffer(",
        "Clear(",
        "Step::Copy(",
    ];
    let mut found = Vec::new();
    for line in text.lines() {
        let code = line.split("//").next().unwrap_or("");
        let sized = code
            .trim_start()
            .strip_prefix("size: ")
            .is_some_and(literal);
        let call = calls.iter().any(|c| {
            code.split_once(c).is_some_and(|(_, args)| {
                args.split(',')
                    .skip(1)
                    .any(|a| literal(a.trim().trim_start_matches("Some(")))
            })
        });
        if sized || call {
            found.push(line.trim().to_string());
        }
    }
    found
}

#[test]
fn no_buffer_size_or_offset_is_written_by_hand() {
    // The deliberate breaks: the forms that were in the renderer.
    assert_eq!(
        hand_sizes("    encoder.clear_buffer(&c.stats, 8, Some(4));").len(),
        1
    );
    assert_eq!(hand_sizes("                size: 12,").len(), 1);
    assert_eq!(
        hand_sizes("Clear(c.named(Binding::SortJobs), 12, Some(4)),").len(),
        1
    );
    assert_eq!(hand_sizes("let x = read_buffer(gpu, b, 0, 4)?;").len(), 1);
    assert_eq!(hand_sizes("read_texture(gpu, texture, 16)?").len(), 1);
    assert!(hand_sizes("encoder.clear_buffer(&c.active, 0, None);").is_empty());
    let mut found = Vec::new();
    for dir in ["src/render", "src/gpu"] {
        for (file, text) in sources(Path::new(dir), "rs") {
            found.extend(
                hand_sizes(&text)
                    .into_iter()
                    .map(|l| format!("{file}: {l}")),
            );
        }
    }
    assert!(found.is_empty(), "sizes written by hand: {found:#?}");
}

/// The renderer's mirror of `sort_jobs`' header has the WGSL struct's offsets.
#[test]
fn the_sort_jobs_header_is_the_shaders() {
    use clusterlab::render::SortJobsHeader;
    let v = crate::common::load("forward_plus");
    let pass = clusterlab::compose::passes(&v.variant)
        .into_iter()
        .find(|p| p.name() == "light_assign")
        .expect("light assignment");
    let composed = clusterlab::compose::Composer::default()
        .compose(&v.variant, &pass)
        .expect("composes");
    let (_, ty) = composed
        .module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref().is_some_and(|n| n.ends_with("SortJobs")))
        .expect("the SortJobs struct");
    let naga::TypeInner::Struct { members, .. } = &ty.inner else {
        panic!("SortJobs is not a struct");
    };
    let at = |name: &str| {
        members
            .iter()
            .find(|m| m.name.as_deref() == Some(name))
            .map(|m| m.offset as usize)
    };
    assert_eq!(
        at("groups_x"),
        Some(std::mem::offset_of!(SortJobsHeader, groups_x))
    );
    assert_eq!(
        at("groups_y"),
        Some(std::mem::offset_of!(SortJobsHeader, groups_y))
    );
    assert_eq!(
        at("groups_z"),
        Some(std::mem::offset_of!(SortJobsHeader, groups_z))
    );
    assert_eq!(
        at("count"),
        Some(std::mem::offset_of!(SortJobsHeader, count))
    );
}
