//! The built-in scenes.

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

use super::{Camera, FRAME_DT, Light, MeshBuilder, Motion, Scene, SceneError, SceneParams};

/// A built-in scene: its name, what it is for, and its default parameters.
pub struct SceneInfo {
    pub name: &'static str,
    pub description: &'static str,
    pub defaults: SceneParams,
    pub generate: fn(SceneParams) -> Scene,
}

const fn defaults(lights: u32, radius_range: (f32, f32)) -> SceneParams {
    SceneParams {
        width: 640,
        height: 360,
        lights,
        radius_range,
        seed: 1,
        time: 1.0,
        spots: 0.0,
        motion: Motion::ALL,
    }
}

/// The error for `name`, neither a built-in scene nor a glTF file: the nearest built-in name
/// and all of them.
pub fn unknown(name: &str) -> SceneError {
    SceneError::Unknown {
        name: name.to_string(),
        near: crate::names::did_you_mean(name, SCENES.iter().map(|s| s.name)),
        names: SCENES.iter().map(|s| s.name).collect::<Vec<_>>().join(", "),
    }
}

pub static SCENES: &[SceneInfo] = &[
    SceneInfo {
        name: "atrium",
        description: "a procedural hall after the Sponza atrium: tiled floor, walls, two rows of columns, beams, galleries, curtains, spheres; real overdraw; the camera walks down the hall at 3 units/s",
        defaults: defaults(1024, (1.0, 3.0)),
        generate: atrium,
    },
    SceneInfo {
        name: "stage",
        description: "a gallery of plinths and statues lit from above by narrow downward spots (spot fraction 1 by default): where cone culling matters; the camera walks along it at 2 units/s",
        defaults: SceneParams {
            spots: 1.0,
            ..defaults(512, (7.0, 10.0))
        },
        generate: stage,
    },
    SceneInfo {
        name: "spheres",
        description: "spheres on a plane, normals over the whole sphere (for normal-packing error); the camera pans at 3 units/s",
        defaults: defaults(128, (1.5, 4.0)),
        generate: spheres,
    },
    SceneInfo {
        name: "glass",
        description: "a courtyard seen through glass: alpha-blended panes at several depths (one just before the camera, two crossing, one beyond the back wall against the sky) over a masked fence and bushes (cut-outs), lit by point and spot lights; the camera pans at 1 unit/s",
        defaults: SceneParams {
            spots: 0.25,
            ..defaults(256, (2.0, 5.0))
        },
        generate: glass,
    },
    SceneInfo {
        name: "empty",
        description: "a plane with no lights: ambient only",
        defaults: defaults(0, (1.0, 3.0)),
        generate: empty,
    },
    SceneInfo {
        name: "one_light",
        description: "a plane with one light above its centre",
        defaults: defaults(1, (6.0, 6.0)),
        generate: one_light,
    },
];

pub fn find_scene(name: &str) -> Option<&'static SceneInfo> {
    SCENES.iter().find(|s| s.name == name)
}

const SANDSTONE: [f32; 3] = [0.72, 0.62, 0.48];
const PALE_STONE: [f32; 3] = [0.80, 0.76, 0.68];
const DARK_TILE: [f32; 3] = [0.35, 0.30, 0.26];
const WOOD: [f32; 3] = [0.45, 0.30, 0.18];
const CURTAINS: [[f32; 3]; 3] = [[0.65, 0.10, 0.08], [0.12, 0.45, 0.15], [0.10, 0.18, 0.60]];
const SPHERE_COLORS: [[f32; 3]; 4] = [
    [0.85, 0.85, 0.85],
    [0.80, 0.55, 0.15],
    [0.25, 0.50, 0.80],
    [0.60, 0.20, 0.55],
];

/// A light that drifts around `base` on a small Lissajous path.
struct LightMotion {
    base: DVec3,
    amplitude: DVec3,
    frequency: DVec3,
    phase: DVec3,
    radius: f32,
    color: [f32; 3],
    intensity: f32,
}

