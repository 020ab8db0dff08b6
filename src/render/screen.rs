//! The screen family: passes that draw over the screen without the scene's geometry
//! (deferred resolve, the forward passes' sample resolve, scissor-rectangle lights, the
//! debug views, tonemapping). Their pipelines, bindings, attachments and draws.

use super::bindings::Binding;
use super::passes::{begin_render, clear_attachment, color_target, render_pipeline};
use super::reflect::Slot;
use super::resources::FrameResources;
use super::targets::LDR_FORMAT;
use crate::compose::{ComposedPass, ScreenPass};
use crate::gpu::{Gpu, GpuError, TimestampSlot};

/// The render pipelines of a screen pass, drawn in order.
pub fn pipelines(
    gpu: &Gpu,
    pass: ScreenPass,
    composed: &ComposedPass,
    layout: &wgpu::PipelineLayout,
    samples: u32,
) -> Result<Vec<wgpu::RenderPipeline>, GpuError> {
    // Only scissor lights draw into multisampled colour; the rest write one sample a pixel.
    let samples = if pass == ScreenPass::ScissorLights {
        samples
    } else {
        1
    };
    let build = |vs: &str, fs: &str, target: Option<wgpu::ColorTargetState>| {
        render_pipeline(
            gpu,
            composed,
            layout,
            (vs, Some(fs)),
            &[],
            &[target],
            None,
            samples,
        )
    };
    Ok(match pass {
        ScreenPass::Resolve | ScreenPass::SampleResolve => {
            vec![build("vs_main", "fs_main", color_target(gpu.hdr_format))?]
        }
        ScreenPass::StillResolve => {
            let target = color_target(super::targets::F32_BITS_FORMAT);
            vec![build("vs_main", "fs_still", target)?]
        }
        // The ambient term over every pixel, then each light added in its rectangle.
        ScreenPass::ScissorLights => {
            let additive = Some(wgpu::ColorTargetState {
                format: gpu.hdr_format,
                blend: Some(wgpu::BlendState {
                    color: wgpu::BlendComponent {
                        src_factor: wgpu::BlendFactor::One,
                        dst_factor: wgpu::BlendFactor::One,
                        operation: wgpu::BlendOperation::Add,
                    },
                    alpha: wgpu::BlendComponent::OVER,
                }),
                write_mask: wgpu::ColorWrites::ALL,
            });
            vec![
                build("vs_ambient", "fs_ambient", additive.clone())?,
                build("vs_light", "fs_light", additive)?,
            ]
        }
        ScreenPass::DebugView | ScreenPass::Tonemap => {
            vec![build("vs_main", "fs_main", color_target(LDR_FORMAT))?]
        }
    })
}

/// What fills `slot` of a screen pass: the scene passes' groups, but for tonemapping, which
/// reads the final colour (`shaded`, after any post effect) at group 0.
pub fn binding<'a>(
    pass: ScreenPass,
    slot: &Slot,
    resources: &'a FrameResources,
    shaded: &'a wgpu::TextureView,
) -> Option<wgpu::BindingResource<'a>> {
    match (pass, slot.name) {
        (ScreenPass::Tonemap, Binding::Hdr) => Some(wgpu::BindingResource::TextureView(shaded)),
        (ScreenPass::Tonemap, _) => None,
        (ScreenPass::SampleResolve, Binding::HdrSamples) => resources
            .targets
            .hdr_samples
            .as_ref()
            .map(|t| wgpu::BindingResource::TextureView(&t.view)),
        (ScreenPass::SampleResolve, _) => None,
        _ => resources.scene_binding(slot),
    }
}

/// Encode a screen pass: one full-screen triangle, or for scissor lights the ambient
/// triangle and one rectangle per light.
pub fn encode(
    pass: ScreenPass,
    pipelines: &[wgpu::RenderPipeline],
    groups: &[Option<wgpu::BindGroup>],
    encoder: &mut wgpu::CommandEncoder,
    slot: Option<TimestampSlot<'_>>,
    resources: &FrameResources,
) {
    let t = &resources.targets;
    let target = match pass {
        ScreenPass::ScissorLights => &t.hdr_samples.as_ref().unwrap_or(&t.hdr).view,
        ScreenPass::Resolve | ScreenPass::SampleResolve => &t.hdr.view,
        ScreenPass::StillResolve => match &t.still {
            Some(still) => &still.view,
            None => return,
        },
        ScreenPass::DebugView | ScreenPass::Tonemap => &t.ldr.view,
    };
    let colors = [clear_attachment(target)];
    let mut rp = begin_render(encoder, pass.into(), &colors, None, slot, groups);
    rp.set_pipeline(&pipelines[0]);
    rp.draw(0..3, 0..1);
    if pass == ScreenPass::ScissorLights {
        rp.set_pipeline(&pipelines[1]);
        rp.draw(0..6, 0..resources.scene.light_count);
    }
}
