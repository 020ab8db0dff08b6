//! The raster truth pass: the same rasterisation as the variant (same vertex transform,
//! depth format and test, and a depth pre-pass when the variant has one), written as
//! 32-bit floats for the CPU reference.
//!
//! The pre-pass matters: with it, shading keeps every fragment whose depth *equals* the
//! nearest, so where two surfaces tie exactly (along a shared edge) the last one drawn
//! wins, where a plain `Less` test keeps the first. Multisampled, the pre-pass also records
//! each sample's kept fragment and the truth writes only its own samples, as the variant's
//! shading pass does (`common/sample_owner.wesl`).

use super::error::RenderError;
use super::passes::{
    ComputePipelines, clear_attachment, color_target, render_pipeline, set_compute_groups,
};
use super::reflect::{BufferSizes, PassLayout, Slot};
use super::resources::SceneBuffers;
use super::targets::{DepthSetup, SHADING_DEPTH_FORMAT, multisampled_target};
use crate::common::Vertex;
use crate::compose::Composer;
use crate::cpu::truth::{BlendedFragment, MAX_BLENDED_FRAGMENTS, RasterTruth};
use crate::gpu::{Gpu, read_buffer, read_texture};
use crate::render::bindings::Binding;
use crate::scene::Scene;
use crate::variant::Variant;
use wgpu::util::DeviceExt;

use super::targets::F32_BITS_FORMAT as TRUTH_FORMAT;

