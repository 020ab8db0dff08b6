//! Patch (`clusters.update: Patch`, `passes/patch_lists.wesl`): the previous frame's lists
//! kept, each light that moved since marking the clusters it touched, moving, counting
//! itself where it entered, then each changed list copied to new room without the lights
//! that left, the entering lights written after it, and those lists sorted.

use super::steps::{Clear, Over, Plan, Step, long_lists, per_light};
use crate::render::bindings::Binding;
use crate::render::clusters::ClusterBuffers;

/// The plan for `moved` lights that moved since the lists were made.
pub(super) fn plan(c: &ClusterBuffers, moved: u32) -> Plan<'_> {
    let mut clears = vec![
        Clear::whole(c.named(Binding::PatchClusters)),
        Clear::whole(c.named(Binding::FillCursors)),
    ];
    clears.extend(Clear::long_lists(c));
    let mut steps = vec![
        Step::Dispatch("mark_left", per_light(moved)),
        Step::Dispatch("transform_moved", Over::Threads(moved, 1)),
        Step::Dispatch("count_entered", per_light(moved)),
        Step::Dispatch("place_lists", Over::Threads(c.clusters, 1)),
        Step::Dispatch("fill_entered", per_light(moved)),
        Step::Dispatch("sort_placed", Over::Threads(c.clusters, 1)),
    ];
    steps.extend(long_lists(c, "sort_long_lists"));
    Plan { clears, steps }
}
