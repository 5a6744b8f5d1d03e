//! A box that holds a set of photons' arrival directions ωₚ (world space), 6 bytes: each coordinate's
//! lower and upper bound in steps of 1/[`DIR_STEPS`], rounded outward. The gather's roulette (method.md §3.1)
//! evaluates the BSDF toward the direction of the box nearest ωₒ's mirror direction, where a glossy lobe
//! peaks: for a sharp lobe that is the difference between its peak and its value toward the photons.
//! Kept per occupancy cell ([`crate::photon::OccupancyGrid::photons_near`]) and per kd-tree leaf
//! ([`crate::photon::KdTree::bound_within`]). The steps (0.45° at worst) are far below the spread of the
//! directions a cell or a leaf gathers on the shipped scenes, and i8 keeps a box at 6 bytes instead of 24.

use crate::math::Vec3;

/// Steps per unit of a direction coordinate (i8: ±127).
pub const DIR_STEPS: f32 = 127.0;

/// x, y, z lower bounds, then upper bounds, in units of 1/[`DIR_STEPS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DirBox([i8; 6]);

impl DirBox {
    /// The box of no direction (min > max); [`DirBox::nearest`] is never asked of it.
    pub const EMPTY: DirBox = DirBox([127, 127, 127, -127, -127, -127]);

    /// The box `[lo, hi]` rounded outward (saturating casts: |ωₚ| ≤ 1 up to rounding).
    #[must_use]
    pub fn new(lo: Vec3, hi: Vec3) -> Self {
        let [lx, ly, lz] = lo.to_array().map(|v| (v * DIR_STEPS).floor() as i8);
        let [hx, hy, hz] = hi.to_array().map(|v| (v * DIR_STEPS).ceil() as i8);
        DirBox([lx, ly, lz, hx, hy, hz])
    }

    /// The box of `dirs` (EMPTY for none).
    #[must_use]
    pub fn of(dirs: impl IntoIterator<Item = Vec3>) -> Self {
        let (lo, hi) = dirs.into_iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), d| (lo.min(d), hi.max(d)));
        if lo.x > hi.x {
            Self::EMPTY
        } else {
            Self::new(lo, hi)
        }
    }

    #[must_use]
    pub fn min(&self) -> Vec3 {
        Vec3::new(f32::from(self.0[0]), f32::from(self.0[1]), f32::from(self.0[2])) / DIR_STEPS
    }

    #[must_use]
    pub fn max(&self) -> Vec3 {
        Vec3::new(f32::from(self.0[3]), f32::from(self.0[4]), f32::from(self.0[5])) / DIR_STEPS
    }

    /// The point of the box nearest `v` (not normalised; the box's own corner may lie inside the sphere).
    #[inline]
    #[must_use]
    pub fn nearest(&self, v: Vec3) -> Vec3 {
        v.clamp(self.min(), self.max())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;
    use crate::sampling::warp::square_to_uniform_sphere;

    /// The box holds every direction it was made of, is at most a step wider than their bounds on each
    /// side, and its nearest point to a direction inside it is that direction.
    #[test]
    fn holds_its_directions_and_is_tight() {
        let mut s = Sampler::for_key(31, 0, 0);
        for n in [1usize, 2, 10, 200] {
            let dirs: Vec<Vec3> = (0..n).map(|_| (Vec3::new(0.3, 0.9, -0.2) + 0.2 * square_to_uniform_sphere(s.next_2d())).normalize()).collect();
            let b = DirBox::of(dirs.iter().copied());
            let (lo, hi) = dirs.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), d| (lo.min(*d), hi.max(*d)));
            assert!(b.min().cmple(lo).all() && b.max().cmpge(hi).all(), "{n}: [{}, {}] misses [{lo}, {hi}]", b.min(), b.max());
            assert!((lo - b.min()).max_element() <= 1.0 / DIR_STEPS && (b.max() - hi).max_element() <= 1.0 / DIR_STEPS);
            for d in &dirs {
                assert_eq!(b.nearest(*d), *d);
            }
        }
        // Unit coordinates saturate to ±1, not past them.
        let axis = DirBox::of([Vec3::X, -Vec3::X]);
        assert_eq!((axis.min().x, axis.max().x), (-1.0, 1.0));
        assert_eq!(DirBox::of([]), DirBox::EMPTY);
    }
}
