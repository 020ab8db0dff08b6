//! The post-processing chain: the compute passes that run between shading and tonemapping
//! (toon and outlines, bloom, motion blur), their images and bind groups.
//!
//! Shading writes the render target `shaded`; each post step reads one image and writes
//! another. The colour ping-pongs between two rgba32float storage images, and bloom keeps
//! its bright and blurred parts in two more; only the images a variant's steps use exist.

use std::collections::HashMap;

use super::passes::compute_pipeline;
use super::resources::texture_entry;
use crate::compose::ComposedPass;
use crate::gpu::{Gpu, TimestampSlot};
use crate::variant::{BloomKernel, Variant};

/// Format of every image a post step writes (`texture_storage_2d<rgba32float, write>`).
pub const POST_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// An image of the chain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Image {
    /// The shading pass's render target.
    Shaded,
    /// One of the two colour images.
    Colour(usize),
    /// One of the two bloom images (bright part, blur).
    Bloom(usize),
    /// The depth buffer.
    Depth,
}

/// One dispatch: an entry point of a pass, reading `input` (and `extra`), writing `output`.
#[derive(Clone, Copy, Debug)]
struct StepPlan {
    pass: &'static str,
    entry: &'static str,
    input: Image,
    output: Image,
    extra: Option<Image>,
}

/// Which dispatches a variant's post passes make, in order, and which image holds the
/// final colour.
fn plan(v: &Variant, pass_names: &[&str]) -> (Vec<StepPlan>, Image) {
    let mut steps = Vec::new();
    let mut colour = Image::Shaded;
    let next_colour = |c: Image| match c {
        Image::Colour(0) => Image::Colour(1),
        _ => Image::Colour(0),
    };
    let step = |pass, entry, input, output, extra| StepPlan {
        pass,
        entry,
        input,
        output,
        extra,
    };
    for &name in pass_names {
        match name {
            "toon" => {
                let out = next_colour(colour);
                steps.push(step("toon", "toon", colour, out, Some(Image::Depth)));
                colour = out;
            }
            "bloom_threshold" => steps.push(step(
                "bloom_threshold",
                "threshold",
                colour,
                Image::Bloom(0),
                None,
            )),
            "bloom_blur" => {
                let kernel = v.post.bloom.as_ref().map(|b| b.kernel);
                if kernel == Some(BloomKernel::Naive) {
                    steps.push(step(
                        "bloom_blur",
                        "blur",
                        Image::Bloom(0),
                        Image::Bloom(1),
                        None,
                    ));
                } else {
                    steps.push(step(
                        "bloom_blur",
                        "blur_horizontal",
                        Image::Bloom(0),
                        Image::Bloom(1),
                        None,
                    ));
                    steps.push(step(
                        "bloom_blur",
                        "blur_vertical",
                        Image::Bloom(1),
                        Image::Bloom(0),
                        None,
                    ));
                }
            }
            "bloom_composite" => {
                let blurred = match steps.last() {
                    Some(s) => s.output,
                    None => Image::Bloom(0),
                };
                let out = next_colour(colour);
                steps.push(step(
                    "bloom_composite",
                    "composite",
                    colour,
                    out,
                    Some(blurred),
                ));
                colour = out;
            }
            "motion_blur" => {
                let out = next_colour(colour);
                steps.push(step(
                    "motion_blur",
                    "motion_blur",
                    colour,
                    out,
                    Some(Image::Depth),
                ));
                colour = out;
            }
            _ => {}
        }
    }
    (steps, colour)
}

/// Whether a pass is a post-processing pass.
pub fn is_post(name: &str) -> bool {
    matches!(
        name,
        "toon" | "bloom_threshold" | "bloom_blur" | "bloom_composite" | "motion_blur"
    )
}

/// Whether a post pass reads the view uniform (group 0).
fn uses_view(pass: &str) -> bool {
    matches!(pass, "toon" | "motion_blur")
}

struct Step {
    pass: &'static str,
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
}

/// The post passes of a variant, ready to encode.
pub struct PostChain {
    steps: Vec<Step>,
    colour: [Option<wgpu::Texture>; 2],
    bloom: [Option<wgpu::Texture>; 2],
    output: Image,
    width: u32,
    height: u32,
    /// The blur's workgroup counts, written by the bright pass.
    blur_dispatch: Option<wgpu::Buffer>,
    /// Dispatch the blur indirectly (skipping it when nothing is bright).
    indirect_blur: bool,
}

/// The chain's inputs from the rest of the frame.
pub struct PostInputs<'a> {
    pub shaded: &'a wgpu::Texture,
    pub depth: &'a wgpu::Texture,
    pub frame_layout: &'a wgpu::BindGroupLayout,
}

