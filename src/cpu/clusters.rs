//! Twin of the cluster modules of `shaders/clustering/`: `bounds.wesl` (cluster boxes in view
//! space), `assign.wesl` (the light tests and lists), `depth_mask.wesl`
//! (2.5D masks), `two_level.wesl` (the coarse test and big tiles) and `raster_bin.wesl`
//! (light proxies), in f64, from the definitions in docs/design.md. Also the CPU light
//! assignment of variants with `assignment: Cpu`.

use glam::{DMat4, DVec2, DVec3};

use super::zslice::Slices;
use crate::common::{Light, SpotTest, ZSlicing};

/// Relative padding of every box: float rounding of a surface's position or slice can put it
/// a hair outside its cluster's exact box, and a light it touches must still be listed (the
/// shaders' `BOUNDS_PADDING`, generated from this).
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

/// Relative widening of the radius in the plane tests: rounding must never reject a light
/// that touches (the shaders' `PLANE_SLACK`, generated from this).
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
    sphere_touches_box(center, radius, b) && sphere_touches_tile(grid, center, radius, x, y)
}

/// Whether a sphere reaches the inner side of the four side planes of tile (x, y)'s frustum
/// (the tile test of z-binning and two-level culling; with the box test, the cluster test).
pub fn sphere_touches_tile(grid: &Grid, center: DVec3, radius: f64, x: u32, y: u32) -> bool {
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

/// Two-level culling's coarse test of a sphere on the big tile of tiles `lo` to `hi`: the
/// side-plane test of some tile of it (the union of the fine tests, so it never culls a light
/// a cluster's test keeps).
pub fn coarse_keeps(
    grid: &Grid,
    center: DVec3,
    radius: f64,
    lo: (u32, u32),
    hi: (u32, u32),
) -> bool {
    (lo.1..=hi.1).any(|y| (lo.0..=hi.0).any(|x| sphere_touches_tile(grid, center, radius, x, y)))
}

/// Two-level culling's big tile of tile (x, y), `n` tiles a side: its first and last tile.
pub fn big_tile(grid: &Grid, n: u32, x: u32, y: u32) -> ((u32, u32), (u32, u32)) {
    let lo = (x / n * n, y / n * n);
    (
        (lo),
        (
            (lo.0 + n - 1).min(grid.x - 1),
            (lo.1 + n - 1).min(grid.y - 1),
        ),
    )
}

/// Tiles ((x0, y0), (x1, y1)) of a rectangle.
pub type TileRect = ((u32, u32), (u32, u32));

/// Rasterised binning's proxy of sphere (center, radius) in slice `k`: the tiles onto which
/// the part of the sphere within the slice's view depths projects (slice 0 from the eye, the
/// last without end; nothing nearer than the camera's near plane), or None where no part of
/// it lies there or on screen. That part lies in the box of the sphere's widest
/// cross-section within those depths (radius sqrt(r^2 - e^2), e the distance from the
/// centre's depth to the nearest of them) between the nearest and farthest of them, and
/// the box's corners project to the rectangle. Twin of `proxy_tiles` in raster_bin.wesl,
/// without its widening.
pub fn proxy_tiles(grid: &Grid, center: DVec3, radius: f64, k: u32) -> Option<TileRect> {
    let (mut s0, mut s1) = grid.slice_depths(k);
    if k == 0 {
        s0 = 0.0;
    }
    if k + 1 == grid.z {
        s1 = f64::INFINITY;
    }
    let d = -center.z;
    let z0 = s0.max(d - radius).max(grid.near);
    let z1 = s1.min(d + radius);
    if z0 > z1 {
        return None;
    }
    let e = (z0 - d).max(d - z1).max(0.0);
    let across = ((radius - e) * (radius + e)).max(0.0).sqrt();
    let scale = DVec2::new(grid.tan_half_fov_y * grid.aspect, grid.tan_half_fov_y);
    let (lo_xy, hi_xy) = (center.truncate() - across, center.truncate() + across);
    let lo = (lo_xy / (z0 * scale)).min(lo_xy / (z1 * scale));
    let hi = (hi_xy / (z0 * scale)).max(hi_xy / (z1 * scale));
    if hi.x < -1.0 || lo.x > 1.0 || hi.y < -1.0 || lo.y > 1.0 {
        return None;
    }
    let tile = |v: f64, tiles: u32| {
        ((v * 0.5 + 0.5) * tiles as f64)
            .floor()
            .clamp(0.0, tiles as f64 - 1.0) as u32
    };
    // Tile rows count from the top, NDC y from the bottom.
    Some((
        (tile(lo.x, grid.x), tile(-hi.y, grid.y)),
        (tile(hi.x, grid.x), tile(-lo.y, grid.y)),
    ))
}

/// Rasterised binning's lists from a cluster test's `lists`: each cluster keeps the lights
/// whose proxy in its slice (`proxy`, [`proxy_tiles`] or a deliberate break of it) holds
/// its tile.
pub fn binned(
    grid: &Grid,
    lists: &ClusterLists,
    lights: &[ViewLight],
    proxy: impl Fn(&ViewLight, u32) -> Option<TileRect>,
) -> ClusterLists {
    let mut out = ClusterLists::default();
    for c in 0..lists.counts.len() {
        let (x, y, k) = (
            c as u32 % grid.x,
            (c as u32 / grid.x) % grid.y,
            c as u32 / (grid.x * grid.y),
        );
        out.offsets.push(out.indices.len() as u32);
        let before = out.indices.len();
        out.indices.extend(lists.list(c).iter().filter(|&&i| {
            proxy(&lights[i as usize], k).is_some_and(|((x0, y0), (x1, y1))| {
                (x0..=x1).contains(&x) && (y0..=y1).contains(&y)
            })
        }));
        let n = (out.indices.len() - before) as u32;
        out.counts.push(n);
        out.max_per_cluster = out.max_per_cluster.max(n);
    }
    out
}

/// Widening of a spot's outer cone, in cosine, before it is tested (the shading compares
/// an f32 cosine with rounding near 1e-7 against the cone's).
pub const CONE_COS_SLACK: f64 = 1e-6;
/// Relative widening of a spot's bounding sphere and of the cone test's distances (this and
/// `CONE_COS_SLACK` generated into the shaders' constants).
pub const SPOT_SLACK: f64 = 1e-5;

/// A spot's cone in view space: apex, unit axis, range, and the cosine and sine of its outer
/// half-angle widened by [`CONE_COS_SLACK`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewCone {
    pub apex: DVec3,
    pub axis: DVec3,
    pub range: f64,
    pub cos: f64,
    pub sin: f64,
}

