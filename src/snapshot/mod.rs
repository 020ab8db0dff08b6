//! Snapshots of variants, for review: the WGSL of every pass (`shaders`) and a frame on a
//! small scene (`images`), written as insta's pending snapshots beside the reviewed ones in
//! the working folder's `snapshots/`, where `cargo insta review` (or `clusterlab snapshot
//! --accept`) takes them in; and what lists the variants, generated from their files: the
//! WGSL index and, in a clusterlab tree, `docs/variants.md` (`table`). The tests hold the
//! tree's variants to the same snapshots and the same generators.

mod format;
pub mod images;
pub mod shaders;
pub mod table;

use std::path::{Path, PathBuf};

use crate::compose::Composer;
use crate::files::write::{create_folder, promote, remove_own_file, write_file};
use crate::gpu::Gpu;
use crate::variant::LoadedVariant;
use format::contents;

/// The snapshot folder, in the working folder.
pub const FOLDER: &str = "snapshots";

/// What a pending snapshot's name adds to the reviewed one's (insta's own naming).
const PENDING: &str = ".new";

/// What one snapshot run found.
#[derive(Default)]
pub struct Outcome {
    /// Snapshots equal to the reviewed ones.
    pub unchanged: usize,
    /// Pending snapshots written, each with why.
    pub pending: Vec<(PathBuf, String)>,
    /// Generated indexes and pages written again (they differed).
    pub regenerated: Vec<PathBuf>,
    /// Reviewed WGSL snapshots that no variant composes any more.
    pub stale: Vec<PathBuf>,
    /// Variants whose image could not be made, and why.
    pub failed: Vec<String>,
}

impl Outcome {
    /// The lines a terminal shows.
    pub fn report(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        for (path, why) in &self.pending {
            let _ = writeln!(s, "pending  {}: {why}", path.display());
        }
        for path in &self.regenerated {
            let _ = writeln!(s, "written  {}", path.display());
        }
        for path in &self.stale {
            let _ = writeln!(
                s,
                "stale    {}: no variant composes it any more (delete it)",
                path.display()
            );
        }
        for why in &self.failed {
            let _ = writeln!(s, "FAILED   {why}");
        }
        let _ = writeln!(
            s,
            "{} unchanged, {} pending{}",
            self.unchanged,
            self.pending.len(),
            if self.pending.is_empty() {
                String::new()
            } else {
                "; review with `cargo insta review`, or take them all with `clusterlab snapshot --accept`".into()
            }
        );
        s
    }
}

/// Write the pending snapshots of `given` under `root` (the working folder): the WGSL of
/// every variant in `all` (those the index covers: `given` and the folder's `variants/`),
/// the images of `given` on the adapter of `gpu`, and the index; in a clusterlab tree also
/// `docs/variants.md` (the default matrix's `cells` with `all`). `progress` hears of each
/// image as it is made.
pub fn write(
    gpu: &Gpu,
    composer: &Composer,
    root: &Path,
    given: &[LoadedVariant],
    all: &[LoadedVariant],
    cells: Option<usize>,
    progress: &mut dyn FnMut(&str),
) -> Result<Outcome, String> {
    let mut outcome = Outcome::default();
    let wgsl_folder = root.join(FOLDER).join(shaders::FOLDER);
    create_folder(&wgsl_folder)?;
    let composed = shaders::distinct(composer, &shaders::with_multisampled(all))?;
    let mut names = Vec::new();
    for shader in &composed {
        let name = format!("{}.snap", shader.name());
        let path = wgsl_folder.join(&name);
        let stored = read_text(&path)?;
        if stored
            .as_deref()
            .and_then(contents)
            .is_some_and(|c| c.trim_end() == shader.wgsl.trim_end())
        {
            outcome.unchanged += 1;
        } else {
            let pending = pending_path(&path);
            write_file(&pending, shader.file().as_bytes())?;
            outcome.pending.push((
                pending,
                format!(
                    "a new shader of pass `{}` ({})",
                    shader.pass,
                    shader.users.join(", ")
                ),
            ));
        }
        names.push(name);
    }
    regenerate(
        &wgsl_folder.join(shaders::INDEX),
        shaders::INDEX_HEADER,
        &shaders::index(&composed),
        &mut outcome,
    )?;
    outcome.stale = listed(&wgsl_folder, ".snap")?
        .into_iter()
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| !names.contains(&n.to_string_lossy().into_owned()))
        })
        .collect();
    let image_folder = root.join(FOLDER).join(images::folder(&gpu.adapter.name));
    create_folder(&image_folder)?;
    for (i, v) in given.iter().enumerate() {
        progress(&format!("[{}/{}] image of {}", i + 1, given.len(), v.name));
        let new = match images::render(gpu, composer, v) {
            Ok(image) => image,
            Err(e) => {
                outcome.failed.push(e);
                continue;
            }
        };
        let name = images::name(&v.name);
        let path = image_folder.join(format!("{name}.snap.png"));
        let stored = crate::files::read(&path, crate::files::read::SNAPSHOT)
            .ok()
            .and_then(|bytes| images::decode_png(&bytes));
        let allowed = crate::gpu::expect::allowance(
            gpu,
            crate::gpu::expect::Check::ImageSnapshot { variant: &v.name },
        )
        .map(|d| d.allowance);
        let verdict = match &stored {
            Some(old) if (old.width, old.height) == (new.width, new.height) => {
                images::judge(&old.rgb, &new.rgb, allowed)
            }
            Some(_) => Err("a reviewed image of another size".into()),
            None => Err("no reviewed image".into()),
        };
        match verdict {
            Ok(()) => outcome.unchanged += 1,
            Err(why) => {
                let meta = image_folder.join(format!("{name}.snap{PENDING}"));
                write_file(&meta, images::metadata().as_bytes())?;
                let png = image_folder.join(format!("{name}.snap{PENDING}.png"));
                write_file(&png, &images::encode_png(&new))?;
                if let Some(old) = stored.filter(|o| (o.width, o.height) == (new.width, new.height))
                {
                    let diff = image_folder.join(format!("{name}.diff.png"));
                    write_file(&diff, &images::encode_png(&images::difference(&old, &new)))?;
                }
                outcome.pending.push((png, why));
            }
        }
    }
    if let Some(cells) = cells {
        let page = root.join(table::PAGE);
        if page.is_file() {
            regenerate(&page, table::HEADER, &table::page(all, cells), &mut outcome)?;
        }
    }
    Ok(outcome)
}

