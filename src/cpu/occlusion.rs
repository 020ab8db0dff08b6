//! Visibility for shadows, in f64 (the groundwork of exact shadows): a bounding volume
//! hierarchy over a scene's triangles, and the watertight ray-triangle test of Woop, Benthin
//! & Wald 2013, which never lets a ray through the crack between two triangles that share
//! an edge. A segment from a surface point to a light's centre is blocked when it crosses a
//! triangle strictly between `t_min` and its end.
//!
//! The tree is built once per scene by binned surface-area-heuristic splits of the
//! triangles' centroids (median splits on the longest axis where SAH finds none, and where
//! the levels left would not hold SAH's deepest tree), `LEAF_TRIANGLES` at most a leaf; a
//! node's box is the union of its triangles'.
//! Triangles of no area (repeated or collinear corners) are counted and left out: they hide
//! nothing and would only add NaN to the tests.

use std::ops::ControlFlow;

use glam::DVec3;

/// Deepest tree the shaders' traversal stack holds (`SHADOW_STACK`, generated from this):
/// the build turns to median splits, which halve the triangles at each level, where SAH's
/// could go deeper, so 2^31 triangles stay within it.
pub const SHADOW_STACK: u32 = 32;

/// Most triangles a leaf holds.
pub const LEAF_TRIANGLES: usize = 4;

/// A node: its box, and either two children or a run of triangles of `order`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    pub min: DVec3,
    pub max: DVec3,
    /// Leaf: the first of its triangles in `order`; inner: its first child (the second
    /// follows it: children are made in pairs).
    pub first: u32,
    /// Triangles of a leaf; 0 for an inner node.
    pub count: u32,
}

/// A scene's triangles and their tree.
#[derive(Clone, Debug)]
pub struct TriangleBvh {
    pub nodes: Vec<Node>,
    /// The triangles that hide anything, by corner.
    pub triangles: Vec<[DVec3; 3]>,
    /// Triangles in leaf order: leaves hold runs of it.
    pub order: Vec<u32>,
    /// Triangles of the scene left out for having no area.
    pub degenerate: usize,
}

/// What a shadow ray finds between its ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Seen {
    /// No triangle near the segment: the light reaches the point.
    Open,
    /// A triangle crosses it with room to spare: the light is blocked.
    Blocked,
    /// A triangle passes within the GPU's error of it: either answer is right.
    Ambiguous,
}

/// What one query did: nodes whose box it tested, triangles it tested.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Visits {
    pub nodes: u32,
    pub triangles: u32,
}

