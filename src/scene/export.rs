//! Write a scene as a binary glTF 2.0 file (`.glb`): one mesh with a primitive per run of
//! triangles that share a material (vertex colours as `COLOR_0`, roughness and metallic as
//! material factors), the camera with its motion as a two-key animation, and the lights as
//! `KHR_lights_punctual` nodes.
//!
//! The file is valid glTF 2.0 (the Khronos glTF Validator finds no error and no warning in
//! it; CI runs it): rotations are unit quaternions, every vertex attribute's view says it is
//! one. Loading it back ([`super::file`]) gives the same vertices, indices, lights and camera
//! bit for bit: every number is written in the single precision the scene holds it in, a
//! light's colour is split into a colour and a power-of-two intensity (exact to multiply
//! back), and a spot's axis and cosines, which a unit quaternion and an angle in single
//! precision hold only to about 1e-7, are also written exactly in the light's
//! `extras.clusterlab` (the loader takes them where they agree with the rotation and angles;
//! another loader reads the standard fields and gets the cone to within that rounding).

use glam::{DQuat, DVec3, Quat, Vec3};
use serde_json::{Value, json};

use super::{FRAME_DT, Scene};

/// The scene as `.glb` bytes.
pub fn to_glb(scene: &Scene) -> Result<Vec<u8>, String> {
    if scene.textures.is_some() {
        return Err("a scene with textures cannot be exported (only built-in scenes can)".into());
    }
    if scene.prev_camera != scene.camera && scene.params.time < FRAME_DT {
        return Err(format!(
            "time {} s: a moving camera is exported as keys at the time and one frame ({FRAME_DT:.4} s) before it, and glTF key times are 0 or more",
            scene.params.time
        ));
    }
    let mut out = Writer::default();
    let primitives = out.mesh(scene);
    let mut nodes = vec![json!({ "name": "geometry", "mesh": 0 })];
    let mut root = vec![0];

    let cam = &scene.camera;
    let eye = cam.eye.as_vec3();
    let rotation = rotation_of(cam);
    root.push(nodes.len());
    nodes.push(json!({
        "name": "camera",
        "camera": 0,
        "translation": eye.to_array(),
        "rotation": rotation.to_array(),
    }));
    let camera_node = nodes.len() - 1;
    let mut animations = Vec::new();
    if scene.prev_camera != scene.camera {
        let times = [
            (scene.params.time - FRAME_DT) as f32,
            scene.params.time as f32,
        ];
        let input = out.accessor_f32(&times, "SCALAR", true, None);
        let prev = scene.prev_camera.eye.as_vec3();
        let output = out.accessor_f32(
            &[prev.to_array(), eye.to_array()].concat(),
            "VEC3",
            false,
            None,
        );
        let mut samplers =
            vec![json!({ "input": input, "output": output, "interpolation": "LINEAR" })];
        let mut channels =
            vec![json!({ "sampler": 0, "target": { "node": camera_node, "path": "translation" } })];
        let prev_rotation = rotation_of(&scene.prev_camera);
        if prev_rotation != rotation {
            let output = out.accessor_f32(
                &[prev_rotation.to_array(), rotation.to_array()].concat(),
                "VEC4",
                false,
                None,
            );
            samplers.push(json!({ "input": input, "output": output, "interpolation": "LINEAR" }));
            channels.push(
                json!({ "sampler": 1, "target": { "node": camera_node, "path": "rotation" } }),
            );
        }
        animations.push(json!({ "name": "camera", "samplers": samplers, "channels": channels }));
    }

    let mut lights = Vec::new();
    for (i, light) in scene.lights.iter().enumerate() {
        let (color, intensity) = split_color(light.color);
        let mut l = json!({
            "color": color,
            "intensity": intensity,
            "range": light.radius,
        });
        let mut node = json!({
            "name": format!("light {i}"),
            "translation": light.position,
            "extensions": { "KHR_lights_punctual": { "light": i } },
        });
        if light.is_spot() {
            l["type"] = "spot".into();
            l["spot"] = json!({
                "innerConeAngle": angle_for_cosine(light.cos_inner),
                "outerConeAngle": angle_for_cosine(light.cos_outer),
            });
            l["extras"] = json!({ "clusterlab": {
                "direction": light.direction,
                "cos_inner": light.cos_inner,
                "cos_outer": light.cos_outer,
            } });
            node["rotation"] = rotation_for_axis(light.direction).to_array().into();
        } else {
            l["type"] = "point".into();
        }
        lights.push(l);
        root.push(nodes.len());
        nodes.push(node);
    }

    let mut gltf = json!({
        "asset": {
            "version": "2.0",
            "generator": format!("clusterlab {}", env!("CARGO_PKG_VERSION")),
            "extras": { "clusterlab": {
                "scene": scene.name,
                "lights": scene.lights.len(),
                "seed": scene.params.seed,
                "time": scene.params.time,
                "spots": scene.params.spots,
            } },
        },
        "scene": 0,
        "scenes": [{ "nodes": root }],
        "nodes": nodes,
        "meshes": [{ "name": scene.name, "primitives": primitives }],
        "materials": out.materials,
        "cameras": [{
            "type": "perspective",
            "perspective": {
                "yfov": cam.fov_y as f32,
                "znear": cam.near as f32,
                "zfar": cam.far as f32,
                "aspectRatio": scene.aspect() as f32,
            },
        }],
        "accessors": out.accessors,
        "bufferViews": out.views,
        "buffers": [{ "byteLength": out.bin.len() }],
    });
    if !animations.is_empty() {
        gltf["animations"] = animations.into();
    }
    if !lights.is_empty() {
        gltf["extensionsUsed"] = json!(["KHR_lights_punctual"]);
        gltf["extensions"] = json!({ "KHR_lights_punctual": { "lights": lights } });
    }
    let json = serde_json::to_vec(&gltf).map_err(|e| e.to_string())?;
    glb(json, out.bin)
}

