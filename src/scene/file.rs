//! glTF 2.0 scenes (`.gltf` with its buffers and images, or `.glb`), read with the `gltf`
//! crate: meshes with their node transforms, base colour (factor, vertex colour and
//! texture), metallic and roughness factors, `KHR_lights_punctual` point and spot lights,
//! and the first camera with its animation.
//!
//! A file is read once per process ([`load`] keeps it by path, size and modification
//! time); [`instantiate`] then makes the scene for a set of parameters (image size, seeded
//! lights when the file has none or another count is asked for, the time at which the
//! camera's animation is sampled).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

use glam::{DAffine3, DMat3, DQuat, DVec3, Quat, Vec3};
use sha2::{Digest, Sha256};

use super::{Camera, FRAME_DT, Light, Scene, SceneError, SceneFile, SceneParams, TextureArray};
use crate::common::{NO_TEXTURE, Vertex};

/// Extensions that change how geometry is stored: clusterlab cannot read their data.
const GEOMETRY_EXTENSIONS: [(&str, &str); 3] = [
    (
        "KHR_draco_mesh_compression",
        "its meshes are Draco-compressed: write them uncompressed, e.g. open the file in Blender and export it again with compression off",
    ),
    (
        "KHR_mesh_quantization",
        "its vertex attributes are quantized integers: write float attributes, e.g. `gltf-transform dequantize IN OUT` (glTF-Transform) or export again without quantization",
    ),
    (
        "EXT_meshopt_compression",
        "its buffers are meshoptimizer-compressed: write them uncompressed, e.g. export again without meshopt compression",
    ),
];

/// The cut-off that gives a light without a `range` its radius: the distance at which its
/// brightest channel falls to 1/256 (about half an 8-bit step of a white surface at
/// exposure 1): `range = sqrt(intensity / CUTOFF)`.
pub const RANGE_CUTOFF: f64 = 1.0 / 256.0;

/// Seeded lights fill a file scene's bounds with a total power of this times the bounds'
/// volume over the mean light radius: the atrium's exposure (power 180 in a 32 x 12 x 14
/// hall with radii 1 to 3) at any scale.
const POWER_PER_VOLUME_OVER_RADIUS: f64 = 180.0 * 2.0 / (32.0 * 12.0 * 14.0);

/// Deeper node hierarchies are taken for cycles (which glTF forbids).
const MAX_NODE_DEPTH: usize = 256;
/// More node visits than this: nodes shared between parents, multiplying the work.
const MAX_NODE_VISITS: usize = 1 << 20;
/// Most vertices a file scene may have (7.5 GB of vertex data), checked before reading
/// each primitive: a small file that instances a large mesh many times must not exhaust
/// memory.
const MAX_VERTICES: usize = 1 << 27;

/// What a glTF file holds, whatever the parameters it is rendered with.
#[derive(Debug)]
pub struct FileScene {
    pub file: SceneFile,
    pub vertices: Vec<Vertex>,
    pub indices: Vec<u32>,
    pub textures: Option<Arc<TextureArray>>,
    /// The file's point and spot lights, in node order.
    pub lights: Vec<Light>,
    pub camera: Option<CameraTrack>,
    /// Bounds of every vertex, world space.
    pub bounds: (DVec3, DVec3),
    pub notes: Vec<String>,
}

/// The file's first perspective camera: its projection and the nodes from the root down
/// to it, each with its animation (animation 0's channels on that node).
#[derive(Clone, Debug)]
pub struct CameraTrack {
    pub fov_y: f32,
    pub near: f32,
    pub far: Option<f32>,
    pub nodes: Vec<NodeTrack>,
}

/// A node's own transform and what animates it.
#[derive(Clone, Debug)]
pub struct NodeTrack {
    pub translation: Vec3,
    pub rotation: Quat,
    pub scale: Vec3,
    pub channels: Vec<Channel>,
}

