//! Semantic checks: values in range and combinations that make sense.

use super::schema::*;

/// One thing wrong with a variant: the field path (as written in the file) and what would
/// be valid.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Problem {
    pub field: String,
    pub message: String,
}

fn problem(field: &str, message: impl Into<String>) -> Problem {
    Problem {
        field: field.to_string(),
        message: message.into(),
    }
}

/// Total bits a packed normal may take (two components of half as many each).
pub const NORMAL_BITS: [u32; 4] = [16, 20, 24, 32];
/// Bounds that keep every buffer well inside wgpu's default limits.
pub const MAX_GRID_XY: u32 = 128;
pub const MAX_GRID_Z: u32 = 256;
pub const MAX_CLUSTERS: u32 = 1 << 18;
/// Most tiles per big tile side in two-level culling.
pub const MAX_BIG_TILES: u32 = 32;
pub const MAX_CAP: u32 = 1024;

/// Every problem of a parsed variant, in field order; empty when the variant is valid.
pub fn check(v: &Variant) -> Vec<Problem> {
    let mut out = Vec::new();
    let p = v.pipeline;

    if v.description.trim().is_empty() {
        out.push(problem(
            "description",
            "is empty; say in one line what this variant measures",
        ));
    }
    if v.depth_prepass && p.is_deferred() {
        out.push(problem(
            "depth_prepass",
            format!(
                "only forward pipelines have a depth pre-pass (pipeline is {p:?}); remove it or use NaiveForward or ClusteredForward"
            ),
        ));
    }
    match &v.clusters {
        Some(_) if !p.is_clustered() => out.push(problem(
            "clusters",
            format!(
                "pipeline {p:?} has no clusters; remove `clusters` or use ClusteredForward or ClusteredDeferred"
            ),
        )),
        Some(c) => check_clusters(c, v, &mut out),
        None => {}
    }
    if v.gbuffer.is_some() && !p.is_deferred() {
        out.push(problem(
            "gbuffer",
            format!(
                "only deferred pipelines have a G-buffer (pipeline is {p:?}); remove `gbuffer` or use ClusteredDeferred or DeferredScissor"
            ),
        ));
    }
    check_normals(v, &mut out);
    check_shading(&v.shading, &mut out);
    check_sampling(v, &mut out);
    check_shadows(v, &mut out);
    if v.shading.model == ShadingModel::Ggx
        && v.post
            .toon
            .as_ref()
            .is_some_and(|t| t.mode == ToonMode::PerLight)
    {
        out.push(problem(
            "post.toon.mode",
            "PerLight bands the Lambert diffuse term, which the Ggx model does not have; use mode: PostProcess with Ggx, or a Lambert or BlinnPhong model",
        ));
    }
    check_post(&v.post, v, &mut out);
    check_msaa(v, &mut out);
    check_debug_view(v, &mut out);
    out
}

