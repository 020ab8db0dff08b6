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
