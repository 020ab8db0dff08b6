//! Light counts past a software GPU's loop budget (llvmpipe ends an invocation's loops after
//! 65535 iterations in all): a clustered frame is held to the lists and walks it builds, not
//! to its light count. Each way of building or walking lists, at a light count past the
//! budget, renders the picture of the one light in view; a frame with one cluster holding
//! more lights than the budget is refused, naming that cluster, where the adapter has the
//! budget, and renders elsewhere.

use super::*;

/// One variant per way lists are built or walked: one level, two levels, z-binning's bins,
/// rasterised proxies, the light BVH, the CPU.
fn every_walk() -> Vec<(&'static str, Variant)> {
    let one_level = clustered(Pipeline::ClusteredForward, ZSlicing::Exponential);
    let mut two_level = one_level.clone();
    two_level.clusters.as_mut().unwrap().big_tiles = Some(2);
    let mut on_cpu = one_level.clone();
    on_cpu.clusters.as_mut().unwrap().assignment = Assignment::Cpu;
    let grid = one_level.clusters().grid;
    vec![
        ("one-level", one_level),
        ("two-level", two_level),
        ("z-binning", zbin_variant(Pipeline::ClusteredForward, grid)),
        (
            "rasterised",
            raster_variant(Pipeline::ClusteredForward, grid, false),
        ),
        ("BVH", bvh_variant(Pipeline::ClusteredForward, grid, false)),
        ("CPU assignment", on_cpu),
    ]
}

/// The bright light of the one-light scene, where it lights the plane.
fn bright() -> Light {
    Light::point([0.0, 1.5, 0.0], 6.0, [1.0; 3], 20.0)
}

/// The one-light scene with `lights` before its bright light, which comes last.
fn with_lights(lights: Vec<Light>) -> Scene {
    let mut scene = scene::generate("one_light", small("one_light", 32, 18, Some(1))).unwrap();
    scene.lights = lights;
    scene.lights.push(bright());
    scene.params.lights = scene.lights.len() as u32;
    scene
}

/// 65536 lights, past the budget of a loop over every light, all
/// but the last far out of view: every method renders what the last light alone renders,
/// bit for bit (before, every clustered frame past 62494 lights was refused on llvmpipe).
#[test]
fn lights_past_the_loop_budget_render_where_their_lists_fit() {
    let gpu = gpu();
    let composer = Composer::default();
    let far = Light::point([100.0; 3], 0.01, [1.0; 3], 1.0);
    let many = with_lights(vec![far; 65535]);
    let alone = with_lights(Vec::new());
    for (name, v) in every_walk() {
        let picture = |scene: &Scene| {
            let mut r = Renderer::new(&gpu, &composer, &v, scene)
                .unwrap_or_else(|e| panic!("{name}, {} lights: {e}", scene.lights.len()));
            r.render()
                .unwrap_or_else(|e| panic!("{name}, {} lights: {e}", scene.lights.len()))
                .ldr
        };
        let got = picture(&many);
        assert!(
            got.iter().any(|p| p[0] > 200),
            "{name}: the light in view is left out"
        );
        assert!(got == picture(&alone), "{name}: the pictures differ");
    }
}

/// One cluster holding one light more than the budget (every light at one point): refused
/// where the adapter ends loops early, naming the cluster and its count; rendered elsewhere.
#[test]
fn a_list_past_the_loop_budget_is_refused_naming_its_cluster() {
    let gpu = gpu();
    let composer = Composer::default();
    let budget = clusterlab::gpu::expect::max_lights_per_pixel(&gpu);
    let n = budget.unwrap_or(64511) + 1;
    let speck = Light::point([0.0, 1.5, 0.0], 0.05, [1.0; 3], 0.01);
    let scene = with_lights(vec![speck; n as usize - 1]);
    for (name, v) in every_walk() {
        let frame = Renderer::new(&gpu, &composer, &v, &scene)
            .unwrap_or_else(|e| panic!("{name}: {e}"))
            .render();
        match (budget, frame) {
            (Some(_), Err(e)) => {
                let message = e.to_string();
                // A list's length is exact where it is counted; a walk through bitmasks
                // or the tree (two-level, z-binning, BVH) is named as such.
                let named = message.contains(&format!("holds {n} lights"))
                    || message.contains("a light-assignment walk");
                assert!(
                    named && message.contains("ends a shader's loops"),
                    "{name}: {message}"
                );
            }
            (Some(_), Ok(_)) => panic!("{name}: a list of {n} lights was not refused"),
            (None, frame) => assert!(frame.is_ok(), "{name}: no budget here, yet refused"),
        }
    }
}