impl LightMotion {
    fn at(&self, t: f64) -> Light {
        let wave = DVec3::new(
            (self.frequency.x * t + self.phase.x).sin(),
            (self.frequency.y * t + self.phase.y).sin(),
            (self.frequency.z * t + self.phase.z).sin(),
        );
        Light::point(
            (self.base + self.amplitude * wave).as_vec3().to_array(),
            self.radius,
            self.color,
            self.intensity,
        )
    }
}

/// Lights and which of them move (ascending indices).
type SeededLights = (Vec<Light>, Vec<u32>);

/// `count` lights spread uniformly over the box `lo..hi`, with saturated random colours, each
/// drifting on its own path; a fraction `p.motion.lights` of them moves with time, the rest
/// stay where they were at `p.motion.still_at`, decided by a stream of its own (seeded from
/// the scene's seed), so the lights' positions and colours do not depend on the fraction.
/// The total intensity stays the same whatever the count (each light gets `power / count`),
/// so light-count sweeps keep a comparable exposure.
fn random_lights(
    rng: &mut Pcg64Mcg,
    p: &SceneParams,
    lo: DVec3,
    hi: DVec3,
    power: f32,
) -> SeededLights {
    let n = p.lights;
    let (rmin, rmax) = p.radius_range;
    let mut motion_rng = Pcg64Mcg::seed_from_u64(p.seed ^ 0x3071_0e5e_eded_0000);
    let mut moving = Vec::new();
    let lights = (0..n)
        .map(|i| {
            let base = DVec3::new(
                rng.random_range(lo.x..=hi.x),
                rng.random_range(lo.y..=hi.y),
                rng.random_range(lo.z..=hi.z),
            );
            let hue: f32 = rng.random_range(0.0..1.0);
            let motion = LightMotion {
                base,
                amplitude: DVec3::splat(rng.random_range(0.1..0.6)),
                frequency: DVec3::new(
                    rng.random_range(0.5..2.0),
                    rng.random_range(0.5..2.0),
                    rng.random_range(0.5..2.0),
                ),
                phase: DVec3::new(
                    rng.random_range(0.0..std::f64::consts::TAU),
                    rng.random_range(0.0..std::f64::consts::TAU),
                    rng.random_range(0.0..std::f64::consts::TAU),
                ),
                radius: if rmin == rmax {
                    rmin
                } else {
                    rng.random_range(rmin..=rmax)
                },
                color: hue_to_rgb(hue),
                intensity: power / n.max(1) as f32 * rng.random_range(0.5..1.5),
            };
            // Every light draws, so light i moves at every fraction above its draw.
            let moves = motion_rng.random_range(0.0..1.0) < p.motion.lights as f64;
            if moves {
                moving.push(i);
            }
            motion.at(p.motion.pose_time(moves, p.time))
        })
        .collect();
    (lights, moving)
}

/// Turn a fraction `p.spots` of `lights` into spots aimed along `aim` (unit, tilted by up to
/// `tilt` in x and z), with outer half-angles in `outer_degrees` and the inner cone at 50-90%
/// of the outer. A stream of its own (seeded from the scene's seed) decides, so the lights'
/// positions and colours are the same whatever the fraction. A spot keeps its light's
/// intensity: it lights less, only where it points.
fn make_spots(
    lights: &mut [Light],
    p: &SceneParams,
    aim: DVec3,
    tilt: f64,
    outer_degrees: (f64, f64),
) {
    let mut rng = Pcg64Mcg::seed_from_u64(p.seed ^ 0x5b07_11c3_5eed_0000);
    for light in lights {
        // Every draw happens for every light, so light i's cone is the same at any fraction.
        let is_spot = rng.random_range(0.0..1.0) < p.spots as f64;
        let direction = aim
            + DVec3::new(
                rng.random_range(-tilt..=tilt),
                0.0,
                rng.random_range(-tilt..=tilt),
            );
        let outer = rng.random_range(outer_degrees.0..=outer_degrees.1);
        let inner = outer * rng.random_range(0.5..0.9);
        if is_spot {
            // Half-angles in single-precision radians, as a glTF file holds them, so that
            // `scenes --export` writes the very same cones.
            let radians = |degrees: f64| (degrees.to_radians() as f32) as f64;
            *light = Light::spot_radians(
                light.position,
                light.radius,
                light.color,
                1.0,
                direction.to_array(),
                radians(inner),
                radians(outer),
            );
        }
    }
}

