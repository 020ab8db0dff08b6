//! The reference frame of a cell: the variant's own rasterisation, read back at full
//! precision, shaded and post-processed by the CPU twins in f64; and (`inputs`) the adapters
//! that read the twins' plain parameters off a variant and a scene.

mod inputs;

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use crate::compose::Composer;
use crate::cpu::frame::{ReferenceFrame, post_process, shade_reference};
use crate::cpu::post::{CameraPair, Geometry, PostParams};
use crate::cpu::shading::ShadingParams;
use crate::cpu::shadows::ShadowRays;
use crate::cpu::truth::RasterTruth;
use crate::gpu::Gpu;
use crate::render::RenderError;
use crate::render::raster_truth;
use crate::render::shadows::Occluders;
use crate::scene::Scene;
use crate::variant::LoadedVariant;

/// Exposure of the tonemap (fixed: images of different variants are comparable).
pub const EXPOSURE: f64 = 1.0;

/// Reference frames by what determines them, so that variants which rasterise, shade and
/// post-process alike share one (the matrix runs many such cells). Below the whole frames,
/// the f64 shading (most of a reference's time) is shared too: by variants that differ only
/// in their post effects, and by variants whose rasterisations agree bit for bit though
/// their depth set-up differs (a depth pre-pass or another depth format mostly changes
/// nothing in the raster truth).
#[derive(Default)]
pub struct ReferenceCache {
    /// Frames by what they depend on: the compositions their raster truth used (logged
    /// again for each cell that takes the frame) and the frame with the time it took, once
    /// shaded.
    frames: Mutex<HashMap<String, Kept>>,
    /// Shadings before post effects, by scene (name, file and parameters).
    shadings: Mutex<HashMap<String, Vec<Shading>>>,
    /// The occluders of each scene that a variant with shadows was shaded on.
    occluders: Mutex<HashMap<String, Arc<Occluders>>>,
}

type Kept = (Vec<Arc<crate::compose::Composition>>, Slot);

/// A reference frame and the milliseconds it took.
type Shaded = (Arc<ReferenceFrame>, f64);

/// Where a begun frame lands once shaded: the frame, or word that it never will be.
type Slot = Arc<OnceLock<Result<Shaded, ()>>>;

/// A job's hold on its slot: a job dropped unfinished (its shading panicked, the thread
/// meant to finish it is gone) marks the slot failed, so no cell waits on it forever.
pub struct Fill(Slot);

impl Drop for Fill {
    fn drop(&mut self) {
        let _ = self.0.set(Err(()));
    }
}

/// Why a reference frame was not made.
#[derive(Debug, thiserror::Error)]
pub enum ReferenceError {
    /// Its raster truth could not be rendered.
    #[error("{0}")]
    Truth(#[from] RenderError),
    /// The cell that began the frame this one shares failed before shading it.
    #[error("the reference frame this cell shares failed in an earlier cell")]
    Shared,
}

/// A reference frame begun on the GPU (`ReferenceCache::begin`), to finish on the CPU.
pub enum ReferenceJob {
    /// Shade this raster truth, and keep the frame for the cells that wait for it.
    Shade {
        truth: RasterTruth,
        scene_key: String,
        slot: Fill,
    },
    /// Take the frame an earlier job shades (waiting until it has).
    Wait(Slot),
}

/// One raster truth shaded in f64, before post effects.
struct Shading {
    truth: Arc<RasterTruth>,
    params: ShadingParams,
    frame: Arc<ReferenceFrame>,
    /// What the shading took when it was computed.
    ms: f64,
}

impl std::fmt::Debug for ReferenceCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.frames.lock().map_or(0, |m| m.len());
        write!(f, "ReferenceCache({n} frames)")
    }
}

impl ReferenceCache {
    /// Reference frames held, and the f64 shadings they were made from.
    pub fn counts(&self) -> (usize, usize) {
        let frames = self.frames.lock().map_or(0, |m| m.len());
        let shadings = self
            .shadings
            .lock()
            .map_or(0, |m| m.values().map(Vec::len).sum());
        (frames, shadings)
    }

    /// The reference frame of `variant` on `scene`, computed once per distinct frame, and
    /// the milliseconds it took when computed (the same figure for every cell sharing it).
    pub fn get_or_compute(
        &self,
        gpu: &Gpu,
        composer: &Composer,
        variant: &LoadedVariant,
        scene: &Scene,
    ) -> Result<(Arc<ReferenceFrame>, f64), ReferenceError> {
        let job = self.begin(gpu, composer, variant, scene)?;
        self.finish(job, variant, scene)
    }

    /// The GPU half of a reference: its raster truth, unless a cell before asked for the
    /// same frame (then the job waits for that cell's to be finished, on whichever thread).
    /// A frame is shaded by the job that began it: begin only where the job will be
    /// finished (a job dropped unfinished fails the cells that share its frame).
    pub fn begin(
        &self,
        gpu: &Gpu,
        composer: &Composer,
        variant: &LoadedVariant,
        scene: &Scene,
    ) -> Result<ReferenceJob, ReferenceError> {
        let v = &variant.variant;
        let scene_key = scene_key_of(scene);
        // Everything the raster truth, the shading and the post chain depend on.
        let key = format!(
            "{scene_key}|{:?}|{:?}|{:?}|{}|{:?}",
            ShadingParams::of(v),
            PostParams::of(v),
            v.depth,
            v.depth_prepass,
            v.msaa
        );
        if let Some((used, slot)) = self.frames.lock().expect("cache lock").get(&key) {
            composer.relog(used);
            return Ok(ReferenceJob::Wait(slot.clone()));
        }
        let mark = composer.log_mark();
        let truth = raster_truth(gpu, composer, v, scene)?;
        let slot = Arc::new(OnceLock::new());
        self.frames
            .lock()
            .expect("cache lock")
            .insert(key, (composer.logged_since(mark), slot.clone()));
        Ok(ReferenceJob::Shade {
            truth,
            scene_key,
            slot: Fill(slot),
        })
    }

