//! Helpers every test module shares: the GPU, variants and small scenes, one cell, a
//! scratch folder, and the command-line runner.

use std::ffi::OsStr;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use clusterlab::compose::Composer;
use clusterlab::gpu::Gpu;
use clusterlab::run::{CellOptions, CellResult, run_cell};
use clusterlab::scene::{SceneParams, find_scene};
use clusterlab::variant::{self, LoadedVariant};

pub fn gpu() -> Gpu {
    Gpu::new(None).unwrap_or_else(|e| panic!("{e}"))
}

pub fn load(name: &str) -> LoadedVariant {
    variant::load(Path::new(&format!("variants/{name}.ron"))).unwrap_or_else(|e| panic!("{e}"))
}

/// A scene's defaults at a small size, with `lights` if given.
pub fn small(scene: &str, width: u32, height: u32, lights: Option<u32>) -> SceneParams {
    let mut p = find_scene(scene).expect("built-in scene").defaults;
    p.width = width;
    p.height = height;
    if let Some(n) = lights {
        p.lights = n;
    }
    p
}

pub fn cell(gpu: &Gpu, v: &LoadedVariant, scene: &str, p: SceneParams) -> CellResult {
    run_cell(
        gpu,
        &Composer::default(),
        v,
        scene,
        p,
        CellOptions {
            frames: clusterlab::measure::Frames::exact(0, 1),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{} on {scene}: {e}", v.name))
}

/// A .glb file's JSON and binary chunk.
pub fn split_glb(glb: &[u8]) -> (serde_json::Value, Vec<u8>) {
    let word = |at: usize| u32::from_le_bytes(glb[at..at + 4].try_into().unwrap()) as usize;
    let json_len = word(12);
    let json = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let bin_len = word(20 + json_len);
    (json, glb[28 + json_len..28 + json_len + bin_len].to_vec())
}

/// Copy folder `from` into `to`, recursively.
/// Every `.rs` file under `dir`, into `out` (the source scans of `layers` and `environment`).
pub fn rust_sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_sources(&path, out);
        } else if path.extension().is_some_and(|x| x == "rs") {
            out.push(path);
        }
    }
}

