//! 2.5D culling (Harada 2012): its masks keep every light that reaches a visible sample.

use super::*;
use clusterlab::render::GpuDepthMask;

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
            let size = (scene.params.width, scene.params.height);
            let (near, far) = (scene.camera.near as f32, scene.camera.far as f32);
            let depth = clusterlab::kernels::gpu_depth_samples(
                &gpu,
                &composer,
                &v,
                r.depth_texture(),
                near,
                far,
            )
            .unwrap();
            let mapping = v.depth.mapping();
            let gpu_depths: Vec<Option<f64>> = (depth.device.iter().zip(&depth.view_depth))
                .map(|(&d, &z)| (!mapping.is_background(d as f64)).then_some(z as f64))
                .collect();
            let unorm24 = v.depth.format == clusterlab::variant::DepthFormat::Unorm24;
            let margin = |z: f64| {
                clusterlab::cpu::clusters::depth_margin(z, near as f64, mapping.reversed, unorm24)
            };
            let masks_of =
                |m: &[GpuDepthMask]| mask_bits_problem(&grid, size, &gpu_depths, &margin, m);
            if let Some(problem) = masks_of(&gpu_masks) {
                panic!("{what}: {problem}");
            }
            // The break: one bit of one mask off must be seen.
            let mut off = gpu_masks.clone();
            let c = off
                .iter()
                .position(|m| m.mask != 0)
                .expect("a marked cluster");
            off[c].mask &= off[c].mask - 1;
            assert!(
                masks_of(&off).is_some(),
                "{what}: a mask bit off went unseen"
            );
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
            // thin 3D clusters seldom have such gaps, and the masks may only not add. The
            // GPU marks each sample over the depths it may be shaded at (`depth_margin`,
            // with standard depth and near 0.1: 0.7% of a depth of 60, under one of a
            // tile's 32 cells), so where the twin's exact depths cut 1% or more of the
            // box lists' entries (atrium's tiles: 3.2% and 5.6%), the GPU's masks must cut
            // too; where the twin cuts a handful (the stage's tiles: 1 of 3013), the
            // margin may keep them.
            let tiled = v.clusters().grid.2 == 1;
            let must_cull =
                tiled && 100 * (boxes.indices.len() - twin.indices.len()) >= boxes.indices.len();
            let fewer = |a: usize, b: usize, strict: bool| if strict { a < b } else { a <= b };
            assert!(
                fewer(twin.indices.len(), boxes.indices.len(), tiled)
                    && fewer(gpu_lists.indices.len(), gpu_boxes.indices.len(), must_cull),
                "{what}: masks culled too little: list entries twin {} against {} with boxes alone, GPU {} against {}",
                twin.indices.len(),
                boxes.indices.len(),
                gpu_lists.indices.len(),
                gpu_boxes.indices.len()
            );
            assert!(
                !tiled || label.starts_with("stage") || must_cull,
                "{what}: the twin's masks cut under 1% on the atrium's tiles, so the GPU's are not held to cut"
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

/// Whether the GPU's 2.5D masks are the cells its own sample ranges give its own samples,
/// marked as `mark_cells` marks them: each sample at depth z sets the cells of
/// [z (1 - m), z (1 + m)] (m: `margin(z)`, `cpu::clusters::depth_margin`) in the clusters
/// of every slice of that range. `depths` are the view depths the GPU rebuilds from its
/// depth buffer (its own function, in f32; None: background), so the twin differs only
/// where f32 rounds the cell arithmetic (z (1 +/- m), z - z0 and the product: a few f32
/// steps of z, under 1e-6 relative) and the slice (its logarithm: 1e-5). Every bit of the
/// cells narrowed by that slack must be set, and no bit outside them widened by it; a
/// depth within the slice slack of a boundary may mark either slice.
fn mask_bits_problem(
    grid: &Grid,
    (w, h): (u32, u32),
    depths: &[Option<f64>],
    margin: &dyn Fn(f64) -> f64,
    gpu: &[GpuDepthMask],
) -> Option<String> {
    use clusterlab::cpu::clusters::cell_span;
    const CELL_SLACK: f64 = 1e-6;
    const SLICE_SLACK: f64 = 1e-5;
    let slices = grid.slices();
    let tile = |p: usize, size: u32, tiles: u32| {
        (((p as f64 + 0.5) * tiles as f64 / size as f64) as u32).min(tiles - 1)
    };
    let (mut narrow, mut wide) = (vec![0u32; gpu.len()], vec![0u32; gpu.len()]);
    for (i, z) in depths.iter().enumerate() {
        let Some(z) = *z else { continue };
        let (x, y) = (
            tile(i % w as usize, w, grid.x),
            tile(i / w as usize, h, grid.y),
        );
        let m = margin(z);
        let (a, b) = ((z * (1.0 - m)).max(0.0), z * (1.0 + m));
        // Slices surely marked, and those that may be.
        let (sure, may) = (
            slices.slice(a * (1.0 + SLICE_SLACK))..=slices.slice(b * (1.0 - SLICE_SLACK)),
            slices.slice(a * (1.0 - SLICE_SLACK))..=slices.slice(b * (1.0 + SLICE_SLACK)),
        );
        for k in may.clone() {
            let c = grid.index(x, y, k);
            let [z0, z1] = gpu[c].range.map(f64::from);
            if z1 <= 0.0 {
                if sure.contains(&k) {
                    return Some(format!("cluster {c} holds a sample at {z} but is unmarked"));
                }
                continue;
            }
            let span = |slack: f64| cell_span(a * (1.0 + slack), b * (1.0 - slack), z0, z1);
            wide[c] |= span(-CELL_SLACK);
            if sure.contains(&k) {
                narrow[c] |= span(CELL_SLACK);
            }
        }
    }
    (0..gpu.len()).find_map(|c| {
        let m = gpu[c].mask;
        (narrow[c] & !m != 0 || m & !wide[c] != 0).then(|| {
            format!(
                "cluster {c}: GPU mask {m:032b}, the samples set {:032b} and may set {:032b}",
                narrow[c], wide[c]
            )
        })
    })
}
