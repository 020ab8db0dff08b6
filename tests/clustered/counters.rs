//! The counters README's tables and the studies print, each held by another path: a pixel's
//! evaluations are the walked length of the cluster its shading looked up, every counter of
//! a hand-built scene is a number worked out by hand, and useful evaluations are a property
//! of the picture, the same on any grid.

use std::collections::{BTreeSet, HashMap};

use super::{clustered, exact_variants, loaded};
use crate::common::{gpu, small};
use clusterlab::compose::Composer;
use clusterlab::gpu::Gpu;
use clusterlab::render::{AssignmentWork, FrameStats, Renderer};
use clusterlab::scene::{self, Camera, Light, MeshBuilder, Scene, SceneParams};
use clusterlab::variant::*;
use glam::DVec3;

/// Whether every pixel is shaded once (a pre-pass or a G-buffer), so its evaluations are
/// its cluster's list exactly; without a pre-pass hidden fragments are shaded too.
fn shaded_once(v: &Variant) -> bool {
    v.pipeline.is_deferred() || v.depth_prepass
}

/// `v` on a grid of one cluster: its list holds every light that reaches the view, so its
/// useful evaluations are every in-range pair of the picture.
fn one_cluster(v: &Variant) -> Variant {
    let mut one = clustered(v.pipeline, ZSlicing::Linear);
    one.depth_prepass = v.depth_prepass;
    one.depth = v.depth.clone();
    one.shading = v.shading.clone();
    one.clusters.as_mut().unwrap().grid = (1, 1, 1);
    one
}

/// What one frame of a clustered variant left: its counters, each pixel's, its lists, and
/// the clusters marked for assignment (before the counting frame re-marks them exactly).
struct Counted {
    stats: FrameStats,
    pixels: clusterlab::render::PixelCounters,
    counts: Vec<u32>,
    assigned: BTreeSet<u32>,
    visible: BTreeSet<u32>,
}

/// The clusters whose flag in `cluster_active` is set.
fn flagged(r: &Renderer) -> BTreeSet<u32> {
    let flags = r
        .cluster_buffer(clusterlab::render::Binding::ClusterActive)
        .unwrap()
        .unwrap();
    (0..flags.len() as u32)
        .filter(|&k| flags[k as usize] != 0)
        .collect()
}

fn count(gpu: &Gpu, composer: &Composer, v: &Variant, scene: &Scene) -> Counted {
    let mut r = Renderer::new(gpu, composer, v, scene).unwrap_or_else(|e| panic!("{e}"));
    r.render().unwrap();
    let assigned = flagged(&r);
    let stats = r.stats().unwrap();
    Counted {
        pixels: r.pixel_counters().unwrap(),
        counts: r.cluster_lists().unwrap().unwrap().counts,
        visible: flagged(&r),
        assigned,
        stats,
    }
}

