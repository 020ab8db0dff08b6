//! A frame, step by step: every pass of a variant's frame in the order it runs, with what
//! it reads, what it writes and what it dispatches or draws. The renderer encodes from this
//! plan (`Renderer::run_frame` walks `Frame::steps`, leaving out what
//! `FrameState::skips_pass` says a frame may), and `clusterlab wgsl VARIANT --frame` prints
//! it. Which passes a variant runs, and in what order, is `compose::passes_for`'s one
//! decision; what each reads and writes is read off its composed module (its bindings and
//! their access) and its family's attachments, so it cannot drift from the shaders.
//!
//! A frame of a clustered variant, the steps it has in this order:
//! 1. `depth_prepass`: the opaque triangles into depth (a variant with a pre-pass).
//! 2. `gbuffer`: the opaque triangles into depth and the G-buffer (deferred).
//! 3. `transparent_depths`: each pixel's nearest and farthest blended depth (scenes with
//!    blended materials whose lists fit the visible depths).
//! 4. `depth_range`: the frame's depth range, reduced over the pixels (dynamic slicing).
//! 5. `mark_active`: the clusters that hold a visible sample.
//! 6. `cluster_bounds`: each cluster's view-space box.
//! 7. `light_assign`: the light lists, by the variant's culling method (`culling/`).
//! 8. `moving_assign` or `list_patch`: StaticDynamic's moving lists, or Patch's.
//! 9. `still_shading` or `still_resolve`: StaticDynamic's still image.
//! 10. `forward`, `resolve` or `scissor_lights`: shading, every light of the pixel's list.
//! 11. `sample_resolve`: multisampled forward colour to one sample a pixel.
//! 12. `transparent`: the blended triangles, shaded over the opaque frame.
//! 13. `depth_range` again, for the next frame (slicing from the previous frame).
//! 14. post effects (`post`): toon, bloom, motion blur.
//! 15. `tonemap`, or a `debug_view`: the displayed image.

use std::fmt;

use super::bindings::Binding;
use super::error::RenderError;
use super::reflect;
use crate::compose::{ClusterPass, ComposedPass, Pass, PassId, RasterPass, ScreenPass};
use crate::variant::{CullingMethod, Variant};

/// What a compute dispatch covers: one invocation per pixel or per cluster, or one
/// workgroup.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Over {
    Pixels,
    Clusters,
    OneGroup,
}

/// What a step dispatches or draws.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Work {
    /// The scene's triangles: the opaque ones, or the blended ones back to front.
    Triangles { blended: bool },
    /// One full-screen triangle.
    FullScreen,
    /// The ambient full-screen triangle, then one rectangle per light.
    LightRectangles,
    /// Compute dispatches, in order: each an entry point over what it covers.
    Dispatches(Vec<(&'static str, Over)>),
    /// Light lists built by a culling method's own plan of clears, dispatches, copies and a
    /// draw (`culling/`): for every light, for the moving lights, or for those that moved.
    Lists(CullingMethod),
    /// One step of the post chain (`post`).
    Post,
}

/// One pass of the frame.
#[derive(Clone, Debug)]
pub struct Step {
    pub pass: Pass,
    /// What it only reads.
    pub reads: Vec<Binding>,
    /// What it may write: storage buffers and images it stores to.
    pub writes: Vec<Binding>,
    /// The images it renders into (its colour and depth attachments).
    pub attachments: Vec<&'static str>,
    pub work: Work,
}

/// A variant's frame: the steps every frame runs, the passes no frame of the scene needs,
/// and the steps only the counters use.
#[derive(Clone, Debug)]
pub struct Frame {
    pub steps: Vec<Step>,
    pub never: Vec<PassId>,
    pub support: Vec<Step>,
}

impl Frame {
    /// The frame of `plan`, each pass described from its composed module (`composed`, by
    /// pass; the first of each).
    pub fn of(
        variant: &Variant,
        plan: &crate::compose::FramePlan,
        composed: &[(Pass, &ComposedPass)],
    ) -> Result<Frame, RenderError> {
        let step = |p: &Pass| -> Result<Step, RenderError> {
            let module = composed
                .iter()
                .find(|(q, _)| q.id == p.id)
                .map(|(_, c)| *c)
                .ok_or_else(|| {
                    RenderError::Reflection(format!("pass `{}` was not composed", p.name()))
                })?;
            Step::of(variant, *p, module)
        };
        Ok(Frame {
            steps: plan.passes.iter().map(step).collect::<Result<_, _>>()?,
            never: plan.never.clone(),
            support: plan.support.iter().map(step).collect::<Result<_, _>>()?,
        })
    }

    /// Whether this frame runs exactly the passes of `plan`.
    pub fn runs(&self, plan: &crate::compose::FramePlan) -> bool {
        let ids = |s: &[Step]| s.iter().map(|s| s.pass).collect::<Vec<_>>();
        ids(&self.steps) == plan.passes
            && ids(&self.support) == plan.support
            && self.never == plan.never
    }
}

impl Step {
    fn of(variant: &Variant, pass: Pass, module: &ComposedPass) -> Result<Step, RenderError> {
        let names = reflect::declared(module)?;
        let (mut reads, mut writes) = (Vec::new(), Vec::new());
        // What the entry points do with each binding (naga's use flags), not what it is
        // declared as: a shared module declares buffers read_write that a pass only reads.
        for (handle, var) in module.module.global_variables.iter() {
            let Some(slot) = &var.binding else { continue };
            let name = names[&(slot.group, slot.binding)];
            let used = (0..module.module.entry_points.len())
                .fold(naga::valid::GlobalUse::empty(), |u, i| {
                    u | module.info.get_entry_point(i)[handle]
                });
            if used.contains(naga::valid::GlobalUse::WRITE) {
                writes.push(name);
            } else if used.contains(naga::valid::GlobalUse::READ) {
                reads.push(name);
            }
        }
        // The moving lists' pass builds its lists in the moving lists' buffers, which
        // shading reads as `moving_*` (`BuiltPasses::bind`, `FrameResources::scene_binding`).
        if pass.id == PassId::Clustering(ClusterPass::MovingAssign) {
            for b in reads.iter_mut().chain(writes.iter_mut()) {
                *b = match *b {
                    Binding::LightCounts => Binding::MovingCounts,
                    Binding::LightOffsets => Binding::MovingOffsets,
                    Binding::LightIndices => Binding::MovingIndices,
                    other => other,
                };
            }
        }
        reads.sort();
        reads.dedup();
        writes.sort();
        writes.dedup();
        Ok(Step {
            pass,
            reads,
            writes,
            attachments: attachments(variant, pass.id),
            work: work(variant, pass.id),
        })
    }
}

/// The images pass `id` renders into.
fn attachments(v: &Variant, id: PassId) -> Vec<&'static str> {
    let samples = crate::compose::shades_samples_apart(v);
    let colour = if samples { "hdr_samples" } else { "hdr" };
    match id {
        PassId::Raster(RasterPass::DepthPrepass) => vec!["depth"],
        PassId::Raster(RasterPass::GBuffer) => {
            let mut targets: Vec<&'static str> = super::gbuffer::formats(v)
                .into_iter()
                .map(|(name, _)| name)
                .collect();
            targets.push("depth");
            targets
        }
        PassId::Raster(RasterPass::Forward | RasterPass::Transparent) => vec![colour, "depth"],
        PassId::Raster(RasterPass::StillShading) => vec!["still_image", "depth"],
        PassId::Raster(RasterPass::TransparentDepths) => vec!["depth"],
        PassId::Screen(ScreenPass::ScissorLights) => vec![colour],
        PassId::Screen(ScreenPass::Resolve | ScreenPass::SampleResolve) => vec!["hdr"],
        PassId::Screen(ScreenPass::StillResolve) => vec!["still_image"],
        PassId::Screen(ScreenPass::Tonemap | ScreenPass::DebugView) => vec!["ldr"],
        PassId::Clustering(ClusterPass::LightAssign)
            if v.clusters().method() == CullingMethod::Rasterised =>
        {
            vec!["binning target"]
        }
        PassId::Clustering(_) | PassId::Post(_) => vec![],
    }
}