    /// The CPU half: shade and post-process the truth in f64 (sharing a shading another
    /// variant made from the same truth), or take the frame the job waits for.
    pub fn finish(
        &self,
        job: ReferenceJob,
        variant: &LoadedVariant,
        scene: &Scene,
    ) -> Result<(Arc<ReferenceFrame>, f64), ReferenceError> {
        let (truth, scene_key, slot) = match job {
            ReferenceJob::Wait(slot) => {
                return slot.wait().clone().map_err(|()| ReferenceError::Shared);
            }
            ReferenceJob::Shade {
                truth,
                scene_key,
                slot,
            } => (truth, scene_key, slot),
        };
        let v = &variant.variant;
        let post_params = PostParams::of(v);
        let (shaded, shading_ms) = self.shading(scene_key, truth, ShadingParams::of(v), scene);
        let start = Instant::now();
        // Without post effects the frame is the shading itself, held once.
        let frame = if post_params.any() {
            let mut frame = Arc::unwrap_or_clone(shaded.frame);
            post(&mut frame, &shaded.truth, &post_params, variant, scene);
            Arc::new(frame)
        } else {
            shaded.frame
        };
        let entry = (frame, shading_ms + start.elapsed().as_secs_f64() * 1e3);
        let _ = slot.0.set(Ok(entry.clone()));
        Ok(entry)
    }

    /// `truth` shaded with `params`, shared with an earlier variant of the same scene whose
    /// truth is the same bit for bit and which shades alike; and the time the shading took.
    fn shading(
        &self,
        scene_key: String,
        truth: RasterTruth,
        params: ShadingParams,
        scene: &Scene,
    ) -> (SharedShading, f64) {
        let mut shadings = self.shadings.lock().expect("cache lock");
        let known = shadings.entry(scene_key).or_default();
        // One copy of each distinct truth, whatever shadings it has.
        let same_truth = known
            .iter()
            .find(|s| s.truth.same_as(&truth))
            .map(|s| s.truth.clone());
        if let Some(same) = &same_truth
            && let Some(s) = known
                .iter()
                .find(|s| Arc::ptr_eq(&s.truth, same) && s.params == params)
        {
            let shared = SharedShading {
                truth: s.truth.clone(),
                frame: s.frame.clone(),
            };
            return (shared, s.ms);
        }
        let truth = same_truth.unwrap_or_else(|| Arc::new(truth));
        let start = Instant::now();
        let occluders = params.shadows.map(|_| {
            let mut kept = self.occluders.lock().expect("cache lock");
            kept.entry(scene_key_of(scene))
                .or_insert_with(|| Arc::new(Occluders::of(scene)))
                .clone()
        });
        let frame = Arc::new(shade(&truth, scene, &params, occluders.as_deref()));
        let ms = start.elapsed().as_secs_f64() * 1e3;
        known.push(Shading {
            truth: truth.clone(),
            params,
            frame: frame.clone(),
            ms,
        });
        (SharedShading { truth, frame }, ms)
    }
}

/// `truth` shaded in f64 with `scene`'s lights, tracing shadow rays to `occluders` where
/// `params` has shadows.
fn shade(
    truth: &RasterTruth,
    scene: &Scene,
    params: &ShadingParams,
    occluders: Option<&Occluders>,
) -> ReferenceFrame {
    let rays = params.shadows.zip(occluders).map(|(source, o)| ShadowRays {
        bvh: &o.bvh,
        eye: scene.camera.eye,
        view: scene.camera.view(),
        near: scene.camera.near,
        source,
    });
    shade_reference(
        truth,
        &scene.lights,
        scene.camera.eye,
        params,
        rays.as_ref(),
        EXPOSURE,
    )
}

/// What tells scenes apart: name, file and parameters.
fn scene_key_of(scene: &Scene) -> String {
    format!(
        "{}|{:?}|{:?}",
        scene.name,
        scene.file.as_ref().map(|f| &f.sha256),
        scene.params
    )
}

/// A cached shading and the truth it was shaded from.
struct SharedShading {
    truth: Arc<RasterTruth>,
    frame: Arc<ReferenceFrame>,
}

/// Apply `variant`'s post effects (`params`) to a shaded reference frame.
fn post(
    frame: &mut ReferenceFrame,
    truth: &RasterTruth,
    params: &PostParams,
    variant: &LoadedVariant,
    scene: &Scene,
) {
    let cams = CameraPair::of(scene, variant.variant.depth.mapping());
    let geometry = Geometry::from_truth(&truth.first_samples(), &cams);
    post_process(frame, params, &geometry, EXPOSURE);
}

/// The raster truth of the variant's rasterisation, shaded and post-processed on the CPU
/// in f64.
pub fn reference_frame(
    gpu: &Gpu,
    composer: &Composer,
    variant: &LoadedVariant,
    scene: &Scene,
) -> Result<(ReferenceFrame, f64), ReferenceError> {
    let truth = raster_truth(gpu, composer, &variant.variant, scene)?;
    let start = Instant::now();
    let params = ShadingParams::of(&variant.variant);
    let occluders = params.shadows.map(|_| Occluders::of(scene));
    let mut reference = shade(&truth, scene, &params, occluders.as_ref());
    let params = PostParams::of(&variant.variant);
    if params.any() {
        post(&mut reference, &truth, &params, variant, scene);
    }
    Ok((reference, start.elapsed().as_secs_f64() * 1e3))
}
