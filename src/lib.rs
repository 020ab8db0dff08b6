//! clusterlab: a harness for real-time many-light shading research.
//!
//! Data flows one way: a [`variant`] file is parsed and checked, [`compose`]d into
//! naga-validated WGSL per pass, and [`render`]ed on the [`gpu`] against seeded [`scene`]s;
//! the frame is compared ([`metrics`]) with an independent [`cpu`] reference. The
//! [`matrix`] runs many such cells and reports them side by side.

pub mod bias;
pub mod common;
pub mod compose;
pub mod cpu;
pub mod efficiency;
pub mod environment;
pub mod explain;
pub mod files;
pub mod flip;
pub mod gpu;
pub mod kernels;
pub mod matrix;
pub mod measure;
pub mod metrics;
pub mod names;
pub mod plot;
pub mod progress;
pub mod reference;
pub mod render;
pub mod run;
pub mod scene;
pub mod sequence;
pub mod snapshot;
pub mod stress;
pub mod study;
pub mod table;
pub mod variant;
pub mod view;
