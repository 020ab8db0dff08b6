//! Result folders: what `matrix --out` and `merge --out` write. A run owns its folder only
//! when the folder is new, empty, or one a run wrote: it holds the marker file
//! [`MARKER_NAME`] (or, from versions before the marker, `results.json`) and nothing a run
//! does not write. Anything else (a file, a symbolic link, a folder of the user's, the
//! working directory or a folder above it) is refused, and no option overrides that.
//!
//! The run writes into a staging folder beside its target and swaps it in whole when done, so
//! the folder always holds one complete run and an interrupted run leaves the previous one as
//! it was. For `--out out/matrix` (made canonical first, so two spellings of one folder are
//! one folder):
//!
//! - `out/matrix.lock` names the process that writes the folder; a second run is refused while
//!   it lives. The lock is created whole (written under a name of this process, then linked).
//! - `out/matrix.staging-PID` is where process PID writes; it holds a marker naming PID.
//! - `out/matrix.old-PID` is the previous run, moved aside by PID while it swaps the new one in
//!   (its marker rewritten to name PID first).
//!
//! A killed run leaves its lock behind: the next run reads it, and only when it names a
//! process that is gone does it undo what that process left, each folder only when its own
//! marker names that process (the previous run goes back in place when the swap was cut
//! short). A folder that merely looks like a leftover is never touched.

use std::path::{Path, PathBuf};

use super::read::{MARKER, read};
use super::write::{create_folder, what_is};
use super::{describe, shown};

/// The marker file every result folder holds.
pub const MARKER_NAME: &str = ".clusterlab-results";
/// What each cell of a matrix run depended on (`matrix::reuse`).
pub const REUSE_FILE: &str = "reuse.json";
const MARKER_HEADER: &str = "clusterlab results";
const LOCK_HEADER: &str = "clusterlab lock";

/// A result folder being written, and the lock that keeps other runs out of it.
#[derive(Debug)]
pub struct ResultFolder {
    /// Where the finished run goes (canonical).
    pub target: PathBuf,
    /// Where the run writes meanwhile.
    pub staging: PathBuf,
    lock: PathBuf,
    /// The staging folder is in place, or kept because it could not be put there.
    committed: bool,
}

fn me() -> u32 {
    std::process::id()
}

/// `target` with `suffix` after its name: `out/matrix` and `.lock` give `out/matrix.lock`.
fn sibling(target: &Path, suffix: &str) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    target.with_file_name(format!("{name}{suffix}"))
}

/// Whether process `pid` is running (Linux: /proc; elsewhere assumed running, so a lock is
/// never taken over there: the message says to remove it).
fn alive(pid: u32) -> bool {
    if !Path::new("/proc/self").exists() {
        return true;
    }
    Path::new(&format!("/proc/{pid}")).exists()
}

/// Whose a folder is.
#[derive(Debug, PartialEq, Eq)]
enum Owner {
    /// Empty: a run may fill it.
    Empty,
    /// A result folder (with the process its marker names, when it has one).
    Run(Option<u32>),
    /// Not the tool's: why.
    Foreign(String),
}

