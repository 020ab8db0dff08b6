//! The variant schema: what a `variants/*.ron` file may say.
//!
//! Every field has a default, so a minimal variant is a few lines. Doc comments here are
//! the user-facing documentation: `clusterlab explain` prints them from the JSON schema
//! that `schemars` derives from these types.

use crate::common::DepthMapping;
pub use crate::common::{
    DepthFormat, DepthRangeSource, MsaaResolve, NormalCodec, PostEffect, SpotTest, ZSlicing,
};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use strum::IntoEnumIterator;

/// One shading pipeline configuration: the unit that the variant matrix measures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Variant {
    /// One line saying what this variant is and why it is worth measuring.
    pub description: String,
    /// Which shading pipeline renders the frame.
    pub pipeline: Pipeline,
    /// Forward pipelines only: render depth first, then shade with depth test `Equal`, so
    /// every pixel is shaded once whatever the overdraw.
    pub depth_prepass: bool,
    /// Clustered pipelines only: how the view frustum is cut into clusters and how lights
    /// are assigned to them. Left out, a clustered pipeline uses the defaults shown here.
    pub clusters: Option<Clusters>,
    /// Deferred pipelines only: the G-buffer layout. Left out, a deferred pipeline uses
    /// the defaults shown here.
    pub gbuffer: Option<GBuffer>,
    /// The depth buffer every raster pass uses.
    pub depth: Depth,
    /// Multisampling: samples per pixel of the depth buffer, the G-buffer and the forward
    /// passes' colour, and how a pixel's samples become one colour.
    pub msaa: Msaa,
    /// Deferred pipelines only: how the G-buffer stores normals. Left out: `Xyz` for the
    /// Wide layout, `Octahedral(bits: 32, precise: true)` for Packed and Compact.
    pub normals: Option<NormalCodec>,
    /// The surface shading model.
    pub shading: Shading,
    /// Post-processing effects, applied in this order: toon, bloom, motion blur.
    pub post: Post,
    /// Replace the shaded image with a diagnostic view.
    pub debug_view: DebugView,
    /// Skip the work a frame does not need: clustering with no lights, light assignment
    /// when neither lights nor camera moved since the last frame, cluster bounds while the
    /// projection holds, the bloom blur when no pixel passes the threshold (decided on the
    /// GPU), motion blur when the camera did not move. `false` runs every pass every frame,
    /// to measure what skipping saves.
    pub skip_unneeded: bool,
    /// In a sequence (`clusterlab sequence`, `matrix --sequence`), reuse what did not change
    /// since the previous frame: with the camera and geometry still, the depth pre-pass, the
    /// G-buffer, the blended depths, the depth range, active-cluster marking and the cluster
    /// bounds (only the lists and shading the moving lights change are redone, as
    /// `clusters.update` says); with no light moving either, the whole frame is the previous
    /// one. `false` redraws every pass every frame. A frame rendered again unchanged (the
    /// matrix's timed frames) is never reused.
    pub reuse_unchanged: bool,
}

impl Default for Variant {
    fn default() -> Self {
        Self {
            description: String::new(),
            pipeline: Pipeline::NaiveForward,
            depth_prepass: false,
            clusters: None,
            gbuffer: None,
            depth: Depth::default(),
            msaa: Msaa::default(),
            normals: None,
            shading: Shading::default(),
            post: Post::default(),
            debug_view: DebugView::Off,
            skip_unneeded: true,
            reuse_unchanged: true,
        }
    }
}

/// The shading pipelines that clusterlab compares.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema, strum::EnumIter,
)]
pub enum Pipeline {
    /// Every fragment loops over every light: the baseline, exact and slow.
    NaiveForward,
    /// Forward+ with 3D clusters: each fragment loops over its cluster's lights.
    ClusteredForward,
    /// G-buffer pass, then a full-screen resolve that shades each pixel with its cluster's
    /// lights.
    ClusteredDeferred,
    /// G-buffer pass, then each light adds its light inside its screen-space bounding
    /// rectangle with additive blending (no clusters): the classic deferred baseline.
    DeferredScissor,
}

impl Pipeline {
    /// The name of the pipeline's plain variant (and of its stress runs).
    pub fn short_name(self) -> &'static str {
        match self {
            Pipeline::NaiveForward => "naive_forward",
            Pipeline::ClusteredForward => "forward_plus",
            Pipeline::ClusteredDeferred => "clustered_deferred",
            Pipeline::DeferredScissor => "deferred_scissor",
        }
    }

    pub fn is_clustered(self) -> bool {
        matches!(
            self,
            Pipeline::ClusteredForward | Pipeline::ClusteredDeferred
        )
    }
    pub fn is_deferred(self) -> bool {
        matches!(
            self,
            Pipeline::ClusteredDeferred | Pipeline::DeferredScissor
        )
    }
}

