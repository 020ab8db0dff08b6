//! README's table of the shipped variants is the variant files' own: a file added, removed
//! or changed without its row fails here, with the table to paste.

use std::path::Path;

use clusterlab::common::{NormalCodec, SpotTest, ZSlicing};
use clusterlab::variant::{
    self, Assignment, BloomKernel, Culling, DebugView, GBufferLayout, LightLists, ListUpdate,
    ShadingModel, ToonMode, Variant,
};

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

/// The table README should hold, one row per file in `variants/`.
fn table() -> String {
    let mut rows =
        vec!["| variant | pipeline | culling | clusters | G-buffer | shading | post |".to_string()];
    rows.push("| --- | --- | --- | --- | --- | --- | --- |".into());
    for file in variant::find_files(Path::new("variants")).expect("variants/") {
        let loaded = variant::load(&file).unwrap_or_else(|e| panic!("{e}"));
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

#[test]
fn readme_lists_every_shipped_variant_as_its_file_says() {
    let readme = std::fs::read_to_string("README.md").expect("README.md");
    let want = table();
    assert!(
        readme.contains(&want),
        "README's variant table differs from variants/; it should read:\n{want}"
    );
}

/// ARCHITECTURE is a map: the layers, the data flow, the conventions and how to add each
/// kind of unit; how each feature works lives in `docs/design.md`.
#[test]
fn architecture_is_a_map() {
    let map = std::fs::read_to_string("docs/ARCHITECTURE.md").expect("docs/ARCHITECTURE.md");
    let lines = map.lines().count();
    assert!(
        lines <= 400,
        "docs/ARCHITECTURE.md is {lines} lines: move a feature's narrative to docs/design.md"
    );
    for section in [
        "## Data flow",
        "## Layout",
        "## Conventions",
        "## How to add",
    ] {
        assert!(
            map.contains(section),
            "docs/ARCHITECTURE.md has no `{section}`"
        );
    }
}

#[test]
fn readme_is_a_front_page() {
    let readme = std::fs::read_to_string("README.md").expect("README.md");
    let lines = readme.lines().count();
    assert!(
        lines <= 200,
        "README is {lines} lines: move detail to docs/"
    );
    // The two commands a newcomer runs come first, before any section.
    let first_section = readme.find("\n## ").unwrap_or(readme.len());
    for command in [
        "cargo run --release -- matrix",
        "cargo test",
        "cargo run --release -- view",
    ] {
        assert!(
            readme[..first_section].contains(command),
            "`{command}` is not on README's first screen"
        );
    }
    // The viewer's picture is there to see.
    assert!(readme[..first_section].contains("](docs/viewer.png)"));
    assert!(std::path::Path::new("docs/viewer.png").is_file());
}

/// The default matrix's size as README and the measurement notes state it is the size of
/// the plan `clusterlab matrix` runs with no arguments.
#[test]
fn the_default_matrix_has_the_cells_readme_says() {
    let cells = clusterlab::matrix::expand(&clusterlab::matrix::default_groups().unwrap())
        .unwrap()
        .len();
    let claim = format!("the default matrix ({cells} cells)");
    for file in ["README.md", "docs/measurement.md"] {
        let text = std::fs::read_to_string(file).unwrap();
        let text = text.split_whitespace().collect::<Vec<_>>().join(" ");
        assert!(text.contains(&claim), "{file} does not say `{claim}`");
    }
}
