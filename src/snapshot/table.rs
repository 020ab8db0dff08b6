//! `docs/variants.md`: the shipped variants, a row each as its file says, and the size of
//! the default matrix they make; generated from the variant files by `clusterlab snapshot`,
//! and checked against them by the tests.

use crate::common::{NormalCodec, SpotTest, ZSlicing};
use crate::variant::{
    Assignment, BloomKernel, Culling, DebugView, GBufferLayout, LightLists, ListUpdate,
    LoadedVariant, ShadingModel, ToonMode, Variant,
};

/// The page, from the tree's root.
pub const PAGE: &str = "docs/variants.md";

/// The page's first line: it marks the file as one the flow may write again.
pub const HEADER: &str = "<!-- Written by `clusterlab snapshot` from variants/: edit the variant files, not this page. -->\n";

/// The page for `variants` (those in `variants/`), whose default matrix has `cells` cells.
pub fn page(variants: &[LoadedVariant], cells: usize) -> String {
    format!(
        "{HEADER}# The shipped variants\n\n\
         One file each in `variants/`; `clusterlab explain` describes every field. With them the \
         default matrix (`clusterlab matrix`) has {cells} cells.\n\n\
         Culling: lists built one light at a time, in two levels, by z-binning, by drawing \
         proxies, through a BVH or on the CPU; `2.5D` depth masks, `+active` clusters a pixel \
         lands in, `+sample` boxes fitted to them, `+cap N`, `+spot sphere`; in a sequence \
         `+static+dynamic`, `+patch`, `+refit`. Shading: the BRDF, and a sampled loop's \
         candidates/kept (`docs/design.md` has the methods).\n\n{}",
        markdown(variants)
    )
}

fn slicing(s: ZSlicing) -> &'static str {
    match s {
        ZSlicing::Linear => "linear",
        ZSlicing::Exponential => "exponential",
        ZSlicing::NearSliceThenExponential { .. } => "near slice + exponential",
        ZSlicing::OlssonCubic => "Olsson cubic",
        ZSlicing::DynamicRange { .. } => "exponential over the frame's depth",
        ZSlicing::NdcUniform => "NDC uniform",
    }
}

/// How the lists are built, the test that keeps a light, and the options that change which
/// clusters get lists.
fn culling(v: &Variant) -> String {
    if !v.pipeline.is_clustered() {
        return "-".into();
    }
    let c = v.clusters();
    let mut label = match c.assignment {
        Assignment::Cpu => "CPU".to_string(),
        Assignment::Gpu => c.method().label().to_string(),
    };
    if c.culling == Culling::DepthMask {
        label += " 2.5D";
    }
    for (on, flag) in [
        (c.active_clusters, " +active"),
        (c.sample_bounds, " +sample"),
        (c.spot_test == SpotTest::Sphere, " +spot sphere"),
    ] {
        if on {
            label += flag;
        }
    }
    if let LightLists::Capped { max_per_cluster } = c.lists {
        label += &format!(" +cap {max_per_cluster}");
    }
    if c.update != ListUpdate::Rebuild {
        label += &format!(" +{}", c.update.label());
    }
    label
}

fn clusters(v: &Variant) -> String {
    if !v.pipeline.is_clustered() {
        return "-".into();
    }
    let c = v.clusters();
    let (x, y, z) = c.grid;
    format!("{x}x{y}x{z} {}", slicing(c.slicing))
}

fn gbuffer(v: &Variant) -> String {
    if !v.pipeline.is_deferred() {
        return "-".into();
    }
    let layout = match v.gbuffer().layout {
        GBufferLayout::Wide => "wide",
        GBufferLayout::Packed => "packed",
        GBufferLayout::Compact => "compact",
    };
    let normals = match v.normal_codec() {
        NormalCodec::Xyz => "xyz".to_string(),
        NormalCodec::Octahedral { bits, precise } => {
            format!("octahedral {bits}{}", if precise { " precise" } else { "" })
        }
        NormalCodec::Polar { bits } => format!("polar {bits}"),
        NormalCodec::Spheremap { bits } => format!("spheremap {bits}"),
    };
    format!("{layout}, {normals}")
}

fn shading(v: &Variant) -> String {
    let model = match v.shading.model {
        ShadingModel::Lambert => "Lambert",
        ShadingModel::BlinnPhong { .. } => "Blinn-Phong",
        ShadingModel::Ggx => "GGX",
    };
    match v.shading.lights.sampling() {
        None => model.into(),
        Some(s) => format!("{model}, {}", s.label()),
    }
}

fn post(v: &Variant) -> String {
    let mut steps = Vec::new();
    if let Some(t) = &v.post.toon {
        steps.push(match t.mode {
            ToonMode::PerLight => "toon per light",
            ToonMode::PostProcess => "toon",
        });
        if t.outlines.is_some() {
            steps.push("outlines");
        }
    }
    if let Some(b) = &v.post.bloom {
        steps.push(match b.kernel {
            BloomKernel::Naive => "bloom naive",
            BloomKernel::Separable => "bloom separable",
        });
    }
    if v.post.motion_blur.is_some() {
        steps.push("motion blur");
    }
    if v.debug_view != DebugView::Off {
        steps.push("debug view");
    }
    if steps.is_empty() {
        "-".into()
    } else {
        steps.join(", ")
    }
}

/// The table of `variants`, a row each.
pub fn markdown(variants: &[LoadedVariant]) -> String {
    let mut rows =
        vec!["| variant | pipeline | culling | clusters | G-buffer | shading | post |".to_string()];
    rows.push("| --- | --- | --- | --- | --- | --- | --- |".into());
    for loaded in variants {
        let v = &loaded.variant;
        rows.push(format!(
            "| `{}` | {} | {} | {} | {} | {} | {} |",
            loaded.name,
            v.pipeline.short_name(),
            culling(v),
            clusters(v),
            gbuffer(v),
            shading(v),
            post(v)
        ));
    }
    rows.join("\n") + "\n"
}
