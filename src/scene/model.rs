//! What a scene is: its geometry, lights, camera and motion, the parameters that make it,
//! and why one could not be made.

use super::textures::TextureArray;
use std::sync::Arc;

use glam::{DMat4, DVec3};

use crate::common::{DepthMapping, MAX_LIGHT_RADIUS, MAX_LIGHT_RADIUS_WHY};
use crate::common::{Light, Vertex};

/// A perspective camera, right-handed, looking from `eye` at `target`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: DVec3,
    pub target: DVec3,
    pub up: DVec3,
    /// Vertical field of view, radians.
    pub fov_y: f64,
    pub near: f64,
    /// The far plane: beyond every piece of geometry (also with reversed-Z, where the
    /// projection's far plane is at infinity and this bounds clustering).
    pub far: f64,
}

impl Camera {
    /// The camera at `eye` turned by `rotation` (glTF's convention: it looks down its local
    /// -Z with +Y up). Built-in scenes and glTF files both make their cameras here, from
    /// single-precision values, so a scene exported to glTF and loaded back has the very
    /// same camera.
    pub fn from_pose(
        eye: glam::Vec3,
        rotation: glam::Quat,
        fov_y: f32,
        near: f32,
        far: f32,
    ) -> Camera {
        let eye = eye.as_dvec3();
        // A zero quaternion (a broken file) looks down -Z rather than making NaNs.
        let rotation = rotation.as_dquat();
        let rotation = if rotation.length() > 1e-12 {
            rotation.normalize()
        } else {
            glam::DQuat::IDENTITY
        };
        Camera {
            eye,
            target: eye + rotation * DVec3::NEG_Z,
            up: rotation * DVec3::Y,
            fov_y: fov_y as f64,
            near: near as f64,
            far: far as f64,
        }
    }

    /// The rotation of a camera at `eye` looking at `target` with `up` roughly up (the
    /// inverse of `from_pose`'s).
    pub fn look_rotation(eye: DVec3, target: DVec3, up: DVec3) -> glam::DQuat {
        let world_from_view = DMat4::look_at_rh(eye, target, up).inverse();
        glam::DQuat::from_mat4(&world_from_view).normalize()
    }

    pub fn view(&self) -> DMat4 {
        DMat4::look_at_rh(self.eye, self.target, self.up)
    }

    /// Projection to wgpu clip space (depth 0..1) with the given depth mapping.
    pub fn projection(&self, aspect: f64, mapping: DepthMapping) -> DMat4 {
        mapping.projection(self.fov_y, aspect, self.near, self.far)
    }

    /// Why this camera cannot make a meaningful frame, if it cannot: no field of view, a near
    /// plane at or behind the eye, a far plane not beyond it, a pose that is not finite, or a
    /// view-projection that overflows single precision (what the GPU computes with).
    pub fn problem(&self, aspect: f64) -> Option<String> {
        if !(self.fov_y.is_finite() && self.fov_y > 0.0 && self.fov_y < std::f64::consts::PI) {
            return Some(format!(
                "its vertical field of view is {} rad: it lies strictly between 0 and pi",
                self.fov_y
            ));
        }
        if !(self.near.is_finite() && self.near > 0.0) {
            return Some(format!(
                "its near plane is at {}: it is a positive distance in front of the eye",
                self.near
            ));
        }
        if !(self.far.is_finite() && self.far > self.near) {
            return Some(format!(
                "its far plane, at {}, is not beyond its near plane, at {}",
                self.far, self.near
            ));
        }
        if ![self.eye, self.target, self.up]
            .iter()
            .all(|v| v.is_finite())
        {
            return Some(format!(
                "its eye {:?} or direction is not finite",
                self.eye.to_array()
            ));
        }
        let clip = self.projection(aspect, DepthMapping::default()) * self.view();
        if !clip.as_mat4().is_finite() {
            return Some(format!(
                "its view-projection is not finite in single precision (eye {:?}: too far out for the GPU's numbers)",
                self.eye.to_array()
            ));
        }
        None
    }
}

/// Why `radius` is not a light radius clusterlab shades, if it is not: one in
/// (0, MAX_LIGHT_RADIUS].
pub fn radius_problem(radius: f32) -> Option<String> {
    if !(radius.is_finite() && radius > 0.0) {
        return Some(format!(
            "{radius} is not a light radius: radii are positive distances of at most {MAX_LIGHT_RADIUS:e}"
        ));
    }
    over_radius_limit(radius)
}

