//! `clusterlab stress`: adversarial cases (see `cases`) run on every pipeline they apply to,
//! each checked for non-finite pixels, cluster indices outside the grid, lights left out at
//! a visible sample or of a cluster they touch, error against the reference, and GPU
//! validation errors; all on the one renderer of the run.

mod cases;

pub use cases::{
    Case, Edit, SIZE, TIES_CASE, all as cases, codec_case_name, coplanar_ties, slicing_case_name,
};

use std::collections::HashMap;

use serde::Serialize;

use crate::compose::Composer;
use crate::cpu::clusters::{self as cpu, Grid};
use crate::gpu::{Gpu, expect};
use crate::reference::{EXPOSURE, ReferenceCache};
use crate::render::FrameOutput;
use crate::render::{PixelCounters, Renderer};
use crate::run::{CellOptions, run_scene_keeping_renderer};
use crate::scene::Scene;
use crate::variant::{GBufferLayout, LoadedVariant, Variant};

/// One check of one run.
#[derive(Clone, Debug, Serialize)]
pub struct Check {
    pub check: &'static str,
    pub ok: bool,
    /// What was found, and where when it failed.
    pub detail: String,
}

/// A case run with one variant.
#[derive(Clone, Debug, Serialize)]
pub struct CaseRun {
    pub case: String,
    pub variant: String,
    pub what: String,
    pub ok: bool,
    pub checks: Vec<Check>,
    /// Where the depth margin blunts z-culling for the variant on the case
    /// (`run::margin_note`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// Why the case does not apply to the variant (then it did not run, and `ok` is true).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub not_applicable: Option<String>,
}

/// Largest 8-bit error a variant may have against the reference on an adapter whose HDR
/// target keeps f32: 1 LSB (the f32 shading's rounding), also where the G-buffer packs
/// normals into 32 bits (octahedral and polar at most 0.0037 degrees off, the spheremap far
/// off only towards normals facing away from the camera, `docs/studies/codecs.md`; every
/// stress case measures 1 LSB at most); 3 LSB for codecs of fewer bits, whose error is the
/// codec's to report, not bounded here; none (255) for the Compact layout multisampled, which
/// shades a sample at its own depth on the pixel centre's ray rather than at the point the
/// rasteriser interpolated (`clustering/shading_depth.wesl`).
pub fn error_bound(v: &Variant) -> u32 {
    let compact = v.pipeline.is_deferred() && v.gbuffer().layout == GBufferLayout::Compact;
    if compact && v.msaa.on() {
        255
    } else if !v.pipeline.is_deferred() || v.normal_codec().bits() >= 32 {
        crate::run::EXACT_LSB
    } else {
        3
    }
}

/// Largest 8-bit error of one pixel whose reference colour is `reference_hdr` and which
/// `lights` lights reach: [`error_bound`], and for scissor deferred, which adds each light
/// by blending, on an adapter that declares its blends rounded (see `gpu::expect`), the
/// rounding error bound of that sum (`expect::blended_sum_error`, one rounding per light
/// that adds a non-zero term) carried through the tonemap and sRGB encoding to 8 bits,
/// channel by channel. No bound (255) where the sum's has none.
pub fn pixel_error_bound(v: &Variant, gpu: &Gpu, lights: u32, reference_hdr: [f64; 3]) -> f64 {
    let base = error_bound(v) as f64;
    if v.pipeline != crate::variant::Pipeline::DeferredScissor {
        return base;
    }
    let Some(deviation) = expect::allowance(gpu, expect::Check::BlendedLightSum) else {
        return base;
    };
    let expect::Allowance::BlendRounding { mantissa_bits } = deviation.allowance else {
        return base;
    };
    let display = |c: f64| {
        let [t, _, _] = crate::cpu::color::tonemap_reinhard([c, 0.0, 0.0], EXPOSURE);
        crate::cpu::color::srgb_encode(t) * 255.0
    };
    let extra = reference_hdr
        .iter()
        .map(
            |&s| match expect::blended_sum_error(s, lights, mantissa_bits) {
                None => 255.0,
                Some(d) => {
                    (display(s) - display((s - d).max(0.0))).max(display(s + d) - display(s))
                }
            },
        )
        .fold(0.0f64, f64::max);
    (base + extra).min(255.0)
}