/// One animated property of a node.
#[derive(Clone, Debug)]
pub struct Channel {
    pub property: Property,
    pub interpolation: gltf::animation::Interpolation,
    pub times: Vec<f32>,
    /// Values, 3 (translation, scale) or 4 (rotation, x y z w) floats each; a cubic spline
    /// holds in-tangent, value and out-tangent for every key.
    pub values: Vec<f32>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Property {
    Translation,
    Rotation,
    Scale,
}

/// Whether `name` names a glTF file rather than a built-in scene.
pub fn is_file(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    lower.ends_with(".gltf") || lower.ends_with(".glb")
}

/// A file's size and modification time: when either changes, it is read again.
type Stamp = (u64, Option<std::time::SystemTime>);
type Cache = Mutex<HashMap<PathBuf, (Stamp, Arc<FileScene>)>>;

/// The file at `path`, read on first use (again when its size or modification time change).
pub fn load(path: &str) -> Result<Arc<FileScene>, SceneError> {
    static CACHE: OnceLock<Cache> = OnceLock::new();
    let fail = |message: String| SceneError::File {
        path: path.to_string(),
        message,
    };
    let meta = std::fs::metadata(path).map_err(|e| fail(format!("cannot read: {e}")))?;
    if !meta.is_file() {
        return Err(fail("not a file".into()));
    }
    let stamp = (meta.len(), meta.modified().ok());
    let key = std::fs::canonicalize(path).unwrap_or_else(|_| PathBuf::from(path));
    let cache = CACHE.get_or_init(Default::default);
    if let Some((s, scene)) = cache.lock().expect("scene cache").get(&key)
        && *s == stamp
    {
        return Ok(scene.clone());
    }
    // The reader is not ours: a file it trips over must still be an error, not a crash.
    let read = std::panic::catch_unwind(|| read_file(path)).unwrap_or_else(|_| {
        Err(
            "the glTF reader failed on this file (it is malformed in a way not checked above)"
                .into(),
        )
    });
    let scene = Arc::new(read.map_err(fail)?);
    cache
        .lock()
        .expect("scene cache")
        .insert(key, (stamp, scene.clone()));
    Ok(scene)
}

fn read_file(path: &str) -> Result<FileScene, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read: {e}"))?;
    let parsed = gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| format!("not a glTF 2.0 file: {}", reader_error(&e)))?;
    for ext in parsed.extensions_used().chain(parsed.extensions_required()) {
        if let Some((name, what)) = GEOMETRY_EXTENSIONS.iter().find(|(n, _)| *n == ext) {
            return Err(format!(
                "uses extension {name}, which clusterlab cannot read: {what}"
            ));
        }
    }
    let gltf::Gltf { document, blob } = parsed;
    check_position_indices(document.as_json())?;
    let gltf = Parsed {
        document: gltf::Document::from_json(document.into_json())
            .map_err(|e| format!("not a valid glTF 2.0 file: {}", reader_error(&e)))?,
        blob,
    };
    let base = Path::new(path).parent().unwrap_or(Path::new("."));
    let mut hash = Sha256::new();
    hash.update(&bytes);
    let buffers = read_buffers(&gltf, base, &mut hash)?;
    let scene = gltf
        .default_scene()
        .or_else(|| gltf.scenes().next())
        .ok_or("no scene in the file: it has no `scenes`, so nothing to draw")?;
    let mut notes = Vec::new();

    // Walk the nodes depth first, keeping each node's path from the root and its parent's
    // world transform.
    let mut meshes: Vec<(gltf::Mesh, DAffine3)> = Vec::new();
    let mut lights = Vec::new();
    let mut camera = None;
    let mut stack: Vec<(gltf::Node, Vec<gltf::Node>, DAffine3)> = scene
        .nodes()
        .map(|n| (n.clone(), vec![n], DAffine3::IDENTITY))
        .collect();
    stack.reverse();
    let mut unsupported_lights = 0;
    let mut visits = 0usize;
    while let Some((node, chain, parent)) = stack.pop() {
        visits += 1;
        if visits > MAX_NODE_VISITS {
            return Err(format!(
                "the node hierarchy reaches more than {MAX_NODE_VISITS} nodes: a node is the child of several parents (glTF forbids it)"
            ));
        }
        if chain.len() > MAX_NODE_DEPTH {
            return Err(format!(
                "node {} is more than {MAX_NODE_DEPTH} levels deep: the node hierarchy has a cycle",
                node.index()
            ));
        }
        let world = parent * local_transform(&node);
        if let Some(mesh) = node.mesh() {
            meshes.push((mesh, world));
        }
        if let Some(light) = node.light() {
            match file_light(&light, &world, &chain) {
                Some(l) if finite_light(&l) => lights.push(l),
                Some(_) => {
                    return Err(format!(
                        "light {} at node {} has a position, direction, colour or range that is not a finite number",
                        light.index(),
                        node.index()
                    ));
                }
                None => unsupported_lights += 1,
            }
        }
        if camera.is_none()
            && let Some(cam) = node.camera()
        {
            match cam.projection() {
                gltf::camera::Projection::Perspective(p) => {
                    camera = Some(CameraTrack {
                        fov_y: p.yfov(),
                        near: p.znear(),
                        far: p.zfar(),
                        nodes: chain.iter().map(|n| node_track(&gltf, n, &buffers)).collect(),
                    });
                }
                gltf::camera::Projection::Orthographic(_) => notes.push(format!(
                    "camera {} is orthographic, which clusterlab does not render: the scene is framed instead",
                    cam.index()
                )),
            }
        }
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            let mut c = chain.clone();
            c.push(child.clone());
            stack.push((child, c, world));
        }
    }
    if unsupported_lights > 0 {
        notes.push(format!(
            "{unsupported_lights} directional light(s) left out: clusterlab shades point and spot lights (a directional light has no range to cluster)"
        ));
    }

    let images = BaseColorImages::collect(&gltf);
    let mut vertices = Vec::new();
    let mut indices = Vec::new();
    for (mesh, world) in &meshes {
        for primitive in mesh.primitives() {
            read_primitive(
                &primitive,
                world,
                &buffers,
                &images,
                &mut vertices,
                &mut indices,
                &mut notes,
            )
            .map_err(|e| format!("mesh {} primitive {}: {e}", mesh.index(), primitive.index()))?;
        }
    }
    if indices.is_empty() {
        return Err("no triangles to draw: the default scene's nodes hold no mesh with triangles (points and lines are not drawn)".into());
    }
    let textures = images.decode(&gltf, base, &buffers, &mut hash)?;
    let bounds = vertices.iter().fold(
        (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)),
        |(lo, hi), v| {
            let p = Vec3::from(v.position).as_dvec3();
            (lo.min(p), hi.max(p))
        },
    );
    if !(bounds.0.is_finite() && bounds.1.is_finite()) {
        return Err("a vertex position is not finite (NaN or infinity)".into());
    }
    Ok(FileScene {
        file: SceneFile {
            path: path.to_string(),
            sha256: format!("{:x}", hash.finalize()),
        },
        vertices,
        indices,
        textures: textures.map(Arc::new),
        lights,
        camera,
        bounds,
        notes,
    })
}

