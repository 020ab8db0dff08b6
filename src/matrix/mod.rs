//! The variant matrix: every cell (a variant on a scene with given parameters) rendered,
//! timed over several frames and measured against the CPU reference; then speed-ups against
//! naive forward, the time-error Pareto front, and a report (JSON, CSV, HTML, terminal).

mod baseline;
mod columns;
mod html;
mod plan;
mod plots;
mod record;
mod report;
mod reuse;
mod validate;
mod verdicts;

pub use crate::measure::Front;
pub use baseline::{RunComparison, compare_runs};
pub use columns::{COLUMNS, Cell, Column, Measured, Shown, count};
pub use plan::{
    CellSpec, Group, GroupSequence, MSAA_GROUP, ParamsRecord, PlannedCell, SEQUENCE_REBUILDS,
    Sweep, TRANSPARENCY_GROUP, VariantEntry, default_groups, expand, find_variants, parse_shard,
    parse_sweep, shard,
};
pub use record::{
    AgainstLeader, BaselineChange, CellRecord, Fidelity, Images, Provenance, Rank, Results,
    RunCost, VariantFile, grouped, label,
};
pub use report::{table, write_report};
pub use reuse::{FILE as REUSE_FILE, Previous, ReuseIndex, reuse_summary};

use std::collections::BTreeMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use serde_json::Map;
use sha2::{Digest, Sha256};

use std::sync::Arc;

use crate::compose::{Composer, Composition};
use crate::gpu::{Gpu, PipelineStats};
use crate::measure::{Budget, Frames, Paired, Stop, Verdict};
use crate::reference::{ReferenceCache, ReferenceJob};
use crate::run::{CellCost, CellOptions, GpuHalf, RunError, finish_cell, write_images, write_png};
use crate::scene::SCENES;
use crate::variant::DebugView;

/// How a matrix runs.
#[derive(Clone, Debug)]
pub struct MatrixOptions {
    /// Frames per cell: by budget, or an exact count.
    pub frames: Frames,
    pub out: PathBuf,
    /// Show a progress bar on stderr.
    pub progress: bool,
    pub shard: Option<(u32, u32)>,
    pub command: Vec<String>,
    /// The variant files of the whole matrix (all shards), for provenance: `merge` checks
    /// that every shard read the same files.
    pub variant_files: BTreeMap<String, VariantFile>,
    /// Called before each cell runs (tests use it to break the device on purpose).
    #[doc(hidden)]
    pub before_cell: Option<fn(&Gpu, &CellSpec)>,
    /// An earlier run whose unchanged cells are taken rather than run (`--reuse`).
    pub reuse: Option<std::sync::Arc<Previous>>,
    /// Run each cell's CPU half (reference shading, error figures, images) on a thread of
    /// its own beside the next cells' GPU work (`--overlap`).
    pub overlap: bool,
}

/// Cells timed together in interleaved rounds at most: each holds its renderer (its
/// targets and buffers) until its group's rounds end.
pub const INTERLEAVED_CELLS: usize = 64;

