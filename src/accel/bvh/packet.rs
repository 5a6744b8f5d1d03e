//! Leaf triangles in packets of four (structure of arrays), tested four at a time by the shared
//! watertight test (Woop, Benthin & Wald 2013) — *bit-identical* to
//! [`crate::accel::triangle::RayPrecomp::intersect`].
//!
//! Every lane performs the scalar test's IEEE operations in the scalar test's order (Rust never
//! contracts `a·b + c` into an FMA, and `1/det` is a correctly rounded division in both forms), so
//! `(t, u, v)` and the hit/miss decision agree bit for bit. The one branchy part of the scalar test,
//! the double-precision recomputation when a scaled barycentric is exactly zero (paper §4), is
//! delegated lane by lane to the scalar test itself. Unused lanes hold NaN corners and the
//! `prim` [`NO_PRIM`]; they are masked out explicitly as well.

use crate::accel::triangle::RayPrecomp;
use crate::math::Vec3;

/// Triangles per packet.
pub(super) const LANES: usize = 4;
/// `prim` of an unused lane.
pub(super) const NO_PRIM: u32 = u32::MAX;

/// Four triangles: `v[corner][axis][lane]`, and their input indices.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(super) struct Tri4 {
    pub v: [[[f32; LANES]; 3]; 3],
    pub prim: [u32; LANES],
}

impl Tri4 {
    /// Packs up to four triangles (with their input indices); missing lanes are unused.
    #[must_use]
    pub fn pack(tris: &[([Vec3; 3], u32)]) -> Self {
        debug_assert!(!tris.is_empty() && tris.len() <= LANES);
        let mut p = Tri4 { v: [[[f32::NAN; LANES]; 3]; 3], prim: [NO_PRIM; LANES] };
        for (lane, (corners, prim)) in tris.iter().enumerate() {
            for (c, corner) in corners.iter().enumerate() {
                for axis in 0..3 {
                    p.v[c][axis][lane] = corner[axis];
                }
            }
            p.prim[lane] = *prim;
        }
        p
    }

    /// The corners of lane `lane`.
    #[must_use]
    pub fn corners(&self, lane: usize) -> [Vec3; 3] {
        [0, 1, 2].map(|c| Vec3::new(self.v[c][0][lane], self.v[c][1][lane], self.v[c][2][lane]))
    }

    /// Lanes holding a triangle (bit mask).
    #[inline(always)]
    #[must_use]
    pub fn used_mask(&self) -> u32 {
        let mut m = 0u32;
        for i in 0..LANES {
            m |= u32::from(self.prim[i] != NO_PRIM) << i;
        }
        m
    }