fn check_clusters(c: &Clusters, v: &Variant, out: &mut Vec<Problem>) {
    let (x, y, z) = c.grid;
    for (name, value, max) in [
        ("x", x, MAX_GRID_XY),
        ("y", y, MAX_GRID_XY),
        ("z", z, MAX_GRID_Z),
    ] {
        if value == 0 || value > max {
            out.push(problem(
                "clusters.grid",
                format!("{name} is {value}; it must be in 1..={max}"),
            ));
        }
    }
    let total = x as u64 * y as u64 * z as u64;
    if total > MAX_CLUSTERS as u64 {
        out.push(problem(
            "clusters.grid",
            format!("{x}x{y}x{z} = {total} clusters; at most {MAX_CLUSTERS} are allowed"),
        ));
    }
    match c.slicing {
        ZSlicing::NearSliceThenExponential { near_slice_end } => {
            if !(near_slice_end.is_finite() && near_slice_end > 0.0) {
                out.push(problem(
                    "clusters.slicing.near_slice_end",
                    format!("is {near_slice_end}; it must be a positive view depth"),
                ));
            }
            if z < 2 {
                out.push(problem(
                    "clusters.grid",
                    "NearSliceThenExponential needs z >= 2 (a near slice and at least one more)",
                ));
            }
        }
        ZSlicing::DynamicRange {
            source: DepthRangeSource::CurrentFrame,
        } if v.pipeline == Pipeline::ClusteredForward && !v.depth_prepass => {
            out.push(problem(
                "clusters.slicing.source",
                "CurrentFrame needs this frame's depth before shading: set `depth_prepass: true`, use PreviousFrame, or use ClusteredDeferred",
            ));
        }
        _ => {}
    }
    if c.assignment == Assignment::Cpu {
        if matches!(c.slicing, ZSlicing::DynamicRange { .. }) {
            out.push(problem(
                "clusters.assignment",
                "Cpu assignment needs a z-range known before the frame; use static slicing or Gpu assignment",
            ));
        }
        if c.active_clusters {
            out.push(problem(
                "clusters.assignment",
                "Cpu assignment cannot see which clusters are active (that needs this frame's depth on the GPU); turn active_clusters off or use Gpu assignment",
            ));
        }
    }
    if let LightLists::Capped { max_per_cluster } = c.lists
        && (max_per_cluster == 0 || max_per_cluster > MAX_CAP)
    {
        out.push(problem(
            "clusters.lists.max_per_cluster",
            format!("is {max_per_cluster}; it must be in 1..={MAX_CAP}"),
        ));
    }
    if c.sample_bounds && !c.active_clusters {
        out.push(problem(
            "clusters.sample_bounds",
            "bounds from samples come from active-cluster marking: set `active_clusters: true` too",
        ));
    }
    if c.culling == Culling::ZBinning {
        if c.active_clusters || c.sample_bounds {
            out.push(problem(
                "clusters.culling",
                "ZBinning has no clusters to mark or shrink: set `active_clusters: false` and `sample_bounds: false`",
            ));
        }
        if c.lists != LightLists::Exact {
            out.push(problem(
                "clusters.lists",
                "ZBinning keeps every light in its bins and masks: use `lists: Exact`",
            ));
        }
        if c.assignment != Assignment::Gpu {
            out.push(problem(
                "clusters.assignment",
                "ZBinning sorts and bins lights on the GPU: use `assignment: Gpu`",
            ));
        }
        if v.debug_view == DebugView::LightsPerCluster {
            out.push(problem(
                "debug_view",
                "ZBinning keeps no per-cluster light counts: use ClusterIndex or ZSlice, or another culling",
            ));
        }
    }
    if let Some(n) = c.big_tiles {
        if !(1..=MAX_BIG_TILES).contains(&n) {
            out.push(problem(
                "clusters.big_tiles",
                format!("is {n}; it must be in 1..={MAX_BIG_TILES} (tiles per big tile side)"),
            ));
        }
        if !c.culling.takes_big_tiles() || c.assignment == Assignment::Cpu {
            out.push(problem(
                "clusters.big_tiles",
                "two-level culling builds per-cluster lists on the GPU: remove `big_tiles`, or use Boxes or DepthMask culling with Gpu assignment",
            ));
        }
    }
    // The CPU builds lists by the box test (with or without depth masks) alone; z-binning
    // says why itself, above.
    if c.assignment != Assignment::Gpu && !c.culling.takes_cpu_assignment() {
        out.push(problem(
            "clusters.assignment",
            format!(
                "{:?} builds its lists on the GPU: use `assignment: Gpu`",
                c.culling
            ),
        ));
    }
    if c.culling == Culling::DepthMask && !c.sample_bounds {
        out.push(problem(
            "clusters.culling",
            "DepthMask cuts each cluster's sample depth range into cells: set `active_clusters: true` and `sample_bounds: true`, or use `culling: Boxes`",
        ));
    }
    if c.active_clusters && v.pipeline == Pipeline::ClusteredForward && !v.depth_prepass {
        out.push(problem(
            "clusters.active_clusters",
            "marking active clusters needs depth before shading: set `depth_prepass: true` or use ClusteredDeferred",
        ));
    }
    check_update(c, out);
}

