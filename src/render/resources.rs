//! GPU-side scene data: the view uniform, vertex, index and light buffers, render targets,
//! counters, and which of them fills each bind group slot of the scene passes.

use crate::render::bindings::Binding;
use bytemuck::{Pod, Zeroable};
use glam::DMat4;
use wgpu::util::DeviceExt;

use super::reflect::{BufferSizes, Slot};
use super::targets::{
    DepthSetup, F32_BITS_FORMAT, LDR_FORMAT, SHADING_DEPTH_FORMAT, Target, Targets,
};
use crate::compose::RAY_COUNTERS;
use crate::cpu::depth::DepthMapping;
use crate::gpu::Gpu;
use crate::scene::{Light, Scene, Vertex};
use crate::variant::{ListUpdate, Variant};

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
    /// The blended triangles in the order they are drawn (`Scene::blend_order`), and their
    /// index count (scenes with blended materials).
    pub blended: Option<(wgpu::Buffer, u32)>,
    pub lights: wgpu::Buffer,
    pub view: wgpu::Buffer,
    pub light_count: u32,
    /// The base colour texture array and its sampler (scenes with textures).
    pub base_color: Option<(wgpu::TextureView, wgpu::Sampler)>,
    /// The occluders' tree and triangles (frames with shadows: `render::shadows`).
    pub occluders: Option<wgpu::Buffer>,
}

impl SceneBuffers {
    pub fn upload(
        gpu: &Gpu,
        scene: &Scene,
        mapping: DepthMapping,
        occluders: Option<&[[u32; 4]]>,
    ) -> Self {
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
            blended: scene.has_blend().then(|| {
                let order = scene.blend_order();
                let buffer = init(
                    "blended indices",
                    bytemuck::cast_slice(&order),
                    wgpu::BufferUsages::INDEX,
                );
                (buffer, order.len() as u32)
            }),
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
            base_color: scene.textures.as_deref().map(|t| upload_textures(gpu, t)),
            occluders: occluders.map(|words| {
                init(
                    "occluders",
                    bytemuck::cast_slice(words),
                    wgpu::BufferUsages::STORAGE,
                )
            }),
        }
    }

    /// What fills the frame's binding declared as `name`, if it is one of its: the view, the
    /// lights, the base colour textures and their sampler (`common/material.wesl`).
    pub fn frame_binding(&self, name: Binding) -> Option<wgpu::BindingResource<'_>> {
        match name {
            Binding::View => Some(self.view.as_entire_binding()),
            Binding::Lights => Some(self.lights.as_entire_binding()),
            Binding::Occluders => Some(self.occluders.as_ref()?.as_entire_binding()),
            Binding::BaseColorTextures => Some(wgpu::BindingResource::TextureView(
                &self.base_color.as_ref()?.0,
            )),
            Binding::BaseColorSampler => {
                Some(wgpu::BindingResource::Sampler(&self.base_color.as_ref()?.1))
            }
            _ => None,
        }
    }

    pub fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
        const ATTRIBUTES: [wgpu::VertexAttribute; 7] = wgpu::vertex_attr_array![
            0 => Float32x3, 1 => Float32x3, 2 => Float32x3, 3 => Float32x2, 4 => Float32x2,
            5 => Uint32, 6 => Float32x2
        ];
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &ATTRIBUTES,
        }
    }
}

/// The texture array on the GPU (sRGB, every mip level) and a trilinear repeating sampler.
fn upload_textures(
    gpu: &Gpu,
    t: &crate::scene::TextureArray,
) -> (wgpu::TextureView, wgpu::Sampler) {
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("base colour textures"),
        size: wgpu::Extent3d {
            width: t.size,
            height: t.size,
            // wgpu's OpenGL backend makes a one-layer texture a plain 2D texture, which an
            // array view cannot sample (it reads black): give it a second, unused layer.
            depth_or_array_layers: t.layers.max(2),
        },
        mip_level_count: t.mip_count(),
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8UnormSrgb,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    for (level, bytes) in t.levels.iter().enumerate() {
        let side = (t.size >> level).max(1);
        gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: level as u32,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytes,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * side),
                rows_per_image: Some(side),
            },
            wgpu::Extent3d {
                width: side,
                height: side,
                depth_or_array_layers: t.layers,
            },
        );
    }
    let view = texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    });
    let sampler = gpu.device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("base colour"),
        address_mode_u: wgpu::AddressMode::Repeat,
        address_mode_v: wgpu::AddressMode::Repeat,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        ..Default::default()
    });
    (view, sampler)
}

