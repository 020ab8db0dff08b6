//! G-buffer targets per layout. Mirrors `shaders/packing/gbuffer.wesl`.

use super::targets::{F32_BITS_FORMAT, Target};
use crate::gpu::Gpu;
use crate::variant::{GBufferLayout, ShadingModel, Variant};

/// The colour targets of a variant's layout, in location order, each with the name the
/// resolve passes read it by (`packing/gbuffer.wesl`). Only Compact needs a target of its
/// own for GGX's roughness and metallic; the others keep them in spare bits.
pub fn formats(v: &Variant) -> Vec<(&'static str, wgpu::TextureFormat)> {
    match v.gbuffer().layout {
        GBufferLayout::Wide => ["gbuffer0", "gbuffer1", "gbuffer2"]
            .map(|name| (name, F32_BITS_FORMAT))
            .to_vec(),
        GBufferLayout::Packed => ["gbuffer0", "gbuffer1"]
            .map(|name| (name, F32_BITS_FORMAT))
            .to_vec(),
        GBufferLayout::Compact => {
            let mut f = vec![
                ("albedo_texture", wgpu::TextureFormat::Rgba8Unorm),
                ("normal_texture", wgpu::TextureFormat::R32Uint),
            ];
            if v.shading.model == ShadingModel::Ggx {
                f.push(("material_texture", wgpu::TextureFormat::Rg8Unorm));
            }
            f
        }
    }
}

/// Bytes a pixel of the variant's layout takes, depth included (4 bytes), every sample.
pub fn bytes_per_pixel(v: &Variant) -> u32 {
    let sample = 4 + formats(v)
        .iter()
        .map(|(_, f)| f.block_copy_size(None).unwrap_or(0))
        .sum::<u32>();
    sample * v.msaa.samples
}

/// The layout's targets, each with its name.
pub fn targets(gpu: &Gpu, v: &Variant, w: u32, h: u32) -> Vec<(&'static str, Target)> {
    formats(v)
        .into_iter()
        .map(|(name, f)| {
            let t = Target::multisampled(gpu, name, (w, h), f, v.msaa.samples);
            (name, t)
        })
        .collect()
}
