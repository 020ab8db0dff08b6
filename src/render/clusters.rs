//! Cluster buffers on the GPU: bounds, light counts, offsets and indices, the clustered
//! depth range, and the assignment counters. Mirrors `shaders/clustering/build_bindings.wesl`.

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::compose::ComposedPass;
use crate::cpu::clusters::ClusterLists;
use crate::gpu::{Gpu, GpuError, read_buffer};
use crate::render::bindings::Binding;
use crate::render::reflect::BufferLayout;
use crate::render::reflect::BufferSizes;
use crate::variant::CullingMethod;
use crate::variant::{Clusters, Culling, ListUpdate};
use serde::Serialize;

/// Rasterised binning's buffer layouts as its shader root declares them, read off its naga
/// module: a proxy's bytes (`light_proxies`' stride, the draw's instance stride too), the
/// bytes of `ProxyDraw`, and where in it the scatter's dispatch starts (`scatter_x`).
#[derive(Clone, Copy, Debug)]
pub struct ProxyLayout {
    pub proxy_bytes: u64,
    pub draw_bytes: u64,
    pub scatter_at: u64,
}

impl ProxyLayout {
    /// The layout of light assignment pass `pass`; `None` where it declares no proxies.
    pub fn of(pass: &ComposedPass) -> Option<Self> {
        let draw = BufferLayout::of(pass, Binding::ProxyDraw)?;
        Some(Self {
            proxy_bytes: BufferLayout::of(pass, Binding::LightProxies)?.element_bytes,
            draw_bytes: draw.element_bytes,
            scatter_at: draw.offset("scatter_x")?,
        })
    }
}

/// The work of a frame's light assignment, the same on every machine (`clustering/work.wesl`):
/// what a change to assignment is judged by where its time measures a CPU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct AssignmentWork {
    /// Bounds tests of a light against one cluster, tile or big tile.
    pub light_tests: u64,
    /// Bounds tests of a light BVH node against a tile of clusters (or one cluster).
    pub node_tests: u64,
    /// Light-list entries stored (z-binning: tile-mask bits set).
    pub entries_written: u64,
    /// Lights whose range holds no cluster, dropped before any per-cluster work.
    pub lights_rejected: u64,
}

impl AssignmentWork {
    /// Light and node tests per light of a frame of `lights` lights.
    pub fn tests_per_light(&self, lights: usize) -> f64 {
        (self.light_tests + self.node_tests) as f64 / lights.max(1) as f64
    }
}

impl std::ops::Add for AssignmentWork {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        AssignmentWork {
            light_tests: self.light_tests + o.light_tests,
            node_tests: self.node_tests + o.node_tests,
            entries_written: self.entries_written + o.entries_written,
            lights_rejected: self.lights_rejected + o.lights_rejected,
        }
    }
}

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
    /// 1 in a counting frame: assignment counts its work (`clustering/work.wesl`).
    pub counting: u32,
    /// The work counters, each (low, high) words of 64 bits, in `work.wesl`'s order.
    pub work: [u32; 8],
}

impl ClusterStats {
    /// The work counters as the counting frame left them.
    pub fn work(&self) -> AssignmentWork {
        let at = |k: usize| self.work[2 * k] as u64 | (self.work[2 * k + 1] as u64) << 32;
        AssignmentWork {
            light_tests: at(0),
            node_tests: at(1),
            entries_written: at(2),
            lights_rejected: at(3),
        }
    }
}

/// Bytes of an indirect dispatch's arguments (x, y, z).
pub const DISPATCH_ARGS_BYTES: u64 = std::mem::size_of::<wgpu::util::DispatchIndirectArgs>() as u64;

/// Bytes of an indirect draw's arguments (vertices, instances, first vertex, first
/// instance).
pub const DRAW_ARGS_BYTES: u64 = std::mem::size_of::<wgpu::util::DrawIndirectArgs>() as u64;

/// The header of `sort_jobs` (`SortJobs` in `clustering/build_bindings.wesl`): the long
/// lists' indirect dispatch (x, y, z workgroups) and their number. Its offsets are the
/// WGSL's (`tests/constants.rs`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct SortJobsHeader {
    pub groups_x: u32,
    pub groups_y: u32,
    pub groups_z: u32,
    pub count: u32,
}

/// Bytes of one word of a header.
pub const WORD_BYTES: u64 = std::mem::size_of::<u32>() as u64;

