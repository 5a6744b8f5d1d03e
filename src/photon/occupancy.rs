//! The occupancy grid of a photon map: one bit per cell of a uniform grid whose cells are at least the
//! search radius wide, set for every cell next to (or holding) a photon. A query point whose cell's bit
//! is clear has no photon within the search radius, so the density estimate there is empty and costs one
//! memory read instead of a k-NN descent (issue 9: a surface no caustic reaches).
//!
//! Why one bit suffices: with cells of side `c ≥ r`, a photon within `r` of `q` lies in `q`'s cell or in
//! one of its 26 neighbours, so marking the 3×3×3 block around each photon's cell marks every cell from
//! which it can be found. `c` is `r` plus 1% (rounding of the cell indices is far below that), or larger
//! when the grid would exceed [`MAX_CELLS_PER_AXIS`] cells along an axis.
//!
//! Each marked cell also keeps the list of the kd-tree's leaves that may hold a photon within `r` of a
//! point of the cell (leaf boxes within `r` of the cell's box, plus a margin for rounding;
//! [`KdTree::leaves_near_box`]), when there are at most [`MAX_LEAVES_PER_CELL`]: a query there scans those
//! leaves ([`crate::photon::SearchFrom::Leaves`]) instead of walking the tree from its root. Where photons
//! are sparse (most of `cornell-caustics`: a query finds fewer than k within `r`, so the walk covers the
//! whole search disk, ~20 nodes for ~3 leaves) that is a few box tests instead of a descent.
//!
//! Where lists are kept, each marked cell also keeps the summed power of the photons in its 3×3×3 block and
//! the box their arrival directions lie in ([`OccupancyGrid::photons_near`]): the bound on a density
//! estimate from which the eye path decides whether to make it (method.md §3.1).

use super::dirbox::DirBox;
use super::{KdTree, SearchFrom};
use crate::math::Vec3;

/// Leaves per cell at most in a cell's list; a cell near more leaves (a dense caustic, where the warm-started
/// walk from the root prunes well) keeps none and its queries walk the tree.
const MAX_LEAVES_PER_CELL: usize = 24;

/// Marked cells per photon at most for the lists to be built (a sparse map spread over many cells keeps
/// none: every query walks the tree), and list entries per photon at most (later cells keep none). So the
/// lists hold at most 2·16 + 6·4 = [`LIST_BYTES_PER_PHOTON`] bytes per photon, and their build (one bounded
/// tree walk per marked cell) stays proportional to the photons.
const MAX_MARKED_PER_PHOTON: usize = 2;
const MAX_LIST_ENTRIES_PER_PHOTON: usize = 6;

/// The lists' largest memory per stored photon (`render::memory` counts it).
pub const LIST_BYTES_PER_PHOTON: usize = MAX_MARKED_PER_PHOTON * size_of::<CellList>() + MAX_LIST_ENTRIES_PER_PHOTON * size_of::<u32>();

/// What a query point's cell says about the search ([`OccupancyGrid::near`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Near<'a> {
    /// No photon lies within the radius: the estimate is empty.
    Empty,
    /// Search from these leaves (every leaf with a photon within the radius is among them).
    Leaves(&'a [u32]),
    /// Search from the root.
    Tree,
}

impl<'a> Near<'a> {
    /// Where the search starts (`Empty` searches nothing: an empty list).
    #[must_use]
    pub fn search_from(self) -> SearchFrom<'a> {
        match self {
            Near::Empty => SearchFrom::Leaves(&[]),
            Near::Leaves(ids) => SearchFrom::Leaves(ids),
            Near::Tree => SearchFrom::Root,
        }
    }
}

/// Where a query point falls in the grid ([`OccupancyGrid::cell_at`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellAt {
    /// The point is not finite: the search decides, as without a grid.
    NotFinite,
    /// Outside the grid or in an unmarked cell: no photon within the radius.
    Empty,
    /// A marked cell of a grid that keeps no lists (too many marked cells).
    NoList,
    /// A marked cell, by its rank among the marked cells (its index in the lists).
    Listed(u32),
}

/// A marked cell's leaves: `leaf_ids[start .. start + len]`, or `len == NO_LIST` (walk the tree); and what
/// the photons in the 3×3×3 cells around it (every photon within the radius of a point of the cell is among
/// them: [`OccupancyGrid::photons_near`]) hold: `power`, the largest RGB channel of their summed power,
/// `count`, their number (saturating), and `dirs`, the box of their arrival directions. 16 bytes (checked
/// below).
#[derive(Clone, Copy, Debug)]
struct CellList {
    start: u32,
    power: f32,
    dirs: DirBox,
    len: u8,
    count: u8,
}

