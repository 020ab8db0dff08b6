//! The clustering family: compute passes that fit the depth range, mark active clusters,
//! build cluster boxes and assign lights (count, prefix sum, fill). Their entry points, the
//! buffers they clear and their dispatches.

use super::clusters::{
    BIN_TARGET_FORMAT, ClusterBuffers, DISPATCH_ARGS_BYTES, SCAN_BLOCK, SCATTER_DISPATCH_AT,
};
use super::passes::{
    ComputePipelines, begin_render, color_target, render_pipeline, set_compute_groups,
};
use crate::compose::{ClusterPass, ComposedPass};
use crate::gpu::{Gpu, GpuError, TimestampSlot};
use crate::variant::Culling;

/// Rasterised binning's draw of the light proxies, which counts and records the pairs.
pub struct BinningPipelines {
    draw: wgpu::RenderPipeline,
}

impl BinningPipelines {
    /// The draw of light assignment pass `pass` (composed with `raster_binning`).
    pub fn new(
        gpu: &Gpu,
        pass: &ComposedPass,
        layout: &wgpu::PipelineLayout,
    ) -> Result<Self, GpuError> {
        // One instance per proxy: (light, slice, x0 | x1 << 16, y0 | y1 << 16).
        let instances = wgpu::VertexBufferLayout {
            array_stride: 16,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &[wgpu::VertexAttribute {
                format: wgpu::VertexFormat::Uint32x4,
                offset: 0,
                shader_location: 0,
            }],
        };
        Ok(Self {
            draw: render_pipeline(
                gpu,
                pass,
                layout,
                ("bin_vertex", Some("bin_lights")),
                &[Some(instances)],
                &[color_target(BIN_TARGET_FORMAT)],
                None,
            )?,
        })
    }
}

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
            "assign_clusters",
            "fill_long_lists",
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
        ClusterPass::LightAssign if culling == Culling::Rasterised => &[
            "transform_lights",
            "count_proxies",
            "place_proxies",
            "split_lights",
            "scan_local",
            "scan_blocks",
            "size_pair_passes",
            "scatter_pairs",
            "find_unsorted",
            "finish_lists",
            "sort_long_lists",
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
#[allow(clippy::too_many_arguments)]
pub fn encode(
    pass: ClusterPass,
    p: &ComputePipelines,
    binning: Option<&BinningPipelines>,
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
            // The fine pass writes only the lists of clusters that take part; the others
            // stay empty.
            encoder.clear_buffer(&c.counts, 0, None);
            encoder.clear_buffer(&c.offsets, 0, None);
            encoder.clear_buffer(&c.coarse_masks, 0, None);
            c.clear_long_lists(encoder);
        }
        ClusterPass::LightAssign => {
            encoder.clear_buffer(&c.counts, 0, None);
            encoder.clear_buffer(&c.fill_cursors, 0, None);
            c.clear_long_lists(encoder);
            if c.culling == Culling::Rasterised {
                encoder.clear_buffer(&c.proxy_draw, 0, None);
            }
        }
        ClusterPass::DepthRange | ClusterPass::ClusterBounds => {}
    }
    if pass == ClusterPass::LightAssign && c.culling == Culling::Rasterised {
        return encode_binning(p, binning, groups, encoder, slot, c, extent.lights);
    }
    // Light assignment ends with a second compute pass over the long lists, dispatched
    // indirectly (sorting them; with two-level culling, writing them); the first pass then
    // writes the beginning timestamp, the second the end. Z-binning builds no lists.
    let long_lists = pass == ClusterPass::LightAssign && c.culling != Culling::ZBinning;
    let mut cp = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(<&str>::from(pass)),
        timestamp_writes: if long_lists {
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
        ClusterPass::LightAssign if let Some(b) = c.big_tiles => {
            // Every cluster of every big tile (`fine_cluster` in two_level.wesl).
            let (x, y, z) = c.grid;
            let fine = x.div_ceil(b) * y.div_ceil(b) * b * b * z;
            vec![
                ("transform_lights", (dispatch_size(l, 64), 1, 1)),
                ("coarse_cull", per_light),
                ("assign_clusters", (dispatch_size(fine, 64), 1, 1)),
            ]
        }
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
    if long_lists {
        encode_long_lists(p, groups, encoder, slot, c);
    }
}

