//! What the last frame left on the GPU, read back for the tests, the counters and the debug
//! views: the shaded image, the light lists, boxes, masks and bins, the depth range, and a
//! debug view drawn from the frame's own depth and lists.

use super::bindings::Binding;
use super::error::RenderError;
use super::reflect::PassLayout;
use super::targets::read_hdr;
use super::{ClusterRange, GpuDepthMask, Renderer, screen};
use crate::compose::{self, Composer, PassId};
use crate::cpu::clusters::ClusterLists;
use crate::gpu::read_texture;
use crate::variant::CullingMethod;

impl Renderer<'_> {
    /// Debug view `view` of the last frame, drawn from its depth and light lists by the
    /// debug pass alone (the same image a whole frame of the variant with that view shows;
    /// post effects, which a debug view leaves out, change neither). 8-bit RGBA, row-major.
    pub fn debug_image(
        &self,
        composer: &Composer,
        view: crate::variant::DebugView,
    ) -> Result<Vec<[u8; 4]>, RenderError> {
        let gpu = self.gpu;
        let mut v = self.variant.clone();
        v.debug_view = view;
        v.post = Default::default();
        let id = PassId::Screen(compose::ScreenPass::DebugView);
        let Some(pass) = compose::passes(&v).into_iter().find(|p| p.id == id) else {
            return Err(RenderError::Reflection(format!(
                "variant has no debug pass for view {view:?}"
            )));
        };
        let composed = composer.compose_with(&v, &pass, &self.state.frame_features)?;
        // It draws over the output: a sequence's next frame draws its own.
        self.state.held.disturbed.set(true);
        gpu.scoped("drawing a debug view", || -> Result<(), RenderError> {
            let layout = PassLayout::of(gpu, &composed)?;
            let pipelines = screen::pipelines(
                gpu,
                compose::ScreenPass::DebugView,
                &composed,
                &layout.pipeline,
                1,
            )?;
            let groups = layout.bind_groups(gpu, id.name(), |slot| self.res.scene_binding(slot))?;
            let mut e = gpu.device.create_command_encoder(&Default::default());
            screen::encode(
                compose::ScreenPass::DebugView,
                &pipelines,
                &groups,
                &mut e,
                None,
                &self.res,
            );
            gpu.queue.submit([e.finish()]);
            Ok(())
        })??;
        let ldr = read_texture(gpu, &self.res.targets.ldr.texture)?;
        Ok(bytemuck::cast_slice(&ldr).to_vec())
    }

    /// The shading pass's HDR image of the last frame, before post-processing.
    pub fn read_shaded(&self) -> Result<Vec<[f32; 4]>, RenderError> {
        Ok(read_hdr(self.gpu, &self.res.targets.hdr.texture)?)
    }

    /// The light lists as the GPU holds them after the last frame (clustered variants);
    /// StaticDynamic's still and moving lists as one, each cluster's merged in ascending
    /// order.
    pub fn cluster_lists(&self) -> Result<Option<ClusterLists>, RenderError> {
        let Some(c) = &self.res.clusters else {
            return Ok(None);
        };
        let lists = c.read_lists(self.gpu)?;
        Ok(Some(match &self.res.moving {
            Some(m) => lists.merged(&m.read_lists(self.gpu)?),
            None => lists,
        }))
    }

    /// The cluster boxes after the last frame (clustered variants): [min, max] per cluster.
    pub fn cluster_bounds(&self) -> Result<Option<Vec<[[f32; 4]; 2]>>, RenderError> {
        match &self.res.clusters {
            Some(c) => Ok(Some(c.read_bounds(self.gpu)?)),
            None => Ok(None),
        }
    }

    /// Each cluster's sample depth range and 2.5D mask after the last frame (clustered
    /// variants; see `ClusterBuffers::read_depth_masks`).
    pub fn depth_masks(&self) -> Result<Option<Vec<GpuDepthMask>>, RenderError> {
        match &self.res.clusters {
            Some(c) => Ok(Some(c.read_depth_masks(self.gpu)?)),
            None => Ok(None),
        }
    }

    /// Z-binning's sorted lights, bins and tile masks after the last frame (None for other
    /// pipelines and culling methods).
    pub fn zbins(&self) -> Result<Option<crate::cpu::zbin::ZBins>, RenderError> {
        match &self.res.clusters {
            Some(c) if c.method == CullingMethod::ZBinning => Ok(Some(c.read_zbins(self.gpu)?)),
            _ => Ok(None),
        }
    }

    /// A cluster buffer after the last frame, in 32-bit words (None for pipelines without
    /// clusters).
    pub fn cluster_buffer(&self, name: Binding) -> Result<Option<Vec<u32>>, RenderError> {
        match &self.res.clusters {
            Some(c) => Ok(Some(c.read_words(self.gpu, name)?)),
            None => Ok(None),
        }
    }

    /// The depth buffer of the last frame (read it with `kernels::gpu_depth_samples`).
    pub fn depth_texture(&self) -> &wgpu::Texture {
        &self.res.targets.depth.texture
    }

    /// The clustered depth range after the last frame (clustered variants).
    pub fn cluster_range(&self) -> Result<Option<ClusterRange>, RenderError> {
        match &self.res.clusters {
            Some(c) => Ok(Some(c.read_range(self.gpu)?)),
            None => Ok(None),
        }
    }
}