/// What `dir` is, judged by its contents: a result folder holds the marker or results.json,
/// and nothing but what a run writes (the report files, reuse.json beside the marker,
/// images/*.png and a sequence's images/*.gif, plots/*.svg).
fn owner(dir: &Path) -> Result<Owner, String> {
    let unreadable =
        |e: std::io::Error| format!("{}: cannot read folder: {}", shown(dir), describe(&e));
    let mut empty = true;
    let mut marker = None;
    let mut results = false;
    let mut reuse = false;
    for entry in std::fs::read_dir(dir).map_err(unreadable)? {
        let entry = entry.map_err(unreadable)?;
        empty = false;
        let name = entry.file_name().to_string_lossy().into_owned();
        let kind = entry.file_type().map_err(unreadable)?;
        let foreign = |what: String| Ok(Owner::Foreign(what));
        match name.as_str() {
            MARKER_NAME if kind.is_file() => match marker_process(&entry.path(), MARKER_HEADER) {
                Some(pid) => marker = Some(pid),
                None => return foreign(format!("its `{MARKER_NAME}` is not one clusterlab wrote")),
            },
            "results.json" if kind.is_file() => match results_problem(&entry.path()) {
                None => results = true,
                Some(why) => return foreign(format!("its results.json {why}")),
            },
            "results.csv" | "index.html" if kind.is_file() => {}
            REUSE_FILE if kind.is_file() => reuse = true,
            "images" | "plots" if kind.is_dir() => {
                let exts: &[&str] = if name == "images" {
                    &[".png", ".gif"]
                } else {
                    &[".svg"]
                };
                for inner in std::fs::read_dir(entry.path()).map_err(unreadable)? {
                    let inner = inner.map_err(unreadable)?;
                    let inner_name = inner.file_name().to_string_lossy().into_owned();
                    if !inner.file_type().map_err(unreadable)?.is_file()
                        || !exts.iter().any(|e| inner_name.ends_with(e))
                    {
                        return foreign(format!(
                            "it holds `{name}/{inner_name}`, which no run writes"
                        ));
                    }
                }
            }
            _ => return foreign(format!("it holds `{name}`, which no run writes")),
        }
    }
    Ok(if empty {
        Owner::Empty
    } else if reuse && marker.is_none() {
        // Every run that writes reuse.json leaves its marker: without one, the file is not
        // a run's (an earlier version's folder holds none).
        Owner::Foreign(format!(
            "it holds `{REUSE_FILE}` but no `{MARKER_NAME}` marker, which every run that writes one leaves"
        ))
    } else if marker.is_some() || results {
        Owner::Run(marker)
    } else {
        Owner::Foreign(format!(
            "it holds no `{MARKER_NAME}` marker and no results.json"
        ))
    })
}

/// Why `path` is not a results file a clusterlab run wrote, if it is not: one is a JSON
/// object whose `provenance` lists the runs that wrote it, each naming the tool and its
/// version (`clusterlab X.Y.Z`), and whose `cells` is a list. A file of the user's that
/// happens to be called results.json is not, and its folder is left alone.
fn results_problem(path: &Path) -> Option<String> {
    let bytes = match read(path, super::read::RESULTS) {
        Ok(bytes) => bytes,
        Err(e) => return Some(format!("cannot be read ({})", e.why)),
    };
    let value: serde_json::Value = match serde_json::from_slice(&bytes) {
        Ok(v) => v,
        Err(e) => return Some(format!("is not JSON ({e})")),
    };
    let is_tool = |p: &serde_json::Value| {
        p["tool"].as_str().is_some_and(|t| {
            t.strip_prefix("clusterlab ")
                .is_some_and(|version| version.split('.').count() == 3)
        })
    };
    let runs = value["provenance"].as_array();
    if !runs.is_some_and(|r| !r.is_empty() && r.iter().all(is_tool)) {
        return Some(
            "names no clusterlab run in its `provenance`, where each run's `tool` is `clusterlab X.Y.Z`"
                .into(),
        );
    }
    if !value["cells"].is_array() {
        return Some("has no list of `cells`".into());
    }
    None
}

/// The process a marker or lock file of the tool names (its first line `header`, its
/// second `process PID`); None when the file is not one the tool wrote.
fn marker_process(path: &Path, header: &str) -> Option<u32> {
    let meta = std::fs::symlink_metadata(path).ok()?;
    if !meta.file_type().is_file() {
        return None;
    }
    let bytes = read(path, MARKER).ok()?;
    let text = String::from_utf8(bytes).ok()?;
    let mut lines = text.lines();
    (lines.next()? == header).then_some(())?;
    lines.next()?.strip_prefix("process ")?.parse().ok()
}

fn marker_text(header: &str, extra: &str) -> String {
    format!("{header}\nprocess {}\n{extra}", me())
}

/// The marker a study's output folder holds (`study --out`): several studies write their
/// files side by side there, so the folder is not swapped whole; it is the tool's only when
/// new, empty, or holding this marker and nothing but studies' files.
pub const STUDY_MARKER: &str = ".clusterlab-study";
const STUDY_HEADER: &str = "clusterlab studies";

/// Make `dir` a study folder that may take `files` (names inside it), or say why not: it is
/// new, empty, or holds [`STUDY_MARKER`] and only names `is_study_file` accepts; it is no
/// link, not the working folder or one above it, and none of `files` exists as anything
/// but a regular file. Every check comes before the first write; the marker is written
/// last.
pub fn claim_study_folder(
    dir: &Path,
    files: &[&str],
    is_study_file: impl Fn(&str) -> bool,
) -> Result<(), String> {
    check_study_folder(dir, files, &is_study_file)?;
    create_folder(dir)?;
    let marker = dir.join(STUDY_MARKER);
    if !marker.exists() {
        super::write_file(&marker, marker_text(STUDY_HEADER, "").as_bytes())?;
    }
    Ok(())
}