/// The cluster grid and how lights are assigned to it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Clusters {
    /// Clusters along screen x, screen y and view depth: (x, y, z). x and y in 1..=128,
    /// z in 1..=256. With `OlssonCubic` slicing, z is the most slices the grid may hold.
    pub grid: (u32, u32, u32),
    /// How view depth is cut into slices.
    pub slicing: ZSlicing,
    /// Where light lists are built.
    pub assignment: Assignment,
    /// How long a cluster's light list may be.
    pub lists: LightLists,
    /// Assign lights only to clusters that hold at least one visible sample (Olsson 2012).
    /// Needs depth before shading (a pre-pass or a G-buffer).
    pub active_clusters: bool,
    /// Olsson 2012's explicit bounds: shrink each active cluster's box in depth to the
    /// samples it holds, so fewer lights touch it. Needs `active_clusters`.
    pub sample_bounds: bool,
    /// How a spot light is tested against a cluster (point lights always use their sphere).
    pub spot_test: SpotTest,
    /// How a light is tested against a cluster beyond its box. Tiled shading with per-tile
    /// depth bounds (Harada et al. 2012) is a grid of one slice, `(x, y, 1)`, with
    /// `active_clusters` and `sample_bounds`; `DepthMask` on such a grid is Harada's 2.5D
    /// culling.
    pub culling: Culling,
    /// Two-level culling (as HDRP does): a coarse pass first culls the lights per big tile of
    /// n x n tiles (by its tiles' side planes and, with sample bounds, its samples' depth
    /// range); each cluster then tests only its big tile's survivors, one invocation per
    /// cluster, skipping inactive clusters at once, and its list comes out in index order
    /// with no sort. HDRP: 64-pixel big tiles over 16-pixel tiles, n = 4. n in 1..=32;
    /// left out, each light tests every cluster of its range. Not with `ZBinning`,
    /// `Rasterised` or `Cpu` assignment.
    pub big_tiles: Option<u32>,
    /// How the lists follow lights that move from frame to frame in a sequence, with the
    /// camera and geometry still (a moving camera rebuilds every list, but `Refit`
    /// refits). Every strategy keeps the lists exact.
    pub update: ListUpdate,
}

impl Default for Clusters {
    fn default() -> Self {
        Self {
            grid: (16, 9, 24),
            slicing: ZSlicing::Exponential,
            assignment: Assignment::Gpu,
            lists: LightLists::Exact,
            active_clusters: false,
            sample_bounds: false,
            spot_test: SpotTest::Cone,
            culling: Culling::Boxes,
            big_tiles: None,
            update: ListUpdate::Rebuild,
        }
    }
}

/// How a sequence's light lists follow the lights that move (`clusters.update`).
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema, strum::EnumIter,
)]
pub enum ListUpdate {
    /// Every list rebuilt by the variant's culling method every frame a light moved.
    Rebuild,
    /// Two sets of lists: the still lights' built once by the variant's method (while the
    /// camera and geometry stay still), the moving lights' every frame by one-level
    /// assignment over them alone; shading walks both. Where a frame shades each pixel once
    /// (one sample, and a pre-pass in forward), the still lights' part of each pixel is
    /// shaded once into an image (`still_shading`, `still_resolve`) and reused, so a frame
    /// shades only the moving lights. A light that was still and moves rebuilds both.
    /// Needs exact lists, GPU assignment and a culling method whose lists are one-level's
    /// (`Boxes` or `DepthMask`, with or without big tiles, or `Bvh`).
    StaticDynamic,
    /// The previous frame's lists, patched: each moved light is removed from the clusters
    /// it left and added to those it entered (a cluster whose set changed takes new room in
    /// the index buffer and is sorted; the rest keep theirs). When the index buffer fills,
    /// the frame rebuilds every list (and compacts it). Needs exact lists, GPU assignment
    /// and a method whose lists are one-level's (as `StaticDynamic`).
    Patch,
    /// The light BVH's tree refitted instead of rebuilt (Moreau, Pharr and Clarberg 2019):
    /// the previous frame's light order kept, each node's range recomputed from its
    /// children; the walks stay exact, only their length changes. Applies also when the
    /// camera moves. `Bvh` culling only.
    Refit,
}

