//! `clusterlab study culling`: every way clusterlab culls lights, on every built-in scene, at
//! 64 to 16384 lights with none and half of them spots: light evaluations performed and
//! useful, the worst tile or cluster, assignment and shading time, and list memory.

use std::sync::Arc;

use serde::Serialize;

use super::{Reads, StudyError, StudyOptions, measure};
use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::plot::Plot;
use crate::scene::{Scene, SceneParams};
use crate::table::{Table, sig};
use crate::variant::{Clusters, Culling, Pipeline, Variant, ZSlicing};

/// Light counts of the study.
pub const LIGHT_COUNTS: [u32; 4] = [64, 1024, 4096, 16384];
/// Spot fractions of the study.
pub const SPOT_FRACTIONS: [f32; 2] = [0.0, 0.5];

/// Harada 2012 and Olsson 2012 work with 32 x 32 pixel tiles.
const OLSSON_TILE: u32 = 32;
/// The fine grids' tiles: 10 pixels (64 x 36 at 640 x 360).
const FINE_TILE: u32 = 10;
/// Z-binning's tiles: 16 pixels.
const ZBIN_TILE: u32 = 16;

/// A culling method: its name, what it is, and its Forward+ variant at an image size.
pub struct Method {
    pub name: &'static str,
    pub source: &'static str,
    grid: fn(tiles: (u32, u32)) -> (u32, u32, u32),
    slicing: ZSlicing,
    /// Active clusters with boxes shrunk to their samples.
    sample_bounds: bool,
    culling: Culling,
    /// Two-level culling's big tiles, in tiles a side.
    big_tiles: Option<u32>,
    /// Tile size in pixels (None: the grid is fixed).
    tile_pixels: Option<u32>,
}

impl Method {
    /// The Forward+ variant (depth pre-pass) of this method for a `size` image.
    pub fn variant(&self, size: (u32, u32)) -> Variant {
        let px = self.tile_pixels.unwrap_or(OLSSON_TILE);
        let tiles = (
            size.0.div_ceil(px).clamp(1, 128),
            size.1.div_ceil(px).clamp(1, 128),
        );
        Variant {
            description: format!("culling study: {}", self.name),
            pipeline: Pipeline::ClusteredForward,
            depth_prepass: true,
            clusters: Some(Clusters {
                grid: (self.grid)(tiles),
                slicing: self.slicing,
                active_clusters: self.sample_bounds,
                sample_bounds: self.sample_bounds,
                culling: self.culling,
                big_tiles: self.big_tiles,
                ..Clusters::default()
            }),
            ..Variant::default()
        }
    }
}

