//! Running the WGSL twins of CPU functions on the GPU over many inputs (test kernels under
//! `shaders/passes/twin_*.wesl`), so tests can compare both sides.

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::compose::Composer;
use crate::gpu::{Gpu, read_buffer};
use crate::render::RenderError;

/// Run entry point `entry` of test kernel `root` once per input (64 a workgroup). Group 0
/// binds `inputs` (read-only storage) at 0.., then read-write outputs of the given byte
/// sizes; returns the outputs' bytes.
pub fn run_kernel(
    gpu: &Gpu,
    composer: &Composer,
    root: &str,
    entry: &str,
    invocations: u32,
    inputs: &[&[u8]],
    output_sizes: &[u64],
) -> Result<Vec<Vec<u8>>, RenderError> {
    // Kernels call functions directly, but every module's flags and constants must still be
    // defined: take those of the default variant.
    let v = crate::variant::Variant::default();
    let pass = composer.compose_root(
        root,
        &format!("passes::{root}"),
        &crate::compose::feature_flags(&v),
        &crate::compose::constants_module(&v),
    )?;
    let outputs = gpu.scoped(root, || {
        let module = crate::render::shader_module(gpu, &pass);
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
        let input_buffers: Vec<wgpu::Buffer> = inputs
            .iter()
            .map(|bytes| {
                // Storage bindings may not be empty.
                let contents: &[u8] = if bytes.is_empty() { &[0; 16] } else { bytes };
                gpu.device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("kernel input"),
                        contents,
                        usage: wgpu::BufferUsages::STORAGE,
                    })
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
        let entries: Vec<wgpu::BindGroupEntry> = input_buffers
            .iter()
            .chain(&output_buffers)
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
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

/// Parameters of the z-slicing kernel. Mirrors `SliceParams` in twin_zslice.wesl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct SliceParams {
    pub near: f32,
    pub far: f32,
    pub near_end: f32,
    pub tan_half_fov_y: f32,
    pub slices: u32,
    pub tiles_y: u32,
    pub count: u32,
    pub _pad: u32,
}

/// What the z-slicing kernel computed, per scheme: linear, exponential,
/// near-then-exponential, Olsson.
pub struct ZSliceResults {
    /// The slice of each depth.
    pub slices: Vec<[u32; 4]>,
    /// Where slice k begins, for k in 0..=slices.
    pub starts: Vec<[f32; 4]>,
}

/// Run the z-slicing functions of the WGSL on `depths`.
pub fn gpu_zslices(
    gpu: &Gpu,
    composer: &Composer,
    mut params: SliceParams,
    depths: &[f32],
) -> Result<ZSliceResults, RenderError> {
    params.count = depths.len() as u32;
    let n = depths.len().max(params.slices as usize + 1) as u32;
    let out = run_kernel(
        gpu,
        composer,
        "twin_zslice",
        "zslice_main",
        n,
        &[bytemuck::bytes_of(&params), bytemuck::cast_slice(depths)],
        &[depths.len() as u64 * 16, (params.slices as u64 + 1) * 16],
    )?;
    Ok(ZSliceResults {
        slices: bytemuck::cast_slice(&out[0]).to_vec(),
        starts: bytemuck::cast_slice(&out[1]).to_vec(),
    })
}

/// What the codec kernel computed.
pub struct CodecResults {
    /// Per normal: codes of octahedral, precise octahedral, polar, spheremap.
    pub codes: Vec<[[u32; 2]; 4]>,
    /// Per given code: its decode under octahedral, polar, spheremap.
    pub decoded: Vec<[[f32; 4]; 3]>,
}

/// The GPU's codes of `normals` (octahedral, precise octahedral, polar, spheremap) with
/// `bits` per component, and its decodes of `codes` (octahedral, polar, spheremap).
pub fn gpu_codecs(
    gpu: &Gpu,
    composer: &Composer,
    bits: u32,
    normals: &[[f32; 4]],
    codes: &[[u32; 2]],
) -> Result<CodecResults, RenderError> {
    let n = normals.len();
    assert_eq!(n, codes.len(), "one code per normal");
    let params = [bits, n as u32, 0, 0];
    let out = run_kernel(
        gpu,
        composer,
        "twin_codecs",
        "codec_main",
        n as u32,
        &[
            bytemuck::cast_slice(&params),
            bytemuck::cast_slice(normals),
            bytemuck::cast_slice(codes),
        ],
        &[n as u64 * 32, n as u64 * 48],
    )?;
    Ok(CodecResults {
        codes: bytemuck::cast_slice(&out[0]).to_vec(),
        decoded: bytemuck::cast_slice(&out[1]).to_vec(),
    })
}