impl ListUpdate {
    /// Its short name (README's table, the matrix's labels).
    pub fn label(self) -> &'static str {
        match self {
            ListUpdate::Rebuild => "rebuild",
            ListUpdate::StaticDynamic => "static+dynamic",
            ListUpdate::Patch => "patch",
            ListUpdate::Refit => "refit",
        }
    }
}

/// The test that decides whether a light goes into a cluster's list.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema, strum::EnumIter,
)]
pub enum Culling {
    /// The light's sphere against the cluster's box, tightened by its tile's four side
    /// planes (and a spot's cone against the box's bounding sphere).
    Boxes,
    /// Harada 2012's 2.5D culling, on top of `Boxes`: each cluster's sample depth range is
    /// cut into 32 equal cells and a 32-bit mask marks the cells that hold a visible sample;
    /// a light is kept only where the cells its depth range spans hold one, so lights in
    /// the empty space between a tile's near and far surfaces are left out. Needs
    /// `active_clusters` and `sample_bounds`.
    DepthMask,
    /// Drobot 2017's z-binning (Call of Duty): no per-cluster lists. Lights are sorted by
    /// view depth; each of the grid's z slices is a depth bin that stores the first and last
    /// sorted light reaching it, and each of its x-by-y tiles a bitmask of the lights that
    /// reach the tile; a pixel walks the lights of its bin's range that its tile's mask
    /// holds. Memory is bins + tiles x lights / 32 words. Spots are binned by their bounding
    /// sphere. Exact lists only, GPU assignment, no active clusters.
    ZBinning,
    /// Ortegren and Persson 2016's rasterised binning (Bevy's GPU clustering): a compute pass
    /// splits each light into one proxy per z slice its sphere reaches, the rectangle of
    /// tiles that the sphere's part within that slice's depths projects onto; one draw of
    /// the proxies into a one-pixel-per-tile target (a cell per slice), each fragment
    /// testing its cluster as `Boxes` does, counting the light there and recording the pair,
    /// then a compute pass writes the recorded pairs into the lists.
    /// Coverage is conservative by construction: each proxy's corners lie on tile
    /// boundaries, so a tile is drawn exactly when the rectangle holds it (no conservative
    /// rasterisation needed). Works with active clusters and sample bounds; GPU assignment.
    Rasterised,
    /// Olsson, Billeter and Assarsson 2012's light BVH, built on the GPU every frame: lights
    /// sorted by the Morton code of the centre of their range of clusters, a tree of 32
    /// children a node over that order (each node the union of its children's ranges, as
    /// boxes of clusters), then each cluster walks the tree to the lights whose range holds
    /// it and tests each as `Boxes` does. Lists equal `Boxes` lists; a cluster's work grows
    /// with the lights near it, not with all of them. Works with active clusters and sample
    /// bounds; GPU assignment.
    Bvh,
}

/// How light assignment on the GPU reaches the clusters: the method a variant's `culling`
/// and `big_tiles` choose (`Clusters::method`). Each has its shader root
/// (`compose::passes`) and its unit in `render/culling/`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CullingMethod {
    /// A workgroup per light counts the clusters it touches, a prefix sum, a second walk
    /// fills the lists, each list sorted (`Boxes` or `DepthMask` without big tiles).
    OneLevel,
    /// Big tiles of `big_tile` x `big_tile` tiles: a coarse pass per light, then each
    /// cluster walks its big tile's survivors (`big_tiles`).
    TwoLevel { big_tile: u32 },
    /// Lights sorted by depth into bins, a bitmask per tile; no lists.
    ZBinning,
    /// Light proxies drawn into a one-pixel-per-tile target.
    Rasterised,
    /// A light BVH built each frame, walked by each cluster.
    Bvh,
}

impl Culling {
    /// Whether marking also records each cluster's depth cells (2.5D culling's masks).
    pub fn marks_depth_cells(self) -> bool {
        match self {
            Culling::DepthMask => true,
            Culling::Boxes | Culling::ZBinning | Culling::Rasterised | Culling::Bvh => false,
        }
    }

    /// Whether its lists may be built over big tiles first (two-level culling).
    pub fn takes_big_tiles(self) -> bool {
        match self {
            Culling::Boxes | Culling::DepthMask => true,
            Culling::ZBinning | Culling::Rasterised | Culling::Bvh => false,
        }
    }

    /// Whether the CPU may build its lists (`assignment: Cpu`): the box test, with or
    /// without depth masks; z-binning refuses it with its own reason.
    pub fn takes_cpu_assignment(self) -> bool {
        match self {
            Culling::Boxes | Culling::DepthMask | Culling::ZBinning => true,
            Culling::Rasterised | Culling::Bvh => false,
        }
    }

