//! The clustering family: compute passes that fit the depth range, mark active clusters,
//! build cluster boxes and assign lights (count, prefix sum, fill). Their entry points, the
//! buffers they clear and their dispatches.

use super::clusters::{ClusterBuffers, SCAN_BLOCK, SORT_DISPATCH_BYTES};
use super::passes::{ComputePipelines, set_compute_groups};
use crate::compose::ClusterPass;
use crate::gpu::TimestampSlot;
use crate::variant::Culling;

/// Lights per row of the per-light dispatches (`LIGHTS_PER_ROW` in light_assign.wesl).
const LIGHTS_PER_ROW: u32 = 32768;

/// Workgroups to cover `n` items, `per_group` a workgroup (at least one).
pub fn dispatch_size(n: u32, per_group: u32) -> u32 {
    n.div_ceil(per_group).max(1)
}

/// Compute entry points of a pass of a variant culling with `culling` (and two levels or
/// not), in dispatch order (`mark_visible` runs only for the counters; see
/// [`encode_visible_count`]).
pub fn entries(pass: ClusterPass, culling: Culling, two_level: bool) -> &'static [&'static str] {
    match pass {
        ClusterPass::LightAssign if two_level => &[
            "transform_lights",
            "coarse_cull",
            "count_clusters",
            "scan_local",
            "scan_blocks",
            "fill_clusters",
            "finish_lists",
            "sort_long_lists",
        ],
        ClusterPass::MarkActive if culling == Culling::DepthMask => {
            &["mark_active", "mark_visible", "mark_cells"]
        }
        ClusterPass::LightAssign if culling == Culling::ZBinning => &[
            "transform_lights",
            "sort_lights",
            "bin_lights",
            "mask_tiles",
        ],
        ClusterPass::ClusterBounds => &["build_bounds"],
        ClusterPass::LightAssign => &[
            "transform_lights",
            "count_lights",
            "scan_local",
            "scan_blocks",
            "fill_lists",
            "finish_lists",
            "sort_long_lists",
        ],
        ClusterPass::MarkActive => &["mark_active", "mark_visible"],
        ClusterPass::DepthRange => &["reduce", "finalize"],
    }
}

/// What a clustering pass dispatches over.
pub struct Extent {
    pub width: u32,
    pub height: u32,
    pub lights: u32,
}

