//! Two-level assignment (HDRP; `clustering/two_level.wesl`): a workgroup per light sets its
//! bit in each big tile whose tiles it reaches, then each cluster walks its big tile's
//! survivors once and writes its list; lists too long to hold are written by a second walk.

use super::{Clear, Over, Plan, Step, long_lists, per_light};
use crate::render::clusters::ClusterBuffers;

pub(super) fn plan(c: &ClusterBuffers, lights: u32, big_tile: u32) -> Plan<'_> {
    // The fine pass writes only the lists of clusters that take part; the others stay empty.
    let mut clears = vec![
        Clear::whole(&c.counts),
        Clear::whole(&c.offsets),
        Clear::whole(&c.coarse_masks),
    ];
    clears.extend(Clear::long_lists(c));
    // Every cluster of every big tile (`fine_cluster` in two_level.wesl).
    let (x, y, z) = c.grid;
    let fine = x.div_ceil(big_tile) * y.div_ceil(big_tile) * big_tile * big_tile * z;
    let mut steps = vec![
        Step::Dispatch("transform_lights", Over::Threads(lights, 1)),
        Step::Dispatch("coarse_cull", per_light(lights)),
        Step::Dispatch("assign_clusters", Over::Threads(fine, 1)),
    ];
    steps.extend(long_lists(c, "fill_long_lists"));
    Plan { clears, steps }
}
