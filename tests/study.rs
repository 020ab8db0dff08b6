//! The accuracy studies on small inputs: the codec figures of the GPU path match the CPU
//! twin and the published octahedral figures, depth comes back as Reed's model says, the
//! slicing study counts what shading does, and the command writes every file.

use crate::common::{self, cli, scratch};

use clusterlab::compose::Composer;
use clusterlab::gpu::Gpu;
use clusterlab::gpu::expect::{self, Allowance, Check};
use clusterlab::study::{self, Finished, Study, StudyOptions};
use clusterlab::study::{codecs, culling, depth, msaa, shadows, slicing};

/// Study `S` with `options`, every point run.
fn run<S: Study>(gpu: &Gpu, options: StudyOptions) -> Finished<S> {
    study::run_points::<S>(gpu, &Composer::default(), &options, &mut |_| {}).expect(S::NAME)
}

/// The options of a small run on the atrium: `size`, `lights`, one timed frame.
fn small(size: (u32, u32), lights: &[u32]) -> StudyOptions {
    StudyOptions {
        scenes: vec!["atrium".into()],
        size: Some(size),
        lights: lights.to_vec(),
        frames: 1,
        ..Default::default()
    }
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-30)
}

#[test]
fn codecs_on_the_gpu_match_the_cpu_twin_and_the_published_figures() {
    let gpu = common::gpu();
    // The study's own sample and seed: the figures docs/studies/codecs.md states.
    let options = StudyOptions::default();
    assert_eq!(options.samples, 1 << 20);
    let done = run::<codecs::CodecStudy>(&gpu, options);
    let rows = &done.rows;
    for g in rows.iter().filter(|r| r.source == "gpu") {
        let c = rows
            .iter()
            .find(|c| {
                c.source == "cpu"
                    && c.codec == g.codec
                    && c.bits == g.bits
                    && c.sampling == g.sampling
            })
            .expect("a CPU row per GPU row");
        // The GPU computes in f32 with approximate trig; the figures still agree closely.
        let tolerance = if g.codec == "polar" { 0.05 } else { 0.01 };
        for (what, a, b) in [
            ("mean", g.mean_deg, c.mean_deg),
            ("p99", g.p99_deg, c.p99_deg),
            ("max", g.max_deg, c.max_deg),
        ] {
            assert!(
                rel(a, b) < tolerance,
                "{} {} bits {what}: GPU {a} CPU {b}",
                g.codec,
                g.bits
            );
        }
        let differing = g.codes_differing_from_cpu as f64 / g.samples as f64;
        assert!(differing < 0.05, "{} {}: {differing}", g.codec, g.bits);
        // Nothing is lost on the adversarial set but the spheremap's singular pole.
        if g.codec != "spheremap" {
            assert!(
                g.adversarial_max_deg < 1.5 * g.max_deg,
                "{} {} bits: adversarial {} against {}",
                g.codec,
                g.bits,
                g.adversarial_max_deg,
                g.max_deg
            );
        }
        // No code of that many bits can beat the covering bound.
        assert!(g.max_deg >= codecs::covering_bound_deg(g.bits as f64));
    }
    // Every printed figure of the GPU is the CPU twin's, or one unit off in its last digit.
    assert!(done.ok, "{}", done.table().terminal());
    let find = |codec: &str, sampling: &str, bits: u32| {
        rows.iter()
            .find(|r| {
                r.source == "gpu" && r.codec == codec && r.sampling == sampling && r.bits == bits
            })
            .unwrap()
    };
    // Tyler 2024, cube-normalized sampling: plain octahedral at 8, 10 and 12 bits a
    // component over 1M vectors. Sampled the same way, the means agree within 0.3% and the
    // maxima within 0.9%, as docs/studies/codecs.md says; uniform on the sphere the means
    // come out 4% lower (3.5% to 4.5%).
    for (bits, mean, max) in codecs::TYLER_OCT {
        let cube = find("octahedral", "cube", 2 * bits);
        assert!(
            rel(cube.mean_deg, mean) < 0.003,
            "{bits}: {}",
            cube.mean_deg
        );
        assert!(rel(cube.max_deg, max) < 0.009, "{bits}: {}", cube.max_deg);
        let uniform = find("octahedral", "uniform", 2 * bits).mean_deg;
        assert!(
            (0.955..0.965).contains(&(uniform / mean)),
            "{bits} bits: {uniform}"
        );
    }
    // The precise encoder lowers the max error at every bit count, to what Meyer 2010
    // predicts: the optimal discretisation's error with one bit fewer.
    for bits in [16, 20, 24, 32] {
        let precise = find("octahedral precise", "uniform", bits).max_deg;
        assert!(precise < 0.8 * find("octahedral", "uniform", bits).max_deg);
        let meyer = codecs::meyer_octahedral_max_deg(bits);
        // Within 1%, as the study's table prints them (0.0025 beside 0.0025 at 32 bits).
        assert!(
            rel(precise, meyer) < 0.01,
            "{bits} bits: {precise} against {meyer}"
        );
    }
}

