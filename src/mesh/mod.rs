//! Triangle meshes and the loaders that read them (OBJ via tobj, PLY and gzipped PLY, Mitsuba's serialized).
//!
//! A [`TriangleMesh`] is an indexed triangle list with optional per-vertex normals and uvs.
//! Scenes flatten all their meshes into one soup, so a triangle's index in the soup is the
//! `prim` that both intersection backends report.
//!
//! [`load_mesh`] picks the reader from the file name (`.obj`, `.ply`, `.ply.gz`, `.serialized`: its first
//! shape; any case) and checks what every backend relies on: finite coordinates and indices in range.
//! Errors name the file. A serialized file's other shapes: [`serialized::load_serialized`].
//!
//! **Hostile files.** A mesh file must be a regular file ([`open_regular`]: not a device, FIFO or
//! directory), read no further than its size. Each reader knows the mesh's size before it allocates its
//! arrays (the PLY and serialized headers' counts, a count of an OBJ file's lines) and refuses a file whose
//! header promises more data than the file can hold (compressed data: at most [`MAX_INFLATE_RATIO`] times
//! its size) or a mesh larger than the memory left (`render::memory::check_mesh`, the render's one memory
//! limit); the arrays are then reserved with `try_reserve`, so an allocation that fails is an error, never
//! an abort.

pub mod attribute;
pub mod obj;
pub mod ply;
pub mod serialized;
pub mod shapes;

use std::fs::File;
use std::path::Path;

use crate::error::MeshError;
use crate::math::{Aabb, Vec2, Vec3};

/// The mesh file formats [`load_mesh`] reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    Obj,
    Ply,
    /// A gzip-compressed PLY file (`.ply.gz`).
    PlyGz,
    /// Mitsuba's serialized format (`.serialized`).
    Serialized,
}

impl MeshFormat {
    /// The format named by the file's extension (case-insensitive), if it is one we read.
    #[must_use]
    pub fn from_path(path: &Path) -> Option<Self> {
        let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
        if name.ends_with(".obj") {
            Some(Self::Obj)
        } else if name.ends_with(".ply") {
            Some(Self::Ply)
        } else if name.ends_with(".ply.gz") {
            Some(Self::PlyGz)
        } else if name.ends_with(".serialized") {
            Some(Self::Serialized)
        } else {
            None
        }
    }
}

/// Loads a triangle mesh from an OBJ, PLY, gzipped PLY or serialized file (the first shape), chosen by
/// extension (case-insensitive).
///
/// Polygons are triangulated as fans. The result has at least one triangle, only finite positions,
/// normals and uvs, and every index in range.
pub fn load_mesh(path: &Path) -> Result<TriangleMesh, MeshError> {
    let mesh = match MeshFormat::from_path(path) {
        Some(MeshFormat::Obj) => obj::load_obj(path)?,
        Some(MeshFormat::Ply) => ply::load_ply(path)?,
        Some(MeshFormat::PlyGz) => ply::load_ply_gz(path)?,
        // (checked by the reader, which every caller goes through)
        Some(MeshFormat::Serialized) => return Ok(serialized::load_serialized(path, 0)?.mesh),
        None => return Err(MeshError::UnsupportedFormat { path: path.to_path_buf() }),
    };
    mesh.validate(path)?;
    Ok(mesh)
}

/// The most bytes one byte of a deflate stream (gzip, zlib) can inflate to: a 258-byte match in as little
/// as two bits, 1032:1 (zlib's FAQ, "What's the maximum compression ratio?"). A compressed file cannot hold
/// more data than this many times its size.
pub const MAX_INFLATE_RATIO: u64 = 1032;