/// The gltf crate's validation reads each POSITION accessor without checking its index (it
/// panics on a bad one): check those indices first.
fn check_position_indices(root: &gltf::json::Root) -> Result<(), String> {
    let count = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(gltf::Semantic::Positions);
            if let Some(index) = primitive.attributes.get(&position)
                && index.value() >= count
            {
                return Err(format!(
                    "not a valid glTF 2.0 file: `meshes[{m}].primitives[{p}].attributes.POSITION` is accessor {}, and the file has {count} accessors",
                    index.value()
                ));
            }
        }
    }
    Ok(())
}

/// A validated document and the binary chunk of a .glb.
struct Parsed {
    document: gltf::Document,
    blob: Option<Vec<u8>>,
}

impl std::ops::Deref for Parsed {
    type Target = gltf::Document;
    fn deref(&self) -> &gltf::Document {
        &self.document
    }
}

/// The gltf crate's error, with validation errors listed by their JSON path.
fn reader_error(e: &gltf::Error) -> String {
    match e {
        gltf::Error::Validation(errors) => {
            let shown: Vec<String> = errors
                .iter()
                .take(5)
                .map(|(path, err)| format!("`{path}`: {err}"))
                .collect();
            let more = errors.len().saturating_sub(5);
            let tail = if more > 0 {
                format!(" (and {more} more)")
            } else {
                String::new()
            };
            format!("{}{tail}", shown.join("; "))
        }
        gltf::Error::Deserialize(json) => format!(
            "its JSON does not parse at line {}, column {}: {json}",
            json.line(),
            json.column()
        ),
        other => other.to_string(),
    }
}

/// Every buffer's bytes: the GLB's binary chunk, data URIs, and files beside the glTF.
fn read_buffers(gltf: &Parsed, base: &Path, hash: &mut Sha256) -> Result<Vec<Vec<u8>>, String> {
    let mut out = Vec::new();
    for buffer in gltf.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().ok_or(format!(
                "buffer {} refers to the binary chunk of a .glb, and the file has none (is it truncated?)",
                buffer.index()
            ))?,
            gltf::buffer::Source::Uri(uri) => {
                read_uri(base, uri, &format!("buffer {}", buffer.index()), hash)?
            }
        };
        if data.len() < buffer.length() {
            return Err(format!(
                "buffer {} holds {} bytes where the file declares {} (is it truncated?)",
                buffer.index(),
                data.len(),
                buffer.length()
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// The bytes a URI names: base64 data, or a file relative to the glTF's folder.
/// Only files are hashed: data URIs are part of the glTF file itself.
fn read_uri(base: &Path, uri: &str, what: &str, hash: &mut Sha256) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, data) = rest
            .split_once(";base64,")
            .ok_or(format!("{what}: a data URI without base64 data"))?;
        use base64::Engine;
        return base64::engine::general_purpose::STANDARD
            .decode(data)
            .map_err(|e| format!("{what}: its data URI is not valid base64: {e}"));
    }
    if uri.contains("://") {
        return Err(format!(
            "{what} refers to `{uri}`: clusterlab reads files, not URLs; download it beside the .gltf"
        ));
    }
    let decoded = urlencoding::decode(uri)
        .map_err(|_| format!("{what}: `{uri}` is not valid UTF-8 once decoded"))?;
    let file = base.join(&*decoded);
    if file.exists() && !file.is_file() {
        return Err(format!(
            "{what} refers to `{uri}`, which is not a regular file at {} (a folder, device or pipe)",
            file.display()
        ));
    }
    let bytes = std::fs::read(&file).map_err(|e| {
        format!(
            "{what} refers to `{uri}`, which cannot be read at {}: {e} (a .gltf file's buffers and images must sit where it says; a .glb holds them inside)",
            file.display()
        )
    })?;
    hash.update(&bytes);
    Ok(bytes)
}

