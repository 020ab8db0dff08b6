//! Every read of a file the user named and every write of the tool's own files goes through
//! here, under one rule: a command creates, replaces or deletes only what it made, and reads
//! only what it was given, a bounded number of bytes at a time.
//!
//! - [`read`]: bounded reads of regular files (a stated limit per kind of file, checked
//!   before reading; devices, pipes and folders refused without blocking on them), and text
//!   decoding that names a byte-order mark or the first byte that is not UTF-8.
//! - [`write`]: single files written through a temporary file and a rename, refusing a
//!   target that exists and is not a regular file.
//! - [`folder`]: result folders (`--out` of `matrix` and `merge`): recognised by a marker
//!   file, locked under their canonical path, written beside and swapped in whole.

pub mod folder;
pub mod read;
pub mod write;

pub use folder::ResultFolder;
pub use read::{Kind, read, read_text};
pub use write::write_file;

use std::path::{Path, PathBuf};

/// An I/O error in words, naming a symbolic link loop as one (`std` calls it "too many
/// levels of symbolic links").
pub fn describe(e: &std::io::Error) -> String {
    #[cfg(unix)]
    if e.raw_os_error() == Some(libc::ELOOP) {
        return "it is a symbolic link that leads back to itself (a loop), so there is no file to read".into();
    }
    e.to_string()
}

/// `root` joined with `relative`, a path that stays inside `root`: relative, no `..`, and
/// no part of it that exists a symbolic link (a folder of links could lead anywhere) or,
/// before the last, anything but a folder. `what` names the path in messages ("image path",
/// "State path"). Parts that do not exist yet are allowed: a write creates them.
pub fn inside(root: &Path, relative: &Path, what: &str) -> Result<PathBuf, String> {
    use std::path::Component;
    let refused = |why: &str| {
        Err(format!(
            "{what} `{}` {why}: it must stay inside {}",
            shown(relative),
            shown(root)
        ))
    };
    if relative.as_os_str().is_empty() {
        return refused("is empty");
    }
    let mut at = root.to_path_buf();
    let parts: Vec<Component> = relative.components().collect();
    for (i, part) in parts.iter().enumerate() {
        match part {
            Component::Normal(name) => at.push(name),
            Component::CurDir => continue,
            Component::ParentDir => return refused("climbs out with `..`"),
            Component::RootDir | Component::Prefix(_) => return refused("is absolute"),
        }
        match std::fs::symlink_metadata(&at) {
            Ok(meta) if meta.file_type().is_symlink() => {
                return refused(&format!(
                    "passes through the symbolic link `{}`",
                    shown(&at)
                ));
            }
            Ok(meta) if i + 1 < parts.len() && !meta.is_dir() => {
                return refused(&format!(
                    "passes through `{}`, which is not a folder",
                    shown(&at)
                ));
            }
            _ => {}
        }
    }
    Ok(at)
}

/// `path` as shown in messages.
fn shown(path: &Path) -> String {
    path.display().to_string()
}
