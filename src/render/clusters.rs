//! Cluster buffers on the GPU: bounds, light counts, offsets and indices, the clustered
//! depth range, and the assignment counters. Mirrors `shaders/clustering/build_bindings.wesl`.

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::cpu::clusters::ClusterLists;
use crate::cpu::zbin::ZBins;
use crate::gpu::{Gpu, GpuError, read_buffer};
use crate::render::culling::ProxyLayout;
use crate::variant::CullingMethod;
use crate::variant::{Clusters, Culling};

/// Mirrors `ClusterRange` in `shaders/clustering/clusters.wesl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ClusterRange {
    pub near: f32,
    pub far: f32,
    pub min_bits: u32,
    pub max_bits: u32,
}

impl ClusterRange {
    /// A static range, with the reduction scratch reset.
    pub fn new(near: f32, far: f32) -> Self {
        Self {
            near,
            far,
            min_bits: u32::MAX,
            max_bits: 0,
        }
    }
}

/// Mirrors `ClusterStats` in `shaders/clustering/build_bindings.wesl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ClusterStats {
    pub total: u32,
    pub dropped: u32,
    pub active_clusters: u32,
    pub max_per_cluster: u32,
    pub overflow: u32,
    pub longest_walk: u32,
    pub proxies_unheld: u32,
    pub _pad: u32,
}

/// Bytes of an indirect dispatch's arguments (x, y, z).
pub const DISPATCH_ARGS_BYTES: u64 = 12;

pub struct ClusterBuffers {
    pub clusters: u32,
    pub range: wgpu::Buffer,
    pub bounds: wgpu::Buffer,
    pub active: wgpu::Buffer,
    pub counts: wgpu::Buffer,
    pub offsets: wgpu::Buffer,
    pub block_sums: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    pub stats: wgpu::Buffer,
    pub light_view: wgpu::Buffer,
    pub light_ranges: wgpu::Buffer,
    pub fill_cursors: wgpu::Buffer,
    pub sample_depths: wgpu::Buffer,
    /// The long lists to sort, or with two-level culling to write (`SortJobs` in
    /// build_bindings.wesl): a 16-byte header, then (cluster, entries) each.
    pub sort_jobs: wgpu::Buffer,
    /// The indirect dispatch of the long-list sort, copied from `sort_jobs`' header (a
    /// buffer cannot be bound for storage and read as indirect arguments in one dispatch).
    pub sort_dispatch: wgpu::Buffer,
    /// Entries the index buffer holds.
    pub index_capacity: u32,
    /// 2.5D culling: each cluster's mask of depth cells that hold a sample.
    pub depth_masks: wgpu::Buffer,
    /// Z-binning: lights in depth order, each bin's range of them, each tile's mask.
    pub light_order: wgpu::Buffer,
    pub bin_ranges: wgpu::Buffer,
    pub tile_masks: wgpu::Buffer,
    /// Two-level culling: per big tile, a mask of the lights that survive its coarse test.
    pub coarse_masks: wgpu::Buffer,
    /// Two-level culling with active clusters: each big tile's sample depth range.
    pub big_tile_depths: wgpu::Buffer,
    /// Rasterised binning: the lights' proxies in light order (`split_lights`), and their
    /// indirect draw with the pair count and the scatter's dispatch (`ProxyDraw` in
    /// build_bindings.wesl).
    pub light_proxies: wgpu::Buffer,
    pub proxy_draw: wgpu::Buffer,
    /// Rasterised binning: each light's proxy count, then its first proxy's place.
    pub proxy_places: wgpu::Buffer,
    /// Copies of those the draw reads as instances and indirect arguments, and of the
    /// scatter's dispatch (a buffer bound for storage in a pass cannot also be its vertex
    /// or indirect buffer).
    pub proxy_instances: wgpu::Buffer,
    pub proxy_draw_args: wgpu::Buffer,
    pub scatter_dispatch: wgpu::Buffer,
    /// Rasterised binning: its buffers' layouts as its root declares them.
    pub proxy_layout: Option<ProxyLayout>,
    /// Rasterised binning: the one-pixel-per-tile target the proxies are drawn into.
    pub bin_target: Option<wgpu::TextureView>,
    /// The buffers only the method's own shader root declares, by that name
    /// (`CullingMethod::own_buffers`).
    pub own: Vec<(&'static str, wgpu::Buffer)>,
    /// The grid: tiles across, tiles down, slices (z-binning's bins).
    pub grid: (u32, u32, u32),
    pub lights: u32,
    pub culling: Culling,
    /// How light assignment builds the lists.
    pub method: CullingMethod,
}

/// A cluster's samples on the GPU: their depth range [z0, z1] (z1 = 0 where it holds none)
/// and the mask of depth cells that hold one (2.5D culling; zero without it).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpuDepthMask {
    pub range: [f32; 2],
    pub mask: u32,
}

