//! A camera placed by hand: `render --camera`, and the viewer's flown camera, which it shows
//! as that argument so a view found by flying becomes a reproducible `render`.

use glam::DVec3;

use super::{Camera, Scene, SceneError};

/// Where the camera is and the point it looks at, +Y up. The field of view and near plane
/// stay the scene's; the far plane encloses the scene's geometry seen from the eye. A placed
/// camera stands still (its previous frame's pose is the same: no motion blur).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraPose {
    pub eye: [f32; 3],
    pub target: [f32; 3],
}

impl CameraPose {
    /// Parse `EX,EY,EZ,TX,TY,TZ`: six finite numbers, the eye and the point it looks at.
    pub fn parse(text: &str) -> Result<CameraPose, String> {
        let numbers: Vec<f32> = text
            .split(',')
            .map(|v| v.trim().parse::<f32>().ok().filter(|v| v.is_finite()))
            .collect::<Option<_>>()
            .filter(|v: &Vec<f32>| v.len() == 6)
            .ok_or_else(|| {
                format!("`{text}` is not a camera: give EX,EY,EZ,TX,TY,TZ, six finite numbers (the eye and the point it looks at), e.g. 0,2,8,0,1,0")
            })?;
        let pose = CameraPose {
            eye: [numbers[0], numbers[1], numbers[2]],
            target: [numbers[3], numbers[4], numbers[5]],
        };
        if pose.eye == pose.target {
            return Err(format!(
                "`{text}`: the camera looks at its own eye; give a target apart from it"
            ));
        }
        Ok(pose)
    }

    /// The pose of `camera` (rounded to single precision, as a file or argument holds it).
    pub fn of(camera: &Camera) -> CameraPose {
        CameraPose {
            eye: camera.eye.as_vec3().to_array(),
            target: camera.target.as_vec3().to_array(),
        }
    }

    /// The pose as `--camera`'s value: each number written as the shortest text that reads
    /// back as the same f32, so the argument reproduces the pose exactly.
    pub fn argument(&self) -> String {
        let n: Vec<String> = self
            .eye
            .iter()
            .chain(&self.target)
            .map(|v| v.to_string())
            .collect();
        n.join(",")
    }
}

impl Scene {
    /// Put the camera at `pose`, still; the frame must still be one the tool can render.
    pub fn place_camera(&mut self, pose: CameraPose) -> Result<(), SceneError> {
        let eye = DVec3::from(pose.eye.map(f64::from));
        let target = DVec3::from(pose.target.map(f64::from));
        // Looking straight up or down, +Y cannot be the camera's up.
        let forward = (target - eye).normalize_or_zero();
        let up = if forward.cross(DVec3::Y).length() < 1e-6 {
            DVec3::NEG_Z
        } else {
            DVec3::Y
        };
        self.camera = Camera {
            eye,
            target,
            up,
            far: Scene::far_plane_for(&self.vertices, eye).max(self.camera.near * 2.0),
            ..self.camera
        };
        self.prev_camera = self.camera;
        self.params.motion.camera = false;
        self.check()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_reads_back_from_its_argument_exactly() {
        let pose = CameraPose {
            eye: [0.1, -2.5e-3, 7.0 / 3.0],
            target: [1e7, 0.0, -0.333_333_34],
        };
        assert_eq!(CameraPose::parse(&pose.argument()), Ok(pose));
        // A break: writing fewer digits loses the pose.
        let rounded: Vec<String> = pose
            .eye
            .iter()
            .chain(&pose.target)
            .map(|v| format!("{v:.3}"))
            .collect();
        assert_ne!(CameraPose::parse(&rounded.join(",")), Ok(pose));
    }

    #[test]
    fn a_bad_pose_says_what_a_camera_is() {
        for bad in ["1,2,3", "1,2,3,4,5,x", "1,2,3,4,5,NaN", "1,2,3,1,2,3"] {
            let e = CameraPose::parse(bad).unwrap_err();
            assert!(
                e.contains(bad) && (e.contains("EX,EY,EZ") || e.contains("target")),
                "{e}"
            );
        }
    }
}
