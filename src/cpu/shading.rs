//! Twin of `shaders/shading/` and `shaders/common/lights.wesl`: one light's contribution to
//! one surface point, from the formulas in docs/design.md.

use glam::DVec3;

use crate::common::Light;

/// Smallest squared distance of the inverse-square law: no division by zero where a light
/// sits on a surface (the shaders' `MIN_DISTANCE_SQUARED`, generated from this).
pub const MIN_DISTANCE_SQUARED: f64 = 1e-4;

/// What shading needs from a variant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingParams {
    pub brdf: Brdf,
    pub ambient: f64,
    /// Toon bands applied to each light's diffuse term (toon in the shading pass).
    pub toon_bands: Option<u32>,
    /// How a pixel's samples become its colour, when it has more than one.
    pub resolve: crate::common::MsaaResolve,
    /// With shadows: what the GPU's shading surface is made of (its rays' error).
    pub shadows: Option<super::shadows::ShadowSource>,
}

/// The BRDF of a shading model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Brdf {
    Lambert,
    BlinnPhong {
        shininess: f64,
        specular: f64,
    },
    /// Metallic-roughness GGX, with each surface's roughness and metallic.
    Ggx,
}

/// A surface point: world position, unit normal, linear albedo (GGX: base colour), and
/// perceptual roughness and metallic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    pub position: DVec3,
    pub normal: DVec3,
    pub albedo: DVec3,
    pub roughness: f64,
    pub metallic: f64,
}

/// Karis's window: (1 - (d/r)^4)^2 clamped to [0, 1]; zero for d >= r.
pub fn range_window(distance: f64, radius: f64) -> f64 {
    let w = (1.0 - (distance / radius).powi(4)).clamp(0.0, 1.0);
    w * w
}

/// Inverse-square falloff within the window.
pub fn attenuation(distance: f64, radius: f64) -> f64 {
    range_window(distance, radius) / (distance * distance).max(MIN_DISTANCE_SQUARED)
}

/// `ceil(x * bands) / bands`, capped at 1; zero stays zero.
pub fn toon_ramp(x: f64, bands: u32) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let b = bands as f64;
    (x * b).ceil().min(b) / b
}

/// Blinn-Phong lobe max(n.h, 0)^shininess, zero where the light is behind the surface.
pub fn blinn_phong(n: DVec3, l: DVec3, v: DVec3, shininess: f64) -> f64 {
    let h = l + v;
    if n.dot(l) <= 0.0 || h.length_squared() <= 0.0 {
        return 0.0;
    }
    n.dot(h.normalize()).max(0.0).powf(shininess)
}

/// The cone's angular falloff for `l`, the unit vector from the surface to the light: 1 for
/// a point light and inside the inner cone, 0 at and beyond the outer cone, a smoothstep of
/// the cosine between them.
pub fn spot_factor(light: &Light, l: DVec3) -> f64 {
    let cos_outer = light.cos_outer as f64;
    let cos_inner = light.cos_inner as f64;
    if cos_outer <= -1.0 {
        return 1.0;
    }
    let cos_angle = -l.dot(DVec3::from(light.direction.map(f64::from)));
    if cos_angle <= cos_outer {
        return 0.0;
    }
    if cos_angle >= cos_inner {
        return 1.0;
    }
    let t = (cos_angle - cos_outer) / (cos_inner - cos_outer);
    t * t * (3.0 - 2.0 * t)
}

/// Smallest perceptual roughness GGX shades with: below it the lobe is narrower than f32
/// can resolve, and Filament clamps likewise (the shaders' `MIN_PERCEPTUAL_ROUGHNESS`,
/// generated from this).
pub const MIN_PERCEPTUAL_ROUGHNESS: f64 = 0.045;

/// GGX's alpha for a perceptual roughness: its square, after the clamp.
pub fn ggx_alpha(roughness: f64) -> f64 {
    let r = roughness.clamp(MIN_PERCEPTUAL_ROUGHNESS, 1.0);
    r * r
}

/// Trowbridge-Reitz normal distribution `alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)`.
pub fn d_ggx(n_dot_h: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    let f = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    a2 / (std::f64::consts::PI * f * f)
}

/// Height-correlated Smith visibility `G2 / (4 n.l n.v)` (Heitz 2014, eq. 99):
/// `0.5 / (n.l sqrt((n.v)^2 (1 - a^2) + a^2) + n.v sqrt((n.l)^2 (1 - a^2) + a^2))`.
pub fn v_smith_ggx_correlated(n_dot_v: f64, n_dot_l: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    let gv = n_dot_l * (n_dot_v * n_dot_v * (1.0 - a2) + a2).sqrt();
    let gl = n_dot_v * (n_dot_l * n_dot_l * (1.0 - a2) + a2).sqrt();
    0.5 / (gv + gl)
}

/// Schlick's Fresnel `f0 + (1 - f0) (1 - v.h)^5`.
pub fn f_schlick(v_dot_h: f64, f0: DVec3) -> DVec3 {
    f0 + (DVec3::ONE - f0) * (1.0 - v_dot_h).powi(5)
}

/// The specular BRDF `D V F` (without n.l), zero where light or eye is below the surface.
pub fn ggx_specular(n: DVec3, l: DVec3, v: DVec3, alpha: f64, f0: DVec3) -> DVec3 {
    let (n_dot_l, n_dot_v) = (n.dot(l), n.dot(v));
    let h = l + v;
    if n_dot_l <= 0.0 || n_dot_v <= 0.0 || h.length_squared() <= 0.0 {
        return DVec3::ZERO;
    }
    let h = h.normalize();
    d_ggx(n.dot(h).max(0.0), alpha)
        * v_smith_ggx_correlated(n_dot_v, n_dot_l, alpha)
        * f_schlick(v.dot(h).max(0.0), f0)
}

