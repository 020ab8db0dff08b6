//! What the pipeline cache keeps: shader modules, layouts and pipelines by kind and key, and
//! what it did over a run.

use std::collections::HashMap;
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

/// What the cache did over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PipelineStats {
    /// Pipelines created (each compiled once).
    pub created: u32,
    /// Requests answered with a pipeline created earlier in the run.
    pub reused: u32,
    /// Wall-clock milliseconds spent creating shader modules, layouts and pipelines.
    pub creation_ms: f64,
}

/// The bind group layouts of a pass (a gap where it uses no group) and its pipeline layout.
#[derive(Clone, Debug)]
pub struct LayoutObjects {
    pub groups: Vec<Option<wgpu::BindGroupLayout>>,
    pub pipeline: wgpu::PipelineLayout,
}

#[derive(Default)]
pub struct PipelineCache {
    inner: Mutex<Inner>,
}

/// What the cache keeps, by kind.
pub(super) enum Kept {
    Module(wgpu::ShaderModule),
    Layout(LayoutObjects),
    Render(wgpu::RenderPipeline),
    Compute(wgpu::ComputePipeline),
}

#[derive(Default)]
pub(super) struct Inner {
    /// By kind and key (a module and a layout share their WGSL as key).
    pub(super) kept: HashMap<(&'static str, String), Kept>,
    pub(super) stats: PipelineStats,
}

impl PipelineCache {
    pub(super) fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        // A panic while the lock was held left at worst an entry missing: keep going.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }
}
