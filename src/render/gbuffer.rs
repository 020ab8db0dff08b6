//! G-buffer targets per layout. Mirrors `shaders/packing/gbuffer.wesl`.

use super::resources::{F32_BITS_FORMAT, Target};
use crate::gpu::Gpu;
use crate::variant::{GBufferLayout, ShadingModel, Variant};

/// The colour targets of a variant's layout, in location order. Only Compact needs a target
/// of its own for GGX's roughness and metallic; the others keep them in spare bits.
pub fn formats(v: &Variant) -> Vec<wgpu::TextureFormat> {
    match v.gbuffer().layout {
        GBufferLayout::Wide => vec![F32_BITS_FORMAT; 3],
        GBufferLayout::Packed => vec![F32_BITS_FORMAT; 2],
        GBufferLayout::Compact => {
            let mut f = vec![
                wgpu::TextureFormat::Rgba8Unorm,
                wgpu::TextureFormat::R32Uint,
            ];
            if v.shading.model == ShadingModel::Ggx {
                f.push(wgpu::TextureFormat::Rg8Unorm);
            }
            f
        }
    }
}

/// Bytes a pixel of the variant's layout takes, depth included (4 bytes).
pub fn bytes_per_pixel(v: &Variant) -> u32 {
    4 + formats(v)
        .iter()
        .map(|f| f.block_copy_size(None).unwrap_or(0))
        .sum::<u32>()
}

pub fn targets(gpu: &Gpu, v: &Variant, w: u32, h: u32) -> Vec<Target> {
    formats(v)
        .into_iter()
        .enumerate()
        .map(|(i, f)| Target::new(gpu, &format!("gbuffer {i}"), w, h, f))
        .collect()
}