/// `p.lights` seeded lights in the box `lo..hi` with `power` in all, a fraction `p.spots` of
/// them spots aimed down (as the atrium's): the lights of a file scene that has none, and
/// which of them move.
pub(super) fn seeded_lights(p: &SceneParams, lo: DVec3, hi: DVec3, power: f32) -> SeededLights {
    let mut rng = Pcg64Mcg::seed_from_u64(p.seed);
    let (mut lights, moving) = random_lights(&mut rng, p, lo, hi, power);
    make_spots(&mut lights, p, DVec3::NEG_Y, 0.8, (20.0, 60.0));
    (lights, moving)
}

/// A saturated colour of hue `h` in [0, 1), mixed a little towards white.
fn hue_to_rgb(h: f32) -> [f32; 3] {
    let channel = |offset: f32| {
        let x = ((h + offset).fract() * 6.0 - 3.0).abs() - 1.0;
        0.25 + 0.75 * x.clamp(0.0, 1.0)
    };
    [channel(0.0), channel(2.0 / 3.0), channel(1.0 / 3.0)]
}

/// The camera of a frame at `p.time` and one frame earlier: at `eye` at the default time (1
/// s), moving at `velocity` (scene units per second), so the previous frame's camera is
/// `velocity * FRAME_DT` behind it; a still camera (`p.motion.camera` false) is where it was
/// at `p.motion.still_at`, in both. Every number is single precision, as a glTF file holds
/// it (`scenes --export`).
fn camera_pair(
    mesh: &MeshBuilder,
    eye: DVec3,
    target: DVec3,
    velocity: DVec3,
    p: &SceneParams,
) -> (Camera, Camera) {
    let moves = p.motion.camera;
    let t = p.motion.pose_time(moves, p.time);
    let rotation = Camera::look_rotation(eye, target, DVec3::Y).as_quat();
    let fov_y = 60f32.to_radians();
    let far = Scene::far_plane_for(&mesh.vertices, eye + velocity * (t - 1.0)) as f32;
    // One projection for both frames: motion vectors compare positions, not depths.
    let at = |time: f64| {
        let eye = (eye + velocity * (time - 1.0)).as_vec3();
        Camera::from_pose(eye, rotation, fov_y, 0.1, far)
    };
    let earlier = if moves { t - FRAME_DT } else { t };
    (at(t), at(earlier))
}

fn finish(
    name: &str,
    p: SceneParams,
    mesh: MeshBuilder,
    (lights, moving_lights): SeededLights,
    cams: (Camera, Camera),
) -> Scene {
    Scene {
        name: name.to_string(),
        params: p,
        vertices: mesh.vertices,
        indices: mesh.indices,
        blended: mesh.blended,
        lights,
        camera: cams.0,
        prev_camera: cams.1,
        moving_lights,
        textures: None,
        file: None,
        notes: Vec::new(),
    }
}

