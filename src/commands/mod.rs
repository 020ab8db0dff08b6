//! The bodies of the commands `main.rs` dispatches to, one module per family; each calls
//! the library and prints.

mod inspect;
mod matrix;
mod render;
mod sequence;
mod setup;
mod snapshot;
mod stress;
mod study;

pub(crate) use inspect::{adapters, export_scene, scenes, validate, wgsl};
pub(crate) use matrix::{matrix, merge};
pub(crate) use render::{render, view};
pub(crate) use sequence::sequence;
pub(crate) use setup::{end_quietly_on_closed_pipe, quiet_mesa_wsi, spread_software_gpu_threads};
pub(crate) use snapshot::snapshot;
pub(crate) use stress::{StressArgs, stress};
pub(crate) use study::study;
