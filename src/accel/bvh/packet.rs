//! Leaf triangles in packets of four (structure of arrays), tested four at a time by the shared
//! watertight test (Woop, Benthin & Wald 2013) — *bit-identical* to
//! [`crate::accel::triangle::RayPrecomp::intersect`].
//!
//! Every lane performs the scalar test's IEEE operations in the scalar test's order (Rust never
//! contracts `a·b + c` into an FMA, and `1/det` is a correctly rounded division in both forms), so
//! `(t, u, v)` and the hit/miss decision agree bit for bit. The one branchy part of the scalar test,
//! the double-precision recomputation when a scaled barycentric is exactly zero (paper §4), is
//! delegated lane by lane to the scalar test itself. Unused lanes hold NaN corners and the
//! `prim` [`NO_PRIM`], and the caller masks them out ([`lanes_used`]).

use crate::accel::triangle::RayPrecomp;
use crate::math::{Vec3, Vec4};

/// Triangles per packet.
pub(super) const LANES: usize = 4;
/// `prim` of an unused lane.
pub(super) const NO_PRIM: u32 = u32::MAX;

/// The per-ray constants of [`RayPrecomp`] in the form the packet test wants: the axis
/// permutation as row indices and the origin (permuted), shear and `t_min` splatted.
pub(super) struct PacketRay {
    k: [usize; 3],
    origin: [Vec4; 3],
    shear: [Vec4; 3],
    t_min: Vec4,
}

impl PacketRay {
    #[must_use]
    pub fn new(pre: &RayPrecomp) -> Self {
        // `min(2)` only tells the compiler the indices are in range (`RayPrecomp` keeps them so).
        let k = [pre.kx, pre.ky, pre.kz].map(|i| i.min(2));
        let o = pre.origin.to_array();
        Self {
            k,
            origin: k.map(|i| Vec4::splat(o[i])),
            shear: [pre.sx, pre.sy, pre.sz].map(Vec4::splat),
            t_min: Vec4::splat(pre.t_min),
        }
    }
}

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
        let mut p = Tri4 {
            v: [[[f32::NAN; LANES]; 3]; 3],
            prim: [NO_PRIM; LANES],
        };
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
    #[cfg(test)]
    #[must_use]
    pub fn used_mask(&self) -> u32 {
        let mut m = 0u32;
        for i in 0..LANES {
            m |= u32::from(self.prim[i] != NO_PRIM) << i;
        }
        m
    }

    /// The watertight test on the lanes in `used` against `pre` (its `t_min`, `t_max`; `ray` holds
    /// the same constants splatted): the bit mask of the hit lanes and their `(t, u, v)`
    /// (meaningful for hit lanes only).
    #[inline(always)]
    #[must_use]
    pub fn intersect(&self, ray: &PacketRay, pre: &RayPrecomp, used: u32) -> (u32, [f32; LANES], [f32; LANES], [f32; LANES]) {
        let [kx, ky, kz] = ray.k;
        let [p0, p1, p2] = &self.v;
        // Rows in ray-permuted order (a pointer choice per row), then four lanes at once.
        let row = |r: &[f32; LANES]| Vec4::from_array(*r);
        let [ox, oy, oz] = ray.origin;
        let [sx, sy, sz] = ray.shear;
        // Same operations as `RayPrecomp::intersect`: a = p0 − o, then shear (paper §3).
        let (a_x, a_y, a_z) = (row(&p0[kx]) - ox, row(&p0[ky]) - oy, row(&p0[kz]) - oz);
        let (b_x, b_y, b_z) = (row(&p1[kx]) - ox, row(&p1[ky]) - oy, row(&p1[kz]) - oz);
        let (c_x, c_y, c_z) = (row(&p2[kx]) - ox, row(&p2[ky]) - oy, row(&p2[kz]) - oz);
        let ax = a_x - sx * a_z;
        let ay = a_y - sy * a_z;
        let bx = b_x - sx * b_z;
        let by = b_y - sy * b_z;
        let cx = c_x - sx * c_z;
        let cy = c_y - sy * c_z;
        let u_s = cx * by - cy * bx;
        let v_s = ax * cy - ay * cx;
        let w_s = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        let redo = (u_s.cmpeq(zero) | v_s.cmpeq(zero) | w_s.cmpeq(zero)).bitmask() & used;
        let outside = (u_s.cmplt(zero) | v_s.cmplt(zero) | w_s.cmplt(zero)) & (u_s.cmpgt(zero) | v_s.cmpgt(zero) | w_s.cmpgt(zero));
        let det = u_s + v_s + w_s;
        let inside = !outside & det.cmpne(zero);
        if (inside.bitmask() | redo) & used == 0 {
            // The common case in a leaf: the ray passes beside every triangle.
            return (0, [0.0; LANES], [0.0; LANES], [0.0; LANES]);
        }
        let t_scaled = u_s * (sz * a_z) + v_s * (sz * b_z) + w_s * (sz * c_z);
        let inv_det = Vec4::ONE / det;
        let t = t_scaled * inv_det;
        let hit = inside & t.cmpge(ray.t_min) & t.cmple(Vec4::splat(pre.t_max));
        let mut mask = hit.bitmask() & used;
        let (mut t, mut u, mut v) = (t.to_array(), (v_s * inv_det).to_array(), (w_s * inv_det).to_array());
        if redo != 0 {
            // A scaled barycentric is exactly zero: the scalar test's f64 path decides.
            let mut m = redo;
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
        (mask, t, u, v)
    }
}

/// The used-lane mask of packet `k` of a leaf with `count` triangles.
#[inline(always)]
#[must_use]
pub(super) fn lanes_used(count: u32, k: usize) -> u32 {
    let left = count as usize - k * LANES;
    if left >= LANES {
        (1 << LANES) - 1
    } else {
        (1 << left) - 1
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
            let mut tris: Vec<([Vec3; 3], u32)> = (0..1 + k as usize % LANES)
                .map(|i| ([0, 1, 2].map(|_| offset + random_vec(&mut s, scale)), i as u32 * 7))
                .collect();
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
            let (mask, t, u, v) = packet.intersect(&PacketRay::new(&pre), &pre, packet.used_mask());
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
