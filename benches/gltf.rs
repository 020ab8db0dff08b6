//! A glTF scene of over a million triangles, end to end (a benchmark, not a test): written by
//! the export path from a procedural mesh (a field of spheres on a floor), loaded back as a
//! file scene with seeded lights, and rendered by naive forward, Forward+ and clustered
//! deferred.
//!
//!     cargo bench --bench gltf
//!
//! Environment: CLUSTERLAB_BENCH_SPHERES (per side, default 9: 81 spheres of 12,800
//! triangles), CLUSTERLAB_BENCH_LIGHTS (default 1024), CLUSTERLAB_BENCH_SIZE (default
//! 640x360), CLUSTERLAB_BENCH_VARIANTS (default naive_forward,forward_plus,
//! clustered_deferred_16x16x24).

use std::path::Path;
use std::time::Instant;

mod common;

use clusterlab::compose::Composer;
use clusterlab::gpu::Gpu;
use clusterlab::render::Renderer;
use clusterlab::scene::{self, Camera, MeshBuilder, Scene, SceneParams};
use clusterlab::variant;
use common::env;
use glam::DVec3;

/// Peak resident memory of this process so far, MiB (Linux; 0 elsewhere).
fn peak_rss_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(0.0, |kib| kib / 1024.0)
}

fn field_of_spheres(per_side: u32) -> Scene {
    let mut m = MeshBuilder::default();
    let spacing = 3.0;
    let half = per_side as f64 * spacing / 2.0;
    m.set_material(0.6, 0.0);
    m.axis_rect(1, 0.0, [-half, -half], [half, half], true, [0.7, 0.65, 0.6]);
    for i in 0..per_side {
        for k in 0..per_side {
            m.set_material(0.2 + 0.6 * (i as f32 / per_side as f32), (k % 2) as f32);
            let c = DVec3::new(
                -half + spacing * (i as f64 + 0.5),
                1.0,
                -half + spacing * (k as f64 + 0.5),
            );
            let hue = [(i % 3) as f32 / 2.0, (k % 3) as f32 / 2.0, 0.5];
            m.sphere(c, 1.0, 80, 80, hue);
        }
    }
    let eye = DVec3::new(0.0, half * 0.6, half * 1.3);
    let rotation = Camera::look_rotation(eye, DVec3::ZERO, DVec3::Y).as_quat();
    let far = Scene::far_plane_for(&m.vertices, eye) as f32;
    let camera = Camera::from_pose(eye.as_vec3(), rotation, 60f32.to_radians(), 0.1, far);
    Scene {
        name: "field_of_spheres".into(),
        params: SceneParams {
            width: 640,
            height: 360,
            lights: 0,
            radius_range: (1.0, 3.0),
            seed: 1,
            time: 1.0,
            spots: 0.0,
            motion: clusterlab::scene::Motion::ALL,
        },
        vertices: m.vertices,
        indices: m.indices,
        blended: m.blended,
        lights: Vec::new(),
        camera,
        prev_camera: camera,
        moving_lights: Vec::new(),
        textures: None,
        file: None,
        notes: Vec::new(),
    }
}

fn main() {
    let per_side: u32 = env("CLUSTERLAB_BENCH_SPHERES", 9);
    let lights: u32 = env("CLUSTERLAB_BENCH_LIGHTS", 1024);
    let (w, h) = common::size("640x360");
    let names: String = env(
        "CLUSTERLAB_BENCH_VARIANTS",
        "naive_forward,forward_plus,clustered_deferred_16x16x24".to_string(),
    );

    let start = Instant::now();
    let built = field_of_spheres(per_side);
    let triangles = built.indices.len() / 3;
    let bytes = scene::export::to_glb(&built).expect("export");
    let dir = Path::new("target/bench");
    std::fs::create_dir_all(dir).expect("target/bench");
    let path = dir.join("million.glb");
    std::fs::write(&path, &bytes).expect("write");
    let export_s = start.elapsed().as_secs_f64();
    let rss_before = peak_rss_mib();
    drop(built);

    let name = path.to_str().expect("utf-8 path");
    let start = Instant::now();
    let mut params = scene::defaults(name).unwrap_or_else(|e| panic!("{e}"));
    let load_s = start.elapsed().as_secs_f64();
    (params.width, params.height, params.lights) = (w, h, lights);
    let start = Instant::now();
    let scene = scene::generate(name, params).unwrap_or_else(|e| panic!("{e}"));
    let instantiate_s = start.elapsed().as_secs_f64();
    let rss_loaded = peak_rss_mib();
    println!(
        "{name}: {triangles} triangles, {} vertices, {:.1} MB; built and exported in {export_s:.2} s",
        scene.vertices.len(),
        bytes.len() as f64 / 1e6
    );
    println!(
        "load (read, hash, parse, flatten) {load_s:.2} s; scene with {lights} seeded lights {instantiate_s:.3} s; peak RSS {rss_before:.0} MiB after export, {rss_loaded:.0} MiB after loading"
    );
    let gpu = Gpu::new(None).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "rendering {w}x{h} on {} ({}, {})",
        gpu.adapter.name, gpu.adapter.backend, gpu.adapter.driver
    );
    let composer = Composer::default();
    let mut naive_ms = None;
    for n in names.split(',') {
        let v = variant::load(Path::new(&format!("variants/{n}.ron")))
            .unwrap_or_else(|e| panic!("{e}"));
        let start = Instant::now();
        let mut r = Renderer::new(&gpu, &composer, &v.variant, &scene)
            .unwrap_or_else(|e| panic!("{n}: {e}"));
        let setup_s = start.elapsed().as_secs_f64();
        r.render().expect("warm-up frame");
        let f = r.render().expect("timed frame");
        let total = f.timings.total_ms();
        let passes: Vec<String> = f
            .timings
            .passes
            .iter()
            .map(|(p, ms)| format!("{p} {ms:.1}"))
            .collect();
        let speedup = naive_ms.map_or(String::new(), |n: f64| format!(", {:.1}x naive", n / total));
        if n == "naive_forward" {
            naive_ms = Some(total);
        }
        println!(
            "  {n:<28} {total:9.1} ms a frame{speedup} (set-up {setup_s:.2} s; {})",
            passes.join(", ")
        );
    }
    println!("peak RSS {:.0} MiB", peak_rss_mib());
}
