//! `clusterlab study depth`: how well view depth comes back from the depth buffer, for each
//! format and depth mapping, read from rendered frames of planes at known depths.

use glam::DVec3;
use serde::Serialize;

use super::{Reads, StudyError, StudyOptions};
use crate::compose::Composer;
use crate::cpu::depth::DepthMapping;
use crate::gpu::Gpu;
use crate::plot::Plot;
use crate::render::Renderer;
use crate::scene::MeshBuilder;
use crate::scene::{Camera, Scene, SceneParams};
use crate::table::{Table, sig};
use crate::variant::{Depth, DepthFormat, Pipeline, Variant};

pub const NEAR: f64 = 0.05;
/// The finite far plane; the planes reach 1e4.
pub const FAR: f64 = 2e4;
const NEAREST: f64 = 0.1;
const FARTHEST: f64 = 1e4;
/// Decades of distance the table reports.
const BINS: [(f64, f64); 5] = [
    (0.1, 1.0),
    (1.0, 10.0),
    (10.0, 100.0),
    (100.0, 1e3),
    (1e3, 1e4),
];

/// One depth setup of the study.
#[derive(Clone, Copy, Debug)]
pub struct Setup {
    pub format: DepthFormat,
    pub mapping: DepthMapping,
}

impl Setup {
    pub fn all() -> Vec<Setup> {
        let mut out = Vec::new();
        for format in [DepthFormat::Unorm24, DepthFormat::Float32] {
            for reversed in [false, true] {
                for infinite_far in [false, true] {
                    out.push(Setup {
                        format,
                        mapping: DepthMapping {
                            reversed,
                            infinite_far,
                        },
                    });
                }
            }
        }
        out
    }

    pub fn name(&self) -> String {
        format!(
            "{} {} {}",
            match self.format {
                DepthFormat::Unorm24 => "24-bit",
                DepthFormat::Float32 => "float32",
            },
            if self.mapping.reversed {
                "reversed-Z"
            } else {
                "standard"
            },
            if self.mapping.infinite_far {
                "infinite far"
            } else {
                "finite far"
            }
        )
    }

    fn variant(&self) -> Variant {
        Variant {
            description: self.name(),
            pipeline: Pipeline::NaiveForward,
            depth: Depth {
                format: self.format,
                reversed_z: self.mapping.reversed,
                infinite_far: Some(self.mapping.infinite_far),
            },
            ..Variant::default()
        }
    }

    /// Reed 2015's model (`DepthMapping::stored_relative_error`) at the study's planes.
    pub fn model_relative_error(&self, z: f64) -> f64 {
        self.mapping
            .stored_relative_error(self.format, z, NEAR, FAR)
    }
}

/// The frame: `columns` fronto-parallel strips, one per pixel column, at view depths spaced
/// evenly in log from 0.1 to 1e4, `rows` pixels high. Returns the scene and each column's
/// exact view depth (that of its f32 vertices).
pub fn planes_scene(columns: u32, rows: u32) -> (Scene, Vec<f64>) {
    let fov_y = 60f64.to_radians();
    let aspect = columns as f64 / rows as f64;
    let tan = (fov_y / 2.0).tan();
    let mut mesh = MeshBuilder::default();
    let mut depths = Vec::with_capacity(columns as usize);
    for i in 0..columns {
        let t = i as f64 / (columns - 1) as f64;
        let z = (NEAREST * (FARTHEST / NEAREST).powf(t)) as f32 as f64;
        // Cover the middle of pixel column i (its centre is at i + 0.5) at depth z.
        let ndc = |px: f64| (px / columns as f64) * 2.0 - 1.0;
        let (x0, x1) = (ndc(i as f64 + 0.2), ndc(i as f64 + 0.8));
        let (sx, sy) = (z * tan * aspect, z * tan * 1.2);
        mesh.quad(
            [
                DVec3::new(x0 * sx, -sy, -z),
                DVec3::new(x1 * sx, -sy, -z),
                DVec3::new(x1 * sx, sy, -z),
                DVec3::new(x0 * sx, sy, -z),
            ],
            DVec3::Z,
            [0.5, 0.5, 0.5],
        );
        // The vertices store -z as f32; z was rounded to f32 above, so this is exact.
        depths.push(-(mesh.vertices.last().expect("a vertex").position[2] as f64));
    }
    let camera = Camera {
        eye: DVec3::ZERO,
        target: DVec3::NEG_Z,
        up: DVec3::Y,
        fov_y,
        near: NEAR,
        far: FAR,
    };
    let scene = Scene {
        name: "depth_planes".into(),
        params: SceneParams {
            width: columns,
            height: rows,
            lights: 0,
            radius_range: (1.0, 1.0),
            seed: 0,
            time: 0.0,
            spots: 0.0,
            motion: crate::scene::Motion::ALL,
        },
        vertices: mesh.vertices,
        indices: mesh.indices,
        blended: mesh.blended,
        lights: Vec::new(),
        camera,
        prev_camera: camera,
        moving_lights: Vec::new(),
        textures: None,
        file: None,
        notes: Vec::new(),
    };
    (scene, depths)
}

