//! The binary binned-SAH builder (Wald 2007, "On fast Construction of SAH-based Bounding Volume
//! Hierarchies"), parallel over subtrees with `rayon::join`.
//!
//! The builder sees only primitive boxes ([`PrimRef`]); it reorders them in place so that every leaf
//! owns a contiguous range, and returns a pointer tree ([`BuildNode`]) that [`super::wide`] collapses
//! into the flattened wide node array. Degenerate input is handled explicitly:
//! all centroids equal (no axis to bin along) → leaf if small enough, otherwise an index-median split;
//! no split with two non-empty sides (float corner cases) or recursion deeper than [`MAX_SAH_DEPTH`]
//! → object-median split along the widest centroid axis, which bounds the depth by
//! `MAX_SAH_DEPTH + log2(n)`. SAH costs are evaluated in f32 with empty boxes counted as area 0;
//! areas that overflow (coordinates beyond ~1e19) make every split infinitely expensive and fall
//! back to the median split, never to NaN.

use glam::Vec3A;
use rayon::prelude::*;

use crate::math::Aabb;

/// Number of bins per axis of the SAH sweep.
pub(super) const BINS: usize = 16;
/// Maximum number of triangles in a leaf.
pub const MAX_LEAF: usize = 8;
/// SAH cost of one node traversal relative to the test of one packet of [`PACKET`] triangles
/// (which costs the same whether 1 or 4 of its lanes are used, so leaf costs count packets, as
/// Embree's builders count blocks).
const TRAVERSAL_COST: f32 = 2.0;
/// Triangles tested together in a leaf.
const PACKET: f32 = 4.0;

/// Packets needed for `n` triangles (`n` holds exact small integers).
#[inline]
fn packets(n: Vec3A) -> Vec3A {
    ((n + Vec3A::splat(PACKET - 1.0)) * (1.0 / PACKET)).floor()
}
/// Below this depth the split is chosen by SAH; deeper nodes are split at the object median so
/// that pathological inputs cannot make the tree (and the builder's recursion) arbitrarily deep.
pub(super) const MAX_SAH_DEPTH: u32 = 48;
/// Subtrees with at least this many primitives are built with `rayon::join`.
const PARALLEL_THRESHOLD: usize = 2048;
/// Nodes with at least this many primitives are binned in parallel chunks of this size.
const PARALLEL_BIN_CHUNK: usize = 16384;

/// A primitive's box as the builder sees it (SIMD layout; the input index lives in a parallel
/// `ids` array that is permuted alongside).
#[derive(Clone, Copy, Debug)]
pub(super) struct PrimRef {
    pub min: Vec3A,
    pub max: Vec3A,
}

impl PrimRef {
    /// Twice the box centre (the factor 2 does not change any split and saves a multiply).
    #[inline]
    fn centroid2(&self) -> Vec3A {
        self.min + self.max
    }
}

/// The binary tree the builder returns. Leaves index the reordered `PrimRef` array.
#[derive(Debug)]
pub(super) enum BuildNode {
    Leaf { bounds: Aabb, start: u32, count: u32 },
    Interior { bounds: Aabb, children: Box<[BuildNode; 2]> },
}

impl BuildNode {
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        match self {
            BuildNode::Leaf { bounds, .. } | BuildNode::Interior { bounds, .. } => *bounds,
        }
    }
}

/// A box in SIMD layout (the builder's working type).
#[derive(Clone, Copy, Debug)]
struct Box3 {
    min: Vec3A,
    max: Vec3A,
}

impl Box3 {
    const EMPTY: Box3 = Box3 {
        min: Vec3A::splat(f32::INFINITY),
        max: Vec3A::splat(f32::NEG_INFINITY),
    };

