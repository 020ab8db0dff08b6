//! `validate`, `wgsl`, `scenes` and `adapters`: what a variant, a scene or the machine is.

use clusterlab::compose::{Composer, passes};
use clusterlab::variant;
use std::path::{Path, PathBuf};
use std::time::Instant;

use super::args::parse_fraction;

/// `validate`: which variants, and how to print.
#[derive(clap::Args)]
pub(crate) struct ValidateArgs {
    /// Variant files or folders of them.
    #[arg(default_value = "variants")]
    pub paths: Vec<PathBuf>,
    /// Print one JSON object: each variant's passes, error, and needs of a device's
    /// limits (bindings per stage, bind groups, workgroup storage and size, colour
    /// attachment bytes) beside WebGPU's and wgpu's downlevel defaults.
    #[arg(long)]
    pub json: bool,
}

/// `wgsl`: a variant and perhaps one pass.
#[derive(clap::Args)]
pub(crate) struct WgslArgs {
    /// A variant file, or the name of one in variants/.
    pub variant: String,
    /// Only this pass (see the pass names in the output without it).
    #[arg(long)]
    pub pass: Option<String>,
    /// Print the frame instead: every pass in order, what it reads, writes and renders
    /// into, and what it dispatches or draws (on a scene with blended materials, with the
    /// passes only counting frames run).
    #[arg(long, conflicts_with = "pass")]
    pub frame: bool,
}

/// `scenes`: list them, or write one as glTF.
#[derive(clap::Args)]
pub(crate) struct ScenesArgs {
    /// Write built-in scene NAME (meshes, materials, lights, camera and its motion) to
    /// FILE as binary glTF (.glb); `--scene FILE` then loads it.
    #[arg(long, num_args = 2, value_names = ["NAME", "FILE"])]
    pub export: Option<Vec<String>>,
    /// With --export: number of lights (default: the scene's).
    #[arg(long, requires = "export")]
    pub lights: Option<u32>,
    /// With --export: seed of the scene generator.
    #[arg(long, requires = "export")]
    pub seed: Option<u64>,
    /// With --export: fraction of the lights that are spots, in 0..=1.
    #[arg(long, requires = "export", value_parser = parse_fraction)]
    pub spots: Option<f32>,
}

/// `adapters`: how to print, and which backend to choose for.
#[derive(clap::Args)]
pub(crate) struct AdaptersArgs {
    /// Print one JSON object instead.
    #[arg(long)]
    pub json: bool,
    /// Show the choice for this backend (vulkan, gl, ...), as `--backend` would make it.
    #[arg(long)]
    pub backend: Option<String>,
}

pub(crate) fn validate(args: &ValidateArgs) -> Result<bool, String> {
    let json = args.json;
    let composer = Composer::default();
    let (mut ok, mut failed) = (0, 0);
    let mut records = Vec::new();
    for path in &args.paths {
        let path = &variant::locate(&path.to_string_lossy())?;
        let files = variant::find_files(path)?;
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
                    let needs = clusterlab::render::variant_needs(&composer, &v.variant)
                        .map_err(|e| e.to_string())?;
                    Ok((v, composed.len(), needs))
                });
            let ms = start.elapsed().as_secs_f64() * 1e3;
            match outcome {
                Ok((v, n, needs)) => {
                    ok += 1;
                    if json {
                        records.push(validated_json(&file, &v.name, n, &needs));
                    } else {
                        println!(
                            "ok    {:<32} {n} passes, {ms:5.1} ms  {}",
                            v.name, v.variant.description
                        );
                    }
                }
                Err(message) => {
                    failed += 1;
                    if json {
                        records.push(serde_json::json!({
                            "file": file.display().to_string(),
                            "ok": false,
                            "error": message,
                        }));
                    } else {
                        println!("FAIL  {}", file.display());
                        for line in message.lines() {
                            println!("      {line}");
                        }
                    }
                }
            }
        }
    }
    if json {
        let out = serde_json::json!({ "variants": records, "ok": ok, "failed": failed });
        println!(
            "{}",
            serde_json::to_string_pretty(&out).map_err(|e| e.to_string())?
        );
    } else {
        println!("{} variants: {ok} ok, {failed} failed", ok + failed);
    }
    Ok(failed == 0)
}

