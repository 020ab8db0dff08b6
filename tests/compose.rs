//! Composition: every pass of every variant in variants/ (and of the default matrix's MSAA
//! group at 4 samples) composes and validates, and its WGSL matches the reviewed snapshot
//! (`clusterlab snapshot` writes them for review); bad input gives the reviewed error text.

use std::path::Path;

use clusterlab::compose::{Composer, feature_flags, passes};
use clusterlab::snapshot::shaders;
use clusterlab::variant;

fn snapshot_settings(folder: &str) -> insta::Settings {
    let mut settings = insta::Settings::clone_current();
    settings.set_snapshot_path(Path::new("../snapshots").join(folder));
    settings.set_prepend_module_to_snapshot(false);
    settings
}

/// One snapshot per distinct composed shader (`snapshot::shaders`), for every pass of every
/// variant in variants/ and the default matrix's MSAA group at 4 samples; the index of which
/// variants compose each is what `clusterlab snapshot` generates, and no snapshot is left
/// that no shader produces.
#[test]
fn composed_wgsl_of_every_distinct_pass() {
    let files = variant::find_files(Path::new("variants")).expect("variants/");
    let variants: Vec<variant::LoadedVariant> = files
        .iter()
        .map(|path| variant::load(path).unwrap_or_else(|e| panic!("{e}")))
        .collect();
    let composed = shaders::distinct(&Composer::default(), &shaders::with_multisampled(&variants))
        .unwrap_or_else(|e| panic!("{e}"));
    let mut names: Vec<String> = Vec::new();
    for shader in &composed {
        let name = shader.name();
        let mut settings = snapshot_settings("wgsl");
        settings.set_description(format!("pass `{}`", shader.pass));
        settings.bind(|| insta::assert_snapshot!(name.clone(), &shader.wgsl));
        let file_name = format!("{name}.snap");
        assert!(
            !names.contains(&file_name),
            "two shaders of pass `{}` hash alike: lengthen `Shader::name`'s hash",
            shader.pass
        );
        names.push(file_name);
    }
    let index = shaders::index(&composed);
    let path = Path::new("snapshots/wgsl").join(shaders::INDEX);
    assert!(
        std::fs::read_to_string(&path).is_ok_and(|t| t.replace("\r\n", "\n") == index),
        "{} does not list the variants composing each shader: run `clusterlab snapshot`",
        path.display()
    );
    // No snapshot is left that no shader produces.
    let stale: Vec<String> = std::fs::read_dir("snapshots/wgsl")
        .expect("snapshots/wgsl")
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|f| f.ends_with(".snap") && !names.contains(f))
        .collect();
    assert!(
        stale.is_empty(),
        "snapshots of no composed shader (delete them): {stale:?}"
    );
}

#[test]
fn bad_variant_files_give_located_errors() {
    snapshot_settings("errors").bind(|| {
        insta::glob!("bad_variants", "*.ron", |path| {
            let relative = path
                .strip_prefix(env!("CARGO_MANIFEST_DIR"))
                .unwrap_or(path);
            let error = variant::load(relative).expect_err("a bad variant must be rejected");
            insta::assert_snapshot!("variant_error", error.to_string());
        });
    });
}

#[test]
fn shader_errors_name_the_module_file_line_and_column() {
    let composer = Composer::new(Path::new("tests/bad_shaders"));
    let v = variant::Variant::default();
    let features = feature_flags(&v);
    snapshot_settings("errors").bind(|| {
        for root in ["type_error", "syntax_error", "missing_import"] {
            let error = composer
                .compose_root(
                    root,
                    &format!("passes::{root}"),
                    &features,
                    "",
                    Default::default(),
                )
                .expect_err("a broken shader must be rejected");
            insta::assert_snapshot!(format!("shader_{root}"), error.to_string());
        }
    });
}

