//! Running a variant on the GPU: one frame of a scene, pass by pass, timed.

mod passes;
mod resources;
mod truth;

pub use passes::{PassRunner, TimestampSlot, shader_module};
pub use resources::{DepthSetup, F32_BITS_FORMAT, LDR_FORMAT, SceneBuffers, ViewUniform};
pub use truth::raster_truth;

use std::collections::HashMap;
use std::fmt;
use std::time::Instant;

use crate::compose::{self, ComposedPass, Composer, ShaderError};
use crate::gpu::{Gpu, GpuError, Timings, read_texture};
use crate::scene::Scene;
use crate::variant::Variant;
use passes::{clear_attachment, color_target, pipeline_layout, render_pipeline};
use resources::{frame_bind_group, frame_layout, target, texture_entry};

/// Why a frame could not be rendered.
#[derive(Debug)]
pub enum RenderError {
    Shader(ShaderError),
    Gpu(GpuError),
    /// The variant composes, but this build cannot run one of its passes.
    NotRunnable(String),
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RenderError::Shader(e) => write!(f, "{e}"),
            RenderError::Gpu(e) => write!(f, "{e}"),
            RenderError::NotRunnable(m) => write!(f, "{m}"),
        }
    }
}

impl std::error::Error for RenderError {}

impl From<ShaderError> for RenderError {
    fn from(e: ShaderError) -> Self {
        RenderError::Shader(e)
    }
}

impl From<GpuError> for RenderError {
    fn from(e: GpuError) -> Self {
        RenderError::Gpu(e)
    }
}

/// What one frame produced.
#[derive(Clone, Debug)]
pub struct FrameOutput {
    pub width: u32,
    pub height: u32,
    /// Linear HDR colour before tonemapping (rgba32float), row-major.
    pub hdr: Vec<[f32; 4]>,
    /// The displayed 8-bit image (tonemapped, sRGB), row-major.
    pub ldr: Vec<[u8; 4]>,
    pub timings: Timings,
    /// Wall-clock time from the first encode to the frame's completion.
    pub wall_ms: f64,
}

/// The targets every frame draws into.
struct Targets {
    depth: wgpu::Texture,
    hdr: wgpu::Texture,
    ldr: wgpu::Texture,
}

/// A variant ready to render a scene: composed passes, pipelines and resources.
pub struct Renderer<'g> {
    gpu: &'g Gpu,
    variant: Variant,
    passes: Vec<compose::Pass>,
    width: u32,
    height: u32,
    depth: DepthSetup,
    scene: SceneBuffers,
    frame_group: wgpu::BindGroup,
    targets: Targets,
    render_pipelines: HashMap<&'static str, wgpu::RenderPipeline>,
    tonemap_group: wgpu::BindGroup,
}