/// Take every pending snapshot under `root`'s snapshot folder in: each `NAME.snap.new` (and
/// an image's `NAME.snap.new.png`) replaces `NAME.snap` (and `NAME.snap.png`), and the
/// image's difference picture goes. Only files in insta's format are taken. Returns the
/// snapshots taken.
pub fn accept(root: &Path) -> Result<Vec<PathBuf>, String> {
    let mut taken = Vec::new();
    let mut folders = vec![root.join(FOLDER)];
    while let Some(folder) = folders.pop() {
        let Ok(entries) = std::fs::read_dir(&folder) else {
            continue;
        };
        for entry in entries.flatten().take(crate::compose::MAX_SHADER_FILES) {
            let path = entry.path();
            let Ok(kind) = entry.file_type() else {
                continue;
            };
            if kind.is_dir() {
                folders.push(path);
                continue;
            }
            let name = path.to_string_lossy().into_owned();
            let Some(reviewed) = name.strip_suffix(PENDING) else {
                continue;
            };
            if !kind.is_file() || read_text(&path)?.is_none_or(|t| contents(&t).is_none()) {
                continue;
            }
            let png = PathBuf::from(format!("{name}.png"));
            if png.is_file() {
                promote(&png, Path::new(&format!("{reviewed}.png")))?;
                if let Some(stem) = reviewed.strip_suffix(".snap") {
                    remove_own_file(Path::new(&format!("{stem}.diff.png")))?;
                }
            }
            promote(&path, Path::new(reviewed))?;
            taken.push(PathBuf::from(reviewed));
        }
    }
    taken.sort();
    Ok(taken)
}

/// `path` with insta's pending suffix.
fn pending_path(path: &Path) -> PathBuf {
    PathBuf::from(format!("{}{PENDING}", path.display()))
}

/// The text of `path`, None when it does not exist.
fn read_text(path: &Path) -> Result<Option<String>, String> {
    match crate::files::read_text(path, crate::files::read::SNAPSHOT) {
        Ok(text) => Ok(Some(text)),
        Err(e) if e.missing => Ok(None),
        Err(e) => Err(e.to_string()),
    }
}

/// Write generated `text` to `path` when it differs, if the file is absent or one the flow
/// wrote (it starts with `header`); a file of someone else's is an error, left as it is.
fn regenerate(path: &Path, header: &str, text: &str, outcome: &mut Outcome) -> Result<(), String> {
    match read_text(path)? {
        Some(old) if old.replace("\r\n", "\n") == text => Ok(()),
        Some(old) if !old.starts_with(header.trim_end()) => Err(format!(
            "{}: not written: it does not begin with the line `clusterlab snapshot` writes, so it is not one of its files",
            path.display()
        )),
        _ => {
            write_file(path, text.as_bytes())?;
            outcome.regenerated.push(path.to_path_buf());
            Ok(())
        }
    }
}

/// The files of `folder` whose names end in `suffix`, sorted (at most
/// `compose::MAX_SHADER_FILES` looked at).
fn listed(folder: &Path, suffix: &str) -> Result<Vec<PathBuf>, String> {
    let entries = std::fs::read_dir(folder)
        .map_err(|e| format!("{}: {}", folder.display(), crate::files::describe(&e)))?;
    let mut out: Vec<PathBuf> = entries
        .flatten()
        .take(crate::compose::MAX_SHADER_FILES)
        .map(|e| e.path())
        .filter(|p| p.to_string_lossy().ends_with(suffix))
        .collect();
    out.sort();
    Ok(out)
}
