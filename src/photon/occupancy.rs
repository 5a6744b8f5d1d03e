//! The occupancy grid of a photon map: one bit per cell of a uniform grid whose cells are at least the
//! search radius wide, set for every cell next to (or holding) a photon. A query point whose cell's bit
//! is clear has no photon within the search radius, so the density estimate there is empty and costs one
//! memory read instead of a k-NN descent (issue 9: a surface no caustic reaches).
//!
//! Why one bit suffices: with cells of side `c ≥ r`, a photon within `r` of `q` lies in `q`'s cell or in
//! one of its 26 neighbours, so marking the 3×3×3 block around each photon's cell marks every cell from
//! which it can be found. `c` is `r` plus 1% (rounding of the cell indices is far below that), or larger
//! when the grid would exceed [`MAX_CELLS_PER_AXIS`] cells along an axis.

use super::KdTree;
use crate::math::Vec3;

/// Cells per axis at most (128³ bits = 256 KiB); beyond it the cells grow (the test stays exact, only
/// coarser).
const MAX_CELLS_PER_AXIS: f32 = 128.0;

/// Occupancy bits over the photons' bounding box plus one cell of margin on every side.
#[derive(Clone, Debug)]
pub struct OccupancyGrid {
    origin: Vec3,
    inv_cell: f32,
    dims: [usize; 3],
    bits: Vec<u64>,
}

impl OccupancyGrid {
    /// The grid of `tree`'s photons for searches of radius `radius`; `None` for an empty map or a radius
    /// that is not finite and positive (then every query searches).
    #[must_use]
    pub fn new(tree: &KdTree, radius: f32) -> Option<Self> {
        if tree.is_empty() || !radius.is_finite() || radius <= 0.0 {
            return None;
        }
        let bounds = tree.bounds();
        let extent = bounds.max - bounds.min;
        let cell = (radius * 1.01).max(extent.max_element() / MAX_CELLS_PER_AXIS);
        if !cell.is_finite() || cell <= 0.0 {
            return None;
        }
        let origin = bounds.min - Vec3::splat(cell);
        // Photons land in cells 1 ..= ⌊extent/c⌋ + 1 (rounding may add one), so +4 leaves room for the
        // marked neighbours on both sides.
        let dims = extent.to_array().map(|e| (e / cell) as usize + 4);
        let mut grid = OccupancyGrid { origin, inv_cell: 1.0 / cell, dims, bits: vec![0; (dims[0] * dims[1] * dims[2]).div_ceil(64)] };
        for p in tree.photons() {
            let Some(c) = grid.cell(p.position()) else { continue };
            for dz in 0..3 {
                for dy in 0..3 {
                    for dx in 0..3 {
                        if let Some(i) = grid.index([c[0] + dx, c[1] + dy, c[2] + dz].map(|v| v.wrapping_sub(1))) {
                            grid.bits[i / 64] |= 1 << (i % 64);
                        }
                    }
                }
            }
        }
        Some(grid)
    }

    /// Whether a photon may lie within the radius of `p`: false only when none does. A non-finite `p` gives
    /// true (the search decides, as without a grid).
    #[inline]
    #[must_use]
    pub fn may_hold_photons_near(&self, p: Vec3) -> bool {
        if !p.is_finite() {
            return true;
        }
        match self.cell(p).and_then(|c| self.index(c)) {
            Some(i) => self.bits[i / 64] & (1 << (i % 64)) != 0,
            // Outside the grid: more than one cell (≥ the radius) from every photon.
            None => false,
        }
    }

    /// The cell of `p` (coordinates may lie outside the grid), `None` below the origin.
    #[inline]
    fn cell(&self, p: Vec3) -> Option<[usize; 3]> {
        let c = (p - self.origin) * self.inv_cell;
        if c.min_element() < 0.0 {
            return None;
        }
        // Saturating float → int casts: a point far beyond the grid gives a large index, refused by `index`.
        Some(c.to_array().map(|v| v as usize))
    }

