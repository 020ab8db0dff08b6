//! The passes of a frame: one typed identifier per pass, grouped by family, and the one place
//! that decides which passes a variant runs, in order.
//!
//! A family is one kind of GPU work, and `render/` has one file for each: `raster` (scene
//! geometry into the depth buffer and targets), `screen` (full-screen and screen-space draws
//! over what the raster passes left), `clustering` (compute passes that build the clusters
//! and their light lists) and `post` (compute passes between shading and tonemapping).

use strum::{EnumIter, IntoEnumIterator, IntoStaticStr};

use crate::common::PostEffect;
use crate::variant::*;

/// Passes that rasterise the scene's geometry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, EnumIter, IntoStaticStr)]
#[strum(serialize_all = "snake_case")]
pub enum RasterPass {
    DepthPrepass,
    #[strum(serialize = "gbuffer")]
    GBuffer,
    Forward,
    /// Scenes with blended materials: the nearest and farthest blended depth of each pixel,
    /// for the clustering passes that fit lists to the visible depths.
    TransparentDepths,
    /// Scenes with blended materials: the blended triangles shaded forward (with the
    /// clusters, in clustered pipelines) and drawn over the opaque frame, back to front.
    Transparent,
    /// StaticDynamic forward after a pre-pass: each pixel's still lights and ambient, into
    /// the still image the forward pass adds the moving lights to.
    StillShading,
}

/// Passes that draw over the screen without the scene's geometry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, EnumIter, IntoStaticStr)]
#[strum(serialize_all = "snake_case")]
pub enum ScreenPass {
    Resolve,
    /// StaticDynamic deferred: each pixel's still lights and ambient, into the still image
    /// the resolve adds the moving lights to.
    StillResolve,
    /// The forward passes' multisampled colour resolved to one sample a pixel.
    SampleResolve,
    ScissorLights,
    DebugView,
    Tonemap,
}

/// Compute passes that build the clusters and their light lists.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, EnumIter, IntoStaticStr)]
#[strum(serialize_all = "snake_case")]
pub enum ClusterPass {
    DepthRange,
    MarkActive,
    ClusterBounds,
    LightAssign,
    /// StaticDynamic: the moving lights' lists (one-level assignment over them alone).
    MovingAssign,
    /// Patch: the previous frame's lists, with the lights that moved since moved in them.
    ListPatch,
}

/// Compute passes of the post-processing chain.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, EnumIter, IntoStaticStr)]
#[strum(serialize_all = "snake_case")]
pub enum PostPass {
    Toon,
    BloomThreshold,
    BloomBlur,
    BloomComposite,
    MotionBlur,
}

/// Which pass: its family and the pass within it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PassId {
    Raster(RasterPass),
    Screen(ScreenPass),
    Clustering(ClusterPass),
    Post(PostPass),
}

/// What kind of GPU work a pass is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassKind {
    Render,
    Compute,
}

impl PassId {
    /// Name in timings, snapshots and `clusterlab wgsl --pass`.
    pub fn name(self) -> &'static str {
        match self {
            PassId::Raster(p) => p.into(),
            PassId::Screen(p) => p.into(),
            PassId::Clustering(p) => p.into(),
            PassId::Post(p) => p.into(),
        }
    }

    /// Every pass there is.
    pub fn all() -> impl Iterator<Item = PassId> {
        RasterPass::iter()
            .map(PassId::Raster)
            .chain(ScreenPass::iter().map(PassId::Screen))
            .chain(ClusterPass::iter().map(PassId::Clustering))
            .chain(PostPass::iter().map(PassId::Post))
    }

    /// The pass of this name, if there is one.
    pub fn from_name(name: &str) -> Option<PassId> {
        PassId::all().find(|p| p.name() == name)
    }

    pub fn kind(self) -> PassKind {
        match self {
            PassId::Raster(_) | PassId::Screen(_) => PassKind::Render,
            PassId::Clustering(_) | PassId::Post(_) => PassKind::Compute,
        }
    }

    /// Shading passes: they loop over lights, and have an instrumented version that counts the
    /// light evaluations.
    pub fn is_shading(self) -> bool {
        matches!(
            self,
            PassId::Raster(RasterPass::Forward | RasterPass::Transparent)
                | PassId::Screen(ScreenPass::Resolve | ScreenPass::ScissorLights)
        )
    }

    /// Passes that only turn shaded colour into the displayed image.
    pub fn after_shading(self) -> bool {
        matches!(
            self,
            PassId::Post(_) | PassId::Screen(ScreenPass::Tonemap | ScreenPass::DebugView)
        )
    }
}

/// One pass of a frame and the root module it is composed from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pass {
    pub id: PassId,
    /// Root module under shaders/, as a module path.
    pub root: &'static str,
}

impl Pass {
    pub fn name(&self) -> &'static str {
        self.id.name()
    }

    pub fn kind(&self) -> PassKind {
        self.id.kind()
    }
}

