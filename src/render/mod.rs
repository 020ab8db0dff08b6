//! Running a variant on the GPU: one frame of a scene, pass by pass, timed; and an
//! instrumented frame for the exact counters.

mod clusters;
mod gbuffer;
mod passes;
mod post;
mod resources;
mod truth;

pub use clusters::{ClusterBuffers, ClusterRange, ClusterStats};
pub use passes::{PassRunner, shader_module};
pub use resources::{DepthSetup, F32_BITS_FORMAT, LDR_FORMAT, SceneBuffers, ViewUniform};
pub use truth::raster_truth;

use std::collections::HashMap;
use std::fmt;
use std::time::Instant;

use serde::Serialize;

use crate::compose::{self, ComposedPass, Composer, Pass, ShaderError};
use crate::cpu::clusters::{self as cpu_clusters, ClusterLists, Grid};
use crate::gpu::{Gpu, GpuError, TimestampSlot, Timings, read_buffer, read_texture};
use crate::scene::{Light, Scene};
use crate::variant::{Assignment, LightLists, Variant, ZSlicing};
use passes::{clear_attachment, color_target, render_pipeline};
use post::{PostChain, PostInputs, is_post};
use resources::{frame_bind_group, frame_layout, storage_entry, target, texture_entry};

/// Why a frame could not be rendered.
#[derive(Debug)]
pub enum RenderError {
    Shader(ShaderError),
    Gpu(GpuError),
    /// The variant composes, but this build cannot run one of its passes.
    NotRunnable(String),
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RenderError::Shader(e) => write!(f, "{e}"),
            RenderError::Gpu(e) => write!(f, "{e}"),
            RenderError::NotRunnable(m) => write!(f, "{m}"),
        }
    }
}

impl std::error::Error for RenderError {}

impl From<ShaderError> for RenderError {
    fn from(e: ShaderError) -> Self {
        RenderError::Shader(e)
    }
}

impl From<GpuError> for RenderError {
    fn from(e: GpuError) -> Self {
        RenderError::Gpu(e)
    }
}

/// What one frame produced.
#[derive(Clone, Debug)]
pub struct FrameOutput {
    pub width: u32,
    pub height: u32,
    /// Linear HDR colour before tonemapping, row-major.
    pub hdr: Vec<[f32; 4]>,
    /// The displayed 8-bit image (tonemapped, sRGB), row-major.
    pub ldr: Vec<[u8; 4]>,
    pub timings: Timings,
    /// Wall-clock time from the first encode to the frame's completion (with CPU light
    /// assignment, when the variant has it).
    pub wall_ms: f64,
    /// CPU light assignment time, for variants with `assignment: Cpu`.
    pub cpu_assign_ms: Option<f64>,
    /// Passes of the variant this frame did not run (see `Variant::skip_unneeded`).
    pub skipped: Vec<String>,
}

/// Exact counters of a frame, from an instrumented run of it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, serde::Deserialize)]
pub struct FrameStats {
    /// Light evaluations performed by the shading pass.
    pub light_evals: u64,
    /// Those with the surface closer to the light than its radius.
    pub useful_light_evals: u64,
    /// Light-cluster pairs left out by a per-cluster cap.
    pub dropped_lights: u64,
    /// Clusters that hold at least one visible sample.
    pub active_clusters: u64,
    /// Clusters that took part in light assignment (all, unless active clusters are on).
    pub assigned_clusters: u64,
    pub clusters: u64,
    pub max_lights_per_cluster: u32,
    /// Mean lights per cluster over the clusters that hold a visible sample (what shading
    /// loops over).
    #[serde(default)]
    pub mean_lights_per_visible_cluster: f64,
    /// Most lights in a cluster that holds a visible sample.
    #[serde(default)]
    pub max_lights_per_visible_cluster: u32,
    /// Entries in all light lists together.
    pub light_list_entries: u64,
    /// Bytes of cluster data on the GPU (bounds, counts, offsets, indices, ...).
    pub cluster_bytes: u64,
    /// G-buffer bytes per pixel, depth included (0 for forward pipelines).
    pub gbuffer_bytes_per_pixel: u32,
    /// Bytes per pixel of the post-processing images (0 without post effects).
    pub post_bytes_per_pixel: u32,
    /// Bytes per pixel of every full-size image the frame keeps: depth, G-buffer, HDR
    /// colour, post images and the 8-bit output.
    pub frame_bytes_per_pixel: u32,
    /// Times the light index buffer was too small and the frame was run again larger.
    pub list_reallocations: u32,
    /// The clustered depth range of the frame [near, far].
    pub z_range: Option<[f32; 2]>,
    /// Pixels whose shading looked up a cluster index outside the grid (clustered).
    pub clusters_out_of_grid: u64,
    /// The first such pixel: [x, y, cluster index].
    pub first_out_of_grid: Option<[u32; 3]>,
}

/// Bind group layouts of every group a pass may use.
struct Layouts {
    frame: wgpu::BindGroupLayout,
    cluster_build: wgpu::BindGroupLayout,
    cluster_lookup: wgpu::BindGroupLayout,
    depth_read: wgpu::BindGroupLayout,
    gbuffer_read: Option<wgpu::BindGroupLayout>,
    stats: wgpu::BindGroupLayout,
    tonemap: wgpu::BindGroupLayout,
}

