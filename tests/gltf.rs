//! glTF scenes: a built-in scene exported and loaded back is the same scene, bit for bit, and
//! renders the same image and counters on every variant; textures are sampled; the matrix
//! runs a file beside a built-in scene; bad files get clear errors (snapshotted).
//!
//! Every file here is written by the test itself.

use std::path::Path;

use crate::common::{self, cli, gpu, load, scratch, small};
use base64::Engine;
use clusterlab::compose::Composer;
use clusterlab::run::{CellOptions, run_cell};
use clusterlab::scene::{self, SCENES, Scene, SceneParams, export::to_glb};
use clusterlab::variant::{DebugView, GBufferChannel};
use glam::Vec3;
use serde_json::json;

/// A fresh folder for one test's files.
fn export(name: &str, params: SceneParams, path: &Path) -> Scene {
    let scene = scene::generate(name, params).expect("built-in scene");
    std::fs::write(path, to_glb(&scene).expect("export")).expect("write .glb");
    scene
}

/// The exported copy with the parameters the built-in scene had (its own lights).
fn load_back(path: &Path, like: &Scene) -> Scene {
    let name = path.to_str().expect("utf-8 path");
    let mut params = scene::defaults(name).expect("load");
    params.width = like.params.width;
    params.height = like.params.height;
    // The file's own lights by default: none for a scene exported with none (a file without
    // lights of its own, and without clusterlab's word that it has none, gets seeded ones).
    assert_eq!(
        params.lights as usize,
        like.lights.len(),
        "the file's lights"
    );
    scene::generate(name, params).expect("load")
}

#[test]
fn every_built_in_scene_comes_back_from_gltf_bit_for_bit() {
    let dir = scratch("round-trip");
    for info in SCENES {
        // Each scene as it is, and with half its lights turned into spots (cones and
        // rotations to carry).
        for spots in [info.defaults.spots, 0.5] {
            let params = SceneParams {
                lights: info.defaults.lights.min(256),
                spots,
                ..info.defaults
            };
            let path = dir.join(format!("{}-{spots}.glb", info.name));
            let built = export(info.name, params, &path);
            let loaded = load_back(&path, &built);
            let what = format!("{} with spot fraction {spots}", info.name);
            assert_eq!(loaded.vertices, built.vertices, "{what}: vertices");
            assert_eq!(loaded.indices, built.indices, "{what}: indices");
            assert_eq!(loaded.lights.len(), built.lights.len(), "{what}: lights");
            if let Some(i) = (0..built.lights.len()).find(|&i| loaded.lights[i] != built.lights[i])
            {
                panic!(
                    "{what}: light {i} of {} differs:\n  built  {:?}\n  loaded {:?}",
                    built.lights.len(),
                    built.lights[i],
                    loaded.lights[i]
                );
            }
            assert_eq!(loaded.camera, built.camera, "{what}: camera");
            assert_eq!(
                loaded.prev_camera, built.prev_camera,
                "{what}: previous camera"
            );
            let file = loaded.file.expect("a file scene knows its file");
            assert_eq!(file.sha256.len(), 64, "{what}: {}", file.sha256);
            assert!(loaded.notes.is_empty(), "{what}: {:?}", loaded.notes);
        }
    }
}

