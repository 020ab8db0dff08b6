//! `clusterlab study cones`: spot lights culled by their bounding sphere against the cone
//! test, on every built-in scene at spot fractions 0, 0.5 and 1: light evaluations performed
//! and useful, shading time, and lights missing from a cluster they light (must be 0).

use std::sync::Arc;

use serde::Serialize;
use strum::IntoEnumIterator;

use super::{Reads, StudyError, StudyOptions};
use crate::compose::Composer;
use crate::gpu::Gpu;
use crate::render::Renderer;
use crate::scene::{Scene, SceneParams};
use crate::table::Table;
use crate::variant::{Clusters, Pipeline, SpotTest, Variant, ZSlicing};

/// The spot fractions every scene runs at.
pub const FRACTIONS: [f32; 3] = [0.0, 0.5, 1.0];

/// The study: both spot tests at each fraction on each scene.
pub struct ConeStudy {
    frames: u32,
}

/// One spot test on one scene (its name, lights and spot fraction in its parameters).
pub struct Point {
    name: String,
    scene: Arc<Scene>,
    test: SpotTest,
}

/// One scene, spot fraction and spot test.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ConeRow {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub lights: u32,
    pub spot_fraction: f32,
    pub spot_test: String,
    pub evaluations: u64,
    pub useful_evaluations: u64,
    /// None: no light evaluated.
    pub efficiency: Option<f64>,
    /// Evaluations over those of the sphere test on the same frame (1 for the sphere rows).
    pub over_sphere: Option<f64>,
    pub shading_ms: f64,
    /// Light-cluster pairs where the light lights part of the cluster but is not listed.
    pub missed: u64,
    pub error: Option<String>,
}

super::outcome_in_error_field!(ConeRow);

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

/// The row of a point, with no figures yet.
fn named(p: &Point) -> ConeRow {
    let params = &p.scene.params;
    ConeRow {
        scene: p.name.clone(),
        width: params.width,
        height: params.height,
        lights: params.lights,
        spot_fraction: params.spots,
        spot_test: format!("{:?}", p.test),
        ..Default::default()
    }
}

impl super::Study for ConeStudy {
    const NAME: &'static str = "cones";
    const READS: &'static [Reads] = &[Reads::Scenes, Reads::Size, Reads::Lights, Reads::Frames];
    const ABOUT: &'static str = "Spot lights culled by their bounding sphere against the cone \
        test, at spot fractions 0, 0.5 and 1 on each scene: evaluations, shading time and \
        lights missed, which must be 0 (--scenes, --size, --lights, --frames)";
    type Point = Point;
    type Row = ConeRow;

    /// Scenes with no lights are left out: they have no spots to cull.
    fn plan(_gpu: &Gpu, options: &StudyOptions) -> Result<(Self, Vec<Point>), StudyError> {
        let mut points = Vec::new();
        for name in &options.scenes {
            for params in options.params_for(name, &[])? {
                if params.lights == 0 {
                    continue;
                }
                for spots in FRACTIONS {
                    let params = SceneParams { spots, ..params };
                    let scene = Arc::new(super::generate(name, params)?);
                    // The schema's list, the sphere test first: the others are measured
                    // against it.
                    for test in SpotTest::iter() {
                        let (name, scene) = (name.clone(), scene.clone());
                        points.push(Point { name, scene, test });
                    }
                }
            }
        }
        let frames = options.frames;
        Ok((ConeStudy { frames }, points))
    }

    fn label(&self, p: &Point) -> String {
        let params = &p.scene.params;
        let (lights, spots) = (params.lights, params.spots);
        format!("{} {lights} lights, spots {spots}: {:?}", p.name, p.test)
    }

    fn run(&self, gpu: &Gpu, composer: &Composer, p: &Point) -> Result<Vec<ConeRow>, StudyError> {
        let v = variant(p.test);
        let mut r = Renderer::new(gpu, composer, &v, &p.scene)?;
        r.render()?;
        let mut shading = Vec::new();
        for _ in 0..self.frames.max(1) {
            let f = r.render()?;
            shading.push(f.timings.get("forward"));
        }
        let stats = r.stats()?;
        let (missed, _) =
            crate::stress::missing_lights_of(&r, &v, &p.scene).map_err(StudyError::Usage)?;
        Ok(vec![ConeRow {
            evaluations: stats.light_evals,
            useful_evaluations: stats.useful_light_evals,
            efficiency: stats.useful_fraction(),
            shading_ms: crate::measure::median(shading),
            missed,
            ..named(p)
        }])
    }

    fn named(&self, p: &Point) -> ConeRow {
        named(p)
    }

    /// Each test's evaluations over the sphere test's on the same frame.
    fn relate(&self, rows: &mut [ConeRow]) {
        let same_frame = |a: &ConeRow, b: &ConeRow| {
            (&a.scene, a.lights, a.spot_fraction) == (&b.scene, b.lights, b.spot_fraction)
        };
        let sphere = format!("{:?}", SpotTest::Sphere);
        for i in 0..rows.len() {
            let base = rows
                .iter()
                .find(|o| same_frame(o, &rows[i]) && o.spot_test == sphere && o.error.is_none())
                .map(|o| o.evaluations)
                .filter(|&n| n > 0);
            if rows[i].error.is_none() {
                rows[i].over_sphere = base.map(|n| rows[i].evaluations as f64 / n as f64);
            }
        }
    }

    /// No light missed.
    fn keeps(&self, row: &ConeRow, _: &[ConeRow]) -> bool {
        row.missed == 0
    }

    fn table(&self, rows: &[ConeRow]) -> Table {
        table(rows)
    }
}

fn table(rows: &[ConeRow]) -> Table {
    let mut t = Table::new(
        "Spot culling: bounding sphere against the cone test (Forward+, 16x9x24 exponential, depth pre-pass)",
        &[
            "scene / lights",
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
        let names = vec![
            format!("{} / {}", r.scene, r.lights),
            r.spot_fraction.to_string(),
            r.spot_test.clone(),
        ];
        if let Some(e) = &r.error {
            t.failed_row(names, e);
            continue;
        }
        let mut cells = names;
        cells.extend([
            r.evaluations.to_string(),
            r.useful_evaluations.to_string(),
            crate::table::percent(r.efficiency),
            r.over_sphere
                .map_or("-".into(), |x| format!("{:.1}%", 100.0 * x)),
            format!("{:.1}", r.shading_ms),
            r.missed.to_string(),
        ]);
        t.row(cells);
    }
    t.notes.push(
        "cone / sphere: the cone test's evaluations over the sphere test's on the same frame; missed: light-cluster pairs where a light lights a sampled point of the cluster but is not in its list (must be 0)".into(),
    );
    t
}
