//! How light assignment builds a frame's light lists: one module per method, each a plan of
//! its clears and steps (entry points, what they dispatch over, copies, a draw), chosen by
//! one exhaustive match on the variant's method (`Clusters::method`). The steps run in order
//! ([`encode`]); workgroup counts come from each entry point's workgroup size in the pass's
//! naga module.

mod bvh;
mod one_level;
mod patch;
mod rasterised;
mod two_level;
mod zbinning;

pub use rasterised::{BinningPipelines, ProxyLayout};
pub(super) use zbinning::read as read_zbins;

use super::built::Pipelines;
use super::clusters::{ClusterBuffers, DISPATCH_ARGS_BYTES, ProxyDrawing, Sizing};
use super::error::RenderError;
use super::passes::{ComputePipelines, set_compute_groups};
use crate::compose::{ComposedPass, LIGHTS_PER_ROW};
use crate::cpu::sort::{SORT_BLOCK, merge_schedule, sorted_size};
use crate::gpu::{Gpu, GpuError, TimestampSlot};
use crate::render::reflect::BufferSizes;

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
    pub fn own_buffers(self, s: &Sizing) -> Vec<(&'static str, u64)> {
        match self {
            CullingMethod::OneLevel => Vec::new(),
            CullingMethod::TwoLevel { big_tile } => two_level::own_buffers(s, big_tile),
            CullingMethod::Rasterised => rasterised::own_buffers(s),
            CullingMethod::ZBinning => zbinning::own_buffers(s),
            CullingMethod::Bvh => bvh::own_buffers(s.lights),
        }
    }

    /// The pipelines of light assignment's pass: its entry points' (`compute`), and with
    /// rasterised binning its draws' too (laid out as `drawing` says).
    pub(in crate::render) fn assignment_pipelines(
        self,
        gpu: &Gpu,
        pass: &ComposedPass,
        layout: &wgpu::PipelineLayout,
        compute: ComputePipelines,
        drawing: Option<&ProxyDrawing>,
    ) -> Result<Pipelines, RenderError> {
        match self {
            CullingMethod::Rasterised => rasterised::pipelines(gpu, pass, layout, compute, drawing),
            CullingMethod::OneLevel
            | CullingMethod::TwoLevel { .. }
            | CullingMethod::ZBinning
            | CullingMethod::Bvh => Ok(Pipelines::Compute(compute)),
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

/// What one light-list pass of a frame does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ListWork {
    /// The variant's method builds every list over `lights` lights (the BVH `refit` over
    /// its last order, where the frame refits).
    Assign { lights: u32, refit: bool },
    /// One-level assignment of StaticDynamic's moving lists over `moving` lights (the
    /// moving set's buffers, `lists` their lists).
    Moving { moving: u32 },
    /// Patch: the lists moved along with `moved` lights.
    Patch { moved: u32 },
}

/// What light assignment runs: buffers (or parts of them) cleared first, then its steps.
struct Plan<'a> {
    clears: Vec<Clear<'a>>,
    steps: Vec<Step<'a>>,
}

/// A buffer cleared from byte `at`, `bytes` of it or to its end.
struct Clear<'a>(&'a wgpu::Buffer, u64, Option<u64>);

impl<'a> Clear<'a> {
    fn whole(buffer: &'a wgpu::Buffer) -> Self {
        Clear(buffer, 0, None)
    }

    /// The long lists' workgroup and job counts (the header's x and fourth word).
    fn long_lists(c: &'a ClusterBuffers) -> [Self; 2] {
        [
            Clear(c.named("sort_jobs"), 0, Some(4)),
            Clear(c.named("sort_jobs"), 12, Some(4)),
        ]
    }
}

/// One step of light assignment. Dispatches run in a compute pass; a copy or the draw ends
/// it, and the next dispatch begins another.
enum Step<'a> {
    /// Entry point `entry` over `Over`.
    Dispatch(&'static str, Over),
    /// Entry point `entry`, its workgroup count read from a buffer.
    Indirect(&'static str, &'a wgpu::Buffer),
    /// `bytes` (or all) of a buffer from byte `at`, to the start of another.
    Copy(&'a wgpu::Buffer, u64, &'a wgpu::Buffer, Option<u64>),
    /// Rasterised binning's draw of the light proxies.
    DrawProxies,
}

/// What a dispatch covers.
enum Over {
    /// One invocation per item (x, y), in workgroups of the entry's own size.
    Threads(u32, u32),
    /// Exactly this many workgroups.
    Groups(u32, u32, u32),
}

/// One workgroup per light, in rows of LIGHTS_PER_ROW.
fn per_light(lights: u32) -> Over {
    Over::Groups(
        lights.clamp(1, LIGHTS_PER_ROW),
        lights.div_ceil(LIGHTS_PER_ROW).max(1),
        1,
    )
}

/// The long lists at the end of one-level and rasterised assignment (sorted) and two-level
/// (written): as many workgroups as the passes before queued, in a compute pass of their own.
fn long_lists<'a>(c: &'a ClusterBuffers, entry: &'static str) -> [Step<'a>; 2] {
    [
        Step::Copy(
            c.named("sort_jobs"),
            0,
            &c.sort_dispatch,
            Some(DISPATCH_ARGS_BYTES),
        ),
        Step::Indirect(entry, &c.sort_dispatch),
    ]
}

/// The lights sorted by key (`clustering/sort.wesl`, shared by the BVH and z-binning):
/// each block sorted in a workgroup's memory, then each merge step, which carries its
/// place in the schedule as workgroups beyond the blocks.
fn sort_lights(lights: u32) -> Vec<Step<'static>> {
    let n = sorted_size(lights);
    let blocks = n / SORT_BLOCK;
    let mut steps = vec![Step::Dispatch("sort_blocks", Over::Groups(blocks, 1, 1))];
    for (s, (_, j)) in merge_schedule(n).into_iter().enumerate() {
        let entry = if j == 0 { "merge_blocks" } else { "merge_step" };
        steps.push(Step::Dispatch(entry, Over::Groups(blocks + s as u32, 1, 1)));
    }
    steps
}

/// The sort's order: a key and a light an entry.
fn sorted_lights(lights: u32) -> (&'static str, u64) {
    ("sorted_lights", sorted_size(lights) as u64)
}

/// Refuse a frame whose sorted order does not fit one buffer.
fn check_sorted(
    gpu: &Gpu,
    method: &str,
    lights: usize,
    sizes: &BufferSizes,
) -> Result<(), GpuError> {
    let (name, count) = sorted_lights(lights as u32);
    let bytes = sizes.bytes(name, count).unwrap_or(0);
    let max = gpu.max_storage_bytes();
    if bytes > max {
        return Err(GpuError::TooLarge(format!(
            "{method}'s sorted order of {lights} lights takes {bytes} bytes, more than the {max} bytes adapter `{}` allows in one buffer; use fewer lights",
            gpu.adapter.name
        )));
    }
    Ok(())
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