/// Every counter of `c` that another summation of the same read-back gives, for variant
/// `v` with `grid`'s cluster count.
fn assert_counters_add_up(c: &Counted, v: &Variant, clusters: u32, what: &str) {
    let s = &c.stats;
    let layer = {
        let (x, y, _) = v.clusters().grid;
        x * y
    };
    let shaded: Vec<(usize, u32)> = (0..c.pixels.evals.len())
        .filter_map(|i| c.pixels.cluster(i).map(|k| (i, k)))
        .collect();
    assert!(shaded.len() > 100, "{what}: {} pixels shaded", shaded.len());
    if shaded_once(v) {
        // Each pixel: its cluster's walked list, exactly (0 for background).
        for i in 0..c.pixels.evals.len() {
            let want = c.pixels.cluster(i).map_or(0, |k| c.counts[k as usize]);
            assert_eq!(
                c.pixels.evals[i],
                want,
                "{what}: pixel {i} (cluster {:?}) evaluated {} lights, its list holds {want}",
                c.pixels.cluster(i),
                c.pixels.evals[i]
            );
        }
        // The frame: each cluster's list times the pixels that looked it up.
        let mut pixels_of: HashMap<u32, u64> = HashMap::new();
        for &(_, k) in &shaded {
            *pixels_of.entry(k).or_default() += 1;
        }
        let total: u64 = pixels_of
            .iter()
            .map(|(&k, &n)| n * c.counts[k as usize] as u64)
            .sum();
        assert_eq!(s.light_evals, total, "{what}: light_evals");
    } else {
        // Hidden fragments add evaluations; the visible ones are at least the lists'.
        let visible: u64 = shaded
            .iter()
            .map(|&(_, k)| c.counts[k as usize] as u64)
            .sum();
        assert!(s.light_evals >= visible, "{what}: light_evals");
    }
    assert_eq!(s.clusters, clusters as u64, "{what}: clusters");
    assert_eq!(
        s.light_list_entries,
        c.counts.iter().map(|&n| n as u64).sum::<u64>(),
        "{what}: light_list_entries"
    );
    assert_eq!(
        s.max_lights_per_cluster,
        c.counts.iter().copied().max().unwrap_or(0),
        "{what}: max_lights_per_cluster"
    );
    assert_eq!(s.dropped_lights, 0, "{what}");
    assert_eq!(s.clusters_out_of_grid, 0, "{what}");
    // Visible clusters: those the shading looked up; the marking pass, which finds depth
    // from the depth buffer rather than the surface, may round a sample within a hair of a
    // slice boundary into the next slice of its tile, never another tile.
    let looked_up: BTreeSet<u32> = shaded.iter().map(|&(_, k)| k).collect();
    let marked = &c.visible;
    assert_eq!(
        s.active_clusters,
        marked.len() as u64,
        "{what}: active_clusters"
    );
    if !shaded_once(v) {
        // A pixel records the largest cluster of its fragments', hidden ones included.
        return;
    }
    let beside = |k: u32, set: &BTreeSet<u32>| {
        set.contains(&k)
            || set.contains(&(k + layer))
            || k.checked_sub(layer).is_some_and(|j| set.contains(&j))
    };
    for &k in &looked_up {
        assert!(beside(k, marked), "{what}: cluster {k} shaded, not marked");
    }
    for &k in marked {
        assert!(
            beside(k, &looked_up),
            "{what}: cluster {k} marked, not shaded"
        );
    }
    let lengths: Vec<u64> = looked_up
        .iter()
        .map(|&k| c.counts[k as usize] as u64)
        .collect();
    assert_eq!(
        s.max_lights_per_visible_cluster as u64,
        lengths.iter().copied().max().unwrap_or(0),
        "{what}: max_lights_per_visible_cluster"
    );
    let mean = lengths.iter().sum::<u64>() as f64 / lengths.len() as f64;
    // Both divide one integer sum by one count: equal to the last bit.
    assert_eq!(
        s.mean_lights_per_visible_cluster, mean,
        "{what}: mean_lights_per_visible_cluster"
    );
    if v.clusters().active_clusters {
        assert_eq!(
            s.assigned_clusters,
            c.assigned.len() as u64,
            "{what}: assigned_clusters"
        );
        // Every cluster shading looks up had a list built.
        for &k in &looked_up {
            assert!(
                c.assigned.contains(&k),
                "{what}: cluster {k} shaded, not assigned"
            );
        }
    } else {
        assert_eq!(
            s.assigned_clusters, clusters as u64,
            "{what}: assigned_clusters"
        );
    }
}

