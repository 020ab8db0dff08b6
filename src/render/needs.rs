//! What a frame's passes need of the device's limits, read off their modules and layouts
//! (as the layouts themselves are, `reflect`): bindings of each kind per shader stage,
//! bind groups, workgroup storage and size, colour attachment bytes; and the refusal,
//! naming the limit, of a frame that needs more than the device was given (`--limits`).

use naga::{AddressSpace, ShaderStage};
use serde::Serialize;

use super::error::RenderError;
use super::reflect::layout_entries;
use crate::compose::ComposedPass;

/// One need: the most any pass asks for, and the first pass that asks for it.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Need {
    pub value: u64,
    pub pass: String,
}

impl Need {
    fn raise(&mut self, value: u64, pass: &str) {
        if value > self.value {
            *self = Need {
                value,
                pass: pass.to_string(),
            };
        }
    }
}

/// A variant's needs of the limits wgpu checks when it makes layouts and pipelines. The
/// largest storage binding grows with the scene (lights, grid, image size) and is checked
/// on each frame's own buffers (`limits::check_frame`, `Gpu::check_scene`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Needs {
    pub storage_buffers_per_stage: Need,
    pub uniform_buffers_per_stage: Need,
    pub sampled_textures_per_stage: Need,
    pub storage_textures_per_stage: Need,
    pub samplers_per_stage: Need,
    pub bind_groups: Need,
    pub workgroup_storage_bytes: Need,
    pub invocations_per_workgroup: Need,
    pub color_attachment_bytes_per_sample: Need,
}

impl Needs {
    /// The needs of `passes` (timed and instrumented alike) and of render targets with
    /// `color_formats` (a G-buffer's, say) drawn by pass `target_pass`.
    pub fn of<'a>(
        passes: impl IntoIterator<Item = &'a ComposedPass>,
        (target_pass, color_formats): (&str, &[wgpu::TextureFormat]),
    ) -> Result<Needs, RenderError> {
        let mut needs = Needs::default();
        for pass in passes {
            needs.add(pass)?;
        }
        needs
            .color_attachment_bytes_per_sample
            .raise(attachment_bytes(color_formats), target_pass);
        Ok(needs)
    }

    fn add(&mut self, pass: &ComposedPass) -> Result<(), RenderError> {
        let groups = layout_entries(pass)?;
        let name = pass.name.as_str();
        self.bind_groups
            .raise(groups.keys().next_back().map_or(0, |g| g + 1) as u64, name);
        for stage in [
            wgpu::ShaderStages::VERTEX,
            wgpu::ShaderStages::FRAGMENT,
            wgpu::ShaderStages::COMPUTE,
        ] {
            let count = |kind: fn(&wgpu::BindingType) -> bool| {
                groups
                    .values()
                    .flatten()
                    .filter(|e| e.visibility.contains(stage) && kind(&e.ty))
                    .count() as u64
            };
            use wgpu::{BindingType as B, BufferBindingType as U};
            let storage = count(|t| {
                matches!(
                    t,
                    B::Buffer {
                        ty: U::Storage { .. },
                        ..
                    }
                )
            });
            let uniform = count(|t| matches!(t, B::Buffer { ty: U::Uniform, .. }));
            self.storage_buffers_per_stage.raise(storage, name);
            self.uniform_buffers_per_stage.raise(uniform, name);
            self.sampled_textures_per_stage
                .raise(count(|t| matches!(t, B::Texture { .. })), name);
            self.storage_textures_per_stage
                .raise(count(|t| matches!(t, B::StorageTexture { .. })), name);
            self.samplers_per_stage
                .raise(count(|t| matches!(t, B::Sampler(_))), name);
        }
        let module = &pass.module;
        for (i, entry) in module.entry_points.iter().enumerate() {
            if entry.stage != ShaderStage::Compute {
                continue;
            }
            let uses = pass.info.get_entry_point(i);
            let shared: u64 = module
                .global_variables
                .iter()
                .filter(|(h, v)| v.space == AddressSpace::WorkGroup && !uses[*h].is_empty())
                .map(|(_, v)| module.types[v.ty].inner.size(module.to_ctx()) as u64)
                .sum();
            self.workgroup_storage_bytes.raise(shared, name);
            let [x, y, z] = entry.workgroup_size;
            self.invocations_per_workgroup
                .raise(x as u64 * y as u64 * z as u64, name);
        }
        Ok(())
    }

    /// Each need beside the limit wgpu checks it against: (name of the limit, need, allowed).
    pub fn against(&self, limits: &wgpu::Limits) -> Vec<(&'static str, &Need, u64)> {
        vec![
            (
                "max_storage_buffers_per_shader_stage",
                &self.storage_buffers_per_stage,
                limits.max_storage_buffers_per_shader_stage as u64,
            ),
            (
                "max_uniform_buffers_per_shader_stage",
                &self.uniform_buffers_per_stage,
                limits.max_uniform_buffers_per_shader_stage as u64,
            ),
            (
                "max_sampled_textures_per_shader_stage",
                &self.sampled_textures_per_stage,
                limits.max_sampled_textures_per_shader_stage as u64,
            ),
            (
                "max_storage_textures_per_shader_stage",
                &self.storage_textures_per_stage,
                limits.max_storage_textures_per_shader_stage as u64,
            ),
            (
                "max_samplers_per_shader_stage",
                &self.samplers_per_stage,
                limits.max_samplers_per_shader_stage as u64,
            ),
            (
                "max_bind_groups",
                &self.bind_groups,
                limits.max_bind_groups as u64,
            ),
            (
                "max_compute_workgroup_storage_size",
                &self.workgroup_storage_bytes,
                limits.max_compute_workgroup_storage_size as u64,
            ),
            (
                "max_compute_invocations_per_workgroup",
                &self.invocations_per_workgroup,
                limits.max_compute_invocations_per_workgroup as u64,
            ),
            (
                "max_color_attachment_bytes_per_sample",
                &self.color_attachment_bytes_per_sample,
                limits.max_color_attachment_bytes_per_sample as u64,
            ),
        ]
    }

    /// Refuse what `limits` (the device's, from `limit_set`) do not allow, naming each
    /// limit, the need and the pass that has it.
    pub fn check(&self, limits: &wgpu::Limits, limit_set: &str) -> Result<(), RenderError> {
        let over: Vec<String> = self
            .against(limits)
            .into_iter()
            .filter(|(_, need, allowed)| need.value > *allowed)
            .map(|(limit, need, allowed)| {
                format!(
                    "{limit}: pass `{}` needs {}, the device allows {allowed}",
                    need.pass, need.value
                )
            })
            .collect();
        if over.is_empty() {
            return Ok(());
        }
        Err(RenderError::Limits(format!(
            "the variant needs more than the device's {limit_set} limits allow ({}); run with `--limits adapter` or on an adapter that offers more",
            over.join("; ")
        )))
    }
}

/// Colour attachment bytes per sample of targets with `formats`, as WebGPU counts them:
/// each target's byte cost, aligned to its component size.
fn attachment_bytes(formats: &[wgpu::TextureFormat]) -> u64 {
    formats.iter().fold(0, |total, f| {
        let align = f.target_component_alignment().unwrap_or(1) as u64;
        total.div_ceil(align) * align + f.target_pixel_byte_cost().unwrap_or(0) as u64
    })
}
