//! How the modules of `src/` may import each other (`docs/ARCHITECTURE.md`, "Data flow"):
//! - a module imports only modules of lower layers (`LAYERS`);
//! - no file of `src/` imports, through any chain, a file that imports it back;
//! - `main.rs` names the commands and dispatches; their arguments and bodies are in
//!   `src/commands/`.
//!
//! Every path is read: `use` trees with nested groups, `crate::`, `super::` chains, `self::`,
//! a child module's name, and items of the crate root. An edge points to the file that
//! defines what is named, through re-exports (`pub use`), which are not edges of their own.

use std::collections::BTreeMap;
use std::path::Path;

/// The layers, lowest first (a module of the crate is a file or folder under `src/`).
/// `commands/` is the binary's (the bodies `main.rs` dispatches to); `main.rs` stands above
/// them all.
const LAYERS: &[&[&str]] = &[
    &[
        "common",
        "files",
        "environment",
        "measure",
        "names",
        "progress",
        "table",
    ],
    &["cpu", "variant", "scene", "flip"],
    &["compose", "gpu", "explain"],
    &["render", "efficiency"],
    &["reference", "metrics"],
    &["run", "bias", "plot"],
    &["sequence"],
    &["kernels", "stress", "matrix"],
    &["study", "view", "snapshot"],
    &["commands"],
];

