//! Twin of `shaders/shading/` and `shaders/common/lights.wesl`: one light's contribution to
//! one surface point, from the formulas in docs/ARCHITECTURE.md.

use glam::DVec3;

use crate::common::Light;

/// Smallest squared distance of the inverse-square law (as in the shaders).
pub const MIN_DISTANCE_SQUARED: f64 = 1e-4;

/// What shading needs from a variant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingParams {
    /// (shininess, specular strength) for Blinn-Phong; None for Lambert.
    pub blinn_phong: Option<(f64, f64)>,
    pub ambient: f64,
    /// Toon bands applied to each light's diffuse term (toon in the shading pass).
    pub toon_bands: Option<u32>,
}

/// A surface point: world position, unit normal, linear albedo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    pub position: DVec3,
    pub normal: DVec3,
    pub albedo: DVec3,
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
    let mut diffuse = s.normal.dot(l).max(0.0);
    if let Some(bands) = p.toon_bands {
        diffuse = toon_ramp(diffuse, bands);
    }
    let mut reflected = s.albedo * diffuse;
    if let Some((shininess, specular)) = p.blinn_phong {
        reflected += DVec3::splat(specular * blinn_phong(s.normal, l, to_eye, shininess));
    }
    let color = DVec3::from(light.color.map(f64::from));
    reflected * color * (light.intensity as f64 * attenuation(d, radius))
}

/// The full shading of a point: every light, then the ambient term.
pub fn shade(s: &Surface, eye: DVec3, lights: &[Light], p: &ShadingParams) -> DVec3 {
    let to_eye = (eye - s.position).normalize_or_zero();
    let direct: DVec3 = lights
        .iter()
        .map(|l| light_contribution(s, to_eye, l, p))
        .sum();
    direct + s.albedo * p.ambient
}