/// Rasterise `scene` with `variant`'s depth set-up and sample count, and read back position,
/// normal, albedo of every sample.
pub fn raster_truth(
    gpu: &Gpu,
    composer: &Composer,
    variant: &Variant,
    scene: &Scene,
) -> Result<RasterTruth, RenderError> {
    let (w, h) = (scene.params.width, scene.params.height);
    gpu.check_size(w, h)?;
    gpu.check_scene(scene)?;
    let features = crate::compose::features_with(
        variant,
        &crate::compose::SceneFeatures::of(scene, true).flags(),
    );
    let pass = composer.compose_root(
        "truth",
        "passes::truth",
        &features,
        &crate::compose::constants_module(variant),
        crate::compose::LightLoop::of(variant),
    )?;
    let prepass = if variant.depth_prepass {
        Some(composer.compose_root(
            "truth depth pre-pass",
            "passes::depth_prepass",
            &features,
            &crate::compose::constants_module(variant),
            crate::compose::LightLoop::of(variant),
        )?)
    } else {
        None
    };
    let blended_pass = if scene.has_blend() {
        Some(composer.compose_root(
            "truth of blended materials",
            "passes::truth_blended",
            &features,
            &crate::compose::constants_module(variant),
            crate::compose::LightLoop::of(variant),
        )?)
    } else {
        None
    };
    let depth = DepthSetup::of(variant);
    let (textures, blended, blended_offsets) =
        gpu.scoped("raster truth", || -> Result<_, RenderError> {
            let buffers = SceneBuffers::upload(gpu, scene, depth.mapping, None);
            let samples = variant.msaa.samples;
            // Multisampled after a pre-pass, the pre-pass decides which fragment each sample
            // shows, as in the variant (`common/sample_owner.wesl`).
            let kept = |label| {
                (variant.msaa.on() && prepass.is_some()).then(|| {
                    multisampled_target(gpu, label, (w, h), SHADING_DEPTH_FORMAT, samples)
                        .create_view(&Default::default())
                })
            };
            let (shading_depth, sample_owner) =
                (kept("truth shading depth"), kept("truth sample owner"));
            let frame = |slot: &Slot| match slot.name {
                Binding::ShadingDepth => shading_depth
                    .as_ref()
                    .map(wgpu::BindingResource::TextureView),
                Binding::SampleOwner => sample_owner
                    .as_ref()
                    .map(wgpu::BindingResource::TextureView),
                name => buffers.frame_binding(name),
            };
            let layout = PassLayout::of(gpu, &pass)?;
            let groups = layout.bind_groups(gpu, "truth", frame)?;
            let vertex = [Some(SceneBuffers::vertex_layout())];
            let depth_state = if prepass.is_some() {
                depth.state(wgpu::CompareFunction::Equal, false)
            } else {
                depth.state(depth.compare(), true)
            };
            // Each group of targets is drawn whole, from a cleared depth: the same draws and
            // tests pick the same fragment every time, so the groups agree sample for sample.
            let pipelines = truth_target_groups(gpu)
                .iter()
                .map(|group| {
                    let targets: Vec<_> = (0..TRUTH_TARGETS)
                        .map(|t| {
                            group
                                .contains(&t)
                                .then(|| color_target(TRUTH_FORMAT))
                                .flatten()
                        })
                        .collect();
                    let pipeline = render_pipeline(
                        gpu,
                        &pass,
                        &layout.pipeline,
                        ("vs_main", Some("fs_main")),
                        &vertex,
                        &targets,
                        Some(depth_state.clone()),
                        variant.msaa.samples,
                    )?;
                    Ok((pipeline, *group))
                })
                .collect::<Result<Vec<_>, RenderError>>()?;
            let prepass_pipeline = match &prepass {
                Some(p) => {
                    let layout = PassLayout::of(gpu, p)?;
                    let groups = layout.bind_groups(gpu, "truth depth pre-pass", frame)?;
                    // Masked materials discard in the pre-pass too.
                    let (fs, targets) = if shading_depth.is_some() {
                        let target = color_target(SHADING_DEPTH_FORMAT);
                        (Some("fs_shading_depth"), vec![target.clone(), target])
                    } else {
                        (scene.has_masks().then_some("fs_mask"), Vec::new())
                    };
                    let pipeline = render_pipeline(
                        gpu,
                        p,
                        &layout.pipeline,
                        ("vs_main", fs),
                        &vertex,
                        &targets,
                        Some(depth.state(depth.compare(), true)),
                        samples,
                    )?;
                    Some((pipeline, groups))
                }
                None => None,
            };
            let textures: Vec<wgpu::Texture> = ["truth position", "truth normal", "truth albedo"]
                .iter()
                .map(|label| multisampled_target(gpu, label, (w, h), TRUTH_FORMAT, samples))
                .collect();
            let depth_texture =
                multisampled_target(gpu, "truth depth", (w, h), depth.format, samples);
            let views: Vec<wgpu::TextureView> = textures
                .iter()
                .map(|t| t.create_view(&Default::default()))
                .collect();
            let depth_view = depth_texture.create_view(&Default::default());
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
            for (pipeline, targets) in &pipelines {
                let draws = prepass_pipeline
                    .iter()
                    .map(|(p, g)| (p, g, false))
                    .chain([(pipeline, &groups, true)]);
                for (i, (pipeline, groups, colors)) in draws.enumerate() {
                    let attachments: Vec<_> = if colors {
                        (0..TRUTH_TARGETS)
                            .map(|t| {
                                targets
                                    .contains(&t)
                                    .then(|| clear_attachment(&views[t]))
                                    .flatten()
                            })
                            .collect()
                    } else {
                        shading_depth
                            .iter()
                            .chain(&sample_owner)
                            .map(clear_attachment)
                            .collect()
                    };
                    let mut rp = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                        label: Some("truth"),
                        color_attachments: &attachments,
                        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                            view: &depth_view,
                            depth_ops: Some(wgpu::Operations {
                                load: if i == 0 {
                                    wgpu::LoadOp::Clear(depth.clear())
                                } else {
                                    wgpu::LoadOp::Load
                                },
                                store: wgpu::StoreOp::Store,
                            }),
                            stencil_ops: None,
                        }),
                        timestamp_writes: None,
                        occlusion_query_set: None,
                        multiview_mask: None,
                    });
                    rp.set_pipeline(pipeline);
                    for (g, group) in groups.iter().enumerate() {
                        if let Some(group) = group {
                            rp.set_bind_group(g as u32, group, &[]);
                        }
                    }
                    // No opaque triangle (every material blended): the targets stay clear.
                    if buffers.index_count > 0 {
                        rp.set_vertex_buffer(0, buffers.vertices.slice(..));
                        rp.set_index_buffer(buffers.indices.slice(..), wgpu::IndexFormat::Uint32);
                        rp.draw_indexed(0..buffers.index_count, 0, 0..1);
                    }
                }
            }
            gpu.queue.submit([encoder.finish()]);
            let (blended, offsets) = if let Some(pass) = &blended_pass {
                let blend = BlendedDraw {
                    pass,
                    layout: &PassLayout::of(gpu, pass)?,
                    buffers: &buffers,
                    depth_view: &depth_view,
                    target: &views[0],
                };
                record_blended(gpu, scene, &blend)?
            } else {
                (Vec::new(), Vec::new())
            };
            Ok((textures, blended, offsets))
        })??;
    let mut planes = Vec::with_capacity(3);
    for t in &textures {
        let bytes = if variant.msaa.on() {
            read_samples(gpu, composer, t)?
        } else {
            read_texture(gpu, t)?
        };
        // The targets hold f32 bit patterns: read them back as f32.
        planes.push(bytemuck::cast_slice::<u8, [f32; 4]>(&bytes).to_vec());
    }
    let albedo = planes.pop().unwrap_or_default();
    let normal = planes.pop().unwrap_or_default();
    let position = planes.pop().unwrap_or_default();
    Ok(RasterTruth {
        width: w,
        height: h,
        samples: variant.msaa.samples,
        position,
        normal,
        albedo,
        blended,
        blended_offsets,
    })
}