pub struct ClusterBuffers {
    pub clusters: u32,
    /// The buffers every method binds.
    pub range: wgpu::Buffer,
    pub active: wgpu::Buffer,
    pub stats: wgpu::Buffer,
    pub light_view: wgpu::Buffer,
    pub light_ranges: wgpu::Buffer,
    /// The rest the frame's passes bind, by the names their WGSL declares, only those this
    /// variant uses (`named_sizes`): the lists', 2.5D culling's masks, the method's own.
    named: Vec<(Binding, wgpu::Buffer)>,
    /// The indirect dispatch of the long-list sort, copied from `sort_jobs`' header (a
    /// buffer cannot be bound for storage and read as indirect arguments in one dispatch).
    pub sort_dispatch: wgpu::Buffer,
    /// Entries the index buffer holds.
    pub index_capacity: u32,
    /// Rasterised binning: its draw's target and copies.
    pub drawing: Option<ProxyDrawing>,
    /// The grid: tiles across, tiles down, slices (z-binning's bins).
    pub grid: (u32, u32, u32),
    pub lights: u32,
    pub culling: Culling,
    /// How light assignment builds the lists.
    pub method: CullingMethod,
    /// How the lists follow moving lights in a sequence.
    pub update: ListUpdate,
    /// Rasterised binning: its buffers' layouts as its root declares them.
    proxies: Option<ProxyLayout>,
    /// Every buffer's bytes as the frame's passes declare it.
    sizes: BufferSizes,
    /// StaticDynamic's moving lists: the buffers they share with the clusters' own lists
    /// (range, marks, view-space lights), which their bytes leave out.
    shares: bool,
}

/// Rasterised binning's draw: the layouts of its buffers, the copies of those the draw
/// reads as instances and indirect arguments and of the scatter's dispatch (a buffer bound
/// for storage in a pass cannot also be its vertex or indirect buffer), and the
/// one-pixel-per-tile target the proxies are drawn into.
pub struct ProxyDrawing {
    pub layout: ProxyLayout,
    pub instances: wgpu::Buffer,
    pub draw_args: wgpu::Buffer,
    pub scatter_dispatch: wgpu::Buffer,
    pub target: wgpu::TextureView,
}

/// What sizes a method's own buffers: the grid, the lights, the list entries, and with
/// rasterised binning its layouts and the largest buffer the adapter binds.
pub struct Sizing {
    pub grid: (u32, u32, u32),
    pub lights: u32,
    pub entries: u32,
    pub proxies: Option<ProxyLayout>,
    pub max_storage: u64,
}

