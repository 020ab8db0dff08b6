//! Twin of `shaders/clustering/bounds.wesl` and `assign.wesl`: cluster boxes in view space
//! and light lists, in f64, from the definitions in docs/ARCHITECTURE.md. Also the CPU light assignment
//! of variants with `assignment: Cpu`.

use glam::{DMat4, DVec2, DVec3};

use super::zslice::Slices;
use crate::common::Light;
use crate::common::ZSlicing;

/// Relative padding of every box (as in the shaders).
pub const BOUNDS_PADDING: f64 = 1e-4;

/// A cluster grid over a camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub x: u32,
    pub y: u32,
    pub z: u32,
    pub slicing: ZSlicing,
    /// The clustered depth range.
    pub range: (f64, f64),
    /// The camera's near and far planes (slice 0 starts at near, the last ends at far).
    pub near: f64,
    pub far: f64,
    pub tan_half_fov_y: f64,
    pub aspect: f64,
}

impl Grid {
    /// The grid's slicing over its clustered range.
    pub fn slices(&self) -> Slices {
        Slices {
            scheme: self.slicing,
            near: self.range.0,
            far: self.range.1,
            count: self.z,
            tan_half_fov_y: self.tan_half_fov_y,
            tiles_y: self.y,
        }
    }

    pub fn count(&self) -> usize {
        (self.x * self.y * self.z) as usize
    }

    pub fn index(&self, x: u32, y: u32, k: u32) -> usize {
        (x + self.x * (y + self.y * k)) as usize
    }

    /// View depths bounding slice `k`: the scheme's, widened to the camera's near and far
    /// planes at the ends.
    pub fn slice_depths(&self, k: u32) -> (f64, f64) {
        let slices = self.slices();
        let start = |k: u32| {
            if k >= self.z {
                slices.far
            } else {
                slices.start(k)
            }
        };
        let mut z0 = start(k);
        let mut z1 = start(k + 1);
        if k == 0 {
            z0 = z0.min(self.near);
        }
        if k + 1 == self.z {
            z1 = z1.max(self.far);
        }
        (z0, z1)
    }
}

/// An axis-aligned box in view space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: DVec3,
    pub max: DVec3,
}

/// The box of every cluster (`None` where the slice is empty), index x + X (y + Y k).
pub fn cluster_bounds(grid: &Grid) -> Vec<Option<Aabb>> {
    let mut out = vec![None; grid.count()];
    for k in 0..grid.z {
        let (z0, z1) = grid.slice_depths(k);
        if z0 >= z1 {
            continue;
        }
        for y in 0..grid.y {
            for x in 0..grid.x {
                out[grid.index(x, y, k)] = Some(tile_box(grid, x, y, z0, z1));
            }
        }
    }
    out
}

/// The box of the frustum piece of tile (x, y) (y from the top) between depths z0 and z1.
fn tile_box(grid: &Grid, x: u32, y: u32, z0: f64, z1: f64) -> Aabb {
    let step = DVec2::new(2.0 / grid.x as f64, 2.0 / grid.y as f64);
    let ndc_min = DVec2::new(-1.0 + x as f64 * step.x, 1.0 - (y + 1) as f64 * step.y);
    let mut lo = DVec3::splat(f64::MAX);
    let mut hi = DVec3::splat(f64::MIN);
    for corner in 0..4 {
        let ndc = ndc_min
            + DVec2::new(
                if corner & 1 != 0 { step.x } else { 0.0 },
                if corner & 2 != 0 { step.y } else { 0.0 },
            );
        let ray = DVec3::new(
            ndc.x * grid.tan_half_fov_y * grid.aspect,
            ndc.y * grid.tan_half_fov_y,
            -1.0,
        );
        for z in [z0, z1] {
            lo = lo.min(ray * z);
            hi = hi.max(ray * z);
        }
    }
    let pad = (lo.abs().max(hi.abs()) + DVec3::splat(1e-3)) * BOUNDS_PADDING;
    Aabb {
        min: lo - pad,
        max: hi + pad,
    }
}