/// Where `variant` draws random numbers (a sampled light loop, or sampled shadows): its
/// seed, and whether it reuses earlier frames' reservoirs.
fn random_numbers(variant: &Variant) -> Option<(u32, bool)> {
    let lights = variant.shading.lights.sampling();
    let shadows = variant.shading.shadows.sampling();
    lights
        .map(|s| (s.seed, s.reuses_frames()))
        .or(shadows.map(|s| (s.seed, false)))
}

/// Per-pixel counters of instrumented frames (group 3 of the shading passes, in
/// `shaders/shading/light_loop/counters.wesl`): light evaluations, useful ones, and the cluster each
/// pixel looked up (index + 1; 0 for background).
pub struct Counters {
    pub evals: wgpu::Buffer,
    pub useful: wgpu::Buffer,
    pub clusters: wgpu::Buffer,
    /// Multisampled frames: the shadings of each pixel.
    pub shadings: Option<wgpu::Buffer>,
    /// Sampled light loops: the candidates each pixel drew or walked.
    pub candidates: Option<wgpu::Buffer>,
    /// Frames with shadows: each pixel's rays, those blocked and the nodes they visited.
    pub rays: Option<wgpu::Buffer>,
}

impl Counters {
    /// A counter a pixel, each at the size `counters.wesl` declares it.
    pub fn new(
        gpu: &Gpu,
        sizes: &BufferSizes,
        pixels: u64,
        multisampled: bool,
        sampled: bool,
        shadowed: bool,
    ) -> Self {
        let buffer_of = |name: Binding, elements: u64| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(name.name()),
                size: sizes.bindable(name, elements),
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let buffer = |name: Binding| buffer_of(name, pixels);
        Self {
            rays: shadowed.then(|| buffer_of(Binding::PixelRays, RAY_COUNTERS as u64 * pixels)),
            evals: buffer(Binding::PixelEvals),
            useful: buffer(Binding::PixelUseful),
            clusters: buffer(Binding::PixelClusters),
            shadings: multisampled.then(|| buffer(Binding::PixelShadings)),
            candidates: sampled.then(|| buffer(Binding::PixelCandidates)),
        }
    }

    /// Zero every counter.
    pub fn clear(&self, encoder: &mut wgpu::CommandEncoder) {
        for b in [&self.evals, &self.useful, &self.clusters]
            .into_iter()
            .chain(&self.shadings)
            .chain(&self.candidates)
            .chain(&self.rays)
        {
            encoder.clear_buffer(b, 0, None);
        }
    }
}

/// The lights a sequence's list strategy treats apart, as `clustering/moving.wesl` reads
/// them: their number and indices, and a bit per light.
pub struct MovingSet {
    pub ids: wgpu::Buffer,
    pub mask: wgpu::Buffer,
    /// The lights the buffers hold, ascending.
    pub lights: Vec<u32>,
}

impl MovingSet {
    /// Room for `lights` lights, holding none, at the sizes `clustering/moving.wesl`
    /// declares.
    fn new(gpu: &Gpu, sizes: &BufferSizes, lights: usize) -> Self {
        let buffer = |name: Binding, count: usize| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(name.name()),
                size: sizes.bindable(name, count as u64),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        Self {
            ids: buffer(Binding::MovingLights, lights),
            mask: buffer(Binding::MovingMask, lights.div_ceil(32)),
            lights: Vec::new(),
        }
    }

    /// Hold `lights` (ascending indices below the scene's light count). A buffer no pass of
    /// the variant declares is empty and left so (nothing reads it).
    pub fn set(&mut self, gpu: &Gpu, lights: &[u32]) {
        if self.ids.size() > 0 {
            let mut ids = Vec::with_capacity(lights.len() + 1);
            ids.push(lights.len() as u32);
            ids.extend_from_slice(lights);
            gpu.queue
                .write_buffer(&self.ids, 0, bytemuck::cast_slice(&ids));
        }
        if self.mask.size() > 0 {
            let mut mask = vec![0u32; self.mask.size() as usize / std::mem::size_of::<u32>()];
            for &i in lights {
                mask[i as usize / 32] |= 1 << (i % 32);
            }
            gpu.queue
                .write_buffer(&self.mask, 0, bytemuck::cast_slice(&mask));
        }
        self.lights = lights.to_vec();
    }
}