/// The pixel of `frame` furthest over its [`pixel_error_bound`] from the 8-bit image
/// `against` (the reference's, or another pipeline's), with its error and bound: None when
/// every pixel is within. `reference_hdr` is the reference's colour, and `lights` the
/// lights that reach each pixel (the useful evaluations a frame counted there).
pub fn worst_over_bound(
    v: &Variant,
    gpu: &Gpu,
    lights: &[u32],
    frame: &FrameOutput,
    against: &[[u8; 3]],
    reference_hdr: &[[f64; 3]],
) -> Option<(usize, u32, f64)> {
    (0..frame.ldr.len())
        .filter_map(|i| {
            let error = (0..3)
                .map(|c| frame.ldr[i][c].abs_diff(against[i][c]) as u32)
                .max()
                .unwrap_or(0);
            let bound = pixel_error_bound(v, gpu, lights[i], reference_hdr[i]);
            (error as f64 > bound).then_some((i, error, bound))
        })
        .max_by(|a, b| (a.1 as f64 - a.2).total_cmp(&(b.1 as f64 - b.2)))
}

fn check(check: &'static str, ok: bool, detail: String) -> Check {
    Check { check, ok, detail }
}

/// Run one case with one variant and check everything. `references` shares reference
/// frames between the variants of a case that would compute the same one.
pub fn run_case(
    gpu: &Gpu,
    composer: &Composer,
    references: &ReferenceCache,
    case: &Case,
    name: &str,
    v: &Variant,
) -> CaseRun {
    let loaded = LoadedVariant {
        name: name.to_string(),
        path: "built-in".into(),
        variant: v.clone(),
    };
    if !case.later.is_empty() {
        let checks = run_sequence_case(gpu, composer, references, case, &loaded);
        return CaseRun {
            case: case.name.to_string(),
            variant: name.to_string(),
            what: case.what.to_string(),
            ok: checks.iter().all(|c| c.ok),
            checks,
            note: crate::run::margin_note(v, &case.scene),
            not_applicable: None,
        };
    }
    let mut checks = Vec::new();
    // Two frames: with a depth range from the previous frame, the second frame's lists
    // are built on the range the first left (see `missing_lights_of`).
    let cell = run_scene_keeping_renderer(
        gpu,
        composer,
        &loaded,
        &case.scene,
        CellOptions {
            frames: crate::measure::Frames::exact(1, 1),
            references: Some(references),
            ..Default::default()
        },
    );
    match cell {
        Err(e) => checks.push(check("renders", false, e.to_string())),
        Ok((cell, renderer)) => {
            checks.push(check("renders", true, "no GPU validation error".into()));
            checks.push(check(
                "meaningful",
                cell.report.failure.is_none(),
                cell.report.failure.clone().unwrap_or_else(|| {
                    "geometry in view, and lights evaluated where the reference is lit".into()
                }),
            ));
            let f = &cell.frame;
            let w = f.width as usize;
            let bad: Vec<usize> = (0..f.hdr.len())
                .filter(|&i| f.hdr[i][..3].iter().any(|c| !c.is_finite()))
                .collect();
            checks.push(check(
                "finite",
                bad.is_empty(),
                match bad.first() {
                    None => "no NaN or infinite pixel".into(),
                    Some(&i) => format!(
                        "{} pixels not finite; first at pixel ({}, {}): {:?}",
                        bad.len(),
                        i % w,
                        i / w,
                        &f.hdr[i][..3]
                    ),
                },
            ));
            let stats = cell.report.stats.clone().unwrap_or_default();
            let pixels = renderer.pixel_counters().map_err(|e| e.to_string());
            if v.pipeline.is_clustered() {
                checks.push(check(
                    "cluster index in grid",
                    stats.clusters_out_of_grid == 0,
                    match stats.first_out_of_grid {
                        None => format!("every pixel's cluster is one of {}", stats.clusters),
                        Some([x, y, c]) => format!(
                            "{} pixels looked up a cluster outside the grid; first at pixel ({x}, {y}): cluster {c} of {}",
                            stats.clusters_out_of_grid, stats.clusters
                        ),
                    },
                ));
            }
            // Multisampled, a pixel's fragments look up several clusters and its counters
            // keep the largest: the end-to-end error check below covers those runs.
            if v.pipeline.is_clustered() && !v.msaa.on() {
                let missing = pixels
                    .as_ref()
                    .map_err(Clone::clone)
                    .and_then(|p| missing_at_samples(gpu, composer, &renderer, p, v, &case.scene));
                checks.push(match missing {
                    Ok((0, _)) => check(
                        "no light missing at a sample",
                        true,
                        "every light that clearly reaches a visible sample is in the list of the cluster it is shaded with".into(),
                    ),
                    Ok((n, why)) => check(
                        "no light missing at a sample",
                        false,
                        format!("{n} sample-light pairs missing; first: {}", why.unwrap_or_default()),
                    ),
                    Err(e) => check("no light missing at a sample", false, e),
                });
            }
            if covers_every_cluster(v) {
                checks.push(match missing_lights_of(&renderer, v, &case.scene) {
                    Ok((_, None)) => check(
                        "no dropped light",
                        stats.dropped_lights == 0,
                        format!(
                            "{} dropped; every light that touches a cluster is in its list",
                            stats.dropped_lights
                        ),
                    ),
                    Ok((n, Some(why))) => check(
                        "no dropped light",
                        false,
                        format!("{n} light-cluster pairs missing; first: {why}"),
                    ),
                    Err(e) => check("no dropped light", false, e),
                });
            } else if v.pipeline.is_clustered() {
                checks.push(check(
                    "no dropped light",
                    stats.dropped_lights == 0,
                    format!(
                        "{} dropped (lists hold the lights of clusters with samples: checked at the samples)",
                        stats.dropped_lights
                    ),
                ));
            }
            // The lights that reach each pixel, as the frame counted them.
            let reach = match pixels {
                Ok(p) => p.useful,
                Err(e) => {
                    checks.push(check("counted", false, e));
                    vec![case.scene.lights.len() as u32; f.ldr.len()]
                }
            };
            // A debug view shows no shaded scene: no error to bound.
            if let Some(e) = &cell.report.error {
                let over =
                    worst_over_bound(v, gpu, &reach, f, &cell.reference.ldr, &cell.reference.hdr);
                let detail = match over {
                    Some((i, error, bound)) => format!(
                        "max {} LSB, {} pixels over 1 LSB; worst at pixel ({}, {}): {error} LSB, bound there {bound:.2} ({} lights reach it): GPU {:?}, reference {:?}",
                        e.max_abs_8bit,
                        e.pixels_over_1lsb,
                        i % w,
                        i / w,
                        reach[i],
                        [f.ldr[i][0], f.ldr[i][1], f.ldr[i][2]],
                        cell.reference.ldr[i]
                    ),
                    None => format!(
                        "max {} LSB, {} pixels over 1 LSB; every pixel within its bound ({} LSB, more where the adapter rounds blended sums)",
                        e.max_abs_8bit,
                        e.pixels_over_1lsb,
                        error_bound(v)
                    ),
                };
                checks.push(check("error within bound", over.is_none(), detail));
            }
        }
    }
    CaseRun {
        case: case.name.to_string(),
        variant: name.to_string(),
        what: case.what.to_string(),
        ok: checks.iter().all(|c| c.ok),
        checks,
        note: crate::run::margin_note(v, &case.scene),
        not_applicable: None,
    }
}

