//! Records the git revision the binary is built from, so results name it wherever the
//! binary runs (`matrix::Provenance`): `CLUSTERLAB_GIT_REVISION` ("unknown" outside a git
//! checkout) and `CLUSTERLAB_GIT_DIRTY` (tracked files changed since that revision).

use std::process::Command;

fn main() {
    for path in [
        "src",
        "shaders",
        "Cargo.toml",
        "Cargo.lock",
        ".git/HEAD",
        ".git/index",
    ] {
        println!("cargo:rerun-if-changed={path}");
    }
    let git = |args: &[&str]| {
        Command::new("git")
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    let revision = git(&["rev-parse", "HEAD"]).unwrap_or_else(|| "unknown".into());
    let dirty =
        git(&["status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| !s.is_empty());
    println!("cargo:rustc-env=CLUSTERLAB_GIT_REVISION={revision}");
    println!("cargo:rustc-env=CLUSTERLAB_GIT_DIRTY={dirty}");
}
