//! The exact counters of a frame: an instrumented run of it (shading passes that count
//! their light evaluations per pixel), the light lists, and the bytes a frame keeps.

use serde::Serialize;

use super::clusters::AssignmentWork;
use super::error::RenderError;
use super::targets::Target;
use super::{Pipelines, Renderer, clustering, gbuffer};
use crate::compose::Composer;
use crate::compose::{ClusterPass, PassId};
use crate::gpu::{GpuError, read_buffer};
use crate::scene::Scene;
use crate::variant::{Clusters, DebugView, Pipeline, Variant};

/// Exact counters of a frame, from an instrumented run of it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, serde::Deserialize)]
pub struct FrameStats {
    /// Light evaluations performed by the shading pass.
    pub light_evals: u64,
    /// Those with the surface closer to the light than its radius (and inside its cone).
    pub useful_light_evals: u64,
    /// The lights the shading looked at: its lists' entries walked (exact loops: the
    /// evaluations), or a sampled loop's candidates (RIS: drawn, each then evaluated;
    /// stochastic culling: walked, of which the roulette keeps the evaluated ones).
    #[serde(default)]
    pub light_candidates: u64,
    /// A sampled light loop: its estimator and whether it is biased (absent for an exact
    /// loop), so the report labels what it plots.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sampler: Option<String>,
    /// Most useful evaluations at one pixel: the most lights that light one surface point
    /// (summed over the fragments shaded there).
    #[serde(default)]
    pub max_useful_per_pixel: u32,
    /// Multisampled frames: the fraction of the frame's pixels shaded more than once (edge
    /// pixels: forward shades each fragment, the deferred resolve each distinct surface;
    /// forward without a pre-pass also each fragment drawn over later).
    #[serde(default)]
    pub edge_fraction: f64,
    /// Frames with shadows: the shadow rays traced (one per pixel and light above 0), those
    /// an occluder blocked, and the BVH nodes their walks visited.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shadow_rays: Option<ShadowRays>,
    /// Light-cluster pairs left out by a per-cluster cap.
    pub dropped_lights: u64,
    /// Clusters that hold at least one visible sample.
    pub active_clusters: u64,
    /// Clusters that took part in light assignment (all, unless active clusters are on).
    pub assigned_clusters: u64,
    pub clusters: u64,
    pub max_lights_per_cluster: u32,
    /// Mean lights per cluster over the clusters that hold a visible sample (what shading
    /// loops over).
    #[serde(default)]
    pub mean_lights_per_visible_cluster: f64,
    /// Most lights in a cluster that holds a visible sample.
    #[serde(default)]
    pub max_lights_per_visible_cluster: u32,
    /// Entries in all light lists together.
    pub light_list_entries: u64,
    /// Bytes of cluster data on the GPU (bounds, counts, offsets, indices, ...).
    pub cluster_bytes: u64,
    /// G-buffer bytes per pixel, depth included (0 for forward pipelines).
    pub gbuffer_bytes_per_pixel: u32,
    /// Bytes per pixel of the post-processing images (0 without post effects).
    pub post_bytes_per_pixel: u32,
    /// Bytes per pixel of every full-size image the frame keeps: depth, G-buffer, HDR
    /// colour, post images and the 8-bit output.
    pub frame_bytes_per_pixel: u32,
    /// Times the light index buffer was too small and the frame was run again larger.
    pub list_reallocations: u32,
    /// The clustered depth range of the frame [near, far].
    pub z_range: Option<[f32; 2]>,
    /// Pixels whose shading looked up a cluster index outside the grid (clustered).
    pub clusters_out_of_grid: u64,
    /// The first such pixel: [x, y, cluster index].
    pub first_out_of_grid: Option<[u32; 3]>,
    /// What light assignment did, counted on the GPU (absent where it builds no lists on
    /// the GPU).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub assignment_work: Option<AssignmentWork>,
}

/// What a frame's shadow rays did, counted on the GPU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, serde::Deserialize)]
pub struct ShadowRays {
    pub traced: u64,
    pub blocked: u64,
    pub node_visits: u64,
}

