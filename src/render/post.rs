//! The post-processing chain: the compute passes that run between shading and tonemapping
//! (toon and outlines, bloom, motion blur), their images and bind groups.
//!
//! Shading writes the render target `shaded`; each post step reads one image and writes
//! another. The colour ping-pongs between two rgba32float storage images, and bloom keeps
//! its bright and blurred parts in two more; only the images a variant's steps use exist.

use super::clusters::{DISPATCH_ARGS_BYTES, WORD_BYTES};
use super::error::RenderError;
use super::passes::{ComputePipelines, set_compute_groups};
use super::reflect::PassLayout;
use super::resources::FrameResources;
use super::targets::Target;
use crate::compose::{ComposedPass, PostPass};
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
    pass: PostPass,
    entry: &'static str,
    input: Image,
    output: Image,
    extra: Option<Image>,
}

/// Which dispatches a variant's post passes make, in order, and which image holds the
/// final colour.
fn plan(v: &Variant, passes: &[PostPass]) -> (Vec<StepPlan>, Image) {
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
    for &pass in passes {
        match pass {
            PostPass::Toon => {
                let out = next_colour(colour);
                steps.push(step(pass, "toon", colour, out, Some(Image::Depth)));
                colour = out;
            }
            PostPass::BloomThreshold => {
                steps.push(step(pass, "threshold", colour, Image::Bloom(0), None))
            }
            PostPass::BloomBlur => {
                let kernel = v.post.bloom.as_ref().map(|b| b.kernel);
                if kernel == Some(BloomKernel::Naive) {
                    steps.push(step(pass, "blur", Image::Bloom(0), Image::Bloom(1), None));
                } else {
                    steps.push(step(
                        pass,
                        "blur_horizontal",
                        Image::Bloom(0),
                        Image::Bloom(1),
                        None,
                    ));
                    steps.push(step(
                        pass,
                        "blur_vertical",
                        Image::Bloom(1),
                        Image::Bloom(0),
                        None,
                    ));
                }
            }
            PostPass::BloomComposite => {
                let blurred = match steps.last() {
                    Some(s) => s.output,
                    None => Image::Bloom(0),
                };
                let out = next_colour(colour);
                steps.push(step(pass, "composite", colour, out, Some(blurred)));
                colour = out;
            }
            PostPass::MotionBlur => {
                let out = next_colour(colour);
                steps.push(step(pass, "motion_blur", colour, out, Some(Image::Depth)));
                colour = out;
            }
        }
    }
    (steps, colour)
}

struct Step {
    pass: PostPass,
    pipeline: wgpu::ComputePipeline,
    groups: Vec<Option<wgpu::BindGroup>>,
}

/// The post passes of a variant, ready to encode.
pub struct PostChain {
    steps: Vec<Step>,
    colour: [Option<Target>; 2],
    bloom: [Option<Target>; 2],
    output: Image,
    width: u32,
    height: u32,
    /// The blur's workgroup counts, written by the bright pass.
    blur_dispatch: Option<wgpu::Buffer>,
    /// Dispatch the blur indirectly (skipping it when nothing is bright).
    indirect_blur: bool,
}

