//! The adversarial cases: cameras, sizes, lights and geometry where clustered shading tends
//! to break numerically, each a hand-built scene and the variants it applies to.

use glam::DVec3;

use crate::cpu::zslice::Slices;
use crate::scene::{Camera, Light, MeshBuilder, Motion, Scene, SceneParams, Vertex};
use std::sync::Arc;

use strum::IntoEnumIterator;

use crate::variant::*;

/// One stress case: a scene and the variants to run on it.
pub struct Case {
    pub name: String,
    pub what: String,
    pub scene: Scene,
    /// Frames after the first (lights moving, the camera still): the case then runs as a
    /// sequence, every frame checked (`sequence::run`).
    pub later: Vec<Scene>,
    pub variants: Vec<(String, Variant)>,
    /// How a user's variant (`stress --variants`) joins the case: one run per edit.
    pub edits: Vec<Edit>,
}

/// What a case sets in a user's variant before running it (a grid, a slicing, a depth
/// mapping, a sample count; nothing for most), and the suffix that names the result. An edit
/// that cannot apply says why.
#[derive(Clone)]
pub struct Edit {
    pub suffix: String,
    pub apply: Arc<EditFn>,
}

/// What an edit does to a variant, or why it cannot.
pub type EditFn = dyn Fn(&mut Variant) -> Result<(), String> + Send + Sync;

impl Edit {
    fn new(
        suffix: impl Into<String>,
        apply: impl Fn(&mut Variant) -> Result<(), String> + Send + Sync + 'static,
    ) -> Edit {
        Edit {
            suffix: suffix.into(),
            apply: Arc::new(apply),
        }
    }

    /// The variant as it is; a clustered one where the case checks cluster lists only.
    fn as_is(clustered_only: bool) -> Edit {
        Edit::new("", move |v| {
            if clustered_only && !v.pipeline.is_clustered() {
                Err(NEEDS_CLUSTERS.into())
            } else {
                Ok(())
            }
        })
    }

    /// `v` with this edit, checked as a variant file is, named `name` and the suffix.
    fn applied(&self, name: &str, v: &Variant) -> (String, Result<Variant, String>) {
        let mut v = v.clone();
        let result = (self.apply)(&mut v).and_then(|()| match check(&v).first() {
            None => Ok(v),
            Some(p) => Err(format!(
                "the case's edit makes it invalid: {}: {}",
                p.field, p.message
            )),
        });
        (format!("{name}{}", self.suffix), result)
    }
}

const NEEDS_CLUSTERS: &str = "the case checks cluster lists: it needs a clustered pipeline";

impl Case {
    /// The runs of a user's variant `v` named `name` in this case: the variant each edit
    /// makes, or why it does not apply.
    pub fn runs_of(&self, name: &str, v: &Variant) -> Vec<(String, Result<Variant, String>)> {
        self.edits.iter().map(|e| e.applied(name, v)).collect()
    }

    fn with_edits(mut self, edits: Vec<Edit>) -> Case {
        self.edits = edits;
        self
    }
}

/// The built-in variants `set` with `edit` applied (those it applies to).
fn edited(set: Vec<(String, Variant)>, edit: &Edit) -> Vec<(String, Variant)> {
    set.into_iter()
        .filter_map(|(n, v)| match edit.applied(&n, &v) {
            (name, Ok(v)) => Some((name, v)),
            (_, Err(_)) => None,
        })
        .collect()
}

fn set_grid(grid: (u32, u32, u32)) -> Edit {
    Edit::new(format!("_{}x{}x{}", grid.0, grid.1, grid.2), move |v| {
        v.clusters.as_mut().ok_or(NEEDS_CLUSTERS)?.grid = grid;
        Ok(())
    })
}

fn set_slicing(slicing: ZSlicing, tag: &str) -> Edit {
    Edit::new(format!("_{tag}"), move |v| {
        v.clusters.as_mut().ok_or(NEEDS_CLUSTERS)?.slicing = slicing;
        Ok(())
    })
}

/// The depth mappings other than the standard finite one, each with 32-bit float depth.
fn set_depths() -> Vec<Edit> {
    [
        ("reversed_z", true, None),
        ("reversed_z_finite_far", true, Some(false)),
        ("infinite_far", false, Some(true)),
    ]
    .into_iter()
    .map(|(tag, reversed_z, infinite_far)| {
        Edit::new(format!("_{tag}"), move |v| {
            v.depth = Depth {
                format: DepthFormat::Float32,
                reversed_z,
                infinite_far,
            };
            Ok(())
        })
    })
    .collect()
}

/// Four samples a pixel.
fn set_msaa4() -> Edit {
    Edit::new("_msaa4", |v| {
        v.msaa.samples = 4;
        Ok(())
    })
}

const PREVIOUS_FRAME_RANGE: ZSlicing = ZSlicing::DynamicRange {
    source: DepthRangeSource::PreviousFrame,
};

/// Image size of the cases that do not test sizes (small: CI runs them all).
pub const SIZE: (u32, u32) = (48, 27);

const STONE: [f32; 3] = [0.75, 0.72, 0.66];
const RED: [f32; 3] = [0.8, 0.3, 0.25];
const BLUE: [f32; 3] = [0.25, 0.4, 0.8];

