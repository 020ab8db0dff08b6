//! The `clusterlab` command line. The library does the work; this file only parses
//! arguments, calls it, and prints.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::{Parser, Subcommand};
use clusterlab::compose::{Composer, passes};
use clusterlab::variant;

#[derive(Parser)]
#[command(
    name = "clusterlab",
    version,
    about = "Measure many-light shading pipelines side by side"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Parse, check, compose and naga-validate every pass of variant files.
    Validate {
        /// Variant files or folders of them.
        #[arg(default_value = "variants")]
        paths: Vec<PathBuf>,
    },
    /// Print the composed WGSL of a variant's passes.
    Wgsl {
        /// A variant file, or the name of one in variants/.
        variant: String,
        /// Only this pass (see the pass names in the output without it).
        #[arg(long)]
        pass: Option<String>,
    },
    /// Explain the variant schema: every field, its meaning, allowed values and default.
    Explain,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Validate { paths } => validate(&paths),
        Command::Wgsl { variant, pass } => wgsl(&variant, pass.as_deref()),
        Command::Explain => {
            print!("{}", clusterlab::explain::explain());
            Ok(true)
        }
    };
    match result {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}

/// A variant argument: a path, or a name in variants/.
fn variant_path(arg: &str) -> PathBuf {
    let path = PathBuf::from(arg);
    if path.exists() {
        return path;
    }
    let in_folder = Path::new("variants").join(format!("{arg}.ron"));
    if in_folder.exists() { in_folder } else { path }
}

fn validate(paths: &[PathBuf]) -> Result<bool, String> {
    let composer = Composer::default();
    let (mut ok, mut failed) = (0, 0);
    for path in paths {
        let files = variant::find_files(path).map_err(|e| e.to_string())?;
        if files.is_empty() {
            return Err(format!("{}: no .ron variant files there", path.display()));
        }
        for file in files {
            let start = Instant::now();
            let outcome = variant::load(&file)
                .map_err(|e| e.to_string())
                .and_then(|v| {
                    let composed = composer
                        .compose_all(&v.variant)
                        .map_err(|e| e.to_string())?;
                    Ok((v, composed.len()))
                });
            let ms = start.elapsed().as_secs_f64() * 1e3;
            match outcome {
                Ok((v, n)) => {
                    ok += 1;
                    println!(
                        "ok    {:<32} {n} passes, {ms:5.1} ms  {}",
                        v.name, v.variant.description
                    );
                }
                Err(message) => {
                    failed += 1;
                    println!("FAIL  {}", file.display());
                    for line in message.lines() {
                        println!("      {line}");
                    }
                }
            }
        }
    }
    println!("{} variants: {ok} ok, {failed} failed", ok + failed);
    Ok(failed == 0)
}

fn wgsl(arg: &str, only: Option<&str>) -> Result<bool, String> {
    let loaded = variant::load(&variant_path(arg)).map_err(|e| e.to_string())?;
    let all = passes(&loaded.variant);
    let selected: Vec<_> = all
        .iter()
        .filter(|p| only.is_none_or(|o| o == p.name))
        .collect();
    if selected.is_empty() {
        let names: Vec<&str> = all.iter().map(|p| p.name).collect();
        return Err(format!(
            "variant `{}` has no pass `{}`; its passes are: {}",
            loaded.name,
            only.unwrap_or_default(),
            names.join(", ")
        ));
    }
    let composer = Composer::default();
    for pass in selected {
        let composed = composer
            .compose(&loaded.variant, pass)
            .map_err(|e| e.to_string())?;
        println!(
            "// ---- variant `{}`, pass `{}` ----",
            loaded.name, pass.name
        );
        println!("{}", composed.wgsl);
    }
    Ok(true)
}