/// Run every cell and return the results with speed-ups, ranks and the Pareto front
/// filled in. The cells of a group (scene and parameters) are timed together, one frame
/// each in turn (`run::Timing`), so that drift of the machine hits each alike; at most
/// [`INTERLEAVED_CELLS`] at a time. A cell that fails (or panics) is recorded and the others
/// still run: after a failure the device is checked and, when it is unusable (lost, still
/// busy past the cell limit, failing a read-back), replaced by a new one, and the cells of
/// the group that had not finished run again on it.
pub fn run(
    gpu: &mut Gpu,
    composer: &Composer,
    cells: &[PlannedCell],
    options: &MatrixOptions,
) -> Results {
    let images = options.out.join("images");
    let references = ReferenceCache::default();
    // Folders a reused cell's images are copied into before any cell writes its own.
    for folder in [&images, &options.out.join("plots")] {
        if let Err(e) = crate::files::write::create_folder(folder) {
            eprintln!("warning: {e}");
        }
    }
    let mut bar = crate::progress::Bar::new(options.progress, cells.len());
    let start = std::time::Instant::now();
    // Pipeline counts of devices replaced during the run.
    let mut replaced = PipelineStats::default();
    // Why there is no usable device (the last one broke and no new one could be opened).
    let mut no_device: Option<String> = None;
    // What each cell depended on, for a later `--reuse` (none when clusterlab's build cannot
    // be read to identify it).
    composer.record();
    let run_inputs = reuse::run_inputs(gpu, &options.frames)
        .map_err(|e| bar.println(format!("warning: no {REUSE_FILE} for a later --reuse: {e}")))
        .ok();
    let mut index = ReuseIndex::default();
    let mut recomposed = std::collections::HashMap::new();
    let mut reused: Vec<String> = Vec::new();
    let mut records: Vec<Option<CellRecord>> = vec![None; cells.len()];
    // Batches timed so far: each one's cells compare with each other only.
    let mut batches_run = 0;
    std::thread::scope(|scope| {
        // With overlap, the cells' CPU halves run on one thread of their own, in order, while
        // the next cells' GPU halves run here; a bounded queue keeps at most two waiting.
        let (to_worker, jobs) = std::sync::mpsc::sync_channel::<(usize, Box<Pending>)>(1);
        let (to_main, finished) = std::sync::mpsc::channel::<(usize, CellRecord)>();
        let references = &references;
        let worker = options.overlap.then(|| {
            scope.spawn(move || {
                for (i, pending) in jobs {
                    let _ = to_main.send((i, finish_guarded(*pending, options, references)));
                }
            })
        });
        let mut queue: std::collections::VecDeque<Vec<usize>> = batches(cells).into();
        while let Some(batch) = queue.pop_front() {
            let mut todo = Vec::new();
            for i in batch {
                let cell = &cells[i];
                let inputs = run_inputs.as_deref().map(|run| {
                    let variant = options.variant_files.get(&cell.spec.variant);
                    reuse::cell_inputs(run, &cell.spec, variant.map(|f| f.sha256.as_str()))
                });
                if let (Some(previous), Some(inputs)) = (&options.reuse, &inputs)
                    && let Some((record, used)) =
                        previous.unchanged(cell, inputs, composer, gpu, &mut recomposed)
                {
                    match copy_images(&previous.dir, record, &options.out) {
                        Ok(()) => {
                            index.add(&cell.spec.id, inputs.clone(), &used);
                            reused.push(cell.spec.id.clone());
                            records[i] = Some(record.clone());
                            bar.done(&format!("{}: reused", cell.spec.id));
                            continue;
                        }
                        Err(e) => {
                            bar.println(format!("{}: not reused, run again: {e}", cell.spec.id))
                        }
                    }
                }
                todo.push((i, inputs));
            }
            if todo.is_empty() {
                continue;
            }
            if no_device.is_some() {
                let before = gpu.pipeline_stats();
                no_device = gpu
                    .reopen()
                    .map(|fresh| {
                        replaced = add_pipelines(replaced, before);
                        *gpu = fresh
                    })
                    .err()
                    .map(no_usable_device);
            }
            let ids: Vec<usize> = todo.iter().map(|(i, _)| *i).collect();
            let ended = match &no_device {
                Some(why) => BatchEnd {
                    ran: ids
                        .iter()
                        .map(|&i| {
                            let failed = CellRecord::failed(cells[i].spec.clone(), why.clone());
                            (i, Ran::done(failed), Vec::new())
                        })
                        .collect(),
                    again: Vec::new(),
                },
                None => {
                    batches_run += 1;
                    let batch = (batches_run, &ids[..]);
                    run_batch(gpu, composer, cells, batch, options, references, &bar)
                }
            };
            // The failure that ended the batch is its last.
            let culprit = ended
                .ran
                .iter()
                .rev()
                .find(|(_, r, _)| r.failed())
                .map(|c| c.0);
            // After a failure: keep the device if it still works, else open a new one; the
            // group's cells that had not finished run again on it.
            let mut note = None;
            if culprit.is_some() && no_device.is_none() {
                let before = gpu.pipeline_stats();
                note = renew_if_unusable(gpu, &mut no_device);
                if note.is_some() && no_device.is_none() {
                    // Replaced by a new device: keep what the old one compiled in the count.
                    replaced = add_pipelines(replaced, before);
                }
            }
            if !ended.again.is_empty() {
                queue.push_front(ended.again);
            }
            for (i, ran, compositions) in ended.ran {
                if let Some((_, Some(inputs))) = todo.iter().find(|(j, _)| *j == i) {
                    index.add(&cells[i].spec.id, inputs.clone(), &compositions);
                }
                let mut record = match ran {
                    Ran::Pending(pending) if worker.is_some() => {
                        // The worker only ends when the queue closes.
                        let _ = to_worker.send((i, pending));
                        bar.done(&format!("{}: rendered", cells[i].spec.id));
                        continue;
                    }
                    Ran::Pending(pending) => finish_guarded(*pending, options, references),
                    Ran::Done(record) => *record,
                };
                if let (Some(why), Some(note)) = (&mut record.failure, &note)
                    && culprit == Some(i)
                {
                    bar.println(format!("{}: {note}", cells[i].spec.id));
                    why.push_str(&format!(" [{note}]"));
                }
                bar.done(&match &record.failure {
                    None => format!("{}: ok", cells[i].spec.id),
                    Some(why) => format!("{}: FAILED: {why}", cells[i].spec.id),
                });
                records[i] = Some(record);
            }
            bar.checkpoint();
        }
        drop(to_worker);
        if let Some(worker) = worker {
            let _ = worker.join();
        }
        for (i, record) in finished.try_iter() {
            records[i] = Some(record);
        }
    });
    let records: Vec<CellRecord> = records
        .into_iter()
        .zip(cells)
        .map(|(r, cell)| {
            r.unwrap_or_else(|| {
                CellRecord::failed(cell.spec.clone(), "its CPU half did not finish".into())
            })
        })
        .collect();
    // Each note once, with the cells it concerns.
    let mut notes: Vec<(&str, Vec<&str>)> = Vec::new();
    for r in &records {
        for note in &r.notes {
            match notes.iter_mut().find(|(n, _)| n == note) {
                Some((_, ids)) => ids.push(&r.spec.id),
                None => notes.push((note, vec![&r.spec.id])),
            }
        }
    }
    for (note, ids) in notes {
        let shown = ids[..ids.len().min(3)].join(", ");
        let more = match ids.len() {
            0..=3 => String::new(),
            n => format!(" and {} more", n - 3),
        };
        bar.println(format!("note ({shown}{more}): {note}"));
    }
    for r in &records {
        if let Some(why) = &r.failure {
            bar.println(format!(
                "FAILED {}: {}",
                r.spec.id,
                why.lines().next().unwrap_or("")
            ));
        }
    }
    bar.finish();
    let (reference_frames, reference_shadings) = references.counts();
    let reused_ids: Vec<&str> = reused.iter().map(String::as_str).collect();
    let mut cost = RunCost {
        wall_s: start.elapsed().as_secs_f64(),
        pipelines: add_pipelines(replaced, gpu.pipeline_stats()),
        reference_frames,
        reference_shadings,
        reused_cells: reused.len(),
        ..Default::default()
    };
    if run_inputs.is_some()
        && let Err(e) = index.write(&options.out)
    {
        eprintln!("warning: no {REUSE_FILE} for a later --reuse: {e}");
    }
    for r in records
        .iter()
        .filter(|r| !reused_ids.contains(&r.spec.id.as_str()))
    {
        if let Some(c) = &r.cost_ms {
            let t = &mut cost.cells_ms;
            t.setup += c.setup;
            t.frames += c.frames;
            t.counters += c.counters;
            t.reference += c.reference;
            t.images += c.images;
        }
        cost.warmup_frames += r.warmup_frames;
        cost.timed_frames += r.frames;
    }
    let mut provenance = provenance(gpu, composer, options);
    provenance.cost = Some(cost);
    let mut records = records;
    for r in &mut records {
        if !reused_ids.contains(&r.spec.id.as_str()) {
            r.perturbed_depth_ulps = provenance.perturbed_depth_ulps;
        }
    }
    let mut results = Results {
        provenance: vec![provenance],
        cells: records,
        reused: reused_ids.iter().map(|s| s.to_string()).collect(),
    };
    if let Some(previous) = &options.reuse {
        previous.mark_reused(&mut results);
    }
    derive(&mut results.cells, None);
    results
}