impl PostChain {
    /// Build the images, pipelines and bind groups of `passes` (composed post passes of
    /// `v`, by name). Call inside an error scope.
    pub fn new(
        gpu: &Gpu,
        v: &Variant,
        passes: &[(&'static str, &ComposedPass)],
        inputs: PostInputs<'_>,
    ) -> Self {
        let names: Vec<&str> = passes.iter().map(|(n, _)| *n).collect();
        let (plan, output) = plan(v, &names);
        let (width, height) = (inputs.shaded.width(), inputs.shaded.height());
        let uses = |image: Image| {
            plan.iter()
                .any(|s| s.input == image || s.output == image || s.extra == Some(image))
        };
        let image = |label, image| uses(image).then(|| storage_image(gpu, label, width, height));
        let colour = [
            image("post colour 0", Image::Colour(0)),
            image("post colour 1", Image::Colour(1)),
        ];
        let bloom = [
            image("bloom 0", Image::Bloom(0)),
            image("bloom 1", Image::Bloom(1)),
        ];
        let any_bloom = plan.iter().any(|s| s.pass == "bloom_threshold");
        let blur_dispatch = any_bloom.then(|| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("bloom blur dispatch"),
                size: 12,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::INDIRECT
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        });
        let mut modules = HashMap::new();
        let mut steps = Vec::new();
        for s in &plan {
            let Some((_, composed)) = passes.iter().find(|(n, _)| *n == s.pass) else {
                continue;
            };
            let module = modules
                .entry(s.pass)
                .or_insert_with(|| super::shader_module(gpu, composed));
            let dispatch = dispatch_access(s.pass);
            let io = io_layout(gpu, s.extra.is_some(), dispatch);
            let view_layout = uses_view(s.pass).then_some(inputs.frame_layout);
            let layout = gpu
                .device
                .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some(s.pass),
                    bind_group_layouts: &[view_layout, Some(&io)],
                    immediate_size: 0,
                });
            let texture = |i: Image| -> &wgpu::Texture {
                match i {
                    Image::Shaded => inputs.shaded,
                    Image::Depth => inputs.depth,
                    Image::Colour(k) => colour[k].as_ref().expect("planned image exists"),
                    Image::Bloom(k) => bloom[k].as_ref().expect("planned image exists"),
                }
            };
            let views: Vec<wgpu::TextureView> = [Some(s.input), Some(s.output), s.extra]
                .into_iter()
                .flatten()
                .map(|i| texture(i).create_view(&Default::default()))
                .collect();
            let mut entries: Vec<wgpu::BindGroupEntry> = views
                .iter()
                .enumerate()
                .map(|(b, view)| wgpu::BindGroupEntry {
                    binding: b as u32,
                    resource: wgpu::BindingResource::TextureView(view),
                })
                .collect();
            if dispatch.is_some()
                && let Some(buffer) = &blur_dispatch
            {
                entries.push(wgpu::BindGroupEntry {
                    binding: entries.len() as u32,
                    resource: buffer.as_entire_binding(),
                });
            }
            steps.push(Step {
                pass: s.pass,
                pipeline: compute_pipeline(gpu, module, s.entry, &layout, s.entry),
                group: gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(s.entry),
                    layout: &io,
                    entries: &entries,
                }),
            });
        }
        Self {
            steps,
            colour,
            bloom,
            output,
            width,
            height,
            blur_dispatch,
            indirect_blur: v.skip_unneeded,
        }
    }

    /// Whether the last frame's bloom blur ran no workgroup (no pixel passed the
    /// threshold). Reads back 4 bytes.
    pub fn blur_skipped(&self, gpu: &Gpu) -> Result<bool, crate::gpu::GpuError> {
        match &self.blur_dispatch {
            Some(b) if self.indirect_blur => {
                let x = crate::gpu::read_buffer(gpu, b, 0, 4)?;
                Ok(bytemuck::cast_slice::<u8, u32>(&x)[0] == 0)
            }
            _ => Ok(false),
        }
    }

    /// The image that holds the final colour: the last post step's output, or `shaded`.
    pub fn output<'a>(&'a self, shaded: &'a wgpu::Texture) -> &'a wgpu::Texture {
        match self.output {
            Image::Colour(k) => self.colour[k].as_ref().expect("output exists"),
            _ => shaded,
        }
    }

    /// Bytes of the chain's own images per pixel.
    pub fn bytes_per_pixel(&self) -> u32 {
        let images = self.colour.iter().chain(&self.bloom).flatten().count() as u32;
        images * POST_FORMAT.block_copy_size(None).unwrap_or(16)
    }

    /// Encode the dispatches of post pass `name` as one compute pass.
    pub fn encode(
        &self,
        name: &str,
        encoder: &mut wgpu::CommandEncoder,
        slot: Option<TimestampSlot<'_>>,
        frame: &wgpu::BindGroup,
    ) {
        if name == "bloom_threshold"
            && let Some(b) = &self.blur_dispatch
        {
            encoder.clear_buffer(b, 0, None);
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(name),
            timestamp_writes: TimestampSlot::compute(slot),
        });
        for s in self.steps.iter().filter(|s| s.pass == name) {
            if uses_view(s.pass) {
                pass.set_bind_group(0, frame, &[]);
            }
            pass.set_bind_group(1, &s.group, &[]);
            pass.set_pipeline(&s.pipeline);
            match &self.blur_dispatch {
                Some(b) if name == "bloom_blur" && self.indirect_blur => {
                    pass.dispatch_workgroups_indirect(b, 0)
                }
                _ => pass.dispatch_workgroups(self.width.div_ceil(8), self.height.div_ceil(8), 1),
            }
        }
    }
}

