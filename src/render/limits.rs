//! What a frame of a variant and scene must fit before anything is made for it: the
//! adapter's sizes, the method's buffers, the scene-dependent variant values, and Mesa's
//! loop budget.

use super::RenderError;
use crate::gpu::{Gpu, GpuError};
use crate::scene::Scene;
use crate::variant::{Pipeline, Variant};

/// Refuse a frame the adapter or the variant cannot render right, naming why.
pub fn check_frame(gpu: &Gpu, variant: &Variant, scene: &Scene) -> Result<(), RenderError> {
    gpu.check_size(scene.params.width, scene.params.height)?;
    gpu.check_scene(scene)?;
    if variant.pipeline.is_clustered() {
        let c = variant.clusters();
        gpu.check_grid(c.grid)?;
        c.method().check(gpu, c.grid, scene.lights.len())?;
    }
    check_for_scene(variant, scene)?;
    // Every pipeline but scissor deferred loops over up to all the lights per pixel; a
    // walk through light bitmasks (z-binning's light loop, two-level culling's clusters)
    // also loops once per 32-bit word of them, and two-level culling once per word of
    // their summary.
    let method = variant.clusters().method();
    let mask_words = |n: usize| match variant.pipeline.is_clustered() {
        true => method.mask_words(n),
        false => 0,
    };
    if let Some(limit) = crate::gpu::expect::max_lights_per_pixel(gpu)
        && variant.pipeline != Pipeline::DeferredScissor
        && scene.lights.len() + mask_words(scene.lights.len()) > limit as usize
    {
        let limit = limit as usize;
        let most = (0..=limit)
            .rev()
            .find(|&n| n + mask_words(n) <= limit)
            .unwrap_or(0);
        return Err(RenderError::Gpu(GpuError::TooLarge(format!(
            "{} lights: adapter `{}` ends a shader's loops after {} iterations in all, so a light loop over more than {most} lights{} would leave lights out without a word; use at most {most} lights on this adapter, or scissor deferred",
            scene.lights.len(),
            gpu.adapter.name,
            crate::gpu::expect::LLVMPIPE_LOOP_ITERATIONS,
            if mask_words(1) > 0 {
                " and their bitmask words"
            } else {
                ""
            }
        ))));
    }
    Ok(())
}

/// Variant values whose valid range depends on the scene's camera.
fn check_for_scene(variant: &Variant, scene: &Scene) -> Result<(), RenderError> {
    if variant.pipeline.is_clustered()
        && let crate::common::ZSlicing::NearSliceThenExponential { near_slice_end } =
            variant.clusters().slicing
    {
        let (near, far) = (scene.camera.near, scene.camera.far);
        let end = near_slice_end as f64;
        if !(end > near && end < far) {
            return Err(RenderError::VariantForScene {
                field: "clusters.slicing.near_slice_end".into(),
                message: format!(
                    "is {near_slice_end}; on scene `{}` it must lie between the camera's near and far planes, {} < value < {}",
                    scene.name, near as f32, far as f32
                ),
            });
        }
    }
    Ok(())
}
