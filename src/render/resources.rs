//! GPU-side scene data: the view uniform, vertex, index and light buffers, render targets,
//! and the bind group layouts shared by the passes.

use bytemuck::{Pod, Zeroable};
use glam::DMat4;
use wgpu::util::DeviceExt;

use crate::cpu::depth::DepthMapping;
use crate::gpu::Gpu;
use crate::scene::{Light, Scene, Vertex};
use crate::variant::{DepthFormat, Variant};

/// Mirrors `View` in `shaders/common/view.wesl` (432 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ViewUniform {
    pub clip_from_world: [[f32; 4]; 4],
    pub view_from_world: [[f32; 4]; 4],
    pub world_from_view: [[f32; 4]; 4],
    pub clip_from_view: [[f32; 4]; 4],
    pub view_from_clip: [[f32; 4]; 4],
    pub prev_clip_from_world: [[f32; 4]; 4],
    pub camera_position: [f32; 3],
    pub light_count: u32,
    pub viewport_size: [f32; 2],
    pub near: f32,
    pub far: f32,
    pub tan_half_fov_y: f32,
    pub aspect: f32,
    pub time: f32,
    pub _pad: f32,
}

fn mat(m: DMat4) -> [[f32; 4]; 4] {
    m.as_mat4().to_cols_array_2d()
}

impl ViewUniform {
    pub fn new(scene: &Scene, mapping: DepthMapping) -> Self {
        let aspect = scene.aspect();
        let cam = &scene.camera;
        let view = cam.view();
        let proj = cam.projection(aspect, mapping);
        let prev = scene.prev_camera.projection(aspect, mapping) * scene.prev_camera.view();
        Self {
            clip_from_world: mat(proj * view),
            view_from_world: mat(view),
            world_from_view: mat(view.inverse()),
            clip_from_view: mat(proj),
            view_from_clip: mat(proj.inverse()),
            prev_clip_from_world: mat(prev),
            camera_position: cam.eye.as_vec3().to_array(),
            light_count: scene.lights.len() as u32,
            viewport_size: [scene.params.width as f32, scene.params.height as f32],
            near: cam.near as f32,
            far: cam.far as f32,
            tan_half_fov_y: (cam.fov_y / 2.0).tan() as f32,
            aspect: aspect as f32,
            time: scene.params.time as f32,
            _pad: 0.0,
        }
    }
}

/// Scene data on the GPU.
pub struct SceneBuffers {
    pub vertices: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    pub index_count: u32,
    pub lights: wgpu::Buffer,
    pub view: wgpu::Buffer,
    pub light_count: u32,
}

impl SceneBuffers {
    pub fn upload(gpu: &Gpu, scene: &Scene, mapping: DepthMapping) -> Self {
        let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
            gpu.device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents,
                    usage,
                })
        };
        // A storage binding may not be empty: with no lights, bind one zero light (never
        // read, since light_count is 0).
        let zero = [Light::default()];
        let lights: &[Light] = if scene.lights.is_empty() {
            &zero
        } else {
            &scene.lights
        };
        Self {
            vertices: init(
                "vertices",
                bytemuck::cast_slice(&scene.vertices),
                wgpu::BufferUsages::VERTEX,
            ),
            indices: init(
                "indices",
                bytemuck::cast_slice(&scene.indices),
                wgpu::BufferUsages::INDEX,
            ),
            index_count: scene.indices.len() as u32,
            lights: init(
                "lights",
                bytemuck::cast_slice(lights),
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            ),
            view: init(
                "view",
                bytemuck::bytes_of(&ViewUniform::new(scene, mapping)),
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            light_count: scene.lights.len() as u32,
        }
    }

    pub fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
        const ATTRIBUTES: [wgpu::VertexAttribute; 3] =
            wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x3];
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &ATTRIBUTES,
        }
    }
}

/// Targets that hold f32 data exactly on every adapter: the f32 bits in rgba32uint
/// (rgba32float is not renderable through wgpu's OpenGL backend).
pub const F32_BITS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Uint;
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

/// A 2D texture usable as a render target, sampled texture and copy source.
pub fn target(
    gpu: &Gpu,
    label: &str,
    w: u32,
    h: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

/// Layout of group 0 of the scene passes: the view uniform and the light array.
pub fn frame_layout(gpu: &Gpu) -> wgpu::BindGroupLayout {
    gpu.device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("frame"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::all(),
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                storage_entry(1, true),
            ],
        })
}

/// A storage-buffer layout entry visible to every stage that may use it.
pub fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    let visibility = if read_only {
        wgpu::ShaderStages::all()
    } else {
        // Vertex shaders may not write storage buffers.
        wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE
    };
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A non-filterable float texture entry (rgba32float targets cannot be filtered).
pub fn texture_entry(
    binding: u32,
    sample_type: wgpu::TextureSampleType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

pub fn frame_bind_group(
    gpu: &Gpu,
    layout: &wgpu::BindGroupLayout,
    s: &SceneBuffers,
) -> wgpu::BindGroup {
    gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("frame"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: s.view.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: s.lights.as_entire_binding(),
            },
        ],
    })
}
