//! Studies against published numbers (`clusterlab study NAME`). A study is one file: its
//! points, how a point runs, its table and plot (`Study`); running the points, the check
//! that every row keeps the study's promise, the files (terminal, Markdown, CSV, JSON, the
//! plot) and the dispatch (`STUDIES`) are here, once.

pub mod codecs;
pub mod cones;
pub mod culling;
pub mod depth;
pub mod msaa;
pub mod sampling;
pub mod scale;
pub mod shadows;
mod shared;
pub mod slicing;
pub mod temporal;
pub mod transparency;

pub use crate::table::Table;
pub use shared::{
    DEFAULT_SIZE, Finished, Outcome, Reads, Study, StudyError, StudyOptions, StudyOutput, all_kept,
    json, run_points,
};
pub(crate) use shared::{
    Measured, generate, measure, outcome_in_error_field, scene_defaults, shipped,
};

use crate::compose::Composer;
use crate::gpu::{AdapterSummary, Gpu};
use shared::conduct;
use std::path::{Path, PathBuf};

/// A study as the command line finds and runs it.
pub struct Entry {
    pub name: &'static str,
    pub about: &'static str,
    pub reads: &'static [Reads],
    conduct: Conduct,
}

type Conduct =
    fn(&Gpu, &Composer, &StudyOptions, &mut dyn FnMut(&str)) -> Result<StudyOutput, StudyError>;

impl Entry {
    const fn of<S: Study>() -> Entry {
        Entry {
            name: S::NAME,
            about: S::ABOUT,
            reads: S::READS,
            conduct: conduct::<S>,
        }
    }

    /// Refuse the options `given` that this study does not read (they would change
    /// nothing), and a light count given twice (it would run twice).
    pub fn check_given(&self, given: &[Reads], lights: &[u32]) -> Result<(), StudyError> {
        if let Some(unread) = given.iter().find(|g| !self.reads.contains(g)) {
            let reads: Vec<&str> = self.reads.iter().map(|r| r.flag()).collect();
            return Err(StudyError::Usage(format!(
                "study {} does not read {}: it would change nothing; the options it reads: {}",
                self.name,
                unread.flag(),
                if reads.is_empty() {
                    "none of these".into()
                } else {
                    reads.join(", ")
                }
            )));
        }
        if let Some((_, n)) = lights
            .iter()
            .enumerate()
            .find(|&(i, n)| lights[..i].contains(n))
        {
            return Err(StudyError::Usage(format!(
                "--lights names {n} twice: each count runs once; give each count once"
            )));
        }
        Ok(())
    }

    /// Run the study; `progress` hears of each point as it ends.
    pub fn run(
        &self,
        gpu: &Gpu,
        composer: &Composer,
        options: &StudyOptions,
        progress: &mut dyn FnMut(&str),
    ) -> Result<StudyOutput, StudyError> {
        (self.conduct)(gpu, composer, options, progress)
    }
}

/// Every study, in the order `clusterlab study --help` lists them.
pub const STUDIES: &[Entry] = &[
    Entry::of::<codecs::CodecStudy>(),
    Entry::of::<depth::DepthStudy>(),
    Entry::of::<slicing::SlicingStudy>(),
    Entry::of::<cones::ConeStudy>(),
    Entry::of::<culling::CullingStudy>(),
    Entry::of::<msaa::MsaaStudy>(),
    Entry::of::<transparency::TransparencyStudy>(),
    Entry::of::<temporal::TemporalStudy>(),
    Entry::of::<sampling::SamplingStudy>(),
    Entry::of::<scale::ScaleStudy>(),
    Entry::of::<shadows::ShadowStudy>(),
];

/// The study of that name.
pub fn find(name: &str) -> Result<&'static Entry, StudyError> {
    STUDIES.iter().find(|e| e.name == name).ok_or_else(|| {
        let names: Vec<&str> = STUDIES.iter().map(|e| e.name).collect();
        StudyError::Usage(format!(
            "no study named `{name}`; the studies: {}",
            names.join(", ")
        ))
    })
}

/// Whether `file` is one a study writes: NAME.csv, .json, .md or .svg of a study in
/// [`STUDIES`].
pub fn is_study_file(file: &str) -> bool {
    file.rsplit_once('.').is_some_and(|(stem, ext)| {
        ["csv", "json", "md", "svg"].contains(&ext) && STUDIES.iter().any(|e| e.name == stem)
    })
}

/// The files study `name` writes.
pub fn files_of(name: &str) -> [String; 4] {
    ["csv", "json", "md", "svg"].map(|ext| format!("{name}.{ext}"))
}

/// Whether study `name` may write its files into `dir` (`files::folder::check_study_folder`):
/// asked before it runs.
pub fn check_folder(dir: &Path, name: &str) -> Result<(), String> {
    let files = files_of(name);
    let files: Vec<&str> = files.iter().map(String::as_str).collect();
    crate::files::folder::check_study_folder(dir, &files, &is_study_file)
}

/// Write NAME.csv, NAME.json, NAME.md and the plot into `dir` (each file atomically), once
/// the folder is checked to be a study folder that may take them.
pub fn write(
    dir: &Path,
    out: &StudyOutput,
    adapter: &AdapterSummary,
    command: &str,
) -> Result<Vec<PathBuf>, StudyError> {
    let name = out.name;
    let mut names: Vec<String> = files_of(name).into();
    if let Some(p) = &out.plot {
        names.push(p.file.clone());
    }
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    crate::files::folder::claim_study_folder(dir, &names, is_study_file).map_err(StudyError::Io)?;
    let doc = serde_json::to_string_pretty(&json(out, adapter, command))
        .map_err(|e| StudyError::Io(e.to_string()))?;
    let markdown = format!(
        "{}\nAdapter: {} ({}, {}). Command: `{command}`.\n",
        out.table.markdown(),
        adapter.name,
        adapter.backend,
        adapter.driver
    );
    let mut files = vec![
        (dir.join(format!("{name}.csv")), out.csv.clone()),
        (dir.join(format!("{name}.json")), doc),
        (dir.join(format!("{name}.md")), markdown),
    ];
    if let Some(p) = &out.plot {
        files.push((dir.join(&p.file), p.svg.clone()));
    }
    for (path, text) in &files {
        crate::files::write_file(path, text.as_bytes()).map_err(StudyError::Io)?;
    }
    Ok(files.into_iter().map(|(p, _)| p).collect())
}