/// A case whose lights move: its frames as a sequence, every one checked against its
/// reference and against the frame rendered from scratch by a new renderer (which holds
/// every light a cluster's list must, and no other, as the single-frame cases check); and
/// that each frame whose lights moved did the variant's list work, not a rebuild.
fn run_sequence_case(
    gpu: &Gpu,
    composer: &Composer,
    references: &ReferenceCache,
    case: &Case,
    v: &LoadedVariant,
) -> Vec<Check> {
    let frames = |i: u32| -> Result<Scene, crate::scene::SceneError> {
        Ok(match i {
            0 => case.scene.clone(),
            i => case.later[i as usize - 1].clone(),
        })
    };
    let spec = crate::sequence::SequenceSpec {
        frames: 1 + case.later.len() as u32,
        check_every: 1,
    };
    let run = match crate::sequence::run(gpu, composer, v, spec, &frames, references) {
        Ok(run) => run,
        Err(e) => return vec![check("renders", false, e.to_string())],
    };
    let r = &run.report;
    let mut checks = vec![check("renders", true, "no GPU validation error".into())];
    let checked: Vec<(u32, &crate::sequence::FrameCheck)> = r
        .frames
        .iter()
        .filter_map(|f| f.check.as_ref().map(|c| (f.frame, c)))
        .collect();
    let meaningless = checked
        .iter()
        .find_map(|(i, c)| Some((i, c.failure.as_ref()?)));
    checks.push(check(
        "meaningful",
        meaningless.is_none(),
        meaningless.map_or(
            "every frame has geometry in view and finite pixels".into(),
            |(i, why)| format!("frame {i}: {why}"),
        ),
    ));
    let differs = checked.iter().find(|(_, c)| !c.equals_fresh);
    checks.push(check(
        "equals a fresh frame",
        differs.is_none(),
        match differs {
            None => format!(
                "each of {} frames equals the frame rendered from scratch, its lists as sets",
                checked.len()
            ),
            Some((i, c)) => format!("frame {i}: {}", c.difference.clone().unwrap_or_default()),
        },
    ));
    let bound = error_bound(&v.variant);
    let worst = checked.iter().max_by_key(|(_, c)| c.error.max_abs_8bit);
    checks.push(check(
        "error within bound",
        worst.is_none_or(|(_, c)| c.error.max_abs_8bit <= bound),
        worst.map_or(String::new(), |(i, c)| {
            format!(
                "worst frame {i}: max {} LSB (bound {bound})",
                c.error.max_abs_8bit
            )
        }),
    ));
    let (ok, detail) = crate::sequence::followed(&v.variant, r);
    checks.push(check("lists follow the lights", ok, detail));
    checks
}

