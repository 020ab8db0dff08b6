//! Where WESL modules come from: files under the shader folder, the chosen light loop's
//! unit for `shading::light_loop::selected`, and a `constants` module generated from the
//! variant's numbers.

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use wesl::syntax::PathOrigin;
use wesl::{FileResolver, ModulePath, ResolveError, Resolver};

/// Resolves `package::...` to files under the shader folder and `constants::...` to the
/// generated constants module. Unlike wesl's own constants module (a `HashMap`), the text here
/// is in a fixed order, so composed WGSL is the same bits on every run.
pub struct ShaderResolver {
    files: FileResolver,
    root: PathBuf,
    display_base: PathBuf,
    constants: String,
    light_loop: super::LightLoop,
}

impl ShaderResolver {
    /// `root` is the shader folder; file names in messages are shown relative to
    /// `display_base` (the repository root).
    pub fn new(
        root: &Path,
        display_base: &Path,
        constants: String,
        light_loop: super::LightLoop,
    ) -> Self {
        Self {
            files: FileResolver::new(root),
            root: root.to_path_buf(),
            display_base: display_base.to_path_buf(),
            constants,
            light_loop,
        }
    }

    /// The file behind `path`: the light loop's own for the selected loop.
    fn file_of(&self, path: &ModulePath) -> Option<PathBuf> {
        match self.light_loop.file_path(path) {
            Some(unit) => self.files.fs_path(&unit),
            None => self.files.fs_path(path),
        }
    }

    fn is_constants(path: &ModulePath) -> bool {
        matches!(&path.origin, PathOrigin::Package(name) if name == "constants")
    }
}

/// The deepest a shader module may nest brackets: wesl parses recursively, and about 20,000
/// nested parentheses overflowed its stack and aborted the process (10,000 did not); this
/// project's modules nest under 10.
pub const MAX_NESTING: usize = 256;

/// Where `text` first nests ( [ { deeper than [`MAX_NESTING`]: its 1-based line and column.
pub fn too_deep(text: &str) -> Option<(usize, usize)> {
    let (mut depth, mut line, mut column) = (0usize, 1, 0);
    for c in text.chars() {
        column += 1;
        match c {
            '\n' => (line, column) = (line + 1, 0),
            '(' | '[' | '{' => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Some((line, column));
                }
            }
            ')' | ']' | '}' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    None
}

/// `text` of module `shown`, or an error where it nests too deep for the parser.
fn checked<'a>(shown: &str, text: Cow<'a, str>) -> Result<Cow<'a, str>, ResolveError> {
    match too_deep(&text) {
        None => Ok(text),
        Some((line, column)) => Err(ResolveError::Error(wesl::Diagnostic::from(
            wesl::Error::Custom(format!(
                "{shown}:{line}:{column}: brackets nest more than {MAX_NESTING} deep here: a shader module may nest at most {MAX_NESTING} (the WESL parser is recursive)"
            )),
        ))),
    }
}

impl Resolver for ShaderResolver {
    fn resolve_source<'a>(&'a self, path: &ModulePath) -> Result<Cow<'a, str>, ResolveError> {
        let shown = self.display_name(path).unwrap_or_else(|| path.to_string());
        if Self::is_constants(path) {
            return checked(&shown, Cow::Borrowed(&self.constants));
        }
        // Read here rather than by wesl's resolver, which reads a file whole whatever it is
        // (a named pipe in the shader folder would block the run).
        let Some(file) = self.file_of(path) else {
            // No such file: wesl's own error says so.
            return self.files.resolve_source(path);
        };
        let text = crate::files::read_text(&file, crate::files::read::SHADER)
            .map_err(|e| ResolveError::ModuleNotFound(path.clone(), e.to_string()))?;
        checked(&shown, Cow::Owned(text))
    }

    fn display_name(&self, path: &ModulePath) -> Option<String> {
        if Self::is_constants(path) {
            return Some("<constants generated from the variant>".into());
        }
        let fs = self.file_of(path)?;
        let shown = fs
            .strip_prefix(&self.display_base)
            .map(Path::to_path_buf)
            .unwrap_or(fs);
        Some(shown.display().to_string())
    }

    fn fs_path(&self, path: &ModulePath) -> Option<PathBuf> {
        if Self::is_constants(path) {
            None
        } else {
            self.file_of(path)
        }
    }
}

impl ShaderResolver {
    pub fn root(&self) -> &Path {
        &self.root
    }
}