/// The order cells run in: the cells of one group (scene and parameters) together, in
/// batches of at most [`INTERLEAVED_CELLS`] timed in interleaved rounds, groups in the
/// order the plan first names them; a sequence cell alone.
fn batches(cells: &[PlannedCell]) -> Vec<Vec<usize>> {
    let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
    let mut alone = Vec::new();
    for (i, c) in cells.iter().enumerate() {
        if c.spec.sequence.is_some() {
            alone.push(vec![i]);
            continue;
        }
        let g = c.spec.group();
        match groups.iter_mut().find(|(k, _)| *k == g) {
            Some((_, v)) => v.push(i),
            None => groups.push((g, vec![i])),
        }
    }
    groups
        .into_iter()
        .flat_map(|(_, v)| {
            v.chunks(INTERLEAVED_CELLS)
                .map(<[usize]>::to_vec)
                .collect::<Vec<_>>()
        })
        .chain(alone)
        .collect()
}

/// What a batch of cells came to: each cell that ended (done, or waiting for its CPU half),
/// with the compositions it used, in the order they ran; and the cells that must run again
/// on a new device (the device became unusable while they were timed).
struct BatchEnd {
    ran: Vec<(usize, Ran, Vec<Arc<Composition>>)>,
    again: Vec<usize>,
}

/// A cell of a batch being timed.
struct Live<'g> {
    i: usize,
    scene: crate::scene::Scene,
    timing: crate::run::Timing<'g>,
    compositions: Vec<Arc<Composition>>,
    /// Its frame's total in each round of the batch (None where it took none).
    rounds: Vec<Option<f64>>,
}

/// Run the cells `batch` of one group: each set up, then timed one frame each in turn
/// until each has enough, then each counted and its reference's raster truth read back.
/// After a failure that left the device unusable the batch ends there, and the cells that
/// had not finished are returned to run again.
fn run_batch(
    gpu: &Gpu,
    composer: &Composer,
    cells: &[PlannedCell],
    (batch_id, batch): (usize, &[usize]),
    options: &MatrixOptions,
    references: &ReferenceCache,
    bar: &crate::progress::Bar,
) -> BatchEnd {
    let mut ran: Vec<(usize, Ran, Vec<Arc<Composition>>)> = Vec::new();
    let mut live: Vec<Live> = Vec::new();
    let failed = |i: usize, why: String| CellRecord::failed(cells[i].spec.clone(), why);
    let panicked = |panic: Box<dyn std::any::Any + Send>| {
        format!("panicked: {}", crate::common::panic_message(panic.as_ref()))
    };
    let stop_here = |ran, live: &[Live], rest: &[usize]| BatchEnd {
        ran,
        again: live
            .iter()
            .map(|l| l.i)
            .chain(rest.iter().copied())
            .collect(),
    };
    for (k, &i) in batch.iter().enumerate() {
        let cell = &cells[i];
        bar.status(format!("setting up {}", cell.spec.id));
        gpu.begin_cell();
        if let Some(hook) = options.before_cell {
            hook(gpu, &cell.spec);
        }
        let mark = composer.log_mark();
        let started = catch_unwind(AssertUnwindSafe(|| {
            start_cell(gpu, composer, cell, options, references)
        }))
        .unwrap_or_else(|panic| Started::Done(Ran::done(failed(i, panicked(panic)))));
        let compositions = composer.logged_since(mark);
        match started {
            Started::Timing(started) => {
                let (scene, timing) = *started;
                live.push(Live {
                    i,
                    scene,
                    timing,
                    compositions,
                    rounds: Vec::new(),
                })
            }
            Started::Done(done) => {
                let broke = done.failed();
                ran.push((i, done, compositions));
                if broke && gpu.check_health().is_err() {
                    return stop_here(ran, &live, &batch[k + 1..]);
                }
            }
        }
    }
    let mut round = 0;
    while live.iter().any(|l| !l.timing.done()) {
        round += 1;
        bar.status(format!(
            "timing {} cells of {}, round {round}",
            live.iter().filter(|l| !l.timing.done()).count(),
            cells[batch[0]].spec.group()
        ));
        // Every other round runs the cells in reverse, so that no cell always follows the
        // same one (what a frame leaves warm or busy, the next one meets).
        let mut order: Vec<usize> = (0..live.len())
            .filter(|&k| !live[k].timing.done())
            .collect();
        if round % 2 == 0 {
            order.reverse();
        }
        let mut failed_now: Vec<(usize, CellRecord)> = Vec::new();
        for l in &mut live {
            l.rounds.push(None);
        }
        for k in order {
            gpu.begin_cell();
            let timing = &mut live[k].timing;
            let why = match catch_unwind(AssertUnwindSafe(|| timing.next_frame())) {
                Ok(Ok(())) => {
                    let ms = live[k].timing.last_frame_ms();
                    *live[k].rounds.last_mut().expect("pushed above") = ms;
                    continue;
                }
                Ok(Err(e)) => {
                    CellRecord::not_run(cells[live[k].i].spec.clone(), &RunError::from(e))
                }
                Err(panic) => failed(live[k].i, panicked(panic)),
            };
            failed_now.push((k, why));
            if gpu.check_health().is_err() {
                break;
            }
        }
        if failed_now.is_empty() {
            if let Frames::Budget(budget) = options.frames {
                stop_decided(&mut live, &budget);
            }
            continue;
        }
        // Out of the rounds, in the order they failed (the last is the one a broken device
        // is charged to).
        let mut gone: Vec<usize> = failed_now.iter().map(|(k, _)| *k).collect();
        gone.sort_unstable_by(|a, b| b.cmp(a));
        let mut removed: std::collections::HashMap<usize, Live> =
            gone.into_iter().map(|k| (k, live.remove(k))).collect();
        for (k, record) in failed_now {
            let l = removed.remove(&k).expect("removed above");
            ran.push((l.i, Ran::done(record), l.compositions));
        }
        if gpu.check_health().is_err() {
            return stop_here(ran, &live, &[]);
        }
        if let Frames::Budget(budget) = options.frames {
            stop_decided(&mut live, &budget);
        }
    }
    // Groups in which some cell traces shadow rays: their truth is shadowed.
    let shadowed_groups: std::collections::HashSet<String> = cells
        .iter()
        .filter(|c| {
            c.variant
                .as_ref()
                .is_ok_and(|v| v.variant.shading.shadows.traced())
        })
        .map(|c| c.spec.group())
        .collect();
    let mut unfinished = live.into_iter();
    while let Some(Live {
        i,
        scene,
        timing,
        mut compositions,
        rounds,
    }) = unfinished.next()
    {
        let cell = &cells[i];
        bar.status(format!("counting {}", cell.spec.id));
        gpu.begin_cell();
        let mark = composer.log_mark();
        let shadowed_group = shadowed_groups.contains(&cell.spec.group());
        let done = catch_unwind(AssertUnwindSafe(|| {
            let with = (options, shadowed_group);
            finish_gpu(timing, composer, cell, scene, with, references)
        }))
        .unwrap_or_else(|panic| Ran::done(failed(i, panicked(panic))))
        .timed_in(batch_id, rounds);
        compositions.extend(composer.logged_since(mark));
        let broke = done.failed();
        ran.push((i, done, compositions));
        if broke && gpu.check_health().is_err() {
            let rest: Vec<Live> = unfinished.collect();
            return stop_here(ran, &rest, &[]);
        }
    }
    BatchEnd {
        ran,
        again: Vec::new(),
    }
}

