//! `view --script FILE`: timed inputs played into the viewer, frame by frame, so a test (or
//! a README picture) needs no person. A script is a RON list of steps; the viewer runs
//! them in order, each on the frame the one before it left off, and exits when the last is
//! done (with a failure if a step could not be done).
//!
//! ```ron
//! [
//!     Wait(frames: 2),
//!     Key(key: "W", frames: 10),      // held for 10 frames: the camera flies forward
//!     Drag(dx: 40, dy: -10),          // the mouse dragged over the image: the camera turns
//!     Wheel(steps: 2),                // faster
//!     Set(Lights(64)),                // a panel change
//!     Edit(file: "shaders/x.wesl", find: "a", replace: "b"),  // waits until drawn (or failed)
//!     Screenshot,                     // what `render` writes, into --out
//!     State("state.json"),            // what the viewer shows, as JSON, into --out
//!     WindowShot("viewer.png"),       // the window as it is on screen, into --out
//! ]
//! ```

use std::path::{Path, PathBuf};

use serde::Deserialize;

/// Frames a step that waits for something (a reload, a job) waits at most, at least this
/// many seconds (a composition and a reference take seconds on a software adapter).
pub const WAIT_LIMIT_S: f64 = 120.0;

/// One timed input.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum Step {
    /// Draw this many frames doing nothing else.
    Wait { frames: u32 },
    /// Hold a key for this many frames: W, A, S, D, Q, E fly (one frame step of flight a
    /// frame); Space plays or pauses, Period steps time, Home returns to the scene's
    /// camera, P takes a screenshot, R starts or stops a recording.
    Key { key: String, frames: u32 },
    /// Drag the mouse over the image by this many pixels: the camera turns.
    Drag { dx: f32, dy: f32 },
    /// Turn the mouse wheel over the image: each step flies 25% faster (negative: slower).
    Wheel { steps: i32 },
    /// Change something on the panel.
    Set(Change),
    /// Replace the first `find` in `file` with `replace` (as an editor saving the file
    /// would), and wait until the watcher has seen it and the viewer has composed and drawn
    /// the result, or shown why it cannot.
    Edit {
        file: PathBuf,
        find: String,
        replace: String,
    },
    /// Write the shown frame as `render` would, into the output folder, and wait for it.
    Screenshot,
    /// Measure the shown frame's error against the reference, and wait for it.
    MeasureError,
    /// Record the next `frames` frames as an animated image in the output folder.
    Record { frames: u32 },
    /// Write what follows (screenshots, recordings, states, window shots) into this folder
    /// under the output folder.
    Out(PathBuf),
    /// Write what the viewer shows (frame hash, error message, setup) as JSON.
    State(PathBuf),
    /// Write the window as it is on screen as a PNG.
    WindowShot(PathBuf),
}

/// A panel change.
#[derive(Clone, Debug, Deserialize, PartialEq)]
pub enum Change {
    /// A variant file, or the name of one in `variants/`.
    Variant(String),
    /// A built-in scene or a glTF file.
    Scene(String),
    Lights(u32),
    /// Light radius range, world units.
    Radius(f32, f32),
    Spots(f32),
    Seed(u64),
    /// Seconds into the scene's animation.
    Time(f64),
    Play(bool),
    /// A debug view by name (`render --debug-view`'s), or "off".
    DebugView(String),
    Samples(u32),
    /// `EX,EY,EZ,TX,TY,TZ`, or "scene" for the scene's own camera.
    Camera(String),
    Counters(bool),
}

/// Read and parse a script; errors name the file, line and column.
pub fn load(path: &Path) -> Result<Vec<Step>, String> {
    let text = crate::files::read_text(path, crate::files::read::VARIANT)
        .map_err(|e| format!("{}: {}", path.display(), e.why))?;
    ron::from_str(&text).map_err(|e| {
        let at = e.span.start;
        format!(
            "{}:{}:{}: {}\n{}\na script is a list of steps: Wait(frames: N), Key(key: \"W\", frames: N), Drag(dx: X, dy: Y), Wheel(steps: N), Set(..), Edit(file: F, find: A, replace: B), Screenshot, MeasureError, Record(frames: N), Out(\"folder\"), State(\"F.json\"), WindowShot(\"F.png\")",
            path.display(),
            at.line,
            at.col,
            e.code,
            crate::variant::caret_snippet(&text, at.line, at.col)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_script_reads_as_its_steps_and_a_bad_one_says_where() {
        let steps: Vec<Step> =
            ron::from_str(r#"[Wait(frames: 2), Set(Lights(64)), Edit(file: "a.wesl", find: "x", replace: "y"), Screenshot]"#)
                .unwrap();
        assert_eq!(steps[1], Step::Set(Change::Lights(64)));
        assert_eq!(steps.len(), 4);
        let dir = std::env::temp_dir().join(format!("clusterlab-script-{}", std::process::id()));
        crate::files::write::create_folder(&dir).unwrap();
        let file = dir.join("bad.ron");
        crate::files::write_file(&file, b"[\n  Wait(frames: 2),\n  Jump(3),\n]").unwrap();
        let e = load(&file).unwrap_err();
        assert!(e.contains("bad.ron:3:3") && e.contains("Jump"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