    /// Whether its lists equal one-level assignment's, as a list strategy other than
    /// `Rebuild` needs.
    pub fn keeps_one_level_lists(self) -> bool {
        match self {
            Culling::Boxes | Culling::DepthMask | Culling::Bvh => true,
            Culling::ZBinning | Culling::Rasterised => false,
        }
    }
}

/// The WESL flags of the methods that have one (shared modules test them); each is set
/// where `CullingMethod::flag` names it.
pub const METHOD_FLAGS: [&str; 3] = ["zbinning", "two_level", "raster_binning"];

impl CullingMethod {
    /// Its light-assignment pass's shader root.
    pub fn shader_root(self) -> &'static str {
        match self {
            CullingMethod::OneLevel => "passes::assign_one_level",
            CullingMethod::TwoLevel { .. } => "passes::assign_two_level",
            CullingMethod::ZBinning => "passes::zbin_assign",
            CullingMethod::Rasterised => "passes::assign_rasterised",
            CullingMethod::Bvh => "passes::assign_bvh",
        }
    }

    /// Its WESL flag (one of `METHOD_FLAGS`), where shared modules treat it apart.
    pub fn flag(self) -> Option<&'static str> {
        match self {
            CullingMethod::OneLevel | CullingMethod::Bvh => None,
            CullingMethod::TwoLevel { .. } => Some("two_level"),
            CullingMethod::ZBinning => Some("zbinning"),
            CullingMethod::Rasterised => Some("raster_binning"),
        }
    }

    /// Its short name, as README's table of variants labels it.
    pub fn label(self) -> &'static str {
        match self {
            CullingMethod::OneLevel => "one-level",
            CullingMethod::TwoLevel { .. } => "two-level",
            CullingMethod::ZBinning => "z-binning",
            CullingMethod::Rasterised => "rasterised",
            CullingMethod::Bvh => "BVH",
        }
    }

    /// Whether it builds per-cluster lists (and boxes to test them on); z-binning walks bins
    /// and tile masks instead.
    pub fn builds_lists(self) -> bool {
        match self {
            CullingMethod::OneLevel
            | CullingMethod::TwoLevel { .. }
            | CullingMethod::Rasterised
            | CullingMethod::Bvh => true,
            CullingMethod::ZBinning => false,
        }
    }
}

impl Clusters {
    /// The method these clusters' lights are assigned by. Every `Culling` has its arm: a
    /// new one does not compile until it says which method builds its lists.
    pub fn method(&self) -> CullingMethod {
        match self.culling {
            Culling::Boxes | Culling::DepthMask => match self.big_tiles {
                Some(big_tile) => CullingMethod::TwoLevel { big_tile },
                None => CullingMethod::OneLevel,
            },
            Culling::ZBinning => CullingMethod::ZBinning,
            Culling::Rasterised => CullingMethod::Rasterised,
            Culling::Bvh => CullingMethod::Bvh,
        }
    }
}

/// Where light lists are built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub enum Assignment {
    /// Compute passes: count, prefix sum, fill.
    Gpu,
    /// On the CPU, uploaded each frame (as the older write-ups did); its time is measured.
    Cpu,
}

/// How long a cluster's light list may be.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub enum LightLists {
    /// Exact compacted lists: every light that touches a cluster is in its list.
    Exact,
    /// At most `max_per_cluster` lights per cluster; every light over the cap is counted
    /// and reported as dropped.
    Capped {
        /// The cap, in 1..=1024.
        max_per_cluster: u32,
    },
}

/// The G-buffer of a deferred pipeline.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct GBuffer {
    /// Which targets hold what.
    pub layout: GBufferLayout,
}

impl Default for GBuffer {
    fn default() -> Self {
        Self {
            layout: GBufferLayout::Wide,
        }
    }
}

/// G-buffer layouts, from exact and fat to lossy and thin.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub enum GBufferLayout {
    /// 3 x rgba32float: position, albedo, normal (xyz floats). 48 bytes a pixel.
    Wide,
    /// 2 x rgba32float: position and albedo, with a 2-component packed normal in the
    /// alpha channels. 32 bytes a pixel.
    Packed,
    /// Position rebuilt from depth, albedo rgba8unorm, packed normal in r32uint.
    /// 8 bytes a pixel beside depth.
    Compact,
}

