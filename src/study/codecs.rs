//! `clusterlab study codecs`: the angular error of every normal codec at every bit count, on
//! the GPU through the G-buffer's own WGSL path and by the CPU twin in f64.

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde::Serialize;

use std::sync::Arc;

use super::{Reads, StudyError, StudyOptions};
use crate::compose::Composer;
use crate::cpu::normals::*;
use crate::cpu::normals::{decode, encode};
use crate::gpu::Gpu;
use crate::plot::Plot;
use crate::table::{Table, sig};
use crate::variant::{NORMAL_BITS, NormalCodec};

/// Significant digits the table prints, and at most 4 decimals (1e-4 degrees, 17 times the
/// direction resolution of an f32 unit vector: finer digits would print the GPU's f32
/// rounding). GPU and CPU must agree to them.
pub const DIGITS: usize = 3;

/// An angle in degrees as the table prints it.
pub fn degrees(x: f64) -> String {
    let printed = sig(x, DIGITS);
    match printed.split_once('.') {
        Some((_, decimals)) if decimals.len() > 4 && !printed.contains('e') => format!("{x:.4}"),
        _ => printed,
    }
}

/// Published figures for plain octahedral encoding over 1M random unit vectors (arccos of
/// the dot product, degrees): Liam Tyler, "Analyzing Octahedral Encoded Normals" (2024),
/// bits per component, mean, max.
pub const TYLER_OCT: [(u32, f64, f64); 3] = [
    (8, 0.350526, 0.946480),
    (10, 0.087357, 0.235790),
    (12, 0.021842, 0.058642),
];

/// Error statistics of one codec at one bit count, from one side (GPU or CPU).
#[derive(Clone, Debug, Default, Serialize)]
pub struct CodecRow {
    pub codec: String,
    /// "uniform" (on the sphere) or "cube" (cube points normalized, as Tyler 2024 samples).
    pub sampling: String,
    /// Total bits of a packed normal.
    pub bits: u32,
    /// "gpu" or "cpu".
    pub source: String,
    /// Over the sample (uniform or cube), degrees.
    pub mean_deg: f64,
    pub p99_deg: f64,
    pub max_deg: f64,
    /// Over the adversarial set (axes, poles, seams, signed zeros), degrees.
    pub adversarial_max_deg: f64,
    /// The adversarial normal with the largest error, x y z.
    pub adversarial_worst: String,
    /// Codes that differ from the CPU twin's (GPU rows; 0 for CPU rows).
    pub codes_differing_from_cpu: u64,
    pub samples: u64,
    pub adversarial_samples: u64,
    pub error: Option<String>,
}

super::outcome_in_error_field!(CodecRow);

/// `n` unit vectors uniform on the sphere (z uniform in [-1, 1], azimuth uniform), seeded.
pub fn uniform_normals(n: usize, seed: u64) -> Vec<DVec3> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let z: f64 = rng.random_range(-1.0..=1.0);
            let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let r = (1.0 - z * z).max(0.0).sqrt();
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// `n` points uniform in the cube [-1, 1]^3, normalized: the sampling of Tyler 2024 (and of
/// many codec write-ups). Denser towards the cube's corners than uniform sampling.
pub fn cube_normalized_normals(n: usize, seed: u64) -> Vec<DVec3> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let p = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if p.length() > 1e-6 {
            out.push(p.normalize());
        }
    }
    out
}

