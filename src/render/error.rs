//! Why a frame could not be rendered: the render core's one error, which every part of it
//! returns.

use crate::compose::ShaderError;
use crate::gpu::GpuError;

/// Why a frame could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("{0}")]
    Shader(#[from] ShaderError),
    #[error("{0}")]
    Gpu(#[from] GpuError),
    /// A pass's module binds something clusterlab cannot fill.
    #[error("{0}")]
    Reflection(String),
    /// A scene the frame cannot be measured on, and why.
    #[error("{0}")]
    Scene(String),
    /// A variant value that only the scene can check (a depth against its camera).
    #[error("field `{field}` {message}")]
    VariantForScene { field: String, message: String },
    /// The frame needs more than the device's limits allow (`needs`).
    #[error("{0}")]
    Limits(String),
}