impl<'g> Renderer<'g> {
    /// Compose the variant's passes, check that they can run, and build everything a frame
    /// of `scene` needs.
    pub fn new(
        gpu: &'g Gpu,
        composer: &Composer,
        variant: &Variant,
        scene: &Scene,
    ) -> Result<Self, RenderError> {
        let (width, height) = (scene.params.width, scene.params.height);
        gpu.check_size(width, height)?;
        let passes = compose::passes(variant);
        if let Some(p) = passes.iter().find(|p| !runnable(p.name)) {
            return Err(RenderError::NotRunnable(format!(
                "pass `{}` composes and validates, but this version of clusterlab cannot run it yet",
                p.name
            )));
        }
        let composed: HashMap<&str, ComposedPass> = passes
            .iter()
            .map(|p| Ok((p.name, composer.compose(variant, p)?)))
            .collect::<Result<_, ShaderError>>()?;
        let depth = DepthSetup::of(variant);

        gpu.scoped("creating pipelines and resources", || {
            let scene_buffers = SceneBuffers::upload(gpu, scene, depth.reversed);
            let frame = frame_layout(gpu);
            let frame_group = frame_bind_group(gpu, &frame, &scene_buffers);
            let targets = Targets {
                depth: target(gpu, "depth", width, height, depth.format),
                hdr: target(gpu, "hdr", width, height, gpu.hdr_format),
                ldr: target(gpu, "ldr", width, height, LDR_FORMAT),
            };
            let scene_layout = pipeline_layout(gpu, &[&frame]);
            let tonemap_layout =
                gpu.device
                    .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                        label: Some("tonemap"),
                        entries: &[texture_entry(
                            0,
                            wgpu::TextureSampleType::Float { filterable: false },
                        )],
                    });
            let tonemap_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("tonemap"),
                layout: &tonemap_layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(
                        &targets.hdr.create_view(&Default::default()),
                    ),
                }],
            });

            let mut render_pipelines = HashMap::new();
            let vertex = [Some(SceneBuffers::vertex_layout())];
            for (name, pass) in &composed {
                let pipeline = match *name {
                    "depth_prepass" => render_pipeline(
                        gpu,
                        pass,
                        &scene_layout,
                        &vertex,
                        &[],
                        Some(depth.state(depth.compare(), true)),
                    ),
                    "forward" => {
                        let state = if variant.depth_prepass {
                            depth.state(wgpu::CompareFunction::Equal, false)
                        } else {
                            depth.state(depth.compare(), true)
                        };
                        render_pipeline(
                            gpu,
                            pass,
                            &scene_layout,
                            &vertex,
                            &[color_target(gpu.hdr_format)],
                            Some(state),
                        )
                    }
                    "tonemap" => render_pipeline(
                        gpu,
                        pass,
                        &pipeline_layout(gpu, &[&tonemap_layout]),
                        &[],
                        &[color_target(LDR_FORMAT)],
                        None,
                    ),
                    _ => continue,
                };
                render_pipelines.insert(*name, pipeline);
            }
            Ok(Renderer {
                gpu,
                variant: variant.clone(),
                passes,
                width,
                height,
                depth,
                scene: scene_buffers,
                frame_group,
                targets,
                render_pipelines,
                tonemap_group,
            })
        })?
    }

    /// Render one frame and read back its images.
    pub fn render(&mut self) -> Result<FrameOutput, RenderError> {
        let gpu = self.gpu;
        let start = Instant::now();
        let timings = gpu.scoped("rendering a frame", || -> Result<Timings, GpuError> {
            let mut runner = PassRunner::new(gpu, self.passes.len() as u32 + 4);
            for pass in self.passes.clone() {
                runner.pass(pass.name, |encoder, slot| {
                    self.encode(pass.name, encoder, slot)
                })?;
            }
            runner.finish()
        })??;
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        let hdr = read_hdr(gpu, &self.targets.hdr)?;
        let ldr = read_texture(gpu, &self.targets.ldr, 4)?;
        Ok(FrameOutput {
            width: self.width,
            height: self.height,
            hdr,
            ldr: bytemuck::cast_slice(&ldr).to_vec(),
            timings,
            wall_ms,
        })
    }

    fn encode(
        &self,
        name: &str,
        encoder: &mut wgpu::CommandEncoder,
        slot: Option<TimestampSlot<'_>>,
    ) {
        match name {
            "depth_prepass" => self.draw_scene(name, encoder, slot, None, true),
            "forward" => {
                let hdr = self.targets.hdr.create_view(&Default::default());
                self.draw_scene(name, encoder, slot, Some(&hdr), !self.variant.depth_prepass);
            }
            "tonemap" => {
                let ldr = self.targets.ldr.create_view(&Default::default());
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some(name),
                    color_attachments: &[clear_attachment(&ldr)],
                    depth_stencil_attachment: None,
                    timestamp_writes: TimestampSlot::render(slot),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(&self.render_pipelines[name]);
                pass.set_bind_group(0, &self.tonemap_group, &[]);
                pass.draw(0..3, 0..1);
            }
            _ => unreachable!("Renderer::new refuses passes it cannot run"),
        }
    }

    /// Draw the scene geometry with pipeline `name` into `color` (if any), clearing or
    /// keeping depth.
    fn draw_scene(
        &self,
        name: &str,
        encoder: &mut wgpu::CommandEncoder,
        slot: Option<TimestampSlot<'_>>,
        color: Option<&wgpu::TextureView>,
        clear_depth: bool,
    ) {
        let depth_view = self.targets.depth.create_view(&Default::default());
        let colors = [color.and_then(clear_attachment)];
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(name),
            color_attachments: if color.is_some() { &colors } else { &[] },
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: if clear_depth {
                        wgpu::LoadOp::Clear(self.depth.clear())
                    } else {
                        wgpu::LoadOp::Load
                    },
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: TimestampSlot::render(slot),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.render_pipelines[name]);
        pass.set_bind_group(0, &self.frame_group, &[]);
        pass.set_vertex_buffer(0, self.scene.vertices.slice(..));
        pass.set_index_buffer(self.scene.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..self.scene.index_count, 0, 0..1);
    }
}

/// Read an HDR target (rgba32float or rgba16float) as f32.
fn read_hdr(gpu: &Gpu, texture: &wgpu::Texture) -> Result<Vec<[f32; 4]>, GpuError> {
    Ok(match texture.format() {
        wgpu::TextureFormat::Rgba16Float => {
            let bytes = read_texture(gpu, texture, 8)?;
            bytemuck::cast_slice::<u8, [u16; 4]>(&bytes)
                .iter()
                .map(|p| p.map(|h| half::f16::from_bits(h).to_f32()))
                .collect()
        }
        _ => bytemuck::cast_slice(&read_texture(gpu, texture, 16)?).to_vec(),
    })
}

/// Passes this version can run.
fn runnable(name: &str) -> bool {
    matches!(name, "depth_prepass" | "forward" | "tonemap")
}
