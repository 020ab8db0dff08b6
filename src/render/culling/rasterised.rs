//! Rasterised binning (Ortegren and Persson 2016; `clustering/raster_bin.wesl`): view-space
//! lights and their proxies laid out in light order (count, place, write), one draw into a
//! one-pixel-per-tile target that counts each light in the clusters its proxies cover and
//! records the pairs, the prefix sum, the pairs scattered into the lists and the lists left
//! out of order marked (indirect dispatches), then lists finished and the marked ones sorted.

use super::one_level::scan_blocks;
use super::{Clear, Over, Plan, Step, long_lists};
use crate::compose::ComposedPass;
use crate::gpu::{Gpu, GpuError};
use crate::render::clusters::{BIN_TARGET_FORMAT, ClusterBuffers, DISPATCH_ARGS_BYTES};
use crate::render::passes::{begin_render, color_target, render_pipeline};
use crate::render::reflect::BufferLayout;

/// Rasterised binning's buffer layouts as its shader root declares them, read off its naga
/// module: a proxy's bytes (`light_proxies`' stride, the draw's instance stride too), the
/// bytes of `ProxyDraw`, and where in it the scatter's dispatch starts (`scatter_x`).
#[derive(Clone, Copy, Debug)]
pub struct ProxyLayout {
    pub proxy_bytes: u64,
    pub draw_bytes: u64,
    pub scatter_at: u64,
}

impl ProxyLayout {
    /// The layout of light assignment pass `pass`; `None` where it declares no proxies.
    pub fn of(pass: &ComposedPass) -> Option<Self> {
        let draw = BufferLayout::of(pass, "proxy_draw")?;
        Some(Self {
            proxy_bytes: BufferLayout::of(pass, "light_proxies")?.element_bytes,
            draw_bytes: draw.element_bytes,
            scatter_at: draw.offset("scatter_x")?,
        })
    }
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
            )?,
        })
    }
}

pub(super) fn plan(c: &ClusterBuffers, lights: u32) -> Plan<'_> {
    let scatter_at = c
        .proxy_layout
        .expect("rasterised binning's buffers have its layout")
        .scatter_at;
    let mut clears = vec![
        Clear::whole(&c.counts),
        Clear::whole(&c.fill_cursors),
        Clear::whole(&c.proxy_draw),
    ];
    clears.extend(Clear::long_lists(c));
    let mut steps = vec![
        Step::Dispatch("transform_lights", Over::Threads(lights, 1)),
        Step::Dispatch("count_proxies", Over::Threads(lights, 1)),
        Step::Dispatch("place_proxies", Over::Groups(1, 1, 1)),
        Step::Dispatch("split_lights", Over::Threads(lights, 1)),
        // The draw's indirect arguments and instances (a buffer bound for storage in a pass
        // cannot also be its vertex or indirect buffer).
        Step::Copy(&c.proxy_draw, 0, &c.proxy_draw_args, Some(16)),
        Step::Copy(&c.light_proxies, 0, &c.proxy_instances, None),
        Step::DrawProxies,
        Step::Dispatch("scan_local", scan_blocks(c)),
        Step::Dispatch("scan_blocks", Over::Groups(1, 1, 1)),
        Step::Dispatch("size_pair_passes", Over::Groups(1, 1, 1)),
        Step::Copy(
            &c.proxy_draw,
            scatter_at,
            &c.scatter_dispatch,
            Some(DISPATCH_ARGS_BYTES),
        ),
        Step::Indirect("scatter_pairs", &c.scatter_dispatch),
        Step::Indirect("find_unsorted", &c.scatter_dispatch),
        Step::Dispatch("finish_lists", Over::Threads(c.clusters, 1)),
    ];
    steps.extend(long_lists(c, "sort_long_lists"));
    Plan { clears, steps }
}

/// The pairs the draw records: cluster, light and place arrays, an entry per list entry.
pub(super) fn own_buffers(entries: u32) -> Vec<(&'static str, u64)> {
    let bytes = entries as u64 * 4;
    vec![
        ("pair_clusters", bytes),
        ("pair_lights", bytes),
        ("pair_places", bytes),
    ]
}

/// The draw of the proxies into the binning target, which it clears and discards.
pub(super) fn draw(
    binning: &BinningPipelines,
    groups: &[Option<wgpu::BindGroup>],
    encoder: &mut wgpu::CommandEncoder,
    c: &ClusterBuffers,
) {
    let target = c
        .bin_target
        .as_ref()
        .expect("rasterised binning's buffers have its target");
    let mut rp = begin_render(
        encoder,
        "light binning",
        &[Some(wgpu::RenderPassColorAttachment {
            view: target,
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
    rp.set_vertex_buffer(0, c.proxy_instances.slice(..));
    rp.draw_indirect(&c.proxy_draw_args, 0);
}
