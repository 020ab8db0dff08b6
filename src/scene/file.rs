//! glTF 2.0 scenes (`.gltf` with its buffers and images, or `.glb`), read with the `gltf`
//! crate: meshes with their node transforms, base colour (factor, vertex colour and
//! texture), metallic and roughness factors, `KHR_lights_punctual` point and spot lights,
//! and the first camera with its animation.
//!
//! A file is read once per process ([`load`] keeps it by path, size and modification
//! time); [`instantiate`] then makes the scene for a set of parameters (image size, seeded
//! lights when the file has none or another count is asked for, the time at which the
//! camera's animation is sampled).

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

use glam::{DAffine3, DMat3, DQuat, DVec3, Quat, Vec3};
use sha2::{Digest, Sha256};

use super::{Camera, FRAME_DT, Light, Scene, SceneError, SceneFile, SceneParams, TextureArray};
use crate::common::{NO_TEXTURE, Vertex};
use crate::files;

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
    /// Triangles of opaque and masked materials.
    pub indices: Vec<u32>,
    /// Triangles of blended materials.
    pub blended: Vec<u32>,
    pub textures: Option<Arc<TextureArray>>,
    /// The file's point and spot lights, in node order.
    pub lights: Vec<Light>,
    /// The file says it was written with no lights (clusterlab's export of a scene of 0
    /// lights): it is rendered with none by default, not with seeded ones.
    pub without_lights: bool,
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
    let meta = std::fs::metadata(path)
        .map_err(|e| fail(format!("cannot read: {}", files::describe(&e))))?;
    if !meta.is_file() {
        return Err(fail(
            "not a regular file (a folder, device or pipe): a glTF scene is a .gltf or .glb file"
                .into(),
        ));
    }
    let stamp = (meta.len(), meta.modified().ok());
    let key = std::fs::canonicalize(path).unwrap_or_else(|_| PathBuf::from(path));
    let cache = CACHE.get_or_init(Default::default);
    if let Some((s, scene)) = cache.lock().expect("scene cache").get(&key)
        && *s == stamp
    {
        return Ok(scene.clone());
    }
    let scene = Arc::new(read_guarded(path).map_err(fail)?);
    cache
        .lock()
        .expect("scene cache")
        .insert(key, (stamp, scene.clone()));
    Ok(scene)
}

thread_local! {
    /// What this thread's glTF reading is at, while it reads a file (for the message of a
    /// failure inside the gltf crate).
    static READING: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// Say what the reading is at now.
fn reading(what: impl Into<String>) {
    READING.with(|r| *r.borrow_mut() = Some(what.into()));
}

/// Read the file with the gltf crate's panics caught: the checks before each call into it
/// cover what it is known to panic on, and anything else it trips over is an error naming
/// what was being read, not a crash (and nothing is printed for it).
fn read_guarded(path: &str) -> Result<FileScene, String> {
    static QUIET: std::sync::Once = std::sync::Once::new();
    QUIET.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if READING.with(|r| r.borrow().is_none()) {
                previous(info);
            }
        }));
    });
    reading("the file");
    let read = std::panic::catch_unwind(|| read_file(path));
    let at = READING.with(|r| r.borrow_mut().take()).unwrap_or_default();
    read.unwrap_or_else(|panic| {
        let why = crate::common::panic_message(panic.as_ref());
        Err(format!(
            "the glTF reader (the gltf crate) failed on {at} ({why}): the file is malformed in a way clusterlab does not check before reading"
        ))
    })
}

