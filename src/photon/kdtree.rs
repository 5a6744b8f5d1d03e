//! The photon kd-tree and its k-nearest-neighbour query with the acceptance test inside the search
//! (method.md §3: photons that cannot contribute are rejected *before* they shrink the radius).
//!
//! Structure: a complete, count-balanced binary tree of depth `D` (the smallest depth whose leaves hold at
//! most `leaf_size` photons). Each internal node splits its photons at the median along the longest axis of
//! their tight bounding box. Photons are stored reordered so that every leaf is a contiguous range; the
//! ranges are implicit (each node covers `[lo, hi)` and splits at `lo + (hi − lo)/2`), so a node is only
//! `(split, axis)`, 8 bytes. Nodes are laid out in depth-first pre-order: the left child follows its parent
//! directly and the right child sits `2^(h−1)` further (h = levels below the node), which keeps each
//! descent's nodes close in memory. The build is parallel (rayon::join over the two halves above a size
//! threshold; `select_nth_unstable_by` per node).
//!
//! Query: depth-first, near child first, pruning the far child with the incremental squared distance from
//! the query to the far cell (Arya & Mount 1993, "Algorithms for fast vector quantization"). The k best are
//! kept in a bounded binary max-heap of `(dist², index)` reused across queries through [`KnnResult`].
//! Distances are computed as `(dx² + dy²) + dz²` in f32, and every pruning bound uses the same operation
//! order on per-axis lower bounds, so the bound never exceeds a true f32 distance: the result is exact
//! (the same sorted distances as a brute-force scan, ties broken arbitrarily).

use rayon::prelude::*;

use super::record::Photon;
use crate::math::{Aabb, Vec3};

/// Default photons per leaf (measured with `cargo bench --no-default-features --bench kdtree`).
pub const DEFAULT_LEAF_SIZE: usize = 8;

/// Below this many photons a subtree is built on the current thread.
const PARALLEL_BUILD_THRESHOLD: usize = 1 << 14;

/// Errors from building a [`KdTree`].
#[derive(Debug, thiserror::Error)]
pub enum KdTreeError {
    #[error("{count} photons: the kd-tree indexes photons with u32, at most {max}", max = u32::MAX)]
    TooManyPhotons { count: usize },
    #[error("the kd-tree leaf size must be at least 1")]
    ZeroLeafSize,
}

/// An internal node: photons with `position[axis] <= split` are in the left subtree, `>= split` in the right.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
struct Node {
    split: f32,
    axis: u32,
}

/// A balanced kd-tree over photons. Immutable once built; queries are `&self` and thread-safe.
#[derive(Clone, Debug)]
pub struct KdTree {
    /// The photons, reordered so that each leaf is a contiguous range.
    photons: Vec<Photon>,
    /// Internal nodes in depth-first pre-order; `2^depth − 1` of them.
    nodes: Vec<Node>,
    depth: u32,
    bounds: Aabb,
    dropped_non_finite: usize,
}

/// One neighbour found by [`KdTree::knn`]: squared distance to the query and index into [`KdTree::photons`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbor {
    pub dist2: f32,
    pub index: u32,
}

/// The result of a k-NN query, reusable across queries (its buffer is kept, so steady-state queries do not
/// allocate). Create one per thread with [`KnnResult::default`].
#[derive(Clone, Debug, Default)]
pub struct KnnResult {
    /// A binary max-heap on `dist2` while searching; arbitrary order after [`KnnResult::sort_by_distance`].
    heap: Vec<Neighbor>,
    r2: f32,
}

impl KnnResult {
    /// Number of accepted photons found (≤ k).
    #[must_use]
    pub fn len(&self) -> usize {
        self.heap.len()
    }

    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }

    /// Squared search radius r² (method.md §3): the squared distance to the k-th accepted photon, or
    /// `max_radius²` if fewer than k were found (also for an empty map or a non-finite query point), and 0
    /// for k = 0. May be 0 when photons coincide with the query: the caller clamps ΔA = πr².
    #[must_use]
    pub fn r2(&self) -> f32 {
        self.r2
    }

    /// The neighbours, in no particular order (heap order) unless [`KnnResult::sort_by_distance`] was called.
    #[must_use]
    pub fn neighbors(&self) -> &[Neighbor] {
        &self.heap
    }

    /// The neighbours' photons with their squared distances.
    pub fn photons<'t>(&'t self, tree: &'t KdTree) -> impl Iterator<Item = (&'t Photon, f32)> + 't {
        self.heap.iter().map(move |n| (&tree.photons[n.index as usize], n.dist2))
    }

    /// Orders the neighbours by increasing distance (ties by index). Not needed for density estimation.
    pub fn sort_by_distance(&mut self) {
        self.heap.sort_unstable_by(|a, b| a.dist2.total_cmp(&b.dist2).then(a.index.cmp(&b.index)));
    }
}

