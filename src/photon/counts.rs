//! How many photons can lie within the search radius of a point: a summed-volume table (Crow 1984's
//! summed-area table in three dimensions) of the photon counts of a uniform grid finer than the
//! radius. The count of the cells that a cube of half-side `r` around `p` overlaps, eight reads, is at
//! least the number of photons within `r` of `p`.
//!
//! Why (method.md §3.1): the gather's roulette needs a bound on a density estimate before making it. The
//! occupancy grid's 3×3×3 cells of side ≥ `r` hold more than k photons around most of a path's later
//! vertices on `cornell-caustics`, where the search then finds fewer than k within `r` (so its area is
//! that of `r` and the photons it finds are few): measured at 4 spp, 92 k such vertices had no bound, and
//! for 58 % of them the cube of side 2.25·r (cells of `r/4`) held fewer than k photons, 74 % with 2.5·r.
//! Where the cube holds fewer than k, so does the ball, and the estimate's area is known: `π·r²`.
//!
//! The cells are `r/4` wide, or wider where that would exceed [`MAX_CELLS_PER_PHOTON`] cells per
//! stored photon (plus [`MIN_CELLS`]), and no table is built when they would be wider than `r`
//! (the cube would be no smaller than the occupancy grid's block). Counts are exact integers, so the
//! table's differences are exact (wrapping `u32` arithmetic: a count never exceeds the photons).

use super::KdTree;
use crate::math::Vec3;

/// Cells of the table per stored photon at most (4 B each: 32 B per photon, which `render::memory`
/// counts), beyond [`MIN_CELLS`]; the zero planes count.
pub const MAX_CELLS_PER_PHOTON: usize = 8;

/// Cells a table may always have (256 KiB), so that small maps still get a fine grid.
const MIN_CELLS: usize = 1 << 16;

/// A summed-volume table of photon counts (module docs).
#[derive(Clone, Debug)]
pub struct PhotonCounts {
    /// The corner of cell (0, 0, 0).
    origin: Vec3,
    inv_cell: f32,
    /// Cells per axis.
    dims: [usize; 3],
    /// `sums[(z·(dy+1) + y)·(dx+1) + x]`: the photons in the cells `[0, x) × [0, y) × [0, z)`.
    sums: Vec<u32>,
    /// How far from a query point its cube reaches: the radius plus margins for the rounding of cell
    /// indices and of distances.
    reach: f32,
    /// The largest RGB channel of any one photon's power: `n` photons carry at most `n` times it.
    max_power: f32,
}

impl PhotonCounts {
    /// The table of `tree`'s photons for queries of radius `radius`; `None` for an empty map, a radius
    /// that is not positive and finite, or cells that would be wider than the radius (module docs).
    #[must_use]
    pub fn new(tree: &KdTree, radius: f32) -> Option<Self> {
        if tree.is_empty() || !(radius > 0.0 && radius.is_finite()) {
            return None;
        }
        let bounds = tree.bounds();
        let extent = bounds.max - bounds.min;
        let cells_allowed = MAX_CELLS_PER_PHOTON.saturating_mul(tree.len()).saturating_add(MIN_CELLS);
        // Photons land in cells 1 ..= ⌊extent/c⌋ + 1 (rounding may add one); the table has a zero plane in
        // front on each axis.
        let table_len = |cell: f32| {
            let dims = extent.to_array().map(|e| (e / cell) as usize + 3);
            let len = dims.iter().try_fold(1usize, |n, &d| n.checked_mul(d + 1));
            (dims, len)
        };
        // r/4, widened by 10 % steps until the table fits.
        let mut cell = radius / 4.0;
        let dims = loop {
            if !(cell.is_finite() && cell <= radius) {
                return None;
            }
            match table_len(cell) {
                (dims, Some(len)) if len <= cells_allowed => break dims,
                _ => cell *= 1.1,
            }
        };
        let origin = bounds.min - Vec3::splat(cell);
        let [dx, dy, dz] = dims;
        // Counts per cell at [x + 1, y + 1, z + 1] (the zero planes in front), then a prefix sum per axis.
        let (sx, sy) = (dx + 1, (dx + 1) * (dy + 1));
        let mut sums = vec![0u32; sy * (dz + 1)];
        let inv_cell = 1.0 / cell;
        for p in tree.photons() {
            let c = ((p.position() - origin) * inv_cell).to_array();
            let [x, y, z] = [0, 1, 2].map(|a| (c[a] as usize).min(dims[a] - 1) + 1);
            sums[z * sy + y * sx + x] += 1;
        }
        // Along x, then y, then z: the step back to the previous cell along that axis.
        for stride in [1, sx, sy] {
            for z in 1..=dz {
                for y in 1..=dy {
                    for x in 1..=dx {
                        let i = z * sy + y * sx + x;
                        sums[i] = sums[i].wrapping_add(sums[i - stride]);
                    }
                }
            }
        }
        // As the occupancy grid's lists: 1% of the radius and 16 ulps of the largest coordinate.
        let far = origin.abs().max((origin + Vec3::from_array(dims.map(|d| d as f32)) * cell).abs()).max_element();
        let reach = 1.01 * radius + 16.0 * f32::EPSILON * far;
        let max_power = tree.decoded().iter().fold(0.0f32, |m, d| m.max(d.power.max_element()));
        Some(PhotonCounts { origin, inv_cell, dims, sums, reach, max_power })
    }