/// Metallic-roughness GGX (Filament) times pi and n.l: `((1 - m) base + pi D V F) n.l`,
/// f0 = 0.04 for dielectrics and the base colour for metals.
pub fn ggx(n: DVec3, l: DVec3, v: DVec3, base: DVec3, roughness: f64, metallic: f64) -> DVec3 {
    let n_dot_l = n.dot(l);
    if n_dot_l <= 0.0 || n.dot(v) <= 0.0 || (l + v).length_squared() <= 0.0 {
        return DVec3::ZERO;
    }
    let f0 = DVec3::splat(0.04).lerp(base, metallic);
    let specular = ggx_specular(n, l, v, ggx_alpha(roughness), f0);
    ((1.0 - metallic) * base + std::f64::consts::PI * specular) * n_dot_l
}

/// Light of `light` reflected from `s` towards the eye (`to_eye` is a unit vector).
pub fn light_contribution(s: &Surface, to_eye: DVec3, light: &Light, p: &ShadingParams) -> DVec3 {
    let position = DVec3::from(light.position.map(f64::from));
    let radius = light.radius as f64;
    let to_light = position - s.position;
    let d = to_light.length();
    if d >= radius {
        return DVec3::ZERO;
    }
    let l = if d > 0.0 { to_light / d } else { DVec3::ZERO };
    let cone = spot_factor(light, l);
    if cone <= 0.0 {
        return DVec3::ZERO;
    }
    let diffuse = || {
        let d = s.normal.dot(l).max(0.0);
        s.albedo * p.toon_bands.map_or(d, |bands| toon_ramp(d, bands))
    };
    let reflected = match p.brdf {
        Brdf::Lambert => diffuse(),
        Brdf::BlinnPhong {
            shininess,
            specular,
        } => diffuse() + DVec3::splat(specular * blinn_phong(s.normal, l, to_eye, shininess)),
        Brdf::Ggx => ggx(s.normal, l, to_eye, s.albedo, s.roughness, s.metallic),
    };
    let color = DVec3::from(light.color.map(f64::from));
    reflected * color * (cone * attenuation(d, radius))
}

/// The full shading of a point: every light, then the ambient term.
pub fn shade(s: &Surface, eye: DVec3, lights: &[Light], p: &ShadingParams) -> DVec3 {
    shade_lights(s, eye, lights.iter(), p)
}

/// `shade` with `lights` only, in their order: the same sum, bit for bit, when the lights
/// left out add exactly 0 (lie beyond their radius; see `light_grid`).
pub fn shade_lights<'a>(
    s: &Surface,
    eye: DVec3,
    lights: impl Iterator<Item = &'a Light>,
    p: &ShadingParams,
) -> DVec3 {
    direct_light(s, eye, lights, p) + s.albedo * p.ambient
}

/// The lights' part of [`shade_lights`]: their contributions summed, without the ambient term.
pub fn direct_light<'a>(
    s: &Surface,
    eye: DVec3,
    lights: impl Iterator<Item = &'a Light>,
    p: &ShadingParams,
) -> DVec3 {
    let to_eye = (eye - s.position).normalize_or_zero();
    lights.map(|l| light_contribution(s, to_eye, l, p)).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Karis's window is exactly zero at and past the radius (so a conservative cluster test
    /// never changes the picture), one at the light, and falls in between.
    #[test]
    fn the_range_window_is_exactly_zero_at_the_radius() {
        for r in [1e-4, 0.5, 3.0, 1e6] {
            assert_eq!(range_window(r, r), 0.0);
            assert_eq!(attenuation(r, r), 0.0);
            assert_eq!(range_window(r * 1.5, r), 0.0);
            assert_eq!(range_window(0.0, r), 1.0);
            let inside = range_window(r * (1.0 - 1e-6), r);
            assert!(inside > 0.0 && inside < 1e-10, "{inside}");
            let samples: Vec<f64> = (0..=100)
                .map(|i| range_window(r * i as f64 / 100.0, r))
                .collect();
            assert!(samples.windows(2).all(|w| w[0] >= w[1]));
        }
        // (1 - (1/2)^4)^2 = (15/16)^2.
        assert_eq!(range_window(1.0, 2.0), (15.0f64 / 16.0).powi(2));
    }

    /// Published GGX forms at points with closed forms: D at n.h = 1 is 1 / (pi a^2); the
    /// height-correlated visibility at n.l = n.v = 1 is 1/4; Schlick at v.h = 1 is f0 and at
    /// v.h = 0 is 1.
    #[test]
    fn ggx_terms_take_their_closed_form_values() {
        let a = 0.3;
        assert!((d_ggx(1.0, a) - 1.0 / (std::f64::consts::PI * a * a)).abs() < 1e-12);
        assert!((v_smith_ggx_correlated(1.0, 1.0, a) - 0.25).abs() < 1e-15);
        let f0 = DVec3::splat(0.04);
        assert_eq!(f_schlick(1.0, f0), f0);
        assert_eq!(f_schlick(0.0, f0), DVec3::ONE);
        assert_eq!(
            ggx_alpha(0.0),
            MIN_PERCEPTUAL_ROUGHNESS * MIN_PERCEPTUAL_ROUGHNESS
        );
        assert_eq!(blinn_phong(DVec3::Z, DVec3::Z, DVec3::Z, 32.0), 1.0);
        assert_eq!(blinn_phong(DVec3::Z, -DVec3::Z, DVec3::Z, 32.0), 0.0);
    }
}
