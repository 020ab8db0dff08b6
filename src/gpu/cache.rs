//! Compile once per run: shader modules, pipeline layouts and pipelines kept by what
//! determines them (the composed WGSL and the pipeline state), so that the many cells of a
//! matrix whose passes compose to the same WGSL (most bounds, assignment and tonemap passes)
//! share one pipeline. Held by the device: a replaced device starts with an empty cache.

use std::time::Instant;

use super::pipeline_store::{Kept, LayoutObjects, PipelineStats};
use super::{Gpu, GpuError};

impl Gpu {
    /// What the pipeline cache did since the device was opened.
    pub fn pipeline_stats(&self) -> PipelineStats {
        self.pipelines.lock().stats
    }

    /// The shader module of `wgsl`, created on first use.
    pub fn shader_module(&self, label: &str, wgsl: &str) -> Result<wgpu::ShaderModule, GpuError> {
        let what = format!("compiling the shader of pass `{label}`");
        let make = || {
            self.device
                .create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(label),
                    source: wgpu::ShaderSource::Wgsl(wgsl.into()),
                })
        };
        self.kept(
            &what,
            ("module", wgsl.into()),
            make,
            Kept::Module,
            |k| match k {
                Kept::Module(m) => Some(m),
                _ => None,
            },
        )
    }

    /// The layouts of the pass whose WGSL is `wgsl`, made by `make` on first use (the
    /// entries are read off that WGSL, so it determines them).
    pub fn pass_layout(
        &self,
        wgsl: &str,
        make: impl FnOnce() -> LayoutObjects,
    ) -> Result<LayoutObjects, GpuError> {
        let what = "creating a pipeline layout";
        self.kept(
            what,
            ("layout", wgsl.into()),
            make,
            Kept::Layout,
            |k| match k {
                Kept::Layout(l) => Some(l),
                _ => None,
            },
        )
    }

    /// The render pipeline keyed by `key` (the WGSL and every piece of pipeline state),
    /// made by `make` on first use.
    pub fn render_pipeline(
        &self,
        label: &str,
        key: String,
        make: impl FnOnce() -> wgpu::RenderPipeline,
    ) -> Result<wgpu::RenderPipeline, GpuError> {
        let what = format!("creating the pipeline of pass `{label}`");
        self.kept(&what, ("render", key), make, Kept::Render, |k| match k {
            Kept::Render(p) => Some(p),
            _ => None,
        })
    }

    /// The compute pipeline keyed by `key` (the WGSL and the entry point), made by `make`
    /// on first use.
    pub fn compute_pipeline(
        &self,
        label: &str,
        key: String,
        make: impl FnOnce() -> wgpu::ComputePipeline,
    ) -> Result<wgpu::ComputePipeline, GpuError> {
        let what = format!("creating the pipeline of pass `{label}`");
        self.kept(&what, ("compute", key), make, Kept::Compute, |k| match k {
            Kept::Compute(p) => Some(p),
            _ => None,
        })
    }

    /// The object kept under `key`, or made by `make` (inside an error scope named `what`)
    /// and kept: an object whose creation failed is not kept. Pipelines count as created or
    /// reused; every creation's time counts.
    fn kept<T: Clone>(
        &self,
        what: &str,
        key: (&'static str, String),
        make: impl FnOnce() -> T,
        wrap: fn(T) -> Kept,
        unwrap: fn(&Kept) -> Option<&T>,
    ) -> Result<T, GpuError> {
        let pipeline = matches!(key.0, "render" | "compute");
        let mut cache = self.pipelines.lock();
        if let Some(t) = cache.kept.get(&key).and_then(unwrap) {
            let t = t.clone();
            cache.stats.reused += u32::from(pipeline);
            return Ok(t);
        }
        let start = Instant::now();
        let t = self.scoped(what, make)?;
        cache.stats.creation_ms += start.elapsed().as_secs_f64() * 1e3;
        cache.stats.created += u32::from(pipeline);
        cache.kept.insert(key, wrap(t.clone()));
        Ok(t)
    }
}