    #[inline]
    fn union(self, o: Box3) -> Box3 {
        Box3 {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    #[inline]
    fn grow(self, p: Vec3A) -> Box3 {
        Box3 {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    fn to_aabb(self) -> Aabb {
        Aabb {
            min: self.min.into(),
            max: self.max.into(),
        }
    }

    /// Half the surface area (0 for the empty box).
    #[inline]
    fn half_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// Builds the binary tree over `refs` and the parallel `ids` (both reordered in place into leaf
/// order). `refs` must not be empty.
pub(super) fn build(refs: &mut [PrimRef], ids: &mut [u32]) -> BuildNode {
    debug_assert!(!refs.is_empty() && refs.len() == ids.len());
    let fold = |b: (Box3, Box3), r: &PrimRef| (b.0.union(Box3 { min: r.min, max: r.max }), b.1.grow(r.centroid2()));
    let merge = |a: (Box3, Box3), b: (Box3, Box3)| (a.0.union(b.0), a.1.union(b.1));
    let (bounds, cbounds) = refs
        .par_chunks(PARALLEL_BIN_CHUNK)
        .map(|c| c.iter().fold((Box3::EMPTY, Box3::EMPTY), fold))
        .reduce(|| (Box3::EMPTY, Box3::EMPTY), merge);
    build_node(refs, ids, 0, 0, bounds, cbounds, &mut Bins::new(BINS))
}

/// Box of the (doubled) centroids of `refs`.
fn centroid_bounds_of(refs: &[PrimRef]) -> Box3 {
    refs.iter().fold(Box3::EMPTY, |c, r| c.grow(r.centroid2()))
}

/// Box and centroid box of `refs`.
fn bounds_of(refs: &[PrimRef]) -> (Box3, Box3) {
    refs.iter().fold((Box3::EMPTY, Box3::EMPTY), |(b, c), r| {
        (b.union(Box3 { min: r.min, max: r.max }), c.grow(r.centroid2()))
    })
}

/// Per axis and bin: the box of the primitives and their number. Only the first `n_bins` bins of
/// each axis are used (fewer bins for small nodes, where 16 would mostly stay empty).
#[derive(Clone, Copy)]
struct Bins {
    n_bins: usize,
    bounds: [[Box3; BINS]; 3],
    count: [[u32; BINS]; 3],
}

impl Bins {
    fn new(n_bins: usize) -> Self {
        Self {
            n_bins,
            bounds: [[Box3::EMPTY; BINS]; 3],
            count: [[0; BINS]; 3],
        }
    }

    /// Empties the first `n_bins` bins of every axis (reusing the scratch space of a parent node).
    fn reset(&mut self, n_bins: usize) {
        self.n_bins = n_bins;
        for axis in 0..3 {
            self.bounds[axis][..n_bins].fill(Box3::EMPTY);
            self.count[axis][..n_bins].fill(0);
        }
    }

    fn add(&mut self, refs: &[PrimRef], map: &BinMap) {
        for r in refs {
            let idx = map.bins(r.centroid2());
            for ((bounds, count), &bin) in self.bounds.iter_mut().zip(&mut self.count).zip(&idx) {
                let b = &mut bounds[bin];
                b.min = b.min.min(r.min);
                b.max = b.max.max(r.max);
                count[bin] += 1;
            }
        }
    }

    fn merge(mut self, o: Bins) -> Bins {
        for axis in 0..3 {
            for i in 0..self.n_bins {
                self.bounds[axis][i] = self.bounds[axis][i].union(o.bounds[axis][i]);
                self.count[axis][i] += o.count[axis][i];
            }
        }
        self
    }
}

/// Maps a doubled centroid to one of `n_bins` bins along each axis; `scale` is 0 on axes without
/// extent.
#[derive(Clone, Copy)]
struct BinMap {
    origin: Vec3A,
    scale: Vec3A,
    n_bins: usize,
}

impl BinMap {
    fn new(cbounds: &Box3, n_bins: usize) -> Self {
        let extent = cbounds.max - cbounds.min;
        let mut scale = [0.0f32; 3];
        for (a, s) in scale.iter_mut().enumerate() {
            // An extent below a few ulps of the coordinates is no extent: binning it would only
            // amplify rounding noise (and 1/extent could overflow).
            let tiny = 4.0 * f32::EPSILON * cbounds.min[a].abs().max(cbounds.max[a].abs());
            if extent[a] > tiny && extent[a].is_finite() {
                *s = n_bins as f32 * (1.0 - 1e-5) / extent[a];
            }
        }
        Self {
            origin: cbounds.min,
            scale: Vec3A::from_array(scale),
            n_bins,
        }
    }

    /// Bin indices along the three axes: `round((c2 − origin)·scale − ½)`, at most the last bin.
    /// The rounding uses the float "magic number" `1.5·2²³` (adding it leaves the rounded integer
    /// in the low mantissa bits), which is exact for the range in play and vectorises, unlike
    /// Rust's saturating float → int casts. For finite input the argument is ≥ −½ (`origin` is the
    /// exact minimum), so the integer is ≥ 0; anything else wraps to a huge `u32` and is clamped.
    /// The mapping is monotone, which is all the binning and the partition need.
    #[inline]
    fn bins(&self, c2: Vec3A) -> [usize; 3] {
        let f = ((c2 - self.origin) * self.scale - Vec3A::splat(0.5) + Vec3A::splat(Self::MAGIC)).to_array();
        f.map(|x| self.clamp_bits(x))
    }

    /// The same mapping along one axis (bit-identical to the lane of [`Self::bins`]: the same
    /// IEEE operations in the same order).
    #[inline]
    fn bin(&self, c2: Vec3A, axis: usize) -> usize {
        self.clamp_bits((c2[axis] - self.origin[axis]) * self.scale[axis] - 0.5 + Self::MAGIC)
    }

    const MAGIC: f32 = 12_582_912.0;

    #[inline]
    fn clamp_bits(&self, x: f32) -> usize {
        (x.to_bits().wrapping_sub(Self::MAGIC.to_bits())).min(self.n_bins as u32 - 1) as usize
    }
}

/// The best SAH split found by binning: along `axis`, bins `< bin` go left.
#[derive(Clone, Copy, Debug)]
struct Split {
    axis: usize,
    bin: usize,
    /// `C_trav·A + Σ A_side·N_side` (the SAH cost multiplied by the half area `A` of the node).
    cost: f32,
}

/// Half areas of three boxes given by their extents, one box per lane of the result. Negative
/// extents (empty boxes) count as 0.
#[inline]
fn half_areas(e: [Vec3A; 3]) -> Vec3A {
    let (e0, e1, e2) = (e[0].max(Vec3A::ZERO), e[1].max(Vec3A::ZERO), e[2].max(Vec3A::ZERO));
    let x = Vec3A::new(e0.x, e1.x, e2.x);
    let y = Vec3A::new(e0.y, e1.y, e2.y);
    let z = Vec3A::new(e0.z, e1.z, e2.z);
    x * y + y * z + z * x
}

/// The cheapest split with two non-empty sides over the binned axes (Wald 2007, §3.2). The three
/// axes are swept together, one per SIMD lane. Costs are in f32: inputs whose areas overflow give
/// infinite costs, no split, and the caller's median fallback.
fn best_split(bins: &Bins, map: &BinMap, node_half_area: f32) -> Option<Split> {
    let nb = bins.n_bins;
    let count = |i: usize| Vec3A::new(bins.count[0][i] as f32, bins.count[1][i] as f32, bins.count[2][i] as f32);
    // Right-to-left sweep: cost and count of the right side of a split before bin i.
    let mut right_cost = [Vec3A::ZERO; BINS];
    let mut right_count = [Vec3A::ZERO; BINS];
    let mut acc = [Box3::EMPTY; 3];
    let mut n = Vec3A::ZERO;
    for i in (1..nb).rev() {
        for (a, b) in acc.iter_mut().enumerate() {
            *b = b.union(bins.bounds[a][i]);
        }
        n += count(i);
        right_cost[i] = half_areas(acc.map(|b| b.max - b.min)) * packets(n);
        right_count[i] = n;
    }
    let mut acc = [Box3::EMPTY; 3];
    let mut n = Vec3A::ZERO;
    let mut best_cost = Vec3A::from_array(map.scale.to_array().map(|s| if s > 0.0 { f32::INFINITY } else { f32::NAN }));
    let mut best_bin = Vec3A::ZERO;
    let trav = Vec3A::splat(TRAVERSAL_COST * node_half_area);
    for i in 1..nb {
        for (a, b) in acc.iter_mut().enumerate() {
            *b = b.union(bins.bounds[a][i - 1]);
        }
        n += count(i - 1);
        let cost = trav + half_areas(acc.map(|b| b.max - b.min)) * packets(n) + right_cost[i];
        // Axes without extent have a NaN best cost, so `cmplt` never selects them.
        let better = cost.cmplt(best_cost) & n.cmpgt(Vec3A::ZERO) & right_count[i].cmpgt(Vec3A::ZERO);
        best_cost = Vec3A::select(better, cost, best_cost);
        best_bin = Vec3A::select(better, Vec3A::splat(i as f32), best_bin);
    }
    let mut best: Option<Split> = None;
    for axis in 0..3 {
        let cost = best_cost[axis];
        if cost < f32::INFINITY && best.is_none_or(|s| cost < s.cost) {
            best = Some(Split {
                axis,
                bin: best_bin[axis] as usize,
                cost,
            });
        }
    }
    best
}

/// Reorders `refs` (and `ids` alongside) so that elements satisfying `left` come first; returns
/// their number.
fn partition(refs: &mut [PrimRef], ids: &mut [u32], left: impl Fn(&PrimRef) -> bool) -> usize {
    let (mut i, mut j) = (0usize, refs.len());
    loop {
        while i < j && left(&refs[i]) {
            i += 1;
        }
        while i < j && !left(&refs[j - 1]) {
            j -= 1;
        }
        if i >= j {
            return i;
        }
        refs.swap(i, j - 1);
        ids.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}

/// Splits at the object median along the widest centroid axis (or at the index median when all
/// centroids coincide). Both sides are non-empty for `refs.len() >= 2`.
fn median_split(refs: &mut [PrimRef], ids: &mut [u32], cbounds: &Box3) -> usize {
    let mid = refs.len() / 2;
    let e = (cbounds.max - cbounds.min).to_array();
    if e.iter().any(|&x| x > 0.0) {
        let axis = if e[0] >= e[1] && e[0] >= e[2] {
            0
        } else if e[1] >= e[2] {
            1
        } else {
            2
        };
        let mut pairs: Vec<(PrimRef, u32)> = refs.iter().copied().zip(ids.iter().copied()).collect();
        pairs.select_nth_unstable_by(mid, |a, b| a.0.centroid2()[axis].total_cmp(&b.0.centroid2()[axis]));
        for (k, (r, id)) in pairs.into_iter().enumerate() {
            refs[k] = r;
            ids[k] = id;
        }
    }
    mid
}

fn build_node(refs: &mut [PrimRef], ids: &mut [u32], offset: usize, depth: u32, bounds: Box3, cbounds: Box3, bins: &mut Bins) -> BuildNode {
    let n = refs.len();
    let leaf = || BuildNode::Leaf {
        bounds: bounds.to_aabb(),
        start: offset as u32,
        count: n as u32,
    };
    if n == 1 {
        return leaf();
    }
    let map = BinMap::new(&cbounds, n.clamp(4, BINS));
    let mut sides: Option<(Box3, Box3)> = None;
    let mid = if map.scale == Vec3A::ZERO {
        // All centroids (numerically) equal: nothing to separate.
        if n <= MAX_LEAF {
            return leaf();
        }
        median_split(refs, ids, &cbounds)
    } else if depth >= MAX_SAH_DEPTH {
        median_split(refs, ids, &cbounds)
    } else {
        if n >= 2 * PARALLEL_BIN_CHUNK {
            let binned = |c: &[PrimRef]| {
                let mut b = Bins::new(map.n_bins);
                b.add(c, &map);
                b
            };
            *bins = refs
                .par_chunks(PARALLEL_BIN_CHUNK)
                .map(binned)
                .reduce(|| Bins::new(map.n_bins), Bins::merge);
        } else {
            bins.reset(map.n_bins);
            bins.add(refs, &map);
        }
        let node_half_area = bounds.half_area();
        match best_split(bins, &map, node_half_area) {
            Some(split) => {
                let leaf_cost = node_half_area * packets(Vec3A::splat(n as f32)).x;
                if n <= MAX_LEAF && leaf_cost <= split.cost {
                    return leaf();
                }
                let mid = partition(refs, ids, |r| map.bin(r.centroid2(), split.axis) < split.bin);
                let ab = &bins.bounds[split.axis];
                let side = |range: std::ops::Range<usize>| ab[range].iter().fold(Box3::EMPTY, |b, bin| b.union(*bin));
                // The partition uses the same bin function as the binning, so the bins' boxes are
                // exactly the children's boxes.
                sides = Some((side(0..split.bin), side(split.bin..map.n_bins)));
                debug_assert!(mid > 0 && mid < n, "SAH split must leave both sides non-empty");
                mid
            }
            None if n <= MAX_LEAF => return leaf(),
            None => median_split(refs, ids, &cbounds),
        }
    };
    let (left, right) = refs.split_at_mut(mid);
    let (left_ids, right_ids) = ids.split_at_mut(mid);
    let ((lb, lc), (rb, rc)) = match sides {
        Some((lb, rb)) => ((lb, centroid_bounds_of(left)), (rb, centroid_bounds_of(right))),
        None => (bounds_of(left), bounds_of(right)),
    };
    let (l, r) = if n >= PARALLEL_THRESHOLD {
        rayon::join(
            || build_node(left, left_ids, offset, depth + 1, lb, lc, bins),
            || build_node(right, right_ids, offset + mid, depth + 1, rb, rc, &mut Bins::new(BINS)),
        )
    } else {
        let l = build_node(left, left_ids, offset, depth + 1, lb, lc, bins);
        (l, build_node(right, right_ids, offset + mid, depth + 1, rb, rc, bins))
    };
    BuildNode::Interior {
        bounds: bounds.to_aabb(),
        children: Box::new([l, r]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    fn refs_from_points(points: &[Vec3]) -> (Vec<PrimRef>, Vec<u32>) {
        let refs = points
            .iter()
            .map(|&p| PrimRef {
                min: p.into(),
                max: Vec3A::from(p) + Vec3A::splat(0.01),
            })
            .collect();
        (refs, (0..points.len() as u32).collect())
    }

    fn check(node: &BuildNode, refs: &[PrimRef], ids: &[u32], seen: &mut [u32], depth: u32, max_depth: &mut u32) {
        *max_depth = (*max_depth).max(depth);
        match node {
            BuildNode::Leaf { bounds, start, count } => {
                assert!(*count >= 1 && *count as usize <= MAX_LEAF);
                for k in *start as usize..(*start + *count) as usize {
                    assert!(bounds.contains(refs[k].min.into()) && bounds.contains(refs[k].max.into()));
                    seen[ids[k] as usize] += 1;
                }
            }
            BuildNode::Interior { bounds, children } => {
                for c in children.iter() {
                    let cb = c.bounds();
                    assert!(bounds.contains(cb.min) && bounds.contains(cb.max));
                    check(c, refs, ids, seen, depth + 1, max_depth);
                }
            }
        }
    }

    #[test]
    fn bin_mapping_is_monotone_and_covers_all_bins() {
        let cb = Box3 {
            min: Vec3A::splat(-3.0),
            max: Vec3A::new(5.0, -3.0, 1e-3),
        };
        let map = BinMap::new(&cb, BINS);
        assert_eq!(map.scale.y, 0.0, "no extent along y");
        let mut last = 0;
        let mut seen = [false; BINS];
        for k in 0..=10_000 {
            let x = -3.0 + 8.0 * k as f32 / 10_000.0;
            let b = map.bins(Vec3A::new(x, -3.0, 0.0))[0];
            assert!(b >= last && b < BINS, "x {x}: bin {b} after {last}");
            seen[b] = true;
            last = b;
        }
        assert!(seen.iter().all(|&s| s), "{seen:?}");
        // Out-of-range and non-finite inputs still land in a valid bin.
        for x in [-1e30, 1e30, f32::NAN, f32::INFINITY] {
            assert!(map.bins(Vec3A::splat(x)).iter().all(|&b| b < BINS));
        }
    }

    #[test]
    fn partition_splits_by_predicate() {
        let (mut refs, mut ids) = refs_from_points(&(0..37).map(|i| Vec3::splat(((i * 7) % 37) as f32)).collect::<Vec<_>>());
        let mid = partition(&mut refs, &mut ids, |r| r.min.x < 10.0);
        assert_eq!(mid, 10);
        assert!(refs[..mid].iter().all(|r| r.min.x < 10.0) && refs[mid..].iter().all(|r| r.min.x >= 10.0));
        assert!(
            refs.iter().zip(&ids).all(|(r, &id)| r.min.x == ((id * 7) % 37) as f32),
            "ids move with their boxes"
        );
    }

    #[test]
    fn every_primitive_lands_in_exactly_one_leaf() {
        // A line of points with exponentially growing spacing stresses the SAH (and the depth cap);
        // a block of identical points stresses the equal-centroid fallback.
        let mut pts: Vec<Vec3> = (0..3000).map(|i| Vec3::new(1.01f32.powi(i), 0.0, 0.0)).collect();
        pts.extend(std::iter::repeat_n(Vec3::splat(-5.0), 100));
        let (mut refs, mut ids) = refs_from_points(&pts);
        let root = build(&mut refs, &mut ids);
        let mut seen = vec![0u32; pts.len()];
        let mut max_depth = 0;
        check(&root, &refs, &ids, &mut seen, 0, &mut max_depth);
        assert!(seen.iter().all(|&c| c == 1));
        assert!(max_depth <= MAX_SAH_DEPTH + 13, "depth {max_depth}");
    }
}
