//! Olsson 2012's light BVH (`passes/assign_bvh.wesl`, twin `cpu::bvh`): each block of the
//! lights' Morton order sorted in a workgroup's memory, then the bitonic merges, the tree
//! built level by level, and each cluster's walk counted, summed into offsets, walked again
//! to write its list, and the lists sorted. A merge step and a level are told apart by
//! their dispatch's workgroup count: a merge carries its place in the schedule as
//! workgroups beyond the blocks (which return at once), a level is its nodes.

use super::one_level::scan_blocks;
use super::steps::{Clear, Over, Plan, Step, check_sorted, long_lists, sort_lights, sorted_lights};
use crate::cpu::bvh::level_sizes;
use crate::cpu::sort::sorted_size;
use crate::gpu::{Gpu, GpuError};
use crate::render::bindings::Binding;
use crate::render::clusters::ClusterBuffers;
use crate::render::reflect::BufferSizes;

/// Most lights: the lowest level's dispatch has a workgroup per node of 32 sorted entries,
/// at most 65535, and the sorted order is a power of two: 2^20 entries make 32768 nodes.
const MAX_LIGHTS: u32 = 1 << 20;

/// The tree built (`refit` false: the lights sorted by key first) or refitted over the
/// previous frame's order (Moreau et al. 2019: each node's range recomputed from its
/// children, whatever the order; the walks stay exact).
pub(super) fn plan(c: &ClusterBuffers, lights: u32, refit: bool) -> Plan<'_> {
    let mut clears = vec![Clear::whole(c.named(Binding::LightCounts))];
    clears.extend(Clear::long_lists(c));
    let mut steps = vec![Step::Dispatch("transform_lights", Over::Threads(lights, 1))];
    if !refit {
        steps.extend(sort_lights(lights));
    }
    for nodes in level_sizes(sorted_size(lights)) {
        steps.push(Step::Dispatch("build_nodes", Over::Groups(nodes, 1, 1)));
    }
    steps.extend([
        Step::Dispatch("count_clusters", Over::Threads(c.clusters, 1)),
        Step::Dispatch("scan_local", scan_blocks(c)),
        Step::Dispatch("scan_blocks", Over::Groups(1, 1, 1)),
        Step::Dispatch("fill_clusters", Over::Threads(c.clusters, 1)),
        Step::Dispatch("finish_lists", Over::Threads(c.clusters, 1)),
    ]);
    steps.extend(long_lists(c, "sort_long_lists"));
    Plan { clears, steps }
}

/// The sorted order (a key and a light each) and every level's nodes (a range each).
pub(super) fn own_buffers(lights: u32) -> Vec<(Binding, u64)> {
    let n = sorted_size(lights);
    let nodes: u64 = level_sizes(n).iter().map(|&s| s as u64).sum();
    vec![sorted_lights(lights), (Binding::BvhNodes, nodes)]
}

/// Refuse a frame of more lights than the tree's lowest level can be built for, or whose
/// order does not fit one buffer.
pub(super) fn check(gpu: &Gpu, lights: usize, sizes: &BufferSizes) -> Result<(), GpuError> {
    if lights > MAX_LIGHTS as usize {
        return Err(GpuError::TooLarge(format!(
            "the light BVH is built for at most {MAX_LIGHTS} lights and the scene has {lights}; use fewer lights or another `clusters.culling`"
        )));
    }
    check_sorted(gpu, "the light BVH", lights, sizes)
}
