//! Clustering changes the cost, never the picture: every clustered variant with exact lists
//! and a full-precision G-buffer matches naive forward within 1 LSB, GPU light lists equal
//! the CPU twin's, caps count every dropped light, and lossy layouts report their error.
//! Each culling method's own checks are in its module.

mod bvh;
mod counters;
mod depth_mask;
mod loop_budget;
mod msaa;
mod one_level;
mod rasterised;
mod transparency;
mod two_level;
mod zbinning;

use std::collections::BTreeSet;

use crate::common::{self, EditedShaders, gpu, small};
use clusterlab::common::MAX_LIGHT_RADIUS;
use clusterlab::compose::Composer;
use clusterlab::cpu::clusters::{self as cpu, Grid};
use clusterlab::cpu::truth::RasterTruth;
use clusterlab::cpu::zbin::ZBins;
use clusterlab::gpu::Gpu;
use clusterlab::reference::reference_frame;
use clusterlab::render::{FrameOutput, Renderer, raster_truth};
use clusterlab::scene::{self, Light, SCENES, Scene};
use clusterlab::stress::clearly_reaches;
use clusterlab::variant::*;
use glam::DVec3;

fn loaded(name: &str, variant: Variant) -> LoadedVariant {
    LoadedVariant {
        name: name.to_string(),
        path: "generated".into(),
        variant,
    }
}

/// A depth range like the built-in scenes' cameras (for the schemes' example parameters).
const SCENE_NEAR: f64 = 0.1;
const SCENE_FAR: f64 = 60.0;