/// After a round of a batch timed by budget: stop each cell whose verdict against the
/// leader is decided (`verdicts::decided_after_round`), and each that spent its budget or
/// took its most frames with its verdict still open; time again a cell stopped as decided
/// whose verdict a new leader opened.
fn stop_decided(live: &mut [Live], budget: &Budget) {
    // Cells that may still time: all but those past their budget or frame cap.
    let capped = |l: &Live| l.timing.spent(budget);
    let open: Vec<bool> = live.iter().map(|l| capped(l).is_none()).collect();
    let rounds: Vec<&[Option<f64>]> = live.iter().map(|l| &l.rounds[..]).collect();
    let mut decided = verdicts::decided_after_round(&rounds, &open);
    // A leader with fewer than an interval's frames of its own goes on.
    for (k, l) in live.iter().enumerate() {
        if l.rounds.iter().flatten().count() < crate::measure::MIN_FRAMES {
            decided[k] = false;
        }
    }
    // A leader past its cap takes no more rounds: what is open against it stays open, so
    // the others stop with it, for its reason.
    let lead_cap = verdicts::leader(&rounds).and_then(|k| capped(&live[k]));
    for (k, l) in live.iter_mut().enumerate() {
        let stopped = l.timing.stop();
        let cap = capped(l).or(lead_cap);
        if decided[k] {
            if stopped.is_none() {
                l.timing.end(Stop::Decided);
            }
        } else if let Some(stop) = cap {
            if stopped.is_none() {
                l.timing.end(stop);
            }
        } else if stopped == Some(Stop::Decided) {
            l.timing.resume();
        }
    }
}

/// A cell after its set-up: timing frames, or done (failed, refused, a sequence).
enum Started<'g> {
    Timing(Box<(crate::scene::Scene, crate::run::Timing<'g>)>),
    Done(Ran),
}

/// Set a cell up and draw its untimed frames; a sequence runs whole here.
fn start_cell<'g>(
    gpu: &'g Gpu,
    composer: &Composer,
    cell: &PlannedCell,
    options: &MatrixOptions,
    references: &ReferenceCache,
) -> Started<'g> {
    let spec = cell.spec.clone();
    let loaded = match &cell.variant {
        Ok(v) => v,
        Err(why) => return Started::Done(Ran::done(CellRecord::failed(spec, why.clone()))),
    };
    if let Some(sequence) = spec.sequence {
        let record = run_sequence(gpu, composer, loaded, sequence, spec, options, references);
        return Started::Done(Ran::done(record));
    }
    let params = spec.params.into();
    let started = gpu
        .check_size(spec.params.width, spec.params.height)
        .map_err(RunError::from)
        .and_then(|()| crate::scene::generate(&spec.scene, params).map_err(RunError::Scene))
        .and_then(|scene| {
            let timing = crate::run::Timing::start(gpu, composer, loaded, &scene, options.frames)?;
            Ok((scene, timing))
        });
    match started {
        Ok(started) => Started::Timing(Box::new(started)),
        Err(e) => Started::Done(Ran::done(CellRecord::not_run(spec, &e))),
    }
}

/// The variant whose reference is the truth of a cell of `loaded` in a group where some
/// cell traces shadow rays (`shadowed_group`): `loaded` with exact shadows, where it has
/// none (None where its own reference is the truth; an error where that variant is not
/// one the reference can shade).
fn truth_variant(
    loaded: &crate::variant::LoadedVariant,
    shadowed_group: bool,
) -> Option<Result<crate::variant::LoadedVariant, String>> {
    use crate::variant::Shadows;
    if !shadowed_group || loaded.variant.shading.shadows != Shadows::None {
        return None;
    }
    let mut truth = loaded.clone();
    truth.variant.shading.shadows = Shadows::Exact;
    let problems = crate::variant::check(&truth.variant);
    Some(match problems.first() {
        None => Ok(truth),
        Some(p) => Err(format!(
            "no shadowed truth for {}: {}",
            loaded.name, p.message
        )),
    })
}

/// After a cell's timed frames: its debug view, counters and raster truth.
fn finish_gpu(
    timing: crate::run::Timing<'_>,
    composer: &Composer,
    cell: &PlannedCell,
    scene: crate::scene::Scene,
    (options, shadowed_group): (&MatrixOptions, bool),
    references: &ReferenceCache,
) -> Ran {
    let gpu = timing.gpu();
    let spec = cell.spec.clone();
    let loaded = match &cell.variant {
        Ok(v) => v,
        Err(why) => return Ran::done(CellRecord::failed(spec, why.clone())),
    };
    let v = &loaded.variant;
    // The lights-per-cluster view shows where a clustered variant spends its time.
    let debug_view =
        (v.pipeline.is_clustered() && spec.sweep.is_empty() && v.debug_view == DebugView::Off)
            .then_some(DebugView::LightsPerCluster);
    let cell_options = CellOptions {
        frames: options.frames,
        stats: true,
        out: None,
        references: Some(references),
        debug_view,
    };
    match timing.finish(composer, loaded, &scene, cell_options, references) {
        Ok((half, _)) => {
            // Begun after the cell's own reference, so finished after it (`finish`).
            let truth = truth_variant(loaded, shadowed_group).map(|t| {
                let t = t?;
                let job = references
                    .begin(gpu, composer, &t, &scene)
                    .map_err(|e| format!("the group's truth: {e}"))?;
                Ok((t, job))
            });
            Ran::Pending(Box::new(Pending {
                spec,
                loaded: loaded.clone(),
                scene,
                half,
                rounds: None,
                truth,
            }))
        }
        Err(e) => Ran::done(CellRecord::not_run(spec, &e)),
    }
}