/// Everything the scene passes bind.
pub struct FrameResources {
    pub scene: SceneBuffers,
    pub targets: Targets,
    pub clusters: Option<super::ClusterBuffers>,
    /// StaticDynamic: the moving lights' lists (their own counts, offsets and indices; the
    /// rest shared with `clusters`).
    pub moving: Option<super::ClusterBuffers>,
    /// The lights a list strategy treats apart (`clustering/moving.wesl`).
    pub moving_set: MovingSet,
    pub counters: Counters,
    /// Scenes with blended materials, clustered variants: each pixel's nearest and farthest
    /// blended depth (`clustering/transparent_depths.wesl`), two words a pixel.
    pub transparent_depths: Option<wgpu::Buffer>,
    /// Sampled light loops: the frame's seed and the reservoirs.
    pub sampling: Option<super::sampling::SampleBuffers>,
}

impl FrameResources {
    /// Upload `scene` and make the targets, cluster buffers (clustered variants) and
    /// counters a frame of `variant` needs (`proxies`: rasterised binning's buffer layouts,
    /// from its pass; `sizes`: every buffer's, from the frame's passes). Call inside an
    /// error scope.
    pub fn new(
        gpu: &Gpu,
        variant: &Variant,
        scene: &Scene,
        proxies: Option<super::clusters::ProxyLayout>,
        sizes: &BufferSizes,
        occluders: Option<&[[u32; 4]]>,
    ) -> Self {
        let (w, h) = (scene.params.width, scene.params.height);
        let sampling = variant.shading.lights.sampling();
        let depth = DepthSetup::of(variant);
        let samples = variant.msaa.samples;
        let targets = Targets {
            depth: Target::multisampled(gpu, "depth", (w, h), depth.format, samples),
            hdr: Target::new(gpu, "hdr", w, h, gpu.hdr_format),
            hdr_samples: crate::compose::shades_samples_apart(variant)
                .then(|| Target::multisampled(gpu, "hdr samples", (w, h), gpu.hdr_format, samples)),
            shading_depth: (variant.msaa.on() && variant.depth_prepass).then(|| {
                Target::multisampled(gpu, "shading depth", (w, h), SHADING_DEPTH_FORMAT, samples)
            }),
            sample_owner: (variant.msaa.on() && variant.depth_prepass).then(|| {
                Target::multisampled(gpu, "sample owner", (w, h), SHADING_DEPTH_FORMAT, samples)
            }),
            ldr: Target::new(gpu, "ldr", w, h, LDR_FORMAT),
            gbuffer: if variant.pipeline.is_deferred() {
                super::gbuffer::targets(gpu, variant, w, h)
            } else {
                Vec::new()
            },
            still: crate::compose::keeps_still_image(variant)
                .then(|| Target::new(gpu, "still image", w, h, F32_BITS_FORMAT)),
        };
        let clusters = variant.pipeline.is_clustered().then(|| {
            let c = variant.clusters();
            let count = c.grid.0 * c.grid.1 * c.grid.2;
            let lights = scene.lights.len() as u32;
            // A first guess, within what one binding holds; a frame whose lists overflow
            // grows the buffer and runs again (or says the lists cannot fit).
            let entry = sizes.bindable(Binding::LightIndices, 1).max(1);
            let bindable =
                (gpu.limits.max_storage_buffer_binding_size / entry).min(u32::MAX as u64);
            let capacity = (count as u64 * lights.clamp(1, 32) as u64)
                .max(1024)
                .min(bindable) as u32;
            let range = super::ClusterRange::new(scene.camera.near as f32, scene.camera.far as f32);
            super::ClusterBuffers::new(gpu, &c, lights, capacity, range, proxies, sizes.clone())
        });
        let update = variant
            .pipeline
            .is_clustered()
            .then(|| variant.clusters().update);
        let moving = clusters
            .as_ref()
            .filter(|_| update == Some(ListUpdate::StaticDynamic))
            .map(|c| c.moving_lists(gpu));
        // Room in the moving set for every light where a strategy reads one.
        let moving_room = match update {
            Some(ListUpdate::StaticDynamic | ListUpdate::Patch) => scene.lights.len(),
            _ => 0,
        };
        // Every clustered variant's marking pass declares it (the active-cluster count's
        // `mark_visible` shares the module).
        let transparent_depths =
            (scene.has_blend() && variant.pipeline.is_clustered()).then(|| {
                gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("transparent_depths"),
                    // Two words a pixel: its nearest and farthest pane.
                    size: sizes.bindable(Binding::TransparentDepths, 2 * w as u64 * h as u64),
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            });
        Self {
            scene: SceneBuffers::upload(gpu, scene, depth.mapping, occluders),
            targets,
            clusters,
            moving,
            moving_set: MovingSet::new(gpu, sizes, moving_room),
            counters: Counters::new(
                gpu,
                sizes,
                w as u64 * h as u64,
                variant.msaa.on(),
                sampling.is_some(),
                variant.shading.shadows.traced(),
            ),
            transparent_depths,
            sampling: random_numbers(variant).map(|seeded| {
                let pixels = w as u64 * h as u64;
                super::sampling::SampleBuffers::new(gpu, sizes, seeded, pixels, scene.params.time)
            }),
        }
    }