/// Largest f32 strictly below `x` for `x ≥ 0` (−1 for `x = 0`, so that `d² <= below(x)` means `d² < x`).
#[inline]
fn below(x: f32) -> f32 {
    if x > 0.0 {
        // For positive floats (including +∞) the predecessor is the previous bit pattern.
        f32::from_bits(x.to_bits() - 1)
    } else {
        -1.0
    }
}

/// Tight bounds of the photons' positions (parallel for large slices).
fn bounds_of(photons: &[Photon]) -> Aabb {
    const CHUNK: usize = 1 << 15;
    let seq = |ps: &[Photon]| ps.iter().fold(Aabb::EMPTY, |b, p| b.grow(p.position()));
    if photons.len() > 2 * CHUNK {
        photons.par_chunks(CHUNK).map(seq).reduce(|| Aabb::EMPTY, Aabb::union)
    } else {
        seq(photons)
    }
}

/// Builds the subtree of height `h` over `photons` into `nodes` (which has exactly `2^h − 1` slots).
fn build_recursive(photons: &mut [Photon], nodes: &mut [Node], h: u32) {
    debug_assert_eq!(nodes.len(), (1usize << h) - 1);
    if h == 0 {
        return;
    }
    let axis = bounds_of(photons).largest_axis();
    let mid = photons.len() / 2;
    let split = if photons.is_empty() {
        0.0
    } else {
        // total_cmp: a total order that agrees with `<` on the finite positions the tree keeps.
        let (_, m, _) = photons.select_nth_unstable_by(mid, |a, b| a.position_array()[axis].total_cmp(&b.position_array()[axis]));
        m.position_array()[axis]
    };
    let (node, rest) = nodes.split_first_mut().expect("h >= 1 so there is a node");
    *node = Node { split, axis: axis as u32 };
    let (left_nodes, right_nodes) = rest.split_at_mut((1usize << (h - 1)) - 1);
    let (left, right) = photons.split_at_mut(mid);
    if left.len() + right.len() >= PARALLEL_BUILD_THRESHOLD {
        rayon::join(|| build_recursive(left, left_nodes, h - 1), || build_recursive(right, right_nodes, h - 1));
    } else {
        build_recursive(left, left_nodes, h - 1);
        build_recursive(right, right_nodes, h - 1);
    }
}

impl KdTree {
    /// Builds the tree with [`DEFAULT_LEAF_SIZE`] photons per leaf. See [`KdTree::build_with_leaf_size`].
    pub fn build(photons: Vec<Photon>) -> Result<Self, KdTreeError> {
        Self::build_with_leaf_size(photons, DEFAULT_LEAF_SIZE)
    }

    /// Builds the tree (in parallel) with at most `leaf_size` photons per leaf. Photons whose position is
    /// not finite are dropped (a bug upstream; counted in [`KdTree::dropped_non_finite`]).
    pub fn build_with_leaf_size(mut photons: Vec<Photon>, leaf_size: usize) -> Result<Self, KdTreeError> {
        if leaf_size == 0 {
            return Err(KdTreeError::ZeroLeafSize);
        }
        let before = photons.len();
        photons.retain(|p| p.position().is_finite());
        let dropped_non_finite = before - photons.len();
        let n = photons.len();
        if u32::try_from(n).is_err() {
            return Err(KdTreeError::TooManyPhotons { count: n });
        }
        let mut depth = 0u32;
        while n.div_ceil(1usize << depth) > leaf_size {
            depth += 1;
        }
        let mut nodes = vec![Node::default(); (1usize << depth) - 1];
        build_recursive(&mut photons, &mut nodes, depth);
        let bounds = bounds_of(&photons);
        Ok(Self { photons, nodes, depth, bounds, dropped_non_finite })
    }

    /// Number of photons stored.
    #[must_use]
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// The stored photons, in tree order ([`Neighbor::index`] indexes this slice).
    #[must_use]
    pub fn photons(&self) -> &[Photon] {
        &self.photons
    }

