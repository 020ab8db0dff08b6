//! The GGX BRDF twin (`cpu::shading`) conserves energy: its directional albedo (the light it
//! reflects of a unit irradiance from all directions) never exceeds 1, and the quadrature
//! that says so agrees with an independent Monte Carlo estimate.

use clusterlab::cpu::shading::{ggx_alpha, ggx_specular};
use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::f64::consts::{PI, TAU};

const N: DVec3 = DVec3::Z;

/// View direction at `mu` = n.v.
fn view(mu: f64) -> DVec3 {
    DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu)
}

/// Specular directional albedo with F = 1 (the largest any f0 gives), by quadrature over
/// half vectors distributed as GGX's D(h) n.h: a midpoint rule on an `n` x `n` grid of its
/// inverse CDF, `tan^2 theta_h = alpha^2 u / (1 - u)`, where each cell carries the weight
/// `f(l, v) (n.l) / pdf(l)` and `pdf(l) = D(h) (n.h) / (4 v.h)`.
fn albedo_quadrature(roughness: f64, mu: f64, n: u32) -> f64 {
    let alpha = ggx_alpha(roughness);
    let v = view(mu);
    let mut sum = 0.0;
    for i in 0..n {
        let u = (i as f64 + 0.5) / n as f64;
        let tan2 = alpha * alpha * u / (1.0 - u);
        let cos_h = 1.0 / (1.0 + tan2).sqrt();
        let sin_h = (1.0 - cos_h * cos_h).sqrt();
        for j in 0..n {
            let phi = TAU * (j as f64 + 0.5) / n as f64;
            let h = DVec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
            let v_dot_h = v.dot(h);
            if v_dot_h <= 0.0 {
                continue;
            }
            let l = 2.0 * v_dot_h * h - v;
            let n_dot_l = N.dot(l);
            if n_dot_l <= 0.0 {
                continue;
            }
            let d = clusterlab::cpu::shading::d_ggx(cos_h, alpha);
            let f = ggx_specular(N, l, v, alpha, DVec3::ONE).x;
            sum += f * n_dot_l * 4.0 * v_dot_h / (d * cos_h);
        }
    }
    sum / (n * n) as f64
}

/// The same albedo by Monte Carlo with cosine-weighted light directions: nothing shared
/// with the quadrature but the BRDF itself.
fn albedo_monte_carlo(roughness: f64, mu: f64, samples: u32, seed: u64) -> f64 {
    let alpha = ggx_alpha(roughness);
    let v = view(mu);
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut sum = 0.0;
    for _ in 0..samples {
        let (a, b): (f64, f64) = (rng.random(), rng.random());
        let r = a.sqrt();
        let l = DVec3::new(r * (TAU * b).cos(), r * (TAU * b).sin(), (1.0 - a).sqrt());
        // pdf = n.l / pi, so f (n.l) / pdf = pi f.
        sum += PI * ggx_specular(N, l, v, alpha, DVec3::ONE).x;
    }
    sum / samples as f64
}

const ROUGHNESS: [f64; 7] = [0.0, 0.045, 0.1, 0.25, 0.5, 0.75, 1.0];
const MU: [f64; 6] = [0.02, 0.1, 0.3, 0.5, 0.8, 1.0];

#[test]
fn ggx_directional_albedo_never_exceeds_one() {
    let mut most = (0.0, 0.0, 0.0);
    for r in ROUGHNESS {
        for mu in MU {
            let e = albedo_quadrature(r, mu, 1024);
            if e > most.0 {
                most = (e, r, mu);
            }
            assert!(e <= 1.0 + 1e-6, "roughness {r}, n.v {mu}: albedo {e}");
            assert!(
                e > 0.3,
                "roughness {r}, n.v {mu}: albedo {e} lost most energy"
            );
        }
    }
    println!(
        "largest albedo {:.5} at roughness {}, n.v {}",
        most.0, most.1, most.2
    );
    // Smooth surfaces reflect all but the grazing light (single scattering loses little).
    let smooth = albedo_quadrature(0.045, 1.0, 1024);
    assert!(smooth > 0.99, "{smooth}");
}

/// At roughness 1 (alpha = 1) D is 1/pi and V = 1 / (2 (n.l + n.v)), so at normal incidence
/// the albedo is `integral_0^1 c / (1 + c) dc = 1 - ln 2`: an analytic reference figure.
#[test]
fn ggx_albedo_at_roughness_one_is_one_minus_ln_2() {
    let q = albedo_quadrature(1.0, 1.0, 1024);
    let exact = 1.0 - std::f64::consts::LN_2;
    assert!(
        (q - exact).abs() < 1e-5,
        "quadrature {q:.6}, 1 - ln 2 = {exact:.6}"
    );
}

/// The quadrature agrees with Monte Carlo to 3 digits where Monte Carlo converges (rough
/// lobes; a narrow lobe would need far more samples).
#[test]
fn ggx_albedo_quadrature_matches_monte_carlo() {
    for (r, mu) in [(1.0, 1.0), (1.0, 0.5), (0.75, 0.8), (0.75, 0.3)] {
        let q = albedo_quadrature(r, mu, 1024);
        let mc = albedo_monte_carlo(r, mu, 4_000_000, 7);
        assert!(
            (q - mc).abs() < 5e-4,
            "roughness {r}, n.v {mu}: quadrature {q:.5}, Monte Carlo {mc:.5}"
        );
        println!("roughness {r}, n.v {mu}: quadrature {q:.5}, Monte Carlo {mc:.5}");
    }
}