fn atrium(p: SceneParams) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(p.seed);
    let mut m = MeshBuilder::default();
    let (hx, hz, height) = (16.0, 7.0, 12.0);
    m.set_material(0.8, 0.0);

    // Floor of 2 m tiles in two shades.
    let tile = 2.0;
    let (nx, nz) = ((2.0 * hx / tile) as i32, (2.0 * hz / tile) as i32);
    for i in 0..nx {
        for k in 0..nz {
            let (x0, z0) = (-hx + i as f64 * tile, -hz + k as f64 * tile);
            let albedo = if (i + k) % 2 == 0 {
                SANDSTONE
            } else {
                DARK_TILE
            };
            m.axis_rect(1, 0.0, [z0, x0], [z0 + tile, x0 + tile], true, albedo);
        }
    }
    // Walls facing in.
    m.axis_rect(2, -hz, [-hx, 0.0], [hx, height], true, PALE_STONE);
    m.axis_rect(2, hz, [-hx, 0.0], [hx, height], false, PALE_STONE);
    m.axis_rect(0, -hx, [0.0, -hz], [height, hz], true, SANDSTONE);
    m.axis_rect(0, hx, [0.0, -hz], [height, hz], false, SANDSTONE);

    // No two faces are coplanar: where pieces meet, one runs into the other, so every
    // pipeline's rasterisation agrees on which surface a pixel sees.
    let into_wall = 0.3;
    for side in [-1.0, 1.0] {
        // Gallery slab over the aisle, then ground-floor and gallery columns, and a beam on
        // each row of columns.
        let slab_z = if side < 0.0 {
            (-hz - into_wall, -4.2)
        } else {
            (4.2, hz + into_wall)
        };
        m.cuboid(
            DVec3::new(-hx - into_wall, 5.0, slab_z.0),
            DVec3::new(hx + into_wall, 5.4, slab_z.1),
            SANDSTONE,
        );
        for i in 0..9 {
            let x = -12.0 + 3.0 * i as f64;
            // Ground columns stand in the floor and end inside the beam above them; gallery
            // columns start inside the slab and end inside the upper beam.
            m.cylinder(DVec3::new(x, -0.1, side * 3.6), 0.35, 4.7, 16, PALE_STONE);
            m.cylinder(DVec3::new(x, 5.3, side * 4.5), 0.25, 4.9, 12, PALE_STONE);
        }
        m.cuboid(
            DVec3::new(-13.0, 4.4, side * 3.6 - 0.35),
            DVec3::new(13.0, 5.0, side * 3.6 + 0.35),
            SANDSTONE,
        );
        m.cuboid(
            DVec3::new(-13.0, 10.0, side * 4.5 - 0.3),
            DVec3::new(13.0, 10.5, side * 4.5 + 0.3),
            SANDSTONE,
        );
        // Curtains hanging in some gallery bays, behind the gallery columns.
        for bay in 0..8 {
            if rng.random_range(0.0..1.0) < 0.35 {
                continue;
            }
            let x0 = -12.0 + 3.0 * bay as f64 + 0.4;
            let color = CURTAINS[rng.random_range(0..CURTAINS.len())];
            let z = side * 4.9;
            m.axis_rect(2, z, [x0, 6.0], [x0 + 2.2, 9.8], side < 0.0, color);
        }
    }
    // Roof beams across the hall.
    m.set_material(0.6, 0.0);
    for i in 0..6 {
        let x = -12.5 + 5.0 * i as f64;
        m.cuboid(
            DVec3::new(x - 0.3, 10.45, -hz - into_wall),
            DVec3::new(x + 0.3, 11.2, hz + into_wall),
            WOOD,
        );
    }
    // A few spheres on the floor: polished metal and lacquer, alternately.
    for (i, color) in SPHERE_COLORS.iter().enumerate() {
        m.set_material(0.25 + 0.1 * i as f32, (i % 2) as f32);
        let r = rng.random_range(0.5..1.0);
        let x = -8.0 + 5.0 * i as f64 + rng.random_range(-1.0..1.0);
        let z = rng.random_range(-1.5..1.5);
        m.sphere(DVec3::new(x, r, z), r, 16, 32, *color);
    }

    let (mut lights, moving) = random_lights(
        &mut rng,
        &p,
        DVec3::new(-hx + 0.5, 0.2, -hz + 0.2),
        DVec3::new(hx - 0.5, height - 0.5, hz - 0.2),
        180.0,
    );
    make_spots(&mut lights, &p, DVec3::NEG_Y, 0.8, (20.0, 60.0));
    let cams = camera_pair(
        &m,
        DVec3::new(-14.0, 1.8, 0.8),
        DVec3::new(5.5, 3.6, -0.4),
        DVec3::new(3.0, 0.0, 0.0),
        &p,
    );
    finish("atrium", p, m, (lights, moving), cams)
}

