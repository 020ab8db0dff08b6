//! Z-binning (Drobot 2017; `passes/zbin_assign.wesl`, `clustering/zbin.wesl`): lights sorted
//! by depth (the shared sort, `clustering/sort.wesl`), each bin the range of sorted lights
//! that reach its slice, each tile a bit per light that reaches its side planes. No lists:
//! a pixel walks its bin's range.

use super::steps::{Clear, Over, Plan, Step, check_sorted, per_light, sort_lights, sorted_lights};
use crate::cpu::zbin::ZBins;
use crate::gpu::{Gpu, GpuError};
use crate::render::bindings::Binding;
use crate::render::clusters::{ClusterBuffers, Sizing};
use crate::render::reflect::BufferSizes;

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
            Clear::whole(c.named(Binding::BinRanges)),
            Clear::whole(c.named(Binding::TileMasks)),
        ],
        steps,
    }
}

/// The lights in depth order (what the shading walks), each bin's range of them (first
/// and last), and each tile's mask of a bit per light: their names and elements, for
/// `lights` lights on `grid`.
fn binned(grid: (u32, u32, u32), lights: u32) -> [(Binding, u64); 3] {
    let (x, y, z) = grid;
    let words = (lights as u64).div_ceil(32);
    [
        (Binding::LightOrder, lights as u64),
        (Binding::BinRanges, z as u64 * 2),
        (Binding::TileMasks, (x * y) as u64 * words),
    ]
}

/// The sort's order, and the binned lights.
pub(super) fn own_buffers(s: &Sizing) -> Vec<(Binding, u64)> {
    let mut buffers = vec![sorted_lights(s.lights)];
    buffers.extend(binned(s.grid, s.lights));
    buffers
}

/// The sorted lights, bins and tile masks as the GPU holds them after a frame.
pub(in crate::render) fn read(c: &ClusterBuffers, gpu: &Gpu) -> Result<ZBins, GpuError> {
    let [order, bins, masks] = binned(c.grid, c.lights)
        .map(|(name, count)| c.read_named(gpu, name, Some(c.declared_bytes(name, count))));
    Ok(ZBins::from_gpu(
        (c.grid.0, c.grid.1),
        order?,
        &bins?,
        masks?,
    ))
}

/// Refuse a frame whose sorted order or tile masks do not fit one buffer.
pub(super) fn check(
    gpu: &Gpu,
    grid: (u32, u32, u32),
    lights: usize,
    sizes: &BufferSizes,
) -> Result<(), GpuError> {
    check_sorted(gpu, "z-binning", lights, sizes)?;
    let (name, count) = binned(grid, lights as u32)[2];
    let bytes = sizes.bytes(name, count).unwrap_or(0);
    let max = gpu.max_storage_bytes();
    if bytes > max {
        return Err(GpuError::TooLarge(format!(
            "z-binning's tile masks for {}x{} tiles and {lights} lights take {bytes} bytes, more than the {max} bytes adapter `{}` allows in one buffer; use fewer tiles or lights",
            grid.0, grid.1, gpu.adapter.name
        )));
    }
    Ok(())
}