impl ShadowRays {
    /// Mean nodes a ray's walk visited (None without rays).
    pub fn nodes_per_ray(&self) -> Option<f64> {
        (self.traced > 0).then(|| self.node_visits as f64 / self.traced as f64)
    }
}

impl FrameStats {
    /// Useful evaluations over those performed (1 when none was performed).
    pub fn useful_fraction(&self) -> Option<f64> {
        // No evaluation at all has no share of useful ones (not 100%).
        (self.light_evals > 0).then(|| self.useful_light_evals as f64 / self.light_evals as f64)
    }
}

/// The per-pixel counters of the last instrumented frame, as the shading pass left them.
#[derive(Clone, Debug, Default)]
pub struct PixelCounters {
    /// Light evaluations at each pixel (summed over the fragments shaded there).
    pub evals: Vec<u32>,
    /// Those with the surface in the light's range.
    pub useful: Vec<u32>,
    /// 1 + the largest cluster index a pixel's fragments looked up (0: none; clustered).
    pub clusters: Vec<u32>,
    /// Multisampled frames: how many times each pixel was shaded (empty with one sample).
    pub shadings: Vec<u32>,
    /// Sampled loops: the candidates each pixel drew or walked (empty for exact loops).
    pub candidates: Vec<u32>,
    /// Frames with shadows: each pixel's rays, those blocked and the nodes they visited,
    /// three words a pixel (empty without shadows).
    pub rays: Vec<u32>,
}

impl PixelCounters {
    /// The cluster a pixel's fragments looked up, if any did.
    pub fn cluster(&self, pixel: usize) -> Option<u32> {
        self.clusters[pixel].checked_sub(1)
    }
}

impl<'g> Renderer<'g> {
    /// Make naive forward's clustered stand-in, so that `stats` counts on it: a clustered
    /// renderer with the same rasterisation (pre-pass or not, depth format and test, vertex
    /// shader), exact light lists, and shading that counts every light as evaluated per
    /// fragment and tests only the lights of its list for range. Exact lists hold every
    /// light in range of a fragment, so the useful count is naive forward's own, at a small
    /// part of the cost of looping over every light (`tests/measure.rs` holds them equal).
    /// Nothing to do for other pipelines; a stand-in that cannot be made (its cluster buffers
    /// over a limit) leaves naive forward counting on its own frame: slower, as exact.
    pub fn prepare_counting(&mut self, composer: &Composer, scene: &Scene) {
        // A sampled loop counts on its own frame: its candidates are not a list's.
        if self.variant.pipeline != Pipeline::NaiveForward
            || self.naive_stand_in.is_some()
            || self.variant.shading.lights.sampling().is_some()
        {
            return;
        }
        let stand_in = Variant {
            pipeline: Pipeline::ClusteredForward,
            clusters: Some(Clusters::default()),
            post: Default::default(),
            debug_view: DebugView::Off,
            ..self.variant.clone()
        };
        self.naive_stand_in = Renderer::build_renderer(self.gpu, composer, &stand_in, scene, true)
            .ok()
            .map(Box::new);
    }

    /// Run an instrumented frame and read its per-pixel counters.
    fn count_shading(&mut self) -> Result<PixelCounters, RenderError> {
        self.run_fitted(true)?;
        // It shaded over the images and re-marks the clusters: a sequence's next frame
        // redoes them.
        self.state.held.disturbed.set(true);
        Ok(self.read_pixel_counters()?)
    }

