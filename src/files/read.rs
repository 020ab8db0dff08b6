//! Bounded reads: a regular file of at most its kind's limit, checked before reading and
//! again while reading (a file that grows past the limit is refused, not read whole).

use std::io::Read;
use std::path::Path;

use super::{describe, shown};

/// A kind of file the tool reads, with the most bytes it reads of one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Kind {
    /// What the file is, as a message names it ("a variant file").
    pub what: &'static str,
    pub limit: u64,
    /// Why the limit is what it is, said beside it.
    pub why: &'static str,
}

const KIB: u64 = 1 << 10;
const MIB: u64 = 1 << 20;
const GIB: u64 = 1 << 30;

/// A variant file.
pub const VARIANT: Kind = Kind {
    what: "a variant file",
    limit: 64 * KIB,
    why: "the shipped ones are under 2 KiB",
};
/// A matrix run's `results.json` (shards, baselines).
pub const RESULTS: Kind = Kind {
    what: "a results file",
    limit: 256 * MIB,
    why: "about 40,000 cells",
};
/// A WESL or WGSL shader module.
pub const SHADER: Kind = Kind {
    what: "a shader module",
    limit: MIB,
    why: "the largest shipped one is under 40 KiB",
};
/// A `.gltf` file (its JSON, with any data URIs in it).
pub const GLTF: Kind = Kind {
    what: "a .gltf file",
    limit: 512 * MIB,
    why: "keep large data in .bin buffers or a .glb",
};
/// A `.glb` file.
pub const GLB: Kind = Kind {
    what: "a .glb file",
    limit: 2 * GIB,
    why: "a scene's vertices must also fit in GPU buffers",
};
/// A buffer file a `.gltf` refers to.
pub const GLTF_BUFFER: Kind = Kind {
    what: "a glTF buffer",
    limit: 2 * GIB,
    why: "a scene's vertices must also fit in GPU buffers",
};
/// An image file a `.gltf` refers to.
pub const GLTF_IMAGE: Kind = Kind {
    what: "a glTF image",
    limit: 256 * MIB,
    why: "textures are resampled to at most 1024 px a side",
};
/// An image of a result folder, copied by `merge`.
pub const RESULT_IMAGE: Kind = Kind {
    what: "a result image",
    limit: 256 * MIB,
    why: "a 16384 x 16384 image in PNG is under 1 GiB only when it compresses",
};
/// clusterlab's own executable, hashed as its build's identity (`matrix --reuse`).
pub const EXECUTABLE: Kind = Kind {
    what: "clusterlab's executable",
    limit: GIB,
    why: "a debug build is under 200 MiB",
};
/// A marker or lock file the tool writes.
pub const SNAPSHOT: Kind = Kind {
    what: "a snapshot file",
    limit: 16 * MIB,
    why: "the largest shipped one is under 100 KiB",
};

pub const MARKER: Kind = Kind {
    what: "a clusterlab marker",
    limit: 64 * KIB,
    why: "the tool writes a few lines",
};

/// Why a file was not read; shown as `PATH: WHY`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{path}: {why}")]
pub struct ReadError {
    pub path: String,
    pub why: String,
    /// The file does not exist.
    pub missing: bool,
}

/// The bytes of the regular file `path`, at most `kind.limit` of them. Devices, pipes and
/// folders are refused without reading them (a pipe would block, a device never end).
pub fn read(path: &Path, kind: Kind) -> Result<Vec<u8>, ReadError> {
    let too_large = |bytes: String| {
        failure(
            path,
            format!(
                "{bytes} bytes, over the {} bytes {} may have ({})",
                kind.limit, kind.what, kind.why
            ),
            false,
        )
    };
    let (file, length) = open_regular(path, kind)?;
    if length > kind.limit {
        return Err(too_large(length.to_string()));
    }
    let mut bytes = Vec::with_capacity(length as usize);
    file.take(kind.limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| failure(path, format!("cannot read: {}", describe(&e)), false))?;
    if bytes.len() as u64 > kind.limit {
        return Err(too_large(format!("more than {}", kind.limit)));
    }
    Ok(bytes)
}