/// A cell after its GPU half: done (failed, refused, a sequence), or waiting for its CPU
/// half (`finish_guarded`).
enum Ran {
    Done(Box<CellRecord>),
    Pending(Box<Pending>),
}

impl Ran {
    fn done(record: CellRecord) -> Self {
        Ran::Done(Box::new(record))
    }

    /// A pending cell's rounds: its frame times in batch `batch`'s interleaved rounds.
    fn timed_in(self, batch: usize, rounds: Vec<Option<f64>>) -> Self {
        match self {
            Ran::Pending(mut p) => {
                p.rounds = Some((batch, rounds));
                Ran::Pending(p)
            }
            done => done,
        }
    }

    fn failed(&self) -> bool {
        matches!(self, Ran::Done(r) if r.failure.is_some())
    }
}

/// What a cell's CPU half needs.
struct Pending {
    spec: CellSpec,
    loaded: crate::variant::LoadedVariant,
    scene: crate::scene::Scene,
    half: GpuHalf,
    /// The batch it was timed in, and its frame time in each of the batch's rounds.
    rounds: Option<(usize, Vec<Option<f64>>)>,
    /// Its group's truth where its own reference is not it: the variant that truth is
    /// shaded for and its reference job, or why there is none.
    truth: Option<Result<(crate::variant::LoadedVariant, ReferenceJob), String>>,
}

/// After a failed cell: keep the device if it still works, else open a new one (or record in
/// `no_device` why none opens). Returns what happened when the device was not kept.
fn renew_if_unusable(gpu: &mut Gpu, no_device: &mut Option<String>) -> Option<String> {
    match gpu.renew_if_unusable() {
        Ok(None) => None,
        Ok(Some(broken)) => Some(format!(
            "the device was unusable afterwards ({broken}); a new one runs the next cells"
        )),
        Err(e) => {
            let why = no_usable_device(e);
            *no_device = Some(why.clone());
            Some(format!("the device was unusable afterwards; {why}"))
        }
    }
}

fn add_pipelines(a: PipelineStats, b: PipelineStats) -> PipelineStats {
    PipelineStats {
        created: a.created + b.created,
        reused: a.reused + b.reused,
        creation_ms: a.creation_ms + b.creation_ms,
    }
}

fn no_usable_device(e: crate::gpu::GpuError) -> String {
    format!("no usable GPU device: opening a new one failed: {e}")
}

/// A cell's CPU half (`run::finish_cell`) and its images; a panic fails the cell alone.
fn finish_guarded(
    pending: Pending,
    options: &MatrixOptions,
    references: &ReferenceCache,
) -> CellRecord {
    let spec = pending.spec.clone();
    catch_unwind(AssertUnwindSafe(|| finish(pending, options, references))).unwrap_or_else(
        |panic| {
            let why = crate::common::panic_message(panic.as_ref());
            CellRecord::failed(spec, format!("panicked: {why}"))
        },
    )
}

fn finish(pending: Pending, options: &MatrixOptions, references: &ReferenceCache) -> CellRecord {
    let Pending {
        spec,
        loaded,
        scene,
        half,
        rounds,
        truth,
    } = pending;
    let (batch, round_ms) = rounds.map_or((None, Vec::new()), |(b, r)| (Some(b), r));
    let finished = finish_cell(half, references, &loaded, &scene, None);
    // The truth's job is finished whatever became of the cell: cells after it may share it.
    let truth = truth.map(|t| {
        let (variant, job) = t?;
        let (frame, _) = references
            .finish(job, &variant, &scene)
            .map_err(|e| format!("the group's truth: {e}"))?;
        Ok::<_, String>(frame)
    });
    let mut c = match finished {
        Ok(c) => c,
        Err(e) => return CellRecord::not_run(spec, &e),
    };
    let fidelity = match truth {
        None => c
            .report
            .error
            .as_ref()
            .map(|e| Fidelity::of(e, Fidelity::OWN)),
        Some(Ok(truth)) => Some(Fidelity::of(
            &crate::metrics::compare(&c.frame, &truth),
            Fidelity::SHADOWED,
        )),
        Some(Err(why)) => {
            c.report.scene_notes.push(why);
            None
        }
    };
    let images = options.out.join("images");
    let start = std::time::Instant::now();
    let stem = spec.file_stem();
    let relative = |p: &Path| {
        p.strip_prefix(&options.out)
            .unwrap_or(p)
            .to_string_lossy()
            .into_owned()
    };
    let mut files = Images::default();
    match write_images(&images, &stem, &c.frame, &c.reference) {
        Ok(paths) => {
            files.image = paths.first().map(|p| relative(p));
            files.heat = paths.get(1).map(|p| relative(p));
        }
        Err(e) => return CellRecord::failed(spec, e.to_string()),
    }
    if let Some(debug) = &c.debug {
        let path = images.join(format!("{stem}.debug.png"));
        let rgb: Vec<u8> = debug.iter().flat_map(|p| [p[0], p[1], p[2]]).collect();
        if write_png(&path, c.frame.width, c.frame.height, &rgb).is_ok() {
            files.debug = Some(relative(&path));
        }
    }
    c.report.cost_ms.images += start.elapsed().as_secs_f64() * 1e3;
    let r = c.report;
    CellRecord {
        spec,
        // A frame that means nothing fails with its figures kept beside the reason.
        failure: r.failure,
        refused: false,
        gpu_ms: r.gpu_ms,
        gpu_ms_spread: r.gpu_ms_spread,
        gpu_ms_interval: r.gpu_ms_interval,
        interval_level: r.interval_level,
        timing_stop: r.frame_count.stop,
        timing_source: Some(r.timing_source.to_string()),
        frames: r.frames,
        wall_ms: Some(r.wall_ms),
        reference_ms: Some(r.reference_ms),
        error: r.error,
        stats: r.stats,
        efficiency: r.efficiency,
        fidelity,
        images: files,
        speedup_vs_naive: None,
        speedup_interval: None,
        speedup_least: None,
        rank: None,
        run: 0,
        reused_from: None,
        exact_claim: r.exact_claim,
        notes: r.scene_notes,
        perturbed_depth_ulps: 0,
        vs_baseline: None,
        skipped_passes: r.skipped_passes,
        warmup_frames: r.frame_count.warmup,
        frame_without_lights: r.frame_count.frame_without_lights,
        disturbed_frames: r.frame_count.disturbed,
        cost_ms: Some(r.cost_ms),
        sequence_summary: None,
        front: None,
        batch,
        round_ms,
        against_leader: None,
    }
}

