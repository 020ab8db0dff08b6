//! Which lights can reach a point, for the reference frame: a uniform world-space grid over
//! the points it shades, each cell listing (in index order) the lights whose bounding box
//! meets it: the box of a point light's sphere, of a spot's cone's bounding sphere. A light
//! adds exactly 0 beyond its radius and outside its cone (`shading::light_contribution`),
//! so inside that box: the lights of a point's cell hold every light that reaches it, and
//! shading them in index order gives the sum that every light gives, bit for bit (the
//! others add +0.0, which changes no sum that starts at +0.0). The shading itself is the f64
//! twin, unchanged.

use glam::DVec3;

use super::clusters::cone_bounding_sphere;
use crate::common::Light;

/// Most cells a grid has.
const MAX_CELLS: usize = 1 << 20;

/// Most cell entries a grid holds per point and light it is made for (a few lights far
/// wider than the mean would otherwise fill every cell).
const MAX_ENTRIES_PER_ITEM: usize = 64;

/// Lights bucketed by the cells of a box around a set of points.
#[derive(Clone, Debug)]
pub struct LightGrid {
    lo: DVec3,
    /// Cells per world unit along each axis.
    scale: DVec3,
    dims: [usize; 3],
    /// Cell c's lights are `indices[starts[c]..starts[c + 1]]`, ascending.
    starts: Vec<u32>,
    indices: Vec<u32>,
}