impl TriangleBvh {
    /// The tree of the triangles `indices` makes of `positions` (three indices a triangle).
    pub fn build(positions: &[[f32; 3]], indices: &[u32]) -> Self {
        let corner = |i: u32| DVec3::from(positions[i as usize].map(f64::from));
        let mut triangles = Vec::new();
        let mut degenerate = 0;
        for t in indices.chunks_exact(3) {
            let [a, b, c] = [corner(t[0]), corner(t[1]), corner(t[2])];
            if (b - a).cross(c - a).length_squared() > 0.0 {
                triangles.push([a, b, c]);
            } else {
                degenerate += 1;
            }
        }
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let mut nodes = vec![Node {
            min: DVec3::ZERO,
            max: DVec3::ZERO,
            first: 0,
            count: 0,
        }];
        let centroid = |t: u32| {
            let [a, b, c] = triangles[t as usize];
            (a + b + c) / 3.0
        };
        let bounds = |t: u32| {
            let [a, b, c] = triangles[t as usize];
            (a.min(b).min(c), a.max(b).max(c))
        };
        // (node, first, end, level) still to make.
        let mut todo = vec![(0usize, 0usize, order.len(), 1u32)];
        while let Some((at, first, end, level)) = todo.pop() {
            let (min, max) = order[first..end].iter().map(|&t| bounds(t)).fold(
                (DVec3::INFINITY, DVec3::NEG_INFINITY),
                |(lo, hi), (a, b)| (lo.min(a), hi.max(b)),
            );
            nodes[at].min = min;
            nodes[at].max = max;
            let count = end - first;
            if count <= LEAF_TRIANGLES {
                nodes[at].first = first as u32;
                nodes[at].count = count as u32;
                continue;
            }
            let run = &mut order[first..end];
            // Median splits from where the levels left would not hold SAH's worst case.
            let levels_needed = (count.div_ceil(LEAF_TRIANGLES)).next_power_of_two().ilog2();
            let sah = (level + levels_needed < SHADOW_STACK)
                .then(|| sah_split(run, &centroid, &bounds))
                .flatten();
            let half = match sah {
                Some(half) => half,
                None => {
                    let (lo, hi) = run
                        .iter()
                        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &t| {
                            (lo.min(centroid(t)), hi.max(centroid(t)))
                        });
                    let axis = (hi - lo).max_position();
                    let half = count / 2;
                    run.select_nth_unstable_by(half, |&a, &b| {
                        centroid(a)[axis].total_cmp(&centroid(b)[axis])
                    });
                    half
                }
            };
            let child = nodes.len();
            nodes[at].first = child as u32;
            nodes.extend([nodes[at]; 2]);
            todo.push((child, first, first + half, level + 1));
            todo.push((child + 1, first + half, end, level + 1));
        }
        if triangles.is_empty() {
            nodes[0].min = DVec3::ZERO;
            nodes[0].max = DVec3::ZERO;
        }
        Self {
            nodes,
            triangles,
            order,
            degenerate,
        }
    }

    /// Walk the nodes whose box `meets` holds, and give each of their leaves' triangles to
    /// `triangle` until it breaks; what the walk visited.
    fn walk(
        &self,
        meets: impl Fn(&Node) -> bool,
        mut triangle: impl FnMut([DVec3; 3]) -> ControlFlow<()>,
    ) -> Visits {
        let mut visits = Visits::default();
        if self.triangles.is_empty() {
            return visits;
        }
        let mut stack = vec![0u32];
        while let Some(at) = stack.pop() {
            let node = self.nodes[at as usize];
            visits.nodes += 1;
            if !meets(&node) {
                continue;
            }
            if node.count == 0 {
                stack.extend([node.first, node.first + 1]);
                continue;
            }
            for &t in &self.order[node.first as usize..(node.first + node.count) as usize] {
                visits.triangles += 1;
                if triangle(self.triangles[t as usize]).is_break() {
                    return visits;
                }
            }
        }
        visits
    }

    /// Whether a triangle crosses the segment from `from` to `to` at a fraction `t` of it
    /// with `t_min < t < 1`, and what the walk visited.
    pub fn blocked(&self, from: DVec3, to: DVec3, t_min: f64) -> (bool, Visits) {
        let dir = to - from;
        let inverse = dir.recip();
        let mut blocked = false;
        let visits = self.walk(
            |node| box_meets(node.min, node.max, from, inverse, t_min),
            |triangle| {
                blocked = hit(from, dir, triangle).is_some_and(|t| t > t_min && t < 1.0);
                if blocked {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            },
        );
        (blocked, visits)
    }

    /// What a segment within `reach` of `from`-`to` (every point of it moved by at most
    /// `reach`: the GPU's ray, whose ends lie that close) finds: `Blocked` where every such
    /// segment crosses a triangle, `Open` where none meets one, `Ambiguous` otherwise. A
    /// triangle decides `Blocked` when the segment crosses it, both ends lie farther than
    /// `reach` from its plane and the segment passes farther than `reach` from its edges
    /// (moving the segment continuously to any other within reach, its crossing could
    /// leave the triangle only through an edge or an end); it cannot block any of them
    /// when the segment passes farther than `reach` from it.
    ///
    /// The reach of each test is the GPU's error for the coordinates that test handles
    /// (`Reach::at`): the segment's ends and the triangle's corners (or the node's box),
    /// never the scene's largest coordinate, so that a far light or a vast floor widens
    /// only the rays whose arithmetic meets it.
    pub fn classify(&self, from: DVec3, to: DVec3, reach: Reach) -> (Seen, Visits) {
        let inverse = (to - from).recip();
        let ends = largest(from).max(largest(to));
        let mut near = Vec::new();
        let mut widest: f64 = 0.0;
        let mut blocked = false;
        let visits = self.walk(
            // A segment within reach of a triangle meets its node's box grown by reach.
            |node| {
                let r = reach.at(ends.max(largest(node.min)).max(largest(node.max)));
                box_meets(node.min - r, node.max + r, from, inverse, 0.0)
            },
            |triangle| {
                let r = reach.at(triangle.iter().fold(ends, |m, &v| m.max(largest(v))));
                match triangle_seen(from, to, triangle, r) {
                    Seen::Blocked => {
                        blocked = true;
                        ControlFlow::Break(())
                    }
                    Seen::Ambiguous => {
                        near.push(triangle);
                        widest = widest.max(r);
                        ControlFlow::Continue(())
                    }
                    Seen::Open => ControlFlow::Continue(()),
                }
            },
        );
        if blocked {
            return (Seen::Blocked, visits);
        }
        let seen = match near.is_empty() {
            true => Seen::Open,
            false => patch_seen(from, to, &near, widest),
        };
        (seen, visits)
    }

    /// Levels of the tree: 1 where the root is a leaf.
    pub fn depth(&self) -> u32 {
        let mut deepest = 0;
        let mut stack = vec![(0u32, 1u32)];
        while let Some((at, level)) = stack.pop() {
            deepest = deepest.max(level);
            let node = self.nodes[at as usize];
            if node.count == 0 && !self.triangles.is_empty() {
                stack.extend([(node.first, level + 1), (node.first + 1, level + 1)]);
            }
        }
        deepest
    }

    /// Whether every node's box holds its children's (inner) or its triangles (leaf): the
    /// tree finds every hit only then.
    pub fn covers(&self) -> bool {
        let holds = |outer: &Node, min: DVec3, max: DVec3| {
            outer.min.cmple(min).all() && outer.max.cmpge(max).all()
        };
        self.nodes.iter().all(|n| {
            if n.count == 0 {
                let [a, b] = [
                    self.nodes[n.first as usize],
                    self.nodes[n.first as usize + 1],
                ];
                holds(n, a.min, a.max) && holds(n, b.min, b.max)
            } else {
                self.order[n.first as usize..(n.first + n.count) as usize]
                    .iter()
                    .all(|&t| {
                        let [a, b, c] = self.triangles[t as usize];
                        holds(n, a.min(b).min(c), a.max(b).max(c))
                    })
            }
        })
    }
}

