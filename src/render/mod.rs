//! Running a variant on the GPU: one frame of a scene, pass by pass, timed; and an
//! instrumented frame for the exact counters.
//!
//! The renderer keeps the resources and the frame loop. What each pass does (entry points,
//! pipelines, attachments, dispatch) lives with its family: `raster`, `screen`,
//! `clustering`, `post`. Bind group layouts come from each composed pass's naga module
//! (`reflect`); which buffer or image fills a slot is `FrameResources::scene_binding`.

mod clustering;
mod clusters;
mod gbuffer;
mod lists;
mod passes;
mod post;
mod raster;
mod reflect;
mod resources;
mod screen;
mod stats;
mod truth;

pub use clusters::{ClusterBuffers, ClusterRange, ClusterStats, GpuDepthMask};
pub use passes::{PassRunner, shader_module};
pub use resources::{DepthSetup, F32_BITS_FORMAT, LDR_FORMAT, SceneBuffers, ViewUniform};
pub use stats::FrameStats;
pub use truth::raster_truth;

use std::time::Instant;

use crate::compose::{self, ComposedPass, Composer, FramePlan, Pass, PassId, ShaderError};
use crate::cpu::clusters::ClusterLists;
use crate::gpu::{Gpu, GpuError, TimestampSlot, Timings, read_texture};
use crate::scene::Scene;
use crate::variant::{Assignment, DepthRangeSource, Pipeline, Variant, ZSlicing};
use lists::CpuAssignment;
use passes::ComputePipelines;
use post::PostChain;
use reflect::PassLayout;
use resources::FrameResources;

