//! Twin of `passes/assign_bvh.wesl`: Olsson 2012's light BVH. Lights are ordered by the
//! Morton code of the centre of their cluster range (then by index), and a tree of
//! `BVH_WIDTH` children a node is built over that order, each node the union of its
//! children's ranges; a cluster walks the tree to the lights whose range holds it. Bounds
//! are integer boxes of clusters (tiles across, down, slices), so a walk finds exactly the
//! lights one-level assignment walks for that cluster, with no slack to derive.

use super::sort::{NO_KEY, sorted_size};

/// Children of a node.
pub const BVH_WIDTH: u32 = 32;
/// A light's range of clusters as the GPU packs it (`light_range::cluster_span`):
/// x0 | x1 << 16, y0 | y1 << 16, k0 | k1 << 16, and 1 when the range is not empty.
pub type Range = [u32; 4];

/// Nodes of each level above the lights, from the lowest (one per `BVH_WIDTH` sorted
/// lights) to the root (one node).
pub fn level_sizes(n: u32) -> Vec<u32> {
    let mut sizes = vec![n.div_ceil(BVH_WIDTH)];
    while sizes[sizes.len() - 1] > 1 {
        sizes.push(sizes[sizes.len() - 1].div_ceil(BVH_WIDTH));
    }
    sizes
}

/// The first and last of a packed pair.
fn span(v: u32) -> (u32, u32) {
    (v & 0xffff, v >> 16)
}

/// Bits 0..10 of `v` spread to every third bit.
fn spread(v: u32) -> u32 {
    (0..10).fold(0, |out, b| out | ((v >> b) & 1) << (3 * b))
}

/// A range's Morton key: its centre in half clusters, scaled to 10 bits an axis, x in the
/// lowest bit; `NO_KEY` for an empty range.
pub fn morton_key(r: Range, grid: (u32, u32, u32)) -> u32 {
    if r[3] == 0 {
        return NO_KEY;
    }
    let axis = |v: u32, cells: u32| {
        let (a, b) = span(v);
        ((a + b) * 1024 / (2 * cells)).min(1023)
    };
    spread(axis(r[0], grid.0)) | spread(axis(r[1], grid.1)) << 1 | spread(axis(r[2], grid.2)) << 2
}

/// The sorted order: (key, light) by key then light, padded to `sorted_size` with
/// (`NO_KEY`, `NO_KEY`).
pub fn order(ranges: &[Range], grid: (u32, u32, u32)) -> Vec<[u32; 2]> {
    let mut order: Vec<[u32; 2]> = ranges
        .iter()
        .enumerate()
        .map(|(i, &r)| [morton_key(r, grid), i as u32])
        .collect();
    order.sort_unstable();
    order.resize(sorted_size(ranges.len() as u32) as usize, [NO_KEY; 2]);
    order
}

/// The union of two ranges (either may be empty).
fn union(a: Range, b: Range) -> Range {
    match (a[3], b[3]) {
        (0, _) => b,
        (_, 0) => a,
        _ => {
            let join = |u: u32, v: u32| {
                let ((a0, a1), (b0, b1)) = (span(u), span(v));
                a0.min(b0) | a1.max(b1) << 16
            };
            [join(a[0], b[0]), join(a[1], b[1]), join(a[2], b[2]), 1]
        }
    }
}

/// Every level's nodes, the lowest first, each the union of its children's ranges (padding
/// and missing children are empty).
pub fn nodes(order: &[[u32; 2]], ranges: &[Range]) -> Vec<Range> {
    let sizes = level_sizes(order.len() as u32);
    let light = |p: usize| match order.get(p) {
        Some(&[_, i]) if (i as usize) < ranges.len() => ranges[i as usize],
        _ => [0; 4],
    };
    let mut all: Vec<Range> = Vec::new();
    let mut below_start = 0;
    for (level, &size) in sizes.iter().enumerate() {
        let start = all.len();
        for m in 0..size as usize {
            let children = m * BVH_WIDTH as usize..(m + 1) * BVH_WIDTH as usize;
            let node = children.fold([0; 4], |acc, c| {
                let child = match level {
                    0 => light(c),
                    _ if c < start - below_start => all[below_start + c],
                    _ => [0; 4],
                };
                union(acc, child)
            });
            all.push(node);
        }
        below_start = start;
    }
    all
}