/// Every exact clustered variant at a size no grid divides (tiles of fractional pixels): each
/// counter by another summation, and useful evaluations equal to those of the same variant
/// on one cluster.
#[test]
fn every_counter_equals_another_summation_of_its_read_back() {
    let gpu = gpu();
    let composer = Composer::default();
    let mut params = small("atrium", 100, 57, Some(300));
    params.spots = 0.5;
    let scene = scene::generate("atrium", params).unwrap();
    let mut useful_on_one_cluster: HashMap<String, u64> = HashMap::new();
    for v in exact_variants() {
        if !v.variant.pipeline.is_clustered() {
            continue;
        }
        let what = &v.name;
        let c = count(&gpu, &composer, &v.variant, &scene);
        let grid = clusterlab::cpu::clusters::Grid::of(&v.variant, &scene);
        assert_counters_add_up(&c, &v.variant, grid.x * grid.y * grid.z, what);
        let one = one_cluster(&v.variant);
        let want = *useful_on_one_cluster
            .entry(format!("{one:?}"))
            .or_insert_with(|| {
                count(&gpu, &composer, &one, &scene)
                    .stats
                    .useful_light_evals
            });
        assert_eq!(
            c.stats.useful_light_evals, want,
            "{what}: useful evaluations"
        );
    }
}

/// Tiles 3 x 2 over 10 x 6 pixels (3, 4 and 3 pixels wide), 4 linear slices of 2 from 1 to
/// 9, and a wall facing the camera at depth 6 (slice 2) that fills the view: light A (at
/// depth 3, radius 100) reaches every cluster and every pixel; light B (radius 0.05, at
/// depth 5.9 in front of tile (0, 0)'s 3 x 3 pixels) touches one cluster and no surface;
/// light C (radius 1, 20 behind the eye) reaches nothing in view.
fn hand_built_scene() -> Scene {
    let mut mesh = MeshBuilder::default();
    let z = -6.0;
    mesh.quad(
        [
            DVec3::new(-50.0, -50.0, z),
            DVec3::new(50.0, -50.0, z),
            DVec3::new(50.0, 50.0, z),
            DVec3::new(-50.0, 50.0, z),
        ],
        DVec3::Z,
        [0.5; 3],
    );
    let camera = Camera {
        eye: DVec3::ZERO,
        target: DVec3::new(0.0, 0.0, -1.0),
        up: DVec3::Y,
        fov_y: 60f64.to_radians(),
        near: 1.0,
        far: 9.0,
    };
    // Tile (0, 0)'s centre, (-2/3, 1/2) in NDC, at depth 5.9.
    let (depth, tan) = (5.9, 30f64.to_radians().tan());
    let b = DVec3::new(
        -2.0 / 3.0 * tan * (10.0 / 6.0) * depth,
        0.5 * tan * depth,
        -depth,
    );
    let lights = vec![
        Light::point([0.0, 0.0, -3.0], 100.0, [1.0; 3], 1.0),
        Light::point(b.as_vec3().to_array(), 0.05, [1.0; 3], 1.0),
        Light::point([0.0, 0.0, 20.0], 1.0, [1.0; 3], 1.0),
    ];
    Scene {
        name: "hand-built".into(),
        params: SceneParams {
            width: 10,
            height: 6,
            lights: 3,
            radius_range: (0.05, 100.0),
            seed: 0,
            time: 0.0,
            spots: 0.0,
            motion: clusterlab::scene::Motion::ALL,
        },
        vertices: mesh.vertices,
        indices: mesh.indices,
        blended: mesh.blended,
        lights,
        camera,
        prev_camera: camera,
        moving_lights: Vec::new(),
        textures: None,
        file: None,
        notes: Vec::new(),
    }
}