/// Every method the study compares.
pub fn methods() -> Vec<Method> {
    let base = Method {
        name: "",
        source: "",
        grid: |_| (16, 9, 24),
        slicing: ZSlicing::Exponential,
        sample_bounds: false,
        culling: Culling::Boxes,
        big_tiles: None,
        tile_pixels: None,
    };
    vec![
        Method {
            name: "clusters 16x9x24",
            source: "the default grid: exponential slices, boxes",
            ..base
        },
        Method {
            name: "tiled, depth bounds",
            source: "Harada 2012: 32-pixel tiles, each between its samples' min and max depth",
            grid: |(x, y)| (x, y, 1),
            sample_bounds: true,
            tile_pixels: Some(OLSSON_TILE),
            ..base
        },
        Method {
            name: "tiled 2.5D",
            source: "Harada 2012: depth bounds and a 32-cell mask of the depths holding geometry",
            grid: |(x, y)| (x, y, 1),
            sample_bounds: true,
            culling: Culling::DepthMask,
            tile_pixels: Some(OLSSON_TILE),
            ..base
        },
        Method {
            name: "Olsson explicit bounds",
            source: "Olsson 2012: 32-pixel tiles, cubic slices, active clusters, sample bounds",
            grid: |(x, y)| (x, y, 256),
            slicing: ZSlicing::OlssonCubic,
            sample_bounds: true,
            tile_pixels: Some(OLSSON_TILE),
            ..base
        },
        Method {
            name: "Olsson + 2.5D",
            source: "Olsson's clusters, each with Harada's 32-cell depth mask",
            grid: |(x, y)| (x, y, 256),
            slicing: ZSlicing::OlssonCubic,
            sample_bounds: true,
            culling: Culling::DepthMask,
            tile_pixels: Some(OLSSON_TILE),
            ..base
        },
        Method {
            name: "Olsson light BVH",
            source: "Olsson 2012: the same clusters, each walking a light BVH built every frame",
            grid: |(x, y)| (x, y, 256),
            slicing: ZSlicing::OlssonCubic,
            sample_bounds: true,
            culling: Culling::Bvh,
            tile_pixels: Some(OLSSON_TILE),
            ..base
        },
        Method {
            name: "z-binning",
            source: "Drobot 2017: 16-pixel tiles of light bitmasks, 128 exponential depth bins",
            grid: |(x, y)| (x, y, 128),
            culling: Culling::ZBinning,
            tile_pixels: Some(ZBIN_TILE),
            ..base
        },
        Method {
            name: "deep clusters",
            source: "32-pixel tiles, 128 exponential slices, boxes",
            grid: |(x, y)| (x, y, 128),
            tile_pixels: Some(OLSSON_TILE),
            ..base
        },
        Method {
            name: "deep clusters, rasterised",
            source: "Ortegren and Persson 2016: the same grid, each light drawn as one proxy per slice",
            grid: |(x, y)| (x, y, 128),
            culling: Culling::Rasterised,
            tile_pixels: Some(OLSSON_TILE),
            ..base
        },
        Method {
            name: "fine clusters",
            source: "10-pixel tiles, 24 exponential slices, active clusters, sample bounds",
            grid: |(x, y)| (x, y, 24),
            sample_bounds: true,
            tile_pixels: Some(FINE_TILE),
            ..base
        },
        Method {
            name: "fine clusters, two-level",
            source: "the same with HDRP's two-level culling: big tiles of 2x2 tiles first",
            grid: |(x, y)| (x, y, 24),
            sample_bounds: true,
            big_tiles: Some(2),
            tile_pixels: Some(FINE_TILE),
            ..base
        },
    ]
}

/// One method on one scene, light count and spot fraction.
#[derive(Clone, Debug, Default, Serialize)]
pub struct CullingRow {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub lights: u32,
    pub spot_fraction: f32,
    pub method: String,
    pub grid: String,
    /// Light evaluations shading performed, and those within the light's reach.
    pub evaluations: u64,
    pub useful_evaluations: u64,
    /// useful / performed.
    /// None: no light evaluated.
    pub efficiency: Option<f64>,
    /// Longest list of a tile or cluster that holds a visible sample.
    pub worst_list: u32,
    /// Median GPU time of the passes that build the lists (depth range, marking, boxes,
    /// assignment), ms.
    pub assignment_ms: f64,
    /// Median time of the shading pass (the light loop), ms.
    pub shading_ms: f64,
    /// Median time of the frame, ms.
    pub frame_ms: f64,
    /// Bytes of every culling buffer (boxes, counts, offsets, indices, masks, scratch).
    pub list_bytes: u64,
    pub timing_source: String,
    /// Set when the run failed; the other figures are then zero.
    pub error: Option<String>,
}

super::outcome_in_error_field!(CullingRow);

/// The study: every method on each scene, light count and spot fraction.
pub struct CullingStudy {
    methods: Vec<Method>,
    frames: u32,
}

/// One method (an index into the study's) on one scene.
pub struct Point {
    name: String,
    scene: Arc<Scene>,
    method: usize,
}

impl CullingStudy {
    /// The row of a point, with no figures yet.
    fn row_of(&self, p: &Point) -> CullingRow {
        let params = &p.scene.params;
        let m = &self.methods[p.method];
        let g = m.variant((params.width, params.height)).clusters().grid;
        CullingRow {
            scene: p.name.clone(),
            width: params.width,
            height: params.height,
            lights: params.lights,
            spot_fraction: params.spots,
            method: m.name.into(),
            grid: format!("{}x{}x{}", g.0, g.1, g.2),
            ..Default::default()
        }
    }
}

