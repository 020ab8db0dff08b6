//! Running a variant on the GPU: one frame of a scene, pass by pass, timed; and an
//! instrumented frame for the exact counters.
//!
//! Read `frame` first: a variant's frame, pass by pass, with what each reads, writes and
//! dispatches; the renderer encodes those steps in order. What each pass does (entry
//! points, pipelines, attachments, dispatch) lives with its family: `raster`, `screen`,
//! `clustering` (light assignment one unit per method, `culling`), `post`. Bind group
//! layouts come from each composed pass's naga module (`reflect`, `built`); which resource
//! fills a slot, by its typed name (`bindings`), is `FrameResources::scene_binding`. What a
//! frame must fit is `limits`, what it leaves to read back `readback`, what carries from
//! frame to frame `state`.

mod bindings;
mod built;
mod clustering;
mod clusters;
mod culling;
mod error;
pub mod frame;
mod gbuffer;
mod limits;
mod lists;
pub mod needs;
mod passes;
mod post;
mod raster;
mod readback;
mod redo;
mod reflect;
mod resources;
mod reuse;
mod sampling;
mod screen;
pub mod shadows;
mod skips;
mod state;
mod stats;
mod targets;
mod truth;

pub use bindings::Binding;
pub use clusters::{
    AssignmentWork, ClusterBuffers, ClusterRange, ClusterStats, GpuDepthMask, SortJobsHeader,
};
pub use error::RenderError;
pub use frame::{Frame, Step};
pub use passes::{PassRunner, shader_module};
pub use resources::{SceneBuffers, ViewUniform};
pub use reuse::FrameChange;
pub use stats::{FrameStats, PixelCounters, ShadowRays};
pub use targets::{DepthSetup, F32_BITS_FORMAT, LDR_FORMAT};
pub use truth::raster_truth;

use std::time::Instant;

use crate::compose::{self, ComposedPass, Composer, Pass, PassId};
use crate::gpu::{Gpu, GpuError, TimestampSlot, Timings, read_texture};
use crate::scene::Scene;
use crate::variant::{Assignment, Variant};
use built::{BuiltPasses, Pipelines};
use lists::{CpuAssignment, Fit};
use post::PostChain;
use redo::{Held, Lists, Redo};
use resources::FrameResources;
use skips::Skips;
use state::FrameState;

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

/// The pass that draws the most colour targets a frame of `variant` attaches, and their
/// formats: the G-buffer pass's, else the forward pass's HDR target.
fn targets_of(
    variant: &Variant,
    hdr: wgpu::TextureFormat,
) -> (&'static str, Vec<wgpu::TextureFormat>) {
    if variant.pipeline.is_deferred() {
        let formats = gbuffer::formats(variant).into_iter().map(|(_, f)| f);
        ("gbuffer", formats.collect())
    } else {
        ("forward", vec![hdr])
    }
}

/// The scene features a variant's needs and its printed frame are taken on: spots,
/// textures and blended materials (the most passes a frame composes).
const EVERY_FEATURE: compose::SceneFeatures = compose::SceneFeatures {
    spots: true,
    textures: true,
    masks: false,
    blend: true,
};

/// What every pass of a variant's frames needs of a device's limits: its timed and
/// instrumented passes on a scene with blended materials (the most a frame composes), an
/// rgba32float HDR target.
pub fn variant_needs(
    composer: &crate::compose::Composer,
    variant: &Variant,
) -> Result<needs::Needs, RenderError> {
    let timed = compose::frame_features(EVERY_FEATURE, None);
    let counting = compose::frame_features(EVERY_FEATURE, Some(false));
    let mut passes = Vec::new();
    for p in compose::passes_for(variant, true) {
        passes.push(composer.compose_with(variant, &p, &timed)?);
        if p.id.is_shading() {
            passes.push(composer.compose_with(variant, &p, &counting)?);
        }
    }
    let targets = targets_of(variant, wgpu::TextureFormat::Rgba32Float);
    needs::Needs::of(&passes, (targets.0, &targets.1))
}