/// The GLB container: header, JSON chunk, binary chunk, each padded to 4 bytes.
pub fn glb(mut json: Vec<u8>, mut bin: Vec<u8>) -> Result<Vec<u8>, String> {
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let total = u32::try_from(total)
        .map_err(|_| format!("{total} bytes: a .glb file holds at most 4 GiB"))?;
    let mut out = Vec::with_capacity(total as usize);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend(total.to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    Ok(out)
}

/// A buffer view's `target` for vertex attributes and for indices (OpenGL's names).
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// The binary chunk being written and the JSON that describes it.
#[derive(Default)]
struct Writer {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    materials: Vec<Value>,
    material_keys: Vec<MaterialKey>,
}

impl Writer {
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({ "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len() });
        if let Some(t) = target {
            v["target"] = t.into();
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    /// An accessor of f32 `values` (`kind` VEC3, VEC4 or SCALAR), with bounds if asked, in a
    /// view of its own for GPU buffer `target` (vertex attributes), if any.
    fn accessor_f32(
        &mut self,
        values: &[f32],
        kind: &str,
        bounds: bool,
        target: Option<u32>,
    ) -> usize {
        let n = match kind {
            "SCALAR" => 1,
            "VEC3" => 3,
            _ => 4,
        };
        let view = self.view(bytemuck::cast_slice(values), target);
        let mut a = json!({
            "bufferView": view,
            "componentType": 5126,
            "count": values.len() / n,
            "type": kind,
        });
        if bounds {
            let (mut lo, mut hi) = (vec![f32::MAX; n], vec![f32::MIN; n]);
            for item in values.chunks_exact(n) {
                for c in 0..n {
                    lo[c] = lo[c].min(item[c]);
                    hi[c] = hi[c].max(item[c]);
                }
            }
            a["min"] = lo.into();
            a["max"] = hi.into();
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn material(&mut self, key: MaterialKey) -> usize {
        if let Some(i) = self.material_keys.iter().position(|k| *k == key) {
            return i;
        }
        let [roughness, metallic] = key.material;
        let mut material = json!({
            "pbrMetallicRoughness": {
                "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                "roughnessFactor": roughness,
                "metallicFactor": metallic,
            },
        });
        if key.blend {
            material["alphaMode"] = json!("BLEND");
        } else if key.cutoff > 0.0 {
            material["alphaMode"] = json!("MASK");
            material["alphaCutoff"] = json!(key.cutoff);
        }
        self.material_keys.push(key);
        self.materials.push(material);
        self.materials.len() - 1
    }

    /// A primitive per run of triangles whose first corners share a material, each with
    /// the vertex range its triangles use: the opaque and masked triangles, then the
    /// blended ones (a scene whose blended vertices follow its opaque ones loads back with
    /// the same vertex order).
    fn mesh(&mut self, scene: &Scene) -> Vec<Value> {
        let v = &scene.vertices;
        let key = |t: &[u32], blend: bool| MaterialKey {
            material: v[t[0] as usize].material,
            cutoff: v[t[0] as usize].alpha[1],
            blend,
        };
        let tris: Vec<(&[u32], MaterialKey)> =
            (scene.indices.chunks_exact(3).map(|t| (t, key(t, false))))
                .chain(scene.blended.chunks_exact(3).map(|t| (t, key(t, true))))
                .collect();
        let mut primitives = Vec::new();
        let mut start = 0;
        while start < tris.len() {
            let material = tris[start].1;
            let mut end = start + 1;
            while end < tris.len() && tris[end].1 == material {
                end += 1;
            }
            let run: Vec<&[u32]> = tris[start..end].iter().map(|(t, _)| *t).collect();
            let (lo, hi) = run
                .iter()
                .flat_map(|t| t.iter())
                .fold((u32::MAX, 0), |(lo, hi), &i| (lo.min(i), hi.max(i)));
            let verts = &v[lo as usize..=hi as usize];
            let positions: Vec<f32> = verts.iter().flat_map(|v| v.position).collect();
            let normals: Vec<f32> = verts.iter().flat_map(|v| v.normal).collect();
            // Alpha in COLOR_0 where a vertex has one below 1.
            let with_alpha = verts.iter().any(|v| v.alpha[0] != 1.0);
            let colors: Vec<f32> = if with_alpha {
                verts
                    .iter()
                    .flat_map(|v| [v.albedo[0], v.albedo[1], v.albedo[2], v.alpha[0]])
                    .collect()
            } else {
                verts.iter().flat_map(|v| v.albedo).collect()
            };
            let indices: Vec<u32> = run.iter().flat_map(|t| t.iter().map(|i| i - lo)).collect();
            let position = self.accessor_f32(&positions, "VEC3", true, Some(ARRAY_BUFFER));
            let normal = self.accessor_f32(&normals, "VEC3", false, Some(ARRAY_BUFFER));
            let color_type = if with_alpha { "VEC4" } else { "VEC3" };
            let color = self.accessor_f32(&colors, color_type, false, Some(ARRAY_BUFFER));
            let view = self.view(bytemuck::cast_slice(&indices), Some(ELEMENT_ARRAY_BUFFER));
            self.accessors.push(json!({
                "bufferView": view,
                "componentType": 5125,
                "count": indices.len(),
                "type": "SCALAR",
            }));
            let index = self.accessors.len() - 1;
            let material = self.material(material);
            primitives.push(json!({
                "attributes": { "POSITION": position, "NORMAL": normal, "COLOR_0": color },
                "indices": index,
                "material": material,
            }));
            start = end;
        }
        primitives
    }
}

/// What makes a glTF material: (roughness, metallic), the alpha cutoff, blending.
#[derive(Clone, Copy, Debug, PartialEq)]
struct MaterialKey {
    material: [f32; 2],
    cutoff: f32,
    blend: bool,
}

/// glTF colours lie in [0, 1]: the colour over the smallest power of two at least its
/// brightest channel, and that power as the intensity (dividing and multiplying by it is
/// exact).
fn split_color(color: [f32; 3]) -> ([f32; 3], f32) {
    let brightest = color.iter().fold(0.0f32, |a, &c| a.max(c));
    if brightest <= 1.0 {
        return (color, 1.0);
    }
    let scale = 2f32.powi(brightest.log2().ceil() as i32);
    (color.map(|c| c / scale), scale)
}

/// The single-precision angle whose cosine, as `Light::spot_radians` computes it, is
/// `cosine` (the nearest to `acos` when none is).
fn angle_for_cosine(cosine: f32) -> f32 {
    let start = (cosine as f64).clamp(-1.0, 1.0).acos() as f32;
    neighbours(start)
        .find(|&a| (a as f64).cos() as f32 == cosine)
        .unwrap_or(start)
}

/// The unit rotation taking -Z to `axis`, rounded to single precision.
fn rotation_for_axis(axis: [f32; 3]) -> Quat {
    let axis = Vec3::from(axis).as_dvec3().normalize();
    DQuat::from_rotation_arc(DVec3::NEG_Z, axis).as_quat()
}

/// `x` and the single-precision values up to 2 steps either side of it, nearest first.
fn neighbours(x: f32) -> impl Iterator<Item = f32> {
    [0i64, 1, -1, 2, -2]
        .into_iter()
        .map(move |k| f32::from_bits((x.to_bits() as i64 + k).clamp(0, u32::MAX as i64) as u32))
}

/// The camera's rotation as glTF holds it (single precision; exact for cameras made by
/// `Camera::from_pose`).
fn rotation_of(c: &super::Camera) -> Quat {
    super::Camera::look_rotation(c.eye, c.target, c.up).as_quat()
}
