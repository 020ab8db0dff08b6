//! Running a frame's passes with timing, and building pipelines from composed passes.

use std::time::Instant;

use crate::compose::ComposedPass;
use crate::gpu::{Gpu, GpuError, PassTimer, TimestampSlot, Timings};

/// Encodes a frame pass by pass. With timestamps, all passes go into one submission; without,
/// each pass is submitted and waited for, and timed by the wall clock.
pub struct PassRunner<'g> {
    gpu: &'g Gpu,
    timer: PassTimer,
    encoder: Option<wgpu::CommandEncoder>,
}

impl<'g> PassRunner<'g> {
    pub fn new(gpu: &'g Gpu, max_passes: u32) -> Self {
        Self {
            gpu,
            timer: PassTimer::new(gpu, max_passes),
            encoder: None,
        }
    }

    /// Encode one pass named `name`; `f` records it into the encoder, using the slot for
    /// its timestamp writes.
    pub fn pass(
        &mut self,
        name: &str,
        f: impl FnOnce(&mut wgpu::CommandEncoder, Option<TimestampSlot<'_>>),
    ) -> Result<(), GpuError> {
        let gpu = self.gpu;
        let encoder = self.encoder.get_or_insert_with(|| {
            gpu.device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(name) })
        });
        if self.timer.wall_clock() {
            let start = Instant::now();
            f(encoder, None);
            let encoder = self.encoder.take().expect("encoder was just made");
            gpu.queue.submit([encoder.finish()]);
            gpu.wait()?;
            self.timer
                .record_wall(name, start.elapsed().as_secs_f64() * 1e3);
        } else {
            let slot = self.timer.claim_slot(name);
            f(encoder, slot);
        }
        Ok(())
    }

    /// Submit what is left, wait, and return the pass times.
    pub fn finish(mut self) -> Result<Timings, GpuError> {
        if let Some(encoder) = self.encoder.take() {
            self.gpu.queue.submit([encoder.finish()]);
        }
        self.gpu.wait()?;
        self.timer.finish(self.gpu)
    }
}

/// The shader module of a composed pass (one per distinct WGSL on the device).
pub fn shader_module(gpu: &Gpu, pass: &ComposedPass) -> Result<wgpu::ShaderModule, GpuError> {
    gpu.shader_module(&pass.name, &pass.wgsl)
}

/// A render pipeline of a composed pass with vertex and (optional) fragment entry points,
/// created once per device for its WGSL and state (`layout` is the pass's own, which its
/// WGSL determines), drawing `samples` samples a pixel.
#[allow(clippy::too_many_arguments)]
pub fn render_pipeline(
    gpu: &Gpu,
    pass: &ComposedPass,
    layout: &wgpu::PipelineLayout,
    (vs, fs): (&str, Option<&str>),
    vertex_buffers: &[Option<wgpu::VertexBufferLayout<'_>>],
    targets: &[Option<wgpu::ColorTargetState>],
    depth: Option<wgpu::DepthStencilState>,
    samples: u32,
) -> Result<wgpu::RenderPipeline, GpuError> {
    let key = format!(
        "{}\0{vs}|{fs:?}|{vertex_buffers:?}|{targets:?}|{depth:?}|{samples}",
        pass.wgsl
    );
    let module = shader_module(gpu, pass)?;
    gpu.render_pipeline(&pass.name, key, || {
        gpu.device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(&pass.name),
                layout: Some(layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers: vertex_buffers,
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: depth.clone(),
                multisample: wgpu::MultisampleState {
                    count: samples,
                    ..Default::default()
                },
                fragment: fs.map(|fs| wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets,
                }),
                multiview_mask: None,
                cache: gpu.pipeline_cache(),
            })
    })
}

/// The compute pipelines of a pass, one per entry point, sharing its layout, each with its
/// workgroup size as the pass's naga module states it.
pub struct ComputePipelines(Vec<(String, [u32; 3], wgpu::ComputePipeline)>);

