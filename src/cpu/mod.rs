//! CPU twins of the GPU modules, in f64, written from the math (see docs/design.md).
//! They are the oracles that the WGSL is tested against, and `frame` shades whole frames
//! with them. They import only `common`: never the variant schema or the scenes.

pub mod bvh;
pub mod clusters;
pub mod color;
pub mod depth;
pub mod frame;
pub mod light_grid;
pub mod msaa;
pub mod normals;
pub mod occlusion;
pub mod post;
pub mod shading;
pub mod shadows;
pub mod sort;
pub mod truth;
pub mod zbin;
pub mod zslice;

/// The whole numbers the twins share with the shaders, generated into the `constants`
/// module (`compose::constants_module`): each written once, here.
pub const SHARED_U32S: &[(&str, u32)] = &[
    ("DEPTH_CELLS", clusters::DEPTH_CELLS),
    ("RADIX_BITS", bvh::RADIX_BITS),
    ("LEAF", bvh::LEAF),
    ("EMPTY_SPAN", bvh::EMPTY_SPAN),
    ("RADIX_LANES", bvh::RADIX_LANES),
    ("RADIX_ITEMS", bvh::RADIX_ITEMS),
    ("RADIX_HEADER", bvh::RADIX_HEADER),
    ("TILE_X", bvh::TILE.0),
    ("TILE_Y", bvh::TILE.1),
    ("TILE_Z", bvh::TILE.2),
    ("SORT_BLOCK", sort::SORT_BLOCK),
    ("SHADOW_STACK", occlusion::SHADOW_STACK),
];
