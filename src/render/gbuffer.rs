//! G-buffer targets per layout. Mirrors `shaders/packing/gbuffer.wesl`.

use super::resources::{F32_BITS_FORMAT, Target};
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

pub fn targets(gpu: &Gpu, layout: GBufferLayout, w: u32, h: u32) -> Vec<Target> {
    formats(layout)
        .into_iter()
        .enumerate()
        .map(|(i, f)| Target::new(gpu, &format!("gbuffer {i}"), w, h, f))
        .collect()
}
