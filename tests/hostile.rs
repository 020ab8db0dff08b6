//! The hostile-input suite: what a new user's slip or a hostile file could make a command do
//! that no user would forgive. Each case runs the binary in a sandbox folder this test makes
//! (never the project's own tree), with the user's files in it, and asserts the exit code,
//! the exact message where it is the point (snapshots/errors/hostile_*.snap) and that every
//! file outside what the run may write is byte-identical afterwards (links and pipes
//! included).
//!
//! `CLUSTERLAB_UNDER_TEST=PATH` runs the cases against another build of the binary: the code
//! before a fix, to see them fail on it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::common::{self, cli, scratch};

use clusterlab::scene::{self, export::to_glb};
use serde_json::{Value, json};

/// What the sandbox holds at a path: a file's bytes, a folder, a link's target, a pipe.
#[derive(Clone, Debug, PartialEq)]
enum Entry {
    File(Vec<u8>),
    Folder,
    Link(PathBuf),
    Other(String),
}

/// A folder of a user's: a project with sources, notes and variant files, and a secret file
/// beside it that no command was given.
struct Sandbox {
    root: PathBuf,
}

/// Bytes no command may read: a glTF buffer that refers to this file must not get its bytes
/// (it is a valid buffer, so a reader that follows the reference renders with it).
const SECRET: &[u8] = b"SECRET-BYTES-";

impl Sandbox {
    fn new(case: &str) -> Sandbox {
        let root = std::fs::canonicalize(scratch(case)).unwrap();
        let s = Sandbox { root };
        s.write("project/src/main.rs", b"fn main() {}\n");
        s.write("project/src/lib.rs", b"pub fn thesis() {}\n");
        s.write("project/notes/todo.md", b"- finish chapter 3\n");
        s.write("project/home.txt", b"my notes\n");
        for v in ["forward_plus", "naive_forward"] {
            let text = std::fs::read(format!("variants/{v}.ron")).unwrap();
            s.write(&format!("project/variants/{v}.ron"), &text);
        }
        s
    }

    fn path(&self, rel: &str) -> PathBuf {
        self.root.join(rel)
    }

    fn write(&self, rel: &str, bytes: &[u8]) {
        let p = self.path(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, bytes).unwrap();
    }

    fn link(&self, rel: &str, target: &str) {
        std::os::unix::fs::symlink(target, self.path(rel)).unwrap();
    }

    fn fifo(&self, rel: &str) {
        let p = std::ffi::CString::new(self.path(rel).to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(
            unsafe { libc::mkfifo(p.as_ptr(), 0o644) },
            0,
            "mkfifo {rel}"
        );
    }

    /// Every path under the root and what is there, links not followed.
    fn tree(&self) -> BTreeMap<PathBuf, Entry> {
        fn walk(dir: &Path, root: &Path, out: &mut BTreeMap<PathBuf, Entry>) {
            for e in std::fs::read_dir(dir).unwrap() {
                let path = e.unwrap().path();
                let rel = path.strip_prefix(root).unwrap().to_path_buf();
                let meta = std::fs::symlink_metadata(&path).unwrap();
                let kind = meta.file_type();
                let entry = if kind.is_symlink() {
                    Entry::Link(std::fs::read_link(&path).unwrap())
                } else if kind.is_dir() {
                    walk(&path, root, out);
                    Entry::Folder
                } else if kind.is_file() {
                    Entry::File(std::fs::read(&path).unwrap())
                } else {
                    Entry::Other(format!("{kind:?}"))
                };
                out.insert(rel, entry);
            }
        }
        let mut out = BTreeMap::new();
        walk(&self.root, &self.root, &mut out);
        out
    }

    /// Run the binary in `cwd` (relative to the root): its exit code and everything it
    /// printed, with the sandbox's path shown as `SANDBOX`.
    fn run(&self, cwd: &str, args: &[&str], env: &[(&str, &str)]) -> (Option<i32>, String) {
        let (code, text) = cli(args).dir(self.path(cwd)).envs(env).run().outcome();
        (code, text.replace(self.root.to_str().unwrap(), "SANDBOX"))
    }
}

impl Drop for Sandbox {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

/// The paths that differ between two trees, outside `allowed` (paths relative to the root
/// under which a run may write).
fn changes(
    before: &BTreeMap<PathBuf, Entry>,
    after: &BTreeMap<PathBuf, Entry>,
    allowed: &[&str],
) -> Vec<String> {
    let free = |p: &Path| allowed.iter().any(|a| p.starts_with(a));
    let mut out = Vec::new();
    for (p, e) in before {
        match after.get(p) {
            _ if free(p) => {}
            None => out.push(format!("{} removed", p.display())),
            Some(now) if now != e => out.push(format!("{} changed", p.display())),
            _ => {}
        }
    }
    for p in after.keys() {
        if !before.contains_key(p) && !free(p) {
            out.push(format!("{} created", p.display()));
        }
    }
    out
}

/// One hostile case.
struct Case {
    name: &'static str,
    /// Working folder, relative to the sandbox root.
    cwd: &'static str,
    args: Vec<String>,
    env: Vec<(&'static str, String)>,
    code: i32,
    /// Paths the run may create or change (its own result folder), relative to the root.
    allowed: Vec<&'static str>,
    /// The whole message, snapshotted; else only these must be in it.
    snapshot: bool,
    expect: Vec<&'static str>,
    /// Run `clusterlab view ARGS` on a display (`common::viewer`) instead.
    in_viewer: bool,
}

impl Case {
    fn new(name: &'static str, args: &[&str], code: i32) -> Case {
        Case {
            name,
            cwd: "project",
            args: args.iter().map(|s| s.to_string()).collect(),
            env: Vec::new(),
            code,
            allowed: Vec::new(),
            snapshot: true,
            expect: Vec::new(),
            in_viewer: false,
        }
    }
    /// Run `clusterlab view` with the case's arguments, on a display.
    fn in_viewer(mut self) -> Case {
        self.in_viewer = true;
        self
    }
    fn cwd(mut self, cwd: &'static str) -> Case {
        self.cwd = cwd;
        self
    }
    fn env(mut self, key: &'static str, value: impl Into<String>) -> Case {
        self.env.push((key, value.into()));
        self
    }
    fn allow(mut self, path: &'static str) -> Case {
        self.allowed.push(path);
        self
    }
    /// Check only that the output holds `text` (output with times in it, or an adapter's).
    fn expect(mut self, text: &'static str) -> Case {
        self.snapshot = false;
        self.expect.push(text);
        self
    }

    /// Run in `s` and check it, recording a failure (see [`report`]) so that every case runs.
    fn check(&self, s: &Sandbox) {
        let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.check_now(s)));
        if let Err(panic) = run {
            let why = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            FAILED.with(|f| f.borrow_mut().push(format!("{}: {why}", self.name)));
        }
    }