#[test]
fn depth_comes_back_as_reeds_model_says() {
    let gpu = common::gpu();
    let options = StudyOptions {
        depth_columns: 200,
        depth_rows: 2,
        ..Default::default()
    };
    let study = run::<depth::DepthStudy>(&gpu, options);
    assert!(study.ok);
    assert_eq!(study.rows.len(), 8 * 5);
    // Where the adapter stores reversed-Z float32 depth no better than 24-bit unorm, hold it
    // to the 24-bit model (declared in `gpu::expect`).
    let as_24_bit = expect::allowance(&gpu, Check::ReversedFloatDepth)
        .is_some_and(|d| d.allowance == Allowance::DepthAs24BitUnorm);
    let model_24_bit = |from: f64| {
        study
            .rows
            .iter()
            .find(|r| r.format != "Float32" && r.reversed_z && r.from == from)
            .expect("24-bit reversed-Z row")
            .max_relative_model
    };
    for r in &study.rows {
        assert_eq!(r.missing, 0, "{}: strips missed", r.setup);
        assert!(r.samples > 0);
        let reversed_float = r.format == "Float32" && r.reversed_z;
        if reversed_float && as_24_bit {
            // Stored as 24-bit reversed depth is: held to that row's window of its model.
            let ratio = r.max_relative_gpu / model_24_bit(r.from);
            assert!(
                (0.4..=5.0).contains(&ratio),
                "{} {}: {} is {ratio} times the 24-bit model {}",
                r.setup,
                r.from,
                r.max_relative_gpu,
                model_24_bit(r.from)
            );
        } else if reversed_float {
            // Reversed-Z float: about 1e-7 at every distance.
            assert!(
                r.max_relative_gpu < 3e-7,
                "{} {}: {}",
                r.setup,
                r.from,
                r.max_relative_gpu
            );
        } else {
            // Elsewhere the storage step sets the error, as Reed's model of one rounding of
            // the stored value says. Reversed 24-bit sits on it (the samples find 0.45 to
            // 1.01 of it on lavapipe); the standard mappings and float32 come out
            // above it, by the f32 arithmetic of the projection and of the rebuild (1.4 to 4.6
            // times), never below it. A wrong mapping or depth rebuild is off by orders of
            // magnitude.
            let ratio = r.max_relative_gpu / r.max_relative_model;
            // Where OpenGL's clip space is kept (the deviation above), depth is rounded again
            // by the remap from [-1, 1] and by f32 arithmetic near 1, as in the standard
            // mappings: held to their upper bound there.
            let window = if r.format != "Float32" && r.reversed_z {
                0.4..=if as_24_bit { 5.0 } else { 1.25 }
            } else {
                1.0..=5.0
            };
            assert!(
                window.contains(&ratio),
                "{} {}: {} is {ratio} times the model {} (window {window:?})",
                r.setup,
                r.from,
                r.max_relative_gpu,
                r.max_relative_model
            );
        }
    }
    // Standard float32 is no better than 24-bit far away (Reed's point).
    let far = |setup: &str| {
        study
            .rows
            .iter()
            .find(|r| r.setup == setup && r.from == 1e3)
            .unwrap()
            .max_relative_gpu
    };
    assert!(far("float32 standard finite far") > 0.3 * far("24-bit standard finite far"));
    if !as_24_bit {
        assert!(far("float32 reversed-Z infinite far") < 1e-3 * far("24-bit standard finite far"));
    }
}

