//! Every debug view against what it claims to show, computed on the CPU from the raster
//! truth (the variant's own rasterisation at full precision): the cluster index and z-slice
//! of each pixel, and each G-buffer channel. The lights-per-cluster view is held to the
//! debug variant's own frame in `tests/measure.rs`.

use crate::common::{gpu, load, small};
use clusterlab::compose::Composer;
use clusterlab::cpu::clusters::Grid;
use clusterlab::cpu::truth::RasterTruth;
use clusterlab::render::{Renderer, raster_truth};
use clusterlab::scene::{self, Scene};
use clusterlab::variant::{DebugView, DepthFormat, GBufferChannel, Variant};
use glam::{DVec3, DVec4};

/// The debug pass's colour of an index (`index_color` in `shaders/passes/debug_view.wesl`).
fn index_color(i: u32) -> DVec3 {
    let mut h = i.wrapping_mul(747796405).wrapping_add(2891336453);
    h = ((h >> ((h >> 28) + 4)) ^ h).wrapping_mul(277803737);
    h ^= h >> 22;
    DVec3::new(
        (h & 255) as f64,
        ((h >> 8) & 255) as f64,
        ((h >> 16) & 255) as f64,
    ) / 255.0
        * 0.8
        + DVec3::splat(0.2)
}

fn setup() -> (Scene, Variant) {
    let scene = scene::generate("atrium", small("atrium", 96, 54, Some(64))).expect("atrium");
    let mut v = load("clustered_deferred_16x16x24").variant;
    // Depth as the reference keeps it: float32, so a view depth rebuilt on the GPU is within
    // a few 1e-7 of the truth's.
    v.depth.format = DepthFormat::Float32;
    (scene, v)
}

fn debug_frame(v: &Variant, scene: &Scene, view: DebugView) -> Vec<[u8; 4]> {
    let gpu = gpu();
    let mut v = v.clone();
    v.debug_view = view;
    let mut r = Renderer::new(&gpu, &Composer::default(), &v, scene).expect("renderer");
    r.render().expect("frame").ldr
}

/// Each covered pixel's view depth, from the truth's world position.
fn view_depths(truth: &RasterTruth, scene: &Scene) -> Vec<Option<f64>> {
    let view = scene.camera.view();
    (0..truth.position.len())
        .map(|i| {
            truth.covered(i).then(|| {
                let p = truth.position[i];
                -(view * DVec4::new(p[0] as f64, p[1] as f64, p[2] as f64, 1.0)).z
            })
        })
        .collect()
}

/// Compare a debug image with the colours `want` per pixel (None: background, black):
/// every pixel within 1 LSB but those `undecided` (a decision on the edge), and returns
/// how many of those there were. `periodic`: values that wrap from 1 to 0 (a fractional
/// part), so 0 and 255 are 1 LSB apart.
fn check(
    name: &str,
    have: &[[u8; 4]],
    want: &[Option<DVec3>],
    undecided: &[bool],
    periodic: bool,
) -> usize {
    let mut skipped = 0;
    for (i, (h, w)) in have.iter().zip(want).enumerate() {
        if undecided[i] {
            skipped += 1;
            continue;
        }
        let w = w.unwrap_or(DVec3::ZERO).to_array();
        for c in 0..3 {
            let expected = (w[c].clamp(0.0, 1.0) * 255.0).round() as u8;
            let apart = h[c].abs_diff(expected);
            let apart = if periodic {
                apart.min(255 - apart)
            } else {
                apart
            };
            assert!(apart <= 1, "{name}: pixel {i}: GPU {h:?}, expected {w:?}");
        }
    }
    skipped
}