/// [`claim_study_folder`]'s checks, writing nothing (a study checks its folder before it
/// runs, so a refused folder costs no work).
pub fn check_study_folder(
    dir: &Path,
    files: &[&str],
    is_study_file: &dyn Fn(&str) -> bool,
) -> Result<(), String> {
    let refuse = |why: String| {
        Err(format!(
            "--out `{}` {why}: a study writes only into a new folder, an empty one or one studies wrote (it holds `{STUDY_MARKER}` and only their files)",
            shown(dir)
        ))
    };
    let meta = match std::fs::symlink_metadata(dir) {
        Ok(meta) => meta,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(format!("--out `{}`: {}", shown(dir), describe(&e))),
    };
    if !meta.is_dir() {
        return refuse(format!("is {}", what_is(&meta)));
    }
    if let (Ok(cwd), Ok(target)) = (
        std::env::current_dir().and_then(std::fs::canonicalize),
        std::fs::canonicalize(dir),
    ) && cwd.starts_with(&target)
    {
        return refuse("is the working folder or a folder above it".into());
    }
    let unreadable =
        |e: std::io::Error| format!("{}: cannot read folder: {}", shown(dir), describe(&e));
    let mut names = Vec::new();
    let mut marked = false;
    for entry in std::fs::read_dir(dir).map_err(unreadable)? {
        let entry = entry.map_err(unreadable)?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let kind = entry.file_type().map_err(unreadable)?;
        if name == STUDY_MARKER {
            if !kind.is_file() || marker_process(&entry.path(), STUDY_HEADER).is_none() {
                return refuse(format!("holds a `{STUDY_MARKER}` clusterlab did not write"));
            }
            marked = true;
        } else if files.contains(&name.as_str()) && !kind.is_file() {
            return refuse(format!("holds `{name}` as a link or folder, not a file"));
        }
        names.push((name, kind.is_file()));
    }
    if names.is_empty() {
        return Ok(());
    }
    if !marked {
        return refuse(format!(
            "holds no `{STUDY_MARKER}` (it is not a folder studies wrote)"
        ));
    }
    match names
        .iter()
        .find(|(n, file)| n != STUDY_MARKER && !(*file && is_study_file(n)))
    {
        Some((n, _)) => refuse(format!("holds `{n}`, which no study writes")),
        None => Ok(()),
    }
}

/// Refuse `path` as an output folder unless it is absent, empty, or a result folder.
fn check_target(path: &Path) -> Result<(), String> {
    let meta = match std::fs::symlink_metadata(path) {
        Ok(meta) => meta,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(format!("--out `{}`: {}", shown(path), describe(&e))),
    };
    if !meta.is_dir() {
        return Err(format!(
            "--out `{}` is {}, not a result folder: a run writes a folder of its own and replaces it whole; give a new path, an empty folder or the folder of an earlier run",
            shown(path),
            what_is(&meta)
        ));
    }
    match owner(path)? {
        Owner::Empty | Owner::Run(_) => Ok(()),
        Owner::Foreign(why) => Err(format!(
            "--out `{}` is a folder clusterlab did not write ({why}): a run replaces its folder whole, so it writes only into a new path, an empty folder or the folder of an earlier run",
            shown(path)
        )),
    }
}

/// Create `path` holding `text`, whole or not at all: written under a name of this process,
/// then linked to `path` (which fails when `path` exists).
fn create_whole(path: &Path, text: &str) -> std::io::Result<()> {
    let tmp = sibling(path, &format!("-{}", me()));
    // One this process left (an earlier lock of the same run that failed) is its own.
    if marker_process(&tmp, LOCK_HEADER) == Some(me()) {
        let _ = std::fs::remove_file(&tmp);
    }
    {
        use std::io::Write;
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)?;
        f.write_all(text.as_bytes())?;
    }
    let linked = std::fs::hard_link(&tmp, path);
    let _ = std::fs::remove_file(&tmp);
    match linked {
        Err(e) if e.kind() != std::io::ErrorKind::AlreadyExists => {
            // A file system without hard links: create it directly.
            use std::io::Write;
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(path)?;
            f.write_all(text.as_bytes())
        }
        other => other,
    }
}