/// Where codecs break: the axes with every sign of zero, the poles approached from many
/// azimuths, the octahedral fold seams (x or y = ±0 below the equator), the equator itself,
/// the polar codec's azimuth seam (y = ±0, x < 0), and the octant diagonals.
pub fn adversarial_normals() -> Vec<DVec3> {
    let mut out = Vec::new();
    let zeros = [0.0, -0.0];
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            for a in zeros {
                for b in zeros {
                    let mut n = [0.0; 3];
                    n[axis] = sign;
                    n[(axis + 1) % 3] = a;
                    n[(axis + 2) % 3] = b;
                    out.push(DVec3::from(n));
                }
            }
        }
    }
    for eps in [1e-7, 1e-5, 1e-3, 1e-2] {
        for k in 0..16 {
            let a = k as f64 * std::f64::consts::TAU / 16.0;
            for zs in [1.0, -1.0] {
                out.push(DVec3::new(eps * a.cos(), eps * a.sin(), zs).normalize());
            }
        }
    }
    for k in 0..=32 {
        let t = k as f64 * std::f64::consts::FRAC_PI_2 / 32.0;
        let (s, c) = t.sin_cos();
        for x0 in zeros {
            for sx in [1.0, -1.0] {
                out.push(DVec3::new(sx * s, x0, -c));
                out.push(DVec3::new(x0, sx * s, -c));
            }
        }
    }
    for k in 0..64 {
        let a = k as f64 * std::f64::consts::TAU / 64.0;
        for z in [0.0, -0.0, 1e-6, -1e-6] {
            out.push(DVec3::new(a.cos(), a.sin(), z).normalize());
        }
    }
    for k in 0..=32 {
        let t = k as f64 * std::f64::consts::PI / 32.0;
        for y in [0.0, -0.0, 1e-7, -1e-7] {
            out.push(DVec3::new(-t.sin(), y, t.cos()).normalize());
        }
    }
    for sx in [1.0, -1.0] {
        for sy in [1.0, -1.0] {
            for sz in [1.0, -1.0] {
                out.push(DVec3::new(sx, sy, sz).normalize());
            }
        }
    }
    out
}

/// Mean, 99th percentile and max of `errors` (reordered), and the index of the max.
fn summarize(errors: &mut [f64]) -> (f64, f64, f64) {
    let n = errors.len();
    let mean = errors.iter().sum::<f64>() / n as f64;
    let max = errors.iter().copied().fold(0.0, f64::max);
    let k = ((n as f64 * 0.99).ceil() as usize).clamp(1, n) - 1;
    let (_, p99, _) = errors.select_nth_unstable_by(k, f64::total_cmp);
    (mean, *p99, max)
}

fn worst(errors: &[f64], normals: &[DVec3]) -> (f64, String) {
    let (i, e) = errors
        .iter()
        .copied()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((0, 0.0));
    let n = normals.get(i).copied().unwrap_or_default();
    (e, format!("{:+e} {:+e} {:+e}", n.x, n.y, n.z))
}

/// The normals as the GPU takes them (f32), and the same values in f64 for the CPU twin.
fn as_f32(normals: &[DVec3]) -> (Vec<[f32; 4]>, Vec<DVec3>) {
    normals
        .iter()
        .map(|n| {
            let f = n.as_vec3();
            ([f.x, f.y, f.z, 0.0], f.as_dvec3())
        })
        .unzip()
}

/// The CPU twin's codes (packed like `pack_code`) and decodes.
fn cpu_round_trip(codec: NormalCodec, inputs: &[DVec3]) -> (Vec<u32>, Vec<DVec3>) {
    let bits = codec.bits() / 2;
    inputs
        .par_iter()
        .map(|&n| {
            let q = encode(codec, n).expect("a packed codec");
            (
                q[0] | (q[1] << bits),
                decode(codec, q).expect("a packed codec"),
            )
        })
        .unzip()
}

fn angles(truth: &[DVec3], decoded: impl IndexedParallelIterator<Item = DVec3>) -> Vec<f64> {
    truth
        .par_iter()
        .zip(decoded)
        .map(|(&t, d)| angle_degrees(t, d))
        .collect()
}

/// A set of normals the codecs round-trip: the sample, then the adversarial normals, as
/// f64 truth and as the f32 inputs of the GPU and the CPU twin.
pub struct NormalSet {
    /// "uniform" or "cube".
    sampling: &'static str,
    truth: Vec<DVec3>,
    gpu_in: Vec<[f32; 4]>,
    cpu_in: Vec<DVec3>,
    /// Normals of the sample; the adversarial ones follow.
    samples: usize,
    adversarial: Vec<DVec3>,
}

impl NormalSet {
    fn new(sampling: &'static str, sample: &[DVec3]) -> Self {
        let adversarial = adversarial_normals();
        let truth: Vec<DVec3> = sample.iter().chain(&adversarial).copied().collect();
        let (gpu_in, cpu_in) = as_f32(&truth);
        NormalSet {
            sampling,
            truth,
            gpu_in,
            cpu_in,
            samples: sample.len(),
            adversarial,
        }
    }