/// Every counter of the hand-built scene, worked out by hand: 60 pixels in 6 clusters of
/// slice 2; A in all 24 lists, B in cluster (0, 0, 2)'s (not with 2.5D culling, whose cells
/// hold only the wall's depth); with active clusters only slice 2's 6 clusters get lists.
///
/// Assignment's work: C's range is empty (1 light rejected), A's range is every cluster
/// and B's one. One-level tests each cluster of a light's range that takes part twice (the
/// count and the fill): 2 (24 + 1), active 2 (6 + 1). Two-level (one big tile): the coarse
/// pass tests tile (0, 0) for A and B (the first tile passes), then each cluster tests the
/// survivors its slice's mask holds, A and B in slice 2's 6 and A in the other 18: 2 + 12 +
/// 18. The BVH sorts A (Morton code 46: centre (2, 1, 3) in half clusters), B (256) and C
/// (511, empty): the root splits A from a node over B and C, whose bounds are B's cluster.
/// The one tile of 4 x 4 x 4 clusters tests the root, then that node: 2 nodes; its clusters
/// test A, and B in B's cluster, once: 24 + 1. Z-binning tests each tile of a light's
/// range, 6 + 1, and sets a mask bit for each it touches. The rasterised draw tests each
/// cluster its proxies cover, the range's, once.
#[test]
fn a_hand_built_scene_counts_what_was_worked_out_by_hand() {
    let gpu = gpu();
    let composer = Composer::default();
    let scene = hand_built_scene();
    let hdr = gpu.hdr_format.block_copy_size(None).unwrap();
    let work = |light_tests, node_tests, entries_written| AssignmentWork {
        light_tests,
        node_tests,
        entries_written,
        lights_rejected: 1,
    };
    // (name, culling, big tiles, active clusters, light evaluations, list entries, assigned
    // clusters, lights of the longest visible list, mean over visible clusters, work)
    let cases = [
        (
            "boxes",
            Culling::Boxes,
            None,
            false,
            60 + 9,
            24 + 1,
            24,
            2,
            7.0 / 6.0,
            work(2 * (24 + 1), 0, 24 + 1),
        ),
        (
            "boxes, active",
            Culling::Boxes,
            None,
            true,
            60 + 9,
            6 + 1,
            6,
            2,
            7.0 / 6.0,
            work(2 * (6 + 1), 0, 6 + 1),
        ),
        (
            "two-level",
            Culling::Boxes,
            Some(4),
            false,
            60 + 9,
            24 + 1,
            24,
            2,
            7.0 / 6.0,
            work(2 + 6 * 2 + 18, 0, 24 + 1),
        ),
        (
            "BVH",
            Culling::Bvh,
            None,
            false,
            60 + 9,
            24 + 1,
            24,
            2,
            7.0 / 6.0,
            work(24 + 1, 2, 24 + 1),
        ),
        (
            "rasterised",
            Culling::Rasterised,
            None,
            false,
            60 + 9,
            24 + 1,
            24,
            2,
            7.0 / 6.0,
            work(24 + 1, 0, 24 + 1),
        ),
        (
            "z-binning",
            Culling::ZBinning,
            None,
            false,
            60 + 9,
            24 + 1,
            24,
            2,
            7.0 / 6.0,
            work(6 + 1, 0, 6 + 1),
        ),
        (
            "2.5D",
            Culling::DepthMask,
            None,
            true,
            60,
            6,
            6,
            1,
            1.0,
            work(2 * (6 + 1), 0, 6),
        ),
    ];
    for (name, culling, big_tiles, active, evals, entries, assigned, longest, mean, work) in cases {
        for pipeline in [Pipeline::ClusteredForward, Pipeline::ClusteredDeferred] {
            let mut v = clustered(pipeline, ZSlicing::Linear);
            let c = v.clusters.as_mut().unwrap();
            c.grid = (3, 2, 4);
            c.culling = culling;
            c.big_tiles = big_tiles;
            c.active_clusters = active;
            // Sample bounds would shrink slice 2's boxes to the wall, leaving B out.
            c.sample_bounds = culling == Culling::DepthMask;
            let v = loaded(&format!("{pipeline:?} {name}"), v);
            let s = count(&gpu, &composer, &v.variant, &scene).stats;
            let what = &v.name;
            let gbuffer = if pipeline.is_deferred() { 52 } else { 0 };
            let want = FrameStats {
                light_evals: evals,
                useful_light_evals: 60,
                // An exact loop looks at the lights it evaluates.
                light_candidates: evals,
                sampler: None,
                max_useful_per_pixel: 1,
                edge_fraction: 0.0,
                shadow_rays: None,
                dropped_lights: 0,
                active_clusters: 6,
                assigned_clusters: assigned,
                clusters: 24,
                max_lights_per_cluster: longest,
                mean_lights_per_visible_cluster: mean,
                max_lights_per_visible_cluster: longest,
                light_list_entries: entries,
                cluster_bytes: s.cluster_bytes,
                gbuffer_bytes_per_pixel: gbuffer,
                post_bytes_per_pixel: 0,
                // Depth (4), the G-buffer's three 16-byte targets, HDR colour, 8-bit output.
                frame_bytes_per_pixel: 4 + gbuffer.saturating_sub(4) + hdr + 4,
                list_reallocations: 0,
                z_range: Some([1.0, 9.0]),
                clusters_out_of_grid: 0,
                first_out_of_grid: None,
                assignment_work: Some(work),
            };
            assert_eq!(s, want, "{what}");
            assert!(s.cluster_bytes > 0, "{what}");
        }
    }
}

