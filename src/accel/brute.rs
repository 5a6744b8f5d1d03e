//! The brute-force intersector: tests every triangle. The oracle the accelerators are tested
//! against; never used for rendering.

use super::triangle::RayPrecomp;
use super::{Accel, Hit};
use crate::math::{Ray, Vec3};

/// Owns a copy of the triangle soup and tests every triangle per ray.
#[derive(Clone, Debug)]
pub struct BruteForce {
    tris: Vec<[Vec3; 3]>,
}

impl BruteForce {
    #[must_use]
    pub fn new(positions: &[Vec3], indices: &[[u32; 3]]) -> Self {
        let tris = indices.iter().map(|t| [positions[t[0] as usize], positions[t[1] as usize], positions[t[2] as usize]]).collect();
        Self { tris }
    }
}

impl Accel for BruteForce {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut pre = RayPrecomp::new(ray);
        let mut best: Option<Hit> = None;
        for (i, t) in self.tris.iter().enumerate() {
            if let Some((th, u, v)) = pre.intersect(t[0], t[1], t[2]) {
                if best.is_none_or(|b| th < b.t) {
                    best = Some(Hit { t: th, prim: i as u32, u, v });
                    pre.t_max = th;
                }
            }
        }
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let pre = RayPrecomp::new(ray);
        self.tris.iter().any(|t| pre.intersect(t[0], t[1], t[2]).is_some())
    }

    fn name(&self) -> &'static str {
        "brute"
    }
}