/// The truth's targets: position, normal, albedo (`passes/truth.wesl`).
const TRUTH_TARGETS: usize = 3;

/// The truth's targets in groups one draw can write: all three at once where the device
/// takes 48 bytes of colour a sample, else position and normal, then albedo (WebGPU's
/// default limit is 32 bytes; the truth is the reference's, not the variant's, so the
/// limits a variant is checked against say nothing of it).
fn truth_target_groups(gpu: &Gpu) -> &'static [&'static [usize]] {
    let bytes = TRUTH_FORMAT
        .target_pixel_byte_cost()
        .expect("a renderable format");
    if gpu.device.limits().max_color_attachment_bytes_per_sample >= TRUTH_TARGETS as u32 * bytes {
        &[&[0, 1, 2]]
    } else {
        &[&[0, 1], &[2]]
    }
}

/// What the blended draws of the truth share with its opaque draw.
struct BlendedDraw<'a> {
    pass: &'a crate::compose::ComposedPass,
    layout: &'a PassLayout,
    buffers: &'a SceneBuffers,
    depth_view: &'a wgpu::TextureView,
    /// A colour target to draw with, written nothing (a render pass needs an attachment,
    /// and the depth cannot be one: the shaders read it, which OpenGL's wgpu refuses even
    /// read-only).
    target: &'a wgpu::TextureView,
}

