//! Composition: a variant and a pass become one naga-validated WGSL module.
//!
//! Each pass has a root module under `shaders/passes/`. wesl resolves its imports, keeps
//! only the `@if` branches the variant's features select, strips what the entry points do
//! not reach, and reads the variant's numbers from a generated `constants` module. naga then
//! parses and validates the result with every validation flag.

mod diagnostics;
mod features;
mod light_loop;
mod passes;
mod resolver;

pub use diagnostics::SourceLocation;
pub use features::{
    CLUSTERS_PER_LANE, LIGHTS_PER_ROW, RAY_COUNTERS, SCAN_BLOCK, SCAN_LANES, SceneFeatures,
    WALK_CUT_SHORT, constants_module, feature_flags, features_with, frame_features,
    perturbation_note, perturbed_depth_ulps,
};
pub use light_loop::LightLoop;
pub use passes::{
    ClusterPass, FramePlan, Pass, PassId, PassKind, PostPass, RasterPass, ScreenPass,
    keeps_still_image, pass_flags, passes, passes_for, plan, reads_visible_depths,
    shades_samples_apart,
};
pub use resolver::ShaderResolver;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use wesl::{Feature, ModulePath, Wesl};

use crate::variant::Variant;

/// A composed and validated pass.
#[derive(Clone, Debug)]
pub struct ComposedPass {
    pub name: String,
    /// The WGSL fed to naga and wgpu.
    pub wgsl: String,
    pub module: naga::Module,
    pub info: naga::valid::ModuleInfo,
    /// Each resource binding's name as its module declares it (unmangled), by (group,
    /// binding): what the renderer binds a slot by.
    pub slot_names: std::collections::BTreeMap<(u32, u32), String>,
}

/// Why a pass did not compose.
#[derive(Debug, thiserror::Error)]
pub enum ShaderError {
    /// wesl could not read, parse, import or select (its own message names the module).
    #[error("pass `{pass}`: shader composition failed:\n{message}")]
    Wesl { pass: String, message: String },
    /// naga rejected the composed WGSL.
    #[error("{}", naga_text(pass, message, location.as_deref(), *composed_line))]
    Naga {
        pass: String,
        message: String,
        /// Where the error is in the module's own file, when it could be traced back.
        location: Option<Box<SourceLocation>>,
        /// Line of the error in the composed WGSL (see `clusterlab wgsl`).
        composed_line: Option<usize>,
    },
}

/// A naga error at the module's own file, line and column when known, with the line of
/// the composed WGSL to look at.
fn naga_text(
    pass: &str,
    message: &str,
    location: Option<&SourceLocation>,
    composed_line: Option<usize>,
) -> String {
    let mut s = match location {
        Some(l) => format!(
            "{}:{}:{}: {message}\n{}",
            l.file, l.line, l.column, l.snippet
        ),
        None => format!("pass `{pass}`: {message}"),
    };
    if let Some(line) = composed_line {
        s.push_str(&format!(
            "\n(in pass `{pass}`, line {line} of its composed WGSL: `clusterlab wgsl VARIANT --pass {pass}`)"
        ));
    }
    s
}

/// Shader capabilities beyond the WebGPU baseline that passes may use: forced early depth
/// testing, so instrumented passes count only the fragments a GPU with early-Z shades
/// (wgpu feature SHADER_EARLY_DEPTH_TEST, which lavapipe and llvmpipe have); per-sample
/// shading, for multisampled scissor deferred (downlevel flag MULTISAMPLED_SHADING).
pub const CAPABILITIES: naga::valid::Capabilities = naga::valid::Capabilities::EARLY_DEPTH_TEST
    .union(naga::valid::Capabilities::MULTISAMPLED_SHADING);

/// Composes passes from one shader folder.
#[derive(Clone, Debug)]
pub struct Composer {
    shader_root: PathBuf,
    display_base: PathBuf,
    /// Passes composed so far, by name, root, features and constants: a matrix composes
    /// the same pass for many cells, and composing and validating it once is enough.
    composed: Arc<Mutex<HashMap<String, Composed>>>,
    /// Every composition asked for, in order, once `record` turned it on (`matrix --reuse`
    /// reads which shaders a cell used from it).
    log: Arc<Mutex<Option<Vec<Arc<Composition>>>>>,
}

/// A composed pass and how it was composed.
type Composed = (ComposedPass, Arc<Composition>);

