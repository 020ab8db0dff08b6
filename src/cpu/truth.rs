//! The rasteriser's own output for a frame, read back at full precision: what the CPU
//! reference shades and the post twins take their geometry from.

use glam::DVec3;

use super::shading::Surface;

/// The rasteriser's coverage and attributes at full precision, read back from the GPU.
#[derive(Clone, Debug, Default)]
pub struct RasterTruth {
    pub width: u32,
    pub height: u32,
    /// Samples a pixel; the planes hold a pixel's samples one after another.
    pub samples: u32,
    /// World position; w = 1 where covered, 0 where background.
    pub position: Vec<[f32; 4]>,
    /// Unit world normal (xyz), perceptual roughness (w).
    pub normal: Vec<[f32; 4]>,
    /// Linear albedo (rgb), metallic (w).
    pub albedo: Vec<[f32; 4]>,
    /// Scenes with blended materials: every blended fragment in front of the opaque surface,
    /// pixel by pixel, each pixel's in the order the frame blends them.
    pub blended: Vec<BlendedFragment>,
    /// Where each pixel's blended fragments start in `blended`, and after the last pixel
    /// their total (empty without blended materials).
    pub blended_offsets: Vec<u32>,
}

/// Most blended fragments a pixel's reference blends (a frame with more is refused, naming
/// the pixel).
pub const MAX_BLENDED_FRAGMENTS: u32 = 256;

/// A blended fragment as the truth pass records it (`passes/truth.wesl`, `BlendedFragment`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BlendedFragment {
    /// World position; w = alpha.
    pub position: [f32; 4],
    /// Unit world normal; w = perceptual roughness.
    pub normal: [f32; 4],
    /// Linear albedo; w = metallic.
    pub albedo: [f32; 4],
    /// x: the triangle's place in the blended draw (draw order); the rest 0.
    pub order: [u32; 4],
}

impl BlendedFragment {
    pub fn alpha(&self) -> f64 {
        self.position[3] as f64
    }

    pub fn surface(&self) -> Surface {
        surface_of(self.position, self.normal, self.albedo)
    }
}

/// A surface from its three rows: position, normal and roughness, albedo and metallic.
fn surface_of(p: [f32; 4], n: [f32; 4], a: [f32; 4]) -> Surface {
    Surface {
        position: DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64),
        normal: DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64).normalize_or_zero(),
        albedo: DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64),
        roughness: n[3] as f64,
        metallic: a[3] as f64,
    }
}

impl RasterTruth {
    /// Whether `other` holds the same coverage and attributes, bit for bit (so that
    /// shading either gives the same frame).
    pub fn same_as(&self, other: &RasterTruth) -> bool {
        fn bytes(v: &[[f32; 4]]) -> &[u8] {
            bytemuck::cast_slice(v)
        }
        self.width == other.width
            && self.height == other.height
            && self.samples == other.samples
            && bytes(&self.position) == bytes(&other.position)
            && bytes(&self.normal) == bytes(&other.normal)
            && bytes(&self.albedo) == bytes(&other.albedo)
            && self.blended == other.blended
            && self.blended_offsets == other.blended_offsets
    }

    /// The blended fragments of pixel `i`, in the order they are blended.
    pub fn blended_at(&self, i: usize) -> &[BlendedFragment] {
        match self.blended_offsets.get(i..i + 2) {
            Some(&[a, b]) => &self.blended[a as usize..b as usize],
            _ => &[],
        }
    }

    /// The first sample of every pixel: one sample a pixel, for what reads the geometry
    /// per pixel (the post effects' twins).
    pub fn first_samples(&self) -> RasterTruth {
        let n = self.samples.max(1) as usize;
        let first = |plane: &[[f32; 4]]| plane.iter().step_by(n).copied().collect();
        RasterTruth {
            width: self.width,
            height: self.height,
            samples: 1,
            position: first(&self.position),
            normal: first(&self.normal),
            albedo: first(&self.albedo),
            blended: self.blended.clone(),
            blended_offsets: self.blended_offsets.clone(),
        }
    }

    pub fn covered(&self, i: usize) -> bool {
        self.position[i][3] > 0.5
    }

    pub fn surface(&self, i: usize) -> Surface {
        surface_of(self.position[i], self.normal[i], self.albedo[i])
    }
}