impl ComputePipelines {
    /// Pipelines of the named compute entry points of `pass`.
    pub fn new(
        gpu: &Gpu,
        pass: &ComposedPass,
        layout: &wgpu::PipelineLayout,
        entries: &[&str],
    ) -> Result<Self, GpuError> {
        let module = shader_module(gpu, pass)?;
        let pipelines = entries
            .iter()
            .map(|&entry| {
                let size = workgroup_size(pass, entry);
                let key = format!("{}\0{entry}", pass.wgsl);
                let pipeline = gpu.compute_pipeline(&pass.name, key, || {
                    gpu.device
                        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                            label: Some(entry),
                            layout: Some(layout),
                            module: &module,
                            entry_point: Some(entry),
                            compilation_options: Default::default(),
                            cache: gpu.pipeline_cache(),
                        })
                })?;
                Ok((entry.to_string(), size, pipeline))
            })
            .collect::<Result<_, GpuError>>()?;
        Ok(Self(pipelines))
    }

    /// Pipelines of every compute entry point the composed pass holds (its features leave
    /// only those its variant runs).
    pub fn all(
        gpu: &Gpu,
        pass: &ComposedPass,
        layout: &wgpu::PipelineLayout,
    ) -> Result<Self, GpuError> {
        let entries: Vec<&str> = pass
            .module
            .entry_points
            .iter()
            .filter(|e| e.stage == naga::ShaderStage::Compute)
            .map(|e| e.name.as_str())
            .collect();
        Self::new(gpu, pass, layout, &entries)
    }

    /// The pipeline of `entry`, one of those it was made with.
    pub fn get(&self, entry: &str) -> &wgpu::ComputePipeline {
        &self.find(entry).2
    }

    /// The workgroups that cover `threads` invocations of `entry` (at least one a side).
    pub fn groups_for(&self, entry: &str, threads: [u32; 3]) -> [u32; 3] {
        let size = self.find(entry).1;
        [0, 1, 2].map(|i| threads[i].div_ceil(size[i]).max(1))
    }

    fn find(&self, entry: &str) -> &(String, [u32; 3], wgpu::ComputePipeline) {
        self.0
            .iter()
            .find(|(e, _, _)| e == entry)
            .unwrap_or_else(|| panic!("no compute pipeline for entry point `{entry}`"))
    }
}

/// The workgroup size of compute entry point `entry` of `pass`, from its naga module.
fn workgroup_size(pass: &ComposedPass, entry: &str) -> [u32; 3] {
    pass.module
        .entry_points
        .iter()
        .find(|e| e.name == entry && e.stage == naga::ShaderStage::Compute)
        .map_or([1, 1, 1], |e| e.workgroup_size)
}

/// A colour target without blending.
pub fn color_target(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState {
        format,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    })
}

/// A colour attachment cleared to zero and stored.
pub fn clear_attachment(view: &wgpu::TextureView) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
            store: wgpu::StoreOp::Store,
        },
    })
}

/// Begin render pass `label` with these attachments, timed in `slot`, with a pass's bind
/// groups set (a group it does not use is a gap).
pub fn begin_render<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    colors: &[Option<wgpu::RenderPassColorAttachment<'_>>],
    depth: Option<wgpu::RenderPassDepthStencilAttachment<'_>>,
    slot: Option<TimestampSlot<'_>>,
    groups: &[Option<wgpu::BindGroup>],
) -> wgpu::RenderPass<'e> {
    let mut rp = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: colors,
        depth_stencil_attachment: depth,
        timestamp_writes: TimestampSlot::render(slot),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    for (i, g) in groups.iter().enumerate() {
        if let Some(g) = g {
            rp.set_bind_group(i as u32, g, &[]);
        }
    }
    rp
}

/// Set a pass's bind groups on a compute pass (a group it does not use is a gap).
pub fn set_compute_groups(cp: &mut wgpu::ComputePass<'_>, groups: &[Option<wgpu::BindGroup>]) {
    for (i, g) in groups.iter().enumerate() {
        if let Some(g) = g {
            cp.set_bind_group(i as u32, g, &[]);
        }
    }
}