/// Arvo's sphere-box test.
pub fn sphere_touches_box(center: DVec3, radius: f64, b: &Aabb) -> bool {
    let nearest = center.clamp(b.min, b.max);
    nearest.distance_squared(center) <= radius * radius
}

/// Relative widening of the radius in the plane tests (as in the shaders).
pub const PLANE_SLACK: f64 = 1e-4;

/// The box test and the four side planes of tile (x, y)'s frustum piece: a light passes
/// when its sphere reaches the box and the inner side of every plane.
pub fn sphere_touches_cluster(
    grid: &Grid,
    center: DVec3,
    radius: f64,
    b: &Aabb,
    x: u32,
    y: u32,
) -> bool {
    if !sphere_touches_box(center, radius, b) {
        return false;
    }
    let sx = grid.tan_half_fov_y * grid.aspect;
    let sy = grid.tan_half_fov_y;
    let step = (2.0 / grid.x as f64, 2.0 / grid.y as f64);
    let left = (-1.0 + x as f64 * step.0) * sx;
    let right = (-1.0 + (x + 1) as f64 * step.0) * sx;
    let top = (1.0 - y as f64 * step.1) * sy;
    let bottom = (1.0 - (y + 1) as f64 * step.1) * sy;
    // Signed distance to the plane through the eye holding the rays coord = s (-z).
    let reaches = |coord: f64, s: f64, sign: f64| {
        sign * (coord + s * center.z) / (1.0 + s * s).sqrt() >= -radius * (1.0 + PLANE_SLACK) - 1e-6
    };
    reaches(center.x, left, 1.0)
        && reaches(center.x, right, -1.0)
        && reaches(center.y, bottom, 1.0)
        && reaches(center.y, top, -1.0)
}

/// Light positions in view space, with their radii.
pub fn view_lights(lights: &[Light], view_from_world: DMat4) -> Vec<(DVec3, f64)> {
    lights
        .iter()
        .map(|l| {
            let p = DVec3::from(l.position.map(f64::from));
            (view_from_world.transform_point3(p), l.radius as f64)
        })
        .collect()
}

/// Compacted light lists, as the GPU builds them.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ClusterLists {
    pub counts: Vec<u32>,
    pub offsets: Vec<u32>,
    /// Every list in ascending light index, one after the other.
    pub indices: Vec<u32>,
    /// Light-cluster pairs left out by the cap.
    pub dropped: u64,
    pub max_per_cluster: u32,
}

impl ClusterLists {
    /// The lights of cluster `c`.
    pub fn list(&self, c: usize) -> &[u32] {
        let first = self.offsets[c] as usize;
        &self.indices[first..first + self.counts[c] as usize]
    }
}

/// Assign lights to clusters: each list holds, in ascending index order, the lights whose
/// sphere touches the cluster, up to `cap` if given. Clusters where `active` is false get
/// empty lists.
pub fn assign(
    grid: &Grid,
    bounds: &[Option<Aabb>],
    lights: &[(DVec3, f64)],
    cap: Option<u32>,
    active: Option<&[bool]>,
) -> ClusterLists {
    let mut out = ClusterLists {
        counts: Vec::with_capacity(bounds.len()),
        offsets: Vec::with_capacity(bounds.len()),
        ..Default::default()
    };
    for (c, b) in bounds.iter().enumerate() {
        out.offsets.push(out.indices.len() as u32);
        let mut kept = 0u32;
        let mut touching = 0u64;
        if let Some(b) = b
            && active.is_none_or(|a| a[c])
        {
            let (x, y) = (c as u32 % grid.x, (c as u32 / grid.x) % grid.y);
            for (i, &(center, radius)) in lights.iter().enumerate() {
                if sphere_touches_cluster(grid, center, radius, b, x, y) {
                    touching += 1;
                    if cap.is_none_or(|cap| kept < cap) {
                        out.indices.push(i as u32);
                        kept += 1;
                    }
                }
            }
        }
        out.dropped += touching - kept as u64;
        out.max_per_cluster = out.max_per_cluster.max(kept);
        out.counts.push(kept);
    }
    out
}
