//! What a renderer carries from frame to frame: its size, what its frames have done (boxes
//! built, frames drawn, whether the last one can be counted on), what the next one redoes,
//! what the GPU holds of the last, and what a frame may leave out (`skips_pass`).

use super::redo::{Held, Redo};
use super::skips::Skips;
use crate::compose::{self, PassId};
use crate::variant::{Variant, ZSlicing};

/// The per-frame state of a renderer.
pub(super) struct FrameState {
    pub width: u32,
    pub height: u32,
    /// Cluster bounds are valid for the projection, size and a static z-range.
    pub bounds_built: bool,
    /// Frames rendered (not counting instrumented ones).
    pub frames_done: u32,
    /// A frame without lights was drawn (see `Renderer::draw_without_lights`).
    pub drew_without_lights: bool,
    /// The last frame drawn left depth, G-buffer, cluster data and light lists that agree
    /// with what shading reads, for an instrumented frame to count on (see `render`).
    pub last_frame_countable: bool,
    /// Pipelines of the timed frame that this renderer created rather than found made
    /// earlier in the run (see `Renderer::cold`).
    pub fresh_pipelines: u32,
    /// Times the light lists' buffers grew.
    pub reallocations: u32,
    /// Patch frames that ran out of room in the index buffer and were rebuilt instead.
    pub patch_rebuilds: u32,
    /// What this renderer's frames may leave out.
    pub skips: Skips,
    /// What the next frame redoes (`advance` decides it for a sequence's next frame).
    pub redo: Redo,
    /// What the GPU holds of the last frame, for `advance` to compare with.
    pub held: Held,
    /// Features set by the scene rather than the variant (spots, textures).
    pub frame_features: Vec<(&'static str, bool)>,
}

impl FrameState {
    /// Whether this frame can leave out pass `id`.
    pub(super) fn skips_pass(&self, id: PassId, instrumented: bool, variant: &Variant) -> bool {
        // An instrumented frame's counters come from assignment and shading: what only
        // turns shaded colour into pixels (post effects, tonemap, a debug view) is left out.
        // After a timed frame it counts on that frame's depth, G-buffer and marks (every
        // frame of a renderer draws the same picture), so only assignment, which counts
        // its work only when instrumented, and the shading pass run.
        let assigns = matches!(
            id,
            PassId::Clustering(
                compose::ClusterPass::LightAssign | compose::ClusterPass::MovingAssign
            )
        );
        if instrumented
            && (id.after_shading() || (self.last_frame_countable && !id.is_shading() && !assigns))
        {
            return true;
        }
        // An instrumented frame walks both of StaticDynamic's lists itself, and builds what
        // it builds from scratch (a patch needs the lists before it).
        let still_image = matches!(
            id,
            PassId::Raster(compose::RasterPass::StillShading)
                | PassId::Screen(compose::ScreenPass::StillResolve)
        );
        if instrumented
            && (still_image || id == PassId::Clustering(compose::ClusterPass::ListPatch))
        {
            return true;
        }
        if !instrumented && self.redo.leaves_out(id) {
            return true;
        }
        let s = &self.skips;
        if !s.on {
            return false;
        }
        let builds_clusters = still_image
            || matches!(
                id,
                PassId::Clustering(_) | PassId::Raster(compose::RasterPass::TransparentDepths)
            );
        // Without lights the lists stay as made, empty (wgpu zeroes new buffers). The still
        // image is not skipped: it holds ambient, which a frame without lights still shows.
        if s.no_lights && builds_clusters && !still_image {
            return true;
        }
        // From a still scene's third frame on, the lists are those built before (an
        // instrumented frame with no countable frame before it builds its own).
        if s.static_scene && !instrumented && self.frames_done >= 2 && builds_clusters {
            return true;
        }
        // Boxes depend on the projection, the size and the z-range, and with sample bounds
        // on this frame's depth.
        let clusters = variant.clusters();
        let static_bounds =
            !matches!(clusters.slicing, ZSlicing::DynamicRange { .. }) && !clusters.sample_bounds;
        id == PassId::Clustering(compose::ClusterPass::ClusterBounds)
            && self.bounds_built
            && static_bounds
    }
}
