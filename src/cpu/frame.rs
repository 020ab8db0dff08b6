//! The CPU reference frame: every covered pixel of the raster truth shaded with every light
//! in f64. Every variant's image is measured against this.

use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

use super::color::display8;
use super::light_grid::LightGrid;
use super::msaa::resolve;
use super::post::{Geometry, Image, PostParams};
use super::shading::{ShadingParams, direct_light};
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
    exposure: f64,
) -> ReferenceFrame {
    let covered: Vec<DVec3> = (0..truth.position.len())
        .filter(|&i| truth.covered(i))
        .map(|i| truth.surface(i).position)
        .chain(truth.blended.iter().map(|f| f.surface().position))
        .collect();
    let grid = LightGrid::new(&covered, lights).filter(|g| g.culls(&covered, lights.len()));
    // A surface's colour, and whether some light reaches it with light.
    let shade = |s: &super::shading::Surface| {
        let direct = match &grid {
            Some(grid) => {
                let near = grid.lights_at(s.position).iter();
                direct_light(s, eye, near.map(|&l| &lights[l as usize]), params)
            }
            None => direct_light(s, eye, lights.iter(), params),
        };
        // As `shade_lights` sums them, bit for bit.
        (
            direct + s.albedo * params.ambient,
            direct.max_element() > 0.0,
        )
    };
    let (colours, lit): (Vec<[f64; 3]>, Vec<bool>) = (0..truth.position.len())
        .into_par_iter()
        .map(|i| {
            SHADED_SAMPLES.fetch_add(1, Ordering::Relaxed);
            if !truth.covered(i) {
                return ([0.0; 3], false);
            }
            let (colour, lit) = shade(&truth.surface(i));
            (colour.to_array(), lit)
        })
        .unzip();
    // A pixel's samples resolved to one colour; a pixel is covered and lit where one of its
    // samples is.
    let n = truth.samples.max(1) as usize;
    let mut hdr: Vec<[f64; 3]> = if n == 1 {
        colours
    } else {
        colours
            .chunks(n)
            .map(|samples| resolve(samples, params.resolve))
            .collect()
    };
    let any =
        |flags: &[bool]| -> u64 { flags.chunks(n).filter(|c| c.contains(&true)).count() as u64 };
    let mut covered_samples: Vec<bool> = (0..truth.position.len())
        .map(|i| truth.covered(i))
        .collect();
    let mut lit = lit;
    if !truth.blended.is_empty() {
        // Blended materials are drawn at one sample a pixel (`render::limits`).
        hdr.par_iter_mut()
            .zip(lit.par_iter_mut())
            .enumerate()
            .for_each(|(i, (c, lit))| {
                let mut colour = DVec3::from(*c);
                for f in truth.blended_at(i) {
                    let (shaded, reached) = shade(&f.surface());
                    let alpha = f.alpha();
                    colour = alpha * shaded + (1.0 - alpha) * colour;
                    *lit |= reached;
                }
                *c = colour.to_array();
            });
        for (i, covered) in covered_samples.iter_mut().enumerate() {
            *covered |= !truth.blended_at(i).is_empty();
        }
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
