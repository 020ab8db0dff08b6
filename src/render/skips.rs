//! What a frame may leave out: passes its scene and variant do not need
//! (`Variant::skip_unneeded`), and what an instrumented frame counts on from the frame before.

use super::Renderer;
use crate::compose::{self, PassId};
use crate::scene::Scene;
use crate::variant::{Variant, ZSlicing};

/// What this renderer's frames may leave out (all false when the variant skips nothing).
#[derive(Clone, Debug, Default)]
pub(super) struct Skips {
    /// The scene has no lights: no clustering at all.
    pub(super) no_lights: bool,
    /// Neither lights nor camera move: after two frames (the second settles a depth range
    /// taken from the previous frame) the lists, boxes and range stay valid (never where
    /// each frame draws the lights' ranges again).
    pub(super) static_scene: bool,
    /// No light is a spot: the light loops are composed without the cone (reported as the
    /// skipped part `spot_cone`).
    pub(super) no_spots: bool,
    /// Skipping is on at all.
    pub(super) on: bool,
}

impl Skips {
    pub(super) fn new(variant: &Variant, scene: &Scene) -> Self {
        let on = variant.skip_unneeded;
        Self {
            no_lights: on && scene.lights.is_empty(),
            static_scene: on
                && scene.camera == scene.prev_camera
                && !scene.lights_move()
                && !variant.shading.lights.redraws_ranges(),
            no_spots: on && !scene.lights.iter().any(|l| l.is_spot()),
            on,
        }
    }
}

impl Renderer<'_> {
    /// Whether this frame can leave out pass `id`.
    pub(super) fn skips_pass(&self, id: PassId, instrumented: bool) -> bool {
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
        if !instrumented && self.reuses(id) {
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
        let clusters = self.variant.clusters();
        let static_bounds =
            !matches!(clusters.slicing, ZSlicing::DynamicRange { .. }) && !clusters.sample_bounds;
        id == PassId::Clustering(compose::ClusterPass::ClusterBounds)
            && self.bounds_built
            && static_bounds
    }
}