impl ResultFolder {
    /// Lock `out` for this process and make an empty staging folder beside it. Refused when
    /// `out` is not the tool's to replace, or while another live process holds its lock.
    pub fn acquire(out: &Path) -> Result<ResultFolder, String> {
        let Some(name) = out.file_name() else {
            return Err(format!(
                "--out `{}` does not name a folder of its own (a run replaces its folder whole): give one, e.g. out/matrix",
                shown(out)
            ));
        };
        let parent = out
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        create_folder(parent)?;
        let parent = std::fs::canonicalize(parent)
            .map_err(|e| format!("{}: {}", shown(parent), describe(&e)))?;
        let target = parent.join(name);
        if let Ok(cwd) = std::env::current_dir().and_then(std::fs::canonicalize)
            && cwd.starts_with(&target)
        {
            return Err(format!(
                "--out `{}` is the working folder or a folder above it: a run replaces its folder whole; give a folder of its own, e.g. out/matrix",
                shown(out)
            ));
        }
        check_target(out)?;
        let lock = sibling(&target, ".lock");
        take_lock(&lock, &target)?;
        let mut folder = ResultFolder {
            staging: sibling(&target, &format!(".staging-{}", me())),
            target,
            lock,
            // Until the staging folder is made, there is none of ours to remove.
            committed: true,
        };
        // Under the lock, the target is looked at again.
        check_target(&folder.target)?;
        std::fs::create_dir(&folder.staging).map_err(|e| {
            format!(
                "{}: cannot create folder: {}",
                shown(&folder.staging),
                describe(&e)
            )
        })?;
        folder.committed = false;
        super::write_file(
            &folder.staging.join(MARKER_NAME),
            marker_text(MARKER_HEADER, "").as_bytes(),
        )?;
        Ok(folder)
    }

    /// Swap the finished run in: the previous folder aside, the staging folder in its place,
    /// the previous folder removed.
    pub fn commit(mut self) -> Result<(), String> {
        let keep = |folder: &mut ResultFolder, why: String| {
            folder.committed = true;
            Err(format!(
                "{why}; the finished run is in {}",
                shown(&folder.staging)
            ))
        };
        if let Err(why) = check_target(&self.target) {
            return keep(&mut self, why);
        }
        let old = sibling(&self.target, &format!(".old-{}", me()));
        let had_old = self.target.exists();
        if had_old {
            // The previous run, marked as moved aside by this process: a run that finds this
            // process gone puts it back.
            let marked = super::write_file(
                &self.target.join(MARKER_NAME),
                marker_text(MARKER_HEADER, "moving aside\n").as_bytes(),
            );
            if let Err(why) = marked.and_then(|()| {
                std::fs::rename(&self.target, &old).map_err(|e| {
                    format!(
                        "{}: cannot move the previous run aside: {}",
                        shown(&self.target),
                        describe(&e)
                    )
                })
            }) {
                return keep(&mut self, why);
            }
        }
        if let Err(e) = std::fs::rename(&self.staging, &self.target) {
            if had_old {
                let _ = std::fs::rename(&old, &self.target);
            }
            let why = format!(
                "{}: cannot move the finished run in place: {}",
                shown(&self.target),
                describe(&e)
            );
            return keep(&mut self, why);
        }
        self.committed = true;
        if had_old {
            std::fs::remove_dir_all(&old).map_err(|e| {
                format!(
                    "{}: cannot remove the previous run: {}",
                    shown(&old),
                    describe(&e)
                )
            })?;
        }
        Ok(())
    }
}

impl Drop for ResultFolder {
    /// An unfinished run (an error) leaves no staging folder; the lock goes either way.
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
        let _ = std::fs::remove_file(&self.lock);
    }
}

