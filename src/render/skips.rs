//! What a frame may leave out: passes its scene and variant do not need
//! (`Variant::skip_unneeded`), and what an instrumented frame counts on from the frame before.

use crate::scene::Scene;
use crate::variant::Variant;

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
