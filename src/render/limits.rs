//! What a frame of a variant and scene must fit before anything is made for it: the
//! adapter's sizes (the method's buffers are checked once its passes declare their sizes:
//! `CullingMethod::check`), the scene-dependent variant values, and Mesa's
//! loop budget for the pipelines that loop over every light (a clustered frame's is checked
//! on the lists it builds, after it: `Renderer::check_walks`).

use super::error::RenderError;
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
    }
    check_for_scene(variant, scene)?;
    check_samples(gpu, variant)?;
    // Naive forward loops over every light per pixel; scissor deferred draws them instead,
    // and a clustered frame's loops are checked on the lengths it builds (`check_walks`).
    let loops_over_every_light = match variant.pipeline {
        Pipeline::NaiveForward => true,
        Pipeline::ClusteredForward | Pipeline::ClusteredDeferred | Pipeline::DeferredScissor => {
            false
        }
    };
    if let Some(limit) = crate::gpu::expect::max_lights_per_pixel(gpu)
        && loops_over_every_light
        && scene.lights.len() > limit as usize
    {
        return Err(RenderError::Gpu(GpuError::TooLarge(format!(
            "{} lights: adapter `{}` ends a shader's loops after {} iterations in all, so a light loop over more than {limit} lights would leave lights out without a word; use at most {limit} lights on this adapter, a clustered pipeline or scissor deferred",
            scene.lights.len(),
            gpu.adapter.name,
            crate::gpu::expect::LLVMPIPE_LOOP_ITERATIONS,
        ))));
    }
    Ok(())
}

/// The targets a frame of `variant` multisamples, and the raster truth's, all rendered with
/// its sample count.
fn check_samples(gpu: &Gpu, variant: &Variant) -> Result<(), RenderError> {
    let samples = variant.msaa.samples;
    if samples == 1 {
        return Ok(());
    }
    let mut targets = vec![
        (
            "depth buffer",
            super::targets::DepthSetup::of(variant).format,
        ),
        ("raster truth", super::targets::F32_BITS_FORMAT),
    ];
    if variant.pipeline.is_deferred() {
        targets.extend(
            super::gbuffer::formats(variant)
                .into_iter()
                .map(|(_, f)| ("G-buffer", f)),
        );
    }
    // Scissor deferred blends into multisampled colour, as forward shades into it.
    if variant.pipeline != Pipeline::ClusteredDeferred {
        targets.push(("HDR target", gpu.hdr_format));
    }
    if variant.depth_prepass {
        targets.push(("shading depth", super::targets::SHADING_DEPTH_FORMAT));
        targets.push(("sample owner", super::targets::SHADING_DEPTH_FORMAT));
    }
    Ok(gpu.check_samples(samples, &targets)?)
}

/// Variant values whose valid range depends on the scene's camera or materials.
fn check_for_scene(variant: &Variant, scene: &Scene) -> Result<(), RenderError> {
    if variant.msaa.on() && scene.has_blend() {
        return Err(RenderError::VariantForScene {
            field: "msaa.samples".into(),
            message: format!(
                "is {}; scene `{}` has blended materials, which clusterlab draws at 1 sample a pixel: its reference records each pixel's blended fragments once, not per sample (masked materials multisample)",
                variant.msaa.samples, scene.name
            ),
        });
    }
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