#[test]
fn slicing_counts_what_shading_does() {
    let gpu = common::gpu();
    let lights = 64;
    let done = run::<slicing::SlicingStudy>(&gpu, small((64, 36), &[lights]));
    assert!(done.ok);
    let rows = done.rows;
    // Every scheme on every grid, then tiled and Olsson's clustered shading.
    assert_eq!(
        rows.len(),
        slicing::GRIDS.len() * slicing::schemes(0.1, 60.0).len() + 2
    );
    // The useful evaluations are the scene's, counted by naive forward on the same frame.
    let scene =
        clusterlab::scene::generate("atrium", common::small("atrium", 64, 36, Some(lights)))
            .expect("atrium");
    let naive = clusterlab::variant::Variant {
        depth_prepass: true,
        ..Default::default()
    };
    let mut r = clusterlab::render::Renderer::new(&gpu, &Composer::default(), &naive, &scene)
        .expect("naive forward");
    r.render().expect("frame");
    let useful = r.stats().expect("counters").useful_light_evals;
    assert!(useful > 0);
    for r in &rows {
        assert!(r.error.is_none(), "{} {}: {:?}", r.scheme, r.grid, r.error);
        assert_eq!(r.useful_evaluations, useful, "{} {}", r.scheme, r.grid);
        assert!(r.evaluations >= r.useful_evaluations);
        assert!(r.occupied_clusters > 0 && r.occupied_clusters <= r.clusters);
        assert!(r.max_lights_per_occupied <= lights);
        assert!(r.mean_lights_per_occupied <= r.max_lights_per_occupied as f64);
    }
    // The culling differs: finer grids and schemes perform different numbers of evaluations.
    let performed: std::collections::BTreeSet<u64> = rows.iter().map(|r| r.evaluations).collect();
    assert!(performed.len() > rows.len() / 2, "{performed:?}");
}