/// A light in view space: the sphere every cluster test starts from (a point light's own,
/// a spot's bounding sphere), and a spot's cone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewLight {
    pub center: DVec3,
    pub radius: f64,
    pub cone: Option<ViewCone>,
}

/// The smallest sphere around the spherical sector of a cone (apex, unit axis, range r,
/// half-angle with cosine c): for half-angles up to 45 degrees the sphere through the apex and
/// the rim, centre at r / (2c) along the axis; up to 90 the sphere of the rim circle, centre
/// at r c, radius r sqrt(1 - c^2); wider, the light's own sphere.
pub fn cone_bounding_sphere(apex: DVec3, axis: DVec3, range: f64, cos: f64) -> (DVec3, f64) {
    let (center, radius) = if cos >= std::f64::consts::FRAC_1_SQRT_2 {
        let r = range / (2.0 * cos);
        (apex + axis * r, r)
    } else if cos > 0.0 {
        (
            apex + axis * (range * cos),
            range * ((1.0 - cos) * (1.0 + cos)).sqrt(),
        )
    } else {
        (apex, range)
    };
    (center, radius * (1.0 + SPOT_SLACK))
}

/// Wronski 2017 ("Cull that cone"): whether a cone's spherical sector may reach the sphere
/// (center, radius). Rejects a sphere wholly beside the cone (its distance to the cone's
/// side, measured in the plane of the axis, above its radius), beyond the range along the
/// axis, or behind the apex. Conservative: each rejection is of a region the cone misses.
pub fn cone_touches_sphere(cone: &ViewCone, center: DVec3, radius: f64) -> bool {
    let d = center - cone.apex;
    let along = d.dot(cone.axis);
    let across = (d - cone.axis * along).length();
    let slack = SPOT_SLACK * (radius + d.length()) + 1e-6;
    let beside = cone.cos * across - along * cone.sin > radius + slack;
    let beyond = along > radius + cone.range + slack;
    let behind = along < -radius - slack;
    !(beside || beyond || behind)
}

