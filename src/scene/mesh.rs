//! Procedural geometry: quads, boxes, cylinders and spheres with exact normals.

use glam::{DVec3, Vec3};

use super::Vertex;
use crate::common::AlphaMode;

/// Collects triangles into one indexed mesh: opaque and masked ones in `indices`, blended
/// ones in `blended`.
pub struct MeshBuilder {
    pub vertices: Vec<Vertex>,
    pub indices: Vec<u32>,
    /// Triangles of blended materials (`AlphaMode::Blend`), drawn after the opaque frame.
    pub blended: Vec<u32>,
    /// (perceptual roughness, metallic) of the primitives added from now on.
    pub material: [f32; 2],
    /// `Vertex::alpha` of the primitives added from now on.
    alpha: [f32; 2],
    /// Whether the primitives added from now on are blended.
    blend: bool,
}

impl Default for MeshBuilder {
    fn default() -> Self {
        MeshBuilder {
            vertices: Vec::new(),
            indices: Vec::new(),
            blended: Vec::new(),
            material: [0.0; 2],
            alpha: [1.0, 0.0],
            blend: false,
        }
    }
}

impl MeshBuilder {
    fn vertex(&self, p: DVec3, n: DVec3, albedo: [f32; 3]) -> Vertex {
        Vertex {
            position: p.as_vec3().to_array(),
            normal: n.normalize().as_vec3().to_array(),
            albedo,
            material: self.material,
            uv: [0.0; 2],
            texture: crate::common::NO_TEXTURE,
            alpha: self.alpha,
        }
    }

    /// Set the (roughness, metallic) of what is added next. Both are rounded to a multiple of
    /// 1/255, so G-buffer layouts that keep them in 8 bits keep them exactly.
    pub fn set_material(&mut self, roughness: f32, metallic: f32) {
        self.material = [roughness, metallic].map(|x| (x.clamp(0.0, 1.0) * 255.0).round() / 255.0);
    }

    /// Set the base colour alpha and alpha mode of what is added next.
    pub fn set_alpha(&mut self, alpha: f32, mode: AlphaMode) {
        let cutoff = match mode {
            AlphaMode::Mask { cutoff } => cutoff,
            AlphaMode::Opaque | AlphaMode::Blend => 0.0,
        };
        self.alpha = [alpha, cutoff];
        self.blend = mode == AlphaMode::Blend;
    }

    /// Where the triangles added now go: the opaque list or the blended one.
    fn triangles(&mut self) -> &mut Vec<u32> {
        if self.blend {
            &mut self.blended
        } else {
            &mut self.indices
        }
    }
}

impl MeshBuilder {
    /// A flat quad `a b c d` (counter-clockwise seen from the side `normal` points to).
    pub fn quad(&mut self, corners: [DVec3; 4], normal: DVec3, albedo: [f32; 3]) {
        let base = self.vertices.len() as u32;
        for c in corners {
            self.vertices.push(self.vertex(c, normal, albedo));
        }
        self.triangles()
            .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }

    /// A flat quad whose corners have their own base colour alpha (the material's cutoff and
    /// mode as set): masked cut-outs where it crosses the cutoff.
    pub fn quad_with_alpha(
        &mut self,
        corners: [DVec3; 4],
        normal: DVec3,
        albedo: [f32; 3],
        alphas: [f32; 4],
    ) {
        let base = self.vertices.len() as u32;
        for (c, a) in corners.into_iter().zip(alphas) {
            let mut v = self.vertex(c, normal, albedo);
            v.alpha[0] = a;
            self.vertices.push(v);
        }
        self.triangles()
            .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }

    /// An axis-aligned rectangle in the plane `axis = offset`, spanning `min..max` on the
    /// other two axes, facing `+axis` if `positive` else `-axis`.
    pub fn axis_rect(
        &mut self,
        axis: usize,
        offset: f64,
        min: [f64; 2],
        max: [f64; 2],
        positive: bool,
        albedo: [f32; 3],
    ) {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let point = |a: f64, b: f64| {
            let mut p = [0.0; 3];
            p[axis] = offset;
            p[u] = a;
            p[v] = b;
            DVec3::from(p)
        };
        let mut n = [0.0; 3];
        n[axis] = if positive { 1.0 } else { -1.0 };
        let corners = [
            point(min[0], min[1]),
            point(max[0], min[1]),
            point(max[0], max[1]),
            point(min[0], max[1]),
        ];
        let corners = if positive {
            corners
        } else {
            [corners[0], corners[3], corners[2], corners[1]]
        };
        self.quad(corners, DVec3::from(n), albedo);
    }

