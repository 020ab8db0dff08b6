//! Frames that follow each other (`Renderer::advance`): what changed since the frame the
//! GPU holds (the camera, which lights), uploaded; and what the next frame redoes, from
//! `Variant::reuse_unchanged` and `clusters.update`.

use serde::Serialize;

use super::error::RenderError;
use super::redo::{Lists, Redo};
use super::{Renderer, ViewUniform};
use crate::scene::{Light, Scene};
use crate::variant::ListUpdate;

/// What changed between two frames of a sequence.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct FrameChange {
    /// The camera (or the one a frame before it, which motion blur reads) moved.
    pub camera_moved: bool,
    /// The lights whose position, radius, colour or cone changed, ascending.
    pub moved_lights: Vec<u32>,
}

impl Renderer<'_> {
    /// Make the next frame `scene`: the same geometry, size and number of lights as the
    /// frame before, at a later time. Uploads the lights that changed and the camera if it
    /// moved, and decides what the next `render` redoes (with `reuse_unchanged`, only what
    /// the change reaches; `clusters.update` says how the lists follow the lights).
    pub fn advance(&mut self, scene: &Scene) -> Result<FrameChange, RenderError> {
        if let Some(why) = self
            .state
            .held
            .mismatch(scene, (self.state.width, self.state.height))
        {
            return Err(RenderError::Scene(format!(
                "scene `{}` at time {} s cannot follow the sequence's last frame: {why}",
                scene.name, scene.params.time
            )));
        }
        scene
            .check()
            .map_err(|e| RenderError::Scene(e.to_string()))?;
        let moved: Vec<u32> = (0..scene.lights.len())
            .filter(|&i| {
                bytemuck::bytes_of(&scene.lights[i])
                    != bytemuck::bytes_of(&self.state.held.lights[i])
            })
            .map(|i| i as u32)
            .collect();
        let camera_moved = scene.camera != self.state.held.camera
            || scene.prev_camera != self.state.held.prev_camera;
        // What the renderer was made for must hold: the passes its plan runs and the
        // shaders' features (a still first camera leaves motion blur out; spots, the cone).
        let plan = crate::compose::plan(
            &self.variant,
            scene.camera == scene.prev_camera,
            scene.has_blend(),
        );
        if !self.frame.runs(&plan)
            || (self.state.skips.no_spots && scene.lights.iter().any(|l| l.is_spot()))
        {
            return Err(RenderError::Scene(format!(
                "scene `{}` at time {} s cannot follow the sequence's last frame: it needs passes or shader features the first frame did not (a camera that starts to move under motion blur, or a light that becomes a spot)",
                scene.name, scene.params.time
            )));
        }
        self.upload_lights(scene, &moved);
        let (near, far) = (scene.camera.near, scene.camera.far);
        if camera_moved && (near, far) != (self.state.held.camera.near, self.state.held.camera.far)
        {
            // The static slicing runs from near to far: the boxes are built again.
            if let Some(c) = &self.res.clusters {
                let range = super::ClusterRange::new(near as f32, far as f32);
                self.gpu
                    .queue
                    .write_buffer(&c.range, 0, bytemuck::bytes_of(&range));
            }
            self.state.bounds_built = false;
        }
        if camera_moved || !moved.is_empty() {
            // Lists built on the CPU start from the lights in view space; naive forward's
            // counting stand-in is remade for the frame it counts.
            if self.cpu_assignment.is_some() {
                self.cpu_assignment = Some(super::lists::CpuAssignment::new(&self.variant, scene));
            }
            self.naive_stand_in = None;
        }
        if camera_moved {
            let view = ViewUniform::new(scene, self.variant.depth.mapping());
            self.gpu
                .queue
                .write_buffer(&self.res.scene.view, 0, bytemuck::bytes_of(&view));
            if let Some((buffer, _)) = &self.res.scene.blended {
                let order = scene.blend_order();
                self.gpu
                    .queue
                    .write_buffer(buffer, 0, bytemuck::cast_slice(&order));
            }
        }
        let h = &mut self.state.held;
        h.time = scene.params.time;
        if let Some(s) = &mut self.res.sampling {
            // The next frame follows this renderer's last one: its reservoirs are history.
            s.set_frame(self.gpu, scene.params.time, self.state.frames_done > 0);
        }
        h.lights.clone_from(&scene.lights);
        (h.camera, h.prev_camera) = (scene.camera, scene.prev_camera);
        h.still_frames = if camera_moved { 0 } else { h.still_frames + 1 };
        // A sequence decides what each frame redoes; a still scene's rule is for frames
        // rendered again unchanged.
        self.state.skips.static_scene = false;
        self.state.redo = self.plan_redo(camera_moved, &moved);
        Ok(FrameChange {
            camera_moved,
            moved_lights: moved,
        })
    }

    /// Write the lights that moved into the light buffer: runs of neighbours in one write.
    fn upload_lights(&self, scene: &Scene, moved: &[u32]) {
        let bytes = std::mem::size_of::<Light>() as u64;
        let mut i = 0;
        while i < moved.len() {
            let mut j = i + 1;
            while j < moved.len() && moved[j] == moved[j - 1] + 1 {
                j += 1;
            }
            let (first, last) = (moved[i] as usize, moved[j - 1] as usize);
            self.gpu.queue.write_buffer(
                &self.res.scene.lights,
                first as u64 * bytes,
                bytemuck::cast_slice(&scene.lights[first..=last]),
            );
            i = j;
        }
    }

    /// What the next frame redoes after a change of the camera (`camera_moved`) and of the
    /// lights `moved`; sets the moving set the list passes read.
    fn plan_redo(&mut self, camera_moved: bool, moved: &[u32]) -> Redo {
        let disturbed = self.state.held.disturbed.replace(false);
        if self.state.frames_done == 0 {
            if let Some(ListUpdate::StaticDynamic) = self.update() {
                self.join_moving(moved);
            }
            return Redo::ALL;
        }
        // The boxes and view-space lights hold while the view does; with a depth range from
        // the previous frame, the range settles a frame after the view stops.
        let frames_needed = 1 + u32::from(self.variant.range_from_previous_frame());
        let view_holds = !camera_moved && self.state.held.still_frames >= frames_needed;
        let reuse = self.variant.reuse_unchanged;
        // Stochastic culling draws every light's range again each frame.
        let redrawn = self.variant.shading.lights.redraws_ranges();
        let lists = match self.update() {
            None => Lists::Keep,
            Some(_) if redrawn => Lists::Build,
            Some(_) if view_holds && moved.is_empty() => Lists::Keep,
            Some(ListUpdate::Refit) => Lists::Refit,
            Some(_) if !view_holds => Lists::Build,
            Some(ListUpdate::Rebuild) => Lists::Build,
            Some(ListUpdate::Patch) => Lists::Patch,
            Some(ListUpdate::StaticDynamic) => {
                let held = &self.res.moving_set.lights;
                if moved.iter().all(|i| held.binary_search(i).is_ok()) {
                    Lists::Moving
                } else {
                    Lists::Build
                }
            }
        };
        match self.update() {
            // A still light that moved joins the moving lights; both lists are rebuilt.
            Some(ListUpdate::StaticDynamic) if lists == Lists::Build => self.join_moving(moved),
            Some(ListUpdate::Patch) if lists == Lists::Patch => {
                self.res.moving_set.set(self.gpu, moved);
            }
            _ => {}
        }
        // A sampled frame draws new random numbers: it is never the last one again.
        let sampled = self.variant.shading.lights.sampling().is_some()
            || self.variant.shading.shadows.sampling().is_some();
        let unchanged = reuse && view_holds && moved.is_empty() && !disturbed && !sampled;
        Redo {
            surfaces: !(reuse && view_holds) || disturbed,
            lists,
            still: self.update() == Some(ListUpdate::StaticDynamic) && lists == Lists::Build,
            frame: !unchanged,
        }
    }

    /// StaticDynamic: lights `moved` join the moving set (its lists are built next).
    fn join_moving(&mut self, moved: &[u32]) {
        let mut set = self.res.moving_set.lights.clone();
        set.extend_from_slice(moved);
        set.sort_unstable();
        set.dedup();
        self.res.moving_set.set(self.gpu, &set);
    }
}