fn raster(p: RasterPass, root: &'static str) -> Pass {
    Pass {
        id: PassId::Raster(p),
        root,
    }
}

fn screen(p: ScreenPass, root: &'static str) -> Pass {
    Pass {
        id: PassId::Screen(p),
        root,
    }
}

fn clustering(p: ClusterPass, root: &'static str) -> Pass {
    Pass {
        id: PassId::Clustering(p),
        root,
    }
}

fn post(p: PostPass, root: &'static str) -> Pass {
    Pass {
        id: PassId::Post(p),
        root,
    }
}

/// The passes of a variant's frame on a scene without blended materials, in the order they
/// run. A pass the variant does not need is not in the list.
pub fn passes(v: &Variant) -> Vec<Pass> {
    passes_for(v, false)
}

/// Whether a clustering pass of `v` fits the lists to the visible depths, so that blended
/// fragments must be measured for it (`passes/transparent_depths.wesl`).
pub fn reads_visible_depths(v: &Variant) -> bool {
    let clusters = v.clusters();
    v.pipeline.is_clustered()
        && (clusters.active_clusters || matches!(clusters.slicing, ZSlicing::DynamicRange { .. }))
}

/// Whether `v` shades its still lights into an image that its frames reuse (StaticDynamic,
/// where a frame shades each pixel once: one sample, and a pre-pass in forward).
pub fn keeps_still_image(v: &Variant) -> bool {
    v.pipeline.is_clustered()
        && v.clusters().update == ListUpdate::StaticDynamic
        && !v.msaa.on()
        && (v.pipeline.is_deferred() || v.depth_prepass)
}

/// Whether `v` shades into a multisampled colour target that a later pass resolves to one
/// sample a pixel (`sample_resolve`): every multisampled pipeline but clustered deferred,
/// whose resolve resolves the samples as it shades them.
pub fn shades_samples_apart(v: &Variant) -> bool {
    v.msaa.on() && v.pipeline != Pipeline::ClusteredDeferred
}

/// The flags pass `id` sets over its variant's: StaticDynamic's moving lists take every
/// light they are given (`still_lists` leaves the moving ones out of the still lists), and
/// the still image's passes write it (`still_pass`) rather than read it.
pub fn pass_flags(id: PassId) -> &'static [(&'static str, bool)] {
    match id {
        PassId::Clustering(ClusterPass::MovingAssign) => &[("still_lists", false)],
        PassId::Raster(RasterPass::StillShading) | PassId::Screen(ScreenPass::StillResolve) => {
            &[("still_pass", true)]
        }
        // Panes are shaded over the opaque frame, their fragments several a pixel: with RIS
        // as it is, but no pixel reservoir to keep (the opaque surface's is).
        PassId::Raster(RasterPass::Transparent) => {
            &[("temporal_reuse", false), ("transparent_pass", true)]
        }
        _ => &[],
    }
}

/// The passes of a variant's frame, in the order they run, on a scene with blended materials
/// (`blend`) or without.
pub fn passes_for(v: &Variant, blend: bool) -> Vec<Pass> {
    let mut out = Vec::new();
    let clusters = v.clusters();
    let clustered = v.pipeline.is_clustered();
    let range_from = |source| clustered && clusters.slicing == (ZSlicing::DynamicRange { source });

    if v.depth_prepass {
        out.push(raster(RasterPass::DepthPrepass, "passes::depth_prepass"));
    }
    if v.pipeline.is_deferred() {
        out.push(raster(RasterPass::GBuffer, "passes::gbuffer"));
    }
    if blend && reads_visible_depths(v) {
        out.push(raster(
            RasterPass::TransparentDepths,
            "passes::transparent_depths",
        ));
    }
    if clustered {
        if range_from(DepthRangeSource::CurrentFrame) {
            out.push(clustering(ClusterPass::DepthRange, "passes::depth_range"));
        }
        // Marking reads the slices, not the boxes; with sample bounds the boxes need it.
        if clusters.active_clusters {
            out.push(clustering(ClusterPass::MarkActive, "passes::mark_active"));
        }
        // Each method's own root; bins and tile masks need no cluster boxes.
        let assign = clusters.method().shader_root();
        if !clusters.method().builds_lists() {
            out.push(clustering(ClusterPass::LightAssign, assign));
        } else {
            out.push(clustering(
                ClusterPass::ClusterBounds,
                "passes::cluster_bounds",
            ));
            if clusters.assignment == Assignment::Gpu {
                out.push(clustering(ClusterPass::LightAssign, assign));
            }
        }
        match clusters.update {
            ListUpdate::StaticDynamic => out.push(clustering(
                ClusterPass::MovingAssign,
                "passes::assign_moving",
            )),
            ListUpdate::Patch => {
                out.push(clustering(ClusterPass::ListPatch, "passes::patch_lists"))
            }
            ListUpdate::Rebuild | ListUpdate::Refit => {}
        }
    }
    if keeps_still_image(v) {
        out.push(if v.pipeline.is_deferred() {
            screen(ScreenPass::StillResolve, "passes::resolve")
        } else {
            raster(RasterPass::StillShading, "passes::forward")
        });
    }
    out.push(match v.pipeline {
        Pipeline::NaiveForward | Pipeline::ClusteredForward => {
            raster(RasterPass::Forward, "passes::forward")
        }
        Pipeline::ClusteredDeferred => screen(ScreenPass::Resolve, "passes::resolve"),
        Pipeline::DeferredScissor => screen(ScreenPass::ScissorLights, "passes::scissor_lights"),
    });
    if shades_samples_apart(v) {
        out.push(screen(ScreenPass::SampleResolve, "passes::sample_resolve"));
    }
    // Blended surfaces over the opaque frame, shaded forward in every pipeline (deferred's
    // hybrid: the G-buffer holds one surface a pixel).
    if blend {
        out.push(raster(RasterPass::Transparent, "passes::forward"));
    }
    if range_from(DepthRangeSource::PreviousFrame) {
        // Reduced after shading, for the next frame.
        out.push(clustering(ClusterPass::DepthRange, "passes::depth_range"));
    }
    for effect in v.post.effects() {
        out.extend(post_passes(v, effect));
    }
    out.push(if v.debug_view == DebugView::Off {
        screen(ScreenPass::Tonemap, "passes::tonemap")
    } else {
        screen(ScreenPass::DebugView, "passes::debug_view")
    });
    out
}