    /// Bounds of the stored photons' positions (empty box for an empty map).
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Photons dropped at build time because their position was not finite.
    #[must_use]
    pub fn dropped_non_finite(&self) -> usize {
        self.dropped_non_finite
    }

    /// Heap memory held by the tree, in bytes (photons + nodes).
    #[must_use]
    pub fn memory_bytes(&self) -> usize {
        self.photons.capacity() * std::mem::size_of::<Photon>() + self.nodes.capacity() * std::mem::size_of::<Node>()
    }

    /// The `k` nearest photons to `p` within `max_radius` (inclusive) among those for which `accept` is
    /// true, written to `out` (method.md §3). `accept` runs inside the search on photons within the current
    /// radius only; rejected photons never enter the heap and never shrink the radius. `max_radius` may be
    /// `f32::INFINITY`.
    ///
    /// Edge cases: `k = 0` gives an empty result with `r² = 0`; an empty map or `k` larger than the number
    /// of accepted photons within `max_radius` gives them all with `r² = max_radius²`. A non-finite `p` or a
    /// negative/NaN `max_radius` is a bug upstream (debug assertion); release builds return an empty result
    /// (with `r² = max_radius²`, resp. 0).
    pub fn knn<F: Fn(&Photon) -> bool>(&self, p: Vec3, k: usize, max_radius: f32, accept: F, out: &mut KnnResult) {
        out.heap.clear();
        out.r2 = 0.0;
        if k == 0 {
            return;
        }
        if !(max_radius >= 0.0) {
            debug_assert!(false, "knn: max_radius {max_radius} is negative or NaN");
            return;
        }
        let max_r2 = max_radius * max_radius;
        out.r2 = max_r2;
        if !p.is_finite() {
            debug_assert!(false, "knn: non-finite query point {p:?}");
            return;
        }
        if self.photons.is_empty() {
            return;
        }
        out.heap.reserve(k.min(self.photons.len()));
        let mut search = Search { photons: &self.photons, nodes: &self.nodes, q: p.to_array(), k, limit: max_r2, heap: &mut out.heap, accept };
        search.descend(0, self.depth, 0, self.photons.len(), &mut [0.0; 3]);
        if out.heap.len() == k {
            out.r2 = out.heap[0].dist2;
        }
    }
}

/// State of one k-NN search.
struct Search<'a, F> {
    photons: &'a [Photon],
    nodes: &'a [Node],
    q: [f32; 3],
    k: usize,
    /// Inclusive bound on d²: `max_radius²` until k photons are held, then just below the heap's top.
    limit: f32,
    heap: &'a mut Vec<Neighbor>,
    accept: F,
}