/// How far the GPU's segment may lie from the reference's in a test: a part the test's
/// coordinates do not change (the shading position's and normal's errors, the lift's) and
/// a part per unit of the largest coordinate it handles (f32 rounding in the traversal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reach {
    pub fixed: f64,
    pub per_coordinate: f64,
}

impl Reach {
    /// The same reach for every test (`per_coordinate` 0).
    pub const fn fixed(reach: f64) -> Reach {
        Reach {
            fixed: reach,
            per_coordinate: 0.0,
        }
    }

    /// The reach of a test whose largest coordinate is `largest`.
    pub fn at(&self, largest: f64) -> f64 {
        self.fixed + self.per_coordinate * largest
    }
}

/// The largest absolute coordinate of `v`.
fn largest(v: DVec3) -> f64 {
    v.abs().max_element()
}

/// Whether the segment `from + t dir`, `t_min <= t <= 1`, meets the box (slab test; a
/// direction of 0 along an axis has an infinite inverse, and a ray on a slab's plane is
/// kept, never lost).
fn box_meets(min: DVec3, max: DVec3, from: DVec3, inverse: DVec3, t_min: f64) -> bool {
    let (mut near, mut far) = (t_min, 1.0f64);
    for k in 0..3 {
        let (a, b) = (
            (min[k] - from[k]) * inverse[k],
            (max[k] - from[k]) * inverse[k],
        );
        // 0 x inf (the ray on a slab's plane) is NaN: that axis constrains nothing.
        let (lo, hi) = if a.is_nan() || b.is_nan() {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            (a.min(b), a.max(b))
        };
        near = near.max(lo);
        far = far.min(hi);
    }
    near <= far
}

