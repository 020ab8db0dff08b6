//! Naive forward against the CPU f64 reference, and the command line's handling of bad
//! requests.

use clusterlab::scene::SCENES;

use crate::common::{Ran, cell, cli, gpu, load, scratch, small};

#[test]
fn naive_forward_is_within_one_lsb_of_the_reference_on_every_scene() {
    let gpu = gpu();
    for name in ["naive_forward", "naive_forward_blinn_phong"] {
        let v = load(name);
        for scene in SCENES {
            let r = cell(&gpu, &v, scene.name, small(scene.name, 160, 90, None)).report;
            let e = r.error.as_ref().expect("a shaded image");
            assert!(
                e.max_abs_8bit <= 1 && e.nan_pixels == 0,
                "{name} on {}: {e:?}",
                scene.name
            );
        }
    }
}

#[test]
fn naive_forward_stays_exact_from_zero_to_many_lights() {
    let gpu = gpu();
    let v = load("naive_forward");
    for lights in [0, 1, 64, 2048] {
        let r = cell(&gpu, &v, "atrium", small("atrium", 96, 54, Some(lights))).report;
        assert_eq!(r.lights, lights);
        let e = r.error.as_ref().expect("a shaded image");
        assert!(
            e.max_abs_8bit <= 1 && e.nan_pixels == 0,
            "{lights} lights: {e:?}"
        );
    }
}

#[test]
fn an_empty_scene_is_ambient_only_and_a_lit_one_is_not() {
    let gpu = gpu();
    let v = load("naive_forward");
    let dark = cell(&gpu, &v, "empty", small("empty", 64, 64, None)).frame;
    let lit = cell(&gpu, &v, "one_light", small("one_light", 64, 64, None)).frame;
    let brightest = |f: &clusterlab::render::FrameOutput| {
        f.hdr
            .iter()
            .map(|p| p[0].max(p[1]).max(p[2]))
            .fold(0.0f32, f32::max)
    };
    // Ambient 0.02 of albedo at most 0.8: nothing brighter than 0.016.
    assert!(brightest(&dark) <= 0.0161, "{}", brightest(&dark));
    assert!(brightest(&lit) > 0.5, "{}", brightest(&lit));
}

#[test]
fn render_prints_the_json_report() {
    let out = scratch("json").join("images");
    let Ran {
        code,
        stdout,
        stderr,
    } = cli([
        "render",
        "--variant",
        "naive_forward",
        "--scene",
        "one_light",
        "--size",
        "64x48",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ])
    .run();
    assert_eq!(code, Some(0), "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    for key in [
        "variant", "scene", "adapter", "size", "lights", "gpu_ms", "wall_ms", "error",
    ] {
        assert!(json.get(key).is_some(), "no `{key}` in {json}");
    }
    for key in ["name", "backend", "driver"] {
        assert!(json["adapter"].get(key).is_some(), "no adapter.{key}");
    }
    for key in [
        "max_abs_8bit",
        "rmse",
        "psnr_db",
        "flip_mean",
        "pixels_over_1lsb",
        "nan_pixels",
    ] {
        assert!(json["error"].get(key).is_some(), "no error.{key}");
    }
    assert_eq!(json["size"], serde_json::json!([64, 48]));
    assert!(json["gpu_ms"]["total"].as_f64().is_some_and(|t| t > 0.0));
    assert!(json["gpu_ms"]["forward"].as_f64().is_some());
    assert!(
        json["error"]["max_abs_8bit"]
            .as_u64()
            .is_some_and(|e| e <= 1)
    );
    assert!(out.join("naive_forward@one_light.png").exists());
    assert!(out.join("naive_forward@one_light.heat.png").exists());
}

