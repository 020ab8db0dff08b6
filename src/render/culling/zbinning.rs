//! Z-binning (Drobot 2017; `passes/zbin_assign.wesl`, `clustering/zbin.wesl`): lights sorted
//! by depth (the shared sort, `clustering/sort.wesl`), each bin the range of sorted lights
//! that reach its slice, each tile a bit per light that reaches its side planes. No lists:
//! a pixel walks its bin's range.

use super::{Clear, Over, Plan, Step, check_sorted, per_light, sort_lights, sorted_lights};
use crate::gpu::{Gpu, GpuError};
use crate::render::clusters::{ClusterBuffers, Sizing};

pub(super) fn plan(c: &ClusterBuffers, lights: u32) -> Plan<'_> {
    let mut steps = vec![Step::Dispatch("transform_lights", Over::Threads(lights, 1))];
    steps.extend(sort_lights(lights));
    steps.extend([
        Step::Dispatch("bin_lights", Over::Threads(lights, 1)),
        Step::Dispatch("mask_tiles", per_light(lights)),
        Step::Dispatch("measure_walks", Over::Threads(c.clusters, 1)),
    ]);
    Plan {
        clears: vec![
            Clear::whole(c.named("bin_ranges")),
            Clear::whole(c.named("tile_masks")),
        ],
        steps,
    }
}

/// The sort's order; the lights in depth order (what the shading walks), each bin's range
/// of them, and each tile's mask of a bit per light.
pub(super) fn own_buffers(s: &Sizing) -> Vec<(&'static str, u64)> {
    let (x, y, z) = s.grid;
    let words = (s.lights as u64).div_ceil(32);
    vec![
        sorted_lights(s.lights),
        ("light_order", s.lights as u64 * 4),
        ("bin_ranges", z as u64 * 8),
        ("tile_masks", (x * y) as u64 * words * 4),
    ]
}

/// Refuse a frame whose sorted order or tile masks do not fit one buffer.
pub(super) fn check(gpu: &Gpu, grid: (u32, u32, u32), lights: usize) -> Result<(), GpuError> {
    check_sorted(gpu, "z-binning", lights)?;
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