/// Each cluster's list, sorted here: a check must not depend on the GPU having sorted its
/// lists. A list past the end of what was read back (an overflowing frame) lists nothing.
fn sorted_lists(lists: &cpu::ClusterLists) -> Vec<Vec<u32>> {
    (0..lists.counts.len())
        .map(|c| {
            let (start, count) = (lists.offsets[c] as usize, lists.counts[c] as usize);
            let mut list = lists
                .indices
                .get(start..start + count)
                .unwrap_or_default()
                .to_vec();
            list.sort_unstable();
            list
        })
        .collect()
}

/// Whether `light` clearly reaches world point `p`: closer than its radius by a relative
/// 1e-4 and inside its outer cone by 2e-6 in cosine, so no rounding of the GPU's can decide
/// it otherwise.
pub fn clearly_reaches(light: &crate::scene::Light, p: glam::DVec3) -> bool {
    let to_p = p - glam::DVec3::from(light.position.map(f64::from));
    let d = to_p.length();
    if d >= light.radius as f64 * (1.0 - 1e-4) {
        return false;
    }
    if !light.is_spot() {
        return true;
    }
    let axis = glam::DVec3::from(light.direction.map(f64::from)).normalize();
    d > 0.0 && to_p.dot(axis) / d > light.cos_outer as f64 + 2e-6
}