/// Lights in view space, for cluster tests.
pub fn view_lights(lights: &[Light], view_from_world: DMat4) -> Vec<ViewLight> {
    lights
        .iter()
        .map(|l| {
            let (apex, axis, range, cos_outer) = exact_view_cone(l, view_from_world);
            if !l.is_spot() {
                return ViewLight {
                    center: apex,
                    radius: range,
                    cone: None,
                };
            }
            let cos = cos_outer - CONE_COS_SLACK;
            let (center, radius) = cone_bounding_sphere(apex, axis, range, cos);
            ViewLight {
                center,
                radius,
                cone: Some(ViewCone {
                    apex,
                    axis,
                    range,
                    cos,
                    sin: ((1.0 - cos) * (1.0 + cos)).max(0.0).sqrt(),
                }),
            }
        })
        .collect()
}

/// The full test of a light against cluster (x, y) with box `b`: the sphere test, then with
/// `SpotTest::Cone` a spot's cone against the box's bounding sphere.
pub fn light_touches_cluster(
    grid: &Grid,
    light: &ViewLight,
    spot_test: SpotTest,
    b: &Aabb,
    x: u32,
    y: u32,
) -> bool {
    if !sphere_touches_cluster(grid, light.center, light.radius, b, x, y) {
        return false;
    }
    match (light.cone, spot_test) {
        (Some(cone), SpotTest::Cone) => {
            let mid = (b.min + b.max) * 0.5;
            cone_touches_sphere(&cone, mid, (b.max - b.min).length() * 0.5)
        }
        _ => true,
    }
}

/// Marking finds a sample's depth from the depth buffer, shading from its surface; the two
/// may round to different sides of a slice boundary, so marking marks every slice of
/// [z (1 - m), z (1 + m)] and 2.5D cells span it, m = [`depth_margin`]. MARK_MARGIN is
/// the part of m that covers the f32 arithmetic on both sides (the depth rebuilt from the
/// buffer, the surface's view depth: a few f32 steps, under 1e-6) and the surface's own
/// interpolation (1 part in 1e5, [`INTERPOLATION_PRECISION`]), with room to spare (the
/// shaders' `MARK_MARGIN`, generated from this).
pub const MARK_MARGIN: f64 = 1e-3;

/// The precision Vulkan and OpenGL ES require of interpolation at a fragment: 1 part in
/// 1e5 of the value. A rasteriser may store a depth that far from the exact one (lavapipe
/// stores it within an f32 step; other GPUs do not), and the view depth rebuilt from it
/// moves by that much times the mapping's amplification (`depth_margin`).
pub const INTERPOLATION_PRECISION: f64 = 1e-5;

/// How far, relative to `z`, the view depth shading computes from a sample's surface may lie
/// from `z`, the view depth rebuilt from the sample's stored depth `d` (near plane `near`):
/// MARK_MARGIN, plus the stored depth's interpolation error (INTERPOLATION_PRECISION of d)
/// carried through the mapping: |dz/dd| d / z is (z - near) / near with standard depth
/// (d = f (z - n) / (z (f - n)), or 1 - n / z with an infinite far plane: a depth near 1
/// holds the far view depths in few steps) and at most 1 with reversed depth (d = n / z,
/// or n (f - z) / (z (f - n))). A 24-bit depth also rounds to steps of 1 / (2^24 - 1),
/// which move z by up to a step times |dz/dd| <= z^2 / near, so z / near steps relative.
/// The shaders' `depth_margin` is this, in f32.
pub fn depth_margin(z: f64, near: f64, reversed: bool, unorm24: bool) -> f64 {
    MARK_MARGIN + stored_depth_error(z, near, reversed, unorm24)
}

/// How far, relative to `z`, a view depth rebuilt from a stored depth may lie from the
/// exact one for the storing alone: the interpolation and 24-bit terms of `depth_margin`.
pub fn stored_depth_error(z: f64, near: f64, reversed: bool, unorm24: bool) -> f64 {
    let amplification = if reversed {
        1.0
    } else {
        (z - near).max(0.0) / near
    };
    let step = if unorm24 {
        UNORM24_DEPTH_STEP * z / near
    } else {
        0.0
    };
    INTERPOLATION_PRECISION * amplification + step
}

/// One step of a 24-bit normalized depth buffer.
pub const UNORM24_DEPTH_STEP: f64 = 1.0 / 16_777_215.0;