/// How to compose a pass again: its root, features, constants and light loop.
#[derive(Clone, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Recipe {
    pub name: String,
    pub root: String,
    pub features: Vec<(String, bool)>,
    pub constants: String,
    #[serde(default)]
    pub light_loop: LightLoop,
}

/// Most files and folders a shader folder may hold (this project's has about 70).
pub const MAX_SHADER_FILES: usize = 4096;

/// The shaders a run composed from (`Composer::shader_tree`).
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ShaderTree {
    pub folder: PathBuf,
    /// Why this folder: which of the places `shader_folder` looks in.
    #[serde(default)]
    pub source: ShaderSource,
    pub files: usize,
    /// SHA-256 over every shader file's relative path and content.
    pub sha256: String,
}

impl ShaderTree {
    pub fn describe(&self) -> String {
        format!(
            "{} ({}, {} files, SHA-256 {})",
            self.folder.display(),
            self.source.describe(),
            self.files,
            &self.sha256[..16.min(self.sha256.len())]
        )
    }
}

/// A composition: its recipe and the SHA-256 of the WGSL it gave.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Composition {
    pub recipe: Recipe,
    pub wgsl_sha256: String,
}

/// SHA-256 of a text, in hex.
pub fn sha256_hex(text: &str) -> String {
    use sha2::Digest;
    format!("{:x}", sha2::Sha256::digest(text.as_bytes()))
}

/// Where a run's shaders were found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShaderSource {
    /// The folder `CLUSTERLAB_SHADERS` names.
    Environment,
    /// `shaders/` in the working folder (beside its `variants/`): a copy of the tree, or a
    /// user's own shaders.
    WorkingFolder,
    /// The `shaders/` of the tree the program was built from.
    #[default]
    Built,
    /// A folder a library caller gave `Composer::new`.
    Given,
}

impl ShaderSource {
    pub fn describe(self) -> &'static str {
        match self {
            ShaderSource::Environment => "named by CLUSTERLAB_SHADERS",
            ShaderSource::WorkingFolder => "the working folder's shaders/",
            ShaderSource::Built => "the shaders/ the program was built from",
            ShaderSource::Given => "given to the composer",
        }
    }
}

/// A file every shader folder of clusterlab's has: a `shaders/` without it is someone
/// else's folder, not looked in.
const SHADER_FOLDER_MARK: &str = "passes/forward.wesl";

/// The shader folder a run composes from, looked for in this order: the one
/// `CLUSTERLAB_SHADERS` names, `shaders/` in the working folder (one with
/// `passes/forward.wesl`), then the one the program was built from.
pub fn shader_folder() -> (PathBuf, ShaderSource) {
    if let Some(dir) = crate::environment::var_os("CLUSTERLAB_SHADERS") {
        return (PathBuf::from(dir), ShaderSource::Environment);
    }
    let built = Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let here = Path::new("shaders");
    let same = |a: &Path, b: &Path| a.canonicalize().ok() == b.canonicalize().ok();
    if here.join(SHADER_FOLDER_MARK).is_file() && !same(here, &built) {
        return (here.to_path_buf(), ShaderSource::WorkingFolder);
    }
    (built, ShaderSource::Built)
}

/// Which place `shader_folder` would have found `root` in; `Given` when none (a composer
/// made with a folder of its caller's).
fn shader_source(root: &Path) -> ShaderSource {
    let (folder, source) = shader_folder();
    let cwd = std::env::current_dir().unwrap_or_default();
    if cwd.join(folder) == root {
        source
    } else {
        ShaderSource::Given
    }
}

/// "shaders: FOLDER (why)", what a command says at its start.
pub fn shaders_line() -> String {
    let (folder, source) = shader_folder();
    let folder = std::env::current_dir()
        .ok()
        .and_then(|cwd| folder.strip_prefix(&cwd).ok().map(Path::to_path_buf))
        .unwrap_or(folder);
    format!("shaders: {} ({})", folder.display(), source.describe())
}

impl Default for Composer {
    /// The shader folder `shader_folder` finds.
    fn default() -> Self {
        Self::new(&shader_folder().0)
    }
}

