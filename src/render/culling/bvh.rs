//! The light BVH (`passes/assign_bvh.wesl`, twin `cpu::bvh`), built on the GPU in linear
//! time every frame: Morton codes, an LSD radix sort (a count, a scan and a scatter a
//! pass), Karras's internal nodes, the bounds bottom up; or with `refit` the bounds alone
//! over the last frame's order. Then a walk per tile of clusters, lists written from the
//! running total, every list sorted.

use super::steps::{Clear, Over, Plan, Step, long_lists};
use crate::cpu::bvh::{RADIX_BITS, RADIX_HEADER, RADIX_ITEMS, RADIX_LANES, TILE, radix_passes};
use crate::gpu::{Gpu, GpuError};
use crate::render::bindings::Binding;
use crate::render::clusters::{ClusterBuffers, WORD_BYTES};
use crate::render::reflect::BufferSizes;

/// Most lights: a dispatch of an invocation per light (64 a workgroup) has at most 65535
/// workgroups.
const MAX_LIGHTS: u32 = 65535 * 64;

/// Workgroups of a radix-sort pass's count and scatter: a tile of entries each.
fn radix_tiles(lights: u32) -> u32 {
    lights.div_ceil(RADIX_LANES * RADIX_ITEMS)
}

/// The steps that build the tree (`refit` false: sorted by Morton code and built) or set
/// its bounds again over the last order, after the lights' ranges.
pub(super) fn build(c: &ClusterBuffers, lights: u32, refit: bool) -> Plan<'_> {
    // The bounds' arrival counts, and the sort's pass count, start at zero.
    let mut clears = vec![Clear::whole(c.named(Binding::BvhBounds))];
    let mut steps = vec![Step::Dispatch("transform_lights", Over::Threads(lights, 1))];
    if !refit {
        clears.push(Clear(c.named(Binding::RadixCounts), 0, Some(WORD_BYTES)));
        steps.push(Step::Dispatch("morton_codes", Over::Threads(lights, 1)));
        let tiles = Over::Groups(radix_tiles(lights), 1, 1);
        for _ in 0..radix_passes(c.grid) {
            steps.extend([
                Step::Dispatch("radix_count", tiles),
                Step::Dispatch("radix_scan", Over::Groups(1, 1, 1)),
                Step::Dispatch("radix_scatter", tiles),
            ]);
        }
        steps.push(Step::Dispatch(
            "build_nodes",
            Over::Threads(lights.saturating_sub(1), 1),
        ));
    }
    steps.push(Step::Dispatch("fit_nodes", Over::Threads(lights, 1)));
    Plan { clears, steps }
}

/// The tree built or refitted, then the lists.
pub(super) fn plan(c: &ClusterBuffers, lights: u32, refit: bool) -> Plan<'_> {
    let Plan {
        mut clears,
        mut steps,
    } = build(c, lights, refit);
    // Clusters that take no part keep empty lists.
    clears.extend([
        Clear::whole(c.named(Binding::LightCounts)),
        Clear::whole(c.named(Binding::LightOffsets)),
    ]);
    clears.extend(Clear::long_lists(c));
    let (x, y, z) = c.grid;
    let tiles = Over::Groups(x.div_ceil(TILE.0), y.div_ceil(TILE.1), z.div_ceil(TILE.2));
    steps.extend([
        Step::Dispatch("assign_tiles", tiles),
        Step::Dispatch("finish_lists", Over::Threads(c.clusters, 1)),
    ]);
    steps.extend(long_lists(c, "sort_long_lists"));
    Plan { clears, steps }
}

/// The sort's two sides (a key and a light an entry, one buffer), its counts, and the
/// tree: each internal node's children, size and parent, then each leaf's parent; its
/// bounds and arrival counts.
pub(super) fn own_buffers(lights: u32) -> Vec<(Binding, u64)> {
    let n = lights.max(1) as u64;
    let internal = n.saturating_sub(1).max(1);
    let counts = RADIX_HEADER as u64 + (1u64 << RADIX_BITS) * radix_tiles(lights).max(1) as u64;
    vec![
        (Binding::SortedLights, 2 * n),
        (Binding::RadixCounts, counts),
        (Binding::BvhNodes, 2 * n - 1),
        // Bounds (3 words) and the arrival count.
        (Binding::BvhBounds, 4 * internal),
    ]
}

/// Refuse a frame of more lights than a dispatch of one invocation a light reaches, or
/// whose sorted order does not fit one buffer.
pub(super) fn check(gpu: &Gpu, lights: usize, sizes: &BufferSizes) -> Result<(), GpuError> {
    if lights > MAX_LIGHTS as usize {
        return Err(GpuError::TooLarge(format!(
            "the light BVH is built for at most {MAX_LIGHTS} lights and the scene has {lights}; use fewer lights or another `clusters.culling`"
        )));
    }
    let max = gpu.max_storage_bytes();
    for (name, count) in own_buffers(lights as u32) {
        let bytes = sizes.bytes(name, count).unwrap_or(0);
        if bytes > max {
            return Err(GpuError::TooLarge(format!(
                "the light BVH's `{}` for {lights} lights takes {bytes} bytes, more than the {max} bytes adapter `{}` allows in one buffer; use fewer lights",
                name.name(),
                gpu.adapter.name
            )));
        }
    }
    Ok(())
}