/// Sample-light pairs where the light clearly reaches a visible sample (the raster truth's
/// surface at a pixel) but is not in the list of the cluster that pixel's shading looked up
/// (as `pixels`, the renderer's last instrumented frame, recorded it): their count, and the
/// first.
/// Holds for every culling method, also those whose lists keep only the lights that reach
/// a cluster's samples (2.5D, sample bounds, active clusters).
pub fn missing_at_samples(
    gpu: &Gpu,
    composer: &Composer,
    r: &Renderer,
    pixels: &PixelCounters,
    v: &Variant,
    scene: &Scene,
) -> Result<(u64, Option<String>), String> {
    let truth = crate::render::raster_truth(gpu, composer, v, scene).map_err(|e| e.to_string())?;
    let lists = r
        .cluster_lists()
        .map_err(|e| e.to_string())?
        .ok_or("no cluster lists")?;
    let listed = sorted_lists(&lists);
    let w = scene.params.width as usize;
    let (mut missing, mut first) = (0u64, None);
    for i in (0..truth.position.len()).filter(|&i| truth.covered(i)) {
        let at = |what: String| format!("pixel ({}, {}): {what}", i % w, i / w);
        let Some(c) = pixels.cluster(i) else {
            missing += 1;
            first.get_or_insert_with(|| at("covered, but its shading looked up no cluster".into()));
            continue;
        };
        let list = &listed[c as usize];
        let p = truth.surface(i).position;
        for (l, light) in scene.lights.iter().enumerate() {
            if clearly_reaches(light, p) && list.binary_search(&(l as u32)).is_err() {
                missing += 1;
                first.get_or_insert_with(|| {
                    at(format!(
                        "light {l} reaches it but is not in cluster {c}'s list of {}",
                        list.len()
                    ))
                });
            }
        }
    }
    // Blended fragments look their cluster up by their own depth: the twin's slice at it, in
    // the tile of their pixel, over the range the frame clustered.
    if !truth.blended.is_empty() {
        let range = r
            .cluster_range()
            .map_err(|e| e.to_string())?
            .ok_or("no cluster range")?;
        let mut grid = Grid::of(v, scene);
        grid.range = (range.near as f64, range.far as f64);
        let slices = grid.slices();
        let view = scene.camera.view();
        let h = scene.params.height as usize;
        let tile = |pixel: usize, size: usize, tiles: u32| {
            (((pixel as f64 + 0.5) * tiles as f64 / size as f64).floor() as u32).min(tiles - 1)
        };
        for i in 0..truth.position.len() {
            for f in truth.blended_at(i) {
                let p = f.surface().position;
                let k = slices.slice(-view.transform_point3(p).z);
                let c = grid.index(tile(i % w, w, grid.x), tile(i / w, h, grid.y), k);
                let list = &listed[c];
                for (l, light) in scene.lights.iter().enumerate() {
                    if clearly_reaches(light, p) && list.binary_search(&(l as u32)).is_err() {
                        missing += 1;
                        first.get_or_insert_with(|| {
                            format!(
                                "pixel ({}, {}): light {l} reaches a blended fragment at view depth {:.4} but is not in cluster {c}'s list of {}",
                                i % w,
                                i / w,
                                -view.transform_point3(p).z,
                                list.len()
                            )
                        });
                    }
                }
            }
        }
    }
    Ok((missing, first))
}

/// Lights missing from `v`'s lists on `scene`: at a visible sample (`missing_at_samples`),
/// and where the lists cover every cluster (no active clusters, no 2.5D masks) in a cluster
/// the light clearly touches (`missing_lights_of`); their count and the first. Renders two
/// frames and an instrumented one of its own.
pub fn missing_lights(
    gpu: &Gpu,
    composer: &Composer,
    v: &Variant,
    scene: &Scene,
) -> Result<(u64, Option<String>), String> {
    let mut r = Renderer::new(gpu, composer, v, scene).map_err(|e| e.to_string())?;
    for _ in 0..2 {
        r.render().map_err(|e| e.to_string())?;
    }
    r.stats().map_err(|e| e.to_string())?;
    let pixels = r.pixel_counters().map_err(|e| e.to_string())?;
    let (mut missing, mut first) = missing_at_samples(gpu, composer, &r, &pixels, v, scene)?;
    if covers_every_cluster(v) {
        let (n, why) = missing_lights_of(&r, v, scene)?;
        missing += n;
        first = first.or(why);
    }
    Ok((missing, first))
}

/// Whether `v`'s lists are built for every cluster and hold every light that touches it
/// (not only the clusters with samples, or the lights that reach their samples).
fn covers_every_cluster(v: &Variant) -> bool {
    v.clusters
        .as_ref()
        .is_some_and(|c| !c.active_clusters && c.culling != crate::variant::Culling::DepthMask)
}

