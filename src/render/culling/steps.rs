//! What a light-assignment plan is made of (clears, dispatches, copies, a draw), and the
//! steps the methods share: long lists, sorting the lights.

use crate::compose::LIGHTS_PER_ROW;
use crate::cpu::sort::{SORT_BLOCK, merge_schedule, sorted_size};
use crate::gpu::{Gpu, GpuError};
use crate::render::bindings::Binding;
use crate::render::clusters::{ClusterBuffers, DISPATCH_ARGS_BYTES, SortJobsHeader, WORD_BYTES};
use crate::render::reflect::BufferSizes;

/// What light assignment runs: buffers (or parts of them) cleared first, then its steps.
pub(super) struct Plan<'a> {
    pub clears: Vec<Clear<'a>>,
    pub steps: Vec<Step<'a>>,
}

/// A buffer cleared from byte `at`, `bytes` of it or to its end.
pub(super) struct Clear<'a>(pub &'a wgpu::Buffer, pub u64, pub Option<u64>);

impl<'a> Clear<'a> {
    pub(super) fn whole(buffer: &'a wgpu::Buffer) -> Self {
        Clear(buffer, 0, None)
    }

    /// The long lists' workgroup and job counts (the header's x and fourth word).
    pub(super) fn long_lists(c: &'a ClusterBuffers) -> [Self; 2] {
        let x = std::mem::offset_of!(SortJobsHeader, groups_x) as u64;
        let count = std::mem::offset_of!(SortJobsHeader, count) as u64;
        [
            Clear(c.named(Binding::SortJobs), x, Some(WORD_BYTES)),
            Clear(c.named(Binding::SortJobs), count, Some(WORD_BYTES)),
        ]
    }
}

/// One step of light assignment. Dispatches run in a compute pass; a copy or the draw ends
/// it, and the next dispatch begins another.
pub(super) enum Step<'a> {
    /// Entry point `entry` over `Over`.
    Dispatch(&'static str, Over),
    /// Entry point `entry`, its workgroup count read from a buffer.
    Indirect(&'static str, &'a wgpu::Buffer),
    /// `bytes` (or all) of a buffer from byte `at`, to the start of another.
    Copy(&'a wgpu::Buffer, u64, &'a wgpu::Buffer, Option<u64>),
    /// Rasterised binning's draw of the light proxies.
    DrawProxies,
}

/// What a dispatch covers.
#[derive(Clone, Copy)]
pub(super) enum Over {
    /// One invocation per item (x, y), in workgroups of the entry's own size.
    Threads(u32, u32),
    /// Exactly this many workgroups.
    Groups(u32, u32, u32),
}

/// One workgroup per light, in rows of LIGHTS_PER_ROW.
pub(super) fn per_light(lights: u32) -> Over {
    Over::Groups(
        lights.clamp(1, LIGHTS_PER_ROW),
        lights.div_ceil(LIGHTS_PER_ROW).max(1),
        1,
    )
}

/// The long lists at the end of one-level and rasterised assignment (sorted) and two-level
/// (written): as many workgroups as the passes before queued, in a compute pass of their own.
pub(super) fn long_lists<'a>(c: &'a ClusterBuffers, entry: &'static str) -> [Step<'a>; 2] {
    [
        Step::Copy(
            c.named(Binding::SortJobs),
            0,
            &c.sort_dispatch,
            Some(DISPATCH_ARGS_BYTES),
        ),
        Step::Indirect(entry, &c.sort_dispatch),
    ]
}

/// The lights sorted by key (`clustering/sort.wesl`, z-binning's bitonic sort):
/// each block sorted in a workgroup's memory, then each merge step, which carries its
/// place in the schedule as workgroups beyond the blocks.
pub(super) fn sort_lights(lights: u32) -> Vec<Step<'static>> {
    let n = sorted_size(lights);
    let blocks = n / SORT_BLOCK;
    let mut steps = vec![Step::Dispatch("sort_blocks", Over::Groups(blocks, 1, 1))];
    for (s, (_, j)) in merge_schedule(n).into_iter().enumerate() {
        let entry = if j == 0 { "merge_blocks" } else { "merge_step" };
        steps.push(Step::Dispatch(entry, Over::Groups(blocks + s as u32, 1, 1)));
    }
    steps
}

/// The sort's order: a key and a light an entry.
pub(super) fn sorted_lights(lights: u32) -> (Binding, u64) {
    (Binding::SortedLights, sorted_size(lights) as u64)
}

/// Refuse a frame whose sorted order does not fit one buffer.
pub(super) fn check_sorted(
    gpu: &Gpu,
    method: &str,
    lights: usize,
    sizes: &BufferSizes,
) -> Result<(), GpuError> {
    let (name, count) = sorted_lights(lights as u32);
    let bytes = sizes.bytes(name, count).unwrap_or(0);
    let max = gpu.max_storage_bytes();
    if bytes > max {
        return Err(GpuError::TooLarge(format!(
            "{method}'s sorted order of {lights} lights takes {bytes} bytes, more than the {max} bytes adapter `{}` allows in one buffer; use fewer lights",
            gpu.adapter.name
        )));
    }
    Ok(())
}