/// A sequence cell: its frames, checks and outputs (the animation in `images/`, the plot of
/// its frames in `plots/`).
fn run_sequence(
    gpu: &Gpu,
    composer: &Composer,
    loaded: &crate::variant::LoadedVariant,
    sequence: crate::sequence::SequenceSpec,
    spec: CellSpec,
    options: &MatrixOptions,
    references: &ReferenceCache,
) -> CellRecord {
    let scene = spec.scene.clone();
    let frames = crate::sequence::scene_frames(&scene, spec.params.into());
    let run = match crate::sequence::run(gpu, composer, loaded, sequence, &frames, references) {
        Ok(run) => run,
        Err(e) => return CellRecord::not_run(spec, &e),
    };
    let images_started = std::time::Instant::now();
    let stem = spec.file_stem();
    let out = |folder: &str, name: String| options.out.join(folder).join(name);
    let mut files = Images::default();
    let written = (|| -> Result<(), String> {
        let paths = write_images(
            &options.out.join("images"),
            &stem,
            &run.last,
            &run.last_reference,
        )
        .map_err(|e| e.to_string())?;
        let relative = |p: &Path| {
            p.strip_prefix(&options.out)
                .unwrap_or(p)
                .to_string_lossy()
                .into_owned()
        };
        files.image = paths.first().map(|p| relative(p));
        files.heat = paths.get(1).map(|p| relative(p));
        let gif = crate::sequence::animation::gif(&run.animation, run.report.frame_step_s)?;
        crate::files::write_file(&out("images", format!("{stem}.gif")), &gif)?;
        files.animation = Some(format!("images/{stem}.gif"));
        let plot_name = format!("{stem}.frames.svg");
        if let Some(p) = crate::sequence::output::frame_plot(&run.report, &plot_name) {
            crate::files::write::create_folder(&options.out.join("plots"))?;
            crate::files::write_file(&out("plots", plot_name.clone()), p.svg.as_bytes())?;
            files.frames_plot = Some(format!("plots/{plot_name}"));
        }
        Ok(())
    })();
    if let Err(why) = written {
        return CellRecord::failed(spec, why);
    }
    let r = run.report;
    let m = &r.summary;
    let mut gpu_ms = m.pass_ms.clone();
    gpu_ms.insert("total".into(), m.frame_ms.into());
    let mut gpu_ms_spread = Map::new();
    gpu_ms_spread.insert("total".into(), m.frame_ms_spread.to_vec().into());
    // No interval: a sequence's frames differ by design (lights move, lists are patched),
    // and sequences run one after another, not in interleaved rounds, so drift between
    // them is not shared. Two back-to-back default matrices called two pairs of sequence
    // cells in opposite orders (Forward+ against Patch: 45-48 against 64-68 ms, then 51-61
    // against 43-45), so a sequence's time ties with every other.
    let gpu_ms_interval = Map::new();
    // The worst checked frame's error stands for the sequence.
    let error = r
        .frames
        .iter()
        .filter_map(|f| f.check.as_ref())
        .map(|c| c.error.clone())
        .max_by(|a, b| {
            (a.max_abs_8bit, a.rmse_8bit)
                .partial_cmp(&(b.max_abs_8bit, b.rmse_8bit))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
    let frames = r.frames.len() as u32;
    CellRecord {
        spec,
        failure: r.failure,
        refused: false,
        gpu_ms,
        gpu_ms_spread,
        gpu_ms_interval,
        interval_level: None,
        timing_stop: Some(Stop::Count),
        timing_source: Some(r.timing_source.to_string()),
        frames,
        wall_ms: None,
        reference_ms: None,
        error,
        stats: r.stats,
        efficiency: None,
        fidelity: None,
        images: files,
        speedup_vs_naive: None,
        speedup_interval: None,
        speedup_least: None,
        rank: None,
        run: 0,
        reused_from: None,
        exact_claim: false,
        notes: Vec::new(),
        perturbed_depth_ulps: 0,
        vs_baseline: None,
        skipped_passes: r
            .frames
            .last()
            .map(|f| f.skipped.clone())
            .unwrap_or_default(),
        warmup_frames: 0,
        frame_without_lights: true,
        disturbed_frames: 0,
        cost_ms: Some(CellCost {
            setup: 0.0,
            frames: run.frames_ms,
            counters: 0.0,
            reference: run.checks_ms,
            images: images_started.elapsed().as_secs_f64() * 1e3,
        }),
        sequence_summary: Some(r.summary),
        front: None,
        batch: None,
        round_ms: Vec::new(),
        against_leader: None,
    }
}

/// Fill in speed-ups against naive forward, each cell's rank in its group, the time-error
/// front (per group of scene and parameters) and the change against a baseline run. A
/// group's cells are compared round by round (`measure::Paired`) among those timed in one
/// batch of one run, the batch with the most of them (this run's first where two tie);
/// the rest are not compared (`Rank::NotCompared`).
pub fn derive(cells: &mut [CellRecord], baseline: Option<&Results>) {
    let timed = |c: &CellRecord| c.ok() && !c.spec.debug_view && c.total_ms().is_some();
    let mut groups: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (i, c) in cells.iter().enumerate() {
        if timed(c) {
            groups.entry(c.spec.group()).or_default().push(i);
        }
    }
    let mut derived: Vec<Derived> = vec![Derived::default(); cells.len()];
    for members in groups.values() {
        let mut sizes: BTreeMap<(usize, usize), usize> = BTreeMap::new();
        for &i in members {
            if let Some(b) = cells[i].batch.filter(|_| !cells[i].round_ms.is_empty()) {
                *sizes.entry((cells[i].run, b)).or_default() += 1;
            }
        }
        let best = sizes
            .iter()
            .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0)))
            .map(|(k, _)| *k);
        let (compared, apart): (Vec<usize>, Vec<usize>) = members.iter().partition(|&&i| {
            best.is_some_and(|k| cells[i].batch == Some(k.1) && cells[i].run == k.0)
        });
        for i in apart {
            derived[i].rank = Some(Rank::NotCompared);
        }
        let rounds: Vec<&[Option<f64>]> =
            compared.iter().map(|&i| &cells[i].round_ms[..]).collect();
        let Some(lead) = verdicts::leader(&rounds) else {
            continue;
        };
        let paired = |a: usize, b: usize| Paired::of(rounds[a], rounds[b]);
        for (k, &i) in compared.iter().enumerate() {
            if k == lead {
                continue;
            }
            let p = paired(k, lead);
            let over_budget = cells[i].timing_stop == Some(Stop::Budget);
            derived[i].rank = Some(match p {
                Some(p) if p.verdict == Verdict::Slower => Rank::Slower,
                Some(p) if p.verdict == Verdict::Tie => Rank::TiedWithFastest,
                Some(p)
                    if over_budget
                        && p.rounds < crate::measure::MIN_FRAMES
                        && p.range[0] > 1.0 + crate::measure::TIE_WITHIN =>
                {
                    Rank::SlowerEachRound
                }
                _ => Rank::Undecided,
            });
            derived[i].against_leader = p.map(|paired| AgainstLeader {
                paired,
                rounds_to_decide: (!paired.verdict.decided())
                    .then(|| verdicts::rounds_to_decide(&paired)),
            });
        }
        let all_decided = compared.iter().enumerate().all(|(k, &i)| {
            k == lead
                || matches!(
                    derived[i].rank,
                    Some(Rank::Slower | Rank::TiedWithFastest | Rank::SlowerEachRound)
                )
        });
        derived[compared[lead]].rank = Some(if all_decided {
            Rank::Fastest
        } else {
            Rank::Leads
        });
        // Speed-ups: naive forward's frame over each cell's, round by round.
        let naive = (0..compared.len())
            .filter(|&k| cells[compared[k]].spec.is_naive_baseline())
            // The variant named naive_forward first, then any plain naive one.
            .min_by_key(|&k| cells[compared[k]].spec.variant != "naive_forward");
        if let Some(n) = naive {
            for (k, &i) in compared.iter().enumerate() {
                if let Some(p) = paired(n, k) {
                    derived[i].speedup = Some(round3(p.ratio));
                    derived[i].speedup_interval = p.interval.map(|r| [round3(r.lo), round3(r.hi)]);
                    derived[i].speedup_least = Some((round3(p.range[0]), p.rounds));
                }
            }
        }
        // The front, by fidelity (`measure::front`).
        let error = |k: usize| cells[compared[k]].fidelity_rmse();
        let verdict = |j: usize, k: usize| paired(j, k).map_or(Verdict::Undecided, |p| p.verdict);
        for (k, &i) in compared.iter().enumerate() {
            derived[i].front = crate::measure::front(k, compared.len(), error, verdict);
        }
    }
    for (i, c) in cells.iter_mut().enumerate() {
        let d = &derived[i];
        c.speedup_vs_naive = d.speedup;
        c.speedup_interval = d.speedup_interval;
        c.speedup_least = d.speedup_least;
        c.front = d.front;
        c.rank = d.rank;
        c.against_leader = d.against_leader;
        c.vs_baseline = baseline.and_then(|b| {
            let old = b
                .cells
                .iter()
                .find(|o| baseline::key(o) == baseline::key(c))?;
            let (t_new, t_old) = (c.total_ms()?, old.total_ms()?);
            let (e_new, e_old) = (c.error.as_ref()?, old.error.as_ref()?);
            Some(BaselineChange {
                time_ratio: round3(t_new / t_old.max(1e-9)),
                max_abs_8bit_change: e_new.max_abs_8bit as i64 - e_old.max_abs_8bit as i64,
                rmse_8bit_change: e_new.rmse_8bit - e_old.rmse_8bit,
            })
        });
    }
}

