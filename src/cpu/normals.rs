//! Twin of `shaders/packing/normals.wesl`: normal codecs in f64. Every codec maps a unit
//! vector to two unorm codes of `bits` bits each.

use glam::{DVec2, DVec3};

use crate::common::NormalCodec;

/// The code of `n` under `codec` (`codec.bits() / 2` bits a component); None for `Xyz`,
/// which stores floats.
pub fn encode(codec: NormalCodec, n: DVec3) -> Option<[u32; 2]> {
    let bits = codec.bits() / 2;
    Some(match codec {
        NormalCodec::Xyz => return None,
        NormalCodec::Octahedral { precise: false, .. } => oct_encode(n, bits),
        NormalCodec::Octahedral { precise: true, .. } => oct_encode_precise(n, bits),
        NormalCodec::Polar { .. } => polar_encode(n, bits),
        NormalCodec::Spheremap { .. } => spheremap_encode(n, bits),
    })
}

/// The unit vector of code `q` under `codec`; None for `Xyz`.
pub fn decode(codec: NormalCodec, q: [u32; 2]) -> Option<DVec3> {
    let bits = codec.bits() / 2;
    Some(match codec {
        NormalCodec::Xyz => return None,
        NormalCodec::Octahedral { .. } => oct_decode(q, bits),
        NormalCodec::Polar { .. } => polar_decode(q, bits),
        NormalCodec::Spheremap { .. } => spheremap_decode(q, bits),
    })
}

fn max_code(bits: u32) -> f64 {
    ((1u64 << bits) - 1) as f64
}

fn quantize(u: DVec2, bits: u32) -> [u32; 2] {
    let m = max_code(bits);
    [u.x, u.y].map(|c| (c.clamp(0.0, 1.0) * m).round() as u32)
}

fn dequantize(q: [u32; 2], bits: u32) -> DVec2 {
    DVec2::new(q[0] as f64, q[1] as f64) / max_code(bits)
}

fn sign_not_zero(v: DVec2) -> DVec2 {
    DVec2::new(
        if v.x >= 0.0 { 1.0 } else { -1.0 },
        if v.y >= 0.0 { 1.0 } else { -1.0 },
    )
}

/// Project onto the octahedron |x|+|y|+|z| = 1 and fold the lower half over the diagonals.
pub fn oct_project(n: DVec3) -> DVec2 {
    let p = DVec2::new(n.x, n.y) / (n.x.abs() + n.y.abs() + n.z.abs());
    if n.z < 0.0 {
        (DVec2::ONE - DVec2::new(p.y.abs(), p.x.abs())) * sign_not_zero(p)
    } else {
        p
    }
}

pub fn oct_unproject(e: DVec2) -> DVec3 {
    let z = 1.0 - e.x.abs() - e.y.abs();
    let xy = if z < 0.0 {
        (DVec2::ONE - DVec2::new(e.y.abs(), e.x.abs())) * sign_not_zero(e)
    } else {
        e
    };
    DVec3::new(xy.x, xy.y, z).normalize()
}

pub fn oct_encode(n: DVec3, bits: u32) -> [u32; 2] {
    quantize(oct_project(n) * 0.5 + DVec2::splat(0.5), bits)
}

pub fn oct_decode(q: [u32; 2], bits: u32) -> DVec3 {
    oct_unproject(dequantize(q, bits) * 2.0 - DVec2::ONE)
}

/// The code among the 4 around the projection whose decode is closest to `n` (smallest
/// squared distance; the first wins a tie).
pub fn oct_encode_precise(n: DVec3, bits: u32) -> [u32; 2] {
    let m = max_code(bits);
    let u = (oct_project(n) * 0.5 + DVec2::splat(0.5)).clamp(DVec2::ZERO, DVec2::ONE) * m;
    let base = [u.x.floor() as u32, u.y.floor() as u32];
    let top = m as u32;
    let mut best = base;
    let mut best_d2 = oct_decode(base, bits).distance_squared(n);
    for i in 1..4u32 {
        let c = [(base[0] + (i & 1)).min(top), (base[1] + (i >> 1)).min(top)];
        let d2 = oct_decode(c, bits).distance_squared(n);
        if d2 < best_d2 {
            best = c;
            best_d2 = d2;
        }
    }
    best
}

/// Polar angle from +z over pi, azimuth over 2 pi (shifted to [0, 1]).
pub fn polar_encode(n: DVec3, bits: u32) -> [u32; 2] {
    let theta = n.x.hypot(n.y).atan2(n.z);
    let phi = n.y.atan2(n.x);
    use std::f64::consts::PI;
    quantize(DVec2::new(theta / PI, phi / (2.0 * PI) + 0.5), bits)
}

pub fn polar_decode(q: [u32; 2], bits: u32) -> DVec3 {
    use std::f64::consts::PI;
    let u = dequantize(q, bits);
    let (theta, phi) = (u.x * PI, (u.y - 0.5) * 2.0 * PI);
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// Lambert azimuthal equal-area projection about +z; n = -z (singular) encodes as +z.
pub fn spheremap_encode(n: DVec3, bits: u32) -> [u32; 2] {
    let f = (8.0 * n.z + 8.0).max(1e-20).sqrt();
    quantize(DVec2::new(n.x, n.y) / f + DVec2::splat(0.5), bits)
}

pub fn spheremap_decode(q: [u32; 2], bits: u32) -> DVec3 {
    let e = dequantize(q, bits) * 4.0 - DVec2::splat(2.0);
    let f = e.dot(e);
    let g = (1.0 - f / 4.0).max(0.0).sqrt();
    DVec3::new(e.x * g, e.y * g, 1.0 - f / 2.0).normalize()
}

/// Angle in degrees between two directions. atan2 of the cross and dot products stays exact
/// for tiny angles and for vectors a few ULP off unit length (f32 decodes), where
/// acos(dot) would read a length error of 1e-7 as an angle of 0.03 degrees.
pub fn angle_degrees(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b)).to_degrees()
}
