//! Twin of `passes/assign_bvh.wesl`: a linear BVH over the lights. Lights are ordered by the
//! Morton code of the centre of their range of clusters (then by index: the GPU's radix
//! sort is stable), and a binary radix tree is built over that order, each internal node
//! holding the union of its children's ranges. The GPU builds each node in parallel
//! (Karras 2012); this twin builds the same tree top down, from its definition: a node's
//! range of sorted entries splits where the highest bit of (key, position) that differs
//! across it turns to 1. Bounds are integer boxes of clusters (tiles across, down, slices),
//! so a walk finds exactly the lights one-level assignment walks, with no slack to derive.

/// Bits of a Morton digit each pass of the GPU's radix sort takes.
pub const RADIX_BITS: u32 = 6;
/// Invocations of a radix-sort workgroup, and the entries each counts and writes in order.
pub const RADIX_LANES: u32 = 32;
pub const RADIX_ITEMS: u32 = 32;
/// Words of the radix sort's counts before the counts (the pass numbers).
pub const RADIX_HEADER: u32 = 2;
/// Clusters across, down and deep of the tile that walks the tree once for all its
/// clusters.
pub const TILE: (u32, u32, u32) = (4, 4, 4);
/// Bits of a Morton code an axis holds at most (3 x 10 fit a word).
const MAX_AXIS_BITS: u32 = 10;
/// Marks a child that is a leaf (its sorted position) rather than an internal node.
pub const LEAF: u32 = 0x8000_0000;

/// A light's range of clusters as the GPU packs it (`light_range::cluster_span`):
/// x0 | x1 << 16, y0 | y1 << 16, k0 | k1 << 16, and 1 when the range is not empty.
pub type Range = [u32; 4];
/// A node's bounds: the x, y and slice spans, packed as a range's; `EMPTY_SPAN`s meet
/// nothing.
pub type Bounds = [u32; 3];
/// The packed span of no cluster: first 0xffff, last 0.
pub const EMPTY_SPAN: u32 = 0xffff;

/// How a range's centre becomes a Morton axis: its bits, and the shift that brings the
/// largest centre (in half clusters, 2 (cells - 1)) to at most MAX_AXIS_BITS bits.
pub fn morton_axis(grid: (u32, u32, u32)) -> (u32, u32) {
    let most = 2 * (grid.0.max(grid.1).max(grid.2).max(1) - 1);
    let bits = (u32::BITS - most.leading_zeros()).max(1);
    (bits.min(MAX_AXIS_BITS), bits.saturating_sub(MAX_AXIS_BITS))
}

/// Passes of the radix sort: enough digits for every bit of a Morton code.
pub fn radix_passes(grid: (u32, u32, u32)) -> u32 {
    (3 * morton_axis(grid).0).div_ceil(RADIX_BITS)
}

/// Bits 0..10 of `v` spread to every third bit.
fn spread(v: u32) -> u32 {
    (0..MAX_AXIS_BITS).fold(0, |out, b| out | ((v >> b) & 1) << (3 * b))
}

/// The first and last of a packed pair.
fn span(v: u32) -> (u32, u32) {
    (v & 0xffff, v >> 16)
}

/// A range's Morton code: its centre in half clusters, x in the lowest bit; an empty
/// range's is the largest code.
pub fn morton_key(r: Range, grid: (u32, u32, u32)) -> u32 {
    let (bits, shift) = morton_axis(grid);
    if r[3] == 0 {
        return (1 << (3 * bits)) - 1;
    }
    let axis = |v: u32| {
        let (a, b) = span(v);
        spread((a + b) >> shift)
    };
    axis(r[0]) | axis(r[1]) << 1 | axis(r[2]) << 2
}

/// The sorted order: (key, light) by key, then light.
pub fn order(ranges: &[Range], grid: (u32, u32, u32)) -> Vec<[u32; 2]> {
    let mut order: Vec<[u32; 2]> = ranges
        .iter()
        .enumerate()
        .map(|(i, &r)| [morton_key(r, grid), i as u32])
        .collect();
    order.sort_unstable();
    order
}

/// An internal node: its children (an internal node's index, or `LEAF` | a sorted
/// position), the count of sorted entries under it, and its parent (the root's 0).
pub type Node = [u32; 4];

