//! Every environment variable clusterlab reads, written once: what it does and how it can
//! change a figure. Every read goes through [`var`] or [`var_os`] (a test fails on a read
//! anywhere else, and on a name not listed here); a matrix run records the values of those
//! that change figures in its provenance ([`recorded`]), and `--reuse` takes a cell only
//! where each is as it was ([`figure_inputs`]; the shader folder through the WGSL it
//! composes to). Imports nothing.

use std::ffi::OsString;

/// One variable: its name, how its value can change a figure, and what it does.
pub struct Variable {
    pub name: &'static str,
    pub effect: Effect,
    pub what: &'static str,
}

/// How a variable can change a figure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Effect {
    /// Its value is part of every cell's reuse key.
    Figures,
    /// Only through the shaders it names: a cell's key holds the WGSL they compose to, not
    /// the folder's name, so an edit reruns exactly the cells whose WGSL it changed.
    Shaders,
    /// None: where files go, what a window opens on.
    NoFigure,
}

/// Every variable clusterlab reads.
pub const VARIABLES: &[Variable] = &[
    Variable {
        name: "CLUSTERLAB_SHADERS",
        effect: Effect::Shaders,
        what: "the shader folder to compose from (default: the one built in)",
    },
    Variable {
        name: "CLUSTERLAB_PERTURB_DEPTH_ULPS",
        effect: Effect::Figures,
        what: "a test mode: every depth the marking passes read moved by N units in the last place",
    },
    Variable {
        name: "CLUSTERLAB_WITHOUT",
        effect: Effect::Figures,
        what: "optional GPU features masked from the device",
    },
    Variable {
        name: "CLUSTERLAB_TIMING",
        effect: Effect::Figures,
        what: "how passes are timed: `timestamps` or `wall`",
    },
    Variable {
        name: "CLUSTERLAB_MAX_BUFFER_SIZE",
        effect: Effect::Figures,
        what: "the largest buffer a run may make, in bytes",
    },
    Variable {
        name: "WGPU_BACKEND",
        effect: Effect::Figures,
        what: "the graphics API wgpu uses (vulkan, gl, metal, dx12)",
    },
    Variable {
        name: "WGPU_ADAPTER_NAME",
        effect: Effect::Figures,
        what: "the adapter wgpu picks, by name",
    },
    Variable {
        name: "LP_NUM_THREADS",
        effect: Effect::Figures,
        what: "the threads Mesa's software GPUs split each pass among",
    },
    Variable {
        name: "CLUSTERLAB_CACHE",
        effect: Effect::NoFigure,
        what: "where compiled pipelines are kept between runs (`off`: nowhere); only set-up time",
    },
    Variable {
        name: "XDG_CACHE_HOME",
        effect: Effect::NoFigure,
        what: "the user's cache folder, where the pipeline cache lives by default",
    },
    Variable {
        name: "HOME",
        effect: Effect::NoFigure,
        what: "the user's home, for `~/.cache` when XDG_CACHE_HOME is unset",
    },
    Variable {
        name: "DISPLAY",
        effect: Effect::NoFigure,
        what: "the X display `view` opens its window on",
    },
    Variable {
        name: "WAYLAND_DISPLAY",
        effect: Effect::NoFigure,
        what: "the Wayland display `view` opens its window on",
    },
    Variable {
        name: "XDG_RUNTIME_DIR",
        effect: Effect::NoFigure,
        what: "where Mesa's window system looks for its sockets (set to /tmp when unset)",
    },
];

fn listed(name: &str) -> bool {
    let known = VARIABLES.iter().any(|v| v.name == name);
    debug_assert!(known, "{name} is read but not in environment::VARIABLES");
    known
}

/// The value of `name` as text (None when unset, not text, or not listed).
pub fn var(name: &str) -> Option<String> {
    listed(name).then(|| std::env::var(name).ok()).flatten()
}

/// The value of `name` (None when unset or not listed).
pub fn var_os(name: &str) -> Option<OsString> {
    listed(name).then(|| std::env::var_os(name)).flatten()
}

/// `NAME=value` (or `NAME unset`) of every variable whose value is part of the reuse key
/// ([`Effect::Figures`]), in list order.
pub fn figure_inputs() -> Vec<String> {
    values(|e| e == Effect::Figures)
}

/// `NAME=value` (or `NAME unset`) of every variable that can change a figure, for the
/// provenance.
pub fn recorded() -> Vec<String> {
    values(|e| e != Effect::NoFigure)
}

fn values(pick: impl Fn(Effect) -> bool) -> Vec<String> {
    VARIABLES
        .iter()
        .filter(|v| pick(v.effect))
        .map(|v| match std::env::var_os(v.name) {
            Some(value) => format!("{}={}", v.name, value.to_string_lossy()),
            None => format!("{} unset", v.name),
        })
        .collect()
}