pub fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_tree(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

/// A fresh, empty folder under the temporary folder for the calling test file's `name`
/// (the file's name and this process's id keep test files and concurrent runs apart).
#[track_caller]
pub fn scratch(name: &str) -> PathBuf {
    let file = Path::new(std::panic::Location::caller().file());
    // A module's `mod.rs` goes by its folder's name.
    let named = if file.file_stem() == Some(OsStr::new("mod")) {
        file.parent().and_then(Path::file_name)
    } else {
        file.file_stem()
    };
    let group = named.and_then(OsStr::to_str).unwrap_or("test");
    let dir =
        std::env::temp_dir().join(format!("clusterlab-{group}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch folder");
    dir
}

/// The binary the command-line tests run: the one cargo built with them, or the one
/// `CLUSTERLAB_UNDER_TEST` names (to show which checks an older build fails).
pub fn binary() -> PathBuf {
    std::env::var_os("CLUSTERLAB_UNDER_TEST")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_clusterlab")))
}

/// Longest a run may take before it counts as a hang (a pipe read, a device read whole).
pub const HANG: Duration = Duration::from_secs(180);

/// A command line of the binary under test.
pub struct Cli(Command);

/// What a run printed and how it ended.
pub struct Ran {
    /// The exit code; `None` when a signal ended it.
    pub code: Option<i32>,
    pub stdout: String,
    pub stderr: String,
}

impl Ran {
    /// Everything it printed: standard output, then standard error.
    pub fn printed(&self) -> String {
        format!("{}{}", self.stdout, self.stderr)
    }

    /// Whether it exited with 0, and everything printed.
    pub fn succeeded(self) -> (bool, String) {
        let printed = self.printed();
        (self.code == Some(0), printed)
    }

    /// The exit code and everything printed.
    pub fn outcome(self) -> (Option<i32>, String) {
        let printed = self.printed();
        (self.code, printed)
    }
}

/// `clusterlab ARGS`, in the current folder, standard input closed, keeping no pipeline
/// cache in the user's cache folder (a test that wants one names a folder).
pub fn cli<S: AsRef<OsStr>>(args: impl IntoIterator<Item = S>) -> Cli {
    let mut command = Command::new(binary());
    command
        .args(args)
        .stdin(Stdio::null())
        .env(clusterlab::gpu::disk_cache::CACHE_VAR, "off");
    Cli(command)
}

impl Cli {
    pub fn arg(mut self, arg: impl AsRef<OsStr>) -> Cli {
        self.0.arg(arg);
        self
    }

    pub fn args<S: AsRef<OsStr>>(mut self, args: impl IntoIterator<Item = S>) -> Cli {
        self.0.args(args);
        self
    }

    /// Set `key` to `value`; an empty value removes it.
    pub fn env(mut self, key: &str, value: impl AsRef<OsStr>) -> Cli {
        if value.as_ref().is_empty() {
            self.0.env_remove(key);
        } else {
            self.0.env(key, value);
        }
        self
    }

    pub fn envs<'a>(self, env: impl IntoIterator<Item = &'a (&'a str, &'a str)>) -> Cli {
        env.into_iter().fold(self, |cli, (k, v)| cli.env(k, v))
    }

    pub fn dir(mut self, dir: impl AsRef<Path>) -> Cli {
        self.0.current_dir(dir);
        self
    }

    /// Started, not waited for (a run a test interrupts), its standard output dropped and
    /// its standard error piped for the test. SIGINT stops it whatever the test inherited:
    /// a shell starts a background job with SIGINT ignored, and its children would ignore
    /// it too.
    pub fn spawn(mut self) -> Child {
        use std::os::unix::process::CommandExt;
        // SAFETY: signal() is async-signal-safe, as pre_exec requires.
        unsafe {
            self.0.pre_exec(|| {
                libc::signal(libc::SIGINT, libc::SIG_DFL);
                Ok(())
            });
        }
        self.0
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start clusterlab")
    }

    /// Run it to the end; still running after `HANG` fails the test. Its output is read
    /// while it runs, so a long report never blocks it on a full pipe.
    pub fn run(mut self) -> Ran {
        let shown = format!("{:?}", self.0);
        let mut child = self
            .0
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start clusterlab");
        let drain = |pipe: Option<Box<dyn Read + Send>>| {
            std::thread::spawn(move || {
                let mut bytes = Vec::new();
                if let Some(mut pipe) = pipe {
                    let _ = pipe.read_to_end(&mut bytes);
                }
                String::from_utf8_lossy(&bytes).into_owned()
            })
        };
        let stdout = drain(child.stdout.take().map(|p| Box::new(p) as _));
        let stderr = drain(child.stderr.take().map(|p| Box::new(p) as _));
        let start = Instant::now();
        let status = loop {
            if let Some(status) = child.try_wait().expect("wait for clusterlab") {
                break status;
            }
            if start.elapsed() > HANG {
                let _ = child.kill();
                panic!("{shown} hung: still running after {HANG:?}");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        Ran {
            code: status.code(),
            stdout: stdout.join().expect("stdout"),
            stderr: stderr.join().expect("stderr"),
        }
    }
}

/// Why the viewer cannot open a window here, if it cannot: no display and no `xvfb-run`
/// (Debian's package xvfb). Its tests are then skipped, saying so; CI installs xvfb.
pub fn windows_unavailable() -> Option<&'static str> {
    let display = clusterlab::view::missing_display().is_none();
    let xvfb = Command::new("xvfb-run").arg("--help").output().is_ok();
    (!display && !xvfb).then_some("no display and no xvfb-run (apt-get install -y xvfb)")
}

/// `clusterlab view ARGS` on a display: the session's own, else a virtual one of its own
/// through `xvfb-run` (Debian's package xvfb, which CI installs), each on its own server
/// number so that tests running side by side do not race for one.
pub fn viewer<S: AsRef<OsStr>>(args: impl IntoIterator<Item = S>) -> Cli {
    use std::sync::atomic::{AtomicU32, Ordering};
    static NEXT_SERVER: AtomicU32 = AtomicU32::new(0);
    if clusterlab::view::missing_display().is_none() {
        return cli(["view"]).args(args);
    }
    let found = Command::new("xvfb-run").arg("--help").output().is_ok();
    assert!(
        found,
        "the viewer's tests need a display or xvfb-run: apt-get install -y xvfb"
    );
    let server = 100 + std::process::id() % 300 * 8 + NEXT_SERVER.fetch_add(1, Ordering::Relaxed);
    let mut command = Command::new("xvfb-run");
    command
        .args(["-n", &server.to_string(), "-s", "-screen 0 1280x1024x24"])
        .arg(binary())
        .arg("view")
        .args(args)
        .stdin(Stdio::null());
    Cli(command)
}

/// Run a viewer with `play` (its exit code and output): a virtual display that did not come
/// up (seen in loaded full runs, when Xvfb servers start side by side) is the machine's
/// fault, not the viewer's, so it is tried once more.
pub fn on_a_display(play: impl Fn() -> (Option<i32>, String)) -> (Option<i32>, String) {
    let (code, text) = play();
    if text.contains("Failed to open connection to X server") {
        return play();
    }
    (code, text)
}

/// A copy of the shipped shaders with edits to one module, each replacing text that must be
/// there; removed when dropped.
pub struct EditedShaders {
    root: PathBuf,
    /// Composes from the edited copy.
    pub composer: Composer,
}

impl EditedShaders {
    /// A copy with edits to `module` (a path under `shaders/`).
    #[track_caller]
    pub fn of(module: &str, name: &str, edits: &[(&str, &str)]) -> Self {
        let root = scratch(name);
        copy_tree(Composer::default().shader_root(), &root);
        let file = root.join(module);
        let mut source = std::fs::read_to_string(&file).unwrap();
        for (from, to) in edits {
            assert!(source.contains(from), "{module} no longer has `{from}`");
            source = source.replace(from, to);
        }
        std::fs::write(&file, source).unwrap();
        let composer = Composer::new(&root);
        EditedShaders { root, composer }
    }

    /// The copy's folder (for `CLUSTERLAB_SHADERS`).
    pub fn root(&self) -> &Path {
        &self.root
    }
}

impl Drop for EditedShaders {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.root);
    }
}