/// The tree over a sorted order, node 0 the root; n entries make n - 1 nodes.
pub fn tree(order: &[[u32; 2]]) -> Vec<Node> {
    let n = order.len();
    let mut nodes = vec![[0; 4]; n.saturating_sub(1)];
    // (key, position): unique, so every range of two or more entries splits.
    let code = |p: usize| (order[p][0] as u64) << 32 | p as u64;
    let mut ranges = vec![(0, n.saturating_sub(1), 0)];
    while let Some((first, last, node)) = ranges.pop() {
        if first == last {
            continue;
        }
        // The highest bit that differs across the range: entries up to `split` have it 0.
        let differs = 63 - (code(first) ^ code(last)).leading_zeros();
        let (mut split, mut above) = (first, last);
        while above - split > 1 {
            let mid = (split + above) / 2;
            match code(mid) >> differs == code(first) >> differs {
                true => split = mid,
                false => above = mid,
            }
        }
        // Karras's numbering: an internal child is named by its range's end at the split.
        let child = |a: usize, b: usize, at: usize| match a == b {
            true => LEAF | a as u32,
            false => at as u32,
        };
        let [left, right] = [
            child(first, split, split),
            child(split + 1, last, split + 1),
        ];
        nodes[node][..3].copy_from_slice(&[left, right, (last - first + 1) as u32]);
        for c in [left, right].into_iter().filter(|&c| c & LEAF == 0) {
            nodes[c as usize][3] = node as u32;
        }
        ranges.push((first, split, split));
        ranges.push((split + 1, last, split + 1));
    }
    nodes
}

/// Each leaf's parent, by sorted position.
pub fn leaf_parents(nodes: &[Node]) -> Vec<u32> {
    let mut parents = vec![0; nodes.len() + 1];
    for (i, node) in nodes.iter().enumerate() {
        for &c in node[..2].iter().filter(|&&c| c & LEAF != 0) {
            parents[(c & !LEAF) as usize] = i as u32;
        }
    }
    parents
}

/// A light's range as bounds.
pub fn light_bounds(r: Range) -> Bounds {
    match r[3] {
        0 => [EMPTY_SPAN; 3],
        _ => [r[0], r[1], r[2]],
    }
}

/// The union of two bounds.
fn join(a: Bounds, b: Bounds) -> Bounds {
    std::array::from_fn(|k| {
        let ((a0, a1), (b0, b1)) = (span(a[k]), span(b[k]));
        a0.min(b0) | a1.max(b1) << 16
    })
}

/// Each internal node's bounds: the union of its children's.
pub fn bounds(order: &[[u32; 2]], nodes: &[Node], ranges: &[Range]) -> Vec<Bounds> {
    let mut bounds = vec![[EMPTY_SPAN; 3]; nodes.len()];
    // Children before parents: a node's internal children are visited after it going down,
    // so the reverse of a depth-first order is bottom up.
    let mut down = Vec::with_capacity(nodes.len());
    let mut stack = if nodes.is_empty() { vec![] } else { vec![0] };
    while let Some(node) = stack.pop() {
        down.push(node);
        stack.extend(
            nodes[node][..2]
                .iter()
                .filter(|&&c| c & LEAF == 0)
                .map(|&c| c as usize),
        );
    }
    for &node in down.iter().rev() {
        bounds[node] = nodes[node][..2]
            .iter()
            .map(|&c| child_bounds(c, order, &bounds, ranges))
            .fold([EMPTY_SPAN; 3], join);
    }
    bounds
}

fn child_bounds(code: u32, order: &[[u32; 2]], bounds: &[Bounds], ranges: &[Range]) -> Bounds {
    match code & LEAF {
        0 => bounds[code as usize],
        _ => light_bounds(ranges[order[(code & !LEAF) as usize][1] as usize]),
    }
}

/// The first node (as `node: child`) whose bounds do not cover a child's: none in a tree
/// the walks can trust.
pub fn uncovered(
    order: &[[u32; 2]],
    nodes: &[Node],
    bounds: &[Bounds],
    ranges: &[Range],
) -> Option<String> {
    (0..nodes.len()).find_map(|node| {
        nodes[node][..2].iter().find_map(|&c| {
            let child = child_bounds(c, order, bounds, ranges);
            (join(bounds[node], child) != bounds[node] && child != [EMPTY_SPAN; 3])
                .then(|| format!("node {node}: child {c:#x}"))
        })
    })
}

/// Whether bounds meet the clusters [lo, hi] (each (x, y, slice)).
pub fn meets(b: Bounds, lo: [u32; 3], hi: [u32; 3]) -> bool {
    (0..3).all(|k| {
        let (first, last) = span(b[k]);
        first <= hi[k] && last >= lo[k]
    })
}

