//! Two-level culling (HDRP): its lists are one-level assignment's, exactly.

use super::*;

/// Two-level culling changes how lists are built, never what they hold: on the GPU, the lists
/// with big tiles equal those without, cluster by cluster (with and without active clusters,
/// whose big tiles also cull by depth; on a scene whose lists pass the 256 entries the fine
/// pass holds, which it writes in a second walk); in f64, every light of a cluster's exact
/// list passes the coarse test of the big tile `cpu::clusters::big_tile` puts the cluster in.
/// A coarse test on a big tile one tile too narrow (a deliberate break) must reject some
/// listed light.
#[test]
fn two_level_lists_equal_one_level_lists() {
    let gpu = gpu();
    let composer = Composer::default();
    let mut long = small("atrium", 128, 72, Some(700));
    long.radius_range = (6.0, 9.0);
    let long_lists = (
        "atrium (long lists)".to_string(),
        scene::generate("atrium", long).unwrap(),
    );
    let mut longest = 0;
    for (label, scene) in culling_scenes().into_iter().chain([long_lists]) {
        let mut active = depth_mask_variant(
            Pipeline::ClusteredForward,
            (24, 16, 32),
            ZSlicing::Exponential,
        );
        active.clusters.as_mut().unwrap().culling = Culling::Boxes;
        let plain = clustered(Pipeline::ClusteredDeferred, ZSlicing::Exponential);
        for (one_level, big) in [(active, 2), (plain, 3)] {
            let mut two_level = one_level.clone();
            two_level.clusters.as_mut().unwrap().big_tiles = Some(big);
            let what = format!("{:?} big tiles {big} on {label}", one_level.clusters().grid);
            let lists = |v: &Variant| gpu_lists(&gpu, &composer, v, &scene);
            let (one, two) = (lists(&one_level), lists(&two_level));
            assert!(
                one.indices.len() > 1000,
                "{what}: {} entries",
                one.indices.len()
            );
            for c in 0..one.counts.len() {
                assert_eq!(one.list(c), two.list(c), "{what}: cluster {c}");
            }
            longest = longest.max(two.max_per_cluster);
            // f64: the lights of each cluster's exact list pass its big tile's coarse test.
            let grid = Grid::of(&one_level, &scene);
            let view_lights = cpu::view_lights(&scene.lights, scene.camera.view());
            let want = exact_lists(&grid, &view_lights, SpotTest::Cone);
            let rejected = |narrower: u32| {
                let mut rejected = 0;
                for c in 0..want.counts.len() {
                    let (x, y) = (c as u32 % grid.x, (c as u32 / grid.x) % grid.y);
                    let (lo, hi) = cpu::big_tile(&grid, big, x, y);
                    let hi = (
                        hi.0.saturating_sub(narrower).max(lo.0),
                        hi.1.saturating_sub(narrower).max(lo.1),
                    );
                    for &i in want.list(c) {
                        let l = &view_lights[i as usize];
                        if !cpu::coarse_keeps(&grid, l.center, l.radius, lo, hi) {
                            rejected += 1;
                        }
                    }
                }
                rejected
            };
            assert_eq!(
                rejected(0),
                0,
                "{what}: the coarse test rejects listed lights"
            );
            assert!(
                rejected(1) > 0,
                "{what}: the check missed a big tile one tile too narrow"
            );
        }
    }
    assert!(
        longest > 256,
        "no list passed what the fine pass holds (longest {longest})"
    );
}