impl<F: Fn(&Photon) -> bool> Search<'_, F> {
    /// Visits the subtree rooted at `node` (height `h`) covering photons `[lo, hi)`; `off` holds per-axis
    /// lower bounds of the distance from the query to the subtree's cell.
    fn descend(&mut self, node: usize, h: u32, lo: usize, hi: usize, off: &mut [f32; 3]) {
        if h == 0 {
            self.scan_leaf(lo, hi);
            return;
        }
        let Node { split, axis } = self.nodes[node];
        let axis = axis as usize;
        let mid = lo + (hi - lo) / 2;
        let (left, right) = (node + 1, node + (1usize << (h - 1)));
        let d = self.q[axis] - split;
        let (near, far, near_range, far_range) = if d < 0.0 { (left, right, (lo, mid), (mid, hi)) } else { (right, left, (mid, hi), (lo, mid)) };
        self.descend(near, h - 1, near_range.0, near_range.1, off);
        let old = off[axis];
        off[axis] = d.abs();
        // Same operation order as the point distance in `scan_leaf`, on per-axis bounds ≤ |p − q|: never
        // larger than a true f32 distance of a photon in the far cell.
        let rd = (off[0] * off[0] + off[1] * off[1]) + off[2] * off[2];
        if rd <= self.limit {
            self.descend(far, h - 1, far_range.0, far_range.1, off);
        }
        off[axis] = old;
    }

    #[inline]
    fn scan_leaf(&mut self, lo: usize, hi: usize) {
        let [qx, qy, qz] = self.q;
        for (i, ph) in self.photons[lo..hi].iter().enumerate() {
            let [x, y, z] = *ph.position_array();
            let (dx, dy, dz) = (x - qx, y - qy, z - qz);
            let d2 = (dx * dx + dy * dy) + dz * dz;
            if d2 <= self.limit && (self.accept)(ph) {
                self.offer(d2, (lo + i) as u32);
            }
        }
    }

    /// Inserts a photon already known to be closer than the current limit into the bounded max-heap.
    #[inline]
    fn offer(&mut self, dist2: f32, index: u32) {
        let heap = &mut *self.heap;
        let item = Neighbor { dist2, index };
        if heap.len() < self.k {
            // Sift up.
            let mut i = heap.len();
            heap.push(item);
            while i > 0 {
                let parent = (i - 1) / 2;
                if heap[parent].dist2 >= dist2 {
                    break;
                }
                heap[i] = heap[parent];
                i = parent;
            }
            heap[i] = item;
            if heap.len() == self.k {
                self.limit = below(heap[0].dist2);
            }
        } else {
            // Replace the farthest and sift down.
            let n = heap.len();
            let mut i = 0;
            loop {
                let l = 2 * i + 1;
                if l >= n {
                    break;
                }
                let r = l + 1;
                let c = if r < n && heap[r].dist2 > heap[l].dist2 { r } else { l };
                if heap[c].dist2 <= dist2 {
                    break;
                }
                heap[i] = heap[c];
                i = c;
            }
            heap[i] = item;
            self.limit = below(heap[0].dist2);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn below_is_the_predecessor() {
        assert_eq!(below(1.0), crate::math::next_float_down(1.0));
        assert_eq!(below(f32::INFINITY), f32::MAX);
        assert!(below(0.0) < 0.0);
        assert!(below(f32::MIN_POSITIVE) < f32::MIN_POSITIVE && below(f32::MIN_POSITIVE) > 0.0);
    }

    /// Every node separates its photons: left ≤ split ≤ right on its axis.
    fn validate(t: &KdTree) {
        fn rec(t: &KdTree, node: usize, h: u32, lo: usize, hi: usize) {
            if h == 0 {
                return;
            }
            let Node { split, axis } = t.nodes[node];
            let mid = lo + (hi - lo) / 2;
            assert!(t.photons[lo..mid].iter().all(|p| p.position_array()[axis as usize] <= split));
            assert!(t.photons[mid..hi].iter().all(|p| p.position_array()[axis as usize] >= split));
            rec(t, node + 1, h - 1, lo, mid);
            rec(t, node + (1 << (h - 1)), h - 1, mid, hi);
        }
        rec(t, 0, t.depth, 0, t.len());
    }

    #[test]
    fn node_layout_is_compact() {
        assert_eq!(std::mem::size_of::<Node>(), 8);
    }

    #[test]
    fn depth_gives_small_leaves() {
        for n in [0usize, 1, 7, 8, 9, 100, 1000] {
            let photons: Vec<Photon> = (0..n).map(|i| Photon::new(Vec3::new(i as f32, 0.0, 0.0), Vec3::Z, Vec3::ONE, 1.0)).collect();
            let t = KdTree::build_with_leaf_size(photons, 8).unwrap();
            assert_eq!(t.len(), n);
            assert!(n.div_ceil(1 << t.depth) <= 8);
            assert!(t.depth == 0 || n.div_ceil(1 << (t.depth - 1)) > 8);
            assert_eq!(t.nodes.len(), (1 << t.depth) - 1);
            validate(&t);
        }
        assert!(matches!(KdTree::build_with_leaf_size(Vec::new(), 0), Err(KdTreeError::ZeroLeafSize)));
    }

    #[test]
    fn large_parallel_build_is_valid_and_drops_non_finite() {
        let mut s = crate::sampler::Sampler::for_key(9, 0, 0);
        let mut photons: Vec<Photon> = (0..100_000)
            .map(|_| Photon::new(Vec3::new(s.next_1d(), s.next_1d() * 0.1, (s.next_1d() * 8.0).floor()), Vec3::Z, Vec3::ONE, 1.0))
            .collect();
        photons.push(Photon::new(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Z, Vec3::ONE, 1.0));
        photons.push(Photon::new(Vec3::new(0.0, f32::INFINITY, 0.0), Vec3::Z, Vec3::ONE, 1.0));
        for leaf in [1, 3, 8, 32] {
            let t = KdTree::build_with_leaf_size(photons.clone(), leaf).unwrap();
            assert_eq!((t.len(), t.dropped_non_finite()), (100_000, 2));
            assert!(t.memory_bytes() >= 100_000 * 32);
            validate(&t);
        }
    }
}