    fn read_pixel_counters(&self) -> Result<PixelCounters, GpuError> {
        // A counter no pass declares (a loop that looks up no cluster) counted nothing.
        let pixels = self.state.width as usize * self.state.height as usize;
        let read = |b: &wgpu::Buffer| -> Result<Vec<u32>, GpuError> {
            if b.size() == 0 {
                return Ok(vec![0; pixels]);
            }
            let bytes = read_buffer(self.gpu, b, 0, b.size())?;
            Ok(bytemuck::pod_collect_to_vec(&bytes))
        };
        let c = &self.res.counters;
        Ok(PixelCounters {
            evals: read(&c.evals)?,
            useful: read(&c.useful)?,
            clusters: read(&c.clusters)?,
            shadings: c
                .shadings
                .as_ref()
                .map(read)
                .transpose()?
                .unwrap_or_default(),
            candidates: c
                .candidates
                .as_ref()
                .map(read)
                .transpose()?
                .unwrap_or_default(),
            rays: c.rays.as_ref().map(read).transpose()?.unwrap_or_default(),
        })
    }

    /// The per-pixel counters of the last instrumented frame (`stats` runs one; naive
    /// forward's are its stand-in's), for checking the counters by another summation.
    pub fn pixel_counters(&self) -> Result<PixelCounters, RenderError> {
        Ok(match &self.naive_stand_in {
            Some(stand_in) => stand_in.read_pixel_counters()?,
            None => self.read_pixel_counters()?,
        })
    }

    /// Render the frame again with instrumented shading and return its exact counters
    /// (naive forward's shading counters on its stand-in, once `prepare_counting` made it).
    pub fn stats(&mut self) -> Result<FrameStats, RenderError> {
        let gpu = self.gpu;
        let pixels = match &mut self.naive_stand_in {
            Some(stand_in) => stand_in.count_shading()?,
            None => self.count_shading()?,
        };
        let sum = |counts: &[u32]| counts.iter().map(|&n| n as u64).sum();
        let mut stats = FrameStats {
            light_evals: sum(&pixels.evals),
            useful_light_evals: sum(&pixels.useful),
            sampler: self
                .variant
                .shading
                .lights
                .sampling()
                .map(|s| format!("{} ({})", s.label(), s.bias_label())),
            light_candidates: if self.variant.shading.lights.sampling().is_some() {
                sum(&pixels.candidates)
            } else {
                sum(&pixels.evals)
            },
            max_useful_per_pixel: pixels.useful.iter().copied().max().unwrap_or(0),
            edge_fraction: pixels.shadings.iter().filter(|&&n| n > 1).count() as f64
                / pixels.evals.len().max(1) as f64,
            gbuffer_bytes_per_pixel: if self.variant.pipeline.is_deferred() {
                gbuffer::bytes_per_pixel(&self.variant)
            } else {
                0
            },
            post_bytes_per_pixel: self.passes.post.bytes_per_pixel(),
            frame_bytes_per_pixel: self.frame_bytes_per_pixel(),
            list_reallocations: self.state.reallocations,
            shadow_rays: self.variant.shading.shadows.traced().then(|| {
                let words = crate::compose::RAY_COUNTERS as usize;
                let word = |k: usize| {
                    let each = pixels.rays.iter().skip(k).step_by(words);
                    each.map(|&n| n as u64).sum()
                };
                ShadowRays {
                    traced: word(0),
                    blocked: word(1),
                    node_visits: word(2),
                }
            }),
            ..Default::default()
        };
        if let Some(c) = &self.res.clusters {
            let s = c.read_stats(gpu)?;
            let range = c.read_range(gpu)?;
            stats.clusters = c.clusters as u64;
            stats.dropped_lights = s.dropped as u64;
            stats.max_lights_per_cluster = s.max_per_cluster;
            stats.light_list_entries = s.total as u64;
            stats.cluster_bytes = c.bytes() + self.res.moving.as_ref().map_or(0, |m| m.bytes());
            stats.z_range = Some([range.near, range.far]);
            stats.assigned_clusters = if self.variant.clusters().active_clusters {
                s.active_clusters as u64
            } else {
                c.clusters as u64
            };
            stats.active_clusters = self.count_visible_clusters()? as u64;
            if self.cpu_assignment.is_none() {
                let moving = match &self.res.moving {
                    Some(m) => m.read_stats(gpu)?.work(),
                    None => AssignmentWork::default(),
                };
                stats.assignment_work = Some(s.work() + moving);
            }
            let used = &pixels.clusters;
            let outside = |&(_, &v): &(usize, &u32)| v > c.clusters;
            stats.clusters_out_of_grid = used.iter().enumerate().filter(outside).count() as u64;
            stats.first_out_of_grid = used.iter().enumerate().find(outside).map(|(i, &v)| {
                let w = self.state.width as usize;
                [(i % w) as u32, (i / w) as u32, v - 1]
            });
            // Pixels record their cluster index + 1 (0: background).
            let mut visible: Vec<u32> = used
                .iter()
                .filter(|&&v| v > 0 && v <= c.clusters)
                .map(|&v| v - 1)
                .collect();
            visible.sort_unstable();
            visible.dedup();
            let mut counts = c.read_counts(gpu)?;
            // Patch leaves old room behind in the index buffer, and StaticDynamic's lights
            // are in two lists: the entries are the lists' lengths.
            if let Some(m) = &self.res.moving {
                for (n, moving) in counts.iter_mut().zip(m.read_counts(gpu)?) {
                    *n += moving;
                }
            }
            if matches!(
                self.update(),
                Some(crate::variant::ListUpdate::Patch | crate::variant::ListUpdate::StaticDynamic)
            ) {
                stats.light_list_entries = counts.iter().map(|&n| n as u64).sum();
                stats.max_lights_per_cluster = counts.iter().copied().max().unwrap_or(0);
            }
            if !c.method.builds_lists() {
                // No lists on the GPU: each tile and bin's walk stands for one.
                stats.light_list_entries = counts.iter().map(|&n| n as u64).sum();
                stats.max_lights_per_cluster = counts.iter().copied().max().unwrap_or(0);
            }
            let lights: Vec<u32> = visible.iter().map(|&k| counts[k as usize]).collect();
            stats.max_lights_per_visible_cluster = lights.iter().copied().max().unwrap_or(0);
            stats.mean_lights_per_visible_cluster = if lights.is_empty() {
                0.0
            } else {
                lights.iter().map(|&n| n as f64).sum::<f64>() / lights.len() as f64
            };
        }
        Ok(stats)
    }

