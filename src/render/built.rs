//! Passes made ready to encode: each composed pass's layout (read off its naga module), its
//! pipelines by family, and its bind groups filled from the frame's resources.

use super::culling::BinningPipelines;
use super::error::RenderError;
use super::passes::ComputePipelines;
use super::post::PostChain;
use super::reflect::PassLayout;
use super::resources::FrameResources;
use super::{raster, screen};
use crate::compose::{self, ComposedPass, Pass, PassId};
use crate::gpu::Gpu;
use crate::variant::Variant;

/// The pipelines of a built pass.
pub(super) enum Pipelines {
    /// Render pipelines, drawn in order.
    Render(Vec<wgpu::RenderPipeline>),
    Compute(ComputePipelines),
    /// Light assignment by rasterised binning: compute passes and the two draws.
    Binning(ComputePipelines, BinningPipelines),
}

/// A pass ready to encode: its layout (read off its module), pipelines and bind groups.
pub(super) struct BuiltPass {
    pub pass: Pass,
    pub layout: PassLayout,
    pub pipelines: Pipelines,
    pub groups: Vec<Option<wgpu::BindGroup>>,
}

/// Every pass of a renderer made ready: the timed frame's, the instrumented frame's
/// shading passes, the passes only the counters use, and the post chain.
pub(super) struct BuiltPasses {
    /// Every pass of the plan but the post ones (the post chain holds those), once each.
    pub timed: Vec<BuiltPass>,
    /// The shading passes with counters.
    pub instrumented: Vec<BuiltPass>,
    /// Passes only the counters use.
    pub support: Vec<BuiltPass>,
    pub post: PostChain,
}

/// What a pass is built for: the device, the variant, the frame's resources and whether
/// the scene has alpha-masked materials.
pub(super) struct For<'a> {
    pub gpu: &'a Gpu,
    pub variant: &'a Variant,
    pub res: &'a FrameResources,
    pub alpha_mask: bool,
}

impl BuiltPasses {
    /// The built pass `id` of a timed frame, or of an instrumented one (its shading passes
    /// count).
    pub(super) fn find(&self, id: PassId, instrumented: bool) -> Option<&BuiltPass> {
        let list = if instrumented && id.is_shading() {
            &self.instrumented
        } else {
            &self.timed
        };
        list.iter().find(|b| b.pass.id == id)
    }

    /// Pipelines and bind groups of one pass (None for post passes: the chain has them).
    pub(super) fn build(
        &self,
        to: &For<'_>,
        pass: Pass,
        composed: &ComposedPass,
        instrumented: bool,
    ) -> Result<Option<BuiltPass>, RenderError> {
        let gpu = to.gpu;
        let layout = PassLayout::of(gpu, composed)?;
        let l = &layout.pipeline;
        let pipelines = match pass.id {
            PassId::Raster(p) => Pipelines::Render(raster::pipelines(
                gpu,
                p,
                composed,
                l,
                to.variant,
                instrumented,
                to.alpha_mask,
            )?),
            PassId::Screen(p) => Pipelines::Render(screen::pipelines(
                gpu,
                p,
                composed,
                l,
                to.variant.msaa.samples,
            )?),
            PassId::Clustering(p) => {
                let compute = ComputePipelines::all(gpu, composed, l)?;
                let draws = if p == compose::ClusterPass::LightAssign {
                    let drawing = to.res.clusters.as_ref().and_then(|c| c.drawing.as_ref());
                    let method = to.variant.clusters().method();
                    method.draw_pipelines(gpu, composed, l, drawing)?
                } else {
                    None
                };
                match draws {
                    Some(draws) => Pipelines::Binning(compute, draws),
                    None => Pipelines::Compute(compute),
                }
            }
            PassId::Post(_) => return Ok(None),
        };
        let groups = self.bind(gpu, to.res, pass.id, &layout)?;
        Ok(Some(BuiltPass {
            pass,
            layout,
            pipelines,
            groups,
        }))
    }

    /// The bind groups of pass `id` with `layout`, filled from the frame's resources.
    fn bind(
        &self,
        gpu: &Gpu,
        res: &FrameResources,
        id: PassId,
        layout: &PassLayout,
    ) -> Result<Vec<Option<wgpu::BindGroup>>, RenderError> {
        let shaded = &self.post.output(&res.targets.hdr).view;
        layout.bind_groups(gpu, id.name(), |slot| match id {
            PassId::Screen(p) => screen::binding(p, slot, res, shaded),
            // The moving lists' pass builds its lists in the moving lists' buffers (and
            // reads the boxes and marks of the clusters' own).
            PassId::Clustering(compose::ClusterPass::MovingAssign) => res
                .moving
                .as_ref()
                .and_then(|m| m.buffer(slot.name))
                .map(|b| b.as_entire_binding())
                .or_else(|| res.scene_binding(slot)),
            _ => res.scene_binding(slot),
        })
    }

    /// Make every pass's bind groups again (after a buffer they bind was replaced).
    pub(super) fn remake_groups(
        &mut self,
        gpu: &Gpu,
        res: &FrameResources,
    ) -> Result<(), RenderError> {
        let mut all = Vec::new();
        for b in self
            .timed
            .iter()
            .chain(&self.instrumented)
            .chain(&self.support)
        {
            all.push(self.bind(gpu, res, b.pass.id, &b.layout)?);
        }
        let built = self
            .timed
            .iter_mut()
            .chain(&mut self.instrumented)
            .chain(&mut self.support);
        for (b, groups) in built.zip(all) {
            b.groups = groups;
        }
        Ok(())
    }
}