/// The smoke test on OpenGL (llvmpipe): the same command, another backend. An OpenGL
/// adapter clusterlab cannot run (NVIDIA's 3.3 context has no storage buffers) is refused
/// in one line naming what it lacks, and the rest is skipped, saying so.
#[test]
fn render_runs_on_opengl_too() {
    use clusterlab::gpu::adapters;
    let gl = adapters::enumerate(wgpu::Backends::GL);
    if gl.is_empty() {
        eprintln!("skipped: no OpenGL adapter here");
        return;
    }
    if gl
        .iter()
        .all(|a| adapters::missing_requirements(a).is_some())
    {
        let (code, text) = cli(["render", "--variant", "naive_forward", "--scene", "atrium"])
            .envs(&[("WGPU_BACKEND", "gl")])
            .run()
            .outcome();
        assert_eq!(code, Some(1), "{text}");
        assert!(
            text.contains("no adapter here can run clusterlab's pipelines"),
            "{text}"
        );
        eprintln!("skipped: no OpenGL adapter here can run the pipelines: {text}");
        return;
    }
    let out = scratch("gl").join("images");
    let Ran {
        code,
        stdout,
        stderr,
    } = cli([
        "render",
        "--variant",
        "naive_forward",
        "--scene",
        "atrium",
        "--size",
        "96x54",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ])
    .envs(&[("WGPU_BACKEND", "gl")])
    .run();
    assert_eq!(code, Some(0), "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    assert_eq!(json["adapter"]["backend"], "gl");
    assert!(
        json["error"]["max_abs_8bit"]
            .as_u64()
            .is_some_and(|e| e <= 1),
        "{json}"
    );
    assert_eq!(json["error"]["nan_pixels"], 0);
}

#[test]
fn bad_requests_get_a_clear_message_and_exit_code_1() {
    // Our own checks exit with 1; argument syntax and value errors are clap's (exit 2).
    let cases: [(&[&str], &str, i32); 6] = [
        (
            &["--scene", "atrum"],
            "unknown scene `atrum`; nearest: `atrium`; the built-in scenes are: atrium",
            1,
        ),
        (
            &["--scene", "atrium", "--size", "0x0"],
            "`0x0`: width and height must be at least 1",
            2,
        ),
        (
            &["--scene", "atrium", "--size", "100000x100000"],
            "each side must be in 1..=",
            1,
        ),
        (
            &["--scene", "atrium", "--backend", "vulcan"],
            "`vulcan` (from --backend) is not a backend",
            1,
        ),
        (
            &["--scene", "atrium", "--debug-view", "z-slice"],
            "pipeline NaiveForward has none",
            1,
        ),
        (
            &["--scene", "atrium", "--size", "big"],
            "is not WIDTHxHEIGHT",
            2,
        ),
    ];
    for (args, expected, exit_code) in cases {
        let mut all = vec!["render", "--variant", "naive_forward"];
        all.extend_from_slice(args);
        let Ran { code, stderr, .. } = cli(&all).run();
        assert_eq!(code, Some(exit_code), "{args:?}: {stderr}");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?} panicked: {stderr}");
    }
}