/// A feature that is off leaves no trace: Lambert has no Blinn-Phong code in its WGSL.
#[test]
fn switched_off_features_leave_no_trace() {
    let composer = Composer::default();
    let lambert = variant::Variant {
        description: "lambert".into(),
        ..Default::default()
    };
    let mut blinn = lambert.clone();
    blinn.shading.model = variant::ShadingModel::BlinnPhong {
        shininess: 16.0,
        specular: 0.5,
    };
    let forward = passes(&lambert)
        .into_iter()
        .find(|p| p.name() == "forward")
        .expect("a forward pass");
    let lambert_wgsl = composer.compose(&lambert, &forward).unwrap().wgsl;
    let blinn_wgsl = composer.compose(&blinn, &forward).unwrap().wgsl;
    for trace in ["blinn_phong", "SHININESS", "SPECULAR", "pow("] {
        assert!(!lambert_wgsl.contains(trace), "`{trace}` in Lambert WGSL");
        assert!(
            blinn_wgsl.contains(trace),
            "`{trace}` missing from Blinn-Phong WGSL"
        );
    }
}

/// Every pass of every variant also composes and validates for a scene with textures (and
/// for one without spots), the shaders a file scene's frames use; with textures the raster
/// passes bind the texture array and its sampler, without them they bind neither.
#[test]
fn every_pass_composes_for_scenes_with_textures() {
    let composer = Composer::default();
    let files = variant::find_files(Path::new("variants")).expect("variants/");
    for file in files {
        let v = variant::load(&file).unwrap_or_else(|e| panic!("{e}"));
        for pass in passes(&v.variant) {
            for spots in [true, false] {
                let overrides = [("base_color_texture", true), ("spot_lights", spots)];
                let composed = composer
                    .compose_with(&v.variant, &pass, &overrides)
                    .unwrap_or_else(|e| panic!("{} {}: {e}", v.name, pass.name()));
                let plain = composer.compose(&v.variant, &pass).unwrap();
                let samples = composed.wgsl.contains("textureSample(");
                assert_eq!(
                    samples,
                    ["forward", "gbuffer", "still_shading"].contains(&pass.name()),
                    "{} {}",
                    v.name,
                    pass.name()
                );
                assert!(
                    !plain.wgsl.contains("base_color_textures"),
                    "{} {}",
                    v.name,
                    pass.name()
                );
            }
        }
    }
}

/// A light loop is a unit: each way of walking a pixel's lights is its own file, chosen in
/// Rust (`LightLoop`), not by guards on `fn shade` that must exclude each other; what the
/// units share stays small. The deliberate break: a `shade` back in the shared module, or a
/// unit file no loop names.
#[test]
fn light_loops_are_units() {
    use clusterlab::compose::LightLoop;
    let root = Composer::default().shader_root().join("shading");
    let shared = std::fs::read_to_string(root.join("light_loop.wesl")).unwrap();
    let lines = shared.lines().count();
    assert!(
        lines <= 150,
        "light_loop.wesl has {lines} lines, at most 150"
    );
    assert!(
        !shared.contains("fn shade"),
        "a `shade` in the shared module"
    );
    // The units' own helpers: the counters and the reservoir RIS and ReSTIR share.
    let helpers = LightLoop::HELPERS;
    let mut files: Vec<String> = std::fs::read_dir(root.join("light_loop"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    for file in &files {
        let stem = file.trim_end_matches(".wesl");
        let named = LightLoop::ALL.iter().any(|l| l.file() == stem);
        assert!(
            named || helpers.contains(&stem),
            "shading/light_loop/{file}: no light loop names it"
        );
        let text = std::fs::read_to_string(root.join("light_loop").join(file)).unwrap();
        let guarded = text
            .lines()
            .collect::<Vec<_>>()
            .windows(2)
            .any(|w| w[0].trim_start().starts_with("@if") && w[1].starts_with("fn shade("));
        assert!(!guarded, "{file}: a guard chooses its `shade`");
    }
    for l in LightLoop::ALL {
        assert!(
            files.contains(&format!("{}.wesl", l.file())),
            "{l:?}: no shading/light_loop/{}.wesl",
            l.file()
        );
    }
}