    /// Run in `s`: exit code, message, and nothing outside `allowed` touched.
    fn check_now(&self, s: &Sandbox) {
        let before = s.tree();
        let args: Vec<&str> = self.args.iter().map(String::as_str).collect();
        let env: Vec<(&str, &str)> = self.env.iter().map(|(k, v)| (*k, v.as_str())).collect();
        let (code, text) = if self.in_viewer {
            let (code, text) = play_viewer(&s.path(self.cwd), &args, &env);
            (code, text.replace(s.root.to_str().unwrap(), "SANDBOX"))
        } else {
            s.run(self.cwd, &args, &env)
        };
        let name = self.name;
        assert_eq!(
            code,
            Some(self.code),
            "{name}: `clusterlab {}`:\n{text}",
            args.join(" ")
        );
        let changed = changes(&before, &s.tree(), &self.allowed);
        assert!(
            changed.is_empty(),
            "{name}: the run touched what was not its own: {changed:?}\n{text}"
        );
        assert!(!text.contains("panicked"), "{name}: {text}");
        assert!(
            !text.as_bytes().windows(SECRET.len()).any(|w| w == SECRET),
            "{name}: the output holds bytes of a file no one named: {text}"
        );
        if self.snapshot {
            let mut settings = insta::Settings::clone_current();
            settings.set_snapshot_path("../snapshots/errors");
            settings.set_prepend_module_to_snapshot(false);
            settings.bind(|| insta::assert_snapshot!(format!("hostile_{name}"), text));
        }
        for e in &self.expect {
            assert!(text.contains(e), "{name}: `{e}` is not in:\n{text}");
        }
    }
}

thread_local! {
    /// The cases of this test that failed so far.
    static FAILED: std::cell::RefCell<Vec<String>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Fail the test when any of its cases failed, naming every one.
fn report() {
    let failed = FAILED.with(|f| f.take());
    assert!(
        failed.is_empty(),
        "{} cases failed:\n\n{}",
        failed.len(),
        failed.join("\n\n")
    );
}

/// A tiny matrix run's arguments: one variant on one_light at 16x9, one frame.
fn tiny_matrix(out: &str) -> Vec<&str> {
    vec![
        "matrix",
        "--variants",
        "variants/forward_plus.ron",
        "--scenes",
        "one_light",
        "--size",
        "16x9",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--out",
        out,
    ]
}

fn case(name: &'static str, args: &[&str], code: i32) -> Case {
    Case::new(name, args, code)
}

/// What a case puts in its sandbox first.
type Setup = fn(&Sandbox);

/// Run `check` on each case in a fresh sandbox prepared by `setup`.
fn run_all(cases: Vec<(Case, Setup)>) {
    for (c, setup) in cases {
        let s = Sandbox::new(c.name);
        setup(&s);
        c.check(&s);
    }
}

fn nothing(_: &Sandbox) {}

#[test]
fn no_command_replaces_moves_or_deletes_what_it_did_not_make() {
    let out_into = |name, out: &'static str| case(name, &tiny_matrix(out), 1);
    // From project/notes, whose variant files are one folder up.
    let from_notes = |name, out: &'static str| {
        let mut args = tiny_matrix(out);
        args[2] = "../variants/forward_plus.ron";
        case(name, &args, 1).cwd("project/notes")
    };
    run_all(vec![
        (out_into("out_is_a_source_folder", "src"), nothing),
        (out_into("out_is_the_variants_folder", "variants"), nothing),
        (out_into("out_is_a_folder_of_notes", "notes"), nothing),
        (out_into("out_is_a_file", "home.txt"), nothing),
        (out_into("out_is_a_link", "link"), |s| {
            s.link("project/link", "notes")
        }),
        (
            from_notes("out_is_above_the_working_folder", "../../project"),
            nothing,
        ),
        (from_notes("out_is_the_working_folder", "../notes"), nothing),
        (out_into("out_lock_is_a_users_file", "out"), |s| {
            s.write("project/out.lock", b"mine\n")
        }),
        // A user's folders that look like a dead run's leftovers stay; the run succeeds.
        (
            case("leftover_look_alikes_are_kept", &tiny_matrix("out"), 0)
                .allow("project/out")
                .allow("project/out.lock")
                .expect("cells on"),
            |s| {
                // A lock left by a clusterlab process that is gone (pid_max is at most 2^22):
                // the next run takes it over, and undoes only what that process marked.
                let lock = "clusterlab lock\nprocess 4194321\ncommand clusterlab matrix\n";
                s.write("project/out.lock", lock.as_bytes());
                s.write("project/out.staging-4194321/thesis.tex", b"chapter 1\n");
                s.write("project/out.old-4194321/results.json", b"{}\n");
                s.write("project/out.lock-4194321", b"mine\n");
            },
        ),
        (
            case(
                "merge_out_is_a_folder_of_notes",
                &["merge", "shard", "--out", "notes"],
                1,
            ),
            make_shard,
        ),
        (
            case(
                "export_onto_a_pipe",
                &["scenes", "--export", "one_light", "pipe.glb"],
                1,
            ),
            |s| s.fifo("project/pipe.glb"),
        ),
        (
            case(
                "export_onto_a_folder",
                &["scenes", "--export", "one_light", "notes"],
                1,
            ),
            nothing,
        ),
        (
            case(
                "export_onto_a_link",
                &["scenes", "--export", "one_light", "link.glb"],
                1,
            ),
            |s| s.link("project/link.glb", "home.txt"),
        ),
        // A study writes only into a folder studies wrote, and checks every target first.
        (
            case(
                "study_out_holds_a_users_scale_csv",
                &[
                    "study", "scale", "--lights", "64", "--size", "32x18", "--out", "notes",
                ],
                1,
            ),
            |s| s.write("project/notes/scale.csv", b"my own table\n"),
        ),
        (
            case(
                "study_target_is_a_link",
                &[
                    "study", "scale", "--lights", "64", "--size", "32x18", "--out", "studies",
                ],
                1,
            )
            .expect("as a link or folder"),
            |s| {
                s.write(
                    "project/studies/.clusterlab-study",
                    b"clusterlab studies\nprocess 1\n",
                );
                s.link("project/studies/scale.md", "../home.txt");
            },
        ),
        (
            case(
                "render_image_onto_a_folder",
                &[
                    "render",
                    "--variant",
                    "variants/forward_plus.ron",
                    "--scene",
                    "one_light",
                    "--size",
                    "16x9",
                    "--out",
                    "pictures",
                ],
                1,
            )
            .expect("exists and is a folder"),
            |s| {
                std::fs::create_dir_all(s.path("project/pictures/forward_plus@one_light.png"))
                    .unwrap()
            },
        ),
    ]);
    report();
}

/// `merge` copies only images inside a shard's own `images/`, regular files, named as a run
/// names them.
#[test]
fn merge_copies_nothing_from_outside_a_shard() {
    run_all(vec![
        (
            case(
                "merge_image_path_leaves_the_shard",
                &["merge", "shard", "--out", "merged"],
                1,
            ),
            |s| {
                make_shard(s);
                s.write("victim.txt", b"keep me\n");
                edit_results(s, |r| {
                    r["cells"][0]["images"]["image"] = "../../victim.txt".into()
                });
            },
        ),
        (
            case(
                "merge_image_path_is_absolute",
                &["merge", "shard", "--out", "merged"],
                1,
            ),
            |s| {
                make_shard(s);
                edit_results(s, |r| {
                    r["cells"][0]["images"]["heat"] = "/etc/hostname".into()
                });
            },
        ),
        (
            case(
                "merge_image_is_a_link_out",
                &["merge", "shard", "--out", "merged"],
                1,
            ),
            |s| {
                make_shard(s);
                let image = image_of(s);
                std::fs::remove_file(s.path(&format!("project/shard/{image}"))).unwrap();
                s.write("secret.png", SECRET);
                s.link(&format!("project/shard/{image}"), "../../../secret.png");
            },
        ),
    ]);
    report();
}

#[test]
fn gltf_files_are_read_only_from_their_own_folder() {
    let uri = |name: &'static str, uri: &'static str| {
        (case(name, &render_args("scene/scene.gltf"), 1), uri)
    };
    for (c, buffer_uri) in [
        uri("gltf_buffer_absolute", "ABSOLUTE"),
        uri("gltf_buffer_dotdot", "../../secret.bin"),
        uri(
            "gltf_buffer_percent_encoded_dotdot",
            "%2E%2E/%2e%2e/secret.bin",
        ),
        uri("gltf_buffer_file_url", "file:///etc/hostname"),
        uri("gltf_buffer_link_out", "link.bin"),
        uri("gltf_buffer_backslash", "..\\..\\secret.bin"),
    ] {
        let s = Sandbox::new(c.name);
        let (json, bin) = gltf_parts();
        // The secret is a valid buffer: a reader that follows the URI would render with it.
        let mut secret = bin.clone();
        secret.extend_from_slice(SECRET);
        s.write("secret.bin", &secret);
        s.write("project/scene/scene.bin", &bin);
        s.link("project/scene/link.bin", "../../secret.bin");
        let uri = buffer_uri.replace("ABSOLUTE", s.path("secret.bin").to_str().unwrap());
        let mut json = json;
        json["buffers"][0]["uri"] = uri.into();
        s.write(
            "project/scene/scene.gltf",
            &serde_json::to_vec(&json).unwrap(),
        );
        c.check(&s);
    }
    // An image outside, behind a texture of the plane's material.
    let s = Sandbox::new("gltf_image_dotdot");
    let (mut json, bin) = gltf_parts();
    json["images"] = json!([{ "uri": "../../secret.png" }]);
    json["textures"] = json!([{ "source": 0 }]);
    json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({ "index": 0 });
    s.write("secret.png", SECRET);
    write_gltf(&s, &json, &bin);
    case("gltf_image_dotdot", &render_args("scene/scene.gltf"), 1).check(&s);
    report();
}

/// A glTF file's parts: the one_light scene (a plane, a light, a moving camera) exported,
/// its JSON with the buffer as `scene.bin` beside it, and the buffer.
fn gltf_parts() -> (Value, Vec<u8>) {
    let params = scene::find_scene("one_light").unwrap().defaults;
    let (mut json, bin) =
        common::split_glb(&to_glb(&scene::generate("one_light", params).unwrap()).unwrap());
    json["buffers"][0]["uri"] = "scene.bin".into();
    (json, bin)
}

fn write_gltf(s: &Sandbox, json: &Value, bin: &[u8]) {
    s.write(
        "project/scene/scene.gltf",
        &serde_json::to_vec(json).unwrap(),
    );
    s.write("project/scene/scene.bin", bin);
}

fn render_args(scene: &str) -> Vec<&str> {
    vec![
        "render",
        "--variant",
        "variants/forward_plus.ron",
        "--scene",
        scene,
        "--size",
        "16x9",
        "--out",
        "out",
    ]
}

/// Write float `v` at the first element of accessor `a` in the buffer.
fn poke(json: &Value, bin: &mut [u8], a: usize, v: f32) {
    let view = &json["bufferViews"][json["accessors"][a]["bufferView"].as_u64().unwrap() as usize];
    let at = view["byteOffset"].as_u64().unwrap_or(0) as usize;
    bin[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

/// The accessor of the plane's attribute `name`.
fn attribute(json: &Value, name: &str) -> usize {
    json["meshes"][0]["primitives"][0]["attributes"][name]
        .as_u64()
        .unwrap() as usize
}

/// The accessor of the camera animation's first channel's values.
fn animation_values(json: &Value) -> usize {
    let sampler = &json["animations"][0]["samplers"][0];
    sampler["output"].as_u64().unwrap() as usize
}

#[test]
fn no_meaningless_frame_passes_as_a_result() {
    type Edit = fn(&mut Value, &mut Vec<u8>);
    let cases: Vec<(&'static str, Edit)> = vec![
        ("gltf_camera_yfov_zero", |j, _| {
            j["cameras"][0]["perspective"]["yfov"] = 0.0.into()
        }),
        ("gltf_camera_yfov_pi", |j, _| {
            j["cameras"][0]["perspective"]["yfov"] = std::f64::consts::PI.into()
        }),
        ("gltf_camera_znear_zero", |j, _| {
            j["cameras"][0]["perspective"]["znear"] = 0.0.into()
        }),
        ("gltf_camera_zfar_before_znear", |j, _| {
            j["cameras"][0]["perspective"]["zfar"] = 0.01.into()
        }),
        ("gltf_camera_znear_beyond_the_scene", |j, _| {
            j["cameras"][0]["perspective"]["znear"] = 1e4.into();
            j["cameras"][0]["perspective"]
                .as_object_mut()
                .unwrap()
                .remove("zfar");
        }),
        ("gltf_animation_key_nan", |j, b| {
            poke(j, b, animation_values(j), f32::NAN)
        }),
        ("gltf_animation_key_huge", |j, b| {
            for k in 0..6 {
                let view = &j["bufferViews"][j["accessors"][animation_values(j)]["bufferView"]
                    .as_u64()
                    .unwrap() as usize];
                let at = view["byteOffset"].as_u64().unwrap() as usize + 4 * k;
                b[at..at + 4].copy_from_slice(&3e38f32.to_le_bytes());
            }
        }),
        ("gltf_position_nan", |j, b| {
            poke(j, b, attribute(j, "POSITION"), f32::NAN)
        }),
        ("gltf_colour_nan", |j, b| {
            poke(j, b, attribute(j, "COLOR_0"), f32::NAN)
        }),
        ("gltf_normal_infinite", |j, b| {
            poke(j, b, attribute(j, "NORMAL"), f32::INFINITY)
        }),
        ("gltf_indices_of_floats", |j, _| {
            let a = j["meshes"][0]["primitives"][0]["indices"].as_u64().unwrap() as usize;
            j["accessors"][a]["componentType"] = 5126.into();
        }),
        ("gltf_light_range_huge", |j, _| {
            light(j)["range"] = 1e30.into()
        }),
        ("gltf_light_range_zero", |j, _| {
            light(j)["range"] = 0.0.into()
        }),
        ("gltf_light_intensity_negative", |j, _| {
            light(j)["intensity"] = (-1.0).into()
        }),
        ("gltf_light_colour_negative", |j, _| {
            light(j)["color"] = json!([1.0, -0.5, 1.0])
        }),
        ("gltf_spot_outer_too_wide", |j, _| {
            light(j)["type"] = "spot".into();
            light(j)["spot"] = json!({ "innerConeAngle": 0.1, "outerConeAngle": 2.0 });
        }),
        ("gltf_spot_inner_past_outer", |j, _| {
            light(j)["type"] = "spot".into();
            light(j)["spot"] = json!({ "innerConeAngle": 0.8, "outerConeAngle": 0.5 });
        }),
        // Rendered, then failed: the camera sees no geometry; the image has infinite pixels.
        ("gltf_camera_looks_away", |j, _| {
            // Straight up, at the sky above the plane.
            j["nodes"][1]["rotation"] = json!([
                std::f64::consts::FRAC_1_SQRT_2,
                0.0,
                0.0,
                std::f64::consts::FRAC_1_SQRT_2
            ]);
            j.as_object_mut().unwrap().remove("animations");
        }),
        ("gltf_lights_overflow_single_precision", |j, _| {
            overflowing_lights(j)
        }),
    ];
    // These render, then fail: their output holds times, so only the reason is checked.
    let rendered = [
        (
            "gltf_camera_looks_away",
            "FAILED: variant `forward_plus` on scene `scene/scene.gltf`: no geometry is in view",
        ),
        (
            "gltf_lights_overflow_single_precision",
            "FAILED: variant `forward_plus` on scene `scene/scene.gltf`: 2 pixels of the image are NaN or infinite",
        ),
    ];
    for (name, edit) in cases {
        let s = Sandbox::new(name);
        let (mut json, mut bin) = gltf_parts();
        edit(&mut json, &mut bin);
        write_gltf(&s, &json, &bin);
        let mut c = case(name, &render_args("scene/scene.gltf"), 1).allow("project/out");
        if let Some((_, reason)) = rendered.iter().find(|(n, _)| *n == name) {
            c = c.expect(reason);
        }
        c.check(&s);
    }
    // The cell fails in the matrix too, with its NaN pixels in their column, and the other
    // cells run.
    let s = Sandbox::new("matrix_nan_cell");
    let (mut json, bin) = gltf_parts();
    overflowing_lights(&mut json);
    write_gltf(&s, &json, &bin);
    let mut args = tiny_matrix("out");
    args[4] = "scene/scene.gltf,one_light";
    case("matrix_nan_cell", &args, 1)
        .allow("project/out")
        .expect("FAILED: 2 pixels of the image are NaN or infinite")
        .expect("NaN px")
        .check(&s);
    let results: Value =
        serde_json::from_slice(&std::fs::read(s.path("project/out/results.json")).unwrap())
            .unwrap();
    let failed: Vec<&str> = results["cells"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| !c["failure"].is_null())
        .map(|c| c["id"].as_str().unwrap())
        .collect();
    assert_eq!(
        failed,
        [
            "forward_plus@scene/scene.gltf",
            "naive_forward@scene/scene.gltf"
        ]
    );
    // A radius beyond what single precision holds through the cluster tests is refused.
    let s = Sandbox::new("radius_over_the_limit");
    let mut args = render_args("one_light");
    args.extend(["--radius", "2e18,2e18"]);
    case("radius_over_the_limit", &args, 2).check(&s);
    report();
}

/// Eight lights of intensity 3.4e38 at one place: their sum overflows single precision.
fn overflowing_lights(json: &mut Value) {
    light(json)["intensity"] = 3.4e38.into();
    light(json)["range"] = 100.0.into();
    for _ in 0..7 {
        let n = json["nodes"].as_array().unwrap().len();
        json["nodes"].as_array_mut().unwrap().push(json!({
            "translation": [0.0, 1.5, 0.0],
            "extensions": { "KHR_lights_punctual": { "light": 0 } },
        }));
        json["scenes"][0]["nodes"]
            .as_array_mut()
            .unwrap()
            .push(n.into());
    }
}

fn light(json: &mut Value) -> &mut Value {
    &mut json["extensions"]["KHR_lights_punctual"]["lights"][0]
}

/// A result folder `project/shard` from a tiny matrix run.
fn make_shard(s: &Sandbox) {
    let (code, text) = s.run("project", &tiny_matrix("shard"), &[]);
    assert_eq!(code, Some(0), "{text}");
}

fn edit_results(s: &Sandbox, edit: impl FnOnce(&mut Value)) {
    let path = s.path("project/shard/results.json");
    let mut r: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    edit(&mut r);
    std::fs::write(path, serde_json::to_vec_pretty(&r).unwrap()).unwrap();
}

/// The first image of the shard's first cell.
fn image_of(s: &Sandbox) -> String {
    let r: Value =
        serde_json::from_slice(&std::fs::read(s.path("project/shard/results.json")).unwrap())
            .unwrap();
    r["cells"][0]["images"]["image"]
        .as_str()
        .unwrap()
        .to_string()
}

#[test]
fn merge_and_baseline_refuse_figures_no_run_could_write() {
    type Edit = fn(&mut Value);
    let cases: Vec<(&'static str, Edit)> = vec![
        ("merge_negative_time", |r| {
            r["cells"][0]["gpu_ms"]["total"] = (-0.5).into()
        }),
        ("merge_huge_time", |r| {
            r["cells"][0]["gpu_ms"]["total"] = 1e308.into()
        }),
        ("merge_spread_reversed", |r| {
            r["cells"][0]["gpu_ms_spread"]["total"] = json!([5.0, 1.0])
        }),
        ("merge_useful_over_performed", |r| {
            let evals = r["cells"][0]["stats"]["light_evals"].as_u64().unwrap();
            r["cells"][0]["stats"]["useful_light_evals"] = (evals + 1).into();
        }),
        ("merge_flip_over_one", |r| {
            r["cells"][0]["error"]["flip_mean"] = 1.5.into()
        }),
        // Figures that fail a cell, recorded as passing: pass or fail is derived from the
        // figures, never taken as written.
        ("merge_exact_cell_at_200_lsb", |r| {
            r["cells"][0]["error"]["max_abs_8bit"] = 200.into()
        }),
        ("merge_nan_pixels_passing", |r| {
            r["cells"][0]["error"]["nan_pixels"] = 3.into()
        }),
        ("merge_error_null", |r| r["cells"][0]["error"] = Value::Null),
        ("merge_efficiency_above_one", |r| {
            r["cells"][0]["efficiency"] = json!({
                "frame_without_lights_ms": 0.5, "ns_per_evaluation": 1.0,
                "ns_per_useful_evaluation": 1.0, "bound_ms": 2.0, "efficiency": 2.0,
                "spread": [2.0, 2.0], "within_noise": false, "bound_above_frame": false
            });
            r["cells"][0]["gpu_ms"]["total"] = 1.0.into();
        }),
        ("merge_run_out_of_range", |r| {
            r["cells"][0]["run"] = 7.into()
        }),
        ("merge_no_provenance", |r| r["provenance"] = json!([])),
        ("merge_no_cells", |r| r["cells"] = json!([])),
    ];
    for (name, edit) in cases {
        let s = Sandbox::new(name);
        make_shard(&s);
        edit_results(&s, edit);
        case(name, &["merge", "shard", "--out", "merged"], 1).check(&s);
    }
    // The same records are refused by `--reuse`, which would serve them as this run's.
    let s = Sandbox::new("reuse_exact_cell_at_200_lsb");
    make_shard(&s);
    edit_results(&s, |r| r["cells"][0]["error"]["max_abs_8bit"] = 200.into());
    let mut args = tiny_matrix("again");
    args.extend(["--reuse", "shard"]);
    case("reuse_exact_cell_at_200_lsb", &args, 1)
        .expect("`error.max_abs_8bit`")
        .check(&s);
    // A sequence marked exact at 200 LSB.
    let s = Sandbox::new("merge_sequence_exact_at_200_lsb");
    let (code, text) = s.run("project", &tiny_sequence_matrix("shard"), &[]);
    assert_eq!(code, Some(0), "{text}");
    edit_results(&s, |r| {
        r["cells"][0]["sequence_summary"]["max_abs_8bit"] = 200.into();
        r["cells"][0]["sequence_summary"]["exact"] = true.into();
    });
    case(
        "merge_sequence_exact_at_200_lsb",
        &["merge", "shard", "--out", "merged"],
        1,
    )
    .check(&s);
    let s = Sandbox::new("baseline_negative_time");
    make_shard(&s);
    edit_results(&s, |r| r["cells"][0]["wall_ms"] = (-1.0).into());
    let mut args = tiny_matrix("again");
    args.extend(["--baseline", "shard"]);
    case("baseline_negative_time", &args, 1).check(&s);
    report();
}

#[test]
fn two_cells_never_share_an_id() {
    // The user's own naive_forward.ron, with bloom: not a speed-up baseline, so the matrix
    // adds one, which must not take the user's cell's id and image.
    let s = Sandbox::new("users_naive_forward");
    let mine = "(description: \"my naive forward, with bloom\", pipeline: NaiveForward, \
                post: (bloom: (threshold: 0.6, radius: 8, kernel: Separable)))";
    s.write("project/mine/naive_forward.ron", mine.as_bytes());
    let args = [
        "matrix",
        "--variants",
        "mine/naive_forward.ron",
        "--scenes",
        "one_light",
        "--size",
        "16x9",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--out",
        "out",
    ];
    case("users_naive_forward", &args, 0)
        .allow("project/out")
        .expect("2 cells")
        .check(&s);
    let r: Value =
        serde_json::from_slice(&std::fs::read(s.path("project/out/results.json")).unwrap())
            .unwrap();
    let ids: Vec<&str> = r["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["id"].as_str().unwrap())
        .collect();
    assert_eq!(
        ids,
        [
            "naive_forward@one_light",
            "baseline-naive_forward@one_light"
        ]
    );
    let images: std::collections::BTreeSet<&str> = r["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["images"]["image"].as_str().unwrap())
        .collect();
    assert_eq!(images.len(), 2, "{images:?}");
    report();
}

#[test]
fn no_read_is_unbounded_or_blocks() {
    run_all(vec![
        (
            case(
                "matrix_variants_from_a_device",
                &tiny_matrix_with_variants("/dev/zero"),
                1,
            )
            .allow("project/out")
            .expect("/dev/zero: not a regular file"),
            nothing,
        ),
        (
            case(
                "merge_results_from_a_device",
                &["merge", "shard", "/dev/zero", "--out", "merged"],
                1,
            ),
            make_shard,
        ),
        (
            case("baseline_from_a_device", &baseline_args("/dev/zero"), 1),
            nothing,
        ),
        (
            case("variant_from_a_pipe", &["validate", "pipe.ron"], 1),
            |s| s.fifo("project/pipe.ron"),
        ),
        (
            case(
                "results_from_a_pipe",
                &["merge", "pipe", "--out", "merged"],
                1,
            ),
            |s| {
                std::fs::create_dir_all(s.path("project/pipe")).unwrap();
                s.fifo("project/pipe/results.json");
            },
        ),
        (
            case("baseline_from_a_pipe", &baseline_args("pipe.json"), 1),
            |s| s.fifo("project/pipe.json"),
        ),
        (
            case("scene_from_a_pipe", &render_args("pipe.glb"), 1),
            |s| s.fifo("project/pipe.glb"),
        ),
        (
            case(
                "gltf_buffer_from_a_pipe",
                &render_args("scene/scene.gltf"),
                1,
            ),
            |s| {
                let (mut json, _) = gltf_parts();
                json["buffers"][0]["uri"] = "pipe.bin".into();
                s.write(
                    "project/scene/scene.gltf",
                    &serde_json::to_vec(&json).unwrap(),
                );
                s.fifo("project/scene/pipe.bin");
            },
        ),
        (
            case(
                "shader_module_from_a_pipe",
                &["validate", "variants/forward_plus.ron"],
                1,
            )
            .env("CLUSTERLAB_SHADERS", "shaders")
            .expect("shaders/common/view.wesl: not a regular file"),
            |s| {
                common::copy_tree(Path::new("shaders"), &s.path("project/shaders"));
                let module = s.path("project/shaders/common/view.wesl");
                std::fs::remove_file(&module).unwrap();
                s.fifo("project/shaders/common/view.wesl");
            },
        ),
    ]);
    report();
}

fn tiny_matrix_with_variants(variants: &'static str) -> Vec<&'static str> {
    let mut args = tiny_matrix("out");
    args[2] = variants;
    args
}

fn baseline_args(baseline: &'static str) -> Vec<&'static str> {
    let mut args = tiny_matrix("out");
    args.extend(["--baseline", baseline]);
    args
}

#[test]
fn bad_input_is_named_with_what_would_be_valid() {
    run_all(vec![
        (
            case(
                "variant_with_a_byte_order_mark",
                &["validate", "bom.ron"],
                1,
            ),
            |s| s.write("project/bom.ron", b"\xEF\xBB\xBF(pipeline: NaiveForward)"),
        ),
        (
            case("variant_not_utf8", &["validate", "latin1.ron"], 1),
            |s| {
                s.write(
                    "project/latin1.ron",
                    b"(description: \"caf\xE9\",\n pipeline: NaiveForward)",
                )
            },
        ),
        (
            case(
                "variant_link_loop_in_validate",
                &["validate", "loop.ron"],
                1,
            ),
            |s| s.link("project/loop.ron", "loop.ron"),
        ),
        (
            case(
                "variant_link_loop_in_render",
                &render_args_variant("loop.ron"),
                1,
            ),
            |s| s.link("project/loop.ron", "loop.ron"),
        ),
        (
            case("variant_integer_out_of_range", &["validate", "big.ron"], 1),
            |s| {
                s.write(
                    "project/big.ron",
                    b"(pipeline: ClusteredForward, clusters: (grid: (4294967296, 9, 24)))",
                )
            },
        ),
        (
            case("sweep_radius_zero", &["matrix", "--sweep", "radius=0"], 2),
            nothing,
        ),
        (
            case(
                "shard_with_no_cells",
                &[
                    "matrix",
                    "--variants",
                    "variants/forward_plus.ron",
                    "--scenes",
                    "one_light",
                    "--shard",
                    "3/3",
                ],
                1,
            ),
            nothing,
        ),
        (
            case("env_max_buffer_size_not_a_number", &["adapters"], 1)
                .env("CLUSTERLAB_MAX_BUFFER_SIZE", "64k"),
            nothing,
        ),
        (
            case("env_software_gpu_threads_not_a_number", &["adapters"], 1)
                .env("LP_NUM_THREADS", "many"),
            nothing,
        ),
        (
            case("env_shaders_not_a_folder", &["validate"], 1)
                .env("CLUSTERLAB_SHADERS", "home.txt"),
            nothing,
        ),
    ]);
    // A square as large as the adapter's textures: over its storage binding or buffer limit
    // on the adapters of this machine, and then refused with the largest that fits; on an
    // adapter that holds it, one pixel wider is refused for its side instead.
    let (side, fits) = largest_texture_frame();
    let size = if fits {
        format!("{}x{side}", side + 1)
    } else {
        format!("{side}x{side}")
    };
    let args = [
        "render",
        "--variant",
        "variants/naive_forward.ron",
        "--scene",
        "one_light",
        "--size",
        &size,
    ];
    let mut c = case("size_over_the_adapters_limits", &args, 1).expect("(`--size`)");
    if !fits {
        c = c.expect("the largest frame of this shape that fits is");
    }
    c.check(&Sandbox::new("size_over_the_adapters_limits"));
    report();
}

/// The chosen adapter's largest texture side, and whether a square frame of that side fits
/// its storage binding (4 bytes a pixel of counters) and buffer (16 bytes a pixel read back,
/// rows padded to 256 bytes): `clusterlab adapters --json`.
fn largest_texture_frame() -> (u64, bool) {
    let out = cli(["adapters", "--json"]).run();
    let survey: Value = serde_json::from_str(&out.stdout).unwrap();
    let a = &survey["adapters"][survey["chosen"].as_u64().unwrap() as usize];
    let number = |key: &str| a[key].as_u64().unwrap_or_else(|| panic!("{key}: {a}"));
    let (side, buffer) = (number("max_texture_side"), number("max_buffer_bytes"));
    let storage = number("max_storage_buffer_bytes").min(buffer);
    let row = (side * 16).next_multiple_of(256);
    (side, side * side * 4 <= storage && row * side <= buffer)
}

fn render_args_variant(variant: &'static str) -> Vec<&'static str> {
    vec![
        "render",
        "--variant",
        variant,
        "--scene",
        "one_light",
        "--size",
        "16x9",
    ]
}

/// The suite's own oracle catches the loss it guards against: the swap the tool used to make
/// (any folder moved aside and deleted) run on a folder of the user's shows as removed files.
#[test]
fn the_tree_comparison_sees_the_old_swap_replace_a_users_folder() {
    let s = Sandbox::new("old_swap");
    let before = s.tree();
    let (target, staging, old) = (
        s.path("project/src"),
        s.path("project/src.staging-1"),
        s.path("project/src.old-1"),
    );
    std::fs::create_dir(&staging).unwrap();
    std::fs::write(staging.join("results.json"), "{}").unwrap();
    std::fs::rename(&target, &old).unwrap();
    std::fs::rename(&staging, &target).unwrap();
    std::fs::remove_dir_all(&old).unwrap();
    let changed = changes(&before, &s.tree(), &[]);
    assert!(
        changed.contains(&"project/src/main.rs removed".to_string()),
        "{changed:?}"
    );
}

/// The features added after the last review (sequences, the viewer's scripts, shards) keep
/// the same promises: nothing outside `--out` is written, nothing silently wrong passes.
#[test]
fn sequences_scripts_and_shards_keep_the_promises() {
    let sequence = |name, extra: &[&str], code| {
        let mut args = vec![
            "sequence",
            "--variant",
            "variants/forward_plus.ron",
            "--size",
            "16x9",
            "--frames",
            "2",
            "--check-every",
            "1",
            "--out",
            "out",
        ];
        args.extend(extra);
        case(name, &args, code).allow("project/out")
    };
    let merge = |name| case(name, &["merge", "shard", "--out", "merged"], 1);
    run_all(vec![
        // A folder of the user's that merely looks like a run's.
        (
            case("out_holds_a_users_results_json", &tiny_matrix("mine"), 1),
            |s| {
                s.write("project/mine/results.json", b"{\"my\":\"data\"}");
                s.write("project/mine/index.html", b"<p>mine</p>");
                s.write("project/mine/results.csv", b"a,b\n");
                s.write("project/mine/images/photo.png", b"my photo");
                s.write("project/mine/plots/chart.svg", b"<svg/>");
            },
        ),
        // A shard whose images/ folder is a link out of it: merge copies nothing through it.
        (merge("merge_images_folder_is_a_link_out"), |s| {
            make_shard(s);
            std::fs::rename(s.path("project/shard/images"), s.path("outside")).unwrap();
            s.link("project/shard/images", "../../outside");
        }),
        // A shard whose figures no run could write.
        (merge("merge_psnr_beyond_any_image"), |s| {
            make_shard(s);
            edit_results(s, |r| r["cells"][0]["error"]["psnr_db"] = 1e300.into());
        }),
        (merge("merge_relative_mse_negative"), |s| {
            make_shard(s);
            edit_results(s, |r| {
                r["cells"][0]["error"]["relative_mse"] = (-1.0).into()
            });
        }),
        // The largest error differs from adapter to adapter: only the reason is checked.
        (
            merge("merge_rmse_over_its_largest_term")
                .expect("a root mean square is at most its largest term"),
            |s| {
                make_shard(s);
                edit_results(s, |r| {
                    let largest = r["cells"][0]["error"]["max_abs_8bit"].as_f64().unwrap();
                    r["cells"][0]["error"]["rmse_8bit"] = (largest + 0.5).into();
                });
            },
        ),
        (merge("merge_checked_frames_over_frames"), |s| {
            let (code, text) = s.run("project", &tiny_sequence_matrix("shard"), &[]);
            assert_eq!(code, Some(0), "{text}");
            edit_results(s, |r| {
                r["cells"][0]["sequence_summary"]["checked_frames"] = 9.into()
            });
        }),
        // A glTF file's own lights cannot move: asking for them to is refused, and a
        // sequence without --moving keeps them still.
        (
            sequence(
                "sequence_moving_a_files_own_lights",
                &["--scene", "scene/scene.gltf", "--moving", "1"],
                1,
            ),
            |s| write_gltf(s, &gltf_parts().0, &gltf_parts().1),
        ),
        (
            sequence(
                "sequence_of_a_files_own_lights",
                &["--scene", "scene/scene.gltf"],
                0,
            )
            .expect("lights, 0% moving"),
            |s| write_gltf(s, &gltf_parts().0, &gltf_parts().1),
        ),
        // An exact variant whose frames are not exact fails, in a sequence and in the
        // matrix (the shaders' ambient term scaled by 1.5, a deliberate break).
        (
            sequence("sequence_not_exact", &["--scene", "one_light"], 1)
                .env("CLUSTERLAB_SHADERS", "shaders")
                .expect("an exact variant is within 1 LSB"),
            break_ambient,
        ),
        (
            case("matrix_sequence_not_exact", &tiny_sequence_matrix("out"), 1)
                .allow("project/out")
                .env("CLUSTERLAB_SHADERS", "shaders")
                .expect("1 cells, 1 failed"),
            break_ambient,
        ),
        // Options that would do nothing.
        (
            case(
                "sweep_moving_without_sequence",
                &["matrix", "--scenes", "one_light", "--sweep", "moving=0.5,1"],
                1,
            ),
            nothing,
        ),
        (
            case(
                "frames_with_sequence",
                &[&tiny_matrix("out")[..], &["--sequence", "2"]].concat(),
                2,
            ),
            nothing,
        ),
        // A vertex colour below 0 renders black against a black reference: refused.
        (
            case("gltf_color_negative", &render_args("scene/scene.gltf"), 1),
            |s| {
                let (json, mut bin) = gltf_parts();
                poke(&json, &mut bin, attribute(&json, "COLOR_0"), -1.0);
                write_gltf(s, &json, &bin);
            },
        ),
        // The reference's own pass fits WebGPU's limits, as validate says the variant does.
        (
            case(
                "render_under_webgpu_limits",
                &[
                    &render_args_variant("variants/naive_forward.ron")[..],
                    &["--limits", "webgpu", "--out", "out"],
                ]
                .concat(),
                0,
            )
            .allow("project/out")
            .expect("naive_forward on one_light"),
            nothing,
        ),
        // An --out that cannot be written is refused before the work.
        (
            case(
                "study_out_is_a_file",
                &["study", "depth", "--out", "home.txt"],
                1,
            ),
            nothing,
        ),
        (
            case(
                "sequence_out_is_a_file",
                &[
                    "sequence",
                    "--variant",
                    "forward_plus",
                    "--scene",
                    "one_light",
                    "--out",
                    "home.txt",
                ],
                1,
            ),
            nothing,
        ),
    ]);
    // A .glb that is no GLB is refused by its header, before its 1.9 GB are read (a sparse
    // file: no disk is used, and the tree comparison, which reads every file, is left out).
    let s = Sandbox::new("glb_of_zeros");
    let file = std::fs::File::create(s.path("project/zeros.glb")).unwrap();
    file.set_len(1_900_000_000).unwrap();
    let (code, text) = s.run("project", &render_args("zeros.glb"), &[]);
    assert_eq!(code, Some(1), "{text}");
    assert!(
        text.contains("not a GLB file: it begins with the bytes [00, 00, 00, 00]"),
        "{text}"
    );
    report();
}

/// The viewer's scripts write only under `--out` and edit only the files the viewer watches.
#[test]
fn a_viewer_script_writes_only_under_out_and_edits_only_what_it_watches() {
    if let Some(why) = common::windows_unavailable() {
        eprintln!("skipped: {why}");
        return;
    }
    let play = |name| {
        case(name, &SCRIPT_RUN, 1)
            .in_viewer()
            .allow("project/out")
            .allow("project/script.ron")
    };
    run_all(vec![
        (play("script_state_absolute"), |s| {
            let target = s.path("project/home.txt");
            script(s, &format!("State({:?})", target.to_str().unwrap()));
        }),
        (play("script_state_dotdot"), |s| {
            script(s, r#"State("../notes/todo.md")"#)
        }),
        (play("script_window_shot_dotdot"), |s| {
            script(s, r#"WindowShot("../../thesis.txt")"#)
        }),
        (play("script_out_dotdot"), |s| {
            script(s, r#"Out("../notes"), Screenshot"#)
        }),
        (
            play("script_edits_an_unwatched_file")
                .expect("Edit `home.txt`: the viewer watches only the shader modules under"),
            |s| script(s, r#"Edit(file: "home.txt", find: "my", replace: "our")"#),
        ),
        (play("script_edit_that_changes_nothing"), |s| {
            script(
                s,
                r#"Edit(file: "variants/forward_plus.ron", find: "Forward", replace: "Forward")"#,
            )
        }),
    ]);
    report();
    // An edit of a watched file keeps its mode.
    let s = Sandbox::new("script_edit_keeps_the_mode");
    use std::os::unix::fs::PermissionsExt;
    let variant = s.path("project/variants/forward_plus.ron");
    std::fs::set_permissions(&variant, std::fs::Permissions::from_mode(0o600)).unwrap();
    script(
        &s,
        r#"Edit(file: "variants/forward_plus.ron", find: "description: \"", replace: "description: \"mine: ")"#,
    );
    let (code, text) = play_viewer(&s.path("project"), &SCRIPT_RUN, &[]);
    assert_eq!(code, Some(0), "{text}");
    let meta = std::fs::metadata(&variant).unwrap();
    assert_eq!(meta.permissions().mode() & 0o777, 0o600);
    assert!(
        std::fs::read_to_string(&variant)
            .unwrap()
            .contains("mine: ")
    );
}

/// `clusterlab view`'s arguments for a script case: a tiny frame, `project/script.ron`
/// played, writing into `project/out`.
const SCRIPT_RUN: [&str; 8] = [
    "--size",
    "16x9",
    "--lights",
    "4",
    "--out",
    "out",
    "--script",
    "script.ron",
];

/// `clusterlab view ARGS` in `dir` on a display: its exit code and output.
fn play_viewer(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> (Option<i32>, String) {
    common::on_a_display(|| common::viewer(args).dir(dir).envs(env).run().outcome())
}

/// A script of one step after the first frame, as `project/script.ron`.
fn script(s: &Sandbox, step: &str) {
    s.write(
        "project/script.ron",
        format!("[Wait(frames: 1), {step}]").as_bytes(),
    );
}

/// A copy of the shaders in `project/shaders` whose ambient term is 1.5 times too bright.
fn break_ambient(s: &Sandbox) {
    common::copy_tree(Path::new("shaders"), &s.path("project/shaders"));
    let module = s.path("project/shaders/shading/lighting.wesl");
    let text = std::fs::read_to_string(&module).unwrap();
    let from = "return AMBIENT * s.albedo;";
    assert!(text.contains(from), "lighting.wesl no longer has `{from}`");
    std::fs::write(
        &module,
        text.replace(from, "return AMBIENT * s.albedo * 1.5;"),
    )
    .unwrap();
}

/// A tiny matrix of 2-frame sequences, every frame checked: forward_plus and its naive
/// baseline on one_light at 16x9.
fn tiny_sequence_matrix(out: &str) -> Vec<&str> {
    vec![
        "matrix",
        "--variants",
        "variants/forward_plus.ron",
        "--scenes",
        "one_light",
        "--size",
        "16x9",
        "--sequence",
        "2",
        "--check-every",
        "1",
        "--out",
        out,
    ]
}

/// A scene with no opaque triangle (the one_light scene exported with every material
/// blended, half transparent) renders, exactly, in every pipeline: the empty opaque draw is
/// drawn as nothing (wgpu refuses an empty index buffer slice; it was a panic, exit 101).
#[test]
fn a_scene_with_every_material_blended_renders_exactly_in_every_pipeline() {
    let dir = scratch("all-blended");
    let (mut json, bin) = gltf_parts();
    for m in json["materials"].as_array_mut().unwrap() {
        m["alphaMode"] = "BLEND".into();
        m["pbrMetallicRoughness"]["baseColorFactor"] = json!([1.0, 1.0, 1.0, 0.5]);
        m.as_object_mut().unwrap().remove("alphaCutoff");
    }
    std::fs::write(dir.join("scene.gltf"), serde_json::to_vec(&json).unwrap()).unwrap();
    std::fs::write(dir.join("scene.bin"), &bin).unwrap();
    let path = dir.join("scene.gltf").to_str().unwrap().to_string();
    let mut params = scene::defaults(&path).unwrap();
    (params.width, params.height) = (48, 27);
    let made = scene::generate(&path, params).unwrap();
    assert!(
        made.indices.is_empty() && made.has_blend(),
        "every triangle blended"
    );
    let gpu = common::gpu();
    for name in [
        "naive_forward",
        "forward_plus",
        "forward_plus_no_prepass",
        "clustered_deferred_16x16x24",
        "deferred_scissor",
        "forward_plus_static_dynamic",
    ] {
        let cell = clusterlab::run::run_scene(
            &gpu,
            &clusterlab::compose::Composer::default(),
            &common::load(name),
            &made,
            Default::default(),
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        let r = &cell.report;
        let e = r.error.as_ref().unwrap();
        // An exact variant: within 1 LSB of the reference (`run::EXACT_LSB`).
        assert!(
            r.failure.is_none() && e.max_abs_8bit <= 1,
            "{name}: {:?} {e:?}",
            r.failure
        );
        assert!(
            cell.reference.ldr.iter().any(|p| p.iter().any(|&c| c > 0)),
            "{name}: something is shown"
        );
    }
}

/// StaticDynamic with no lights shows ambient, as the reference does: its still image (which
/// holds ambient) is drawn even where a frame without lights builds no lists. It was all
/// black, 35 LSB off, exit 0.
#[test]
fn a_static_dynamic_frame_without_lights_shows_ambient_exactly() {
    let gpu = common::gpu();
    for name in [
        "forward_plus_static_dynamic",
        "clustered_deferred_static_dynamic",
    ] {
        let c = common::cell(
            &gpu,
            &common::load(name),
            "atrium",
            common::small("atrium", 64, 36, Some(0)),
        );
        let e = c.report.error.as_ref().unwrap();
        assert!(
            c.report.failure.is_none() && e.max_abs_8bit <= 1,
            "{name}: {:?} {e:?}",
            c.report.failure
        );
    }
}

/// A frame all black where the reference shows something fails, whatever the cause: the
/// deliberate break is a tonemap that maps everything to black (the counters still see every
/// light evaluated, so only the image tells).
#[test]
fn an_all_black_frame_against_a_lit_reference_fails() {
    let edited = common::EditedShaders::of(
        "common/color.wesl",
        "black-tonemap",
        &[("max(hdr * exposure,", "max(hdr * 0.0 * exposure,")],
    );
    let gpu = common::gpu();
    let v = common::load("forward_plus");
    let made = scene::generate("one_light", common::small("one_light", 32, 18, None)).unwrap();
    let cell =
        clusterlab::run::run_scene(&gpu, &edited.composer, &v, &made, Default::default()).unwrap();
    let why = cell.report.failure.unwrap_or_default();
    assert!(why.starts_with("the image is all black, yet"), "{why}");
    // The shipped shaders: the same frame passes.
    let cell = clusterlab::run::run_scene(
        &gpu,
        &clusterlab::compose::Composer::default(),
        &v,
        &made,
        Default::default(),
    )
    .unwrap();
    assert!(cell.report.failure.is_none(), "{:?}", cell.report.failure);
}

/// No light of a kind: a sequence whose lights all stand still (no moving lists), all move
/// (no still lists) or are none at all, for every list strategy, runs exactly.
#[test]
fn a_sequence_with_no_light_of_a_kind_runs_exactly() {
    use clusterlab::variant::ListUpdate;
    let gpu = common::gpu();
    for update in [
        "forward_plus_static_dynamic",
        "forward_plus_patch",
        "forward_plus_bvh_refit",
    ] {
        let v = common::load(update);
        assert_ne!(v.variant.clusters().update, ListUpdate::Rebuild, "{update}");
        for (moving, lights) in [(0.0, 16), (1.0, 16), (1.0, 0)] {
            let mut p = common::small("atrium", 48, 27, Some(lights));
            p.motion = scene::Motion {
                lights: moving,
                camera: false,
                still_at: p.time,
            };
            let frames = clusterlab::sequence::scene_frames("atrium", p);
            let spec = clusterlab::sequence::SequenceSpec {
                frames: 3,
                check_every: 1,
            };
            let run = clusterlab::sequence::run(
                &gpu,
                &clusterlab::compose::Composer::default(),
                &v,
                spec,
                &frames,
                &Default::default(),
            )
            .unwrap_or_else(|e| panic!("{update}, {moving} moving, {lights} lights: {e}"));
            let r = &run.report;
            assert!(
                r.failure.is_none() && r.summary.exact,
                "{update}, {moving} moving, {lights} lights: {:?}, max {} LSB",
                r.failure,
                r.summary.max_abs_8bit
            );
        }
    }
}

/// Numbers a researcher can quote: what would mislead (an option that changes nothing, a
/// count run twice, a cache inside the project, a shader nested past what the parser
/// survives) is refused with the reason, and `--reuse` takes what a user would give it.
#[test]
fn what_would_mislead_is_refused_and_reuse_takes_what_a_user_gives() {
    let study = |name, args: &[&'static str]| {
        let mut all = vec!["study", "scale"];
        all.extend_from_slice(args);
        case(name, &all, 1)
    };
    let deep = format!(
        "const too_deep = {}1.0{};\n",
        "(".repeat(20_000),
        ")".repeat(20_000)
    );
    let tree = env!("CARGO_MANIFEST_DIR");
    run_all(vec![
        (
            study("study_reads_no_scenes", &["--scenes", "/etc/passwd"]),
            nothing,
        ),
        (
            study(
                "study_lights_twice",
                &["--lights", "64,64", "--size", "32x18"],
            ),
            nothing,
        ),
        (
            case("cache_inside_the_project", &["scenes"], 1)
                .env("CLUSTERLAB_CACHE", format!("{tree}/target/a-cache"))
                .expect("lies inside clusterlab's source tree"),
            nothing,
        ),
        (
            {
                let mut args = tiny_matrix("again");
                args.extend(["--reuse", "shard/results.json"]);
                case("reuse_given_its_results_json", &args, 0)
                    .allow("project/again")
                    .allow("project/again.lock")
                    .expect("reused 2 of 2 cells")
            },
            make_shard,
        ),
        (
            {
                let mut args = tiny_matrix("again");
                args.extend(["--reuse", "merged"]);
                case("reuse_of_a_merged_folder", &args, 1)
                    .expect("a folder `merge` made from 2 runs")
            },
            |s| {
                make_shard(s);
                let mut other = tiny_matrix("other");
                other[4] = "empty";
                let (code, text) = s.run("project", &other, &[]);
                assert_eq!(code, Some(0), "{text}");
                let (code, text) = s.run(
                    "project",
                    &["merge", "shard", "other", "--out", "merged"],
                    &[],
                );
                assert_eq!(code, Some(0), "{text}");
            },
        ),
        (
            {
                let mut args = tiny_matrix("again");
                args.extend(["--reuse", "shard"]);
                case("reuse_recipe_nested_20000_deep", &args, 0)
                    .allow("project/again")
                    .allow("project/again.lock")
                    .expect("reused 0 of 2 cells")
            },
            |s| {
                make_shard(s);
                let path = s.path("project/shard/reuse.json");
                let mut index: Value =
                    serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
                for recipe in index["recipes"].as_object_mut().unwrap().values_mut() {
                    let constants = recipe["constants"].as_str().unwrap().to_string();
                    let deep = format!(
                        "const too_deep = {}1.0{};\n",
                        "(".repeat(20_000),
                        ")".repeat(20_000)
                    );
                    recipe["constants"] = (constants + &deep).into();
                }
                std::fs::write(path, serde_json::to_vec(&index).unwrap()).unwrap();
            },
        ),
    ]);
    // A shader module nested 20,000 deep: a clear error, not a stack overflow.
    let s = Sandbox::new("shader_nested_20000_deep");
    copy_shaders(&s, "project/shaders");
    let brdf = s.path("project/shaders/shading/brdf.wesl");
    let mut text = std::fs::read_to_string(&brdf).unwrap();
    text.push_str(&deep);
    std::fs::write(&brdf, text).unwrap();
    let shaders = s.path("project/shaders");
    case(
        "shader_nested_20000_deep",
        &["validate", "variants/forward_plus.ron"],
        1,
    )
    .env("CLUSTERLAB_SHADERS", shaders.to_str().unwrap())
    .expect("brackets nest more than 256 deep here")
    .check(&s);
    report();
}

/// A copy of clusterlab's shader folder at `rel` in the sandbox.
fn copy_shaders(s: &Sandbox, rel: &str) {
    common::copy_tree(Path::new("shaders"), &s.path(rel));
}

/// `scripts/gpu-check` keeps the binary's promises: an empty or unsafe `--out` is refused
/// before anything is written, a folder is its own only when its marker says so, relative
/// paths are the caller's, and a failed step makes it exit non-zero.
#[test]
fn the_gpu_check_script_writes_only_its_own_folder_and_fails_when_a_step_fails() {
    let script = std::fs::canonicalize("scripts/gpu-check").unwrap();
    let s = Sandbox::new("gpu_check");
    s.write("project/mine/.gpu-check", b"");
    s.write("project/mine/notes.txt", b"mine\n");
    let run = |args: &[&str]| {
        let out = std::process::Command::new("bash")
            .arg(&script)
            .args(args)
            .current_dir(s.path("project"))
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stderr).into_owned()
            + &String::from_utf8_lossy(&out.stdout);
        (out.status.code(), text)
    };
    let fake = ["--bin", "/bin/true", "--tests", "/bin/true"];
    let before = s.tree();
    for (out, why) in [
        ("", "is empty"),
        ("/", "filesystem root"),
        ("mine", "not a gpu-check folder"),
        (".", "without . or .. parts"),
        ("..", "without . or .. parts"),
    ] {
        let mut args = vec!["--out", out];
        args.extend_from_slice(&fake);
        let (code, text) = run(&args);
        assert_eq!(code, Some(2), "--out `{out}`: {text}");
        assert!(text.contains(why), "--out `{out}`: {text}");
    }
    assert!(changes(&before, &s.tree(), &[]).is_empty());
    // Relative to the caller's folder; every step passing: exit 0, its own files only.
    let mut args = vec!["--out", "checked"];
    args.extend_from_slice(&fake);
    let (code, text) = run(&args);
    assert_eq!(code, Some(0), "{text}");
    assert!(s.path("project/checked/.gpu-check").is_file());
    // Again into its own folder, with a step failing: exit 1.
    let (code, text) = run(&[
        "--out",
        "checked",
        "--bin",
        "/bin/false",
        "--tests",
        "/bin/true",
    ]);
    assert_eq!(code, Some(1), "{text}");
    assert!(text.contains("steps failed"), "{text}");
    assert!(changes(&before, &s.tree(), &["project/checked"]).is_empty());
}
