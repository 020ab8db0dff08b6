//! The light lists: grown to fit when a frame overflows them, and built on the CPU for
//! variants with `assignment: Cpu`.

use std::time::Instant;

use super::{ClusterBuffers, ClusterStats, FrameRun, RenderError, Renderer};
use crate::compose::WALK_CUT_SHORT;
use crate::cpu::clusters::{self as cpu_clusters, Grid};
use crate::gpu::{Gpu, GpuError};
use crate::scene::Scene;
use crate::variant::{LightLists, Variant};

/// CPU light assignment state: the grid and its boxes (built once), the view-space lights.
pub struct CpuAssignment {
    grid: Grid,
    bounds: Vec<Option<cpu_clusters::Aabb>>,
    lights: Vec<cpu_clusters::ViewLight>,
    spot_test: crate::common::SpotTest,
    cap: Option<u32>,
}

impl CpuAssignment {
    pub fn new(variant: &Variant, scene: &Scene) -> Self {
        let grid = Grid::of(variant, scene);
        CpuAssignment {
            bounds: cpu_clusters::cluster_bounds(&grid),
            grid,
            lights: cpu_clusters::view_lights(&scene.lights, scene.camera.view()),
            spot_test: variant.clusters().spot_test,
            cap: match variant.clusters().lists {
                LightLists::Exact => None,
                LightLists::Capped { max_per_cluster } => Some(max_per_cluster),
            },
        }
    }
}

impl Renderer<'_> {
    /// After a frame: if the light lists overflowed the index buffer, grow it to fit and
    /// say so (the caller runs the frame again); else check its walks against the loop
    /// budget.
    fn grow_lists_if_needed(&mut self) -> Result<bool, RenderError> {
        let gpu = self.gpu;
        let Some(c) = &mut self.res.clusters else {
            return Ok(false);
        };
        let s = c.read_stats(gpu)?;
        // Proxies left out leave lists short too: that is the frame's first problem.
        check_proxies(gpu, &s)?;
        if s.overflow == 0 {
            check_walks(gpu, c, &s)?;
            return Ok(false);
        }
        // Every buffer sized by the entries must bind: the indices, and rasterised binning's
        // pairs (12 bytes an entry).
        let limit = gpu.limits.max_storage_buffer_binding_size / c.bytes_per_entry();
        if s.total as u64 > limit {
            return Err(RenderError::Gpu(GpuError::TooLarge(format!(
                "the light lists need {} entries, more than adapter `{}` can bind ({limit} entries of {} bytes); use fewer lights, a coarser grid or a per-cluster cap",
                s.total,
                gpu.adapter.name,
                c.bytes_per_entry()
            ))));
        }
        let needed = (s.total as u64 + s.total as u64 / 4 + 1024).min(limit);
        c.grow_indices(gpu, needed as u32);
        self.reallocations += 1;
        self.remake_groups()?;
        Ok(true)
    }

    /// Run the frame until its light lists fit: the index buffer grows to the exact total a
    /// frame reports, so one re-run fits; lists that still do not fit are an error, never a
    /// picture with lights missing.
    pub(super) fn run_fitted(&mut self, instrumented: bool) -> Result<FrameRun, RenderError> {
        let mut frame = self.run_frame(instrumented)?;
        let mut runs = 1;
        while self.grow_lists_if_needed()? {
            if runs == 3 {
                return Err(RenderError::Gpu(GpuError::Captured(
                    "the light lists still overflowed their buffer after growing it twice".into(),
                )));
            }
            frame = self.run_frame(instrumented)?;
            runs += 1;
        }
        Ok(frame)
    }

    /// Build and upload the light lists on the CPU (variants with `assignment: Cpu`).
    pub(super) fn assign_on_cpu(&mut self) -> Result<Option<f64>, RenderError> {
        let Some(cpu) = &self.cpu_assignment else {
            return Ok(None);
        };
        let start = Instant::now();
        let lists = cpu_clusters::assign(
            &cpu.grid,
            &cpu.bounds,
            &cpu.lights,
            cpu.spot_test,
            cpu.cap,
            None,
            None,
        );
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let c = self.res.clusters.as_mut().expect("clustered");
        if !c.upload_lists(self.gpu, &lists) {
            c.grow_indices(self.gpu, lists.indices.len() as u32 + 1024);
            self.reallocations += 1;
            self.remake_groups()?;
            let c = self.res.clusters.as_ref().expect("clustered");
            c.upload_lists(self.gpu, &lists);
        }
        Ok(Some(ms))
    }
}

/// Refuse a frame that looped past the adapter's loop budget (llvmpipe ends an invocation's
/// loops after a fixed count in all, without a word): its longest light list, which a
/// pixel's light loop walks, or its longest walk of light assignment (through light bitmasks
/// or the light BVH; `ClusterStats::longest_walk`). Budgeting what the
/// frame built, not a list of every light, lets a clustered frame hold any number of lights
/// whose lists fit. The longest list is named, from the read-back counts.
fn check_walks(gpu: &Gpu, c: &ClusterBuffers, s: &ClusterStats) -> Result<(), RenderError> {
    let Some(budget) = crate::gpu::expect::max_lights_per_pixel(gpu) else {
        return Ok(());
    };
    if s.max_per_cluster.max(s.longest_walk) <= budget {
        return Ok(());
    }
    let counts = c.read_counts(gpu)?;
    let (cluster, lights) = counts
        .iter()
        .enumerate()
        .max_by_key(|&(i, n)| (*n, std::cmp::Reverse(i)))
        .map_or((0, 0), |(i, n)| (i as u32, *n));
    let (x, y) = (c.grid.0, c.grid.1);
    // A walk cut short counted only the lights it reached.
    let cut = s.longest_walk == WALK_CUT_SHORT;
    let longest = format!(
        "cluster {cluster} (tile {}, {}, slice {}) holds {}{lights} lights",
        cluster % x,
        cluster / x % y,
        cluster / (x * y),
        if cut { "at least " } else { "" }
    );
    let what = if cut {
        format!("a light-assignment walk was cut short ({longest})")
    } else if s.longest_walk > budget {
        let w = s.longest_walk;
        format!("a light-assignment walk takes {w} iterations ({longest})")
    } else {
        longest
    };
    Err(RenderError::Gpu(GpuError::TooLarge(format!(
        "{what}: adapter `{}` ends a shader's loops after {} iterations in all, so this frame would leave lights out without a word (at most {budget} a loop here); use smaller lights, a finer grid or scissor deferred",
        gpu.adapter.name,
        crate::gpu::expect::LLVMPIPE_LOOP_ITERATIONS,
    ))))
}

/// Refuse a frame of more rasterised-binning proxies than the largest buffer the adapter
/// binds holds (the buffer is sized for a proxy per light and slice, up to that size; most
/// lights span a few slices, so most frames past that worst case still fit).
fn check_proxies(gpu: &Gpu, s: &ClusterStats) -> Result<(), RenderError> {
    if s.proxies_unheld == 0 {
        return Ok(());
    }
    let bytes = s.proxies_unheld as u64 * super::clusters::PROXY_BYTES;
    Err(RenderError::Gpu(GpuError::TooLarge(format!(
        "rasterised binning's {} light proxies this frame take {bytes} bytes, more than the {} bytes adapter `{}` allows in one buffer; use fewer slices or lights",
        s.proxies_unheld,
        gpu.max_storage_bytes(),
        gpu.adapter.name
    ))))
}
