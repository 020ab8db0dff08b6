//! The frame's images: their formats, depth set-up, the render targets a frame draws into,
//! and reading an HDR target back.

use crate::cpu::depth::DepthMapping;
use crate::gpu::{Gpu, GpuError, read_texture};
use crate::variant::{DepthFormat, Variant};

/// Targets that hold f32 data exactly on every adapter: the f32 bits in rgba32uint
/// (rgba32float is not renderable through wgpu's OpenGL backend).
pub const F32_BITS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Uint;
/// Multisampled forward frames' record of each sample's kept fragment: its shading depth as
/// f32 bits, and its provoking vertex (`common/sample_owner.wesl`).
pub const SHADING_DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
/// The display format; sRGB encoding is done in the shader so the CPU can match it.
pub const LDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// Depth state of a variant: format, compare function and clear value.
#[derive(Clone, Copy, Debug)]
pub struct DepthSetup {
    pub format: wgpu::TextureFormat,
    pub mapping: DepthMapping,
}

impl DepthSetup {
    pub fn of(v: &Variant) -> Self {
        Self {
            format: match v.depth.format {
                DepthFormat::Unorm24 => wgpu::TextureFormat::Depth24Plus,
                DepthFormat::Float32 => wgpu::TextureFormat::Depth32Float,
            },
            mapping: v.depth.mapping(),
        }
    }

    pub fn clear(&self) -> f32 {
        if self.mapping.reversed { 0.0 } else { 1.0 }
    }

    /// Nearer wins.
    pub fn compare(&self) -> wgpu::CompareFunction {
        if self.mapping.reversed {
            wgpu::CompareFunction::Greater
        } else {
            wgpu::CompareFunction::Less
        }
    }

    pub fn state(&self, compare: wgpu::CompareFunction, write: bool) -> wgpu::DepthStencilState {
        wgpu::DepthStencilState {
            format: self.format,
            depth_write_enabled: Some(write),
            depth_compare: Some(compare),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        }
    }
}

/// A 2D render target of `samples` samples a pixel that passes read; with one sample it
/// is also a copy source (a multisampled texture cannot be copied).
pub fn multisampled_target(
    gpu: &Gpu,
    label: &str,
    (w, h): (u32, u32),
    format: wgpu::TextureFormat,
    samples: u32,
) -> wgpu::Texture {
    let copy = if samples == 1 {
        wgpu::TextureUsages::COPY_SRC
    } else {
        wgpu::TextureUsages::empty()
    };
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: samples,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING | copy,
        view_formats: &[],
    })
}

/// A render target and the view passes read and write it through.
pub struct Target {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
}

impl Target {
    pub fn new(gpu: &Gpu, label: &str, w: u32, h: u32, format: wgpu::TextureFormat) -> Self {
        Self::multisampled(gpu, label, (w, h), format, 1)
    }

    pub fn multisampled(
        gpu: &Gpu,
        label: &str,
        size: (u32, u32),
        format: wgpu::TextureFormat,
        samples: u32,
    ) -> Self {
        let texture = multisampled_target(gpu, label, size, format, samples);
        let view = texture.create_view(&Default::default());
        Self { texture, view }
    }
}

/// The images of a frame: depth, HDR colour, the 8-bit output and the G-buffer (deferred).
/// Depth and the G-buffer hold `msaa.samples` samples a pixel, and so does the forward
/// and scissor deferred's colour (`hdr_samples`, resolved into `hdr`); the rest one.
pub struct Targets {
    pub depth: Target,
    pub hdr: Target,
    pub hdr_samples: Option<Target>,
    /// Multisampled forward frames with a pre-pass: the depth each sample is shaded at
    /// (`clustering/shading_depth.wesl`), as f32 bits, and the provoking vertex of the
    /// fragment kept there (`common/sample_owner.wesl`).
    pub shading_depth: Option<Target>,
    pub sample_owner: Option<Target>,
    pub ldr: Target,
    pub gbuffer: Vec<(&'static str, Target)>,
    /// StaticDynamic's still image (`compose::keeps_still_image`): each pixel's still
    /// lights and ambient, as f32 bits.
    pub still: Option<Target>,
}

/// Read an HDR target (rgba32float or rgba16float) as f32.
pub(super) fn read_hdr(gpu: &Gpu, texture: &wgpu::Texture) -> Result<Vec<[f32; 4]>, GpuError> {
    Ok(match texture.format() {
        wgpu::TextureFormat::Rgba16Float => {
            let bytes = read_texture(gpu, texture)?;
            bytemuck::cast_slice::<u8, [u16; 4]>(&bytes)
                .iter()
                .map(|p| p.map(|h| half::f16::from_bits(h).to_f32()))
                .collect()
        }
        _ => bytemuck::cast_slice(&read_texture(gpu, texture)?).to_vec(),
    })
}