    /// The row of `errors` (the sample's, then the adversarial ones').
    fn row(&self, codec: &str, bits: u32, source: &str, errors: &mut [f64]) -> CodecRow {
        let nu = self.samples;
        let (adv_max, adv_worst) = worst(&errors[nu..], &self.adversarial);
        let (mean, p99, max) = summarize(&mut errors[..nu]);
        CodecRow {
            mean_deg: mean,
            p99_deg: p99,
            max_deg: max,
            adversarial_max_deg: adv_max,
            adversarial_worst: adv_worst,
            samples: nu as u64,
            adversarial_samples: self.adversarial.len() as u64,
            ..self.named(codec, bits, source)
        }
    }

    /// A row of this set with no figures yet.
    fn named(&self, codec: &str, bits: u32, source: &str) -> CodecRow {
        CodecRow {
            codec: codec.to_string(),
            sampling: self.sampling.to_string(),
            bits,
            source: source.to_string(),
            ..Default::default()
        }
    }
}

/// The study: every codec on `--samples` uniform normals (seeded) plus the adversarial set;
/// plain octahedral also on as many cube-normalized ones, to compare with Tyler 2024.
pub struct CodecStudy;

/// One codec at one bit count on one set, GPU and CPU; or three f32 components.
pub enum Point {
    Codec {
        set: Arc<NormalSet>,
        codec: NormalCodec,
    },
    /// Three f32 components (the Wide layout): the only error is rounding the normal.
    F32 { set: Arc<NormalSet> },
}

impl super::Study for CodecStudy {
    const NAME: &'static str = "codecs";
    const READS: &'static [Reads] = &[Reads::Samples];
    const ABOUT: &'static str = "Angular error of every normal codec at every bit count, on \
        the GPU through the G-buffer's WGSL and by the CPU twin in f64, beside Tyler 2024 and \
        Meyer 2010; GPU and CPU must print the same (--samples)";
    type Point = Point;
    type Row = CodecRow;

    fn plan(_gpu: &Gpu, options: &StudyOptions) -> Result<(Self, Vec<Point>), StudyError> {
        if options.samples == 0 {
            return Err(StudyError::Usage("--samples must be at least 1".into()));
        }
        let (n, seed) = (options.samples, options.seed);
        let uniform = Arc::new(NormalSet::new("uniform", &uniform_normals(n, seed)));
        let cube = Arc::new(NormalSet::new("cube", &cube_normalized_normals(n, seed)));
        let codecs = NormalCodec::packed(32);
        let mut points = Vec::new();
        for (set, kinds) in [(&uniform, &codecs[..]), (&cube, &codecs[..1])] {
            for kind in kinds {
                for total in NORMAL_BITS {
                    let (set, codec) = (set.clone(), kind.with_bits(total));
                    points.push(Point::Codec { set, codec });
                }
            }
        }
        points.push(Point::F32 { set: uniform });
        Ok((CodecStudy, points))
    }

    fn label(&self, p: &Point) -> String {
        match p {
            Point::Codec { set, codec } => {
                format!("{} {} bits, {}", codec.label(), codec.bits(), set.sampling)
            }
            Point::F32 { set } => format!("xyz f32, {}", set.sampling),
        }
    }

    /// The GPU row and the CPU twin's row.
    fn run(&self, gpu: &Gpu, composer: &Composer, p: &Point) -> Result<Vec<CodecRow>, StudyError> {
        let (set, codec) = match p {
            Point::Codec { set, codec } => (set, *codec),
            Point::F32 { set } => {
                let mut errors = angles(&set.truth, set.cpu_in.clone().into_par_iter());
                return Ok(vec![set.row("xyz f32", 96, "cpu", &mut errors)]);
            }
        };
        let (gpu_codes, gpu_decoded) =
            crate::kernels::gpu_codec_round_trip(gpu, composer, codec, &set.gpu_in)?;
        let (cpu_codes, cpu_decoded) = cpu_round_trip(codec, &set.cpu_in);
        let differing = gpu_codes
            .iter()
            .zip(&cpu_codes)
            .filter(|(a, b)| a != b)
            .count() as u64;
        let mut gpu_errors = angles(
            &set.truth,
            gpu_decoded
                .par_iter()
                .map(|d| DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64)),
        );
        let mut cpu_errors = angles(&set.truth, cpu_decoded.into_par_iter());
        let (label, bits) = (codec.label(), codec.bits());
        Ok(vec![
            CodecRow {
                codes_differing_from_cpu: differing,
                ..set.row(label, bits, "gpu", &mut gpu_errors)
            },
            set.row(label, bits, "cpu", &mut cpu_errors),
        ])
    }

    fn named(&self, p: &Point) -> CodecRow {
        match p {
            Point::Codec { set, codec } => set.named(codec.label(), codec.bits(), "gpu"),
            Point::F32 { set } => set.named("xyz f32", 96, "cpu"),
        }
    }

    /// A GPU row prints the same as its CPU twin, to one unit of the last printed digit.
    fn keeps(&self, g: &CodecRow, rows: &[CodecRow]) -> bool {
        g.source != "gpu"
            || cpu_twin(rows, g).is_some_and(|c| row_agrees(g, c, agree_within_last_digit))
    }

    fn table(&self, rows: &[CodecRow]) -> Table {
        table(rows)
    }

    fn plot(&self, rows: &[CodecRow]) -> Option<Plot> {
        plot(rows)
    }
}

