//! Twin of `shaders/common/depth.wesl`: how view depth maps to the depth buffer and back, in
//! f64, for the four projections (standard or reversed-Z, finite or infinite far plane).

use glam::DMat4;

pub use crate::common::DepthMapping;

impl DepthMapping {
    /// Right-handed perspective projection to wgpu clip space (depth 0..1).
    pub fn projection(self, fov_y: f64, aspect: f64, near: f64, far: f64) -> DMat4 {
        match (self.reversed, self.infinite_far) {
            (false, false) => DMat4::perspective_rh(fov_y, aspect, near, far),
            (false, true) => DMat4::perspective_infinite_rh(fov_y, aspect, near),
            // Swapping near and far in the standard matrix maps near to 1 and far to 0.
            (true, false) => DMat4::perspective_rh(fov_y, aspect, far, near),
            (true, true) => DMat4::perspective_infinite_reverse_rh(fov_y, aspect, near),
        }
    }

    /// The depth-buffer value of positive view depth `z`, exactly.
    pub fn device_depth(self, z: f64, near: f64, far: f64) -> f64 {
        let (n, f) = (near, far);
        match (self.reversed, self.infinite_far) {
            (false, false) => f * (z - n) / ((f - n) * z),
            (false, true) => 1.0 - n / z,
            (true, false) => n * (f - z) / ((f - n) * z),
            (true, true) => n / z,
        }
    }

    /// Positive view depth of depth-buffer value `d`; None for the clear value (no geometry).
    pub fn view_depth(self, d: f64, near: f64, far: f64) -> Option<f64> {
        let (n, f) = (near, far);
        if self.is_background(d) {
            return None;
        }
        Some(match (self.reversed, self.infinite_far) {
            (false, false) => n * f / (f - d * (f - n)),
            (false, true) => n / (1.0 - d),
            (true, false) => n * f / (n + d * (f - n)),
            (true, true) => n / d,
        })
    }

    /// Reed 2015's model: the stored value is the exact d(z) rounded to the nearest one
    /// `format` holds, so depth read back is off by at most half a step of the format at
    /// d(z), divided by the slope dd/dz; relative to z.
    pub fn stored_relative_error(
        self,
        format: crate::common::DepthFormat,
        z: f64,
        near: f64,
        far: f64,
    ) -> f64 {
        let d = self.device_depth(z, near, far);
        let step = match format {
            crate::common::DepthFormat::Unorm24 => 1.0 / ((1u32 << 24) - 1) as f64,
            crate::common::DepthFormat::Float32 => f32_spacing(d),
        };
        0.5 * step / (self.slope(z, near, far) * z)
    }

    /// |dd/dz| at view depth z: how far the stored value moves per unit of depth.
    pub fn slope(self, z: f64, near: f64, far: f64) -> f64 {
        let scale = if self.infinite_far {
            1.0
        } else {
            far / (far - near)
        };
        scale * near / (z * z)
    }

    /// Whether `d` is the clear value.
    pub fn is_background(self, d: f64) -> bool {
        if self.reversed { d <= 0.0 } else { d >= 1.0 }
    }
}

/// Distance between `x` (in [0, 1]) and the next f32.
fn f32_spacing(x: f64) -> f64 {
    let f = x as f32;
    if f <= 0.0 {
        return f32::from_bits(1) as f64;
    }
    (f32::from_bits(f.to_bits() + 1) - f) as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec4;

    const ALL: [DepthMapping; 4] = [
        DepthMapping {
            reversed: false,
            infinite_far: false,
        },
        DepthMapping {
            reversed: false,
            infinite_far: true,
        },
        DepthMapping {
            reversed: true,
            infinite_far: false,
        },
        DepthMapping {
            reversed: true,
            infinite_far: true,
        },
    ];

    #[test]
    fn projection_agrees_with_the_closed_forms_and_inverts() {
        let (n, f) = (0.1, 500.0);
        for m in ALL {
            let proj = m.projection(1.0, 1.5, n, f);
            for z in [0.1, 0.37, 1.0, 12.0, 480.0, 499.0] {
                let clip = proj * DVec4::new(0.3, -0.2, -z, 1.0);
                let d = clip.z / clip.w;
                let closed = m.device_depth(z, n, f);
                assert!(
                    (d - closed).abs() < 1e-12,
                    "{m:?} z {z}: {d} against {closed}"
                );
                let back = m.view_depth(closed, n, f).unwrap();
                assert!((back - z).abs() < 1e-9 * z, "{m:?} z {z}: back {back}");
                // The slope is the derivative of the closed form.
                let h = z * 1e-6;
                let numeric =
                    (m.device_depth(z + h, n, f) - m.device_depth(z - h, n, f)).abs() / (2.0 * h);
                let rel = (numeric - m.slope(z, n, f)).abs() / m.slope(z, n, f);
                assert!(rel < 1e-5, "{m:?} z {z}: slope off by {rel}");
            }
            assert!(
                m.view_depth(if m.reversed { 0.0 } else { 1.0 }, n, f)
                    .is_none()
            );
        }
    }

    #[test]
    fn near_and_far_land_on_the_ends() {
        let (n, f) = (0.5, 80.0);
        for m in ALL {
            let near = m.device_depth(n, n, f);
            assert_eq!(near, if m.reversed { 1.0 } else { 0.0 }, "{m:?}");
            if !m.infinite_far {
                let far = m.device_depth(f, n, f);
                assert!((far - if m.reversed { 0.0 } else { 1.0 }).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn spacing_of_f32() {
        assert_eq!(f32_spacing(1.0), 2f64.powi(-23));
        assert_eq!(f32_spacing(0.75), 2f64.powi(-24));
    }
}
