//! One-level assignment: its lists come back sorted whatever order lights fill them in.

use super::*;

/// One-level assignment fills each list band by band (`band_unit` in assign_one_level.wesl),
/// each band in the order the dispatch runs its lights: index order on a software GPU whose
/// threads take contiguous chunks of workgroups, so `finish_lists` finds nothing to move
/// there, and tests on such an adapter would not see its sort fail. The breaks that exercise
/// it: shaders whose per-light passes take the lights in reverse, so that every band fills
/// in descending order, and shaders with one band, as from 65536 lights on. The lists must
/// still come back ascending and equal to those of the shipped shaders.
#[test]
fn one_level_lists_are_sorted_whatever_order_lights_fill_them_in() {
    let gpu = gpu();
    let (_, scene) = culling_scenes().remove(0);
    let v = clustered(Pipeline::ClusteredForward, Clusters::default().slicing);
    let want = gpu_lists(&gpu, &Composer::default(), &v, &scene);
    let reversed = EditedShaders::of(
        "clustering/assignment.wesl",
        "reversed-lights",
        &[(
            "return group.x + group.y * LIGHTS_PER_ROW;",
            "return view.light_count - 1u - (group.x + group.y * LIGHTS_PER_ROW);",
        )],
    );
    assert_sorted_and_equal(
        &gpu_lists(&gpu, &reversed.composer, &v, &scene),
        &want,
        "lights in reverse",
    );
    let one_band = EditedShaders::of(
        "clustering/lists.wesl",
        "one-band",
        &[("return view.light_count < 65536u;", "return false;")],
    );
    assert_sorted_and_equal(
        &gpu_lists(&gpu, &one_band.composer, &v, &scene),
        &want,
        "one band",
    );
}