/// Where the adapter's driver ends a shader's loops early (llvmpipe), a frame whose light
/// loop would pass the cap is refused, naming the cap, rather than shaded with lights left
/// out; at the cap it renders, and the last light is not left out. Elsewhere there is no cap.
#[test]
fn light_loops_past_the_adapters_loop_cap_are_refused() {
    use clusterlab::compose::Composer;
    use clusterlab::render::Renderer;
    use clusterlab::scene::Light;
    let gpu = gpu();
    let v = load("naive_forward").variant;
    let base = clusterlab::scene::generate("one_light", small("one_light", 32, 18, Some(1)))
        .expect("scene");
    let cap = clusterlab::gpu::expect::max_lights_per_pixel(&gpu);
    let with_lights = |n: u32| {
        // Dark specks far away, then one bright light above the plane, last in the list.
        let mut scene = base.clone();
        scene.lights = vec![Light::point([100.0; 3], 0.01, [0.0; 3], 0.0); n as usize - 1];
        scene
            .lights
            .push(Light::point([0.0, 1.5, 0.0], 6.0, [1.0; 3], 20.0));
        scene.params.lights = n;
        scene
    };
    let n = cap.unwrap_or(65535);
    let mut r = Renderer::new(&gpu, &Composer::default(), &v, &with_lights(n)).expect("renders");
    let lit = r.render().expect("frame").ldr.iter().map(|p| p[0]).max();
    assert!(
        lit > Some(200),
        "{n} lights: the last light is left out ({lit:?})"
    );
    drop(r);
    match (
        cap,
        Renderer::new(&gpu, &Composer::default(), &v, &with_lights(n + 1)),
    ) {
        (Some(_), Err(e)) => {
            let message = e.to_string();
            assert!(message.contains("ends a shader's loops"), "{message}");
        }
        (Some(_), Ok(_)) => panic!("{} lights on a capped adapter were not refused", n + 1),
        (None, r) => assert!(r.is_ok(), "no cap here, yet refused"),
    }
}

/// A shipped variant of each pipeline.
const ONE_OF_EACH_PIPELINE: [&str; 4] = [
    "naive_forward",
    "forward_plus",
    "clustered_deferred_16x16x24",
    "deferred_scissor",
];

/// The HDR image of one frame of `v` on `scene`.
fn hdr_frame(
    gpu: &clusterlab::gpu::Gpu,
    composer: &clusterlab::compose::Composer,
    v: &clusterlab::variant::Variant,
    scene: &clusterlab::scene::Scene,
) -> Vec<[f32; 4]> {
    let mut r = clusterlab::render::Renderer::new(gpu, composer, v, scene).unwrap();
    r.render().unwrap().hdr
}

/// README: every pipeline shades with the same finite-range falloff, exactly zero at a
/// light's radius. On the GPU: with one light, every pixel farther from it than its radius
/// (by more than f32 rounding of the distance, 1e-5) is exactly the unlit image's, and every
/// pixel well inside it that faces it is brighter.
#[test]
fn every_pipeline_adds_exactly_nothing_past_a_lights_radius() {
    use clusterlab::compose::Composer;
    use clusterlab::render::raster_truth;
    let gpu = gpu();
    let composer = Composer::default();
    let lit = clusterlab::scene::generate("one_light", small("one_light", 96, 54, None)).unwrap();
    let mut dark = lit.clone();
    dark.lights[0].color = [0.0; 3];
    let light = lit.lights[0];
    let centre = glam::DVec3::from(light.position.map(f64::from));
    let radius = light.radius as f64;
    for name in ONE_OF_EACH_PIPELINE {
        let v = load(name).variant;
        let truth = raster_truth(&gpu, &composer, &v, &lit).unwrap();
        let frame = |scene| hdr_frame(&gpu, &composer, &v, scene);
        let (with, without) = (frame(&lit), frame(&dark));
        let (mut outside, mut inside) = (0, 0);
        for i in 0..truth.position.len() {
            if !truth.covered(i) {
                continue;
            }
            let s = truth.surface(i);
            let d = s.position.distance(centre);
            if d > radius * (1.0 + 1e-5) {
                assert_eq!(with[i], without[i], "{name}: pixel {i} at {d} > {radius}");
                outside += 1;
            } else if d < radius * 0.9 && s.normal.dot(centre - s.position) > 0.0 {
                assert!(with[i][0] > without[i][0], "{name}: pixel {i} at {d}");
                inside += 1;
            }
        }
        assert!(
            outside > 100 && inside > 100,
            "{name}: {outside} outside, {inside} inside"
        );
    }
}

