//! Speed of the pipelines against naive forward, measured in one run (a benchmark, not a
//! test): atrium at 640x360 with 4096 lights by default.
//!
//!     cargo bench --bench pipelines
//!
//! Environment: CLUSTERLAB_BENCH_LIGHTS, CLUSTERLAB_BENCH_SIZE (WxH), CLUSTERLAB_BENCH_ROUNDS,
//! CLUSTERLAB_BENCH_VARIANTS (comma-separated names in variants/; naive_forward is always
//! measured first, as the baseline).

use std::path::Path;

mod common;

use clusterlab::compose::Composer;
use clusterlab::gpu::Gpu;
use clusterlab::render::Renderer;
use clusterlab::scene::{self, find_scene};
use clusterlab::variant;
use common::{env, median};

fn main() {
    let lights: u32 = env("CLUSTERLAB_BENCH_LIGHTS", 4096);
    let rounds: usize = env("CLUSTERLAB_BENCH_ROUNDS", 3);
    let (w, h) = common::size("640x360");
    let names: String = env(
        "CLUSTERLAB_BENCH_VARIANTS",
        "forward_plus,forward_plus_olsson,clustered_deferred_16x16x24,clustered_deferred_active,clustered_deferred_olsson,deferred_scissor"
            .to_string(),
    );
    let names: Vec<&str> = std::iter::once("naive_forward")
        .chain(names.split(',').filter(|n| *n != "naive_forward"))
        .collect();

    let gpu = Gpu::new(None).unwrap_or_else(|e| panic!("{e}"));
    let composer = Composer::default();
    let mut params = find_scene("atrium").expect("atrium").defaults;
    (params.width, params.height, params.lights) = (w, h, lights);
    let scene = scene::generate("atrium", params).expect("atrium generates");
    println!(
        "atrium {w}x{h}, {lights} lights, {rounds} rounds, on {} ({}, {})",
        gpu.adapter.name, gpu.adapter.backend, gpu.adapter.driver
    );

    let variants: Vec<_> = names
        .iter()
        .map(|n| {
            variant::load(Path::new(&format!("variants/{n}.ron"))).unwrap_or_else(|e| panic!("{e}"))
        })
        .collect();
    let mut renderers: Vec<Renderer> = variants
        .iter()
        .map(|v| {
            let mut r = Renderer::new(&gpu, &composer, &v.variant, &scene)
                .unwrap_or_else(|e| panic!("{}: {e}", v.name));
            r.render().expect("warm-up frame");
            r
        })
        .collect();
    // Rounds interleave the variants, so a slow spell of the machine hits all of them.
    let mut totals = vec![Vec::new(); renderers.len()];
    let mut passes = vec![Vec::new(); renderers.len()];
    for _ in 0..rounds {
        for (i, r) in renderers.iter_mut().enumerate() {
            let f = r.render().expect("frame");
            totals[i].push(f.timings.total_ms() + f.cpu_assign_ms.unwrap_or(0.0));
            passes[i] = f.timings.passes.clone();
        }
    }
    let naive = median(totals[0].clone());
    println!(
        "{:<28} {:>10} {:>9} {:>12} {:>8}  passes (last round, ms)",
        "variant", "median ms", "vs naive", "light evals", "useful"
    );
    for (i, v) in variants.iter().enumerate() {
        let ms = median(totals[i].clone());
        // Counters from one instrumented frame (naive's equal covered pixels x lights).
        let (evals, useful) = if i == 0 {
            ("-".to_string(), "-".to_string())
        } else {
            let s = renderers[i].stats().expect("counters");
            (
                s.light_evals.to_string(),
                format!(
                    "{:.1}%",
                    100.0 * s.useful_light_evals as f64 / s.light_evals.max(1) as f64
                ),
            )
        };
        let detail: Vec<String> = passes[i]
            .iter()
            .map(|(n, t)| format!("{n} {t:.1}"))
            .collect();
        println!(
            "{:<28} {:>10.1} {:>8.1}x {:>12} {:>8}  {}",
            v.name,
            ms,
            naive / ms,
            evals,
            useful,
            detail.join(", ")
        );
    }
}