/// Refuse `CLUSTERLAB_SHADERS` when it does not name a folder, and a depth perturbation
/// (`features::PERTURB_DEPTH_VAR`) that is not a number of steps.
pub fn check_environment() -> Result<(), String> {
    if let Some(value) = crate::environment::var(features::PERTURB_DEPTH_VAR)
        && !value
            .parse::<u32>()
            .is_ok_and(|n| n <= features::MAX_PERTURB_DEPTH_ULPS)
    {
        return Err(format!(
            "{}=`{value}` is not a number of units in the last place: give 0 to {} (a test mode), or unset it",
            features::PERTURB_DEPTH_VAR,
            features::MAX_PERTURB_DEPTH_ULPS
        ));
    }
    let Some(dir) = crate::environment::var_os("CLUSTERLAB_SHADERS") else {
        return Ok(());
    };
    let path = Path::new(&dir);
    match std::fs::metadata(path) {
        Ok(meta) if meta.is_dir() => Ok(()),
        Ok(_) => Err(format!(
            "CLUSTERLAB_SHADERS=`{}` is not a folder: give the shader folder (one like this repository's shaders/), or unset it",
            path.display()
        )),
        Err(e) => Err(format!(
            "CLUSTERLAB_SHADERS=`{}`: {}; give the shader folder (one like this repository's shaders/), or unset it",
            path.display(),
            crate::files::describe(&e)
        )),
    }
}

impl Composer {
    /// Compose from `shader_root`; messages name files relative to the current folder when
    /// they are under it.
    pub fn new(shader_root: &Path) -> Self {
        let cwd = std::env::current_dir().unwrap_or_default();
        Self {
            shader_root: cwd.join(shader_root),
            display_base: cwd,
            composed: Default::default(),
            log: Default::default(),
        }
    }

    /// The shader folder this composer reads, and the SHA-256 of its content: every
    /// `.wesl` and `.wgsl` file under it, by path relative to it, in order (at most
    /// `MAX_SHADER_FILES`, each read as `files::read::SHADER` reads). Results record it, so
    /// that figures from edited shaders are told from stock ones.
    pub fn shader_tree(&self) -> Result<ShaderTree, String> {
        use sha2::Digest;
        let mut files = Vec::new();
        let mut folders = vec![self.shader_root.clone()];
        while let Some(folder) = folders.pop() {
            let entries = std::fs::read_dir(&folder)
                .map_err(|e| format!("{}: {}", folder.display(), crate::files::describe(&e)))?;
            for entry in entries {
                let entry = entry.map_err(|e| format!("{}: {e}", folder.display()))?;
                let kind = entry.file_type().map_err(|e| e.to_string())?;
                let path = entry.path();
                let shader = path.extension().is_some_and(|x| x == "wesl" || x == "wgsl");
                if kind.is_dir() {
                    folders.push(path);
                } else if kind.is_file() && shader {
                    files.push(path);
                }
                if files.len() + folders.len() > MAX_SHADER_FILES {
                    return Err(format!(
                        "{}: more than {MAX_SHADER_FILES} files and folders: not a shader folder",
                        self.shader_root.display()
                    ));
                }
            }
        }
        files.sort();
        let mut hash = sha2::Sha256::new();
        for path in &files {
            let bytes =
                crate::files::read(path, crate::files::read::SHADER).map_err(|e| e.to_string())?;
            let relative = path.strip_prefix(&self.shader_root).unwrap_or(path);
            hash.update(relative.to_string_lossy().as_bytes());
            hash.update([0]);
            hash.update((bytes.len() as u64).to_le_bytes());
            hash.update(&bytes);
        }
        Ok(ShaderTree {
            folder: self.shader_root.clone(),
            source: shader_source(&self.shader_root),
            files: files.len(),
            sha256: format!("{:x}", hash.finalize()),
        })
    }

    /// Log every composition from now on (`logged_since`).
    pub fn record(&self) {
        let mut log = self.log.lock().unwrap_or_else(|p| p.into_inner());
        log.get_or_insert_with(Vec::new);
    }

    /// Where the log stands: what `logged_since` counts from.
    pub fn log_mark(&self) -> usize {
        let log = self.log.lock().unwrap_or_else(|p| p.into_inner());
        log.as_ref().map_or(0, Vec::len)
    }

    /// The compositions asked for since `mark` (none when not recording).
    pub fn logged_since(&self, mark: usize) -> Vec<Arc<Composition>> {
        let log = self.log.lock().unwrap_or_else(|p| p.into_inner());
        log.as_ref()
            .map_or_else(Vec::new, |l| l.get(mark..).unwrap_or_default().to_vec())
    }

    /// Log compositions made earlier again: a cell that takes a cached result (a reference
    /// frame) used the shaders that made it.
    pub fn relog(&self, compositions: &[Arc<Composition>]) {
        let mut log = self.log.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(l) = log.as_mut() {
            l.extend(compositions.iter().cloned());
        }
    }

