//! Plain data every layer shares: the vertex and light layouts the shaders read, the depth
//! mapping, and the z-slicing schemes. A leaf: it imports nothing of this crate, so the CPU
//! twins (`cpu`), the variant schema (`variant`) and the scenes (`scene`) can all use it
//! without pointing at each other.

use bytemuck::{Pod, Zeroable};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use strum::{EnumIter, IntoEnumIterator, IntoStaticStr};

/// One vertex as the raster passes read it. Mirrors `shaders/common/mesh.wesl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub albedo: [f32; 3],
    /// Perceptual roughness and metallic, each in [0, 1] (read by GGX shading only).
    pub material: [f32; 2],
    /// Texture coordinates of the base colour texture (glTF's `TEXCOORD_0`).
    pub uv: [f32; 2],
    /// Layer of the scene's base colour texture array that multiplies `albedo`, or
    /// [`NO_TEXTURE`].
    pub texture: u32,
    /// Base colour alpha (glTF's base colour factor times COLOR_0; the texture's alpha
    /// multiplies it) and the alpha cutoff: a fragment whose alpha is below the cutoff is
    /// discarded (glTF's `MASK`). Opaque surfaces have cutoff 0, which discards nothing;
    /// blended surfaces (`BLEND`) are the scene's `blended` triangles, whatever the cutoff.
    pub alpha: [f32; 2],
}

/// How a material's base colour alpha is used (glTF's `alphaMode`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// Alpha is ignored: the surface is opaque.
    Opaque,
    /// Fragments whose alpha is below `cutoff` are discarded, the rest are opaque.
    Mask { cutoff: f32 },
    /// The surface is drawn over what lies behind it, back to front, with the over operator.
    Blend,
}

/// `Vertex::texture` of a vertex whose albedo is its colour alone.
pub const NO_TEXTURE: u32 = u32::MAX;

/// A point or spot light, 48 bytes. Mirrors `shaders/common/lights.wesl`.
///
/// Three 16-byte rows: position and radius; colour (already times the intensity: the shaders
/// only ever use the product) and the outer cone's cosine; the cone's axis and the inner
/// cone's cosine. A point light is a spot whose outer cosine is -1 (the whole sphere).
/// Folding the intensity into the colour keeps the spot cone inside 48 bytes instead of 64:
/// the light loop reads one light per evaluation, so its size is read bandwidth.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Light {
    pub position: [f32; 3],
    /// Distance at which the light's contribution reaches exactly zero.
    pub radius: f32,
    /// Linear RGB radiant intensity: colour times intensity.
    pub color: [f32; 3],
    /// Cosine of the outer cone's half-angle: no light at or beyond it. -1 for a point light.
    pub cos_outer: f32,
    /// Unit cone axis (spot lights; zero for point lights).
    pub direction: [f32; 3],
    /// Cosine of the inner cone's half-angle: full light within it, a smooth step between
    /// the two cones.
    pub cos_inner: f32,
}

/// Largest light radius (range) clusterlab shades. Light assignment squares radii and widens
/// them in single precision: at this radius the square is 1e36, below f32's 3.4e38 with room
/// for the widening and the sum of three squared distances, so every test stays finite and
/// exact; a larger radius is refused rather than risked.
pub const MAX_LIGHT_RADIUS: f32 = 1e18;
/// Why [`MAX_LIGHT_RADIUS`] is the limit, in a message's words.
pub const MAX_LIGHT_RADIUS_WHY: &str = "its square must stay a finite single-precision number through the cluster tests; at that range a light's falloff is 1 to double precision within 1e9 of it";

/// Largest outer cone half-angle a spot may have, in degrees (a wider cone is a point light
/// with a dark half, which the cone culling does not model).
pub const MAX_SPOT_ANGLE_DEGREES: f64 = 90.0;

impl Light {
    /// A point light of `color` times `intensity`.
    pub fn point(position: [f32; 3], radius: f32, color: [f32; 3], intensity: f32) -> Light {
        Light {
            position,
            radius,
            color: color.map(|c| c * intensity),
            cos_outer: -1.0,
            direction: [0.0; 3],
            cos_inner: -1.0,
        }
    }

    /// A spot light shining along `direction` (normalised here), full within `inner_degrees`
    /// of its axis and dark from `outer_degrees` on (0 < inner <= outer <= 90).
    pub fn spot(
        position: [f32; 3],
        radius: f32,
        color: [f32; 3],
        intensity: f32,
        direction: [f64; 3],
        inner_degrees: f64,
        outer_degrees: f64,
    ) -> Light {
        Light::spot_radians(
            position,
            radius,
            color,
            intensity,
            direction,
            inner_degrees.to_radians(),
            outer_degrees.to_radians(),
        )
    }

