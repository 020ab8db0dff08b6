//! The viewer, played by scripts on a virtual display (`xvfb-run`): what it shows is what
//! `render` draws, and it reloads shaders and variant files as they are saved.

use std::path::Path;

use crate::common::{cli, copy_tree, scratch, viewer};
use clusterlab::compose::Composer;

/// Small frames: each run composes, compiles and draws on a software adapter.
const SIZE: &str = "160x90";
const LIGHTS: &str = "64";

fn json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap()
}

/// Play `script` in the viewer with `args`, writing into `out`; its output if it failed.
fn play(script: &str, out: &Path, args: &[&str], env: &[(&str, &str)]) {
    let file = out.join("script.ron");
    std::fs::write(&file, script).unwrap();
    let (code, printed) = crate::common::on_a_display(|| {
        viewer(["--size", SIZE, "--lights", LIGHTS, "--out"])
            .arg(out)
            .arg("--script")
            .arg(&file)
            .args(args)
            .envs(env)
            .run()
            .outcome()
    });
    assert!(code == Some(0), "the viewer failed:\n{printed}");
}

/// Run the `render` command a screenshot's record gives, into `out`.
fn render_as_recorded(record: &serde_json::Value, out: &Path) {
    let command = record["render_command"].as_str().unwrap();
    let args: Vec<&str> = command
        .strip_prefix("clusterlab render ")
        .expect("a render command")
        .split(' ')
        .collect();
    let (ok, printed) = cli(["render"])
        .args(args)
        .arg("--out")
        .arg(out)
        .run()
        .succeeded();
    assert!(ok, "{command} failed:\n{printed}");
}

#[test]
fn a_screenshot_is_the_image_render_draws_for_the_same_state_byte_for_byte() {
    if let Some(why) = crate::common::windows_unavailable() {
        eprintln!("skipped: {why}");
        return;
    }
    for variant in ["forward_plus", "clustered_deferred_16x16x24"] {
        let out = scratch(&format!("view-{variant}"));
        // At the scene's own camera, then flown forward and turned.
        let script = r#"[
            Wait(frames: 1),
            Out("scene"), Screenshot,
            Key(key: "W", frames: 3), Drag(dx: 30, dy: 10),
            Out("flown"), Screenshot, State("state.json"),
            Set(Play(true)), Record(frames: 3),
        ]"#;
        play(script, &out, &["--variant", variant], &[]);
        let stem = format!("{variant}@atrium");
        for (shot, flown) in [("scene", false), ("flown", true)] {
            let dir = out.join(shot);
            let record = json(&dir.join(format!("{stem}.view.json")));
            assert_eq!(
                record["shown_equals_render"], true,
                "{variant} {shot}: {record}"
            );
            let command = record["render_command"].as_str().unwrap();
            assert_eq!(command.contains("--camera"), flown, "{command}");
            let rendered = out.join(format!("{shot}-render"));
            render_as_recorded(&record, &rendered);
            let png = |d: &Path| std::fs::read(d.join(format!("{stem}.png"))).unwrap();
            assert!(
                png(&dir) == png(&rendered),
                "{variant} {shot}: the screenshot is not render's PNG for `{command}`"
            );
            // render's JSON for the same state, beside it: an exact variant's frame is
            // within 1 LSB of the f64 reference (the claim every exact variant meets).
            let report = json(&dir.join(format!("{stem}.json")));
            let max = report["error"]["max_abs_8bit"].as_u64().unwrap();
            assert!(max <= 1, "{report}");
        }
        // A break: the flown frame is another picture, so equal files above mean something.
        let png = |shot: &str| std::fs::read(out.join(shot).join(format!("{stem}.png"))).unwrap();
        assert_ne!(
            png("scene"),
            png("flown"),
            "{variant}: flying changed nothing"
        );
        // Another state is another picture too: a render of the next seed is not the shot.
        let scene_record = json(&out.join(format!("scene/{stem}.view.json")));
        let command = scene_record["render_command"]
            .as_str()
            .unwrap()
            .replace("--seed 1", "--seed 2");
        let reseeded = out.join("reseeded");
        render_as_recorded(&serde_json::json!({ "render_command": command }), &reseeded);
        assert_ne!(
            png("scene"),
            std::fs::read(reseeded.join(format!("{stem}.png"))).unwrap()
        );
        // The recording: three frames of the scene playing, as an animated GIF.
        let gif = std::fs::File::open(out.join(format!("flown/{stem}.view.gif"))).unwrap();
        let decoder = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(gif)).unwrap();
        let frames = image::AnimationDecoder::into_frames(decoder)
            .collect_frames()
            .unwrap();
        assert_eq!(frames.len(), 3);
        assert_ne!(
            frames[0].buffer(),
            frames[2].buffer(),
            "the scene did not play"
        );
        let state = json(&out.join("flown/state.json"));
        assert!(
            state["shown"]["light_evals"].as_u64().unwrap() > 0,
            "{state}"
        );
        std::fs::remove_dir_all(&out).unwrap();
    }
}

