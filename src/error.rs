//! Typed errors at the edges. Each names the file (and, for scene files, the key path) it is about.

use std::path::PathBuf;

/// Errors from loading a mesh file.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("{path}: cannot read: {error}")]
    Io { path: PathBuf, error: std::io::Error },
    #[error("{path}: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: unsupported mesh format (expected .obj, .ply, .ply.gz or .serialized)")]
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
    /// A Mitsuba `serialized` file that cannot be read (`mesh::serialized`); `shape` is the shape asked for.
    #[error("{path}: shape {shape}: {message}")]
    Serialized { path: PathBuf, shape: u32, message: String },
    #[error("{path}: shape_index {index} is out of range: {}", shapes_held(*count))]
    ShapeIndexOutOfRange { path: PathBuf, index: u32, count: u32 },
}

/// How many shapes a serialized file holds, and so which `shape_index` values it takes.
fn shapes_held(count: u32) -> String {
    match count {
        0 => "the file's dictionary lists no shapes".into(),
        1 => "the file holds 1 shape (shape_index 0)".into(),
        n => format!("the file holds {n} shapes (shape_index 0 to {})", n - 1),
    }
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
