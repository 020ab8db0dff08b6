//! 2.5D culling (Harada 2012): its masks keep every light that reaches a visible sample.

use super::*;

/// 2.5D culling never leaves out a light that reaches a visible sample, on the GPU and in
/// its f64 twin (masks built from the raster truth's depths), and culls more than the boxes
/// alone; the GPU's sample ranges hold the twin's. A twin with each mask moved one cell
/// deeper (a deliberate break) must miss lights.
#[test]
fn depth_masks_keep_every_light_that_reaches_a_sample() {
    let gpu = gpu();
    let composer = Composer::default();
    for (label, scene) in culling_scenes() {
        for v in [
            depth_mask_variant(
                Pipeline::ClusteredForward,
                (16, 9, 1),
                ZSlicing::Exponential,
            ),
            depth_mask_variant(
                Pipeline::ClusteredDeferred,
                (16, 9, 24),
                ZSlicing::Exponential,
            ),
        ] {
            let what = format!("{:?} {:?} on {label}", v.pipeline, v.clusters().grid);
            let mut r = Renderer::new(&gpu, &composer, &v, &scene).unwrap();
            r.render().unwrap();
            let gpu_lists = r.cluster_lists().unwrap().unwrap();
            let gpu_masks = r.depth_masks().unwrap().unwrap();
            let truth = raster_truth(&gpu, &composer, &v, &scene).unwrap();
            let samples = visible_samples(&truth, &scene);
            let mut depths = vec![None; truth.position.len()];
            for &(i, _, z) in &samples {
                depths[i] = Some(z);
            }
            let grid = Grid::of(&v, &scene);
            let masks = cpu::depth_masks(&grid, (scene.params.width, scene.params.height), &depths);
            let bounds = cpu::sample_bounds(&grid, &masks);
            let view_lights = cpu::view_lights(&scene.lights, scene.camera.view());
            let assign = |m: Option<&[Option<cpu::DepthMask>]>| {
                cpu::assign(&grid, &bounds, &view_lights, SpotTest::Cone, None, None, m)
            };
            let twin = assign(Some(&masks));
            let boxes = assign(None);
            for (c, m) in masks.iter().enumerate() {
                let Some(m) = m else { continue };
                let range = gpu_masks[c].range;
                assert!(
                    range[1] > 0.0
                        && range[0] as f64 <= m.range.0 * (1.0 + 1e-6)
                        && range[1] as f64 >= m.range.1 * (1.0 - 1e-6),
                    "{what}: cluster {c}: GPU range {range:?}, twin {:?}",
                    m.range
                );
            }
            let (missing, checked) =
                missing_lights(&grid, &scene, &samples, |c| gpu_lists.list(c).to_vec());
            assert!(
                missing.is_empty(),
                "{what}: GPU lists miss (pixel, light) {:?}",
                &missing[..missing.len().min(5)]
            );
            assert!(checked > 1000, "{what}: only {checked} pairs checked");
            let (missing, _) = missing_lights(&grid, &scene, &samples, |c| twin.list(c).to_vec());
            assert!(
                missing.is_empty(),
                "{what}: twin lists miss {:?}",
                &missing[..missing.len().min(5)]
            );
            // The same variant culling with boxes alone, on the GPU.
            let mut unmasked = v.clone();
            unmasked.clusters.as_mut().unwrap().culling = Culling::Boxes;
            let mut r = Renderer::new(&gpu, &composer, &unmasked, &scene).unwrap();
            r.render().unwrap();
            let gpu_boxes = r.cluster_lists().unwrap().unwrap();
            // Tiles span the scene's depth, so their masks cut lights between surfaces;
            // thin 3D clusters seldom have such gaps, and the masks may only not add.
            let fewer = |a: usize, b: usize| {
                if v.clusters().grid.2 == 1 {
                    a < b
                } else {
                    a <= b
                }
            };
            assert!(
                fewer(twin.indices.len(), boxes.indices.len())
                    && fewer(gpu_lists.indices.len(), gpu_boxes.indices.len()),
                "{what}: masks culled too little: list entries twin {} against {} with boxes alone, GPU {} against {}",
                twin.indices.len(),
                boxes.indices.len(),
                gpu_lists.indices.len(),
                gpu_boxes.indices.len()
            );
            // The break: each mask one cell deeper loses lights at the nearest samples.
            let shifted: Vec<Option<cpu::DepthMask>> = masks
                .iter()
                .map(|m| {
                    m.map(|m| cpu::DepthMask {
                        mask: m.mask << 1,
                        ..m
                    })
                })
                .collect();
            let broken = assign(Some(&shifted));
            let (missing, _) = missing_lights(&grid, &scene, &samples, |c| broken.list(c).to_vec());
            assert!(
                !missing.is_empty(),
                "{what}: the check missed the shifted masks"
            );
        }
    }
}
