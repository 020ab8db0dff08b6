//! A run owns its result folder: a lock file beside it names the process that writes it, the
//! run writes into a staging folder beside it, and only a finished run is swapped in, whole.
//! So the folder always holds one complete run (report, CSV, JSON and the images they
//! reference, nothing else), and an interrupted run leaves the previous one as it was.
//!
//! For `--out out/matrix`: the lock is `out/matrix.lock`, the staging folder
//! `out/matrix.staging-PID`. A lock or staging folder left by a process that no longer runs
//! (killed) is taken over or removed by the next run.

use std::path::{Path, PathBuf};

/// The folder a run is writing, and the lock that keeps other runs out of it.
#[derive(Debug)]
pub struct RunFolder {
    /// Where the finished run goes.
    pub target: PathBuf,
    /// Where the run writes meanwhile.
    pub staging: PathBuf,
    lock: PathBuf,
    /// The staging folder is in place, or kept because it could not be put there.
    committed: bool,
}

fn sibling(target: &Path, suffix: &str) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    target.with_file_name(format!("{name}{suffix}"))
}

/// Whether process `pid` is running (Linux: /proc; elsewhere assumed running).
fn alive(pid: u32) -> bool {
    if !Path::new("/proc/self").exists() {
        return true;
    }
    Path::new(&format!("/proc/{pid}")).exists()
}

impl RunFolder {
    /// Lock `target` for this process and make an empty staging folder beside it. Refused,
    /// naming the other process, while another live process holds the lock.
    pub fn acquire(target: &Path) -> Result<RunFolder, String> {
        let target = target.to_path_buf();
        if target.file_name().is_none() {
            return Err(format!(
                "--out `{}` does not name a folder of its own (a run replaces its folder whole): give one, e.g. out/matrix",
                target.display()
            ));
        }
        if let Some(parent) = target.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent)
                .map_err(|e| format!("{}: cannot create folder: {e}", parent.display()))?;
        }
        let lock = sibling(&target, ".lock");
        let me = std::process::id();
        let claim = format!("{me}\n{}\n", std::env::args().collect::<Vec<_>>().join(" "));
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&lock)
            {
                Ok(mut f) => {
                    use std::io::Write;
                    f.write_all(claim.as_bytes())
                        .map_err(|e| format!("{}: cannot write: {e}", lock.display()))?;
                    let folder = RunFolder {
                        staging: sibling(&target, &format!(".staging-{me}")),
                        target,
                        lock,
                        committed: false,
                    };
                    folder.clean_stale_staging();
                    std::fs::create_dir_all(&folder.staging).map_err(|e| {
                        format!("{}: cannot create folder: {e}", folder.staging.display())
                    })?;
                    return Ok(folder);
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let held = std::fs::read_to_string(&lock).unwrap_or_default();
                    let mut lines = held.lines();
                    let pid = lines.next().and_then(|p| p.trim().parse::<u32>().ok());
                    match pid {
                        Some(pid) if pid != me && alive(pid) => {
                            return Err(format!(
                                "{} is in use by process {pid} (`{}`), which holds {}; wait for it to finish or choose another --out",
                                target.display(),
                                lines.next().unwrap_or("?"),
                                lock.display()
                            ));
                        }
                        // Left by a process that is gone (or unreadable, as a half-written
                        // lock of a killed one): take it over.
                        _ => {
                            let _ = std::fs::remove_file(&lock);
                        }
                    }
                }
                Err(e) => return Err(format!("{}: cannot create lock: {e}", lock.display())),
            }
        }
        Err(format!(
            "{}: another run took the lock as this one was taking over a stale one; try again",
            lock.display()
        ))
    }

    /// Remove staging folders of this target left by processes that are gone.
    fn clean_stale_staging(&self) {
        let Some(parent) = self.target.parent() else {
            return;
        };
        let parent = if parent.as_os_str().is_empty() {
            Path::new(".")
        } else {
            parent
        };
        let prefix = sibling(&self.target, ".staging-")
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let Ok(entries) = std::fs::read_dir(parent) else {
            return;
        };
        let old_prefix = prefix.replace(".staging-", ".old-");
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            let gone = |p: &str| {
                name.strip_prefix(p)
                    .and_then(|pid| pid.parse::<u32>().ok())
                    .is_some_and(|pid| !alive(pid) || pid == std::process::id())
            };
            if gone(&prefix) {
                let _ = std::fs::remove_dir_all(entry.path());
            } else if gone(&old_prefix) {
                // Killed between the two renames of a swap: the previous run goes back.
                if self.target.exists() {
                    let _ = std::fs::remove_dir_all(entry.path());
                } else {
                    let _ = std::fs::rename(entry.path(), &self.target);
                }
            }
        }
    }

    /// Swap the finished run in: the previous folder out, the staging folder in its place.
    pub fn commit(mut self) -> Result<(), String> {
        let old = sibling(&self.target, &format!(".old-{}", std::process::id()));
        let had_old = self.target.exists();
        // Where a rename fails, the finished run stays in its staging folder rather than
        // being lost, and the message says where.
        if had_old && let Err(e) = std::fs::rename(&self.target, &old) {
            self.committed = true;
            return Err(format!(
                "{}: cannot move the previous run aside: {e}; the finished run is in {}",
                self.target.display(),
                self.staging.display()
            ));
        }
        if let Err(e) = std::fs::rename(&self.staging, &self.target) {
            if had_old {
                let _ = std::fs::rename(&old, &self.target);
            }
            self.committed = true;
            return Err(format!(
                "{}: cannot move the finished run in place: {e}; it is in {}",
                self.target.display(),
                self.staging.display()
            ));
        }
        if had_old {
            let _ = std::fs::remove_dir_all(&old);
        }
        self.committed = true;
        Ok(())
    }
}

impl Drop for RunFolder {
    /// An unfinished run (an error) leaves no staging folder; the lock goes either way.
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
        let _ = std::fs::remove_file(&self.lock);
    }
}