/// The passes of one post effect the variant has.
fn post_passes(v: &Variant, effect: PostEffect) -> Vec<Pass> {
    match effect {
        PostEffect::Toon => match &v.post.toon {
            // Per-light bands are made in the shading pass; the compute pass only for the
            // post-process bands or outlines.
            Some(t) if t.mode == ToonMode::PostProcess || t.outlines.is_some() => {
                vec![post(PostPass::Toon, "passes::toon")]
            }
            _ => vec![],
        },
        PostEffect::Bloom => match &v.post.bloom {
            Some(b) => vec![
                post(PostPass::BloomThreshold, "passes::bloom_threshold"),
                post(
                    PostPass::BloomBlur,
                    match b.kernel {
                        BloomKernel::Naive => "passes::bloom_naive",
                        BloomKernel::Separable => "passes::bloom_separable",
                    },
                ),
                post(PostPass::BloomComposite, "passes::bloom_composite"),
            ],
            None => vec![],
        },
        PostEffect::MotionBlur => match &v.post.motion_blur {
            Some(_) => vec![post(PostPass::MotionBlur, "passes::motion_blur")],
            None => vec![],
        },
    }
}

/// What a renderer of a variant on a scene builds and runs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FramePlan {
    /// The passes every frame runs (but those a frame may skip; see `render`).
    pub passes: Vec<Pass>,
    /// Passes of the variant that no frame of this scene needs: not built, reported as
    /// skipped.
    pub never: Vec<PassId>,
    /// Passes built only for the counters of instrumented frames.
    pub support: Vec<Pass>,
}

/// The passes of `v` on a scene whose camera is still (`still_camera`) or moves, with
/// blended materials (`blend`) or without.
pub fn plan(v: &Variant, still_camera: bool, blend: bool) -> FramePlan {
    let mut passes = passes_for(v, blend);
    let mut never = Vec::new();
    // Motion blur has nothing to do when the camera does not move.
    if v.skip_unneeded && still_camera {
        let blur = PassId::Post(PostPass::MotionBlur);
        if passes.iter().any(|p| p.id == blur) {
            never.push(blur);
        }
        passes.retain(|p| p.id != blur);
    }
    // The count of clusters holding a visible sample needs the marking pass.
    let mark = PassId::Clustering(ClusterPass::MarkActive);
    let support = if v.pipeline.is_clustered() && !passes.iter().any(|p| p.id == mark) {
        vec![clustering(ClusterPass::MarkActive, "passes::mark_active")]
    } else {
        vec![]
    };
    FramePlan {
        passes,
        never,
        support,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_pass_has_a_distinct_name_and_is_found_by_it() {
        let names: Vec<&str> = PassId::all().map(PassId::name).collect();
        let mut unique = names.clone();
        unique.sort();
        unique.dedup();
        assert_eq!(unique.len(), names.len(), "{names:?}");
        for id in PassId::all() {
            assert_eq!(PassId::from_name(id.name()), Some(id));
        }
        assert_eq!(PassId::Raster(RasterPass::GBuffer).name(), "gbuffer");
        assert_eq!(PassId::Post(PostPass::BloomBlur).name(), "bloom_blur");
    }
}