/// The exported file read as another loader reads it, from the standard fields alone (the
/// light's `extras` removed): every spot's axis within 1e-6 rad and its cosines within 1e-6
/// of the exact ones (a unit quaternion and an angle rounded to single precision hold them to
/// a few 1e-8). A file edited by another tool after the export (a spot turned 10 degrees, its
/// extras left behind) is read from its data, not from the stale extras.
#[test]
fn another_loader_reads_the_standard_fields_to_single_precision() {
    let dir = scratch("standard-fields");
    let params = SceneParams {
        lights: 64,
        spots: 1.0,
        ..scene::find_scene("atrium").unwrap().defaults
    };
    let built = scene::generate("atrium", params).unwrap();
    let glb = to_glb(&built).unwrap();
    let (mut json, bin) = common::split_glb(&glb);
    let write = |name: &str, json: &serde_json::Value| {
        let path = dir.join(name);
        std::fs::write(
            &path,
            clusterlab::scene::export::glb(serde_json::to_vec(json).unwrap(), bin.clone()).unwrap(),
        )
        .unwrap();
        let name = path.to_str().unwrap().to_string();
        let p = SceneParams {
            lights: 64,
            ..scene::defaults(&name).unwrap()
        };
        scene::generate(&name, p).unwrap()
    };
    let lights = json["extensions"]["KHR_lights_punctual"]["lights"]
        .as_array_mut()
        .unwrap();
    for l in lights.iter_mut() {
        l.as_object_mut().unwrap().remove("extras");
    }
    let standard = write("standard.glb", &json);
    let angle = |a: [f32; 3], b: [f32; 3]| {
        let (a, b) = (Vec3::from(a).as_dvec3(), Vec3::from(b).as_dvec3());
        a.angle_between(b)
    };
    let mut exact = 0;
    for (b, s) in built.lights.iter().zip(&standard.lights) {
        assert!(angle(b.direction, s.direction) < 1e-6, "{b:?} {s:?}");
        assert!(
            (b.cos_inner - s.cos_inner).abs() < 1e-6 && (b.cos_outer - s.cos_outer).abs() < 1e-6,
            "{b:?} {s:?}"
        );
        exact += (b == s) as u32;
    }
    // Without the extras, some cones round off their exact values (else the extras would not
    // be needed).
    assert!(
        exact < built.lights.len() as u32,
        "every light exact without extras"
    );
    // Spot 0 turned by another tool: its node's rotation, not its stale extras, decides.
    let mut json = common::split_glb(&glb).0;
    let node = json["nodes"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .find(|n| n["extensions"]["KHR_lights_punctual"]["light"] == 0)
        .unwrap();
    let q: Vec<f32> = node["rotation"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap() as f32)
        .collect();
    let turned = glam::Quat::from_rotation_x(10f32.to_radians())
        * glam::Quat::from_xyzw(q[0], q[1], q[2], q[3]);
    node["rotation"] = turned.to_array().to_vec().into();
    let edited = write("edited.glb", &json);
    let axis = (turned.as_dquat().normalize() * glam::DVec3::NEG_Z)
        .as_vec3()
        .to_array();
    assert!(angle(axis, edited.lights[0].direction) < 1e-6);
    assert!(angle(built.lights[0].direction, edited.lights[0].direction) > 1f64.to_radians());
    assert_eq!(edited.lights[1..], built.lights[1..]);
}

#[test]
fn two_files_are_two_scenes_whatever_their_path() {
    let dir = scratch("identity");
    let path = dir.join("scene.glb");
    let name = path.to_str().unwrap();
    let params = SceneParams {
        lights: 8,
        ..scene::find_scene("one_light").unwrap().defaults
    };
    export("one_light", params, &path);
    let first = scene::file_of(name).unwrap().unwrap();
    // The same path, another file (another seed moves the lights).
    std::thread::sleep(std::time::Duration::from_millis(20));
    export("one_light", SceneParams { seed: 2, ..params }, &path);
    let second = scene::file_of(name).unwrap().unwrap();
    assert_eq!(first.path, second.path);
    assert_ne!(first.sha256, second.sha256);
    // The same file under two names is one file.
    std::fs::copy(&path, dir.join("copy.glb")).unwrap();
    let copy = scene::file_of(dir.join("copy.glb").to_str().unwrap())
        .unwrap()
        .unwrap();
    assert_eq!(copy.sha256, second.sha256);
}

#[test]
fn every_variant_renders_the_exported_atrium_as_the_built_in_one() {
    let gpu = gpu();
    let composer = Composer::default();
    let dir = scratch("variants");
    let params = small("atrium", 128, 72, Some(128));
    let path = dir.join("atrium.glb");
    let built = export("atrium", params, &path);
    let file = path.to_str().unwrap();
    let loaded_params = SceneParams {
        lights: built.lights.len() as u32,
        ..scene::defaults(file).unwrap()
    };
    let loaded_params = SceneParams {
        width: 128,
        height: 72,
        ..loaded_params
    };
    let files = clusterlab::variant::find_files(Path::new("variants")).expect("variants/");
    let mut failures = Vec::new();
    for f in files {
        let v = clusterlab::variant::load(&f).unwrap_or_else(|e| panic!("{e}"));
        let options = CellOptions {
            frames: clusterlab::measure::Frames::exact(0, 1),
            ..Default::default()
        };
        let a = run_cell(&gpu, &composer, &v, "atrium", params, options);
        let b = run_cell(&gpu, &composer, &v, file, loaded_params, options);
        let (a, b) = match (a, b) {
            (Ok(a), Ok(b)) => (a, b),
            (a, b) => {
                failures.push(format!(
                    "{}: built-in {:?}, file {:?}",
                    v.name,
                    a.err().map(|e| e.to_string()),
                    b.err().map(|e| e.to_string())
                ));
                continue;
            }
        };
        let worst = a
            .frame
            .ldr
            .iter()
            .zip(&b.frame.ldr)
            .flat_map(|(p, q)| (0..3).map(move |c| p[c].abs_diff(q[c])))
            .max()
            .unwrap_or(0);
        if worst > 1 {
            failures.push(format!("{}: images differ by up to {worst} LSB", v.name));
        }
        // The same picture, the same counters; but assignment's work with StaticDynamic lists
        // depends on which lights move, and a file's lights never do.
        let counted = |r: &clusterlab::run::RenderReport| {
            let mut stats = r.stats.clone();
            if let Some(s) = stats.as_mut().filter(|_| {
                v.variant.pipeline.is_clustered()
                    && v.variant.clusters().update == clusterlab::variant::ListUpdate::StaticDynamic
            }) {
                s.assignment_work = None;
            }
            stats
        };
        if counted(&a.report) != counted(&b.report) {
            failures.push(format!(
                "{}: counters differ:\n  built-in {:?}\n  file     {:?}",
                v.name, a.report.stats, b.report.stats
            ));
        }
        assert_eq!(
            b.report.scene_file.as_ref().map(|f| f.path.as_str()),
            Some(file)
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A 4x4 RGBA PNG whose texel (x, y) is `texel(x, y)`.
fn png(texel: impl Fn(u32, u32) -> [u8; 4]) -> Vec<u8> {
    use image::ImageEncoder;
    let pixels: Vec<u8> = (0..16).flat_map(|i| texel(i % 4, i / 4)).collect();
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&pixels, 4, 4, image::ExtendedColorType::Rgba8)
        .unwrap();
    png
}

/// Ground 20 x 20 in two halves (x < 0 and x > 0), each its own primitive and material, a
/// light above and a camera looking straight down (image right is +x). With `textured`,
/// the left half's material samples a black-and-white checkerboard (UVs 0..2, so it
/// repeats) and the right half's a solid blue texture: two layers of the texture array.
fn ground_gltf(textured: bool) -> serde_json::Value {
    let positions: [f32; 18] = [
        -10.0, 0.0, -10.0, -10.0, 0.0, 10.0, 0.0, 0.0, 10.0, 0.0, 0.0, -10.0, 10.0, 0.0, 10.0,
        10.0, 0.0, -10.0,
    ];
    let normals: [f32; 18] = [0.0, 1.0, 0.0].repeat(6).try_into().unwrap();
    let uvs: [f32; 12] = [0.0, 0.0, 0.0, 2.0, 1.0, 2.0, 1.0, 0.0, 2.0, 2.0, 2.0, 0.0];
    let indices: [u32; 12] = [0, 1, 2, 0, 2, 3, 3, 2, 4, 3, 4, 5];
    let mut bin: Vec<u8> = Vec::new();
    bin.extend(bytemuck::cast_slice(&positions));
    bin.extend(bytemuck::cast_slice(&normals));
    bin.extend(bytemuck::cast_slice(&uvs));
    bin.extend(bytemuck::cast_slice(&indices));
    let b64 = |bytes: &[u8]| base64::engine::general_purpose::STANDARD.encode(bytes);
    let material = |texture: usize| {
        let mut m = json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.9, 0.8, 0.7, 1.0] } });
        if textured {
            m["pbrMetallicRoughness"]["baseColorTexture"] = json!({ "index": texture });
        }
        m
    };
    let checker = png(|x, y| {
        let v = if (x / 2 + y / 2) % 2 == 0 { 255 } else { 0 };
        [v, v, v, 255]
    });
    let blue = png(|_, _| [20, 40, 255, 255]);
    // The camera 12 above the ground, looking straight down (a -90 degree turn about x).
    let half = std::f32::consts::FRAC_1_SQRT_2;
    json!({
        "asset": { "version": "2.0" },
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": { "KHR_lights_punctual": { "lights": [
            { "type": "point", "color": [1.0, 1.0, 1.0], "intensity": 60.0, "range": 30.0 }
        ] } },
        "scene": 0,
        "scenes": [{ "nodes": [0, 1, 2] }],
        "nodes": [
            { "mesh": 0 },
            { "camera": 0, "translation": [0.0, 12.0, 0.0], "rotation": [-half, 0.0, 0.0, half] },
            { "translation": [0.0, 4.0, 0.0], "extensions": { "KHR_lights_punctual": { "light": 0 } } }
        ],
        "cameras": [{ "type": "perspective", "perspective": { "yfov": 1.0, "znear": 0.5, "zfar": 40.0 } }],
        "meshes": [{ "primitives": [
            { "attributes": { "POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2 }, "indices": 3, "material": 0 },
            { "attributes": { "POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2 }, "indices": 4, "material": 1 }
        ] }],
        "materials": [material(0), material(1)],
        "textures": [{ "source": 0 }, { "source": 1 }],
        "images": [
            { "uri": format!("data:image/png;base64,{}", b64(&checker)) },
            { "uri": format!("data:image/png;base64,{}", b64(&blue)) }
        ],
        "buffers": [{ "byteLength": bin.len(), "uri": format!("data:application/octet-stream;base64,{}", b64(&bin)) }],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": 72 },
            { "buffer": 0, "byteOffset": 72, "byteLength": 72 },
            { "buffer": 0, "byteOffset": 144, "byteLength": 48 },
            { "buffer": 0, "byteOffset": 192, "byteLength": 48 }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 6, "type": "VEC3",
              "min": [-10.0, 0.0, -10.0], "max": [10.0, 0.0, 10.0] },
            { "bufferView": 1, "componentType": 5126, "count": 6, "type": "VEC3" },
            { "bufferView": 2, "componentType": 5126, "count": 6, "type": "VEC2" },
            { "bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR" },
            { "bufferView": 3, "byteOffset": 24, "componentType": 5125, "count": 6, "type": "SCALAR" }
        ]
    })
}

