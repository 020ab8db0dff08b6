//! `matrix --reuse PREVIOUS`: a cell runs again only when something it depends on changed.
//!
//! A cell depends on its spec (scene, parameters, sweep), its variant file, the WGSL of
//! every pass it composed (its reference's raster truth included), the adapter, its driver
//! and the device asked of it, the timing source, how frames are chosen, every environment
//! variable that can change a figure (`environment::figure_inputs`) and clusterlab's own
//! build. All but the WGSL hash into the cell's `inputs`. The compositions are kept as
//! recipes (root, features, constants) in the run's `reuse.json`, and a later run composes
//! them again from the shaders of now: an edited module reruns exactly the cells whose WGSL
//! it changed (the shader tree's hash is in the provenance, not the key, for that reason).
//!
//! A record taken is checked as a fresh one would be: its spec equal to the plan's, its
//! figures whole, and its verdict derived from them (`Previous::unchanged`); it keeps its
//! own run's provenance (`mark_reused`).

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::{CellRecord, CellSpec, PlannedCell, Results};
use crate::compose::{Composer, Composition, Recipe, sha256_hex};
use crate::gpu::Gpu;
use crate::measure::Frames;

/// The file of a result folder that says what each cell depended on.
pub use crate::files::folder::REUSE_FILE as FILE;

/// What every cell of a run depended on, for a later run to compare with.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct ReuseIndex {
    /// Recipes by the SHA-256 of their JSON (cells share most of them).
    recipes: BTreeMap<String, Recipe>,
    /// By cell id.
    cells: BTreeMap<String, CellShaders>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct CellShaders {
    /// SHA-256 of everything but the WGSL (`cell_inputs`).
    inputs: String,
    /// (recipe, WGSL) hashes, each once, in the order first composed.
    compositions: Vec<(String, String)>,
}

/// An earlier run to take unchanged cells from.
#[derive(Debug)]
pub struct Previous {
    pub dir: PathBuf,
    results: Results,
    index: ReuseIndex,
}

impl Previous {
    /// The result folder `dir` (written by a matrix run with its `reuse.json`), or its
    /// `results.json`.
    pub fn load(dir: &Path) -> Result<Self, String> {
        let dir = match dir.file_name() {
            Some(name) if name == "results.json" && !dir.is_dir() => dir
                .parent()
                .filter(|p| !p.as_os_str().is_empty())
                .unwrap_or(Path::new(".")),
            _ => dir,
        };
        let results = Results::load(dir)?;
        let path = dir.join(FILE);
        let text = crate::files::read_text(&path, crate::files::read::RESULTS).map_err(|e| {
            if e.missing && results.provenance.len() > 1 {
                format!(
                    "--reuse {}: a folder `merge` made from {} runs, which records no {FILE}: give the folder of one of those runs",
                    dir.display(),
                    results.provenance.len()
                )
            } else if e.missing {
                format!(
                    "--reuse {}: no {FILE} there (a run before clusterlab recorded what its cells depend on): run the matrix once without --reuse",
                    dir.display()
                )
            } else {
                e.to_string()
            }
        })?;
        let index = serde_json::from_str(&text).map_err(|e| {
            format!(
                "{}:{}:{}: not a clusterlab {FILE}: {e}",
                path.display(),
                e.line(),
                e.column()
            )
        })?;
        Ok(Self {
            dir: dir.to_path_buf(),
            results,
            index,
        })
    }

    /// The earlier record of `cell` when it ran with the same `inputs`, its spec is the
    /// plan's, its figures hold as a fresh cell's would (`stale`), and every shader it
    /// composed still composes to the same WGSL (`wgsl` remembers recipes composed
    /// before); with the compositions it used. None when anything differs, or the cell
    /// failed there.
    pub fn unchanged(
        &self,
        cell: &PlannedCell,
        inputs: &str,
        composer: &Composer,
        gpu: &Gpu,
        wgsl: &mut HashMap<String, Option<String>>,
    ) -> Option<(&CellRecord, Vec<Arc<Composition>>)> {
        let id = &cell.spec.id;
        let shaders = self.index.cells.get(id)?;
        if shaders.inputs != inputs {
            return None;
        }
        let record = self.results.cells.iter().find(|c| &c.spec.id == id)?;
        if !record.ok() || stale(record, cell, gpu).is_some() {
            return None;
        }
        let mut used = Vec::with_capacity(shaders.compositions.len());
        for (recipe_hash, wgsl_hash) in &shaders.compositions {
            let recipe = self.index.recipes.get(recipe_hash)?;
            // A recipe is read from a file: compose only a pass root (`passes::NAME`).
            let name = recipe.root.strip_prefix("passes::")?;
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_lowercase() || c == '_') {
                return None;
            }
            let now = wgsl
                .entry(recipe_hash.clone())
                .or_insert_with(|| composer.recompose(recipe).ok())
                .as_ref()?;
            if now != wgsl_hash {
                return None;
            }
            used.push(Arc::new(Composition {
                recipe: recipe.clone(),
                wgsl_sha256: now.clone(),
            }));
        }
        Some((record, used))
    }

    /// Give the cells of `results` taken from this run (`results.reused`) their own runs'
    /// provenance: each earlier run's entry is added once, and the cell points to it.
    pub fn mark_reused(&self, results: &mut Results) {
        let mut added: BTreeMap<usize, usize> = BTreeMap::new();
        for cell in results.cells.iter_mut() {
            if !results.reused.contains(&cell.spec.id) {
                continue;
            }
            let Some(earlier) = self.results.provenance.get(cell.run) else {
                continue;
            };
            let index = *added.entry(cell.run).or_insert_with(|| {
                results.provenance.push(earlier.clone());
                results.provenance.len() - 1
            });
            cell.run = index;
            cell.reused_from = Some(format!(
                "{} ({})",
                earlier.date,
                &earlier.git_revision[..12.min(earlier.git_revision.len())]
            ));
        }
    }
}