/// Smallest max error any code of `bits` bits can have: 2^bits caps of angular radius t
/// must cover the sphere, 2^bits * 2 pi (1 - cos t) >= 4 pi, so t = 2 asin(2^(-bits/2)).
pub fn covering_bound_deg(bits: f64) -> f64 {
    (2.0 * 2f64.powf(-bits / 2.0).asin()).to_degrees()
}

/// Whether two figures print the same.
pub fn agree(a: f64, b: f64) -> bool {
    degrees(a) == degrees(b)
}

/// Whether two figures print at most one unit apart in the last digit: as close as an f32
/// computation can promise, since any difference may straddle a rounding boundary.
pub fn agree_within_last_digit(a: f64, b: f64) -> bool {
    let printed = degrees(a);
    let decimals = printed.split_once('.').map_or(0, |(_, d)| d.len()) as i32;
    let unit = 10f64.powi(-decimals);
    ((a / unit).round() - (b / unit).round()).abs() <= 1.0
}

/// The CPU row of the same codec and bit count as GPU row `g`.
fn cpu_twin<'a>(rows: &'a [CodecRow], g: &CodecRow) -> Option<&'a CodecRow> {
    rows.iter().find(|c| {
        c.source == "cpu" && c.codec == g.codec && c.bits == g.bits && c.sampling == g.sampling
    })
}

/// Whether GPU row `g` prints the same figures as its CPU twin `c`.
pub fn row_agrees(g: &CodecRow, c: &CodecRow, agree: fn(f64, f64) -> bool) -> bool {
    agree(g.mean_deg, c.mean_deg)
        && agree(g.p99_deg, c.p99_deg)
        && agree(g.max_deg, c.max_deg)
        && agree(g.adversarial_max_deg, c.adversarial_max_deg)
}