/// Format of rasterised binning's target (its colour is never read).
pub const BIN_TARGET_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R8Unorm;

/// Size of rasterised binning's target: an atlas of a pixel per tile for each slice, at
/// most 8 slices across (`atlas_columns` in raster_bin.wesl). At most 1024 x 4096 pixels
/// (`variant::MAX_GRID_XY`, `MAX_GRID_Z`).
fn bin_target_size(grid: (u32, u32, u32)) -> (u32, u32) {
    let columns = grid.2.min(8);
    (grid.0 * columns, grid.1 * grid.2.div_ceil(columns))
}


/// Bytes of two-level culling's coarse masks: for each big tile of `big` tiles a side, a
/// mask of `words` words and its summary, then a mask for each slice (`two_level.wesl`).
fn coarse_bytes(grid: (u32, u32, u32), big: u32, words: u64) -> u64 {
    let big_tiles = (grid.0.div_ceil(big) * grid.1.div_ceil(big)) as u64;
    (big_tiles * (words + words.div_ceil(32)) + grid.2 as u64 * words) * 4
}

/// The long lists' buffer (`SortJobs` in build_bindings.wesl), its dispatch header
/// (x, y, z, jobs) made (0, 1, 1, 0): frames reset only x and jobs (light assignment's
/// plan clears them, `culling/`).
fn sort_jobs(gpu: &Gpu, size: u64) -> wgpu::Buffer {
    let buffer = storage(gpu, "long lists", size);
    gpu.queue
        .write_buffer(&buffer, 4, bytemuck::cast_slice(&[1u32, 1u32]));
    buffer
}

/// The buffers only `method`'s shader root declares, by those names.
fn own_buffers(
    gpu: &Gpu,
    method: CullingMethod,
    grid: (u32, u32, u32),
    lights: u32,
    entries: u32,
) -> Vec<(&'static str, wgpu::Buffer)> {
    method
        .own_buffers(grid, lights, entries)
        .into_iter()
        .map(|(name, bytes)| (name, storage(gpu, name, bytes)))
        .collect()
}

fn storage(gpu: &Gpu, label: &str, size: u64) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

