//! Cost of bloom's blur against its radius, naive d x d window against two separable
//! passes (a benchmark, not a test): atrium at 256x144 with 64 lights, radius 1 to 64.
//!
//!     cargo bench --bench bloom
//!
//! Environment: CLUSTERLAB_BENCH_SIZE (WxH), CLUSTERLAB_BENCH_ROUNDS, CLUSTERLAB_BENCH_RADII
//! (comma-separated). Prints the median `bloom_blur` time per radius and kernel, the time
//! per tap, and the log-log slope of time against radius (2 = quadratic, 1 = linear).

mod common;

use clusterlab::compose::Composer;
use clusterlab::gpu::Gpu;
use clusterlab::render::Renderer;
use clusterlab::scene::{self, find_scene};
use clusterlab::variant::{Bloom, BloomKernel, Clusters, Pipeline, Post, Variant, ZSlicing};
use common::{env, median};

fn variant(radius: u32, kernel: BloomKernel) -> Variant {
    Variant {
        description: format!("bloom radius {radius}, {kernel:?}"),
        pipeline: Pipeline::ClusteredDeferred,
        clusters: Some(Clusters {
            grid: (16, 16, 24),
            slicing: ZSlicing::Exponential,
            ..Default::default()
        }),
        post: Post {
            bloom: Some(Bloom {
                threshold: 0.6,
                radius,
                kernel,
            }),
            ..Default::default()
        },
        ..Default::default()
    }
}

/// Texture loads a pixel: d^2 for the naive window, 2 d for the separable passes.
fn taps(radius: u32, kernel: BloomKernel) -> u64 {
    let d = 2 * radius as u64 + 1;
    match kernel {
        BloomKernel::Naive => d * d,
        BloomKernel::Separable => 2 * d,
    }
}

fn main() {
    let rounds: usize = env("CLUSTERLAB_BENCH_ROUNDS", 3);
    let (w, h) = common::size("256x144");
    let radii: Vec<u32> = env("CLUSTERLAB_BENCH_RADII", "1,2,4,8,16,32,64".to_string())
        .split(',')
        .map(|r| r.trim().parse().expect("radii are integers"))
        .collect();

    let gpu = Gpu::new(None).unwrap_or_else(|e| panic!("{e}"));
    let composer = Composer::default();
    let mut params = find_scene("atrium").expect("atrium").defaults;
    (params.width, params.height, params.lights) = (w, h, 64);
    let scene = scene::generate("atrium", params).expect("atrium generates");
    println!(
        "bloom blur, atrium {w}x{h}, {rounds} rounds, on {} ({}, {}), timing: {}",
        gpu.adapter.name,
        gpu.adapter.backend,
        gpu.adapter.driver,
        if gpu.timestamps {
            "gpu timestamps"
        } else {
            "wall clock per pass"
        }
    );
    println!(
        "{:>6} {:>12} {:>14} {:>10} {:>12} {:>14}",
        "radius", "naive ms", "separable ms", "ratio", "naive ns/tap", "separable ns/tap"
    );
    let pixels = (w * h) as f64;
    let mut rows = Vec::new();
    for &radius in &radii {
        let kernels = [BloomKernel::Naive, BloomKernel::Separable];
        let mut renderers: Vec<Renderer> = kernels
            .iter()
            .map(|&k| {
                let mut r = Renderer::new(&gpu, &composer, &variant(radius, k), &scene)
                    .unwrap_or_else(|e| panic!("radius {radius}: {e}"));
                r.render().expect("warm-up frame");
                r
            })
            .collect();
        // Rounds interleave the two kernels, so a slow spell hits both.
        let mut times = [Vec::new(), Vec::new()];
        for _ in 0..rounds {
            for (i, r) in renderers.iter_mut().enumerate() {
                times[i].push(r.render().expect("frame").timings.get("bloom_blur"));
            }
        }
        let [naive, separable] = times.map(median);
        let ns_per_tap = |ms: f64, k| ms * 1e6 / (pixels * taps(radius, k) as f64);
        println!(
            "{radius:>6} {naive:>12.3} {separable:>14.3} {:>9.1}x {:>12.3} {:>14.3}",
            naive / separable,
            ns_per_tap(naive, BloomKernel::Naive),
            ns_per_tap(separable, BloomKernel::Separable),
        );
        rows.push((radius as f64, naive, separable));
    }
    // Slope of log(time) against log(radius) over the radii >= 8, where fixed costs fade.
    let big: Vec<_> = rows.iter().filter(|r| r.0 >= 8.0).collect();
    if big.len() >= 2 {
        let slope = |f: fn(&&(f64, f64, f64)) -> f64| {
            let xs: Vec<f64> = big.iter().map(|r| r.0.ln()).collect();
            let ys: Vec<f64> = big.iter().map(|r| f(r).ln()).collect();
            let (mx, my) = (
                xs.iter().sum::<f64>() / xs.len() as f64,
                ys.iter().sum::<f64>() / ys.len() as f64,
            );
            let cov: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
            let var: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
            cov / var
        };
        println!(
            "log-log slope of time against radius (radius >= 8): naive {:.2}, separable {:.2}",
            slope(|r| r.1),
            slope(|r| r.2)
        );
    }
}