/// Bins of the surface area heuristic's split search, per axis.
const SAH_BINS: usize = 16;

/// Split `run` where the surface area heuristic (binned, on the centroids) finds the
/// cheapest pair of children, putting the first child's triangles first; None where no
/// split beats the median (all centroids in one bin).
fn sah_split(
    run: &mut [u32],
    centroid: &impl Fn(u32) -> DVec3,
    bounds: &impl Fn(u32) -> (DVec3, DVec3),
) -> Option<usize> {
    let (lo, hi) = run
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &t| {
            (lo.min(centroid(t)), hi.max(centroid(t)))
        });
    let area = |(a, b): (DVec3, DVec3)| {
        let d = (b - a).max(DVec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    };
    let join = |(a, b): (DVec3, DVec3), (c, d): (DVec3, DVec3)| (a.min(c), b.max(d));
    let empty = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let bin_of = |t: u32, axis: usize| {
        let b = (centroid(t)[axis] - lo[axis]) / (hi[axis] - lo[axis]) * SAH_BINS as f64;
        (b as usize).min(SAH_BINS - 1)
    };
    // The cheapest split: (cost, axis, the first bin of the second child).
    let mut best: Option<(f64, usize, usize)> = None;
    for axis in (0..3).filter(|&a| hi[a] > lo[a]) {
        let mut bins = [(0usize, empty); SAH_BINS];
        for &t in run.iter() {
            let b = &mut bins[bin_of(t, axis)];
            *b = (b.0 + 1, join(b.1, bounds(t)));
        }
        // Cost of splitting before bin k: each side's area times its triangles.
        let mut lefts = [(0usize, empty); SAH_BINS];
        let mut left = (0usize, empty);
        for (k, bin) in bins.iter().enumerate() {
            left = (left.0 + bin.0, join(left.1, bin.1));
            lefts[k] = left;
        }
        let mut right = (0usize, empty);
        for k in (1..SAH_BINS).rev() {
            right = (right.0 + bins[k].0, join(right.1, bins[k].1));
            let l = lefts[k - 1];
            if l.0 == 0 || right.0 == 0 {
                continue;
            }
            let cost = area(l.1) * l.0 as f64 + area(right.1) * right.0 as f64;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, k));
            }
        }
    }
    let (_, axis, k) = best?;
    let mut ahead = 0;
    for i in 0..run.len() {
        if bin_of(run[i], axis) < k {
            run.swap(i, ahead);
            ahead += 1;
        }
    }
    (ahead > 0 && ahead < run.len()).then_some(ahead)
}

