//! `clusterlab view`: a window showing the renderer the matrix times, with a panel to change
//! what it draws, a camera to fly, hot reload of shaders and variant files, screenshots that
//! write what `render` writes, recordings, and scripts that play inputs without a person.
//!
//! The frame is drawn by the measuring device exactly as `render` draws it, read back, and
//! shown through a second device that only paints the window (egui through `egui-wgpu`):
//! what is shown is the image `render` writes, and painting the panel never shares a queue
//! with the timed passes.

pub mod fly;
pub mod jobs;
pub mod script;
pub mod session;
pub mod watch;
mod window;

pub use window::{missing_display, run};

use std::path::PathBuf;

/// What `view` was asked for.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    /// The variant file to start with.
    pub variant: PathBuf,
    /// Variant files the panel offers (those in `variants/`, and any given).
    pub variants: Vec<PathBuf>,
    pub scene: String,
    pub params: crate::scene::SceneParams,
    pub camera: Option<crate::scene::CameraPose>,
    /// Folder screenshots and recordings go to.
    pub out: PathBuf,
    /// Inputs to play, after which the viewer exits.
    pub script: Option<PathBuf>,
}