    fn frame_bytes_per_pixel(&self) -> u32 {
        let t = &self.res.targets;
        // Every sample of a multisampled target.
        let size = |tex: &Target| {
            // Depth formats have no copy size for the whole texture; 24-bit depth takes 4.
            let format = tex.texture.format();
            let sample = format
                .block_copy_size(None)
                .or_else(|| format.block_copy_size(Some(wgpu::TextureAspect::DepthOnly)))
                .unwrap_or(4);
            sample * tex.texture.sample_count()
        };
        [&t.depth, &t.hdr, &t.ldr]
            .into_iter()
            .chain(&t.hdr_samples)
            .chain(&t.shading_depth)
            .chain(&t.sample_owner)
            .chain(t.gbuffer.iter().map(|(_, t)| t))
            .map(size)
            .sum::<u32>()
            + self.passes.post.bytes_per_pixel()
            + self
                .res
                .sampling
                .as_ref()
                .map_or(0, |s| s.bytes_per_pixel())
    }

    /// Clusters holding a visible sample of the last frame's depth (exact marking).
    fn count_visible_clusters(&self) -> Result<u32, RenderError> {
        let gpu = self.gpu;
        let c = self.res.clusters.as_ref().expect("clustered");
        let mark = PassId::Clustering(ClusterPass::MarkActive);
        let Some(built) = self
            .passes
            .support
            .iter()
            .chain(&self.passes.timed)
            .find(|b| b.pass.id == mark)
        else {
            return Ok(0);
        };
        let Pipelines::Compute(p) = &built.pipelines else {
            return Ok(0);
        };
        gpu.scoped("counting visible clusters", || {
            let mut e = gpu.device.create_command_encoder(&Default::default());
            clustering::encode_visible_count(p, &built.groups, &mut e, c, &self.extent());
            gpu.queue.submit([e.finish()]);
        })?;
        Ok(c.read_stats(gpu)?.active_clusters)
    }
}