/// Why `radius` is over `MAX_LIGHT_RADIUS`, if it is.
fn over_radius_limit(radius: f32) -> Option<String> {
    (radius > MAX_LIGHT_RADIUS).then(|| {
        format!("{radius:e} is over the largest light radius, {MAX_LIGHT_RADIUS:e}: {MAX_LIGHT_RADIUS_WHY}")
    })
}

/// What a scene generator is asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneParams {
    pub width: u32,
    pub height: u32,
    pub lights: u32,
    /// Light radii are drawn uniformly from this range (world units).
    pub radius_range: (f32, f32),
    pub seed: u64,
    /// Time of the frame in seconds: lights and camera move with it.
    pub time: f64,
    /// Fraction of the lights that are spots, in [0, 1] (drawn per light from a stream of
    /// its own, so the lights' positions and colours do not depend on it).
    pub spots: f32,
    /// What moves with time: the lights, some of them or none, and the camera.
    pub motion: Motion,
}

/// What moves with time. A still light or camera stays where it was at `still_at` (a
/// sequence's first frame), so a sequence can move some of its lights and not the rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// Fraction of the lights that move, in [0, 1] (drawn per light from a stream of its
    /// own, so a light that moves at 0.1 also moves at 0.5, and positions and colours do not
    /// depend on it).
    pub lights: f32,
    /// Whether the camera moves along its path.
    pub camera: bool,
    /// The time, in seconds, whose pose still lights and a still camera keep.
    pub still_at: f64,
}

impl Motion {
    /// Every light and the camera move (the built-in scenes' default).
    pub const ALL: Motion = Motion {
        lights: 1.0,
        camera: true,
        still_at: 0.0,
    };

    /// The time at which a part that moves (`moves`) is posed in a frame at `time`.
    pub fn pose_time(&self, moves: bool, time: f64) -> f64 {
        if moves { time } else { self.still_at }
    }
}

/// Time between the previous frame and this one (motion vectors, previous-frame depth).
pub const FRAME_DT: f64 = 1.0 / 30.0;
/// The built-in scene with blended panes and masked cut-outs: the transparency study and
/// the default matrix's transparency group run it.
pub const TRANSPARENCY_SCENE: &str = "glass";
/// Most lights a scene may have.
pub const MAX_LIGHTS: u32 = 1 << 20;
/// Latest time of a frame, seconds: the built-in cameras have long left their scenes by then.
pub const MAX_TIME_S: f64 = 3600.0;

/// A generated scene, ready to upload.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub params: SceneParams,
    pub vertices: Vec<Vertex>,
    /// Triangles of opaque and masked materials.
    pub indices: Vec<u32>,
    /// Triangles of blended materials, in the scene's order (`blend_order` sorts them for a
    /// frame).
    pub blended: Vec<u32>,
    /// Lights at `params.time`.
    pub lights: Vec<Light>,
    pub camera: Camera,
    /// The camera one frame earlier (`time - FRAME_DT`).
    pub prev_camera: Camera,
    /// The lights that move with time, by index, ascending (their lists must be rebuilt from
    /// frame to frame; the others stay where they are); the geometry never moves.
    pub moving_lights: Vec<u32>,
    /// The base colour textures the vertices' `texture` layers index (file scenes).
    pub textures: Option<Arc<TextureArray>>,
    /// The file the scene was loaded from; `None` for a built-in scene.
    pub file: Option<SceneFile>,
    /// What the loader left out or chose, one line each (printed by `render`).
    pub notes: Vec<String>,
}

/// A file scene's identity: two files are two scenes, whatever their paths.
#[derive(Clone, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub struct SceneFile {
    /// The path as given.
    pub path: String,
    /// SHA-256 of the file and of every buffer and image it references, in that order
    /// (lowercase hex).
    pub sha256: String,
}

impl Scene {
    /// Whether some light moves from frame to frame.
    pub fn lights_move(&self) -> bool {
        !self.moving_lights.is_empty()
    }

    pub fn aspect(&self) -> f64 {
        self.params.width as f64 / self.params.height as f64
    }

