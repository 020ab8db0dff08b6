//! The CPU reference frame: every covered pixel of the raster truth shaded with every light
//! in f64. Every variant's image is measured against this.

use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

use super::color::display8;
use super::light_grid::LightGrid;
use super::msaa::resolve;
use super::occlusion::Seen;
use super::post::{Geometry, Image, PostParams};
use super::shading::{ShadingParams, Surface, direct_light, light_contribution};
use super::shadows::ShadowRays;
use super::truth::RasterTruth;
use crate::common::Light;

/// Samples shaded by every reference frame of this process so far: how far one under way
/// has got (the viewer's progress bar reads it before and during one).
static SHADED_SAMPLES: AtomicU64 = AtomicU64::new(0);

/// Samples [`shade_reference`] has shaded in this process so far.
pub fn shaded_samples() -> u64 {
    SHADED_SAMPLES.load(Ordering::Relaxed)
}

/// A reference frame: linear HDR and 8-bit display values per pixel, row-major.
#[derive(Clone, Debug)]
pub struct ReferenceFrame {
    pub width: u32,
    pub height: u32,
    pub hdr: Vec<[f64; 3]>,
    pub ldr: Vec<[u8; 3]>,
    /// Pixels the geometry covers.
    pub covered: u64,
    /// Covered pixels some light reaches with light (a radiance above 0 before post effects).
    pub lit: u64,
    /// With shadows: what the rays found, and where a pixel's ambiguous pairs let the GPU's
    /// image differ.
    pub shadows: Option<ShadowFigures>,
}

/// What a shadowed reference's rays found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShadowFigures {
    /// Pairs (sample or blended fragment, light) whose light is above 0: each a ray.
    pub pairs: u64,
    /// Pairs the reference found blocked (ambiguous ones included where its own f64 ray is).
    pub blocked: u64,
    /// Pairs within the GPU's error of an occluder's edge or surface.
    pub ambiguous: u64,
    /// Every pixel with an ambiguous pair: its index, and the lowest and highest display
    /// values its colour may take (each ambiguous light left out, or added).
    pub ranges: Vec<(u32, [u8; 3], [u8; 3])>,
}

/// One surface shaded: its colour, whether some light reached it, and with shadows the
/// light of its ambiguous pairs that the colour holds and leaves out.
#[derive(Clone, Copy, Default)]
struct Shaded {
    colour: DVec3,
    reached: bool,
    held: DVec3,
    left: DVec3,
    pairs: u64,
    blocked: u64,
    ambiguous: u64,
}

/// The lights' part of a surface's shading, and whether some light reaches it with light.
fn shade_with<'a>(
    s: &Surface,
    eye: DVec3,
    near: impl Iterator<Item = &'a Light>,
    params: &ShadingParams,
    shadows: Option<&ShadowRays>,
) -> Shaded {
    let mut shaded = match shadows {
        Some(rays) => shadowed_light(s, eye, near, params, rays),
        None => Shaded {
            colour: direct_light(s, eye, near, params),
            ..Shaded::default()
        },
    };
    shaded.reached = shaded.colour.max_element() > 0.0;
    shaded
}

/// The lights' part of a surface's shading with shadow rays: each light above 0 is traced;
/// a blocked one adds nothing, an ambiguous one what the reference's own ray finds.
fn shadowed_light<'a>(
    s: &Surface,
    eye: DVec3,
    lights: impl Iterator<Item = &'a Light>,
    params: &ShadingParams,
    rays: &ShadowRays,
) -> Shaded {
    let to_eye = (eye - s.position).normalize_or_zero();
    let mut out = Shaded::default();
    for light in lights {
        let c = light_contribution(s, to_eye, light, params);
        if c.max_element() <= 0.0 {
            continue;
        }
        out.pairs += 1;
        let centre = DVec3::from(light.position.map(f64::from));
        let (seen, _) = rays.trace(s.position, s.normal, centre);
        let blocked = match seen {
            Seen::Open => false,
            Seen::Blocked => true,
            Seen::Ambiguous => {
                out.ambiguous += 1;
                let blocked = rays.blocked(s.position, s.normal, centre);
                if blocked {
                    out.left += c;
                } else {
                    out.held += c;
                }
                blocked
            }
        };
        if blocked {
            out.blocked += 1;
        } else {
            out.colour += c;
        }
    }
    out
}

