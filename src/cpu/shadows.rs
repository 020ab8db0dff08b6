//! Twin of `shaders/shading/shadows.wesl`: the shadow ray of a surface point and a light,
//! and how far the GPU's own ray may lie from the reference's, which decides when a pair
//! (sample, light) is ambiguous (`docs/design.md`, Shadows).
//!
//! A ray leaves the point lifted along its normal by `SHADOW_OFFSET` of its `scale` and ends
//! at the light's centre. The GPU's ray differs from the reference's by:
//! - the shading position against the raster truth's: both interpolate the same varying,
//!   each within `INTERPOLATION_PRECISION` of the value's magnitude (per coordinate, so
//!   sqrt 3 of it as a length); a position rebuilt from depth (the Compact G-buffer) moves
//!   along the view ray by the depth's error, the depth margin's interpolation and 24-bit
//!   terms, plus f32 steps (`DEPTH_ARITHMETIC`);
//! - the normal, by its interpolation or its codec's angular error, times the lift;
//! - f32 arithmetic in the traversal: the watertight test decides exactly for the corners
//!   translated and sheared in f32, each coordinate at most 3 roundings of terms up to
//!   2 x the largest coordinate the test handles (the ray's origin and light, the
//!   triangle's corners: `occlusion::Reach`), and its edge functions round once more:
//!   under 32 epsilon x that coordinate of movement in all.
//!
//! Every point of the GPU's segment then lies within that reach of the reference's, for
//! the triangle (or node) at hand: a far light or a vast floor widens only the tests that
//! handle its coordinates.

use glam::{DMat4, DVec3};

use super::clusters::{INTERPOLATION_PRECISION, stored_depth_error};
use super::occlusion::{Reach, Seen, TriangleBvh, Visits};
use crate::common::NormalCodec;

/// How far a shadow ray's origin is lifted off its surface, as a share of the point's
/// `scale` (the shaders' `SHADOW_OFFSET`, generated from this). It must exceed the GPU's
/// position error (`position_error`: a few 1e-5 of the scale for a stored position, about
/// 1e-5 for one rebuilt from reversed depth) many times over, so that no surface shadows
/// itself: at 1e-3, a ray leaves a flat surface 20 times farther than the ray's error.
pub const SHADOW_OFFSET: f64 = 1e-3;

/// Relative f32 error of a view depth rebuilt from a depth value, beyond its interpolation:
/// a few f32 steps (the depth margin's arithmetic part, `cpu::clusters::MARK_MARGIN`,
/// holds it with room to spare).
pub const DEPTH_ARITHMETIC: f64 = 1e-6;

/// What the shaders' slab test widens a box's far end by, so that f32 rounding never loses
/// a box the segment meets: PBRT's 1 + 2 gamma(3) (Pharr, Jakob & Humphreys, 4th ed.,
/// 6.8.2; gamma(n) = n u / (1 - n u), u = 2^-24) doubled, so that its own rounding to f32
/// stays above it (the shaders' `SHADOW_BOX_SLACK`).
pub const BOX_SLACK: f64 = 1.0 + 4.0 * (3.0 * UNIT_ROUNDOFF / (1.0 - 3.0 * UNIT_ROUNDOFF));

/// f32's unit roundoff, 2^-24.
const UNIT_ROUNDOFF: f64 = f32::EPSILON as f64 / 2.0;

/// Movement of the traversal's f32 arithmetic, per unit of `reach`: 32 epsilon of f32.
pub const TRAVERSAL_ROUNDING: f64 = 32.0 * UNIT_ROUNDOFF;

/// The length a point's offset and errors are relative to: its distance from the eye plus
/// its largest coordinate (an f32 position's precision follows its magnitude).
pub fn scale(p: DVec3, eye: DVec3) -> f64 {
    (p - eye).length() + p.abs().max_element()
}

/// Where the shadow ray of the point `p` with unit normal `n` starts.
pub fn ray_origin(p: DVec3, n: DVec3, eye: DVec3) -> DVec3 {
    p + n * (SHADOW_OFFSET * scale(p, eye))
}

/// Where a shading pass takes a sample's position from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PositionSource {
    /// The interpolated world position (forward passes, the Wide and Packed G-buffers).
    Stored,
    /// Rebuilt from the depth buffer (the Compact G-buffer).
    FromDepth { reversed: bool, unorm24: bool },
}

/// What a variant's shading surface is made of, as far as its shadow rays' error goes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowSource {
    pub position: PositionSource,
    /// The G-buffer's normal codec; None where the shading normal is interpolated.
    pub codec: Option<NormalCodec>,
}

/// What the reference's shadow rays need: the occluders and the bounds of the GPU's error.
#[derive(Clone, Debug)]
pub struct ShadowRays<'a> {
    pub bvh: &'a TriangleBvh,
    pub eye: DVec3,
    /// World to view space (a view depth is -z), and the near plane.
    pub view: DMat4,
    pub near: f64,
    pub source: ShadowSource,
}

impl ShadowRays<'_> {
    /// How far the GPU's shading position of `p` may lie from it.
    pub fn position_error(&self, p: DVec3) -> f64 {
        let stored = 2.0 * INTERPOLATION_PRECISION * 3f64.sqrt() * p.abs().max_element();
        match self.source.position {
            PositionSource::Stored => stored,
            PositionSource::FromDepth { reversed, unorm24 } => {
                let z = -self.view.transform_point3(p).z;
                let depth = stored_depth_error(z, self.near, reversed, unorm24) + DEPTH_ARITHMETIC;
                stored + depth * (p - self.eye).length()
            }
        }
    }

    /// The worst angle, in radians, between the GPU's shading normal and the truth's.
    fn normal_angle(&self) -> f64 {
        match self.source.codec {
            None | Some(NormalCodec::Xyz) => 4.0 * INTERPOLATION_PRECISION,
            // Four steps of a component's code: over every codec's bound (tests/properties.rs).
            Some(c) => 4.0 * 4.0 / ((1u64 << (c.bits() / 2)) - 1) as f64,
        }
    }

    /// What the ray from the point `p` with unit normal `n` to `light` finds, within the
    /// GPU's error of it.
    pub fn trace(&self, p: DVec3, n: DVec3, light: DVec3) -> (Seen, Visits) {
        let lift = SHADOW_OFFSET * scale(p, self.eye);
        let origin = ray_origin(p, n, self.eye);
        let reach = Reach {
            fixed: self.position_error(p) + lift * self.normal_angle(),
            per_coordinate: TRAVERSAL_ROUNDING,
        };
        self.bvh.classify(origin, light, reach)
    }

    /// Whether the reference's own ray, in f64, is blocked (what it shades an ambiguous
    /// pair with).
    pub fn blocked(&self, p: DVec3, n: DVec3, light: DVec3) -> bool {
        self.bvh.blocked(ray_origin(p, n, self.eye), light, 0.0).0
    }
}
