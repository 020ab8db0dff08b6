//! Twin of `shaders/clustering/zslice.wesl`, from the formulas of each scheme. Depths are
//! positive view depths.

use crate::common::ZSlicing;

/// A z-slicing scheme over a depth range: what the shaders' `z_slice` and
/// `slice_near_depth` compute.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slices {
    pub scheme: ZSlicing,
    /// The clustered depth range.
    pub near: f64,
    pub far: f64,
    /// The grid's z: how many slices there are.
    pub count: u32,
    /// Olsson's cubic slices follow the camera: tan(fov_y / 2) and the tile rows.
    pub tan_half_fov_y: f64,
    pub tiles_y: u32,
}

fn clamp_slice(k: f64, slices: u32) -> u32 {
    k.clamp(0.0, (slices - 1) as f64) as u32
}

impl Slices {
    /// The same scheme over another range and count (schemes built from others).
    fn over(self, scheme: ZSlicing, near: f64, far: f64, count: u32) -> Slices {
        Slices {
            scheme,
            near,
            far,
            count,
            ..self
        }
    }

    /// Olsson 2012: each slice as deep as a tile is wide, depths grow by this ratio.
    fn olsson_ratio(&self) -> f64 {
        1.0 + 2.0 * self.tan_half_fov_y / self.tiles_y as f64
    }

    /// The slice of view depth `z` in [near, far].
    pub fn slice(&self, z: f64) -> u32 {
        let (near, far, n) = (self.near, self.far, self.count);
        match self.scheme {
            ZSlicing::Linear => clamp_slice(((z - near) / (far - near) * n as f64).floor(), n),
            // A dynamic range is exponential over the range the frame covers.
            ZSlicing::Exponential | ZSlicing::DynamicRange { .. } => {
                clamp_slice(((z / near).ln() * n as f64 / (far / near).ln()).floor(), n)
            }
            ZSlicing::NearSliceThenExponential { near_slice_end } => {
                let near_end = near_slice_end as f64;
                if z < near_end {
                    0
                } else {
                    1 + self
                        .over(ZSlicing::Exponential, near_end, far, n - 1)
                        .slice(z)
                }
            }
            ZSlicing::OlssonCubic => {
                clamp_slice(((z / near).ln() / self.olsson_ratio().ln()).floor(), n)
            }
            // (1/near - 1/z) / (1/near - 1/far), scaled by near.
            ZSlicing::NdcUniform => clamp_slice(
                ((1.0 - near / z) / (1.0 - near / far) * n as f64).floor(),
                n,
            ),
        }
    }

    /// View depth where slice `k` begins under the scheme's formula. For `k = count` this is
    /// far for every scheme but Olsson's, whose slice count follows from the camera; see
    /// [`Slices::bounds`] for the bounds a capped grid uses.
    pub fn start(&self, k: u32) -> f64 {
        let (near, far, n) = (self.near, self.far, self.count);
        let t = k as f64 / n as f64;
        match self.scheme {
            ZSlicing::Linear => near + (far - near) * t,
            ZSlicing::Exponential | ZSlicing::DynamicRange { .. } => near * (far / near).powf(t),
            ZSlicing::NearSliceThenExponential { near_slice_end } => {
                if k == 0 {
                    near
                } else {
                    self.over(ZSlicing::Exponential, near_slice_end as f64, far, n - 1)
                        .start(k - 1)
                }
            }
            ZSlicing::OlssonCubic => near * self.olsson_ratio().powi(k as i32),
            // 1/z falls in equal steps from 1/near to 1/far.
            ZSlicing::NdcUniform => near / (1.0 - t * (1.0 - near / far)),
        }
    }

    /// The view-depth range of slice `k`: the first slice starts at near and the last ends
    /// at far (Olsson's slicing, capped at the grid, reaches to far).
    pub fn bounds(&self, k: u32) -> (f64, f64) {
        let end = if k + 1 >= self.count {
            self.far
        } else {
            self.start(k + 1)
        };
        (self.start(k), end)
    }
}
