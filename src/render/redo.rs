//! What a frame redoes of the one before it, and what the GPU holds of that frame
//! (`Renderer::advance` in `reuse` decides the one from the other).

use std::cell::Cell;

use crate::compose::{ClusterPass, PassId, RasterPass, ScreenPass};
use crate::scene::{Camera, Light, Scene, Vertex};

/// What a frame redoes of the one before it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Redo {
    /// The depth pre-pass, G-buffer, blended depths, depth range, marking and boxes.
    pub surfaces: bool,
    pub lists: Lists,
    /// StaticDynamic: the still lights' lists and the still image.
    pub still: bool,
    /// Any pass at all: false when the frame is the previous one.
    pub frame: bool,
}

/// What a frame does to its light lists.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Lists {
    /// Keeps them: nothing they depend on changed.
    Keep,
    /// Builds every list (StaticDynamic: both sets).
    Build,
    /// StaticDynamic: only the moving lights' lists.
    Moving,
    /// Patch: moves the moved lights in them.
    Patch,
    /// Refit: refits the light BVH over its last order and walks it again.
    Refit,
    /// Builds them and runs every other list pass too, over nothing (`draw_without_lights`,
    /// which compiles every pass a sequence may run).
    Every,
}

impl Redo {
    /// Everything: a first frame, or a frame rendered again unchanged (its lists built as
    /// every frame of a matrix cell builds them).
    pub(super) const ALL: Redo = Redo {
        surfaces: true,
        lists: Lists::Build,
        still: true,
        frame: true,
    };

    /// Every pass a frame may run (a patch too, of no light).
    pub(super) const EVERY: Redo = Redo {
        lists: Lists::Every,
        ..Redo::ALL
    };
}

impl Redo {
    /// Whether this plan of what to redo leaves pass `id` out (never asked for an
    /// instrumented frame, whose own rules are `FrameState::skips_pass`'s).
    pub(super) fn leaves_out(self, id: PassId) -> bool {
        let r = self;
        if !r.frame {
            return true;
        }
        match id {
            PassId::Raster(
                RasterPass::DepthPrepass | RasterPass::GBuffer | RasterPass::TransparentDepths,
            )
            | PassId::Clustering(
                ClusterPass::DepthRange | ClusterPass::MarkActive | ClusterPass::ClusterBounds,
            ) => !r.surfaces,
            PassId::Clustering(ClusterPass::LightAssign) => {
                !matches!(r.lists, Lists::Build | Lists::Refit | Lists::Every)
            }
            PassId::Clustering(ClusterPass::MovingAssign) => {
                !matches!(r.lists, Lists::Build | Lists::Moving | Lists::Every)
            }
            PassId::Clustering(ClusterPass::ListPatch) => {
                !matches!(r.lists, Lists::Patch | Lists::Every)
            }
            PassId::Raster(RasterPass::StillShading) | PassId::Screen(ScreenPass::StillResolve) => {
                !r.still
            }
            _ => false,
        }
    }
}

/// What the GPU holds of the last frame: what `advance` compares the next one with.
pub(super) struct Held {
    pub(super) lights: Vec<Light>,
    pub(super) camera: Camera,
    pub(super) prev_camera: Camera,
    pub(super) vertices: Vec<Vertex>,
    pub(super) indices: Vec<u32>,
    pub(super) blended: Vec<u32>,
    /// The frame's time, seconds (sampled loops seed their random numbers with it).
    pub(super) time: f64,
    /// Frames in a row whose view was the one before theirs.
    pub(super) still_frames: u32,
    /// The images or marks are not the last frame's: an instrumented frame shaded over
    /// the images and re-marked the clusters, or a debug view was drawn into the output.
    pub(super) disturbed: Cell<bool>,
}

impl Held {
    pub(super) fn of(scene: &Scene) -> Self {
        Self {
            lights: scene.lights.clone(),
            camera: scene.camera,
            prev_camera: scene.prev_camera,
            vertices: scene.vertices.clone(),
            indices: scene.indices.clone(),
            blended: scene.blended.clone(),
            time: scene.params.time,
            still_frames: 0,
            disturbed: Cell::new(false),
        }
    }

    /// Why `scene` cannot follow the held frame, if it cannot: a sequence's frames share
    /// their size, geometry and number of lights.
    pub(super) fn mismatch(&self, scene: &Scene, size: (u32, u32)) -> Option<String> {
        let p = &scene.params;
        if (p.width, p.height) != size {
            return Some(format!(
                "its size is {}x{}, the sequence's {}x{}",
                p.width, p.height, size.0, size.1
            ));
        }
        if scene.lights.len() != self.lights.len() {
            return Some(format!(
                "it has {} lights, the sequence {}",
                scene.lights.len(),
                self.lights.len()
            ));
        }
        let same = bytemuck::cast_slice::<Vertex, u8>(&scene.vertices)
            == bytemuck::cast_slice::<Vertex, u8>(&self.vertices)
            && scene.indices == self.indices
            && scene.blended == self.blended;
        (!same).then(|| "its geometry differs (the geometry of a sequence never moves)".into())
    }
}