/// Over the middle rows of the columns `x0..x1` of an image: the spread of luminance (max -
/// min, 8-bit) and the mean of blue minus red.
fn region(ldr: &[[u8; 4]], width: u32, height: u32, x0: u32, x1: u32) -> (u8, f64) {
    let (w, h) = (width as usize, height as usize);
    let pixels: Vec<[u8; 4]> = (h / 4..3 * h / 4)
        .flat_map(|y| (x0 as usize..x1 as usize).map(move |x| y * w + x))
        .map(|i| ldr[i])
        .collect();
    let lum: Vec<u32> = pixels
        .iter()
        .map(|p| (p[0] as u32 + p[1] as u32 + p[2] as u32) / 3)
        .collect();
    let spread = (lum.iter().max().unwrap() - lum.iter().min().unwrap()) as u8;
    let blue = pixels
        .iter()
        .map(|p| p[2] as f64 - p[0] as f64)
        .sum::<f64>()
        / pixels.len() as f64;
    (spread, blue)
}

#[test]
fn base_colour_textures_are_sampled_in_forward_and_deferred_passes_and_in_the_reference() {
    let gpu = gpu();
    let composer = Composer::default();
    let dir = scratch("textures");
    let mut albedo = Vec::new();
    for textured in [true, false] {
        let path = dir.join(format!("ground-{textured}.gltf"));
        std::fs::write(&path, serde_json::to_vec(&ground_gltf(textured)).unwrap()).unwrap();
        let file = path.to_str().unwrap();
        let params = SceneParams {
            width: 96,
            height: 96,
            ..scene::defaults(file).unwrap()
        };
        assert_eq!(params.lights, 1, "the file's own light");
        let loaded = scene::generate(file, params).unwrap();
        assert_eq!(
            loaded.textures.as_ref().map(|t| t.layers),
            textured.then_some(2)
        );
        let options = CellOptions {
            frames: clusterlab::measure::Frames::exact(0, 1),
            ..Default::default()
        };
        for name in ["forward_plus", "clustered_deferred_ggx", "naive_forward"] {
            let v = load(name);
            let c = run_cell(&gpu, &composer, &v, file, params, options)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            // The reference is shaded from the same rasterised and sampled albedo.
            assert!(
                c.report.error.as_ref().unwrap().max_abs_8bit <= 1,
                "{name}: {:?}",
                c.report.error
            );
        }
        // The albedo itself, as the G-buffer holds it, left half and right half.
        let mut v = load("clustered_deferred_ggx");
        v.variant.debug_view = DebugView::GBuffer {
            channel: GBufferChannel::Albedo,
        };
        let c = run_cell(
            &gpu,
            &composer,
            &v,
            file,
            params,
            CellOptions {
                stats: false,
                ..options
            },
        )
        .unwrap();
        albedo.push([
            region(&c.frame.ldr, 96, 96, 24, 44),
            region(&c.frame.ldr, 96, 96, 52, 72),
        ]);
    }
    let [[checker, blue], [plain_left, plain_right]] = [albedo[0], albedo[1]];
    assert!(
        checker.0 > 100,
        "layer 0, the checkerboard's squares: {checker:?}"
    );
    assert!(
        blue.0 < 10 && blue.1 > 100.0,
        "layer 1, solid blue: {blue:?}"
    );
    for plain in [plain_left, plain_right] {
        assert!(
            plain.0 < 10 && plain.1 < 0.0,
            "no texture, the factor alone: {plain:?}"
        );
    }
}