#[test]
fn cluster_index_and_z_slice_views_show_each_pixels_cluster() {
    let (scene, v) = setup();
    let gpu = gpu();
    let truth = raster_truth(&gpu, &Composer::default(), &v, &scene).expect("truth");
    let grid = Grid::of(&v, &scene);
    let slices = grid.slices();
    let (w, h) = (truth.width, truth.height);
    let depths = view_depths(&truth, &scene);
    let cluster = |i: usize, z: f64| {
        let (px, py) = ((i as u32 % w) as f64 + 0.5, (i as u32 / w) as f64 + 0.5);
        let tx = ((px * grid.x as f64 / w as f64) as u32).min(grid.x - 1);
        let ty = ((py * grid.y as f64 / h as f64) as u32).min(grid.y - 1);
        (grid.index(tx, ty, slices.slice(z)) as u32, slices.slice(z))
    };
    // A pixel whose depth lies within 1e-5 of a slice boundary may fall either side on the
    // GPU (its depth is rebuilt in f32 from the depth buffer): its slice is undecided.
    let undecided: Vec<bool> = depths
        .iter()
        .map(|z| {
            z.is_some_and(|z| slices.slice(z * (1.0 - 1e-5)) != slices.slice(z * (1.0 + 1e-5)))
        })
        .collect();
    let index_want: Vec<Option<DVec3>> = depths
        .iter()
        .enumerate()
        .map(|(i, z)| z.map(|z| index_color(cluster(i, z).0)))
        .collect();
    let slice_want: Vec<Option<DVec3>> = depths
        .iter()
        .enumerate()
        .map(|(i, z)| z.map(|z| index_color(cluster(i, z).1)))
        .collect();
    let pixels = depths.len();
    for (name, view, want) in [
        ("cluster-index", DebugView::ClusterIndex, &index_want),
        ("z-slice", DebugView::ZSlice, &slice_want),
    ] {
        let have = debug_frame(&v, &scene, view);
        let skipped = check(name, &have, want, &undecided, false);
        // Undecided pixels are a sliver: the depth's rounding against 24 slices.
        assert!(skipped * 100 < pixels, "{name}: {skipped} undecided");
    }
    // The views differ where they should: many clusters and several slices on screen.
    let distinct = |want: &[Option<DVec3>]| {
        let mut keys: Vec<[u64; 3]> = want
            .iter()
            .flatten()
            .map(|c| c.to_array().map(f64::to_bits))
            .collect();
        keys.sort_unstable();
        keys.dedup();
        keys.len()
    };
    assert!(distinct(&index_want) > 100 && distinct(&slice_want) > 3);
}

#[test]
fn gbuffer_views_show_the_channel_the_gbuffer_holds() {
    let (scene, v) = setup();
    let gpu = gpu();
    let truth = raster_truth(&gpu, &Composer::default(), &v, &scene).expect("truth");
    let depths = view_depths(&truth, &scene);
    let far = scene.camera.far;
    let n = truth.position.len();
    let channel = |i: usize, c: GBufferChannel| -> Option<DVec3> {
        truth.covered(i).then(|| {
            let s = truth.surface(i);
            match c {
                GBufferChannel::Position => s.position - s.position.floor(),
                GBufferChannel::Normal => s.normal * 0.5 + DVec3::splat(0.5),
                GBufferChannel::Albedo => s.albedo,
                GBufferChannel::Depth => DVec3::splat(depths[i].expect("covered") / far),
            }
        })
    };
    for c in [
        GBufferChannel::Position,
        GBufferChannel::Normal,
        GBufferChannel::Albedo,
        GBufferChannel::Depth,
    ] {
        let want: Vec<Option<DVec3>> = (0..n).map(|i| channel(i, c)).collect();
        // fract() jumps from 1 to 0 at every whole coordinate (the floor lies at y = 0):
        // compared on the circle, where 0 and 255 are neighbours.
        let undecided = vec![false; n];
        let have = debug_frame(&v, &scene, DebugView::GBuffer { channel: c });
        let periodic = c == GBufferChannel::Position;
        check(&format!("{c:?}"), &have, &want, &undecided, periodic);
    }
}