/// A node's own static transform.
fn local_transform(node: &gltf::Node) -> DAffine3 {
    let (t, r, s) = node.transform().decomposed();
    DAffine3::from_scale_rotation_translation(
        Vec3::from(s).as_dvec3(),
        Quat::from_array(r).as_dquat(),
        Vec3::from(t).as_dvec3(),
    )
}

/// A `KHR_lights_punctual` point or spot light at a node (None for a directional light).
/// A root node's own translation and rotation are used as they are (no matrix round trip),
/// so an exported light comes back bit for bit.
fn file_light(
    light: &gltf::khr_lights_punctual::Light,
    world: &DAffine3,
    chain: &[gltf::Node],
) -> Option<Light> {
    use gltf::khr_lights_punctual::Kind;
    let (position, direction) = match chain {
        [only] => {
            let (t, r, _) = only.transform().decomposed();
            (
                Vec3::from(t),
                Quat::from_array(r).as_dquat().normalize() * DVec3::NEG_Z,
            )
        }
        _ => (world.translation.as_vec3(), world.matrix3 * DVec3::NEG_Z),
    };
    let intensity = light.intensity().max(0.0);
    let color = light.color().map(|c| c.max(0.0));
    let brightest = color.iter().fold(0.0f32, |a, &c| a.max(c)) * intensity;
    let radius = light
        .range()
        .filter(|r| r.is_finite() && *r > 0.0)
        .unwrap_or_else(|| ((brightest as f64 / RANGE_CUTOFF).sqrt() as f32).max(1e-3));
    let position = position.to_array();
    match light.kind() {
        Kind::Directional => None,
        Kind::Point => Some(Light::point(position, radius, color, intensity)),
        Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => Some(Light::spot_radians(
            position,
            radius,
            color,
            intensity,
            direction.to_array(),
            inner_cone_angle as f64,
            outer_cone_angle as f64,
        )),
    }
}

fn finite_light(l: &Light) -> bool {
    l.position
        .iter()
        .chain(&l.color)
        .chain(&l.direction)
        .chain([&l.radius, &l.cos_inner, &l.cos_outer])
        .all(|x| x.is_finite())
}

fn node_track(gltf: &Parsed, node: &gltf::Node, buffers: &[Vec<u8>]) -> NodeTrack {
    let (t, r, s) = node.transform().decomposed();
    let mut channels = Vec::new();
    if let Some(animation) = gltf.animations().next() {
        for channel in animation.channels() {
            if channel.target().node().index() != node.index() {
                continue;
            }
            use gltf::animation::Property as P;
            let property = match channel.target().property() {
                P::Translation => Property::Translation,
                P::Rotation => Property::Rotation,
                P::Scale => Property::Scale,
                P::MorphTargetWeights => continue,
            };
            let reader = channel.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
            let Some(times) = reader.read_inputs() else {
                continue;
            };
            let values: Vec<f32> = match reader.read_outputs() {
                Some(gltf::animation::util::ReadOutputs::Translations(v))
                | Some(gltf::animation::util::ReadOutputs::Scales(v)) => v.flatten().collect(),
                Some(gltf::animation::util::ReadOutputs::Rotations(v)) => {
                    v.into_f32().flatten().collect()
                }
                _ => continue,
            };
            channels.push(Channel {
                property,
                interpolation: channel.sampler().interpolation(),
                times: times.collect(),
                values,
            });
        }
    }
    NodeTrack {
        translation: Vec3::from(t),
        rotation: Quat::from_array(r),
        scale: Vec3::from(s),
        channels,
    }
}

