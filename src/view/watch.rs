//! Hot reload: the shader folder and the variant files' folders watched (the `notify`
//! crate); each change is sent on, and wakes the window.

use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, channel};

use notify::{RecursiveMode, Watcher};

/// What changed on disk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Changed {
    /// A WESL or WGSL module under the shader folder.
    Shaders,
    /// A variant file (or another file beside one).
    Variants,
}

/// A running watcher and what it saw.
pub struct Watch {
    _watcher: notify::RecommendedWatcher,
    seen: Receiver<Changed>,
    /// What is watched, canonical: the shader folder and the variant files' folders.
    shader_root: PathBuf,
    variant_folders: Vec<PathBuf>,
}

impl Watch {
    /// Watch `shaders` (recursively) and each folder of `variant_folders`; `wake` is called
    /// after each change is sent.
    pub fn new(
        shaders: &Path,
        variant_folders: &[PathBuf],
        wake: impl Fn() + Send + 'static,
    ) -> Result<Watch, String> {
        let (send, seen) = channel();
        let shader_root = shaders
            .canonicalize()
            .unwrap_or_else(|_| shaders.to_path_buf());
        let root = shader_root.clone();
        let canonical_folders = variant_folders
            .iter()
            .filter_map(|f| f.canonicalize().ok())
            .collect();
        let mut watcher =
            notify::recommended_watcher(move |event: notify::Result<notify::Event>| {
                let Ok(event) = event else { return };
                if matches!(event.kind, notify::EventKind::Access(_)) {
                    return;
                }
                for path in &event.paths {
                    let changed = if path.starts_with(&root) {
                        matches!(
                            path.extension().and_then(|e| e.to_str()),
                            Some("wesl" | "wgsl")
                        )
                        .then_some(Changed::Shaders)
                    } else {
                        (path.extension().and_then(|e| e.to_str()) == Some("ron"))
                            .then_some(Changed::Variants)
                    };
                    if let Some(c) = changed {
                        let _ = send.send(c);
                        wake();
                    }
                }
            })
            .map_err(|e| format!("cannot watch files for changes: {e}"))?;
        watcher
            .watch(&shader_root, RecursiveMode::Recursive)
            .map_err(|e| format!("{}: cannot watch for changes: {e}", shaders.display()))?;
        for folder in variant_folders {
            watcher
                .watch(folder, RecursiveMode::NonRecursive)
                .map_err(|e| format!("{}: cannot watch for changes: {e}", folder.display()))?;
        }
        Ok(Watch {
            _watcher: watcher,
            seen,
            shader_root,
            variant_folders: canonical_folders,
        })
    }

    /// Why the viewer does not watch `file`, if it does not: it watches WESL and WGSL
    /// modules under the shader folder and `.ron` files in the variant files' folders,
    /// regular files only (a link could lead anywhere).
    pub fn unwatched(&self, file: &Path) -> Option<String> {
        let meta = match std::fs::symlink_metadata(file) {
            Ok(meta) => meta,
            Err(e) => return Some(crate::files::describe(&e)),
        };
        if !meta.file_type().is_file() {
            return Some(format!(
                "it is {}, not a regular file",
                crate::files::write::what_is(&meta)
            ));
        }
        let ext = file.extension().and_then(|e| e.to_str());
        let canonical = file.canonicalize().ok();
        let shader = canonical
            .as_ref()
            .is_some_and(|c| c.starts_with(&self.shader_root))
            && matches!(ext, Some("wesl" | "wgsl"));
        let variant = canonical
            .as_ref()
            .and_then(|c| c.parent())
            .is_some_and(|p| self.variant_folders.iter().any(|f| f == p))
            && ext == Some("ron");
        (!shader && !variant).then(|| {
            format!(
                "the viewer watches only the shader modules under {} (.wesl, .wgsl) and the variant files (.ron) in {}, and edits nothing else",
                self.shader_root.display(),
                self.variant_folders
                    .iter()
                    .map(|f| f.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
    }

    /// The changes seen since the last call, each kind once.
    pub fn changes(&self) -> Vec<Changed> {
        let mut changes = Vec::new();
        for c in self.seen.try_iter() {
            if !changes.contains(&c) {
                changes.push(c);
            }
        }
        changes
    }
}