/// What `derive` works out for one cell.
#[derive(Clone, Default)]
struct Derived {
    speedup: Option<f64>,
    speedup_interval: Option<[f64; 2]>,
    speedup_least: Option<(f64, usize)>,
    front: Option<Front>,
    rank: Option<Rank>,
    against_leader: Option<AgainstLeader>,
}

/// Combine result folders into one: cells by id (a later folder's cell replaces an earlier
/// one's), images copied into `out`, provenance of every run kept. Folders from different
/// adapters, or whose runs read different variant files under one name, are refused unless
/// `allow_mixed`: their times (and perhaps images) are not comparable.
pub fn merge(
    dirs: &[PathBuf],
    out: &Path,
    allow_mixed: bool,
    prefer: Option<Prefer>,
) -> Result<Results, String> {
    for (i, a) in dirs.iter().enumerate() {
        for b in &dirs[i + 1..] {
            let same = match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
                (Ok(x), Ok(y)) => x == y,
                _ => a == b,
            };
            if same {
                return Err(format!(
                    "{} and {} are the same folder: merging a run with itself would count its cells twice",
                    a.display(),
                    b.display()
                ));
            }
        }
    }
    let loaded: Vec<(&PathBuf, Results)> = dirs
        .iter()
        .map(|d| Results::load(d).map(|r| (d, r)))
        .collect::<Result<_, _>>()?;
    if !allow_mixed {
        check_comparable(&loaded)?;
    }
    if prefer.is_none() {
        check_disjoint(&loaded)?;
    }
    // With --prefer first, the first folder's copy of a cell wins: merge in reverse.
    let loaded: Vec<(&PathBuf, Results)> = match prefer {
        Some(Prefer::First) => loaded.into_iter().rev().collect(),
        _ => loaded,
    };
    let mut merged = Results {
        provenance: Vec::new(),
        cells: Vec::new(),
        reused: Vec::new(),
    };
    crate::files::write::create_folder(&out.join("images"))?;
    crate::files::write::create_folder(&out.join("plots"))?;
    for (dir, r) in loaded {
        let runs_before = merged.provenance.len();
        merged.provenance.extend(r.provenance);
        for mut cell in r.cells {
            cell.run += runs_before;
            copy_images(dir, &cell, out)?;
            merged.cells.retain(|c| c.spec.id != cell.spec.id);
            merged.cells.push(cell);
        }
    }
    derive(&mut merged.cells, None);
    Ok(merged)
}

/// Copy every image of `cell` in result folder `dir` into `out`.
fn copy_images(dir: &Path, cell: &CellRecord, out: &Path) -> Result<(), String> {
    let i = &cell.images;
    for file in [&i.image, &i.heat, &i.debug, &i.animation, &i.frames_plot]
        .into_iter()
        .flatten()
    {
        copy_image(dir, file, out).map_err(|e| format!("cell `{}`: {e}", cell.spec.id))?;
    }
    Ok(())
}