/// Encode one clustering pass: clear what it accumulates into, then its dispatches.
pub fn encode(
    pass: ClusterPass,
    p: &ComputePipelines,
    groups: &[Option<wgpu::BindGroup>],
    encoder: &mut wgpu::CommandEncoder,
    slot: Option<TimestampSlot<'_>>,
    c: &ClusterBuffers,
    extent: &Extent,
) {
    match pass {
        ClusterPass::MarkActive => {
            encoder.clear_buffer(&c.active, 0, None);
            encoder.clear_buffer(&c.sample_depths, 0, None);
            encoder.clear_buffer(&c.depth_masks, 0, None);
            encoder.clear_buffer(&c.big_tile_depths, 0, None);
        }
        ClusterPass::LightAssign if c.culling == Culling::ZBinning => {
            encoder.clear_buffer(&c.bin_ranges, 0, None);
            encoder.clear_buffer(&c.tile_masks, 0, None);
        }
        ClusterPass::LightAssign if c.big_tiles.is_some() => {
            encoder.clear_buffer(&c.coarse_masks, 0, None);
            encoder.clear_buffer(&c.sort_jobs, 0, Some(16));
        }
        ClusterPass::LightAssign => {
            encoder.clear_buffer(&c.counts, 0, None);
            encoder.clear_buffer(&c.fill_cursors, 0, None);
            encoder.clear_buffer(&c.sort_jobs, 0, Some(16));
        }
        ClusterPass::DepthRange | ClusterPass::ClusterBounds => {}
    }
    // Light assignment ends with a second compute pass (the long-list sort, dispatched
    // indirectly); the first pass then writes the beginning timestamp, the second the end.
    let sorts = pass == ClusterPass::LightAssign && c.culling != Culling::ZBinning;
    let mut cp = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(<&str>::from(pass)),
        timestamp_writes: if sorts {
            TimestampSlot::compute_part(slot, false)
        } else {
            TimestampSlot::compute(slot)
        },
    });
    set_compute_groups(&mut cp, groups);
    let pixels = (
        dispatch_size(extent.width, 8),
        dispatch_size(extent.height, 8),
        1,
    );
    let clusters = dispatch_size(c.clusters, 64);
    let l = extent.lights;
    // One workgroup per light, in rows of LIGHTS_PER_ROW (light_assign.wesl).
    let per_light = (
        l.clamp(1, LIGHTS_PER_ROW),
        l.div_ceil(LIGHTS_PER_ROW).max(1),
        1,
    );
    let dispatches: Vec<(&str, (u32, u32, u32))> = match pass {
        ClusterPass::ClusterBounds => vec![("build_bounds", (clusters, 1, 1))],
        ClusterPass::MarkActive if c.culling == Culling::DepthMask => {
            vec![("mark_active", pixels), ("mark_cells", pixels)]
        }
        ClusterPass::MarkActive => vec![("mark_active", pixels)],
        ClusterPass::DepthRange => vec![("reduce", pixels), ("finalize", (1, 1, 1))],
        ClusterPass::LightAssign if c.culling == Culling::ZBinning => vec![
            ("transform_lights", (dispatch_size(l, 64), 1, 1)),
            ("sort_lights", (1, 1, 1)),
            ("bin_lights", (dispatch_size(l, 64), 1, 1)),
            ("mask_tiles", per_light),
        ],
        ClusterPass::LightAssign if c.big_tiles.is_some() => vec![
            ("transform_lights", (dispatch_size(l, 64), 1, 1)),
            ("coarse_cull", per_light),
            ("count_clusters", (clusters, 1, 1)),
            ("scan_local", (dispatch_size(c.clusters, SCAN_BLOCK), 1, 1)),
            ("scan_blocks", (1, 1, 1)),
            ("fill_clusters", (clusters, 1, 1)),
            ("finish_lists", (clusters, 1, 1)),
        ],
        ClusterPass::LightAssign => vec![
            ("transform_lights", (dispatch_size(l, 64), 1, 1)),
            ("count_lights", per_light),
            ("scan_local", (dispatch_size(c.clusters, SCAN_BLOCK), 1, 1)),
            ("scan_blocks", (1, 1, 1)),
            ("fill_lists", per_light),
            ("finish_lists", (clusters, 1, 1)),
        ],
    };
    for (entry, (x, y, z)) in dispatches {
        cp.set_pipeline(p.get(entry));
        cp.dispatch_workgroups(x, y, z);
    }
    drop(cp);
    if sorts {
        // As many workgroups as finish_lists found lists too long to sort alone.
        encoder.copy_buffer_to_buffer(&c.sort_jobs, 0, &c.sort_dispatch, 0, SORT_DISPATCH_BYTES);
        let mut cp = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("sort long lists"),
            timestamp_writes: TimestampSlot::compute_part(slot, true),
        });
        set_compute_groups(&mut cp, groups);
        cp.set_pipeline(p.get("sort_long_lists"));
        cp.dispatch_workgroups_indirect(&c.sort_dispatch, 0);
    }
}

/// Encode the marking of clusters that hold a visible sample of the last frame's depth
/// (`mark_visible`), with the `active` flags and their counter cleared first.
pub fn encode_visible_count(
    p: &ComputePipelines,
    groups: &[Option<wgpu::BindGroup>],
    encoder: &mut wgpu::CommandEncoder,
    c: &ClusterBuffers,
    extent: &Extent,
) {
    encoder.clear_buffer(&c.active, 0, None);
    // The `active_clusters` counter: the third u32 of the stats.
    encoder.clear_buffer(&c.stats, 8, Some(4));
    let mut cp = encoder.begin_compute_pass(&Default::default());
    set_compute_groups(&mut cp, groups);
    cp.set_pipeline(p.get("mark_visible"));
    cp.dispatch_workgroups(
        dispatch_size(extent.width, 8),
        dispatch_size(extent.height, 8),
        1,
    );
}
