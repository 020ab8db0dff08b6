//! Two-level assignment (HDRP; `clustering/two_level.wesl`): a workgroup per light sets its
//! bit in each big tile whose tiles it reaches, then each cluster walks its big tile's
//! survivors once and writes its list; lists too long to hold are written by a second walk.

use super::steps::{Clear, Over, Plan, Step, long_lists, per_light};
use crate::render::bindings::Binding;
use crate::render::clusters::{ClusterBuffers, Sizing};

pub(super) fn plan(c: &ClusterBuffers, lights: u32, big_tile: u32) -> Plan<'_> {
    // The fine pass writes only the lists of clusters that take part; the others stay empty.
    let mut clears = vec![
        Clear::whole(c.named(Binding::LightCounts)),
        Clear::whole(c.named(Binding::LightOffsets)),
        Clear::whole(c.named(Binding::CoarseMasks)),
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

/// Per big tile of `big` tiles a side, a mask of the lights that survive its coarse test
/// and its summary (a bit per mask word), then a mask for each slice (`two_level.wesl`);
/// and with active clusters each big tile's sample depth range.
pub(super) fn own_buffers(s: &Sizing, big: u32) -> Vec<(Binding, u64)> {
    let (x, y, z) = s.grid;
    let words = (s.lights as u64).div_ceil(32);
    let big_tiles = (x.div_ceil(big) * y.div_ceil(big)) as u64;
    vec![
        (
            Binding::CoarseMasks,
            big_tiles * (words + words.div_ceil(32)) + z as u64 * words,
        ),
        // The minimum (inverted) and maximum of each.
        (Binding::BigTileDepths, big_tiles * 2),
    ]
}
