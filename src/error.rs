//! Typed errors at the edges. Each names the file (and, for scene files, the key path) it is about.

use std::path::PathBuf;

/// Errors from loading a mesh file.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("{path}: cannot read: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: unsupported mesh format (expected .obj, .ply or .ply.gz)")]
    UnsupportedFormat { path: PathBuf },
}

/// Errors from building an acceleration structure.
#[derive(Debug, thiserror::Error)]
pub enum AccelError {
    #[error("the Embree backend is not compiled in: rebuild with the default feature `embree` (install libembree-dev and libclang-dev)")]
    EmbreeNotCompiled,
    #[error("Embree error: {0}")]
    Embree(String),
    #[error("invalid geometry: {0}")]
    InvalidGeometry(String),
}
