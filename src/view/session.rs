//! What the viewer shows, without a window: the setup the panel edits, the renderer the
//! matrix times drawing it, and the last good frame. A change of variant, scene or shaders
//! builds a new renderer; a change of time or camera moves the one there is
//! (`Renderer::advance`), as a sequence's frames do.

use std::collections::VecDeque;
use std::path::PathBuf;

use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::render::{FrameOutput, FrameStats, Renderer};
use crate::scene::{CameraPose, FRAME_DT, MAX_TIME_S, Scene, SceneParams};
use crate::variant::{self, DebugView, LoadedVariant, Shadows, Variant};

/// Frames the pass-time graph keeps.
pub const HISTORY: usize = 120;

/// What a frame is made from: what the panel, the keys and a script change.
#[derive(Clone, Debug, PartialEq)]
pub struct Setup {
    /// The variant file (re-read when it changes on disk).
    pub variant: PathBuf,
    /// The variant's debug view and samples per pixel, as the panel sets them over the
    /// file's (as `render --debug-view` does).
    pub debug_view: DebugView,
    pub samples: u32,
    /// The variant's shadows, as the panel sets them over the file's.
    pub shadows: Shadows,
    /// A built-in scene or a glTF file.
    pub scene: String,
    pub params: SceneParams,
    /// The flown camera; `None` is the scene's own at `params.time`.
    pub camera: Option<CameraPose>,
}

/// A frame on screen and what it was drawn from.
pub struct Shown {
    pub frame: FrameOutput,
    pub stats: Option<FrameStats>,
    pub variant: LoadedVariant,
    pub scene: Scene,
    pub setup: Setup,
}

/// The renderer and what it was built for.
struct Built<'g> {
    renderer: Renderer<'g>,
    /// The variant, scene name and parameters but time, and the shader generation.
    key: (Variant, String, SceneParams, u64),
}

/// The viewer's frames.
pub struct Session<'g> {
    gpu: &'g Gpu,
    composer: Composer,
    /// Bumped on every shader change: a renderer of an older generation is rebuilt.
    shader_generation: u64,
    pub setup: Setup,
    built: Option<Built<'g>>,
    /// The last good frame: it stays on screen while a change fails.
    pub shown: Option<Shown>,
    /// Why the last change could not be drawn (a located shader or variant message).
    pub error: Option<String>,
    /// Count the frame's light evaluations (an instrumented frame after each one).
    pub counters: bool,
    /// Pass times of the last frames, oldest first.
    pub history: VecDeque<crate::gpu::Timings>,
    /// Frames drawn since the start.
    pub frames: u64,
    /// The next `draw` has something new to show.
    pub dirty: bool,
}