impl LightGrid {
    /// A grid over the box of `points`, its cells about half as wide as the lights' mean
    /// radius (at most `MAX_CELLS` of them); None where its cells would hold more than
    /// `MAX_ENTRIES_PER_ITEM` entries per point and light.
    pub fn new(points: &[DVec3], lights: &[Light]) -> Option<Self> {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for p in points {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        if points.is_empty() {
            (lo, hi) = (DVec3::ZERO, DVec3::ZERO);
        }
        let extent = (hi - lo).max(DVec3::splat(1e-6));
        let mean_radius =
            lights.iter().map(|l| l.radius as f64).sum::<f64>() / lights.len().max(1) as f64;
        // Half the mean radius: finer cells cut more of each light's box, at more cells per
        // light (measured on the built-in scenes: 0.25, 0.5, 1 and 2 radii, 0.5 fastest).
        let mut cell = (0.5 * mean_radius).max(1e-6);
        let count = |cell: f64| (extent / cell).ceil().max(DVec3::ONE);
        while count(cell).x * count(cell).y * count(cell).z > MAX_CELLS as f64 {
            cell *= 1.25;
        }
        let n = count(cell);
        let dims = [n.x as usize, n.y as usize, n.z as usize];
        let scale = n / extent;
        let mut grid = Self {
            lo,
            scale,
            dims,
            starts: vec![0; dims[0] * dims[1] * dims[2] + 1],
            indices: Vec::new(),
        };
        // Count each light in its cells, take room, then fill in light order.
        let ranges: Vec<Option<[[usize; 2]; 3]>> =
            lights.iter().map(|l| grid.cell_range(l, hi)).collect();
        let cells = |r: &[[usize; 2]; 3]| r.iter().map(|a| a[1] - a[0] + 1).product::<usize>();
        let entries: usize = ranges.iter().flatten().map(cells).sum();
        if entries > MAX_ENTRIES_PER_ITEM * (points.len() + lights.len()) {
            return None;
        }
        for r in ranges.iter().flatten() {
            let starts = &mut grid.starts;
            grid_for_cells(&grid.dims, r, |c| starts[c + 1] += 1);
        }
        for c in 0..grid.starts.len() - 1 {
            grid.starts[c + 1] += grid.starts[c];
        }
        grid.indices = vec![0; grid.starts[grid.starts.len() - 1] as usize];
        let mut cursor = grid.starts.clone();
        for (i, r) in ranges.iter().enumerate() {
            if let Some(r) = r {
                let indices = &mut grid.indices;
                grid_for_cells(&grid.dims, r, |c| {
                    indices[cursor[c] as usize] = i as u32;
                    cursor[c] += 1;
                });
            }
        }
        Some(grid)
    }

    /// The cells along each axis that light `l`'s bounding box meets (None outside the
    /// grid's box, which ends at `hi`). The box is widened by a relative 1e-9 so that a
    /// point whose rounded distance to the light falls below the radius lies in it (a
    /// spot's bounding sphere is widened by `SPOT_SLACK` already, for its cone's rounding).
    fn cell_range(&self, l: &Light, hi: DVec3) -> Option<[[usize; 2]; 3]> {
        let apex = DVec3::from(l.position.map(f64::from));
        let (c, r) = if l.cos_outer > -1.0 {
            let axis = DVec3::from(l.direction.map(f64::from)).normalize_or_zero();
            cone_bounding_sphere(apex, axis, l.radius as f64, l.cos_outer as f64)
        } else {
            (apex, l.radius as f64)
        };
        let r = r * (1.0 + 1e-9) + c.abs().max_element() * 1e-12;
        let (a, b) = (c - r, c + r);
        if a.cmpgt(hi).any() || b.cmplt(self.lo).any() {
            return None;
        }
        let (ca, cb) = (self.cell_of(a), self.cell_of(b));
        Some([[ca[0], cb[0]], [ca[1], cb[1]], [ca[2], cb[2]]])
    }

    /// The cell of `p`, clamped to the grid.
    fn cell_of(&self, p: DVec3) -> [usize; 3] {
        let t = ((p - self.lo) * self.scale).floor();
        let clamp = |v: f64, n: usize| (v.max(0.0) as usize).min(n - 1);
        [
            clamp(t.x, self.dims[0]),
            clamp(t.y, self.dims[1]),
            clamp(t.z, self.dims[2]),
        ]
    }

    /// Whether the cells of `points` hold less than half the lights on average: otherwise
    /// walking every light costs less than looking them up.
    pub fn culls(&self, points: &[DVec3], lights: usize) -> bool {
        let held: usize = points.iter().map(|p| self.lights_at(*p).len()).sum();
        2 * held < points.len() * lights
    }

    /// Every light that can reach `p` (and maybe others), ascending.
    pub fn lights_at(&self, p: DVec3) -> &[u32] {
        let [x, y, z] = self.cell_of(p);
        let c = x + self.dims[0] * (y + self.dims[1] * z);
        &self.indices[self.starts[c] as usize..self.starts[c + 1] as usize]
    }
}

/// Call `f` with the index of every cell in the ranges `r`.
fn grid_for_cells(dims: &[usize; 3], r: &[[usize; 2]; 3], mut f: impl FnMut(usize)) {
    for z in r[2][0]..=r[2][1] {
        for y in r[1][0]..=r[1][1] {
            for x in r[0][0]..=r[0][1] {
                f(x + dims[0] * (y + dims[1] * z));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::shading::{
        Brdf, ShadingParams, Surface, light_contribution, shade, shade_lights,
    };

    /// A small deterministic generator (no dependency for one test).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        fn range(&mut self, a: f64, b: f64) -> f64 {
            a + (b - a) * self.next()
        }
        /// A point of the box [lo, hi].
        fn point(&mut self, lo: [f64; 3], hi: [f64; 3]) -> DVec3 {
            DVec3::from([0, 1, 2].map(|k| self.range(lo[k], hi[k])))
        }
    }

    fn lights(rng: &mut Lcg, n: usize) -> Vec<Light> {
        (0..n)
            .map(|i| {
                let p = [0; 3].map(|_| rng.range(-12.0, 12.0) as f32);
                // Now and then a light far outside the points, a huge one, a zero one.
                let radius = match i % 17 {
                    0 => 0.0,
                    1 => 40.0,
                    _ => rng.range(0.1, 4.0) as f32,
                };
                let mut l = if i % 3 == 0 {
                    let axis = [0; 3].map(|_| rng.range(-1.0, 1.0));
                    let outer = rng.range(5.0, 85.0);
                    Light::spot(p, radius, [1.0, 0.8, 0.6], 1.0, axis, outer * 0.7, outer)
                } else {
                    Light::point(p, radius, [1.0, 0.8, 0.6], 1.0)
                };
                if i % 5 == 0 {
                    l.position[0] += 30.0;
                }
                l
            })
            .collect()
    }

    #[test]
    fn a_cell_holds_every_light_that_reaches_its_points_and_shades_the_same_bit_for_bit() {
        let mut rng = Lcg(7);
        let lights = lights(&mut rng, 300);
        let mut points: Vec<DVec3> = (0..4000)
            .map(|_| rng.point([-8.0, -3.0, -8.0], [8.0, 5.0, 8.0]))
            .collect();
        // Points on lights' spheres and spots' cones, a hair inside and outside (the
        // rounding edge).
        for l in lights.iter().take(90) {
            let c = DVec3::from(l.position.map(f64::from));
            let axis = DVec3::from(l.direction.map(f64::from)).normalize_or(DVec3::Y);
            let side = axis.any_orthonormal_vector();
            let rim = |f: f64| {
                let cos = (l.cos_outer as f64 * f).clamp(-1.0, 1.0);
                axis * cos + side * (1.0 - cos * cos).sqrt()
            };
            for f in [1.0 - 1e-15, 1.0, 1.0 + 1e-15] {
                let r = l.radius as f64;
                points.push(c + DVec3::new(1.0, 2.0, -0.5).normalize() * (r * f));
                points.push(c + rim(f) * (r * 0.999999));
                points.push(c + rim(f) * (r * 0.5));
            }
        }
        let grid = LightGrid::new(&points, &lights).expect("within its entries");
        let models = [Brdf::Lambert, Brdf::Ggx].map(|brdf| ShadingParams {
            brdf,
            ambient: 0.03,
            toon_bands: None,
            resolve: crate::common::MsaaResolve::Box,
            shadows: None,
        });
        let eye = DVec3::new(0.0, 2.0, 15.0);
        let mut reached = 0;
        for p in &points {
            let held = grid.lights_at(*p);
            assert!(held.windows(2).all(|w| w[0] < w[1]), "ascending");
            let s = Surface {
                position: *p,
                normal: (eye - *p).normalize(),
                albedo: DVec3::splat(0.7),
                roughness: 0.5,
                metallic: 0.0,
            };
            let to_eye = (eye - *p).normalize_or_zero();
            for (i, l) in lights.iter().enumerate() {
                if light_contribution(&s, to_eye, l, &models[0]) != DVec3::ZERO {
                    reached += 1;
                    assert!(
                        held.contains(&(i as u32)),
                        "light {i} reaches {p} but is not held"
                    );
                }
            }
            for params in &models {
                let all = shade(&s, eye, &lights, params);
                let near = held.iter().map(|&i| &lights[i as usize]);
                let some = shade_lights(&s, eye, near, params);
                let bits = |v: DVec3| v.to_array().map(f64::to_bits);
                assert_eq!(bits(all), bits(some));
            }
        }
        assert!(reached > 1000, "{reached}");
        // And the grid culls: most cells hold few of the lights.
        let held: usize = points.iter().map(|p| grid.lights_at(*p).len()).sum();
        assert!(held < points.len() * lights.len() / 5, "{held}");
    }

    #[test]
    fn a_few_lights_far_wider_than_the_rest_leave_no_grid() {
        let mut rng = Lcg(3);
        let mut lights: Vec<Light> = (0..1000)
            .map(|_| {
                let p = [0; 3].map(|_| rng.range(-10.0, 10.0) as f32);
                Light::point(p, 0.1, [1.0; 3], 1.0)
            })
            .collect();
        lights.extend((0..20).map(|_| Light::point([0.0; 3], 100.0, [1.0; 3], 1.0)));
        let points: Vec<DVec3> = (0..1000)
            .map(|_| rng.point([-10.0; 3], [10.0; 3]))
            .collect();
        assert!(LightGrid::new(&points, &lights).is_none());
        assert!(LightGrid::new(&points, &lights[..1000]).is_some());
    }
}
