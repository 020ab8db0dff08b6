//! Z-binning (Drobot 2017; `passes/zbin_assign.wesl`, `clustering/zbin.wesl`): lights sorted
//! by depth, each bin the range of sorted lights that reach its slice, each tile a bit per
//! light that reaches its side planes. No lists: a pixel walks its bin's range.

use super::{Clear, Over, Plan, Step, per_light};
use crate::gpu::{Gpu, GpuError};
use crate::render::clusters::{ClusterBuffers, ZBIN_MAX_LIGHTS};

pub(super) fn plan(c: &ClusterBuffers, lights: u32) -> Plan<'_> {
    Plan {
        clears: vec![Clear::whole(&c.bin_ranges), Clear::whole(&c.tile_masks)],
        steps: vec![
            Step::Dispatch("transform_lights", Over::Threads(lights, 1)),
            Step::Dispatch("sort_lights", Over::Groups(1, 1, 1)),
            Step::Dispatch("bin_lights", Over::Threads(lights, 1)),
            Step::Dispatch("measure_bins", Over::Threads(c.grid.2, 1)),
            Step::Dispatch("mask_tiles", per_light(lights)),
        ],
    }
}

/// Refuse a frame the sort or the tile masks cannot hold.
pub(super) fn check(gpu: &Gpu, grid: (u32, u32, u32), lights: usize) -> Result<(), GpuError> {
    if lights > ZBIN_MAX_LIGHTS {
        return Err(GpuError::TooLarge(format!(
            "z-binning sorts at most {ZBIN_MAX_LIGHTS} lights and the scene has {lights}; use fewer lights or another `clusters.culling`"
        )));
    }
    let bytes = (grid.0 * grid.1) as u64 * (lights as u64).div_ceil(32) * 4;
    let max = gpu.max_storage_bytes();
    if bytes > max {
        return Err(GpuError::TooLarge(format!(
            "z-binning's tile masks for {}x{} tiles and {lights} lights take {bytes} bytes, more than the {max} bytes adapter `{}` allows in one buffer; use fewer tiles or lights",
            grid.0, grid.1, gpu.adapter.name
        )));
    }
    Ok(())
}
