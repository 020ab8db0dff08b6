//! Twin of `shaders/passes/zbin_assign.wesl` and z-binning's light loop (Drobot 2017): lights
//! sorted by view depth, a range of sorted lights per depth bin, a bitmask of lights per
//! tile, in f64; and the same structure read back from the GPU, walked the same way.

use super::clusters::{ClusterLists, Grid, ViewLight, sphere_touches_tile};

/// Bins and tile masks over a grid's tiles (x, y) and slices (the bins).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ZBins {
    pub tiles: (u32, u32),
    /// Light indices in sorted order.
    pub order: Vec<u32>,
    /// Per bin, the first and last sorted position of a light that may reach it.
    pub bins: Vec<Option<(u32, u32)>>,
    /// Per tile, `words` words of one bit per sorted light.
    pub masks: Vec<u32>,
    pub words: usize,
}

impl ZBins {
    /// The twin: lights sorted by the view depth of their sphere's centre (then index; lights
    /// wholly in front of the near plane last), each binned into the slices its depth range
    /// [max(-(z + r), near), -(z - r)] spans and masked into the tiles its sphere reaches.
    pub fn build(grid: &Grid, lights: &[ViewLight]) -> ZBins {
        let reaches = |l: &ViewLight| l.center.z - l.radius <= -grid.near;
        let mut order: Vec<u32> = (0..lights.len() as u32).collect();
        let key = |i: u32| {
            let l = &lights[i as usize];
            (!reaches(l), if reaches(l) { -l.center.z } else { 0.0 }, i)
        };
        order.sort_by(|&a, &b| key(a).partial_cmp(&key(b)).expect("finite depths"));
        let slices = grid.slices();
        let words = lights.len().div_ceil(32);
        let tiles = (grid.x * grid.y) as usize;
        let mut bins: Vec<Option<(u32, u32)>> = vec![None; grid.z as usize];
        let mut masks = vec![0u32; tiles * words];
        for (s, &i) in order.iter().enumerate() {
            let l = &lights[i as usize];
            if !reaches(l) {
                continue;
            }
            let s = s as u32;
            let near = (-(l.center.z + l.radius)).max(grid.near);
            for k in slices.slice(near)..=slices.slice(-(l.center.z - l.radius)) {
                let b = &mut bins[k as usize];
                *b = Some(b.map_or((s, s), |(a, z)| (a.min(s), z.max(s))));
            }
            for y in 0..grid.y {
                for x in 0..grid.x {
                    if sphere_touches_tile(grid, l.center, l.radius, x, y) {
                        let t = (x + grid.x * y) as usize;
                        masks[t * words + s as usize / 32] |= 1 << (s % 32);
                    }
                }
            }
        }
        ZBins {
            tiles: (grid.x, grid.y),
            order,
            bins,
            masks,
            words,
        }
    }

    /// The GPU's buffers as read back: `order`, bins stored as (!first, last + 1) pairs
    /// (0 for none), and the tile masks.
    pub fn from_gpu(tiles: (u32, u32), order: Vec<u32>, bins: &[u32], masks: Vec<u32>) -> ZBins {
        let words = order.len().div_ceil(32);
        ZBins {
            tiles,
            bins: bins
                .chunks_exact(2)
                .map(|b| (b[1] != 0).then(|| (!b[0], b[1] - 1)))
                .collect(),
            order,
            masks,
            words,
        }
    }

    /// The lights a pixel of tile (x, y) in bin k walks, in walking (depth) order.
    pub fn walk(&self, x: u32, y: u32, k: u32) -> Vec<u32> {
        let Some((first, last)) = self.bins[k as usize] else {
            return Vec::new();
        };
        let t = (x + self.tiles.0 * y) as usize;
        let mask = &self.masks[t * self.words..(t + 1) * self.words];
        (first..=last)
            .filter(|&s| mask[s as usize / 32] & (1 << (s % 32)) != 0)
            .map(|s| self.order[s as usize])
            .collect()
    }

    /// Lights walked in each cell (tile x, y, bin k), indexed as clusters.
    pub fn counts(&self) -> Vec<u32> {
        let (tx, ty) = self.tiles;
        let mut out = Vec::with_capacity((tx * ty) as usize * self.bins.len());
        for k in 0..self.bins.len() as u32 {
            for y in 0..ty {
                for x in 0..tx {
                    out.push(self.count(x, y, k));
                }
            }
        }
        out
    }

    /// Lights a pixel of tile (x, y) in bin k walks, by counting mask bits word by word.
    fn count(&self, x: u32, y: u32, k: u32) -> u32 {
        let Some((first, last)) = self.bins[k as usize] else {
            return 0;
        };
        let t = (x + self.tiles.0 * y) as usize;
        (first / 32..=last / 32)
            .map(|w| {
                let lo = first.max(32 * w) - 32 * w;
                let hi = last.min(32 * w + 31) - 32 * w;
                let span = (u32::MAX << lo) & (u32::MAX >> (31 - hi));
                (self.masks[t * self.words + w as usize] & span).count_ones()
            })
            .sum()
    }

    /// Each cell's lights as a cluster list (ascending light index), indexed as clusters.
    pub fn lists(&self) -> ClusterLists {
        let (tx, ty) = self.tiles;
        let mut out = ClusterLists::default();
        for k in 0..self.bins.len() as u32 {
            for y in 0..ty {
                for x in 0..tx {
                    let mut list = self.walk(x, y, k);
                    list.sort_unstable();
                    out.push(list);
                }
            }
        }
        out
    }
}