/// What pass `id` dispatches or draws.
fn work(v: &Variant, id: PassId) -> Work {
    match id {
        PassId::Raster(RasterPass::Transparent) => Work::Triangles { blended: true },
        PassId::Raster(_) => Work::Triangles { blended: false },
        PassId::Screen(ScreenPass::ScissorLights) => Work::LightRectangles,
        PassId::Screen(_) => Work::FullScreen,
        PassId::Clustering(ClusterPass::DepthRange) => {
            Work::Dispatches(vec![("reduce", Over::Pixels), ("finalize", Over::OneGroup)])
        }
        PassId::Clustering(ClusterPass::MarkActive) => {
            let mut marks = vec![("mark_active", Over::Pixels)];
            if v.clusters().culling.marks_depth_cells() {
                marks.push(("mark_cells", Over::Pixels));
            }
            Work::Dispatches(marks)
        }
        PassId::Clustering(ClusterPass::ClusterBounds) => {
            Work::Dispatches(vec![("build_bounds", Over::Clusters)])
        }
        PassId::Clustering(ClusterPass::LightAssign) => Work::Lists(v.clusters().method()),
        // The moving lists are one-level lists; Patch moves entries within the lists.
        PassId::Clustering(ClusterPass::MovingAssign | ClusterPass::ListPatch) => {
            Work::Lists(CullingMethod::OneLevel)
        }
        PassId::Post(_) => Work::Post,
    }
}

impl fmt::Display for Work {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Work::Triangles { blended: false } => write!(f, "draws the opaque triangles"),
            Work::Triangles { blended: true } => {
                write!(f, "draws the blended triangles, back to front")
            }
            Work::FullScreen => write!(f, "draws one full-screen triangle"),
            Work::LightRectangles => {
                write!(f, "draws the ambient triangle, then a rectangle per light")
            }
            Work::Dispatches(d) => {
                let each: Vec<String> = d
                    .iter()
                    .map(|(entry, over)| match over {
                        Over::Pixels => format!("{entry} per pixel"),
                        Over::Clusters => format!("{entry} per cluster"),
                        Over::OneGroup => format!("{entry} once"),
                    })
                    .collect();
                write!(f, "dispatches {}", each.join(", then "))
            }
            Work::Lists(method) => write!(f, "builds the light lists: {}'s plan", method.label()),
            Work::Post => write!(f, "runs its post-chain step"),
        }
    }
}

impl fmt::Display for Frame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names =
            |b: &[Binding]| -> String { b.iter().map(|b| b.name()).collect::<Vec<_>>().join(", ") };
        for (i, s) in self.steps.iter().chain(&self.support).enumerate() {
            let support = if i >= self.steps.len() {
                " (instrumented frames only)"
            } else {
                ""
            };
            writeln!(f, "{:>2}. {}{support}: {}", i + 1, s.pass.name(), s.work)?;
            if !s.reads.is_empty() {
                writeln!(f, "      reads  {}", names(&s.reads))?;
            }
            if !s.writes.is_empty() {
                writeln!(f, "      writes {}", names(&s.writes))?;
            }
            if !s.attachments.is_empty() {
                writeln!(f, "      into   {}", s.attachments.join(", "))?;
            }
        }
        for id in &self.never {
            writeln!(f, "    {}: never run on this scene", id.name())?;
        }
        Ok(())
    }
}
