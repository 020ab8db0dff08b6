//! The reference frame of a cell: the variant's own rasterisation, read back at full
//! precision, shaded and post-processed by the CPU twins in f64; and (`inputs`) the adapters
//! that read the twins' plain parameters off a variant and a scene.

mod inputs;

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use crate::compose::Composer;
use crate::cpu::frame::{ReferenceFrame, post_process, shade_reference};
use crate::cpu::post::{CameraPair, Geometry, PostParams};
use crate::cpu::shading::ShadingParams;
use crate::gpu::Gpu;
use crate::render::raster_truth;
use crate::run::RunError;
use crate::scene::Scene;
use crate::variant::LoadedVariant;

/// Exposure of the tonemap (fixed: images of different variants are comparable).
pub const EXPOSURE: f64 = 1.0;

/// Reference frames by what determines them, so that variants which rasterise, shade and
/// post-process alike share one (the matrix runs many such cells).
#[derive(Default)]
pub struct ReferenceCache {
    frames: Mutex<HashMap<String, (Arc<ReferenceFrame>, f64)>>,
}

impl std::fmt::Debug for ReferenceCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.frames.lock().map_or(0, |m| m.len());
        write!(f, "ReferenceCache({n} frames)")
    }
}

impl ReferenceCache {
    /// The reference of `variant` on `scene`, computed on first use. The time returned is
    /// the time it took when it was computed.
    pub fn get_or_compute(
        &self,
        gpu: &Gpu,
        composer: &Composer,
        variant: &LoadedVariant,
        scene: &Scene,
    ) -> Result<(Arc<ReferenceFrame>, f64), RunError> {
        let v = &variant.variant;
        // Everything the raster truth, the shading and the post chain depend on.
        let key = format!(
            "{}|{:?}|{:?}|{:?}|{:?}|{:?}|{}",
            scene.name,
            scene.file.as_ref().map(|f| &f.sha256),
            scene.params,
            ShadingParams::of(v),
            PostParams::of(v),
            v.depth,
            v.depth_prepass
        );
        if let Some(hit) = self.frames.lock().expect("cache lock").get(&key) {
            return Ok(hit.clone());
        }
        let (frame, ms) = reference_frame(gpu, composer, variant, scene)?;
        let entry = (Arc::new(frame), ms);
        self.frames
            .lock()
            .expect("cache lock")
            .insert(key, entry.clone());
        Ok(entry)
    }
}

/// The raster truth of the variant's rasterisation, shaded and post-processed on the CPU
/// in f64.
pub fn reference_frame(
    gpu: &Gpu,
    composer: &Composer,
    variant: &LoadedVariant,
    scene: &Scene,
) -> Result<(ReferenceFrame, f64), RunError> {
    let truth = raster_truth(gpu, composer, &variant.variant, scene)?;
    let start = Instant::now();
    let mut reference = shade_reference(
        &truth,
        &scene.lights,
        scene.camera.eye,
        &ShadingParams::of(&variant.variant),
        EXPOSURE,
    );
    let post = PostParams::of(&variant.variant);
    if post.any() {
        let cams = CameraPair::of(scene, variant.variant.depth.mapping());
        post_process(
            &mut reference,
            &post,
            &Geometry::from_truth(&truth, &cams),
            EXPOSURE,
        );
    }
    Ok((reference, start.elapsed().as_secs_f64() * 1e3))
}