/// Every blended fragment in front of the opaque surface, pixel by pixel in draw order, and
/// where each pixel's start (`RasterTruth::blended`, `blended_offsets`).
fn record_blended(
    gpu: &Gpu,
    scene: &Scene,
    draw: &BlendedDraw<'_>,
) -> Result<(Vec<BlendedFragment>, Vec<u32>), RenderError> {
    let (w, h) = (scene.params.width, scene.params.height);
    let pixels = w as u64 * h as u64;
    // The blended triangles in draw order, unindexed: a vertex's index over 3 is its
    // triangle's place in the draw.
    let vertices: Vec<Vertex> = scene
        .blend_order()
        .iter()
        .map(|&i| scene.vertices[i as usize])
        .collect();
    let storage =
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC;
    // Each buffer at the size `truth_blended.wesl` declares it.
    let sizes = BufferSizes::of([draw.pass])?;
    let buffer = |name: Binding, count: u64| {
        gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(name.name()),
            size: sizes.bindable(name, count),
            usage: storage,
            mapped_at_creation: false,
        })
    };
    let vertex_buffer = gpu
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("truth blended vertices"),
            contents: bytemuck::cast_slice(&vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
    let counts = buffer(Binding::FragmentCounts, pixels);
    let offsets = buffer(Binding::FragmentOffsets, pixels);
    let vertex = [Some(SceneBuffers::vertex_layout())];
    let pipeline = |fs: &str| {
        render_pipeline(
            gpu,
            draw.pass,
            &draw.layout.pipeline,
            ("vs_blended", Some(fs)),
            &vertex,
            &[Some(wgpu::ColorTargetState {
                write_mask: wgpu::ColorWrites::empty(),
                ..color_target(TRUTH_FORMAT).expect("a target")
            })],
            None,
            1,
        )
    };
    let groups = |fragments: &wgpu::Buffer| {
        draw.layout
            .bind_groups(gpu, "truth blended", |slot: &Slot| match slot.name {
                Binding::FragmentCounts => Some(counts.as_entire_binding()),
                Binding::FragmentOffsets => Some(offsets.as_entire_binding()),
                Binding::Fragments => Some(fragments.as_entire_binding()),
                Binding::DepthTexture => Some(wgpu::BindingResource::TextureView(draw.depth_view)),
                name => draw.buffers.frame_binding(name),
            })
    };
    let run = |pipeline: &wgpu::RenderPipeline, groups: &[Option<wgpu::BindGroup>]| {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let target = Some(wgpu::RenderPassColorAttachment {
                view: draw.target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            });
            let mut rp = super::passes::begin_render(
                &mut encoder,
                "truth blended",
                &[target],
                None,
                None,
                groups,
            );
            rp.set_pipeline(pipeline);
            rp.set_vertex_buffer(0, vertex_buffer.slice(..));
            rp.draw(0..vertices.len() as u32, 0..1);
        }
        gpu.queue.submit([encoder.finish()]);
    };
    // Room for one fragment a pixel to count with; the writing draw gets what it needs.
    let first = buffer(Binding::Fragments, pixels);
    run(&pipeline("fs_count")?, &groups(&first)?);
    let per_pixel: Vec<u32> =
        bytemuck::cast_slice(&read_buffer(gpu, &counts, 0, counts.size())?).to_vec();
    if let Some((i, &n)) = per_pixel.iter().enumerate().max_by_key(|(_, n)| **n)
        && n > MAX_BLENDED_FRAGMENTS
    {
        return Err(RenderError::Scene(format!(
            "pixel ({}, {}) of scene `{}` has {n} blended fragments in front of its opaque surface; the reference records at most {MAX_BLENDED_FRAGMENTS} a pixel",
            i as u64 % w as u64,
            i as u64 / w as u64,
            scene.name
        )));
    }
    let mut starts = Vec::with_capacity(per_pixel.len() + 1);
    let mut total = 0u32;
    for &n in &per_pixel {
        starts.push(total);
        total += n;
    }
    starts.push(total);
    let size = sizes.bytes(Binding::Fragments, total as u64).unwrap_or(0);
    if size > gpu.max_storage_bytes() {
        return Err(RenderError::Scene(format!(
            "scene `{}` has {total} blended fragments in front of its opaque surfaces: {size} bytes to record, more than adapter `{}` binds in one buffer ({})",
            scene.name,
            gpu.adapter.name,
            gpu.max_storage_bytes()
        )));
    }
    let fragments = if total as u64 <= pixels {
        first
    } else {
        buffer(Binding::Fragments, total as u64)
    };
    gpu.queue.write_buffer(
        &offsets,
        0,
        bytemuck::cast_slice(&starts[..per_pixel.len()]),
    );
    let mut clear = gpu.device.create_command_encoder(&Default::default());
    clear.clear_buffer(&counts, 0, None);
    gpu.queue.submit([clear.finish()]);
    run(&pipeline("fs_record")?, &groups(&fragments)?);
    let mut recorded: Vec<BlendedFragment> =
        bytemuck::cast_slice(&read_buffer(gpu, &fragments, 0, fragments.size())?[..size as usize])
            .to_vec();
    // Each pixel's fragments in the order they are blended.
    for pixel in starts.windows(2) {
        recorded[pixel[0] as usize..pixel[1] as usize].sort_by_key(|f| f.order[0]);
    }
    Ok((recorded, starts))
}

/// Every sample of a multisampled truth target, pixel by pixel (`passes/truth_samples.wesl`).
fn read_samples(
    gpu: &Gpu,
    composer: &Composer,
    texture: &wgpu::Texture,
) -> Result<Vec<u8>, RenderError> {
    let pass = composer.compose_root(
        "truth samples",
        "passes::truth_samples",
        &[],
        "",
        Default::default(),
    )?;
    let (w, h) = (texture.width(), texture.height());
    let samples = w as u64 * h as u64 * texture.sample_count() as u64;
    let size = BufferSizes::of([&pass])?.bindable(Binding::TruthSamples, samples);
    let buffer = gpu.scoped(
        "reading the truth's samples",
        || -> Result<_, RenderError> {
            let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("truth samples"),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let view = texture.create_view(&Default::default());
            let layout = PassLayout::of(gpu, &pass)?;
            let groups = layout.bind_groups(gpu, "truth samples", |slot| match slot.name {
                Binding::TruthTarget => Some(wgpu::BindingResource::TextureView(&view)),
                Binding::TruthSamples => Some(buffer.as_entire_binding()),
                _ => None,
            })?;
            let pipelines = ComputePipelines::new(gpu, &pass, &layout.pipeline, &["copy_samples"])?;
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
            {
                let mut cp = encoder.begin_compute_pass(&Default::default());
                cp.set_pipeline(pipelines.get("copy_samples"));
                set_compute_groups(&mut cp, &groups);
                let [x, y, z] = pipelines.groups_for("copy_samples", [w, h, 1]);
                cp.dispatch_workgroups(x, y, z);
            }
            gpu.queue.submit([encoder.finish()]);
            Ok(buffer)
        },
    )??;
    Ok(read_buffer(gpu, &buffer, 0, size)?)
}