#[test]
fn an_edit_shows_the_new_frame_and_a_broken_one_its_place_with_the_last_frame_kept() {
    if let Some(why) = crate::common::windows_unavailable() {
        eprintln!("skipped: {why}");
        return;
    }
    let out = scratch("view-reload");
    let shaders = out.join("shaders");
    copy_tree(Composer::default().shader_root(), &shaders);
    let variant = out.join("mine.ron");
    std::fs::copy("variants/forward_plus.ron", &variant).unwrap();
    let color = shaders.join("common/color.wesl");
    let zslice = shaders.join("clustering/zslice.wesl");
    let script = format!(
        r#"[
            Wait(frames: 1), State("start.json"),
            Edit(file: "{color}", find: "max(hdr * exposure,", replace: "max(hdr * exposure * 0.5,"),
            State("darker.json"),
            Edit(file: "{zslice}", find: "clamp_slice(floor(log(z / near) * f32", replace: "clamp_slice(floor(logg(z / near) * f32"),
            State("broken_shader.json"),
            Edit(file: "{zslice}", find: "logg(", replace: "log("),
            State("mended.json"),
            Edit(file: "{variant}", find: "depth_prepass: true", replace: "depth_prepass: yes"),
            State("broken_variant.json"),
        ]"#,
        color = color.display(),
        zslice = zslice.display(),
        variant = variant.display(),
    );
    let shaders_env = shaders.to_str().unwrap();
    play(
        &script,
        &out,
        &["--variant", variant.to_str().unwrap()],
        &[("CLUSTERLAB_SHADERS", shaders_env)],
    );
    let state = |name: &str| json(&out.join(name));
    let image = |s: &serde_json::Value| s["shown"]["image_sha256"].as_str().unwrap().to_string();
    let (start, darker) = (state("start.json"), state("darker.json"));
    assert!(
        start["error"].is_null() && darker["error"].is_null(),
        "{start}\n{darker}"
    );
    assert_ne!(
        image(&start),
        image(&darker),
        "the tonemap edit changed nothing on screen"
    );
    // The composer's located message, and the last good frame still shown.
    let broken = state("broken_shader.json");
    let message = broken["error"].as_str().expect("a shader error shown");
    assert!(
        message.contains("zslice.wesl:22:30: no definition in scope for identifier: `logg`"),
        "{message}"
    );
    assert_eq!(
        image(&broken),
        image(&darker),
        "the broken edit lost the last frame"
    );
    let mended = state("mended.json");
    assert!(mended["error"].is_null(), "{mended}");
    assert_eq!(image(&mended), image(&darker));
    let broken = state("broken_variant.json");
    let message = broken["error"].as_str().expect("a variant error shown");
    assert!(
        message.contains("mine.ron:8:") && message.contains("depth_prepass: yes"),
        "{message}"
    );
    assert_eq!(image(&broken), image(&darker));
    // Nothing but the files the script named was touched: the shipped shaders are as they were.
    let shipped =
        std::fs::read_to_string(Composer::default().shader_root().join("common/color.wesl"))
            .unwrap();
    assert!(shipped.contains("max(hdr * exposure, vec3"));
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn without_a_display_the_viewer_says_so_in_one_line_and_names_xvfb_run() {
    let ran = cli(["view"])
        .env("DISPLAY", "")
        .env("WAYLAND_DISPLAY", "")
        .run();
    let (code, printed) = ran.outcome();
    assert_eq!(code, Some(1), "{printed}");
    assert_eq!(printed.trim().lines().count(), 1, "{printed}");
    assert!(printed.contains("xvfb-run"), "{printed}");
    // Every other command needs no display.
    let (ok, printed) = cli(["validate", "variants/forward_plus.ron"])
        .env("DISPLAY", "")
        .env("WAYLAND_DISPLAY", "")
        .run()
        .succeeded();
    assert!(ok, "{printed}");
}
