//! Variant files: parse (RON, strict), check, and report what is wrong where.

mod check;
mod schema;

pub use check::{
    MAX_BIG_TILES, MAX_CAP, MAX_CLUSTERS, MAX_GRID_XY, MAX_GRID_Z, MAX_SHADOW_RAYS, NORMAL_BITS,
    Problem, SAMPLE_COUNTS, check,
};
pub use schema::*;

use std::path::{Path, PathBuf};

/// Largest variant file read.
pub const MAX_VARIANT_BYTES: u64 = crate::files::read::VARIANT.limit;

/// Why a variant file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum VariantError {
    /// Not something to read as a variant: missing, a device, pipe or folder, too large, or
    /// not UTF-8 text.
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
    let text = crate::files::read_text(path, crate::files::read::VARIANT).map_err(|e| {
        VariantError::NotAVariantFile {
            path: path.to_path_buf(),
            why: e.why,
        }
    })?;
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
        let mut message = e.code.to_string();
        if e.code == ron::Error::IntegerOutOfBounds
            && let Some(field) = field_before(text, pos.line, pos.col)
            && let Some(range) = integer_range(&field)
        {
            message = format!("{message}: field `{field}` takes whole numbers in {range}");
        }
        VariantError::Syntax {
            path: path.to_path_buf(),
            line: pos.line,
            column: pos.col,
            message,
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

/// The folder a variant name is looked for in.
pub const FOLDER: &str = "variants";

/// A variant argument: a path, or the name of a file in the working folder's `variants/`
/// (`forward_plus` is `variants/forward_plus.ron`) or else in the shipped `variants/` of the
/// tree the program was built from (and `variants` itself, where the working folder has
/// none, the tree's folder). An unknown one is an error that says where it was looked for
/// and names the nearest variants there.
pub fn locate(arg: &str) -> Result<PathBuf, String> {
    let path = PathBuf::from(arg);
    // Anything there, a broken or looping link too: reading it says what is wrong with it.
    if std::fs::symlink_metadata(&path).is_ok() {
        return Ok(path);
    }
    let folders = [
        PathBuf::from(FOLDER),
        Path::new(env!("CARGO_MANIFEST_DIR")).join(FOLDER),
    ];
    // `variants` itself (the default of `matrix` and `validate`) outside a tree: the tree's.
    if arg == FOLDER && folders[1].is_dir() {
        return Ok(folders[1].clone());
    }
    let file = format!("{arg}.ron");
    if let Some(found) = folders.iter().map(|f| f.join(&file)).find(|p| p.is_file()) {
        return Ok(found);
    }
    let known: Vec<String> = folders
        .iter()
        .flat_map(|f| find_files(f).unwrap_or_default())
        .filter_map(|p| Some(p.file_stem()?.to_string_lossy().into_owned()))
        .collect();
    Err(format!(
        "no variant `{arg}`: no file or folder {}, and no {file} in {} or {}{}",
        path.display(),
        folders[0].display(),
        folders[1].display(),
        crate::names::did_you_mean(arg, known.iter().map(String::as_str))
    ))
}

/// Every variant of `args` (files, folders of them, or names in `variants/`), loaded; the
/// first that cannot be found or read is the error, with its file, line and column.
pub fn load_args(args: &[String]) -> Result<Vec<LoadedVariant>, String> {
    let mut out = Vec::new();
    for arg in args {
        let path = locate(arg)?;
        let files = find_files(&path)?;
        if files.is_empty() {
            return Err(format!("{}: no .ron variant files there", path.display()));
        }
        for file in files {
            out.push(load(&file).map_err(|e| e.to_string())?);
        }
    }
    Ok(out)
}

/// The variant files under `path` (a file, or a folder searched for `*.ron`), sorted.
pub fn find_files(path: &Path) -> Result<Vec<PathBuf>, String> {
    let meta = std::fs::metadata(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            format!("{}: no such file or folder", path.display())
        } else {
            format!(
                "{}: cannot read: {}",
                path.display(),
                crate::files::describe(&e)
            )
        }
    })?;
    if !meta.is_dir() {
        return Ok(vec![path.to_path_buf()]);
    }
    let entries = std::fs::read_dir(path).map_err(|e| {
        format!(
            "{}: cannot read folder: {}",
            path.display(),
            crate::files::describe(&e)
        )
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    files.sort();
    Ok(files)
}

/// The name of the field whose value is at `line`:`col` (1-based): the last `name:` before
/// it (a tuple's elements have no names of their own).
fn field_before(text: &str, line: usize, col: usize) -> Option<String> {
    let start: usize = text
        .split_inclusive('\n')
        .take(line - 1)
        .map(str::len)
        .sum();
    let before = text.get(..start + col.saturating_sub(1))?;
    let colon = before.rfind(':')?;
    let name: String = before[..colon]
        .trim_end()
        .chars()
        .rev()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect();
    (!name.is_empty()).then_some(name)
}

/// Characters of a source line a snippet shows on each side of the caret: a long line (a
/// file written on one line) is cut to the part around the place, with `...` for the rest.
pub const SNIPPET_REACH: usize = 60;

/// The source line with a caret under `col` (both 1-based), as compilers print it; at most
/// [`SNIPPET_REACH`] characters either side of the caret, control characters escaped.
pub fn caret_snippet(text: &str, line: usize, col: usize) -> String {
    let Some(src) = text.lines().nth(line.saturating_sub(1)) else {
        return String::new();
    };
    let chars: Vec<char> = src.chars().collect();
    let at = col.saturating_sub(1).min(chars.len());
    let start = at.saturating_sub(SNIPPET_REACH);
    let end = (at + SNIPPET_REACH).min(chars.len());
    let shown = |c: &char| {
        if c.is_control() && *c != '\t' {
            '?'
        } else {
            *c
        }
    };
    let before = if start > 0 { "..." } else { "" };
    let after = if end < chars.len() { "..." } else { "" };
    let body: String = chars[start..end].iter().map(shown).collect();
    let gutter = format!("{line:>4} | ");
    let pad: String = chars[start..at]
        .iter()
        .map(|&c| if c == '\t' { '\t' } else { ' ' })
        .collect();
    format!(
        "{gutter}{before}{body}{after}\n{}{}{pad}^",
        " ".repeat(gutter.len()),
        " ".repeat(before.len())
    )
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

/// The variant file's JSON schema (`explain` prints it field by field).
pub fn schema() -> serde_json::Value {
    serde_json::to_value(schemars::schema_for!(Variant)).unwrap_or(serde_json::Value::Null)
}

/// The whole numbers field `name` (a field name, anywhere in the schema) takes, for a
/// message about a number out of range: `0..=4294967295 (u32)`.
pub fn integer_range(name: &str) -> Option<String> {
    fn find<'a>(v: &'a serde_json::Value, name: &str) -> Option<&'a serde_json::Value> {
        match v {
            serde_json::Value::Object(map) => map
                .get("properties")
                .and_then(|p| p.get(name))
                .or_else(|| map.values().find_map(|inner| find(inner, name))),
            serde_json::Value::Array(items) => items.iter().find_map(|inner| find(inner, name)),
            _ => None,
        }
    }
    fn format(v: &serde_json::Value) -> Option<&str> {
        v["format"].as_str().or_else(|| {
            let items = v["prefixItems"].as_array().or(v["anyOf"].as_array())?;
            items.iter().find_map(format)
        })
    }
    let schema = schema();
    let range = match format(find(&schema, name)?)? {
        "uint8" => "0..=255 (u8)",
        "uint16" => "0..=65535 (u16)",
        "uint32" => "0..=4294967295 (u32)",
        "uint64" => "0..=18446744073709551615 (u64)",
        "int32" => "-2147483648..=2147483647 (i32)",
        _ => return None,
    };
    Some(range.to_string())
}
