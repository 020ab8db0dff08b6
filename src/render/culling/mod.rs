//! How light assignment builds a frame's light lists: one module per method, each a plan of
//! its clears and steps (entry points, what they dispatch over, copies, a draw), chosen by
//! one exhaustive match on the variant's method (`Clusters::method`). The steps run in order
//! ([`encode`]); workgroup counts come from each entry point's workgroup size in the pass's
//! naga module.

mod bvh;
mod one_level;
mod patch;
mod rasterised;
mod steps;
mod two_level;
mod zbinning;

pub use rasterised::BinningPipelines;

use crate::render::bindings::Binding;
use steps::{Clear, Over, Plan, Step};

use super::clusters::{ClusterBuffers, ProxyDrawing, Sizing};
use super::error::RenderError;
use super::passes::{ComputePipelines, set_compute_groups};
use crate::compose::ComposedPass;
use crate::gpu::{Gpu, GpuError, TimestampSlot};
use crate::render::reflect::BufferSizes;

use crate::cpu::clusters::ClusterLists;
use crate::cpu::zbin::ZBins;
use crate::variant::CullingMethod;

impl CullingMethod {
    /// Refuse a frame of `lights` lights the method's buffers (`sizes`, as its passes
    /// declare them) cannot hold.
    pub fn check(
        self,
        gpu: &Gpu,
        grid: (u32, u32, u32),
        lights: usize,
        sizes: &BufferSizes,
    ) -> Result<(), GpuError> {
        match self {
            CullingMethod::OneLevel
            | CullingMethod::TwoLevel { .. }
            | CullingMethod::Rasterised => Ok(()),
            CullingMethod::Bvh => bvh::check(gpu, lights, sizes),
            CullingMethod::ZBinning => zbinning::check(gpu, grid, lights, sizes),
        }
    }

    /// The buffers only this method binds (its own root's and its own module's), by the
    /// names they are declared by, with the elements each holds.
    pub fn own_buffers(self, s: &Sizing) -> Vec<(Binding, u64)> {
        match self {
            CullingMethod::OneLevel => Vec::new(),
            CullingMethod::TwoLevel { big_tile } => two_level::own_buffers(s, big_tile),
            CullingMethod::Rasterised => rasterised::own_buffers(s),
            CullingMethod::ZBinning => zbinning::own_buffers(s),
            CullingMethod::Bvh => bvh::own_buffers(s.lights),
        }
    }

    /// The pipelines of light assignment's draws, with rasterised binning (laid out as
    /// `drawing` says); None for the methods that only dispatch.
    pub(in crate::render) fn draw_pipelines(
        self,
        gpu: &Gpu,
        pass: &ComposedPass,
        layout: &wgpu::PipelineLayout,
        drawing: Option<&ProxyDrawing>,
    ) -> Result<Option<BinningPipelines>, RenderError> {
        match self {
            CullingMethod::Rasterised => {
                rasterised::pipelines(gpu, pass, layout, drawing).map(Some)
            }
            CullingMethod::OneLevel
            | CullingMethod::TwoLevel { .. }
            | CullingMethod::ZBinning
            | CullingMethod::Bvh => Ok(None),
        }
    }

    /// The clears and steps of light assignment for `lights` lights (`refit`: the light
    /// BVH refitted over its last order instead of sorted and built).
    fn plan(self, c: &ClusterBuffers, lights: u32, refit: bool) -> Plan<'_> {
        match self {
            CullingMethod::OneLevel => one_level::plan(c, lights),
            CullingMethod::TwoLevel { big_tile } => two_level::plan(c, lights, big_tile),
            CullingMethod::ZBinning => zbinning::plan(c, lights),
            CullingMethod::Rasterised => rasterised::plan(c, lights),
            CullingMethod::Bvh => bvh::plan(c, lights, refit),
        }
    }
}

/// Reading the lists back: z-binning keeps none (a pixel walks its bin), so its counts
/// and lists are made from its bins and tile masks.
impl ClusterBuffers {
    /// Z-binning's sorted lights, bins and tile masks as the GPU holds them.
    pub fn read_zbins(&self, gpu: &Gpu) -> Result<ZBins, GpuError> {
        zbinning::read(self, gpu)
    }

    /// Lights in each cluster's list (z-binning: lights a pixel of each tile and bin walks).
    pub fn read_counts(&self, gpu: &Gpu) -> Result<Vec<u32>, GpuError> {
        if !self.method.builds_lists() {
            return Ok(self.read_zbins(gpu)?.counts());
        }
        let n = self.declared_bytes(Binding::LightCounts, self.clusters as u64);
        self.read_named(gpu, Binding::LightCounts, Some(n))
    }

