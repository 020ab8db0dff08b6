//! CPU twins against their WGSL, run on the GPU over many random inputs and the edges.

use clusterlab::compose::Composer;
use clusterlab::cpu::normals as cpu;
use clusterlab::cpu::zslice::Slices;
use clusterlab::gpu::Gpu;
use clusterlab::kernels::{gpu_codecs, gpu_zslices};
use clusterlab::variant::{NormalCodec, ZSlicing};
use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

fn gpu() -> Gpu {
    Gpu::new(None).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn z_slices_match_on_random_depths_and_at_slice_boundaries() {
    let gpu = gpu();
    let composer = Composer::default();
    let (near, far, slices, tan, tiles_y) = (0.1f32, 60.0f32, 24u32, 0.577_35f32, 9u32);
    // Every scheme of the list, through the same kernel composed for each.
    for scheme in ZSlicing::every(near as f64, far as f64) {
        let s = Slices {
            scheme,
            near: near as f64,
            far: far as f64,
            count: slices,
            tan_half_fov_y: tan as f64,
            tiles_y,
        };
        let mut rng = Pcg64Mcg::seed_from_u64(7);
        let mut depths: Vec<f32> = (0..4000)
            .map(|_| near * (far / near).powf(rng.random_range(0.0f32..1.0)))
            .collect();
        // Edges: near, far, and every boundary of the scheme, with its neighbours.
        depths.extend([near, far]);
        for k in 0..=slices {
            let z = s.start(k) as f32;
            if (near..=far).contains(&z) {
                depths.extend([z, z.next_down(), z.next_up()]);
            }
        }
        let results = gpu_zslices(&gpu, &composer, &s, &depths).expect("kernel runs");
        for (i, &z) in depths.iter().enumerate() {
            let want = s.slice(z as f64);
            let have = results.slices[i];
            if have == want {
                continue;
            }
            // f32 and f64 may round a depth on a boundary to either side of it: allowed only
            // there, and only by one slice.
            let boundary = s.start(have.max(want));
            assert!(
                have.abs_diff(want) == 1 && ((z as f64 - boundary) / boundary).abs() < 1e-5,
                "{scheme:?}: depth {z}: GPU slice {have}, CPU slice {want}"
            );
        }
        for k in 0..slices {
            let want = s.start(k);
            let have = results.starts[k as usize] as f64;
            assert!(
                ((have - want) / want).abs() < 1e-5,
                "{scheme:?}: start of slice {k}: GPU {have}, CPU {want}"
            );
        }
        // Slice `slices` begins at far (the shaders' end of the grid).
        assert_eq!(results.starts[slices as usize], far, "{scheme:?}");
    }
}

fn random_unit(rng: &mut Pcg64Mcg) -> DVec3 {
    loop {
        let v = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if v.length_squared() > 1e-6 && v.length_squared() <= 1.0 {
            return v.normalize();
        }
    }
}

/// Poles, axes, zero components and the octahedron's fold edges.
fn edge_normals() -> Vec<DVec3> {
    let mut v = Vec::new();
    for a in [DVec3::X, DVec3::Y, DVec3::Z] {
        v.extend([a, -a]);
    }
    for (x, y, z) in [
        (1.0, 1.0, 0.0),
        (1.0, -1.0, 0.0),
        (-1.0, 1.0, 0.0),
        (-1.0, -1.0, 0.0),
        (1.0, 0.0, 1.0),
        (0.0, 1.0, -1.0),
        (1.0, 1.0, 1.0),
        (-1.0, -1.0, -1.0),
        (1e-4, 0.0, -1.0),
        (0.0, 1e-4, 1.0),
    ] {
        v.push(DVec3::new(x, y, z).normalize());
    }
    v
}

const RANDOM_NORMALS: usize = 3000;

/// The normals the codec checks run on: 3000 random ones and the edges, as the f32 values
/// the GPU sees and those same values in f64 (the CPU twin's input).
fn codec_inputs() -> (Vec<[f32; 4]>, Vec<DVec3>) {
    let mut rng = Pcg64Mcg::seed_from_u64(11);
    let mut normals: Vec<DVec3> = (0..RANDOM_NORMALS).map(|_| random_unit(&mut rng)).collect();
    normals.extend(edge_normals());
    let as_f32: Vec<[f32; 4]> = normals
        .iter()
        .map(|n| {
            let n = n.as_vec3();
            [n.x, n.y, n.z, 0.0]
        })
        .collect();
    let inputs = as_f32
        .iter()
        .map(|n| DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64))
        .collect();
    (as_f32, inputs)
}

