//! What the CPU twins take from a variant and a scene. The twins (`cpu`) know neither: each
//! takes plain parameters, and these adapters are the one place that reads them off.

use crate::common::DepthMapping;
use crate::cpu::clusters::Grid;
use crate::cpu::post::{CameraPair, PostParams};
use crate::cpu::shading::{Brdf, ShadingParams};
use crate::cpu::shadows::{PositionSource, ShadowSource};
use crate::scene::Scene;
use crate::variant::{DepthFormat, GBufferLayout, ShadingModel, ToonMode, Variant};

impl ShadingParams {
    pub fn of(v: &Variant) -> Self {
        Self {
            brdf: match v.shading.model {
                ShadingModel::Lambert => Brdf::Lambert,
                ShadingModel::BlinnPhong {
                    shininess,
                    specular,
                } => Brdf::BlinnPhong {
                    shininess: shininess as f64,
                    specular: specular as f64,
                },
                ShadingModel::Ggx => Brdf::Ggx,
            },
            ambient: v.shading.ambient as f64,
            resolve: v.msaa.resolve,
            toon_bands: v
                .post
                .toon
                .as_ref()
                .filter(|t| t.mode == ToonMode::PerLight)
                .map(|t| t.bands),
            shadows: v.shading.shadows.traced().then(|| shadow_source(v)),
        }
    }
}

/// What `v`'s shading surface is made of, for its shadow rays' error.
fn shadow_source(v: &Variant) -> ShadowSource {
    let deferred = v.pipeline.is_deferred();
    let position = if deferred && v.gbuffer().layout == GBufferLayout::Compact {
        PositionSource::FromDepth {
            reversed: v.depth.reversed_z,
            unorm24: v.depth.format == DepthFormat::Unorm24,
        }
    } else {
        PositionSource::Stored
    };
    ShadowSource {
        position,
        codec: deferred.then(|| v.normal_codec()),
    }
}

impl PostParams {
    pub fn of(v: &Variant) -> Self {
        let toon = v.post.toon.as_ref();
        Self {
            toon_bands: toon
                .filter(|t| t.mode == ToonMode::PostProcess)
                .map(|t| t.bands),
            outline_threshold: toon
                .and_then(|t| t.outlines.as_ref())
                .map(|o| o.depth_threshold as f64),
            bloom: v
                .post
                .bloom
                .as_ref()
                .map(|b| (b.threshold as f64, b.radius)),
            motion_blur_samples: v.post.motion_blur.as_ref().map(|m| m.samples),
        }
    }
}

impl CameraPair {
    pub fn of(scene: &Scene, mapping: DepthMapping) -> Self {
        let aspect = scene.aspect();
        let c = &scene.camera;
        let p = &scene.prev_camera;
        Self {
            near: c.near,
            far: c.far,
            tan_half_fov_y: (c.fov_y / 2.0).tan(),
            aspect,
            world_from_view: c.view().inverse(),
            prev_clip_from_world: p.projection(aspect, mapping) * p.view(),
            mapping,
        }
    }
}

impl Grid {
    /// The twin of a variant's grid over a scene's camera (static z-range).
    pub fn of(variant: &Variant, scene: &Scene) -> Grid {
        let c = variant.clusters();
        let cam = &scene.camera;
        // The GPU sees the camera's planes as f32; so does the twin.
        let near = cam.near as f32 as f64;
        let far = cam.far as f32 as f64;
        Grid {
            x: c.grid.0,
            y: c.grid.1,
            z: c.grid.2,
            slicing: c.slicing,
            range: (near, far),
            near,
            far,
            tan_half_fov_y: (cam.fov_y / 2.0).tan(),
            aspect: scene.aspect(),
        }
    }
}
