//! Triangle meshes and the loaders that read them (OBJ via tobj, PLY and gzipped PLY).
//!
//! A [`TriangleMesh`] is an indexed triangle list with optional per-vertex normals and uvs.
//! Scenes flatten all their meshes into one soup, so a triangle's index in the soup is the
//! `prim` that both intersection backends report.

pub mod shapes;

use crate::math::{Aabb, Vec2, Vec3};

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

    /// Appends `other`, re-basing its indices. Normals/uvs are kept only if both have them.
    pub fn append(&mut self, other: &TriangleMesh) {
        let base = self.positions.len() as u32;
        let both_normals = (self.positions.is_empty() || self.normals.is_some()) && other.normals.is_some();
        let both_uvs = (self.positions.is_empty() || self.uvs.is_some()) && other.uvs.is_some();
        self.positions.extend_from_slice(&other.positions);
        self.indices.extend(other.indices.iter().map(|t| [t[0] + base, t[1] + base, t[2] + base]));
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
