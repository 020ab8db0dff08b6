//! Helpers shared by the benchmarks.
#![allow(dead_code)]

/// An environment variable parsed, or the default.
pub fn env<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// `CLUSTERLAB_BENCH_SIZE` as (width, height), WxH.
pub fn size(default: &str) -> (u32, u32) {
    let size: String = env("CLUSTERLAB_BENCH_SIZE", default.to_string());
    size.split_once('x')
        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        .expect("CLUSTERLAB_BENCH_SIZE is WxH")
}