/// Why a frame could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("{0}")]
    Shader(#[from] ShaderError),
    #[error("{0}")]
    Gpu(#[from] GpuError),
    /// A pass's module binds something clusterlab cannot fill.
    #[error("{0}")]
    Reflection(String),
    /// A variant value that only the scene can check (a depth against its camera).
    #[error("field `{field}` {message}")]
    VariantForScene { field: String, message: String },
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
    /// Passes of the variant this frame did not run, and `spot_cone` when its light loops
    /// were composed without the cone (see `Variant::skip_unneeded`).
    pub skipped: Vec<String>,
}

/// The pipelines of a built pass.
enum Pipelines {
    /// Render pipelines, drawn in order.
    Render(Vec<wgpu::RenderPipeline>),
    Compute(ComputePipelines),
    /// Light assignment by rasterised binning: compute passes and the two draws.
    Binning(ComputePipelines, clustering::BinningPipelines),
}

/// A pass ready to encode: its layout (read off its module), pipelines and bind groups.
struct BuiltPass {
    pass: Pass,
    layout: PassLayout,
    pipelines: Pipelines,
    groups: Vec<Option<wgpu::BindGroup>>,
}

/// A variant ready to render a scene: composed passes, pipelines and resources.
pub struct Renderer<'g> {
    gpu: &'g Gpu,
    variant: Variant,
    plan: FramePlan,
    width: u32,
    height: u32,
    res: FrameResources,
    post: PostChain,
    /// Every pass of the plan but the post ones (the post chain holds those), once each.
    timed: Vec<BuiltPass>,
    /// The shading passes with counters.
    instrumented: Vec<BuiltPass>,
    /// Passes only the counters use.
    support: Vec<BuiltPass>,
    /// Cluster bounds are valid for the projection, size and a static z-range.
    bounds_built: bool,
    cpu_assignment: Option<CpuAssignment>,
    reallocations: u32,
    skips: Skips,
    /// Frames rendered (not counting instrumented ones).
    frames_done: u32,
    /// A frame without lights was drawn (see `draw_without_lights`).
    drew_without_lights: bool,
    /// The last frame drawn left depth, G-buffer, cluster data and light lists that agree
    /// with what shading reads, for an instrumented frame to count on (see `render`).
    last_frame_countable: bool,
    /// Pipelines of the timed frame that this renderer created rather than found made
    /// earlier in the run (see `cold`).
    fresh_pipelines: u32,
    /// Features set by the scene rather than the variant (spots, textures).
    frame_features: Vec<(&'static str, bool)>,
    /// The clustered twin naive forward counts on, once made (see `prepare_counting`).
    naive_twin: Option<Box<Renderer<'g>>>,
}

/// What this renderer's frames may leave out (all false when the variant skips nothing).
#[derive(Clone, Debug, Default)]
struct Skips {
    /// The scene has no lights: no clustering at all.
    no_lights: bool,
    /// Neither lights nor camera move: after two frames (the second settles a depth range
    /// taken from the previous frame) the lists, boxes and range stay valid.
    static_scene: bool,
    /// No light is a spot: the light loops are composed without the cone (reported as the
    /// skipped part `spot_cone`).
    no_spots: bool,
    /// Skipping is on at all.
    on: bool,
}

/// Variant values whose valid range depends on the scene's camera.
fn check_for_scene(variant: &Variant, scene: &Scene) -> Result<(), RenderError> {
    if variant.pipeline.is_clustered()
        && let crate::common::ZSlicing::NearSliceThenExponential { near_slice_end } =
            variant.clusters().slicing
    {
        let (near, far) = (scene.camera.near, scene.camera.far);
        let end = near_slice_end as f64;
        if !(end > near && end < far) {
            return Err(RenderError::VariantForScene {
                field: "clusters.slicing.near_slice_end".into(),
                message: format!(
                    "is {near_slice_end}; on scene `{}` it must lie between the camera's near and far planes, {} < value < {}",
                    scene.name, near as f32, far as f32
                ),
            });
        }
    }
    Ok(())
}

/// How a frame reports the spot cone it left out of its light loops.
pub const SPOT_CONE: &str = "spot_cone";

/// What running a frame returned.
struct FrameRun {
    timings: Timings,
    cpu_ms: Option<f64>,
    skipped: Vec<String>,
}

/// The composed passes of a plan: each timed pass once (depth_range may run twice; one
/// pipeline serves both), with its instrumented twin when it shades.
type Composed = Vec<(Pass, ComposedPass, Option<ComposedPass>)>;

impl<'g> Renderer<'g> {
    /// Compose the variant's passes and build everything a frame of `scene` needs.
    pub fn new(
        gpu: &'g Gpu,
        composer: &Composer,
        variant: &Variant,
        scene: &Scene,
    ) -> Result<Self, RenderError> {
        Self::build_renderer(gpu, composer, variant, scene, false)
    }

    /// `count_every_light`: the instrumented passes count every light per fragment (the
    /// counting twin of naive forward, see `prepare_counting`).
    fn build_renderer(
        gpu: &'g Gpu,
        composer: &Composer,
        variant: &Variant,
        scene: &Scene,
        count_every_light: bool,
    ) -> Result<Self, RenderError> {
        let (width, height) = (scene.params.width, scene.params.height);
        gpu.check_size(width, height)?;
        gpu.check_scene(scene)?;
        if variant.pipeline.is_clustered() {
            gpu.check_grid(variant.clusters().grid)?;
            match variant.clusters().culling {
                crate::variant::Culling::ZBinning => {
                    clusters::check_zbinning(gpu, variant.clusters().grid, scene.lights.len())?
                }
                crate::variant::Culling::Rasterised => {
                    clusters::check_rasterised(gpu, variant.clusters().grid, scene.lights.len())?
                }
                _ => {}
            }
        }
        check_for_scene(variant, scene)?;
        // Every pipeline but scissor deferred loops over up to all the lights per pixel; a
        // walk through light bitmasks (z-binning's light loop, two-level culling's clusters)
        // also loops once per 32-bit word of them, and two-level culling once per word of
        // their summary.
        let c = variant.clusters();
        let mask_words = |n: usize| match variant.pipeline.is_clustered() {
            true if c.big_tiles.is_some() => n.div_ceil(32) + n.div_ceil(1024) + 2,
            true if c.culling == crate::variant::Culling::ZBinning => n.div_ceil(32) + 1,
            _ => 0,
        };
        if let Some(limit) = crate::gpu::expect::max_lights_per_pixel(gpu)
            && variant.pipeline != Pipeline::DeferredScissor
            && scene.lights.len() + mask_words(scene.lights.len()) > limit as usize
        {
            let limit = limit as usize;
            let most = (0..=limit)
                .rev()
                .find(|&n| n + mask_words(n) <= limit)
                .unwrap_or(0);
            return Err(RenderError::Gpu(GpuError::TooLarge(format!(
                "{} lights: adapter `{}` ends a shader's loops after {} iterations in all, so a light loop over more than {most} lights{} would leave lights out without a word; use at most {most} lights on this adapter, or scissor deferred",
                scene.lights.len(),
                gpu.adapter.name,
                crate::gpu::expect::LLVMPIPE_LOOP_ITERATIONS,
                if mask_words(1) > 0 {
                    " and their bitmask words"
                } else {
                    ""
                }
            ))));
        }
        let still_camera = scene.camera == scene.prev_camera;
        let plan = compose::plan(variant, still_camera);
        let skips = Skips {
            no_lights: variant.skip_unneeded && scene.lights.is_empty(),
            static_scene: variant.skip_unneeded && still_camera && !scene.lights_move,
            no_spots: variant.skip_unneeded && !scene.lights.iter().any(|l| l.is_spot()),
            on: variant.skip_unneeded,
        };
        // A scene without spots needs no cone in its light loops: on a software rasteriser,
        // which runs both sides of a branch, the cone costs point lights about half again.
        let frame = [
            ("spot_lights", !skips.no_spots),
            ("base_color_texture", scene.textures.is_some()),
        ];
        let frame_features = frame.to_vec();
        let instrumented_frame = [
            frame[0],
            frame[1],
            ("stats", true),
            ("count_every_light", count_every_light),
        ];
        let mut composed: Composed = Vec::new();
        for p in &plan.passes {
            if composed.iter().any(|(q, _, _)| q.id == p.id) {
                continue;
            }
            let instrumented = if p.id.is_shading() {
                Some(composer.compose_with(variant, p, &instrumented_frame)?)
            } else {
                None
            };
            composed.push((*p, composer.compose_with(variant, p, &frame)?, instrumented));
        }
        let support = plan
            .support
            .iter()
            .map(|p| Ok((*p, composer.compose_with(variant, p, &frame)?)))
            .collect::<Result<Vec<_>, RenderError>>()?;
        let res = gpu.scoped("creating resources", || {
            FrameResources::new(gpu, variant, scene)
        })?;
        let post_passes: Vec<_> = composed
            .iter()
            .filter_map(|(p, c, _)| match p.id {
                PassId::Post(id) => Some((id, c)),
                _ => None,
            })
            .collect();
        let created_before = gpu.pipeline_stats().created;
        let post = gpu.scoped("creating the post chain", || {
            PostChain::new(gpu, variant, &post_passes, &res)
        })??;
        let mut renderer = Renderer {
            gpu,
            variant: variant.clone(),
            plan,
            width,
            height,
            res,
            post,
            timed: Vec::new(),
            instrumented: Vec::new(),
            support: Vec::new(),
            bounds_built: false,
            cpu_assignment: None,
            reallocations: 0,
            skips,
            frames_done: 0,
            drew_without_lights: false,
            last_frame_countable: false,
            fresh_pipelines: 0,
            frame_features,
            naive_twin: None,
        };
        gpu.scoped("creating pipelines", || -> Result<(), RenderError> {
            for (pass, timed, _) in &composed {
                if let Some(b) = renderer.build(*pass, timed, false)? {
                    renderer.timed.push(b);
                }
            }
            // What the timed frames draw with is known now; the rest only counts.
            renderer.fresh_pipelines = gpu.pipeline_stats().created - created_before;
            for (pass, _, instrumented) in &composed {
                if let Some(i) = instrumented
                    && let Some(b) = renderer.build(*pass, i, true)?
                {
                    renderer.instrumented.push(b);
                }
            }
            for (pass, c) in &support {
                if let Some(b) = renderer.build(*pass, c, false)? {
                    renderer.support.push(b);
                }
            }
            Ok(())
        })??;
        if variant.pipeline.is_clustered() && variant.clusters().assignment == Assignment::Cpu {
            renderer.cpu_assignment = Some(CpuAssignment::new(variant, scene));
        }
        Ok(renderer)
    }

    /// Pipelines and bind groups of one pass (None for post passes: the chain has them).
    fn build(
        &self,
        pass: Pass,
        composed: &ComposedPass,
        instrumented: bool,
    ) -> Result<Option<BuiltPass>, RenderError> {
        let gpu = self.gpu;
        let layout = PassLayout::of(gpu, composed)?;
        let l = &layout.pipeline;
        let pipelines = match pass.id {
            PassId::Raster(p) => Pipelines::Render(raster::pipelines(
                gpu,
                p,
                composed,
                l,
                &self.variant,
                instrumented,
            )?),
            PassId::Screen(p) => Pipelines::Render(screen::pipelines(gpu, p, composed, l)?),
            PassId::Clustering(p) => {
                let culling = self.variant.clusters().culling;
                let compute = ComputePipelines::new(
                    gpu,
                    composed,
                    l,
                    clustering::entries(p, culling, self.variant.clusters().big_tiles.is_some()),
                )?;
                if p == compose::ClusterPass::LightAssign
                    && culling == crate::variant::Culling::Rasterised
                {
                    Pipelines::Binning(
                        compute,
                        clustering::BinningPipelines::new(gpu, composed, l)?,
                    )
                } else {
                    Pipelines::Compute(compute)
                }
            }
            PassId::Post(_) => return Ok(None),
        };
        let groups = self.bind(pass.id, &layout)?;
        Ok(Some(BuiltPass {
            pass,
            layout,
            pipelines,
            groups,
        }))
    }

    /// The bind groups of pass `id` with `layout`, filled from the frame's resources.
    fn bind(
        &self,
        id: PassId,
        layout: &PassLayout,
    ) -> Result<Vec<Option<wgpu::BindGroup>>, RenderError> {
        let shaded = &self.post.output(&self.res.targets.hdr).view;
        layout.bind_groups(self.gpu, id.name(), |group, binding| match id {
            PassId::Screen(p) => screen::binding(p, group, binding, &self.res, shaded),
            _ => self.res.scene_binding(group, binding),
        })
    }

    /// Make every pass's bind groups again (after a buffer they bind was replaced).
    fn remake_groups(&mut self) -> Result<(), RenderError> {
        let mut all = Vec::new();
        for b in self
            .timed
            .iter()
            .chain(&self.instrumented)
            .chain(&self.support)
        {
            all.push(self.bind(b.pass.id, &b.layout)?);
        }
        let built = self
            .timed
            .iter_mut()
            .chain(&mut self.instrumented)
            .chain(&mut self.support);
        for (b, groups) in built.zip(all) {
            b.groups = groups;
        }
        Ok(())
    }

    /// What the clustering passes dispatch over.
    fn extent(&self) -> clustering::Extent {
        clustering::Extent {
            width: self.width,
            height: self.height,
            lights: self.res.scene.light_count,
        }
    }

    /// Whether the next frame is the first to draw with pipelines created for this
    /// renderer: software rasterisers compile shader variants on a pipeline's first draw,
    /// so that frame's time includes compiling. Pipelines found made earlier in the run are
    /// taken as warm (the cell that made them drew with them).
    pub fn cold(&self) -> bool {
        self.fresh_pipelines > 0 && self.frames_done == 0 && !self.drew_without_lights
    }

    /// Draw a frame of the scene without its lights, not read back; returns the summed time
    /// of its passes. Every pass runs with the frame's pipelines, so a software rasteriser
    /// compiles their shader variants (on first draw) and the images are touched, for about
    /// what a frame with nothing to shade costs; the renderer is warm afterwards (`cold` is
    /// false). It leaves no trace in later frames: they count as if it had not been drawn.
    pub fn draw_without_lights(&mut self) -> Result<f64, RenderError> {
        let lights = self.res.scene.light_count;
        self.set_light_count(0);
        let run = self.run_frame(false);
        self.set_light_count(lights);
        self.drew_without_lights = true;
        self.last_frame_countable = false;
        Ok(run?.timings.total_ms())
    }

    /// The light count the frame's passes see: in the view uniform, and for the draws and
    /// dispatches sized by it.
    fn set_light_count(&mut self, lights: u32) {
        self.res.scene.light_count = lights;
        let at = std::mem::offset_of!(resources::ViewUniform, light_count) as u64;
        self.gpu
            .queue
            .write_buffer(&self.res.scene.view, at, bytemuck::bytes_of(&lights));
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
        // With a z-range from the previous frame, the first frame's lists were built on the
        // starting range, which its depth-range pass then replaced with this picture's: the
        // lists agree with the range shading reads from the second frame on.
        let late_range = self.variant.pipeline.is_clustered()
            && self.variant.clusters().slicing
                == (ZSlicing::DynamicRange {
                    source: DepthRangeSource::PreviousFrame,
                });
        self.last_frame_countable = !late_range || self.frames_done >= 2;
        if self.post.blur_skipped(self.gpu)? {
            skipped.push(PassId::Post(compose::PostPass::BloomBlur).name().into());
        }
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        let hdr = read_hdr(self.gpu, &self.post.output(&self.res.targets.hdr).texture)?;
        let ldr = read_texture(self.gpu, &self.res.targets.ldr.texture, 4)?;
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

    /// Whether this frame can leave out pass `id`.
    fn skips_pass(&self, id: PassId, instrumented: bool) -> bool {
        // An instrumented frame's counters come from assignment and shading: what only
        // turns shaded colour into pixels (post effects, tonemap, a debug view) is left out.
        // After a timed frame it counts on that frame's depth, G-buffer and lists (every
        // frame of a renderer draws the same picture, and assignment's counters stay in
        // the cluster stats), so only the shading pass runs.
        if instrumented && (id.after_shading() || (self.last_frame_countable && !id.is_shading())) {
            return true;
        }
        let s = &self.skips;
        if !s.on {
            return false;
        }
        let builds_clusters = matches!(id, PassId::Clustering(_));
        if s.no_lights && builds_clusters {
            return true;
        }
        // From a still scene's third frame on, the lists are those built before (an
        // instrumented frame with no countable frame before it builds its own).
        if s.static_scene && !instrumented && self.frames_done >= 2 && builds_clusters {
            return true;
        }
        // Boxes depend on the projection, the size and the z-range, and with sample bounds
        // on this frame's depth.
        let clusters = self.variant.clusters();
        let static_bounds =
            !matches!(clusters.slicing, ZSlicing::DynamicRange { .. }) && !clusters.sample_bounds;
        id == PassId::Clustering(compose::ClusterPass::ClusterBounds)
            && self.bounds_built
            && static_bounds
    }

    /// Encode and run every pass of the frame (but those it can skip); returns pass timings,
    /// the CPU assignment time and the passes skipped.
    fn run_frame(&mut self, instrumented: bool) -> Result<FrameRun, RenderError> {
        let gpu = self.gpu;
        // Counters start at zero in every run of a frame that adds to them (a re-run must
        // not add up twice); the cluster stats stay as the last assignment left them when
        // this frame assigns nothing.
        let assign = PassId::Clustering(compose::ClusterPass::LightAssign);
        let assigns = !self.skips_pass(assign, instrumented);
        gpu.scoped("clearing counters", || {
            let mut e = gpu.device.create_command_encoder(&Default::default());
            if let Some(c) = self.res.clusters.as_ref().filter(|_| assigns) {
                e.clear_buffer(&c.stats, 0, None);
            }
            if instrumented {
                self.res.counters.clear(&mut e);
            }
            gpu.queue.submit([e.finish()]);
        })?;
        // CPU assignment is the light_assign pass of its variants.
        let cpu_ms = if assigns { self.assign_on_cpu()? } else { None };
        let mut skipped: Vec<String> = self.plan.never.iter().map(|p| p.name().into()).collect();
        if self.skips.no_spots {
            skipped.push(SPOT_CONE.into());
        }
        if self.cpu_assignment.is_some() && cpu_ms.is_none() {
            skipped.push(assign.name().into());
        }
        for p in &self.plan.passes {
            if self.skips_pass(p.id, instrumented) && !skipped.iter().any(|s| s == p.name()) {
                skipped.push(p.name().into());
            }
        }
        let passes = &self.plan.passes;
        let timings = gpu.scoped("rendering a frame", || -> Result<Timings, GpuError> {
            let mut runner = PassRunner::new(gpu, passes.len() as u32 + 2);
            for pass in passes {
                if self.skips_pass(pass.id, instrumented) {
                    continue;
                }
                runner.pass(pass.name(), |encoder, slot| {
                    self.encode(pass.id, encoder, slot, instrumented)
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

    /// Encode pass `id` with the pipelines of its family.
    fn encode(
        &self,
        id: PassId,
        encoder: &mut wgpu::CommandEncoder,
        slot: Option<TimestampSlot<'_>>,
        instrumented: bool,
    ) {
        if let PassId::Post(p) = id {
            return self.post.encode(p, encoder, slot);
        }
        let list = if instrumented && id.is_shading() {
            &self.instrumented
        } else {
            &self.timed
        };
        let Some(built) = list.iter().find(|b| b.pass.id == id) else {
            return;
        };
        let (groups, res) = (&built.groups, &self.res);
        match (id, &built.pipelines) {
            (PassId::Raster(p), Pipelines::Render(pl)) => raster::encode(
                p,
                pl,
                groups,
                encoder,
                slot,
                &res.targets,
                &res.scene,
                &self.variant,
            ),
            (PassId::Screen(p), Pipelines::Render(pl)) => {
                screen::encode(p, pl, groups, encoder, slot, res)
            }
            (PassId::Clustering(p), Pipelines::Compute(pl)) => {
                if let Some(c) = &res.clusters {
                    clustering::encode(p, pl, None, groups, encoder, slot, c, &self.extent());
                }
            }
            (PassId::Clustering(p), Pipelines::Binning(pl, binning)) => {
                if let Some(c) = &res.clusters {
                    let extent = self.extent();
                    clustering::encode(p, pl, Some(binning), groups, encoder, slot, c, &extent);
                }
            }
            _ => {}
        }
    }

    /// Debug view `view` of the last frame, drawn from its depth and light lists by the
    /// debug pass alone (the same image a whole frame of the variant with that view shows;
    /// post effects, which a debug view leaves out, change neither). 8-bit RGBA, row-major.
    pub fn debug_image(
        &self,
        composer: &Composer,
        view: crate::variant::DebugView,
    ) -> Result<Vec<[u8; 4]>, RenderError> {
        let gpu = self.gpu;
        let mut v = self.variant.clone();
        v.debug_view = view;
        v.post = Default::default();
        let id = PassId::Screen(compose::ScreenPass::DebugView);
        let Some(pass) = compose::passes(&v).into_iter().find(|p| p.id == id) else {
            return Err(RenderError::Reflection(format!(
                "variant has no debug pass for view {view:?}"
            )));
        };
        let composed = composer.compose_with(&v, &pass, &self.frame_features)?;
        gpu.scoped("drawing a debug view", || -> Result<(), RenderError> {
            let layout = PassLayout::of(gpu, &composed)?;
            let pipelines = screen::pipelines(
                gpu,
                compose::ScreenPass::DebugView,
                &composed,
                &layout.pipeline,
            )?;
            let groups = layout.bind_groups(gpu, id.name(), |g, b| self.res.scene_binding(g, b))?;
            let mut e = gpu.device.create_command_encoder(&Default::default());
            screen::encode(
                compose::ScreenPass::DebugView,
                &pipelines,
                &groups,
                &mut e,
                None,
                &self.res,
            );
            gpu.queue.submit([e.finish()]);
            Ok(())
        })??;
        let ldr = read_texture(gpu, &self.res.targets.ldr.texture, 4)?;
        Ok(bytemuck::cast_slice(&ldr).to_vec())
    }

    /// The shading pass's HDR image of the last frame, before post-processing.
    pub fn read_shaded(&self) -> Result<Vec<[f32; 4]>, RenderError> {
        Ok(read_hdr(self.gpu, &self.res.targets.hdr.texture)?)
    }

    /// The light lists as the GPU holds them after the last frame (clustered variants).
    pub fn cluster_lists(&self) -> Result<Option<ClusterLists>, RenderError> {
        match &self.res.clusters {
            Some(c) => Ok(Some(c.read_lists(self.gpu)?)),
            None => Ok(None),
        }
    }

    /// The cluster boxes after the last frame (clustered variants): [min, max] per cluster.
    pub fn cluster_bounds(&self) -> Result<Option<Vec<[[f32; 4]; 2]>>, RenderError> {
        match &self.res.clusters {
            Some(c) => Ok(Some(c.read_bounds(self.gpu)?)),
            None => Ok(None),
        }
    }

    /// Each cluster's sample depth range and 2.5D mask after the last frame (clustered
    /// variants; see `ClusterBuffers::read_depth_masks`).
    pub fn depth_masks(&self) -> Result<Option<Vec<GpuDepthMask>>, RenderError> {
        match &self.res.clusters {
            Some(c) => Ok(Some(c.read_depth_masks(self.gpu)?)),
            None => Ok(None),
        }
    }

    /// Z-binning's sorted lights, bins and tile masks after the last frame (None for other
    /// pipelines and culling methods).
    pub fn zbins(&self) -> Result<Option<crate::cpu::zbin::ZBins>, RenderError> {
        match &self.res.clusters {
            Some(c) if c.culling == crate::variant::Culling::ZBinning => {
                Ok(Some(c.read_zbins(self.gpu)?))
            }
            _ => Ok(None),
        }
    }

    /// The depth buffer of the last frame (read it with `twins::gpu_depth_samples`).
    pub fn depth_texture(&self) -> &wgpu::Texture {
        &self.res.targets.depth.texture
    }

    /// The clustered depth range after the last frame (clustered variants).
    pub fn cluster_range(&self) -> Result<Option<ClusterRange>, RenderError> {
        match &self.res.clusters {
            Some(c) => Ok(Some(c.read_range(self.gpu)?)),
            None => Ok(None),
        }
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