/// Whether range `r` holds cluster (x, y, k).
pub fn holds(r: Range, x: u32, y: u32, k: u32) -> bool {
    let inside = |v: u32, c: u32| {
        let (a, b) = span(v);
        a <= c && c <= b
    };
    r[3] != 0 && inside(r[0], x) && inside(r[1], y) && inside(r[2], k)
}

/// The lights whose range holds cluster (x, y, k), in sorted order, found by walking the
/// tree from the root: a node is entered only where its range holds the cluster.
pub fn walk(
    order: &[[u32; 2]],
    nodes: &[Range],
    ranges: &[Range],
    at: (u32, u32, u32),
) -> Vec<u32> {
    let sizes = level_sizes(order.len() as u32);
    let starts: Vec<usize> = sizes
        .iter()
        .scan(0, |start, &s| {
            let this = *start;
            *start += s as usize;
            Some(this)
        })
        .collect();
    let (x, y, k) = at;
    let mut found = Vec::new();
    // (level, node): level 0 the sorted lights, level l the nodes of `sizes[l - 1]`.
    let mut stack = vec![(sizes.len(), 0usize)];
    while let Some((level, node)) = stack.pop() {
        if level == 0 {
            let i = order[node][1];
            if (i as usize) < ranges.len() && holds(ranges[i as usize], x, y, k) {
                found.push(i);
            }
            continue;
        }
        if node < sizes[level - 1] as usize && holds(nodes[starts[level - 1] + node], x, y, k) {
            let first = node * BVH_WIDTH as usize;
            stack.extend(
                (first..first + BVH_WIDTH as usize)
                    .rev()
                    .map(|c| (level - 1, c)),
            );
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    fn range(x: (u32, u32), y: (u32, u32), k: (u32, u32)) -> Range {
        [x.0 | x.1 << 16, y.0 | y.1 << 16, k.0 | k.1 << 16, 1]
    }

    /// A walk finds exactly the lights whose range holds the cluster (every one of a
    /// brute-force search, none else), for ranges of every size over a small grid.
    #[test]
    fn a_walk_finds_exactly_the_ranges_that_hold_the_cluster() {
        let grid = (8, 5, 6);
        let mut seed = 7u32;
        let mut next = |m: u32| {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) % m
        };
        let mut ranges = Vec::new();
        for i in 0..1500 {
            if i % 17 == 0 {
                ranges.push([0; 4]);
                continue;
            }
            let mut axis = |cells: u32| {
                let a = next(cells);
                (a, (a + next(3)).min(cells - 1))
            };
            ranges.push(range(axis(grid.0), axis(grid.1), axis(grid.2)));
        }
        let order = order(&ranges, grid);
        assert_eq!(order.len(), 2048);
        let (lights, padding) = order.split_at(ranges.len());
        assert!(lights.windows(2).all(|w| w[0] < w[1]));
        assert!(padding.iter().all(|&e| e == [NO_KEY; 2]));
        let nodes = nodes(&order, &ranges);
        assert_eq!(nodes.len(), 64 + 2 + 1);
        for k in 0..grid.2 {
            for y in 0..grid.1 {
                for x in 0..grid.0 {
                    let mut got = walk(&order, &nodes, &ranges, (x, y, k));
                    got.sort_unstable();
                    let want: Vec<u32> = (0..ranges.len() as u32)
                        .filter(|&i| holds(ranges[i as usize], x, y, k))
                        .collect();
                    assert_eq!(got, want, "cluster ({x}, {y}, {k})");
                }
            }
        }
    }

    /// The Morton key puts x in the lowest bit, y next, then the slice, and leaves empty
    /// ranges last.
    #[test]
    fn morton_keys_interleave_x_y_and_slice() {
        let grid = (1024, 1024, 1024);
        let one = |x, y, k| morton_key(range((x, x), (y, y), (k, k)), grid);
        assert_eq!(one(0, 0, 0), 0);
        assert_eq!(one(1, 0, 0), 1);
        assert_eq!(one(0, 1, 0), 2);
        assert_eq!(one(0, 0, 1), 4);
        assert_eq!(one(3, 0, 0), 0b1001);
        assert_eq!(one(1023, 1023, 1023), (1 << 30) - 1);
        assert_eq!(morton_key([0; 4], grid), NO_KEY);
    }

    /// One node per BVH_WIDTH entries a level, up to the root.
    #[test]
    fn levels_shrink_by_the_width_to_one_root() {
        assert_eq!(level_sizes(512), vec![16, 1]);
        assert_eq!(level_sizes(1 << 18), vec![8192, 256, 8, 1]);
    }
}
