//! The layers of `docs/ARCHITECTURE.md`: a module of `src/` imports only modules of lower
//! layers, found by a plain scan of every `crate::NAME` in its source (comments left out).

/// The layers, lowest first (a module of the crate is a file or folder under `src/`).
/// `commands/` is the binary's (the bodies `main.rs` dispatches to); `main.rs` stands above
/// them all.
const LAYERS: &[&[&str]] = &[
    &[
        "common",
        "files",
        "environment",
        "measure",
        "names",
        "progress",
    ],
    &["cpu", "variant", "scene", "flip"],
    &["compose", "gpu", "explain"],
    &["render", "efficiency"],
    &["reference", "metrics"],
    &["run", "bias", "plot"],
    &["sequence"],
    &["kernels", "stress", "matrix"],
    &["study", "view", "snapshot"],
    &["commands"],
];

fn layer(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

/// The imports of module `module`'s `source` that do not point to a lower layer.
fn climbs(module: &str, source: &str) -> Vec<String> {
    let own = layer(module).unwrap_or(LAYERS.len());
    let code: String = source
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n");
    let mut found = Vec::new();
    let mut add = |name: &str| {
        let target = layer(name);
        if name != module && target.is_none_or(|t| t >= own) && !found.contains(&name.to_string()) {
            found.push(name.to_string());
        }
    };
    for (i, _) in code.match_indices("crate::") {
        let rest = &code[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // `use crate::{a::X, b}`: every name the group opens with.
            let group = &group[..group.find('}').unwrap_or(group.len())];
            for item in group.split(',') {
                let name: String = item
                    .trim()
                    .chars()
                    .take_while(|c| c.is_ascii_lowercase() || *c == '_')
                    .collect();
                if !name.is_empty() {
                    add(&name);
                }
            }
        } else {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_ascii_lowercase() || *c == '_')
                .collect();
            if !name.is_empty() {
                add(&name);
            }
        }
    }
    found
}

#[test]
fn no_import_climbs_a_layer() {
    // The deliberate break: a file module importing the matrix, and the matrix the study.
    assert_eq!(
        climbs("files", "use crate::matrix::REUSE_FILE;"),
        ["matrix"]
    );
    assert_eq!(
        climbs(
            "matrix",
            "let x = crate::{study::transparency::SCENE, run};"
        ),
        ["study"]
    );
    assert!(climbs("run", "use crate::{measure::median, render::Renderer};").is_empty());
    let mut files = Vec::new();
    crate::common::rust_sources(std::path::Path::new("src"), &mut files);
    let mut wrong = Vec::new();
    for file in &files {
        let relative = file.strip_prefix("src").unwrap();
        let top = relative.components().next().unwrap().as_os_str();
        let module = top.to_str().unwrap().trim_end_matches(".rs");
        if module == "lib" || module == "main" {
            continue;
        }
        assert!(
            layer(module).is_some(),
            "src/{module} is in no layer: add it to LAYERS and to docs/ARCHITECTURE.md"
        );
        let source = std::fs::read_to_string(file).unwrap();
        for name in climbs(module, &source) {
            wrong.push(format!("{} imports `{name}`", file.display()));
        }
    }
    assert!(wrong.is_empty(), "imports that climb a layer: {wrong:#?}");
}

/// `main.rs` parses arguments and dispatches: its only top-level functions are `main` and
/// the argument parsers (`parse_*`); a command's body lives in `src/commands/`. The
/// deliberate break: a command body back in `main.rs`.
#[test]
fn main_only_parses_and_dispatches() {
    let strays = |source: &str| -> Vec<String> {
        source
            .lines()
            .filter_map(|l| l.strip_prefix("fn ").or(l.strip_prefix("pub fn ")))
            .map(|l| l.split('(').next().unwrap_or("").to_string())
            .filter(|name| name != "main" && !name.starts_with("parse_"))
            .collect()
    };
    assert_eq!(strays("fn render(args: &RenderArgs) {}"), ["render"]);
    let main = std::fs::read_to_string("src/main.rs").unwrap();
    assert!(strays(&main).is_empty(), "in main.rs: {:?}", strays(&main));
}