fn layer(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

/// A module's path in its crate: `src/render/culling/bvh.rs` is `render::culling::bvh`,
/// `src/render/mod.rs` is `render`, `lib.rs` and `main.rs` are the root (empty).
type ModPath = Vec<String>;

/// One crate's files: module path -> source, comments and literals left out.
struct Crate {
    files: BTreeMap<ModPath, String>,
}

impl Crate {
    /// The library (`lib.rs` and every module but `commands/`) or the binary (`main.rs`
    /// and `commands/`).
    fn read(binary: bool) -> Crate {
        let mut paths = Vec::new();
        crate::common::rust_sources(Path::new("src"), &mut paths);
        let mut files = BTreeMap::new();
        for file in paths {
            let path = module_path(file.strip_prefix("src").unwrap());
            let in_binary = file.ends_with("main.rs") && path.is_empty()
                || path.first().is_some_and(|m| m == "commands");
            if in_binary == binary {
                files.insert(path, code_of(&std::fs::read_to_string(&file).unwrap()));
            }
        }
        Crate { files }
    }

    fn of(files: &[(&str, &str)]) -> Crate {
        let files = files
            .iter()
            .map(|(file, source)| (module_path(Path::new(file)), code_of(source)))
            .collect();
        Crate { files }
    }

    /// Every import of `module`: (the file that defines what it names, the path as
    /// written). Re-exports are followed, not listed.
    fn imports(&self, module: &ModPath) -> Vec<(ModPath, String)> {
        let source = &self.files[module];
        let mut found = Vec::new();
        for (start, scope) in path_starts(source, &self.children(module)) {
            let reexport = reexport_at(source, start);
            let base: ModPath = module.iter().chain(&scope).cloned().collect();
            for written in use_tree(&source[start..]) {
                // A re-export is an import only where the file itself uses the name.
                if reexport && !used_outside(source, start, written.last().unwrap()) {
                    continue;
                }
                if let Some(target) = self.absolute(&base, &written)
                    && let Some(defining) = self.defining(&target, 0)
                    && &defining != module
                {
                    let entry = (defining, written.join("::"));
                    if !found.contains(&entry) {
                        found.push(entry);
                    }
                }
            }
        }
        found
    }

    /// Calls of methods defined away from their type: a file that defines type `T` and
    /// calls `.m(` (or `Self::m(`, `T::m(`) where another file's `impl T` block defines `m`
    /// depends on that file: (caller, the file with the block, what is called).
    fn method_calls(&self) -> Vec<(ModPath, ModPath, String)> {
        let mut found = Vec::new();
        for (file, code) in &self.files {
            for (ty, methods) in impl_blocks(code) {
                let defining: Vec<&ModPath> = self
                    .files
                    .iter()
                    .filter(|(_, c)| defines_type(c, &ty))
                    .map(|(m, _)| m)
                    .collect();
                let [home] = defining[..] else { continue };
                if home == file {
                    continue;
                }
                let caller = &self.files[home];
                for m in methods {
                    let calls = [
                        format!(".{m}("),
                        format!("Self::{m}("),
                        format!("{ty}::{m}("),
                    ];
                    if calls.iter().any(|c| caller.contains(c.as_str())) {
                        found.push((home.clone(), file.clone(), format!("{ty}::{m}")));
                    }
                }
            }
        }
        found
    }

    fn children(&self, module: &ModPath) -> Vec<String> {
        self.files
            .keys()
            .filter(|p| p.len() == module.len() + 1 && p.starts_with(module))
            .map(|p| p[module.len()].clone())
            .collect()
    }

    /// `written`, seen from (inline module path) `base`, as a path from the crate root.
    fn absolute(&self, base: &ModPath, written: &[String]) -> Option<ModPath> {
        let mut path = base.clone();
        let mut rest = written;
        match rest.first()?.as_str() {
            "crate" => {
                path.clear();
                rest = &rest[1..];
            }
            "super" | "self" => {
                while let Some(step) = rest.first().filter(|s| *s == "super" || *s == "self") {
                    if step == "super" {
                        path.pop()?;
                    }
                    rest = &rest[1..];
                }
            }
            _ => {}
        }
        path.extend(rest.iter().cloned());
        Some(path)
    }

    /// The file that defines the item at `path` (following `pub use`), or None when the
    /// path leaves the crate.
    fn defining(&self, path: &ModPath, depth: usize) -> Option<ModPath> {
        let mut module = Vec::new();
        while module.len() < path.len() {
            let next: ModPath = path[..module.len() + 1].to_vec();
            if !self.files.contains_key(&next) {
                break;
            }
            module = next;
        }
        if !self.files.contains_key(&module) {
            return None;
        }
        if let Some(item) = path.get(module.len())
            && depth < 16
            && let Some(target) = self.reexported(&module, item)
        {
            let mut through = target;
            through.extend(path[module.len() + 1..].iter().cloned());
            return self.defining(&through, depth + 1).or(Some(module));
        }
        Some(module)
    }

    /// Where `module` re-exports `item` from, as a path from the crate root.
    fn reexported(&self, module: &ModPath, item: &str) -> Option<ModPath> {
        let source = &self.files[module];
        for (start, scope) in path_starts(source, &self.children(module)) {
            if !reexport_at(source, start) {
                continue;
            }
            let base: ModPath = module.iter().chain(&scope).cloned().collect();
            for written in use_tree(&source[start..]) {
                if written.last().is_some_and(|l| l == item) {
                    return self.absolute(&base, &written);
                }
            }
        }
        None
    }
}

fn module_path(relative: &Path) -> ModPath {
    let mut parts: ModPath = relative
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts
        .last()
        .is_some_and(|l| l == "mod" || l == "lib" || l == "main")
    {
        parts.pop();
    }
    parts
}

/// `source` without comments, string and character literals (their text is not code).
fn code_of(source: &str) -> String {
    let mut out = String::with_capacity(source.len());
    let mut chars = source.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '/' if chars.peek() == Some(&'/') => {
                for c in chars.by_ref() {
                    if c == '\n' {
                        out.push('\n');
                        break;
                    }
                }
            }
            '"' => {
                while let Some(c) = chars.next() {
                    match c {
                        '\\' => {
                            chars.next();
                        }
                        '"' => break,
                        _ => {}
                    }
                }
                out.push_str("\"\"");
            }
            '\'' => {
                // A character literal ('x', '\n', '{'), or a lifetime ('a), kept.
                let rest: String = chars.clone().take(3).collect();
                let length = if let Some(escaped) = rest.strip_prefix('\\') {
                    escaped.find('\'').map(|i| i + 2)
                } else {
                    rest.chars().nth(1).filter(|&c| c == '\'').map(|_| 2)
                };
                match length {
                    Some(n) => {
                        for _ in 0..n {
                            chars.next();
                        }
                        out.push_str("' '");
                    }
                    None => out.push(c),
                }
            }
            _ => out.push(c),
        }
    }
    out
}

/// Where a path starts in `code`, each with the inline modules (`mod tests { .. }`) it
/// sits in: `crate::`, `super::`, `self::` or `CHILD::` for a child module of the file.
fn path_starts(code: &str, children: &[String]) -> Vec<(usize, ModPath)> {
    let inline = inline_modules(code);
    let bytes = code.as_bytes();
    let mut starts = Vec::new();
    let mut i = 0;
    while let Some(found) = code[i..].find("::") {
        let end = i + found;
        let mut begin = end;
        while begin > 0 && (bytes[begin - 1].is_ascii_alphanumeric() || bytes[begin - 1] == b'_') {
            begin -= 1;
        }
        let word = &code[begin..end];
        // Not a later part of a path, nor a visibility (`pub(in crate::render)`).
        let first =
            (begin < 2 || &code[begin - 2..begin] != "::") && !code[..begin].ends_with("(in ");
        if first
            && !word.is_empty()
            && (matches!(word, "crate" | "super" | "self") || children.iter().any(|c| c == word))
        {
            let scope = inline
                .iter()
                .filter(|(_, from, to)| (*from..*to).contains(&begin))
                .map(|(name, _, _)| name.clone())
                .collect();
            starts.push((begin, scope));
        }
        i = end + 2;
    }
    starts
}