/// The buffers of `counts` (names and elements), made at the sizes the frame's passes
/// declare; one no pass declares is bound by none and made empty (a plan may still clear
/// it).
fn make_declared(
    gpu: &Gpu,
    sizes: &BufferSizes,
    counts: Vec<(Binding, u64)>,
) -> Vec<(Binding, wgpu::Buffer)> {
    counts
        .into_iter()
        .map(|(name, count)| make_named(gpu, name, sizes.bytes(name, count).unwrap_or(0)))
        .collect()
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

impl ProxyDrawing {
    /// The copies of `proxy_bytes` of proxies and of the draw's and scatter's arguments, and
    /// the target of `grid`.
    fn new(gpu: &Gpu, layout: ProxyLayout, proxy_bytes: u64, grid: (u32, u32, u32)) -> Self {
        let copy_of = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let atlas = bin_target_size(grid);
        let target = gpu.device.create_texture(&wgpu::TextureDescriptor {
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
        });
        Self {
            layout,
            instances: copy_of("proxy instances", proxy_bytes, wgpu::BufferUsages::VERTEX),
            // The indirect draw's arguments: vertices, instances, first vertex, first
            // instance.
            draw_args: copy_of(
                "proxy draw arguments",
                DRAW_ARGS_BYTES,
                wgpu::BufferUsages::INDIRECT,
            ),
            scatter_dispatch: copy_of(
                "pair scatter dispatch",
                DISPATCH_ARGS_BYTES,
                wgpu::BufferUsages::INDIRECT,
            ),
            target: target.create_view(&Default::default()),
        }
    }
}

/// The buffers a variant's passes bind beside the ones every method does, by their WGSL
/// names, with the elements each holds: the lists' (methods that build lists), 2.5D
/// culling's masks, and the method's own (`CullingMethod::own_buffers`).
fn named_sizes(
    method: CullingMethod,
    culling: Culling,
    update: ListUpdate,
    s: &Sizing,
) -> Vec<(Binding, u64)> {
    let n = (s.grid.0 * s.grid.1 * s.grid.2) as u64;
    let mut sizes = Vec::new();
    if method.builds_lists() {
        let blocks = n.div_ceil(crate::compose::SCAN_BLOCK as u64);
        sizes.extend([
            (Binding::ClusterBounds, n),
            (Binding::LightCounts, n),
            (Binding::LightOffsets, n),
            (Binding::BlockSums, blocks),
            (Binding::LightIndices, s.entries as u64),
            (Binding::FillCursors, n),
            // The minimum (inverted) and maximum of each.
            (Binding::SampleDepths, n * 2),
            // A job per cluster at most (`SortJobs`).
            (Binding::SortJobs, n),
        ]);
    }
    if culling.marks_depth_cells() {
        sizes.push((Binding::DepthMasks, n));
    }
    if update == ListUpdate::Patch {
        // Per cluster, what the patch did to its list (`passes/patch_lists.wesl`).
        sizes.push((Binding::PatchClusters, n));
    }
    sizes.extend(method.own_buffers(s));
    sizes
}

/// The buffers of one-level lists (StaticDynamic's moving lists), by name: counts,
/// offsets, the prefix sum's blocks, indices, fill cursors, long-list jobs.
const LIST_BUFFERS: [Binding; 6] = [
    Binding::LightCounts,
    Binding::LightOffsets,
    Binding::BlockSums,
    Binding::LightIndices,
    Binding::FillCursors,
    Binding::SortJobs,
];

/// The smallest buffer made: a binding of a runtime-sized array needs one element, and no
/// declared element here is larger (vec4 of 32-bit words).
const MIN_BUFFER_BYTES: u64 = 16;

fn storage(gpu: &Gpu, label: &str, size: u64) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(MIN_BUFFER_BYTES),
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

/// A named buffer, made: the long lists' dispatch header (x, y, z, jobs) made (0, 1, 1, 0),
/// since frames reset only x and jobs (light assignment's plan clears them, `culling/`).
fn make_named(gpu: &Gpu, name: Binding, bytes: u64) -> (Binding, wgpu::Buffer) {
    let buffer = storage(gpu, name.name(), bytes);
    if name == Binding::SortJobs {
        let y = std::mem::offset_of!(SortJobsHeader, groups_y) as u64;
        gpu.queue
            .write_buffer(&buffer, y, bytemuck::cast_slice(&[1u32, 1u32]));
    }
    (name, buffer)
}

impl ClusterBuffers {
    /// The buffers of clusters `c` for `lights` lights, at the `sizes` the frame's passes
    /// declare (with rasterised binning, laid out as `proxies`, its root's declarations):
    /// only those the variant's passes bind.
    pub fn new(
        gpu: &Gpu,
        c: &Clusters,
        lights: u32,
        index_capacity: u32,
        range: ClusterRange,
        proxies: Option<ProxyLayout>,
        sizes: BufferSizes,
    ) -> Self {
        let (grid, method) = (c.grid, c.method());
        let clusters = grid.0 * grid.1 * grid.2;
        let n = clusters as u64;
        let index_capacity = if method.builds_lists() {
            index_capacity
        } else {
            0
        };
        let proxies = proxies.filter(|_| method == CullingMethod::Rasterised);
        let sizing = Sizing {
            grid,
            lights,
            entries: index_capacity,
            proxies,
            max_storage: gpu.max_storage_bytes(),
        };
        let named = make_declared(
            gpu,
            &sizes,
            named_sizes(method, c.culling, c.update, &sizing),
        );
        // Bound by every method's passes; one no pass declares is left empty.
        let every = |name: Binding, count: u64| {
            storage(gpu, name.name(), sizes.bytes(name, count).unwrap_or(0))
        };
        let drawing = proxies.map(|layout| {
            let proxy_bytes = named
                .iter()
                .find(|(name, _)| *name == Binding::LightProxies)
                .map_or(layout.proxy_bytes, |(_, b)| b.size());
            ProxyDrawing::new(gpu, layout, proxy_bytes, grid)
        });
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
            active: every(Binding::ClusterActive, n),
            stats: storage(
                gpu,
                "cluster_stats",
                std::mem::size_of::<ClusterStats>() as u64,
            ),
            light_view: every(Binding::LightView, lights.max(1) as u64),
            light_ranges: every(Binding::LightRanges, lights.max(1) as u64),
            named,
            sort_dispatch: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("long-list sort dispatch"),
                size: DISPATCH_ARGS_BYTES,
                usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            index_capacity,
            drawing,
            grid,
            lights,
            culling: c.culling,
            update: c.update,
            method,
            proxies,
            sizes,
            shares: false,
        }
    }

    /// StaticDynamic's moving lists beside these clusters: one-level lists of their own
    /// (as large as these lists' index buffer to start with), sharing the range, marks and
    /// view-space lights.
    pub fn moving_lists(&self, gpu: &Gpu) -> Self {
        let sizing = Sizing {
            grid: self.grid,
            lights: self.lights,
            entries: self.index_capacity,
            proxies: None,
            max_storage: gpu.max_storage_bytes(),
        };
        let lists = named_sizes(
            CullingMethod::OneLevel,
            Culling::Boxes,
            ListUpdate::Rebuild,
            &sizing,
        )
        .into_iter()
        .filter(|(name, _)| LIST_BUFFERS.contains(name))
        .collect();
        let named = make_declared(gpu, &self.sizes, lists);
        Self {
            clusters: self.clusters,
            range: self.range.clone(),
            active: self.active.clone(),
            stats: storage(
                gpu,
                "moving_stats",
                std::mem::size_of::<ClusterStats>() as u64,
            ),
            light_view: self.light_view.clone(),
            light_ranges: self.light_ranges.clone(),
            named,
            sort_dispatch: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("moving long-list sort dispatch"),
                size: DISPATCH_ARGS_BYTES,
                usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            index_capacity: self.index_capacity,
            drawing: None,
            grid: self.grid,
            lights: self.lights,
            culling: Culling::Boxes,
            update: ListUpdate::Rebuild,
            method: CullingMethod::OneLevel,
            proxies: None,
            sizes: self.sizes.clone(),
            shares: true,
        }
    }

    /// Bytes of all cluster data on the GPU.
    pub fn bytes(&self) -> u64 {
        let drawing = self
            .drawing
            .iter()
            .flat_map(|d| [&d.instances, &d.draw_args, &d.scatter_dispatch]);
        let shared = [
            &self.range,
            &self.active,
            &self.light_view,
            &self.light_ranges,
        ];
        let shared = shared.into_iter().filter(|_| !self.shares);
        [&self.stats, &self.sort_dispatch]
            .into_iter()
            .chain(shared)
            .chain(self.named.iter().map(|(_, b)| b))
            .chain(drawing)
            .map(|b| b.size())
            .sum()
    }

    /// Make the index buffer hold `capacity` entries, and every other buffer sized by the
    /// entries (rasterised binning's pairs); bind groups must be remade.
    pub fn grow_indices(&mut self, gpu: &Gpu, capacity: u32) {
        let sizing = Sizing {
            grid: self.grid,
            lights: self.lights,
            entries: capacity,
            proxies: self.proxies,
            max_storage: gpu.max_storage_bytes(),
        };
        for (name, count) in named_sizes(self.method, self.culling, self.update, &sizing) {
            if let Some(slot) = self.named.iter_mut().find(|(n, _)| *n == name)
                && let bytes = self.sizes.bytes(name, count).unwrap_or(0)
                && slot.1.size() != bytes.max(MIN_BUFFER_BYTES)
            {
                *slot = make_named(gpu, name, bytes);
            }
        }
        self.index_capacity = capacity;
    }

    /// The buffer a cluster pass binds by `name`, the name `build_bindings.wesl` (and,
    /// read-only, `lookup.wesl`) declares it by: the slot numbers are written only there.
    /// `None` for a buffer this variant does not make.
    pub fn buffer(&self, name: Binding) -> Option<&wgpu::Buffer> {
        Some(match name {
            Binding::ClusterRange => &self.range,
            Binding::ClusterActive => &self.active,
            Binding::ClusterStats => &self.stats,
            Binding::LightView => &self.light_view,
            Binding::LightRanges => &self.light_ranges,
            _ => return self.named.iter().find(|(n, _)| *n == name).map(|(_, b)| b),
        })
    }

    /// The buffer named `name`, which this variant's method makes (a light-assignment plan
    /// asks only for its own method's buffers).
    pub fn named(&self, name: Binding) -> &wgpu::Buffer {
        self.buffer(name).unwrap_or_else(|| {
            panic!(
                "{:?} makes no cluster buffer `{}`",
                self.method,
                name.name()
            )
        })
    }

    /// The buffer bound as `name`, as 32-bit words.
    pub fn read_words(&self, gpu: &Gpu, name: Binding) -> Result<Vec<u32>, GpuError> {
        self.read_named(gpu, name, None)
    }

    /// `bytes` (or all) of the buffer bound as `name`, as 32-bit words.
    pub(super) fn read_named(
        &self,
        gpu: &Gpu,
        name: Binding,
        bytes: Option<u64>,
    ) -> Result<Vec<u32>, GpuError> {
        let buffer = self.buffer(name).ok_or_else(|| {
            GpuError::Captured(format!(
                "{:?} makes no cluster buffer `{}`",
                self.method,
                name.name()
            ))
        })?;
        let bytes = bytes.unwrap_or(buffer.size());
        if bytes == 0 {
            return Ok(Vec::new());
        }
        Ok(bytemuck::cast_slice(&read_buffer(gpu, buffer, 0, bytes)?).to_vec())
    }

    pub fn read_stats(&self, gpu: &Gpu) -> Result<ClusterStats, GpuError> {
        let bytes = read_buffer(gpu, &self.stats, 0, self.stats.size())?;
        Ok(bytemuck::pod_read_unaligned(
            &bytes[..std::mem::size_of::<ClusterStats>()],
        ))
    }

    pub fn read_range(&self, gpu: &Gpu) -> Result<ClusterRange, GpuError> {
        let bytes = read_buffer(
            gpu,
            &self.range,
            0,
            std::mem::size_of::<ClusterRange>() as u64,
        )?;
        Ok(bytemuck::pod_read_unaligned(&bytes))
    }

    /// The most bytes one list entry takes in a buffer sized by the entries (the indices,
    /// rasterised binning's pair arrays), as the passes declare them: each must bind.
    pub fn bytes_per_entry(&self) -> u64 {
        let at = |entries| {
            let s = Sizing {
                grid: self.grid,
                lights: self.lights,
                entries,
                proxies: self.proxies,
                max_storage: u64::MAX,
            };
            named_sizes(self.method, self.culling, self.update, &s)
        };
        at(0)
            .into_iter()
            .zip(at(1))
            .map(|((name, none), (_, one))| {
                self.declared_bytes(name, one) - self.declared_bytes(name, none)
            })
            .max()
            .unwrap_or(0)
    }

    /// The bytes of `count` elements of buffer `name` as the frame's passes declare it (0
    /// for one no pass declares).
    pub fn declared_bytes(&self, name: Binding, count: u64) -> u64 {
        self.sizes.bytes(name, count).unwrap_or(0)
    }

    /// Each cluster's view-space box as the GPU holds it: [min, max], xyz and a fourth word.
    pub fn read_bounds(&self, gpu: &Gpu) -> Result<Vec<[[f32; 4]; 2]>, GpuError> {
        let n = self.declared_bytes(Binding::ClusterBounds, self.clusters as u64);
        let words = self.read_named(gpu, Binding::ClusterBounds, Some(n))?;
        Ok(words
            .chunks_exact(8)
            .map(|w| bytemuck::pod_read_unaligned(bytemuck::cast_slice(w)))
            .collect())
    }

    /// Each cluster's samples as the GPU holds them (zero without sample bounds).
    pub fn read_depth_masks(&self, gpu: &Gpu) -> Result<Vec<GpuDepthMask>, GpuError> {
        let n = self.clusters as u64;
        if !self.method.builds_lists() {
            return Ok(vec![GpuDepthMask::default(); n as usize]);
        }
        let depths = self.read_named(
            gpu,
            Binding::SampleDepths,
            Some(self.declared_bytes(Binding::SampleDepths, n * 2)),
        )?;
        let masks = if self.culling.marks_depth_cells() {
            self.read_named(
                gpu,
                Binding::DepthMasks,
                Some(self.declared_bytes(Binding::DepthMasks, n)),
            )?
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

    /// Upload lists built on the CPU; returns false when the index buffer must grow first.
    pub fn upload_lists(&self, gpu: &Gpu, lists: &ClusterLists) -> bool {
        if lists.indices.len() as u64 > self.index_capacity as u64 {
            return false;
        }
        gpu.queue.write_buffer(
            self.named(Binding::LightCounts),
            0,
            bytemuck::cast_slice(&lists.counts),
        );
        gpu.queue.write_buffer(
            self.named(Binding::LightOffsets),
            0,
            bytemuck::cast_slice(&lists.offsets),
        );
        if !lists.indices.is_empty() {
            gpu.queue.write_buffer(
                self.named(Binding::LightIndices),
                0,
                bytemuck::cast_slice(&lists.indices),
            );
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
