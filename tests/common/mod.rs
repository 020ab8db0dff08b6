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

/// A .glb file of `json` and binary chunk `bin`, each padded to 4 bytes.
pub fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |b: &[u8], with: u8| {
        let mut b = b.to_vec();
        while !b.len().is_multiple_of(4) {
            b.push(with);
        }
        b
    };
    let (json, bin) = (pad(json, b' '), pad(bin, 0));
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(((28 + json.len() + bin.len()) as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}