/// Whether the GPU's codes `have` of `inputs` are the CPU twin's. Each encoder quantises
/// values u in [0, 1] that the GPU computes in f32; if its u is within E = 2^-20 (16 ULP of
/// 1.0) of the twin's f64 u, a code can differ only where u * max_code lies within E *
/// max_code of a rounding tie: by one step, for a share of at most 2 * E * max_code of the
/// values per component, so of the codes at most 4 * E * max_code (25% at 16 bits, 0.1% at
/// 8). Each differing code must also decode within a step of the twin's. A step at 16 bits
/// is 2^-16, 256 times E: an encoder off by a step or more (the old acos polar encoder, up
/// to 4) fails. WGSL lets atan2 and acos be off by 4096 ULP, so these bounds are the
/// project's, stricter than WGSL's, and every adapter tested meets them.
/// The one exception is the polar codec's seam (the poles and the -x half-plane, where
/// atan2 of a signed zero may land on either end of the azimuth): any code there, since every
/// one decodes to the same direction.
fn check_codes(
    c: NormalCodec,
    bits: u32,
    inputs: &[DVec3],
    have: &[[u32; 2]],
) -> Result<usize, String> {
    let name = c.label();
    let polar = matches!(c, NormalCodec::Polar { .. });
    let mut exact = 0;
    let mut exact_random = Vec::with_capacity(RANDOM_NORMALS);
    for (i, &n) in inputs.iter().enumerate() {
        let want = cpu::encode(c, n).expect("a packed codec");
        let have = have[i];
        let polar_seam = polar && (n.z.abs() > 1.0 - 1e-6 || (n.y == 0.0 && n.x < 0.0));
        if i < RANDOM_NORMALS {
            exact_random.push(have == want);
        }
        if have == want {
            exact += 1;
            continue;
        }
        if polar_seam {
            continue;
        }
        if have[0].abs_diff(want[0]) > 1 || have[1].abs_diff(want[1]) > 1 {
            return Err(format!(
                "{name} {bits} bits: {n:?}: GPU {have:?}, CPU {want:?}"
            ));
        }
        let err = |q| cpu::angle_degrees(n, cpu::decode(c, q).expect("packed"));
        if (err(have) - err(want)).abs() > step_degrees(bits) {
            return Err(format!(
                "{name} {bits} bits: {n:?}: GPU {have:?} decodes {} degrees off, CPU {want:?} {}",
                err(have),
                err(want)
            ));
        }
    }
    let max_code = ((1u64 << bits) - 1) as f64;
    let allowed = 4.0 * 2f64.powi(-20) * max_code;
    // The share holds for values spread over the steps: the random normals, not the edge
    // normals, whose values are chosen to sit on ties (0.5, 1/sqrt(2)).
    let differ = exact_random.iter().filter(|e| !**e).count();
    if differ as f64 > allowed * RANDOM_NORMALS as f64 {
        return Err(format!(
            "{name} {bits} bits: {differ} of {RANDOM_NORMALS} codes of random normals differ (at most {:.2}%)",
            allowed * 100.0
        ));
    }
    Ok(exact)
}

#[test]
fn normal_codecs_match_on_random_normals_and_at_the_edges() {
    let gpu = gpu();
    let composer = Composer::default();
    let mut rng = Pcg64Mcg::seed_from_u64(12);
    let (as_f32, inputs) = codec_inputs();
    for bits in [8u32, 10, 12, 16] {
        let top = (1u32 << bits) - 1;
        let codes: Vec<[u32; 2]> = (0..inputs.len())
            .map(|_| [rng.random_range(0..=top), rng.random_range(0..=top)])
            .collect();
        for c in NormalCodec::packed(2 * bits) {
            let name = c.label();
            let results = gpu_codecs(&gpu, &composer, c, &as_f32, &codes).expect("kernel runs");
            let exact =
                check_codes(c, bits, &inputs, &results.codes).unwrap_or_else(|e| panic!("{e}"));
            eprintln!(
                "{name} {bits} bits: {exact} of {} codes equal",
                inputs.len()
            );
            for (i, &q) in codes.iter().enumerate() {
                let want = cpu::decode(c, q).expect("a packed codec");
                let h = results.decoded[i];
                let have = DVec3::new(h[0] as f64, h[1] as f64, h[2] as f64);
                let bound = decode_bound(c, q, bits);
                assert!(
                    (have - want).length() < bound,
                    "{name}: decode of {q:?} at {bits} bits: GPU {have:?}, CPU {want:?} (bound {bound:e})"
                );
            }
        }
    }
}

