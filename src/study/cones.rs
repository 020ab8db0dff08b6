//! `clusterlab study cones`: spot lights culled by their bounding sphere against the cone
//! test, on every built-in scene at spot fractions 0, 0.5 and 1: light evaluations performed
//! and useful, shading time, and lights missing from a cluster they light (must be 0).

use serde::Serialize;
use strum::IntoEnumIterator;

use super::{StudyError, Table};
use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::render::Renderer;
use crate::scene::{Scene, SceneParams};
use crate::variant::{Clusters, Pipeline, SpotTest, Variant, ZSlicing};

/// The spot fractions every scene runs at.
pub const FRACTIONS: [f32; 3] = [0.0, 0.5, 1.0];

/// One scene, spot fraction and spot test.
#[derive(Clone, Debug, Serialize)]
pub struct ConeRow {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub lights: u32,
    pub spot_fraction: f32,
    pub spot_test: String,
    pub evaluations: u64,
    pub useful_evaluations: u64,
    pub efficiency: f64,
    /// Evaluations over those of the sphere test on the same frame (1 for the sphere rows).
    pub over_sphere: Option<f64>,
    pub shading_ms: f64,
    /// Light-cluster pairs where the light lights part of the cluster but is not listed.
    pub missed: u64,
    pub error: Option<String>,
}

/// Forward+ with a depth pre-pass on the default grid, with `test` for spots.
fn variant(test: SpotTest) -> Variant {
    Variant {
        description: format!("Forward+, spot test {test:?}"),
        pipeline: Pipeline::ClusteredForward,
        depth_prepass: true,
        clusters: Some(Clusters {
            grid: (16, 9, 24),
            slicing: ZSlicing::Exponential,
            spot_test: test,
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn measure(
    gpu: &Gpu,
    composer: &Composer,
    v: &Variant,
    scene: &Scene,
    frames: u32,
) -> Result<(crate::render::FrameStats, f64, u64), String> {
    let mut r = Renderer::new(gpu, composer, v, scene).map_err(|e| e.to_string())?;
    r.render().map_err(|e| e.to_string())?;
    let mut shading = Vec::new();
    for _ in 0..frames.max(1) {
        let f = r.render().map_err(|e| e.to_string())?;
        shading.push(f.timings.get("forward"));
    }
    let stats = r.stats().map_err(|e| e.to_string())?;
    let (missed, _) = crate::stress::missing_lights_of(&r, v, scene)?;
    Ok((stats, crate::measure::median(shading), missed))
}

/// Run both spot tests at each fraction on each scene (at `size`, with `lights` or the
/// scene's default count). Scenes with no lights are left out: they have no spots to cull.
pub fn run(
    gpu: &Gpu,
    composer: &Composer,
    scenes: &[&str],
    size: (u32, u32),
    lights: Option<u32>,
    frames: u32,
) -> Result<Vec<ConeRow>, StudyError> {
    let mut rows = Vec::new();
    for &name in scenes {
        let defaults =
            crate::scene::defaults(name).map_err(|e| StudyError::Usage(e.to_string()))?;
        let lights = lights.unwrap_or(defaults.lights);
        if lights == 0 {
            continue;
        }
        for spots in FRACTIONS {
            let params = SceneParams {
                width: size.0,
                height: size.1,
                lights,
                spots,
                ..defaults
            };
            let scene = crate::scene::generate(name, params)
                .map_err(|e| StudyError::Usage(e.to_string()))?;
            let mut sphere_evals = None;
            // The schema's list, the sphere test first: the others are measured against it.
            for test in SpotTest::iter() {
                let mut row = ConeRow {
                    scene: name.to_string(),
                    width: size.0,
                    height: size.1,
                    lights,
                    spot_fraction: spots,
                    spot_test: format!("{test:?}"),
                    evaluations: 0,
                    useful_evaluations: 0,
                    efficiency: 0.0,
                    over_sphere: None,
                    shading_ms: 0.0,
                    missed: 0,
                    error: None,
                };
                // One failing run is reported in its row; the others go on.
                match measure(gpu, composer, &variant(test), &scene, frames) {
                    Ok((s, shading_ms, missed)) => {
                        row.evaluations = s.light_evals;
                        row.useful_evaluations = s.useful_light_evals;
                        row.efficiency = s.useful_fraction();
                        row.shading_ms = shading_ms;
                        row.missed = missed;
                        if test == SpotTest::Sphere {
                            sphere_evals = Some(s.light_evals);
                        }
                        row.over_sphere = sphere_evals
                            .filter(|&n| n > 0)
                            .map(|n| s.light_evals as f64 / n as f64);
                    }
                    Err(e) => row.error = Some(e),
                }
                rows.push(row);
            }
        }
    }
    Ok(rows)
}

/// True when every run finished and no run missed a light.
pub fn all_exact(rows: &[ConeRow]) -> bool {
    rows.iter().all(|r| r.error.is_none() && r.missed == 0)
}

pub fn table(rows: &[ConeRow]) -> Table {
    let mut t = Table::new(
        "Spot culling: bounding sphere against the cone test (Forward+, 16x9x24 exponential, depth pre-pass)",
        &[
            "scene",
            "spots",
            "test",
            "evaluations",
            "useful",
            "useful / performed",
            "cone / sphere",
            "shading ms",
            "missed",
        ],
    );
    for r in rows {
        if let Some(e) = &r.error {
            let names = vec![
                r.scene.clone(),
                r.spot_fraction.to_string(),
                r.spot_test.clone(),
            ];
            t.failed_row(names, e);
            continue;
        }
        t.row(vec![
            r.scene.clone(),
            r.spot_fraction.to_string(),
            r.spot_test.clone(),
            r.evaluations.to_string(),
            r.useful_evaluations.to_string(),
            format!("{:.1}%", 100.0 * r.efficiency),
            r.over_sphere
                .map_or("-".into(), |x| format!("{:.1}%", 100.0 * x)),
            format!("{:.1}", r.shading_ms),
            r.missed.to_string(),
        ]);
    }
    t.notes.push(
        "cone / sphere: the cone test's evaluations over the sphere test's on the same frame; missed: light-cluster pairs where a light lights a sampled point of the cluster but is not in its list (must be 0)".into(),
    );
    t
}