/// Bind groups; the cluster ones are remade when the index buffer grows.
struct Groups {
    frame: wgpu::BindGroup,
    cluster_build: Option<wgpu::BindGroup>,
    cluster_lookup: Option<wgpu::BindGroup>,
    depth_read: wgpu::BindGroup,
    gbuffer_read: Option<wgpu::BindGroup>,
    stats: wgpu::BindGroup,
    tonemap: wgpu::BindGroup,
}

/// Pipelines of one pass.
enum PassPipelines {
    /// Render pipelines, drawn in order.
    Render(Vec<wgpu::RenderPipeline>),
    /// Compute pipelines by entry point.
    Compute(HashMap<&'static str, wgpu::ComputePipeline>),
}

/// Compute entry points of each compute pass, in dispatch order.
fn compute_entries(pass: &str) -> &'static [&'static str] {
    match pass {
        "cluster_bounds" => &["build_bounds"],
        "light_assign" => &[
            "transform_lights",
            "count_lights",
            "scan_local",
            "scan_blocks",
            "fill_lists",
            "finish_lists",
        ],
        "mark_active" => &["mark_active", "mark_visible"],
        "depth_range" => &["reduce", "finalize"],
        _ => &[],
    }
}

/// Passes this version can run.
fn runnable(name: &str) -> bool {
    matches!(
        name,
        "depth_prepass"
            | "gbuffer"
            | "depth_range"
            | "cluster_bounds"
            | "mark_active"
            | "light_assign"
            | "forward"
            | "resolve"
            | "scissor_lights"
            | "debug_view"
            | "tonemap"
    ) || is_post(name)
}

/// Shading passes, which have an instrumented twin for the counters.
fn is_shading(name: &str) -> bool {
    matches!(name, "forward" | "resolve" | "scissor_lights")
}

struct Targets {
    depth: wgpu::Texture,
    hdr: wgpu::Texture,
    ldr: wgpu::Texture,
    gbuffer: Vec<wgpu::Texture>,
}

/// CPU light assignment state: the grid and its boxes (built once), the view-space lights.
struct CpuAssignment {
    grid: Grid,
    bounds: Vec<Option<cpu_clusters::Aabb>>,
    lights: Vec<(glam::DVec3, f64)>,
    cap: Option<u32>,
}

/// A variant ready to render a scene: composed passes, pipelines and resources.
pub struct Renderer<'g> {
    gpu: &'g Gpu,
    variant: Variant,
    passes: Vec<Pass>,
    width: u32,
    height: u32,
    depth: DepthSetup,
    scene: SceneBuffers,
    targets: Targets,
    clusters: Option<ClusterBuffers>,
    post: PostChain,
    pixel_evals: wgpu::Buffer,
    pixel_useful: wgpu::Buffer,
    pixel_clusters: wgpu::Buffer,
    layouts: Layouts,
    groups: Groups,
    timed: HashMap<&'static str, PassPipelines>,
    instrumented: HashMap<&'static str, PassPipelines>,
    /// Cluster bounds are valid for the projection, size and a static z-range.
    bounds_built: bool,
    cpu_assignment: Option<CpuAssignment>,
    reallocations: u32,
    skips: Skips,
    /// Frames rendered (not counting instrumented ones).
    frames_done: u32,
}

/// What this renderer's frames may leave out (all false when the variant skips nothing).
#[derive(Clone, Debug, Default)]
struct Skips {
    /// The scene has no lights: no clustering at all.
    no_lights: bool,
    /// Neither lights nor camera move: after two frames (the second settles a depth range
    /// taken from the previous frame) the lists, boxes and range stay valid.
    static_scene: bool,
    /// Passes left out of every frame (motion blur with a still camera).
    always: Vec<&'static str>,
    /// Skipping is on at all.
    on: bool,
}

/// The passes that build clusters and their light lists.
fn builds_clusters(name: &str) -> bool {
    matches!(
        name,
        "depth_range" | "mark_active" | "cluster_bounds" | "light_assign"
    )
}

/// What running a frame returned.
struct FrameRun {
    timings: Timings,
    cpu_ms: Option<f64>,
    skipped: Vec<String>,
}

/// Lights per row of the per-light dispatches (`LIGHTS_PER_ROW` in light_assign.wesl).
const LIGHTS_PER_ROW: u32 = 32768;

fn dispatch_size(n: u32, per_group: u32) -> u32 {
    n.div_ceil(per_group).max(1)
}

