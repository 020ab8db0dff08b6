//! Helpers shared by the GPU tests.
#![allow(dead_code)]

use std::path::Path;

use clusterlab::compose::Composer;
use clusterlab::gpu::Gpu;
use clusterlab::run::{CellOptions, CellResult, run_cell};
use clusterlab::scene::{SceneParams, find_scene};
use clusterlab::variant::{self, LoadedVariant};

pub fn gpu() -> Gpu {
    Gpu::new(None).unwrap_or_else(|e| panic!("{e}"))
}

pub fn load(name: &str) -> LoadedVariant {
    variant::load(Path::new(&format!("variants/{name}.ron"))).unwrap_or_else(|e| panic!("{e}"))
}

/// A scene's defaults at a small size, with `lights` if given.
pub fn small(scene: &str, width: u32, height: u32, lights: Option<u32>) -> SceneParams {
    let mut p = find_scene(scene).expect("built-in scene").defaults;
    p.width = width;
    p.height = height;
    if let Some(n) = lights {
        p.lights = n;
    }
    p
}

pub fn cell(gpu: &Gpu, v: &LoadedVariant, scene: &str, p: SceneParams) -> CellResult {
    run_cell(
        gpu,
        &Composer::default(),
        v,
        scene,
        p,
        CellOptions {
            frames: clusterlab::measure::Frames::exact(0, 1),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{} on {scene}: {e}", v.name))
}

/// A .glb file's JSON and binary chunk.
pub fn split_glb(glb: &[u8]) -> (serde_json::Value, Vec<u8>) {
    let word = |at: usize| u32::from_le_bytes(glb[at..at + 4].try_into().unwrap()) as usize;
    let json_len = word(12);
    let json = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let bin_len = word(20 + json_len);
    (json, glb[28 + json_len..28 + json_len + bin_len].to_vec())
}

/// Copy folder `from` into `to`, recursively.
pub fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_tree(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}
