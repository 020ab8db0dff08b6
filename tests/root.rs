//! clusterlab's integration tests, one binary (as wgpu and naga do): each file below is a
//! module, `common` holds what they share.

mod common;

mod cli;
mod clustered;
mod completeness;
mod compose;
mod constants;
mod debug_views;
mod device;
mod environment;
mod features;
mod folders;
mod frame;
mod fuzz;
mod ggx;
mod gltf;
mod hostile;
mod images;
mod inputs;
mod kernels;
mod layers;
mod matrix;
mod measure;
mod naive;
mod own_variant;
mod page;
mod post;
mod properties;
mod readme;
mod sampling;
mod sequence;
mod shadows;
mod shards;
mod skipping;
mod stress;
mod study;
mod verdicts;
mod view;