/// The culling study: every method at each light count and spot fraction, exact (each finds
/// naive forward's useful evaluations on the same frame), with its own list memory; the
/// exactness verdict fails when one method counts one useful evaluation less.
#[test]
fn culling_counts_what_shading_does() {
    let gpu = common::gpu();
    let composer = Composer::default();
    let size = (96, 54);
    let counts = [64, 256];
    let done = run::<culling::CullingStudy>(&gpu, small(size, &counts));
    let rows = &done.rows;
    let methods = culling::methods();
    assert_eq!(
        rows.len(),
        counts.len() * culling::SPOT_FRACTIONS.len() * methods.len()
    );
    for &lights in &counts {
        for spots in culling::SPOT_FRACTIONS {
            let mut params = common::small("atrium", size.0, size.1, Some(lights));
            params.spots = spots;
            let scene = clusterlab::scene::generate("atrium", params).expect("atrium");
            let naive = clusterlab::variant::Variant {
                depth_prepass: true,
                ..Default::default()
            };
            let mut r = clusterlab::render::Renderer::new(&gpu, &composer, &naive, &scene)
                .expect("naive forward");
            r.render().expect("frame");
            let useful = r.stats().expect("counters").useful_light_evals;
            assert!(useful > 0);
            let group: Vec<&culling::CullingRow> = rows
                .iter()
                .filter(|r| r.lights == lights && r.spot_fraction == spots)
                .collect();
            assert_eq!(group.len(), methods.len());
            for r in group {
                let what = format!("{} at {lights} lights, spots {spots}", r.method);
                assert!(r.error.is_none(), "{what}: {:?}", r.error);
                assert_eq!(r.useful_evaluations, useful, "{what}");
                assert!(r.evaluations >= r.useful_evaluations, "{what}");
                assert!(r.worst_list > 0 && r.worst_list <= lights, "{what}");
                assert!(r.list_bytes > 0 && r.shading_ms > 0.0, "{what}");
            }
        }
    }
    assert!(done.ok);
    let mut short = rows.clone();
    short[3].useful_evaluations -= 1;
    assert!(
        !study::all_kept(&done.study, &short),
        "a method that lost one useful evaluation passed"
    );
    // Z-binning keeps bins and one bit per light and tile, not per-cluster lists.
    let bytes = |m: &str| rows.iter().find(|r| r.method == m).expect(m).list_bytes;
    assert!(bytes("z-binning") < bytes("fine clusters"));
    assert!(done.plot().is_some());

    // Which did best, at 64 lights without spots: among the exact runs only.
    let runs: Vec<&culling::CullingRow> = rows
        .iter()
        .filter(|r| r.lights == 64 && r.spot_fraction == 0.0)
        .collect();
    let b = culling::best(rows, "atrium", 64, 0.0).expect("a best method");
    let fastest = runs
        .iter()
        .map(|r| r.frame_ms)
        .fold(f64::INFINITY, f64::min);
    assert_eq!(b.fastest.frame_ms, fastest);
    let next = b.runner_up.expect("a runner-up");
    assert!(next.frame_ms >= fastest && next.method != b.fastest.method);
    let fewest = runs.iter().map(|r| r.evaluations).min();
    assert_eq!(Some(b.fewest_evaluations.evaluations), fewest);
    let least = runs.iter().map(|r| r.list_bytes).min();
    assert_eq!(Some(b.least_memory.list_bytes), least);
    let notes = done.table().notes.join("\n");
    let line = format!(
        "atrium, 64 lights, spots 0: lowest median frame {} (",
        b.fastest.method
    );
    assert!(notes.contains(&line), "{notes}");
    // A run that left out a light is never the best, however fast, few or small.
    let mut lossy = rows.clone();
    let i = lossy
        .iter()
        .position(|r| r.lights == 64 && r.spot_fraction == 0.0)
        .expect("a run at 64 lights");
    lossy[i].useful_evaluations -= 1;
    lossy[i].frame_ms = 0.0;
    lossy[i].evaluations = 0;
    lossy[i].list_bytes = 0;
    let lb = culling::best(&lossy, "atrium", 64, 0.0).expect("a best method");
    for picked in [lb.fastest, lb.fewest_evaluations, lb.least_memory] {
        assert_ne!(picked.method, lossy[i].method);
    }
    // Where every run failed, nothing is named best and no timing source is made up.
    let mut failed = rows.clone();
    for r in &mut failed {
        r.error = Some("no adapter".into());
        r.timing_source.clear();
    }
    let notes = done.study.table(&failed).notes.join("\n");
    assert!(!notes.contains("lowest median frame"), "{notes}");
    assert!(notes.contains("medians of the timed frames. "), "{notes}");
}

/// A point whose run fails leaves the row that names it, with why, and the other points
/// run: with the light BVH's assignment broken (an import of nothing), the culling study's
/// BVH rows fail naming the module, every other method's rows are whole, the progress
/// says which points failed, and the study is not ok. The same run with the shipped shaders
/// is `culling_counts_what_shading_does`.
#[test]
fn a_failing_point_leaves_its_named_row_and_the_others_run() {
    let gpu = common::gpu();
    let broken = common::EditedShaders::of(
        "passes/assign_bvh.wesl",
        "study-bvh-broken",
        &[(
            "import package::clustering::clusters::cluster_count;",
            "import package::clustering::clusters::cluster_count_nowhere;",
        )],
    );
    let mut lines = Vec::new();
    let options = small((48, 27), &[64]);
    let done =
        study::run_points::<culling::CullingStudy>(&gpu, &broken.composer, &options, &mut |line| {
            lines.push(line.to_string())
        })
        .expect("the study runs");
    let methods = culling::methods().len();
    assert_eq!(done.rows.len(), culling::SPOT_FRACTIONS.len() * methods);
    assert_eq!(lines.len(), done.rows.len());
    assert!(!done.ok);
    let bvh = "Olsson light BVH";
    for (r, line) in done.rows.iter().zip(&lines) {
        if r.method == bvh {
            let e = r.error.as_deref().unwrap_or_default();
            assert!(e.contains("assign_bvh"), "{e}");
            assert!(line.contains(bvh) && line.contains("FAILED"), "{line}");
        } else {
            assert!(r.error.is_none() && r.evaluations > 0, "{r:#?}");
            assert!(!line.contains("FAILED"), "{line}");
        }
    }
    assert!(done.table().terminal().contains("FAILED"));
}

