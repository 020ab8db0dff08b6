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
