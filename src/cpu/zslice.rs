//! Twin of `shaders/clustering/zslice.wesl`, from the formulas of each scheme.
//! Depths are positive view depths; `slices` is the grid's z.

/// Which scheme, with what it needs beyond near, far and the slice count.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scheme {
    Linear,
    Exponential,
    NearThenExponential { near_end: f64 },
    Olsson { tan_half_fov_y: f64, tiles_y: u32 },
}

fn clamp_slice(k: f64, slices: u32) -> u32 {
    k.clamp(0.0, (slices - 1) as f64) as u32
}

/// The slice of view depth `z` in [near, far].
pub fn slice(scheme: Scheme, z: f64, near: f64, far: f64, slices: u32) -> u32 {
    match scheme {
        Scheme::Linear => clamp_slice(((z - near) / (far - near) * slices as f64).floor(), slices),
        Scheme::Exponential => clamp_slice(
            ((z / near).ln() * slices as f64 / (far / near).ln()).floor(),
            slices,
        ),
        Scheme::NearThenExponential { near_end } => {
            if z < near_end {
                0
            } else {
                1 + slice(Scheme::Exponential, z, near_end, far, slices - 1)
            }
        }
        Scheme::Olsson {
            tan_half_fov_y,
            tiles_y,
        } => {
            let ratio = 1.0 + 2.0 * tan_half_fov_y / tiles_y as f64;
            clamp_slice(((z / near).ln() / ratio.ln()).floor(), slices)
        }
    }
}

/// View depth where slice `k` begins under the scheme's formula. For `k = slices` this is
/// far for every scheme but Olsson's, whose slice count follows from the camera; see
/// [`slice_bounds`] for the bounds a capped grid uses.
pub fn slice_start(scheme: Scheme, k: u32, near: f64, far: f64, slices: u32) -> f64 {
    let t = k as f64 / slices as f64;
    match scheme {
        Scheme::Linear => near + (far - near) * t,
        Scheme::Exponential => near * (far / near).powf(t),
        Scheme::NearThenExponential { near_end } => {
            if k == 0 {
                near
            } else {
                slice_start(Scheme::Exponential, k - 1, near_end, far, slices - 1)
            }
        }
        Scheme::Olsson {
            tan_half_fov_y,
            tiles_y,
        } => near * (1.0 + 2.0 * tan_half_fov_y / tiles_y as f64).powi(k as i32),
    }
}

/// The view-depth range of slice `k` in a grid of `slices`: the first slice starts at near
/// and the last ends at far (Olsson's slicing, capped at the grid, reaches to far).
pub fn slice_bounds(scheme: Scheme, k: u32, near: f64, far: f64, slices: u32) -> (f64, f64) {
    let end = if k + 1 >= slices {
        far
    } else {
        slice_start(scheme, k + 1, near, far, slices)
    };
    (slice_start(scheme, k, near, far, slices), end)
}