/// What the segment `a`-`b` finds of `triangle` within `reach` (`TriangleBvh::classify`).
fn triangle_seen(a: DVec3, b: DVec3, triangle: [DVec3; 3], reach: f64) -> Seen {
    let [p, q, r] = triangle;
    let normal = (q - p).cross(r - p).normalize();
    let (da, db) = (normal.dot(a - p), normal.dot(b - p));
    // Both ends on one side, farther than `reach` from the plane: nothing within reach.
    if (da > reach && db > reach) || (da < -reach && db < -reach) {
        return Seen::Open;
    }
    let edges = [(p, q), (q, r), (r, p)];
    let to_edges = edges
        .iter()
        .map(|&(e0, e1)| segment_distance(a, b, e0, e1))
        .fold(f64::INFINITY, f64::min);
    let crosses = da * db < 0.0 && {
        let x = a + (b - a) * (da / (da - db));
        inside(x, triangle, normal)
    };
    if crosses {
        let clear = to_edges > reach && da.abs() > reach && db.abs() > reach;
        return if clear {
            Seen::Blocked
        } else {
            Seen::Ambiguous
        };
    }
    // Missed: its distance is to an edge, or from an end to the face.
    let end_in_face =
        |x: DVec3, d: f64| d.abs() <= reach && inside(x - normal * d, triangle, normal);
    if to_edges <= reach || end_in_face(a, da) || end_in_face(b, db) {
        Seen::Ambiguous
    } else {
        Seen::Open
    }
}

/// What the segment `a`-`b` finds of `near`, the triangles within `reach` of it, none of
/// which decides alone: where they form a patch whose boundary (the edges only one of
/// them has) lies farther than `reach` from the segment, and both ends lie farther than
/// `reach` from every one of them, every segment within reach crosses the patch as many
/// times as this one does, modulo 2 (moving it continuously, a crossing appears or goes
/// only through the boundary or at an end); an odd count is a crossing for all of them,
/// which a watertight test finds. Typically a ray through the shared edge of two
/// triangles of one surface.
fn patch_seen(a: DVec3, b: DVec3, near: &[[DVec3; 3]], reach: f64) -> Seen {
    let key = |p: DVec3| p.to_array().map(f64::to_bits);
    let mut edges: std::collections::HashMap<_, (u32, DVec3, DVec3)> = Default::default();
    for &[p, q, r] in near {
        for (e0, e1) in [(p, q), (q, r), (r, p)] {
            let k = if key(e0) <= key(e1) {
                (key(e0), key(e1))
            } else {
                (key(e1), key(e0))
            };
            edges.entry(k).or_insert((0, e0, e1)).0 += 1;
        }
    }
    let boundary_near = edges
        .values()
        .any(|&(n, e0, e1)| n == 1 && segment_distance(a, b, e0, e1) <= reach);
    let end_near = near
        .iter()
        .any(|&t| point_triangle_distance(a, t) <= reach || point_triangle_distance(b, t) <= reach);
    if boundary_near || end_near {
        return Seen::Ambiguous;
    }
    // Every segment within reach crosses as often, modulo 2: count on one that passes no
    // edge (this one, or one moved by a small part of `reach` in a direction of no
    // particular axis, where this one runs through an edge).
    let shifts = [
        DVec3::ZERO,
        DVec3::new(0.31, 0.57, 0.76),
        DVec3::new(-0.66, 0.24, 0.71),
    ];
    for shift in shifts.map(|w| w * (reach * 1e-3)) {
        if let Some(crossings) = crossings(a + shift, b + shift, near, reach * 1e-6) {
            return if crossings % 2 == 1 {
                Seen::Blocked
            } else {
                Seen::Ambiguous
            };
        }
    }
    Seen::Ambiguous
}

/// How many of `triangles` the segment `a`-`b` crosses; None where it passes within
/// `tolerance` of an edge, where the count could take one crossing twice.
fn crossings(a: DVec3, b: DVec3, triangles: &[[DVec3; 3]], tolerance: f64) -> Option<u32> {
    let mut count = 0;
    for &t in triangles {
        let [p, q, r] = t;
        let normal = (q - p).cross(r - p).normalize();
        let (da, db) = (normal.dot(a - p), normal.dot(b - p));
        if da * db >= 0.0 {
            continue;
        }
        let x = a + (b - a) * (da / (da - db));
        let on_edge = [(p, q), (q, r), (r, p)]
            .iter()
            .any(|&(e0, e1)| segment_distance(x, x, e0, e1) <= tolerance);
        if on_edge {
            return None;
        }
        count += inside(x, t, normal) as u32;
    }
    Some(count)
}