/// The spot factor's closed form on the GPU, every pipeline: the one light made a spot
/// (straight down, inner 35 and outer 55 degrees) adds exactly what the point light adds
/// inside its inner cone, exactly nothing beyond its outer cone or its radius, and between
/// them the point light's times the smoothstep of the cosine. Bounds: the cosine comes from
/// f32 surface positions (a relative 1e-5 keeps a pixel off the cones' edges), and in the
/// band the smoothstep's slope, at most 1.5 / (cos 35 - cos 55) = 6.1 per unit of cosine,
/// turns that 1e-5 into 6.1e-5 of the factor; the ratio's own f32 rounding adds 1e-6, and
/// the HDR target's rounding of each image (a 16-bit float on OpenGL) its share.
#[test]
fn the_spot_factor_is_one_inside_zero_outside_and_a_smoothstep_between() {
    use clusterlab::compose::Composer;
    use clusterlab::cpu::shading::spot_factor;
    use clusterlab::render::raster_truth;
    use clusterlab::scene::Light;
    let gpu = gpu();
    let composer = Composer::default();
    let point =
        clusterlab::scene::generate("one_light", small("one_light", 96, 54, Some(1))).unwrap();
    let l = point.lights[0];
    let mut spot = point.clone();
    spot.lights[0] = Light::spot(
        l.position,
        l.radius,
        l.color,
        1.0,
        [0.0, -1.0, 0.0],
        35.0,
        55.0,
    );
    let mut dark = point.clone();
    dark.lights[0].color = [0.0; 3];
    let centre = glam::DVec3::from(l.position.map(f64::from));
    let (cos_inner, cos_outer) = (35f64.to_radians().cos(), 55f64.to_radians().cos());
    let slope = 1.5 / (cos_inner - cos_outer);
    // Unit roundoff of the HDR target: 2^-11 for a 16-bit float, 2^-24 for a 32-bit one.
    let target_rounding = match gpu.hdr_format {
        wgpu::TextureFormat::Rgba16Float => 2f64.powi(-11),
        _ => 2f64.powi(-24),
    };
    for name in ONE_OF_EACH_PIPELINE {
        let v = load(name).variant;
        let truth = raster_truth(&gpu, &composer, &v, &point).unwrap();
        let frame = |scene| hdr_frame(&gpu, &composer, &v, scene);
        let (by_point, by_spot, unlit) = (frame(&point), frame(&spot), frame(&dark));
        let mut seen = [0; 3];
        for i in (0..truth.position.len()).filter(|&i| truth.covered(i)) {
            let p = truth.surface(i).position;
            let to_light = centre - p;
            let d = to_light.length();
            let cos = -to_light.normalize().dot(glam::DVec3::NEG_Y);
            let added = |f: &[[f32; 4]]| f[i][0] - unlit[i][0];
            let what = format!("{name}: pixel {i}, cosine {cos}, distance {d}");
            if d > l.radius as f64 * (1.0 + 1e-5) || cos < cos_outer - 1e-5 {
                assert_eq!(by_spot[i], unlit[i], "{what}: outside");
                seen[0] += 1;
            } else if cos > cos_inner + 1e-5 {
                assert_eq!(by_spot[i], by_point[i], "{what}: inside the inner cone");
                seen[1] += 1;
            } else if cos > cos_outer + 1e-5 && added(&by_point) > 1e-3 {
                let factor = spot_factor(&spot.lights[0], to_light.normalize());
                let ratio = (added(&by_spot) / added(&by_point)) as f64;
                // The target's rounding of each of the three images, relative to each.
                let [s, p, u] = [&by_spot, &by_point, &unlit].map(|f| f[i][0].abs() as f64);
                let stored = target_rounding * (s + u + factor * (p + u)) / added(&by_point) as f64;
                assert!(
                    (ratio - factor).abs() <= slope * 1e-5 + 1e-6 + stored,
                    "{what}: GPU factor {ratio}, closed form {factor}"
                );
                seen[2] += 1;
            }
        }
        assert!(
            seen.iter().all(|&n| n > 20),
            "{name}: {seen:?} outside, inside, between"
        );
    }
}
