//! Single-file writes: through a temporary file of this process beside the target, renamed
//! over it when whole, so an interrupted write never leaves half a file. A target that
//! exists and is not a regular file (a folder, a symbolic link, a device, a pipe) is refused:
//! renaming over it would replace something the tool did not make.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::{describe, shown};

/// Write `bytes` to `path`, replacing it only when it is a regular file.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), String> {
    check_target(path)?;
    let (tmp, mut file) = temporary_beside(path)?;
    // A file replaced keeps its permissions (a private 0600 file stays private).
    let kept = match std::fs::metadata(path) {
        Ok(meta) => file.set_permissions(meta.permissions()),
        Err(_) => Ok(()),
    };
    let written = kept
        .and_then(|()| file.write_all(bytes))
        .and_then(|()| file.flush());
    drop(file);
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(format!("{}: cannot write: {}", shown(path), describe(&e)));
    }
    // Looked at again: the target may have appeared since.
    if let Err(e) = check_target(path) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        format!("{}: cannot write: {}", shown(path), describe(&e))
    })
}

/// Move `from`, a file this tool wrote, over `to` (a pending snapshot over the reviewed
/// one), replacing `to` only when it is a regular file.
pub fn promote(from: &Path, to: &Path) -> Result<(), String> {
    check_target(to)?;
    std::fs::rename(from, to).map_err(|e| {
        format!(
            "{}: cannot move over {}: {}",
            shown(from),
            shown(to),
            describe(&e)
        )
    })
}

/// Remove `path`, a regular file this tool wrote; a missing one is already gone.
pub fn remove_own_file(path: &Path) -> Result<(), String> {
    match std::fs::symlink_metadata(path) {
        Ok(meta) if meta.file_type().is_file() => std::fs::remove_file(path)
            .map_err(|e| format!("{}: cannot remove: {}", shown(path), describe(&e))),
        Ok(meta) => Err(format!(
            "{}: is {}, not a file clusterlab wrote: left as it is",
            shown(path),
            what_is(&meta)
        )),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(format!("{}: {}", shown(path), describe(&e))),
    }
}

/// Create folder `dir` and the folders above it that are missing; an existing folder (or a
/// link to one) is kept as it is.
pub fn create_folder(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir)
        .map_err(|e| format!("{}: cannot create folder: {}", shown(dir), describe(&e)))
}

/// Refuse `dir` as a folder to write files into when it exists and is not a folder (or a
/// link to one): said before any work, not after it.
pub fn check_folder(dir: &Path, option: &str) -> Result<(), String> {
    match std::fs::metadata(dir) {
        Ok(meta) if meta.is_dir() => Ok(()),
        Ok(meta) => Err(format!(
            "{option} `{}` is {}, not a folder: clusterlab writes its files into a folder; give a new path or a folder",
            shown(dir),
            what_is(&meta)
        )),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(format!("{option} `{}`: {}", shown(dir), describe(&e))),
    }
}

/// Refuse a target that exists and is not a regular file.
fn check_target(path: &Path) -> Result<(), String> {
    match std::fs::symlink_metadata(path) {
        Ok(meta) if meta.file_type().is_file() => Ok(()),
        Ok(meta) => Err(format!(
            "{}: exists and is {}; clusterlab writes over regular files only: remove it or give another path",
            shown(path),
            what_is(&meta)
        )),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(format!("{}: cannot write: {}", shown(path), describe(&e))),
    }
}

/// What a file that is not a regular one is, in words.
pub fn what_is(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a named pipe";
        }
        if t.is_block_device() || t.is_char_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_symlink() {
        "a symbolic link"
    } else if t.is_dir() {
        "a folder"
    } else if t.is_file() {
        "a regular file"
    } else {
        "not a regular file"
    }
}

/// A new file beside `path` that no one else has: `.NAME.tmp-PID-N`, created exclusively (so
/// a file or link already there under that name is never written through).
fn temporary_beside(path: &Path) -> Result<(PathBuf, std::fs::File), String> {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| format!("{}: not a file name", shown(path)))?;
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty());
    for _ in 0..64 {
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let tmp_name = format!(".{name}.tmp-{}-{n}", std::process::id());
        let tmp = dir.map_or_else(|| PathBuf::from(&tmp_name), |d| d.join(&tmp_name));
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
        {
            Ok(file) => return Ok((tmp, file)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => {
                return Err(format!("{}: cannot write: {}", shown(path), describe(&e)));
            }
        }
    }
    Err(format!(
        "{}: cannot write: no free temporary name beside it",
        shown(path)
    ))
}