/// A list strategy other than `Rebuild` works on exact GPU lists that equal one-level
/// assignment's (it patches or splits them with one-level's own test); `Refit` needs the
/// light BVH.
fn check_update(c: &Clusters, out: &mut Vec<Problem>) {
    let update = c.update;
    if update == ListUpdate::Rebuild {
        return;
    }
    if update == ListUpdate::Refit {
        if c.culling != Culling::Bvh {
            out.push(problem(
                "clusters.update",
                format!(
                    "Refit refits the light BVH's tree, and culling is {:?}: use `culling: Bvh`, or Rebuild, StaticDynamic or Patch",
                    c.culling
                ),
            ));
        }
        return;
    }
    if !c.culling.keeps_one_level_lists() {
        out.push(problem(
            "clusters.update",
            format!(
                "{update:?} keeps lists that equal one-level assignment's, and {:?} culling's do not: use Boxes, DepthMask or Bvh culling, or `update: Rebuild`",
                c.culling
            ),
        ));
    }
    if c.lists != LightLists::Exact {
        out.push(problem(
            "clusters.update",
            format!(
                "{update:?} needs every light of a list (a cap forgets the lights it drops): use `lists: Exact`, or `update: Rebuild`"
            ),
        ));
    }
    if c.assignment != Assignment::Gpu {
        out.push(problem(
            "clusters.update",
            format!("{update:?} updates the lists on the GPU: use `assignment: Gpu`, or `update: Rebuild`"),
        ));
    }
}

fn check_normals(v: &Variant, out: &mut Vec<Problem>) {
    let Some(codec) = v.normals else { return };
    let bits = codec.bits();
    if codec != NormalCodec::Xyz && !NORMAL_BITS.contains(&bits) {
        out.push(problem(
            "normals.bits",
            format!("is {bits}; it must be one of 16, 20, 24 or 32"),
        ));
    }
    if !v.pipeline.is_deferred() {
        out.push(problem(
            "normals",
            format!(
                "only a G-buffer stores normals (pipeline is {:?}); remove `normals` or use a deferred pipeline",
                v.pipeline
            ),
        ));
        return;
    }
    let layout = v.gbuffer().layout;
    match (layout, codec) {
        (GBufferLayout::Wide, NormalCodec::Xyz) => {}
        (GBufferLayout::Wide, _) => out.push(problem(
            "normals",
            "the Wide layout stores normals as xyz floats; use `normals: Xyz`, or a Packed or Compact layout for a packed codec",
        )),
        (_, NormalCodec::Xyz) => out.push(problem(
            "normals",
            format!(
                "the {layout:?} layout has room for a 2-component normal; use Octahedral, Polar or Spheremap"
            ),
        )),
        _ => {}
    }
}

fn check_shading(s: &Shading, out: &mut Vec<Problem>) {
    if !(0.0..=1.0).contains(&s.ambient) {
        out.push(problem(
            "shading.ambient",
            format!("is {}; it must be in 0..=1", s.ambient),
        ));
    }
    if let ShadingModel::BlinnPhong {
        shininess,
        specular,
    } = s.model
    {
        if !(1.0..=4096.0).contains(&shininess) {
            out.push(problem(
                "shading.model.shininess",
                format!("is {shininess}; it must be in 1..=4096"),
            ));
        }
        if !(0.0..=1.0).contains(&specular) {
            out.push(problem(
                "shading.model.specular",
                format!("is {specular}; it must be in 0..=1"),
            ));
        }
    }
}

/// Most shadow rays a sampled estimate traces per pixel.
pub const MAX_SHADOW_RAYS: u32 = 16;

