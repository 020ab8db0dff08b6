//! The raster family: passes that draw the scene's geometry (depth pre-pass, G-buffer,
//! forward shading). Their pipelines, attachments and draws.

use super::gbuffer;
use super::passes::{begin_render, clear_attachment, color_target, render_pipeline};
use super::resources::SceneBuffers;
use super::targets::{DepthSetup, Targets};
use crate::compose::{ComposedPass, RasterPass};
use crate::gpu::{Gpu, GpuError, TimestampSlot};
use crate::variant::Variant;

/// The over operator on premultiplied colour (`fs_blend` writes colour times alpha, alpha):
/// `dst = src + (1 - src_alpha) dst`, in linear HDR.
pub const OVER: wgpu::BlendState = wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING;

/// Whether an instrumented raster pass tests depth in its shader with no depth attached:
/// on a device without forced early depth tests, the forward pass after a pre-pass and the
/// transparent pass (`passes/forward.wesl`; OpenGL refuses a depth both attached and read).
pub fn tests_depth_itself(pass: RasterPass, variant: &Variant, early_depth: bool) -> bool {
    !early_depth
        && match pass {
            RasterPass::Forward => variant.depth_prepass,
            RasterPass::Transparent => true,
            _ => false,
        }
}

/// The render pipelines of a raster pass, drawn in order (`masked`: the scene has masked
/// materials).
pub fn pipelines(
    gpu: &Gpu,
    pass: RasterPass,
    composed: &ComposedPass,
    layout: &wgpu::PipelineLayout,
    variant: &Variant,
    instrumented: bool,
    masked: bool,
) -> Result<Vec<wgpu::RenderPipeline>, GpuError> {
    let d = DepthSetup::of(variant);
    let vertex = [Some(SceneBuffers::vertex_layout())];
    let unattached = instrumented && tests_depth_itself(pass, variant, gpu.early_depth);
    let build = |fs: Option<&str>, targets: &[Option<wgpu::ColorTargetState>], depth| {
        render_pipeline(
            gpu,
            composed,
            layout,
            ("vs_main", fs),
            &vertex,
            targets,
            (!unattached).then_some(depth),
            variant.msaa.samples,
        )
    };
    Ok(match pass {
        RasterPass::DepthPrepass if variant.msaa.on() => {
            let target = color_target(super::targets::SHADING_DEPTH_FORMAT);
            let depth = d.state(d.compare(), true);
            vec![build(
                Some("fs_shading_depth"),
                &[target.clone(), target],
                depth,
            )?]
        }
        // Masked materials need a fragment shader that discards.
        RasterPass::DepthPrepass => {
            let fs = masked.then_some("fs_mask");
            vec![build(fs, &[], d.state(d.compare(), true))?]
        }
        // It tests against the opaque depth itself (it reads it, so it cannot be attached)
        // and writes nothing to the target it draws with.
        RasterPass::TransparentDepths => {
            let target = wgpu::ColorTargetState {
                write_mask: wgpu::ColorWrites::empty(),
                ..color_target(gpu.hdr_format).expect("a target")
            };
            vec![render_pipeline(
                gpu,
                composed,
                layout,
                ("vs_main", Some("fs_main")),
                &vertex,
                &[Some(target)],
                None,
                variant.msaa.samples,
            )?]
        }
        RasterPass::Transparent => {
            let fs = if instrumented {
                "fs_blend_stats"
            } else {
                "fs_blend"
            };
            let target = wgpu::ColorTargetState {
                blend: (!instrumented).then_some(OVER),
                ..color_target(gpu.hdr_format).expect("a target")
            };
            vec![build(
                Some(fs),
                &[Some(target)],
                d.state(d.compare(), false),
            )?]
        }
        RasterPass::GBuffer => {
            let formats = gbuffer::formats(variant);
            let targets: Vec<_> = formats.into_iter().map(|(_, f)| color_target(f)).collect();
            vec![build(
                Some("fs_main"),
                &targets,
                d.state(d.compare(), true),
            )?]
        }
        // After the pre-pass (StaticDynamic keeps a still image only with one), the nearest
        // fragment's still lights, once, as f32 bits.
        RasterPass::StillShading => {
            let depth = d.state(wgpu::CompareFunction::Equal, false);
            let target = color_target(super::targets::F32_BITS_FORMAT);
            vec![build(Some("fs_still"), &[target], depth)?]
        }
        RasterPass::Forward => {
            // After a pre-pass, shade exactly the nearest fragment, once.
            let depth = if variant.depth_prepass {
                d.state(wgpu::CompareFunction::Equal, false)
            } else {
                d.state(d.compare(), true)
            };
            let fs = if instrumented { "fs_stats" } else { "fs_main" };
            vec![build(Some(fs), &[color_target(gpu.hdr_format)], depth)?]
        }
    })
}