/// A variant's `validate --json` record: its needs, and the limits of WebGPU's and wgpu's
/// downlevel defaults it exceeds (the largest binding, which grows with the scene, is
/// checked per frame).
fn validated_json(
    file: &Path,
    name: &str,
    passes: usize,
    needs: &clusterlab::render::needs::Needs,
) -> serde_json::Value {
    let over = |limits: wgpu::Limits| -> Vec<serde_json::Value> {
        needs
            .against(&limits)
            .into_iter()
            .filter(|(_, need, allowed)| need.value > *allowed)
            .map(|(limit, need, allowed)| {
                serde_json::json!({ "limit": limit, "need": need.value, "pass": need.pass, "allowed": allowed })
            })
            .collect()
    };
    serde_json::json!({
        "file": file.display().to_string(),
        "name": name,
        "ok": true,
        "passes": passes,
        "needs": needs,
        "exceeds": {
            "webgpu": over(wgpu::Limits::defaults()),
            "downlevel": over(wgpu::Limits::downlevel_defaults()),
        },
    })
}

pub(crate) fn wgsl(args: &WgslArgs) -> Result<bool, String> {
    let only = args.pass.as_deref();
    let loaded = variant::load(&variant::locate(&args.variant)?).map_err(|e| e.to_string())?;
    if args.frame {
        let frame = clusterlab::render::frame_of(&Composer::default(), &loaded.variant)
            .map_err(|e| e.to_string())?;
        println!("frame of variant `{}`:", loaded.name);
        print!("{frame}");
        return Ok(true);
    }
    let all = passes(&loaded.variant);
    let selected: Vec<_> = all
        .iter()
        .filter(|p| only.is_none_or(|o| o == p.name()))
        .collect();
    if selected.is_empty() {
        let names: Vec<&str> = all.iter().map(|p| p.name()).collect();
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
            loaded.name,
            pass.name()
        );
        println!("{}", composed.wgsl);
    }
    Ok(true)
}

pub(crate) fn scenes(args: &ScenesArgs) -> Result<bool, String> {
    if let Some(export) = &args.export {
        return export_scene(
            &export[0],
            Path::new(&export[1]),
            args.lights,
            args.seed,
            args.spots,
        );
    }
    for s in clusterlab::scene::SCENES {
        let d = &s.defaults;
        println!("{:<10} {}", s.name, s.description);
        println!(
            "           default: {}x{}, {} lights (spot fraction {}), radius {}..{}, seed {}, time {}",
            d.width,
            d.height,
            d.lights,
            d.spots,
            d.radius_range.0,
            d.radius_range.1,
            d.seed,
            d.time
        );
    }
    println!(
        "\nAny glTF 2.0 file is a scene too: --scene FILE.gltf or FILE.glb (its meshes, materials,\nlights and first camera; see README). `clusterlab scenes --export NAME FILE.glb` writes a\nbuilt-in scene as glTF."
    );
    Ok(true)
}

fn export_scene(
    name: &str,
    file: &Path,
    lights: Option<u32>,
    seed: Option<u64>,
    spots: Option<f32>,
) -> Result<bool, String> {
    let info = clusterlab::scene::find_scene(name)
        .ok_or_else(|| clusterlab::scene::unknown(name).to_string())?;
    let mut params = info.defaults;
    params.lights = lights.unwrap_or(params.lights);
    params.seed = seed.unwrap_or(params.seed);
    params.spots = spots.unwrap_or(params.spots);
    let scene = clusterlab::scene::generate(name, params).map_err(|e| e.to_string())?;
    let bytes = clusterlab::scene::export::to_glb(&scene).map_err(|e| format!("{name}: {e}"))?;
    if let Some(dir) = file.parent().filter(|d| !d.as_os_str().is_empty()) {
        clusterlab::files::write::create_folder(dir)?;
    }
    clusterlab::files::write_file(file, &bytes)?;
    println!(
        "wrote {} ({} triangles, {} lights, {} bytes)",
        file.display(),
        scene.indices.len() / 3,
        scene.lights.len(),
        bytes.len()
    );
    Ok(true)
}

pub(crate) fn adapters(args: &AdaptersArgs) -> Result<bool, String> {
    let survey = clusterlab::gpu::adapters::survey(args.backend.as_deref());
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&survey).map_err(|e| e.to_string())?
        );
    } else {
        print!("{}", survey.text());
    }
    Ok(survey.chosen.is_some())
}
