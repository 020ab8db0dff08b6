//! Passes made ready to encode: each composed pass's layout (read off its naga module), its
//! pipelines by family, and its bind groups filled from the frame's resources.

use super::culling::BinningPipelines;
use super::error::RenderError;
use super::passes::ComputePipelines;
use super::reflect::PassLayout;
use super::{Renderer, raster, screen};
use crate::compose::{self, ComposedPass, Pass, PassId};

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

impl Renderer<'_> {
    /// Pipelines and bind groups of one pass (None for post passes: the chain has them).
    pub(super) fn build(
        &self,
        pass: Pass,
        composed: &ComposedPass,
        instrumented: bool,
    ) -> Result<Option<BuiltPass>, RenderError> {
        let gpu = self.gpu;
        let layout = PassLayout::of(gpu, composed)?;
        let l = &layout.pipeline;
        let pipelines = match pass.id {
            PassId::Raster(p) => Pipelines::Render(raster::pipelines(
                gpu,
                p,
                composed,
                l,
                &self.variant,
                instrumented,
                self.frame_features.contains(&("alpha_mask", true)),
            )?),
            PassId::Screen(p) => Pipelines::Render(screen::pipelines(
                gpu,
                p,
                composed,
                l,
                self.variant.msaa.samples,
            )?),
            PassId::Clustering(p) => {
                let compute = ComputePipelines::all(gpu, composed, l)?;
                if p == compose::ClusterPass::LightAssign {
                    let drawing = self.res.clusters.as_ref().and_then(|c| c.drawing.as_ref());
                    let method = self.variant.clusters().method();
                    method.assignment_pipelines(gpu, composed, l, compute, drawing)?
                } else {
                    Pipelines::Compute(compute)
                }
            }
            PassId::Post(_) => return Ok(None),
        };
        let groups = self.bind(pass.id, &layout)?;
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
        id: PassId,
        layout: &PassLayout,
    ) -> Result<Vec<Option<wgpu::BindGroup>>, RenderError> {
        let shaded = &self.post.output(&self.res.targets.hdr).view;
        layout.bind_groups(self.gpu, id.name(), |slot| match id {
            PassId::Screen(p) => screen::binding(p, slot, &self.res, shaded),
            // The moving lists' pass builds its lists in the moving lists' buffers (and
            // reads the boxes and marks of the clusters' own).
            PassId::Clustering(compose::ClusterPass::MovingAssign) => self
                .res
                .moving
                .as_ref()
                .and_then(|m| m.buffer(slot.name))
                .map(|b| b.as_entire_binding())
                .or_else(|| self.res.scene_binding(slot)),
            _ => self.res.scene_binding(slot),
        })
    }

    /// Make every pass's bind groups again (after a buffer they bind was replaced).
    pub(super) fn remake_groups(&mut self) -> Result<(), RenderError> {
        let mut all = Vec::new();
        for b in self
            .timed
            .iter()
            .chain(&self.instrumented)
            .chain(&self.support)
        {
            all.push(self.bind(b.pass.id, &b.layout)?);
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