/// Errors of one setup over one decade of distance.
#[derive(Clone, Debug, Default, Serialize)]
pub struct DepthRow {
    pub setup: String,
    pub format: String,
    pub reversed_z: bool,
    pub infinite_far: bool,
    pub from: f64,
    pub to: f64,
    /// Max and mean |z' - z| / z, z' rebuilt on the GPU (f32, `view_depth_from_device`).
    pub max_relative_gpu: f64,
    pub mean_relative_gpu: f64,
    /// Max relative error of z' rebuilt in f64 from the stored value: the storage alone.
    pub max_relative_stored: f64,
    /// Reed 2015's model (half a storage step at the exact d(z)), max over the decade.
    pub max_relative_model: f64,
    /// Pixels measured in the decade.
    pub samples: u64,
    /// Pixels that showed background (a strip missed).
    pub missing: u64,
    pub error: Option<String>,
    /// Per pixel column in the decade, its view depth and the largest relative error of
    /// the GPU rebuild there (the plot's curve).
    #[serde(skip)]
    pub curve: Vec<(f64, f64)>,
    /// How the adapter stores Depth24Plus, judged from this setup's stored values (24-bit
    /// reversed-Z with an infinite far plane only: it puts distant planes on small values).
    #[serde(skip)]
    pub unorm24_storage: Option<String>,
}

super::outcome_in_error_field!(DepthRow);

/// The relative errors of one pixel column (one plane).
#[derive(Clone, Default)]
struct ColumnErrors {
    /// Of the GPU rebuild: largest and sum.
    max_gpu: f64,
    sum_gpu: f64,
    /// Of the f64 rebuild of the stored value.
    max_stored: f64,
    count: u64,
    /// Pixels that showed the clear value.
    missing: u64,
}

/// The study: every setup on one frame of planes at known depths.
pub struct DepthStudy {
    scene: Scene,
    /// Each pixel column's exact view depth.
    truth: Vec<f64>,
    columns: u32,
    /// Why this adapter's reversed-Z float32 depth differs, where it is declared to.
    adapter_deviation: Option<&'static str>,
}

/// The row of a setup's decade, with no figures yet.
fn named(setup: &Setup, (from, to): (f64, f64)) -> DepthRow {
    DepthRow {
        setup: setup.name(),
        format: format!("{:?}", setup.format),
        reversed_z: setup.mapping.reversed,
        infinite_far: setup.mapping.infinite_far,
        from,
        to,
        ..Default::default()
    }
}

impl super::Study for DepthStudy {
    const NAME: &'static str = "depth";
    const READS: &'static [Reads] = &[];
    const ABOUT: &'static str = "Relative error of view depth rebuilt from the depth buffer, \
        for each format and depth mapping, against Reed 2015's model; no plane may be missed";
    type Point = Setup;
    type Row = DepthRow;

    fn plan(gpu: &Gpu, options: &StudyOptions) -> Result<(Self, Vec<Setup>), StudyError> {
        let (columns, rows) = (options.depth_columns, options.depth_rows);
        if columns < 2 || rows == 0 {
            return Err(StudyError::Usage(
                "the depth study needs at least 2 columns and 1 row".into(),
            ));
        }
        let (scene, truth) = planes_scene(columns, rows);
        let adapter_deviation =
            crate::gpu::expect::allowance(gpu, crate::gpu::expect::Check::ReversedFloatDepth)
                .map(|d| d.why);
        let study = DepthStudy {
            scene,
            truth,
            columns,
            adapter_deviation,
        };
        Ok((study, Setup::all()))
    }