/// The depth buffer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Depth {
    /// Storage format.
    pub format: DepthFormat,
    /// Reversed-Z: near maps to 1, the far plane (or infinity) to 0.
    pub reversed_z: bool,
    /// Put the projection's far plane at infinity (the camera's far plane still bounds the
    /// clusters). Default: true with reversed-Z, false without.
    pub infinite_far: Option<bool>,
}

impl Default for Depth {
    fn default() -> Self {
        Self {
            format: DepthFormat::Float32,
            reversed_z: false,
            infinite_far: None,
        }
    }
}

impl Depth {
    /// The depth mapping these settings give.
    pub fn mapping(&self) -> DepthMapping {
        DepthMapping {
            reversed: self.reversed_z,
            infinite_far: self.infinite_far.unwrap_or(self.reversed_z),
        }
    }
}

/// Multisampling (MSAA).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Msaa {
    /// Samples per pixel: 1 (no multisampling), 2, 4 or 8, where the adapter renders every
    /// format the variant uses with that count (`clusterlab adapters` lists them).
    pub samples: u32,
    /// How a pixel's samples become its colour (the reference resolves the same way).
    pub resolve: MsaaResolve,
}

impl Default for Msaa {
    fn default() -> Self {
        Self {
            samples: 1,
            resolve: MsaaResolve::Box,
        }
    }
}

impl Msaa {
    /// Whether a pixel holds more than one sample.
    pub fn on(&self) -> bool {
        self.samples > 1
    }
}

/// The surface shading model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Shading {
    /// The BRDF.
    pub model: ShadingModel,
    /// Constant ambient light, as a fraction of albedo, in 0..=1.
    pub ambient: f32,
    /// How a surface point's lights are summed: every light of its list (`Exact`), or an
    /// unbiased or labelled-biased estimate from a few of them (`Sampled`).
    pub lights: Lights,
    /// Whether the scene's opaque triangles block light: `None` lights every point a
    /// light's range reaches; `Exact` traces one shadow ray per pixel and light that
    /// reaches it, against a BVH of the scene's opaque triangles (masked and blended
    /// triangles receive shadows but cast none).
    pub shadows: Shadows,
}

impl Default for Shading {
    fn default() -> Self {
        Self {
            model: ShadingModel::Lambert,
            ambient: 0.02,
            lights: Lights::Exact,
            shadows: Shadows::None,
        }
    }
}

/// How a light's visibility from a surface point is found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub enum Shadows {
    /// No shadows: every light lights what its range reaches.
    #[default]
    None,
    /// One shadow ray from each pixel to the centre of each light that reaches it, through
    /// a BVH of the scene's opaque triangles with a watertight ray-triangle test: exact
    /// against the f64 reference, which traces the same rays.
    Exact,
    /// A few shadow rays per pixel, to lights of its list drawn at random: an estimate of
    /// the shadowed light (`docs/design.md`, Shadows).
    Sampled(ShadowSampling),
}

/// Shadows estimated from a few rays a pixel.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ShadowSampling {
    /// The estimator.
    pub method: ShadowSampler,
    /// Shadow rays a pixel traces, in 1..=16.
    pub rays: u32,
    /// Seed of the random numbers, mixed with each pixel and each frame's time.
    pub seed: u32,
}

impl Default for ShadowSampling {
    fn default() -> Self {
        Self {
            method: ShadowSampler::Importance,
            rays: 1,
            seed: 0,
        }
    }
}

/// Estimators of a pixel's shadowed light from `rays` rays. Both draw the rays' lights
/// from the pixel's list in proportion to the luminance of their unshadowed light,
/// stratified (one draw in each of `rays` equal parts of the sum), and trace one ray a
/// drawn light.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema, strum::EnumIter,
)]
pub enum ShadowSampler {
    /// Each drawn light's light if its ray is clear, weighted by the inverse of its
    /// probability over `rays`. Unbiased.
    Importance,
    /// The ratio estimator (Heitz, Hill & McGuire 2018): the list's exact unshadowed light
    /// times the ratio of the draws' estimate with visibility to the same estimate without,
    /// per channel. Biased (a ratio of two estimates) and consistent; no noise where every
    /// ray agrees.
    Ratio,
}

impl Shadows {
    /// Whether a frame traces shadow rays.
    pub fn traced(self) -> bool {
        self != Shadows::None
    }

    /// The sampler, if the shadows are estimated.
    pub fn sampling(&self) -> Option<&ShadowSampling> {
        match self {
            Shadows::Sampled(s) => Some(s),
            Shadows::None | Shadows::Exact => None,
        }
    }