/// The distance from `x` to `triangle`: to its face where `x` projects inside it, else to
/// its nearest edge.
fn point_triangle_distance(x: DVec3, triangle: [DVec3; 3]) -> f64 {
    let [p, q, r] = triangle;
    let normal = (q - p).cross(r - p).normalize();
    let d = normal.dot(x - p);
    if inside(x - normal * d, triangle, normal) {
        return d.abs();
    }
    [(p, q), (q, r), (r, p)]
        .iter()
        .map(|&(e0, e1)| segment_distance(x, x, e0, e1))
        .fold(f64::INFINITY, f64::min)
}

/// Whether `x`, on the plane of `triangle` (unit `normal`), is inside it or on its edges.
fn inside(x: DVec3, [p, q, r]: [DVec3; 3], normal: DVec3) -> bool {
    let side = |e0: DVec3, e1: DVec3| (e1 - e0).cross(x - e0).dot(normal) >= 0.0;
    side(p, q) && side(q, r) && side(r, p)
}

/// The distance between segments `p0`-`p1` and `q0`-`q1` (Ericson, Real-Time Collision
/// Detection, 5.1.9: the closest points' parameters, clamped to the segments).
pub fn segment_distance(p0: DVec3, p1: DVec3, q0: DVec3, q1: DVec3) -> f64 {
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    let (s, t) = if a <= f64::MIN_POSITIVE && e <= f64::MIN_POSITIVE {
        (0.0, 0.0)
    } else if a <= f64::MIN_POSITIVE {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= f64::MIN_POSITIVE {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > 0.0 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    ((p0 + d1 * s) - (q0 + d2 * t)).length()
}

/// Where the ray `origin + t dir` crosses `triangle` (either side), as `t`; None where it
/// misses. Watertight (Woop, Benthin & Wald 2013): the ray is sheared so that it runs along
/// +z, each edge is tested by one 2D edge function of the sheared corners, and an edge
/// shared by two triangles gives both the same function with opposite signs, so a ray
/// through the edge is inside at least one of them.
pub fn hit(origin: DVec3, dir: DVec3, triangle: [DVec3; 3]) -> Option<f64> {
    let kz = dir.abs().max_position();
    let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
    // Keep the winding: swap x and y when the ray runs along -z.
    if dir[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let (sx, sy, sz) = (dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
    let [a, b, c] = triangle.map(|v| v - origin);
    let shear = |v: DVec3| (v[kx] - sx * v[kz], v[ky] - sy * v[kz]);
    let ((ax, ay), (bx, by), (cx, cy)) = (shear(a), shear(b), shear(c));
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let t = (u * sz * a[kz] + v * sz * b[kz] + w * sz * c[kz]) / det;
    t.is_finite().then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A seeded generator (xorshift): the same triangles and segments every run.
    struct Seeded(u64);

    impl Seeded {
        fn unit(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }

        fn point(&mut self, scale: f64) -> DVec3 {
            DVec3::new(self.unit(), self.unit(), self.unit()) * scale
        }
    }

    fn scene(n: usize, seed: u64) -> (Vec<[f32; 3]>, Vec<u32>) {
        let mut r = Seeded(seed);
        let mut positions = Vec::new();
        for _ in 0..n {
            let centre = r.point(20.0);
            for _ in 0..3 {
                positions.push((centre + r.point(2.0)).as_vec3().to_array());
            }
        }
        let indices = (0..positions.len() as u32).collect();
        (positions, indices)
    }

    /// Every triangle tested, no tree: what the tree must answer.
    fn brute(bvh: &TriangleBvh, from: DVec3, to: DVec3, t_min: f64) -> bool {
        bvh.triangles
            .iter()
            .any(|&t| hit(from, to - from, t).is_some_and(|t| t > t_min && t < 1.0))
    }

    #[test]
    fn the_tree_answers_as_every_triangle_does() {
        let (positions, indices) = scene(500, 7);
        let bvh = TriangleBvh::build(&positions, &indices);
        assert!(bvh.covers());
        let mut r = Seeded(99);
        let (mut blocked, mut nodes) = (0, 0);
        for _ in 0..2000 {
            let (from, to) = (r.point(22.0), r.point(22.0));
            let (tree, visits) = bvh.blocked(from, to, 1e-9);
            assert_eq!(tree, brute(&bvh, from, to, 1e-9), "{from} -> {to}");
            blocked += usize::from(tree);
            nodes += visits.nodes;
        }
        // Both answers occur, and the walk visits far fewer nodes than the tree holds.
        assert!(blocked > 100 && blocked < 1900, "{blocked} of 2000 blocked");
        assert!(
            (nodes as usize) < 2000 * bvh.nodes.len() / 4,
            "{nodes} visits"
        );
    }

    /// Möller-Trumbore in f32, the usual test: the deliberate break of watertightness.
    fn moller_trumbore(origin: DVec3, dir: DVec3, t: [DVec3; 3]) -> bool {
        let (o, d) = (origin.as_vec3(), dir.as_vec3());
        let [a, b, c] = t.map(|v| v.as_vec3());
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det == 0.0 {
            return false;
        }
        let s = o - a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        u >= 0.0 && v >= 0.0 && u + v <= 1.0
    }

    /// A ray through the edge two triangles share, or the corner a fan shares, hits; the
    /// usual test in f32 (Möller-Trumbore) lets some through.
    #[test]
    fn no_ray_passes_through_a_shared_edge_or_corner() {
        // The unit square in z = 0, split along its diagonal; and a fan of six around the
        // origin.
        let square = [
            [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0)],
            [DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
        ];
        let fan: Vec<[DVec3; 3]> = (0..6)
            .map(|i| {
                let at = |k: i32| {
                    let a = std::f64::consts::TAU * k as f64 / 6.0;
                    DVec3::new(a.cos(), a.sin(), 0.0)
                };
                [DVec3::ZERO, at(i), at(i + 1)]
            })
            .collect();
        let mut r = Seeded(3);
        let mut lost = 0;
        for _ in 0..1000 {
            // On the diagonal, from a random point above to one below.
            let s = r.unit();
            let on = DVec3::new(s, s, 0.0);
            let from = on + DVec3::new(r.unit() - 0.5, r.unit() - 0.5, 1.0 + r.unit());
            let dir = (on - from) * 2.0;
            assert!(
                square.iter().any(|&t| hit(from, dir, t).is_some()),
                "{from}"
            );
            lost += usize::from(!square.iter().any(|&t| moller_trumbore(from, dir, t)));
            let from = DVec3::new(r.unit() - 0.5, r.unit() - 0.5, 1.0 + r.unit());
            assert!(
                fan.iter().any(|&t| hit(from, -from * 2.0, t).is_some()),
                "{from}"
            );
        }
        assert!(lost > 0, "the f32 test lost no ray through the shared edge");
    }

    /// Triangles of no area are counted and left out; no query meets NaN.
    #[test]
    fn degenerate_triangles_are_counted_and_skipped() {
        let positions = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let indices = [0, 1, 2, 0, 0, 3, 0, 1, 3];
        let bvh = TriangleBvh::build(&positions, &indices);
        assert_eq!((bvh.degenerate, bvh.triangles.len()), (2, 1));
        let from = DVec3::new(0.2, 0.2, 1.0);
        assert!(bvh.blocked(from, DVec3::new(0.2, 0.2, -1.0), 0.0).0);
        assert!(!bvh.blocked(from, DVec3::new(2.5, 0.2, -1.0), 0.0).0);
        assert!(
            !TriangleBvh::build(&positions, &indices[..3])
                .blocked(from, -from, 0.0)
                .0
        );
    }

    /// The deliberate break: a node whose box no longer holds a child loses hits, and
    /// `covers` says so.
    #[test]
    fn a_box_that_misses_a_child_is_caught() {
        let (positions, indices) = scene(200, 11);
        let mut bvh = TriangleBvh::build(&positions, &indices);
        let mut r = Seeded(5);
        let segments: Vec<(DVec3, DVec3)> =
            (0..500).map(|_| (r.point(22.0), r.point(22.0))).collect();
        let agree = |b: &TriangleBvh| {
            segments
                .iter()
                .all(|&(f, t)| b.blocked(f, t, 1e-9).0 == brute(b, f, t, 1e-9))
        };
        assert!(agree(&bvh));
        let inner = bvh.nodes.iter().position(|n| n.count == 0).unwrap();
        let child = bvh.nodes[inner].first as usize;
        bvh.nodes[inner].max = bvh.nodes[child].min;
        assert!(!bvh.covers());
        assert!(!agree(&bvh), "a shrunk box lost no hit");
    }

    /// The corners of a unit square at z = 0.
    const UNIT_SQUARE: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];

    /// The reach of a test follows the coordinates it handles: a segment through a unit
    /// square is blocked at a rounding of 2e-6 a unit of coordinate (about the traversal's,
    /// 32 x 2^-24) for coordinates near 1, and so it stays with a light far away elsewhere
    /// in the scene; the deliberate break, the scene's largest coordinate (1e6) as every
    /// test's reach, makes it ambiguous.
    #[test]
    fn a_tests_reach_is_its_own_coordinates_not_the_scenes() {
        let square = TriangleBvh::build(&UNIT_SQUARE, &[0, 1, 2, 0, 2, 3]);
        let (from, to) = (DVec3::new(0.3, 0.6, 1.0), DVec3::new(0.3, 0.6, -1.0));
        let own = Reach {
            fixed: 1e-6,
            per_coordinate: 2e-6,
        };
        assert_eq!(square.classify(from, to, own).0, Seen::Blocked);
        let scene_wide = Reach::fixed(own.at(1e6));
        assert_eq!(square.classify(from, to, scene_wide).0, Seen::Ambiguous);
    }

    /// A unit square of two triangles at z = 0, within `reach` = 1e-3: a segment through
    /// their shared diagonal is blocked (the patch decides what neither triangle does
    /// alone, the deliberate break), one within reach of the outer edge or ending within
    /// reach of the face is ambiguous, one beyond reach of the square is open.
    #[test]
    fn a_patch_decides_what_no_triangle_alone_does() {
        let square = TriangleBvh::build(&UNIT_SQUARE, &[0, 1, 2, 0, 2, 3]);
        let half = TriangleBvh::build(&UNIT_SQUARE, &[0, 1, 2]);
        let reach = Reach::fixed(1e-3);
        let down = |x: f64, y: f64, end: f64| {
            square
                .classify(DVec3::new(x, y, 1.0), DVec3::new(x, y, end), reach)
                .0
        };
        assert_eq!(down(0.5, 0.5, -1.0), Seen::Blocked);
        assert_eq!(down(0.5 + 1e-9, 0.5, -1.0), Seen::Blocked);
        assert_eq!(down(0.3, 0.6, -1.0), Seen::Blocked);
        assert_eq!(down(0.9995, 0.5, -1.0), Seen::Ambiguous);
        assert_eq!(down(1.01, 0.5, -1.0), Seen::Open);
        assert_eq!(down(0.3, 0.6, 5e-4), Seen::Ambiguous);
        assert_eq!(down(0.3, 0.6, 2e-3), Seen::Open);
        // One triangle alone: the diagonal is its boundary.
        let alone = half.classify(DVec3::new(0.5, 0.5, 1.0), DVec3::new(0.5, 0.5, -1.0), reach);
        assert_eq!(alone.0, Seen::Ambiguous);
    }
}
