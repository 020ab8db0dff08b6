//! `clusterlab study slicing`: each z-slicing scheme and grid on each built-in scene, ranked
//! by how well its clusters cull lights.

use std::sync::Arc;

use serde::Serialize;

use super::{Measured, Reads, StudyError, StudyOptions, measure};
use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::plot::Plot;
use crate::scene::Scene;
use crate::table::{Table, sig};
use crate::variant::{Clusters, Pipeline, Variant, ZSlicing};

/// Grids the study runs: coarse, the default, the default with enough slices for Olsson's
/// cubic clusters on the built-in cameras, fine.
pub const GRIDS: [(u32, u32, u32); 4] = [(8, 8, 16), (16, 9, 24), (16, 9, 64), (32, 18, 48)];

/// Olsson 2012 works with 32 x 32 pixel tiles.
const OLSSON_TILE: u32 = 32;

/// Every scheme of the schema (`ZSlicing::every`), with its table label.
pub fn schemes(near: f64, far: f64) -> Vec<(&'static str, ZSlicing)> {
    ZSlicing::every(near, far)
        .into_iter()
        .map(|s| (s.label(), s))
        .collect()
}

/// One scheme and grid on one scene.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SlicingRow {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub lights: u32,
    pub scheme: String,
    pub grid: String,
    /// Active clusters with boxes shrunk to their samples (Olsson's explicit bounds).
    pub explicit_bounds: bool,
    pub clusters: u64,
    /// Slices the scheme uses (Olsson: from the camera, capped at the grid).
    pub slices: u32,
    /// Clusters holding a visible sample.
    pub occupied_clusters: u64,
    /// Lights per occupied cluster: mean and max.
    pub mean_lights_per_occupied: f64,
    pub max_lights_per_occupied: u32,
    /// Light evaluations shading performed, and those within the light's radius.
    pub evaluations: u64,
    pub useful_evaluations: u64,
    /// useful / performed.
    /// None: no light evaluated.
    pub efficiency: Option<f64>,
    /// Median GPU time of the frame over the timed frames, ms.
    pub gpu_ms: f64,
    /// Median time of the shading pass (the light loop), ms.
    pub shading_ms: f64,
    pub timing_source: String,
    /// Set when the run failed; the other figures are then zero.
    pub error: Option<String>,
}

super::outcome_in_error_field!(SlicingRow);

/// Olsson 2012's slice count for the camera: slices as deep as they are wide.
pub fn olsson_slices(near: f64, far: f64, fov_y: f64, tiles_y: u32) -> u32 {
    let ratio = 1.0 + 2.0 * (fov_y / 2.0).tan() / tiles_y as f64;
    ((far / near).ln() / ratio.ln()).ceil() as u32
}

fn variant(grid: (u32, u32, u32), slicing: ZSlicing, explicit_bounds: bool) -> Variant {
    Variant {
        description: "slicing study".into(),
        pipeline: Pipeline::ClusteredForward,
        depth_prepass: true,
        clusters: Some(Clusters {
            grid,
            slicing,
            active_clusters: explicit_bounds,
            sample_bounds: explicit_bounds,
            ..Clusters::default()
        }),
        ..Variant::default()
    }
}

/// One run of the study: a label, the grid, the slicing, explicit bounds or not.
type Config = (String, (u32, u32, u32), ZSlicing, bool);

/// Every scheme on every grid, then Olsson 2012's comparison at 32-pixel tiles: tiled
/// shading (one slice, each tile's box shrunk to its samples' depth range) against his
/// clustered shading (cubic slices, explicit bounds).
fn configs(size: (u32, u32), near: f64, far: f64) -> Vec<Config> {
    let mut out = Vec::new();
    for grid in GRIDS {
        for (label, slicing) in schemes(near, far) {
            out.push((label.to_string(), grid, slicing, false));
        }
    }
    let tiles = (
        size.0.div_ceil(OLSSON_TILE).clamp(1, 128),
        size.1.div_ceil(OLSSON_TILE).clamp(1, 128),
    );
    out.push((
        "tiled, per-tile depth bounds".into(),
        (tiles.0, tiles.1, 1),
        ZSlicing::Exponential,
        true,
    ));
    out.push((
        "Olsson cubic, explicit bounds".into(),
        (tiles.0, tiles.1, 256),
        ZSlicing::OlssonCubic,
        true,
    ));
    out
}

/// The study: every scheme and grid on each scene.
pub struct SlicingStudy {
    frames: u32,
}

/// One configuration on one scene.
pub struct Point {
    scene: Arc<Scene>,
    config: Config,
}

/// The row of a point, with no figures yet.
fn named(p: &Point) -> SlicingRow {
    let (scene, (label, grid, slicing, explicit_bounds)) = (&p.scene, &p.config);
    let (params, cam) = (scene.params, scene.camera);
    let slices = if *slicing == ZSlicing::OlssonCubic {
        olsson_slices(cam.near, cam.far, cam.fov_y, grid.1).min(grid.2)
    } else {
        grid.2
    };
    SlicingRow {
        scene: scene.name.to_string(),
        width: params.width,
        height: params.height,
        lights: params.lights,
        scheme: label.clone(),
        grid: format!("{}x{}x{}", grid.0, grid.1, grid.2),
        explicit_bounds: *explicit_bounds,
        clusters: (grid.0 * grid.1 * grid.2) as u64,
        slices,
        ..Default::default()
    }
}