    /// The SHA-256 of what `recipe` composes to with the shaders of now.
    pub fn recompose(&self, recipe: &Recipe) -> Result<String, ShaderError> {
        let features: Vec<(&str, bool)> = recipe
            .features
            .iter()
            .map(|(k, v)| (k.as_str(), *v))
            .collect();
        let pass = self.compose_root(
            &recipe.name,
            &recipe.root,
            &features,
            &recipe.constants,
            recipe.light_loop,
        )?;
        Ok(sha256_hex(&pass.wgsl))
    }

    pub fn shader_root(&self) -> &Path {
        &self.shader_root
    }

    /// Compose and validate one pass of a variant.
    pub fn compose(&self, variant: &Variant, pass: &Pass) -> Result<ComposedPass, ShaderError> {
        self.compose_with(variant, pass, &[])
    }

    /// A pass of a variant with some of its feature flags set otherwise: `stats` for an
    /// instrumented frame (its counters, never its timings), or what a scene does not need (`spot_lights` off without spots).
    pub fn compose_with(
        &self,
        variant: &Variant,
        pass: &Pass,
        overrides: &[(&str, bool)],
    ) -> Result<ComposedPass, ShaderError> {
        let mut features = features_with(variant, overrides);
        for &(flag, on) in passes::pass_flags(pass.id) {
            if let Some(f) = features.iter_mut().find(|(name, _)| *name == flag) {
                f.1 = on;
            }
        }
        self.compose_root(
            pass.name(),
            pass.root,
            &features,
            &constants_module(variant),
            LightLoop::of(variant),
        )
    }

    /// Compose and validate every pass of a variant, stopping at the first error.
    pub fn compose_all(&self, variant: &Variant) -> Result<Vec<ComposedPass>, ShaderError> {
        passes(variant)
            .iter()
            .map(|p| self.compose(variant, p))
            .collect()
    }

    /// Compose root module `root` (a path like `passes::forward`) with these feature flags,
    /// constants module text and light loop (what `light_loop::selected` is). Every flag a
    /// shader tests must be in `features`.
    pub fn compose_root(
        &self,
        name: &str,
        root: &str,
        features: &[(&str, bool)],
        constants: &str,
        light_loop: LightLoop,
    ) -> Result<ComposedPass, ShaderError> {
        let key = format!("{name}\0{root}\0{features:?}\0{constants}\0{light_loop:?}");
        let cache = || self.composed.lock().unwrap_or_else(|p| p.into_inner());
        let hit = cache().get(&key).cloned();
        let (pass, composition) = match hit {
            Some(hit) => hit,
            None => {
                let pass = self.compose_uncached(name, root, features, constants, light_loop)?;
                let composition = Arc::new(Composition {
                    recipe: Recipe {
                        name: name.to_string(),
                        root: root.to_string(),
                        features: features.iter().map(|&(k, v)| (k.to_string(), v)).collect(),
                        constants: constants.to_string(),
                        light_loop,
                    },
                    wgsl_sha256: sha256_hex(&pass.wgsl),
                });
                cache().insert(key, (pass.clone(), composition.clone()));
                (pass, composition)
            }
        };
        self.relog(&[composition]);
        Ok(pass)
    }

