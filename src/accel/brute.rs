//! The brute-force intersector: tests every triangle, every triangle of every instance through the
//! ray transformed into the instance's object space (`Instance::object_ray`, `t` the world ray's), and
//! every analytic primitive (`analytic_set::closest_linear`). The
//! oracle the accelerators are tested against; never used for rendering.

use super::analytic::Analytic;
use super::analytic_set::closest_linear;
use super::instance::{Geometry, Instance, FLAT};
use super::triangle::RayPrecomp;
use super::{Accel, Hit};
use crate::math::{Ray, Vec3};

/// Owns a copy of the triangles and tests every one per ray.
#[derive(Clone, Debug)]
pub struct BruteForce {
    tris: Vec<[Vec3; 3]>,
    /// Per prototype: its triangles (object space) and the soup index of the first.
    prototypes: Vec<(Vec<[Vec3; 3]>, u32)>,
    instances: Vec<Instance>,
    /// The analytic primitives and the `prim` of the first.
    analytic: Vec<Analytic>,
    first_analytic: u32,
}

fn corners(positions: &[Vec3], indices: &[[u32; 3]]) -> Vec<[Vec3; 3]> {
    indices.iter().map(|t| t.map(|i| positions[i as usize])).collect()
}

impl BruteForce {
    /// Over a soup without instances.
    #[must_use]
    pub fn new(positions: &[Vec3], indices: &[[u32; 3]]) -> Self {
        Self { tris: corners(positions, indices), prototypes: Vec::new(), instances: Vec::new(), analytic: Vec::new(), first_analytic: indices.len() as u32 }
    }

    /// Over a scene's geometry (flat soup and instances).
    #[must_use]
    pub fn from_geometry(g: &Geometry) -> Self {
        let prototypes = (0..g.prototypes.len()).map(|p| (corners(g.positions, g.prototype_indices(p)), g.prototypes[p].start)).collect();
        Self { tris: corners(g.positions, g.flat_indices()), prototypes, instances: g.instances.to_vec(), analytic: g.analytic.to_vec(), first_analytic: g.first_analytic() }
    }

    /// The closest hit among `tris` (numbered from `first`) below `best`.
    fn closest(tris: &[[Vec3; 3]], first: u32, inst: u32, ray: &Ray, best: &mut Option<Hit>) {
        let mut pre = RayPrecomp::new(ray);
        if let Some(b) = best {
            pre.t_max = pre.t_max.min(b.t);
        }
        for (i, t) in tris.iter().enumerate() {
            if let Some((th, u, v)) = pre.intersect(t[0], t[1], t[2]) {
                if best.is_none_or(|b| th < b.t) {
                    *best = Some(Hit { t: th, prim: first + i as u32, u, v, inst });
                    pre.t_max = th;
                }
            }
        }
    }
}

impl Accel for BruteForce {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best = None;
        Self::closest(&self.tris, 0, FLAT, ray, &mut best);
        for (k, inst) in self.instances.iter().enumerate() {
            let (tris, first) = &self.prototypes[inst.prototype as usize];
            Self::closest(tris, *first, k as u32, &inst.object_ray(ray), &mut best);
        }
        closest_linear(&self.analytic, self.first_analytic, ray, &mut best);
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let any = |tris: &[[Vec3; 3]], ray: &Ray| {
            let pre = RayPrecomp::new(ray);
            tris.iter().any(|t| pre.intersect(t[0], t[1], t[2]).is_some())
        };
        any(&self.tris, ray)
            || self.instances.iter().any(|i| any(&self.prototypes[i.prototype as usize].0, &i.object_ray(ray)))
            || self.analytic.iter().any(|s| s.intersect(ray).is_some())
    }

    fn name(&self) -> &'static str {
        "brute"
    }
}