impl super::Study for SlicingStudy {
    const NAME: &'static str = "slicing";
    const READS: &'static [Reads] = &[Reads::Scenes, Reads::Size, Reads::Lights, Reads::Frames];
    const ABOUT: &'static str = "Culling efficiency of each z-slicing scheme and grid on each \
        scene, and Olsson 2012's tiled against clustered comparison (--scenes, --size, \
        --lights, --frames)";
    type Point = Point;
    type Row = SlicingRow;

    fn plan(_gpu: &Gpu, options: &StudyOptions) -> Result<(Self, Vec<Point>), StudyError> {
        let size = options.size();
        let mut points = Vec::new();
        for name in &options.scenes {
            for params in options.params_for(name, &[])? {
                let scene = Arc::new(super::generate(name, params)?);
                let cam = scene.camera;
                for config in configs(size, cam.near, cam.far) {
                    let scene = scene.clone();
                    points.push(Point { scene, config });
                }
            }
        }
        let frames = options.frames;
        Ok((SlicingStudy { frames }, points))
    }

    fn label(&self, p: &Point) -> String {
        let (label, grid, ..) = &p.config;
        let lights = p.scene.params.lights;
        let grid = format!("{}x{}x{}", grid.0, grid.1, grid.2);
        format!("{} {lights} lights: {label} {grid}", p.scene.name)
    }

    fn run(
        &self,
        gpu: &Gpu,
        composer: &Composer,
        p: &Point,
    ) -> Result<Vec<SlicingRow>, StudyError> {
        let (_, grid, slicing, explicit_bounds) = &p.config;
        let v = variant(*grid, *slicing, *explicit_bounds);
        let Measured {
            stats: s,
            frame_ms,
            shading_ms,
            timing_source,
            ..
        } = measure(gpu, composer, &v, &p.scene, self.frames)?;
        Ok(vec![SlicingRow {
            occupied_clusters: s.active_clusters,
            mean_lights_per_occupied: s.mean_lights_per_visible_cluster,
            max_lights_per_occupied: s.max_lights_per_visible_cluster,
            evaluations: s.light_evals,
            useful_evaluations: s.useful_light_evals,
            efficiency: s.useful_fraction(),
            gpu_ms: frame_ms,
            shading_ms,
            timing_source: timing_source.into(),
            ..named(p)
        }])
    }

    fn named(&self, p: &Point) -> SlicingRow {
        named(p)
    }

    fn table(&self, rows: &[SlicingRow]) -> Table {
        table(rows)
    }

    fn plot(&self, rows: &[SlicingRow]) -> Option<Plot> {
        plot(rows)
    }
}

/// Olsson 2012, Fig. 1: shading time of tiled over clustered shading, 17.7 ms / 5.6 ms.
pub const OLSSON_SHADING_RATIO: f64 = 17.7 / 5.6;

/// On scene `s`: tiled shading's light evaluations and shading time over those of Olsson's
/// clustered shading.
pub fn tiled_over_clustered(rows: &[SlicingRow], s: &str) -> Option<(f64, f64)> {
    let find = |scheme: &str| {
        rows.iter()
            .find(|r| r.scene == s && r.scheme == scheme && r.error.is_none())
    };
    let tiled = find("tiled, per-tile depth bounds")?;
    let clustered = find("Olsson cubic, explicit bounds")?;
    (clustered.evaluations > 0 && clustered.shading_ms > 0.0).then(|| {
        (
            tiled.evaluations as f64 / clustered.evaluations as f64,
            tiled.shading_ms / clustered.shading_ms,
        )
    })
}

