//! Olsson's light BVH: the GPU builds the twin's tree, and its lists are the box test's.

use super::*;
use clusterlab::cpu::bvh;
use clusterlab::render::Binding;

/// On every culling scene, and one of 3000 lights (a sort of 4096 entries: 4 blocks and
/// merges at every distance from 2048 down), the GPU's sorted order and every node equal the twin's, built
/// from the GPU's own light ranges (integers: equal, not close); the GPU's lists equal
/// one-level assignment's cluster for cluster (the walk reaches exactly the lights whose
/// range holds the cluster, each tested as one-level tests it), with and without active
/// clusters.
#[test]
fn the_gpu_builds_the_twins_tree_and_lists_what_one_level_lists() {
    let gpu = gpu();
    let composer = Composer::default();
    let mut scenes = culling_scenes();
    let many = scene::generate("atrium", small("atrium", 96, 54, Some(3000))).unwrap();
    scenes.push(("atrium (3000 lights)".into(), many));
    for (label, scene) in scenes {
        for v in [
            bvh_variant(Pipeline::ClusteredForward, (16, 9, 24), false),
            bvh_variant(Pipeline::ClusteredDeferred, (24, 12, 64), true),
        ] {
            let what = format!("{:?} {:?} on {label}", v.pipeline, v.clusters().grid);
            let mut r = Renderer::new(&gpu, &composer, &v, &scene).unwrap();
            r.render().unwrap();
            let words = |name: Binding| r.cluster_buffer(name).unwrap().expect("clustered");
            let lights = scene.lights.len();
            let ranges: Vec<bvh::Range> = words(Binding::LightRanges)
                .chunks_exact(4)
                .take(lights)
                .map(|r| [r[0], r[1], r[2], r[3]])
                .collect();
            let order = bvh::order(&ranges, v.clusters().grid);
            let got_order: Vec<[u32; 2]> = words(Binding::SortedLights)
                .chunks_exact(2)
                .map(|e| [e[0], e[1]])
                .collect();
            assert!(got_order == order, "{what}: the sorted order differs");
            let nodes = bvh::nodes(&order, &ranges);
            let got_nodes: Vec<bvh::Range> = words(Binding::BvhNodes)
                .chunks_exact(4)
                .map(|n| [n[0], n[1], n[2], n[3]])
                .collect();
            assert!(got_nodes == nodes, "{what}: the nodes differ");
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