/// The lights whose range meets the clusters [lo, hi], in the walk's order (left child
/// first), found by walking the tree from the root: a node is entered only where its
/// bounds meet them.
pub fn walk(
    order: &[[u32; 2]],
    nodes: &[Node],
    bounds: &[Bounds],
    ranges: &[Range],
    (lo, hi): ([u32; 3], [u32; 3]),
) -> Vec<u32> {
    let mut found = Vec::new();
    let mut stack = match order.len() {
        0 => vec![],
        1 => vec![LEAF],
        _ => vec![0],
    };
    while let Some(code) = stack.pop() {
        if code & LEAF != 0 {
            let i = order[(code & !LEAF) as usize][1];
            if meets(light_bounds(ranges[i as usize]), lo, hi) {
                found.push(i);
            }
        } else if meets(bounds[code as usize], lo, hi) {
            let [left, right, ..] = nodes[code as usize];
            stack.extend([right, left]);
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

    /// Seeded ranges over `grid`, every 17th empty, many sharing a centre.
    fn ranges(count: usize, grid: (u32, u32, u32)) -> Vec<Range> {
        let mut seed = 7u32;
        let mut next = |m: u32| {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) % m
        };
        (0..count)
            .map(|i| {
                if i % 17 == 0 {
                    return [0; 4];
                }
                let mut axis = |cells: u32| {
                    let a = next(cells);
                    (a, (a + next(3)).min(cells - 1))
                };
                range(axis(grid.0), axis(grid.1), axis(grid.2))
            })
            .collect()
    }

    /// A walk for a cluster, and for a tile of clusters, finds exactly the lights whose
    /// range meets it (every one of a brute-force search, none else), at every size that
    /// has an edge: 1, 2, a power of two and one more.
    #[test]
    fn a_walk_finds_exactly_the_ranges_that_meet_the_clusters() {
        let grid = (8, 5, 6);
        for count in [1, 2, 3, 1024, 1025, 1500] {
            let ranges = ranges(count, grid);
            let order = order(&ranges, grid);
            let nodes = tree(&order);
            let bounds = bounds(&order, &nodes, &ranges);
            assert_eq!(uncovered(&order, &nodes, &bounds, &ranges), None);
            for k in 0..grid.2 {
                for y in 0..grid.1 {
                    for x in 0..grid.0 {
                        for side in [1, 2] {
                            let lo = [x, y, k];
                            let hi = [x + side - 1, y + side - 1, k + side - 1];
                            let mut got = walk(&order, &nodes, &bounds, &ranges, (lo, hi));
                            got.sort_unstable();
                            let want: Vec<u32> = (0..count as u32)
                                .filter(|&i| meets(light_bounds(ranges[i as usize]), lo, hi))
                                .collect();
                            assert_eq!(got, want, "{count} lights, clusters {lo:?}..{hi:?}");
                        }
                    }
                }
            }
        }
    }

    /// Every node but the root is one node's child, its parent that node, and each internal
    /// node holds its two children's entries: a binary tree over the order.
    #[test]
    fn the_tree_is_a_binary_tree_over_the_order() {
        let grid = (8, 5, 6);
        for count in [2, 3, 4, 5, 1025] {
            let order = order(&ranges(count, grid), grid);
            let nodes = tree(&order);
            let leaf_parents = leaf_parents(&nodes);
            let mut seen = vec![0; 2 * count - 1];
            for (i, node) in nodes.iter().enumerate() {
                for &c in &node[..2] {
                    let parent = match c & LEAF {
                        0 => nodes[c as usize][3],
                        _ => leaf_parents[(c & !LEAF) as usize],
                    };
                    assert_eq!(parent, i as u32, "{count}: {c:#x}");
                    seen[match c & LEAF {
                        0 => c as usize,
                        _ => count - 1 + (c & !LEAF) as usize,
                    }] += 1;
                }
                let size = |c: u32| {
                    if c & LEAF == 0 {
                        nodes[c as usize][2]
                    } else {
                        1
                    }
                };
                assert_eq!(node[2], size(node[0]) + size(node[1]), "{count}: {node:?}");
            }
            assert_eq!(seen[0], 0, "{count}: the root has no parent");
            assert_eq!(nodes[0][2], count as u32, "{count}: the root's size");
            assert!(seen[1..].iter().all(|&s| s == 1), "{count}: {seen:?}");
        }
    }

    /// The Morton code puts x in the lowest bit, y next, then the slice, and leaves empty
    /// ranges last; a grid too fine for 10 bits an axis is shifted down.
    #[test]
    fn morton_codes_interleave_x_y_and_slice() {
        let grid = (512, 512, 512);
        assert_eq!(morton_axis(grid), (10, 0));
        let one = |x, y, k| morton_key(range((x, x), (y, y), (k, k)), grid);
        assert_eq!(one(0, 0, 0), 0);
        assert_eq!(one(1, 0, 0), 0b1000);
        assert_eq!(one(0, 1, 0), 0b10000);
        assert_eq!(morton_key(range((0, 1), (0, 0), (0, 0)), grid), 1);
        assert_eq!(one(511, 511, 511), (1 << 30) - 1 - 0b111);
        assert_eq!(morton_key([0; 4], grid), (1 << 30) - 1);
        assert_eq!(morton_axis((20, 12, 256)), (9, 0));
        assert_eq!(radix_passes((20, 12, 256)), 5);
        assert_eq!(morton_axis((2000, 1, 1)), (10, 2));
    }
}
