//! Which passes a variant runs, in order, and the root module of each.

use crate::variant::*;

/// What kind of GPU work a pass is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassKind {
    Render,
    Compute,
}

/// One pass of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pass {
    /// Name in timings, snapshots and `clusterlab wgsl --pass`.
    pub name: &'static str,
    /// Root module under shaders/, as a module path.
    pub root: &'static str,
    pub kind: PassKind,
}

const fn render(name: &'static str, root: &'static str) -> Pass {
    Pass {
        name,
        root,
        kind: PassKind::Render,
    }
}

const fn compute(name: &'static str, root: &'static str) -> Pass {
    Pass {
        name,
        root,
        kind: PassKind::Compute,
    }
}

/// The passes of a variant's frame, in the order they run. A pass the variant does not need
/// is not in the list.
pub fn passes(v: &Variant) -> Vec<Pass> {
    let mut out = Vec::new();
    let clusters = v.clusters();
    let clustered = v.pipeline.is_clustered();
    let current_frame_range = clustered
        && clusters.slicing
            == (ZSlicing::DynamicRange {
                source: DepthRangeSource::CurrentFrame,
            });
    let previous_frame_range = clustered
        && clusters.slicing
            == (ZSlicing::DynamicRange {
                source: DepthRangeSource::PreviousFrame,
            });

    if v.depth_prepass {
        out.push(render("depth_prepass", "passes::depth_prepass"));
    }
    if v.pipeline.is_deferred() {
        out.push(render("gbuffer", "passes::gbuffer"));
    }
    if clustered {
        if current_frame_range {
            out.push(compute("depth_range", "passes::depth_range"));
        }
        // Marking reads the slices, not the boxes; with sample bounds the boxes need it.
        if clusters.active_clusters {
            out.push(compute("mark_active", "passes::mark_active"));
        }
        out.push(compute("cluster_bounds", "passes::cluster_bounds"));
        if clusters.assignment == Assignment::Gpu {
            out.push(compute("light_assign", "passes::light_assign"));
        }
    }
    match v.pipeline {
        Pipeline::NaiveForward | Pipeline::ClusteredForward => {
            out.push(render("forward", "passes::forward"))
        }
        Pipeline::ClusteredDeferred => out.push(render("resolve", "passes::resolve")),
        Pipeline::DeferredScissor => out.push(render("scissor_lights", "passes::scissor_lights")),
    }
    if previous_frame_range {
        // Reduced after shading, for the next frame.
        out.push(compute("depth_range", "passes::depth_range"));
    }
    if let Some(toon) = &v.post.toon
        && (toon.mode == ToonMode::PostProcess || toon.outlines.is_some())
    {
        out.push(compute("toon", "passes::toon"));
    }
    if let Some(bloom) = &v.post.bloom {
        out.push(compute("bloom_threshold", "passes::bloom_threshold"));
        match bloom.kernel {
            BloomKernel::Naive => out.push(compute("bloom_blur", "passes::bloom_naive")),
            BloomKernel::Separable => {
                out.push(compute("bloom_blur", "passes::bloom_separable"));
            }
        }
        out.push(compute("bloom_composite", "passes::bloom_composite"));
    }
    if v.post.motion_blur.is_some() {
        out.push(compute("motion_blur", "passes::motion_blur"));
    }
    if v.debug_view == DebugView::Off {
        out.push(render("tonemap", "passes::tonemap"));
    } else {
        out.push(render("debug_view", "passes::debug_view"));
    }
    out
}