    #[inline]
    fn index(&self, c: [usize; 3]) -> Option<usize> {
        if c[0] < self.dims[0] && c[1] < self.dims[1] && c[2] < self.dims[2] {
            Some((c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0])
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::kdtree::KnnResult;
    use crate::photon::Photon;
    use crate::sampler::Sampler;

    /// Wherever a brute-force scan finds a photon within the radius, the grid says "may"; and most points
    /// far from the photons are cleared.
    #[test]
    fn never_clears_a_cell_with_a_photon_in_reach() {
        let mut s = Sampler::for_key(11, 0, 0);
        // Two clusters on a plane and one lone photon.
        let mut photons = Vec::new();
        for i in 0..2000 {
            let c = if i % 2 == 0 { Vec3::new(-3.0, 0.0, 0.0) } else { Vec3::new(2.0, 0.0, 1.0) };
            photons.push(Photon::new(c + Vec3::new(s.next_1d() - 0.5, 0.0, s.next_1d() - 0.5), Vec3::Y, Vec3::ONE, 1.0));
        }
        photons.push(Photon::new(Vec3::new(0.0, 4.0, 0.0), Vec3::Y, Vec3::ONE, 1.0));
        let tree = KdTree::build(photons).unwrap();
        let mut out = KnnResult::default();
        for radius in [0.01f32, 0.1, 0.37, 2.0] {
            let grid = OccupancyGrid::new(&tree, radius).unwrap();
            let (mut cleared, mut far) = (0, 0);
            for _ in 0..20_000 {
                let q = Vec3::new(12.0 * s.next_1d() - 6.0, 6.0 * s.next_1d() - 1.0, 6.0 * s.next_1d() - 3.0);
                tree.knn(q, 1, radius, |_| true, &mut out);
                let may = grid.may_hold_photons_near(q);
                assert!(may || out.is_empty(), "radius {radius}: {q} cleared with a photon in reach");
                if out.is_empty() {
                    far += 1;
                    cleared += usize::from(!may);
                }
            }
            // Small radii (cells much smaller than the clusters' gaps) clear most empty queries; at r = 2
            // the 3×3×3 blocks of 2-unit cells cover most of the domain, and some are still cleared.
            let share = if radius < 1.0 { 0.5 } else { 0.2 };
            assert!(cleared as f64 > share * far as f64, "radius {radius}: only {cleared} of {far} empty queries cleared");
        }
        assert!(OccupancyGrid::new(&tree, f32::INFINITY).is_none());
        assert!(OccupancyGrid::new(&tree, 0.0).is_none());
        assert!(OccupancyGrid::new(&KdTree::build(Vec::new()).unwrap(), 1.0).is_none());
    }

    /// Photons exactly one radius away along an axis (and diagonally) are within reach of a "may" cell.
    #[test]
    fn photons_exactly_one_radius_away() {
        let r = 0.25f32;
        let tree = KdTree::build(vec![Photon::new(Vec3::ZERO, Vec3::Z, Vec3::ONE, 1.0), Photon::new(Vec3::splat(10.0), Vec3::Z, Vec3::ONE, 1.0)]).unwrap();
        let grid = OccupancyGrid::new(&tree, r).unwrap();
        for q in [Vec3::new(r, 0.0, 0.0), Vec3::new(-r, 0.0, 0.0), Vec3::new(0.0, 0.0, -r), Vec3::splat(r / 3f32.sqrt()), Vec3::splat(10.0 + r / 3f32.sqrt())] {
            assert!(grid.may_hold_photons_near(q), "{q}");
        }
        assert!(!grid.may_hold_photons_near(Vec3::splat(5.0)));
        assert!(!grid.may_hold_photons_near(Vec3::splat(-50.0)));
        assert!(!grid.may_hold_photons_near(Vec3::splat(1e30)));
        assert!(grid.may_hold_photons_near(Vec3::new(f32::NAN, 0.0, 0.0)));
    }
}