#[test]
fn the_matrix_runs_a_file_beside_a_built_in_scene() {
    let dir = scratch("matrix");
    let params = small("one_light", 64, 36, None);
    export("one_light", params, &dir.join("one_light.glb"));
    let out = dir.join("results");
    let ran = cli([
        "matrix",
        "--variants",
        "forward_plus",
        "--size",
        "64x36",
        "--frames",
        "1",
        "--warmup",
        "0",
    ])
    .arg("--scenes")
    .arg(format!("one_light,{}", dir.join("one_light.glb").display()))
    .arg("--out")
    .arg(&out)
    .run();
    assert_eq!(ran.code, Some(0), "{}", ran.stderr);
    let results: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    let cells = results["cells"].as_array().expect("cells");
    let of = |file: bool| {
        cells
            .iter()
            .find(|c| c["variant"] == "forward_plus" && c["scene_sha256"].is_string() == file)
            .unwrap_or_else(|| {
                panic!(
                    "a forward_plus cell on the {} scene",
                    if file { "file" } else { "built-in" }
                )
            })
    };
    let (built, file) = (of(false), of(true));
    assert!(
        built["failure"].is_null() && file["failure"].is_null(),
        "{built} {file}"
    );
    assert!(file["scene"].as_str().unwrap().ends_with("one_light.glb"));
    // The file's own light, so the same frame as the built-in scene: the same error.
    assert_eq!(built["error"], file["error"]);
}