    /// The watertight test on all four lanes against `pre` (its `t_min`, `t_max`): the bit mask of
    /// the hit lanes and their `(t, u, v)` (meaningful for hit lanes only).
    #[inline(always)]
    #[must_use]
    pub fn intersect(&self, pre: &RayPrecomp) -> (u32, [f32; LANES], [f32; LANES], [f32; LANES]) {
        let (kx, ky, kz) = (pre.kx, pre.ky, pre.kz);
        let o = pre.origin;
        let (ox, oy, oz) = (o[kx], o[ky], o[kz]);
        let [p0, p1, p2] = &self.v;
        // Rows in ray-permuted order (a pointer choice per row; the lanes are then straight SIMD).
        let (p0x, p0y, p0z) = (&p0[kx], &p0[ky], &p0[kz]);
        let (p1x, p1y, p1z) = (&p1[kx], &p1[ky], &p1[kz]);
        let (p2x, p2y, p2z) = (&p2[kx], &p2[ky], &p2[kz]);
        let (mut t, mut u, mut v) = ([0.0f32; LANES], [0.0f32; LANES], [0.0f32; LANES]);
        let mut hit = [false; LANES];
        let mut redo = [false; LANES];
        for i in 0..LANES {
            // Same operations as `RayPrecomp::intersect`: a = p0 − o, then shear (paper §3).
            let (a_x, a_y, a_z) = (p0x[i] - ox, p0y[i] - oy, p0z[i] - oz);
            let (b_x, b_y, b_z) = (p1x[i] - ox, p1y[i] - oy, p1z[i] - oz);
            let (c_x, c_y, c_z) = (p2x[i] - ox, p2y[i] - oy, p2z[i] - oz);
            let ax = a_x - pre.sx * a_z;
            let ay = a_y - pre.sy * a_z;
            let bx = b_x - pre.sx * b_z;
            let by = b_y - pre.sy * b_z;
            let cx = c_x - pre.sx * c_z;
            let cy = c_y - pre.sy * c_z;
            let u_s = cx * by - cy * bx;
            let v_s = ax * cy - ay * cx;
            let w_s = bx * ay - by * ax;
            // Non-short-circuit `|`/`&` keep the lanes branch-free (and vectorised).
            redo[i] = (u_s == 0.0) | (v_s == 0.0) | (w_s == 0.0);
            let outside = ((u_s < 0.0) | (v_s < 0.0) | (w_s < 0.0)) & ((u_s > 0.0) | (v_s > 0.0) | (w_s > 0.0));
            let det = u_s + v_s + w_s;
            let t_scaled = u_s * (pre.sz * a_z) + v_s * (pre.sz * b_z) + w_s * (pre.sz * c_z);
            let inv_det = 1.0 / det;
            t[i] = t_scaled * inv_det;
            u[i] = v_s * inv_det;
            v[i] = w_s * inv_det;
            hit[i] = !outside & (det != 0.0) & (t[i] >= pre.t_min) & (t[i] <= pre.t_max);
        }
        let mut mask = 0u32;
        for i in 0..LANES {
            mask |= u32::from(hit[i]) << i;
        }
        let redo_mask = (0..LANES).fold(0u32, |m, i| m | (u32::from(redo[i]) << i)) & self.used_mask();
        if redo_mask != 0 {
            // A scaled barycentric is exactly zero: the scalar test's f64 path decides.
            let mut m = redo_mask;
            while m != 0 {
                let i = m.trailing_zeros() as usize;
                m &= m - 1;
                let [a, b, c] = self.corners(i);
                match pre.intersect(a, b, c) {
                    Some((ti, ui, vi)) => {
                        (t[i], u[i], v[i]) = (ti, ui, vi);
                        mask |= 1 << i;
                    }
                    None => mask &= !(1 << i),
                }
            }
        }
        (mask & self.used_mask(), t, u, v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Ray;
    use crate::sampler::Sampler;

    fn random_vec(s: &mut Sampler, scale: f32) -> Vec3 {
        scale * Vec3::new(2.0 * s.next_1d() - 1.0, 2.0 * s.next_1d() - 1.0, 2.0 * s.next_1d() - 1.0)
    }

    /// Every lane of the packet test equals the scalar test bit for bit, hits and misses alike,
    /// including rays through shared edges and vertices (the f64 path) and t-interval limits.
    #[test]
    fn packet_test_is_bit_identical_to_the_scalar_test() {
        let mut n_hits = 0;
        let mut n_redo = 0;
        for k in 0..20_000u64 {
            let mut s = Sampler::for_key(41, k, 0);
            let scale = [1e-3, 1.0, 1e4][k as usize % 3];
            let offset = if k % 5 == 0 { Vec3::splat(1e6) } else { Vec3::ZERO };
            let mut tris: Vec<([Vec3; 3], u32)> =
                (0..1 + k as usize % LANES).map(|i| ([0, 1, 2].map(|_| offset + random_vec(&mut s, scale)), i as u32 * 7)).collect();
            if k % 4 == 1 && tris.len() >= 2 {
                // Two triangles sharing an edge, and a vertex.
                tris[1].0[0] = tris[0].0[1];
                tris[1].0[1] = tris[0].0[0];
            }
            let origin = offset + random_vec(&mut s, 3.0 * scale);
            // Aim at a corner, an edge point, or a random interior point of lane 0.
            let [a, b, c] = tris[0].0;
            let target = match k % 3 {
                0 => a,
                1 => a + 0.5 * (b - a),
                _ => {
                    let (r1, r2) = (s.next_1d(), s.next_1d());
                    a + r1 * (b - a) + (1.0 - r1) * r2 * (c - a)
                }
            };
            let mut ray = Ray::new(origin, target - origin);
            if k % 7 == 0 {
                ray.t_max = 1.0; // the hit is at t ≈ 1
            }
            if k % 11 == 0 {
                ray.dir.y = 0.0;
            }
            let pre = RayPrecomp::new(&ray);
            let packet = Tri4::pack(&tris);
            let (mask, t, u, v) = packet.intersect(&pre);
            for (lane, (corners, _)) in tris.iter().enumerate() {
                let scalar = pre.intersect(corners[0], corners[1], corners[2]);
                let packed = (mask & (1 << lane) != 0).then(|| (t[lane], u[lane], v[lane]));
                let bits = |h: Option<(f32, f32, f32)>| h.map(|(t, u, v)| (t.to_bits(), u.to_bits(), v.to_bits()));
                assert_eq!(bits(packed), bits(scalar), "case {k} lane {lane}");
                n_hits += usize::from(scalar.is_some());
            }
            n_redo += usize::from(k % 3 == 0);
            assert_eq!(mask & !packet.used_mask(), 0, "unused lanes never hit");
        }
        assert!(n_hits > 5000 && n_redo > 1000, "{n_hits} {n_redo}");
    }
}
