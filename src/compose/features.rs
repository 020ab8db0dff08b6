//! What a variant turns on in the shaders: WESL `@if` feature flags, and the numbers of the
//! generated `constants` module.

use std::fmt::Write;

use strum::IntoEnumIterator;

use crate::variant::*;

/// Lights per row of the per-light dispatches: a dispatch dimension holds at most 65535
/// workgroups (`clustering/assignment.wesl`, `passes/zbin_assign.wesl`).
pub const LIGHTS_PER_ROW: u32 = 32768;
/// Invocations of one prefix-sum workgroup (`clustering/lists.wesl`).
pub const SCAN_LANES: u32 = 256;
/// Clusters one scan invocation adds up in turn before the workgroup scan: a software GPU
/// pays for every invocation at every barrier, so fewer invocations with more clusters each
/// scan faster there.
pub const CLUSTERS_PER_LANE: u32 = 4;
/// Clusters of one prefix-sum block: a workgroup of the first level each.
pub const SCAN_BLOCK: u32 = SCAN_LANES * CLUSTERS_PER_LANE;
/// What a walk of light assignment reports as its length (`ClusterStats::longest_walk`) when
/// a software GPU's loop budget cut it short (`passes/assign_two_level.wesl`,
/// `assign_bvh.wesl`).
pub const WALK_CUT_SHORT: u32 = u32::MAX;

/// Words a pixel's shadow ray counters take: rays, those blocked, nodes visited
/// (`shading/light_loop/counters.wesl`, `pixel_rays`).
pub const RAY_COUNTERS: u32 = 3;

/// What a scene turns on in its frames' shaders.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneFeatures {
    /// Spot lights (a scene without spots needs no cone in its light loops: on a software
    /// rasteriser, which runs both sides of a branch, the cone costs point lights about half
    /// again).
    pub spots: bool,
    /// Base colour textures.
    pub textures: bool,
    /// Masked materials: the raster passes discard below the cutoff.
    pub masks: bool,
    /// Blended materials: the transparent passes.
    pub blend: bool,
}

impl SceneFeatures {
    /// What `scene` needs; its spot cone only where `spots` (a renderer that skips nothing
    /// keeps it).
    pub fn of(scene: &crate::scene::Scene, spots: bool) -> Self {
        SceneFeatures {
            spots,
            textures: scene.textures.is_some(),
            masks: scene.has_masks(),
            blend: scene.has_blend(),
        }
    }

