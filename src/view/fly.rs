//! The flown camera: a position, a heading and a speed, moved by keys, mouse drags and the
//! wheel; it starts on the scene's own camera and becomes a `CameraPose`.

use glam::Vec3;

use crate::scene::{Camera, CameraPose};

/// Radians the camera turns per pixel dragged.
const TURN_PER_PIXEL: f32 = 0.004;
/// Steepest the camera looks up or down, radians (short of straight up, where +Y is no up).
const MAX_PITCH: f32 = 1.5;
/// Speed factor per wheel step.
const WHEEL_FACTOR: f32 = 1.25;

/// Where the flown camera is and where it heads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fly {
    pub eye: Vec3,
    /// Turned about +Y from -Z (glTF's forward), radians; pitch above the horizon.
    pub yaw: f32,
    pub pitch: f32,
    /// World units per second.
    pub speed: f32,
}

/// Which ways the held keys fly: forward, right, up, each -1, 0 or 1.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Thrust {
    pub forward: f32,
    pub right: f32,
    pub up: f32,
}

impl Fly {
    /// On `camera`, flying a tenth of its far plane a second.
    pub fn on(camera: &Camera) -> Fly {
        let eye = camera.eye.as_vec3();
        let f = (camera.target - camera.eye).normalize().as_vec3();
        Fly {
            eye,
            yaw: f.x.atan2(-f.z),
            pitch: f.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH),
            speed: (camera.far as f32 / 10.0).max(0.1),
        }
    }

    pub fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(cp * sy, sp, -cp * cy)
    }

    /// Fly for `dt` seconds.
    pub fn fly(&mut self, thrust: Thrust, dt: f32) {
        let forward = self.forward();
        let right = forward.cross(Vec3::Y).normalize_or_zero();
        let way = forward * thrust.forward + right * thrust.right + Vec3::Y * thrust.up;
        self.eye += way.normalize_or_zero() * self.speed * dt;
    }

    /// Turn by a mouse drag of `dx`, `dy` pixels (right and down turn right and down).
    pub fn turn(&mut self, dx: f32, dy: f32) {
        self.yaw += dx * TURN_PER_PIXEL;
        self.pitch = (self.pitch - dy * TURN_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Fly faster (positive steps) or slower.
    pub fn wheel(&mut self, steps: f32) {
        self.speed = (self.speed * WHEEL_FACTOR.powf(steps)).clamp(1e-3, 1e6);
    }

    pub fn pose(&self) -> CameraPose {
        CameraPose {
            eye: self.eye.to_array(),
            target: (self.eye + self.forward()).to_array(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn camera(eye: DVec3, target: DVec3) -> Camera {
        Camera {
            eye,
            target,
            up: DVec3::Y,
            fov_y: 1.0,
            near: 0.1,
            far: 50.0,
        }
    }

    #[test]
    fn flying_starts_on_the_scene_camera_and_moves_where_it_looks() {
        let c = camera(DVec3::new(1.0, 2.0, 3.0), DVec3::new(4.0, 2.0, -1.0));
        let mut fly = Fly::on(&c);
        let seen = (c.target - c.eye).normalize().as_vec3();
        // f32 of a unit vector through atan2/asin and back: a few ulps.
        assert!(
            (fly.forward() - seen).length() < 1e-6,
            "{:?}",
            fly.forward()
        );
        let before = fly.eye;
        fly.fly(
            Thrust {
                forward: 1.0,
                ..Default::default()
            },
            0.5,
        );
        assert!((fly.eye - before - seen * fly.speed * 0.5).length() < 1e-5);
        // Strafing right keeps the height; up goes up.
        let h = fly.eye.y;
        fly.fly(
            Thrust {
                right: 1.0,
                ..Default::default()
            },
            1.0,
        );
        assert!((fly.eye.y - h).abs() < 1e-5);
        fly.fly(
            Thrust {
                up: 1.0,
                ..Default::default()
            },
            1.0,
        );
        assert!((fly.eye.y - h - fly.speed).abs() < 1e-4);
    }

    #[test]
    fn turning_stops_short_of_straight_up() {
        let mut fly = Fly::on(&camera(DVec3::ZERO, DVec3::NEG_Z));
        fly.turn(0.0, -1e6);
        assert_eq!(fly.pitch, MAX_PITCH);
        fly.wheel(2.0);
        assert!((fly.speed - 5.0 * 1.5625).abs() < 1e-4);
    }
}