impl Channel {
    /// The value at `time`: the first or last key outside the keys' span, a key's value
    /// exactly at its time, else interpolated.
    fn sample(&self, time: f32) -> Option<Vec<f64>> {
        let n = if self.property == Property::Rotation {
            4
        } else {
            3
        };
        let cubic = self.interpolation == gltf::animation::Interpolation::CubicSpline;
        let stride = if cubic { 3 * n } else { n };
        let keys = self.times.len();
        if keys == 0 || self.values.len() < keys * stride {
            return None;
        }
        let value = |k: usize| -> Vec<f64> {
            let at = k * stride + if cubic { n } else { 0 };
            self.values[at..at + n].iter().map(|&v| v as f64).collect()
        };
        let i = self.times.partition_point(|&t| t <= time);
        if i == 0 {
            return Some(value(0));
        }
        let k = i - 1;
        if self.times[k] == time || k + 1 == keys {
            return Some(value(k));
        }
        let (t0, t1) = (self.times[k] as f64, self.times[k + 1] as f64);
        let u = (time as f64 - t0) / (t1 - t0);
        let (a, b) = (value(k), value(k + 1));
        use gltf::animation::Interpolation as I;
        Some(match self.interpolation {
            I::Step => a,
            I::Linear if n == 4 => {
                let q = |v: &[f64]| DQuat::from_xyzw(v[0], v[1], v[2], v[3]).normalize();
                q(&a).slerp(q(&b), u).to_array().to_vec()
            }
            I::Linear => a.iter().zip(&b).map(|(x, y)| x + (y - x) * u).collect(),
            I::CubicSpline => {
                // Hermite with the keys' out- and in-tangents scaled by the interval.
                let dt = t1 - t0;
                let out_tangent = &self.values[k * stride + 2 * n..k * stride + 3 * n];
                let in_tangent = &self.values[(k + 1) * stride..(k + 1) * stride + n];
                let (u2, u3) = (u * u, u * u * u);
                let v: Vec<f64> = (0..n)
                    .map(|c| {
                        (2.0 * u3 - 3.0 * u2 + 1.0) * a[c]
                            + (u3 - 2.0 * u2 + u) * dt * out_tangent[c] as f64
                            + (-2.0 * u3 + 3.0 * u2) * b[c]
                            + (u3 - u2) * dt * in_tangent[c] as f64
                    })
                    .collect();
                if n == 4 {
                    DQuat::from_xyzw(v[0], v[1], v[2], v[3])
                        .normalize()
                        .to_array()
                        .to_vec()
                } else {
                    v
                }
            }
        })
    }
}

impl NodeTrack {
    /// Translation, rotation and scale at `time` (f32, as the keys are).
    fn at(&self, time: f32) -> (Vec3, Quat, Vec3) {
        let (mut t, mut r, mut s) = (self.translation, self.rotation, self.scale);
        for c in &self.channels {
            let Some(v) = c.sample(time) else { continue };
            match c.property {
                Property::Translation => t = DVec3::new(v[0], v[1], v[2]).as_vec3(),
                Property::Rotation => r = DQuat::from_xyzw(v[0], v[1], v[2], v[3]).as_quat(),
                Property::Scale => s = DVec3::new(v[0], v[1], v[2]).as_vec3(),
            }
        }
        (t, r, s)
    }
}

impl CameraTrack {
    /// Eye and rotation at `time`. A camera on a root node keeps its own single-precision
    /// translation and rotation (no matrix round trip).
    fn pose(&self, time: f64) -> (Vec3, Quat) {
        let time = time as f32;
        if let [only] = self.nodes.as_slice() {
            let (t, r, _) = only.at(time);
            return (t, r);
        }
        let world = self.nodes.iter().fold(DAffine3::IDENTITY, |acc, n| {
            let (t, r, s) = n.at(time);
            acc * DAffine3::from_scale_rotation_translation(
                s.as_dvec3(),
                r.as_dquat(),
                t.as_dvec3(),
            )
        });
        let (_, rotation, translation) = world.to_scale_rotation_translation();
        (translation.as_vec3(), rotation.as_quat())
    }

    fn camera(&self, time: f64, far: f32) -> Camera {
        let (eye, rotation) = self.pose(time);
        Camera::from_pose(eye, rotation, self.fov_y, self.near, far)
    }
}

/// The images used as base colour textures, each given a layer of the texture array.
struct BaseColorImages {
    layers: HashMap<usize, u32>,
}