    /// [`Light::spot`] with its half-angles in radians (as glTF gives them).
    pub fn spot_radians(
        position: [f32; 3],
        radius: f32,
        color: [f32; 3],
        intensity: f32,
        direction: [f64; 3],
        inner: f64,
        outer: f64,
    ) -> Light {
        let d = glam::DVec3::from(direction).normalize_or(glam::DVec3::NEG_Y);
        let outer = outer.clamp(0.0, MAX_SPOT_ANGLE_DEGREES.to_radians());
        let inner = inner.clamp(0.0, outer);
        Light {
            direction: d.as_vec3().to_array(),
            cos_outer: outer.cos() as f32,
            cos_inner: inner.cos() as f32,
            ..Light::point(position, radius, color, intensity)
        }
    }

    /// Whether this light is a spot (its outer cone is narrower than the whole sphere).
    pub fn is_spot(&self) -> bool {
        self.cos_outer > -1.0
    }
}

/// The light-against-cluster test of spot lights. Both are conservative: a spot that lights
/// any point of a cluster is always in its list.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema, EnumIter,
)]
pub enum SpotTest {
    /// The bounding sphere of the cone (its spherical sector), tested like a point light.
    Sphere,
    /// The bounding sphere, then the cone against the cluster's bounding sphere (Wronski
    /// 2017, "Cull that cone"): a cluster beside or behind the cone is left out.
    #[default]
    Cone,
}

/// How the samples of a pixel are resolved to one HDR colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema, EnumIter)]
pub enum MsaaResolve {
    /// The mean of the samples' linear HDR colours, then tonemapping: what a hardware
    /// resolve does. A bright sample dominates its pixel, so HDR edges alias.
    Box,
    /// Filament's custom resolve: each sample weighted by `1 / (1 + max(r, g, b))` (Karis
    /// 2013's reversible tonemap), the weighted mean turned back into HDR; close to
    /// tonemapping each sample and averaging, so HDR edges stay smooth.
    Tonemapped,
}

/// Which way depth runs and where the projection's far plane is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DepthMapping {
    /// Near maps to 1 and far (or infinity) to 0.
    pub reversed: bool,
    /// The projection's far plane is at infinity.
    pub infinite_far: bool,
}

/// Depth buffer formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub enum DepthFormat {
    /// 24-bit unsigned normalised depth.
    Unorm24,
    /// 32-bit float depth.
    Float32,
}

/// How view depth between the camera's near and far planes is cut into slices.
#[derive(
    Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema, EnumIter, IntoStaticStr,
)]
#[strum(serialize_all = "snake_case", prefix = "slice_")]
pub enum ZSlicing {
    /// Equal depth steps from near to far.
    Linear,
    /// `slice = floor(log(z/near) * Z / log(far/near))`: equal ratios from near to far.
    Exponential,
    /// Slice 0 covers [near, near_slice_end]; the other slices are exponential from there
    /// to far (Persson 2015, Bevy, Filament).
    NearSliceThenExponential {
        /// View depth (world units) where the special near slice ends; must lie between the
        /// camera's near and far planes.
        near_slice_end: f32,
    },
    /// Olsson 2012: slices as deep as they are wide,
    /// `k = floor(log(z/near) / log(1 + 2 tan(fov_y/2) / grid_y))`; the slice count follows
    /// from the camera, capped at grid z (the last slice then reaches to far).
    OlssonCubic,
    /// Exponential slicing over the depth range the frame actually covers, found by a
    /// min/max reduction of the depth buffer.
    DynamicRange {
        /// Whose depth gives the range.
        source: DepthRangeSource,
    },
    /// Equal steps in device depth (NDC z), as a grid laid over the depth buffer is:
    /// `slice = floor((1/near - 1/z) / (1/near - 1/far) * Z)`. Every perspective mapping
    /// stores an affine function of 1/z, so the steps are equal whatever the mapping; most
    /// slices crowd near the camera.
    NdcUniform,
}

/// Where a dynamic depth range comes from.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema, EnumIter,
)]
pub enum DepthRangeSource {
    /// Reduce this frame's depth (needs depth before shading: a pre-pass or a G-buffer).
    #[default]
    CurrentFrame,
    /// Reduce the previous frame's depth (one frame late, no extra pass before shading).
    PreviousFrame,
}

/// How a normal is stored in the G-buffer.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema, EnumIter)]
pub enum NormalCodec {
    /// Three 32-bit floats (wide layout only).
    Xyz,
    /// Octahedral map (Meyer 2010, Cigolle 2014), two components of bits/2 each.
    Octahedral {
        /// Total bits: 16, 20, 24 or 32.
        bits: u32,
        /// Try the 4 neighbouring codes and keep the one whose decode is closest (default false).
        #[serde(default)]
        precise: bool,
    },
    /// Two angles: polar angle from +z and azimuth, bits/2 each.
    Polar {
        /// Total bits: 16, 20, 24 or 32.
        bits: u32,
    },
    /// Spheremap transform (Lambert azimuthal equal-area), bits/2 each.
    Spheremap {
        /// Total bits: 16, 20, 24 or 32.
        bits: u32,
    },
}

