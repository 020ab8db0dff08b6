//! The light lists: whether a frame's fit (or how far they must grow, or why they cannot),
//! and built on the CPU for variants with `assignment: Cpu`.

use std::time::Instant;

use super::error::RenderError;
use super::{ClusterBuffers, ClusterStats};
use crate::compose::WALK_CUT_SHORT;
use crate::cpu::clusters::{self as cpu_clusters, ClusterLists, Grid};
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

    /// The light lists, built on the CPU, and the milliseconds it took.
    pub fn assign(&self) -> (ClusterLists, f64) {
        let start = Instant::now();
        let lists = cpu_clusters::assign(
            &self.grid,
            &self.bounds,
            &self.lights,
            self.spot_test,
            self.cap,
            None,
            None,
        );
        (lists, start.elapsed().as_secs_f64() * 1e3)
    }
}

/// Whether a frame's light lists fit: they did, or the index buffer must grow to this many
/// entries and the frame run again.
pub enum Fit {
    /// They fit, and hold this many entries (where the last list ends, for lists placed
    /// as they go).
    Fits {
        entries: u32,
    },
    GrowTo(u32),
}

/// After a frame: whether its lists fit the index buffer (from its counters), or how far
/// the buffer must grow; an error where they cannot fit, or where the frame left proxies
/// out or looped past the loop budget.
pub fn fit(gpu: &Gpu, c: &ClusterBuffers) -> Result<Fit, RenderError> {
    let s = c.read_stats(gpu)?;
    // Proxies left out leave lists short too: that is the frame's first problem.
    check_proxies(gpu, c, &s)?;
    if s.overflow == 0 {
        check_walks(gpu, c, &s)?;
        return Ok(Fit::Fits { entries: s.total });
    }
    Ok(Fit::GrowTo(capacity_for(gpu, c, s.total as u64)?))
}

/// The index buffer's entries for lists of `entries` entries, with room to spare: an error
/// where they cannot bind. Every buffer sized by the entries must: the indices, and
/// rasterised binning's pair arrays, at their declared bytes an entry.
pub fn capacity_for(gpu: &Gpu, c: &ClusterBuffers, entries: u64) -> Result<u32, RenderError> {
    let entry = c.bytes_per_entry().max(1);
    let limit = (gpu.limits.max_storage_buffer_binding_size / entry).min(u32::MAX as u64);
    if entries > limit {
        return Err(RenderError::Gpu(GpuError::TooLarge(format!(
            "the light lists need {entries} entries, more than adapter `{}` can bind ({limit} entries of {entry} bytes); use fewer lights, a coarser grid or a per-cluster cap",
            gpu.adapter.name,
        ))));
    }
    Ok((entries + entries / 4 + 1024).min(limit) as u32)
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
fn check_proxies(gpu: &Gpu, c: &ClusterBuffers, s: &ClusterStats) -> Result<(), RenderError> {
    let Some(d) = c.drawing.as_ref().filter(|_| s.proxies_unheld != 0) else {
        return Ok(());
    };
    let bytes = s.proxies_unheld as u64 * d.layout.proxy_bytes;
    Err(RenderError::Gpu(GpuError::TooLarge(format!(
        "rasterised binning's {} light proxies this frame take {bytes} bytes, more than the {} bytes adapter `{}` allows in one buffer; use fewer slices or lights",
        s.proxies_unheld,
        gpu.max_storage_bytes(),
        gpu.adapter.name
    ))))
}
