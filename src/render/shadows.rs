//! The occluders of a frame with shadows: the scene's opaque triangles in a BVH
//! (`cpu::occlusion`, built once per renderer), laid out as the shaders read it
//! (`shaders/shading/shadows.wesl`, `occluders`), and checked against the adapter.
//!
//! Layout, in 16-byte words: node i at words 2i and 2i + 1, (min.xyz, first) and
//! (max.xyz, count), f32 coordinates as their bits; an inner node's `first` is its first
//! child (the second follows), a leaf's the word of its first triangle and `count` its
//! triangles; after the nodes, each leaf's triangles, three words each (a corner's xyz).

use crate::cpu::occlusion::{SHADOW_STACK, TriangleBvh};
use crate::scene::Scene;

use super::error::RenderError;

/// A scene's occluders and what the reference needs with them.
#[derive(Clone, Debug)]
pub struct Occluders {
    pub bvh: TriangleBvh,
}

impl Occluders {
    /// The BVH of `scene`'s opaque triangles: masked ones are left out (their alpha is a
    /// texture's, which the traversal does not read) and blended ones are not in
    /// `scene.indices`.
    pub fn of(scene: &Scene) -> Self {
        let positions: Vec<[f32; 3]> = scene.vertices.iter().map(|v| v.position).collect();
        let masked = |i: u32| scene.vertices[i as usize].alpha[1] > 0.0;
        let opaque: Vec<u32> = scene
            .indices
            .chunks_exact(3)
            .filter(|t| !t.iter().any(|&i| masked(i)))
            .flatten()
            .copied()
            .collect();
        Occluders {
            bvh: TriangleBvh::build(&positions, &opaque),
        }
    }

    /// The words the shaders read (module doc).
    pub fn words(&self) -> Vec<[u32; 4]> {
        let bvh = &self.bvh;
        let bits = |v: glam::DVec3| [v.x as f32, v.y as f32, v.z as f32].map(f32::to_bits);
        let first_triangle = 2 * bvh.nodes.len() as u32;
        let mut words = Vec::with_capacity(2 * bvh.nodes.len() + 3 * bvh.order.len());
        for node in &bvh.nodes {
            let first = if node.count == 0 {
                node.first
            } else {
                first_triangle + 3 * node.first
            };
            let [a, b, c] = bits(node.min);
            let [d, e, f] = bits(node.max);
            words.push([a, b, c, first]);
            words.push([d, e, f, node.count]);
        }
        for &t in &bvh.order {
            for corner in bvh.triangles[t as usize] {
                let [x, y, z] = bits(corner);
                words.push([x, y, z, 0]);
            }
        }
        words
    }

    /// Refuse what a frame cannot trace: a scene with no opaque triangle (shadows would do
    /// nothing), a tree deeper than the stack, or more words than one storage binding
    /// holds on this adapter.
    pub fn check(&self, scene: &Scene, max_storage_bytes: u64) -> Result<(), RenderError> {
        let fail = |why: String| {
            Err(RenderError::VariantForScene {
                field: "shading.shadows".into(),
                message: format!("on scene `{}`: {why}", scene.name),
            })
        };
        if self.bvh.triangles.is_empty() {
            return fail(format!(
                "the scene has no opaque triangle of any area to cast a shadow ({} degenerate, masked ones cast none), so shadows would change nothing; use shadows: None",
                self.bvh.degenerate
            ));
        }
        let depth = self.bvh.depth();
        if depth > SHADOW_STACK {
            return fail(format!(
                "its occluders' tree is {depth} levels deep, and the traversal's stack holds {SHADOW_STACK}"
            ));
        }
        let bytes = (2 * self.bvh.nodes.len() + 3 * self.bvh.order.len()) as u64 * 16;
        if bytes > max_storage_bytes {
            return fail(format!(
                "its occluders ({} triangles, {} nodes) take {bytes} bytes, and one storage buffer holds at most {max_storage_bytes} bytes on this adapter; use a scene with fewer triangles, or shadows: None",
                self.bvh.triangles.len(),
                self.bvh.nodes.len()
            ));
        }
        Ok(())
    }
}
