//! Variant files: parse (RON, strict), check, and report what is wrong where.

mod check;
mod schema;

pub use check::{
    MAX_BIG_TILES, MAX_CAP, MAX_CLUSTERS, MAX_GRID_XY, MAX_GRID_Z, NORMAL_BITS, Problem, check,
};
pub use schema::*;

use std::path::{Path, PathBuf};

/// Largest variant file read: 64 KiB, thirty times the largest shipped one.
pub const MAX_VARIANT_BYTES: u64 = 64 * 1024;

/// Why a variant file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum VariantError {
    #[error("{}: cannot read: {error}", path.display())]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// Not something to read as a variant: a device, pipe or folder, or too large.
    #[error("{}: {why}", path.display())]
    NotAVariantFile { path: PathBuf, why: String },
    /// The text is not a well-formed variant (RON syntax, unknown field or variant, wrong type).
    #[error("{}:{line}:{column}: {message}\n{snippet}", path.display())]
    Syntax {
        path: PathBuf,
        line: usize,
        column: usize,
        message: String,
        snippet: String,
    },
    /// Well-formed, but some values are out of range or do not go together.
    #[error("{}", located(path, problems))]
    Invalid {
        path: PathBuf,
        problems: Vec<LocatedProblem>,
    },
}

/// A [`Problem`] with the place in the file where its field is written, when it is.
#[derive(Debug)]
pub struct LocatedProblem {
    pub problem: Problem,
    pub at: Option<(usize, usize)>,
}

/// The problems of an invalid file, one a line, each at its place when known.
fn located(path: &Path, problems: &[LocatedProblem]) -> String {
    let lines: Vec<String> = problems
        .iter()
        .map(|p| {
            let at = match p.at {
                Some((line, col)) => format!("{}:{line}:{col}", path.display()),
                None => path.display().to_string(),
            };
            format!("{at}: field `{}` {}", p.problem.field, p.problem.message)
        })
        .collect();
    lines.join("\n")
}

/// A parsed and checked variant, with where it came from.
#[derive(Clone, Debug)]
pub struct LoadedVariant {
    /// The file stem: `variants/clustered_deferred.ron` is `clustered_deferred`.
    pub name: String,
    pub path: PathBuf,
    pub variant: Variant,
}

/// Read, parse and check one variant file.
pub fn load(path: &Path) -> Result<LoadedVariant, VariantError> {
    let io = |error| VariantError::Io {
        path: path.to_path_buf(),
        error,
    };
    let refuse = |why: String| VariantError::NotAVariantFile {
        path: path.to_path_buf(),
        why,
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(refuse(
            "not a regular file (a folder, device or pipe); a variant is a .ron file".into(),
        ));
    }
    if meta.len() > MAX_VARIANT_BYTES {
        return Err(refuse(format!(
            "{} bytes, over the {MAX_VARIANT_BYTES} bytes a variant file may have (the shipped ones are under 2 KiB)",
            meta.len()
        )));
    }
    // Read at most the limit, in case the file grew since.
    let mut text = String::new();
    std::io::Read::read_to_string(
        &mut std::io::Read::take(std::fs::File::open(path).map_err(io)?, MAX_VARIANT_BYTES),
        &mut text,
    )
    .map_err(io)?;
    let variant = parse(path, &text)?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "variant".into());
    Ok(LoadedVariant {
        name,
        path: path.to_path_buf(),
        variant,
    })
}

/// Parse and check variant text; `path` only names the source in errors.
pub fn parse(path: &Path, text: &str) -> Result<Variant, VariantError> {
    // `implicit_some` lets a file write `toon: (bands: 4)` rather than `toon: Some((bands: 4))`.
    let options =
        ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
    let variant: Variant = options.from_str(text).map_err(|e| {
        let pos = e.span.start;
        VariantError::Syntax {
            path: path.to_path_buf(),
            line: pos.line,
            column: pos.col,
            message: e.code.to_string(),
            snippet: caret_snippet(text, pos.line, pos.col),
        }
    })?;
    let problems = check(&variant);
    if problems.is_empty() {
        Ok(variant)
    } else {
        Err(VariantError::Invalid {
            path: path.to_path_buf(),
            problems: problems
                .into_iter()
                .map(|problem| LocatedProblem {
                    at: locate_field(text, &problem.field),
                    problem,
                })
                .collect(),
        })
    }
}

/// A variant argument: a path, or the name of a file in `variants/` (`forward_plus` is
/// `variants/forward_plus.ron`). An unknown name comes back as the path it was, so that
/// reading it names what was asked for.
pub fn resolve(arg: &str) -> PathBuf {
    let path = PathBuf::from(arg);
    if path.exists() {
        return path;
    }
    let in_folder = Path::new("variants").join(format!("{arg}.ron"));
    if in_folder.exists() { in_folder } else { path }
}

/// The variant files under `path` (a file, or a folder searched for `*.ron`), sorted.
pub fn find_files(path: &Path) -> std::io::Result<Vec<PathBuf>> {
    if path.is_dir() {
        let mut files: Vec<PathBuf> = std::fs::read_dir(path)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "ron"))
            .collect();
        files.sort();
        Ok(files)
    } else if path.exists() {
        Ok(vec![path.to_path_buf()])
    } else {
        Err(std::io::Error::new(
            std::io::ErrorKind::NotFound,
            format!("{}: no such file or folder", path.display()),
        ))
    }
}

/// The source line with a caret under `col` (both 1-based), as compilers print it.
pub fn caret_snippet(text: &str, line: usize, col: usize) -> String {
    let Some(src) = text.lines().nth(line.saturating_sub(1)) else {
        return String::new();
    };
    let gutter = format!("{line:>4} | ");
    let pad: String = src
        .chars()
        .take(col.saturating_sub(1))
        .map(|c| if c == '\t' { '\t' } else { ' ' })
        .collect();
    format!("{gutter}{src}\n{}{pad}^", " ".repeat(gutter.len()))
}

/// Where a dotted field path is written in RON text, found by looking for each segment's
/// `name:` in turn after the previous one. Returns 1-based (line, column) of the last
/// segment found; `None` when the field is not written (a default).
fn locate_field(text: &str, field: &str) -> Option<(usize, usize)> {
    let mut from = 0;
    let mut found = None;
    for segment in field.split('.') {
        let offset = find_key(&text[from..], segment)?;
        from += offset;
        found = Some(from);
        from += segment.len();
    }
    found.map(|at| {
        let before = &text[..at];
        let line = before.matches('\n').count() + 1;
        let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
        (line, col)
    })
}

/// Byte offset of `key` used as a field name (`key` then optional spaces then `:`),
/// outside comments.
fn find_key(text: &str, key: &str) -> Option<usize> {
    let mut search = 0;
    while let Some(i) = text[search..].find(key) {
        let at = search + i;
        search = at + key.len();
        let before_ok = text[..at]
            .chars()
            .next_back()
            .is_none_or(|c| !(c.is_alphanumeric() || c == '_'));
        let after_ok = text[at + key.len()..].trim_start().starts_with(':');
        let line_start = text[..at].rfind('\n').map_or(0, |n| n + 1);
        let in_comment = text[line_start..at].contains("//");
        if before_ok && after_ok && !in_comment {
            return Some(at);
        }
    }
    None
}
