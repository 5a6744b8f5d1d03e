//! The per-triangle data a hit reads, in one record per triangle (the layout of the hit path).
//!
//! [`Scene::interaction`](super::Scene::interaction) runs once per closest hit, on a triangle the
//! intersector just found in a BVH leaf of its own: in the scene's mesh arrays that triangle's data is
//! cold, and spread over up to seven cache lines (its indices, three positions, three vertex normals,
//! the flat flag, the material and the light index), each load waiting on the index load before it.
//! `perf` on the cornell scene with 65k-triangle spheres put half of `interaction`'s time (5% of a `pt`
//! render) on those misses. [`HitData`] holds the same values, copied from the mesh at scene build,
//! in one 128-byte record aligned to its size (two adjacent cache lines, fetched together by the
//! adjacent-line prefetcher): one miss instead of seven, and no dependent loads.
//!
//! It is a cache of `Scene::mesh`, `tri_material`, `tri_flat` and the light set's primitive map, built
//! once by [`HitData::build`]; those stay the scene's description. Cost: 128 bytes per triangle (counted by
//! `render::memory`).

use crate::light::LightSet;
use crate::math::Vec3;
use crate::mesh::TriangleMesh;

/// `light` of a triangle that does not emit.
const NO_LIGHT: u32 = u32::MAX;

/// One triangle's hit data.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(128))]
pub struct HitData {
    /// The vertex positions, in the triangle's index order.
    pub p: [Vec3; 3],
    /// Index into `Scene::bsdfs`.
    pub material: u32,
    /// Index into the light set, or `NO_LIGHT`.
    light: u32,
    /// The vertex normals (unused when `flat`).
    pub n: [Vec3; 3],
    /// The shading normal is the geometric normal (flat shapes, or a mesh without vertex normals).
    pub flat: bool,
}

const _: () = assert!(size_of::<HitData>() == 128);

impl HitData {
    /// The records of every triangle of `mesh` (material and flatness per triangle, lights by primitive).
    #[must_use]
    pub fn build(mesh: &TriangleMesh, tri_material: &[u32], tri_flat: &[bool], lights: &LightSet) -> Vec<HitData> {
        mesh.indices
            .iter()
            .enumerate()
            .map(|(i, idx)| {
                let normals = mesh.normals.as_ref();
                HitData {
                    p: idx.map(|k| mesh.positions[k as usize]),
                    material: tri_material[i],
                    light: lights.light_of_prim(i as u32).map_or(NO_LIGHT, |l| l as u32),
                    n: normals.map_or([Vec3::ZERO; 3], |n| idx.map(|k| n[k as usize])),
                    flat: tri_flat[i] || normals.is_none(),
                }
            })
            .collect()
    }

    /// The light this triangle belongs to (as `LightSet::light_of_prim`).
    #[must_use]
    #[inline]
    pub fn light(&self) -> Option<usize> {
        (self.light != NO_LIGHT).then_some(self.light as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every record holds exactly the mesh's values, with and without vertex normals.
    #[test]
    fn records_copy_the_mesh() {
        let mut mesh = TriangleMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            indices: vec![[0, 1, 2], [3, 2, 1]],
            normals: Some(vec![Vec3::Z, Vec3::Z, Vec3::X, Vec3::Y]),
            uvs: None,
        };
        let lights = LightSet::new(Vec::new(), 2, crate::math::Aabb::EMPTY.grow(Vec3::ZERO).grow(Vec3::ONE));
        let h = HitData::build(&mesh, &[4, 7], &[false, true], &lights);
        assert_eq!(h[1].p, [Vec3::Z, Vec3::Y, Vec3::X]);
        assert_eq!(h[1].n, [Vec3::Y, Vec3::X, Vec3::Z]);
        assert_eq!((h[0].material, h[1].material, h[0].flat, h[1].flat), (4, 7, false, true));
        assert_eq!(h[0].light(), None);
        mesh.normals = None;
        assert!(HitData::build(&mesh, &[0, 0], &[false, false], &lights).iter().all(|h| h.flat));
    }
}