fn clustered(pipeline: Pipeline, slicing: ZSlicing) -> Variant {
    Variant {
        description: "test".into(),
        pipeline,
        depth_prepass: pipeline == Pipeline::ClusteredForward,
        clusters: Some(Clusters {
            slicing,
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// Every z-slicing scheme on both clustered pipelines, every depth set-up, the pipeline
/// options (no pre-pass, active clusters, sample bounds, CPU assignment), and scissor
/// deferred: all with exact lists and full-precision G-buffers.
fn exact_variants() -> Vec<LoadedVariant> {
    // Every scheme of the schema's list, with parameters for the built-in scenes' cameras.
    let schemes = ZSlicing::every(SCENE_NEAR, SCENE_FAR);
    let mut out = Vec::new();
    for pipeline in [Pipeline::ClusteredForward, Pipeline::ClusteredDeferred] {
        for &s in &schemes {
            out.push(loaded(
                &format!("{pipeline:?} {s:?}"),
                clustered(pipeline, s),
            ));
        }
    }
    for (format, reversed_z, infinite_far) in [
        (DepthFormat::Unorm24, false, None),
        (DepthFormat::Float32, true, None),
        (DepthFormat::Unorm24, true, None),
        (DepthFormat::Float32, false, Some(true)),
        (DepthFormat::Float32, true, Some(false)),
    ] {
        let mut v = clustered(Pipeline::ClusteredDeferred, ZSlicing::Exponential);
        v.depth = Depth {
            format,
            reversed_z,
            infinite_far,
        };
        out.push(loaded(
            &format!("deferred {format:?} reversed {reversed_z} infinite far {infinite_far:?}"),
            v,
        ));
    }
    let mut no_prepass = clustered(Pipeline::ClusteredForward, ZSlicing::Exponential);
    no_prepass.depth_prepass = false;
    out.push(loaded("forward without pre-pass", no_prepass));
    for pipeline in [Pipeline::ClusteredForward, Pipeline::ClusteredDeferred] {
        let mut v = clustered(pipeline, ZSlicing::Exponential);
        let c = v.clusters.as_mut().unwrap();
        c.active_clusters = true;
        c.sample_bounds = true;
        out.push(loaded(&format!("{pipeline:?} sample bounds"), v.clone()));
        v.clusters.as_mut().unwrap().culling = Culling::DepthMask;
        out.push(loaded(&format!("{pipeline:?} 2.5D masks"), v));
        out.push(loaded(
            &format!("{pipeline:?} tiled 2.5D"),
            depth_mask_variant(pipeline, (16, 9, 1), ZSlicing::Exponential),
        ));
        out.push(loaded(
            &format!("{pipeline:?} z-binning"),
            zbin_variant(pipeline, (16, 9, 24)),
        ));
        let mut two_level = depth_mask_variant(pipeline, (16, 9, 24), ZSlicing::Exponential);
        two_level.clusters.as_mut().unwrap().big_tiles = Some(2);
        out.push(loaded(&format!("{pipeline:?} two-level 2.5D"), two_level));
        let mut v = clustered(pipeline, ZSlicing::Exponential);
        v.clusters.as_mut().unwrap().big_tiles = Some(3);
        out.push(loaded(&format!("{pipeline:?} two-level"), v));
        for active in [false, true] {
            out.push(loaded(
                &format!("{pipeline:?} rasterised, active clusters {active}"),
                raster_variant(pipeline, (16, 9, 24), active),
            ));
        }
        out.push(loaded(
            &format!("{pipeline:?} BVH"),
            bvh_variant(
                pipeline,
                (16, 9, 24),
                pipeline == Pipeline::ClusteredForward,
            ),
        ));
    }
    let mut cpu = clustered(Pipeline::ClusteredForward, ZSlicing::Exponential);
    cpu.clusters.as_mut().unwrap().assignment = Assignment::Cpu;
    out.push(loaded("forward CPU assignment", cpu));
    out.push(loaded(
        "scissor",
        Variant {
            description: "test".into(),
            pipeline: Pipeline::DeferredScissor,
            ..Default::default()
        },
    ));
    out
}

/// 2.5D culling on `grid`: active clusters, sample bounds and depth masks.
fn depth_mask_variant(pipeline: Pipeline, grid: (u32, u32, u32), slicing: ZSlicing) -> Variant {
    let mut v = clustered(pipeline, slicing);
    let c = v.clusters.as_mut().unwrap();
    c.grid = grid;
    c.active_clusters = true;
    c.sample_bounds = true;
    c.culling = Culling::DepthMask;
    v
}

/// Z-binning over `grid`'s tiles and slices.
fn zbin_variant(pipeline: Pipeline, grid: (u32, u32, u32)) -> Variant {
    let mut v = clustered(pipeline, ZSlicing::Exponential);
    let c = v.clusters.as_mut().unwrap();
    c.grid = grid;
    c.culling = Culling::ZBinning;
    v
}

/// Rasterised binning on `grid`, with active clusters and sample bounds or without.
fn raster_variant(pipeline: Pipeline, grid: (u32, u32, u32), active: bool) -> Variant {
    let mut v = clustered(pipeline, ZSlicing::Exponential);
    let c = v.clusters.as_mut().unwrap();
    c.grid = grid;
    c.active_clusters = active;
    c.sample_bounds = active;
    c.culling = Culling::Rasterised;
    v
}

/// Olsson's light BVH on `grid`, with active clusters and sample bounds or without.
fn bvh_variant(pipeline: Pipeline, grid: (u32, u32, u32), active: bool) -> Variant {
    let mut v = raster_variant(pipeline, grid, active);
    v.clusters.as_mut().unwrap().culling = Culling::Bvh;
    v
}

/// What scenes with spots run besides `exact_variants` (whose clustered variants use the
/// cone test): the bounding-sphere test, GGX shading, and CPU assignment with the cone test.
fn spot_variants() -> Vec<LoadedVariant> {
    let mut out = Vec::new();
    for pipeline in [Pipeline::ClusteredForward, Pipeline::ClusteredDeferred] {
        let mut v = clustered(pipeline, ZSlicing::Exponential);
        v.clusters.as_mut().unwrap().spot_test = SpotTest::Sphere;
        out.push(loaded(&format!("{pipeline:?} spot sphere test"), v));
        let mut v = clustered(pipeline, ZSlicing::Exponential);
        v.shading.model = ShadingModel::Ggx;
        out.push(loaded(&format!("{pipeline:?} GGX"), v));
    }
    let mut cpu_spots = clustered(Pipeline::ClusteredForward, ZSlicing::Exponential);
    let c = cpu_spots.clusters.as_mut().unwrap();
    c.assignment = Assignment::Cpu;
    c.spot_test = SpotTest::Cone;
    out.push(loaded("forward CPU assignment, cone test", cpu_spots));
    out
}

/// Naive forward with the same rasterisation (depth set-up and pre-pass) as `v`.
fn naive_counterpart(v: &Variant) -> Variant {
    Variant {
        description: "naive counterpart".into(),
        pipeline: Pipeline::NaiveForward,
        depth_prepass: v.depth_prepass,
        depth: v.depth.clone(),
        shading: v.shading.clone(),
        msaa: v.msaa.clone(),
        ..Default::default()
    }
}

fn render(gpu: &Gpu, v: &Variant, scene: &Scene, frames: u32) -> FrameOutput {
    let mut r =
        Renderer::new(gpu, &Composer::default(), v, scene).unwrap_or_else(|e| panic!("{e}"));
    let mut last = None;
    for _ in 0..frames {
        last = Some(r.render().unwrap_or_else(|e| panic!("{e}")));
    }
    last.expect("a frame")
}

/// Every pixel of `frame` within its bound (`stress::pixel_error_bound`: 1 LSB for exact
/// variants on f32 targets) of the reference and of naive forward's `naive`; `reach` holds
/// the lights that reach each pixel.
fn assert_within_bound(
    gpu: &Gpu,
    v: &Variant,
    reach: &[u32],
    frame: &FrameOutput,
    naive: &FrameOutput,
    reference: &clusterlab::cpu::frame::ReferenceFrame,
    what: &str,
) {
    let naive_ldr: Vec<[u8; 3]> = naive.ldr.iter().map(|p| [p[0], p[1], p[2]]).collect();
    for (against, ldr) in [("the reference", &reference.ldr), ("naive", &naive_ldr)] {
        let over = clusterlab::stress::worst_over_bound(v, gpu, reach, frame, ldr, &reference.hdr);
        assert!(
            over.is_none(),
            "{what}: (pixel, LSB, bound) {over:?} from {against}"
        );
    }
}

/// Naive forward's frame with the lights that reach each pixel, and the reference, for each
/// rasterisation and shading of one scene (what `naive_counterpart` keeps of a variant): about 8
/// serve the 40-odd exact variants.
struct Baselines<'a> {
    gpu: &'a Gpu,
    composer: Composer,
    scene: &'a Scene,
    references: clusterlab::reference::ReferenceCache,
    naive: std::collections::HashMap<String, std::sync::Arc<(FrameOutput, Vec<u32>)>>,
}

impl<'a> Baselines<'a> {
    fn new(gpu: &'a Gpu, scene: &'a Scene) -> Self {
        Baselines {
            gpu,
            composer: Composer::default(),
            scene,
            references: Default::default(),
            naive: Default::default(),
        }
    }

    /// Naive forward shaded and rasterised as `v` (its frame, and the useful evaluations
    /// at each pixel), and `v`'s reference.
    fn of(
        &mut self,
        v: &LoadedVariant,
    ) -> (
        std::sync::Arc<(FrameOutput, Vec<u32>)>,
        std::sync::Arc<clusterlab::cpu::frame::ReferenceFrame>,
    ) {
        let counterpart = naive_counterpart(&v.variant);
        let (gpu, composer, scene) = (self.gpu, &self.composer, self.scene);
        let naive = self
            .naive
            .entry(format!("{counterpart:?}"))
            .or_insert_with(|| {
                let mut r = Renderer::new(gpu, composer, &counterpart, scene).unwrap();
                let frame = r.render().unwrap();
                r.prepare_counting(composer, scene);
                r.stats().unwrap();
                let reach = r.pixel_counters().unwrap().useful;
                std::sync::Arc::new((frame, reach))
            })
            .clone();
        let (reference, _) = self
            .references
            .get_or_compute(gpu, composer, v, scene)
            .unwrap_or_else(|e| panic!("{e}"));
        (naive, reference)
    }
}

#[test]
fn clustered_output_equals_naive_output() {
    let gpu = gpu();
    // Every scene at its defaults (the stage's lights are all spots), then light counts from
    // 0 to 4096 with half and all of them spots; at a size no grid divides (tiles of
    // fractional pixels).
    let mut cases: Vec<(&str, Option<u32>, Option<f32>)> =
        SCENES.iter().map(|s| (s.name, None, None)).collect();
    cases.extend([
        ("atrium", Some(0), None),
        ("atrium", Some(1), None),
        ("atrium", Some(4096), None),
        ("atrium", Some(4096), Some(0.5)),
        ("stage", Some(4096), None),
    ]);
    for (scene_name, lights, spots) in cases {
        let mut params = small(scene_name, 100, 57, lights);
        params.spots = spots.unwrap_or(params.spots);
        let scene = scene::generate(scene_name, params).unwrap();
        let mut variants = exact_variants();
        if scene.lights.iter().any(|l| l.is_spot()) {
            variants.extend(spot_variants());
        }
        let mut baselines = Baselines::new(&gpu, &scene);
        for v in variants {
            // 1 LSB, unless the adapter declares a rounding of blended light sums.
            let bound = clusterlab::stress::error_bound(&v.variant);
            // Two frames, so previous-frame z-ranges are in use.
            let frame = render(&gpu, &v.variant, &scene, 2);
            let (naive, reference) = baselines.of(&v);
            let e = clusterlab::metrics::compare(&frame, &reference);
            let what = format!(
                "{} on {scene_name} with {} lights ({} spots)",
                v.name,
                scene.lights.len(),
                scene.lights.iter().filter(|l| l.is_spot()).count()
            );
            assert_eq!(e.nan_pixels, 0, "{what}");
            let what = format!("{what} (bound {bound} on f32 targets)");
            assert_within_bound(
                &gpu, &v.variant, &naive.1, &frame, &naive.0, &reference, &what,
            );
        }
    }
}

/// README's claim for the variant files as shipped, each on its own grid, slicing, depth and
/// G-buffer: every clustered variant with exact lists (and no post effect, which naive
/// forward would not have) within its bound of naive forward and of the reference.
#[test]
fn every_shipped_clustered_variant_with_exact_lists_equals_naive() {
    let gpu = gpu();
    let files =
        clusterlab::variant::find_files(std::path::Path::new("variants")).expect("variants/");
    let shipped: Vec<LoadedVariant> = files
        .iter()
        .map(|f| clusterlab::variant::load(f).expect("loads"))
        .filter(|v| {
            let v = &v.variant;
            v.pipeline.is_clustered()
                && !matches!(v.clusters().lists, LightLists::Capped { .. })
                && v.post.toon.is_none()
                && v.post.bloom.is_none()
                && v.post.motion_blur.is_none()
                && v.debug_view == clusterlab::variant::DebugView::Off
                // A sampled loop estimates the sum (its bias tests: `tests/sampling.rs`).
                && v.shading.lights.sampling().is_none()
                // Shadows allow their ambiguous pixels more (`tests/shadows.rs`).
                && !v.shading.shadows.traced()
        })
        .collect();
    assert!(shipped.len() >= 10, "{} variants", shipped.len());
    for scene_name in ["atrium", "stage"] {
        let scene = scene::generate(scene_name, small(scene_name, 100, 57, None)).unwrap();
        let mut baselines = Baselines::new(&gpu, &scene);
        for v in &shipped {
            let frame = render(&gpu, &v.variant, &scene, 2);
            let (naive, reference) = baselines.of(v);
            let what = format!("{} on {scene_name}", v.name);
            assert_within_bound(
                &gpu, &v.variant, &naive.1, &frame, &naive.0, &reference, &what,
            );
        }
    }
}

/// The boxes the GPU builds are the CPU twin's: equal to f32 rounding (16 ULP of the
/// corner's largest coordinate, far inside the 1e-4 padding both add), on exponential,
/// Olsson and linear grids, and on the first two to what WGSL allows its `exp2` and `log2`
/// (an NVIDIA H200 was 1.0e-6 off on an Olsson box, past the 16 ULP lavapipe keeps).
#[test]
fn gpu_cluster_boxes_are_the_twins() {
    let gpu = gpu();
    let scene = scene::generate("atrium", small("atrium", 96, 54, Some(16))).unwrap();
    // Olsson's slices without his sample bounds (which shrink boxes to the samples).
    let mut olsson = common::load("forward_plus").variant;
    olsson.clusters.as_mut().unwrap().slicing = ZSlicing::OlssonCubic;
    let variants = [
        ("forward_plus", common::load("forward_plus").variant),
        ("forward_plus with Olsson slices", olsson),
        (
            "clustered_deferred_15x15x15_linear",
            common::load("clustered_deferred_15x15x15_linear").variant,
        ),
    ];
    for (name, v) in variants {
        // A slice's depth is near exp2(x), x = k log2(b) for slice k of n (b: Olsson's ratio
        // or (far / near)^(1 / n)), so |x| <= log2(far / near). WGSL allows exp2 3 + 2|x|
        // ULP and log2 2^-21 absolute on [0.5, 2] (3 ULP elsewhere, less here), which k
        // multiplies: a relative error of (3 + 2|x|) 2^-24 + ln 2 n 2^-21 at most.
        let transcendental = match v.clusters().slicing {
            ZSlicing::Linear => 0.0,
            _ => {
                let span = (scene.camera.far / scene.camera.near).log2();
                let n = v.clusters().grid.2 as f64;
                (3.0 + 2.0 * span) * 2f64.powi(-24) + std::f64::consts::LN_2 * n * 2f64.powi(-21)
            }
        };
        let mut r = Renderer::new(&gpu, &Composer::default(), &v, &scene).unwrap();
        r.render().unwrap();
        let boxes = r.cluster_bounds().unwrap().expect("clustered");
        let want = cpu::cluster_bounds(&Grid::of(&v, &scene));
        assert_eq!(boxes.len(), want.len(), "{name}");
        let mut compared = 0;
        for (c, (have, want)) in boxes.iter().zip(&want).enumerate() {
            // An empty slice (Olsson's that run past far) has no box to compare.
            let Some(want) = want else { continue };
            for (corner, expected) in [(have[0], want.min), (have[1], want.max)] {
                // Every coordinate is a ray times a depth: rounded relative to the corner's
                // largest coordinate (its depth, mostly), by a few f32 ULP (2^-24 each).
                let scale = expected.abs().max_element() + 1e-3;
                for axis in 0..3 {
                    let (h, e) = (corner[axis] as f64, expected[axis]);
                    assert!(
                        (h - e).abs() <= (16.0 * 2f64.powi(-24) + transcendental) * scale,
                        "{name}: cluster {c} axis {axis}: GPU {h}, twin {e}"
                    );
                }
            }
            compared += 1;
        }
        assert!(compared * 2 > want.len(), "{name}: {compared} boxes");
    }
}

#[test]
fn capped_lists_drop_lights_exactly_when_the_cap_bites() {
    let gpu = gpu();
    let scene = scene::generate("atrium", small("atrium", 96, 54, Some(1024))).unwrap();
    let exact = clustered(Pipeline::ClusteredForward, ZSlicing::Exponential);
    let grid = Grid::of(&exact, &scene);
    let lights = cpu::view_lights(&scene.lights, scene.camera.view());
    let lists = exact_lists(&grid, &lights, SpotTest::Cone);
    let longest = lists.max_per_cluster;
    assert!(
        longest > 8,
        "the scene must have lists longer than the small cap"
    );
    for cap in [4, longest - 1, longest, longest + 10] {
        let mut v = exact.clone();
        v.clusters.as_mut().unwrap().lists = LightLists::Capped {
            max_per_cluster: cap,
        };
        let mut r = Renderer::new(&gpu, &Composer::default(), &v, &scene).unwrap();
        r.render().unwrap();
        let stats = r.stats().unwrap();
        let expected: u64 = lists
            .counts
            .iter()
            .map(|&n| n.saturating_sub(cap) as u64)
            .sum();
        assert_eq!(stats.dropped_lights, expected, "cap {cap}");
        assert_eq!(
            stats.dropped_lights > 0,
            cap < longest,
            "cap {cap} of {longest}"
        );
        assert!(stats.max_lights_per_cluster <= cap);
    }
}

fn gpu_sets(r: &Renderer) -> Vec<BTreeSet<u32>> {
    let lists = r.cluster_lists().unwrap().expect("clustered");
    (0..lists.counts.len())
        .map(|c| lists.list(c).iter().copied().collect())
        .collect()
}

/// Assert the GPU's lists equal the CPU twin's as sets, except where f32 and f64 may round
/// a test on its boundary differently (the light is then within a hair of the cluster).
fn assert_lists_match(gpu: &Gpu, v: &Variant, scene: &Scene, what: &str) {
    let mut r = Renderer::new(gpu, &Composer::default(), v, scene).unwrap();
    r.render().unwrap();
    let got = gpu_sets(&r);
    let grid: Grid = Grid::of(v, scene);
    let bounds = cpu::cluster_bounds(&grid);
    let lights = cpu::view_lights(&scene.lights, scene.camera.view());
    let want = cpu::assign(&grid, &bounds, &lights, SpotTest::Cone, None, None, None);
    let mut compared = 0;
    for (c, set) in got.iter().enumerate() {
        let expected: BTreeSet<u32> = want.list(c).iter().copied().collect();
        // Lists are in ascending order on the GPU too.
        let lists = r.cluster_lists().unwrap().unwrap();
        assert!(
            lists.list(c).windows(2).all(|w| w[0] < w[1]),
            "{what}: cluster {c} not ascending"
        );
        for &i in set.symmetric_difference(&expected) {
            let cpu::ViewLight { center, radius, .. } = lights[i as usize];
            let b = bounds[c].expect("a listed cluster has a box");
            let (x, y) = (c as u32 % grid.x, (c as u32 / grid.x) % grid.y);
            let wider = cpu::sphere_touches_cluster(&grid, center, radius * (1.0 + 1e-4), &b, x, y);
            let narrower =
                cpu::sphere_touches_cluster(&grid, center, radius * (1.0 - 1e-4), &b, x, y);
            assert!(
                wider != narrower,
                "{what}: cluster {c}, light {i}: GPU {} it, CPU {}",
                if set.contains(&i) {
                    "lists"
                } else {
                    "leaves out"
                },
                if expected.contains(&i) {
                    "lists it"
                } else {
                    "does not"
                }
            );
        }
        compared += set.len();
    }
    assert!(
        compared > 0 || scene.lights.is_empty(),
        "{what}: nothing compared"
    );
}

#[test]
fn gpu_light_lists_equal_the_cpu_twin_on_random_scenes() {
    let gpu = gpu();
    // Every static scheme: the twin's lists assume the camera's range.
    let static_schemes = ZSlicing::every(SCENE_NEAR, SCENE_FAR)
        .into_iter()
        .filter(|s| !matches!(s, ZSlicing::DynamicRange { .. }));
    for slicing in static_schemes {
        let v = clustered(Pipeline::ClusteredForward, slicing);
        for (name, seed) in [("atrium", 1), ("atrium", 7), ("spheres", 3)] {
            let mut p = small(name, 128, 72, Some(512));
            p.seed = seed;
            let scene = scene::generate(name, p).unwrap();
            assert_lists_match(&gpu, &v, &scene, &format!("{slicing:?} {name} seed {seed}"));
        }
    }
}

/// A light at view position `p` (x right, y up, -z forward) with `radius`.
fn light_at_view(scene: &Scene, p: DVec3, radius: f32) -> Light {
    let world = scene.camera.view().inverse().transform_point3(p);
    Light::point(world.as_vec3().to_array(), radius, [1.0; 3], 1.0)
}

#[test]
fn gpu_light_lists_equal_the_cpu_twin_at_the_edges() {
    let gpu = gpu();
    let v = clustered(Pipeline::ClusteredForward, ZSlicing::Exponential);
    let mut scene = scene::generate("atrium", small("atrium", 128, 72, Some(0))).unwrap();
    let grid = Grid::of(&v, &scene);
    let near = grid.near;
    // On a slice boundary, straddling the near plane, behind the camera (reaching past it),
    // entirely behind the camera, beyond far, and one huge light over everything.
    let boundary = grid.slice_depths(10).0;
    scene.lights = vec![
        light_at_view(&scene, DVec3::new(0.0, 0.0, -boundary), 0.5),
        light_at_view(&scene, DVec3::new(0.3, -0.2, -boundary), 1.0),
        light_at_view(&scene, DVec3::new(0.0, 0.0, -near), 0.5),
        light_at_view(&scene, DVec3::new(0.5, 0.5, 1.0), 2.0),
        light_at_view(&scene, DVec3::new(0.0, 0.0, 5.0), 1.0),
        light_at_view(&scene, DVec3::new(0.0, 0.0, -grid.far - 3.0), 2.0),
        light_at_view(&scene, DVec3::new(0.0, 0.0, -10.0), 1000.0),
    ];
    assert_lists_match(&gpu, &v, &scene, "edge lights");
    // The huge light is in every non-empty cluster; the one behind the camera in none.
    let mut r = Renderer::new(&gpu, &Composer::default(), &v, &scene).unwrap();
    r.render().unwrap();
    let sets = gpu_sets(&r);
    assert!(sets.iter().all(|s| s.contains(&6)));
    assert!(sets.iter().all(|s| !s.contains(&4)));
    assert!(
        sets.iter().any(|s| s.contains(&2)),
        "the near-plane light lights the first slice"
    );
}

#[test]
fn lossy_layouts_report_their_error_and_32_bit_octahedral_stays_within_1_lsb() {
    let gpu = gpu();
    let composer = Composer::default();
    let scene = scene::generate("spheres", small("spheres", 128, 72, None)).unwrap();
    // The first case is the most precise; every other must measure a larger error.
    let cases = [
        (
            GBufferLayout::Packed,
            NormalCodec::Octahedral {
                bits: 32,
                precise: true,
            },
            true,
        ),
        (
            GBufferLayout::Packed,
            NormalCodec::Octahedral {
                bits: 32,
                precise: false,
            },
            true,
        ),
        (
            GBufferLayout::Packed,
            NormalCodec::Octahedral {
                bits: 16,
                precise: false,
            },
            false,
        ),
        (
            GBufferLayout::Packed,
            NormalCodec::Polar { bits: 16 },
            false,
        ),
        (
            GBufferLayout::Compact,
            NormalCodec::Spheremap { bits: 24 },
            false,
        ),
    ];
    let mut best = None;
    for (layout, codec, within_1_lsb) in cases {
        let mut v = clustered(Pipeline::ClusteredDeferred, ZSlicing::Exponential);
        v.gbuffer = Some(GBuffer { layout });
        v.normals = Some(codec);
        let v = loaded(&format!("{layout:?} {codec:?}"), v);
        let frame = render(&gpu, &v.variant, &scene, 1);
        let (reference, _) = reference_frame(&gpu, &composer, &v, &scene).unwrap();
        let e = clusterlab::metrics::compare(&frame, &reference);
        assert_eq!(e.nan_pixels, 0, "{}", v.name);
        // The error reported is the error of the image: its largest 8-bit difference,
        // measured here on its own.
        let measured = reference
            .ldr
            .iter()
            .zip(&frame.ldr)
            .flat_map(|(r, f)| (0..3).map(move |c| r[c].abs_diff(f[c]) as u32))
            .max()
            .unwrap_or(0);
        assert_eq!(e.max_abs_8bit, measured, "{}", v.name);
        assert!(e.rmse.is_finite(), "{}: {e:?}", v.name);
        if within_1_lsb {
            assert!(e.max_abs_8bit <= 1, "{}: {e:?}", v.name);
        }
        match best {
            None => best = Some(e.rmse),
            Some(b) if !within_1_lsb => assert!(e.rmse > b, "{}: {e:?} not worse than {b}", v.name),
            _ => {}
        }
    }
}

#[test]
fn counters_are_exact_where_they_can_be_computed() {
    let gpu = gpu();
    let scene = scene::generate("atrium", small("atrium", 96, 54, Some(256))).unwrap();
    let composer = Composer::default();
    // Naive forward with a pre-pass evaluates every light once per covered pixel.
    let naive = Variant {
        description: "naive".into(),
        depth_prepass: true,
        ..Default::default()
    };
    let truth = clusterlab::render::raster_truth(&gpu, &composer, &naive, &scene).unwrap();
    let covered = (0..truth.position.len())
        .filter(|&i| truth.covered(i))
        .count() as u64;
    let mut r = Renderer::new(&gpu, &composer, &naive, &scene).unwrap();
    r.render().unwrap();
    let s = r.stats().unwrap();
    assert_eq!(s.light_evals, covered * 256);
    // Useful evaluations are a property of the picture, the same for every pipeline. The
    // GPU tests the same f32 positions (interpolated, or stored whole in the wide G-buffer)
    // as the raster truth, in f32: its distance is within 8 x 2^-24 of the exact one, so
    // it may decide otherwise only the pairs that close to the radius.
    let (mut useful, mut borderline) = (0u64, 0u64);
    for i in (0..truth.position.len()).filter(|&i| truth.covered(i)) {
        let p = truth.surface(i).position;
        for l in &scene.lights {
            let d = DVec3::from(l.position.map(f64::from)).distance(p) / l.radius as f64;
            useful += u64::from(d < 1.0);
            borderline += u64::from((d - 1.0).abs() <= 8.0 * 2f64.powi(-24));
        }
    }
    assert!(
        s.useful_light_evals.abs_diff(useful) <= borderline,
        "{} vs {useful} ({borderline} on the edge)",
        s.useful_light_evals
    );
    for v in exact_variants() {
        let mut r = Renderer::new(&gpu, &composer, &v.variant, &scene).unwrap();
        r.render().unwrap();
        let c = r.stats().unwrap();
        if v.variant.pipeline == Pipeline::ClusteredForward && !v.variant.depth_prepass {
            // Without a pre-pass, hidden fragments are shaded (and counted) too.
            assert!(c.useful_light_evals > useful, "{}", v.name);
        } else {
            assert!(
                c.useful_light_evals.abs_diff(useful) <= borderline,
                "{}: {} vs {useful} ({borderline} on the edge)",
                v.name,
                c.useful_light_evals
            );
        }
        assert!(c.light_evals >= c.useful_light_evals, "{}", v.name);
        if v.variant.pipeline.is_clustered() {
            assert!(
                c.active_clusters > 0 && c.active_clusters <= c.clusters,
                "{}",
                v.name
            );
            assert!(
                c.cluster_bytes > 0 && c.light_list_entries > 0,
                "{}",
                v.name
            );
            assert_eq!(c.dropped_lights, 0, "{}", v.name);
        }
        if v.variant.pipeline.is_deferred() {
            assert_eq!(
                c.gbuffer_bytes_per_pixel, 52,
                "{}: wide is 3 x 16 bytes and depth",
                v.name
            );
        }
    }
}

/// Lights as large as clusterlab takes (`MAX_LIGHT_RADIUS`) stay in every culling method's
/// lists: each variant's picture within its bound of naive forward and the reference, and
/// its useful evaluations exactly naive forward's (both test the same distances in the same
/// shading function; here every light reaches every covered pixel, so a list that lost one
/// loses whole pixels of them). wgpu's OpenGL backend lost lights from a radius of about 5e7
/// on: a tile span past i32's range was converted to an integer before it was clamped, which
/// GLSL leaves undefined. A copy of the shaders that leaves lights over 1e7 out of their span
/// (a deliberate break) must fail the count; a radius over the limit is refused.
#[test]
fn lights_up_to_the_largest_radius_are_in_every_list() {
    let gpu = gpu();
    let composer = Composer::default();
    let mut params = small("atrium", 48, 27, Some(8));
    params.radius_range = (MAX_LIGHT_RADIUS, MAX_LIGHT_RADIUS);
    params.spots = 0.5;
    let scene = scene::generate("atrium", params).unwrap();
    let useful = |composer: &Composer, v: &Variant| {
        let mut r = Renderer::new(&gpu, composer, v, &scene).unwrap_or_else(|e| panic!("{e}"));
        let frame = r.render().unwrap();
        (frame, r.stats().unwrap())
    };
    let mut naive_v = naive_counterpart(&exact_variants()[0].variant);
    naive_v.depth_prepass = true;
    let (_, naive_stats) = useful(&composer, &naive_v);
    assert!(naive_stats.useful_light_evals > 0);
    let mut variants = exact_variants();
    variants.extend(spot_variants());
    let mut baselines = Baselines::new(&gpu, &scene);
    for v in &variants {
        let (frame, stats) = useful(&composer, &v.variant);
        // Naive forward shaded as this variant shades (its BRDF, its depth set-up).
        let (naive, reference) = baselines.of(v);
        let what = format!("{} with lights of radius {MAX_LIGHT_RADIUS:e}", v.name);
        let hidden_fragments =
            v.variant.pipeline == Pipeline::ClusteredForward && !v.variant.depth_prepass;
        if !hidden_fragments {
            assert_eq!(
                stats.useful_light_evals, naive_stats.useful_light_evals,
                "{what}"
            );
        }
        assert_within_bound(
            &gpu, &v.variant, &naive.1, &frame, &naive.0, &reference, &what,
        );
    }
    let broken = EditedShaders::of(
        "clustering/light_range.wesl",
        "huge-lights-dropped",
        &[(
            "if (c.z - r > -near) {",
            "if (c.z - r > -near || r > 1e7) {",
        )],
    );
    let forward_plus = clustered(Pipeline::ClusteredForward, ZSlicing::Exponential);
    let (_, stats) = useful(&broken.composer, &forward_plus);
    assert!(
        stats.useful_light_evals < naive_stats.useful_light_evals,
        "the break went unseen: {} of {}",
        stats.useful_light_evals,
        naive_stats.useful_light_evals
    );
    params.radius_range = (MAX_LIGHT_RADIUS, MAX_LIGHT_RADIUS * 2.0);
    let refused = scene::generate("atrium", params).unwrap_err().to_string();
    assert!(
        refused.contains("over the largest light radius"),
        "{refused}"
    );
}

/// Lists longer than the first index buffer: the frame grows it and runs again, and the
/// result is the CPU twin's lists and an exact picture, not truncated lists.
#[test]
fn lists_that_outgrow_their_buffer_grow_it_and_stay_exact() {
    let gpu = gpu();
    let composer = Composer::default();
    let scene = scene::generate("atrium", small("atrium", 96, 54, Some(4096))).unwrap();
    let v = loaded(
        "forward",
        clustered(Pipeline::ClusteredForward, ZSlicing::Exponential),
    );
    let mut r = Renderer::new(&gpu, &composer, &v.variant, &scene).unwrap();
    let frame = r.render().unwrap();
    let stats = r.stats().unwrap();
    assert!(
        stats.list_reallocations >= 1,
        "the scene must outgrow the first buffer"
    );
    let grid = Grid::of(&v.variant, &scene);
    let lights = cpu::view_lights(&scene.lights, scene.camera.view());
    let want = exact_lists(&grid, &lights, SpotTest::Cone);
    let total = want.indices.len() as u64;
    // f32 and f64 may decide a borderline light differently (see assert_lists_match).
    assert!(
        stats.light_list_entries.abs_diff(total) <= total / 10_000 + 2,
        "{} vs {total}",
        stats.light_list_entries
    );
    let (reference, _) = reference_frame(&gpu, &composer, &v, &scene).unwrap();
    let e = clusterlab::metrics::compare(&frame, &reference);
    assert!(e.max_abs_8bit <= 1 && e.nan_pixels == 0, "{e:?}");
}

/// Long lists (a thousand lights at one point, ten thousand spots at one point) come back
/// in ascending light order, each holding exactly the CPU twin's lights: one invocation
/// cannot sort them on software rasterisers that stop long-running loops, so they are sorted
/// by a workgroup each.
#[test]
fn long_lists_are_sorted_and_complete() {
    let gpu = gpu();
    for name in ["many_lights_at_one_point", "spots_10000_at_one_point"] {
        let case = clusterlab::stress::cases()
            .into_iter()
            .find(|c| c.name == name)
            .expect("stress case");
        let (_, v) = case
            .variants
            .iter()
            .find(|(n, _)| n == "forward_plus")
            .expect("Forward+ run");
        let scene = &case.scene;
        let mut r = Renderer::new(&gpu, &Composer::default(), v, scene).unwrap();
        r.render().unwrap();
        let got = r.cluster_lists().unwrap().expect("clustered");
        let grid = Grid::of(v, scene);
        let lights = cpu::view_lights(&scene.lights, scene.camera.view());
        let want = exact_lists(&grid, &lights, v.clusters().spot_test);
        let longest = (0..got.counts.len()).map(|c| got.list(c).len()).max();
        assert!(
            longest > Some(300),
            "{name}: lists of {longest:?} are not long"
        );
        for c in 0..got.counts.len() {
            let list = got.list(c);
            if let Some(i) = list.windows(2).position(|w| w[0] >= w[1]) {
                panic!(
                    "{name}: cluster {c}'s list of {} is out of order at entry {i}: {} then {}",
                    list.len(),
                    list[i],
                    list[i + 1]
                );
            }
            // Within a hair of a test's boundary f32 and f64 may disagree; at one point
            // with these radii no light is near one, so the sets are equal.
            let expected: BTreeSet<u32> = want.list(c).iter().copied().collect();
            let listed: BTreeSet<u32> = list.iter().copied().collect();
            assert_eq!(listed, expected, "{name}: cluster {c}");
        }
    }
}

/// Every cluster's exact list by the box test, in f64 (every cluster assigned, no masks).
fn exact_lists(grid: &Grid, lights: &[cpu::ViewLight], spot_test: SpotTest) -> cpu::ClusterLists {
    cpu::assign(
        grid,
        &cpu::cluster_bounds(grid),
        lights,
        spot_test,
        None,
        None,
        None,
    )
}

/// The GPU's lists of one frame of `v` on `scene`.
fn gpu_lists(gpu: &Gpu, composer: &Composer, v: &Variant, scene: &Scene) -> cpu::ClusterLists {
    let mut r = Renderer::new(gpu, composer, v, scene).unwrap();
    r.render().unwrap();
    r.cluster_lists().unwrap().unwrap()
}

/// The scenes the culling tests run on, 128x72, with a label: the atrium with 700 lights,
/// none and half of them spots, and the stage's 256 spots.
fn culling_scenes() -> Vec<(String, Scene)> {
    [
        ("atrium", 700, 0.0),
        ("atrium", 700, 0.5),
        ("stage", 256, 1.0),
    ]
    .into_iter()
    .map(|(name, lights, spots)| {
        let mut params = small(name, 128, 72, Some(lights));
        params.spots = spots;
        let scene = scene::generate(name, params).unwrap();
        (format!("{name} ({spots} spots)"), scene)
    })
    .collect()
}

/// Each covered pixel of `truth`: its index, world position and view depth.
fn visible_samples(truth: &RasterTruth, scene: &Scene) -> Vec<(usize, DVec3, f64)> {
    let view = scene.camera.view();
    (0..truth.position.len())
        .filter(|&i| truth.covered(i))
        .map(|i| {
            let p = truth.position[i];
            let world = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            (i, world, -view.transform_point3(world).z)
        })
        .collect()
}

/// The lights that clearly reach a sample but are missing from the list of the cluster the
/// sample is shaded with (samples within 1e-4 of a slice boundary left out: f32 and f64 may
/// put them in either slice), as (pixel, light); and how many (sample, light) pairs were
/// checked.
fn missing_lights(
    grid: &Grid,
    scene: &Scene,
    samples: &[(usize, DVec3, f64)],
    list_of: impl Fn(usize) -> Vec<u32>,
) -> (Vec<(usize, u32)>, usize) {
    let slices = grid.slices();
    let (w, h) = (scene.params.width, scene.params.height);
    let tile = |p: usize, size: u32, tiles: u32| {
        (((p as f64 + 0.5) * tiles as f64 / size as f64) as u32).min(tiles - 1)
    };
    let (mut missing, mut checked) = (Vec::new(), 0);
    for &(i, p, z) in samples {
        let k = slices.slice(z);
        if slices.slice(z * (1.0 - 1e-4)) != k || slices.slice(z * (1.0 + 1e-4)) != k {
            continue;
        }
        let c = grid.index(
            tile(i % w as usize, w, grid.x),
            tile(i / w as usize, h, grid.y),
            k,
        );
        let list = list_of(c);
        for (l, light) in scene.lights.iter().enumerate() {
            if clearly_reaches(light, p) {
                checked += 1;
                if !list.contains(&(l as u32)) {
                    missing.push((i, l as u32));
                }
            }
        }
    }
    (missing, checked)
}

/// Every list of `got` ascending and equal to `want`'s, and more than 100 of them with two
/// lights or more (so that order could be wrong).
fn assert_sorted_and_equal(got: &cpu::ClusterLists, want: &cpu::ClusterLists, what: &str) {
    let mut long = 0;
    for c in 0..want.counts.len() {
        let list = got.list(c);
        assert!(
            list.windows(2).all(|w| w[0] < w[1]),
            "{what}: cluster {c}'s list {list:?} is not ascending"
        );
        assert_eq!(list, want.list(c), "{what}: cluster {c}");
        long += usize::from(list.len() > 1);
    }
    assert!(
        long > 100,
        "{what}: only {long} lists of two lights or more"
    );
}
