//! Turning an error position in composed WGSL back into the module file it came from.
//!
//! naga reports spans in the composed text. wesl's source map names, for every emitted
//! (mangled) declaration, its module and original name. So: find the composed declaration
//! around the span, map it to its module, find that declaration in the module's own text,
//! and inside it find the same tokens as the span's (identifiers unmangled). The result is
//! the module's own file, line and column.

use wesl::{BasicSourceMap, ModulePath, SourceMap};

/// A place in a shader module's own source file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SourceLocation {
    /// File name relative to the repository root (or the module path when it has none).
    pub file: String,
    /// 1-based line and column.
    pub line: usize,
    pub column: usize,
    /// The source line and a caret line under the error.
    pub snippet: String,
}

/// Map byte `offset` (with `len` bytes) of `composed` to its module file, when the source map
/// knows the declaration it falls in.
pub fn locate(
    composed: &str,
    offset: usize,
    len: usize,
    sourcemap: &BasicSourceMap,
    root: &ModulePath,
) -> Option<SourceLocation> {
    let decl_name = enclosing_declaration(composed, offset)?;
    let (module, original) = match sourcemap.get_decl(&decl_name) {
        Some((path, name)) => (path.clone(), name.to_string()),
        // Declarations of the root module are not mangled.
        None => (root.clone(), decl_name.clone()),
    };
    let source = sourcemap.get_source(&module)?;
    let file = sourcemap
        .get_display_name(&module)
        .map(str::to_string)
        .unwrap_or_else(|| module.to_string());

    let decl_start = find_declaration(source, &original)?;
    let decl_end = next_declaration(source, decl_start).unwrap_or(source.len());
    let end = (offset + len.max(1)).min(composed.len());
    let wanted: Vec<String> = tokens(&composed[offset..end])
        .into_iter()
        .map(|(_, t)| unmangle(&t, sourcemap))
        .collect();
    let region = &source[decl_start..decl_end];
    let module_tokens = tokens_collapsing_paths(region);
    // Longest prefix of the span's tokens that occurs in the declaration.
    let at = (1..=wanted.len().min(12))
        .rev()
        .find_map(|n| {
            module_tokens
                .windows(n)
                .find(|w| w.iter().map(|(_, t)| t).eq(wanted[..n].iter()))
                .map(|w| w[0].0)
        })
        .map_or(decl_start, |rel| decl_start + rel);
    let (line, column) = line_column(source, at);
    Some(SourceLocation {
        file,
        line,
        column,
        snippet: crate::variant::caret_snippet(source, line, column),
    })
}

fn unmangle(token: &str, sourcemap: &BasicSourceMap) -> String {
    sourcemap
        .get_decl(token)
        .map(|(_, name)| name.to_string())
        .unwrap_or_else(|| token.to_string())
}

/// The name of the top-level declaration that contains byte `offset`. wesl prints every
/// top-level declaration (or its attributes) from column 0 and indents everything inside.
fn enclosing_declaration(text: &str, offset: usize) -> Option<String> {
    let line_start = text[..offset.min(text.len())]
        .rfind('\n')
        .map_or(0, |i| i + 1);
    // Walk back to the closest column-0 line that names a declaration; if the span sits in
    // a declaration's attribute lines, walk forward instead.
    let mut starts: Vec<usize> = vec![0];
    starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
    let here = starts.iter().position(|&s| s == line_start)?;
    for &s in starts[..=here].iter().rev() {
        let line = line_at(text, s);
        if let Some(name) = declared_name(line) {
            return Some(name);
        }
        if !line.starts_with(|c: char| c.is_whitespace() || c == '}' || c == '@')
            && !line.is_empty()
        {
            break;
        }
    }
    starts[here..]
        .iter()
        .map(|&s| line_at(text, s))
        .take_while(|l| l.starts_with('@') || declared_name(l).is_some())
        .find_map(declared_name)
}

fn line_at(text: &str, start: usize) -> &str {
    let rest = &text[start..];
    &rest[..rest.find('\n').unwrap_or(rest.len())]
}

