//! Process set-up before anything runs: quiet pipes, Mesa's WSI, software GPU threads.

/// Output piped into a reader that stops early (`clusterlab wgsl ... | head`) ends the
/// program quietly, as a Unix tool does, instead of a panic at the next `print!`: Rust
/// ignores SIGPIPE, so every later write fails with a broken pipe.
pub(crate) fn end_quietly_on_closed_pipe() {
    #[cfg(unix)]
    // SAFETY: setting a signal's action to its default before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Mesa's Vulkan WSI prints "error: XDG_RUNTIME_DIR is invalid" on every instance when the
/// variable is unset (headless machines, CI). Point it at the temp folder so real errors stand
/// out.
pub(crate) fn quiet_mesa_wsi() {
    if clusterlab::environment::var_os("XDG_RUNTIME_DIR").is_none() {
        // SAFETY: called first thing in main, before any other thread exists.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir()) };
    }
}

/// Mesa's software GPU (llvmpipe, lavapipe) splits each pass among LP_NUM_THREADS threads,
/// one per core unless set, and a pass waits for its slowest one. This process and the
/// driver's queue share those cores: on 2 cores a descheduled thread now and then doubled a
/// pass. Twice as many threads as cores halved the spread of the matrix's frame times
/// (README). A value the user set is kept; other drivers ignore the variable.
pub(crate) fn spread_software_gpu_threads() {
    if clusterlab::environment::var_os(clusterlab::gpu::SOFTWARE_GPU_THREADS).is_none() {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        // SAFETY: called in main before any other thread exists.
        unsafe {
            std::env::set_var(
                clusterlab::gpu::SOFTWARE_GPU_THREADS,
                (2 * cores).to_string(),
            )
        };
    }
}
