//! Rasterised binning (Ortegren and Persson 2016): its lists keep every light that reaches a visible sample, sorted whatever order the draw meets lights in.

use super::*;

/// Rasterised binning never leaves out a light that reaches a visible sample, on the GPU and
/// in its f64 twin (`cpu::proxy_tiles` over the box test's lists); each GPU list holds the
/// twin's and lies within the compute method's list of the same cluster, and without
/// sample bounds the proxies cull some of those. A twin whose proxies are one tile too narrow on their right (a
/// deliberate break) must miss lights.
#[test]
fn rasterised_binning_keeps_every_light_that_reaches_a_sample() {
    let gpu = gpu();
    let composer = Composer::default();
    for (label, scene) in culling_scenes() {
        for v in [
            raster_variant(Pipeline::ClusteredForward, (16, 9, 24), false),
            raster_variant(Pipeline::ClusteredDeferred, (24, 12, 64), true),
        ] {
            let what = format!("{:?} {:?} on {label}", v.pipeline, v.clusters().grid);
            let lists = |v: &Variant| gpu_lists(&gpu, &composer, v, &scene);
            let gpu_lists = lists(&v);
            let mut boxes = v.clone();
            boxes.clusters.as_mut().unwrap().culling = Culling::Boxes;
            let gpu_boxes = lists(&boxes);
            let grid = Grid::of(&v, &scene);
            let truth = raster_truth(&gpu, &composer, &v, &scene).unwrap();
            let samples = visible_samples(&truth, &scene);
            let (missing, checked) =
                missing_lights(&grid, &scene, &samples, |c| gpu_lists.list(c).to_vec());
            assert!(
                missing.is_empty(),
                "{what}: GPU lists miss (pixel, light) {:?}",
                &missing[..missing.len().min(5)]
            );
            assert!(checked > 1000, "{what}: only {checked} pairs checked");
            // The twin: the box test's lists (all clusters: a twin of active clusters would
            // need the GPU's samples), each kept where the light's proxy holds the tile.
            let view_lights = cpu::view_lights(&scene.lights, scene.camera.view());
            let all = exact_lists(&grid, &view_lights, SpotTest::Cone);
            let proxy = |l: &cpu::ViewLight, k| cpu::proxy_tiles(&grid, l.center, l.radius, k);
            let twin = cpu::binned(&grid, &all, &view_lights, proxy);
            let (missing, _) = missing_lights(&grid, &scene, &samples, |c| twin.list(c).to_vec());
            assert!(
                missing.is_empty(),
                "{what}: twin lists miss {:?}",
                &missing[..missing.len().min(5)]
            );
            let active = v.clusters().active_clusters;
            let mut culled = 0;
            for c in 0..gpu_lists.counts.len() {
                let (got, compute) = (gpu_lists.list(c), gpu_boxes.list(c));
                assert!(
                    got.iter().all(|i| compute.contains(i)),
                    "{what}: cluster {c}: {got:?} not within the compute list {compute:?}"
                );
                culled += compute.len() - got.len();
                // Without active clusters the GPU tests every cluster as the twin does.
                if !active {
                    assert!(
                        twin.list(c).iter().all(|i| got.contains(i)),
                        "{what}: cluster {c}: GPU {got:?} misses some of the twin's {:?}",
                        twin.list(c)
                    );
                }
            }
            // Sample-bounded boxes seldom leave the proxies anything to cut.
            assert!(active || culled > 0, "{what}: the proxies culled nothing");
            // The break: every proxy one tile narrower on its right.
            let narrow = |l: &cpu::ViewLight, k| {
                proxy(l, k)
                    .map(|(lo, hi): cpu::TileRect| (lo, (hi.0.saturating_sub(1).max(lo.0), hi.1)))
            };
            let broken = cpu::binned(&grid, &all, &view_lights, narrow);
            let (missing, _) = missing_lights(&grid, &scene, &samples, |c| broken.list(c).to_vec());
            assert!(
                !missing.is_empty(),
                "{what}: the check missed proxies one tile too narrow"
            );
        }
    }
}

/// Rasterised binning's lists come out of its draw in the order the draw meets the lights,
/// which is index order only where the rasteriser keeps primitive order; `find_unsorted`
/// marks every list that is not, and `finish_lists` sorts those. The break that exercises
/// it: shaders whose `split_lights` lays the proxies out in reverse, so that the draw meets
/// each cluster's lights in descending order. The lists must still come back ascending and
/// equal to those of the shipped shaders.
#[test]
fn rasterised_lists_are_sorted_whatever_order_the_draw_meets_lights_in() {
    let gpu = gpu();
    let reversed = EditedShaders::of(
        "passes/assign_rasterised.wesl",
        "reversed-proxies",
        &[(
            "light_proxies[at] = vec4<u32>(i, s, p.x, p.y);",
            "light_proxies[atomicLoad(&proxy_draw.instances) - 1u - at] = vec4<u32>(i, s, p.x, p.y);",
        )],
    );
    let (_, scene) = culling_scenes().remove(0);
    let v = raster_variant(Pipeline::ClusteredForward, (16, 9, 24), false);
    let want = gpu_lists(&gpu, &Composer::default(), &v, &scene);
    assert_sorted_and_equal(
        &gpu_lists(&gpu, &reversed.composer, &v, &scene),
        &want,
        "reversed proxies",
    );
}

/// Proxies are held to the frame's own count, not to a proxy per light and slice: 40000
/// small lights on 256 slices would take 164 MB at worst, past lavapipe's largest buffer
/// (128 MiB; before, such a frame was refused), and take a few each; the frame renders what
/// one-level assignment renders, bit for bit.
#[test]
fn proxies_past_the_worst_case_render_where_the_frames_proxies_fit() {
    let gpu = gpu();
    let composer = Composer::default();
    let mut params = small("atrium", 64, 36, Some(40_000));
    params.radius_range = (0.05, 0.1);
    let scene = scene::generate("atrium", params).unwrap();
    let v = raster_variant(Pipeline::ClusteredForward, (4, 3, 256), false);
    let mut boxes = v.clone();
    boxes.clusters.as_mut().unwrap().culling = Culling::Boxes;
    let picture = |v: &Variant| {
        let mut r = Renderer::new(&gpu, &composer, v, &scene).unwrap();
        r.render().unwrap().ldr
    };
    assert!(picture(&v) == picture(&boxes), "the pictures differ");
}
