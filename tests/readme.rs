//! The pages that front the project say what is true: the variant page is the variant
//! files' own, ARCHITECTURE is a map, README a front page.

use std::path::Path;

use clusterlab::snapshot::table;
use clusterlab::variant;

/// `docs/variants.md` is what `clusterlab snapshot` generates from `variants/`: a row per
/// file as the file says, and the default matrix's size with them. A file added, removed or
/// changed without running it fails here, with the page to write.
#[test]
fn the_variant_page_is_the_variant_files_own() {
    let variants: Vec<variant::LoadedVariant> = variant::find_files(Path::new("variants"))
        .expect("variants/")
        .iter()
        .map(|f| variant::load(f).unwrap_or_else(|e| panic!("{e}")))
        .collect();
    let cells = clusterlab::matrix::expand(&clusterlab::matrix::default_groups().unwrap())
        .unwrap()
        .len();
    let want = table::page(&variants, cells);
    let page = std::fs::read_to_string(table::PAGE).expect("docs/variants.md");
    assert!(
        page.replace("\r\n", "\n") == want,
        "{} differs from variants/: run `clusterlab snapshot`; it should read:\n{want}",
        table::PAGE
    );
}

/// ARCHITECTURE is a map: the layers, the data flow, the conventions and how to add each
/// kind of unit; how each feature works lives in `docs/design.md`.
#[test]
fn architecture_is_a_map() {
    let map = std::fs::read_to_string("docs/ARCHITECTURE.md").expect("docs/ARCHITECTURE.md");
    let lines = map.lines().count();
    assert!(
        lines <= 400,
        "docs/ARCHITECTURE.md is {lines} lines: move a feature's narrative to docs/design.md"
    );
    for section in [
        "## Data flow",
        "## Layout",
        "## Conventions",
        "## How to add",
    ] {
        assert!(
            map.contains(section),
            "docs/ARCHITECTURE.md has no `{section}`"
        );
    }
}

#[test]
fn readme_is_a_front_page() {
    let readme = std::fs::read_to_string("README.md").expect("README.md");
    let lines = readme.lines().count();
    assert!(
        lines <= 200,
        "README is {lines} lines: move detail to docs/"
    );
    // The two commands a newcomer runs come first, before any section.
    let first_section = readme.find("\n## ").unwrap_or(readme.len());
    for command in [
        "cargo run --release -- matrix",
        "cargo test",
        "cargo run --release -- view",
    ] {
        assert!(
            readme[..first_section].contains(command),
            "`{command}` is not on README's first screen"
        );
    }
    // The viewer's picture is there to see.
    assert!(readme[..first_section].contains("](docs/viewer.png)"));
    assert!(std::path::Path::new("docs/viewer.png").is_file());
}