/// Copy image `file` (`images/NAME.png`, a sequence's `images/NAME.gif` or
/// `plots/NAME.svg`, checked when its results were read) of result folder `dir` into `out`:
/// a regular file inside `dir`, never a link out of it.
fn copy_image(dir: &Path, file: &str, out: &Path) -> Result<(), String> {
    let from = crate::files::inside(dir, Path::new(file), "image path")?;
    match std::fs::symlink_metadata(&from) {
        Ok(meta) if meta.file_type().is_file() => {}
        Ok(meta) => {
            return Err(format!(
                "{} is {}: a result folder's images are regular files inside it",
                from.display(),
                crate::files::write::what_is(&meta)
            ));
        }
        Err(e) => {
            return Err(format!(
                "{}: {}",
                from.display(),
                crate::files::describe(&e)
            ));
        }
    }
    let bytes =
        crate::files::read(&from, crate::files::read::RESULT_IMAGE).map_err(|e| e.to_string())?;
    crate::files::write_file(&out.join(file), &bytes)
}

/// Which copy of a cell `merge` keeps when folders overlap.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Prefer {
    /// The copy from the folder named first.
    First,
    /// The copy from the folder named last.
    Last,
}

/// Refuse folders that hold the same cell: shards of one study do not overlap.
fn check_disjoint(loaded: &[(&PathBuf, Results)]) -> Result<(), String> {
    let mut seen: std::collections::HashMap<&str, &PathBuf> = std::collections::HashMap::new();
    for (dir, r) in loaded {
        for cell in &r.cells {
            if let Some(first) = seen.insert(&cell.spec.id, dir) {
                return Err(format!(
                    "cell `{}` is in both {} and {}: shards of one study do not overlap; pass --prefer first or --prefer last to keep one copy",
                    cell.spec.id,
                    first.display(),
                    dir.display()
                ));
            }
        }
    }
    Ok(())
}

/// Refuse folders whose runs used different adapters, or different files for one variant.
fn check_comparable(loaded: &[(&PathBuf, Results)]) -> Result<(), String> {
    let runs: Vec<(&PathBuf, &Provenance)> = loaded
        .iter()
        .flat_map(|(dir, r)| r.provenance.iter().map(move |p| (*dir, p)))
        .collect();
    let Some(&(first_dir, first)) = runs.first() else {
        return Ok(());
    };
    let adapter = |p: &Provenance| {
        format!(
            "{} ({}, {})",
            p.adapter.name, p.adapter.backend, p.adapter.driver
        )
    };
    for &(dir, p) in &runs[1..] {
        if p.adapter != first.adapter {
            return Err(format!(
                "{} ran on {}, but {} ran on {}: times from different adapters are not \
                 comparable. Merge folders from one adapter, or pass --allow-mixed to merge \
                 them anyway",
                dir.display(),
                adapter(p),
                first_dir.display(),
                adapter(first)
            ));
        }
    }
    let mut seen: BTreeMap<&str, (&PathBuf, &VariantFile)> = BTreeMap::new();
    for &(dir, p) in &runs {
        for (name, file) in &p.variant_files {
            match seen.get(name.as_str()) {
                Some((other_dir, other)) if other.sha256 != file.sha256 => {
                    return Err(format!(
                        "variant `{name}` differs: {} ran {} (SHA-256 {}), {} ran {} (SHA-256 \
                         {}). Rerun the stale shard with the same variant files, or pass \
                         --allow-mixed to merge them anyway",
                        other_dir.display(),
                        other.path.display(),
                        &other.sha256[..12.min(other.sha256.len())],
                        dir.display(),
                        file.path.display(),
                        &file.sha256[..12.min(file.sha256.len())],
                    ));
                }
                Some(_) => {}
                None => {
                    seen.insert(name, (dir, file));
                }
            }
        }
    }
    Ok(())
}

/// The SHA-256 of each variant file the cells read, by variant name.
pub fn variant_files(cells: &[PlannedCell]) -> BTreeMap<String, VariantFile> {
    let mut files = BTreeMap::new();
    for c in cells {
        if let Ok(text) = crate::files::read(&c.spec.variant_path, crate::files::read::VARIANT) {
            files
                .entry(c.spec.variant.clone())
                .or_insert_with(|| VariantFile {
                    path: c.spec.variant_path.clone(),
                    sha256: format!("{:x}", Sha256::digest(&text)),
                });
        }
    }
    files
}

fn provenance(gpu: &Gpu, composer: &Composer, options: &MatrixOptions) -> Provenance {
    Provenance {
        tool: format!("clusterlab {}", env!("CARGO_PKG_VERSION")),
        date: humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string(),
        // The revision the binary was built from (`build.rs`), wherever it runs.
        git_revision: env!("CLUSTERLAB_GIT_REVISION").into(),
        git_dirty: env!("CLUSTERLAB_GIT_DIRTY") == "true",
        shaders: composer
            .shader_tree()
            .unwrap_or_else(|e| crate::compose::ShaderTree {
                sha256: format!("unreadable: {e}"),
                ..Default::default()
            }),
        environment: crate::environment::recorded(),
        perturbed_depth_ulps: crate::compose::perturbed_depth_ulps(),
        adapter: gpu.adapter.clone(),
        hdr_format: format!("{:?}", gpu.hdr_format).to_lowercase(),
        timing_source: if gpu.timestamps {
            "gpu timestamps"
        } else {
            "wall clock"
        }
        .into(),
        command: options.command.clone(),
        frames: match options.frames {
            Frames::Exact { warmup, timed } => {
                format!("exact: {warmup} untimed then {timed} timed per cell")
            }
            Frames::Budget(b) => format!(
                "by budget, a group's cells in interleaved rounds: a frame without lights (untimed), then rounds until the cell's verdict against the leader is decided (round by round, 95%, a tie within {}%), {} ms of frames are spent (the untimed ones included), or {} frames",
                crate::measure::TIE_WITHIN * 100.0,
                b.budget_ms,
                b.max_frames
            ),
        },
        cost: None,
        software_gpu_threads: crate::gpu::software_gpu_threads(),
        shard: options.shard.map(|(k, n)| format!("{k}/{n}")),
        variant_files: options.variant_files.clone(),
        scenes: SCENES
            .iter()
            .map(|s| (s.name.to_string(), s.defaults.into()))
            .collect(),
    }
}

fn round3(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}