impl super::Study for CullingStudy {
    const NAME: &'static str = "culling";
    const READS: &'static [Reads] = &[Reads::Scenes, Reads::Size, Reads::Lights, Reads::Frames];
    const ABOUT: &'static str = "Every culling method (clusters, tiled, 2.5D, Olsson, \
        z-binning, rasterised binning, two-level) on each scene at 64 to 16384 lights, spot \
        fractions 0 and 0.5: evaluations, the worst list, time, list bytes, and which did \
        best; every method must find the same useful evaluations (--scenes, --size, \
        --lights, --frames)";
    type Point = Point;
    type Row = CullingRow;

    fn plan(_gpu: &Gpu, options: &StudyOptions) -> Result<(Self, Vec<Point>), StudyError> {
        let methods = methods();
        let mut points = Vec::new();
        for name in &options.scenes {
            for params in options.params_for(name, &LIGHT_COUNTS)? {
                for spots in SPOT_FRACTIONS {
                    let params = SceneParams { spots, ..params };
                    let scene = Arc::new(super::generate(name, params)?);
                    for method in 0..methods.len() {
                        let (name, scene) = (name.clone(), scene.clone());
                        points.push(Point {
                            name,
                            scene,
                            method,
                        });
                    }
                }
            }
        }
        let frames = options.frames;
        Ok((CullingStudy { methods, frames }, points))
    }

    fn label(&self, p: &Point) -> String {
        let params = &p.scene.params;
        let (lights, spots) = (params.lights, params.spots);
        let method = self.methods[p.method].name;
        format!("{} {lights} lights, spots {spots}: {method}", p.name)
    }

    fn run(
        &self,
        gpu: &Gpu,
        composer: &Composer,
        p: &Point,
    ) -> Result<Vec<CullingRow>, StudyError> {
        let params = &p.scene.params;
        let v = self.methods[p.method].variant((params.width, params.height));
        let r = measure(gpu, composer, &v, &p.scene, self.frames)?;
        let s = r.stats;
        Ok(vec![CullingRow {
            evaluations: s.light_evals,
            useful_evaluations: s.useful_light_evals,
            efficiency: s.useful_fraction(),
            worst_list: s.max_lights_per_visible_cluster,
            assignment_ms: r.assignment_ms,
            shading_ms: r.shading_ms,
            frame_ms: r.frame_ms,
            list_bytes: s.cluster_bytes,
            timing_source: r.timing_source.into(),
            ..self.row_of(p)
        }])
    }

    fn named(&self, p: &Point) -> CullingRow {
        self.row_of(p)
    }

    /// The same useful evaluations as every other method on the same frame: each is exact,
    /// so a method that left out a light would count fewer.
    fn keeps(&self, r: &CullingRow, rows: &[CullingRow]) -> bool {
        rows.iter()
            .filter(|o| {
                o.scene == r.scene && o.lights == r.lights && o.spot_fraction == r.spot_fraction
            })
            .all(|o| o.useful_evaluations == r.useful_evaluations)
    }

    fn table(&self, rows: &[CullingRow]) -> Table {
        table(rows)
    }

    fn plot(&self, rows: &[CullingRow]) -> Option<Plot> {
        plot(rows)
    }
}

/// Harada 2012 (2.5D culling): the worst tiles of a deep scene held over 200 lights with
/// depth bounds alone and at most 120 with the 2.5D mask.
pub const HARADA_WORST_TILE: (u32, u32) = (200, 120);