    /// The light lists as the GPU holds them (z-binning: each tile and bin's walk, sorted).
    pub fn read_lists(&self, gpu: &Gpu) -> Result<ClusterLists, GpuError> {
        if !self.method.builds_lists() {
            return Ok(self.read_zbins(gpu)?.lists());
        }
        let n = self.clusters as u64;
        let counts = self.read_named(
            gpu,
            Binding::LightCounts,
            Some(self.declared_bytes(Binding::LightCounts, n)),
        )?;
        let offsets = self.read_named(
            gpu,
            Binding::LightOffsets,
            Some(self.declared_bytes(Binding::LightOffsets, n)),
        )?;
        // Lists lie anywhere in the index buffer (two-level places them as it goes, Patch
        // moves the ones it changes): up to the end of the last.
        let end = counts
            .iter()
            .zip(&offsets)
            .map(|(&c, &o)| self.declared_bytes(Binding::LightIndices, o as u64 + c as u64))
            .max()
            .unwrap_or(0);
        let used = end.min(self.named(Binding::LightIndices).size());
        let indices = self.read_named(gpu, Binding::LightIndices, Some(used))?;
        let stats = self.read_stats(gpu)?;
        Ok(ClusterLists {
            max_per_cluster: counts.iter().copied().max().unwrap_or(0),
            counts,
            offsets,
            indices,
            dropped: stats.dropped as u64,
        })
    }
}

/// What one light-list pass of a frame does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ListWork {
    /// The light BVH's build alone (its lights' ranges, sort, nodes and bounds), timed
    /// apart from a frame (`Renderer::time_light_bvh_build`).
    BuildBvh { lights: u32 },
    /// The variant's method builds every list over `lights` lights (the BVH `refit` over
    /// its last order, where the frame refits).
    Assign { lights: u32, refit: bool },
    /// One-level assignment of StaticDynamic's moving lists over `moving` lights (the
    /// moving set's buffers, `lists` their lists).
    Moving { moving: u32 },
    /// Patch: the lists moved along with `moved` lights.
    Patch { moved: u32 },
}

/// Encode one light-list pass (`work`): its clears, then its steps. The first compute pass
/// writes the beginning timestamp and the last the end (one pass writes both).
#[allow(clippy::too_many_arguments)]
pub fn encode(
    work: ListWork,
    p: &ComputePipelines,
    binning: Option<&BinningPipelines>,
    groups: &[Option<wgpu::BindGroup>],
    encoder: &mut wgpu::CommandEncoder,
    slot: Option<TimestampSlot<'_>>,
    c: &ClusterBuffers,
) {
    let plan = match work {
        ListWork::Assign { lights, refit } => c.method.plan(c, lights, refit),
        ListWork::BuildBvh { lights } => bvh::build(c, lights, false),
        ListWork::Moving { moving } => one_level::plan(c, moving),
        ListWork::Patch { moved } => patch::plan(c, moved),
    };
    for Clear(buffer, at, bytes) in &plan.clears {
        encoder.clear_buffer(buffer, *at, *bytes);
    }
    // Compute passes: a run of dispatches between copies and draws.
    let mut passes = 0;
    let mut in_pass = false;
    for step in &plan.steps {
        let dispatch = matches!(step, Step::Dispatch(..) | Step::Indirect(..));
        passes += usize::from(dispatch && !in_pass);
        in_pass = dispatch;
    }
    let mut steps = plan.steps.iter().peekable();
    let mut pass = 0;
    while let Some(step) = steps.next() {
        match step {
            Step::Copy(from, at, to, bytes) => {
                encoder.copy_buffer_to_buffer(from, *at, to, 0, *bytes)
            }
            Step::DrawProxies => {
                // Made with the pass whenever its variant culls by rasterised binning.
                let binning = binning.expect("rasterised binning without its draw");
                rasterised::draw(binning, groups, encoder, c);
            }
            Step::Dispatch(..) | Step::Indirect(..) => {
                pass += 1;
                let timestamps = match (pass == 1, pass == passes) {
                    (true, true) => TimestampSlot::compute(slot),
                    (true, false) => TimestampSlot::compute_part(slot, false),
                    (false, true) => TimestampSlot::compute_part(slot, true),
                    (false, false) => None,
                };
                let mut cp = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("light assignment"),
                    timestamp_writes: timestamps,
                });
                set_compute_groups(&mut cp, groups);
                let mut next = Some(step);
                while let Some(step) = next {
                    match step {
                        Step::Dispatch(entry, over) => {
                            let [x, y, z] = match *over {
                                Over::Threads(x, y) => p.groups_for(entry, [x, y, 1]),
                                Over::Groups(x, y, z) => [x, y, z],
                            };
                            cp.set_pipeline(p.get(entry));
                            cp.dispatch_workgroups(x, y, z);
                        }
                        Step::Indirect(entry, args) => {
                            cp.set_pipeline(p.get(entry));
                            cp.dispatch_workgroups_indirect(args, 0);
                        }
                        Step::Copy(..) | Step::DrawProxies => unreachable!("not a dispatch"),
                    }
                    next = steps.next_if(|s| matches!(s, Step::Dispatch(..) | Step::Indirect(..)));
                }
            }
        }
    }
}
