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
        }
    }

    pub fn covered(&self, i: usize) -> bool {
        self.position[i][3] > 0.5
    }

    pub fn surface(&self, i: usize) -> Surface {
        let p = self.position[i];
        let n = self.normal[i];
        let a = self.albedo[i];
        Surface {
            position: DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64),
            normal: DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64).normalize_or_zero(),
            albedo: DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64),
            roughness: n[3] as f64,
            metallic: a[3] as f64,
        }
    }
}