/// A gallery 32 x 12, open above: a floor of two stones, a back wall, two rows of plinths
/// with statues (spheres of metal and stone), lit by lights hung 5-7 units up that point
/// down (spots by default, outer half-angles 10-30 degrees).
fn stage(p: SceneParams) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(p.seed);
    let mut m = MeshBuilder::default();
    let (hx, hz) = (16.0, 6.0);
    m.set_material(0.55, 0.0);
    for i in 0..8 {
        let x0 = -hx + 4.0 * i as f64;
        let albedo = if i % 2 == 0 { PALE_STONE } else { DARK_TILE };
        m.axis_rect(1, 0.0, [-hz, x0], [hz, x0 + 4.0], true, albedo);
    }
    m.set_material(0.9, 0.0);
    m.axis_rect(2, -hz, [-hx, 0.0], [hx, 8.0], true, SANDSTONE);
    for side in [-1.0, 1.0] {
        for i in 0..7 {
            let x = -12.0 + 4.0 * i as f64;
            let z = side * 2.5;
            m.set_material(0.7, 0.0);
            // Plinths stand in the floor; statues sink into their tops.
            m.cuboid(
                DVec3::new(x - 0.6, -0.1, z - 0.6),
                DVec3::new(x + 0.6, 1.2, z + 0.6),
                PALE_STONE,
            );
            let r = rng.random_range(0.45..0.7);
            m.set_material(
                rng.random_range(0.1..0.6),
                if (i + (side > 0.0) as usize).is_multiple_of(2) {
                    1.0
                } else {
                    0.0
                },
            );
            m.sphere(DVec3::new(x, 1.15 + r, z), r, 16, 32, SPHERE_COLORS[i % 4]);
        }
    }
    let (mut lights, moving) = random_lights(
        &mut rng,
        &p,
        DVec3::new(-hx + 1.0, 5.0, -hz + 0.5),
        DVec3::new(hx - 1.0, 7.0, hz - 0.5),
        1500.0,
    );
    make_spots(&mut lights, &p, DVec3::NEG_Y, 0.35, (10.0, 30.0));
    let cams = camera_pair(
        &m,
        DVec3::new(-15.5, 3.6, 5.0),
        DVec3::new(0.0, 0.6, -1.0),
        DVec3::new(2.0, 0.0, 0.0),
        &p,
    );
    finish("stage", p, m, (lights, moving), cams)
}

fn spheres(p: SceneParams) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(p.seed);
    let mut m = MeshBuilder::default();
    m.set_material(0.7, 0.0);
    m.axis_rect(1, 0.0, [-10.0, -10.0], [10.0, 10.0], true, PALE_STONE);
    for i in 0..4 {
        for k in 0..3 {
            // Roughness across the columns, metal on the middle row.
            m.set_material(0.15 + 0.25 * i as f32, if k == 1 { 1.0 } else { 0.0 });
            let r = rng.random_range(0.5..1.2);
            let center = DVec3::new(-4.5 + 3.0 * i as f64, r, -3.0 + 3.0 * k as f64);
            m.sphere(center, r, 24, 48, SPHERE_COLORS[(i + k) % 4]);
        }
    }
    let (mut lights, moving) = random_lights(
        &mut rng,
        &p,
        DVec3::new(-7.0, 0.2, -6.0),
        DVec3::new(7.0, 3.5, 5.0),
        12.0,
    );
    make_spots(&mut lights, &p, DVec3::NEG_Y, 0.6, (20.0, 50.0));
    let cams = camera_pair(
        &m,
        DVec3::new(0.2, 6.0, 9.0),
        DVec3::new(0.2, 0.3, -0.5),
        DVec3::new(3.0, 0.0, 0.0),
        &p,
    );
    finish("spheres", p, m, (lights, moving), cams)
}

/// Alpha cutoff of the glass scene's masked materials (glTF's default).
const GLASS_CUTOFF: f32 = 0.5;
const LEAVES: [f32; 3] = [0.20, 0.45, 0.12];
const PANE_TINTS: [[f32; 3]; 4] = [
    [0.55, 0.75, 0.95],
    [0.95, 0.60, 0.45],
    [0.60, 0.90, 0.55],
    [0.90, 0.85, 0.50],
];