fn read_file(path: &str) -> Result<FileScene, String> {
    let kind = if path.to_ascii_lowercase().ends_with(".glb") {
        files::read::GLB
    } else {
        files::read::GLTF
    };
    if kind == files::read::GLB {
        // The header first: a large file that is no GLB is refused before it is read.
        let (head, length) =
            files::read::read_head(Path::new(path), GLB_HEADER, kind).map_err(|e| e.why)?;
        check_glb_file_header(&head, length)?;
    }
    let bytes = files::read(Path::new(path), kind).map_err(|e| e.why)?;
    check_glb_header(&bytes)?;
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
    check_unvalidated_indices(document.as_json())?;
    let gltf = Parsed {
        document: gltf::Document::from_json(document.into_json())
            .map_err(|e| format!("not a valid glTF 2.0 file: {}", reader_error(&e)))?,
        blob,
    };
    let base = Path::new(path).parent().unwrap_or(Path::new("."));
    let mut hash = Sha256::new();
    hash.update(&bytes);
    let buffers = read_buffers(&gltf, base, &mut hash)?;
    reading("the accessors");
    check_accessors(&gltf, &buffers)?;
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
            reading(format!("light {} at node {}", light.index(), node.index()));
            let place = |why: String| {
                format!(
                    "light {} at node {} (`extensions.KHR_lights_punctual.lights[{}]`): {why}",
                    light.index(),
                    node.index(),
                    light.index()
                )
            };
            match file_light(&light, &world, &chain).map_err(place)? {
                Some(l) if finite_light(&l) => lights.push(l),
                Some(_) => {
                    return Err(place(
                        "its position or direction is not a finite number (its node's transform)"
                            .into(),
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
                    reading(format!("camera {}", cam.index()));
                    check_perspective(cam.index(), p.yfov(), p.znear(), p.zfar())?;
                    camera = Some(CameraTrack {
                        fov_y: p.yfov(),
                        near: p.znear(),
                        far: p.zfar(),
                        nodes: chain
                            .iter()
                            .map(|n| node_track(&gltf, n, &buffers))
                            .collect::<Result<_, _>>()?,
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
    let mut blended = Vec::new();
    for (mesh, world) in &meshes {
        for primitive in mesh.primitives() {
            reading(format!(
                "mesh {} primitive {}",
                mesh.index(),
                primitive.index()
            ));
            read_primitive(
                &primitive,
                world,
                &buffers,
                &images,
                &mut vertices,
                [&mut indices, &mut blended],
                &mut notes,
            )
            .map_err(|e| format!("mesh {} primitive {}: {e}", mesh.index(), primitive.index()))?;
        }
    }
    if indices.is_empty() && blended.is_empty() {
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
    let without_lights = lights.is_empty() && exported_light_count(&gltf) == Some(0);
    Ok(FileScene {
        without_lights,
        file: SceneFile {
            path: path.to_string(),
            sha256: format!("{:x}", hash.finalize()),
        },
        vertices,
        indices,
        blended,
        textures: textures.map(Arc::new),
        lights,
        camera,
        bounds,
        notes,
    })
}

/// Bytes of a GLB header: magic `glTF`, version, length.
const GLB_HEADER: u64 = 12;

/// A `.glb` file's header, read before the rest (`head`, its first bytes; `length`, the
/// file's): the magic `glTF`, version 2, and a stated length that is the file's own.
fn check_glb_file_header(head: &[u8], length: u64) -> Result<(), String> {
    let word = |at: usize| {
        head.get(at..at + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let (Some(version), Some(stated)) = (word(4), word(8)) else {
        return Err(format!(
            "not a GLB file: {length} bytes, fewer than its 12-byte header (magic, version, length)"
        ));
    };
    if !head.starts_with(b"glTF") {
        return Err(format!(
            "not a GLB file: it begins with the bytes {:02X?}, where a .glb begins with the magic `glTF` (a .gltf file holds JSON: name it .gltf)",
            &head[..4]
        ));
    }
    if version != 2 {
        return Err(format!(
            "its GLB header gives version {version}: clusterlab reads glTF 2.0 (version 2)"
        ));
    }
    if stated as u64 != length {
        return Err(format!(
            "its GLB header gives a length of {stated} bytes, but the file has {length} bytes: it is cut short or has bytes added"
        ));
    }
    Ok(())
}

/// A .glb's header as the gltf crate reads it: it takes the header's 12 bytes from the length
/// the header states without checking that length first.
fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    match bytes
        .get(8..12)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    {
        Some(length) if length >= 12 => Ok(()),
        Some(length) => Err(format!(
            "not a glTF 2.0 file: its GLB header gives a length of {length} bytes, less than the 12-byte header itself"
        )),
        None => Err(
            "not a glTF 2.0 file: its GLB header (magic, version, length: 12 bytes) is cut short"
                .into(),
        ),
    }
}

/// What the gltf crate's validation does not check and its reader takes on trust (it panics
/// on a bad one): each POSITION accessor's index, each image's source, and each animation
/// channel's target.
fn check_unvalidated_indices(root: &gltf::json::Root) -> Result<(), String> {
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
    // An image's source is read assuming glTF's rule: a `uri`, or a `bufferView` with a
    // `mimeType`.
    for (i, image) in root.images.iter().enumerate() {
        let why = match (&image.buffer_view, &image.uri, &image.mime_type) {
            (Some(_), _, None) => "has a `bufferView` and no `mimeType` (glTF requires both)",
            (None, None, _) => "has neither a `uri` nor a `bufferView`",
            _ => continue,
        };
        return Err(format!("not a valid glTF 2.0 file: `images[{i}]` {why}"));
    }
    // Its validation of an animation looks only at each channel's sampler index.
    let nodes = root.nodes.len();
    for (a, animation) in root.animations.iter().enumerate() {
        for (c, channel) in animation.channels.iter().enumerate() {
            let node = channel.target.node.value();
            if node >= nodes {
                return Err(format!(
                    "not a valid glTF 2.0 file: `animations[{a}].channels[{c}].target.node` is node {node}, and the file has {nodes} nodes"
                ));
            }
            if !matches!(
                channel.target.path,
                gltf::json::validation::Checked::Valid(_)
            ) {
                return Err(format!(
                    "not a valid glTF 2.0 file: `animations[{a}].channels[{c}].target.path` is none of translation, rotation, scale, weights"
                ));
            }
        }
    }
    Ok(())
}

/// Check every accessor against the buffers as read, as the gltf crate's reader does not: it
/// slices by offsets, counts and strides it takes on trust (a count of 0 underflows, a stride
/// shorter than an element overlaps, an accessor past its view panics or reads another's
/// bytes).
fn check_accessors(gltf: &gltf::Document, buffers: &[Vec<u8>]) -> Result<(), String> {
    // The bytes `count` elements of `size` bytes, `stride` apart, take from `offset` on.
    let span = |offset: usize, stride: usize, count: usize, size: usize| {
        stride
            .checked_mul(count.checked_sub(1)?)?
            .checked_add(size)?
            .checked_add(offset)
    };
    let view_bytes = |view: &gltf::buffer::View, what: &str| -> Result<usize, String> {
        let buffer = buffers.get(view.buffer().index()).map_or(0, Vec::len);
        let end = view.offset().checked_add(view.length());
        if end.is_none_or(|end| end > buffer) {
            return Err(format!(
                "{what}: buffer view {} (bytes {}..+{}) lies outside buffer {}, which holds {buffer} bytes",
                view.index(),
                view.offset(),
                view.length(),
                view.buffer().index()
            ));
        }
        Ok(view.length())
    };
    for a in gltf.accessors() {
        let what = format!("accessor {}", a.index());
        let (count, size) = (a.count(), a.size());
        if count == 0 {
            return Err(format!(
                "{what} has `count` 0: glTF accessors hold at least one element"
            ));
        }
        if let Some(view) = a.view() {
            let length = view_bytes(&view, &what)?;
            let stride = view.stride().unwrap_or(size);
            if stride < size {
                return Err(format!(
                    "{what}: buffer view {} has `byteStride` {stride}, less than one element of {size} bytes",
                    view.index()
                ));
            }
            if span(a.offset(), stride, count, size).is_none_or(|end| end > length) {
                return Err(format!(
                    "{what}: {count} elements of {size} bytes, {stride} apart from byte {}, run past the {length} bytes of buffer view {}",
                    a.offset(),
                    view.index()
                ));
            }
        }
        if let Some(sparse) = a.sparse() {
            let n = sparse.count();
            if n == 0 || n > count {
                return Err(format!(
                    "{what}: its sparse `count` is {n}, outside 1..={count} (the accessor's count)"
                ));
            }
            let (indices, values) = (sparse.indices(), sparse.values());
            let index_size = indices.index_type().size();
            let checks = [
                (indices.view(), indices.offset(), index_size, "indices"),
                (values.view(), values.offset(), size, "values"),
            ];
            for (view, offset, element, part) in checks {
                let length = view_bytes(&view, &what)?;
                let stride = view.stride().unwrap_or(element);
                if stride < element
                    || span(offset, stride, n, element).is_none_or(|end| end > length)
                {
                    return Err(format!(
                        "{what}: its {n} sparse {part} run past the {length} bytes of buffer view {}",
                        view.index()
                    ));
                }
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
        gltf::Error::Binary(glb) => format!(
            "its GLB container (12-byte header, then JSON and BIN chunks) is malformed: {glb}"
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
                reading(format!("buffer {}", buffer.index()));
                read_uri(
                    base,
                    uri,
                    &format!("buffer {}", buffer.index()),
                    files::read::GLTF_BUFFER,
                    hash,
                )?
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

/// The bytes a URI names: base64 data, or a file in the glTF's folder (`base`) or below it.
/// glTF 2.0 URIs are relative references resolved against the file's folder; clusterlab
/// follows nothing else: no scheme, no absolute path, no `..` segment (after decoding
/// percent-escapes), no symbolic link whose target leaves the folder. Only files are hashed:
/// data URIs are part of the glTF file itself.
fn read_uri(
    base: &Path,
    uri: &str,
    what: &str,
    kind: files::Kind,
    hash: &mut Sha256,
) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, data) = rest
            .split_once(";base64,")
            .ok_or(format!("{what}: a data URI without base64 data"))?;
        use base64::Engine;
        return base64::engine::general_purpose::STANDARD
            .decode(data)
            .map_err(|e| format!("{what}: its data URI is not valid base64: {e}"));
    }
    let file = resolve_uri(base, uri).map_err(|why| format!("{what} refers to `{uri}`: {why}"))?;
    let bytes = files::read(&file, kind).map_err(|e| {
        format!(
            "{what} refers to `{uri}`, which cannot be read at {}: {} (a .gltf file's buffers and images must sit where it says; a .glb holds them inside)",
            file.display(),
            e.why.strip_prefix("cannot read: ").unwrap_or(&e.why)
        )
    })?;
    hash.update(&bytes);
    Ok(bytes)
}

/// The file a relative URI names in folder `base`, or why clusterlab does not read it.
fn resolve_uri(base: &Path, uri: &str) -> Result<PathBuf, String> {
    const RULE: &str = "a glTF file's buffers and images are read only from its own folder and the folders below it, by relative path";
    let scheme = uri
        .split_once(':')
        .is_some_and(|(head, _)| !head.contains('/'));
    if scheme {
        return Err(format!(
            "a URI with a scheme (a URL, `file:` or a drive letter), which clusterlab does not follow: {RULE}"
        ));
    }
    let decoded =
        urlencoding::decode(uri).map_err(|_| "not valid UTF-8 once decoded".to_string())?;
    if decoded.starts_with('/') {
        return Err(format!(
            "an absolute path, which clusterlab does not follow: {RULE}"
        ));
    }
    if decoded.contains('\\') || decoded.contains('\0') {
        return Err(format!(
            "a path with a backslash or NUL, which glTF URIs do not hold (they separate folders with `/`): {RULE}"
        ));
    }
    if decoded.split('/').any(|segment| segment == "..") {
        return Err(format!(
            "a path with a `..` segment, which clusterlab does not follow: {RULE}"
        ));
    }
    let file = base.join(&*decoded);
    // Symbolic links may point anywhere: where the file really is must be inside the folder.
    if let (Ok(real), Ok(folder)) = (std::fs::canonicalize(&file), std::fs::canonicalize(base))
        && !real.starts_with(&folder)
    {
        return Err(format!(
            "a symbolic link that leads out of the file's folder, which clusterlab does not follow: {RULE}"
        ));
    }
    Ok(file)
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

/// A `KHR_lights_punctual` point or spot light at a node (None for a directional light), or
/// why its values are not a light's. A root node's own translation and rotation are used as
/// they are (no matrix round trip), and where the light's `extras` hold clusterlab's exact
/// axis and cosines that agree with its node and angles (a file clusterlab exported), those
/// are taken: an exported light comes back bit for bit.
fn file_light(
    light: &gltf::khr_lights_punctual::Light,
    world: &DAffine3,
    chain: &[gltf::Node],
) -> Result<Option<Light>, String> {
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
    let intensity = light.intensity();
    if !(intensity.is_finite() && intensity >= 0.0) {
        return Err(format!(
            "its `intensity` is {intensity}: a light's intensity is a finite number, 0 or more"
        ));
    }
    let color = light.color();
    if !color.iter().all(|c| c.is_finite() && *c >= 0.0) {
        return Err(format!(
            "its `color` is {color:?}: a light's colour is linear RGB, each channel 0 or more"
        ));
    }
    let brightest = color.iter().fold(0.0f32, |a, &c| a.max(c)) * intensity;
    let radius = match light.range() {
        Some(r) if !(r.is_finite() && r > 0.0) => {
            return Err(format!(
                "its `range` is {r}: a range is a positive distance (leave it out for a light without one, which clusterlab bounds where it falls to 1/256)"
            ));
        }
        Some(r) => r,
        None => ((brightest as f64 / RANGE_CUTOFF).sqrt() as f32).max(1e-3),
    };
    if let Some(p) = super::radius_problem(radius) {
        let given = if light.range().is_some() {
            "`range`"
        } else {
            "range (where its intensity falls to 1/256)"
        };
        return Err(format!("its {given}: {p}"));
    }
    let position = position.to_array();
    Ok(match light.kind() {
        Kind::Directional => None,
        Kind::Point => Some(Light::point(position, radius, color, intensity)),
        Kind::Spot {
            inner_cone_angle: inner,
            outer_cone_angle: outer,
        } => {
            // glTF's pi/2 is a single-precision number a hair above the real one.
            let widest = std::f32::consts::FRAC_PI_2;
            if !(outer.is_finite() && outer > 0.0 && outer <= widest) {
                return Err(format!(
                    "its `spot.outerConeAngle` is {outer}: glTF spot angles are radians in 0 < outer <= pi/2"
                ));
            }
            if !(inner.is_finite() && (0.0..=outer).contains(&inner)) {
                return Err(format!(
                    "its `spot.innerConeAngle` is {inner}: glTF spot angles are radians in 0 <= inner <= outer ({outer})"
                ));
            }
            let mut spot = Light::spot_radians(
                position,
                radius,
                color,
                intensity,
                direction.to_array(),
                inner as f64,
                outer as f64,
            );
            if let Some(exact) = exact_spot(light.extras())
                && exact.agrees_with(&spot)
            {
                (spot.direction, spot.cos_inner, spot.cos_outer) =
                    (exact.direction, exact.cos_inner, exact.cos_outer);
            }
            Some(spot)
        }
    })
}

/// A spot's axis and cosines exactly as clusterlab holds them (`extras.clusterlab` of a light
/// it exported).
#[derive(serde::Deserialize)]
struct ExactSpot {
    direction: [f32; 3],
    cos_inner: f32,
    cos_outer: f32,
}

fn exact_spot(extras: &gltf::json::Extras) -> Option<ExactSpot> {
    #[derive(serde::Deserialize)]
    struct Extras {
        clusterlab: ExactSpot,
    }
    let raw = extras.as_ref()?;
    serde_json::from_str::<Extras>(raw.get())
        .ok()
        .map(|e| e.clusterlab)
}

impl ExactSpot {
    /// Whether these exact values are the ones the file's own data rounds to (a file edited
    /// by another tool since it was exported has other angles or rotations: its extras are
    /// stale and its data wins).
    fn agrees_with(&self, spot: &Light) -> bool {
        let near = |a: f32, b: f32| (a - b).abs() <= 1e-5;
        (0..3).all(|i| near(self.direction[i], spot.direction[i]))
            && near(self.cos_inner, spot.cos_inner)
            && near(self.cos_outer, spot.cos_outer)
    }
}

/// Refuse a perspective camera clusterlab cannot render: no field of view, a near plane at or
/// behind the eye, a far plane not beyond the near one.
fn check_perspective(index: usize, yfov: f32, znear: f32, zfar: Option<f32>) -> Result<(), String> {
    let field = |name: &str| format!("camera {index} (`cameras[{index}].perspective.{name}`)");
    if !(yfov.is_finite() && yfov > 0.0 && yfov < std::f32::consts::PI) {
        return Err(format!(
            "{} is {yfov}: a vertical field of view is radians strictly between 0 and pi",
            field("yfov")
        ));
    }
    if !(znear.is_finite() && znear > 0.0) {
        return Err(format!(
            "{} is {znear}: the near plane is a positive distance in front of the eye",
            field("znear")
        ));
    }
    if let Some(far) = zfar
        && !(far.is_finite() && far > znear)
    {
        return Err(format!(
            "{} is {far}: the far plane lies beyond the near plane ({znear}); leave it out for an infinite one",
            field("zfar")
        ));
    }
    Ok(())
}

fn finite_light(l: &Light) -> bool {
    l.position
        .iter()
        .chain(&l.color)
        .chain(&l.direction)
        .chain([&l.radius, &l.cos_inner, &l.cos_outer])
        .all(|x| x.is_finite())
}

/// A node's transform and its channels in the file's first animation, each checked: keys
/// that are finite and strictly increasing, values that are finite.
fn node_track(gltf: &Parsed, node: &gltf::Node, buffers: &[Vec<u8>]) -> Result<NodeTrack, String> {
    use gltf::accessor::{DataType as T, Dimensions as D};
    let (t, r, s) = node.transform().decomposed();
    let mut channels = Vec::new();
    if let Some(animation) = gltf.animations().next() {
        for channel in animation.channels() {
            if channel.target().node().index() != node.index() {
                continue;
            }
            use gltf::animation::Property as P;
            let (property, kinds, valid): (_, Vec<_>, _) = match channel.target().property() {
                P::Translation => (
                    Property::Translation,
                    vec![(T::F32, D::Vec3)],
                    "VEC3 of FLOAT",
                ),
                P::Scale => (Property::Scale, vec![(T::F32, D::Vec3)], "VEC3 of FLOAT"),
                P::Rotation => (
                    Property::Rotation,
                    [T::F32, T::I8, T::U8, T::I16, T::U16]
                        .map(|t| (t, D::Vec4))
                        .to_vec(),
                    "VEC4 of FLOAT, BYTE, UNSIGNED_BYTE, SHORT or UNSIGNED_SHORT",
                ),
                P::MorphTargetWeights => continue,
            };
            let what = format!(
                "animation {} channel {} (node {} {})",
                animation.index(),
                channel.index(),
                node.index(),
                format!("{property:?}").to_lowercase()
            );
            reading(what.clone());
            let sampler = channel.sampler();
            check_kind(
                &sampler.input(),
                &format!("{what}: its times"),
                &[(T::F32, D::Scalar)],
                "SCALAR of FLOAT",
            )?;
            check_kind(
                &sampler.output(),
                &format!("{what}: its values"),
                &kinds,
                valid,
            )?;
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
            let times: Vec<f32> = times.collect();
            if let Some(k) = times.iter().position(|t| !t.is_finite()) {
                return Err(format!(
                    "{what}: key {k}'s time is {}, not a finite number",
                    times[k]
                ));
            }
            if let Some(k) = (1..times.len()).find(|&k| times[k] <= times[k - 1]) {
                return Err(format!(
                    "{what}: key {k}'s time {} does not come after key {}'s {} (glTF key times increase strictly)",
                    times[k],
                    k - 1,
                    times[k - 1]
                ));
            }
            if let Some(at) = values.iter().position(|v| !v.is_finite()) {
                return Err(format!(
                    "{what}: value {at} is {}, not a finite number",
                    values[at]
                ));
            }
            channels.push(Channel {
                property,
                interpolation: sampler.interpolation(),
                times,
                values,
            });
        }
    }
    Ok(NodeTrack {
        translation: Vec3::from(t),
        rotation: Quat::from_array(r),
        scale: Vec3::from(s),
        channels,
    })
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
            reading(what.clone());
            let bytes = match image.source() {
                gltf::image::Source::Uri { uri, .. } => {
                    read_uri(base, uri, &what, files::read::GLTF_IMAGE, hash)?
                }
                gltf::image::Source::View { view, .. } => {
                    let data = buffers
                        .get(view.buffer().index())
                        .ok_or(format!("{what}: its buffer does not exist"))?;
                    let end = view.offset().checked_add(view.length());
                    end.and_then(|end| data.get(view.offset()..end))
                        .ok_or(format!(
                            "{what}: its buffer view {} lies outside its buffer",
                            view.index()
                        ))?
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

/// Append one primitive's triangles, transformed to world space, to the opaque triangles
/// (`triangle_lists[0]`, also masked ones) or the blended ones (`[1]`).
fn read_primitive(
    primitive: &gltf::Primitive,
    world: &DAffine3,
    buffers: &[Vec<u8>],
    images: &BaseColorImages,
    vertices: &mut Vec<Vertex>,
    triangle_lists: [&mut Vec<u32>; 2],
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
    {
        use gltf::accessor::{DataType as T, Dimensions as D};
        if let Some(a) = primitive.indices() {
            let kinds = [(T::U8, D::Scalar), (T::U16, D::Scalar), (T::U32, D::Scalar)];
            check_kind(
                &a,
                "its indices",
                &kinds,
                "SCALAR of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
            )?;
        }
        if let Some(a) = primitive.get(&gltf::Semantic::Colors(0)) {
            let kinds = [T::U8, T::U16, T::F32]
                .map(|t| [(t, D::Vec3), (t, D::Vec4)])
                .concat();
            check_kind(
                &a,
                "COLOR_0",
                &kinds,
                "VEC3 or VEC4 of FLOAT, UNSIGNED_BYTE or UNSIGNED_SHORT",
            )?;
        }
        if let Some(a) = primitive.get(&gltf::Semantic::TexCoords(0)) {
            let kinds = [T::U8, T::U16, T::F32].map(|t| (t, D::Vec2));
            check_kind(
                &a,
                "TEXCOORD_0",
                &kinds,
                "VEC2 of FLOAT, UNSIGNED_BYTE or UNSIGNED_SHORT",
            )?;
        }
    }
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
        let accessor = primitive.indices().map_or(0, |a| a.index());
        return Err(format!(
            "index {bad} (indices accessor {accessor}) is past its {count} vertices"
        ));
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
    let colors: Option<Vec<[f32; 4]>> = reader.read_colors(0).map(|c| c.into_rgba_f32().collect());
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
    // A NaN would pass every later check that compares (bounds fold past it): look here.
    use gltf::Semantic as S;
    let uv3: Option<Vec<[f32; 3]>> = uvs
        .as_ref()
        .map(|u| u.iter().map(|&[a, b]| [a, b, 0.0]).collect());
    for (name, semantic, values) in [
        ("POSITION", S::Positions, Some(&points)),
        ("NORMAL", S::Normals, normals.as_ref()),
        ("COLOR_0", S::Colors(0), None),
        ("TEXCOORD_0", S::TexCoords(0), uv3.as_ref()),
    ] {
        let first_bad = match semantic {
            S::Colors(_) => colors.as_ref().and_then(|c| first_non_finite(c)),
            _ => values.and_then(|v| first_non_finite(v)),
        };
        if let Some(at) = first_bad {
            let accessor = primitive.get(&semantic).map_or(0, |a| a.index());
            return Err(format!(
                "{name} (accessor {accessor}) holds a value that is not a finite number (NaN or infinity) at vertex {at}"
            ));
        }
    }
    // A vertex colour multiplies the base colour: a negative one is no colour (it renders
    // black, and so does the reference, which would score the frame as perfect).
    if let Some(at) = colors
        .as_ref()
        .and_then(|c| c.iter().position(|v| v.iter().any(|&x| x < 0.0)))
    {
        let accessor = primitive.get(&S::Colors(0)).map_or(0, |a| a.index());
        return Err(format!(
            "COLOR_0 (accessor {accessor}) holds a negative value at vertex {at}: a vertex colour multiplies the base colour, so each component must be 0 or more (glTF's normalized integer colours are 0..=1)"
        ));
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
    // glTF's default cutoff is 0.5; a cutoff of 0 keeps every fragment, as opaque does.
    let (cutoff, blend) = match material.alpha_mode() {
        gltf::material::AlphaMode::Opaque => (0.0, false),
        gltf::material::AlphaMode::Mask => (material.alpha_cutoff().unwrap_or(0.5).max(0.0), false),
        gltf::material::AlphaMode::Blend => (0.0, true),
    };
    let [opaque_triangles, blended_triangles] = triangle_lists;
    let indices = if blend {
        blended_triangles
    } else {
        opaque_triangles
    };
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
        let color = colors.as_ref().map_or([1.0; 4], |c| c[i]);
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
            albedo: [0, 1, 2].map(|c| factor[c] * color[c]),
            material: [roughness, metallic],
            uv: uvs.as_ref().map_or([0.0; 2], |u| u[i]),
            texture,
            alpha: [factor[3] * color[3], cutoff],
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
    let placed = &vertices[base as usize..];
    if let Some(at) = placed
        .iter()
        .position(|v| !v.position.iter().chain(&v.normal).all(|x| x.is_finite()))
    {
        return Err(format!(
            "vertex {at} is not a finite single-precision number once its node's transform places it (a scale or translation too large)"
        ));
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

/// Refuse accessor `a` (what `name` calls it) unless its component type and dimensions are
/// among `kinds` (`valid` says them in glTF's words): the gltf crate's reader panics on others.
fn check_kind(
    a: &gltf::Accessor,
    name: &str,
    kinds: &[(gltf::accessor::DataType, gltf::accessor::Dimensions)],
    valid: &str,
) -> Result<(), String> {
    if kinds.contains(&(a.data_type(), a.dimensions())) {
        return Ok(());
    }
    use gltf::accessor::{DataType as T, Dimensions as D};
    let dimensions = match a.dimensions() {
        D::Scalar => "SCALAR",
        D::Vec2 => "VEC2",
        D::Vec3 => "VEC3",
        D::Vec4 => "VEC4",
        D::Mat2 => "MAT2",
        D::Mat3 => "MAT3",
        D::Mat4 => "MAT4",
    };
    let component = match a.data_type() {
        T::I8 => "BYTE",
        T::U8 => "UNSIGNED_BYTE",
        T::I16 => "SHORT",
        T::U16 => "UNSIGNED_SHORT",
        T::U32 => "UNSIGNED_INT",
        T::F32 => "FLOAT",
    };
    Err(format!(
        "{name} (accessor {}): {dimensions} of {component}, where clusterlab reads {valid} (glTF's types for them)",
        a.index()
    ))
}

/// The index of the first element of `values` that is not a finite number.
fn first_non_finite<const N: usize>(values: &[[f32; N]]) -> Option<usize> {
    values.iter().position(|v| !v.iter().all(|x| x.is_finite()))
}

/// Refuse a POSITION or NORMAL accessor that is not float VEC3 (what clusterlab reads).
fn check_float_vec3(a: &gltf::Accessor, name: &str) -> Result<(), String> {
    use gltf::accessor::{DataType as T, Dimensions as D};
    check_kind(a, name, &[(T::F32, D::Vec3)], "VEC3 of FLOAT").map_err(|e| {
        format!(
            "{e}; quantized attributes come from KHR_mesh_quantization: write floats instead, e.g. `gltf-transform dequantize IN OUT`"
        )
    })
}

fn note_once(notes: &mut Vec<String>, note: String) {
    if !notes.contains(&note) {
        notes.push(note);
    }
}

/// How many lights clusterlab's exporter says it wrote (`asset.extras.clusterlab.lights`).
fn exported_light_count(gltf: &gltf::Document) -> Option<u64> {
    let raw = gltf.as_json().asset.extras.as_ref()?;
    let extras: serde_json::Value = serde_json::from_str(raw.get()).ok()?;
    extras["clusterlab"]["lights"].as_u64()
}

/// The default parameters of a file scene: 640x360, the file's lights (or 1024 seeded ones
/// when it has none and does not say it was written without), light radii scaled to its
/// bounds as the atrium's are to its hall.
pub fn defaults(file: &FileScene) -> SceneParams {
    let diagonal = (file.bounds.1 - file.bounds.0).length().max(1e-3);
    let round3 = |x: f64| {
        let scale = 10f64.powi(2 - x.log10().floor() as i32);
        ((x * scale).round() / scale) as f32
    };
    SceneParams {
        width: 640,
        height: 360,
        lights: if file.lights.is_empty() && !file.without_lights {
            1024
        } else {
            file.lights.len() as u32
        },
        // The atrium's radii 1..3 against its 37-unit diagonal.
        radius_range: (round3(diagonal * 0.027), round3(diagonal * 0.081)),
        seed: 1,
        time: 1.0,
        spots: 0.0,
        motion: super::Motion::ALL,
    }
}

/// Whether a scene made from `file` with `params` has the file's own lights (it has some,
/// or says it has none, and `params.lights` is their number), which never move.
pub fn uses_own_lights(file: &FileScene, params: &SceneParams) -> bool {
    (!file.lights.is_empty() || file.without_lights) && params.lights as usize == file.lights.len()
}

/// The scene a file makes with `params`: the file's own lights when it has some and
/// `params.lights` is their number, else that many seeded lights in its bounds; the file's
/// camera at `params.time` (and one frame earlier), else a camera framing the bounds.
pub fn instantiate(file: &FileScene, params: SceneParams) -> Scene {
    let (lo, hi) = file.bounds;
    // A file's own lights stay where it put them.
    let (lights, moving_lights) = if uses_own_lights(file, &params) {
        (file.lights.clone(), Vec::new())
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
            // A still camera keeps its pose at the still time in both frames.
            let moves = params.motion.camera;
            let now = params.motion.pose_time(moves, params.time);
            let earlier = if moves { now - FRAME_DT } else { now };
            let eye_now = track.pose(now).0.as_dvec3();
            let far = track
                .far
                .unwrap_or_else(|| Scene::far_plane_for(&file.vertices, eye_now) as f32);
            (track.camera(now, far), track.camera(earlier, far))
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
        blended: file.blended.clone(),
        lights,
        camera,
        prev_camera,
        moving_lights,
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
