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

use std::path::Path;

/// An I/O error in words, naming a symbolic link loop as one (`std` calls it "too many
/// levels of symbolic links").
pub fn describe(e: &std::io::Error) -> String {
    #[cfg(unix)]
    if e.raw_os_error() == Some(libc::ELOOP) {
        return "it is a symbolic link that leads back to itself (a loop), so there is no file to read".into();
    }
    e.to_string()
}

/// `path` as shown in messages.
fn shown(path: &Path) -> String {
    path.display().to_string()
}