/// Why an earlier record cannot stand for `cell` now, judged as a fresh cell's figures
/// would be (`run::meaningless`, `run::inexact`): a spec other than the plan's, a shaded
/// frame without error figures, NaN pixels, or an exact variant over its 1 LSB, each
/// recorded as passing.
pub fn stale(record: &CellRecord, cell: &PlannedCell, gpu: &Gpu) -> Option<String> {
    let spec = |s: &CellSpec| serde_json::to_string(s).unwrap_or_default();
    if spec(&record.spec) != spec(&cell.spec) {
        return Some("its spec is not the plan's".into());
    }
    let loaded = cell.variant.as_ref().ok()?;
    if record.ok() {
        let shaded = loaded.variant.debug_view == crate::variant::DebugView::Off;
        if shaded && record.error.is_none() {
            return Some("a shaded frame without error figures".into());
        }
        if let Some(e) = &record.error
            && e.nan_pixels > 0
        {
            return Some(format!("{} NaN pixels recorded as passing", e.nan_pixels));
        }
        if record.sequence_summary.is_none()
            && let Some(why) = crate::run::inexact(&loaded.variant, gpu, record.error.as_ref())
        {
            return Some(format!("recorded as passing: {why}"));
        }
    }
    None
}

impl ReuseIndex {
    /// Record that cell `id` ran with `inputs` and these compositions.
    pub fn add(&mut self, id: &str, inputs: String, compositions: &[Arc<Composition>]) {
        let mut seen = Vec::new();
        for c in compositions {
            let recipe = serde_json::to_string(&c.recipe).expect("a recipe serialises");
            let key = (sha256_hex(&recipe), c.wgsl_sha256.clone());
            if !seen.contains(&key) {
                self.recipes
                    .entry(key.0.clone())
                    .or_insert_with(|| c.recipe.clone());
                seen.push(key);
            }
        }
        self.cells.insert(
            id.to_string(),
            CellShaders {
                inputs,
                compositions: seen,
            },
        );
    }

    /// Write `reuse.json` into the result folder being made.
    pub fn write(&self, dir: &Path) -> Result<(), String> {
        let json = serde_json::to_string(self).map_err(|e| e.to_string())?;
        crate::files::write_file(&dir.join(FILE), json.as_bytes())
    }
}

/// "reused R of N cells from DIR; ran M: ID, ID, ..." (the first ten of those it ran).
pub fn reuse_summary(results: &Results, dir: &Path) -> String {
    const SHOWN: usize = 10;
    let ran: Vec<&str> = results
        .cells
        .iter()
        .map(|c| c.spec.id.as_str())
        .filter(|id| !results.reused.iter().any(|r| r == id))
        .collect();
    let mut names = ran[..ran.len().min(SHOWN)].join(", ");
    if ran.len() > SHOWN {
        names.push_str(&format!(" and {} more", ran.len() - SHOWN));
    }
    format!(
        "reused {} of {} cells from {}; ran {}{}{names}",
        results.reused.len(),
        results.cells.len(),
        dir.display(),
        ran.len(),
        if ran.is_empty() { "" } else { ": " }
    )
}

/// What every cell of a run on `gpu` depends on alike: clusterlab's build (the SHA-256 of
/// its executable), the adapter (name, backend, driver) and the device asked of it, the
/// timing source, how frames are chosen, and every environment variable that can change a
/// figure (`environment::figure_inputs`: the depth perturbation, the shader folder, masked
/// features, the software GPU's threads, ...).
pub fn run_inputs(gpu: &Gpu, frames: &Frames) -> Result<String, String> {
    let exe =
        std::env::current_exe().map_err(|e| format!("finding clusterlab's executable: {e}"))?;
    let bytes =
        crate::files::read(&exe, crate::files::read::EXECUTABLE).map_err(|e| e.to_string())?;
    let build = {
        use sha2::Digest;
        format!("{:x}", sha2::Sha256::digest(&bytes))
    };
    Ok(sha256_hex(&format!(
        "{build}|{:?}|{:?}|timestamps {}|{frames:?}|{:?}",
        gpu.adapter,
        gpu.request,
        gpu.timestamps,
        crate::environment::figure_inputs()
    )))
}

/// The inputs of one cell: the run's, its spec and its variant file's SHA-256.
pub fn cell_inputs(run: &str, spec: &CellSpec, variant_sha256: Option<&str>) -> String {
    let spec = serde_json::to_string(spec).expect("a cell spec serialises");
    sha256_hex(&format!("{run}|{spec}|{variant_sha256:?}"))
}