/// Take `lock` for this process: refused while a live process (this one included) holds it;
/// a lock left by a process that is gone is taken over once what that process left is undone.
fn take_lock(lock: &Path, target: &Path) -> Result<(), String> {
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let claim = marker_text(LOCK_HEADER, &format!("command {command}\n"));
    for _ in 0..3 {
        match create_whole(lock, &claim) {
            Ok(()) => return Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                let Some(pid) = marker_process(lock, LOCK_HEADER) else {
                    return Err(format!(
                        "{} exists and is not a lock clusterlab wrote, so {} is left alone: remove it, or choose another --out",
                        shown(lock),
                        shown(target)
                    ));
                };
                if pid == me() || alive(pid) {
                    let held_by = read(lock, MARKER)
                        .ok()
                        .and_then(|b| String::from_utf8(b).ok())
                        .and_then(|t| {
                            t.lines()
                                .find_map(|l| l.strip_prefix("command ").map(str::to_string))
                        })
                        .unwrap_or_else(|| "?".into());
                    return Err(format!(
                        "{} is in use by process {pid} (`{held_by}`), which holds {}; wait for it to finish or choose another --out (if no such run is going on, remove the lock)",
                        shown(target),
                        shown(lock)
                    ));
                }
                undo_leftovers(target, pid);
                let _ = std::fs::remove_file(lock);
            }
            Err(e) => {
                return Err(format!(
                    "{}: cannot create lock: {}",
                    shown(lock),
                    describe(&e)
                ));
            }
        }
    }
    Err(format!(
        "{}: another run took the lock as this one was taking over a stale one; try again",
        shown(lock)
    ))
}