/// Cells of a cluster's sample depth range in 2.5D culling: the bits of a u32 (the shaders'
/// `DEPTH_CELLS`, generated from this).
pub const DEPTH_CELLS: u32 = 32;

/// The cell of view depth `z` in range [z0, z1], clamped to the first and last cell.
pub fn depth_cell(z: f64, z0: f64, z1: f64) -> u32 {
    let t = (z - z0) * DEPTH_CELLS as f64 / (z1 - z0).max(1e-30);
    t.clamp(0.0, (DEPTH_CELLS - 1) as f64) as u32
}

/// The mask of the cells from the one of depth `a` to the one of depth `b` (a <= b).
pub fn cell_span(a: f64, b: f64, z0: f64, z1: f64) -> u32 {
    let (lo, hi) = (depth_cell(a, z0, z1), depth_cell(b, z0, z1));
    let above_hi = if hi < 31 { u32::MAX << (hi + 1) } else { 0 };
    (u32::MAX << lo) & !above_hi
}

/// A cluster's visible samples as 2.5D culling sees them: their depth range and the mask of
/// the cells of that range that hold one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthMask {
    pub range: (f64, f64),
    pub mask: u32,
}

impl DepthMask {
    /// Whether the cells a light's depth range spans (its sphere's) hold a sample.
    pub fn admits(&self, light: &ViewLight) -> bool {
        let (z0, z1) = self.range;
        let a = -(light.center.z + light.radius);
        let b = -(light.center.z - light.radius);
        self.mask & cell_span(a, b, z0, z1) != 0
    }
}

/// Each cluster's samples (`None` where it holds none), from the view depth of every pixel
/// of a `width` x `height` frame (`None`: background), each in the cluster of its tile and
/// the slice of its depth.
pub fn depth_masks(
    grid: &Grid,
    (width, height): (u32, u32),
    depths: &[Option<f64>],
) -> Vec<Option<DepthMask>> {
    let slices = grid.slices();
    // The tile of a pixel's centre, as shading finds it.
    let tile = |p: u32, size: u32, tiles: u32| {
        (((p as f64 + 0.5) * tiles as f64 / size as f64) as u32).min(tiles - 1)
    };
    let cluster = |i: usize, z: f64| {
        let (px, py) = (i as u32 % width, i as u32 / width);
        grid.index(
            tile(px, width, grid.x),
            tile(py, height, grid.y),
            slices.slice(z),
        )
    };
    let mut ranges = vec![None::<(f64, f64)>; grid.count()];
    for (i, z) in depths.iter().enumerate() {
        if let Some(z) = *z {
            let r = &mut ranges[cluster(i, z)];
            *r = Some(r.map_or((z, z), |(a, b)| (a.min(z), b.max(z))));
        }
    }
    let mut out: Vec<Option<DepthMask>> = ranges
        .iter()
        .map(|r| r.map(|range| DepthMask { range, mask: 0 }))
        .collect();
    for (i, z) in depths.iter().enumerate() {
        if let Some(z) = *z {
            let m = out[cluster(i, z)].as_mut().expect("a range");
            m.mask |= 1 << depth_cell(z, m.range.0, m.range.1);
        }
    }
    out
}

