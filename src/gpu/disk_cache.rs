//! Compiled pipelines kept on disk between runs, where wgpu offers it (`wgpu::PipelineCache`
//! on Vulkan): one file per adapter in the user's cache folder, never inside the project.
//! The file opens with a header naming the clusterlab version and the adapter (name,
//! backend, vendor, device, driver) that wrote it; one written by another is ignored, with
//! a note, and replaced when the run saves its own. A file of that name without the header
//! is not clusterlab's: it is left alone, and the run keeps no cache. wgpu checks its own header behind ours
//! (its version, the adapter, the driver's cache key) and the driver checks the shaders'.

use std::path::{Path, PathBuf};

/// The variable naming the cache folder, or `off`.
pub const CACHE_VAR: &str = "CLUSTERLAB_CACHE";

/// The first line of every cache file.
const MAGIC: &str = "clusterlab pipeline cache";

/// A cache file is read whole; larger ones are left alone (a driver's cache of the
/// default matrix is a few MiB).
const READ: crate::files::Kind = crate::files::Kind {
    what: "a pipeline cache",
    limit: 1 << 30,
    why: "the default matrix's is a few MiB",
};

/// The cache attached to a device, and where it is saved.
pub struct DiskCache {
    pub cache: wgpu::PipelineCache,
    path: PathBuf,
    header: String,
}

/// The folder caches live in: `CLUSTERLAB_CACHE` (`off`: none), else the user's cache
/// folder (`$XDG_CACHE_HOME/clusterlab`, `~/.cache/clusterlab`); None when there is none.
pub fn folder() -> Option<PathBuf> {
    let var = |name| crate::environment::var_os(name).filter(|v| !v.is_empty());
    match var(CACHE_VAR) {
        Some(v) if v == "off" => None,
        Some(v) => Some(PathBuf::from(v)),
        None => var("XDG_CACHE_HOME")
            .map(PathBuf::from)
            .or_else(|| var("HOME").map(|h| Path::new(&h).join(".cache")))
            .map(|base| base.join("clusterlab")),
    }
}

impl DiskCache {
    /// Attach the pipeline cache of this adapter in `folder`, loading what an earlier run
    /// of this clusterlab version on this adapter saved there. Returns a note for the user:
    /// where the cache is, or why it was not loaded or is not kept.
    pub(super) fn attach(
        device: &wgpu::Device,
        folder: &Path,
        (key, identity): &(Option<String>, String),
        backend: &str,
    ) -> (Option<DiskCache>, String) {
        let Some(key) = key else {
            return (
                None,
                format!("pipeline cache: none on {backend} (wgpu keeps one on Vulkan only)"),
            );
        };
        let path = folder.join(format!("{key}.bin"));
        let header = format!(
            "{MAGIC}\nclusterlab {}\n{identity}\n",
            env!("CARGO_PKG_VERSION")
        );
        let (data, note) = match crate::files::read(&path, READ) {
            Ok(bytes) if !bytes.starts_with(format!("{MAGIC}\n").as_bytes()) => {
                return (
                    None,
                    format!(
                        "pipeline cache: none kept: {} is not one clusterlab wrote (no `{MAGIC}` header), so it is left alone",
                        path.display()
                    ),
                );
            }
            Ok(bytes) => match bytes.strip_prefix(header.as_bytes()) {
                Some(data) => (
                    Some(data.to_vec()),
                    format!("pipeline cache: {}", path.display()),
                ),
                None => (
                    None,
                    format!(
                        "pipeline cache: {} was written by {}; ignored (this run is clusterlab {} on {identity}) and replaced at the end",
                        path.display(),
                        written_by(&bytes),
                        env!("CARGO_PKG_VERSION")
                    ),
                ),
            },
            Err(e) if e.missing => (None, format!("pipeline cache: {} (new)", path.display())),
            Err(e) => return (None, format!("pipeline cache: not used: {e}")),
        };
        // SAFETY: the data is what `PipelineCache::get_data` returned on an adapter with
        // this identity (our header says so), and wgpu validates its own header behind it
        // (`fallback: true` starts empty where that fails).
        let cache = unsafe {
            device.create_pipeline_cache(&wgpu::PipelineCacheDescriptor {
                label: Some("clusterlab pipelines"),
                data: data.as_deref(),
                fallback: true,
            })
        };
        let kept = DiskCache {
            cache,
            path,
            header,
        };
        (Some(kept), note)
    }

    /// Save the cache (nothing when the driver gives no data).
    pub(super) fn save(&self) -> Result<(), String> {
        let d = self;
        let Some(data) = d.cache.get_data() else {
            return Ok(());
        };
        if let Some(parent) = d.path.parent() {
            crate::files::write::create_folder(parent)?;
        }
        let mut bytes = d.header.clone().into_bytes();
        bytes.extend_from_slice(&data);
        crate::files::write_file(&d.path, &bytes)
    }
}

/// Who wrote a cache file, from its header: its clusterlab version and adapter lines.
fn written_by(bytes: &[u8]) -> String {
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(512)]).into_owned();
    let mut lines = head.lines().skip(1);
    // A header is the file's, not ours: its control characters are shown escaped, never
    // sent to the terminal.
    let shown = |line: &str| {
        line.chars()
            .flat_map(char::escape_debug)
            .take(200)
            .collect::<String>()
    };
    match (lines.next(), lines.next()) {
        (Some(version), Some(adapter)) => format!("{} on {}", shown(version), shown(adapter)),
        _ => "an unfinished header".into(),
    }
}

/// Refuse a `CLUSTERLAB_CACHE` inside clusterlab's source tree: the cache is kept outside
/// the project (a cache file there would be committed, or cleaned away with the tree).
pub fn check_environment() -> Result<(), String> {
    let Some(value) =
        crate::environment::var_os(CACHE_VAR).filter(|v| !v.is_empty() && *v != "off")
    else {
        return Ok(());
    };
    let path = PathBuf::from(&value);
    // The deepest part of the path that exists, made canonical (the folder may not yet).
    let mut existing = path.as_path();
    let canonical = loop {
        if let Ok(c) = std::fs::canonicalize(existing) {
            break c.join(path.strip_prefix(existing).unwrap_or(Path::new("")));
        }
        match existing.parent() {
            Some(parent) if !parent.as_os_str().is_empty() => existing = parent,
            _ => break std::env::current_dir().unwrap_or_default().join(&path),
        }
    };
    let tree = std::fs::canonicalize(env!("CARGO_MANIFEST_DIR"));
    match tree {
        Ok(tree) if canonical.starts_with(&tree) => Err(format!(
            "{CACHE_VAR}=`{}` lies inside clusterlab's source tree ({}): the pipeline cache is kept outside the project; give a folder elsewhere, `off` for none, or unset it (the user's cache folder)",
            path.display(),
            tree.display()
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A header written by someone else is shown with its control characters escaped.
    #[test]
    fn a_foreign_header_reaches_the_terminal_escaped() {
        let bytes = b"clusterlab pipeline cache\nclusterlab 9\x1b[2J\nadapter\x07\n";
        let shown = written_by(bytes);
        assert!(!shown.chars().any(char::is_control), "{shown:?}");
        assert!(shown.contains("\\u{1b}[2J"), "{shown}");
    }
}