/// The first `n` bytes of the regular file `path` (fewer when it is shorter) and its
/// length, under [`read`]'s rules: a header looked at before a large file is read whole.
pub fn read_head(path: &Path, n: u64, kind: Kind) -> Result<(Vec<u8>, u64), ReadError> {
    let (file, length) = open_regular(path, kind)?;
    let mut bytes = Vec::new();
    file.take(n)
        .read_to_end(&mut bytes)
        .map_err(|e| failure(path, format!("cannot read: {}", describe(&e)), false))?;
    Ok((bytes, length))
}

fn failure(path: &Path, why: String, missing: bool) -> ReadError {
    ReadError {
        path: shown(path),
        why,
        missing,
    }
}

/// `path` opened for reading, and its length, when it is a regular file (looked at before
/// opening, without blocking, and again after: it may have been replaced between).
fn open_regular(path: &Path, kind: Kind) -> Result<(std::fs::File, u64), ReadError> {
    let meta = std::fs::metadata(path).map_err(|e| {
        failure(
            path,
            format!("cannot read: {}", describe(&e)),
            e.kind() == std::io::ErrorKind::NotFound,
        )
    })?;
    let not_regular = || {
        failure(
            path,
            format!(
                "not a regular file (a folder, device or pipe): {} must be one",
                kind.what
            ),
            false,
        )
    };
    if !meta.is_file() {
        return Err(not_regular());
    }
    let file = open_without_blocking(path).map_err(|e| failure(path, describe(&e), false))?;
    if !file.metadata().is_ok_and(|m| m.is_file()) {
        return Err(not_regular());
    }
    Ok((file, meta.len()))
}

/// The text of `path` (see [`read`] and [`text`]).
pub fn read_text(path: &Path, kind: Kind) -> Result<String, ReadError> {
    let bytes = read(path, kind)?;
    text(bytes).map_err(|why| ReadError {
        path: shown(path),
        why,
        missing: false,
    })
}

/// `bytes` as UTF-8 text, or why not: a byte-order mark is named as one (RON and JSON
/// parsers take it for a stray character), and invalid UTF-8 by its byte offset and line.
pub fn text(bytes: Vec<u8>) -> Result<String, String> {
    if bytes.starts_with(&[0xEF, 0xBB, 0xBF]) {
        return Err(
            "starts with a UTF-8 byte-order mark (bytes EF BB BF), which the parser does not take: save the file as UTF-8 without BOM"
                .into(),
        );
    }
    if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) {
        return Err(
            "is UTF-16 text (it starts with a UTF-16 byte-order mark): save it as UTF-8".into(),
        );
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let line = bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        let column = at - bytes[..at].iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1) + 1;
        format!(
            "is not UTF-8 text: byte {at} (line {line}, column {column}) is 0x{:02X}, which does not begin or continue a UTF-8 character; save the file as UTF-8",
            bytes[at]
        )
    })
}

#[cfg(unix)]
fn open_without_blocking(path: &Path) -> std::io::Result<std::fs::File> {
    use std::os::unix::fs::OpenOptionsExt;
    std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
}

#[cfg(not(unix))]
fn open_without_blocking(path: &Path) -> std::io::Result<std::fs::File> {
    std::fs::File::open(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_names_a_bom_and_the_first_bad_byte() {
        assert!(
            text(b"\xEF\xBB\xBF(a: 1)".to_vec())
                .unwrap_err()
                .contains("byte-order mark")
        );
        let e = text(b"ab\ncd\xFFe".to_vec()).unwrap_err();
        assert!(e.contains("byte 5 (line 2, column 3) is 0xFF"), "{e}");
        assert_eq!(text(b"ok".to_vec()).unwrap(), "ok");
    }
}