/// What process `pid` (gone) left of a run into `target`, each part only when its marker
/// names `pid`: its staging folder goes (the process made it, exclusively, and wrote into it,
/// temporary files of cut-short writes included), and the previous run it had moved aside
/// goes back in place (or goes, when its finished run was already in place and the old folder
/// holds nothing but what a run writes).
fn undo_leftovers(target: &Path, pid: u32) {
    let left_by_pid = |dir: &Path| {
        std::fs::symlink_metadata(dir).is_ok_and(|m| m.is_dir())
            && marker_process(&dir.join(MARKER_NAME), MARKER_HEADER) == Some(pid)
    };
    let staging = sibling(target, &format!(".staging-{pid}"));
    if left_by_pid(&staging) {
        let _ = std::fs::remove_dir_all(&staging);
    }
    let old = sibling(target, &format!(".old-{pid}"));
    if left_by_pid(&old) {
        if !target.exists() {
            let _ = std::fs::rename(&old, target);
        } else if matches!(owner(&old), Ok(Owner::Run(_))) {
            // Removed only while it holds nothing but what a run writes.
            let _ = std::fs::remove_dir_all(&old);
        }
    }
    let lock_tmp = sibling(&sibling(target, ".lock"), &format!("-{pid}"));
    if marker_process(&lock_tmp, LOCK_HEADER) == Some(pid) {
        let _ = std::fs::remove_file(&lock_tmp);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("clusterlab-folder-{name}-{}", me()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::canonicalize(dir).unwrap()
    }

    /// The smallest results.json a run writes: one run's provenance, no cells.
    const RUN_RESULTS: &str = r#"{"provenance": [{"tool": "clusterlab 0.1.0"}], "cells": []}"#;

    /// The lock of a clusterlab process `pid` that is gone.
    fn stale_lock(pid: u32) -> String {
        format!("{LOCK_HEADER}\nprocess {pid}\ncommand clusterlab matrix\n")
    }

    /// Give `dir` the marker of process `pid`.
    fn mark(dir: &Path, pid: u32) {
        std::fs::write(
            dir.join(MARKER_NAME),
            format!("{MARKER_HEADER}\nprocess {pid}\n"),
        )
        .unwrap();
    }

    #[test]
    fn a_folder_is_the_tools_only_by_its_contents() {
        let dir = scratch("owner");
        assert_eq!(owner(&dir).unwrap(), Owner::Empty);
        std::fs::write(dir.join("results.json"), RUN_RESULTS).unwrap();
        std::fs::create_dir(dir.join("images")).unwrap();
        std::fs::write(dir.join("images/a.png"), "").unwrap();
        assert_eq!(
            owner(&dir).unwrap(),
            Owner::Run(None),
            "an earlier version's folder"
        );
        std::fs::write(dir.join("images/notes.txt"), "").unwrap();
        assert!(matches!(owner(&dir).unwrap(), Owner::Foreign(_)));
        std::fs::remove_file(dir.join("images/notes.txt")).unwrap();
        // A sequence's animation is a run's in images/, and in no other folder.
        std::fs::write(dir.join("images/a.gif"), "").unwrap();
        assert_eq!(owner(&dir).unwrap(), Owner::Run(None));
        std::fs::create_dir(dir.join("plots")).unwrap();
        std::fs::write(dir.join("plots/a.gif"), "").unwrap();
        assert!(matches!(owner(&dir).unwrap(), Owner::Foreign(_)));
        std::fs::remove_file(dir.join("plots/a.gif")).unwrap();
        // A marker the tool did not write is not one.
        std::fs::write(dir.join(MARKER_NAME), "mine\n").unwrap();
        assert!(matches!(owner(&dir).unwrap(), Owner::Foreign(_)));
        std::fs::remove_file(dir.join(MARKER_NAME)).unwrap();
        // reuse.json is a run's only beside the marker every run that writes it leaves.
        std::fs::write(dir.join(REUSE_FILE), "{}").unwrap();
        assert!(matches!(owner(&dir).unwrap(), Owner::Foreign(_)));
        std::fs::write(dir.join(MARKER_NAME), "clusterlab results\nprocess 7\n").unwrap();
        assert_eq!(owner(&dir).unwrap(), Owner::Run(Some(7)));
        std::fs::remove_file(dir.join("results.json")).unwrap();
        std::fs::write(dir.join("notes.md"), "").unwrap();
        assert!(matches!(owner(&dir).unwrap(), Owner::Foreign(_)));
    }

    #[test]
    fn two_spellings_of_one_folder_share_one_lock() {
        let dir = scratch("spellings");
        std::fs::create_dir(dir.join("sub")).unwrap();
        let first = ResultFolder::acquire(&dir.join("out")).unwrap();
        let second = ResultFolder::acquire(&dir.join("sub/../out"));
        let e = second.unwrap_err();
        assert!(e.contains("is in use by process"), "{e}");
        first.commit().unwrap();
        assert!(dir.join("out").join(MARKER_NAME).is_file());
        // Released: the other spelling now takes it.
        ResultFolder::acquire(&dir.join("sub/../out"))
            .unwrap()
            .commit()
            .unwrap();
        let names: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names.len(), 2, "only out/ and sub/ remain: {names:?}");
    }

    #[test]
    fn leftovers_go_only_when_their_marker_names_the_dead_process() {
        let dir = scratch("leftovers");
        let out = dir.join("out");
        // A process that is gone (pid_max on Linux is at most 2^22).
        let dead = 4_194_304 + 17;
        std::fs::write(dir.join("out.lock"), stale_lock(dead)).unwrap();
        // Its staging folder (marked) and a look-alike of another dead process (unmarked).
        let staging = dir.join(format!("out.staging-{dead}"));
        std::fs::create_dir(&staging).unwrap();
        mark(staging.as_path(), dead);
        let look_alike = dir.join(format!("out.staging-{}", dead + 1));
        std::fs::create_dir(&look_alike).unwrap();
        std::fs::write(look_alike.join("thesis.tex"), "mine").unwrap();
        // The previous run it had moved aside.
        let old = dir.join(format!("out.old-{dead}"));
        std::fs::create_dir(&old).unwrap();
        mark(old.as_path(), dead);
        std::fs::write(old.join("results.json"), RUN_RESULTS).unwrap();

        let folder = ResultFolder::acquire(&out).unwrap();
        assert!(!staging.exists(), "the dead run's staging folder goes");
        assert!(
            out.join("results.json").is_file(),
            "its previous run is back in place"
        );
        assert!(
            look_alike.join("thesis.tex").is_file(),
            "a look-alike is kept"
        );
        drop(folder);
        assert!(!dir.join("out.lock").exists());
    }

    #[test]
    fn a_moved_aside_run_with_something_of_the_users_in_it_is_kept() {
        let dir = scratch("old-with-notes");
        let dead = 4_194_304 + 18;
        std::fs::write(dir.join("out.lock"), stale_lock(dead)).unwrap();
        std::fs::create_dir(dir.join("out")).unwrap();
        std::fs::write(dir.join("out/results.json"), RUN_RESULTS).unwrap();
        let old = dir.join(format!("out.old-{dead}"));
        std::fs::create_dir(&old).unwrap();
        mark(old.as_path(), dead);
        std::fs::write(old.join("notes.txt"), "mine").unwrap();
        drop(ResultFolder::acquire(&dir.join("out")).unwrap());
        assert!(old.join("notes.txt").is_file());
    }

    #[test]
    fn a_lock_the_tool_did_not_write_is_left_alone() {
        let dir = scratch("foreign-lock");
        std::fs::write(dir.join("out.lock"), "my lock\n").unwrap();
        let e = ResultFolder::acquire(&dir.join("out")).unwrap_err();
        assert!(e.contains("is not a lock clusterlab wrote"), "{e}");
        assert_eq!(
            std::fs::read_to_string(dir.join("out.lock")).unwrap(),
            "my lock\n"
        );
    }
}
