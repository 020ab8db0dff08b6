//! Test kernels: the shaders' own WGSL functions run on the GPU over many inputs (roots
//! `shaders/passes/kernel_*.wesl`), so tests can compare them with their CPU twins.

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::compose::Composer;
use crate::cpu::zslice::Slices;
use crate::gpu::{Gpu, read_buffer};
use crate::render::RenderError;
use crate::variant::{Clusters, NormalCodec, Pipeline, Variant};

/// What a kernel reads: a read-only storage buffer, or a depth texture.
pub enum KernelInput<'a> {
    Bytes(&'a [u8]),
    Depth(&'a wgpu::Texture),
}

/// Run a test kernel with the flags and constants of `variant` (kernels that call the
/// variant's own functions, such as `encode_normal`), on inputs that may be depth textures.
#[allow(clippy::too_many_arguments)]
pub fn run_kernel_for(
    gpu: &Gpu,
    composer: &Composer,
    variant: &Variant,
    root: &str,
    entry: &str,
    invocations: u32,
    inputs: &[KernelInput],
    output_sizes: &[u64],
) -> Result<Vec<Vec<u8>>, RenderError> {
    run_kernel_with(
        gpu,
        composer,
        (variant, &[]),
        root,
        entry,
        invocations,
        inputs,
        output_sizes,
    )
}

/// [`run_kernel_for`] with flags of the kernel's own besides the variant's.
#[allow(clippy::too_many_arguments)]
fn run_kernel_with(
    gpu: &Gpu,
    composer: &Composer,
    (variant, kernel_flags): (&Variant, &[(&'static str, bool)]),
    root: &str,
    entry: &str,
    invocations: u32,
    inputs: &[KernelInput],
    output_sizes: &[u64],
) -> Result<Vec<Vec<u8>>, RenderError> {
    let mut features = crate::compose::feature_flags(variant);
    features.extend_from_slice(kernel_flags);
    let pass = composer.compose_root(
        root,
        &format!("passes::{root}"),
        &features,
        &crate::compose::constants_module(variant),
        crate::compose::LightLoop::of(variant),
    )?;
    let outputs = gpu.scoped(root, || {
        let module = gpu
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(root),
                source: wgpu::ShaderSource::Wgsl(pass.wgsl.as_str().into()),
            });
        let pipeline = gpu
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(root),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            });
        let input_resources: Vec<InputResource> = inputs
            .iter()
            .map(|input| match input {
                KernelInput::Bytes(bytes) => {
                    // Storage bindings may not be empty.
                    let contents: &[u8] = if bytes.is_empty() { &[0; 16] } else { bytes };
                    InputResource::Buffer(gpu.device.create_buffer_init(
                        &wgpu::util::BufferInitDescriptor {
                            label: Some("kernel input"),
                            contents,
                            usage: wgpu::BufferUsages::STORAGE,
                        },
                    ))
                }
                KernelInput::Depth(texture) => {
                    InputResource::Texture(texture.create_view(&wgpu::TextureViewDescriptor {
                        aspect: wgpu::TextureAspect::DepthOnly,
                        ..Default::default()
                    }))
                }
            })
            .collect();
        let output_buffers: Vec<wgpu::Buffer> = output_sizes
            .iter()
            .map(|&size| {
                gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("kernel output"),
                    size: size.max(16),
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                })
            })
            .collect();
        let entries: Vec<wgpu::BindGroupEntry> = input_resources
            .iter()
            .map(|r| match r {
                InputResource::Buffer(b) => b.as_entire_binding(),
                InputResource::Texture(view) => wgpu::BindingResource::TextureView(view),
            })
            .chain(output_buffers.iter().map(|b| b.as_entire_binding()))
            .enumerate()
            .map(|(i, resource)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource,
            })
            .collect();
        let group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(root),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(invocations.div_ceil(64).max(1), 1, 1);
        }
        gpu.queue.submit([encoder.finish()]);
        output_buffers
    })?;
    outputs
        .iter()
        .zip(output_sizes)
        .map(|(b, &size)| Ok(read_buffer(gpu, b, 0, size.max(16))?[..size as usize].to_vec()))
        .collect()
}