const _: () = assert!(size_of::<CellList>() == 16 && MAX_LEAVES_PER_CELL < NO_LIST as usize);

/// What may lie within the search radius of a point ([`OccupancyGrid::photons_near`]): the photons of the
/// 3×3×3 cells around it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonsNear {
    /// The largest RGB channel of their summed power (0: none).
    pub power: f32,
    /// Their number, saturating at `u8::MAX`.
    pub count: u8,
    /// A box holding their arrival directions ωₚ ([`DirBox::EMPTY`] when there are none).
    pub dirs: DirBox,
}

impl PhotonsNear {
    /// Whether fewer than `k` photons lie there (then a k-NN search within the radius finds fewer than `k`).
    #[must_use]
    pub fn fewer_than(&self, k: usize) -> bool {
        self.count < u8::MAX && usize::from(self.count) < k
    }
}

const NO_LIST: u8 = u8::MAX;

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
    /// Per word of `bits`: the marked cells before it (a marked cell's rank indexes `lists`); empty when
    /// no lists were built.
    rank: Vec<u32>,
    /// Per marked cell, in index order.
    lists: Vec<CellList>,
    leaf_ids: Vec<u32>,
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
        let words = (dims[0] * dims[1] * dims[2]).div_ceil(64);
        let mut grid = OccupancyGrid { origin, inv_cell: 1.0 / cell, dims, bits: vec![0; words], rank: Vec::new(), lists: Vec::new(), leaf_ids: Vec::new() };
        for p in tree.photons() {
            for i in grid.block_around(p.position()) {
                grid.bits[i / 64] |= 1 << (i % 64);
            }
        }
        grid.build_lists(tree, radius, cell);
        grid.add_sums(tree);
        Some(grid)
    }

    /// The marked cells' leaf lists (module docs). A cell's box is `origin + c·[i, i + 1]` per axis; a
    /// query assigned to it by [`OccupancyGrid::cell`] may lie outside by the rounding of that assignment,
    /// and a photon at f32 distance ≤ r may lie a little farther, so the reach is `1.01·r` plus 16 ulps of
    /// the largest coordinate of the grid (each error is a few ulps of the coordinates involved, and a few
    /// 10⁻⁷ of r).
    fn build_lists(&mut self, tree: &KdTree, radius: f32, cell: f32) {
        let far = self.origin.abs().max((self.origin + Vec3::from_array(self.dims.map(|d| d as f32)) * cell).abs()).max_element();
        let reach = 1.01 * radius + 16.0 * f32::EPSILON * far;
        let mut marked = 0u32;
        self.rank = self
            .bits
            .iter()
            .map(|w| {
                let before = marked;
                marked += w.count_ones();
                before
            })
            .collect();
        if marked as usize > MAX_MARKED_PER_PHOTON * tree.len() {
            self.rank.clear();
            return;
        }
        self.lists.reserve(marked as usize);
        let mut ids = Vec::new();
        for (w, &word) in self.bits.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                let i = w * 64 + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let (x, y, z) = (i % self.dims[0], (i / self.dims[0]) % self.dims[1], i / (self.dims[0] * self.dims[1]));
                let lo = Vec3::new(x as f32, y as f32, z as f32);
                let (min, max) = (self.origin + lo * cell, self.origin + (lo + Vec3::ONE) * cell);
                ids.clear();
                let room = self.leaf_ids.len() + MAX_LEAVES_PER_CELL <= MAX_LIST_ENTRIES_PER_PHOTON * tree.len();
                let list = if room && tree.leaves_near_box(min, max, reach, MAX_LEAVES_PER_CELL, &mut ids) {
                    let start = self.leaf_ids.len() as u32;
                    self.leaf_ids.extend_from_slice(&ids);
                    CellList { start, len: ids.len() as u8, power: 0.0, dirs: DirBox::EMPTY, count: 0 }
                } else {
                    CellList { start: 0, len: NO_LIST, power: 0.0, dirs: DirBox::EMPTY, count: 0 }
                };
                self.lists.push(list);
            }
        }
    }

    /// Adds each photon's power, count and direction to the 27 cells its own cell's block marked (only where
    /// lists were built).
    fn add_sums(&mut self, tree: &KdTree) {
        if self.rank.is_empty() {
            return;
        }
        let mut sums = vec![(Vec3::ZERO, 0u8, Vec3::INFINITY, Vec3::NEG_INFINITY); self.lists.len()];
        for (p, d) in tree.photons().iter().zip(tree.decoded()) {
            for r in self.block_around(p.position()).filter_map(|i| self.rank_of(i)) {
                let (power, count, lo, hi) = &mut sums[r];
                *power += d.power;
                *count = count.saturating_add(1);
                *lo = lo.min(d.wi);
                *hi = hi.max(d.wi);
            }
        }
        for (list, (power, count, lo, hi)) in self.lists.iter_mut().zip(sums) {
            (list.power, list.count, list.dirs) = (power.max_element(), count, DirBox::new(lo, hi));
        }
    }

    /// The indices of the 3×3×3 cells around `p`'s cell that lie in the grid (none for a point below its
    /// origin): the cells from which a photon at `p` can be found.
    fn block_around(&self, p: Vec3) -> impl Iterator<Item = usize> + use<> {
        let (c, dims) = (self.cell(p), self.dims);
        (0..27usize).filter_map(move |n| {
            let c = c?;
            index_in(dims, [c[0] + n % 3, c[1] + n / 3 % 3, c[2] + n / 9].map(|v| v.wrapping_sub(1)))
        })
    }

    /// The rank of marked cell `i` among the marked cells (its index in `lists`).
    #[inline]
    fn rank_of(&self, i: usize) -> Option<usize> {
        let (w, b) = (i / 64, i % 64);
        let word = self.bits[w];
        (word & (1 << b) != 0 && !self.rank.is_empty()).then(|| self.rank[w] as usize + (word & ((1u64 << b) - 1)).count_ones() as usize)
    }

    /// Where `p` falls in the grid, found once per query point: [`OccupancyGrid::near_in`] and
    /// [`OccupancyGrid::photons_in`] read it.
    #[inline]
    #[must_use]
    pub fn cell_at(&self, p: Vec3) -> CellAt {
        if !p.is_finite() {
            return CellAt::NotFinite;
        }
        // Outside the grid: more than one cell (≥ the radius) from every photon.
        let Some(i) = self.cell(p).and_then(|c| self.index(c)) else { return CellAt::Empty };
        if self.bits[i / 64] & (1 << (i % 64)) == 0 {
            return CellAt::Empty;
        }
        // No rank: no lists (too many marked cells).
        self.rank_of(i).map_or(CellAt::NoList, |r| CellAt::Listed(r as u32))
    }

    /// The photons that may lie within the radius of a point in `cell` (a bound: those of the 3×3×3 cells
    /// around it): their power, number and the box of their directions, power 0 where none does; `None`
    /// where the grid keeps no sums (no lists were built) or the point is not finite.
    #[inline]
    #[must_use]
    pub fn photons_in(&self, cell: CellAt) -> Option<PhotonsNear> {
        let none = PhotonsNear { power: 0.0, count: 0, dirs: DirBox::EMPTY };
        match cell {
            CellAt::NotFinite | CellAt::NoList => None,
            _ if self.rank.is_empty() => None,
            CellAt::Empty => Some(none),
            CellAt::Listed(r) => {
                let list = &self.lists[r as usize];
                Some(PhotonsNear { power: list.power, count: list.count, dirs: list.dirs })
            }
        }
    }

    /// [`OccupancyGrid::photons_in`] the cell of `p`.
    #[inline]
    #[must_use]
    pub fn photons_near(&self, p: Vec3) -> Option<PhotonsNear> {
        self.photons_in(self.cell_at(p))
    }

    /// Where the search for the photons within the radius of a point in `cell` starts (module docs):
    /// nowhere (no photon within reach), from a list of leaves, or from the root (a non-finite point too).
    #[inline]
    #[must_use]
    pub fn near_in(&self, cell: CellAt) -> Near<'_> {
        match cell {
            CellAt::NotFinite | CellAt::NoList => Near::Tree,
            CellAt::Empty => Near::Empty,
            CellAt::Listed(r) => {
                let list = self.lists[r as usize];
                if list.len == NO_LIST {
                    Near::Tree
                } else {
                    Near::Leaves(&self.leaf_ids[list.start as usize..list.start as usize + usize::from(list.len)])
                }
            }
        }
    }

    /// [`OccupancyGrid::near_in`] the cell of `p`.
    #[inline]
    #[must_use]
    pub fn near(&self, p: Vec3) -> Near<'_> {
        self.near_in(self.cell_at(p))
    }

    /// Whether a photon may lie within the radius of `p`: false only when none does. A non-finite `p` gives
    /// true (the search decides, as without a grid).
    #[inline]
    #[must_use]
    pub fn may_hold_photons_near(&self, p: Vec3) -> bool {
        self.near(p) != Near::Empty
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
        index_in(self.dims, c)
    }
}