    fn label(&self, setup: &Setup) -> String {
        setup.name()
    }

    fn run(
        &self,
        gpu: &Gpu,
        composer: &Composer,
        setup: &Setup,
    ) -> Result<Vec<DepthRow>, StudyError> {
        let variant = setup.variant();
        let mut renderer = Renderer::new(gpu, composer, &variant, &self.scene)?;
        renderer.render()?;
        let samples = crate::kernels::gpu_depth_samples(
            gpu,
            composer,
            &variant,
            renderer.depth_texture(),
            NEAR as f32,
            FAR as f32,
        )?;
        let (w, truth) = (self.columns as usize, &self.truth);
        let mut per_column = vec![ColumnErrors::default(); w];
        for (i, (&d, &rebuilt)) in samples.device.iter().zip(&samples.view_depth).enumerate() {
            let c = &mut per_column[i % w];
            let z = truth[i % w];
            if setup.mapping.is_background(d as f64) {
                c.missing += 1;
                continue;
            }
            let gpu = (rebuilt as f64 - z).abs() / z;
            let stored = setup
                .mapping
                .view_depth(d as f64, NEAR, FAR)
                .unwrap_or(f64::INFINITY);
            c.max_gpu = c.max_gpu.max(gpu);
            c.sum_gpu += gpu;
            c.max_stored = c.max_stored.max((stored - z).abs() / z);
            c.count += 1;
        }
        let storage = (setup.format == DepthFormat::Unorm24
            && setup.mapping
                == (DepthMapping {
                    reversed: true,
                    infinite_far: true,
                }))
        .then(|| unorm24_storage(&samples.device));
        let mut rows = Vec::new();
        for &(from, to) in &BINS {
            let in_bin: Vec<usize> = (0..w)
                .filter(|&i| {
                    truth[i] >= from && (truth[i] < to || (to == FARTHEST && truth[i] <= to))
                })
                .collect();
            let max = |f: fn(&ColumnErrors) -> f64| {
                in_bin
                    .iter()
                    .map(|&i| f(&per_column[i]))
                    .fold(0.0, f64::max)
            };
            let count: u64 = in_bin.iter().map(|&i| per_column[i].count).sum();
            rows.push(DepthRow {
                max_relative_gpu: max(|c| c.max_gpu),
                mean_relative_gpu: in_bin.iter().map(|&i| per_column[i].sum_gpu).sum::<f64>()
                    / count.max(1) as f64,
                max_relative_stored: max(|c| c.max_stored),
                max_relative_model: in_bin
                    .iter()
                    .map(|&i| setup.model_relative_error(truth[i]))
                    .fold(0.0, f64::max),
                samples: count,
                missing: in_bin.iter().map(|&i| per_column[i].missing).sum(),
                curve: in_bin
                    .iter()
                    .map(|&i| (truth[i], per_column[i].max_gpu))
                    .collect(),
                unorm24_storage: storage.clone(),
                ..named(setup, (from, to))
            });
        }
        Ok(rows)
    }

    /// A setup that failed leaves one row, its first decade's.
    fn named(&self, setup: &Setup) -> DepthRow {
        named(setup, BINS[0])
    }

    /// Every plane drawn.
    fn keeps(&self, row: &DepthRow, _: &[DepthRow]) -> bool {
        row.missing == 0
    }

    fn table(&self, rows: &[DepthRow]) -> Table {
        table(rows, self.adapter_deviation)
    }

    fn plot(&self, rows: &[DepthRow]) -> Option<Plot> {
        plot(rows)
    }
}