enum InputResource {
    Buffer(wgpu::Buffer),
    Texture(wgpu::TextureView),
}

/// Parameters of the z-slicing kernel. Mirrors `SliceParams` in kernel_zslice.wesl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct SliceParams {
    near: f32,
    far: f32,
    tan_half_fov_y: f32,
    tiles_y: u32,
    count: u32,
    starts: u32,
    _pad: [u32; 2],
}

/// What the z-slicing kernel computed for one scheme.
pub struct ZSliceResults {
    /// The slice of each depth.
    pub slices: Vec<u32>,
    /// Where slice k begins, for k in 0..=count (slice `count` begins at far).
    pub starts: Vec<f32>,
}

/// Run the variant's own z-slicing (`z_slice`, `slice_near_depth` of zslice.wesl, composed
/// with `slices.scheme` and a grid of `slices.count` slices) on `depths`. Any scheme: the
/// kernel is the same for all.
pub fn gpu_zslices(
    gpu: &Gpu,
    composer: &Composer,
    slices: &Slices,
    depths: &[f32],
) -> Result<ZSliceResults, RenderError> {
    let variant = Variant {
        pipeline: Pipeline::ClusteredForward,
        clusters: Some(Clusters {
            grid: (1, slices.tiles_y, slices.count),
            slicing: slices.scheme,
            ..Clusters::default()
        }),
        ..Variant::default()
    };
    let params = SliceParams {
        near: slices.near as f32,
        far: slices.far as f32,
        tan_half_fov_y: slices.tan_half_fov_y as f32,
        tiles_y: slices.tiles_y,
        count: depths.len() as u32,
        starts: slices.count + 1,
        _pad: [0; 2],
    };
    let n = depths.len().max(slices.count as usize + 1) as u32;
    let out = run_kernel_for(
        gpu,
        composer,
        &variant,
        "kernel_zslice",
        "zslice_main",
        n,
        &[
            KernelInput::Bytes(bytemuck::bytes_of(&params)),
            KernelInput::Bytes(bytemuck::cast_slice(depths)),
        ],
        &[depths.len() as u64 * 4, (slices.count as u64 + 1) * 4],
    )?;
    Ok(ZSliceResults {
        slices: bytemuck::cast_slice(&out[0]).to_vec(),
        starts: bytemuck::cast_slice(&out[1]).to_vec(),
    })
}

/// What the codec kernel computed for one codec.
pub struct CodecResults {
    /// Per normal: its code.
    pub codes: Vec<[u32; 2]>,
    /// Per given code: its decode.
    pub decoded: Vec<[f32; 4]>,
}

/// A deferred variant whose G-buffer stores normals with `codec`.
fn with_codec(codec: NormalCodec) -> Variant {
    Variant {
        pipeline: Pipeline::ClusteredDeferred,
        gbuffer: Some(crate::variant::GBuffer {
            layout: crate::variant::GBufferLayout::Packed,
        }),
        normals: Some(codec),
        ..Variant::default()
    }
}

/// The GPU's codes of `normals` under `codec`, and its decodes of `codes`: the G-buffer's
/// own `encode_normal` and `decode_normal`, composed for that codec. Any packed codec: the
/// kernel is the same for all.
pub fn gpu_codecs(
    gpu: &Gpu,
    composer: &Composer,
    codec: NormalCodec,
    normals: &[[f32; 4]],
    codes: &[[u32; 2]],
) -> Result<CodecResults, RenderError> {
    codec_kernel(gpu, composer, codec, normals, codes, false)
}

/// [`gpu_codecs`] for the polar codec with the encoder it had before this project fixed it
/// (the polar angle from `acos(z)`; codes up to 4 steps off at 16 bits on lavapipe). A
/// deliberate break, kept so that the tests can show their codec check rejects it.
pub fn gpu_codecs_old_acos_polar(
    gpu: &Gpu,
    composer: &Composer,
    bits: u32,
    normals: &[[f32; 4]],
    codes: &[[u32; 2]],
) -> Result<CodecResults, RenderError> {
    let polar = NormalCodec::Polar { bits: 2 * bits };
    codec_kernel(gpu, composer, polar, normals, codes, true)
}