/// The printed table: one line per codec and bit count, GPU figures with the CPU's where
/// they print differently, and the published figures beside them.
fn table(rows: &[CodecRow]) -> Table {
    let mut t = Table::new(
        "Normal codecs: angular error in degrees (GPU through the G-buffer's WGSL; CPU twin in f64)",
        &[
            "codec",
            "bits",
            "mean",
            "p99",
            "max",
            "adversarial max",
            "GPU = CPU",
            "published (mean / max)",
            "covering bound",
        ],
    );
    let cell = |g: f64, c: f64| {
        if agree(g, c) {
            degrees(g)
        } else {
            format!("{} (cpu {})", degrees(g), degrees(c))
        }
    };
    for r in rows.iter().filter(|r| r.error.is_some()) {
        let error = r.error.as_deref().unwrap_or_default();
        t.failed_row(vec![r.codec.clone(), r.bits.to_string()], error);
    }
    for g in rows.iter().filter(|r| r.source == "gpu") {
        let Some(c) = cpu_twin(rows, g) else {
            continue;
        };
        let same = if row_agrees(g, c, agree) {
            "yes"
        } else if row_agrees(g, c, agree_within_last_digit) {
            "last digit"
        } else {
            "NO"
        };
        let published = if g.codec == "octahedral precise" {
            format!("Meyer: max {}", degrees(meyer_octahedral_max_deg(g.bits)))
        } else {
            TYLER_OCT
                .iter()
                .find(|p| g.codec == "octahedral" && g.sampling == "cube" && 2 * p.0 == g.bits)
                .map(|p| format!("Tyler: {} / {}", degrees(p.1), degrees(p.2)))
                .unwrap_or_else(|| "-".into())
        };
        t.row(vec![
            if g.sampling == "uniform" {
                g.codec.clone()
            } else {
                format!("{}, {} sampling", g.codec, g.sampling)
            },
            g.bits.to_string(),
            cell(g.mean_deg, c.mean_deg),
            cell(g.p99_deg, c.p99_deg),
            cell(g.max_deg, c.max_deg),
            cell(g.adversarial_max_deg, c.adversarial_max_deg),
            format!(
                "{}{}",
                same,
                if g.codes_differing_from_cpu > 0 {
                    format!(", {} codes differ", g.codes_differing_from_cpu)
                } else {
                    String::new()
                }
            ),
            published,
            degrees(covering_bound_deg(g.bits as f64)),
        ]);
    }
    if let Some(x) = rows
        .iter()
        .find(|r| r.codec == "xyz f32" && r.error.is_none())
    {
        t.row(vec![
            x.codec.clone(),
            x.bits.to_string(),
            sig(x.mean_deg, 2),
            sig(x.p99_deg, 2),
            sig(x.max_deg, 2),
            sig(x.adversarial_max_deg, 2),
            "CPU only".into(),
            format!("Meyer: max {}", sig(meyer_f32_max_deg(), 2)),
            sig(covering_bound_deg(96.0), 2),
        ]);
    }
    if let Some(r) = rows.first() {
        t.notes.push(format!(
            "{} unit vectors uniform on the sphere (z and azimuth uniform, seeded) plus {} \
             adversarial ones (axes with signed zeros, poles, octahedral and polar seams, \
             equator, diagonals). Error: atan2(|a x b|, a.b) between the f64 vector and the \
             decode of its f32 rounding. Cube sampling: points uniform in [-1, 1]^3, \
             normalized, as Tyler 2024 samples (1M vectors, plain octahedral; the published \
             figures). Covering bound: no code of that many bits has a smaller max error, \
             2 asin(2^(-bits/2)). Meyer 2010: octahedron normals need one bit more than the \
             optimal discretisation with the same error (printed: the covering bound of one \
             bit fewer); f32 normals are as fine as 2^50.2 uniform normals (printed: their \
             covering radius).",
            r.samples, r.adversarial_samples
        ));
    }
    t
}

/// Meyer et al. 2010: octahedron normal vectors need one bit more than the optimal
/// discretisation with the same error; so at `bits` their max error is the covering bound
/// of `bits - 1` bits.
pub fn meyer_octahedral_max_deg(bits: u32) -> f64 {
    covering_bound_deg(bits as f64 - 1.0)
}

/// Meyer et al. 2010: the discretisation error of f32 normals equals that of 2^50.2
/// uniformly spread normals; as an angle, their covering radius.
pub fn meyer_f32_max_deg() -> f64 {
    covering_bound_deg(50.2)
}