/// "24-bit unorm" when the small stored values sit on the 1/(2^24 - 1) grid (reversed-Z puts
/// distant planes there), else "32-bit float": Depth24Plus may be either.
fn unorm24_storage(device: &[f32]) -> String {
    let scale = ((1u32 << 24) - 1) as f64;
    let small: Vec<f64> = device
        .iter()
        .map(|&d| d as f64)
        .filter(|&d| d > 0.0 && d < 1e-4)
        .collect();
    if small.is_empty() {
        return "unknown (no small values to judge from)".into();
    }
    let off_grid = small
        .iter()
        // Below 1e-4 (k < 1678), f32 holds k / (2^24 - 1) to within 1e-4 of a code.
        .filter(|&&d| ((d * scale) - (d * scale).round()).abs() > 1e-2)
        .count();
    if off_grid == 0 {
        "24-bit unorm".into()
    } else {
        format!(
            "32-bit float ({off_grid} of {} small values off the 24-bit grid)",
            small.len()
        )
    }
}

/// The table: per setup, the max relative error of the GPU rebuild in each decade, with
/// Reed's model in parentheses.
fn table(rows: &[DepthRow], adapter_deviation: Option<&str>) -> Table {
    let mut columns = vec!["setup".to_string()];
    columns.extend(
        BINS.iter()
            .map(|(a, b)| format!("{}..{}", sig(*a, 1), sig(*b, 1))),
    );
    let refs: Vec<&str> = columns.iter().map(|s| s.as_str()).collect();
    let mut t = Table::new(
        "Depth: max relative error of view depth rebuilt from the depth buffer, measured (Reed 2015 model)",
        &refs,
    );
    for s in setups(rows) {
        let here: Vec<&DepthRow> = rows.iter().filter(|r| r.setup == s).collect();
        if let Some(e) = here.iter().find_map(|r| r.error.as_deref()) {
            t.failed_row(vec![s.to_string()], e);
            continue;
        }
        let mut cells = vec![s.to_string()];
        for r in here {
            cells.push(format!(
                "{} ({})",
                sig(r.max_relative_gpu, 2),
                sig(r.max_relative_model, 2)
            ));
        }
        t.row(cells);
    }
    let missing: u64 = rows.iter().map(|r| r.missing).sum();
    let storage = rows
        .iter()
        .find_map(|r| r.unorm24_storage.as_deref())
        .unwrap_or("not measured");
    t.notes.push(format!(
        "Planes at 0.1..1e4 (one pixel column each, log spaced), near {NEAR}, finite far \
         {FAR}; view depth rebuilt by the shaders' `view_depth_from_device` in f32 and \
         compared with the planes' exact depth in f64. Model (Reed 2015): the exact d(z) \
         rounded to the format, half a step over the slope dd/dz. Depth24Plus is stored on \
         this adapter as: {storage}. Pixels that missed their plane: {missing}."
    ));
    if let Some(why) = adapter_deviation {
        t.notes.push(format!(
            "On this adapter reversed-Z float32 is only as precise as 24-bit depth: {why}."
        ));
    }
    t
}

/// The setups of `rows`, in order.
fn setups(rows: &[DepthRow]) -> Vec<&str> {
    let mut setups: Vec<&str> = rows.iter().map(|r| r.setup.as_str()).collect();
    setups.dedup();
    setups
}

/// The envelope of a curve: the largest error in each of `bins` log-spaced distance bins
/// (single columns swing between 0 and the max as planes fall on or between stored values).
fn envelope(points: &[(f64, f64)], bins: usize) -> Vec<(f64, f64)> {
    let bin = |z: f64| {
        let t = (z / NEAREST).ln() / (FARTHEST / NEAREST).ln();
        ((t * bins as f64) as usize).min(bins - 1)
    };
    let mut out: Vec<(f64, f64)> = Vec::new();
    let mut current = None;
    for &(z, e) in points {
        let b = bin(z);
        if current == Some(b) {
            let last = out.last_mut().expect("a point per bin");
            last.1 = last.1.max(e);
        } else {
            current = Some(b);
            out.push((z, e));
        }
    }
    out
}