/// Shadows where a frame can trace them and the reference can hold them to its bound.
fn check_shadows(v: &Variant, out: &mut Vec<Problem>) {
    if !v.shading.shadows.traced() {
        return;
    }
    let mut refuse = |why: String| out.push(problem("shading.shadows", why));
    if v.pipeline == Pipeline::DeferredScissor {
        refuse(
            "DeferredScissor adds each light in its own rectangle, outside the light loops that trace shadow rays; use ClusteredDeferred, ClusteredForward or NaiveForward, or shadows: None".into(),
        );
    }
    if v.pipeline.is_clustered() && v.clusters().update == ListUpdate::StaticDynamic {
        refuse(
            "StaticDynamic shades its still lights once into an image kept across frames, and its light loop traces no shadow rays yet; use update: Rebuild, Patch or Refit, or shadows: None".into(),
        );
    }
    if v.shading.lights.sampling().is_some() {
        refuse(
            "shadows trace rays to the lights of an exact light loop, and a sampled light loop shades a few of them; use lights: Exact with it, or shadows: None".into(),
        );
    }
    let zbinning = v.pipeline.is_clustered() && v.clusters().method() == CullingMethod::ZBinning;
    if v.shading.shadows.sampling().is_some() && zbinning {
        refuse(
            "Sampled draws its rays' lights from a list, and z-binning walks bins and tile masks; use another culling, or shadows: Exact".into(),
        );
    }
    if let Some(s) = v.shading.shadows.sampling()
        && !(1..=MAX_SHADOW_RAYS).contains(&s.rays)
    {
        refuse(format!(
            "Sampled: rays is {}; it must be in 1..={MAX_SHADOW_RAYS}",
            s.rays
        ));
    }
    let after_shading = [
        (
            "toon",
            v.post
                .toon
                .as_ref()
                .is_some_and(|t| t.mode == ToonMode::PostProcess),
        ),
        ("bloom", v.post.bloom.is_some()),
        ("motion_blur", v.post.motion_blur.is_some()),
    ];
    for (effect, _) in after_shading.iter().filter(|(_, on)| *on) {
        refuse(format!(
            "post.{effect} works on the shaded image, and the reference bounds a shadow's ambiguous pixels in the shading itself (docs/design.md, Shadows); remove post.{effect} (toon's PerLight mode is shading), or use shadows: None"
        ));
    }
}

/// Most candidates a sampled light loop draws per pixel.
pub const MAX_CANDIDATES: u32 = 256;
/// Most lights RIS keeps per pixel.
pub const MAX_KEPT: u32 = 8;
/// Longest temporal history, in frames' worth of candidates.
pub const MAX_HISTORY: u32 = 100;
/// Most neighbours, and the largest disk in pixels, of spatial reuse.
pub const MAX_NEIGHBOURS: u32 = 8;
pub const MAX_SPATIAL_RADIUS: u32 = 64;