/// The frame of `variant` on a scene with blended materials and a moving camera (every
/// pass a frame of it may run), with the passes only instrumented frames run: the plan
/// `wgsl --frame` prints. Fails on a pass that does not compose, or that binds a name no
/// resource of a frame has.
pub fn frame_of(composer: &Composer, variant: &Variant) -> Result<Frame, RenderError> {
    let plan = compose::plan(variant, false, true);
    let features = compose::frame_features(EVERY_FEATURE, None);
    let composed = plan
        .passes
        .iter()
        .chain(&plan.support)
        .map(|p| Ok((*p, composer.compose_with(variant, p, &features)?)))
        .collect::<Result<Vec<_>, RenderError>>()?;
    let modules: Vec<(Pass, &ComposedPass)> = composed.iter().map(|(p, c)| (*p, c)).collect();
    Frame::of(variant, &plan, &modules)
}

/// A variant ready to render a scene. Its state, by owner: the frame's passes in order
/// (`frame`), the resources they bind (`res`), their pipelines and bind groups (`passes`),
/// and what carries from frame to frame (`state`).
pub struct Renderer<'g> {
    gpu: &'g Gpu,
    variant: Variant,
    frame: Frame,
    res: FrameResources,
    passes: BuiltPasses,
    state: FrameState,
    cpu_assignment: Option<CpuAssignment>,
    /// The clustered stand-in naive forward counts on, once made (see `prepare_counting`).
    naive_stand_in: Option<Box<Renderer<'g>>>,
}

/// How a frame reports the spot cone it left out of its light loops.
pub const SPOT_CONE: &str = "spot_cone";

/// The pass that builds the light lists.
const ASSIGN: PassId = PassId::Clustering(compose::ClusterPass::LightAssign);

/// Patch keeps room in the index buffer for this many times a rebuild's entries: lists it
/// changes take new room, and a frame that finds none is rebuilt.
const PATCH_ROOM: u64 = 3;

/// What running a frame returned.
struct FrameRun {
    timings: Timings,
    cpu_ms: Option<f64>,
    skipped: Vec<String>,
}