/// Relative error against distance, per setup (log-log): the measured envelope as lines,
/// Reed's model as dashes.
fn plot(rows: &[DepthRow]) -> Option<Plot> {
    use plotters::prelude::*;
    const FLOOR: f64 = 1e-9;
    crate::plot::svg(
        "depth.svg",
        "Depth: relative error of rebuilt view depth",
        (880 + crate::plot::LEGEND_WIDTH, 560),
        |area| {
            let mut chart = ChartBuilder::on(area)
                .caption(
                    "Depth: relative error of rebuilt view depth",
                    ("sans-serif", 20),
                )
                .margin(12)
                .margin_right(crate::plot::LEGEND_WIDTH)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(
                    crate::plot::log_axis(0.1, 1e4),
                    crate::plot::log_axis(FLOOR, 1.0),
                )
                .ok()?;
            chart
                .configure_mesh()
                .light_line_style(TRANSPARENT)
                .x_desc("view depth (near 0.05)")
                .y_desc("max relative error")
                .x_label_formatter(&crate::plot::tick_label)
                .y_label_formatter(&crate::plot::tick_label)
                .draw()
                .ok()?;
            let mut legend = Vec::new();
            for (i, setup) in setups(rows).into_iter().enumerate() {
                let color = crate::plot::series_color(i);
                let curve: Vec<(f64, f64)> = rows
                    .iter()
                    .filter(|r| r.setup == setup)
                    .flat_map(|r| r.curve.iter().copied())
                    .collect();
                let points: Vec<(f64, f64)> = envelope(&curve, 60)
                    .into_iter()
                    .map(|(z, e)| (z, e.max(FLOOR)))
                    .collect();
                chart
                    .draw_series(LineSeries::new(points, color.stroke_width(2)))
                    .ok()?;
                legend.push((setup.to_string(), color, None));
            }
            // Reed's model for the three distinct cases: fixed point (either direction),
            // standard float, reversed float.
            let model = |format, reversed| {
                let setup = Setup {
                    format,
                    mapping: DepthMapping {
                        reversed,
                        infinite_far: true,
                    },
                };
                let points: Vec<(f64, f64)> = (0..=60)
                    .map(|k| {
                        let z = NEAREST * (FARTHEST / NEAREST).powf(k as f64 / 60.0);
                        (z, setup.model_relative_error(z))
                    })
                    .collect();
                DashedLineSeries::new(points, 6, 4, BLACK.stroke_width(1))
            };
            chart.draw_series(model(DepthFormat::Unorm24, false)).ok()?;
            chart.draw_series(model(DepthFormat::Float32, true)).ok()?;
            legend.push(("Reed 2015 model (dashed)".to_string(), BLACK, None));
            crate::plot::legend(area, &legend)
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planes_cover_the_range_at_exact_f32_depths() {
        let (scene, z) = planes_scene(64, 2);
        assert_eq!(z.len(), 64);
        assert!((z[0] - 0.1).abs() < 1e-8 && (z[63] - 1e4).abs() < 1e-3);
        assert!(z.windows(2).all(|w| w[1] > w[0]));
        assert_eq!(scene.vertices.len(), 64 * 4);
        assert!(z.iter().all(|&d| d as f32 as f64 == d));
    }

    #[test]
    fn model_follows_reed() {
        let s = |format, reversed, infinite_far| Setup {
            format,
            mapping: DepthMapping {
                reversed,
                infinite_far,
            },
        };
        // Fixed point: the error grows linearly with distance, standard or reversed.
        let u = s(DepthFormat::Unorm24, false, true);
        let r = u.model_relative_error(1000.0) / u.model_relative_error(10.0);
        assert!((r - 100.0).abs() < 1.0, "{r}");
        let ur = s(DepthFormat::Unorm24, true, true);
        assert!(
            (ur.model_relative_error(100.0) / u.model_relative_error(100.0) - 1.0).abs() < 1e-9
        );
        // Reversed float: about 2^-24 relative (half an ULP of d = n/z) at every distance.
        let f = s(DepthFormat::Float32, true, true);
        for z in [0.1, 3.0, 700.0, 1e4] {
            let e = f.model_relative_error(z);
            assert!(e > 2f64.powi(-26) && e < 1.01 * 2f64.powi(-24), "{z} {e}");
        }
        // Standard float is no better than 24-bit far away (d is near 1, ULP 2^-24).
        let fs = s(DepthFormat::Float32, false, true);
        let ratio = fs.model_relative_error(1e4) / u.model_relative_error(1e4);
        assert!((0.9..1.1).contains(&ratio), "{ratio}");
    }
}