    /// At least the number of photons within the radius of `p` (those of the cells the cube of half-side
    /// [`PhotonCounts::reach`] around `p` overlaps); `u32::MAX` for a point that is not finite.
    #[must_use]
    pub fn at_most_near(&self, p: Vec3) -> u32 {
        if !p.is_finite() {
            return u32::MAX;
        }
        // Cells [lo, hi) per axis, clamped to the grid (no photon lies outside it); saturating casts.
        let lo = ((p - Vec3::splat(self.reach) - self.origin) * self.inv_cell).to_array();
        let hi = ((p + Vec3::splat(self.reach) - self.origin) * self.inv_cell).to_array();
        let lo = [0, 1, 2].map(|a| (lo[a].max(0.0) as usize).min(self.dims[a]));
        let hi = [0, 1, 2].map(|a| ((hi[a].max(0.0) as usize).saturating_add(1)).min(self.dims[a]).max(lo[a]));
        let (sx, sy) = (self.dims[0] + 1, (self.dims[0] + 1) * (self.dims[1] + 1));
        let at = |x: usize, y: usize, z: usize| self.sums[z * sy + y * sx + x];
        let [x0, y0, z0] = lo;
        let [x1, y1, z1] = hi;
        // Inclusion–exclusion over the eight corners (exact in wrapping u32).
        at(x1, y1, z1)
            .wrapping_sub(at(x0, y1, z1))
            .wrapping_sub(at(x1, y0, z1))
            .wrapping_sub(at(x1, y1, z0))
            .wrapping_add(at(x0, y0, z1))
            .wrapping_add(at(x0, y1, z0))
            .wrapping_add(at(x1, y0, z0))
            .wrapping_sub(at(x0, y0, z0))
    }

    /// The largest RGB channel of one photon's power (so `n` photons hold at most `n` times it).
    #[must_use]
    pub fn max_power(&self) -> f32 {
        self.max_power
    }

    /// How far from a query point [`PhotonCounts::at_most_near`] counts (the radius plus margins).
    #[must_use]
    pub fn reach(&self) -> f32 {
        self.reach
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::Photon;
    use crate::sampler::Sampler;

    /// The count is at least the photons within the radius (brute force) and at most those within the
    /// cube the cells can reach (`reach` + one cell per side), on clustered and spread maps; far and
    /// non-finite points; the table stays within its cells.
    #[test]
    fn counts_bound_the_photons_within_the_radius() {
        for (m, spread) in [(3000u64, 1.0f32), (20_000, 0.05), (50, 2.0)] {
            let mut s = Sampler::for_key(31, m, 0);
            let photons: Vec<Photon> = (0..m)
                .map(|_| {
                    let c = if s.next_1d() < 0.5 { Vec3::ZERO } else { Vec3::new(3.0, 1.0, -2.0) };
                    let q = c + spread * Vec3::new(s.next_1d() - 0.5, s.next_1d() - 0.5, 0.2 * (s.next_1d() - 0.5));
                    Photon::new(q, Vec3::Z, Vec3::ONE, 1.0)
                })
                .collect();
            let tree = KdTree::build(photons).unwrap();
            let radius = 0.2;
            let counts = PhotonCounts::new(&tree, radius).expect("cells fit");
            let cell = 1.0 / counts.inv_cell;
            assert!(cell <= radius && counts.sums.len() <= MAX_CELLS_PER_PHOTON * m as usize + MIN_CELLS);
            for _ in 0..2000 {
                let p = tree.photons()[(s.next_1d() * m as f32) as usize].position() + 0.1 * Vec3::new(s.next_1d() - 0.5, s.next_1d() - 0.5, s.next_1d() - 0.5);
                let ball = tree.photons().iter().filter(|q| q.position().distance(p) <= radius).count() as u32;
                let cube = tree.photons().iter().filter(|q| (q.position() - p).abs().max_element() <= counts.reach() + 1.01 * cell).count() as u32;
                let n = counts.at_most_near(p);
                assert!(n >= ball && n <= cube, "{p}: {n} outside [{ball}, {cube}]");
            }
            assert_eq!(counts.at_most_near(Vec3::splat(1e30)), 0);
            assert_eq!(counts.at_most_near(Vec3::splat(-1e30)), 0);
            assert_eq!(counts.at_most_near(Vec3::new(f32::NAN, 0.0, 0.0)), u32::MAX);
        }
    }

    /// A radius so small that the cells allowed would be wider than it builds no table; so does an empty
    /// map or a radius that is not positive and finite.
    #[test]
    fn no_table_where_cells_would_be_wider_than_the_radius() {
        let photons = vec![Photon::new(Vec3::ZERO, Vec3::Z, Vec3::ONE, 1.0), Photon::new(Vec3::splat(1e4), Vec3::Z, Vec3::ONE, 1.0)];
        let tree = KdTree::build(photons).unwrap();
        assert!(PhotonCounts::new(&tree, 1e-3).is_none());
        assert!(PhotonCounts::new(&tree, 1e4).is_some());
        assert!(PhotonCounts::new(&tree, 0.0).is_none());
        assert!(PhotonCounts::new(&tree, f32::INFINITY).is_none());
        assert!(PhotonCounts::new(&KdTree::build(Vec::new()).unwrap(), 1.0).is_none());
    }
}