fn variant(description: &str, pipeline: Pipeline) -> Variant {
    Variant {
        description: description.into(),
        pipeline,
        depth_prepass: pipeline == Pipeline::ClusteredForward,
        clusters: pipeline.is_clustered().then(|| Clusters {
            grid: (8, 6, 12),
            slicing: ZSlicing::Exponential,
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// Every pipeline, exact (full-precision G-buffer, exact lists), and Forward+ with each
/// other culling, with two-level culling, with active clusters (and sample bounds), and with
/// lists built on the CPU.
pub fn pipelines() -> Vec<(String, Variant)> {
    let mut out: Vec<(String, Variant)> = Pipeline::iter()
        .map(|p| (p.short_name().to_string(), variant(p.short_name(), p)))
        .collect();
    let mut forward_plus = |name: &str, edit: &dyn Fn(&mut Clusters)| {
        let mut v = variant(name, Pipeline::ClusteredForward);
        edit(v.clusters.as_mut().expect("clustered"));
        out.push((name.to_string(), v));
    };
    for culling in Culling::iter().filter(|&c| c != Culling::Boxes) {
        let name = format!("forward_plus_{}", format!("{culling:?}").to_lowercase());
        forward_plus(&name, &|c| {
            c.culling = culling;
            // 2.5D cells cut each cluster's sample range: marking must find it.
            if culling == Culling::DepthMask {
                c.active_clusters = true;
                c.sample_bounds = true;
            }
        });
    }
    forward_plus("forward_plus_two_level", &|c| c.big_tiles = Some(2));
    forward_plus("forward_plus_active", &|c| c.active_clusters = true);
    forward_plus("forward_plus_sample_bounds", &|c| {
        c.active_clusters = true;
        c.sample_bounds = true;
    });
    forward_plus("forward_plus_cpu_assignment", &|c| {
        c.assignment = Assignment::Cpu;
    });
    out
}

/// The clustered pipelines only.
fn clustered() -> Vec<(String, Variant)> {
    pipelines()
        .into_iter()
        .filter(|(_, v)| v.pipeline.is_clustered())
        .collect()
}

/// The pipelines plus deferred with each packed normal codec (the codec list, at 32 bits)
/// and the compact layout (for the normal cases).
fn with_codecs() -> Vec<(String, Variant)> {
    let mut out = pipelines();
    for codec in NormalCodec::packed(32) {
        let name = codec_case_name(codec);
        let mut v = variant(&name, Pipeline::ClusteredDeferred);
        v.gbuffer = Some(GBuffer {
            layout: GBufferLayout::Packed,
        });
        v.normals = Some(codec);
        out.push((name, v));
    }
    let mut compact = variant("deferred_compact", Pipeline::ClusteredDeferred);
    compact.gbuffer = Some(GBuffer {
        layout: GBufferLayout::Compact,
    });
    out.push(("deferred_compact".to_string(), compact));
    out
}

/// The stress run name of deferred with a packed codec.
pub fn codec_case_name(codec: NormalCodec) -> String {
    match codec {
        NormalCodec::Octahedral { precise: true, .. } => "deferred_octahedral".into(),
        NormalCodec::Octahedral { precise: false, .. } => "deferred_octahedral_fast".into(),
        c => format!("deferred_{}", c.label().replace(' ', "_")),
    }
}

fn with_slicing(slicing: ZSlicing, tag: &str) -> Vec<(String, Variant)> {
    edited(clustered(), &set_slicing(slicing, tag))
}

/// The name of the stress case of a z-slicing scheme: its feature flag, and the range source
/// of a dynamic range.
pub fn slicing_case_name(slicing: ZSlicing) -> String {
    match slicing {
        ZSlicing::DynamicRange { source } => format!("{}_{source:?}", slicing.feature()),
        s => s.feature().to_string(),
    }
}

/// Every pipeline with each depth mapping other than the standard finite one.
fn depth_mappings() -> Vec<(String, Variant)> {
    set_depths()
        .iter()
        .flat_map(|edit| edited(pipelines(), edit))
        .collect()
}

/// A room of boxes and a sphere: every normal direction, some overdraw.
fn room() -> MeshBuilder {
    let mut m = MeshBuilder::default();
    m.axis_rect(1, 0.0, [-6.0, -6.0], [6.0, 6.0], true, STONE);
    m.cuboid(
        DVec3::new(-2.5, 0.0, -2.0),
        DVec3::new(-1.0, 2.0, -0.5),
        RED,
    );
    m.cuboid(DVec3::new(1.0, 0.0, -3.0), DVec3::new(2.5, 1.0, -1.5), BLUE);
    m.sphere(DVec3::new(0.3, 1.0, 0.5), 1.0, 12, 24, STONE);
    m
}

fn camera(eye: DVec3, target: DVec3, fov_deg: f64, near: f64, far: f64) -> Camera {
    Camera {
        eye,
        target,
        up: DVec3::Y,
        fov_y: fov_deg.to_radians(),
        near,
        far,
    }
}

fn default_camera(m: &MeshBuilder) -> Camera {
    let eye = DVec3::new(0.0, 3.0, 7.0);
    camera(
        eye,
        DVec3::new(0.0, 0.8, 0.0),
        60.0,
        0.1,
        Scene::far_plane_for(&m.vertices, eye),
    )
}

fn light(position: DVec3, radius: f32, intensity: f32) -> Light {
    Light::point(
        position.as_vec3().to_array(),
        radius,
        [1.0, 0.9, 0.8],
        intensity,
    )
}

/// `n` lights on a lattice over the room, radius `r`, total power about 60.
fn lattice(n: u32, r: f32) -> Vec<Light> {
    let side = (n as f64).cbrt().ceil().max(1.0) as u32;
    (0..n)
        .map(|i| {
            let (a, b, c) = (i % side, (i / side) % side, i / (side * side));
            let t = |k: u32| (k as f64 + 0.5) / side as f64;
            let p = DVec3::new(-5.5 + 11.0 * t(a), 0.2 + 3.5 * t(c), -5.5 + 11.0 * t(b));
            let color = [0.5 + 0.5 * t(a) as f32, 0.6, 1.0 - 0.5 * t(b) as f32];
            Light::point(p.as_vec3().to_array(), r, color, 60.0 / n.max(1) as f32)
        })
        .collect()
}

fn scene(
    name: &str,
    size: (u32, u32),
    mesh: MeshBuilder,
    lights: Vec<Light>,
    cam: Camera,
) -> Scene {
    Scene {
        name: name.to_string(),
        params: SceneParams {
            width: size.0,
            height: size.1,
            lights: lights.len() as u32,
            radius_range: (0.0, 0.0),
            seed: 0,
            time: 1.0,
            spots: lights.iter().filter(|l| l.is_spot()).count() as f32
                / lights.len().max(1) as f32,
            motion: Motion::ALL,
        },
        vertices: mesh.vertices,
        indices: mesh.indices,
        blended: mesh.blended,
        lights,
        camera: cam,
        prev_camera: cam,
        moving_lights: Vec::new(),
        textures: None,
        file: None,
        notes: Vec::new(),
    }
}

fn case(
    name: impl Into<String>,
    what: impl Into<String>,
    scene: Scene,
    variants: Vec<(String, Variant)>,
) -> Case {
    let clustered_only = variants.iter().all(|(_, v)| v.pipeline.is_clustered());
    Case {
        name: name.into(),
        what: what.into(),
        scene,
        later: Vec::new(),
        // A case's edit (a slicing, a grid) can make a combination a variant file would be
        // refused for (CPU assignment with a dynamic range): those are not run.
        variants: variants
            .into_iter()
            .filter(|(_, v)| check(v).is_empty())
            .collect(),
        edits: vec![Edit::as_is(clustered_only)],
    }
}

/// A room scene with `lights` and the default camera at `size`.
fn lit_room(name: &str, size: (u32, u32), lights: Vec<Light>) -> Scene {
    let m = room();
    let cam = default_camera(&m);
    scene(name, size, m, lights, cam)
}

/// Every stress case.
pub fn all() -> Vec<Case> {
    let mut cases = Vec::new();
    let base_lights = || lattice(27, 3.0);

    // Cameras.
    {
        let m = room();
        let eye = DVec3::new(0.0, 3.0, 7.0);
        let cam = camera(eye, DVec3::new(0.0, 0.8, 0.0), 60.0, 1e-4, 1e6);
        cases.push(case(
            "near_1e-4_far_1e6",
            "near plane 1e-4, far plane 1e6: 10 decades of depth in the slices",
            scene("near_1e-4_far_1e6", SIZE, m, base_lights(), cam),
            pipelines(),
        ));
    }
    cases.push(case(
        "reversed_z_infinite_far",
        "reversed-Z (infinite and finite far plane) and an infinite far plane, 32-bit float depth",
        lit_room("reversed_z_infinite_far", SIZE, base_lights()),
        depth_mappings(),
    )
    .with_edits(set_depths()));
    for (name, fov, what) in [
        (
            "fov_1_degree",
            1.0,
            "a 1 degree field of view: tiles a few thousandths wide",
        ),
        (
            "fov_170_degrees",
            170.0,
            "a 170 degree field of view: tan(fov/2) = 11.4",
        ),
    ] {
        let m = room();
        let eye = DVec3::new(0.0, 3.0, 7.0);
        let cam = camera(
            eye,
            DVec3::new(0.0, 0.8, 0.0),
            fov,
            0.1,
            Scene::far_plane_for(&m.vertices, eye),
        );
        cases.push(case(
            name,
            what,
            scene(name, SIZE, m, base_lights(), cam),
            pipelines(),
        ));
    }
    for (name, size, what) in [
        ("size_1x1", (1, 1), "a single pixel"),
        (
            "size_3x7",
            (3, 7),
            "3x7 pixels: a grid that does not divide the size",
        ),
        ("size_1x4096", (1, 4096), "one column of 4096 pixels"),
        ("size_4096x1", (4096, 1), "one row of 4096 pixels"),
    ] {
        cases.push(case(
            name,
            what,
            lit_room(name, size, base_lights()),
            pipelines(),
        ));
    }

    // Lights.
    cases.push(case(
        "no_lights",
        "0 lights: ambient only, empty lists everywhere",
        lit_room("no_lights", SIZE, vec![]),
        pipelines(),
    ));
    cases.push(case(
        "one_light",
        "1 light",
        lit_room(
            "one_light",
            SIZE,
            vec![light(DVec3::new(0.0, 2.5, 0.0), 6.0, 20.0)],
        ),
        pipelines(),
    ));
    cases.push(case(
        "lights_62000",
        "62000 small lights on a lattice (llvmpipe's loops allow 64511 per pixel, 62555 with z-binning's or two-level culling's bitmask words)",
        lit_room("lights_62000", SIZE, lattice(62000, 0.4)),
        pipelines(),
    ));
    cases.push(case(
        "radius_zero",
        "lights of radius 0: they light nothing",
        lit_room("radius_zero", SIZE, lattice(64, 0.0)),
        pipelines(),
    ));
    cases.push(case(
        "radius_1e-4",
        "lights of radius 1e-4, some on surfaces",
        lit_room(
            "radius_1e-4",
            SIZE,
            lattice(64, 1e-4)
                .into_iter()
                .chain([light(DVec3::new(0.0, 0.0, 0.0), 1e-4, 1.0)])
                .collect(),
        ),
        pipelines(),
    ));
    cases.push(case(
        "light_covers_every_cluster",
        "one light whose sphere holds the whole frustum",
        lit_room(
            "light_covers_every_cluster",
            SIZE,
            vec![light(DVec3::new(0.0, 1.0, 0.0), 1e4, 1e3)],
        ),
        pipelines(),
    ));
    {
        let m = room();
        let cam = default_camera(&m);
        let view = cam.view();
        let world_from_view = view.inverse();
        let grid = (8u32, 6u32, 12u32);
        // Centres exactly on the exponential slice boundaries along the view axis and
        // off it, and exactly on tile boundary planes.
        let mut on_slices = Vec::new();
        let exponential = Slices {
            scheme: ZSlicing::Exponential,
            near: cam.near,
            far: cam.far,
            count: grid.2,
            tan_half_fov_y: (cam.fov_y / 2.0).tan(),
            tiles_y: grid.1,
        };
        for k in 1..grid.2 {
            let z = exponential.start(k);
            for x in [-0.5, 0.0, 0.5] {
                let p = world_from_view.transform_point3(DVec3::new(x * z, 0.0, -z));
                on_slices.push(light(p, 0.8, 2.0));
            }
        }
        cases.push(case(
            "lights_on_slice_boundaries",
            "light centres exactly on z-slice boundaries",
            scene("lights_on_slice_boundaries", SIZE, room(), on_slices, cam),
            clustered(),
        ));
        let tan = (cam.fov_y / 2.0).tan();
        let aspect = SIZE.0 as f64 / SIZE.1 as f64;
        let mut on_tiles = Vec::new();
        for i in 0..=grid.0 {
            for z in [2.0, 5.0, 8.0] {
                let x = (2.0 * i as f64 / grid.0 as f64 - 1.0) * tan * aspect * z;
                let p = world_from_view.transform_point3(DVec3::new(x, 0.0, -z));
                on_tiles.push(light(p, 0.7, 2.0));
            }
        }
        for j in 0..=grid.1 {
            let z = 4.0;
            let y = (2.0 * j as f64 / grid.1 as f64 - 1.0) * tan * z;
            let p = world_from_view.transform_point3(DVec3::new(0.3, y, -z));
            on_tiles.push(light(p, 0.7, 2.0));
        }
        cases.push(case(
            "lights_on_tile_boundaries",
            "light centres exactly on tile boundary planes",
            scene("lights_on_tile_boundaries", SIZE, room(), on_tiles, cam),
            clustered(),
        ));
        let behind: Vec<Light> = (0..8)
            .map(|i| {
                let p = world_from_view.transform_point3(DVec3::new(
                    i as f64 - 3.5,
                    0.0,
                    1.0 + i as f64 * 0.3,
                ));
                light(p, 6.0, 10.0)
            })
            .collect();
        cases.push(case(
            "lights_behind_camera",
            "light centres behind the camera, spheres reaching into the view",
            scene("lights_behind_camera", SIZE, room(), behind, cam),
            pipelines(),
        ));
        let straddle: Vec<Light> = (0..8)
            .map(|i| {
                let p = world_from_view.transform_point3(DVec3::new(
                    (i as f64 - 3.5) * 0.02,
                    0.0,
                    -cam.near,
                ));
                light(p, 3.0 + i as f32 * 0.5, 5.0)
            })
            .collect();
        cases.push(case(
            "lights_straddling_near_plane",
            "light centres on the near plane",
            scene("lights_straddling_near_plane", SIZE, room(), straddle, cam),
            pipelines(),
        ));
        let at_far: Vec<Light> = (0..8)
            .map(|i| {
                let p = world_from_view.transform_point3(DVec3::new(i as f64 - 3.5, 0.5, -cam.far));
                light(p, (cam.far * 0.9) as f32, 50.0)
            })
            .collect();
        cases.push(case(
            "lights_at_far_plane",
            "light centres on the far plane, radii reaching the room",
            scene("lights_at_far_plane", SIZE, room(), at_far, cam),
            pipelines(),
        ));
    }
    cases.push(case(
        "many_lights_at_one_point",
        "1000 lights at one position",
        lit_room(
            "many_lights_at_one_point",
            SIZE,
            (0..1000)
                .map(|_| light(DVec3::new(0.5, 1.5, 1.0), 4.0, 0.05))
                .collect(),
        ),
        pipelines(),
    ));
    cases.push(case(
        "intensity_zero",
        "lights of intensity 0",
        lit_room(
            "intensity_zero",
            SIZE,
            lattice(27, 3.0)
                .into_iter()
                .map(|mut l| {
                    l.color = [0.0; 3];
                    l
                })
                .collect(),
        ),
        pipelines(),
    ));
    cases.push(case(
        "intensity_1e6",
        "lights of intensity 1e6: HDR far above display white",
        lit_room(
            "intensity_1e6",
            SIZE,
            lattice(8, 3.0)
                .into_iter()
                .map(|mut l| {
                    // The lattice's colours carry its intensity, 60/8: make it 1e6.
                    l.color = l.color.map(|c| c / (60.0 / 8.0) * 1e6);
                    l
                })
                .collect(),
        ),
        pipelines(),
    ));
    cases.push(case(
        "positions_at_1e6",
        "lights 1e6 away with radii that reach the room",
        lit_room(
            "positions_at_1e6",
            SIZE,
            [
                DVec3::new(1e6, 0.0, 0.0),
                DVec3::new(0.0, 1e6, 0.0),
                DVec3::new(-7e5, 7e5, 1e3),
            ]
            .into_iter()
            .map(|p| light(p, 1.5e6, 1e13))
            .collect(),
        ),
        pipelines(),
    ));

    // Geometry.
    {
        // Inside a box, looking towards +z: floor, ceiling, both side walls and the far
        // wall have normals exactly along the axes (+y, -y, +x, -x, -z).
        let mut m = MeshBuilder::default();
        m.cuboid_inside(
            DVec3::new(-4.0, 0.0, -4.0),
            DVec3::new(4.0, 4.0, 4.0),
            STONE,
        );
        let eye = DVec3::new(0.3, 2.0, -3.5);
        let cam = camera(
            eye,
            DVec3::new(0.0, 1.8, 4.0),
            80.0,
            0.1,
            Scene::far_plane_for(&m.vertices, eye),
        );
        let lights = vec![
            light(DVec3::new(0.0, 3.5, 2.0), 8.0, 30.0),
            light(DVec3::new(-3.0, 1.0, 3.0), 5.0, 10.0),
            light(DVec3::new(3.0, 1.0, 1.0), 5.0, 10.0),
        ];
        cases.push(case(
            "normals_along_axes",
            "surfaces whose normals are exactly +-x, +-y and -z",
            scene("normals_along_axes", SIZE, m, lights, cam),
            with_codecs(),
        ));
    }
    {
        // A sphere seen from above the pole, and a ring of quads whose normals lie on the
        // octahedron's seams (z = 0, and x = +-y).
        let mut m = MeshBuilder::default();
        m.sphere(DVec3::ZERO, 1.5, 24, 48, STONE);
        let eye = DVec3::new(0.01, 0.02, 5.0);
        let cam = camera(eye, DVec3::ZERO, 50.0, 0.1, 10.0);
        cases.push(case(
            "normals_near_octahedron_poles",
            "a sphere seen down the z axis: normals near (0, 0, +-1)",
            scene(
                "normals_near_octahedron_poles",
                SIZE,
                m,
                vec![light(DVec3::new(0.5, 0.5, 4.0), 8.0, 20.0)],
                cam,
            ),
            with_codecs(),
        ));
        let mut m = MeshBuilder::default();
        for i in 0..8 {
            let a = i as f64 * std::f64::consts::FRAC_PI_4;
            let n = DVec3::new(a.cos(), a.sin(), 0.0);
            let t = DVec3::Z;
            let b = n.cross(t);
            let c = n * 3.0;
            m.quad(
                [c - b - t, c + b - t, c + b + t, c - b + t],
                n,
                if i % 2 == 0 { RED } else { BLUE },
            );
        }
        m.axis_rect(2, -1.0, [-4.0, -4.0], [4.0, 4.0], true, STONE);
        let eye = DVec3::new(0.0, 0.0, 1.0);
        let cam = camera(eye, DVec3::new(1.0, 0.3, 0.0), 100.0, 0.05, 10.0);
        cases.push(case(
            "normals_on_octahedron_seams",
            "a ring of walls with normals in the z = 0 plane, on x = +-y among them",
            scene(
                "normals_on_octahedron_seams",
                SIZE,
                m,
                vec![
                    light(DVec3::new(0.0, 0.0, 0.5), 6.0, 20.0),
                    light(DVec3::new(1.5, -1.0, 0.0), 3.0, 5.0),
                ],
                cam,
            ),
            with_codecs(),
        ));
    }
    {
        // Degenerate triangles (all three corners at one point, and collinear ones) whose
        // vertex normals are zero, on top of the room.
        let mut m = room();
        let base = m.vertices.len() as u32;
        let zero = |p: [f32; 3]| Vertex {
            position: p,
            normal: [0.0; 3],
            albedo: RED,
            material: [0.5, 0.0],
            uv: [0.0; 2],
            texture: crate::common::NO_TEXTURE,
            alpha: [1.0, 0.0],
        };
        m.vertices.extend([
            zero([0.0, 0.5, 2.0]),
            zero([0.0, 0.5, 2.0]),
            zero([0.0, 0.5, 2.0]),
            zero([-1.0, 0.2, 2.5]),
            zero([0.0, 0.2, 2.5]),
            zero([1.0, 0.2, 2.5]),
        ]);
        m.indices
            .extend([base, base + 1, base + 2, base + 3, base + 4, base + 5]);
        // And a real quad whose vertex normals are zero (the shading sees a zero normal).
        let b = m.vertices.len() as u32;
        m.vertices.extend([
            zero([-1.0, 0.01, 3.0]),
            zero([1.0, 0.01, 3.0]),
            zero([1.0, 0.01, 4.0]),
            zero([-1.0, 0.01, 4.0]),
        ]);
        m.indices.extend([b, b + 2, b + 1, b, b + 3, b + 2]);
        let cam = default_camera(&m);
        cases.push(case(
            "zero_length_normals",
            "degenerate triangles and a quad with zero vertex normals",
            scene("zero_length_normals", SIZE, m, base_lights(), cam),
            with_codecs(),
        ));
    }
    {
        let mut m = MeshBuilder::default();
        m.axis_rect(1, 0.0, [-50.0, -50.0], [50.0, 50.0], true, STONE);
        let eye = DVec3::new(0.0, 0.02, 10.0);
        let cam = camera(
            eye,
            DVec3::new(0.0, 0.0, -40.0),
            60.0,
            0.01,
            Scene::far_plane_for(&m.vertices, eye),
        );
        cases.push(case(
            "grazing_angles",
            "a floor seen 2 cm above it: n.v near 0 across the image",
            scene("grazing_angles", SIZE, m, lattice(64, 6.0), cam),
            pipelines(),
        ));
    }
    {
        let mut m = room();
        let cam = default_camera(&m);
        let f = (cam.target - cam.eye).normalize();
        let c = cam.eye + f * (cam.near * 1.001);
        let right = f.cross(DVec3::Y).normalize() * 0.05;
        let up = right.cross(f).normalize() * 0.03;
        m.quad(
            [
                c - right - up,
                c + right - up,
                c + right + up,
                c - right + up,
            ],
            -f,
            BLUE,
        );
        cases.push(case(
            "surface_at_near_plane",
            "a quad 0.1% beyond the near plane over the middle of the image",
            scene("surface_at_near_plane", SIZE, m, base_lights(), cam),
            pipelines(),
        ));
    }

    // Grids.
    for (grid, what) in [
        ((1, 1, 1), "one cluster holding every light"),
        ((64, 64, 64), "262144 clusters, most smaller than a pixel"),
    ] {
        let edit = set_grid(grid);
        let name = format!("grid{}", edit.suffix);
        cases.push(
            case(
                name.clone(),
                what,
                lit_room(&name, SIZE, lattice(64, 2.0)),
                edited(clustered(), &edit),
            )
            .with_edits(vec![edit]),
        );
    }
    // Every z-slicing scheme (the schema's list), with lights across many slices.
    {
        let cam = default_camera(&room());
        for slicing in ZSlicing::every(cam.near, cam.far) {
            let tag = slicing_case_name(slicing);
            cases.push(
                case(
                    tag.clone(),
                    format!("{} slicing, 64 lights through the room", slicing.label()),
                    lit_room(&tag, SIZE, lattice(64, 2.0)),
                    with_slicing(slicing, &tag),
                )
                .with_edits(vec![set_slicing(slicing, &tag)]),
            );
        }
    }
    cases.push(case(
        "dynamic_range_previous_frame",
        "slices fitted to the previous frame's depth range: the deepest pixel sits on the far end",
        lit_room("dynamic_range_previous_frame", SIZE, base_lights()),
        with_slicing(PREVIOUS_FRAME_RANGE, "dynamic_previous"),
    )
    .with_edits(vec![set_slicing(PREVIOUS_FRAME_RANGE, "dynamic_previous")]));
    cases.push(case(
        "olsson_slices_run_out",
        "Olsson's cubic slices at a 30 degree field of view: 12 slices end long before the far plane, the last holds the rest",
        {
            let m = room();
            let eye = DVec3::new(0.0, 3.0, 7.0);
            let cam = camera(
                eye,
                DVec3::new(0.0, 0.8, 0.0),
                30.0,
                0.1,
                Scene::far_plane_for(&m.vertices, eye),
            );
            scene("olsson_slices_run_out", SIZE, m, base_lights(), cam)
        },
        with_slicing(ZSlicing::OlssonCubic, "olsson"),
    )
    .with_edits(vec![set_slicing(ZSlicing::OlssonCubic, "olsson")]));
    spot_cases(&mut cases);
    transparency_cases(&mut cases);
    shadow_cases(&mut cases);
    motion_cases(&mut cases);
    cases
}

/// Forward+ with every list strategy (`clusters.update`) on each method whose lists it
/// keeps: one-level, two-level, with sample bounds, the light BVH; and clustered deferred
/// with static and dynamic lists (its still image is the resolve's).
fn strategies() -> Vec<(String, Variant)> {
    let mut out = Vec::new();
    let methods: [(&str, Culling, Option<u32>, bool); 4] = [
        ("one_level", Culling::Boxes, None, false),
        ("two_level", Culling::Boxes, Some(2), false),
        ("sample_bounds", Culling::Boxes, None, true),
        ("bvh", Culling::Bvh, None, false),
    ];
    for (method, culling, big_tiles, bounds) in methods {
        for update in ListUpdate::iter() {
            let name = format!("forward_plus_{method}_{}", update.label().replace('+', "_"));
            let mut v = variant(&name, Pipeline::ClusteredForward);
            let c = v.clusters.as_mut().expect("clustered");
            (c.culling, c.big_tiles, c.update) = (culling, big_tiles, update);
            (c.active_clusters, c.sample_bounds) = (bounds, bounds);
            out.push((name, v));
        }
    }
    let mut deferred = variant("deferred_static_dynamic", Pipeline::ClusteredDeferred);
    deferred.clusters.as_mut().expect("clustered").update = ListUpdate::StaticDynamic;
    out.push(("deferred_static_dynamic".into(), deferred));
    // Refit is for the BVH alone: the others are refused.
    out.into_iter()
        .filter(|(_, v)| check(v).is_empty())
        .collect()
}

/// A room lit by `frames[i]` in frame i, the camera still: the case of a sequence whose
/// lights move (each light that differs between frames is a moving one).
fn motion_case(name: &str, what: &str, frames: Vec<Vec<Light>>) -> Case {
    let m = room();
    let cam = default_camera(&m);
    let bytes = |l: &Light| bytemuck::bytes_of(l).to_vec();
    let moving: Vec<u32> = (0..frames[0].len())
        .filter(|&i| frames.iter().any(|f| bytes(&f[i]) != bytes(&frames[0][i])))
        .map(|i| i as u32)
        .collect();
    let mut scenes: Vec<Scene> = frames
        .into_iter()
        .enumerate()
        .map(|(k, lights)| {
            let mut s = scene(name, SIZE, room(), lights, cam);
            s.params.time = 1.0 + k as f64 * crate::scene::FRAME_DT;
            s.moving_lights = moving.clone();
            s
        })
        .collect();
    let first = scenes.remove(0);
    Case {
        name: name.into(),
        what: what.into(),
        scene: first,
        later: scenes,
        variants: strategies(),
        edits: vec![Edit::as_is(true)],
    }
}

/// World point that the default camera sees at pixel (x, y) of a `SIZE` image, at view
/// depth `z`.
fn seen_at(cam: &Camera, (x, y): (f64, f64), z: f64) -> DVec3 {
    let (w, h) = (SIZE.0 as f64, SIZE.1 as f64);
    let t = (cam.fov_y / 2.0).tan();
    let ndc = (2.0 * x / w - 1.0, 1.0 - 2.0 * y / h);
    let view = DVec3::new(ndc.0 * t * (w / h) * z, ndc.1 * t * z, -z);
    cam.view().inverse().transform_point3(view)
}

/// Lights that move from frame to frame where lists go wrong: across a tile corner, across
/// the frustum in one step, out of the view and back, and every light at once.
fn motion_cases(cases: &mut Vec<Case>) {
    let cam = default_camera(&room());
    let still = lattice(27, 2.0);
    let with = |moving: Light| {
        let mut lights = still.clone();
        lights.push(moving);
        lights
    };
    // The corner of four tiles of the 8x6 grid, 4 units in: the light crosses it
    // diagonally, a step a frame, through it exactly in the middle frame.
    let corner = (SIZE.0 as f64 * 3.0 / 8.0, SIZE.1 as f64 * 2.0 / 6.0);
    let crossing = (-2..=2)
        .map(|k| {
            let step = 0.6 * k as f64;
            let p = seen_at(&cam, (corner.0 + step, corner.1 + step), 4.0);
            with(light(p, 0.5, 4.0))
        })
        .collect();
    cases.push(motion_case(
        "motion_tile_corner",
        "a small light crossing a tile corner diagonally, through the corner itself",
        crossing,
    ));
    let left = seen_at(&cam, (4.0, SIZE.1 as f64 / 2.0), 5.0);
    let right = seen_at(&cam, (SIZE.0 as f64 - 4.0, SIZE.1 as f64 / 2.0), 5.0);
    let jumping = [left, left, right, right, left]
        .into_iter()
        .map(|p| with(light(p, 1.5, 6.0)))
        .collect();
    cases.push(motion_case(
        "motion_jump_across",
        "a light jumping across the frustum in one frame, and back",
        jumping,
    ));
    // In view, at the edge, behind the camera, beyond the far side, in view again.
    let inside = seen_at(&cam, (SIZE.0 as f64 / 2.0, SIZE.1 as f64 / 2.0), 4.0);
    let edge = seen_at(&cam, (0.0, SIZE.1 as f64 / 2.0), 4.0);
    let behind = cam.eye + (cam.eye - cam.target).normalize() * 4.0;
    let beside = seen_at(&cam, (-3.0 * SIZE.0 as f64, SIZE.1 as f64 / 2.0), 4.0);
    let leaving = [inside, edge, behind, beside, inside]
        .into_iter()
        .map(|p| with(light(p, 1.2, 6.0)))
        .collect();
    cases.push(motion_case(
        "motion_leave_view",
        "a light leaving the view (to its edge, behind the camera, beside it) and coming back",
        leaving,
    ));
    let swirling = (0..5)
        .map(|k| {
            lattice(64, 1.5)
                .into_iter()
                .enumerate()
                .map(|(i, mut l)| {
                    let a = 0.7 * k as f32 + i as f32;
                    l.position[0] += 0.8 * a.sin();
                    l.position[1] += 0.3 * (1.3 * a).cos();
                    l.position[2] += 0.8 * a.cos();
                    l
                })
                .collect()
        })
        .collect();
    cases.push(motion_case(
        "motion_all_lights",
        "every light moving at once, each its own way",
        swirling,
    ));
}

/// A square of half-size `half` facing `cam` at `distance` along its view axis, moved by
/// `offset` (in units of `half`) right and up; blended with `alpha`, or masked with its
/// corners' alphas `corners` (counter-clockwise from the bottom left).
fn facing_square(
    m: &mut MeshBuilder,
    cam: &Camera,
    distance: f64,
    half: f64,
    offset: (f64, f64),
    albedo: [f32; 3],
    corners: [f32; 4],
) {
    let forward = (cam.target - cam.eye).normalize();
    let right = forward.cross(DVec3::Y).normalize() * half;
    let up = right.cross(forward).normalize() * half;
    let c = cam.eye + forward * distance + right * offset.0 + up * offset.1;
    m.quad_with_alpha(
        [
            c - right - up,
            c + right - up,
            c + right + up,
            c - right + up,
        ],
        -forward,
        albedo,
        corners,
    );
}

/// Forward+ and clustered deferred with exact shadows.
fn shadowed() -> Vec<(String, Variant)> {
    [Pipeline::ClusteredForward, Pipeline::ClusteredDeferred]
        .into_iter()
        .map(|p| {
            let name = format!("{}_shadows", p.short_name());
            let mut v = variant(&name, p);
            v.shading.shadows = Shadows::Exact;
            (name, v)
        })
        .collect()
}

/// A user's variant with its own shadows, or exact ones where it has none (where it can
/// trace them).
fn set_shadows() -> Edit {
    Edit::new("_shadows", |v| {
        if !v.shading.shadows.traced() {
            v.shading.shadows = Shadows::Exact;
        }
        Ok(())
    })
}

/// Shadow rays where they are hardest on the room's boxes and sphere: lights a hair above
/// the floor (rays from the floor graze it), lights a hair off a box's faces (the occluder
/// touches the light), lights inside a box and inside the sphere (every ray out blocked).
fn shadow_cases(cases: &mut Vec<Case>) {
    let room_lit = |name: &str, lights: Vec<Light>| {
        let mut all = lattice(8, 3.0);
        all.extend(lights);
        lit_room(name, SIZE, all)
    };
    let grazing = (0..8)
        .map(|i| light(DVec3::new(-4.0 + i as f64, 0.01, 1.5), 4.0, 3.0))
        .collect();
    // The red box spans x -2.5..-1, y 0..2, z -2..-0.5.
    let touching = vec![
        light(DVec3::new(-1.0 + 1e-3, 1.0, -1.2), 3.0, 3.0),
        light(DVec3::new(-1.8, 2.0 + 1e-3, -1.2), 3.0, 3.0),
        light(DVec3::new(-1.8, 1.0, -0.5 + 1e-3), 3.0, 3.0),
    ];
    let inside = vec![
        light(DVec3::new(-1.8, 1.0, -1.2), 4.0, 3.0),
        light(DVec3::new(0.3, 1.0, 0.5), 4.0, 3.0),
    ];
    for (name, what, lights) in [
        (
            "shadow_grazing_light",
            "shadow rays that graze the floor: lights 0.01 above it",
            grazing,
        ),
        (
            "shadow_occluder_touching_light",
            "lights 1e-3 off a box's faces: the occluder inside the light's range, at its centre",
            touching,
        ),
        (
            "shadow_light_inside_occluder",
            "lights inside a box and inside the sphere: every ray out of them blocked",
            inside,
        ),
    ] {
        cases.push(
            case(name, what, room_lit(name, lights), shadowed()).with_edits(vec![set_shadows()]),
        );
    }
}

/// Masked and blended materials on the room: a pane on the near plane, 64 panes over the
/// same pixels, alpha 0 and 1, a light that reaches only a pane against the background (no
/// opaque sample in its clusters), masks at their cutoff; every pipeline and culling method.
fn transparency_cases(cases: &mut Vec<Case>) {
    use crate::common::AlphaMode;
    let room_with = |name: &str, build: &dyn Fn(&mut MeshBuilder, &Camera), lights: Vec<Light>| {
        let mut m = room();
        let cam = default_camera(&m);
        build(&mut m, &cam);
        scene(name, SIZE, m, lights, cam)
    };
    let blended = |m: &mut MeshBuilder, alpha: f32| m.set_alpha(alpha, AlphaMode::Blend);
    cases.push(case(
        "pane_on_near_plane",
        "blended panes at the near plane's distance (one centred, one off to the side)",
        room_with(
            "pane_on_near_plane",
            &|m, cam| {
                blended(m, 0.5);
                facing_square(m, cam, cam.near, 0.02, (0.0, 0.0), BLUE, [0.5; 4]);
                facing_square(m, cam, cam.near, 0.02, (1.5, 0.5), RED, [0.5; 4]);
            },
            lattice(27, 3.0),
        ),
        pipelines(),
    ));
    cases.push(case(
        "panes_64_overlapping",
        "64 blended panes (alpha 0.1) one behind the other over the same pixels",
        room_with(
            "panes_64_overlapping",
            &|m, cam| {
                blended(m, 0.1);
                for i in 0..64 {
                    let tint = [0.3 + 0.01 * i as f32, 0.5, 0.9 - 0.01 * i as f32];
                    facing_square(
                        m,
                        cam,
                        1.0 + 0.06 * i as f64,
                        0.4,
                        (0.0, 0.0),
                        tint,
                        [0.1; 4],
                    );
                }
            },
            lattice(27, 3.0),
        ),
        pipelines(),
    ));
    cases.push(case(
        "alpha_0_and_1",
        "blended panes of alpha 0 (no trace) and 1 (opaque, over a pane of 0.5)",
        room_with(
            "alpha_0_and_1",
            &|m, cam| {
                blended(m, 0.0);
                facing_square(m, cam, 3.0, 0.8, (-0.8, 0.0), RED, [0.0; 4]);
                blended(m, 0.5);
                facing_square(m, cam, 4.0, 0.8, (0.8, 0.0), BLUE, [0.5; 4]);
                blended(m, 1.0);
                facing_square(m, cam, 3.0, 0.8, (1.2, 0.0), STONE, [1.0; 4]);
            },
            lattice(27, 3.0),
        ),
        pipelines(),
    ));
    {
        // A pane high in the view, with only background behind it, and a light a hair in
        // front of it that no opaque surface is near.
        let pane = DVec3::new(0.0, 4.5, -4.0);
        let mut lights = lattice(27, 3.0);
        let toward_eye = (DVec3::new(0.0, 3.0, 7.0) - pane).normalize();
        lights.push(light(pane + toward_eye * 0.3, 0.8, 2.0));
        cases.push(case(
            "light_only_on_a_pane",
            "a light that reaches a blended pane against the background and no opaque sample",
            room_with(
                "light_only_on_a_pane",
                &|m, cam| {
                    blended(m, 0.6);
                    let distance = (pane - cam.eye).length();
                    let forward = (cam.target - cam.eye).normalize();
                    // The square faces the camera; placed on the line to `pane`.
                    let along = (pane - cam.eye).normalize();
                    let right = forward.cross(DVec3::Y).normalize();
                    let up = right.cross(forward).normalize();
                    let offset = (
                        along.dot(right) / along.dot(forward),
                        along.dot(up) / along.dot(forward),
                    );
                    let depth = distance * along.dot(forward);
                    let half = 1.0;
                    facing_square(
                        m,
                        cam,
                        depth,
                        half,
                        (offset.0 * depth / half, offset.1 * depth / half),
                        STONE,
                        [0.6; 4],
                    );
                },
                lights,
            ),
            pipelines(),
        ));
    }
    cases.push(case(
        "mask_at_cutoff",
        "masked squares: alpha equal to the cutoff everywhere, a gradient across it, cutoff 1 with alpha 1 and just below",
        room_with(
            "mask_at_cutoff",
            &|m, cam| {
                m.set_alpha(1.0, AlphaMode::Mask { cutoff: 0.5 });
                facing_square(m, cam, 4.0, 0.6, (-1.5, 0.0), RED, [0.5; 4]);
                facing_square(m, cam, 4.0, 0.6, (0.0, 0.0), BLUE, [0.25, 0.75, 0.75, 0.25]);
                m.set_alpha(1.0, AlphaMode::Mask { cutoff: 1.0 });
                facing_square(m, cam, 4.0, 0.6, (1.5, 0.0), STONE, [1.0; 4]);
                facing_square(m, cam, 4.0, 0.6, (1.5, 1.5), STONE, [0.99999; 4]);
            },
            lattice(27, 3.0),
        ),
        pipelines(),
    ));
}

/// A spot at `p` along `axis` (world space).
fn spot(p: DVec3, axis: DVec3, radius: f32, inner: f64, outer: f64, intensity: f32) -> Light {
    Light::spot(
        p.as_vec3().to_array(),
        radius,
        [1.0, 0.9, 0.8],
        intensity,
        axis.to_array(),
        inner,
        outer,
    )
}

/// Every pipeline, the clustered ones again with the bounding-sphere spot test, and Forward+
/// with GGX shading: the spot cases run each test and each shading model.
fn with_spot_tests() -> Vec<(String, Variant)> {
    let mut out = pipelines();
    for (n, mut v) in clustered() {
        if let Some(c) = &mut v.clusters {
            c.spot_test = SpotTest::Sphere;
        }
        out.push((format!("{n}_sphere_test"), v));
    }
    let mut ggx = variant("forward_plus_ggx", Pipeline::ClusteredForward);
    ggx.shading.model = ShadingModel::Ggx;
    out.push(("forward_plus_ggx".into(), ggx));
    out
}

/// `n` unit vectors spread over the sphere (a Fibonacci spiral).
fn spread_directions(n: u32) -> impl Iterator<Item = DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n).map(move |i| {
        let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - y * y).sqrt();
        let phi = golden * i as f64;
        DVec3::new(r * phi.cos(), y, r * phi.sin())
    })
}

/// The spot lights' cases: extreme cone angles, apexes on cluster corners and planes, cones
/// along and against the view, behind the camera, at the near plane, grazing a cluster, and
/// ten thousand at one point. Each runs every pipeline and both spot tests.
fn spot_cases(cases: &mut Vec<Case>) {
    let down = DVec3::NEG_Y;
    let overhead = |outer: f64, inner: f64| -> Vec<Light> {
        (0..9)
            .map(|i| {
                let p = DVec3::new(
                    -3.0 + 3.0 * (i % 3) as f64,
                    2.5,
                    -3.0 + 3.0 * (i / 3) as f64,
                );
                spot(
                    p,
                    down + DVec3::new(0.1 * (i % 3) as f64, 0.0, 0.0),
                    5.0,
                    inner,
                    outer,
                    8.0,
                )
            })
            .collect()
    };
    for (name, what, outer, inner) in [
        (
            "spot_outer_0_01_degrees",
            "spots with a 0.01 degree outer cone (its cosine rounds to 1 in f32: they light nothing, everywhere)",
            0.01,
            0.005,
        ),
        (
            "spot_outer_89_9_degrees",
            "spots with an 89.9 degree outer cone: nearly a hemisphere",
            89.9,
            60.0,
        ),
        (
            "spot_inner_equals_outer",
            "inner cone equal to the outer: a hard edge",
            30.0,
            30.0,
        ),
    ] {
        cases.push(case(
            name,
            what,
            lit_room(name, SIZE, overhead(outer, inner)),
            with_spot_tests(),
        ));
    }
    let m = room();
    let cam = default_camera(&m);
    let world_from_view = cam.view().inverse();
    let to_world = |p: DVec3| world_from_view.transform_point3(p);
    let dir_to_world = |d: DVec3| world_from_view.transform_vector3(d);
    let grid = (8u32, 6u32, 12u32);
    let tan = (cam.fov_y / 2.0).tan();
    let aspect = SIZE.0 as f64 / SIZE.1 as f64;
    let slices = Slices {
        scheme: ZSlicing::Exponential,
        near: cam.near,
        far: cam.far,
        count: grid.2,
        tan_half_fov_y: tan,
        tiles_y: grid.1,
    };
    // A view-space corner of the grid: tile corner (i, j) at the start of slice k.
    let corner = |i: u32, j: u32, k: u32| {
        let z = slices.start(k);
        DVec3::new(
            (2.0 * i as f64 / grid.0 as f64 - 1.0) * tan * aspect * z,
            (1.0 - 2.0 * j as f64 / grid.1 as f64) * tan * z,
            -z,
        )
    };
    let on_corners: Vec<Light> = (0..16)
        .map(|n| {
            let p = corner(1 + n % 6, 1 + n % 4, 2 + n % 9);
            let axis = spread_directions(16)
                .nth(n as usize)
                .expect("16 directions");
            spot(to_world(p), dir_to_world(axis), 2.5, 15.0, 25.0, 4.0)
        })
        .collect();
    cases.push(case(
        "spot_apex_on_cluster_corner",
        "spot apexes exactly on cluster corners, axes in 16 directions",
        scene("spot_apex_on_cluster_corner", SIZE, room(), on_corners, cam),
        with_spot_tests(),
    ));
    let on_planes: Vec<Light> = (0..=grid.0)
        .map(|i| {
            let z = 3.0 + i as f64 * 0.5;
            let x = (2.0 * i as f64 / grid.0 as f64 - 1.0) * tan * aspect * z;
            let axis = DVec3::new(if i % 2 == 0 { 1.0 } else { -1.0 }, -0.5, 0.0);
            spot(
                to_world(DVec3::new(x, 0.2, -z)),
                dir_to_world(axis),
                3.0,
                10.0,
                20.0,
                4.0,
            )
        })
        .collect();
    cases.push(case(
        "spot_apex_on_tile_plane",
        "spot apexes exactly on tile planes, pointing across them",
        scene("spot_apex_on_tile_plane", SIZE, room(), on_planes, cam),
        with_spot_tests(),
    ));
    let forward = (cam.target - cam.eye).normalize();
    let along: Vec<Light> = (0..5)
        .map(|i| {
            let p =
                cam.eye + forward * (0.5 + i as f64) + DVec3::new(0.3 * i as f64 - 0.6, 0.0, 0.0);
            spot(p, forward, 8.0, 5.0, 12.0, 20.0)
        })
        .collect();
    cases.push(case(
        "spot_axis_along_view",
        "spots pointing straight away from the camera",
        scene("spot_axis_along_view", SIZE, room(), along, cam),
        with_spot_tests(),
    ));
    let against: Vec<Light> = (0..5)
        .map(|i| {
            let p = cam.target
                + forward * (0.5 * i as f64)
                + DVec3::new(0.5 * i as f64 - 1.0, 0.5, 0.0);
            spot(p, -forward, 9.0, 10.0, 25.0, 20.0)
        })
        .collect();
    cases.push(case(
        "spot_axis_against_view",
        "spots pointing straight at the camera",
        scene("spot_axis_against_view", SIZE, room(), against, cam),
        with_spot_tests(),
    ));
    let behind: Vec<Light> = (0..5)
        .map(|i| {
            let p = cam.eye - forward * (1.0 + 0.5 * i as f64)
                + DVec3::new(0.4 * i as f64 - 0.8, 0.0, 0.0);
            spot(
                p,
                forward + DVec3::new(0.0, -0.1 * i as f64, 0.0),
                12.0,
                8.0,
                20.0,
                40.0,
            )
        })
        .collect();
    cases.push(case(
        "spot_apex_behind_camera",
        "spot apexes behind the camera, cones pointing into the view",
        scene("spot_apex_behind_camera", SIZE, room(), behind, cam),
        with_spot_tests(),
    ));
    let at_near: Vec<Light> = (0..5)
        .map(|i| {
            let p = to_world(DVec3::new(0.02 * i as f64 - 0.04, 0.0, -cam.near));
            let axis = dir_to_world(DVec3::new(0.0, -0.3 * i as f64, -1.0));
            spot(p, axis, 9.0, 10.0, 30.0, 30.0)
        })
        .collect();
    cases.push(case(
        "spot_apex_at_near_plane",
        "spot apexes on the near plane",
        scene("spot_apex_at_near_plane", SIZE, room(), at_near, cam),
        with_spot_tests(),
    ));
    // Each cone's side passes exactly through a cluster corner: the axis is turned from the
    // corner's direction by the outer angle.
    let grazing: Vec<Light> = (0..12)
        .map(|n| {
            let apex = DVec3::new(-1.0 + 0.2 * n as f64, 1.0, -2.0);
            let q = corner(2 + n % 5, 1 + n % 4, 3 + n % 7);
            let to_q = (q - apex).normalize();
            let outer = 10.0 + 5.0 * (n % 4) as f64;
            let side = to_q.cross(DVec3::Y).normalize_or(DVec3::X);
            let axis = glam::DQuat::from_axis_angle(side, outer.to_radians()) * to_q;
            let range = ((q - apex).length() * 1.5) as f32;
            spot(
                to_world(apex),
                dir_to_world(axis),
                range,
                outer * 0.5,
                outer,
                6.0,
            )
        })
        .collect();
    cases.push(case(
        "spot_grazing_cluster",
        "cones whose side passes exactly through a cluster corner",
        scene("spot_grazing_cluster", SIZE, room(), grazing, cam),
        with_spot_tests(),
    ));
    let point = DVec3::new(0.3, 2.2, 0.4);
    let crowd: Vec<Light> = spread_directions(10_000)
        .enumerate()
        .map(|(i, d)| {
            spot(
                point,
                d,
                4.0,
                5.0 + (i % 30) as f64,
                10.0 + (i % 60) as f64,
                0.01,
            )
        })
        .collect();
    cases.push(case(
        "spots_10000_at_one_point",
        "10000 spots at one point, axes spread over the sphere",
        lit_room("spots_10000_at_one_point", SIZE, crowd),
        with_spot_tests(),
    ));

    // Multisampling: every method at 4 samples (skipped where the adapter has not 4).
    for (name, size, lights, what) in [
        (
            "msaa_1x1",
            (1, 1),
            lattice(27, 3.0),
            "4 samples in a 1x1 frame: every sample an edge of the sphere, walls or floor",
        ),
        (
            "msaa_odd_size",
            (13, 7),
            lattice(27, 3.0),
            "4 samples at 13x7: tile and pixel edges apart, corners where three walls meet",
        ),
        (
            "msaa_small_lights",
            SIZE,
            lattice(512, 0.3),
            "4 samples, 512 lights of radius 0.3 (a few pixels): lights that reach some samples of an edge pixel and not others",
        ),
    ] {
        cases.push(
            case(name, what, lit_room(name, size, lights), multisampled())
                .with_edits(vec![set_msaa4()]),
        );
    }
    {
        // The near plane through the sphere and the walls: edges on the near plane.
        let m = room();
        let eye = DVec3::new(0.0, 1.0, 3.0);
        let cam = camera(eye, DVec3::new(0.0, 1.0, 0.0), 60.0, 2.6, 40.0);
        cases.push(
            case(
                "msaa_near_plane",
                "4 samples, the near plane cutting the sphere: edges on the near plane",
                scene("msaa_near_plane", SIZE, m, lattice(27, 3.0), cam),
                multisampled(),
            )
            .with_edits(vec![set_msaa4()]),
        );
    }
    cases.push(
        case(
            TIES_CASE,
            "4 samples, two floors in one plane cut along other diagonals: samples where they tie",
            coplanar_ties(),
            multisampled(),
        )
        .with_edits(vec![set_msaa4()]),
    );
}

/// The name of the case whose samples tie between two surfaces (`coplanar_ties`).
pub const TIES_CASE: &str = "msaa_coplanar_ties";

/// The room with a second floor in the floor's plane, of another colour, cut along the other
/// diagonal and over other corners: at many samples the two interpolate the same depth and
/// at their pixels' centres different ones, so a pass that keeps whatever ties the nearest
/// fragment shades (and counts) fragments the depth pre-pass did not keep.
pub fn coplanar_ties() -> Scene {
    let mut m = room();
    let corner = |x: f64, z: f64| DVec3::new(x, 0.0, z);
    m.quad(
        [
            corner(-5.0, 5.5),
            corner(5.5, 5.5),
            corner(5.5, -5.0),
            corner(-5.0, -5.0),
        ],
        DVec3::Y,
        RED,
    );
    let cam = default_camera(&m);
    scene(TIES_CASE, SIZE, m, lattice(27, 3.0), cam)
}

/// Every pipeline at 4 samples.
fn multisampled() -> Vec<(String, Variant)> {
    edited(pipelines(), &set_msaa4())
}