    fn compose_uncached(
        &self,
        name: &str,
        root: &str,
        features: &[(&str, bool)],
        constants: &str,
        light_loop: LightLoop,
    ) -> Result<ComposedPass, ShaderError> {
        let wesl_error = |message: String| ShaderError::Wesl {
            pass: name.to_string(),
            message,
        };
        let root_path: ModulePath = format!("package::{root}")
            .parse()
            .map_err(|e| wesl_error(format!("bad root module path `{root}`: {e}")))?;
        let resolver = ShaderResolver::new(
            &self.shader_root,
            &self.display_base,
            constants.to_string(),
            light_loop,
        );
        let mut compiler = Wesl::new(&self.shader_root).set_custom_resolver(resolver);
        compiler
            .set_custom_mangler(light_loop::LoopMangler)
            .use_sourcemap(true)
            .use_stripping(true)
            // A flag the Rust side forgot is an error, not a silently dropped branch.
            .set_missing_feature_behavior(Feature::Error)
            .set_features(features.iter().map(|&(k, v)| (k, v)));
        let result = compiler.compile(&root_path).map_err(|e| {
            let text = strip_ansi(&e.to_string());
            // Show file names relative to the display base, as everywhere else.
            let base = format!("{}/", self.display_base.display());
            wesl_error(text.replace(&base, ""))
        })?;
        let sourcemap = result.sourcemap.unwrap_or_default();
        let wgsl = deterministic_order(result.syntax, &sourcemap).to_string();

        let naga_error = |message: String, span: Option<std::ops::Range<usize>>| {
            let (location, composed_line) = match span {
                Some(r) => (
                    diagnostics::locate(&wgsl, r.start, r.len(), &sourcemap, &root_path)
                        .map(Box::new),
                    Some(diagnostics::line_column(&wgsl, r.start).0),
                ),
                None => (None, None),
            };
            ShaderError::Naga {
                pass: name.to_string(),
                message,
                location,
                composed_line,
            }
        };
        let module = naga::front::wgsl::parse_str(&wgsl).map_err(|e| {
            let span = e.labels().next().and_then(|(s, _)| s.to_range());
            let label = e.labels().next().map(|(_, l)| l.to_string());
            let message = match label {
                Some(l) if !l.is_empty() => format!("{}: {l}", e.message()),
                _ => e.message().to_string(),
            };
            naga_error(unmangle_names(&message, &sourcemap), span)
        })?;
        let mut validator =
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), CAPABILITIES);
        let info = validator.validate(&module).map_err(|e| {
            // naga lists spans from the outside in (function, then expression): the last is
            // the most precise.
            let span = e.spans().last().and_then(|(s, _)| s.to_range());
            naga_error(unmangle_names(&error_chain(e.as_inner()), &sourcemap), span)
        })?;
        let slot_names = declared_slot_names(&module, &sourcemap);
        Ok(ComposedPass {
            name: name.to_string(),
            wgsl,
            module,
            info,
            slot_names,
        })
    }
}

/// The declarations grouped by module: the root's first, then the others by module path,
/// each in its source order. wesl assembles modules in hash-map order, which changes from
/// one process to the next; WGSL does not care about declaration order, snapshots do.
fn deterministic_order(
    mut unit: wesl::syntax::TranslationUnit,
    sourcemap: &wesl::BasicSourceMap,
) -> wesl::syntax::TranslationUnit {
    use wesl::SourceMap;
    use wgsl_parse::SyntaxNode;
    unit.global_declarations.sort_by_cached_key(|decl| {
        decl.ident()
            .and_then(|id| sourcemap.get_decl(&id.name()).map(|(m, _)| m.to_string()))
            .map_or((0, String::new()), |module| (1, module))
    });
    unit
}

/// The declared name of every resource binding of `module`, by (group, binding).
fn declared_slot_names(
    module: &naga::Module,
    sourcemap: &wesl::BasicSourceMap,
) -> std::collections::BTreeMap<(u32, u32), String> {
    use wesl::SourceMap;
    module
        .global_variables
        .iter()
        .filter_map(|(_, var)| {
            let slot = var.binding.as_ref()?;
            let name = var.name.as_deref()?;
            let declared = sourcemap
                .get_decl(name)
                .map_or_else(|| name.to_string(), |(_, n)| n.to_string());
            Some(((slot.group, slot.binding), declared))
        })
        .collect()
}

/// `text` with every mangled declaration name replaced by `module::name`.
fn unmangle_names(text: &str, sourcemap: &wesl::BasicSourceMap) -> String {
    use wesl::SourceMap;
    let mut out = String::with_capacity(text.len());
    let mut word = String::new();
    let flush = |word: &mut String, out: &mut String| {
        match sourcemap.get_decl(word) {
            Some((module, name)) => out.push_str(&format!("{module}::{name}")),
            None => out.push_str(word),
        }
        word.clear();
    };
    for c in text.chars() {
        if c.is_alphanumeric() || c == '_' {
            word.push(c);
        } else {
            flush(&mut word, &mut out);
            out.push(c);
        }
    }
    flush(&mut word, &mut out);
    out
}

/// An error and its sources, joined with ": ".
fn error_chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut source = e.source();
    while let Some(inner) = source {
        s.push_str(": ");
        s.push_str(&inner.to_string());
        source = inner.source();
    }
    s
}

/// `text` without ANSI colour sequences (wesl always colours its diagnostics).
fn strip_ansi(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '\u{1b}' && chars.peek() == Some(&'[') {
            chars.next();
            // Parameters and intermediates, then one final byte in '@'..='~'.
            for c in chars.by_ref() {
                if ('@'..='~').contains(&c) {
                    break;
                }
            }
        } else {
            out.push(c);
        }
    }
    out
}
