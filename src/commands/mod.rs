//! The bodies of the commands `main.rs` dispatches to, one module per family; each calls
//! the library and prints.

mod args;
mod inspect;
mod matrix;
mod render;
mod sequence;
mod setup;
mod snapshot;
mod stress;
mod study;

pub(crate) use inspect::{
    AdaptersArgs, ScenesArgs, ValidateArgs, WgslArgs, adapters, scenes, validate, wgsl,
};
pub(crate) use matrix::{MatrixArgs, MergeArgs, matrix, merge};
pub(crate) use render::{RenderArgs, ViewArgs, render, view};
pub(crate) use sequence::{SequenceArgs, sequence};
pub(crate) use setup::{end_quietly_on_closed_pipe, quiet_mesa_wsi, spread_software_gpu_threads};
pub(crate) use snapshot::{SnapshotArgs, snapshot};
pub(crate) use stress::{StressCommand, stress};
pub(crate) use study::{StudyArgs, study};
