//! `stress`: the adversarial cases, on their own variants or the user's.

use std::time::Instant;

use super::args::GpuArgs;
use clusterlab::compose::Composer;
use clusterlab::stress::{self, Progress, Subjects};

/// `stress` as given on the command line.
#[derive(clap::Args)]
pub(crate) struct StressCommand {
    /// Only the cases whose name contains this (as --cases).
    pub filter: Option<String>,
    /// Only the cases whose name contains this.
    #[arg(long, conflicts_with = "filter")]
    pub cases: Option<String>,
    /// Variant files, folders of them, or names in variants/: every case that applies
    /// runs on these (with what the case sets: a grid, a slicing, a depth mapping, a
    /// sample count) instead of its own variants; one that cannot apply says why.
    #[arg(long, num_args = 1..)]
    pub variants: Vec<String>,
    /// List the cases, and with --variants the runs each makes, then stop.
    #[arg(long)]
    pub list: bool,
    /// Print the runs as JSON.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

pub(crate) fn stress(args: &StressCommand) -> Result<bool, String> {
    let wanted = args.cases.as_deref().or(args.filter.as_deref());
    let cases = stress::selected(wanted);
    if cases.is_empty() {
        return Err(format!(
            "no stress case matches `{}`; `clusterlab stress --list` lists them",
            wanted.unwrap_or_default()
        ));
    }
    let given = if args.variants.is_empty() {
        Vec::new()
    } else {
        clusterlab::variant::load_args(&args.variants)?
    };
    if args.list {
        print!("{}", list(&cases, &given));
        return Ok(true);
    }
    let mut gpu = args.gpu.open()?;
    eprintln!(
        "stress suite on {} ({}, {}); {}",
        gpu.adapter.name,
        gpu.adapter.backend,
        gpu.adapter.driver,
        clusterlab::compose::shaders_line()
    );
    let subjects = if given.is_empty() {
        Subjects::BuiltIn
    } else {
        Subjects::Given(&given)
    };
    let started = Instant::now();
    let mut case_count = 0;
    let runs = stress::run(
        &mut gpu,
        &Composer::default(),
        &cases,
        subjects,
        &mut |p| match p {
            Progress::Starting(_) => {}
            Progress::Note(note) => eprintln!("{note}"),
            Progress::CaseDone {
                case,
                runs,
                done,
                total,
            } => {
                case_count += 1;
                eprintln!(
                    "[{case_count}/{}] {case}: {}; {done}/{total} runs, {}",
                    cases.len(),
                    summary(runs),
                    clusterlab::progress::eta(started.elapsed(), done, total)
                );
            }
        },
    );
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&runs).map_err(|e| e.to_string())?
        );
    } else {
        print!("{}", stress::report(&runs));
    }
    Ok(runs.iter().all(|r| r.ok))
}

/// The cases, what each is, and with `given` variants the run each makes of each or why it
/// does not apply.
fn list(cases: &[stress::Case], given: &[clusterlab::variant::LoadedVariant]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    for case in cases {
        let _ = writeln!(s, "{}: {}", case.name, case.what);
        for v in given {
            for (name, run) in case.runs_of(&v.name, &v.variant) {
                let _ = match run {
                    Ok(_) => writeln!(s, "  runs   {name}"),
                    Err(why) => writeln!(s, "  n/a    {name}: {why}"),
                };
            }
        }
    }
    let _ = writeln!(s, "{} cases", cases.len());
    s
}

/// "ok", "2 failed: a, b" or "not applicable" for a case's runs.
fn summary(runs: &[stress::CaseRun]) -> String {
    let ran: Vec<&stress::CaseRun> = runs.iter().filter(|r| r.not_applicable.is_none()).collect();
    let failed: Vec<&str> = ran
        .iter()
        .filter(|r| !r.ok)
        .map(|r| r.variant.as_str())
        .collect();
    if ran.is_empty() {
        "not applicable".into()
    } else if failed.is_empty() {
        format!(
            "ok ({} run{})",
            ran.len(),
            if ran.len() == 1 { "" } else { "s" }
        )
    } else {
        format!(
            "{} of {} FAILED: {}",
            failed.len(),
            ran.len(),
            failed.join(", ")
        )
    }
}