/// The table, each scene's rows ranked by culling efficiency (best first).
fn table(rows: &[SlicingRow]) -> Table {
    let mut t = Table::new(
        "Z-slicing: culling efficiency of each scheme and grid (Forward+, depth pre-pass)",
        &[
            "scene / lights / scheme",
            "grid",
            "slices",
            "occupied",
            "lights/cluster mean",
            "max",
            "evaluations",
            "useful",
            "useful / performed",
            "shading ms",
            "frame ms",
        ],
    );
    let mut frames: Vec<(&str, u32)> = rows.iter().map(|r| (r.scene.as_str(), r.lights)).collect();
    frames.dedup();
    for (s, lights) in frames {
        let mut ranked: Vec<&SlicingRow> = rows
            .iter()
            .filter(|r| (r.scene.as_str(), r.lights) == (s, lights))
            .collect();
        ranked.sort_by(|a, b| {
            b.efficiency
                .unwrap_or(0.0)
                .total_cmp(&a.efficiency.unwrap_or(0.0))
                .then(a.evaluations.cmp(&b.evaluations))
        });
        for r in ranked {
            if let Some(e) = &r.error {
                let name = format!("{s} / {lights} / {}", r.scheme);
                t.failed_row(vec![name, r.grid.clone()], e);
                continue;
            }
            t.row(vec![
                format!("{s} / {lights} / {}", r.scheme),
                r.grid.clone(),
                r.slices.to_string(),
                r.occupied_clusters.to_string(),
                sig(r.mean_lights_per_occupied, 3),
                r.max_lights_per_occupied.to_string(),
                r.evaluations.to_string(),
                r.useful_evaluations.to_string(),
                crate::table::percent(r.efficiency),
                sig(r.shading_ms, 3),
                sig(r.gpu_ms, 3),
            ]);
        }
    }
    for s in rows
        .iter()
        .map(|r| r.scene.as_str())
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
    {
        if let Some((evaluations, time)) = tiled_over_clustered(rows, s) {
            t.notes.push(format!(
                "{s}: tiled shading performs {}x the light evaluations of Olsson's clustered \
                 shading and takes {}x its shading time (Olsson 2012, Fig. 1: shading 17.7 ms \
                 tiled against 5.6 ms clustered, {}x, ~2400 lights, 32-pixel tiles).",
                sig(evaluations, 3),
                sig(time, 3),
                sig(OLSSON_SHADING_RATIO, 3)
            ));
        }
    }
    t.notes.dedup();
    if let Some(r) = rows.first() {
        t.notes.push(format!(
            "Built-in scenes at {}x{} with {}; times are medians of the \
             timed frames ({} on this adapter); shading is the light loop's pass, the frame \
             adds the pre-pass, clustering and tonemapping. Occupied: clusters holding a visible sample. Lights per \
             cluster over the occupied clusters. Useful: evaluations where the surface is \
             within the light's radius. Olsson's slice count is his formula \
             ceil(ln(far/near) / ln(1 + 2 tan(fov/2) / tiles_y)), capped at the grid.",
            r.width,
            r.height,
            if rows.iter().all(|x| x.lights == r.lights) {
                format!("{} lights", r.lights)
            } else {
                "their default lights".into()
            },
            r.timing_source
        ));
    }
    t
}

/// Useful fraction against shading time, one point per run, coloured by scheme.
fn plot(rows: &[SlicingRow]) -> Option<Plot> {
    use plotters::prelude::*;
    let ok: Vec<&SlicingRow> = rows
        .iter()
        .filter(|r| r.error.is_none() && r.evaluations > 0)
        .collect();
    let max_ms = ok.iter().map(|r| r.shading_ms).fold(1.0, f64::max) * 1.1;
    crate::plot::svg(
        "slicing.svg",
        "Z-slicing: useful evaluations against shading time",
        (880 + crate::plot::LEGEND_WIDTH, 520),
        |area| {
            let mut chart = ChartBuilder::on(area)
                .caption(
                    "Z-slicing: useful fraction of light evaluations against shading time",
                    ("sans-serif", 20),
                )
                .margin(12)
                .margin_right(crate::plot::LEGEND_WIDTH)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(0.0..max_ms, 0.0..100.0)
                .ok()?;
            chart
                .configure_mesh()
                .light_line_style(TRANSPARENT)
                .x_desc("shading pass, ms (median)")
                .y_desc("useful / performed (%)")
                .x_label_formatter(&crate::plot::tick_label)
                .y_label_formatter(&crate::plot::tick_label)
                .draw()
                .ok()?;
            let names: Vec<&str> = schemes(0.1, 100.0).iter().map(|s| s.0).collect();
            let mut legend = Vec::new();
            for (i, name) in names.iter().enumerate() {
                let color = crate::plot::series_color(i);
                let points: Vec<(f64, f64)> = ok
                    .iter()
                    .filter(|r| r.scheme == *name)
                    .filter_map(|r| Some((r.shading_ms, 100.0 * r.efficiency?)))
                    .collect();
                chart
                    .draw_series(points.iter().map(|&p| Circle::new(p, 4, color.filled())))
                    .ok()?;
                legend.push((name.to_string(), color, Some(0)));
            }
            crate::plot::legend(area, &legend)
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn olsson_slices_are_as_deep_as_wide() {
        // tan(30 deg) = 0.577; 9 tiles: ratio 1.128; ln(1000) / ln(1.128) = 57.4.
        assert_eq!(olsson_slices(0.1, 100.0, 60f64.to_radians(), 9), 58);
    }

    #[test]
    fn every_scheme_makes_a_valid_variant() {
        for (name, s) in schemes(0.1, 60.0) {
            let problems = crate::variant::check(&variant((16, 9, 24), s, false));
            assert!(problems.is_empty(), "{name}: {problems:?}");
        }
        for (name, grid, s, bounds) in configs((640, 360), 0.1, 60.0) {
            let problems = crate::variant::check(&variant(grid, s, bounds));
            assert!(problems.is_empty(), "{name}: {problems:?}");
        }
    }
}