/// A one-triangle .gltf with its buffer in a data URI, changed by `edit`.
fn triangle(edit: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
    let positions: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let data = base64::engine::general_purpose::STANDARD.encode(bytemuck::cast_slice(&positions));
    let mut gltf = json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 } }] }],
        "buffers": [{ "byteLength": 36, "uri": format!("data:application/octet-stream;base64,{data}") }],
        "bufferViews": [{ "buffer": 0, "byteLength": 36 }],
        "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                        "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0] }]
    });
    edit(&mut gltf);
    serde_json::to_vec_pretty(&gltf).unwrap()
}

fn with_extension(name: &'static str) -> impl FnOnce(&mut serde_json::Value) {
    move |g| {
        g["extensionsUsed"] = json!([name]);
        g["extensionsRequired"] = json!([name]);
    }
}

#[test]
fn bad_files_exit_1_with_a_clear_message() {
    let dir = scratch("errors");
    let spheres = SceneParams {
        lights: 4,
        ..scene::find_scene("spheres").unwrap().defaults
    };
    export("spheres", spheres, &dir.join("spheres.glb"));
    let whole = std::fs::read(dir.join("spheres.glb")).unwrap();
    let files: Vec<(&str, Vec<u8>)> = vec![
        ("truncated.glb", whole[..whole.len() / 2].to_vec()),
        (
            "not_json.gltf",
            b"{ \"asset\": { \"version\": \"2.0\" }, this is not JSON".to_vec(),
        ),
        (
            "invalid.gltf",
            triangle(|g| g["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(7)),
        ),
        (
            "bad_view.gltf",
            triangle(|g| g["accessors"][0]["bufferView"] = json!(5)),
        ),
        (
            "outside_buffer.gltf",
            triangle(|g| g["accessors"][0]["count"] = json!(30)),
        ),
        (
            "missing_buffer.gltf",
            triangle(|g| g["buffers"][0]["uri"] = json!("geometry.bin")),
        ),
        (
            "draco.gltf",
            triangle(with_extension("KHR_draco_mesh_compression")),
        ),
        (
            "quantized.gltf",
            triangle(with_extension("KHR_mesh_quantization")),
        ),
        (
            "meshopt.gltf",
            triangle(with_extension("EXT_meshopt_compression")),
        ),
        (
            "points.gltf",
            triangle(|g| g["meshes"][0]["primitives"][0]["mode"] = json!(0)),
        ),
        ("no_meshes.gltf", triangle(|g| g["nodes"][0] = json!({}))),
    ];
    for (name, bytes) in &files {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    let variant = std::fs::canonicalize("variants/forward_plus.ron").unwrap();
    let run = |scene: &str, envs: &[(&str, &str)]| {
        let out = cli([
            "render",
            "--size",
            "32x18",
            "--no-stats",
            "--scene",
            scene,
            "--out",
            "images",
        ])
        .arg("--variant")
        .arg(&variant)
        .dir(&dir)
        .envs(envs)
        .run();
        assert_eq!(out.code, Some(1), "{scene}: exit status");
        let text = out.stderr;
        // The adapter's name is the one part that depends on the machine.
        match text.split_once("adapter `") {
            Some((head, tail)) => format!(
                "{head}adapter `ADAPTER`{}",
                tail.split_once('`').map_or("", |t| t.1)
            ),
            None => text,
        }
    };
    let mut settings = insta::Settings::clone_current();
    settings.set_snapshot_path("../snapshots/errors");
    settings.set_prepend_module_to_snapshot(false);
    settings.bind(|| {
        insta::assert_snapshot!("gltf_missing.glb", run("missing.glb", &[]));
        for (name, _) in &files {
            insta::assert_snapshot!(format!("gltf_{name}"), run(name, &[]));
        }
        // A mesh over the adapter's buffer limit, with the limit lowered to 64 KiB.
        insta::assert_snapshot!(
            "gltf_too_large.glb",
            run("spheres.glb", &[("CLUSTERLAB_MAX_BUFFER_SIZE", "65536")])
        );
    });
}

#[test]
fn nested_node_transforms_apply_parent_first_and_mirrors_keep_their_facing() {
    let dir = scratch("nodes");
    // A parent mirrored in x and moved to x = 5, its child moved up by 2 holding the triangle
    // (0,0,0), (1,0,0), (0,1,0), which faces +z and has no normals (so it is drawn flat).
    let path = dir.join("nested.gltf");
    std::fs::write(
        &path,
        triangle(|g| {
            g["scenes"][0]["nodes"] = json!([0]);
            g["nodes"] = json!([
                { "children": [1], "translation": [5.0, 0.0, 0.0], "scale": [-1.0, 1.0, 1.0] },
                { "mesh": 0, "translation": [0.0, 2.0, 0.0] }
            ]);
        }),
    )
    .unwrap();
    let name = path.to_str().unwrap();
    let s = scene::generate(name, scene::defaults(name).unwrap()).unwrap();
    let positions: Vec<[f32; 3]> = s
        .indices
        .iter()
        .map(|&i| s.vertices[i as usize].position)
        .collect();
    // World corners (5,2,0), (4,2,0), (5,3,0), wound the other way round under the mirror.
    assert_eq!(
        positions,
        [[5.0, 2.0, 0.0], [5.0, 3.0, 0.0], [4.0, 2.0, 0.0]]
    );
    for v in &s.vertices {
        assert_eq!(v.normal, [0.0, 0.0, 1.0], "still facing +z");
    }
    assert!(
        s.notes.iter().any(|n| n.contains("drawn flat")),
        "{:?}",
        s.notes
    );
}

/// A file without a camera is framed (docs/guide.md): 60 degrees, looking at the centre of
/// the bounds' sphere from twice its radius along (0, 0.5, 1), every vertex in view between
/// near and far; a light without a `range` ends where its brightest channel falls to 1/256.
#[test]
fn a_file_without_camera_or_ranges_is_framed_and_its_lights_end_at_1_in_256() {
    let dir = scratch("no-camera");
    let params = SceneParams {
        lights: 16,
        ..scene::find_scene("atrium").unwrap().defaults
    };
    let built = scene::generate("atrium", params).unwrap();
    let (mut json, bin) = common::split_glb(&to_glb(&built).unwrap());
    json.as_object_mut().unwrap().remove("cameras");
    for node in json["nodes"].as_array_mut().unwrap() {
        node.as_object_mut().unwrap().remove("camera");
    }
    for l in json["extensions"]["KHR_lights_punctual"]["lights"]
        .as_array_mut()
        .unwrap()
    {
        let l = l.as_object_mut().unwrap();
        l.remove("range");
        l.remove("extras");
    }
    let path = dir.join("bare.glb");
    std::fs::write(
        &path,
        clusterlab::scene::export::glb(serde_json::to_vec(&json).unwrap(), bin).unwrap(),
    )
    .unwrap();
    let name = path.to_str().unwrap();
    let loaded = scene::generate(name, scene::defaults(name).unwrap()).unwrap();
    let cam = loaded.camera;
    assert!((cam.fov_y - 60f64.to_radians()).abs() < 1e-6, "{cam:?}");
    let (lo, hi) = loaded.vertices.iter().fold(
        (glam::DVec3::splat(f64::MAX), glam::DVec3::splat(f64::MIN)),
        |(lo, hi), v| {
            let p = glam::DVec3::from(v.position.map(f64::from));
            (lo.min(p), hi.max(p))
        },
    );
    let (centre, radius) = ((lo + hi) / 2.0, (hi - lo).length() / 2.0);
    let along = (cam.eye - centre).normalize();
    // The pose goes through f32: a few 1e-7 of the distance.
    assert!(
        along.distance(glam::DVec3::new(0.0, 0.5, 1.0).normalize()) < 1e-5,
        "{cam:?}"
    );
    assert!(
        ((cam.eye - centre).length() / (2.0 * radius) - 1.0).abs() < 1e-5,
        "{cam:?}"
    );
    let view = cam.view();
    let tan = (cam.fov_y / 2.0).tan();
    let aspect = loaded.aspect();
    for v in &loaded.vertices {
        let p = view.transform_point3(glam::DVec3::from(v.position.map(f64::from)));
        let z = -p.z;
        assert!(
            z >= cam.near && z <= cam.far,
            "vertex at depth {z}: {cam:?}"
        );
        assert!(
            p.x.abs() <= z * tan * aspect && p.y.abs() <= z * tan,
            "{p} out of view"
        );
    }
    assert_eq!(loaded.lights.len(), built.lights.len());
    for l in &loaded.lights {
        // Colour carries intensity; the brightest channel over the radius squared is the
        // cut-off, to f32 rounding of the radius (2 x 2^-24 relative on the square).
        let brightest = l.color.iter().fold(0.0f32, |a, &c| a.max(c)) as f64;
        let at_radius = brightest / (l.radius as f64).powi(2);
        assert!(
            (at_radius * 256.0 - 1.0).abs() < 4.0 * 2f64.powi(-24),
            "{l:?}: {at_radius} at its radius"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
