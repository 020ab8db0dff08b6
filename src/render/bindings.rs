//! Every resource a frame's passes bind, by the name their WGSL declares it by: one typed
//! name per binding, so that a name the Rust side asks for is checked by the compiler, and
//! a name a composed pass declares is checked when the pass is laid out (`Binding::declared`),
//! on every variant by the tests. The string is the WGSL's, written once (strum's
//! `snake_case`, or `serialize` where a digit makes it ambiguous).

use strum::{EnumIter, EnumString, IntoEnumIterator, IntoStaticStr};

use super::error::RenderError;

/// A resource a pass binds, by its declared name.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, EnumIter, EnumString, IntoStaticStr,
)]
#[strum(serialize_all = "snake_case")]
pub enum Binding {
    // The frame's inputs, uploaded by the CPU (`SceneBuffers`, `MovingSet`).
    View,
    Lights,
    BaseColorTextures,
    BaseColorSampler,
    MovingLights,
    MovingMask,
    Occluders,
    // The surfaces: depth, the G-buffer, and what the forward passes leave per sample.
    DepthTexture,
    #[strum(serialize = "gbuffer0")]
    Gbuffer0,
    #[strum(serialize = "gbuffer1")]
    Gbuffer1,
    #[strum(serialize = "gbuffer2")]
    Gbuffer2,
    AlbedoTexture,
    NormalTexture,
    MaterialTexture,
    ShadingDepth,
    SampleOwner,
    TransparentDepths,
    StillImage,
    Hdr,
    HdrSamples,
    // The clusters and their light lists (`ClusterBuffers`), and StaticDynamic's moving
    // lists as shading reads them.
    ClusterRange,
    ClusterActive,
    ClusterStats,
    ClusterBounds,
    LightView,
    LightRanges,
    LightCounts,
    LightOffsets,
    LightIndices,
    MovingCounts,
    MovingOffsets,
    MovingIndices,
    FillCursors,
    SampleDepths,
    DepthMasks,
    // What a culling method binds of its own (`CullingMethod::own_buffers`).
    BigTileDepths,
    CoarseMasks,
    PairClusters,
    PairLights,
    PairPlaces,
    BlockSums,
    LightProxies,
    ProxyDraw,
    ProxyPlaces,
    LightOrder,
    SortedLights,
    SortJobs,
    BinRanges,
    TileMasks,
    RadixCounts,
    BvhNodes,
    BvhBounds,
    PatchClusters,
    // The counters of instrumented frames (`shading/light_loop/counters.wesl`).
    PixelEvals,
    PixelUseful,
    PixelClusters,
    PixelShadings,
    PixelCandidates,
    PixelRays,
    // Sampled light loops (`SampleBuffers`).
    SampleFrame,
    Reservoirs,
    PreviousReservoirs,
    // The post chain's images and its indirect dispatch.
    HdrIn,
    HdrOut,
    BrightIn,
    BrightOut,
    BlurIn,
    BlurOut,
    BlurredIn,
    BlurredOut,
    BlurDispatch,
    // The raster truth (`truth`).
    TruthTarget,
    TruthSamples,
    FragmentCounts,
    FragmentOffsets,
    Fragments,
}

impl Binding {
    /// The name the WGSL declares it by.
    pub fn name(self) -> &'static str {
        self.into()
    }

    /// The binding pass `pass` declares as `name`: an error naming the pass, the name and
    /// the nearest known one where it is none of them.
    pub fn declared(pass: &str, name: &str) -> Result<Binding, RenderError> {
        name.parse().map_err(|_| {
            RenderError::Reflection(format!(
                "pass `{pass}` binds `{name}`, which is no resource of a frame{}; a new resource needs a `Binding` and a place in the frame's resources",
                crate::names::did_you_mean(name, Binding::iter().map(Binding::name))
            ))
        })
    }
}
