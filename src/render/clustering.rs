//! The clustering family: compute passes that fit the depth range, mark active clusters,
//! build cluster boxes and assign lights (each culling method's plan in `culling/`). The
//! buffers they clear and their dispatches; workgroup counts from each entry point's
//! workgroup size in the pass's naga module.

use super::bindings::Binding;
use super::clusters::{ClusterBuffers, ClusterStats, WORD_BYTES};
use super::culling::{self, BinningPipelines, ListWork};
use super::frame::{Over, Work};
use super::passes::{ComputePipelines, set_compute_groups};
use crate::compose::ClusterPass;
use crate::gpu::TimestampSlot;

/// What a clustering pass dispatches over.
pub struct Extent {
    pub width: u32,
    pub height: u32,
    pub lights: u32,
    /// The lights of the moving set (`MovingSet`): StaticDynamic's moving lights, or the
    /// lights Patch moves this frame.
    pub moving: u32,
    /// The light BVH is refitted over its last order (`clusters.update: Refit`).
    pub refit: bool,
}

/// Encode one clustering pass as its frame step says (`work`): clear what it accumulates
/// into, then its dispatches, or the culling method's plan for the lists. `c` is
/// the lists the pass builds: the clusters' own, or StaticDynamic's moving lists.
#[allow(clippy::too_many_arguments)]
pub fn encode(
    pass: ClusterPass,
    work: &Work,
    p: &ComputePipelines,
    binning: Option<&BinningPipelines>,
    groups: &[Option<wgpu::BindGroup>],
    encoder: &mut wgpu::CommandEncoder,
    slot: Option<TimestampSlot<'_>>,
    c: &ClusterBuffers,
    extent: &Extent,
) {
    let pixels = [extent.width, extent.height, 1];
    let dispatches = match work {
        Work::Lists(_) => {
            let work = match pass {
                ClusterPass::MovingAssign => ListWork::Moving {
                    moving: extent.moving,
                },
                ClusterPass::ListPatch => ListWork::Patch {
                    moved: extent.moving,
                },
                _ => ListWork::Assign {
                    lights: extent.lights,
                    refit: extent.refit,
                },
            };
            return culling::encode(work, p, binning, groups, encoder, slot, c);
        }
        Work::Dispatches(d) => d,
        _ => return,
    };
    if pass == ClusterPass::MarkActive {
        encoder.clear_buffer(&c.active, 0, None);
        for name in [
            Binding::SampleDepths,
            Binding::DepthMasks,
            Binding::BigTileDepths,
        ] {
            if let Some(buffer) = c.buffer(name) {
                encoder.clear_buffer(buffer, 0, None);
            }
        }
    }
    let mut cp = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(<&str>::from(pass)),
        timestamp_writes: TimestampSlot::compute(slot),
    });
    set_compute_groups(&mut cp, groups);
    for &(entry, over) in dispatches {
        let [x, y, z] = match over {
            Over::Pixels => p.groups_for(entry, pixels),
            Over::Clusters => p.groups_for(entry, [c.clusters, 1, 1]),
            Over::OneGroup => [1, 1, 1],
        };
        cp.set_pipeline(p.get(entry));
        cp.dispatch_workgroups(x, y, z);
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
    let at = std::mem::offset_of!(ClusterStats, active_clusters) as u64;
    encoder.clear_buffer(&c.stats, at, Some(WORD_BYTES));
    let mut cp = encoder.begin_compute_pass(&Default::default());
    set_compute_groups(&mut cp, groups);
    cp.set_pipeline(p.get("mark_visible"));
    let [x, y, z] = p.groups_for("mark_visible", [extent.width, extent.height, 1]);
    cp.dispatch_workgroups(x, y, z);
}
