//! The watertight ray–triangle test (Woop, Benthin & Wald 2013, "Watertight Ray/Triangle
//! Intersection", JCGT 2(1)), shared by the brute-force oracle and the BVH.
//!
//! Barycentrics follow Embree: `p = (1 − u − v)·p0 + u·p1 + v·p2`. Rays through a shared edge or
//! vertex of a closed mesh hit at least one of the triangles that share it (the scaled barycentrics
//! are recomputed in f64 when one of them is exactly zero, as the paper prescribes).

use crate::accel::Hit;
use crate::math::{Ray, Vec3};

/// Per-ray constants of the watertight test: the permutation that makes `kz` the dominant axis of
/// the direction, and the shear that maps the ray onto +z.
#[derive(Clone, Copy, Debug)]
pub struct RayPrecomp {
    pub origin: Vec3,
    pub kx: usize,
    pub ky: usize,
    pub kz: usize,
    pub sx: f32,
    pub sy: f32,
    pub sz: f32,
    pub t_min: f32,
    pub t_max: f32,
}

impl RayPrecomp {
    #[must_use]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.dir;
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Self {
            origin: ray.origin,
            kx,
            ky,
            kz,
            sx: d[kx] / d[kz],
            sy: d[ky] / d[kz],
            sz: 1.0 / d[kz],
            t_min: ray.t_min,
            t_max: ray.t_max,
        }
    }

    /// Intersects triangle `(p0, p1, p2)`; returns `(t, u, v)` when `t ∈ [t_min, t_max]`.
    #[inline]
    #[must_use]
    pub fn intersect(&self, p0: Vec3, p1: Vec3, p2: Vec3) -> Option<(f32, f32, f32)> {
        let a = p0 - self.origin;
        let b = p1 - self.origin;
        let c = p2 - self.origin;
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        // Shear and scale the vertices into ray space (paper §3, eq. for A_x, A_y ...).
        let ax = a[kx] - self.sx * a[kz];
        let ay = a[ky] - self.sy * a[kz];
        let bx = b[kx] - self.sx * b[kz];
        let by = b[ky] - self.sy * b[kz];
        let cx = c[kx] - self.sx * c[kz];
        let cy = c[ky] - self.sy * c[kz];
        // Scaled barycentrics: U weighs p0, V weighs p1, W weighs p2.
        let mut u_s = cx * by - cy * bx;
        let mut v_s = ax * cy - ay * cx;
        let mut w_s = bx * ay - by * ax;
        if u_s == 0.0 || v_s == 0.0 || w_s == 0.0 {
            // Edge case: recompute in double precision for watertightness (paper §4).
            u_s = (f64::from(cx) * f64::from(by) - f64::from(cy) * f64::from(bx)) as f32;
            v_s = (f64::from(ax) * f64::from(cy) - f64::from(ay) * f64::from(cx)) as f32;
            w_s = (f64::from(bx) * f64::from(ay) - f64::from(by) * f64::from(ax)) as f32;
        }
        if (u_s < 0.0 || v_s < 0.0 || w_s < 0.0) && (u_s > 0.0 || v_s > 0.0 || w_s > 0.0) {
            return None;
        }
        let det = u_s + v_s + w_s;
        if det == 0.0 {
            return None;
        }
        let az = self.sz * a[kz];
        let bz = self.sz * b[kz];
        let cz = self.sz * c[kz];
        let t_scaled = u_s * az + v_s * bz + w_s * cz;
        let inv_det = 1.0 / det;
        let t = t_scaled * inv_det;
        if !(t >= self.t_min && t <= self.t_max) {
            return None;
        }
        Some((t, v_s * inv_det, w_s * inv_det))
    }
}

/// Convenience: the closest-hit record for triangle `prim`, if the ray hits it.
#[inline]
#[must_use]
pub fn intersect_triangle(pre: &RayPrecomp, prim: u32, p: [Vec3; 3]) -> Option<Hit> {
    pre.intersect(p[0], p[1], p[2]).map(|(t, u, v)| Hit { t, prim, u, v, inst: super::FLAT })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn barycentrics_follow_embree_convention() {
        let (p0, p1, p2) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        let target = 0.5 * p0 + 0.3 * p1 + 0.2 * p2;
        let ray = Ray::new(target + Vec3::new(0.1, -0.2, 2.0), Vec3::new(-0.1, 0.2, -2.0));
        let (t, u, v) = RayPrecomp::new(&ray).intersect(p0, p1, p2).expect("hit");
        assert!((t - 1.0).abs() < 1e-6 && (u - 0.3).abs() < 1e-6 && (v - 0.2).abs() < 1e-6, "{t} {u} {v}");
        // Both windings are hit (no culling).
        assert!(RayPrecomp::new(&ray).intersect(p0, p2, p1).is_some());
    }

    #[test]
    fn respects_t_interval() {
        let tri = [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let r = Ray::segment(Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0), 0.0, 0.99);
        assert!(RayPrecomp::new(&r).intersect(tri[0], tri[1], tri[2]).is_none());
        let r = Ray::segment(Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0), 1.01, 5.0);
        assert!(RayPrecomp::new(&r).intersect(tri[0], tri[1], tri[2]).is_none());
        let r = Ray::segment(Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0), 0.5, 1.0);
        assert!(RayPrecomp::new(&r).intersect(tri[0], tri[1], tri[2]).is_some());
    }
}
