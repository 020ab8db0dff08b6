//! One list per concept: every z-slicing scheme, normal codec, pipeline and post effect is
//! enumerable in one place (the schema's enums), and each place that must handle all of them
//! does. A test here fails naming what is missing.

use std::path::Path;

use crate::common;
use clusterlab::compose::{Composer, PassId, passes};
use clusterlab::cpu::normals;
use clusterlab::cpu::zslice::Slices;
use clusterlab::kernels::{gpu_codecs, gpu_zslices};
use clusterlab::stress;
use clusterlab::study::{codecs, slicing};
use clusterlab::variant::{
    self, Culling, METHOD_FLAGS, NormalCodec, Pipeline, PostEffect, ZSlicing,
};
use strum::IntoEnumIterator;

const NEAR: f64 = 0.1;
const FAR: f64 = 60.0;

/// The stress case of `name`, if there is one, with the variants it runs.
fn stress_case(name: &str) -> Option<stress::Case> {
    stress::cases().into_iter().find(|c| c.name == name)
}

#[test]
fn every_z_slicing_scheme_has_an_example_a_kernel_check_a_stress_case_and_a_study_row() {
    let gpu = common::gpu();
    let composer = Composer::default();
    let every = ZSlicing::every(NEAR, FAR);
    let study = slicing::schemes(NEAR, FAR);
    let mut missing = Vec::new();
    for kind in ZSlicing::iter() {
        let name = kind.feature();
        let examples: Vec<ZSlicing> = every
            .iter()
            .copied()
            .filter(|s| s.same_scheme(kind))
            .collect();
        if examples.is_empty() {
            missing.push(format!(
                "{name}: no example in ZSlicing::every (property tests, twin checks)"
            ));
            continue;
        }
        for s in examples {
            let case = stress::slicing_case_name(s);
            match stress_case(&case) {
                None => missing.push(format!("{name}: no stress case `{case}`")),
                Some(c) => {
                    let uses =
                        |v: &variant::Variant| v.clusters.as_ref().is_some_and(|c| c.slicing == s);
                    if c.variants.is_empty() || !c.variants.iter().all(|(_, v)| uses(v)) {
                        missing.push(format!("{name}: stress case `{case}` does not run {s:?}"));
                    }
                }
            }
            if !study.iter().any(|(_, row)| *row == s) {
                missing.push(format!("{name}: no row in `study slicing`"));
            }
            // The twin kernel runs the variant's own z_slice: it composes only when
            // zslice.wesl has code for the scheme, and must agree with the CPU twin.
            let slices = Slices {
                scheme: s,
                near: NEAR,
                far: FAR,
                count: 16,
                tan_half_fov_y: 0.5,
                tiles_y: 9,
            };
            let depths = [NEAR as f32, 1.0, 7.5, 30.0, FAR as f32];
            match gpu_zslices(&gpu, &composer, &slices, &depths) {
                Err(e) => missing.push(format!("{name}: no twin kernel check: {e}")),
                Ok(r) => {
                    let cpu: Vec<u32> = depths.iter().map(|&z| slices.slice(z as f64)).collect();
                    if r.slices != cpu {
                        missing.push(format!(
                            "{name}: the GPU slices {:?} are not the CPU twin's {cpu:?}",
                            r.slices
                        ));
                    }
                }
            }
        }
    }
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

#[test]
fn every_normal_codec_has_a_kernel_check_a_stress_run_and_a_study_row() {
    let gpu = common::gpu();
    let composer = Composer::default();
    let packed = NormalCodec::packed(32);
    let options = clusterlab::study::StudyOptions {
        samples: 256,
        ..Default::default()
    };
    let study =
        clusterlab::study::run_points::<codecs::CodecStudy>(&gpu, &composer, &options, &mut |_| {})
            .expect("codec study")
            .rows;
    let runs: Vec<String> = stress_case("normals_on_octahedron_seams")
        .expect("the normal-codec stress case")
        .variants
        .into_iter()
        .map(|(name, _)| name)
        .collect();
    let mut missing = Vec::new();
    for kind in NormalCodec::iter().filter(|c| *c != NormalCodec::Xyz) {
        let name = format!("{kind:?}");
        let codecs: Vec<NormalCodec> = packed
            .iter()
            .copied()
            .filter(|c| std::mem::discriminant(c) == std::mem::discriminant(&kind))
            .collect();
        if codecs.is_empty() {
            missing.push(format!(
                "{name}: not in NormalCodec::packed (property tests, twin checks)"
            ));
        }
        for c in codecs {
            let run = stress::codec_case_name(c);
            if !runs.contains(&run) {
                missing.push(format!("{}: no stress run `{run}`", c.label()));
            }
            if !study.iter().any(|r| r.codec == c.label()) {
                missing.push(format!("{}: no row in `study codecs`", c.label()));
            }
            let n = [0.6f32, 0.0, 0.8, 0.0];
            let unit = glam::DVec3::new(0.6, 0.0, 0.8).normalize();
            let want = normals::encode(c, unit);
            // The precise encoder picks the neighbouring code that decodes closest to the
            // normal: two whose cosines to it differ by less than the f32 rounding of that
            // comparison (a few steps of 2^-24; an NVIDIA H200 chose [46811, 32768] where
            // the twin has [46810, 32767]) are equally right.
            let as_close = |code: [u32; 2]| {
                let cos = |q| normals::decode(c, q).map_or(-1.0, |d| d.normalize().dot(unit));
                want.is_some_and(|w| cos(code) >= cos(w) - 8.0 * 2f64.powi(-24))
            };
            match gpu_codecs(&gpu, &composer, c, &[n], &[[0, 0]]) {
                Err(e) => missing.push(format!("{}: no twin kernel check: {e}", c.label())),
                Ok(r) if Some(r.codes[0]) != want && !as_close(r.codes[0]) => {
                    missing.push(format!(
                        "{}: GPU code {:?}, CPU twin {want:?}",
                        c.label(),
                        r.codes[0]
                    ))
                }
                Ok(_) => {}
            }
        }
    }
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

/// Every variant in variants/.
fn shipped() -> Vec<variant::LoadedVariant> {
    variant::find_files(Path::new("variants"))
        .expect("variants/")
        .iter()
        .map(|f| variant::load(f).unwrap_or_else(|e| panic!("{e}")))
        .collect()
}

#[test]
fn every_pipeline_has_a_stress_run_and_a_shipped_variant() {
    let runs: Vec<String> = stress_case("one_light")
        .expect("the one-light stress case")
        .variants
        .into_iter()
        .map(|(name, _)| name)
        .collect();
    let shipped = shipped();
    let mut missing = Vec::new();
    for p in Pipeline::iter() {
        if !runs.iter().any(|r| r == p.short_name()) {
            missing.push(format!("{p:?}: no stress run `{}`", p.short_name()));
        }
        if !shipped.iter().any(|v| v.variant.pipeline == p) {
            missing.push(format!("{p:?}: no variant file in variants/"));
        }
    }
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

#[test]
fn every_post_effect_has_a_shipped_variant_whose_frame_runs_it() {
    let shipped = shipped();
    let mut missing = Vec::new();
    for effect in PostEffect::iter() {
        let with: Vec<_> = shipped
            .iter()
            .filter(|v| v.variant.post.effects().any(|e| e == effect))
            .collect();
        if with.is_empty() {
            missing.push(format!("{effect:?}: no variant file in variants/"));
        }
        // Toon per light shades in the shading pass; every other variant with an effect
        // has a post pass for it.
        let post_passes = |v: &variant::Variant| {
            passes(v)
                .iter()
                .filter(|p| matches!(p.id, PassId::Post(_)))
                .count()
        };
        if !with.iter().any(|v| post_passes(&v.variant) > 0) {
            missing.push(format!(
                "{effect:?}: no shipped variant runs a post pass for it"
            ));
        }
    }
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

#[test]
fn every_spot_test_has_stress_runs_a_shipped_variant_and_a_study() {
    let spot_cases: Vec<stress::Case> = stress::cases()
        .into_iter()
        .filter(|c| c.scene.lights.iter().any(|l| l.is_spot()))
        .collect();
    let shipped = shipped();
    let mut missing = Vec::new();
    if spot_cases.is_empty() {
        missing.push("no stress case has spot lights".to_string());
    }
    for test in variant::SpotTest::iter() {
        let runs_it =
            |v: &variant::Variant| v.pipeline.is_clustered() && v.clusters().spot_test == test;
        for case in &spot_cases {
            if !case.variants.iter().any(|(_, v)| runs_it(v)) {
                missing.push(format!(
                    "{test:?}: stress case `{}` does not run it",
                    case.name
                ));
            }
        }
        if !shipped.iter().any(|v| runs_it(&v.variant)) {
            missing.push(format!("{test:?}: no shipped variant uses it"));
        }
    }
    // `study cones` iterates SpotTest::iter() itself.
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

/// Every culling choice has a shipped variant, a row in `study culling` and a stress run;
/// every method a shipped variant uses names a flag the features set.
#[test]
fn every_culling_has_a_shipped_variant_a_study_row_and_a_stress_run() {
    let shipped = shipped();
    let culling_of = |v: &variant::Variant| v.pipeline.is_clustered().then(|| v.clusters().culling);
    let study = clusterlab::study::culling::methods();
    let cases = stress::cases();
    let mut missing = Vec::new();
    for culling in Culling::iter() {
        if !shipped
            .iter()
            .any(|v| culling_of(&v.variant) == Some(culling))
        {
            missing.push(format!("{culling:?}: no shipped variant"));
        }
        if !study
            .iter()
            .any(|m| culling_of(&m.variant((640, 360))) == Some(culling))
        {
            missing.push(format!("{culling:?}: no row in `study culling`"));
        }
        if !cases.iter().any(|c| {
            c.variants
                .iter()
                .any(|(_, v)| culling_of(v) == Some(culling))
        }) {
            missing.push(format!("{culling:?}: no stress run"));
        }
    }
    for v in shipped.iter().filter(|v| v.variant.pipeline.is_clustered()) {
        if let Some(flag) = v.variant.clusters().method().flag()
            && !METHOD_FLAGS.contains(&flag)
        {
            missing.push(format!("{}: flag `{flag}` is not in METHOD_FLAGS", v.name));
        }
    }
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

/// Every list strategy has a shipped variant (which the default matrix's sequence group
/// runs), a row in `study temporal` and stress runs on the motion cases.
#[test]
fn every_list_strategy_has_a_shipped_variant_a_study_row_and_a_stress_run() {
    use clusterlab::variant::ListUpdate;
    let shipped = shipped();
    let update_of = |v: &variant::Variant| v.pipeline.is_clustered().then(|| v.clusters().update);
    let study: Vec<Option<ListUpdate>> = clusterlab::study::temporal::VARIANTS
        .iter()
        .map(|(name, _)| update_of(&common::load(name).variant))
        .collect();
    let cases = stress::cases();
    let mut missing = Vec::new();
    for update in ListUpdate::iter() {
        if !shipped
            .iter()
            .any(|v| update_of(&v.variant) == Some(update))
        {
            missing.push(format!("{update:?}: no shipped variant"));
        }
        if !study.contains(&Some(update)) {
            missing.push(format!("{update:?}: no row in `study temporal`"));
        }
        if !cases.iter().any(|c| {
            !c.later.is_empty() && c.variants.iter().any(|(_, v)| update_of(v) == Some(update))
        }) {
            missing.push(format!("{update:?}: no stress run on a motion case"));
        }
    }
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

/// Each kind of sampled light loop (an exhaustive match: a new sampler does not compile
/// until it is named here) has a shipped variant, and every shipped sampled variant is in
/// `study sampling` and in the bias tests.
#[test]
fn every_sampler_has_a_shipped_variant_a_study_row_and_a_bias_test() {
    use clusterlab::variant::Sampler;
    let kind = |s: &Sampler| match s {
        Sampler::Uniform { .. } => "uniform",
        Sampler::Ris { temporal: None, .. } => "RIS",
        Sampler::Ris {
            temporal: Some(_),
            spatial: None,
            ..
        } => "RIS with temporal reuse",
        Sampler::Ris {
            spatial: Some(_), ..
        } => "RIS with spatiotemporal reuse",
        Sampler::StochasticCulling { .. } => "stochastic culling",
    };
    let kinds = [
        "uniform",
        "RIS",
        "RIS with temporal reuse",
        "RIS with spatiotemporal reuse",
        "stochastic culling",
    ];
    let sampled: Vec<variant::LoadedVariant> = shipped()
        .into_iter()
        .filter(|v| v.variant.shading.lights.sampling().is_some())
        .collect();
    let kind_of =
        |v: &variant::LoadedVariant| kind(&v.variant.shading.lights.sampling().unwrap().method);
    let tested: Vec<String> = crate::sampling::unbiased_samplers()
        .into_iter()
        .map(|(v, _)| v.name)
        .chain(
            crate::sampling::labelled_biased_samplers()
                .into_iter()
                .map(|(v, _)| v.name),
        )
        .collect();
    let study = clusterlab::study::sampling::SAMPLERS;
    let mut missing = Vec::new();
    for k in kinds {
        if !sampled.iter().any(|v| kind_of(v) == k) {
            missing.push(format!("{k}: no shipped variant"));
        }
    }
    for v in &sampled {
        let name = v.name.as_str();
        if !study.contains(&name) && !clusterlab::study::sampling::TEMPORAL.contains(&name) {
            missing.push(format!("{name}: no row in `study sampling`"));
        }
        if !tested.iter().any(|t| t == name) {
            missing.push(format!(
                "{name}: not in the bias tests (`tests/sampling.rs`)"
            ));
        }
    }
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

/// A study is one file under `src/study/`, its line in `STUDIES` and its page: each file
/// there (but the registry, what every study shares and the table) is a registered study named after it, with its page
/// in `docs/studies/` and its row in that folder's index.
#[test]
fn every_study_file_is_registered_with_its_page() {
    let names: Vec<&str> = clusterlab::study::STUDIES.iter().map(|e| e.name).collect();
    let index = std::fs::read_to_string("docs/studies/README.md").expect("the studies' index");
    let mut missing = Vec::new();
    for entry in std::fs::read_dir("src/study").expect("src/study") {
        let path = entry.expect("an entry").path();
        let stem = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or_default();
        if ["mod", "shared", "table"].contains(&stem) {
            continue;
        }
        if !names.contains(&stem) {
            missing.push(format!("src/study/{stem}.rs: no `Entry::of` in STUDIES"));
        }
    }
    for name in &names {
        if !Path::new(&format!("docs/studies/{name}.md")).is_file() {
            missing.push(format!("{name}: no docs/studies/{name}.md"));
        }
        if !index.contains(&format!("| `{name}` | [{name}.md]({name}.md) |")) {
            missing.push(format!("{name}: no row in docs/studies/README.md"));
        }
    }
    assert!(missing.is_empty(), "{}", missing.join("\n"));
}

/// A culling method's file stem (`src/render/culling/<method>.rs`,
/// `tests/clustered/<method>.rs`): an exhaustive match, so a new method is named here
/// before this test compiles.
fn culling_stem(m: clusterlab::variant::CullingMethod) -> &'static str {
    use clusterlab::variant::CullingMethod;
    match m {
        CullingMethod::OneLevel => "one_level",
        CullingMethod::TwoLevel { .. } => "two_level",
        CullingMethod::ZBinning => "zbinning",
        CullingMethod::Rasterised => "rasterised",
        CullingMethod::Bvh => "bvh",
    }
}

/// A shadow estimator's file stem (`shaders/shading/shadows/<method>.wesl`): an exhaustive
/// match, so a new estimator is named here before this test compiles.
fn shadow_stem(s: clusterlab::variant::ShadowSampler) -> &'static str {
    use clusterlab::variant::ShadowSampler;
    match s {
        ShadowSampler::Importance => "importance",
        ShadowSampler::Ratio => "ratio",
    }
}

/// The section of `doc` that opens with `heading`, up to the next bold heading.
fn how_to<'a>(doc: &'a str, heading: &str) -> &'a str {
    let start = doc
        .find(heading)
        .unwrap_or_else(|| panic!("docs/ARCHITECTURE.md has no how-to {heading}"));
    let rest = &doc[start + heading.len()..];
    &rest[..rest.find("\n**").unwrap_or(rest.len())]
}

/// The files a how-to names: backticked paths with a folder and an extension.
fn named_files(section: &str) -> Vec<String> {
    section
        .split('`')
        .skip(1)
        .step_by(2)
        .filter(|t| t.contains('/') && !t.contains(' '))
        .filter(|t| {
            [".rs", ".wesl", ".md", ".ron"]
                .iter()
                .any(|x| t.ends_with(x))
        })
        .map(String::from)
        .collect()
}

/// Each how-to of `docs/ARCHITECTURE.md` ("How to add") names the files its unit touches:
/// every file it names exists, and one named by the unit (`<method>`, `<loop>`, `<name>`)
/// exists for every unit there is, and the how-to names at least the files it counts. A
/// unit added without its file, or a how-to naming a file that moved, fails here. The
/// deliberate break: a how-to naming a file that is not there.
#[test]
fn every_how_to_names_files_that_exist_for_every_unit() {
    use clusterlab::compose::LightLoop;
    let doc = std::fs::read_to_string("docs/ARCHITECTURE.md").expect("the architecture");
    let methods: Vec<String> = Culling::iter()
        .map(|culling| {
            let clusters = clusterlab::variant::Clusters {
                culling,
                ..Default::default()
            };
            culling_stem(clusters.method()).to_string()
        })
        .chain(std::iter::once(
            culling_stem(clusterlab::variant::CullingMethod::TwoLevel { big_tile: 2 }).to_string(),
        ))
        .collect();
    let loops: Vec<String> = LightLoop::ALL
        .iter()
        .map(|l| l.file().to_string())
        .collect();
    let studies: Vec<String> = clusterlab::study::STUDIES
        .iter()
        .map(|e| e.name.to_string())
        .collect();
    let estimators: Vec<String> = clusterlab::variant::ShadowSampler::iter()
        .map(|s| shadow_stem(s).to_string())
        .collect();
    let kinds: [(&str, &str, &[String], usize); 5] = [
        ("**A culling method**", "<method>", &methods, 8),
        ("**A sampler or light loop**", "<loop>", &loops, 5),
        ("**A normal codec**", "<name>", &[], 6),
        ("**A study**", "<name>", &studies, 3),
        ("**A sampled shadow method**", "<method>", &estimators, 4),
    ];
    let missing_in = |files: &[String], units: &[String], placeholder: &str| -> Vec<String> {
        let mut missing = Vec::new();
        for file in files {
            let each: Vec<String> = if file.contains(placeholder) {
                units.iter().map(|u| file.replace(placeholder, u)).collect()
            } else if file.contains('<') {
                Vec::new()
            } else {
                vec![file.clone()]
            };
            missing.extend(each.into_iter().filter(|f| !Path::new(f).exists()));
        }
        missing
    };
    assert_eq!(
        missing_in(
            &["src/render/culling/<method>.rs".into()],
            &["no_such".into()],
            "<method>"
        ),
        ["src/render/culling/no_such.rs"]
    );
    let mut wrong = Vec::new();
    for (heading, placeholder, units, at_least) in kinds {
        let files = named_files(how_to(&doc, heading));
        if files.len() < at_least {
            wrong.push(format!(
                "{heading} names {} files, fewer than {at_least}",
                files.len()
            ));
        }
        for f in missing_in(&files, units, placeholder) {
            wrong.push(format!("{heading}: `{f}` does not exist"));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}
