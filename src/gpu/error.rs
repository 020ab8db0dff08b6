//! Why the GPU could not be used.

use std::time::Duration;

/// Why the GPU could not be used.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found (backends tried: {backends}). Without a GPU, install Mesa's \
         software Vulkan driver (lavapipe): `apt-get install mesa-vulkan-drivers`; or try \
         OpenGL (llvmpipe) with `--backend gl` or `WGPU_BACKEND=gl`"
    )]
    NoAdapter { backends: String },
    #[error(
        "`{value}` (from {from}) is not a backend; use vulkan, gl, metal or dx12, or a comma \
         list of them"
    )]
    UnknownBackend { value: String, from: &'static str },
    #[error("could not open the GPU device: {0}")]
    Device(String),
    /// An environment setting clusterlab reads that has no meaning.
    #[error("{0}")]
    Setting(String),
    /// A wgpu validation, out-of-memory or internal error captured while running a pass.
    #[error("GPU error: {0}")]
    Captured(String),
    #[error("{0}")]
    TooLarge(String),
    /// The cell's GPU work did not finish within its time limit.
    #[error(
        "the GPU work did not finish within the cell time limit of {} s; raise it with \
         --cell-timeout SECONDS",
        limit.as_secs_f64()
    )]
    TimedOut { limit: Duration },
    /// The device was lost (driver reset, destroyed) and cannot run anything more.
    #[error("the GPU device was lost: {0}")]
    Lost(String),
}
