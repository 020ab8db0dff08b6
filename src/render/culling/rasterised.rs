//! Rasterised binning (Ortegren and Persson 2016; `clustering/raster_bin.wesl`): view-space
//! lights and their proxies laid out in light order (count, place, write), one draw into a
//! one-pixel-per-tile target that counts each light in the clusters its proxies cover and
//! records the pairs, the prefix sum, the pairs scattered into the lists and the lists left
//! out of order marked (indirect dispatches), then lists finished and the marked ones sorted.

use super::one_level::scan_blocks;
use super::steps::{Clear, Over, Plan, Step, long_lists};
use crate::compose::ComposedPass;
use crate::gpu::{Gpu, GpuError};
use crate::render::bindings::Binding;
use crate::render::clusters::{
    BIN_TARGET_FORMAT, ClusterBuffers, DISPATCH_ARGS_BYTES, DRAW_ARGS_BYTES, ProxyDrawing,
    ProxyLayout, Sizing,
};
use crate::render::error::RenderError;
use crate::render::passes::{begin_render, color_target, render_pipeline};

/// The pipelines of light assignment's draw, laid out as `drawing` (made with the cluster
/// buffers) says.
pub(super) fn pipelines(
    gpu: &Gpu,
    pass: &ComposedPass,
    layout: &wgpu::PipelineLayout,
    drawing: Option<&ProxyDrawing>,
) -> Result<BinningPipelines, RenderError> {
    let proxies = drawing.ok_or_else(|| no_proxy_layout(pass))?.layout;
    Ok(BinningPipelines::new(gpu, pass, layout, proxies)?)
}

/// Rasterised binning's root without the proxy buffers its draw and copies need.
fn no_proxy_layout(pass: &ComposedPass) -> RenderError {
    RenderError::Reflection(format!(
        "pass `{}`: rasterised binning's root must declare `light_proxies` and `proxy_draw` (a `ProxyDraw` with `scatter_x`)",
        pass.name
    ))
}

/// The draw of the light proxies, which counts and records the pairs.
pub struct BinningPipelines {
    draw: wgpu::RenderPipeline,
}

impl BinningPipelines {
    /// The draw of light assignment pass `pass` (composed with `raster_binning`).
    pub fn new(
        gpu: &Gpu,
        pass: &ComposedPass,
        layout: &wgpu::PipelineLayout,
        proxies: ProxyLayout,
    ) -> Result<Self, GpuError> {
        // One instance per proxy: (light, slice, x0 | x1 << 16, y0 | y1 << 16).
        let instances = wgpu::VertexBufferLayout {
            array_stride: proxies.proxy_bytes,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &[wgpu::VertexAttribute {
                format: wgpu::VertexFormat::Uint32x4,
                offset: 0,
                shader_location: 0,
            }],
        };
        Ok(Self {
            draw: render_pipeline(
                gpu,
                pass,
                layout,
                ("bin_vertex", Some("bin_lights")),
                &[Some(instances)],
                &[color_target(BIN_TARGET_FORMAT)],
                None,
                1,
            )?,
        })
    }
}

pub(super) fn plan(c: &ClusterBuffers, lights: u32) -> Plan<'_> {
    let d = drawing(c);
    let proxy_draw = c.named(Binding::ProxyDraw);
    let mut clears = vec![
        Clear::whole(c.named(Binding::LightCounts)),
        Clear::whole(c.named(Binding::FillCursors)),
        Clear::whole(proxy_draw),
    ];
    clears.extend(Clear::long_lists(c));
    let mut steps = vec![
        Step::Dispatch("transform_lights", Over::Threads(lights, 1)),
        Step::Dispatch("count_proxies", Over::Threads(lights, 1)),
        Step::Dispatch("place_proxies", Over::Groups(1, 1, 1)),
        Step::Dispatch("split_lights", Over::Threads(lights, 1)),
        // The draw's indirect arguments and instances (a buffer bound for storage in a pass
        // cannot also be its vertex or indirect buffer).
        Step::Copy(proxy_draw, 0, &d.draw_args, Some(DRAW_ARGS_BYTES)),
        Step::Copy(c.named(Binding::LightProxies), 0, &d.instances, None),
        Step::DrawProxies,
        Step::Dispatch("scan_local", scan_blocks(c)),
        Step::Dispatch("scan_blocks", Over::Groups(1, 1, 1)),
        Step::Dispatch("size_pair_passes", Over::Groups(1, 1, 1)),
        Step::Copy(
            proxy_draw,
            d.layout.scatter_at,
            &d.scatter_dispatch,
            Some(DISPATCH_ARGS_BYTES),
        ),
        Step::Indirect("scatter_pairs", &d.scatter_dispatch),
        Step::Indirect("find_unsorted", &d.scatter_dispatch),
        Step::Dispatch("finish_lists", Over::Threads(c.clusters, 1)),
    ];
    steps.extend(long_lists(c, "sort_long_lists"));
    Plan { clears, steps }
}

/// The proxies, a proxy per light and slice at most, up to the largest buffer the adapter
/// binds (a frame with more is refused after it runs: `ClusterStats::proxies_unheld`);
/// the draw's arguments; each light's proxy count, then place; and the pairs the draw
/// records, cluster, light and place arrays of an entry per list entry.
pub(super) fn own_buffers(s: &Sizing) -> Vec<(Binding, u64)> {
    let Some(layout) = s.proxies else {
        return Vec::new();
    };
    let worst = s.lights.max(1) as u64 * s.grid.2 as u64;
    let pairs = s.entries as u64;
    vec![
        (
            Binding::LightProxies,
            worst.min(s.max_storage / layout.proxy_bytes),
        ),
        (Binding::ProxyDraw, 0),
        (Binding::ProxyPlaces, s.lights as u64),
        (Binding::PairClusters, pairs),
        (Binding::PairLights, pairs),
        (Binding::PairPlaces, pairs),
    ]
}

/// The draw of the proxies into the binning target, which it clears and discards.
pub(super) fn draw(
    binning: &BinningPipelines,
    groups: &[Option<wgpu::BindGroup>],
    encoder: &mut wgpu::CommandEncoder,
    c: &ClusterBuffers,
) {
    let d = drawing(c);
    let mut rp = begin_render(
        encoder,
        "light binning",
        &[Some(wgpu::RenderPassColorAttachment {
            view: &d.target,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                store: wgpu::StoreOp::Discard,
            },
        })],
        None,
        None,
        groups,
    );
    rp.set_pipeline(&binning.draw);
    rp.set_vertex_buffer(0, d.instances.slice(..));
    rp.draw_indirect(&d.draw_args, 0);
}

/// The draw's copies and target, which the cluster buffers of rasterised binning have.
fn drawing(c: &ClusterBuffers) -> &ProxyDrawing {
    c.drawing
        .as_ref()
        .expect("rasterised binning's cluster buffers have its draw")
}