/// How far an f32 decode of code `q` may lie from the f64 twin's: 1e-5 for the octahedral
/// and polar decodes (well-conditioned: a few f32 steps of a unit vector). The spheremap's
/// is not: its xy is e g with g = sqrt(1 - f / 4), f = |e|^2 <= 8, so f32's rounding of
/// 1 - f / 4 (delta: 8 steps of 2^-24) moves g by min(delta / (2 g), sqrt(delta)) and xy by
/// |e| <= 2 times that, beside 16 steps for the rest (an NVIDIA H200 was 1e-5 off near the
/// rim, where g is small).
fn decode_bound(c: NormalCodec, q: [u32; 2], bits: u32) -> f64 {
    let NormalCodec::Spheremap { .. } = c else {
        return 1e-5;
    };
    let step = 2f64.powi(-24);
    let top = ((1u64 << bits) - 1) as f64;
    let e = glam::DVec2::new(q[0] as f64, q[1] as f64) / top * 4.0 - glam::DVec2::splat(2.0);
    let g = (1.0 - e.dot(e) / 4.0).max(0.0).sqrt();
    let delta = 8.0 * step;
    let moved = if g > 0.0 {
        (delta / (2.0 * g)).min(delta.sqrt())
    } else {
        delta.sqrt()
    };
    16.0 * step + 2.0 * moved
}

/// The break the polar check exists for: the old acos encoder fails it at 16 bits.
#[test]
fn the_codec_check_rejects_the_old_acos_polar_encoder() {
    let gpu = gpu();
    let composer = Composer::default();
    let (as_f32, inputs) = codec_inputs();
    let zeros = vec![[0u32; 2]; inputs.len()];
    let polar = NormalCodec::Polar { bits: 32 };
    let old = clusterlab::kernels::gpu_codecs_old_acos_polar(&gpu, &composer, 16, &as_f32, &zeros)
        .expect("kernel runs");
    let verdict = check_codes(polar, 16, &inputs, &old.codes);
    eprintln!("old acos encoder: {verdict:?}");
    assert!(verdict.is_err(), "the acos encoder passes the codec check");
}

/// Angle of one code step at `bits` bits, in degrees (a generous scale for comparisons).
fn step_degrees(bits: u32) -> f64 {
    (4.0 / ((1u64 << bits) - 1) as f64).to_degrees()
}

/// Oracle properties of the codecs themselves (CPU only): the precise octahedral encoder is
/// never worse than the plain one, and errors shrink as bits grow.
#[test]
fn codec_errors_behave() {
    let mut rng = Pcg64Mcg::seed_from_u64(3);
    let normals: Vec<DVec3> = (0..5000).map(|_| random_unit(&mut rng)).collect();
    let mut last = f64::MAX;
    for bits in [8u32, 10, 12, 16] {
        let mut worst_plain: f64 = 0.0;
        for &n in &normals {
            let plain = cpu::angle_degrees(n, cpu::oct_decode(cpu::oct_encode(n, bits), bits));
            let precise =
                cpu::angle_degrees(n, cpu::oct_decode(cpu::oct_encode_precise(n, bits), bits));
            assert!(
                precise <= plain + 1e-12,
                "precise worse at {bits} bits for {n:?}"
            );
            worst_plain = worst_plain.max(plain);
        }
        assert!(worst_plain < last, "error did not shrink at {bits} bits");
        last = worst_plain;
    }
    // The spheremap's one singular direction decodes to the opposite pole (documented).
    let back = cpu::spheremap_decode(cpu::spheremap_encode(DVec3::NEG_Z, 16), 16);
    assert!((back - DVec3::Z).length() < 1e-3, "{back:?}");
}