/// How a post pass uses the blur's dispatch buffer (bound after its images): the bright
/// pass writes it, the composite reads it.
fn dispatch_access(pass: &str) -> Option<bool> {
    match pass {
        "bloom_threshold" => Some(false),
        "bloom_composite" => Some(true),
        _ => None,
    }
}

/// The images of a step: input (0), output (1), an extra texture (2) when it reads one,
/// then the dispatch buffer when `dispatch` says how it uses it (read-only or not).
fn io_layout(gpu: &Gpu, extra: bool, dispatch: Option<bool>) -> wgpu::BindGroupLayout {
    let mut entries = vec![
        texture_entry(0, wgpu::TextureSampleType::Float { filterable: false }),
        wgpu::BindGroupLayoutEntry {
            binding: 1,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::StorageTexture {
                access: wgpu::StorageTextureAccess::WriteOnly,
                format: POST_FORMAT,
                view_dimension: wgpu::TextureViewDimension::D2,
            },
            count: None,
        },
    ];
    if extra {
        // Depth binds as unfilterable float, like the other passes that read it.
        entries.push(texture_entry(
            2,
            wgpu::TextureSampleType::Float { filterable: false },
        ));
    }
    if let Some(read_only) = dispatch {
        entries.push(wgpu::BindGroupLayoutEntry {
            visibility: wgpu::ShaderStages::COMPUTE,
            ..super::resources::storage_entry(entries.len() as u32, read_only)
        });
    }
    gpu.device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("post images"),
            entries: &entries,
        })
}

fn storage_image(gpu: &Gpu, label: &str, width: u32, height: u32) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: POST_FORMAT,
        usage: wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::variant::{Bloom, MotionBlur, Outlines, Toon, ToonMode};

    fn names(v: &Variant) -> Vec<&'static str> {
        crate::compose::passes(v).iter().map(|p| p.name).collect()
    }

    #[test]
    fn every_effect_ping_pongs_to_the_final_image() {
        let mut v = Variant::default();
        v.post.toon = Some(Toon {
            mode: ToonMode::PostProcess,
            bands: 4,
            outlines: Some(Outlines::default()),
        });
        v.post.bloom = Some(Bloom::default());
        v.post.motion_blur = Some(MotionBlur::default());
        let (steps, out) = plan(&v, &names(&v));
        let chain: Vec<_> = steps.iter().map(|s| (s.entry, s.input, s.output)).collect();
        use Image::{Bloom as B, Colour as C, Shaded};
        assert_eq!(
            chain,
            [
                ("toon", Shaded, C(0)),
                ("threshold", C(0), B(0)),
                ("blur_horizontal", B(0), B(1)),
                ("blur_vertical", B(1), B(0)),
                ("composite", C(0), C(1)),
                ("motion_blur", C(1), C(0)),
            ]
        );
        assert_eq!(steps[4].extra, Some(B(0)));
        assert_eq!(out, C(0));
    }

    #[test]
    fn naive_bloom_composites_its_own_blur_and_no_effect_keeps_the_shaded_image() {
        let mut v = Variant::default();
        v.post.bloom = Some(Bloom {
            kernel: BloomKernel::Naive,
            ..Default::default()
        });
        let (steps, out) = plan(&v, &names(&v));
        assert_eq!(steps.len(), 3);
        assert_eq!(steps[2].extra, Some(Image::Bloom(1)));
        assert_eq!(steps[2].input, Image::Shaded);
        assert_eq!(out, Image::Colour(0));
        let plain = Variant::default();
        let (steps, out) = plan(&plain, &names(&plain));
        assert!(steps.is_empty());
        assert_eq!(out, Image::Shaded);
    }
}