/// The index of cell `c` in a grid of `dims` cells (x fastest), `None` outside it.
#[inline]
fn index_in(dims: [usize; 3], c: [usize; 3]) -> Option<usize> {
    (c[0] < dims[0] && c[1] < dims[1] && c[2] < dims[2]).then(|| (c[2] * dims[1] + c[1]) * dims[0] + c[0])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::dirbox::DIR_STEPS;
    use crate::photon::kdtree::{KnnMemory, KnnResult};
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

    /// `photons_near` bounds the photon power within the radius (the largest RGB channel of the brute-force
    /// sum of the photons within it, for a grid that keeps lists) and its box holds their directions; the
    /// power is 0 where no photon lies in the 3×3×3 cells around the point, and no more than the whole map's
    /// power; without lists it is `None`.
    #[test]
    fn photons_near_bounds_the_photons_within_the_radius() {
        let mut s = Sampler::for_key(13, 0, 0);
        // A dense spot of red photons from one direction beside a sparse layer of blue ones from all over the
        // upper hemisphere, on a plane.
        let red = Vec3::new(0.6, 0.8, 0.0);
        let photons: Vec<Photon> = (0..4000)
            .map(|i| {
                let u = s.next_2d();
                if i % 4 == 0 {
                    Photon::new(Vec3::new(2.6 + 0.2 * u.x, 0.0, 0.2 * u.y), red, Vec3::new(2.0, 0.1, 0.0), 1.0)
                } else {
                    let w = crate::sampling::warp::square_to_cosine_hemisphere(s.next_2d());
                    Photon::new(Vec3::new(4.0 * u.x - 2.0, 0.0, 4.0 * u.y - 2.0), Vec3::new(w.x, w.z, w.y), Vec3::new(0.0, 0.0, 0.5), 1.0)
                }
            })
            .collect();
        let total: Vec3 = photons.iter().map(|p| p.power()).sum();
        let tree = KdTree::build(photons.clone()).unwrap();
        let radius = 0.1;
        let grid = OccupancyGrid::new(&tree, radius).unwrap();
        let (mut tight, mut zero, mut narrow) = (0, 0, 0);
        for _ in 0..5000 {
            let q = Vec3::new(6.0 * s.next_1d() - 3.0, 0.2 * s.next_1d() - 0.1, 6.0 * s.next_1d() - 3.0);
            let near: Vec<&Photon> = photons.iter().filter(|p| p.position().distance_squared(q) <= radius * radius).collect();
            let within: Vec3 = near.iter().map(|p| p.power()).sum();
            let bound = grid.photons_near(q).expect("lists were built");
            assert!(usize::from(bound.count) >= near.len().min(255), "{q}: count {} below the {} photons within the radius", bound.count, near.len());
            assert!(bound.power >= within.max_element() * (1.0 - 1e-5), "{q}: bound {} below the power within the radius {within}", bound.power);
            assert!(bound.power <= total.max_element() * (1.0 + 1e-5), "{q}: bound {} above the map's power", bound.power);
            for p in &near {
                let w = p.wi_world();
                let inside = w.cmpge(bound.dirs.min() - Vec3::splat(1e-6)).all() && w.cmple(bound.dirs.max() + Vec3::splat(1e-6)).all();
                assert!(inside, "{q}: direction {w} outside [{}, {}]", bound.dirs.min(), bound.dirs.max());
            }
            if bound.power == 0.0 {
                zero += 1;
                assert_eq!(grid.near(q), Near::Empty, "{q}: no power but photons may be near");
            } else if bound.power <= 12.0 * within.max_element() {
                tight += 1;
            }
            // Beyond the blue layer (x ≤ 2) by more than two cells, the box is the red spot's one direction,
            // rounded outward by at most a step.
            if q.x > 2.35 && bound.power > 0.0 {
                narrow += 1;
                let red = photons[0].wi_world();
                let (lo, hi) = (red - bound.dirs.min(), bound.dirs.max() - red);
                assert!(lo.min(hi).min_element() >= -1e-6 && lo.max(hi).max_element() <= 1.0 / DIR_STEPS, "{q}: [{}, {}] for {red}", bound.dirs.min(), bound.dirs.max());
            }
        }
        // The bound is a local figure, not the map's power: queries outside the layer see 0, and most
        // inside it see a sum over a few cells (a 3×3 block of cells is 9/π the search disk's area).
        assert!(zero > 500 && tight > 1500 && narrow > 10, "{zero} queries with no power, {tight} with a bound within 12× the power in reach, {narrow} near the red spot");
        // Without lists (more than 2 marked cells per photon: a sparse cloud), no sums.
        let sparse: Vec<Photon> = (0..200).map(|_| Photon::new(Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 50.0, Vec3::Y, Vec3::ONE, 1.0)).collect();
        let sparse_grid = OccupancyGrid::new(&KdTree::build(sparse).unwrap(), 0.5).unwrap();
        assert_eq!(sparse_grid.photons_near(Vec3::splat(25.0)), None);
    }

    /// A search from the cell's leaves ([`OccupancyGrid::near`]) finds the k-NN of the search from the root:
    /// sparse and dense photons (so that both lists and the tree's fallback are used), far from the origin
    /// (rounding of the cell assignment against a small radius), with the acceptance test inside.
    #[test]
    fn searches_from_cell_leaves_are_exact() {
        let mut s = Sampler::for_key(12, 0, 0);
        for (offset, radius) in [(Vec3::ZERO, 0.1f32), (Vec3::new(2000.0, -1500.0, 700.0), 0.003), (Vec3::ZERO, 0.5)] {
            let scale = radius / 0.1;
            let mut photons = Vec::new();
            // A sparse layer on a plane, a dense spot in it, and a sparse cloud above it (sparse enough that the
            // grid keeps lists: at most 2 marked cells per photon).
            for i in 0..6000 {
                let p = match i % 20 {
                    0 => Vec3::new(4.0 * s.next_1d() - 2.0, 0.3 * s.next_1d(), 4.0 * s.next_1d() - 2.0),
                    1..=7 => Vec3::new(0.1 * s.next_1d(), 0.0, 0.1 * s.next_1d()),
                    _ => Vec3::new(4.0 * s.next_1d() - 2.0, 0.0, 4.0 * s.next_1d() - 2.0),
                };
                let w = if s.next_1d() < 0.5 { Vec3::Y } else { -Vec3::Y };
                photons.push(Photon::new(offset + p * scale, w, Vec3::ONE, 1.0));
            }
            let tree = KdTree::build(photons).unwrap();
            let grid = OccupancyGrid::new(&tree, radius).unwrap();
            let dirs = tree.decoded();
            let (mut from_cell, mut from_root, mut memory) = (KnnResult::default(), KnnResult::default(), KnnMemory::default());
            let (mut lists, mut walks) = (0, 0);
            for i in 0..20_000 {
                let q = Vec3::new(4.4 * s.next_1d() - 2.2, 2.4 * s.next_1d() - 0.2, 4.4 * s.next_1d() - 2.2);
                // Half the queries near the plane, where the photons are.
                let q = offset + scale * if i % 2 == 0 { Vec3::new(q.x, 0.02 * q.y, q.z) } else { Vec3::new(q.x, 0.2 * q.y, q.z) };
                let above = i % 3 != 0;
                let accept = move |j: usize| (dirs[j].wi.y > 0.0) == above;
                let k = if i % 5 == 0 { 4 } else { 50 };
                let near = grid.near(q);
                match near {
                    Near::Leaves(_) => lists += 1,
                    Near::Tree => walks += 1,
                    Near::Empty => {}
                }
                tree.knn_warm_from(q, k, radius, u64::from(above), near.search_from(), accept, &mut memory, &mut from_cell);
                tree.knn_by_index(q, k, radius, accept, &mut from_root);
                let sorted = |o: &KnnResult| {
                    let mut d: Vec<u32> = o.neighbors().iter().map(|n| n.dist2.to_bits()).collect();
                    d.sort_unstable();
                    d
                };
                assert_eq!(from_cell.r2().to_bits(), from_root.r2().to_bits(), "radius {radius}, query {i} {q}");
                assert_eq!(sorted(&from_cell), sorted(&from_root), "radius {radius}, query {i} {q}");
            }
            assert!(lists > 1000 && walks > 100, "radius {radius}: {lists} searches from lists, {walks} from the root");
        }
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