/// Shade every covered sample of `truth` with all `lights` and resolve each pixel's samples
/// (`params.resolve`); background stays black. Then each pixel's blended fragments, in the
/// order the frame blends them, each shaded as an opaque surface is and laid over the
/// colour with the over operator: `c = alpha shade + (1 - alpha) c`. Where a
/// `LightGrid` is made and culls, each pixel sums the lights of its cell, in index order:
/// the sum of every light's contribution, bit for bit, since the others add exactly 0.
pub fn shade_reference(
    truth: &RasterTruth,
    lights: &[Light],
    eye: DVec3,
    params: &ShadingParams,
    shadows: Option<&ShadowRays>,
    exposure: f64,
) -> ReferenceFrame {
    let covered: Vec<DVec3> = (0..truth.position.len())
        .filter(|&i| truth.covered(i))
        .map(|i| truth.surface(i).position)
        .chain(truth.blended.iter().map(|f| f.surface().position))
        .collect();
    let grid = LightGrid::new(&covered, lights).filter(|g| g.culls(&covered, lights.len()));
    // A surface's colour, whether some light reaches it with light, and what its shadows'
    // ambiguous pairs hold and leave out.
    let shade = |s: &Surface| {
        let mut shaded = match &grid {
            Some(grid) => {
                let near = grid.lights_at(s.position).iter();
                shade_with(s, eye, near.map(|&l| &lights[l as usize]), params, shadows)
            }
            None => shade_with(s, eye, lights.iter(), params, shadows),
        };
        // As `shade_lights` sums them, bit for bit.
        shaded.colour += s.albedo * params.ambient;
        shaded
    };
    let shaded: Vec<Shaded> = (0..truth.position.len())
        .into_par_iter()
        .map(|i| {
            SHADED_SAMPLES.fetch_add(1, Ordering::Relaxed);
            if !truth.covered(i) {
                return Shaded::default();
            }
            shade(&truth.surface(i))
        })
        .collect();
    // A pixel's samples resolved to one colour; a pixel is covered and lit where one of its
    // samples is. With shadows, the lowest and highest colours resolve alike.
    let n = truth.samples.max(1) as usize;
    let resolved = |part: &dyn Fn(&Shaded) -> DVec3| -> Vec<[f64; 3]> {
        let colours: Vec<[f64; 3]> = shaded.iter().map(|s| part(s).to_array()).collect();
        if n == 1 {
            colours
        } else {
            colours
                .chunks(n)
                .map(|samples| resolve(samples, params.resolve))
                .collect()
        }
    };
    let mut hdr = resolved(&|s| s.colour);
    let ambiguous_samples = shadows.is_some() && shaded.iter().any(|s| s.ambiguous > 0);
    let (mut low, mut high) = if ambiguous_samples {
        (
            resolved(&|s| s.colour - s.held),
            resolved(&|s| s.colour + s.left),
        )
    } else {
        (Vec::new(), Vec::new())
    };
    let mut figures = shadows.map(|_| ShadowFigures::default());
    let mut count = |s: &Shaded| {
        if let Some(f) = figures.as_mut() {
            f.pairs += s.pairs;
            f.blocked += s.blocked;
            f.ambiguous += s.ambiguous;
        }
    };
    shaded.iter().for_each(&mut count);
    let any =
        |flags: &[bool]| -> u64 { flags.chunks(n).filter(|c| c.contains(&true)).count() as u64 };
    let mut covered_samples: Vec<bool> = (0..truth.position.len())
        .map(|i| truth.covered(i))
        .collect();
    let mut lit: Vec<bool> = shaded.iter().map(|s| s.reached).collect();
    let mut blended_ambiguous = vec![false; hdr.len()];
    if !truth.blended.is_empty() {
        // Blended materials are drawn at one sample a pixel (`render::limits`).
        let layered: Vec<Vec<Shaded>> = (0..hdr.len())
            .into_par_iter()
            .map(|i| {
                truth
                    .blended_at(i)
                    .iter()
                    .map(|f| shade(&f.surface()))
                    .collect()
            })
            .collect();
        for (i, layers) in layered.iter().enumerate() {
            let mut colour = DVec3::from(hdr[i]);
            let mut bounds = (!low.is_empty()).then(|| (DVec3::from(low[i]), DVec3::from(high[i])));
            for (f, s) in truth.blended_at(i).iter().zip(layers) {
                let alpha = f.alpha();
                // The first ambiguous layer starts the range from what lies under it.
                if s.ambiguous > 0 && bounds.is_none() {
                    bounds = Some((colour, colour));
                }
                colour = alpha * s.colour + (1.0 - alpha) * colour;
                if let Some((lo, hi)) = bounds.as_mut() {
                    *lo = alpha * (s.colour - s.held) + (1.0 - alpha) * *lo;
                    *hi = alpha * (s.colour + s.left) + (1.0 - alpha) * *hi;
                }
                blended_ambiguous[i] |= s.ambiguous > 0;
                lit[i] |= s.reached;
                count(s);
            }
            hdr[i] = colour.to_array();
            if let Some((lo, hi)) = bounds {
                if low.is_empty() {
                    low = hdr.clone();
                    high = hdr.clone();
                }
                low[i] = lo.to_array();
                high[i] = hi.to_array();
            }
        }
        for (i, covered) in covered_samples.iter_mut().enumerate() {
            *covered |= !truth.blended_at(i).is_empty();
        }
    }
    if let Some(f) = figures.as_mut() {
        let ambiguous_pixel = |i: usize| {
            blended_ambiguous[i] || shaded[i * n..(i + 1) * n].iter().any(|s| s.ambiguous > 0)
        };
        f.ranges = (0..hdr.len())
            .filter(|&i| ambiguous_pixel(i))
            .map(|i| {
                (
                    i as u32,
                    display8(low[i], exposure),
                    display8(high[i], exposure),
                )
            })
            .collect();
    }
    let ldr = hdr.iter().map(|&c| display8(c, exposure)).collect();
    let covered = any(&covered_samples);
    let lit = any(&lit);
    ReferenceFrame {
        width: truth.width,
        height: truth.height,
        hdr,
        ldr,
        covered,
        lit,
        shadows: figures,
    }
}

/// Apply the variant's post effects to a reference frame, in f64, on the geometry of the
/// raster truth.
pub fn post_process(
    frame: &mut ReferenceFrame,
    params: &PostParams,
    geometry: &Geometry,
    exposure: f64,
) {
    if !params.any() {
        return;
    }
    let image = Image::new(
        frame.width,
        frame.height,
        frame.hdr.iter().map(|&c| DVec3::from(c)).collect(),
    );
    let out = super::post::apply(params, &image, geometry);
    frame.hdr = out.pixels.iter().map(|c| c.to_array()).collect();
    frame.ldr = frame.hdr.iter().map(|&c| display8(c, exposure)).collect();
}