/// The long lists: as many workgroups as finish_lists found lists too long to sort alone
/// (with two-level culling: as assign_clusters found lists too long to hold), sorted (or
/// written), in a compute pass that ends light assignment's timing.
fn encode_long_lists(
    p: &ComputePipelines,
    groups: &[Option<wgpu::BindGroup>],
    encoder: &mut wgpu::CommandEncoder,
    slot: Option<TimestampSlot<'_>>,
    c: &ClusterBuffers,
) {
    encoder.copy_buffer_to_buffer(&c.sort_jobs, 0, &c.sort_dispatch, 0, DISPATCH_ARGS_BYTES);
    let mut cp = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some("long lists"),
        timestamp_writes: TimestampSlot::compute_part(slot, true),
    });
    set_compute_groups(&mut cp, groups);
    cp.set_pipeline(p.get(if c.big_tiles.is_some() {
        "fill_long_lists"
    } else {
        "sort_long_lists"
    }));
    cp.dispatch_workgroups_indirect(&c.sort_dispatch, 0);
}

/// A compute pass of rasterised binning's light assignment, its bind groups set.
fn begin_assignment<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    groups: &[Option<wgpu::BindGroup>],
    timestamps: Option<wgpu::ComputePassTimestampWrites<'e>>,
) -> wgpu::ComputePass<'e> {
    let mut cp = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some("light assignment"),
        timestamp_writes: timestamps,
    });
    set_compute_groups(&mut cp, groups);
    cp
}

/// Rasterised binning's light assignment: view-space lights and their proxies in light
/// order (compute: count, place, write), the draw that counts and records the pairs, the
/// prefix sum (compute), the pairs scattered into the lists and the lists left out of order
/// marked (indirect dispatches), then lists finished, and the marked ones sorted, as the
/// compute method's.
fn encode_binning(
    p: &ComputePipelines,
    binning: Option<&BinningPipelines>,
    groups: &[Option<wgpu::BindGroup>],
    encoder: &mut wgpu::CommandEncoder,
    slot: Option<TimestampSlot<'_>>,
    c: &ClusterBuffers,
    lights: u32,
) {
    // Both are made with the pass whenever its variant culls by rasterised binning.
    let (Some(binning), Some(target)) = (binning, &c.bin_target) else {
        unreachable!("rasterised binning without its draw or target");
    };
    {
        let mut cp = begin_assignment(encoder, groups, TimestampSlot::compute_part(slot, false));
        for (entry, workgroups) in [
            ("transform_lights", dispatch_size(lights, 64)),
            ("count_proxies", dispatch_size(lights, 64)),
            ("place_proxies", 1),
            ("split_lights", dispatch_size(lights, 64)),
        ] {
            cp.set_pipeline(p.get(entry));
            cp.dispatch_workgroups(workgroups, 1, 1);
        }
    }
    encoder.copy_buffer_to_buffer(&c.proxy_draw, 0, &c.proxy_draw_args, 0, 16);
    encoder.copy_buffer_to_buffer(&c.light_proxies, 0, &c.proxy_instances, 0, None);
    {
        let mut rp = begin_render(
            encoder,
            "light binning",
            &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Discard,
                },
            })],
            None,
            None,
            groups,
        );
        rp.set_pipeline(&binning.draw);
        rp.set_vertex_buffer(0, c.proxy_instances.slice(..));
        rp.draw_indirect(&c.proxy_draw_args, 0);
    }
    {
        let mut cp = begin_assignment(encoder, groups, None);
        cp.set_pipeline(p.get("scan_local"));
        cp.dispatch_workgroups(dispatch_size(c.clusters, SCAN_BLOCK), 1, 1);
        cp.set_pipeline(p.get("scan_blocks"));
        cp.dispatch_workgroups(1, 1, 1);
        cp.set_pipeline(p.get("size_pair_passes"));
        cp.dispatch_workgroups(1, 1, 1);
    }
    encoder.copy_buffer_to_buffer(
        &c.proxy_draw,
        SCATTER_DISPATCH_AT,
        &c.scatter_dispatch,
        0,
        DISPATCH_ARGS_BYTES,
    );
    {
        let mut cp = begin_assignment(encoder, groups, None);
        for entry in ["scatter_pairs", "find_unsorted"] {
            cp.set_pipeline(p.get(entry));
            cp.dispatch_workgroups_indirect(&c.scatter_dispatch, 0);
        }
        cp.set_pipeline(p.get("finish_lists"));
        cp.dispatch_workgroups(dispatch_size(c.clusters, 64), 1, 1);
    }
    encode_long_lists(p, groups, encoder, slot, c);
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