fn check_sampling(v: &Variant, out: &mut Vec<Problem>) {
    let Some(s) = v.shading.lights.sampling() else {
        return;
    };
    let p = v.pipeline;
    if p == Pipeline::DeferredScissor {
        out.push(problem(
            "shading.lights",
            "DeferredScissor blends one draw per light and has no per-pixel loop to sample; use `lights: Exact`, or NaiveForward, ClusteredForward or ClusteredDeferred",
        ));
    }
    let c = v.clusters();
    if p.is_clustered() && c.update == ListUpdate::StaticDynamic {
        out.push(problem(
            "shading.lights",
            "a sampled loop draws from one list, and StaticDynamic shades two: use `lights: Exact`, or `clusters.update` Rebuild, Patch or Refit",
        ));
    }
    if p.is_clustered() && c.culling == Culling::ZBinning {
        out.push(problem(
            "shading.lights",
            "z-binning's lights are a walk over bitmasks, not a list to draw from: use `lights: Exact`, or another culling",
        ));
    }
    if v.msaa.on() {
        out.push(problem(
            "shading.lights",
            "sampled loops shade one point a pixel (their random numbers are per pixel): use `msaa: (samples: 1)` or `lights: Exact`",
        ));
    }
    match s.method {
        Sampler::Ris {
            candidates,
            kept,
            temporal,
            spatial,
        } => {
            if let Some(sp) = spatial {
                if temporal.is_none() {
                    out.push(problem(
                        "shading.lights.method.spatial",
                        "spatial reuse draws on the previous frame's reservoirs, which temporal reuse keeps: give `temporal: Some(N)`, or `spatial: None`",
                    ));
                }
                if !(1..=MAX_NEIGHBOURS).contains(&sp.neighbours) {
                    out.push(problem(
                        "shading.lights.method.spatial.neighbours",
                        format!("is {}; it must be in 1..={MAX_NEIGHBOURS}", sp.neighbours),
                    ));
                }
                if !(1..=MAX_SPATIAL_RADIUS).contains(&sp.radius) {
                    out.push(problem(
                        "shading.lights.method.spatial.radius",
                        format!("is {}; it must be in 1..={MAX_SPATIAL_RADIUS}", sp.radius),
                    ));
                }
            }
            if !(1..=MAX_CANDIDATES).contains(&candidates) {
                out.push(problem(
                    "shading.lights.method.candidates",
                    format!("is {candidates}; it must be in 1..={MAX_CANDIDATES}"),
                ));
            }
            if !(1..=MAX_KEPT).contains(&kept) {
                out.push(problem(
                    "shading.lights.method.kept",
                    format!("is {kept}; it must be in 1..={MAX_KEPT}"),
                ));
            }
            if let Some(t) = temporal {
                if !(1..=MAX_HISTORY).contains(&t) {
                    out.push(problem(
                        "shading.lights.method.temporal",
                        format!("is {t}; it must be in 1..={MAX_HISTORY}, or None"),
                    ));
                }
                if kept != 1 {
                    out.push(problem(
                        "shading.lights.method.kept",
                        format!(
                            "is {kept}; temporal reuse keeps one reservoir a pixel: use `kept: 1`"
                        ),
                    ));
                }
                if p != Pipeline::ClusteredDeferred {
                    out.push(problem(
                        "shading.lights.method.temporal",
                        format!(
                            "temporal reuse keeps a reservoir per pixel, which needs one shading a pixel from a G-buffer (pipeline is {p:?}): use ClusteredDeferred, or `temporal: None`"
                        ),
                    ));
                }
            }
        }
        Sampler::Uniform { candidates } => {
            if !(1..=MAX_CANDIDATES).contains(&candidates) {
                out.push(problem(
                    "shading.lights.method.candidates",
                    format!("is {candidates}; it must be in 1..={MAX_CANDIDATES}"),
                ));
            }
        }
        Sampler::StochasticCulling { threshold } => {
            if p.is_clustered() && c.update != ListUpdate::Rebuild {
                out.push(problem(
                    "shading.lights",
                    format!(
                        "stochastic culling draws every light's range again each frame, so its lists are rebuilt, and `clusters.update` is {:?}: use `update: Rebuild`",
                        c.update
                    ),
                ));
            }
            if !(threshold > 0.0 && threshold <= 1e6) {
                out.push(problem(
                    "shading.lights.method.threshold",
                    format!("is {threshold}; it must be in (0, 1e6]"),
                ));
            }
        }
    }
}

fn check_post(post: &Post, v: &Variant, out: &mut Vec<Problem>) {
    if let Some(toon) = &post.toon {
        if !(2..=32).contains(&toon.bands) {
            out.push(problem(
                "post.toon.bands",
                format!("is {}; it must be in 2..=32", toon.bands),
            ));
        }
        if let Some(o) = &toon.outlines
            && !(o.depth_threshold > 0.0 && o.depth_threshold <= 1.0)
        {
            out.push(problem(
                "post.toon.outlines.depth_threshold",
                format!("is {}; it must be in (0, 1]", o.depth_threshold),
            ));
        }
    }
    if let Some(bloom) = &post.bloom {
        if !(bloom.threshold.is_finite() && bloom.threshold >= 0.0) {
            out.push(problem(
                "post.bloom.threshold",
                format!("is {}; it must be a finite value >= 0", bloom.threshold),
            ));
        }
        if !(1..=64).contains(&bloom.radius) {
            out.push(problem(
                "post.bloom.radius",
                format!("is {}; it must be in 1..=64", bloom.radius),
            ));
        }
    }
    if let Some(mb) = &post.motion_blur
        && !(2..=64).contains(&mb.samples)
    {
        out.push(problem(
            "post.motion_blur.samples",
            format!("is {}; it must be in 2..=64", mb.samples),
        ));
    }
    if post.any() && v.debug_view != DebugView::Off {
        out.push(problem(
            "debug_view",
            "a debug view replaces the shaded image, so post effects would have nothing to work on; turn one of them off",
        ));
    }
}