/// Inline modules of `code` (`mod NAME { .. }`), with the span of their bodies, outermost
/// first.
fn inline_modules(code: &str) -> Vec<(String, usize, usize)> {
    let mut found = Vec::new();
    let mut i = 0;
    while let Some(at) = code[i..].find("mod ") {
        let start = i + at;
        i = start + 4;
        if start > 0 && (code.as_bytes()[start - 1].is_ascii_alphanumeric()) {
            continue;
        }
        let rest = &code[start + 4..];
        let name: String = rest
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        let after = rest[name.len()..].trim_start();
        if name.is_empty() || !after.starts_with('{') {
            continue;
        }
        let open = code.len() - after.len();
        let mut depth = 0;
        for (j, c) in code[open..].char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        found.push((name, open, open + j));
                        break;
                    }
                }
                _ => {}
            }
        }
    }
    found
}

/// The inherent `impl` blocks of `code` (not `impl Trait for T`): each type's name with
/// the methods the block defines.
fn impl_blocks(code: &str) -> Vec<(String, Vec<String>)> {
    let mut found = Vec::new();
    for (at, _) in code.match_indices("\nimpl") {
        let head_end = code[at..].find('{').map_or(code.len(), |i| at + i);
        let head = &code[at + "\nimpl".len()..head_end];
        if head.contains(" for ") {
            continue;
        }
        // `impl<'g> Renderer<'g>`: the name after any generic parameters.
        let head = head.trim_start();
        let head = match head.strip_prefix('<') {
            Some(rest) => &rest[rest.find('>').map_or(0, |i| i + 1)..],
            None => head,
        };
        let name: String = head
            .trim_start()
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        if name.is_empty() {
            continue;
        }
        let body_end = code[head_end..]
            .find("\n}")
            .map_or(code.len(), |i| head_end + i);
        let methods = code[head_end..body_end]
            .lines()
            .filter_map(|l| {
                let l = l.strip_prefix("    ")?;
                let l = l.split("fn ").nth(1).filter(|_| {
                    let before = l.split("fn ").next().unwrap_or("");
                    before.trim().is_empty()
                        || before.trim().starts_with("pub")
                        || before.trim() == "const"
                })?;
                Some(
                    l.chars()
                        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                        .collect::<String>(),
                )
            })
            .collect();
        found.push((name, methods));
    }
    found
}

/// Whether `code` declares type `name` (`struct name`, `enum name`).
fn defines_type(code: &str, name: &str) -> bool {
    ["struct ", "enum "].iter().any(|kind| {
        code.match_indices(&format!("{kind}{name}")).any(|(i, _)| {
            let after = code[i + kind.len() + name.len()..].chars().next();
            !after.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_')
        })
    })
}

/// Whether `name` occurs as a word in `code` outside the statement that holds `start`, and
/// not as a method, another path's item or a module declared (`.name`, `x::name`,
/// `mod name`).
fn used_outside(code: &str, start: usize, name: &str) -> bool {
    let begin = code[..start].rfind(';').map_or(0, |i| i + 1);
    let end = code[start..].find(';').map_or(code.len(), |i| start + i);
    let word = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let bytes = code.as_bytes();
    code.match_indices(name).any(|(i, _)| {
        let j = i + name.len();
        !(begin..end).contains(&i)
            && !code[..i].ends_with("mod ")
            && (i == 0 || !(word(bytes[i - 1]) || bytes[i - 1] == b'.' || bytes[i - 1] == b':'))
            && (j == code.len() || !word(bytes[j]))
    })
}

/// Whether the path at `start` belongs to a `pub use` (or `pub(crate) use`) statement.
fn reexport_at(code: &str, start: usize) -> bool {
    let statement = code[..start].rsplit([';', '}', '{']).next().unwrap_or("");
    let statement = statement.trim_start();
    let statement = statement
        .strip_prefix("#[doc(inline)]")
        .unwrap_or(statement)
        .trim_start();
    statement.starts_with("pub use") || statement.starts_with("pub(crate) use")
}

/// The paths a use tree (or a plain path) at the start of `code` names:
/// `a::{b::{C, d}, E as F, *}` is `a::b::C`, `a::b::d`, `a::E` and `a`.
fn use_tree(code: &str) -> Vec<Vec<String>> {
    let mut paths = Vec::new();
    tree(code, &mut Vec::new(), &mut paths);
    paths
}