/// [`missing_lights`] in the lists of renderer `r`'s last frame. It must have rendered at
/// least two frames: with the previous frame's depth range, the second frame's lists are
/// built on the range the first left, which is the range read back after it.
pub fn missing_lights_of(
    r: &Renderer,
    v: &Variant,
    scene: &Scene,
) -> Result<(u64, Option<String>), String> {
    let lists = r
        .cluster_lists()
        .map_err(|e| e.to_string())?
        .ok_or("no cluster lists")?;
    let range = r
        .cluster_range()
        .map_err(|e| e.to_string())?
        .ok_or("no cluster range")?;
    let mut grid = Grid::of(v, scene);
    grid.range = (range.near as f64, range.far as f64);
    let bounds = cpu::cluster_bounds(&grid);
    let view = scene.camera.view();
    let lights = cpu::view_lights(&scene.lights, view);
    let listed = sorted_lists(&lists);
    let rasterised = v.clusters().culling == crate::variant::Culling::Rasterised;
    // Identical lights touch identical clusters: decide each distinct light once (a stress
    // case may stack thousands at one point).
    let mut touched: HashMap<&[u8], Vec<usize>> = HashMap::new();
    let (mut missing, mut first) = (0u64, None);
    for (i, light) in lights.iter().enumerate() {
        let clusters = touched
            .entry(bytemuck::bytes_of(&scene.lights[i]))
            .or_insert_with(|| {
                candidate_clusters(&grid, &bounds, light)
                    .into_iter()
                    .filter(|&(c, x, y, k)| {
                        let b = bounds[c].as_ref().expect("a candidate has a box");
                        clearly_touches(&grid, &scene.lights[i], light, view, b, (x, y, k))
                            && (!rasterised || in_proxy(&grid, light, (x, y, k)))
                    })
                    .map(|(c, ..)| c)
                    .collect()
            });
        for &c in clusters.iter() {
            if listed[c].binary_search(&(i as u32)).is_ok() {
                continue;
            }
            missing += 1;
            let what = if light.cone.is_some() {
                "spot"
            } else {
                "light"
            };
            first.get_or_insert_with(|| {
                let (x, y, k) = (
                    c as u32 % grid.x,
                    (c as u32 / grid.x) % grid.y,
                    c as u32 / (grid.x * grid.y),
                );
                format!(
                    "{what} {i} (view-space centre {:.4?}, radius {}) touches cluster {c} (tile {x}, {y}, slice {k}) but is not in its list of {}",
                    light.center.to_array(),
                    light.radius,
                    listed[c].len()
                )
            });
        }
    }
    Ok((missing, first))
}

/// The clusters (index, x, y, k) whose box meets the box around a light's sphere: every
/// cluster the sphere can touch. A cluster box's x extent depends on its tile column and
/// slice only, its y extent on its row and slice (`cpu::cluster_bounds`), so the columns
/// and rows of each slice are found on its first row and column.
fn candidate_clusters(
    grid: &Grid,
    bounds: &[Option<cpu::Aabb>],
    light: &cpu::ViewLight,
) -> Vec<(usize, u32, u32, u32)> {
    let reach = glam::DVec3::splat(light.radius);
    let (lo, hi) = (light.center - reach, light.center + reach);
    let meets = |x: u32, y: u32, k: u32, axis: usize| {
        bounds[grid.index(x, y, k)]
            .as_ref()
            .is_some_and(|b| b.min[axis] <= hi[axis] && b.max[axis] >= lo[axis])
    };
    let mut out = Vec::new();
    for k in (0..grid.z).filter(|&k| meets(0, 0, k, 2)) {
        let columns: Vec<u32> = (0..grid.x).filter(|&x| meets(x, 0, k, 0)).collect();
        for y in (0..grid.y).filter(|&y| meets(0, y, k, 1)) {
            out.extend(columns.iter().map(|&x| (grid.index(x, y, k), x, y, k)));
        }
    }
    out
}

/// Whether a light clearly lights part of a cluster, decided independently of the cluster
/// tests' own slack: a point light's sphere, 1e-4 smaller, against the cluster; a spot's own
/// cone (not its bounding sphere or widened cone), sampled over the cluster's frustum piece.
fn clearly_touches(
    grid: &Grid,
    light: &crate::common::Light,
    view_light: &cpu::ViewLight,
    view: glam::DMat4,
    b: &cpu::Aabb,
    (x, y, k): (u32, u32, u32),
) -> bool {
    let r = view_light.radius;
    if view_light.cone.is_none() {
        return cpu::sphere_touches_cluster(grid, view_light.center, r * (1.0 - 1e-4), b, x, y);
    }
    // The bounding sphere, unshrunk, only skips clusters no sample could be lit in.
    cpu::sphere_touches_cluster(grid, view_light.center, r, b, x, y)
        && cpu::spot_point_in_piece(grid, light, view, x, y, grid.slice_depths(k), 6).is_some()
}