impl<'g> Renderer<'g> {
    /// Compose the variant's passes, check that they can run, and build everything a frame
    /// of `scene` needs.
    pub fn new(
        gpu: &'g Gpu,
        composer: &Composer,
        variant: &Variant,
        scene: &Scene,
    ) -> Result<Self, RenderError> {
        let (width, height) = (scene.params.width, scene.params.height);
        gpu.check_size(width, height)?;
        let mut passes = compose::passes(variant);
        let still_camera = scene.camera == scene.prev_camera;
        let skips = Skips {
            no_lights: variant.skip_unneeded && scene.lights.is_empty(),
            static_scene: variant.skip_unneeded && still_camera && !scene.lights_move,
            always: if variant.skip_unneeded && still_camera {
                vec!["motion_blur"]
            } else {
                vec![]
            },
            on: variant.skip_unneeded,
        };
        passes.retain(|p| !skips.always.contains(&p.name));
        if let Some(p) = passes.iter().find(|p| !runnable(p.name)) {
            return Err(RenderError::NotRunnable(format!(
                "pass `{}` composes and validates, but this version of clusterlab cannot run it yet",
                p.name
            )));
        }
        let clustered = variant.pipeline.is_clustered();
        let mut composed: Vec<(Pass, ComposedPass, Option<ComposedPass>)> = Vec::new();
        for p in &passes {
            if composed.iter().any(|(q, _, _)| q.name == p.name) {
                continue; // depth_range may run twice; one pipeline serves both.
            }
            let instrumented = if is_shading(p.name) {
                Some(composer.compose_instrumented(variant, p)?)
            } else {
                None
            };
            composed.push((*p, composer.compose(variant, p)?, instrumented));
        }
        // The active-cluster count needs mark_visible even when assignment does not mark.
        if clustered && !passes.iter().any(|p| p.name == "mark_active") {
            let p = Pass {
                name: "mark_active",
                root: "passes::mark_active",
                kind: compose::PassKind::Compute,
            };
            composed.push((p, composer.compose(variant, &p)?, None));
        }

        let depth = DepthSetup::of(variant);
        let gbuffer_layout = variant
            .pipeline
            .is_deferred()
            .then(|| variant.gbuffer().layout);
        let cluster_count = {
            let c = variant.clusters();
            c.grid.0 * c.grid.1 * c.grid.2
        };
        let light_count = scene.lights.len() as u32;

        let mut renderer = gpu.scoped("creating pipelines and resources", || {
            let scene_buffers = SceneBuffers::upload(gpu, scene, depth.mapping);
            let targets = Targets {
                depth: target(gpu, "depth", width, height, depth.format),
                hdr: target(gpu, "hdr", width, height, gpu.hdr_format),
                ldr: target(gpu, "ldr", width, height, LDR_FORMAT),
                gbuffer: gbuffer_layout
                    .map(|l| gbuffer::targets(gpu, l, width, height))
                    .unwrap_or_default(),
            };
            let clusters = clustered.then(|| {
                let capacity = (cluster_count * light_count.clamp(1, 32)).max(1024);
                let range = ClusterRange::new(scene.camera.near as f32, scene.camera.far as f32);
                ClusterBuffers::new(gpu, cluster_count, light_count, capacity, range)
            });
            let pixels = width as u64 * height as u64 * 4;
            let pixel_buffer = |label| {
                gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: pixels,
                    usage: wgpu::BufferUsages::STORAGE
                        | wgpu::BufferUsages::COPY_SRC
                        | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            };
            let pixel_evals = pixel_buffer("pixel light evaluations");
            let pixel_useful = pixel_buffer("pixel useful evaluations");
            let pixel_clusters = pixel_buffer("pixel cluster indices");
            let layouts = Layouts {
                frame: frame_layout(gpu),
                cluster_build: ClusterBuffers::build_layout(gpu),
                cluster_lookup: ClusterBuffers::lookup_layout(gpu),
                depth_read: gbuffer::read_layout(gpu, None),
                gbuffer_read: gbuffer_layout.map(|l| gbuffer::read_layout(gpu, Some(l))),
                stats: gpu
                    .device
                    .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                        label: Some("stats"),
                        entries: &[0, 1, 2].map(|b| wgpu::BindGroupLayoutEntry {
                            visibility: wgpu::ShaderStages::FRAGMENT,
                            ..storage_entry(b, false)
                        }),
                    }),
                tonemap: gpu
                    .device
                    .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                        label: Some("tonemap"),
                        entries: &[texture_entry(
                            0,
                            wgpu::TextureSampleType::Float { filterable: false },
                        )],
                    }),
            };
            let post_passes: Vec<_> = composed
                .iter()
                .filter(|(p, _, _)| is_post(p.name))
                .map(|(p, c, _)| (p.name, c))
                .collect();
            let post = PostChain::new(
                gpu,
                variant,
                &post_passes,
                PostInputs {
                    shaded: &targets.hdr,
                    depth: &targets.depth,
                    frame_layout: &layouts.frame,
                },
            );
            let groups = Groups {
                frame: frame_bind_group(gpu, &layouts.frame, &scene_buffers),
                cluster_build: None,
                cluster_lookup: None,
                depth_read: gbuffer::read_group(gpu, &layouts.depth_read, &targets.depth, &[]),
                gbuffer_read: layouts
                    .gbuffer_read
                    .as_ref()
                    .map(|l| gbuffer::read_group(gpu, l, &targets.depth, &targets.gbuffer)),
                stats: gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("stats"),
                    layout: &layouts.stats,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: pixel_evals.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: pixel_useful.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 2,
                            resource: pixel_clusters.as_entire_binding(),
                        },
                    ],
                }),
                tonemap: gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("tonemap"),
                    layout: &layouts.tonemap,
                    entries: &[wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(
                            &post.output(&targets.hdr).create_view(&Default::default()),
                        ),
                    }],
                }),
            };
            Renderer {
                gpu,
                variant: variant.clone(),
                passes,
                width,
                height,
                depth,
                scene: scene_buffers,
                targets,
                clusters,
                post,
                pixel_evals,
                pixel_useful,
                pixel_clusters,
                layouts,
                groups,
                timed: HashMap::new(),
                instrumented: HashMap::new(),
                bounds_built: false,
                cpu_assignment: None,
                reallocations: 0,
                skips,
                frames_done: 0,
            }
        })?;
        renderer.remake_cluster_groups();
        gpu.scoped("creating pipelines", || {
            for (pass, timed, instrumented) in &composed {
                if is_post(pass.name) {
                    continue; // The post chain holds their pipelines.
                }
                let p = renderer.pipelines(pass, timed, false);
                renderer.timed.insert(pass.name, p);
                if let Some(i) = instrumented {
                    let p = renderer.pipelines(pass, i, true);
                    renderer.instrumented.insert(pass.name, p);
                }
            }
        })?;
        if clustered && variant.clusters().assignment == Assignment::Cpu {
            renderer.cpu_assignment = Some(cpu_assignment(variant, scene));
        }
        Ok(renderer)
    }

    fn remake_cluster_groups(&mut self) {
        if let Some(c) = &self.clusters {
            self.groups.cluster_build = Some(c.build_group(self.gpu, &self.layouts.cluster_build));
            self.groups.cluster_lookup =
                Some(c.lookup_group(self.gpu, &self.layouts.cluster_lookup));
        }
    }

    /// The pipeline layout of a pass: its groups, with gaps where it uses none.
    fn pass_layout(&self, name: &str, instrumented: bool) -> wgpu::PipelineLayout {
        let l = &self.layouts;
        let clustered = self.variant.pipeline.is_clustered();
        let lookup = clustered.then_some(&l.cluster_lookup);
        let stats = instrumented.then_some(&l.stats);
        let surface = l.gbuffer_read.as_ref().unwrap_or(&l.depth_read);
        let groups: Vec<Option<&wgpu::BindGroupLayout>> = match name {
            "depth_prepass" | "gbuffer" => vec![Some(&l.frame)],
            "forward" => vec![Some(&l.frame), lookup, None, stats],
            "resolve" => vec![Some(&l.frame), lookup, Some(surface), stats],
            "scissor_lights" => vec![Some(&l.frame), None, Some(surface), stats],
            "debug_view" => vec![Some(&l.frame), lookup, Some(surface)],
            "tonemap" => vec![Some(&l.tonemap)],
            "cluster_bounds" | "light_assign" => vec![Some(&l.frame), Some(&l.cluster_build)],
            _ => vec![Some(&l.frame), Some(&l.cluster_build), Some(&l.depth_read)],
        };
        self.gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(name),
                bind_group_layouts: &groups,
                immediate_size: 0,
            })
    }

    fn pipelines(&self, pass: &Pass, composed: &ComposedPass, instrumented: bool) -> PassPipelines {
        let gpu = self.gpu;
        let layout = self.pass_layout(pass.name, instrumented);
        if pass.kind == compose::PassKind::Compute {
            let module = shader_module(gpu, composed);
            let map = compute_entries(pass.name)
                .iter()
                .map(|&entry| {
                    (
                        entry,
                        passes::compute_pipeline(gpu, &module, entry, &layout, entry),
                    )
                })
                .collect();
            return PassPipelines::Compute(map);
        }
        let vertex = [Some(SceneBuffers::vertex_layout())];
        let d = self.depth;
        let hdr = color_target(gpu.hdr_format);
        let additive = Some(wgpu::ColorTargetState {
            format: gpu.hdr_format,
            blend: Some(wgpu::BlendState {
                color: wgpu::BlendComponent {
                    src_factor: wgpu::BlendFactor::One,
                    dst_factor: wgpu::BlendFactor::One,
                    operation: wgpu::BlendOperation::Add,
                },
                alpha: wgpu::BlendComponent::OVER,
            }),
            write_mask: wgpu::ColorWrites::ALL,
        });
        let fs = if instrumented && pass.name == "forward" {
            "fs_stats"
        } else {
            "fs_main"
        };
        let build = |vs: &str,
                     fs: Option<&str>,
                     buffers: &[Option<wgpu::VertexBufferLayout<'_>>],
                     targets: &[Option<wgpu::ColorTargetState>],
                     depth| {
            render_pipeline(gpu, composed, &layout, (vs, fs), buffers, targets, depth)
        };
        let pipelines = match pass.name {
            "depth_prepass" => vec![build(
                "vs_main",
                None,
                &vertex,
                &[],
                Some(d.state(d.compare(), true)),
            )],
            "gbuffer" => {
                let formats = gbuffer::formats(self.variant.gbuffer().layout);
                let targets: Vec<_> = formats.into_iter().map(color_target).collect();
                vec![build(
                    "vs_main",
                    Some("fs_main"),
                    &vertex,
                    &targets,
                    Some(d.state(d.compare(), true)),
                )]
            }
            "forward" => {
                let state = if self.variant.depth_prepass {
                    d.state(wgpu::CompareFunction::Equal, false)
                } else {
                    d.state(d.compare(), true)
                };
                vec![build("vs_main", Some(fs), &vertex, &[hdr], Some(state))]
            }
            "resolve" => vec![build("vs_main", Some("fs_main"), &[], &[hdr], None)],
            "scissor_lights" => vec![
                build(
                    "vs_ambient",
                    Some("fs_ambient"),
                    &[],
                    std::slice::from_ref(&additive),
                    None,
                ),
                build(
                    "vs_light",
                    Some("fs_light"),
                    &[],
                    std::slice::from_ref(&additive),
                    None,
                ),
            ],
            "debug_view" | "tonemap" => {
                vec![build(
                    "vs_main",
                    Some("fs_main"),
                    &[],
                    &[color_target(LDR_FORMAT)],
                    None,
                )]
            }
            other => unreachable!("no render pipelines for pass `{other}`"),
        };
        PassPipelines::Render(pipelines)
    }

    /// Render one frame (timed) and read back its images.
    pub fn render(&mut self) -> Result<FrameOutput, RenderError> {
        let start = Instant::now();
        let FrameRun {
            timings,
            cpu_ms: cpu_assign_ms,
            mut skipped,
        } = self.run_fitted(false)?;
        self.frames_done += 1;
        if self.post.blur_skipped(self.gpu)? {
            skipped.push("bloom_blur".into());
        }
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        let hdr = read_hdr(self.gpu, self.post.output(&self.targets.hdr))?;
        let ldr = read_texture(self.gpu, &self.targets.ldr, 4)?;
        Ok(FrameOutput {
            width: self.width,
            height: self.height,
            hdr,
            ldr: bytemuck::cast_slice(&ldr).to_vec(),
            timings,
            wall_ms,
            cpu_assign_ms,
            skipped,
        })
    }

    /// Render the frame again with instrumented shading and return its exact counters.
    pub fn stats(&mut self) -> Result<FrameStats, RenderError> {
        let gpu = self.gpu;
        self.run_fitted(true)?;
        let sum = |b: &wgpu::Buffer| -> Result<u64, GpuError> {
            let bytes = read_buffer(gpu, b, 0, b.size())?;
            Ok(bytemuck::cast_slice::<u8, u32>(&bytes)
                .iter()
                .map(|&v| v as u64)
                .sum())
        };
        let mut stats = FrameStats {
            light_evals: sum(&self.pixel_evals)?,
            useful_light_evals: sum(&self.pixel_useful)?,
            gbuffer_bytes_per_pixel: if self.variant.pipeline.is_deferred() {
                gbuffer::bytes_per_pixel(self.variant.gbuffer().layout)
            } else {
                0
            },
            post_bytes_per_pixel: self.post.bytes_per_pixel(),
            frame_bytes_per_pixel: self.frame_bytes_per_pixel(),
            list_reallocations: self.reallocations,
            ..Default::default()
        };
        if let Some(c) = &self.clusters {
            let s = c.read_stats(gpu)?;
            let range = c.read_range(gpu)?;
            stats.clusters = c.clusters as u64;
            stats.dropped_lights = s.dropped as u64;
            stats.max_lights_per_cluster = s.max_per_cluster;
            stats.light_list_entries = s.total as u64;
            stats.cluster_bytes = c.bytes();
            stats.z_range = Some([range.near, range.far]);
            stats.assigned_clusters = if self.variant.clusters().active_clusters {
                s.active_clusters as u64
            } else {
                c.clusters as u64
            };
            stats.active_clusters = self.count_visible_clusters()? as u64;
            let bytes = read_buffer(gpu, &self.pixel_clusters, 0, self.pixel_clusters.size())?;
            let used: &[u32] = bytemuck::cast_slice(&bytes);
            let outside = |&(_, &v): &(usize, &u32)| v > c.clusters;
            stats.clusters_out_of_grid = used.iter().enumerate().filter(outside).count() as u64;
            stats.first_out_of_grid = used.iter().enumerate().find(outside).map(|(i, &v)| {
                let w = self.width as usize;
                [(i % w) as u32, (i / w) as u32, v - 1]
            });
            // Pixels record their cluster index + 1 (0: background).
            let mut visible: Vec<u32> = used
                .iter()
                .filter(|&&v| v > 0 && v <= c.clusters)
                .map(|&v| v - 1)
                .collect();
            visible.sort_unstable();
            visible.dedup();
            let counts = c.read_counts(gpu)?;
            let lights: Vec<u32> = visible.iter().map(|&k| counts[k as usize]).collect();
            stats.max_lights_per_visible_cluster = lights.iter().copied().max().unwrap_or(0);
            stats.mean_lights_per_visible_cluster = if lights.is_empty() {
                0.0
            } else {
                lights.iter().map(|&n| n as f64).sum::<f64>() / lights.len() as f64
            };
        }
        Ok(stats)
    }

    fn frame_bytes_per_pixel(&self) -> u32 {
        let t = &self.targets;
        let size = |tex: &wgpu::Texture| {
            // Depth formats have no copy size for the whole texture; 24-bit depth takes 4.
            tex.format()
                .block_copy_size(None)
                .or_else(|| {
                    tex.format()
                        .block_copy_size(Some(wgpu::TextureAspect::DepthOnly))
                })
                .unwrap_or(4)
        };
        [&t.depth, &t.hdr, &t.ldr]
            .into_iter()
            .chain(&t.gbuffer)
            .map(size)
            .sum::<u32>()
            + self.post.bytes_per_pixel()
    }

    /// Clusters holding a visible sample of the last frame's depth (exact marking).
    fn count_visible_clusters(&self) -> Result<u32, RenderError> {
        let gpu = self.gpu;
        let c = self.clusters.as_ref().expect("clustered");
        let Some(PassPipelines::Compute(p)) = self.timed.get("mark_active") else {
            return Ok(0);
        };
        gpu.scoped("counting visible clusters", || {
            let mut e = gpu.device.create_command_encoder(&Default::default());
            e.clear_buffer(&c.active, 0, None);
            // Zero the `active_clusters` counter (third u32 of the stats).
            e.clear_buffer(&c.stats, 8, Some(4));
            {
                let mut pass = e.begin_compute_pass(&Default::default());
                pass.set_pipeline(&p["mark_visible"]);
                self.set_compute_groups(&mut pass, true);
                pass.dispatch_workgroups(
                    dispatch_size(self.width, 8),
                    dispatch_size(self.height, 8),
                    1,
                );
            }
            gpu.queue.submit([e.finish()]);
        })?;
        Ok(c.read_stats(gpu)?.active_clusters)
    }

    /// After a frame: if the light lists overflowed the index buffer, grow it to fit and
    /// say so (the caller runs the frame again).
    fn grow_lists_if_needed(&mut self) -> Result<bool, RenderError> {
        let gpu = self.gpu;
        let Some(c) = &mut self.clusters else {
            return Ok(false);
        };
        let s = c.read_stats(gpu)?;
        if s.overflow == 0 {
            return Ok(false);
        }
        let needed = s.total as u64 + s.total as u64 / 4 + 1024;
        let limit = gpu.limits.max_storage_buffer_binding_size / 4;
        if needed > limit {
            return Err(RenderError::Gpu(GpuError::TooLarge(format!(
                "the light lists need {} entries, more than adapter `{}` can bind ({limit}); use fewer lights, a coarser grid or a per-cluster cap",
                s.total, gpu.adapter.name
            ))));
        }
        c.grow_indices(gpu, needed as u32);
        self.reallocations += 1;
        self.remake_cluster_groups();
        Ok(true)
    }

    /// Run the frame until its light lists fit: the index buffer grows to the exact total a
    /// frame reports, so one re-run fits; lists that still do not fit are an error, never a
    /// picture with lights missing.
    fn run_fitted(&mut self, instrumented: bool) -> Result<FrameRun, RenderError> {
        let mut frame = self.run_frame(instrumented)?;
        let mut runs = 1;
        while self.grow_lists_if_needed()? {
            if runs == 3 {
                return Err(RenderError::Gpu(GpuError::Captured(
                    "the light lists still overflowed their buffer after growing it twice".into(),
                )));
            }
            frame = self.run_frame(instrumented)?;
            runs += 1;
        }
        Ok(frame)
    }

    /// Whether this frame can leave out pass `name`.
    fn skips_pass(&self, name: &str, instrumented: bool) -> bool {
        let s = &self.skips;
        if !s.on {
            return false;
        }
        if s.no_lights && builds_clusters(name) {
            return true;
        }
        // Instrumented frames rebuild the lists: their counters come from assignment.
        if s.static_scene && !instrumented && self.frames_done >= 2 && builds_clusters(name) {
            return true;
        }
        // Boxes depend on the projection, the size and the z-range, and with sample bounds
        // on this frame's depth.
        let clusters = self.variant.clusters();
        let static_bounds =
            !matches!(clusters.slicing, ZSlicing::DynamicRange { .. }) && !clusters.sample_bounds;
        name == "cluster_bounds" && self.bounds_built && static_bounds
    }

    /// Encode and run every pass of the frame (but those it can skip); returns pass timings,
    /// the CPU assignment time and the passes skipped.
    fn run_frame(&mut self, instrumented: bool) -> Result<FrameRun, RenderError> {
        let gpu = self.gpu;
        // Counters start at zero in every run of a frame (a re-run must not add up twice).
        gpu.scoped("clearing counters", || {
            let mut e = gpu.device.create_command_encoder(&Default::default());
            if let Some(c) = &self.clusters {
                e.clear_buffer(&c.stats, 0, None);
            }
            if instrumented {
                e.clear_buffer(&self.pixel_evals, 0, None);
                e.clear_buffer(&self.pixel_useful, 0, None);
                e.clear_buffer(&self.pixel_clusters, 0, None);
            }
            gpu.queue.submit([e.finish()]);
        })?;
        // CPU assignment is the light_assign pass of its variants.
        let cpu_ms = if self.skips_pass("light_assign", instrumented) {
            None
        } else {
            self.assign_on_cpu()?
        };
        let passes = self.passes.clone();
        let mut skipped: Vec<String> = self.skips.always.iter().map(|s| s.to_string()).collect();
        if self.cpu_assignment.is_some() && cpu_ms.is_none() {
            skipped.push("light_assign".into());
        }
        for p in &passes {
            if self.skips_pass(p.name, instrumented) && !skipped.iter().any(|s| s == p.name) {
                skipped.push(p.name.to_string());
            }
        }
        let timings = gpu.scoped("rendering a frame", || -> Result<Timings, GpuError> {
            let mut runner = PassRunner::new(gpu, passes.len() as u32 + 2);
            for pass in &passes {
                if self.skips_pass(pass.name, instrumented) {
                    continue;
                }
                runner.pass(pass.name, |encoder, slot| {
                    self.encode(pass.name, encoder, slot, instrumented)
                })?;
            }
            runner.finish()
        })??;
        self.bounds_built = true;
        Ok(FrameRun {
            timings,
            cpu_ms,
            skipped,
        })
    }

    /// Build and upload the light lists on the CPU (variants with `assignment: Cpu`).
    fn assign_on_cpu(&mut self) -> Result<Option<f64>, RenderError> {
        let Some(cpu) = &self.cpu_assignment else {
            return Ok(None);
        };
        let start = Instant::now();
        let lists = cpu_clusters::assign(&cpu.grid, &cpu.bounds, &cpu.lights, cpu.cap, None);
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let c = self.clusters.as_mut().expect("clustered");
        if !c.upload_lists(self.gpu, &lists) {
            c.grow_indices(self.gpu, lists.indices.len() as u32 + 1024);
            self.reallocations += 1;
            self.remake_cluster_groups();
            let c = self.clusters.as_ref().expect("clustered");
            c.upload_lists(self.gpu, &lists);
        }
        Ok(Some(ms))
    }

    fn set_compute_groups(&self, pass: &mut wgpu::ComputePass<'_>, depth: bool) {
        pass.set_bind_group(0, &self.groups.frame, &[]);
        pass.set_bind_group(1, self.groups.cluster_build.as_ref(), &[]);
        if depth {
            pass.set_bind_group(2, &self.groups.depth_read, &[]);
        }
    }

    fn encode(
        &self,
        name: &str,
        encoder: &mut wgpu::CommandEncoder,
        slot: Option<TimestampSlot<'_>>,
        instrumented: bool,
    ) {
        if is_post(name) {
            return self.post.encode(name, encoder, slot, &self.groups.frame);
        }
        let pipelines = if instrumented && is_shading(name) {
            &self.instrumented[name]
        } else {
            &self.timed[name]
        };
        match pipelines {
            PassPipelines::Compute(p) => self.encode_compute(name, p, encoder, slot),
            PassPipelines::Render(p) => self.encode_render(name, p, encoder, slot, instrumented),
        }
    }

    fn encode_compute(
        &self,
        name: &str,
        p: &HashMap<&'static str, wgpu::ComputePipeline>,
        encoder: &mut wgpu::CommandEncoder,
        slot: Option<TimestampSlot<'_>>,
    ) {
        let c = self
            .clusters
            .as_ref()
            .expect("compute passes are clustered");
        match name {
            "mark_active" => {
                encoder.clear_buffer(&c.active, 0, None);
                encoder.clear_buffer(&c.sample_depths, 0, None);
            }
            "light_assign" => {
                encoder.clear_buffer(&c.counts, 0, None);
                encoder.clear_buffer(&c.fill_cursors, 0, None);
            }
            _ => {}
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(name),
            timestamp_writes: TimestampSlot::compute(slot),
        });
        let pixels = (dispatch_size(self.width, 8), dispatch_size(self.height, 8));
        let clusters = dispatch_size(c.clusters, 64);
        match name {
            "cluster_bounds" => {
                self.set_compute_groups(&mut pass, false);
                pass.set_pipeline(&p["build_bounds"]);
                pass.dispatch_workgroups(clusters, 1, 1);
            }
            "mark_active" => {
                self.set_compute_groups(&mut pass, true);
                pass.set_pipeline(&p["mark_active"]);
                pass.dispatch_workgroups(pixels.0, pixels.1, 1);
            }
            "depth_range" => {
                self.set_compute_groups(&mut pass, true);
                pass.set_pipeline(&p["reduce"]);
                pass.dispatch_workgroups(pixels.0, pixels.1, 1);
                pass.set_pipeline(&p["finalize"]);
                pass.dispatch_workgroups(1, 1, 1);
            }
            "light_assign" => {
                let l = self.scene.light_count;
                // One workgroup per light, in rows of LIGHTS_PER_ROW (light_assign.wesl).
                let per_light = (
                    l.clamp(1, LIGHTS_PER_ROW),
                    l.div_ceil(LIGHTS_PER_ROW).max(1),
                );
                self.set_compute_groups(&mut pass, false);
                for (entry, groups) in [
                    ("transform_lights", (dispatch_size(l, 64), 1)),
                    ("count_lights", per_light),
                    (
                        "scan_local",
                        (dispatch_size(c.clusters, clusters::SCAN_BLOCK), 1),
                    ),
                    ("scan_blocks", (1, 1)),
                    ("fill_lists", per_light),
                    ("finish_lists", (clusters, 1)),
                ] {
                    pass.set_pipeline(&p[entry]);
                    pass.dispatch_workgroups(groups.0, groups.1, 1);
                }
            }
            other => unreachable!("no compute encoding for `{other}`"),
        }
    }

    fn encode_render(
        &self,
        name: &str,
        p: &[wgpu::RenderPipeline],
        encoder: &mut wgpu::CommandEncoder,
        slot: Option<TimestampSlot<'_>>,
        instrumented: bool,
    ) {
        let view_of = |t: &wgpu::Texture| t.create_view(&Default::default());
        let hdr = view_of(&self.targets.hdr);
        let ldr = view_of(&self.targets.ldr);
        let depth_view = view_of(&self.targets.depth);
        let gbuffer_views: Vec<_> = self.targets.gbuffer.iter().map(view_of).collect();
        let depth_attachment = |clear: bool| {
            Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: if clear {
                        wgpu::LoadOp::Clear(self.depth.clear())
                    } else {
                        wgpu::LoadOp::Load
                    },
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            })
        };
        let (colors, depth): (Vec<_>, _) = match name {
            "depth_prepass" => (vec![], depth_attachment(true)),
            "gbuffer" => (
                gbuffer_views.iter().map(clear_attachment).collect(),
                depth_attachment(true),
            ),
            "forward" => (
                vec![clear_attachment(&hdr)],
                depth_attachment(!self.variant.depth_prepass),
            ),
            "resolve" | "scissor_lights" => (vec![clear_attachment(&hdr)], None),
            _ => (vec![clear_attachment(&ldr)], None),
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(name),
            color_attachments: &colors,
            depth_stencil_attachment: depth,
            timestamp_writes: TimestampSlot::render(slot),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        let g = &self.groups;
        let surface = g.gbuffer_read.as_ref().unwrap_or(&g.depth_read);
        match name {
            "tonemap" => pass.set_bind_group(0, &g.tonemap, &[]),
            _ => pass.set_bind_group(0, &g.frame, &[]),
        }
        if matches!(name, "forward" | "resolve" | "debug_view") && self.clusters.is_some() {
            pass.set_bind_group(1, g.cluster_lookup.as_ref(), &[]);
        }
        if matches!(name, "resolve" | "scissor_lights" | "debug_view") {
            pass.set_bind_group(2, surface, &[]);
        }
        if instrumented && is_shading(name) {
            pass.set_bind_group(3, &g.stats, &[]);
        }
        match name {
            "depth_prepass" | "gbuffer" | "forward" => {
                pass.set_pipeline(&p[0]);
                pass.set_vertex_buffer(0, self.scene.vertices.slice(..));
                pass.set_index_buffer(self.scene.indices.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..self.scene.index_count, 0, 0..1);
            }
            "scissor_lights" => {
                pass.set_pipeline(&p[0]);
                pass.draw(0..3, 0..1);
                pass.set_pipeline(&p[1]);
                pass.draw(0..6, 0..self.scene.light_count);
            }
            _ => {
                pass.set_pipeline(&p[0]);
                pass.draw(0..3, 0..1);
            }
        }
    }

    /// The shading pass's HDR image of the last frame, before post-processing.
    pub fn read_shaded(&self) -> Result<Vec<[f32; 4]>, RenderError> {
        Ok(read_hdr(self.gpu, &self.targets.hdr)?)
    }

    /// The light lists as the GPU holds them after the last frame (clustered variants).
    pub fn cluster_lists(&self) -> Result<Option<ClusterLists>, RenderError> {
        match &self.clusters {
            Some(c) => Ok(Some(c.read_lists(self.gpu)?)),
            None => Ok(None),
        }
    }

    /// The depth buffer of the last frame (read it with `twins::gpu_depth_samples`).
    pub fn depth_texture(&self) -> &wgpu::Texture {
        &self.targets.depth
    }

    /// The clustered depth range after the last frame (clustered variants).
    pub fn cluster_range(&self) -> Result<Option<ClusterRange>, RenderError> {
        match &self.clusters {
            Some(c) => Ok(Some(c.read_range(self.gpu)?)),
            None => Ok(None),
        }
    }
}

fn cpu_assignment(variant: &Variant, scene: &Scene) -> CpuAssignment {
    let grid = Grid::of(variant, scene);
    let lights: &[Light] = &scene.lights;
    CpuAssignment {
        bounds: cpu_clusters::cluster_bounds(&grid),
        grid,
        lights: cpu_clusters::view_lights(lights, scene.camera.view()),
        cap: match variant.clusters().lists {
            LightLists::Exact => None,
            LightLists::Capped { max_per_cluster } => Some(max_per_cluster),
        },
    }
}

/// Read an HDR target (rgba32float or rgba16float) as f32.
fn read_hdr(gpu: &Gpu, texture: &wgpu::Texture) -> Result<Vec<[f32; 4]>, GpuError> {
    Ok(match texture.format() {
        wgpu::TextureFormat::Rgba16Float => {
            let bytes = read_texture(gpu, texture, 8)?;
            bytemuck::cast_slice::<u8, [u16; 4]>(&bytes)
                .iter()
                .map(|p| p.map(|h| half::f16::from_bits(h).to_f32()))
                .collect()
        }
        _ => bytemuck::cast_slice(&read_texture(gpu, texture, 16)?).to_vec(),
    })
}