impl<'g> Session<'g> {
    pub fn new(gpu: &'g Gpu, setup: Setup) -> Session<'g> {
        Session {
            gpu,
            composer: Composer::default(),
            shader_generation: 0,
            setup,
            built: None,
            shown: None,
            error: None,
            counters: true,
            history: VecDeque::new(),
            frames: 0,
            dirty: true,
        }
    }

    pub fn composer(&self) -> &Composer {
        &self.composer
    }

    /// The setup of variant file `path` as it is on disk, its own debug view and samples.
    pub fn setup_for_variant(&self, path: PathBuf) -> Result<Setup, String> {
        let loaded = variant::load(&path).map_err(|e| e.to_string())?;
        Ok(Setup {
            variant: path,
            debug_view: loaded.variant.debug_view,
            samples: loaded.variant.msaa.samples,
            shadows: loaded.variant.shading.shadows,
            ..self.setup.clone()
        })
    }

    /// Shaders changed on disk: compose again (a new composer forgets what it composed).
    pub fn shaders_changed(&mut self) {
        self.composer = Composer::default();
        self.shader_generation += 1;
        self.dirty = true;
    }

    /// Change what is drawn; the next `draw` draws it.
    pub fn change(&mut self, setup: Setup) {
        if setup != self.setup {
            self.setup = setup;
            self.dirty = true;
        }
    }

    /// Move the scene's time by `steps` frames (`FRAME_DT` each), within 0..=MAX_TIME_S.
    pub fn step_time(&mut self, steps: i32) {
        let mut setup = self.setup.clone();
        setup.params.time = (setup.params.time + steps as f64 * FRAME_DT).clamp(0.0, MAX_TIME_S);
        self.change(setup);
    }

    /// The variant the setup says: the file, with the panel's debug view, samples and
    /// shadows.
    pub fn variant(&self) -> Result<LoadedVariant, String> {
        let mut loaded = variant::load(&self.setup.variant).map_err(|e| e.to_string())?;
        let v = &mut loaded.variant;
        (v.debug_view, v.msaa.samples) = (self.setup.debug_view, self.setup.samples);
        v.shading.shadows = self.setup.shadows;
        if let Some(p) = variant::check(v).first() {
            return Err(format!(
                "{}: with the panel's debug view {}, {} samples and {}: field `{}` {}",
                self.setup.variant.display(),
                self.setup.debug_view.name(),
                self.setup.samples,
                self.setup.shadows.label(),
                p.field,
                p.message
            ));
        }
        if self.setup.debug_view != DebugView::Off {
            loaded.name = format!("{}+{}", loaded.name, self.setup.debug_view.name());
        }
        Ok(loaded)
    }

    /// The scene the setup says, with the flown camera placed.
    pub fn scene(&self) -> Result<Scene, String> {
        let s = &self.setup;
        self.gpu
            .check_size(s.params.width, s.params.height)
            .map_err(|e| e.to_string())?;
        let mut scene = crate::scene::generate(&s.scene, s.params).map_err(|e| e.to_string())?;
        if let Some(pose) = s.camera {
            scene
                .place_camera(pose)
                .map_err(|e| format!("camera {}: {e}", pose.argument()))?;
        }
        Ok(scene)
    }

    /// Draw the setup if it changed: the new frame replaces the shown one, or the error
    /// says why it could not be drawn and the last good frame stays.
    pub fn draw(&mut self) {
        if !self.dirty {
            return;
        }
        self.dirty = false;
        match self.try_draw() {
            Ok(shown) => {
                self.history.push_back(shown.frame.timings.clone());
                while self.history.len() > HISTORY {
                    self.history.pop_front();
                }
                self.frames += 1;
                self.shown = Some(shown);
                self.error = None;
            }
            Err(e) => self.error = Some(e),
        }
    }

    fn try_draw(&mut self) -> Result<Shown, String> {
        let variant = self.variant()?;
        let scene = self.scene()?;
        let key = (
            variant.variant.clone(),
            self.setup.scene.clone(),
            SceneParams {
                time: 0.0,
                ..self.setup.params
            },
            self.shader_generation,
        );
        let gpu = self.gpu;
        let failed = |e: crate::render::RenderError| {
            format!("variant `{}` on scene `{}`: {e}", variant.name, scene.name)
        };
        // The renderer there is follows the new frame if it was built for the same
        // variant, scene and shaders and can follow it; otherwise one is built.
        let followed = match &mut self.built {
            Some(b) if b.key == key => b.renderer.advance(&scene).is_ok(),
            _ => false,
        };
        if !followed {
            self.built = None;
            gpu.begin_cell();
            let renderer =
                Renderer::new(gpu, &self.composer, &variant.variant, &scene).map_err(failed)?;
            self.built = Some(Built { renderer, key });
        }
        let renderer = &mut self.built.as_mut().expect("built above").renderer;
        gpu.begin_cell();
        let frame = renderer.render().map_err(failed)?;
        let stats = if self.counters && variant.variant.debug_view == DebugView::Off {
            renderer.prepare_counting(&self.composer, &scene);
            Some(renderer.stats().map_err(failed)?)
        } else {
            None
        };
        Ok(Shown {
            frame,
            stats,
            variant,
            scene,
            setup: self.setup.clone(),
        })
    }
}