impl PostChain {
    /// Build the images, pipelines and bind groups of `passes` (composed post passes of
    /// `v`), reading the shaded image and depth of `frame`. Call inside an error scope.
    pub fn new(
        gpu: &Gpu,
        v: &Variant,
        passes: &[(PostPass, &ComposedPass)],
        frame: &FrameResources,
    ) -> Result<Self, RenderError> {
        let ids: Vec<PostPass> = passes.iter().map(|(p, _)| *p).collect();
        let (plan, output) = plan(v, &ids);
        let shaded = &frame.targets.hdr;
        let (width, height) = (shaded.texture.width(), shaded.texture.height());
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
        let any_bloom = plan.iter().any(|s| s.pass == PostPass::BloomThreshold);
        let blur_dispatch = any_bloom.then(|| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("bloom blur dispatch"),
                size: DISPATCH_ARGS_BYTES,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::INDIRECT
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        });
        let target = |i: Image| -> &Target {
            match i {
                Image::Shaded => shaded,
                Image::Depth => &frame.targets.depth,
                Image::Colour(k) => colour[k].as_ref().expect("planned image exists"),
                Image::Bloom(k) => bloom[k].as_ref().expect("planned image exists"),
            }
        };
        // Per pass: its layout, and a pipeline for each entry point its steps use.
        let mut built = Vec::new();
        for &(pass, composed) in passes {
            let layout = PassLayout::of(gpu, composed)?;
            let entries: Vec<&'static str> = plan
                .iter()
                .filter(|s| s.pass == pass)
                .map(|s| s.entry)
                .collect();
            let pipelines = ComputePipelines::new(gpu, composed, &layout.pipeline, &entries)?;
            built.push((pass, layout, pipelines, composed));
        }
        let mut steps = Vec::new();
        for s in &plan {
            let Some((_, layout, pipelines, composed)) = built.iter().find(|b| b.0 == s.pass)
            else {
                continue;
            };
            // Group 1: the input image (0), the output image (1), an extra image (2) when
            // the step reads one, then the blur's dispatch buffer.
            let images: Vec<&Target> = [Some(s.input), Some(s.output), s.extra]
                .into_iter()
                .flatten()
                .map(target)
                .collect();
            let groups =
                layout.bind_groups(gpu, composed.name.as_str(), |slot| match slot.group {
                    0 => frame.scene_binding(slot),
                    1 => match images.get(slot.binding as usize) {
                        Some(t) => Some(wgpu::BindingResource::TextureView(&t.view)),
                        None => blur_dispatch.as_ref().map(|b| b.as_entire_binding()),
                    },
                    _ => None,
                })?;
            steps.push(Step {
                pass: s.pass,
                pipeline: pipelines.get(s.entry).clone(),
                groups,
            });
        }
        Ok(Self {
            steps,
            colour,
            bloom,
            output,
            width,
            height,
            blur_dispatch,
            indirect_blur: v.skip_unneeded,
        })
    }

    /// Whether the last frame's bloom blur ran no workgroup (no pixel passed the
    /// threshold). Reads back its workgroup count along x.
    pub fn blur_skipped(&self, gpu: &Gpu) -> Result<bool, crate::gpu::GpuError> {
        match &self.blur_dispatch {
            Some(b) if self.indirect_blur => {
                let at = std::mem::offset_of!(wgpu::util::DispatchIndirectArgs, x) as u64;
                let x = crate::gpu::read_buffer(gpu, b, at, WORD_BYTES)?;
                Ok(bytemuck::cast_slice::<u8, u32>(&x)[0] == 0)
            }
            _ => Ok(false),
        }
    }

    /// The image that holds the final colour: the last post step's output, or `shaded`.
    pub fn output<'a>(&'a self, shaded: &'a Target) -> &'a Target {
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

    /// Encode the dispatches of post pass `pass` as one compute pass.
    pub fn encode(
        &self,
        pass: PostPass,
        encoder: &mut wgpu::CommandEncoder,
        slot: Option<TimestampSlot<'_>>,
    ) {
        if pass == PostPass::BloomThreshold
            && let Some(b) = &self.blur_dispatch
        {
            encoder.clear_buffer(b, 0, None);
        }
        let mut cp = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(<&str>::from(pass)),
            timestamp_writes: TimestampSlot::compute(slot),
        });
        for s in self.steps.iter().filter(|s| s.pass == pass) {
            set_compute_groups(&mut cp, &s.groups);
            cp.set_pipeline(&s.pipeline);
            match &self.blur_dispatch {
                Some(b) if pass == PostPass::BloomBlur && self.indirect_blur => {
                    cp.dispatch_workgroups_indirect(b, 0)
                }
                _ => cp.dispatch_workgroups(self.width.div_ceil(8), self.height.div_ceil(8), 1),
            }
        }
    }
}

fn storage_image(gpu: &Gpu, label: &str, width: u32, height: u32) -> Target {
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
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
    });
    let view = texture.create_view(&Default::default());
    Target { texture, view }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::variant::{Bloom, MotionBlur, Outlines, Toon, ToonMode};

    fn names(v: &Variant) -> Vec<PostPass> {
        crate::compose::passes(v)
            .iter()
            .filter_map(|p| match p.id {
                crate::compose::PassId::Post(p) => Some(p),
                _ => None,
            })
            .collect()
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