/// On one scene, light count and spot fraction: the worst tile list of tiled shading with
/// depth bounds and with the 2.5D mask.
pub fn worst_tiles(
    rows: &[CullingRow],
    scene: &str,
    lights: u32,
    spots: f32,
) -> Option<(u32, u32)> {
    let find = |m: &str| {
        rows.iter().find(|r| {
            r.scene == scene
                && r.lights == lights
                && r.spot_fraction == spots
                && r.method == m
                && r.error.is_none()
        })
    };
    Some((
        find("tiled, depth bounds")?.worst_list,
        find("tiled 2.5D")?.worst_list,
    ))
}

/// On one scene, light count and spot fraction, the methods that did best among the exact
/// ones: those that ran and found the group's most useful evaluations (a method that left
/// out a light would find fewer).
pub struct Best<'a> {
    /// The shortest median frame, and the next shortest (on a noisy machine, whether the
    /// first is a clear win).
    pub fastest: &'a CullingRow,
    pub runner_up: Option<&'a CullingRow>,
    /// The fewest evaluations (the highest useful fraction); among equals, the faster.
    pub fewest_evaluations: &'a CullingRow,
    /// The fewest bytes of culling buffers.
    pub least_memory: &'a CullingRow,
}

/// The best methods of one scene, light count and spot fraction (None if no run succeeded).
pub fn best<'a>(rows: &'a [CullingRow], scene: &str, lights: u32, spots: f32) -> Option<Best<'a>> {
    let group = || {
        rows.iter().filter(move |r| {
            r.scene == scene && r.lights == lights && r.spot_fraction == spots && r.error.is_none()
        })
    };
    let useful = group().map(|r| r.useful_evaluations).max()?;
    let exact = || group().filter(move |r| r.useful_evaluations == useful);
    let mut by_frame: Vec<&CullingRow> = exact().collect();
    by_frame.sort_by(|a, b| a.frame_ms.total_cmp(&b.frame_ms));
    Some(Best {
        fastest: by_frame.first()?,
        runner_up: by_frame.get(1).copied(),
        fewest_evaluations: exact().min_by(|a, b| {
            a.evaluations
                .cmp(&b.evaluations)
                .then(a.frame_ms.total_cmp(&b.frame_ms))
        })?,
        least_memory: exact().min_by_key(|r| r.list_bytes)?,
    })
}

