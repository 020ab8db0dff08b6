//! CPU twins of the GPU modules, in f64, written from the math (see DESIGN.md). They are the
//! oracles that the WGSL is tested against, and `reference` shades whole frames with them.

pub mod clusters;
pub mod color;
pub mod depth;
pub mod frame;
pub mod normals;
pub mod post;
pub mod shading;
pub mod truth;
pub mod zslice;
