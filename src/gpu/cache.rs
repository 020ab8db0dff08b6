//! Compile once per run: shader modules, pipeline layouts and pipelines kept by what
//! determines them (the composed WGSL and the pipeline state), so that the many cells of a
//! matrix whose passes compose to the same WGSL (most bounds, assignment and tonemap passes)
//! share one pipeline. Held by the device: a replaced device starts with an empty cache.

use std::collections::HashMap;
use std::sync::Mutex;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::{Gpu, GpuError};

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

/// A pipeline the cache keeps.
enum Kept {
    Render(wgpu::RenderPipeline),
    Compute(wgpu::ComputePipeline),
}

#[derive(Default)]
struct Inner {
    modules: HashMap<String, wgpu::ShaderModule>,
    layouts: HashMap<String, LayoutObjects>,
    pipelines: HashMap<String, Kept>,
    stats: PipelineStats,
}

impl Gpu {
    /// What the pipeline cache did since the device was opened.
    pub fn pipeline_stats(&self) -> PipelineStats {
        self.pipelines.lock().stats
    }

    /// The shader module of `wgsl`, created on first use.
    pub fn shader_module(&self, label: &str, wgsl: &str) -> Result<wgpu::ShaderModule, GpuError> {
        let mut cache = self.pipelines.lock();
        if let Some(m) = cache.modules.get(wgsl) {
            return Ok(m.clone());
        }
        let start = Instant::now();
        let module = self.scoped(&format!("compiling the shader of pass `{label}`"), || {
            self.device
                .create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(label),
                    source: wgpu::ShaderSource::Wgsl(wgsl.into()),
                })
        })?;
        cache.stats.creation_ms += start.elapsed().as_secs_f64() * 1e3;
        cache.modules.insert(wgsl.to_string(), module.clone());
        Ok(module)
    }

    /// The layouts of the pass whose WGSL is `wgsl`, made by `make` on first use (the
    /// entries are read off that WGSL, so it determines them).
    pub fn pass_layout(
        &self,
        wgsl: &str,
        make: impl FnOnce() -> LayoutObjects,
    ) -> Result<LayoutObjects, GpuError> {
        let mut cache = self.pipelines.lock();
        if let Some(l) = cache.layouts.get(wgsl) {
            return Ok(l.clone());
        }
        let start = Instant::now();
        let layout = self.scoped("creating a pipeline layout", make)?;
        cache.stats.creation_ms += start.elapsed().as_secs_f64() * 1e3;
        cache.layouts.insert(wgsl.to_string(), layout.clone());
        Ok(layout)
    }

    /// The render pipeline keyed by `key` (the WGSL and every piece of pipeline state),
    /// made by `make` on first use. A pipeline whose creation failed is not kept.
    pub fn render_pipeline(
        &self,
        label: &str,
        key: String,
        make: impl FnOnce() -> wgpu::RenderPipeline,
    ) -> Result<wgpu::RenderPipeline, GpuError> {
        self.kept(label, key, make, Kept::Render, |k| match k {
            Kept::Render(p) => Some(p),
            _ => None,
        })
    }

    /// The compute pipeline keyed by `key` (the WGSL and the entry point), made by `make`
    /// on first use. A pipeline whose creation failed is not kept.
    pub fn compute_pipeline(
        &self,
        label: &str,
        key: String,
        make: impl FnOnce() -> wgpu::ComputePipeline,
    ) -> Result<wgpu::ComputePipeline, GpuError> {
        self.kept(label, key, make, Kept::Compute, |k| match k {
            Kept::Compute(p) => Some(p),
            _ => None,
        })
    }

    fn kept<P: Clone>(
        &self,
        label: &str,
        key: String,
        make: impl FnOnce() -> P,
        wrap: fn(P) -> Kept,
        unwrap: fn(&Kept) -> Option<&P>,
    ) -> Result<P, GpuError> {
        let mut cache = self.pipelines.lock();
        if let Some(p) = cache.pipelines.get(&key).and_then(unwrap) {
            let pipeline = p.clone();
            cache.stats.reused += 1;
            return Ok(pipeline);
        }
        let start = Instant::now();
        let pipeline = self.scoped(&format!("creating the pipeline of pass `{label}`"), make)?;
        cache.stats.creation_ms += start.elapsed().as_secs_f64() * 1e3;
        cache.stats.created += 1;
        cache.pipelines.insert(key, wrap(pipeline.clone()));
        Ok(pipeline)
    }
}

impl PipelineCache {
    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        // A panic while the lock was held left at worst an entry missing: keep going.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }
}