impl ClusterBuffers {
    /// The buffers of clusters `c` for `lights` lights (with rasterised binning, laid out
    /// as `proxies`, its root's declarations); the buffers its method does not use are
    /// 16-byte placeholders that no pass binds (layouts hold only what a pass declares).
    pub fn new(
        gpu: &Gpu,
        c: &Clusters,
        lights: u32,
        index_capacity: u32,
        range: ClusterRange,
        proxies: Option<ProxyLayout>,
    ) -> Self {
        let (grid, culling, method) = (c.grid, c.culling, c.method());
        let clusters = grid.0 * grid.1 * grid.2;
        let n = clusters as u64;
        let lists = method.builds_lists();
        let zbin = !lists;
        let raster = method == CullingMethod::Rasterised;
        let big_tiles = match method {
            CullingMethod::TwoLevel { big_tile } => Some(big_tile),
            _ => None,
        };
        // `bytes` where the method uses a buffer, a placeholder elsewhere.
        let sized = |used: bool, bytes: u64| if used { bytes } else { 16 };
        let index_capacity = if lists { index_capacity } else { 4 };
        let words = (lights as u64).div_ceil(32);
        // A proxy per light and slice at most, in the largest buffer the adapter binds: a
        // frame with more is refused after it runs (`ClusterStats::proxies_unheld`).
        let (proxy_bytes, draw_bytes) = match proxies.filter(|_| raster) {
            Some(p) => {
                let largest = gpu.max_storage_bytes() / p.proxy_bytes * p.proxy_bytes;
                let worst = lights.max(1) as u64 * grid.2 as u64 * p.proxy_bytes;
                (worst.min(largest), p.draw_bytes)
            }
            None => (16, 16),
        };
        let copy_of = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        Self {
            clusters,
            range: gpu
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("cluster range"),
                    contents: bytemuck::bytes_of(&range),
                    usage: wgpu::BufferUsages::STORAGE
                        | wgpu::BufferUsages::COPY_DST
                        | wgpu::BufferUsages::COPY_SRC,
                }),
            bounds: storage(gpu, "cluster bounds", sized(lists, n * 32)),
            active: storage(gpu, "active clusters", n * 4),
            counts: storage(gpu, "light counts", sized(lists, n * 4)),
            offsets: storage(gpu, "light offsets", sized(lists, n * 4)),
            block_sums: storage(
                gpu,
                "block sums",
                sized(lists, n.div_ceil(crate::compose::SCAN_BLOCK as u64) * 4),
            ),
            indices: storage(gpu, "light indices", index_capacity as u64 * 4),
            stats: storage(
                gpu,
                "cluster stats",
                std::mem::size_of::<ClusterStats>() as u64,
            ),
            light_view: storage(gpu, "view-space lights", lights.max(1) as u64 * 48),
            light_ranges: storage(gpu, "light cluster ranges", lights.max(1) as u64 * 16),
            fill_cursors: storage(gpu, "fill cursors", sized(lists, n * 4)),
            sample_depths: storage(gpu, "cluster sample depths", sized(lists, n * 8)),
            sort_jobs: sort_jobs(gpu, sized(lists, 16 + n * 8)),
            sort_dispatch: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("long-list sort dispatch"),
                size: DISPATCH_ARGS_BYTES,
                usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            index_capacity,
            depth_masks: storage(
                gpu,
                "depth masks",
                sized(culling.marks_depth_cells(), n * 4),
            ),
            light_order: storage(gpu, "light order", sized(zbin, lights as u64 * 4)),
            bin_ranges: storage(gpu, "bin ranges", sized(zbin, grid.2 as u64 * 8)),
            tile_masks: storage(
                gpu,
                "tile masks",
                sized(zbin, (grid.0 * grid.1) as u64 * words * 4),
            ),
            coarse_masks: storage(
                gpu,
                "coarse masks",
                big_tiles.map_or(16, |b| coarse_bytes(grid, b, words)),
            ),
            big_tile_depths: storage(
                gpu,
                "big tile depths",
                big_tiles.map_or(16, |b| (grid.0.div_ceil(b) * grid.1.div_ceil(b)) as u64 * 8),
            ),
            light_proxies: storage(gpu, "light proxies", proxy_bytes),
            proxy_draw: storage(gpu, "proxy draw", draw_bytes),
            proxy_places: storage(gpu, "proxy places", sized(raster, lights as u64 * 4)),
            proxy_instances: copy_of("proxy instances", proxy_bytes, wgpu::BufferUsages::VERTEX),
            proxy_draw_args: copy_of("proxy draw arguments", 16, wgpu::BufferUsages::INDIRECT),
            scatter_dispatch: copy_of(
                "pair scatter dispatch",
                DISPATCH_ARGS_BYTES,
                wgpu::BufferUsages::INDIRECT,
            ),
            proxy_layout: proxies.filter(|_| raster),
            bin_target: raster.then(|| {
                let atlas = bin_target_size(grid);
                gpu.device
                    .create_texture(&wgpu::TextureDescriptor {
                        label: Some("binning target"),
                        size: wgpu::Extent3d {
                            width: atlas.0,
                            height: atlas.1,
                            depth_or_array_layers: 1,
                        },
                        mip_level_count: 1,
                        sample_count: 1,
                        dimension: wgpu::TextureDimension::D2,
                        format: BIN_TARGET_FORMAT,
                        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                        view_formats: &[],
                    })
                    .create_view(&Default::default())
            }),
            own: own_buffers(gpu, method, grid, lights, index_capacity),
            grid,
            lights,
            culling,
            method,
        }
    }

    /// Bytes of all cluster data on the GPU.
    pub fn bytes(&self) -> u64 {
        [
            &self.range,
            &self.bounds,
            &self.active,
            &self.counts,
            &self.offsets,
            &self.block_sums,
            &self.indices,
            &self.stats,
            &self.light_view,
            &self.light_ranges,
            &self.fill_cursors,
            &self.sample_depths,
            &self.sort_jobs,
            &self.sort_dispatch,
            &self.depth_masks,
            &self.light_order,
            &self.bin_ranges,
            &self.tile_masks,
            &self.coarse_masks,
            &self.big_tile_depths,
            &self.light_proxies,
            &self.proxy_draw,
            &self.proxy_places,
            &self.proxy_instances,
            &self.proxy_draw_args,
            &self.scatter_dispatch,
        ]
        .into_iter()
        .chain(self.own.iter().map(|(_, b)| b))
        .map(|b| b.size())
        .sum()
    }

    /// Replace the index buffer with one of `capacity` entries, and the method's own
    /// buffers, which may be sized by the entries (bind groups must be remade).
    pub fn grow_indices(&mut self, gpu: &Gpu, capacity: u32) {
        self.indices = storage(gpu, "light indices", capacity as u64 * 4);
        self.own = own_buffers(gpu, self.method, self.grid, self.lights, capacity);
        self.index_capacity = capacity;
    }

    /// The buffer a cluster pass binds by `name`, the name `build_bindings.wesl` (and,
    /// read-only, `lookup.wesl`) declares it by: the slot numbers are written only there.
    pub fn buffer(&self, name: &str) -> Option<&wgpu::Buffer> {
        Some(match name {
            "cluster_range" => &self.range,
            "cluster_bounds" => &self.bounds,
            "cluster_active" => &self.active,
            "light_counts" => &self.counts,
            "light_offsets" => &self.offsets,
            "block_sums" => &self.block_sums,
            "light_indices" => &self.indices,
            "cluster_stats" => &self.stats,
            "light_view" => &self.light_view,
            "light_ranges" => &self.light_ranges,
            "fill_cursors" => &self.fill_cursors,
            "sample_depths" => &self.sample_depths,
            "sort_jobs" => &self.sort_jobs,
            "depth_masks" => &self.depth_masks,
            "light_order" => &self.light_order,
            "bin_ranges" => &self.bin_ranges,
            "tile_masks" => &self.tile_masks,
            "coarse_masks" => &self.coarse_masks,
            "big_tile_depths" => &self.big_tile_depths,
            "light_proxies" => &self.light_proxies,
            "proxy_draw" => &self.proxy_draw,
            "proxy_places" => &self.proxy_places,
            _ => return self.own.iter().find(|(n, _)| *n == name).map(|(_, b)| b),
        })
    }

    /// The buffer bound as `name`, as 32-bit words.
    pub fn read_words(&self, gpu: &Gpu, name: &str) -> Result<Vec<u32>, GpuError> {
        let buffer = self
            .buffer(name)
            .ok_or_else(|| GpuError::Captured(format!("no cluster buffer is named `{name}`")))?;
        Ok(bytemuck::cast_slice(&read_buffer(gpu, buffer, 0, buffer.size())?).to_vec())
    }

    pub fn read_stats(&self, gpu: &Gpu) -> Result<ClusterStats, GpuError> {
        let bytes = read_buffer(gpu, &self.stats, 0, self.stats.size())?;
        Ok(bytemuck::pod_read_unaligned(
            &bytes[..std::mem::size_of::<ClusterStats>()],
        ))
    }

    pub fn read_range(&self, gpu: &Gpu) -> Result<ClusterRange, GpuError> {
        let bytes = read_buffer(gpu, &self.range, 0, 16)?;
        Ok(bytemuck::pod_read_unaligned(&bytes))
    }

    /// Each cluster's view-space box as the GPU holds it: [min, max], xyz and a fourth word.
    pub fn read_bounds(&self, gpu: &Gpu) -> Result<Vec<[[f32; 4]; 2]>, GpuError> {
        let n = self.clusters as u64 * 32;
        let bytes = read_buffer(gpu, &self.bounds, 0, n)?;
        Ok(bytes
            .chunks_exact(32)
            .map(bytemuck::pod_read_unaligned)
            .collect())
    }

    /// Each cluster's samples as the GPU holds them (zero without sample bounds).
    pub fn read_depth_masks(&self, gpu: &Gpu) -> Result<Vec<GpuDepthMask>, GpuError> {
        let n = self.clusters as u64;
        if !self.method.builds_lists() {
            return Ok(vec![GpuDepthMask::default(); n as usize]);
        }
        let depths = read_buffer(gpu, &self.sample_depths, 0, n * 8)?;
        let depths: &[u32] = bytemuck::cast_slice(&depths);
        let masks = if self.culling.marks_depth_cells() {
            bytemuck::cast_slice(&read_buffer(gpu, &self.depth_masks, 0, n * 4)?).to_vec()
        } else {
            vec![0u32; n as usize]
        };
        Ok(depths
            .chunks_exact(2)
            .zip(masks)
            .map(|(d, m)| {
                let range = if d[1] == 0 {
                    [0.0, 0.0]
                } else {
                    [f32::from_bits(!d[0]), f32::from_bits(d[1])]
                };
                GpuDepthMask { range, mask: m }
            })
            .collect())
    }

    /// Z-binning's sorted lights, bins and tile masks as the GPU holds them.
    pub fn read_zbins(&self, gpu: &Gpu) -> Result<ZBins, GpuError> {
        let read = |b: &wgpu::Buffer, bytes: u64| -> Result<Vec<u32>, GpuError> {
            if bytes == 0 {
                return Ok(Vec::new());
            }
            Ok(bytemuck::cast_slice(&read_buffer(gpu, b, 0, bytes)?).to_vec())
        };
        let (x, y, z) = self.grid;
        let words = (self.lights as u64).div_ceil(32);
        Ok(ZBins::from_gpu(
            (x, y),
            read(&self.light_order, self.lights as u64 * 4)?,
            &read(&self.bin_ranges, z as u64 * 8)?,
            read(&self.tile_masks, (x * y) as u64 * words * 4)?,
        ))
    }

    /// Lights in each cluster's list (z-binning: lights a pixel of each tile and bin walks).
    pub fn read_counts(&self, gpu: &Gpu) -> Result<Vec<u32>, GpuError> {
        if !self.method.builds_lists() {
            return Ok(self.read_zbins(gpu)?.counts());
        }
        let n = self.clusters as u64 * 4;
        Ok(bytemuck::cast_slice(&read_buffer(gpu, &self.counts, 0, n)?).to_vec())
    }

    /// The light lists as the GPU holds them (z-binning: each tile and bin's walk, sorted).
    pub fn read_lists(&self, gpu: &Gpu) -> Result<ClusterLists, GpuError> {
        if !self.method.builds_lists() {
            return Ok(self.read_zbins(gpu)?.lists());
        }
        let n = self.clusters as u64 * 4;
        let counts: Vec<u32> =
            bytemuck::cast_slice(&read_buffer(gpu, &self.counts, 0, n)?).to_vec();
        let offsets: Vec<u32> =
            bytemuck::cast_slice(&read_buffer(gpu, &self.offsets, 0, n)?).to_vec();
        let total: u64 = counts.iter().map(|&c| c as u64).sum();
        let used = (total * 4).min(self.indices.size());
        let indices: Vec<u32> = if used == 0 {
            Vec::new()
        } else {
            bytemuck::cast_slice(&read_buffer(gpu, &self.indices, 0, used)?).to_vec()
        };
        let stats = self.read_stats(gpu)?;
        Ok(ClusterLists {
            max_per_cluster: counts.iter().copied().max().unwrap_or(0),
            counts,
            offsets,
            indices,
            dropped: stats.dropped as u64,
        })
    }

    /// Upload lists built on the CPU; returns false when the index buffer must grow first.
    pub fn upload_lists(&self, gpu: &Gpu, lists: &ClusterLists) -> bool {
        if lists.indices.len() as u64 > self.index_capacity as u64 {
            return false;
        }
        gpu.queue
            .write_buffer(&self.counts, 0, bytemuck::cast_slice(&lists.counts));
        gpu.queue
            .write_buffer(&self.offsets, 0, bytemuck::cast_slice(&lists.offsets));
        if !lists.indices.is_empty() {
            gpu.queue
                .write_buffer(&self.indices, 0, bytemuck::cast_slice(&lists.indices));
        }
        let stats = ClusterStats {
            total: lists.indices.len() as u32,
            dropped: lists.dropped as u32,
            max_per_cluster: lists.max_per_cluster,
            ..Default::default()
        };
        gpu.queue
            .write_buffer(&self.stats, 0, bytemuck::bytes_of(&stats));
        true
    }
}