fn codec_kernel(
    gpu: &Gpu,
    composer: &Composer,
    codec: NormalCodec,
    normals: &[[f32; 4]],
    codes: &[[u32; 2]],
    old_acos_polar: bool,
) -> Result<CodecResults, RenderError> {
    let n = normals.len();
    assert_eq!(n, codes.len(), "one code per normal");
    let params = [n as u32, 0, 0, 0];
    let out = run_kernel_with(
        gpu,
        composer,
        (
            &with_codec(codec),
            &[("kernel_old_acos_polar", old_acos_polar)],
        ),
        "kernel_codecs",
        "codec_main",
        n as u32,
        &[
            KernelInput::Bytes(bytemuck::cast_slice(&params)),
            KernelInput::Bytes(bytemuck::cast_slice(normals)),
            KernelInput::Bytes(bytemuck::cast_slice(codes)),
        ],
        &[n as u64 * 8, n as u64 * 16],
    )?;
    Ok(CodecResults {
        codes: bytemuck::cast_slice(&out[0]).to_vec(),
        decoded: bytemuck::cast_slice(&out[1]).to_vec(),
    })
}

/// Round trips of `normals` through the G-buffer's own path with `codec`: `encode_normal`,
/// `pack_code`, `unpack_code` and `decode_normal` of `shaders/packing/normals.wesl`, composed
/// as a deferred variant with that codec composes them. Returns each normal's packed code and
/// its decode. `codec` must not be `Xyz` (no code to pack).
pub fn gpu_codec_round_trip(
    gpu: &Gpu,
    composer: &Composer,
    codec: NormalCodec,
    normals: &[[f32; 4]],
) -> Result<(Vec<u32>, Vec<[f32; 4]>), RenderError> {
    assert!(
        codec != NormalCodec::Xyz,
        "xyz floats are stored, not packed"
    );
    let variant = with_codec(codec);
    let (mut codes, mut decoded) = (Vec::new(), Vec::new());
    // Batches keep the storage buffers well under the binding size limit.
    for batch in normals.chunks(1 << 18) {
        let n = batch.len();
        let params = [n as u32, 0, 0, 0];
        let out = run_kernel_for(
            gpu,
            composer,
            &variant,
            "kernel_codec_round_trip",
            "round_trip_main",
            n as u32,
            &[
                KernelInput::Bytes(bytemuck::cast_slice(&params)),
                KernelInput::Bytes(bytemuck::cast_slice(batch)),
            ],
            &[n as u64 * 4, n as u64 * 16],
        )?;
        codes.extend_from_slice(bytemuck::cast_slice(&out[0]));
        decoded.extend_from_slice(bytemuck::cast_slice(&out[1]));
    }
    Ok((codes, decoded))
}

/// A depth buffer as the GPU reads it: each texel's stored value, and the view depth that
/// `view_depth_from_device` (with `variant`'s depth mapping) rebuilds from it.
pub struct DepthSamples {
    pub device: Vec<f32>,
    pub view_depth: Vec<f32>,
}

/// Read `depth` (any depth format, Depth24Plus included, which cannot be copied out) with a
/// compute pass that loads each texel.
pub fn gpu_depth_samples(
    gpu: &Gpu,
    composer: &Composer,
    variant: &Variant,
    depth: &wgpu::Texture,
    near: f32,
    far: f32,
) -> Result<DepthSamples, RenderError> {
    let (w, h) = (depth.width(), depth.height());
    let n = w * h;
    let params: [u32; 4] = [w, h, near.to_bits(), far.to_bits()];
    let out = run_kernel_for(
        gpu,
        composer,
        variant,
        "kernel_depth",
        "depth_main",
        n,
        &[
            KernelInput::Bytes(bytemuck::cast_slice(&params)),
            KernelInput::Depth(depth),
        ],
        &[n as u64 * 8],
    )?;
    let pairs: &[[f32; 2]] = bytemuck::cast_slice(&out[0]);
    Ok(DepthSamples {
        device: pairs.iter().map(|p| p[0]).collect(),
        view_depth: pairs.iter().map(|p| p[1]).collect(),
    })
}