    /// The flags they set.
    pub fn flags(self) -> [(&'static str, bool); 4] {
        [
            ("spot_lights", self.spots),
            ("base_color_texture", self.textures),
            ("alpha_mask", self.masks),
            ("blend", self.blend),
        ]
    }
}

/// The flags a frame sets over its variant's: what its scene needs, and for an instrumented
/// frame `stats` with `count_every_light` (`Some`: whether it counts every light, as the
/// clustered stand-in of naive forward does).
pub fn frame_features(
    scene: SceneFeatures,
    instrumented: Option<bool>,
) -> Vec<(&'static str, bool)> {
    let mut flags = scene.flags().to_vec();
    if let Some(count_every_light) = instrumented {
        flags.extend([("stats", true), ("count_every_light", count_every_light)]);
    }
    flags
}

/// The feature flags of `v` with some set otherwise: `stats` for an instrumented frame of a
/// pass, or what a scene needs (`spot_lights` off without spots, `base_color_texture` on
/// with textures).
pub fn features_with(v: &Variant, overrides: &[(&str, bool)]) -> Vec<(&'static str, bool)> {
    let mut features = feature_flags(v);
    for (name, on) in &mut features {
        if let Some(&(_, value)) = overrides.iter().find(|(n, _)| n == name) {
            *on = value;
        }
    }
    features
}

/// Every feature flag the shaders may test, with its value for `v`. All flags are always
/// set (true or false): the composer treats an unset flag as an error.
/// The test mode that shows what another rasteriser's depth would do: every marking pass
/// reads the depth buffer moved by N units in the last place, up at pixels whose x + y is
/// even and down at the others (`common/depth.wesl`, `perturbed`), as a GPU whose
/// interpolation or rounding differs from lavapipe's may store it. Unset or 0: off.
pub const PERTURB_DEPTH_VAR: &str = "CLUSTERLAB_PERTURB_DEPTH_ULPS";

/// Most units in the last place the test mode may move a depth.
pub const MAX_PERTURB_DEPTH_ULPS: u32 = 1 << 16;

/// N of [`PERTURB_DEPTH_VAR`] (0 when unset or not a number: `check_environment` refuses
/// such a value before anything runs).
pub fn perturbed_depth_ulps() -> u32 {
    crate::environment::var(PERTURB_DEPTH_VAR)
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

/// What a run perturbed by [`PERTURB_DEPTH_VAR`] prints first, and None for a stock run.
pub fn perturbation_note() -> Option<String> {
    match perturbed_depth_ulps() {
        0 => None,
        n => Some(format!(
            "note: {PERTURB_DEPTH_VAR}={n}: every depth the marking passes read is moved {n} units in the last place (a test mode of what another rasteriser may store); results record it, and their figures are not a stock run's"
        )),
    }
}

/// The variant's spatial reuse, if its light loop has one.
fn spatial_reuse(v: &Variant) -> Option<crate::variant::SpatialReuse> {
    match v.shading.lights.sampling()?.method {
        Sampler::Ris { spatial, .. } => spatial,
        Sampler::Uniform { .. } | Sampler::StochasticCulling { .. } => None,
    }
}

pub fn feature_flags(v: &Variant) -> Vec<(&'static str, bool)> {
    let p = v.pipeline;
    let shadow_sampler = v.shading.shadows.sampling().map(|s| s.method);
    let clusters = v.clusters();
    let codec = v.normal_codec();
    let layout = v.gbuffer().layout;
    let deferred = p.is_deferred();
    let toon = v.post.toon.as_ref();
    let slicing = clusters.slicing;
    let static_dynamic = p.is_clustered() && clusters.update == ListUpdate::StaticDynamic;
    let sampling = v.shading.lights.sampling().map(|s| s.method);
    let ris = matches!(sampling, Some(Sampler::Ris { .. }));
    let mut flags = vec![
        // Sampled light loops (`shading.lights`): RIS, with or without temporal reuse, or
        // stochastic light culling.
        ("sampled", sampling.is_some()),
        ("ris", ris),
        (
            "temporal_reuse",
            matches!(
                sampling,
                Some(Sampler::Ris {
                    temporal: Some(_),
                    ..
                })
            ),
        ),
        (
            "stochastic_culling",
            matches!(sampling, Some(Sampler::StochasticCulling { .. })),
        ),
        (
            "spatial_balance",
            spatial_reuse(v).is_some_and(|s| s.balance),
        ),
        (
            "uniform_sampling",
            matches!(sampling, Some(Sampler::Uniform { .. })),
        ),
        (
            "blinn_phong",
            matches!(v.shading.model, ShadingModel::BlinnPhong { .. }),
        ),
        ("ggx", v.shading.model == ShadingModel::Ggx),
        ("shadows", v.shading.shadows.traced()),
        ("shadows_exact", v.shading.shadows == Shadows::Exact),
        ("shadows_sampled", shadow_sampler.is_some()),
        (
            "shadows_importance",
            shadow_sampler == Some(ShadowSampler::Importance),
        ),
        (
            "shadows_ratio",
            shadow_sampler == Some(ShadowSampler::Ratio),
        ),
        // The spot cone in the shading: on for every variant; a renderer turns it off for a
        // scene without spots (`render::Renderer::new`).
        ("spot_lights", true),
        // The base colour texture: off for every variant; a renderer turns it on for a scene
        // that has textures (a file scene).
        ("base_color_texture", false),
        // Masked and blended materials: off for every variant; a renderer turns them on for
        // a scene that has them.
        ("alpha_mask", false),
        ("blend", false),
        (
            "spot_cone_test",
            p.is_clustered() && clusters.spot_test == SpotTest::Cone,
        ),
        ("clustered", p.is_clustered()),
        ("deferred", deferred),
        ("depth_prepass", v.depth_prepass),
        ("msaa", v.msaa.on()),
        (
            "resolve_tonemapped",
            v.msaa.on() && v.msaa.resolve == MsaaResolve::Tonemapped,
        ),
        ("reversed_z", v.depth.reversed_z),
        ("perturbed_depth", perturbed_depth_ulps() > 0),
        ("depth_unorm24", v.depth.format == DepthFormat::Unorm24),
        // The device forces early depth tests (`Gpu::early_depth`; off for an instrumented
        // frame where it does not, whose passes then test depth themselves), and the pass is
        // the transparent one (`passes::pass_flags`).
        ("early_depth", true),
        ("transparent_pass", false),
        ("infinite_far", v.depth.mapping().infinite_far),
        (
            "capped_lists",
            matches!(clusters.lists, LightLists::Capped { .. }),
        ),
        ("active_clusters", clusters.active_clusters),
        // StaticDynamic: the still and moving lights' lists, the still lists leaving the
        // moving lights out (off in the moving lists' pass, `passes::pass_flags`), and the
        // still image where the variant keeps one (written only by its own passes).
        ("static_dynamic", static_dynamic),
        ("still_lists", static_dynamic),
        ("still_cache", super::passes::keeps_still_image(v)),
        ("still_pass", false),
        ("sample_bounds", clusters.sample_bounds),
        ("depth_mask", clusters.culling.marks_depth_cells()),
        ("gbuffer_wide", deferred && layout == GBufferLayout::Wide),
        (
            "gbuffer_packed",
            deferred && layout == GBufferLayout::Packed,
        ),
        (
            "gbuffer_compact",
            deferred && layout == GBufferLayout::Compact,
        ),
        ("codec_xyz", deferred && codec == NormalCodec::Xyz),
        (
            "codec_octahedral",
            deferred && matches!(codec, NormalCodec::Octahedral { precise: false, .. }),
        ),
        (
            "codec_octahedral_precise",
            deferred && matches!(codec, NormalCodec::Octahedral { precise: true, .. }),
        ),
        (
            "codec_polar",
            deferred && matches!(codec, NormalCodec::Polar { .. }),
        ),
        (
            "codec_spheremap",
            deferred && matches!(codec, NormalCodec::Spheremap { .. }),
        ),
        (
            "toon_per_light",
            toon.is_some_and(|t| t.mode == ToonMode::PerLight),
        ),
        (
            "toon_post",
            toon.is_some_and(|t| t.mode == ToonMode::PostProcess),
        ),
        ("outlines", toon.is_some_and(|t| t.outlines.is_some())),
        // On only in instrumented frames (`Composer::compose_with`, from `Renderer::build_renderer`).
        ("stats", false),
        // On only in the clustered stand-in that naive forward counts on (`render::stats`): a clustered
        // frame that counts every light as evaluated, as naive forward evaluates them.
        ("count_every_light", false),
        (
            "debug_cluster_index",
            v.debug_view == DebugView::ClusterIndex,
        ),
        (
            "debug_lights_per_cluster",
            v.debug_view == DebugView::LightsPerCluster,
        ),
        ("debug_z_slice", v.debug_view == DebugView::ZSlice),
        (
            "debug_gbuffer",
            matches!(v.debug_view, DebugView::GBuffer { .. }),
        ),
    ];
    // One flag per z-slicing scheme, from the scheme list itself.
    flags.extend(ZSlicing::iter().map(|s| (s.feature(), s.same_scheme(slicing))));
    // Each light-assignment method's flag, from the one method the variant's fields choose.
    let method = p.is_clustered().then(|| clusters.method().flag()).flatten();
    flags.extend(METHOD_FLAGS.map(|f| (f, method == Some(f))));
    flags
}

/// The numbers of a variant as WGSL constants, in a fixed order. Every constant is always
/// present (with a neutral value when its feature is off); stripping drops unused ones.
pub fn constants_module(v: &Variant) -> String {
    let clusters = v.clusters();
    let (shininess, specular) = match v.shading.model {
        ShadingModel::Lambert | ShadingModel::Ggx => (1.0, 0.0),
        ShadingModel::BlinnPhong {
            shininess,
            specular,
        } => (shininess, specular),
    };
    let near_slice_end = match clusters.slicing {
        ZSlicing::NearSliceThenExponential { near_slice_end } => near_slice_end,
        _ => 0.0,
    };
    let cap = match clusters.lists {
        LightLists::Exact => 0,
        LightLists::Capped { max_per_cluster } => max_per_cluster,
    };
    let toon = v.post.toon.clone().unwrap_or_default();
    let outline = toon.outlines.clone().unwrap_or_default();
    let bloom = v.post.bloom.clone().unwrap_or_default();
    let motion = v.post.motion_blur.clone().unwrap_or_default();
    let (candidates, kept, history, threshold) = match v.shading.lights.sampling().map(|s| s.method)
    {
        Some(Sampler::Ris {
            candidates,
            kept,
            temporal,
            ..
        }) => (candidates, kept, temporal.unwrap_or(0), 1.0),
        Some(Sampler::StochasticCulling { threshold }) => (1, 1, 0, threshold),
        Some(Sampler::Uniform { candidates }) => (candidates, 1, 0, 1.0),
        None => (1, 1, 0, 1.0),
    };
    let spatial = spatial_reuse(v);
    let gbuffer_channel = match v.debug_view {
        DebugView::GBuffer { channel } => channel as u32,
        _ => 0,
    };

    use crate::cpu::{clusters as twin, shading};
    // The twins' numbers after the row width, where they have always been.
    let mut u32s = vec![("LIGHTS_PER_ROW", LIGHTS_PER_ROW)];
    u32s.extend_from_slice(crate::cpu::SHARED_U32S);
    u32s.extend([
        ("SCAN_LANES", SCAN_LANES),
        ("CLUSTERS_PER_LANE", CLUSTERS_PER_LANE),
        ("WALK_CUT_SHORT", WALK_CUT_SHORT),
        ("RAY_COUNTERS", RAY_COUNTERS),
        (
            "SHADOW_RAYS",
            v.shading.shadows.sampling().map_or(1, |s| s.rays),
        ),
        ("GRID_X", clusters.grid.0),
        ("GRID_Y", clusters.grid.1),
        ("GRID_Z", clusters.grid.2),
        ("MORTON_BITS", crate::cpu::bvh::morton_axis(clusters.grid).0),
        (
            "MORTON_SHIFT",
            crate::cpu::bvh::morton_axis(clusters.grid).1,
        ),
        ("RADIX_PASSES", crate::cpu::bvh::radix_passes(clusters.grid)),
        ("LIGHT_CAP", cap),
        ("BIG_TILE", clusters.big_tiles.unwrap_or(1)),
        ("NORMAL_BITS", v.normal_codec().bits() / 2),
        ("TOON_BANDS", toon.bands),
        ("BLOOM_RADIUS", bloom.radius),
        ("MOTION_BLUR_SAMPLES", motion.samples),
        ("GBUFFER_CHANNEL", gbuffer_channel),
        ("MSAA_SAMPLES", v.msaa.samples),
        ("CANDIDATES", candidates),
        ("KEPT", kept),
        ("HISTORY_FRAMES", history),
        ("SPATIAL_NEIGHBOURS", spatial.map_or(0, |s| s.neighbours)),
        ("SPATIAL_RADIUS", spatial.map_or(0, |s| s.radius)),
        ("PERTURB_DEPTH_ULPS", perturbed_depth_ulps()),
    ]);
    // The CPU twins' slack and clamps, in single precision: the same numbers on both sides.
    let f32s = [
        ("BOUNDS_PADDING", twin::BOUNDS_PADDING as f32),
        ("PLANE_SLACK", twin::PLANE_SLACK as f32),
        ("MARK_MARGIN", twin::MARK_MARGIN as f32),
        (
            "INTERPOLATION_PRECISION",
            twin::INTERPOLATION_PRECISION as f32,
        ),
        ("UNORM24_DEPTH_STEP", twin::UNORM24_DEPTH_STEP as f32),
        ("CONE_COS_SLACK", twin::CONE_COS_SLACK as f32),
        ("SPOT_SLACK", twin::SPOT_SLACK as f32),
        ("MIN_DISTANCE_SQUARED", shading::MIN_DISTANCE_SQUARED as f32),
        (
            "MIN_PERCEPTUAL_ROUGHNESS",
            shading::MIN_PERCEPTUAL_ROUGHNESS as f32,
        ),
        ("SHININESS", shininess),
        ("SPECULAR", specular),
        ("AMBIENT", v.shading.ambient),
        ("EXPOSURE", 1.0),
        ("NEAR_SLICE_END", near_slice_end),
        ("OUTLINE_THRESHOLD", outline.depth_threshold),
        ("BLOOM_THRESHOLD", bloom.threshold),
        (
            "BLOOM_SIGMA",
            crate::cpu::post::bloom_sigma(bloom.radius) as f32,
        ),
        (
            "BLOOM_WEIGHT_SUM",
            crate::cpu::post::bloom_weight_sum(bloom.radius) as f32,
        ),
        ("CULL_THRESHOLD", threshold),
        ("SHADOW_OFFSET", crate::cpu::shadows::SHADOW_OFFSET as f32),
        ("SHADOW_BOX_SLACK", crate::cpu::shadows::BOX_SLACK as f32),
    ];
    let mut text = String::new();
    for (name, value) in u32s {
        let _ = writeln!(text, "const {name}: u32 = {value}u;");
    }
    for (name, value) in f32s {
        // `{:?}` prints the shortest text that reads back as the same f32.
        let _ = writeln!(text, "const {name}: f32 = {value:?};");
    }
    text
}