/// Rasterised binning: whether the light's proxy in slice k, its sphere shrunk as in
/// `clearly_touches`, holds tile (x, y) (the proxy leaves out clusters whose box the sphere
/// meets where the slice's frustum piece is not; `tests/clustered.rs` checks against the
/// raster truth that no light reaching a sample is among them).
fn in_proxy(grid: &Grid, light: &cpu::ViewLight, (x, y, k): (u32, u32, u32)) -> bool {
    cpu::proxy_tiles(grid, light.center, light.radius * (1.0 - 1e-4), k)
        .is_some_and(|((x0, y0), (x1, y1))| (x0..=x1).contains(&x) && (y0..=y1).contains(&y))
}

/// Which variants a stress run uses: each case's own, or the user's (`--variants`), each
/// with the case's edits.
pub enum Subjects<'a> {
    BuiltIn,
    Given(&'a [LoadedVariant]),
}

/// One run a stress run plans: a case, a variant's name there, and the variant or why it
/// does not apply.
struct Planned<'c> {
    case: &'c Case,
    name: String,
    variant: Result<Variant, String>,
}

/// What a stress run says as it goes: a run about to start, a device replaced, and each case
/// once its runs are done, with how many of the applicable runs are done of how many.
pub enum Progress<'a> {
    Starting(&'a str),
    Note(&'a str),
    CaseDone {
        case: &'a str,
        runs: &'a [CaseRun],
        done: usize,
        total: usize,
    },
}

/// The cases whose name contains `filter` (all without one).
pub fn selected(filter: Option<&str>) -> Vec<Case> {
    cases()
        .into_iter()
        .filter(|c| filter.is_none_or(|f| c.name.contains(f)))
        .collect()
}

/// Run `cases` on `subjects`, every run checked; a run that does not apply (the case needs
/// what the variant lacks, or the adapter lacks its sample count) is recorded with why.
/// After a failed run the device is checked, and replaced when it is unusable, so one run's
/// broken device does not fail the runs after it.
pub fn run(
    gpu: &mut Gpu,
    composer: &Composer,
    cases: &[Case],
    subjects: Subjects,
    progress: &mut dyn FnMut(Progress),
) -> Vec<CaseRun> {
    let samples = &gpu.multisample_counts();
    let planned: Vec<Planned> = cases
        .iter()
        .flat_map(|case| {
            let runs: Vec<(String, Result<Variant, String>)> = match &subjects {
                Subjects::BuiltIn => case
                    .variants
                    .iter()
                    .map(|(n, v)| (n.clone(), Ok(v.clone())))
                    .collect(),
                Subjects::Given(given) => given
                    .iter()
                    .flat_map(|l| case.runs_of(&l.name, &l.variant))
                    .collect(),
            };
            runs.into_iter().map(move |(name, variant)| {
                let variant = variant.and_then(|v| {
                    if samples.contains(&v.msaa.samples) {
                        Ok(v)
                    } else {
                        Err(format!(
                            "the adapter does not multisample {} samples",
                            v.msaa.samples
                        ))
                    }
                });
                Planned {
                    case,
                    name,
                    variant,
                }
            })
        })
        .collect();
    let total = planned.iter().filter(|p| p.variant.is_ok()).count();
    let mut out: Vec<CaseRun> = Vec::new();
    // Why there is no usable device: the runs after that fail with it.
    let mut no_device: Option<String> = None;
    let mut done = 0;
    // Shared by the variants of a case that would compute the same reference frame.
    let mut references = ReferenceCache::default();
    for (i, p) in planned.iter().enumerate() {
        let case = p.case;
        if i > 0 && planned[i - 1].case.name != case.name {
            references = ReferenceCache::default();
        }
        let failed = |why: String| CaseRun {
            case: case.name.to_string(),
            variant: p.name.clone(),
            what: case.what.to_string(),
            ok: false,
            checks: vec![check("renders", false, why)],
            note: None,
            not_applicable: None,
        };
        let run = match (&p.variant, &no_device) {
            (Err(why), _) => CaseRun {
                ok: true,
                checks: Vec::new(),
                not_applicable: Some(why.clone()),
                ..failed(String::new())
            },
            (Ok(_), Some(why)) => failed(why.clone()),
            (Ok(v), None) => {
                progress(Progress::Starting(&format!("{} / {}", case.name, p.name)));
                gpu.begin_cell();
                let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    run_case(gpu, composer, &references, case, &p.name, v)
                }))
                .unwrap_or_else(|_| failed("panicked".into()));
                if !run.ok {
                    match gpu.renew_if_unusable() {
                        Ok(None) => {}
                        Ok(Some(broken)) => progress(Progress::Note(&format!(
                            "device unusable after {} / {} ({broken}); opened a new one",
                            case.name, p.name
                        ))),
                        Err(e) => no_device = Some(format!("no usable GPU device: {e}")),
                    }
                }
                run
            }
        };
        done += usize::from(p.variant.is_ok());
        out.push(run);
        let last_of_case = planned.get(i + 1).is_none_or(|n| n.case.name != case.name);
        if last_of_case {
            let first = out
                .iter()
                .rposition(|r| r.case != case.name)
                .map_or(0, |k| k + 1);
            progress(Progress::CaseDone {
                case: &case.name,
                runs: &out[first..],
                done,
                total,
            });
        }
    }
    out
}