/// Max error against bits per codec (GPU), with the covering bound.
fn plot(rows: &[CodecRow]) -> Option<Plot> {
    use plotters::prelude::*;
    crate::plot::svg(
        "codecs.svg",
        "Normal codecs: max error against bits",
        (880 + crate::plot::LEGEND_WIDTH, 520),
        |area| {
            let mut chart = ChartBuilder::on(area)
                .caption("Normal codecs: max angular error (GPU)", ("sans-serif", 20))
                .margin(12)
                .margin_right(crate::plot::LEGEND_WIDTH)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(15u32..33u32, crate::plot::log_axis(1e-4, 10.0))
                .ok()?;
            chart
                .configure_mesh()
                .light_line_style(TRANSPARENT)
                .x_desc("bits per normal")
                .y_desc("max error (degrees)")
                .y_label_formatter(&crate::plot::tick_label)
                .draw()
                .ok()?;
            let mut legend = Vec::new();
            for (i, codec) in NormalCodec::packed(32).iter().enumerate() {
                let color = crate::plot::series_color(i);
                let points: Vec<(u32, f64)> = rows
                    .iter()
                    .filter(|r| {
                        r.source == "gpu" && r.sampling == "uniform" && r.codec == codec.label()
                    })
                    .map(|r| (r.bits, r.max_deg.max(1e-4)))
                    .collect();
                chart
                    .draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))
                    .ok()?;
                chart
                    .draw_series(points.iter().map(|&p| Circle::new(p, 4, color.filled())))
                    .ok()?;
                legend.push((codec.label().to_string(), color, Some(0)));
            }
            let bound: Vec<(u32, f64)> = (16..=32)
                .step_by(4)
                .map(|b| (b, covering_bound_deg(b as f64)))
                .collect();
            chart
                .draw_series(LineSeries::new(bound, BLACK.stroke_width(1)))
                .ok()?;
            legend.push(("covering bound".to_string(), BLACK, None));
            crate::plot::legend(area, &legend)
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampling_is_uniform_and_unit() {
        let n = uniform_normals(20000, 7);
        assert!(n.iter().all(|v| (v.length() - 1.0).abs() < 1e-12));
        // Each octant holds an eighth, within sampling noise.
        let upper = n
            .iter()
            .filter(|v| v.z > 0.0 && v.x > 0.0 && v.y > 0.0)
            .count();
        assert!((upper as f64 / 20000.0 - 0.125).abs() < 0.01, "{upper}");
        let mean = n.iter().copied().sum::<DVec3>() / 20000.0;
        assert!(mean.length() < 0.02, "{mean}");
    }

    #[test]
    fn adversarial_set_holds_the_breaking_points() {
        let a = adversarial_normals();
        assert!(a.iter().all(|v| (v.length() - 1.0).abs() < 1e-12));
        let has = |v: DVec3| {
            a.iter().any(|w| {
                w.to_array()
                    .iter()
                    .zip(v.to_array())
                    .all(|(x, y)| x.to_bits() == y.to_bits())
            })
        };
        assert!(has(DVec3::new(0.0, 0.0, -1.0)));
        assert!(has(DVec3::new(-0.0, -0.0, -1.0)));
        assert!(has(DVec3::new(1.0, -0.0, 0.0)));
    }

    #[test]
    fn degrees_print_three_digits_and_at_most_four_decimals() {
        assert_eq!(degrees(0.946480), "0.946");
        assert_eq!(degrees(0.0218), "0.0218");
        assert_eq!(degrees(0.003675), "0.0037");
        assert_eq!(degrees(179.6), "180");
    }

    #[test]
    fn cube_sampling_leans_to_the_corners() {
        let n = cube_normalized_normals(20000, 3);
        assert!(n.iter().all(|v| (v.length() - 1.0).abs() < 1e-12));
        // Uniform on the sphere, E|x| + |y| + |z| = 1.5; cube points sit nearer the diagonals.
        let l1 = |s: &[DVec3]| {
            s.iter()
                .map(|v| v.x.abs() + v.y.abs() + v.z.abs())
                .sum::<f64>()
                / s.len() as f64
        };
        assert!((l1(&uniform_normals(20000, 3)) - 1.5).abs() < 0.01);
        assert!(l1(&n) > 1.52, "{}", l1(&n));
    }

    #[test]
    fn agreement_to_the_printed_digit_and_within_one() {
        assert!(agree(0.03672, 0.03668));
        assert!(!agree(0.0491, 0.0490));
        assert!(agree_within_last_digit(0.0491, 0.0490));
        assert!(agree_within_last_digit(0.00318, 0.00307));
        assert!(!agree_within_last_digit(0.00437, 0.00138));
        assert!(!agree_within_last_digit(0.193, 0.195));
    }

    #[test]
    fn summary_statistics() {
        let mut e: Vec<f64> = (1..=100).map(|i| i as f64).collect();
        let (mean, p99, max) = summarize(&mut e);
        assert_eq!((mean, p99, max), (50.5, 99.0, 100.0));
    }

    #[test]
    fn covering_bound_halves_per_two_bits() {
        let r = covering_bound_deg(16.0) / covering_bound_deg(18.0);
        assert!((r - 2.0).abs() < 1e-3, "{r}");
        // 2^16 caps of radius t: 2^16 * 2 pi (1 - cos t) = 4 pi exactly.
        let t = covering_bound_deg(16.0).to_radians();
        assert!((65536.0 * 2.0 * (1.0 - t.cos()) - 4.0).abs() < 1e-9);
        assert!(covering_bound_deg(96.0) > 0.0);
    }
}
