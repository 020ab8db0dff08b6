//! Z-binning (Drobot 2017): its bins and tile masks keep every light that reaches a visible sample.

use super::*;

/// Z-binning never leaves out a light that reaches a visible sample, on the GPU and in its
/// f64 twin; the GPU sorts lights by depth as the twin does (to f32 rounding); a twin whose
/// bins each keep only the nearer half of their range (a deliberate break) must miss lights.
#[test]
fn zbins_keep_every_light_that_reaches_a_sample() {
    let gpu = gpu();
    let composer = Composer::default();
    for (label, scene) in culling_scenes() {
        for v in [
            zbin_variant(Pipeline::ClusteredForward, (16, 9, 24)),
            zbin_variant(Pipeline::ClusteredDeferred, (8, 8, 64)),
        ] {
            let what = format!("{:?} {:?} on {label}", v.pipeline, v.clusters().grid);
            let mut r = Renderer::new(&gpu, &composer, &v, &scene).unwrap();
            r.render().unwrap();
            let gpu_lists = r.cluster_lists().unwrap().unwrap();
            let truth = raster_truth(&gpu, &composer, &v, &scene).unwrap();
            let samples = visible_samples(&truth, &scene);
            let grid = Grid::of(&v, &scene);
            let view_lights = cpu::view_lights(&scene.lights, scene.camera.view());
            let twin = ZBins::build(&grid, &view_lights);
            let (missing, checked) =
                missing_lights(&grid, &scene, &samples, |c| gpu_lists.list(c).to_vec());
            assert!(
                missing.is_empty(),
                "{what}: GPU bins miss (pixel, light) {:?}",
                &missing[..missing.len().min(5)]
            );
            assert!(checked > 1000, "{what}: only {checked} pairs checked");
            let twin_lists = twin.lists();
            let (missing, _) =
                missing_lights(&grid, &scene, &samples, |c| twin_lists.list(c).to_vec());
            assert!(
                missing.is_empty(),
                "{what}: twin bins miss {:?}",
                &missing[..missing.len().min(5)]
            );
            // The GPU's order: by the f64 depth of each light's centre, to f32 rounding, for
            // the lights that reach a tile (the others go last, in any order).
            let zbins = r.zbins().unwrap().expect("z-binning");
            let in_a_tile = |s: usize| {
                zbins
                    .masks
                    .chunks_exact(zbins.words)
                    .any(|m| m[s / 32] & (1 << (s % 32)) != 0)
            };
            let depth = |i: u32| -view_lights[i as usize].center.z;
            let masked: Vec<u32> = (0..zbins.order.len())
                .filter(|&s| in_a_tile(s))
                .map(|s| zbins.order[s])
                .collect();
            assert!(
                masked.len() > 10,
                "{what}: {} lights in tiles",
                masked.len()
            );
            for w in masked.windows(2) {
                assert!(
                    depth(w[0]) <= depth(w[1]) + 1e-5 * depth(w[1]).abs().max(1.0),
                    "{what}: light {} (depth {}) sorted before {} ({})",
                    w[0],
                    depth(w[0]),
                    w[1],
                    depth(w[1])
                );
            }
            // The break: each bin's range cut to its nearer half.
            let mut broken = twin.clone();
            for b in broken.bins.iter_mut() {
                *b = b.map(|(first, last)| (first, first + (last - first) / 2));
            }
            let broken = broken.lists();
            let (missing, _) = missing_lights(&grid, &scene, &samples, |c| broken.list(c).to_vec());
            assert!(
                !missing.is_empty(),
                "{what}: the check missed the shortened bins"
            );
        }
    }
}
