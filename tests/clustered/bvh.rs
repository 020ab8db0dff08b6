//! The light BVH: the GPU sorts and builds the twin's tree, and its lists are the box test's.

use super::*;
use clusterlab::cpu::bvh;
use clusterlab::render::Binding;

/// The atrium at 96x54 with `lights` lights (its own, repeated where it has fewer).
fn atrium_with(lights: usize) -> Scene {
    let mut scene =
        scene::generate("atrium", small("atrium", 96, 54, Some(lights as u32))).unwrap();
    scene.lights = scene.lights.iter().cycle().take(lights).cloned().collect();
    scene.params.lights = lights as u32;
    scene
}

/// What a frame left of the tree: the lights' ranges, the sorted order, each internal
/// node (children, size, parent) and its bounds, each leaf's parent.
struct GpuTree {
    ranges: Vec<bvh::Range>,
    order: Vec<[u32; 2]>,
    nodes: Vec<bvh::Node>,
    bounds: Vec<bvh::Bounds>,
    leaf_parents: Vec<u32>,
}

fn gpu_tree(r: &Renderer, lights: usize) -> GpuTree {
    let words = |name: Binding| r.cluster_buffer(name).unwrap().expect("clustered");
    let internal = lights.saturating_sub(1);
    let nodes = words(Binding::BvhNodes);
    GpuTree {
        ranges: words(Binding::LightRanges)
            .chunks_exact(4)
            .take(lights)
            .map(|r| [r[0], r[1], r[2], r[3]])
            .collect(),
        order: words(Binding::SortedLights)
            .chunks_exact(2)
            .take(lights)
            .map(|e| [e[0], e[1]])
            .collect(),
        nodes: nodes
            .chunks_exact(4)
            .take(internal)
            .map(|n| [n[0], n[1], n[2], n[3]])
            .collect(),
        bounds: words(Binding::BvhBounds)
            .chunks_exact(4)
            .take(internal)
            .map(|b| [b[0], b[1], b[2]])
            .collect(),
        // Leaf p's parent at n - 1 + p, in x.
        leaf_parents: nodes
            .chunks_exact(4)
            .skip(internal)
            .take(lights)
            .map(|n| n[0])
            .collect(),
    }
}

/// The GPU's tree against the twin's, built from the GPU's own light ranges (integers:
/// equal, not close): the radix sort's order (by Morton code, then light), Karras's nodes
/// against the twin's top-down split, the parents, and the bounds set bottom up.
fn check_tree(what: &str, t: &GpuTree, grid: (u32, u32, u32)) {
    let order = bvh::order(&t.ranges, grid);
    assert!(t.order == order, "{what}: the sorted order differs");
    let mut nodes = bvh::tree(&order);
    // The root's parent is never written.
    if let (Some(root), Some(got)) = (nodes.first_mut(), t.nodes.first()) {
        root[3] = got[3];
    }
    assert!(t.nodes == nodes, "{what}: the nodes differ");
    if !nodes.is_empty() {
        let parents = bvh::leaf_parents(&nodes);
        assert!(
            t.leaf_parents == parents,
            "{what}: the leaves' parents differ"
        );
    }
    assert!(
        t.bounds == bvh::bounds(&order, &nodes, &t.ranges),
        "{what}: the bounds differ"
    );
    assert_eq!(
        bvh::uncovered(&order, &nodes, &t.bounds, &t.ranges),
        None,
        "{what}"
    );
}

/// On every culling scene, on 1, 2 and 1025 (2^10 + 1: a second radix tile of one entry)
/// lights, on 3000, and on 1200 lights that are 30 repeated 40 times (equal Morton codes,
/// which Karras tells apart by position), the GPU's sorted order and tree equal the twin's;
/// the GPU's lists equal one-level assignment's cluster for cluster (the walk reaches
/// exactly the lights whose range holds the cluster, each tested as one-level tests it),
/// with and without active clusters, built and refitted.
#[test]
fn the_gpu_builds_the_twins_tree_and_lists_what_one_level_lists() {
    let gpu = gpu();
    let composer = Composer::default();
    let mut scenes = culling_scenes();
    for lights in [1, 2, 1025, 3000] {
        scenes.push((format!("atrium ({lights} lights)"), atrium_with(lights)));
    }
    let mut repeated = atrium_with(30);
    repeated.lights = (0..40).flat_map(|_| repeated.lights.clone()).collect();
    repeated.params.lights = repeated.lights.len() as u32;
    scenes.push(("atrium (30 lights, 40 times each)".into(), repeated));
    for (label, scene) in scenes {
        for v in [
            bvh_variant(Pipeline::ClusteredForward, (16, 9, 24), false),
            bvh_variant(Pipeline::ClusteredDeferred, (24, 12, 64), true),
        ] {
            let what = format!("{:?} {:?} on {label}", v.pipeline, v.clusters().grid);
            let mut r = Renderer::new(&gpu, &composer, &v, &scene).unwrap();
            r.render().unwrap();
            let lights = scene.lights.len();
            check_tree(&what, &gpu_tree(&r, lights), v.clusters().grid);
            let got = r.cluster_lists().unwrap().unwrap();
            let mut one_level = v.clone();
            one_level.clusters.as_mut().unwrap().culling = Culling::Boxes;
            let want = gpu_lists(&gpu, &composer, &one_level, &scene);
            for c in 0..got.counts.len() {
                assert_eq!(got.list(c), want.list(c), "{what}: cluster {c}");
            }
        }
    }
}

/// The deliberate break: one node's bounds no longer cover a child (its last x cut below
/// the child's), as a bottom-up pass that lost an arrival would leave them. The check
/// names the node; the GPU's own tree passes it (above).
#[test]
fn a_node_that_does_not_cover_its_child_is_found() {
    let gpu = gpu();
    let composer = Composer::default();
    let scene = atrium_with(3000);
    let v = bvh_variant(Pipeline::ClusteredForward, (16, 9, 24), false);
    let mut r = Renderer::new(&gpu, &composer, &v, &scene).unwrap();
    r.render().unwrap();
    let mut t = gpu_tree(&r, scene.lights.len());
    let (node, x) = t
        .bounds
        .iter()
        .enumerate()
        .find_map(|(i, b)| (b[0] >> 16 > (b[0] & 0xffff)).then_some((i, b[0])))
        .expect("a node spanning two tiles");
    t.bounds[node][0] = (x & 0xffff) | ((x >> 16) - 1) << 16;
    let found = bvh::uncovered(&t.order, &t.nodes, &t.bounds, &t.ranges);
    assert!(
        found.is_some_and(|f| f.starts_with(&format!("node {node}:"))),
        "the cut node {node} was not found"
    );
}