/// `fn name`, `struct name`, `const name`, `override name`, `alias name`, `var<...> name`
/// at the start of a line (after attributes), or `None`.
fn declared_name(line: &str) -> Option<String> {
    if line.starts_with(char::is_whitespace) {
        return None;
    }
    let mut rest = line.trim_start();
    while let Some(after) = rest.strip_prefix('@') {
        // Skip one attribute: a name and an optional parenthesised argument list.
        let name_end = after
            .find(|c: char| !(c.is_alphanumeric() || c == '_'))
            .unwrap_or(after.len());
        let mut r = after[name_end..].trim_start();
        if r.starts_with('(') {
            r = &r[r.find(')')? + 1..];
        }
        rest = r.trim_start();
    }
    for keyword in ["fn", "struct", "const", "override", "alias", "var"] {
        if let Some(after) = rest.strip_prefix(keyword) {
            let mut after = after;
            if keyword == "var" && after.starts_with('<') {
                after = &after[after.find('>')? + 1..];
            } else if !after.starts_with(char::is_whitespace) {
                continue;
            }
            let name: String = after
                .trim_start()
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            return (!name.is_empty()).then_some(name);
        }
    }
    None
}

/// Byte offset of the line that declares `name` at top level in module `source`.
fn find_declaration(source: &str, name: &str) -> Option<usize> {
    let mut offset = 0;
    for line in source.split_inclusive('\n') {
        if declared_name(line.trim_end()).as_deref() == Some(name) {
            return Some(offset);
        }
        offset += line.len();
    }
    None
}

fn next_declaration(source: &str, after: usize) -> Option<usize> {
    let mut offset = after;
    let mut first = true;
    for line in source[after..].split_inclusive('\n') {
        if !first && (declared_name(line.trim_end()).is_some() || line.starts_with('@')) {
            return Some(offset);
        }
        first = false;
        offset += line.len();
    }
    None
}

/// Tokens with their byte offsets: identifiers, numbers, and single punctuation characters;
/// whitespace and `//` comments skipped.
fn tokens(text: &str) -> Vec<(usize, String)> {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i] as char;
        if c.is_whitespace() {
            i += 1;
        } else if text[i..].starts_with("//") {
            i += text[i..].find('\n').unwrap_or(text.len() - i);
        } else if c.is_alphanumeric() || c == '_' {
            let start = i;
            while i < bytes.len()
                && ((bytes[i] as char).is_alphanumeric()
                    || bytes[i] == b'_'
                    || bytes[i] == b'.' && (bytes[start] as char).is_ascii_digit())
            {
                i += 1;
            }
            out.push((start, text[start..i].to_string()));
        } else {
            let len = c.len_utf8();
            out.push((i, text[i..i + len].to_string()));
            i += len;
        }
    }
    out
}

/// Like [`tokens`], but a module path `a::b::name` becomes the single token `name`.
fn tokens_collapsing_paths(text: &str) -> Vec<(usize, String)> {
    let raw = tokens(text);
    let mut out: Vec<(usize, String)> = Vec::with_capacity(raw.len());
    let mut i = 0;
    while i < raw.len() {
        if i + 3 < raw.len() && raw[i + 1].1 == ":" && raw[i + 2].1 == ":" {
            let start = raw[i].0;
            i += 3;
            while i + 3 < raw.len() && raw[i + 1].1 == ":" && raw[i + 2].1 == ":" {
                i += 3;
            }
            out.push((start, raw[i].1.clone()));
        } else {
            out.push(raw[i].clone());
        }
        i += 1;
    }
    out
}

/// 1-based line and column (in characters) of byte `offset`.
pub fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, before[line_start..].chars().count() + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn declared_names() {
        assert_eq!(
            declared_name("fn foo(x: f32) -> f32 {").as_deref(),
            Some("foo")
        );
        assert_eq!(
            declared_name("@group(0) @binding(1) var<storage, read> lights: array<L>;").as_deref(),
            Some("lights")
        );
        assert_eq!(declared_name("const A: u32 = 1u;").as_deref(), Some("A"));
        assert_eq!(declared_name("    let x = 1;"), None);
        assert_eq!(declared_name("function"), None);
    }

    #[test]
    fn paths_collapse_to_their_last_name() {
        let t: Vec<String> = tokens_collapsing_paths("a + lights::window(d)")
            .into_iter()
            .map(|(_, t)| t)
            .collect();
        assert_eq!(t, ["a", "+", "window", "(", "d", ")"]);
    }

    #[test]
    fn enclosing_declaration_of_a_body_line() {
        let text = "struct S {\n    a: f32\n}\n\nfn f() {\n    let x = 1;\n}\n";
        let offset = text.find("let").unwrap();
        assert_eq!(enclosing_declaration(text, offset).as_deref(), Some("f"));
        assert_eq!(enclosing_declaration(text, 12).as_deref(), Some("S"));
    }
}
