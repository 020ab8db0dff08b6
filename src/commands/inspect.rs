//! `validate`, `wgsl`, `scenes` and `adapters`: what a variant, a scene or the machine is.

use clusterlab::compose::{Composer, passes};
use clusterlab::variant;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub(crate) fn validate(paths: &[PathBuf], json: bool) -> Result<bool, String> {
    let composer = Composer::default();
    let (mut ok, mut failed) = (0, 0);
    let mut records = Vec::new();
    for path in paths {
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

pub(crate) fn wgsl(arg: &str, only: Option<&str>) -> Result<bool, String> {
    let loaded = variant::load(&variant::locate(arg)?).map_err(|e| e.to_string())?;
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

pub(crate) fn scenes() {
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
}

pub(crate) fn export_scene(
    name: &str,
    file: &Path,
    lights: Option<u32>,
    seed: Option<u64>,
    spots: Option<f32>,
) -> Result<bool, String> {
    let info = clusterlab::scene::find_scene(name)
        .ok_or_else(|| clusterlab::scene::SceneError::Unknown(name.to_string()).to_string())?;
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

pub(crate) fn adapters(json: bool, backend: Option<&str>) -> Result<bool, String> {
    let survey = clusterlab::gpu::adapters::survey(backend);
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&survey).map_err(|e| e.to_string())?
        );
    } else {
        print!("{}", survey.text());
    }
    Ok(survey.chosen.is_some())
}
