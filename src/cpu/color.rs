//! Twin of `shaders/common/color.wesl`: tonemapping and sRGB encoding.

/// Reinhard per channel after exposure: c / (1 + c), negative values clamped to 0.
pub fn tonemap_reinhard(hdr: [f64; 3], exposure: f64) -> [f64; 3] {
    hdr.map(|c| {
        let c = (c * exposure).max(0.0);
        c / (1.0 + c)
    })
}

/// Scenes' textures use it too, so it lives with the plain shared types.
pub use crate::common::srgb_encode;

/// Round a display value in [0, 1] to 8 bits.
pub fn to_unorm8(x: f64) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// The 8-bit display colour of a linear HDR colour: tonemap, sRGB, round.
pub fn display8(hdr: [f64; 3], exposure: f64) -> [u8; 3] {
    tonemap_reinhard(hdr, exposure).map(|c| to_unorm8(srgb_encode(c)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// IEC 61966-2-1's transfer function at its published points: the linear segment's
    /// end (0.0031308 -> 0.0404500), mid-grey (0.5 -> 0.735357, 8-bit 188) and white; the
    /// two segments meet there to 1e-7.
    #[test]
    fn srgb_encode_gives_the_standards_values() {
        assert!((srgb_encode(0.0031308) - 0.040_449_936).abs() < 1e-9);
        let above = 1.055 * 0.0031308f64.powf(1.0 / 2.4) - 0.055;
        assert!((above - srgb_encode(0.0031308)).abs() < 1e-7);
        assert!((srgb_encode(0.5) - 0.735_357).abs() < 1e-6);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-15);
        assert_eq!(srgb_encode(0.0), 0.0);
        assert_eq!(to_unorm8(srgb_encode(0.5)), 188);
    }

    /// Reinhard: c / (1 + c) after exposure, 1 maps to 1/2 and negatives to 0; white is
    /// approached, never reached, and rounds to 8-bit 255 for large c.
    #[test]
    fn reinhard_and_display_round_as_documented() {
        assert_eq!(tonemap_reinhard([1.0, -2.0, 3.0], 1.0), [0.5, 0.0, 0.75]);
        assert_eq!(tonemap_reinhard([1.0, 0.0, 0.0], 2.0)[0], 2.0 / 3.0);
        assert_eq!(display8([1.0, 0.0, 1e9], 1.0), [188, 0, 255]);
        assert_eq!(to_unorm8(-1.0), 0);
        assert_eq!(to_unorm8(2.0), 255);
    }
}