/// At 0 lights a study claims no useful share (not "100% useful" of 0 of 0) and writes no
/// negative zero (an empty sum of pass times is -0.0 in Rust).
#[test]
fn a_study_at_no_lights_claims_no_share_and_writes_no_negative_zero() {
    let dir = scratch("no-lights").join("results");
    for study in ["scale", "cones"] {
        let out = cli([
            "study", study, "--lights", "0", "--size", "32x18", "--frames", "1",
        ])
        .arg("--out")
        .arg(&dir)
        .run();
        assert_eq!(out.code, Some(0), "{study}: {}", out.printed());
        for ext in ["csv", "json", "md"] {
            let text = std::fs::read_to_string(dir.join(format!("{study}.{ext}"))).unwrap();
            assert!(
                !text.contains("-0.0") && !text.contains(",-0,"),
                "{study}.{ext}: {text}"
            );
            assert!(
                !text.contains("100.0%"),
                "{study}.{ext} claims a share of nothing: {text}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(dir.parent().unwrap());
}

#[test]
fn the_study_command_writes_every_file() {
    let dir = scratch("codecs").join("results");
    let out = cli(["study", "codecs", "--samples", "2000", "--json", "--out"])
        .arg(&dir)
        .run();
    let stderr = &out.stderr;
    let doc: serde_json::Value = serde_json::from_str(&out.stdout).expect("JSON on stdout");
    assert_eq!(doc["study"], "codecs");
    // 4 codecs x 4 bit counts x GPU and CPU, the f32 row, plain octahedral on cube sampling.
    assert_eq!(
        doc["rows"].as_array().map(|r| r.len()),
        Some(4 * 4 * 2 + 1 + 4 * 2)
    );
    assert!(stderr.contains("Normal codecs"), "{stderr}");
    for f in ["codecs.csv", "codecs.json", "codecs.md", "codecs.svg"] {
        let text = std::fs::read_to_string(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert!(!text.is_empty(), "{f}");
    }
    let csv = std::fs::read_to_string(dir.join("codecs.csv")).unwrap();
    assert!(
        csv.starts_with("codec,sampling,bits,source,mean_deg"),
        "{csv}"
    );
    // A bad study name is named with the valid ones.
    let bad = cli(["study", "colours"]).run();
    assert_ne!(bad.code, Some(0));
    let msg = &bad.stderr;
    assert!(
        msg.contains("codecs") && msg.contains("depth") && msg.contains("slicing"),
        "{msg}"
    );
    let _ = std::fs::remove_dir_all(dir.parent().unwrap());
}

/// `study cones` and `study culling` exit 0 when every run is exact and 1 when a light is
/// missed: run again on a copy of the shaders with a deliberate break (through
/// `CLUSTERLAB_SHADERS`): for cones, light ranges that leave out every light of radius over
/// 1; for culling, z-binning's walk skipping every other light of a mask word (the methods'
/// useful evaluations then differ). In the cones rows, the cone test lights the same
/// samples as the sphere test (equal useful evaluations), never evaluates more, and its
/// "cone / sphere" is its evaluations over the sphere test's.
#[test]
fn the_cones_and_culling_studies_exit_1_when_a_light_is_missed() {
    let cones_broken = common::EditedShaders::of(
        "clustering/light_range.wesl",
        "study-lights-dropped",
        &[(
            "if (c.z - r > -near) {",
            "if (c.z - r > -near || r > 1.0) {",
        )],
    );
    let culling_broken = common::EditedShaders::of(
        "shading/light_loop/zbin_walk.wesl",
        "study-walk-halved",
        &[(
            "var bits = tile_masks[base + w] & span_bits(w, span);",
            "var bits = tile_masks[base + w] & span_bits(w, span) & 0x55555555u;",
        )],
    );
    let dir = scratch("exit").join("results");
    let study = |name: &str, shaders: &std::path::Path| {
        let args = [
            "study", name, "--scenes", "stage", "--size", "48x27", "--lights", "64",
        ];
        cli(args)
            .args(["--frames", "1", "--json", "--out"])
            .arg(&dir)
            .env("CLUSTERLAB_SHADERS", shaders)
            .run()
    };
    let shipped = Composer::default().shader_root().to_path_buf();
    for name in ["cones", "culling"] {
        let out = study(name, &shipped);
        assert_eq!(out.code, Some(0), "{name}: {}", out.stderr);
        if name == "cones" {
            let doc: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
            let rows = doc["rows"].as_array().unwrap();
            for pair in rows.chunks(2) {
                let (sphere, cone) = (&pair[0], &pair[1]);
                assert_eq!(
                    (&sphere["spot_test"], &cone["spot_test"]),
                    (&"Sphere".into(), &"Cone".into())
                );
                let evals = |r: &serde_json::Value| r["evaluations"].as_f64().unwrap();
                assert_eq!(sphere["useful_evaluations"], cone["useful_evaluations"]);
                assert!(evals(cone) <= evals(sphere), "{cone}");
                let ratio = cone["over_sphere"].as_f64().unwrap();
                assert_eq!(ratio, evals(cone) / evals(sphere), "{cone}");
            }
        }
        let broken = if name == "cones" {
            &cones_broken
        } else {
            &culling_broken
        };
        let out = study(name, broken.root());
        assert_eq!(
            out.code,
            Some(1),
            "{name} on the broken shaders: {}",
            out.stderr
        );
    }
    let _ = std::fs::remove_dir_all(dir.parent().unwrap());
}

/// The MSAA study: the group's seven variants at every sample count the adapter
/// multisamples (1 and 4 on lavapipe; 1 alone through OpenGL, which refuses), each exact;
/// with more than one count, a multisampled frame costs more memory per pixel and has edge
/// pixels, and the table sets each deferred/forward ratio beside the published one.
#[test]
fn the_msaa_study_runs_every_pipeline_at_every_sample_count_exactly() {
    let gpu = common::gpu();
    let counts = gpu.multisample_counts();
    if gpu.backend == wgpu::Backend::Gl {
        assert_eq!(counts, [1]);
    } else {
        assert!(counts.contains(&4), "{counts:?}");
    }
    let done = run::<msaa::MsaaStudy>(&gpu, small((64, 36), &[64]));
    let rows = &done.rows;
    assert_eq!(
        rows.len(),
        clusterlab::matrix::MSAA_GROUP.len() * counts.len()
    );
    assert!(done.ok, "{rows:#?}");
    for r in rows.iter().filter(|r| r.samples > 1) {
        let one = rows
            .iter()
            .find(|o| o.variant == r.variant && o.samples == 1)
            .expect("a one-sample row");
        assert!(r.bytes_per_pixel > one.bytes_per_pixel, "{}", r.variant);
        assert!(r.edge_fraction > 0.0, "{}", r.variant);
    }
    let notes = done.table().notes.join("\n");
    assert_eq!(
        msaa::ratios(rows).len(),
        msaa::PAIRS.len() * counts.len(),
        "{notes}"
    );
    assert!(notes.contains("GPU Pro 4"), "{notes}");
}

/// The temporal study runs every strategy at every moving fraction with the camera still
/// and moving, exactly, and its figures are what its sequences did: no frame after the first
/// runs a pass where nothing moves and the camera is still, and every other one does.
#[test]
fn the_temporal_study_runs_every_strategy_at_every_fraction_exactly() {
    use clusterlab::study::temporal;
    let gpu = common::gpu();
    let done = run::<temporal::TemporalStudy>(&gpu, small((64, 36), &[64]));
    let rows = &done.rows;
    assert_eq!(
        rows.len(),
        temporal::VARIANTS.len() * temporal::MOVING.len() * 2
    );
    assert!(done.ok, "{rows:#?}");
    // Whether any of the 64 lights moves at a fraction (1% of 64 may be none).
    let movers = |moving: f32| {
        let mut p = clusterlab::scene::defaults(temporal::SCENE).unwrap();
        (p.width, p.height, p.lights) = (64, 36, 64);
        p.motion.lights = moving;
        let scene = clusterlab::scene::generate(temporal::SCENE, p).unwrap();
        !scene.moving_lights.is_empty()
    };
    assert!(!movers(0.0) && movers(0.5));
    for r in rows {
        let idle = !movers(r.moving) && !r.camera_moves;
        assert_eq!(r.frames_reused, u32::from(idle), "{r:#?}");
        assert_eq!(r.frame_ms == 0.0, idle, "{r:#?}");
        // A rebuilding variant is its own measure.
        let rebuilds = temporal::VARIANTS
            .iter()
            .any(|(v, b)| v == b && *v == r.variant);
        if rebuilds && !idle {
            assert_eq!(r.vs_rebuild, Some(1.0), "{}", r.variant);
        }
    }
    let table = done.table();
    assert_eq!(table.rows.len(), rows.len());
    assert!(table.notes.iter().any(|n| n.contains("Moreau")));
    assert!(done.plot().is_some());
}

/// The spatial reuse of shipped variant `name` (its sweep points share it), if any.
fn spatial_of(name: &str) -> Option<clusterlab::variant::SpatialReuse> {
    let base = name.split('@').next().unwrap_or(name);
    let v = common::load(base);
    match v.variant.shading.lights.sampling()?.method {
        clusterlab::variant::Sampler::Ris { spatial, .. } => spatial,
        _ => None,
    }
}

/// The sampling study runs every exact variant, every sampler and its sweep at a point, and
/// its figures are what its frames did: exact rows within 1 LSB and evaluating what they
/// look at, useful evaluations among the evaluated and those among the candidates, the
/// sweeps stopping at the first point that reaches the target, the front holding the
/// fastest single frame and no dominated row, the temporal row beside it.
#[test]
fn the_sampling_study_measures_every_sampler_against_the_exact_variants() {
    use clusterlab::study::sampling;
    let gpu = common::gpu();
    let done = run::<sampling::SamplingStudy>(&gpu, small((64, 36), &[256]));
    let rows = &done.rows;
    assert!(done.ok, "{rows:#?}");
    let points = sampling::RADII.len();
    let shipped = |r: &&sampling::SamplingRow| !r.sweep;
    assert_eq!(
        rows.iter().filter(shipped).count(),
        points * (sampling::EXACT.len() + sampling::SAMPLERS.len() + sampling::TEMPORAL.len())
    );
    for r in rows {
        if r.sampler == "exact" {
            assert!(r.max_abs_8bit <= 1, "{r:#?}");
            assert_eq!(r.candidates, r.evaluations, "{r:#?}");
        }
        // Each candidate is evaluated once; with the balance heuristic each combined
        // reservoir's light also at each combined surface (the pixel's two and its
        // neighbours'), this frame's reservoir one of them.
        let per_candidate = match spatial_of(&r.variant) {
            Some(s) if s.balance => 1 + 2 * (s.neighbours as u64 + 2),
            _ => 1,
        };
        assert!(
            r.useful <= r.evaluations && r.evaluations <= r.candidates * per_candidate,
            "{r:#?}"
        );
        assert!(!(r.pareto && r.last_rmse_8bit.is_some()), "{r:#?}");
    }
    for &(lo, hi) in &sampling::RADII {
        let here: Vec<&sampling::SamplingRow> = rows
            .iter()
            .filter(|r| (r.radius_min, r.radius_max) == (lo, hi))
            .collect();
        let single: Vec<&&sampling::SamplingRow> =
            here.iter().filter(|r| r.last_rmse_8bit.is_none()).collect();
        let fastest = single
            .iter()
            .min_by(|a, b| a.frame_ms.total_cmp(&b.frame_ms))
            .unwrap();
        assert!(fastest.pareto, "{fastest:#?}");
        for a in &single {
            for b in &single {
                let dominates = b.frame_ms < a.frame_ms && b.rmse_8bit < a.rmse_8bit;
                assert!(
                    !(a.pareto && dominates),
                    "{} on the front, {} better",
                    a.variant,
                    b.variant
                );
            }
        }
        // A sweep ends at its first point within the target.
        for base in sampling::SAMPLERS {
            let family: Vec<&&sampling::SamplingRow> = here
                .iter()
                .filter(|r| r.sweep && r.variant.starts_with(&format!("{base}@")))
                .collect();
            if let Some(i) = family
                .iter()
                .position(|r| r.rmse_8bit <= sampling::TARGET_RMSE_8BIT)
            {
                assert_eq!(i + 1, family.len(), "{base}: {family:#?}");
            }
        }
        let temporal = here
            .iter()
            .find(|r| r.variant == sampling::TEMPORAL[0])
            .unwrap();
        assert!(temporal.last_rmse_8bit.is_some());
    }
    let table = done.table();
    assert_eq!(table.rows.len(), rows.len());
    assert!(table.notes.iter().any(|n| n.contains("Bitterli")));
    assert!(done.plot().is_some());
}

/// The scale study runs every method exactly at each count it is given, and every method
/// finds the same useful evaluations on the same frame (each is exact: one that left out a
/// light would find fewer); the radius shrinks with the count as its rule says; the light
/// BVH's row, and no other, times its build.
#[test]
fn the_scale_study_runs_every_method_exactly() {
    use clusterlab::study::scale;
    let gpu = common::gpu();
    let done = run::<scale::ScaleStudy>(&gpu, small((64, 36), &[256, 2048]));
    let rows = &done.rows;
    assert_eq!(rows.len(), 2 * scale::METHODS.len());
    assert!(done.ok, "{rows:#?}");
    for r in rows {
        let first = rows.iter().find(|o| o.lights == r.lights).unwrap();
        assert_eq!(r.useful_evaluations, first.useful_evaluations, "{r:#?}");
        assert!(r.useful_evaluations > 0 && r.evaluations >= r.useful_evaluations);
        assert!(r.max_abs_8bit <= clusterlab::run::EXACT_LSB, "{r:#?}");
        assert_eq!((r.radius_min, r.radius_max), scale::radius_range(r.lights));
        // The build is timed for the light BVH alone, and is part of its assignment.
        assert_eq!(
            r.build_ms.is_some(),
            r.variant == "forward_plus_bvh",
            "{r:#?}"
        );
        assert!(r.build_ms.is_none_or(|b| b > 0.0), "{r:#?}");
    }
    assert!(done.plot().is_some());
}

/// The shadows study runs every shadowed variant and its twin at every ray budget; exact
/// shadows stay within 1 LSB outside ambiguous pairs; its figures are its frames': rays
/// traced where shadows are on, none where off, more rays for a bigger budget, and each
/// shadowed frame's cost over its twin's.
#[test]
fn the_shadows_study_runs_every_method_and_budget() {
    let gpu = common::gpu();
    let done = run::<shadows::ShadowStudy>(&gpu, small((96, 54), &[256]));
    let rows = &done.rows;
    let sampled = 2;
    assert_eq!(
        rows.len(),
        shadows::VARIANTS.len() + sampled * shadows::RAYS.len()
    );
    assert!(done.ok, "{rows:#?}");
    for r in rows {
        let unshadowed = r.method == "unshadowed";
        assert_eq!(r.rays == 0, unshadowed, "{}: {} rays", r.variant, r.rays);
        assert!(r.over_unshadowed.is_some(), "{}", r.variant);
    }
    let rays = |name: &str| rows.iter().find(|r| r.variant == name).map(|r| r.rays);
    let one = rays("forward_plus_shadows_importance_1").unwrap();
    let sixteen = rays("forward_plus_shadows_importance_1@16rays").unwrap();
    assert!(sixteen > one, "{one} and {sixteen} rays");
    let notes = done.table().notes.join("\n");
    assert!(notes.contains("exact shadows:"), "{notes}");
}
