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

/// Why there is no window to open, if there is none: on Linux and the BSDs a window needs
/// an X11 or Wayland display.
pub fn missing_display() -> Option<String> {
    let unix_desktop = cfg!(all(
        unix,
        not(target_os = "macos"),
        not(target_os = "android")
    ));
    let display = ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .any(|v| crate::environment::var_os(v).is_some_and(|d| !d.is_empty()));
    (unix_desktop && !display).then(|| {
        "`view` opens a window and this machine has no display (neither DISPLAY nor WAYLAND_DISPLAY is set): run it under a virtual one, `xvfb-run -a clusterlab view ...` (Debian's package xvfb); every other command needs none".to_string()
    })
}

/// Open the window and run until it is closed or the script ends: `Ok(false)` when a
/// script step failed.
pub fn run(options: ViewOptions, gpu: &crate::gpu::Gpu) -> Result<bool, String> {
    if let Some(why) = missing_display() {
        return Err(why);
    }
    window::run(options, gpu)
}