/// One line per run, and the failed checks under it.
pub fn report(runs: &[CaseRun]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let mut case = "";
    for r in runs {
        if r.case != case {
            case = &r.case;
            let _ = writeln!(s, "{}: {}", r.case, r.what);
        }
        if let Some(why) = &r.not_applicable {
            let _ = writeln!(s, "  n/a    {}: {why}", r.variant);
            continue;
        }
        let _ = writeln!(
            s,
            "  {} {}",
            if r.ok { "ok    " } else { "FAILED" },
            r.variant
        );
        for c in r.checks.iter().filter(|c| !c.ok) {
            let _ = writeln!(s, "         {}: {}", c.check, c.detail);
        }
        if let Some(note) = &r.note {
            let _ = writeln!(s, "         note: {note}");
        }
    }
    let failed = runs.iter().filter(|r| !r.ok).count();
    let not_applicable = runs.iter().filter(|r| r.not_applicable.is_some()).count();
    let cases: std::collections::BTreeSet<&str> = runs.iter().map(|r| r.case.as_str()).collect();
    let _ = writeln!(
        s,
        "{} cases, {} runs, {} failed{}",
        cases.len(),
        runs.len() - not_applicable,
        failed,
        if not_applicable > 0 {
            format!(", {not_applicable} not applicable")
        } else {
            String::new()
        }
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::variant::{Clusters, Pipeline, ZSlicing};

    /// The candidates of every light hold every cluster whose box its sphere touches, on a
    /// grid that does not divide the image; some of those are in a slice's last column,
    /// which a scan one column short would lose.
    #[test]
    fn candidate_clusters_hold_every_cluster_a_sphere_touches() {
        let mut params = crate::scene::defaults("atrium").unwrap();
        (params.width, params.height, params.lights) = (100, 57, 200);
        let scene = crate::scene::generate("atrium", params).unwrap();
        let v = Variant {
            pipeline: Pipeline::ClusteredForward,
            clusters: Some(Clusters {
                grid: (7, 5, 9),
                slicing: ZSlicing::Exponential,
                ..Default::default()
            }),
            ..Default::default()
        };
        let grid = Grid::of(&v, &scene);
        let bounds = cpu::cluster_bounds(&grid);
        let lights = cpu::view_lights(&scene.lights, scene.camera.view());
        let (mut touched, mut lost_by_break) = (0, 0);
        for light in &lights {
            let candidates: Vec<usize> = candidate_clusters(&grid, &bounds, light)
                .into_iter()
                .map(|(c, ..)| c)
                .collect();
            for (c, b) in bounds.iter().enumerate() {
                let Some(b) = b else { continue };
                if !cpu::sphere_touches_box(light.center, light.radius, b) {
                    continue;
                }
                touched += 1;
                assert!(candidates.contains(&c), "cluster {c} of {light:?}");
                lost_by_break += usize::from(c as u32 % grid.x == grid.x - 1);
            }
        }
        assert!(
            touched > 1000 && lost_by_break > 0,
            "{touched} {lost_by_break}"
        );
    }
}