impl BaseColorImages {
    fn collect(gltf: &Parsed) -> Self {
        let mut layers = HashMap::new();
        for material in gltf.materials() {
            if let Some(info) = material.pbr_metallic_roughness().base_color_texture() {
                let image = info.texture().source().index();
                let next = layers.len() as u32;
                layers.entry(image).or_insert(next);
            }
        }
        Self { layers }
    }

    fn layer_of(&self, material: &gltf::Material) -> Option<u32> {
        let info = material.pbr_metallic_roughness().base_color_texture()?;
        self.layers.get(&info.texture().source().index()).copied()
    }

    /// Decode the images in layer order into the texture array (None without textures).
    fn decode(
        &self,
        gltf: &Parsed,
        base: &Path,
        buffers: &[Vec<u8>],
        hash: &mut Sha256,
    ) -> Result<Option<TextureArray>, String> {
        if self.layers.is_empty() {
            return Ok(None);
        }
        let mut by_layer: Vec<(u32, usize)> = self.layers.iter().map(|(&i, &l)| (l, i)).collect();
        by_layer.sort();
        let mut images = Vec::with_capacity(by_layer.len());
        for (_, index) in by_layer {
            let image = gltf
                .images()
                .nth(index)
                .ok_or(format!("image {index} does not exist"))?;
            let what = format!("image {index}");
            let bytes = match image.source() {
                gltf::image::Source::Uri { uri, .. } => read_uri(base, uri, &what, hash)?,
                gltf::image::Source::View { view, .. } => {
                    let data = buffers
                        .get(view.buffer().index())
                        .ok_or(format!("{what}: its buffer does not exist"))?;
                    data.get(view.offset()..view.offset() + view.length())
                        .ok_or(format!("{what}: its buffer view lies outside its buffer"))?
                        .to_vec()
                }
            };
            let decoded = image::load_from_memory(&bytes)
                .map_err(|e| format!("{what} does not decode as PNG or JPEG: {e}"))?;
            images.push(decoded.to_rgba8());
        }
        Ok(Some(TextureArray::new(&images)))
    }
}

