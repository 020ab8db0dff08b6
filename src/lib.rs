//! clusterlab: a harness for real-time many-light shading research.
//!
//! Data flows one way: a [`variant`] file is parsed and checked, [`compose`]d into
//! naga-validated WGSL per pass, and run on the GPU against seeded scenes; the frame is
//! compared with an independent CPU reference.

pub mod compose;
pub mod explain;
pub mod variant;
