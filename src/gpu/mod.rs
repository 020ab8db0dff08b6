//! The GPU: adapter choice (`adapters`), device with checked features and limits, captured
//! errors, waits bounded by a per-cell time limit, device health and replacement, per-pass
//! timing, read-back, and where adapters are declared to differ (`expect`).

pub mod adapters;
mod cache;
mod deviations;
mod device;
pub mod disk_cache;
mod error;
pub mod expect;
mod health;
mod pipeline_store;
mod readback;
mod timing;

pub use adapters::{AdapterSummary, MSAA_ON_GL, SOFTWARE_GPU_THREADS, software_gpu_threads};
pub use device::{DEFAULT_CELL_TIMEOUT, Gpu, MAX_BUFFER_SIZE_VAR};
pub use pipeline_store::{LayoutObjects, PipelineStats};

pub use error::GpuError;
pub use readback::{read_buffer, read_texture};
pub use timing::{PassTimer, TimestampSlot, Timings};

/// Most threads `LP_NUM_THREADS` may ask of Mesa's software GPU (Mesa clamps to its own
/// limit, 32 or 64 by version, below this).
const MAX_SOFTWARE_GPU_THREADS: u32 = 256;

/// Refuse environment variables with values the GPU layer cannot use, naming the variable
/// and what would be valid (before anything reads them: Mesa would take a bad
/// `LP_NUM_THREADS` without a word).
pub fn check_environment() -> Result<(), String> {
    device::buffer_cap()?;
    disk_cache::check_environment()?;
    if let Some(value) = crate::environment::var_os(SOFTWARE_GPU_THREADS) {
        let value = value.to_string_lossy();
        if !value
            .trim()
            .parse::<u32>()
            .is_ok_and(|n| n <= MAX_SOFTWARE_GPU_THREADS)
        {
            return Err(format!(
                "{SOFTWARE_GPU_THREADS}=`{value}` is not a thread count: give a whole number in 0..={MAX_SOFTWARE_GPU_THREADS} (0 runs Mesa's software GPU on one thread), or unset it (clusterlab then sets twice the cores)"
            ));
        }
    }
    Ok(())
}