/// A courtyard 20 x 12 with walls 4 high, open above. Opaque: a tiled floor, the back and
/// left walls, plinths. Masked (cutoff 0.5): a fence whose vertex alphas alternate 1 and 0
/// along it, so each quad keeps the half nearer its opaque side (slats and gaps), and bushes
/// of crossed leaf cards, alpha 1 at two opposite corners and 0 at the others. Blended, added
/// last (their vertices after every opaque one, as `scenes --export` writes them): a pane
/// just before the camera, panes across the courtyard, two crossing each other, and a tall
/// pane beyond the back wall that shows above it against the sky.
fn glass(p: SceneParams) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(p.seed);
    let mut m = MeshBuilder::default();
    let (hx, hz, wall) = (10.0, 6.0, 4.0);
    m.set_material(0.8, 0.0);
    for i in 0..10 {
        for k in 0..6 {
            let (x0, z0) = (-hx + 2.0 * i as f64, -hz + 2.0 * k as f64);
            let albedo = if (i + k) % 2 == 0 {
                PALE_STONE
            } else {
                DARK_TILE
            };
            m.axis_rect(1, 0.0, [z0, x0], [z0 + 2.0, x0 + 2.0], true, albedo);
        }
    }
    m.axis_rect(2, -hz, [-hx, 0.0], [hx, wall], true, SANDSTONE);
    m.axis_rect(0, -hx, [0.0, -hz], [wall, hz], true, SANDSTONE);
    m.set_material(0.5, 0.0);
    for i in 0..3 {
        let x = -6.0 + 6.0 * i as f64;
        m.cuboid(
            DVec3::new(x - 0.5, -0.1, -3.5),
            DVec3::new(x + 0.5, 1.0, -2.5),
            PALE_STONE,
        );
    }

    // The fence: 24 quads from x = -8 to 0 at z = 1, 1.2 high.
    m.set_material(0.7, 0.0);
    m.set_alpha(
        1.0,
        crate::common::AlphaMode::Mask {
            cutoff: GLASS_CUTOFF,
        },
    );
    let slats = 24;
    for i in 0..slats {
        let x0 = -8.0 + 8.0 * i as f64 / slats as f64;
        let x1 = -8.0 + 8.0 * (i + 1) as f64 / slats as f64;
        let (a0, a1) = if i % 2 == 0 { (1.0, 0.0) } else { (0.0, 1.0) };
        m.quad_with_alpha(
            [
                DVec3::new(x0, 0.0, 1.0),
                DVec3::new(x1, 0.0, 1.0),
                DVec3::new(x1, 1.2, 1.0),
                DVec3::new(x0, 1.2, 1.0),
            ],
            DVec3::Z,
            WOOD,
            [a0, a1, a1, a0],
        );
    }
    // Bushes: five leaf cards around a vertical axis each.
    m.set_material(0.6, 0.0);
    for b in 0..4 {
        let centre = DVec3::new(
            -7.0 + 4.5 * b as f64 + rng.random_range(-0.5..0.5),
            0.0,
            -1.0 + rng.random_range(-1.0..1.0),
        );
        let size: f64 = rng.random_range(0.8..1.3);
        for c in 0..5 {
            let angle = std::f64::consts::PI * c as f64 / 5.0 + rng.random_range(0.0..0.3);
            let along = DVec3::new(angle.cos(), 0.0, angle.sin()) * size;
            let up = DVec3::new(0.0, 2.0 * size, 0.0);
            let normal = along.cross(up).normalize();
            m.quad_with_alpha(
                [
                    centre - along,
                    centre + along,
                    centre + along + up,
                    centre - along + up,
                ],
                normal,
                LEAVES,
                [1.0, 0.0, 1.0, 0.0],
            );
        }
    }

    // Panes, blended: (centre, half width, half height, angle about y, alpha).
    m.set_material(0.1, 0.0);
    let panes: [(DVec3, f64, f64, f64, f32); 6] = [
        // Just before the camera: nearer than any sensible near slice's end.
        (DVec3::new(1.6, 2.1, 7.4), 0.6, 0.8, 0.3, 0.3),
        (DVec3::new(-3.0, 1.5, 3.0), 2.0, 1.5, 0.0, 0.45),
        (DVec3::new(4.0, 1.2, 0.5), 1.5, 1.2, 0.6, 0.6),
        // Two crossing each other.
        (DVec3::new(0.5, 1.5, -1.0), 1.8, 1.5, 0.7, 0.5),
        (DVec3::new(0.5, 1.5, -1.0), 1.8, 1.5, -0.7, 0.35),
        // Beyond the back wall and above it, against the sky.
        (DVec3::new(2.0, 4.5, -9.0), 5.0, 4.5, 0.0, 0.4),
    ];
    for (i, &(centre, half_width, half_height, angle, alpha)) in panes.iter().enumerate() {
        m.set_alpha(alpha, crate::common::AlphaMode::Blend);
        let along = DVec3::new(angle.cos(), 0.0, -angle.sin()) * half_width;
        let up = DVec3::new(0.0, half_height, 0.0);
        let normal = along.cross(up).normalize();
        m.quad(
            [
                centre - along - up,
                centre + along - up,
                centre + along + up,
                centre - along + up,
            ],
            normal,
            PANE_TINTS[i % PANE_TINTS.len()],
        );
    }

    let (mut lights, moving) = random_lights(
        &mut rng,
        &p,
        DVec3::new(-hx + 0.5, 0.3, -hz - 4.0),
        DVec3::new(hx - 0.5, 5.0, hz),
        60.0,
    );
    make_spots(&mut lights, &p, DVec3::NEG_Y, 0.6, (20.0, 50.0));
    let cams = camera_pair(
        &m,
        DVec3::new(0.0, 2.2, 9.0),
        DVec3::new(-0.5, 1.4, -2.0),
        DVec3::new(1.0, 0.0, 0.0),
        &p,
    );
    finish("glass", p, m, (lights, moving), cams)
}