    pub fn label(self) -> String {
        match self {
            Shadows::None => "unshadowed".into(),
            Shadows::Exact => "exact shadows".into(),
            Shadows::Sampled(s) => format!("{} ({})", s.label(), s.bias_label()),
        }
    }
}

impl ShadowSampling {
    /// Whether the estimate's expectation is the exact shadowed light.
    pub fn unbiased(&self) -> bool {
        match self.method {
            ShadowSampler::Importance => true,
            ShadowSampler::Ratio => false,
        }
    }

    pub fn bias_label(&self) -> &'static str {
        match self.method {
            ShadowSampler::Importance => "unbiased",
            ShadowSampler::Ratio => "biased: a ratio of estimates",
        }
    }

    /// The estimator and its rays, e.g. "ratio shadows, 1 ray".
    pub fn label(&self) -> String {
        let method = match self.method {
            ShadowSampler::Importance => "importance-sampled shadows",
            ShadowSampler::Ratio => "ratio shadows",
        };
        let s = if self.rays == 1 { "" } else { "s" };
        format!("{method}, {} ray{s}", self.rays)
    }
}

/// How a surface point's light loop sums its lights.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub enum Lights {
    /// Every light of the pixel's list (naive forward: every light), in index order.
    #[default]
    Exact,
    /// A stochastic estimate, its random numbers from a hash of the pixel, the frame's time
    /// and `seed`: every run reproducible.
    Sampled(Sampling),
}

/// A stochastic light loop.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Sampling {
    /// The estimator.
    pub method: Sampler,
    /// Seed of the random numbers, mixed with each pixel and each frame's time.
    pub seed: u32,
}

impl Default for Sampling {
    fn default() -> Self {
        Self {
            method: Sampler::Ris {
                candidates: 8,
                kept: 1,
                temporal: None,
                spatial: None,
            },
            seed: 0,
        }
    }
}

/// Stochastic light loops (`docs/design.md`, "Sampled lights", has the estimators).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub enum Sampler {
    /// Plain Monte Carlo, what RIS resamples from: `candidates` lights drawn uniformly from
    /// the list, each shaded, their mean times the list's length. Unbiased.
    Uniform {
        /// Candidates a pixel draws, in 1..=256.
        candidates: u32,
    },
    /// Resampled importance sampling (Talbot 2005; ReSTIR's first step, Bitterli 2020):
    /// `candidates` lights drawn uniformly from the list, each weighted by its target (the
    /// luminance of its unshadowed contribution, which is the contribution itself here: no
    /// visibility to defer), and `kept` of them chosen in proportion, each shaded with weight
    /// `sum of weights / (candidates x target)`; every candidate counts, also those whose
    /// target is 0. Unbiased. With `temporal` (clustered deferred only), ReSTIR DI's
    /// temporal reuse: the previous frame's reservoir at the reprojected pixel, its count
    /// capped at `temporal` times `candidates`, joins this frame's; unbiased while the camera
    /// and the lights hold still, biased (1/M weights across changed targets) once they move.
    /// With `spatial` too, ReSTIR's spatial reuse fused with the temporal (RTXDI's
    /// spatiotemporal resampling): the previous frame's reservoirs at neighbours of the
    /// reprojected pixel join as well.
    Ris {
        /// Candidates a pixel draws, in 1..=256.
        candidates: u32,
        /// Lights kept and shaded, in 1..=8 (1 with temporal reuse).
        kept: u32,
        /// Temporal reuse: the previous reservoir's count capped at this many frames' worth
        /// of candidates, in 1..=100; `None`: none.
        temporal: Option<u32>,
        /// Spatial reuse (with `temporal`): which neighbours join and how; `None`: none.
        #[serde(default)]
        spatial: Option<SpatialReuse>,
    },
    /// Stochastic light culling (Tokuyoshi and Harada 2016): each light's range is drawn per
    /// frame by Russian roulette, a light reaching a point with probability
    /// `min(1, luminance(intensity) / (d^2 threshold))`, and a light kept there is weighted by
    /// the inverse of that probability. Lists are built with the drawn ranges, so they
    /// shorten. Unbiased.
    StochasticCulling {
        /// Linear radiance below which a light's unwindowed inverse-square intensity is
        /// rouletted, in (0, 1e6].
        threshold: f32,
    },
}