/// Olsson's explicit bounds: each cluster's box shrunk to the depth range of its samples
/// (within its slice), `None` where it holds none.
pub fn sample_bounds(grid: &Grid, masks: &[Option<DepthMask>]) -> Vec<Option<Aabb>> {
    (0..grid.count())
        .map(|c| {
            let m = masks[c]?;
            let (x, y, k) = (
                c as u32 % grid.x,
                (c as u32 / grid.x) % grid.y,
                c as u32 / (grid.x * grid.y),
            );
            let (s0, s1) = grid.slice_depths(k);
            let (z0, z1) = (m.range.0.max(s0), m.range.1.min(s1));
            Some(tile_box(grid, x, y, z0.min(z1), z0.max(z1)))
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

    /// These lists and `other`'s (of the same grid) as one, each cluster's lights of both in
    /// ascending order (StaticDynamic's still and moving lists). A list reaching past what
    /// was read back (an overflowing frame) adds nothing.
    pub fn merged(&self, other: &ClusterLists) -> ClusterLists {
        let part = |lists: &'_ ClusterLists, c: usize| -> Vec<u32> {
            let first = lists.offsets[c] as usize;
            let end = first + lists.counts[c] as usize;
            lists.indices.get(first..end).unwrap_or_default().to_vec()
        };
        let mut out = ClusterLists {
            dropped: self.dropped + other.dropped,
            ..Default::default()
        };
        for c in 0..self.counts.len() {
            let mut list = part(self, c);
            list.extend(part(other, c));
            list.sort_unstable();
            out.push(list);
        }
        out
    }

    /// Add the next cluster's list.
    pub fn push(&mut self, list: Vec<u32>) {
        self.offsets.push(self.indices.len() as u32);
        self.counts.push(list.len() as u32);
        self.max_per_cluster = self.max_per_cluster.max(list.len() as u32);
        self.indices.extend(list);
    }
}

/// Assign lights to clusters: each list holds, in ascending index order, the lights that
/// touch the cluster (`light_touches_cluster`), up to `cap` if given. Clusters where `active`
/// is false get empty lists; with `masks` (2.5D culling), so do clusters without samples,
/// and a light must also pass its cluster's mask.
pub fn assign(
    grid: &Grid,
    bounds: &[Option<Aabb>],
    lights: &[ViewLight],
    spot_test: SpotTest,
    cap: Option<u32>,
    active: Option<&[bool]>,
    masks: Option<&[Option<DepthMask>]>,
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
        let mask = masks.map(|m| m[c]);
        if let Some(b) = b
            && active.is_none_or(|a| a[c])
            && mask.is_none_or(|m| m.is_some())
        {
            let (x, y) = (c as u32 % grid.x, (c as u32 / grid.x) % grid.y);
            for (i, light) in lights.iter().enumerate() {
                if light_touches_cluster(grid, light, spot_test, b, x, y)
                    && mask.flatten().is_none_or(|m| m.admits(light))
                {
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

/// A light's own cone in view space, not widened: apex, unit axis, range, outer cosine (a
/// point light's axis is zero).
fn exact_view_cone(light: &Light, view_from_world: DMat4) -> (DVec3, DVec3, f64, f64) {
    let apex = view_from_world.transform_point3(DVec3::from(light.position.map(f64::from)));
    let axis = view_from_world
        .transform_vector3(DVec3::from(light.direction.map(f64::from)))
        .normalize_or_zero();
    (apex, axis, light.radius as f64, light.cos_outer as f64)
}

/// Whether view-space point `p` is clearly lit by the spot (apex, axis, range, outer
/// cosine): closer than the range by a relative 1e-4, inside the cone by 2e-6 in cosine, so
/// that no rounding of the GPU's can decide it.
pub fn clearly_in_sector(cone: (DVec3, DVec3, f64, f64), p: DVec3) -> bool {
    let (apex, axis, range, cos_outer) = cone;
    let d = p - apex;
    let len = d.length();
    len > 0.0 && len < range * (1.0 - 1e-4) && d.dot(axis) / len > cos_outer + 2e-6
}

/// An independent f64 check of the cone tests: a point of the frustum piece of tile (x, y)
/// (y from the top) between view depths z0 and z1 that the spot clearly lights, sampled on
/// an n x n x n lattice of the piece (its corners and faces included); None when no sample
/// is lit.
pub fn spot_point_in_piece(
    grid: &Grid,
    light: &Light,
    view_from_world: DMat4,
    x: u32,
    y: u32,
    (z0, z1): (f64, f64),
    n: u32,
) -> Option<DVec3> {
    let cone = exact_view_cone(light, view_from_world);
    let step = DVec2::new(2.0 / grid.x as f64, 2.0 / grid.y as f64);
    let t = |i: u32| i as f64 / (n - 1).max(1) as f64;
    for i in 0..n {
        for j in 0..n {
            let ndc = DVec2::new(
                -1.0 + (x as f64 + t(i)) * step.x,
                1.0 - (y as f64 + t(j)) * step.y,
            );
            let ray = DVec3::new(
                ndc.x * grid.tan_half_fov_y * grid.aspect,
                ndc.y * grid.tan_half_fov_y,
                -1.0,
            );
            for k in 0..n {
                let p = ray * (z0 + (z1 - z0) * t(k));
                if clearly_in_sector(cone, p) {
                    return Some(p);
                }
            }
        }
    }
    None
}