/// The deliberate break of the work counters: one-level assignment that tests each cluster
/// of a light's range twice draws the same lists, and the hand-worked count catches it.
#[test]
fn a_cluster_tested_twice_fails_the_hand_worked_count() {
    let gpu = gpu();
    let scene = hand_built_scene();
    let edited = crate::common::EditedShaders::of(
        "clustering/one_level.wesl",
        "work-tested-twice",
        &[(
            "if (touches_at(i, c, w.x, w.y)) {",
            "if (touches_at(i, c, w.x, w.y) && touches_at(i, c, w.x, w.y)) {",
        )],
    );
    let mut v = clustered(Pipeline::ClusteredForward, ZSlicing::Linear);
    v.clusters.as_mut().unwrap().grid = (3, 2, 4);
    let v = loaded("tested twice", v);
    let s = count(&gpu, &edited.composer, &v.variant, &scene).stats;
    assert_eq!(s.light_list_entries, 24 + 1, "the lists stay the same");
    let work = s.assignment_work.unwrap();
    assert_ne!(
        work.light_tests,
        2 * (24 + 1),
        "the break went unseen: {work:?}"
    );
    assert_eq!(work.light_tests, 4 * (24 + 1), "{work:?}");
}

/// Scissor deferred adds each light only inside its screen rectangle: every pixel a light
/// reaches must lie inside it. Each pixel's useful evaluations (the lights that reach its
/// G-buffer surface, tested in f32 as shading tests them) equal those of clustered deferred
/// on one cluster, whose list holds every light in view, pixel by pixel.
#[test]
fn scissor_rectangles_hold_every_pixel_their_light_reaches() {
    let gpu = gpu();
    let composer = Composer::default();
    let scissor = Variant {
        description: "scissor".into(),
        pipeline: Pipeline::DeferredScissor,
        ..Default::default()
    };
    let one = one_cluster(&clustered(Pipeline::ClusteredDeferred, ZSlicing::Linear));
    for (name, lights, spots) in [("atrium", 300, 0.5), ("stage", 256, 1.0)] {
        let mut params = small(name, 100, 57, Some(lights));
        params.spots = spots;
        let scene = scene::generate(name, params).unwrap();
        let useful = |v: &Variant| {
            let mut r = Renderer::new(&gpu, &composer, v, &scene).unwrap();
            r.render().unwrap();
            r.stats().unwrap();
            r.pixel_counters().unwrap().useful
        };
        let (inside, everywhere) = (useful(&scissor), useful(&one));
        assert!(
            everywhere.iter().sum::<u32>() > 1000,
            "{name}: too few to check"
        );
        if let Some(i) = (0..inside.len()).find(|&i| inside[i] != everywhere[i]) {
            panic!(
                "{name}: pixel ({}, {}): {} lights reach it, {} of them inside their rectangles",
                i % 100,
                i / 100,
                everywhere[i],
                inside[i]
            );
        }
    }
}