/// Reads one tree from `code` below `prefix`; returns the bytes read.
fn tree(code: &str, prefix: &mut Vec<String>, paths: &mut Vec<Vec<String>>) -> usize {
    let mut i = 0;
    let depth = prefix.len();
    let skip_space = |i: &mut usize| {
        while code[*i..].starts_with(char::is_whitespace) {
            *i += code[*i..].chars().next().unwrap().len_utf8();
        }
    };
    loop {
        skip_space(&mut i);
        if code[i..].starts_with('{') {
            i += 1;
            loop {
                skip_space(&mut i);
                if code[i..].starts_with('}') || i >= code.len() {
                    i += 1;
                    break;
                }
                i += tree(&code[i..], prefix, paths);
                skip_space(&mut i);
                if code[i..].starts_with(',') {
                    i += 1;
                }
            }
            break;
        }
        if code[i..].starts_with('*') {
            paths.push(prefix.clone());
            i += 1;
            break;
        }
        let word: String = code[i..]
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        if word.is_empty() {
            paths.push(prefix.clone());
            break;
        }
        i += word.len();
        prefix.push(word);
        skip_space(&mut i);
        if code[i..].starts_with("::") {
            i += 2;
            continue;
        }
        paths.push(prefix.clone());
        break;
    }
    prefix.truncate(depth);
    skip_space(&mut i);
    if code[i..].starts_with("as ") {
        i += 3;
        skip_space(&mut i);
        i += code[i..]
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .count();
    }
    i
}

/// The imports of `module` (a file of `krate`) that climb: to a top-level module of its
/// own layer or above, or to an item of the crate root.
fn climbs(krate: &Crate, module: &ModPath) -> Vec<String> {
    let own = layer(&module[0]).unwrap_or(LAYERS.len());
    krate
        .imports(module)
        .into_iter()
        .filter(|(target, _)| match target.first() {
            None => true,
            Some(top) => top != &module[0] && layer(top).is_none_or(|t| t >= own),
        })
        .map(|(_, written)| written)
        .collect()
}

#[test]
fn no_import_climbs_a_layer() {
    let planted = |files: &[(&str, &str)], module: &str| {
        let krate = Crate::of(files);
        climbs(&krate, &module.split('/').map(String::from).collect())
    };
    // The deliberate breaks, one per way to write an import.
    let files = |source| {
        [
            ("matrix/mod.rs", "pub fn run() {}"),
            ("study/mod.rs", "pub const SCENE: u8 = 0;"),
            (
                "lib.rs",
                "pub mod matrix; pub mod study; pub const ROOT: u8 = 0;",
            ),
            ("common/mod.rs", "pub struct X;"),
            ("files/mod.rs", source),
            ("files/read.rs", source),
        ]
    };
    assert_eq!(
        planted(&files("use crate::matrix::run;"), "files"),
        ["crate::matrix::run"]
    );
    assert_eq!(
        planted(&files("use crate::{files::read, matrix::{run}};"), "files"),
        ["crate::matrix::run"],
        "a nested group"
    );
    assert_eq!(
        planted(
            &files("fn f() { super::super::matrix::run() }"),
            "files/read"
        ),
        ["super::super::matrix::run"],
        "a super:: chain"
    );
    assert_eq!(
        planted(&files("use crate::ROOT;"), "files"),
        ["crate::ROOT"],
        "an item of the crate root"
    );
    assert!(planted(&files("use crate::files::read; // crate::matrix"), "files").is_empty());

    let mut wrong = Vec::new();
    for binary in [false, true] {
        let krate = Crate::read(binary);
        for module in krate.files.keys().filter(|m| !m.is_empty()) {
            assert!(
                layer(&module[0]).is_some(),
                "src/{} is in no layer: add it to LAYERS and to docs/ARCHITECTURE.md",
                module[0]
            );
            for written in climbs(&krate, module) {
                wrong.push(format!("{} imports `{written}`", module.join("::")));
            }
        }
    }
    assert!(wrong.is_empty(), "imports that climb a layer: {wrong:#?}");
}