/// Encode a raster pass: its attachments, then the scene's triangles.
#[allow(clippy::too_many_arguments)]
pub fn encode(
    pass: RasterPass,
    pipelines: &[wgpu::RenderPipeline],
    groups: &[Option<wgpu::BindGroup>],
    encoder: &mut wgpu::CommandEncoder,
    slot: Option<TimestampSlot<'_>>,
    targets: &Targets,
    scene: &SceneBuffers,
    transparent_depths: Option<&wgpu::Buffer>,
    variant: &Variant,
    depth_unattached: bool,
) {
    let d = DepthSetup::of(variant);
    let depth = |clear: bool| {
        (!depth_unattached).then_some(wgpu::RenderPassDepthStencilAttachment {
            view: &targets.depth.view,
            depth_ops: Some(wgpu::Operations {
                load: if clear {
                    wgpu::LoadOp::Clear(d.clear())
                } else {
                    wgpu::LoadOp::Load
                },
                store: wgpu::StoreOp::Store,
            }),
            stencil_ops: None,
        })
    };
    let forward_target = targets.hdr_samples.as_ref().unwrap_or(&targets.hdr);
    let load = |view| {
        Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Load,
                store: wgpu::StoreOp::Store,
            },
        })
    };
    let (colors, depth): (Vec<_>, _) = match pass {
        RasterPass::DepthPrepass => (
            targets
                .shading_depth
                .iter()
                .chain(&targets.sample_owner)
                .map(|t| clear_attachment(&t.view))
                .collect(),
            depth(true),
        ),
        RasterPass::GBuffer => (
            targets
                .gbuffer
                .iter()
                .map(|(_, t)| clear_attachment(&t.view))
                .collect(),
            depth(true),
        ),
        RasterPass::Forward => (
            vec![clear_attachment(&forward_target.view)],
            depth(!variant.depth_prepass),
        ),
        RasterPass::StillShading => match &targets.still {
            Some(t) => (vec![clear_attachment(&t.view)], depth(false)),
            None => return,
        },
        RasterPass::TransparentDepths => {
            if let Some(b) = transparent_depths {
                encoder.clear_buffer(b, 0, None);
            }
            (vec![load(&targets.hdr.view)], None)
        }
        RasterPass::Transparent => (vec![load(&targets.hdr.view)], depth(false)),
    };
    let (indices, count) = match pass {
        RasterPass::TransparentDepths | RasterPass::Transparent => match &scene.blended {
            Some((buffer, count)) => (buffer, *count),
            None => return,
        },
        _ => (&scene.indices, scene.index_count),
    };
    let label = <&str>::from(pass);
    let mut rp = begin_render(encoder, label, &colors, depth, slot, groups);
    // A scene with no triangle of this kind (all of them blended, say) still clears and
    // loads the pass's targets; it draws nothing, and wgpu refuses an empty index slice.
    if count == 0 {
        return;
    }
    rp.set_pipeline(&pipelines[0]);
    rp.set_vertex_buffer(0, scene.vertices.slice(..));
    rp.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
    rp.draw_indexed(0..count, 0, 0..1);
}