    /// The far plane that encloses every vertex as seen from `eye`, with a margin.
    /// Check what a frame is computed from: cameras that can render (now and one frame
    /// earlier) and lights the cluster tests represent.
    pub fn check(&self) -> Result<(), SceneError> {
        let fail = |message: String| match &self.file {
            Some(f) => SceneError::File {
                path: f.path.clone(),
                message,
            },
            None => SceneError::BadParam(format!("scene `{}`: {message}", self.name)),
        };
        let aspect = self.aspect();
        if let Some(p) = self.camera.problem(aspect) {
            return Err(fail(format!(
                "the camera at time {} s: {p}",
                self.params.time
            )));
        }
        if let Some(p) = self.prev_camera.problem(aspect) {
            return Err(fail(format!(
                "the camera one frame earlier (time {} s): {p}",
                self.params.time - FRAME_DT
            )));
        }
        for (i, l) in self.lights.iter().enumerate() {
            // A scene made in code may hold lights of radius 0: they light nothing, exactly
            // (a stress case has them). A radius given by a user is positive (`radius_problem`).
            let problem = match l.radius {
                r if r >= 0.0 => over_radius_limit(r),
                r => Some(format!("its radius {r} is negative or not a number")),
            };
            if let Some(p) = problem {
                return Err(fail(format!("light {i}: {p}")));
            }
            if !l
                .position
                .iter()
                .chain(&l.color)
                .chain(&l.direction)
                .all(|x| x.is_finite())
            {
                return Err(fail(format!(
                    "light {i}: its position, colour or axis is not finite"
                )));
            }
        }
        Ok(())
    }

    /// Whether some opaque triangle's material is masked (an alpha cutoff above 0): the
    /// raster passes then discard below it.
    pub fn has_masks(&self) -> bool {
        self.indices.iter().any(|&i| {
            self.vertices
                .get(i as usize)
                .is_some_and(|v| v.alpha[1] > 0.0)
        })
    }

    /// Whether the scene has blended triangles: a frame then draws them over its opaque
    /// picture in a transparent pass.
    pub fn has_blend(&self) -> bool {
        !self.blended.is_empty()
    }

    /// The blended triangles in the order every frame draws them: back to front, by the
    /// view depth of each triangle's centroid (the mean of its corners, in f64) under the
    /// frame's camera, the farthest first; triangles at the same depth in the scene's
    /// order. A triangle is blended whole, so where two triangles cross, the one drawn
    /// later is over the other on both sides of the crossing (the reference blends in the
    /// same order, so that is what both agree on).
    pub fn blend_order(&self) -> Vec<u32> {
        let view = self.camera.view();
        let depth = |t: &[u32]| {
            let centroid = t
                .iter()
                .map(|&i| DVec3::from(self.vertices[i as usize].position.map(f64::from)))
                .sum::<DVec3>()
                / 3.0;
            -view.transform_point3(centroid).z
        };
        let mut triangles: Vec<(f64, &[u32])> = self
            .blended
            .chunks_exact(3)
            .map(|t| (depth(t), t))
            .collect();
        // A stable sort keeps equal depths in the scene's order.
        triangles.sort_by(|a, b| b.0.total_cmp(&a.0));
        triangles
            .into_iter()
            .flat_map(|(_, t)| t.iter().copied())
            .collect()
    }

    pub fn far_plane_for(vertices: &[Vertex], eye: DVec3) -> f64 {
        let furthest = vertices
            .iter()
            .map(|v| DVec3::from(v.position.map(f64::from)).distance(eye))
            .fold(1.0, f64::max);
        furthest * 1.05
    }
}

/// Why a scene could not be made.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// A name that is neither a built-in scene nor a glTF file (`builtin::unknown`).
    #[error(
        "unknown scene `{name}`{near}; the built-in scenes are: {names} (see `clusterlab scenes`), or give a glTF file (a path ending in .gltf or .glb)"
    )]
    Unknown {
        name: String,
        /// "; nearest: ..." where a built-in name is near.
        near: String,
        names: String,
    },
    #[error("{0}")]
    BadParam(String),
    /// A glTF file that cannot be used, and why.
    #[error("{path}: {message}")]
    File { path: String, message: String },
}
