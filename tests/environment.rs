//! Every environment variable clusterlab reads is in `environment::VARIABLES`, and every
//! read goes through that module: a read anywhere else would change figures that neither
//! the provenance nor `matrix --reuse` sees.

use clusterlab::environment::VARIABLES;

/// The reads of the environment in `source` that bypass `environment::var`, and the names
/// it reads through it that the list does not hold, as `FILE:LINE: what`.
fn stray_reads(file: &str, source: &str) -> Vec<String> {
    let mut found = Vec::new();
    for (n, line) in source.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        for direct in ["env::var(", "env::var_os(", "env::vars(", "env::vars_os("] {
            if code.contains(direct) {
                found.push(format!("{file}:{}: reads `{direct}` directly", n + 1));
            }
        }
        for through in ["environment::var(\"", "environment::var_os(\""] {
            for (i, _) in code.match_indices(through) {
                let rest = &code[i + through.len()..];
                let name = &rest[..rest.find('"').unwrap_or(rest.len())];
                if !VARIABLES.iter().any(|v| v.name == name) {
                    found.push(format!("{file}:{}: reads {name}, not in the list", n + 1));
                }
            }
        }
    }
    found
}

#[test]
fn every_environment_read_goes_through_the_one_list() {
    let mut files = Vec::new();
    crate::common::rust_sources(std::path::Path::new("src"), &mut files);
    let mut stray = Vec::new();
    for path in files.iter().filter(|p| !p.ends_with("environment.rs")) {
        let text = std::fs::read_to_string(path).unwrap();
        stray.extend(stray_reads(&path.display().to_string(), &text));
    }
    assert!(stray.is_empty(), "{stray:#?}");
    // The deliberate break: a direct read, and a name the list does not hold, are found.
    let broken =
        "let a = std::env::var(\"HOME\");\nlet b = crate::environment::var(\"NOT_LISTED\");";
    assert_eq!(stray_reads("broken.rs", broken).len(), 2);
    // Each variable once.
    for (i, v) in VARIABLES.iter().enumerate() {
        assert!(
            VARIABLES[..i].iter().all(|w| w.name != v.name),
            "{} twice",
            v.name
        );
    }
}
