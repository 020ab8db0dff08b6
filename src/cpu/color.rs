//! Twin of `shaders/common/color.wesl`: tonemapping and sRGB encoding.

/// Reinhard per channel after exposure: c / (1 + c), negative values clamped to 0.
pub fn tonemap_reinhard(hdr: [f64; 3], exposure: f64) -> [f64; 3] {
    hdr.map(|c| {
        let c = (c * exposure).max(0.0);
        c / (1.0 + c)
    })
}

/// The sRGB transfer function (IEC 61966-2-1).
pub fn srgb_encode(linear: f64) -> f64 {
    if linear <= 0.0031308 {
        linear * 12.92
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// Round a display value in [0, 1] to 8 bits.
pub fn to_unorm8(x: f64) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// The 8-bit display colour of a linear HDR colour: tonemap, sRGB, round.
pub fn display8(hdr: [f64; 3], exposure: f64) -> [u8; 3] {
    tonemap_reinhard(hdr, exposure).map(|c| to_unorm8(srgb_encode(c)))
}