/// Append one primitive's triangles, transformed to world space.
fn read_primitive(
    primitive: &gltf::Primitive,
    world: &DAffine3,
    buffers: &[Vec<u8>],
    images: &BaseColorImages,
    vertices: &mut Vec<Vertex>,
    indices: &mut Vec<u32>,
    notes: &mut Vec<String>,
) -> Result<(), String> {
    use gltf::mesh::Mode;
    let mode = primitive.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        note_once(
            notes,
            format!("{mode:?} primitives left out: clusterlab draws triangles"),
        );
        return Ok(());
    }
    let positions = primitive
        .get(&gltf::Semantic::Positions)
        .ok_or("it has no POSITION attribute")?;
    check_float_vec3(&positions, "POSITION")?;
    if vertices.len()
        + positions
            .count()
            .max(primitive.indices().map_or(0, |i| i.count()))
        > MAX_VERTICES
    {
        return Err(format!(
            "the scene would have more than {MAX_VERTICES} vertices (instanced meshes count once per node): more than clusterlab loads"
        ));
    }
    let reader = primitive.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
    let unreadable = |what: &str| format!("its {what} accessor lies outside its buffer");
    let points: Vec<[f32; 3]> = reader
        .read_positions()
        .ok_or_else(|| unreadable("POSITION"))?
        .collect();
    let count = points.len();
    let corners: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None if primitive.indices().is_some() => return Err(unreadable("indices")),
        None => (0..count as u32).collect(),
    };
    if let Some(bad) = corners.iter().find(|&&i| i as usize >= count) {
        return Err(format!("index {bad} is past its {count} vertices"));
    }
    let triangles = triangle_list(mode, &corners);
    let normals: Option<Vec<[f32; 3]>> = match primitive.get(&gltf::Semantic::Normals) {
        Some(a) => {
            check_float_vec3(&a, "NORMAL")?;
            Some(
                reader
                    .read_normals()
                    .ok_or_else(|| unreadable("NORMAL"))?
                    .collect(),
            )
        }
        None => None,
    };
    let colors: Option<Vec<[f32; 3]>> = reader.read_colors(0).map(|c| c.into_rgb_f32().collect());
    let uvs: Option<Vec<[f32; 2]>> = reader.read_tex_coords(0).map(|t| t.into_f32().collect());
    for (name, len) in [
        ("NORMAL", normals.as_ref().map(Vec::len)),
        ("COLOR_0", colors.as_ref().map(Vec::len)),
        ("TEXCOORD_0", uvs.as_ref().map(Vec::len)),
    ] {
        if let Some(n) = len
            && n != count
        {
            return Err(format!("{name} has {n} entries for {count} positions"));
        }
    }

    let material = primitive.material();
    let pbr = material.pbr_metallic_roughness();
    let factor = pbr.base_color_factor();
    let mut texture = images.layer_of(&material).unwrap_or(NO_TEXTURE);
    if texture != NO_TEXTURE && uvs.is_none() {
        note_once(notes, "a textured material on a primitive without TEXCOORD_0 is drawn with its base colour factor alone".into());
        texture = NO_TEXTURE;
    }
    if pbr.metallic_roughness_texture().is_some() {
        note_once(
            notes,
            "metallic-roughness textures are not sampled: their factors are used".into(),
        );
    }
    if material.normal_texture().is_some() {
        note_once(
            notes,
            "normal maps are not sampled: the vertex normals are used".into(),
        );
    }
    if material.occlusion_texture().is_some() {
        note_once(notes, "occlusion textures are not sampled".into());
    }
    if material.alpha_mode() != gltf::material::AlphaMode::Opaque {
        note_once(notes, "alpha modes MASK and BLEND are drawn opaque".into());
    }
    if let Some(info) = pbr.base_color_texture()
        && info.tex_coord() != 0
    {
        note_once(
            notes,
            "base colour textures read TEXCOORD_0 whatever their texCoord".into(),
        );
    }
    let roughness = pbr.roughness_factor().clamp(0.0, 1.0);
    let metallic = pbr.metallic_factor().clamp(0.0, 1.0);

    // A node transform that is the identity leaves the data as it is, bit for bit.
    let identity = *world == DAffine3::IDENTITY;
    let normal_matrix: DMat3 = world.matrix3.inverse().transpose();
    let mirrored = world.matrix3.determinant() < 0.0;
    let vertex = |i: usize, face_normal: Option<[f32; 3]>| -> Vertex {
        let albedo = colors.as_ref().map_or([1.0; 3], |c| c[i]);
        let normal = face_normal
            .or_else(|| normals.as_ref().map(|n| n[i]))
            .unwrap_or([0.0, 0.0, 1.0]);
        let (position, normal) = if identity || face_normal.is_some() {
            (
                if identity {
                    points[i]
                } else {
                    world
                        .transform_point3(Vec3::from(points[i]).as_dvec3())
                        .as_vec3()
                        .to_array()
                },
                normal,
            )
        } else {
            (
                world
                    .transform_point3(Vec3::from(points[i]).as_dvec3())
                    .as_vec3()
                    .to_array(),
                (normal_matrix * Vec3::from(normal).as_dvec3())
                    .normalize_or_zero()
                    .as_vec3()
                    .to_array(),
            )
        };
        Vertex {
            position,
            normal,
            albedo: [0, 1, 2].map(|c| factor[c] * albedo[c]),
            material: [roughness, metallic],
            uv: uvs.as_ref().map_or([0.0; 2], |u| u[i]),
            texture,
        }
    };
    let base = vertices.len() as u32;
    if normals.is_some() {
        vertices.extend((0..count).map(|i| vertex(i, None)));
        for t in &triangles {
            let t = if mirrored { [t[0], t[2], t[1]] } else { *t };
            indices.extend(t.map(|i| base + i));
        }
    } else {
        // Without normals a triangle is flat (glTF's rule): each gets its own corners.
        for t in &triangles {
            let t = if mirrored { [t[0], t[2], t[1]] } else { *t };
            let p = t.map(|i| world.transform_point3(Vec3::from(points[i as usize]).as_dvec3()));
            let n = (p[1] - p[0])
                .cross(p[2] - p[0])
                .normalize_or_zero()
                .as_vec3()
                .to_array();
            let first = vertices.len() as u32;
            for &i in &t {
                vertices.push(vertex(i as usize, Some(n)));
            }
            indices.extend([first, first + 1, first + 2]);
        }
        if base as usize != vertices.len() {
            note_once(notes, "primitives without NORMAL are drawn flat".into());
        }
    }
    Ok(())
}

