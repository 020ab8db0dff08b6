//! `render` and `view`: one variant on one scene, measured, or in a window.

use crate::{RenderArgs, ViewArgs};
use clusterlab::compose::Composer;
use clusterlab::measure::Frames;
use clusterlab::variant;
use std::path::{Path, PathBuf};

pub(crate) fn view(args: &ViewArgs) -> Result<bool, String> {
    clusterlab::files::write::check_folder(&args.out, "--out")?;
    // Said before anything slow: without a display there is nothing to wait for.
    if let Some(why) = clusterlab::view::missing_display() {
        return Err(why);
    }
    let given: Vec<PathBuf> = args
        .variant
        .iter()
        .map(|v| variant::locate(v))
        .collect::<Result<_, _>>()?;
    let mut variants = variant::find_files(Path::new(variant::FOLDER)).unwrap_or_default();
    for v in &given {
        if !variants.contains(v) {
            variants.push(v.clone());
        }
    }
    let first = given
        .first()
        .cloned()
        .map_or_else(|| variant::locate("forward_plus"), Ok)?;
    let params = args.options.params(&args.scene)?;
    let gpu = args.gpu.open()?;
    clusterlab::view::run(
        clusterlab::view::ViewOptions {
            variant: first,
            variants,
            scene: args.scene.clone(),
            params,
            camera: args.camera,
            out: args.out.clone(),
            script: args.script.clone(),
        },
        &gpu,
    )
}

pub(crate) fn render(args: &RenderArgs) -> Result<bool, String> {
    clusterlab::files::write::check_folder(&args.out, "--out")?;
    let mut loaded = args.cell.variant()?;
    if let Some(view) = args.debug_view {
        loaded.variant.debug_view = view;
        let problems = variant::check(&loaded.variant);
        if let Some(p) = problems.first() {
            return Err(format!("--debug-view: {} {}", p.field, p.message));
        }
        loaded.name = format!("{}+{}", loaded.name, view.name());
    }
    if let Some(n) = args.samples {
        loaded.variant.msaa.samples = n;
        let problems = variant::check(&loaded.variant);
        if let Some(p) = problems.first() {
            return Err(format!("--samples: {} {}", p.field, p.message));
        }
    }
    let params = args.cell.params()?;
    let scene = &args.cell.scene;
    let gpu = args.gpu.open()?;
    let failed =
        |e: &dyn std::fmt::Display| format!("variant `{}` on scene `{scene}`: {e}", loaded.name);
    gpu.check_size(params.width, params.height)
        .map_err(|e| failed(&e))?;
    let mut made = clusterlab::scene::generate(scene, params).map_err(|e| failed(&e))?;
    if let Some(pose) = args.camera {
        made.place_camera(pose)
            .map_err(|e| format!("--camera {}: {e}", pose.argument()))?;
    }
    gpu.begin_cell();
    let cell = clusterlab::run::run_scene(
        &gpu,
        &Composer::default(),
        &loaded,
        &made,
        clusterlab::run::CellOptions {
            frames: Frames::exact(args.warmup, args.frames),
            stats: !args.no_stats,
            out: Some(&args.out),
            references: None,
            debug_view: None,
        },
    )
    .map_err(|e| format!("variant `{}` on scene `{scene}`: {e}", loaded.name))?;
    let r = &cell.report;
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(r).map_err(|e| e.to_string())?
        );
    } else {
        println!(
            "{} on {} ({}x{}, {} lights) with {} ({}, {})",
            r.variant,
            r.scene,
            r.size[0],
            r.size[1],
            r.lights,
            r.adapter.name,
            r.adapter.backend,
            r.adapter.driver
        );
        if let Some(file) = &r.scene_file {
            println!("  scene file: {} (sha256 {})", file.path, file.sha256);
        }
        for note in &r.scene_notes {
            println!("  note: {note}");
        }
        println!("  timing: {}", r.timing_source);
        println!("  {}", clusterlab::compose::shaders_line());
        // The result columns, as the matrix table and CSV have them.
        let m = r.measured();
        for col in clusterlab::matrix::COLUMNS {
            let text = (col.text)(&m);
            if !text.is_empty() && text != "-" && (col.shown.terminal || col.shown.csv) {
                println!("  {:<17} {text}", col.heading);
            }
        }
        for image in &r.images {
            println!("  wrote {}", image.display());
        }
    }
    if let Some(why) = &r.failure {
        eprintln!(
            "FAILED: variant `{}` on scene `{scene}`: {why}",
            loaded.name
        );
        return Ok(false);
    }
    Ok(true)
}
