//! Seeded synthetic scenes: geometry, materials (per-vertex albedo, roughness and
//! metallic), point and spot lights and a camera, all deterministic functions of their
//! parameters.

mod builtin;
pub mod export;
pub mod file;
mod mesh;
mod model;
mod pose;
mod textures;

pub use builtin::{SCENES, SceneInfo, find_scene, unknown};
pub use mesh::MeshBuilder;
pub use model::{
    Camera, FRAME_DT, MAX_LIGHTS, MAX_TIME_S, Motion, Scene, SceneError, SceneFile, SceneParams,
    TRANSPARENCY_SCENE, radius_problem,
};
pub use pose::CameraPose;
pub use textures::{MAX_TEXTURE_SIZE, TextureArray};

pub use crate::common::{Light, Vertex};

/// The default parameters of scene `name`: a built-in scene's, or a glTF file's (read on
/// first use).
pub fn defaults(name: &str) -> Result<SceneParams, SceneError> {
    if file::is_file(name) {
        return Ok(file::defaults(&*file::load(name)?));
    }
    find_scene(name)
        .map(|info| info.defaults)
        .ok_or_else(|| unknown(name))
}

/// Whether scene `name` made with `params` has lights that cannot move: a glTF file's own
/// lights stand where the file puts them (seeded lights in a file's bounds move as the
/// built-in scenes' do).
pub fn lights_fixed(name: &str, params: &SceneParams) -> Result<bool, SceneError> {
    if !file::is_file(name) {
        return Ok(false);
    }
    Ok(file::uses_own_lights(&*file::load(name)?, params))
}

/// The file behind scene `name` (None for a built-in scene).
pub fn file_of(name: &str) -> Result<Option<SceneFile>, SceneError> {
    if file::is_file(name) {
        return Ok(Some(file::load(name)?.file.clone()));
    }
    Ok(None)
}

/// Make scene `name` with `params`: a built-in scene, or a `.gltf` or `.glb` file.
pub fn generate(name: &str, params: SceneParams) -> Result<Scene, SceneError> {
    check_params(&params)?;
    let scene = if file::is_file(name) {
        file::instantiate(&*file::load(name)?, params)
    } else {
        let info = find_scene(name).ok_or_else(|| unknown(name))?;
        (info.generate)(params)
    };
    scene.check()?;
    Ok(scene)
}

fn check_params(params: &SceneParams) -> Result<(), SceneError> {
    if params.width == 0 || params.height == 0 {
        return Err(SceneError::BadParam(format!(
            "size {}x{}: width and height must be at least 1",
            params.width, params.height
        )));
    }
    if params.lights > MAX_LIGHTS {
        return Err(SceneError::BadParam(format!(
            "{} lights: at most {MAX_LIGHTS}",
            params.lights
        )));
    }
    if !(0.0..=1.0).contains(&params.spots) {
        return Err(SceneError::BadParam(format!(
            "spot fraction {}: it must be in 0..=1",
            params.spots
        )));
    }
    let (lo, hi) = params.radius_range;
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(SceneError::BadParam(format!(
            "light radius range {lo}..{hi}: both ends must be finite numbers"
        )));
    }
    if !(lo > 0.0 && lo <= hi) {
        return Err(SceneError::BadParam(format!(
            "light radius range {lo}..{hi}: both ends must be positive and min <= max"
        )));
    }
    if let Some(p) = radius_problem(hi) {
        return Err(SceneError::BadParam(format!(
            "light radius range {lo}..{hi}: {p}"
        )));
    }
    for (what, t) in [
        ("time", params.time),
        ("still time", params.motion.still_at),
    ] {
        if !(t.is_finite() && (0.0..=MAX_TIME_S).contains(&t)) {
            return Err(SceneError::BadParam(format!(
                "{what} {t}: it must be seconds in 0..={MAX_TIME_S}"
            )));
        }
    }
    if !(0.0..=1.0).contains(&params.motion.lights) {
        return Err(SceneError::BadParam(format!(
            "moving fraction {}: it must be in 0..=1",
            params.motion.lights
        )));
    }
    Ok(())
}