/// ReSTIR's spatial reuse from the previous frame's reservoirs (Bitterli et al. 2020,
/// section 4.3; RTXDI's spatiotemporal resampling): `neighbours` pixels drawn from a disk
/// of `radius` pixels around the reprojected one, a neighbour whose surface is unlike the
/// pixel's (normals over 25 degrees apart, or depths over 10% apart, as RTXDI rejects them)
/// left out, each other one's reservoir one candidate standing for its count M.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SpatialReuse {
    /// Neighbours a pixel draws, in 1..=8.
    pub neighbours: u32,
    /// Radius of their disk in pixels, in 1..=64.
    pub radius: u32,
    /// How the reservoirs combine: `true`, each weighted by the generalised balance
    /// heuristic over the combined surfaces (Bitterli 2020, eq. 22: unbiased while the
    /// scene holds still); `false`, by 1/M over every combined count (cheaper, biased
    /// where a neighbour's surface reaches lights the pixel's does not).
    pub balance: bool,
}

impl Lights {
    /// The sampler, if the loop samples.
    pub fn sampling(&self) -> Option<&Sampling> {
        match self {
            Lights::Exact => None,
            Lights::Sampled(s) => Some(s),
        }
    }

    /// Whether each frame draws the lights' ranges, and so builds its lists, again
    /// (stochastic culling: a real frame has new random numbers, so a frame never keeps the
    /// lists of the one before).
    pub fn redraws_ranges(&self) -> bool {
        matches!(
            self.sampling().map(|s| s.method),
            Some(Sampler::StochasticCulling { .. })
        )
    }
}

impl Sampling {
    /// Whether the estimate's expectation is the exact sum on every frame (temporal reuse
    /// keeps it only while nothing moves: `unbiased_when_still`).
    pub fn unbiased(&self) -> bool {
        !self.reuses_frames()
    }

    /// Whether the estimator reuses earlier frames' reservoirs.
    pub fn reuses_frames(&self) -> bool {
        matches!(
            self.method,
            Sampler::Ris {
                temporal: Some(_),
                ..
            }
        )
    }

    /// How a report labels the estimator's bias.
    pub fn bias_label(&self) -> &'static str {
        match self.method {
            _ if self.unbiased() => "unbiased",
            Sampler::Ris {
                spatial: Some(SpatialReuse { balance: false, .. }),
                ..
            } => "biased: 1/M across surfaces",
            _ => "unbiased while still, biased in motion",
        }
    }

    /// A short label: `RIS 8/1`, `RIS 8 +temporal 20`, `stochastic culling 0.01`.
    pub fn label(&self) -> String {
        match self.method {
            Sampler::Ris {
                candidates,
                kept,
                temporal,
                spatial,
            } => {
                let t = temporal.map_or(String::new(), |t| format!(" +temporal {t}"));
                let s = spatial.map_or(String::new(), |s| {
                    let mis = if s.balance { "balance" } else { "1/M" };
                    format!(" +spatial {}x{}px {mis}", s.neighbours, s.radius)
                });
                format!("RIS {candidates}/{kept}{t}{s}")
            }
            Sampler::StochasticCulling { threshold } => format!("stochastic culling {threshold}"),
            Sampler::Uniform { candidates } => format!("uniform {candidates}"),
        }
    }
}

/// BRDFs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub enum ShadingModel {
    /// Diffuse only: `albedo * max(n.l, 0)`.
    Lambert,
    /// Lambert plus a Blinn-Phong highlight `specular * max(n.h, 0)^shininess`.
    BlinnPhong {
        /// Exponent, in 1..=4096.
        shininess: f32,
        /// Strength of the white highlight, in 0..=1.
        specular: f32,
    },
    /// Metallic-roughness GGX as Filament documents it: Trowbridge-Reitz distribution,
    /// height-correlated Smith visibility (Heitz 2014), Schlick Fresnel, Lambert diffuse
    /// `(1 - metallic) base`; roughness and metallic come from each material.
    Ggx,
}

/// Post-processing effects; each is off unless given.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Post {
    /// Quantised (cel) shading.
    pub toon: Option<Toon>,
    /// Bright parts of the image bleed into their surroundings.
    pub bloom: Option<Bloom>,
    /// Blur along each pixel's screen-space motion.
    pub motion_blur: Option<MotionBlur>,
}

impl Post {
    /// The effects this variant has, in the order a frame applies them.
    pub fn effects(&self) -> impl Iterator<Item = PostEffect> + '_ {
        PostEffect::iter().filter(|e| match e {
            PostEffect::Toon => self.toon.is_some(),
            PostEffect::Bloom => self.bloom.is_some(),
            PostEffect::MotionBlur => self.motion_blur.is_some(),
        })
    }
}