/// The table: each scene, light count and spot fraction, methods ranked by useful fraction.
fn table(rows: &[CullingRow]) -> Table {
    let mut t = Table::new(
        "Culling: every method on every scene (Forward+, depth pre-pass)",
        &[
            "scene / lights / spots",
            "method",
            "grid",
            "evaluations",
            "useful",
            "useful / performed",
            "worst list",
            "assignment ms",
            "shading ms",
            "frame ms",
            "list bytes",
        ],
    );
    let mut groups: Vec<(&str, u32, f32)> = Vec::new();
    for r in rows {
        let key = (r.scene.as_str(), r.lights, r.spot_fraction);
        if !groups.contains(&key) {
            groups.push(key);
        }
    }
    for (scene, lights, spots) in &groups {
        let label = format!("{scene} / {lights} / {spots}");
        let mut ranked: Vec<&CullingRow> = rows
            .iter()
            .filter(|r| r.scene == *scene && r.lights == *lights && r.spot_fraction == *spots)
            .collect();
        ranked.sort_by(|a, b| {
            b.efficiency
                .unwrap_or(0.0)
                .total_cmp(&a.efficiency.unwrap_or(0.0))
        });
        for r in ranked {
            if let Some(e) = &r.error {
                t.failed_row(vec![label.clone(), r.method.clone(), r.grid.clone()], e);
                continue;
            }
            t.row(vec![
                label.clone(),
                r.method.clone(),
                r.grid.clone(),
                r.evaluations.to_string(),
                r.useful_evaluations.to_string(),
                crate::table::percent(r.efficiency),
                r.worst_list.to_string(),
                sig(r.assignment_ms, 3),
                sig(r.shading_ms, 3),
                sig(r.frame_ms, 3),
                r.list_bytes.to_string(),
            ]);
        }
    }
    for (scene, lights, spots) in &groups {
        if let Some(b) = best(rows, scene, *lights, *spots) {
            let next = b
                .runner_up
                .map(|r| format!("; next {}, {} ms", r.method, sig(r.frame_ms, 3)))
                .unwrap_or_default();
            t.notes.push(format!(
                "{scene}, {lights} lights, spots {spots}: lowest median frame {} ({} ms{next}; points timed apart, no verdict); \
                 fewest evaluations {} ({} useful); smallest lists {} ({} bytes).",
                b.fastest.method,
                sig(b.fastest.frame_ms, 3),
                b.fewest_evaluations.method,
                crate::table::percent(b.fewest_evaluations.efficiency),
                b.least_memory.method,
                b.least_memory.list_bytes,
            ));
        }
    }
    for (scene, lights, spots) in &groups {
        if let Some((bounds, mask)) = worst_tiles(rows, scene, *lights, *spots) {
            t.notes.push(format!(
                "{scene}, {lights} lights, spots {spots}: worst tile {bounds} lights with depth \
                 bounds, {mask} with the 2.5D mask (Harada 2012: over {} down to at most {}).",
                HARADA_WORST_TILE.0, HARADA_WORST_TILE.1
            ));
        }
    }
    if let Some(r) = rows.first() {
        // A failed run has no timing source; when every run failed, none is named.
        let timing = rows
            .iter()
            .find(|r| r.error.is_none())
            .map(|r| format!(" ({} on this adapter)", r.timing_source))
            .unwrap_or_default();
        t.notes.push(format!(
            "Scenes at {}x{}; times are medians of the timed frames{timing}. Assignment: \
             every pass that builds the lists (marking, boxes, assignment); shading: the \
             light loop's pass. Worst list: the longest list of a tile or cluster holding a \
             visible sample. Useful: evaluations where the surface is within the light's \
             reach. Sources: {}.",
            r.width,
            r.height,
            methods()
                .iter()
                .map(|m| format!("{}: {}", m.name, m.source))
                .collect::<Vec<_>>()
                .join("; ")
        ));
    }
    t
}

/// A figure of a row that the plot draws.
type Measure = fn(&CullingRow) -> f64;

/// Evaluations performed (left) and shading time (right) against light count, log-log, one
/// line per method (the mean over scenes and spot fractions).
fn plot(rows: &[CullingRow]) -> Option<Plot> {
    let ok: Vec<&CullingRow> = rows
        .iter()
        .filter(|r| r.error.is_none() && r.evaluations > 0)
        .collect();
    let mut counts: Vec<u32> = ok.iter().map(|r| r.lights).collect();
    counts.sort_unstable();
    counts.dedup();
    if counts.len() < 2 {
        return None;
    }
    // Mean of `value` over a method's rows at each light count.
    let series = |method: &str, value: Measure| -> Vec<(f64, f64)> {
        counts
            .iter()
            .filter_map(|&n| {
                let v: Vec<f64> = ok
                    .iter()
                    .filter(|r| r.method == method && r.lights == n)
                    .map(|r| value(r))
                    .filter(|&v| v > 0.0)
                    .collect();
                (!v.is_empty()).then(|| (n as f64, v.iter().sum::<f64>() / v.len() as f64))
            })
            .collect()
    };
    let methods = methods();
    let panel = |label, value: Measure| crate::plot::Panel {
        label,
        values: ok.iter().map(|r| value(r)).collect(),
        series: methods
            .iter()
            .map(|m| (m.name, series(m.name, value)))
            .collect(),
    };
    crate::plot::against_lights(
        "culling.svg",
        "Culling: evaluations and time against light count",
        (counts[0], *counts.last()?),
        &[
            panel("light evaluations per frame", |r| r.evaluations as f64),
            panel("shading + assignment, ms", |r| {
                r.shading_ms + r.assignment_ms
            }),
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_method_makes_a_valid_variant() {
        for m in methods() {
            let problems = crate::variant::check(&m.variant((640, 360)));
            assert!(problems.is_empty(), "{}: {problems:?}", m.name);
        }
    }
}
