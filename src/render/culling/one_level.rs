//! One-level assignment (`passes/assign_one_level.wesl`): a workgroup per light counts the
//! clusters it touches, a two-level prefix sum turns counts into offsets, a second walk
//! fills the lists, each short list sorted by its cluster and each long one by a workgroup.

use super::steps::{Clear, Over, Plan, Step, long_lists, per_light};
use crate::compose::SCAN_BLOCK;
use crate::render::bindings::Binding;
use crate::render::clusters::ClusterBuffers;

pub(super) fn plan(c: &ClusterBuffers, lights: u32) -> Plan<'_> {
    let mut clears = vec![
        Clear::whole(c.named(Binding::LightCounts)),
        Clear::whole(c.named(Binding::FillCursors)),
    ];
    clears.extend(Clear::long_lists(c));
    let mut steps = vec![
        Step::Dispatch("transform_lights", Over::Threads(lights, 1)),
        Step::Dispatch("count_lights", per_light(lights)),
        Step::Dispatch("scan_local", scan_blocks(c)),
        Step::Dispatch("scan_blocks", Over::Groups(1, 1, 1)),
        Step::Dispatch("fill_lists", per_light(lights)),
        Step::Dispatch("finish_lists", Over::Threads(c.clusters, 1)),
    ];
    steps.extend(long_lists(c, "sort_long_lists"));
    Plan { clears, steps }
}

/// A workgroup per block of SCAN_BLOCK clusters (the prefix sum's first level).
pub(super) fn scan_blocks(c: &ClusterBuffers) -> Over {
    Over::Groups(c.clusters.div_ceil(SCAN_BLOCK).max(1), 1, 1)
}