/// The files on import cycles of `krate`: each strongly connected set of two or more,
/// with the imports between them.
fn cycles(krate: &Crate) -> Vec<Vec<String>> {
    let modules: Vec<&ModPath> = krate.files.keys().collect();
    let index = |m: &ModPath| modules.iter().position(|n| *n == m).unwrap();
    let mut edges: Vec<Vec<(usize, String)>> = modules
        .iter()
        .map(|m| {
            krate
                .imports(m)
                .into_iter()
                .map(|(target, written)| (index(&target), written))
                .collect()
        })
        .collect();
    for (from, to, written) in krate.method_calls() {
        edges[index(&from)].push((index(&to), written));
    }
    // Two files are on one cycle when each reaches the other.
    let reach: Vec<Vec<bool>> = (0..modules.len())
        .map(|from| {
            let mut seen = vec![false; modules.len()];
            let mut stack = vec![from];
            while let Some(at) = stack.pop() {
                for (to, _) in &edges[at] {
                    if !seen[*to] {
                        seen[*to] = true;
                        stack.push(*to);
                    }
                }
            }
            seen
        })
        .collect();
    let name = |i: usize| match modules[i].join("/") {
        root if root.is_empty() => "(root)".to_string(),
        path => path,
    };
    let mut placed = vec![false; modules.len()];
    let mut found = Vec::new();
    for a in 0..modules.len() {
        let set: Vec<usize> = (0..modules.len())
            .filter(|&b| reach[a][b] && reach[b][a])
            .collect();
        if set.len() < 2 || placed[a] {
            continue;
        }
        let mut lines = Vec::new();
        for &from in &set {
            placed[from] = true;
            for (to, written) in edges[from].iter().filter(|(to, _)| set.contains(to)) {
                lines.push(format!("{} -> {} ({written})", name(from), name(*to)));
            }
        }
        found.push(lines);
    }
    found
}

#[test]
fn no_import_cycle() {
    // The deliberate breaks: a child importing its parent's own item while the parent
    // calls the child; two siblings through a re-export.
    let planted = Crate::of(&[
        (
            "render/mod.rs",
            "mod clusters; pub struct Renderer; fn f() { clusters::encode() }",
        ),
        (
            "render/clusters.rs",
            "use super::Renderer; pub fn encode() {}",
        ),
    ]);
    assert_eq!(cycles(&planted).len(), 1, "parent and child");
    let planted = Crate::of(&[
        (
            "matrix/mod.rs",
            "mod html; mod report; pub use report::grouped;",
        ),
        ("matrix/html.rs", "use super::grouped; pub fn page() {}"),
        (
            "matrix/report.rs",
            "pub fn grouped() { super::html::page() }",
        ),
    ]);
    assert_eq!(cycles(&planted).len(), 1, "siblings through a re-export");
    let planted = Crate::of(&[
        (
            "render/mod.rs",
            "mod built; pub struct Renderer; impl Renderer { fn run(&self) { self.build() } }",
        ),
        (
            "render/built.rs",
            "use super::Renderer;\nimpl Renderer {\n    pub(super) fn build(&self) {}\n}\n",
        ),
    ]);
    assert_eq!(
        cycles(&planted).len(),
        1,
        "a method defined away from its type, called home"
    );
    let fine = Crate::of(&[
        (
            "matrix/mod.rs",
            "mod html; mod report; pub use report::grouped; fn f() { html::page() }",
        ),
        ("matrix/html.rs", "use super::grouped; pub fn page() {}"),
        ("matrix/report.rs", "pub fn grouped() {}"),
    ]);
    assert!(cycles(&fine).is_empty(), "{:#?}", cycles(&fine));

    for binary in [false, true] {
        let found = cycles(&Crate::read(binary));
        assert!(found.is_empty(), "import cycles in src/: {found:#?}");
    }
}

/// `main.rs` names the commands and dispatches: its only function is `main`, and it
/// declares no argument struct (each command's arguments are beside its body in
/// `src/commands/`). The deliberate break: a command body or an argument struct back in
/// `main.rs`.
#[test]
fn main_only_names_and_dispatches() {
    let strays = |source: &str| -> Vec<String> {
        source
            .lines()
            .filter_map(|l| {
                l.strip_prefix("fn ")
                    .or(l.strip_prefix("pub fn "))
                    .or(l.strip_prefix("struct "))
                    .or(l.strip_prefix("pub(crate) struct "))
            })
            .map(|l| l.split(['(', ' ', '<']).next().unwrap_or("").to_string())
            .filter(|name| name != "main" && name != "Cli")
            .collect()
    };
    assert_eq!(strays("fn render(args: &RenderArgs) {}"), ["render"]);
    assert_eq!(strays("struct MatrixArgs {"), ["MatrixArgs"]);
    let main = std::fs::read_to_string("src/main.rs").unwrap();
    assert!(strays(&main).is_empty(), "in main.rs: {:?}", strays(&main));
    // 250 lines: the command list with its help, and the dispatch.
    let lines = main.lines().count();
    assert!(lines <= 250, "main.rs has {lines} lines, at most 250");
}