impl NormalCodec {
    /// Bits a packed normal takes (xyz floats: 96).
    pub fn bits(self) -> u32 {
        match self {
            NormalCodec::Xyz => 96,
            NormalCodec::Octahedral { bits, .. }
            | NormalCodec::Polar { bits }
            | NormalCodec::Spheremap { bits } => bits,
        }
    }

    /// The same codec at `bits` in all.
    pub fn with_bits(self, bits: u32) -> NormalCodec {
        match self {
            NormalCodec::Xyz => NormalCodec::Xyz,
            NormalCodec::Octahedral { precise, .. } => NormalCodec::Octahedral { bits, precise },
            NormalCodec::Polar { .. } => NormalCodec::Polar { bits },
            NormalCodec::Spheremap { .. } => NormalCodec::Spheremap { bits },
        }
    }

    /// The codec's name in tables.
    pub fn label(self) -> &'static str {
        match self {
            NormalCodec::Xyz => "xyz floats",
            NormalCodec::Octahedral { precise: false, .. } => "octahedral",
            NormalCodec::Octahedral { precise: true, .. } => "octahedral precise",
            NormalCodec::Polar { .. } => "polar",
            NormalCodec::Spheremap { .. } => "spheremap",
        }
    }

    /// Every codec that packs a normal into a code, at `bits` in all (and octahedral with
    /// and without the precise encoder): the one list that the twin checks, property tests,
    /// stress cases and the codec study iterate. `Xyz` stores floats and has no code.
    pub fn packed(bits: u32) -> Vec<NormalCodec> {
        NormalCodec::iter()
            .flat_map(|c| match c {
                NormalCodec::Xyz => vec![],
                NormalCodec::Octahedral { .. } => [false, true]
                    .map(|precise| NormalCodec::Octahedral { bits, precise })
                    .to_vec(),
                NormalCodec::Polar { .. } => vec![NormalCodec::Polar { bits }],
                NormalCodec::Spheremap { .. } => vec![NormalCodec::Spheremap { bits }],
            })
            .collect()
    }
}

/// The post-processing effects, in the order a frame applies them (the passes, the post
/// chain and the CPU twin all follow this order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, EnumIter)]
pub enum PostEffect {
    Toon,
    Bloom,
    MotionBlur,
}

/// Where the special near slice ends in the examples of [`ZSlicing::every`] (world units;
/// Bevy's and Persson's default), kept inside the camera's range.
const EXAMPLE_NEAR_SLICE_END: f64 = 5.0;

impl ZSlicing {
    /// The WESL feature flag under which `shaders/clustering/zslice.wesl` holds this scheme's
    /// code: `slice_` and the scheme's name in snake case.
    pub fn feature(self) -> &'static str {
        self.into()
    }

    /// Whether `self` and `other` are the same scheme, whatever their parameters.
    pub fn same_scheme(self, other: ZSlicing) -> bool {
        std::mem::discriminant(&self) == std::mem::discriminant(&other)
    }

    /// The scheme's name in tables.
    pub fn label(self) -> &'static str {
        match self {
            ZSlicing::Linear => "linear",
            ZSlicing::Exponential => "exponential",
            ZSlicing::NearSliceThenExponential { .. } => "near slice + exponential",
            ZSlicing::OlssonCubic => "Olsson cubic",
            ZSlicing::DynamicRange {
                source: DepthRangeSource::CurrentFrame,
            } => "dynamic (this frame)",
            ZSlicing::DynamicRange {
                source: DepthRangeSource::PreviousFrame,
            } => "dynamic (previous frame)",
            ZSlicing::NdcUniform => "NDC uniform",
        }
    }

    /// Every scheme, each with example parameters fitted to a camera's depth range
    /// [near, far] (and a dynamic range from each source): the one list that the twin
    /// checks, property tests, stress cases and the slicing study iterate.
    pub fn every(near: f64, far: f64) -> Vec<ZSlicing> {
        let near_end = if near * 2.0 <= far / 2.0 {
            EXAMPLE_NEAR_SLICE_END.clamp(near * 2.0, far / 2.0)
        } else {
            (near * far).sqrt()
        };
        ZSlicing::iter()
            .flat_map(|s| match s {
                ZSlicing::NearSliceThenExponential { .. } => {
                    vec![ZSlicing::NearSliceThenExponential {
                        near_slice_end: near_end as f32,
                    }]
                }
                ZSlicing::DynamicRange { .. } => DepthRangeSource::iter()
                    .map(|source| ZSlicing::DynamicRange { source })
                    .collect(),
                s => vec![s],
            })
            .collect()
    }
}

/// What a caught panic said (its message, when it has one).
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "unknown panic".into())
}

/// The sRGB transfer function (IEC 61966-2-1).
pub fn srgb_encode(linear: f64) -> f64 {
    if linear <= 0.0031308 {
        linear * 12.92
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}