    /// What fills `slot` of a scene pass, by the name its module declares it by (the slot
    /// numbers are written only in the WGSL): the frame's (`view`, `lights`, the base
    /// colour textures), the clusters' (by the names `build_bindings.wesl` declares, and
    /// `lookup.wesl` read-only), the surface's (depth, the G-buffer targets of
    /// `packing/gbuffer.wesl`), and the counters of `shading/light_loop/counters.wesl`.
    pub fn scene_binding(&self, slot: &Slot) -> Option<wgpu::BindingResource<'_>> {
        fn texture(t: &Target) -> wgpu::BindingResource<'_> {
            wgpu::BindingResource::TextureView(&t.view)
        }
        let name = slot.name;
        if let Some(frame) = self.scene.frame_binding(name) {
            return Some(frame);
        }
        if let Some(s) = self.sampling.as_ref().and_then(|s| s.binding(name)) {
            return Some(s);
        }
        // The moving lists as shading reads them: the moving lists' own buffers.
        let moving_list = match name {
            Binding::MovingLights => return Some(self.moving_set.ids.as_entire_binding()),
            Binding::MovingMask => return Some(self.moving_set.mask.as_entire_binding()),
            Binding::StillImage => return self.targets.still.as_ref().map(texture),
            Binding::MovingCounts => Some(Binding::LightCounts),
            Binding::MovingOffsets => Some(Binding::LightOffsets),
            Binding::MovingIndices => Some(Binding::LightIndices),
            _ => None,
        };
        if let Some(list) = moving_list {
            return self
                .moving
                .as_ref()
                .and_then(|m| m.buffer(list))
                .map(|b| b.as_entire_binding());
        }
        if let Some(buffer) = self.clusters.as_ref().and_then(|c| c.buffer(name)) {
            return Some(buffer.as_entire_binding());
        }
        match name {
            Binding::DepthTexture => Some(texture(&self.targets.depth)),
            Binding::ShadingDepth => self.targets.shading_depth.as_ref().map(texture),
            Binding::SampleOwner => self.targets.sample_owner.as_ref().map(texture),
            Binding::TransparentDepths => self
                .transparent_depths
                .as_ref()
                .map(|b| b.as_entire_binding()),
            Binding::PixelEvals => Some(self.counters.evals.as_entire_binding()),
            Binding::PixelUseful => Some(self.counters.useful.as_entire_binding()),
            Binding::PixelClusters => Some(self.counters.clusters.as_entire_binding()),
            Binding::PixelShadings => self
                .counters
                .shadings
                .as_ref()
                .map(|b| b.as_entire_binding()),
            Binding::PixelCandidates => self
                .counters
                .candidates
                .as_ref()
                .map(|b| b.as_entire_binding()),
            Binding::PixelRays => self.counters.rays.as_ref().map(|b| b.as_entire_binding()),
            _ => self
                .targets
                .gbuffer
                .iter()
                .find(|(n, _)| *n == name.name())
                .map(|(_, t)| texture(t)),
        }
    }
}