/// Opens the mesh file at `path` if it is a regular file, with its size in bytes: a device (`/dev/zero`),
/// FIFO or directory is refused before it is opened (opening a FIFO would wait for a writer).
pub fn open_regular(path: &Path) -> Result<(File, u64), MeshError> {
    let io = |error| MeshError::Io { path: path.to_path_buf(), error };
    let not_regular = || MeshError::Parse {
        path: path.to_path_buf(),
        message: "not a regular file (a device, FIFO, socket or directory); a mesh must be a file".into(),
    };
    if !std::fs::metadata(path).map_err(io)?.is_file() {
        return Err(not_regular());
    }
    let file = File::open(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    if !meta.is_file() {
        return Err(not_regular());
    }
    Ok((file, meta.len()))
}

/// An empty vector with room for `n` elements, or the error `what` (the reserve failed: no abort).
pub(crate) fn reserved<T>(n: u64, what: &str) -> Result<Vec<T>, String> {
    let mut v = Vec::new();
    let n = usize::try_from(n).map_err(|_| format!("{n} {what} do not fit in this machine's address space"))?;
    v.try_reserve_exact(n).map_err(|_| format!("cannot allocate {n} {what}: out of memory"))?;
    Ok(v)
}

/// An indexed triangle mesh.
#[derive(Clone, Debug, Default)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
    /// Per-vertex shading normals, same length as `positions` when present.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates, same length as `positions` when present.
    pub uvs: Option<Vec<Vec2>>,
}

impl TriangleMesh {
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    #[must_use]
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(&self.positions)
    }

    /// The three corners of triangle `i`.
    #[must_use]
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[i];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Checks the invariants every backend and the shading code rely on: at least one triangle, indices
    /// in range, finite positions/normals/uvs, attribute arrays as long as `positions`. `path` names the
    /// source in the error.
    pub fn validate(&self, path: &Path) -> Result<(), MeshError> {
        let path_buf = || path.to_path_buf();
        if self.indices.is_empty() {
            return Err(MeshError::NoTriangles { path: path_buf() });
        }
        let vertex_count = self.positions.len();
        for (triangle, tri) in self.indices.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertex_count) {
                return Err(MeshError::IndexOutOfRange {
                    path: path_buf(),
                    triangle,
                    index: i64::from(index),
                    vertex_count,
                });
            }
        }
        let non_finite = |vertex: usize, attribute: &'static str, value: String| MeshError::NonFinite {
            path: path_buf(),
            vertex,
            attribute,
            value,
        };
        if let Some(i) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(non_finite(i, "position", format!("{}", self.positions[i])));
        }
        let length_mismatch = |what: &str, n: usize| MeshError::Parse {
            path: path_buf(),
            message: format!("{n} {what} for {vertex_count} vertices"),
        };
        if let Some(normals) = &self.normals {
            if normals.len() != vertex_count {
                return Err(length_mismatch("normals", normals.len()));
            }
            if let Some(i) = normals.iter().position(|n| !n.is_finite()) {
                return Err(non_finite(i, "normal", format!("{}", normals[i])));
            }
        }
        if let Some(uvs) = &self.uvs {
            if uvs.len() != vertex_count {
                return Err(length_mismatch("uvs", uvs.len()));
            }
            if let Some(i) = uvs.iter().position(|uv| !uv.is_finite()) {
                return Err(non_finite(i, "uv", format!("{}", uvs[i])));
            }
        }
        Ok(())
    }

    /// Appends `other`, re-basing its indices. Normals/uvs are kept only if both have them.
    pub fn append(&mut self, other: &TriangleMesh) {
        let base = self.positions.len() as u32;
        let both_normals = (self.positions.is_empty() || self.normals.is_some()) && other.normals.is_some();
        let both_uvs = (self.positions.is_empty() || self.uvs.is_some()) && other.uvs.is_some();
        self.positions.extend_from_slice(&other.positions);
        self.indices
            .extend(other.indices.iter().map(|t| [t[0] + base, t[1] + base, t[2] + base]));
        self.normals = if both_normals {
            let mut n = self.normals.take().unwrap_or_default();
            n.extend_from_slice(other.normals.as_deref().unwrap_or_default());
            Some(n)
        } else {
            None
        };
        self.uvs = if both_uvs {
            let mut u = self.uvs.take().unwrap_or_default();
            u.extend_from_slice(other.uvs.as_deref().unwrap_or_default());
            Some(u)
        } else {
            None
        };
    }
}