/// The composed passes of a plan: each timed pass once (depth_range may run twice; one
/// pipeline serves both), with its instrumented version when it shades.
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
    /// clustered stand-in of naive forward, see `prepare_counting`).
    fn build_renderer(
        gpu: &'g Gpu,
        composer: &Composer,
        variant: &Variant,
        scene: &Scene,
        count_every_light: bool,
    ) -> Result<Self, RenderError> {
        let (width, height) = (scene.params.width, scene.params.height);
        limits::check_frame(gpu, variant, scene)?;
        let still_camera = scene.camera == scene.prev_camera;
        let plan = compose::plan(variant, still_camera, scene.has_blend());
        let skips = Skips::new(variant, scene);
        let scene_features = compose::SceneFeatures::of(scene, !skips.no_spots);
        let features = compose::frame_features(scene_features, None);
        let mut instrumented_frame =
            compose::frame_features(scene_features, Some(count_every_light));
        instrumented_frame.push(("early_depth", gpu.early_depth));
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
            composed.push((
                *p,
                composer.compose_with(variant, p, &features)?,
                instrumented,
            ));
        }
        let support = plan
            .support
            .iter()
            .map(|p| Ok((*p, composer.compose_with(variant, p, &features)?)))
            .collect::<Result<Vec<_>, RenderError>>()?;
        let every_pass = composed
            .iter()
            .flat_map(|(_, c, i)| std::iter::once(c).chain(i))
            .chain(support.iter().map(|(_, c)| c));
        let targets = targets_of(variant, gpu.hdr_format);
        needs::Needs::of(every_pass, (targets.0, &targets.1))?
            .check(&gpu.limits, gpu.request.limits.name())?;
        let modules: Vec<(Pass, &ComposedPass)> = composed
            .iter()
            .map(|(p, c, _)| (*p, c))
            .chain(support.iter().map(|(p, c)| (*p, c)))
            .collect();
        let frame = Frame::of(variant, &plan, &modules)?;
        let proxies = composed
            .iter()
            .find(|(p, _, _)| p.id == PassId::Clustering(compose::ClusterPass::LightAssign))
            .and_then(|(_, c, _)| clusters::ProxyLayout::of(c));
        let sizes = reflect::BufferSizes::of(
            composed
                .iter()
                .flat_map(|(_, c, i)| std::iter::once(c).chain(i))
                .chain(support.iter().map(|(_, c)| c)),
        )?;
        if variant.pipeline.is_clustered() {
            let c = variant.clusters();
            c.method().check(gpu, c.grid, scene.lights.len(), &sizes)?;
        }
        let occluders = match variant.shading.shadows.traced() {
            true => {
                let occluders = shadows::Occluders::of(scene);
                occluders.check(scene, gpu.max_storage_bytes())?;
                Some(occluders.words())
            }
            false => None,
        };
        let res = gpu.scoped("creating resources", || {
            FrameResources::new(gpu, variant, scene, proxies, &sizes, occluders.as_deref())
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
        let mut res = res;
        if variant.pipeline.is_clustered()
            && variant.clusters().update == crate::variant::ListUpdate::StaticDynamic
        {
            res.moving_set.set(gpu, &scene.moving_lights);
        }
        let mut passes = BuiltPasses {
            timed: Vec::new(),
            instrumented: Vec::new(),
            support: Vec::new(),
            post,
        };
        let to = built::For {
            gpu,
            variant,
            res: &res,
            alpha_mask: features.contains(&("alpha_mask", true)),
        };
        let mut fresh_pipelines = 0;
        gpu.scoped("creating pipelines", || -> Result<(), RenderError> {
            for (pass, timed, _) in &composed {
                if let Some(b) = passes.build(&to, *pass, timed, false)? {
                    passes.timed.push(b);
                }
            }
            // What the timed frames draw with is known now; the rest only counts.
            fresh_pipelines = gpu.pipeline_stats().created - created_before;
            for (pass, _, instrumented) in &composed {
                if let Some(i) = instrumented
                    && let Some(b) = passes.build(&to, *pass, i, true)?
                {
                    passes.instrumented.push(b);
                }
            }
            for (pass, c) in &support {
                if let Some(b) = passes.build(&to, *pass, c, false)? {
                    passes.support.push(b);
                }
            }
            Ok(())
        })??;
        let state = FrameState {
            width,
            height,
            bounds_built: false,
            frames_done: 0,
            drew_without_lights: false,
            last_frame_countable: false,
            fresh_pipelines,
            reallocations: 0,
            patch_rebuilds: 0,
            skips,
            redo: Redo::ALL,
            held: Held::of(scene),
            frame_features: features,
        };
        let mut renderer = Renderer {
            gpu,
            variant: variant.clone(),
            frame,
            res,
            passes,
            state,
            cpu_assignment: None,
            naive_stand_in: None,
        };
        if variant.pipeline.is_clustered() && variant.clusters().assignment == Assignment::Cpu {
            renderer.cpu_assignment = Some(CpuAssignment::new(variant, scene));
        }
        Ok(renderer)
    }

    /// What the clustering passes dispatch over.
    fn extent(&self) -> clustering::Extent {
        clustering::Extent {
            width: self.state.width,
            height: self.state.height,
            lights: self.res.scene.light_count,
            moving: self.res.moving_set.lights.len() as u32,
            refit: self.state.redo.lists == Lists::Refit,
        }
    }

    /// The list strategy of a clustered variant (None without clusters).
    fn update(&self) -> Option<crate::variant::ListUpdate> {
        self.variant
            .pipeline
            .is_clustered()
            .then(|| self.variant.clusters().update)
    }

    /// Patch frames so far that found no room in the index buffer and rebuilt every list.
    pub fn patch_rebuilds(&self) -> u32 {
        self.state.patch_rebuilds
    }

    /// Whether the next frame is the first to draw with pipelines created for this
    /// renderer: software rasterisers compile shader variants on a pipeline's first draw,
    /// so that frame's time includes compiling. Pipelines found made earlier in the run are
    /// taken as warm (the cell that made them drew with them).
    pub fn cold(&self) -> bool {
        self.state.fresh_pipelines > 0
            && self.state.frames_done == 0
            && !self.state.drew_without_lights
    }

    /// Draw a frame of the scene without its lights, not read back; returns the summed time
    /// of its passes. Every pass runs with the frame's pipelines, so a software rasteriser
    /// compiles their shader variants (on first draw) and the images are touched, for about
    /// what a frame with nothing to shade costs; the renderer is warm afterwards (`cold` is
    /// false). It leaves no trace in later frames: they count as if it had not been drawn.
    pub fn draw_without_lights(&mut self) -> Result<crate::gpu::Timings, RenderError> {
        let lights = self.res.scene.light_count;
        self.set_light_count(0);
        // Every pass a sequence's frames may run: a patch of no light, too.
        self.state.redo = Redo::EVERY;
        let run = self.run_frame(false);
        self.state.redo = Redo::ALL;
        self.set_light_count(lights);
        self.state.drew_without_lights = true;
        self.state.last_frame_countable = false;
        Ok(run?.timings)
    }

    /// The light BVH's build alone (its lights' ranges, Morton codes, sort, nodes and
    /// bounds) for the frame's lights, timed as one pass, ms; None without a light BVH.
    /// Run after a frame: it rebuilds what that frame built.
    pub fn time_light_bvh_build(&self) -> Result<Option<f64>, RenderError> {
        let Some(c) = self.res.clusters.as_ref() else {
            return Ok(None);
        };
        let Some(built) = self.passes.find(ASSIGN, false) else {
            return Ok(None);
        };
        let Pipelines::Compute(p) = &built.pipelines else {
            return Ok(None);
        };
        if c.method != crate::variant::CullingMethod::Bvh {
            return Ok(None);
        }
        const NAME: &str = "bvh_build";
        let work = culling::ListWork::BuildBvh {
            lights: self.res.scene.light_count,
        };
        let timings = self.gpu.scoped("timing the light BVH's build", || {
            let mut runner = PassRunner::new(self.gpu, 1);
            runner.pass(NAME, |encoder, slot| {
                culling::encode(work, p, None, &built.groups, encoder, slot, c)
            })?;
            runner.finish()
        })??;
        Ok(Some(timings.get(NAME)))
    }

    /// The names of the passes that shade with the lights (`PassId::is_shading`), as the
    /// frame's timings name them.
    pub fn shading_pass_names(&self) -> Vec<&'static str> {
        self.frame
            .steps
            .iter()
            .filter(|s| s.pass.id.is_shading())
            .map(|s| s.pass.name())
            .collect()
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
        if let Some(s) = &self.res.sampling {
            let gpu = self.gpu;
            gpu.scoped("starting a sampled frame", || {
                let mut e = gpu.device.create_command_encoder(&Default::default());
                s.start_frame(&mut e);
                gpu.queue.submit([e.finish()]);
            })?;
        }
        let FrameRun {
            timings,
            cpu_ms: cpu_assign_ms,
            mut skipped,
        } = self.run_fitted(false)?;
        self.state.frames_done += 1;
        // A frame drawn again without `advance` draws as this one did, with no history.
        if let Some(s) = &mut self.res.sampling {
            s.set_frame(self.gpu, self.state.held.time, false);
        }
        // With a z-range from the previous frame, the first frame's lists were built on the
        // starting range, which its depth-range pass then replaced with this picture's: the
        // lists agree with the range shading reads from the second frame on.
        let late_range = self.variant.range_from_previous_frame();
        self.state.last_frame_countable = !late_range || self.state.frames_done >= 2;
        // A frame rendered again without `advance` redoes everything.
        self.state.redo = Redo::ALL;
        if self.passes.post.blur_skipped(self.gpu)? {
            skipped.push(PassId::Post(compose::PostPass::BloomBlur).name().into());
        }
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        let hdr = targets::read_hdr(
            self.gpu,
            &self.passes.post.output(&self.res.targets.hdr).texture,
        )?;
        let ldr = read_texture(self.gpu, &self.res.targets.ldr.texture)?;
        Ok(FrameOutput {
            width: self.state.width,
            height: self.state.height,
            hdr,
            ldr: bytemuck::cast_slice(&ldr).to_vec(),
            timings,
            wall_ms,
            cpu_assign_ms,
            skipped,
        })
    }

    /// Seed a sampled variant's random numbers with `seed` instead of its own, from the
    /// next frame on, with no history (independent runs of one frame: the bias tests and
    /// `study sampling`). Nothing for an exact variant.
    pub fn reseed(&mut self, seed: u32) {
        if let Some(s) = &mut self.res.sampling {
            s.reseed(seed);
            s.set_frame(self.gpu, self.state.held.time, false);
        }
    }

    /// Run the frame until its light lists fit: the index buffer grows to the exact total a
    /// frame reports, so one re-run fits; lists that still do not fit are an error, never a
    /// picture with lights missing. A Patch frame that finds no room is run again as a
    /// rebuild (which compacts the lists), and Patch's index buffer keeps room for
    /// `PATCH_ROOM` times a rebuild's entries; StaticDynamic's moving lists grow as the
    /// lists do.
    fn run_fitted(&mut self, instrumented: bool) -> Result<FrameRun, RenderError> {
        for _ in 0..4 {
            let frame = self.run_frame(instrumented)?;
            let Some(c) = &self.res.clusters else {
                return Ok(frame);
            };
            let built = !self.state.skips_pass(ASSIGN, instrumented, &self.variant);
            match lists::fit(self.gpu, c)? {
                Fit::GrowTo(_) if self.state.redo.lists == Lists::Patch && !instrumented => {
                    self.state.redo.lists = Lists::Build;
                    self.state.patch_rebuilds += 1;
                    continue;
                }
                Fit::GrowTo(capacity) => {
                    self.grow_lists(capacity)?;
                    continue;
                }
                Fit::Fits { entries }
                    if built
                        && self.update() == Some(crate::variant::ListUpdate::Patch)
                        && (c.index_capacity as u64) < PATCH_ROOM * entries as u64 =>
                {
                    let room = lists::capacity_for(self.gpu, c, PATCH_ROOM * entries as u64)?;
                    if room > c.index_capacity {
                        self.grow_lists(room)?;
                        continue;
                    }
                }
                Fit::Fits { .. } => {}
            }
            let moving = PassId::Clustering(compose::ClusterPass::MovingAssign);
            if let Some(m) = &self.res.moving
                && !self.state.skips_pass(moving, instrumented, &self.variant)
                && let Fit::GrowTo(capacity) = lists::fit(self.gpu, m)?
            {
                let m = self.res.moving.as_mut().expect("moving lists");
                m.grow_indices(self.gpu, capacity);
                self.state.reallocations += 1;
                self.passes.remake_groups(self.gpu, &self.res)?;
                continue;
            }
            return Ok(frame);
        }
        Err(RenderError::Gpu(GpuError::Captured(
            "the light lists still overflowed their buffer after growing it three times".into(),
        )))
    }

    /// Replace the index buffer with one of `capacity` entries, and rebind.
    fn grow_lists(&mut self, capacity: u32) -> Result<(), RenderError> {
        let c = self.res.clusters.as_mut().expect("clustered");
        c.grow_indices(self.gpu, capacity);
        self.state.reallocations += 1;
        self.passes.remake_groups(self.gpu, &self.res)
    }

    /// Build the light lists on the CPU and upload them (variants with `assignment: Cpu`);
    /// the milliseconds it took.
    fn assign_on_cpu(&mut self) -> Result<Option<f64>, RenderError> {
        let Some(cpu) = &self.cpu_assignment else {
            return Ok(None);
        };
        let (lists, ms) = cpu.assign();
        let c = self.res.clusters.as_ref().expect("clustered");
        if !c.upload_lists(self.gpu, &lists) {
            let room = lists::capacity_for(self.gpu, c, lists.indices.len() as u64)?;
            self.grow_lists(room)?;
            let c = self.res.clusters.as_ref().expect("clustered");
            c.upload_lists(self.gpu, &lists);
        }
        Ok(Some(ms))
    }

    /// Encode and run every pass of the frame (but those it can skip); returns pass timings,
    /// the CPU assignment time and the passes skipped.
    fn run_frame(&mut self, instrumented: bool) -> Result<FrameRun, RenderError> {
        let gpu = self.gpu;
        // Counters start at zero in every run of a frame that adds to them (a re-run must
        // not add up twice); the cluster stats stay as the last assignment left them when
        // this frame assigns nothing.
        let assigns = !self.state.skips_pass(ASSIGN, instrumented, &self.variant);
        let moving = PassId::Clustering(compose::ClusterPass::MovingAssign);
        let assigns_moving = !self.state.skips_pass(moving, instrumented, &self.variant);
        let marks = !self.state.skips_pass(
            PassId::Clustering(compose::ClusterPass::MarkActive),
            instrumented,
            &self.variant,
        );
        gpu.scoped("clearing counters", || {
            let mut e = gpu.device.create_command_encoder(&Default::default());
            if let Some(c) = self.res.clusters.as_ref().filter(|_| assigns) {
                if marks {
                    e.clear_buffer(&c.stats, 0, None);
                } else {
                    // The marks of the frame before stay, and so does their count.
                    let at = std::mem::offset_of!(ClusterStats, active_clusters) as u64;
                    e.clear_buffer(&c.stats, 0, Some(at));
                    e.clear_buffer(&c.stats, at + clusters::WORD_BYTES, None);
                }
            }
            if let Some(m) = self.res.moving.as_ref().filter(|_| assigns_moving) {
                e.clear_buffer(&m.stats, 0, None);
            }
            if instrumented {
                self.res.counters.clear(&mut e);
            }
            gpu.queue.submit([e.finish()]);
            // An instrumented frame's assignment counts its work (after the clear, so the
            // write lands with the frame's own passes).
            let counting = std::mem::offset_of!(ClusterStats, counting) as u64;
            let lists = [
                self.res.clusters.as_ref().filter(|_| assigns),
                self.res.moving.as_ref().filter(|_| assigns_moving),
            ];
            for c in lists.into_iter().flatten().filter(|_| instrumented) {
                gpu.queue
                    .write_buffer(&c.stats, counting, bytemuck::bytes_of(&1u32));
            }
        })?;
        // CPU assignment is the light_assign pass of its variants.
        let cpu_ms = if assigns { self.assign_on_cpu()? } else { None };
        let mut skipped: Vec<String> = self.frame.never.iter().map(|p| p.name().into()).collect();
        if self.state.skips.no_spots {
            skipped.push(SPOT_CONE.into());
        }
        if self.cpu_assignment.is_some() && cpu_ms.is_none() {
            skipped.push(ASSIGN.name().into());
        }
        for s in &self.frame.steps {
            let name = s.pass.name();
            if self
                .state
                .skips_pass(s.pass.id, instrumented, &self.variant)
                && !skipped.iter().any(|k| k == name)
            {
                skipped.push(name.into());
            }
        }
        let steps = &self.frame.steps;
        let timings = gpu.scoped("rendering a frame", || -> Result<Timings, GpuError> {
            let mut runner = PassRunner::new(gpu, steps.len() as u32 + 2);
            for step in steps {
                if self
                    .state
                    .skips_pass(step.pass.id, instrumented, &self.variant)
                {
                    continue;
                }
                runner.pass(step.pass.name(), |encoder, slot| {
                    self.encode(step, encoder, slot, instrumented)
                })?;
            }
            runner.finish()
        })??;
        self.state.bounds_built = true;
        Ok(FrameRun {
            timings,
            cpu_ms,
            skipped,
        })
    }

    /// Encode `step` with the pipelines of its family.
    fn encode(
        &self,
        step: &Step,
        encoder: &mut wgpu::CommandEncoder,
        slot: Option<TimestampSlot<'_>>,
        instrumented: bool,
    ) {
        let id = step.pass.id;
        if let PassId::Post(p) = id {
            return self.passes.post.encode(p, encoder, slot);
        }
        let Some(built) = self.passes.find(id, instrumented) else {
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
                res.transparent_depths.as_ref(),
                &self.variant,
                instrumented && raster::tests_depth_itself(p, &self.variant, self.gpu.early_depth),
            ),
            (PassId::Screen(p), Pipelines::Render(pl)) => {
                screen::encode(p, pl, groups, encoder, slot, res)
            }
            (PassId::Clustering(p), Pipelines::Compute(pl)) => {
                let lists = match p {
                    compose::ClusterPass::MovingAssign => res.moving.as_ref(),
                    _ => res.clusters.as_ref(),
                };
                if let Some(c) = lists {
                    let extent = self.extent();
                    let binning = None;
                    clustering::encode(
                        p, &step.work, pl, binning, groups, encoder, slot, c, &extent,
                    );
                }
            }
            (PassId::Clustering(p), Pipelines::Binning(pl, binning)) => {
                if let Some(c) = &res.clusters {
                    let extent = self.extent();
                    let binning = Some(binning);
                    clustering::encode(
                        p, &step.work, pl, binning, groups, encoder, slot, c, &extent,
                    );
                }
            }
            _ => {}
        }
    }
}
