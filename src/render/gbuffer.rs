//! G-buffer targets per layout, and the group-2 bindings that read them (with depth).
//! Mirrors `shaders/packing/gbuffer.wesl`.

use super::resources::{F32_BITS_FORMAT, target, texture_entry};
use crate::gpu::Gpu;
use crate::variant::GBufferLayout;

/// The colour targets of a layout, in location order.
pub fn formats(layout: GBufferLayout) -> Vec<wgpu::TextureFormat> {
    match layout {
        GBufferLayout::Wide => vec![F32_BITS_FORMAT; 3],
        GBufferLayout::Packed => vec![F32_BITS_FORMAT; 2],
        GBufferLayout::Compact => vec![
            wgpu::TextureFormat::Rgba8Unorm,
            wgpu::TextureFormat::R32Uint,
        ],
    }
}

/// Bytes a pixel of the layout takes, depth included (4 bytes).
pub fn bytes_per_pixel(layout: GBufferLayout) -> u32 {
    4 + formats(layout)
        .iter()
        .map(|f| f.block_copy_size(None).unwrap_or(0))
        .sum::<u32>()
}

pub fn targets(gpu: &Gpu, layout: GBufferLayout, w: u32, h: u32) -> Vec<wgpu::Texture> {
    formats(layout)
        .into_iter()
        .enumerate()
        .map(|(i, f)| target(gpu, &format!("gbuffer {i}"), w, h, f))
        .collect()
}

fn sample_type(format: wgpu::TextureFormat) -> wgpu::TextureSampleType {
    match format {
        wgpu::TextureFormat::Rgba8Unorm => wgpu::TextureSampleType::Float { filterable: false },
        _ => wgpu::TextureSampleType::Uint,
    }
}

/// Group 2: depth at binding 0, then the layout's targets (none for `None`: depth only).
pub fn read_layout(gpu: &Gpu, layout: Option<GBufferLayout>) -> wgpu::BindGroupLayout {
    // Depth binds as unfilterable float: naga's GLSL output cannot load from depth textures.
    let mut entries = vec![texture_entry(
        0,
        wgpu::TextureSampleType::Float { filterable: false },
    )];
    if let Some(layout) = layout {
        for (i, f) in formats(layout).into_iter().enumerate() {
            entries.push(texture_entry(i as u32 + 1, sample_type(f)));
        }
    }
    gpu.device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("gbuffer read"),
            entries: &entries,
        })
}

pub fn read_group(
    gpu: &Gpu,
    layout: &wgpu::BindGroupLayout,
    depth: &wgpu::Texture,
    targets: &[wgpu::Texture],
) -> wgpu::BindGroup {
    let views: Vec<wgpu::TextureView> = std::iter::once(depth)
        .chain(targets)
        .map(|t| t.create_view(&Default::default()))
        .collect();
    let entries: Vec<_> = views
        .iter()
        .enumerate()
        .map(|(i, v)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: wgpu::BindingResource::TextureView(v),
        })
        .collect();
    gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("gbuffer read"),
        layout,
        entries: &entries,
    })
}
