//! Typed errors at the edges. Each names the file (and, for scene files, the key path) it is about.

use std::path::PathBuf;

/// Errors from loading a mesh file.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("{path}: cannot read: {error}")]
    Io { path: PathBuf, error: std::io::Error },
    #[error("{path}: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: unsupported mesh format (expected .obj, .ply or .ply.gz)")]
    UnsupportedFormat { path: PathBuf },
    #[error("{path}: triangle {triangle} refers to vertex {index}, but there are only {vertex_count} vertices")]
    IndexOutOfRange {
        path: PathBuf,
        triangle: usize,
        index: i64,
        vertex_count: usize,
    },
    #[error("{path}: vertex {vertex} has a non-finite {attribute} {value}")]
    NonFinite {
        path: PathBuf,
        vertex: usize,
        attribute: &'static str,
        value: String,
    },
    #[error("{path}: contains no triangles")]
    NoTriangles { path: PathBuf },
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
