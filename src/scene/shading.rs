//! Per-triangle shading records: what [`Scene::interaction`](super::Scene::interaction) reads of a triangle
//! (its vertex positions and normals, its material, flatness and whether the material is anisotropic), copied at load into one record per
//! triangle, so that a hit costs one memory access instead of a chain (index, then positions and normals
//! at the indices' vertices). On a 130k-triangle mesh the chain missed the cache twice per hit. The record
//! also holds the triangle's unit geometric normal, computed once by the one rule
//! ([`triangle_normal_area`]) instead of at every hit.

use crate::math::{triangle_normal_area, Vec3};
use crate::mesh::TriangleMesh;

/// One triangle's shading data: the values of the mesh's vertex arrays at its three indices, bit for bit.
/// 96 bytes (aligned to 16, so a record spans two cache lines, fetched together).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct TriangleShading {
    /// Vertex positions `p0, p1, p2` (`mesh.positions` at the triangle's indices).
    pub p: [Vec3; 3],
    /// Vertex shading normals (`mesh.normals` at the indices); zero when `flat`.
    pub n: [Vec3; 3],
    /// Unit geometric normal of `p` ([`triangle_normal_area`]); `None` for a zero-area triangle.
    pub ng: Option<Vec3>,
    /// Index into `Scene::bsdfs`.
    pub material: u32,
    /// The shading normal is the geometric normal (`Scene::tri_flat`, or a mesh without normals).
    pub flat: bool,
    /// The material may be anisotropic (`material::Facts::anisotropic`): the shading frame's tangent then
    /// follows `∂p/∂u` (`Scene::interaction`). In the record's padding: a hit reads no material to know.
    pub anisotropic: bool,
}

/// The records of every triangle of `mesh`, in triangle order; `anisotropic` tells of a material index
/// whether it may be anisotropic.
#[must_use]
pub fn shading_records(mesh: &TriangleMesh, tri_material: &[u32], tri_flat: &[bool], anisotropic: impl Fn(u32) -> bool) -> Vec<TriangleShading> {
    debug_assert_eq!(tri_material.len(), mesh.indices.len());
    debug_assert_eq!(tri_flat.len(), mesh.indices.len());
    mesh.indices
        .iter()
        .zip(tri_material.iter().zip(tri_flat))
        .map(|(idx, (&material, &flat))| {
            let normals = mesh.normals.as_ref().filter(|_| !flat);
            let p = idx.map(|k| mesh.positions[k as usize]);
            TriangleShading {
                p,
                n: normals.map_or([Vec3::ZERO; 3], |n| idx.map(|k| n[k as usize])),
                ng: triangle_normal_area(p).map(|(n, _)| n),
                material,
                flat: normals.is_none(),
                anisotropic: anisotropic(material),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_is_ninety_six_bytes() {
        assert_eq!(size_of::<TriangleShading>(), 96);
    }

    #[test]
    fn records_copy_the_mesh_at_the_indices() {
        let mesh = TriangleMesh {
            positions: vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.5)],
            indices: vec![[0, 1, 2], [1, 3, 2]],
            normals: Some(vec![Vec3::Z, Vec3::X, Vec3::Y, Vec3::new(0.6, 0.0, 0.8)]),
            uvs: None,
        };
        let r = shading_records(&mesh, &[3, 7], &[false, true], |m| m == 7);
        assert_eq!(r[0].p, [mesh.positions[0], mesh.positions[1], mesh.positions[2]]);
        assert_eq!(r[0].n, [Vec3::Z, Vec3::X, Vec3::Y]);
        assert_eq!((r[0].material, r[0].flat, r[0].anisotropic), (3, false, false));
        assert!(r[1].anisotropic);
        assert_eq!(r[0].ng, Some(Vec3::Z));
        assert_eq!(r[1].p, [mesh.positions[1], mesh.positions[3], mesh.positions[2]]);
        assert_eq!(r[1].n, [Vec3::ZERO; 3]);
        assert_eq!((r[1].material, r[1].flat), (7, true));
        let degenerate = TriangleMesh { indices: vec![[0, 1, 1]], ..mesh.clone() };
        assert_eq!(shading_records(&degenerate, &[0], &[false], |_| false)[0].ng, None);
        let no_normals = TriangleMesh { normals: None, ..mesh };
        assert!(shading_records(&no_normals, &[3, 7], &[false, false], |_| false).iter().all(|t| t.flat));
    }
}