fn plane() -> MeshBuilder {
    let mut m = MeshBuilder::default();
    m.set_material(0.5, 0.0);
    m.axis_rect(1, 0.0, [-20.0, -20.0], [20.0, 20.0], true, PALE_STONE);
    m
}

fn plane_camera(m: &MeshBuilder, p: &SceneParams) -> (Camera, Camera) {
    camera_pair(
        m,
        DVec3::new(0.1, 3.0, 8.0),
        DVec3::new(0.1, 0.0, 0.0),
        DVec3::new(2.0, 0.0, 0.0),
        p,
    )
}

fn empty(p: SceneParams) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(p.seed);
    let m = plane();
    let (mut lights, moving) = random_lights(
        &mut rng,
        &p,
        DVec3::new(-8.0, 0.2, -8.0),
        DVec3::new(8.0, 3.0, 4.0),
        4.0,
    );
    make_spots(&mut lights, &p, DVec3::NEG_Y, 0.8, (20.0, 60.0));
    let cams = plane_camera(&m, &p);
    finish("empty", p, m, (lights, moving), cams)
}

fn one_light(p: SceneParams) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(p.seed);
    let m = plane();
    let (mut lights, moving) = random_lights(
        &mut rng,
        &p,
        DVec3::new(-3.0, 0.5, -3.0),
        DVec3::new(3.0, 2.0, 3.0),
        4.0,
    );
    if let Some(first) = lights.first_mut() {
        // The one light sits above the centre; more lights (--lights) scatter around it. Its
        // colour's largest channel is its intensity (`hue_to_rgb` peaks at 1).
        let intensity = first.color.into_iter().fold(0.0, f32::max);
        first.position = [0.0, 1.5, 0.0];
        first.color = [1.0, 0.95, 0.85].map(|c| c * intensity);
    }
    // ... and stays there.
    let moving: Vec<u32> = moving.into_iter().filter(|&i| i != 0).collect();
    make_spots(&mut lights, &p, DVec3::NEG_Y, 0.8, (20.0, 60.0));
    let cams = plane_camera(&m, &p);
    finish("one_light", p, m, (lights, moving), cams)
}