/// Toon shading.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Toon {
    /// Where the bands are made.
    pub mode: ToonMode,
    /// Number of bands, in 2..=32.
    pub bands: u32,
    /// Dark outlines where depth jumps; the threshold is a relative view-depth step. They
    /// run in the toon compute pass, with either mode.
    pub outlines: Option<Outlines>,
}

impl Default for Toon {
    fn default() -> Self {
        Self {
            mode: ToonMode::PerLight,
            bands: 4,
            outlines: None,
        }
    }
}

/// Where toon bands are made.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub enum ToonMode {
    /// Each light's diffuse term goes through the band ramp inside the shading pass.
    PerLight,
    /// A compute pass quantises the norm of the accumulated colour on the display scale
    /// n / (1 + n), to the middle of each band, and keeps its hue.
    PostProcess,
}

/// Depth-edge outlines.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Outlines {
    /// Relative view-depth step between neighbours that makes an edge, in (0, 1].
    pub depth_threshold: f32,
}

impl Default for Outlines {
    fn default() -> Self {
        Self {
            depth_threshold: 0.1,
        }
    }
}

/// Bloom.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Bloom {
    /// Linear HDR luminance above which a pixel blooms, >= 0.
    pub threshold: f32,
    /// Blur radius in pixels, in 1..=64; the Gaussian's sigma is radius / 2.
    pub radius: u32,
    /// How the blur is computed.
    pub kernel: BloomKernel,
}

impl Default for Bloom {
    fn default() -> Self {
        Self {
            threshold: 1.0,
            radius: 4,
            kernel: BloomKernel::Separable,
        }
    }
}

/// Bloom blur kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub enum BloomKernel {
    /// One pass over a full d x d window (d = 2 radius + 1): d^2 taps a pixel.
    Naive,
    /// A horizontal then a vertical pass: 2 d taps a pixel.
    Separable,
}

/// Motion blur.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct MotionBlur {
    /// Samples along each pixel's motion vector (from the previous frame's camera), in
    /// 2..=64.
    pub samples: u32,
}

impl Default for MotionBlur {
    fn default() -> Self {
        Self { samples: 8 }
    }
}

/// Diagnostic views that replace the shaded image.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema, strum::IntoStaticStr,
)]
#[strum(serialize_all = "kebab-case")]
pub enum DebugView {
    /// The shaded image.
    Off,
    /// Each cluster in its own colour (clustered pipelines).
    ClusterIndex,
    /// Heat map of the number of lights in each pixel's cluster (clustered pipelines).
    LightsPerCluster,
    /// Each z-slice in its own colour (clustered pipelines).
    ZSlice,
    /// One G-buffer channel (deferred pipelines).
    #[strum(serialize = "gbuffer")]
    GBuffer {
        /// Which channel.
        channel: GBufferChannel,
    },
}

/// G-buffer channels a debug view can show.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Serialize,
    Deserialize,
    JsonSchema,
    strum::IntoStaticStr,
    strum::EnumIter,
)]
#[strum(serialize_all = "kebab-case")]
pub enum GBufferChannel {
    /// World position (fractional part of each coordinate).
    Position,
    /// Decoded normal, mapped from [-1, 1] to [0, 1].
    Normal,
    /// Albedo.
    Albedo,
    /// Linear view depth.
    Depth,
}

impl DebugView {
    /// Every view, `Off` first, each G-buffer channel its own.
    pub fn every() -> Vec<DebugView> {
        use strum::IntoEnumIterator;
        // A new view joins the list: without its arm here this does not compile.
        let _every_arm = |v: DebugView| match v {
            DebugView::Off
            | DebugView::ClusterIndex
            | DebugView::LightsPerCluster
            | DebugView::ZSlice
            | DebugView::GBuffer { .. } => (),
        };
        let plain = [
            DebugView::Off,
            DebugView::ClusterIndex,
            DebugView::LightsPerCluster,
            DebugView::ZSlice,
        ];
        let channels = GBufferChannel::iter().map(|channel| DebugView::GBuffer { channel });
        plain.into_iter().chain(channels).collect()
    }

    /// The command-line name: `lights-per-cluster`, `gbuffer-normal`.
    pub fn name(self) -> String {
        let view: &str = self.into();
        match self {
            DebugView::GBuffer { channel } => format!("{view}-{}", <&str>::from(channel)),
            _ => view.to_string(),
        }
    }

    /// The view of a command-line name.
    pub fn named(name: &str) -> Option<DebugView> {
        DebugView::every().into_iter().find(|v| v.name() == name)
    }
}