/// Corners of a triangle list from a list, strip or fan.
fn triangle_list(mode: gltf::mesh::Mode, corners: &[u32]) -> Vec<[u32; 3]> {
    use gltf::mesh::Mode;
    match mode {
        Mode::TriangleStrip => (2..corners.len())
            .map(|i| {
                if i % 2 == 0 {
                    [corners[i - 2], corners[i - 1], corners[i]]
                } else {
                    [corners[i - 1], corners[i - 2], corners[i]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..corners.len())
            .map(|i| [corners[i - 1], corners[i], corners[0]])
            .collect(),
        _ => corners
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
    }
}

fn check_float_vec3(a: &gltf::Accessor, name: &str) -> Result<(), String> {
    use gltf::accessor::{DataType, Dimensions};
    if a.data_type() != DataType::F32 || a.dimensions() != Dimensions::Vec3 || a.normalized() {
        return Err(format!(
            "{name} (accessor {}) is {:?} {:?}: clusterlab reads float VEC3 (quantized attributes come from KHR_mesh_quantization: write floats instead, e.g. `gltf-transform dequantize IN OUT`)",
            a.index(),
            a.dimensions(),
            a.data_type()
        ));
    }
    if a.count() == 0 {
        return Err(format!("{name} (accessor {}) is empty", a.index()));
    }
    Ok(())
}

fn note_once(notes: &mut Vec<String>, note: String) {
    if !notes.contains(&note) {
        notes.push(note);
    }
}

/// The default parameters of a file scene: 640x360, the file's lights (or 1024 seeded ones
/// when it has none), light radii scaled to its bounds as the atrium's are to its hall.
pub fn defaults(file: &FileScene) -> SceneParams {
    let diagonal = (file.bounds.1 - file.bounds.0).length().max(1e-3);
    let round3 = |x: f64| {
        let scale = 10f64.powi(2 - x.log10().floor() as i32);
        ((x * scale).round() / scale) as f32
    };
    SceneParams {
        width: 640,
        height: 360,
        lights: if file.lights.is_empty() {
            1024
        } else {
            file.lights.len() as u32
        },
        // The atrium's radii 1..3 against its 37-unit diagonal.
        radius_range: (round3(diagonal * 0.027), round3(diagonal * 0.081)),
        seed: 1,
        time: 1.0,
        spots: 0.0,
    }
}

/// The scene a file makes with `params`: the file's own lights when it has some and
/// `params.lights` is their number, else that many seeded lights in its bounds; the file's
/// camera at `params.time` (and one frame earlier), else a camera framing the bounds.
pub fn instantiate(file: &FileScene, params: SceneParams) -> Scene {
    let (lo, hi) = file.bounds;
    let use_file_lights = !file.lights.is_empty() && params.lights as usize == file.lights.len();
    let lights = if use_file_lights {
        file.lights.clone()
    } else {
        // Seeded lights inside the bounds (5% in from each side), as the built-in scenes
        // place theirs, with the atrium's exposure.
        let margin = (hi - lo) * 0.05;
        let extent = (hi - lo).max(DVec3::splat((hi - lo).length() * 0.05));
        let mean_radius = (params.radius_range.0 + params.radius_range.1) as f64 / 2.0;
        let power = POWER_PER_VOLUME_OVER_RADIUS * extent.x * extent.y * extent.z / mean_radius;
        super::builtin::seeded_lights(&params, lo + margin, hi - margin, power as f32)
    };
    let (camera, prev_camera) = match &file.camera {
        Some(track) => {
            let eye_now = track.pose(params.time).0.as_dvec3();
            let far = track
                .far
                .unwrap_or_else(|| Scene::far_plane_for(&file.vertices, eye_now) as f32);
            (
                track.camera(params.time, far),
                track.camera(params.time - FRAME_DT, far),
            )
        }
        None => {
            let c = framing_camera(file);
            (c, c)
        }
    };
    Scene {
        name: file.file.path.clone(),
        params,
        vertices: file.vertices.clone(),
        indices: file.indices.clone(),
        lights,
        camera,
        prev_camera,
        lights_move: !use_file_lights,
        textures: file.textures.clone(),
        file: Some(file.file.clone()),
        notes: file.notes.clone(),
    }
}

/// A camera for a file without one: 60 degrees vertical field of view, looking at the
/// centre of the bounds' sphere (radius R) from distance R / sin(30 degrees) = 2R along
/// (0, 0.5, 1), so the whole sphere is in view; near = 0.9 (2R - R) and far = 1.05 times
/// the distance to the furthest vertex.
pub fn framing_camera(file: &FileScene) -> Camera {
    let (lo, hi) = file.bounds;
    let center = (lo + hi) / 2.0;
    let radius = ((hi - lo).length() / 2.0).max(1e-3);
    let fov_y = 60f32.to_radians();
    let distance = radius / (fov_y as f64 / 2.0).sin();
    let eye = center + DVec3::new(0.0, 0.5, 1.0).normalize() * distance;
    let rotation = Camera::look_rotation(eye, center, DVec3::Y).as_quat();
    let far = Scene::far_plane_for(&file.vertices, eye) as f32;
    let near = (0.9 * (distance - radius)) as f32;
    Camera::from_pose(eye.as_vec3(), rotation, fov_y, near, far)
}