/// Sample counts a variant may ask for (the adapter may offer fewer).
pub const SAMPLE_COUNTS: [u32; 4] = [1, 2, 4, 8];

fn check_msaa(v: &Variant, out: &mut Vec<Problem>) {
    let samples = v.msaa.samples;
    if !SAMPLE_COUNTS.contains(&samples) {
        out.push(problem(
            "msaa.samples",
            format!("is {samples}; it must be one of {SAMPLE_COUNTS:?}"),
        ));
        return;
    }
    if !v.msaa.on() {
        return;
    }
    // What reads one sample a pixel of depth or the G-buffer.
    let single_sample_readers = [
        (
            v.debug_view != DebugView::Off,
            "debug_view",
            "debug views read one sample a pixel; use samples: 1 with a debug view",
        ),
        (
            v.post.toon.as_ref().is_some_and(|t| t.outlines.is_some()),
            "post.toon.outlines",
            "outlines read one depth sample a pixel; remove them or use samples: 1",
        ),
        (
            v.post.motion_blur.is_some(),
            "post.motion_blur",
            "motion blur reads one depth sample a pixel; remove it or use samples: 1",
        ),
    ];
    for (refused, field, why) in single_sample_readers {
        if refused {
            out.push(problem(
                field,
                format!("with msaa.samples {samples}: {why}"),
            ));
        }
    }
}

fn check_debug_view(v: &Variant, out: &mut Vec<Problem>) {
    let p = v.pipeline;
    match v.debug_view {
        DebugView::ClusterIndex | DebugView::LightsPerCluster | DebugView::ZSlice
            if !p.is_clustered() =>
        {
            out.push(problem(
                "debug_view",
                format!(
                    "{:?} shows clusters, and pipeline {p:?} has none; use a clustered pipeline",
                    v.debug_view
                ),
            ))
        }
        DebugView::GBuffer { .. } if !p.is_deferred() => out.push(problem(
            "debug_view",
            format!("pipeline {p:?} has no G-buffer to show; use a deferred pipeline"),
        )),
        _ => {}
    }
}

impl Post {
    /// Whether any post effect is on.
    pub fn any(&self) -> bool {
        self.toon.is_some() || self.bloom.is_some() || self.motion_blur.is_some()
    }
}

impl Variant {
    /// The cluster settings in effect (the defaults when the file leaves them out).
    pub fn clusters(&self) -> Clusters {
        self.clusters.clone().unwrap_or_default()
    }
    /// Whether a frame's lists are built on the depth range the previous frame reduced (a
    /// renderer's first frame, or a sequence's first after the view moved, on another).
    pub fn range_from_previous_frame(&self) -> bool {
        self.pipeline.is_clustered()
            && self.clusters().slicing
                == (ZSlicing::DynamicRange {
                    source: DepthRangeSource::PreviousFrame,
                })
    }
    /// The G-buffer settings in effect (the defaults when the file leaves them out).
    pub fn gbuffer(&self) -> GBuffer {
        self.gbuffer.clone().unwrap_or_default()
    }
    /// The normal codec in effect: the file's, or the layout's default.
    pub fn normal_codec(&self) -> NormalCodec {
        self.normals.unwrap_or(match self.gbuffer().layout {
            GBufferLayout::Wide => NormalCodec::Xyz,
            GBufferLayout::Packed | GBufferLayout::Compact => NormalCodec::Octahedral {
                bits: 32,
                precise: true,
            },
        })
    }
}