    /// An axis-aligned box from `min` to `max`, faces pointing out.
    pub fn cuboid(&mut self, min: DVec3, max: DVec3, albedo: [f32; 3]) {
        let (lo, hi) = (min.to_array(), max.to_array());
        for axis in 0..3 {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let span_min = [lo[u], lo[v]];
            let span_max = [hi[u], hi[v]];
            self.axis_rect(axis, hi[axis], span_min, span_max, true, albedo);
            self.axis_rect(axis, lo[axis], span_min, span_max, false, albedo);
        }
    }

    /// The inside of an axis-aligned box: the six faces pointing in (a room).
    pub fn cuboid_inside(&mut self, min: DVec3, max: DVec3, albedo: [f32; 3]) {
        let (lo, hi) = (min.to_array(), max.to_array());
        for axis in 0..3 {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let span_min = [lo[u], lo[v]];
            let span_max = [hi[u], hi[v]];
            self.axis_rect(axis, hi[axis], span_min, span_max, false, albedo);
            self.axis_rect(axis, lo[axis], span_min, span_max, true, albedo);
        }
    }

    /// A vertical cylinder standing on `base`, smooth sides and flat caps.
    pub fn cylinder(
        &mut self,
        base: DVec3,
        radius: f64,
        height: f64,
        segments: u32,
        albedo: [f32; 3],
    ) {
        let around = |i: u32| {
            let a = std::f64::consts::TAU * i as f64 / segments as f64;
            DVec3::new(a.cos(), 0.0, -a.sin())
        };
        let up = DVec3::Y * height;
        let start = self.vertices.len() as u32;
        for i in 0..=segments {
            let d = around(i);
            self.vertices
                .push(self.vertex(base + d * radius, d, albedo));
            self.vertices
                .push(self.vertex(base + d * radius + up, d, albedo));
        }
        for i in 0..segments {
            let (a, b) = (start + 2 * i, start + 2 * i + 2);
            self.triangles().extend([a, b, b + 1, a, b + 1, a + 1]);
        }
        for (y, normal) in [(height, DVec3::Y), (0.0, DVec3::NEG_Y)] {
            let center = self.vertices.len() as u32;
            self.vertices
                .push(self.vertex(base + DVec3::Y * y, normal, albedo));
            for i in 0..=segments {
                self.vertices.push(self.vertex(
                    base + around(i) * radius + DVec3::Y * y,
                    normal,
                    albedo,
                ));
            }
            for i in 0..segments {
                let (a, b) = (center + 1 + i, center + 2 + i);
                if normal.y > 0.0 {
                    self.triangles().extend([center, a, b]);
                } else {
                    self.triangles().extend([center, b, a]);
                }
            }
        }
    }

    /// A UV sphere with exact (radial) normals over the whole sphere.
    pub fn sphere(
        &mut self,
        center: DVec3,
        radius: f64,
        stacks: u32,
        slices: u32,
        albedo: [f32; 3],
    ) {
        let start = self.vertices.len() as u32;
        for i in 0..=stacks {
            let polar = std::f64::consts::PI * i as f64 / stacks as f64;
            for j in 0..=slices {
                let azimuth = std::f64::consts::TAU * j as f64 / slices as f64;
                let n = DVec3::new(
                    polar.sin() * azimuth.cos(),
                    polar.cos(),
                    -polar.sin() * azimuth.sin(),
                );
                self.vertices
                    .push(self.vertex(center + n * radius, n, albedo));
            }
        }
        let row = slices + 1;
        for i in 0..stacks {
            for j in 0..slices {
                let a = start + i * row + j;
                let b = a + row;
                self.triangles().extend([a, b, b + 1, a, b + 1, a + 1]);
            }
        }
    }

    /// Bounding box of everything built so far.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.vertices.iter().fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(lo, hi), v| {
                let p = Vec3::from(v.position);
                (lo.min(p), hi.max(p))
            },
        )
    }
}
