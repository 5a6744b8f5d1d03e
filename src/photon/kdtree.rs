//! The photon kd-tree and its k-nearest-neighbour query with the acceptance test inside the search
//! (method.md §3: photons that cannot contribute are rejected *before* they shrink the radius).
//!
//! Structure: a complete, count-balanced binary tree of depth `D` (the smallest depth whose leaves hold at
//! most `leaf_size` photons). Each internal node splits its photons at the median along the longest axis of
//! their tight bounding box. Photons are stored reordered so that every leaf is a contiguous range; the
//! ranges are implicit (a node covers `[lo, hi)` and splits at `lo + (hi − lo)/2`). A node stores the tight
//! bounding boxes of its two children (64 bytes, one cache line; SIMD vectors), so one node read decides
//! which children to visit and in which order. Nodes are laid out in depth-first pre-order: the left child follows its parent directly and
//! the right child sits `2^(h−1)` further (h = levels below the node). The build is parallel (rayon::join
//! over the two halves above a size threshold; `select_nth_unstable_by` per node).
//!
//! Why boxes and not split planes: photons lie on surfaces, so whole subtrees are flat (say z = 0 on a floor)
//! and a query a little off the surface is far from them along an axis that is never split. Split-plane
//! bounds (Arya & Mount 1993) never see that distance and visit every cell within the query's height; tight
//! boxes do (measured: 5× fewer photons scanned for queries within 1 cm of a dense floor caustic). Boxes also
//! keep coincident photons cheap: a box shrunk to a point is pruned as soon as k photons are held, where
//! split planes would visit every one of them.
//!
//! Query: depth-first, nearer child box first, skipping a child whose box is farther than the current
//! radius. The k best are kept in a bounded 4-ary max-heap of `(dist², index)` reused across queries
//! through [`KnnResult`]. Distances are computed as `(dx² + dy²) + dz²` in f32 and box distances use the
//! same operation order on per-axis lower bounds, so a box distance never exceeds the f32 distance of a
//! photon inside it: the result is exact (the same sorted distances as a brute-force scan, ties broken
//! arbitrarily).

use std::ops::ControlFlow;

use rayon::prelude::*;

use super::dirbox::DirBox;
use super::record::{DecodedPhoton, Photon, PhotonList};
use crate::math::{Aabb, Vec3, Vec3A, Vec4};

/// Default photons per leaf. Measured with `cargo bench --no-default-features --bench kdtree -- --ours-only
/// --leaf N` at k = 50: 16, 24 and 32 are within noise of each other and ~5% faster than 8 (4: ~15% slower);
/// 16 keeps leaves small for smaller k. Nodes (64 bytes) then cost 4 to 8 bytes per photon (a leaf holds 8
/// to 16).
pub const DEFAULT_LEAF_SIZE: usize = 16;

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

/// Tight bounds of a set of positions; the empty box (min = +∞, max = −∞) is infinitely far from everything.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct Bounds {
    min: [f32; 3],
    max: [f32; 3],
}

impl Bounds {
    const EMPTY: Bounds = Bounds {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
    };

    #[inline]
    fn grow(self, p: &[f32; 3]) -> Self {
        Bounds {
            min: [0, 1, 2].map(|a| self.min[a].min(p[a])),
            max: [0, 1, 2].map(|a| self.max[a].max(p[a])),
        }
    }

    #[inline]
    fn union(self, o: Bounds) -> Self {
        Bounds {
            min: [0, 1, 2].map(|a| self.min[a].min(o.min[a])),
            max: [0, 1, 2].map(|a| self.max[a].max(o.max[a])),
        }
    }

    /// Index of the longest axis (0 for the empty box).
    fn largest_axis(&self) -> usize {
        let e = [0, 1, 2].map(|a| (self.max[a] - self.min[a]).max(0.0));
        if e[0] >= e[1] && e[0] >= e[2] {
            0
        } else if e[1] >= e[2] {
            1
        } else {
            2
        }
    }

    /// Squared distance from `q` to the box, never larger than `(dx² + dy²) + dz²` for a point inside it
    /// (per axis `max(min − q, q − max, 0) ≤ |p − q|` under monotone rounding, summed in the same order).
    /// +∞ for the empty box.
    #[inline]
    fn dist2(&self, q: &[f32; 3]) -> f32 {
        let d = [0, 1, 2].map(|a| (self.min[a] - q[a]).max(q[a] - self.max[a]).max(0.0));
        (d[0] * d[0] + d[1] * d[1]) + d[2] * d[2]
    }
}

/// A child's tight box as two SIMD vectors (glam's `Vec3A`, one SSE register each), so that the box
/// distance is a handful of vector instructions: the same operations in the same order as
/// [`Bounds::dist2`], hence the same f32 value.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct NodeBox {
    min: Vec3A,
    max: Vec3A,
}

impl NodeBox {
    fn new(b: Bounds) -> Self {
        NodeBox { min: Vec3A::from_array(b.min), max: Vec3A::from_array(b.max) }
    }

    /// [`Bounds::dist2`] (no NaN arises: the coordinates and the query are finite or, for the empty box, ∓∞).
    #[inline]
    fn dist2(&self, q: Vec3A) -> f32 {
        let d = (self.min - q).max(q - self.max).max(Vec3A::ZERO);
        let d = d * d;
        (d.x + d.y) + d.z
    }
}

/// An internal node: the tight boxes of its left and right children (one cache line).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node {
    children: [NodeBox; 2],
}

/// A leaf: the tight box of its photons (as its parent node stores it) and their range in tree order.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct Leaf {
    bounds: NodeBox,
    lo: u32,
    hi: u32,
}

/// A leaf's photons for the gather's roulette: the largest RGB channel of their summed power and the box of
/// their arrival directions (12 bytes per 8 to 16 photons).
#[derive(Clone, Copy, Debug)]
struct LeafSums {
    power: f32,
    dirs: DirBox,
}

/// What the leaves within a radius hold ([`KdTree::bound_within`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeavesNear {
    /// The largest RGB channel of those photons' summed power.
    pub power: f32,
    /// A box holding their arrival directions (`lo > hi` for none).
    pub lo: Vec3,
    pub hi: Vec3,
}

/// The leaves of the subtree at `node` (height `h`, photons `[lo, hi)`, box `bounds`), left to right.
fn collect_leaves(nodes: &[Node], node: usize, h: u32, lo: usize, hi: usize, bounds: NodeBox, out: &mut Vec<Leaf>) {
    if h == 0 {
        // Photon counts fit u32 (checked at build).
        out.push(Leaf { bounds, lo: lo as u32, hi: hi as u32 });
        return;
    }
    let [bl, br] = nodes[node].children;
    let mid = lo + (hi - lo) / 2;
    collect_leaves(nodes, node + 1, h - 1, lo, mid, bl, out);
    collect_leaves(nodes, node + (1usize << (h - 1)), h - 1, mid, hi, br, out);
}

/// Where a k-NN search starts: the root, or a list of leaves that holds every photon within the search
/// radius of the query ([`KdTree::leaves_near_box`], kept per cell by [`crate::photon::OccupancyGrid`]).
#[derive(Clone, Copy, Debug)]
pub enum SearchFrom<'a> {
    Root,
    /// Leaf ids (indices in left-to-right order).
    Leaves(&'a [u32]),
}

/// A balanced kd-tree over photons. Immutable once built; queries are `&self` and thread-safe.
#[derive(Clone, Debug)]
pub struct KdTree {
    /// The photons, reordered so that each leaf is a contiguous range.
    photons: Vec<Photon>,
    /// The photons' positions in tree order as a structure of arrays (x, y, z; 12 bytes instead of 32 per
    /// photon): the leaf scan reads only these, [`LEAF_GROUP`] photons at a time with vector loads. Each
    /// array has [`LEAF_GROUP`] − 1 entries of padding at its end, so that every group is a whole
    /// `LEAF_GROUP`-slice (the entries past the leaf's end are masked off).
    positions: Positions,
    /// The photons' direction, `p_emit` and power ([`DecodedPhoton`]), decoded once at build time (tree
    /// order): the acceptance test and the density estimate never decode the octahedral code per query, and
    /// the estimate reads one 32-byte record per photon, the one the acceptance test already loaded.
    decoded: Vec<DecodedPhoton>,
    /// Internal nodes in depth-first pre-order; `2^depth − 1` of them.
    nodes: Vec<Node>,
    /// The `2^depth` leaves, left to right: a search from a list of leaves reads their boxes and ranges here.
    leaves: Vec<Leaf>,
    /// Per leaf (same order), what its photons hold for the gather's roulette ([`KdTree::bound_within`]).
    leaf_sums: Vec<LeafSums>,
    depth: u32,
    /// Tight bounds of all photons (the root's box).
    root: Bounds,
    dropped_non_finite: usize,
}

/// Positions as a structure of arrays ([`KdTree::positions`]).
#[derive(Clone, Debug, Default)]
struct Positions {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
}

impl Positions {
    fn new(photons: &[Photon]) -> Self {
        let axis = |a: usize| photons.iter().map(|p| p.position_array()[a]).chain(std::iter::repeat_n(0.0, LEAF_GROUP - 1)).collect();
        Positions { x: axis(0), y: axis(1), z: axis(2) }
    }

    #[cfg(test)]
    fn get(&self, i: usize) -> [f32; 3] {
        [self.x[i], self.y[i], self.z[i]]
    }

    fn memory_bytes(&self) -> usize {
        (self.x.capacity() + self.y.capacity() + self.z.capacity()) * std::mem::size_of::<f32>()
    }
}

/// One neighbour found by [`KdTree::knn`]: squared distance to the query and index into [`KdTree::photons`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbor {
    pub dist2: f32,
    pub index: u32,
}

/// The result of a k-NN query, reusable across queries (its buffer is kept, so steady-state queries do not
/// allocate). Create one per thread with [`KnnResult::default`]: it carries nothing from one query to the
/// next (what a warm start reads is in a [`KnnMemory`]).
#[derive(Clone, Debug, Default)]
pub struct KnnResult {
    /// A 4-ary max-heap on `dist2` while searching; arbitrary order after [`KnnResult::sort_by_distance`].
    heap: Vec<Neighbor>,
    r2: f32,
}

/// What [`KdTree::knn_warm`] remembers of the last [`RECENT`] queries (a ring), and reads to bound the next
/// one's radius. Small and `Copy` (136 bytes), apart from the result buffer: keep one wherever results must
/// not depend on which queries were made elsewhere (the render keeps one per pixel).
#[derive(Clone, Copy, Debug, Default)]
pub struct KnnMemory {
    recent: [Recent; RECENT],
    next: usize,
}

/// Remembered queries of [`KdTree::knn_warm`]. Eye paths of one pixel hit nearby points, but a path's
/// later vertices come between two samples' first hits: a few entries keep the previous sample's.
const RECENT: usize = 4;

/// A query at `p` under the acceptance test named `key` whose k-th photon lies at `r`, or that found fewer
/// than `k` within `r` = its `max_radius` (then `r + |p − p₀|` is no tighter than `max_radius` and the warm
/// start never uses it, while `r − |p − p₀|` still bounds the k-NN radius from below).
#[derive(Clone, Copy, Debug)]
struct Recent {
    p: Vec3,
    r: f32,
    k: usize,
    key: u64,
}

impl Default for Recent {
    fn default() -> Self {
        // k = 0 matches no query (k ≥ 1 is searched).
        Recent { p: Vec3::ZERO, r: f32::INFINITY, k: 0, key: 0 }
    }
}

impl KnnMemory {
    /// Bounds `(lo, hi)` on the distance from `p` to its k-th nearest photon under the acceptance test named
    /// `key`, from the remembered queries of [`KdTree::knn_warm`] with the same `k` and `key` (the triangle
    /// inequality: a query at `p₀` found its k-th at `r₀`, so `r₀ − |p − p₀| ≤ r_k(p) ≤ r₀ + |p − p₀|`);
    /// `(−∞, ∞)` without one. Up to f32 rounding of the distances (a relative 10⁻⁷).
    #[must_use]
    pub fn radius_bounds(&self, p: Vec3, k: usize, key: u64) -> (f32, f32) {
        self.recent.iter().filter(|r| r.k == k && r.key == key).fold((f32::NEG_INFINITY, f32::INFINITY), |(lo, hi), r| {
            let d = r.p.distance(p);
            (lo.max(r.r - d), hi.min(r.r + d))
        })
    }

    /// Remembers the query at `p` (`k`, `key`) whose k-th photon lies at `r`, in place of the oldest.
    fn remember(&mut self, p: Vec3, r: f32, k: usize, key: u64) {
        self.recent[self.next] = Recent { p, r, k, key };
        self.next = (self.next + 1) % RECENT;
    }
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
        self.heap
            .sort_unstable_by(|a, b| a.dist2.total_cmp(&b.dist2).then(a.index.cmp(&b.index)));
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

/// A photon as the build sorts it: its position and its index in the build's input. The records (32 bytes)
/// and their chains ([`PhotonList`]) move once, into tree order, after the sort; a sort over records and
/// chains together would need both in one element (the chain has no room in the record).
#[derive(Clone, Copy, Debug)]
struct Keyed {
    position: [f32; 3],
    index: u32,
}

/// Tight bounds of the photons' positions (parallel for large slices).
fn bounds_of(photons: &[Keyed]) -> Bounds {
    const CHUNK: usize = 1 << 15;
    let seq = |ps: &[Keyed]| ps.iter().fold(Bounds::EMPTY, |b, p| b.grow(&p.position));
    if photons.len() > 2 * CHUNK {
        photons.par_chunks(CHUNK).map(seq).reduce(|| Bounds::EMPTY, Bounds::union)
    } else {
        seq(photons)
    }
}

/// Builds the subtree of height `h` over `photons` (whose tight bounds are `bounds`) into `nodes`, which has
/// exactly `2^h − 1` slots.
fn build_recursive(photons: &mut [Keyed], bounds: Bounds, nodes: &mut [Node], h: u32) {
    debug_assert_eq!(nodes.len(), (1usize << h) - 1);
    if h == 0 {
        return;
    }
    let axis = bounds.largest_axis();
    let mid = photons.len() / 2;
    if mid < photons.len() {
        // total_cmp: a total order that agrees with `<` on the finite positions the tree keeps.
        photons.select_nth_unstable_by(mid, |a, b| a.position[axis].total_cmp(&b.position[axis]));
    }
    let (left, right) = photons.split_at_mut(mid);
    let big = left.len() + right.len() >= PARALLEL_BUILD_THRESHOLD;
    let (bl, br) = if big {
        rayon::join(|| bounds_of(left), || bounds_of(right))
    } else {
        (bounds_of(left), bounds_of(right))
    };
    let (node, rest) = nodes.split_first_mut().expect("h >= 1 so there is a node");
    *node = Node { children: [NodeBox::new(bl), NodeBox::new(br)] };
    let (left_nodes, right_nodes) = rest.split_at_mut((1usize << (h - 1)) - 1);
    if big {
        rayon::join(
            || build_recursive(left, bl, left_nodes, h - 1),
            || build_recursive(right, br, right_nodes, h - 1),
        );
    } else {
        build_recursive(left, bl, left_nodes, h - 1);
        build_recursive(right, br, right_nodes, h - 1);
    }
}

impl KdTree {
    /// Builds the tree with [`DEFAULT_LEAF_SIZE`] photons per leaf. See [`KdTree::build_with_leaf_size`].
    pub fn build(photons: impl Into<PhotonList>) -> Result<Self, KdTreeError> {
        Self::build_with_leaf_size(photons, DEFAULT_LEAF_SIZE)
    }

    /// Builds the tree (in parallel) with at most `leaf_size` photons per leaf, each photon's chain
    /// ([`PhotonList`]) moved with it into [`KdTree::decoded`]. Photons whose position is not finite are
    /// dropped (a bug upstream; counted in [`KdTree::dropped_non_finite`]).
    pub fn build_with_leaf_size(photons: impl Into<PhotonList>, leaf_size: usize) -> Result<Self, KdTreeError> {
        if leaf_size == 0 {
            return Err(KdTreeError::ZeroLeafSize);
        }
        let (input, chains) = photons.into().into_parts();
        let before = input.len();
        if u32::try_from(before).is_err() {
            return Err(KdTreeError::TooManyPhotons { count: before });
        }
        let mut keyed: Vec<Keyed> = input
            .iter()
            .enumerate()
            .filter(|(_, p)| p.position().is_finite())
            .map(|(i, p)| Keyed { position: *p.position_array(), index: i as u32 })
            .collect();
        let dropped_non_finite = before - keyed.len();
        let n = keyed.len();
        let mut depth = 0u32;
        while n.div_ceil(1usize << depth) > leaf_size {
            depth += 1;
        }
        let mut nodes = vec![
            Node {
                children: [NodeBox::new(Bounds::EMPTY); 2]
            };
            (1usize << depth) - 1
        ];
        let root = bounds_of(&keyed);
        build_recursive(&mut keyed, root, &mut nodes, depth);
        // The records and chains in tree order, one move each. At most 82 bytes per photon are held here
        // (the input, the sorted keys, the records in order and the chains), against the 76 of the
        // finished tree's records, positions and decoded photons (`render::memory` estimates 180 a map).
        let photons: Vec<Photon> = keyed.par_iter().map(|k| input[k.index as usize]).collect();
        let chains: Vec<u8> = keyed.par_iter().map(|k| chains[k.index as usize]).collect();
        drop((keyed, input));
        let positions = Positions::new(&photons);
        let decoded: Vec<DecodedPhoton> = photons.par_iter().zip(&chains).map(|(p, &chain)| p.decoded(chain)).collect();
        let mut leaves = Vec::with_capacity(1 << depth);
        collect_leaves(&nodes, 0, depth, 0, n, NodeBox::new(root), &mut leaves);
        let leaf_sums = leaves
            .iter()
            .map(|l| {
                let of_leaf: &[DecodedPhoton] = &decoded[l.lo as usize..l.hi as usize];
                LeafSums { power: of_leaf.iter().map(|d| d.power).sum::<Vec3>().max_element(), dirs: DirBox::of(of_leaf.iter().map(|d| d.wi)) }
            })
            .collect();
        Ok(Self {
            photons,
            positions,
            decoded,
            nodes,
            leaves,
            leaf_sums,
            depth,
            root,
            dropped_non_finite,
        })
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

    /// `photons()[i].decoded(chain)` for every stored photon with its delta chain, decoded once (tree order).
    #[must_use]
    pub fn decoded(&self) -> &[DecodedPhoton] {
        &self.decoded
    }

    /// Bounds of the stored photons' positions (empty box for an empty map).
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        if self.photons.is_empty() {
            Aabb::EMPTY
        } else {
            Aabb {
                min: Vec3::from_array(self.root.min),
                max: Vec3::from_array(self.root.max),
            }
        }
    }

    /// Photons dropped at build time because their position was not finite.
    #[must_use]
    pub fn dropped_non_finite(&self) -> usize {
        self.dropped_non_finite
    }

    /// Heap memory held by the tree, in bytes (photons, their packed positions and decoded records,
    /// nodes).
    #[must_use]
    pub fn memory_bytes(&self) -> usize {
        self.photons.capacity() * std::mem::size_of::<Photon>()
            + self.positions.memory_bytes()
            + self.decoded.capacity() * std::mem::size_of::<DecodedPhoton>()
            + self.nodes.capacity() * std::mem::size_of::<Node>()
            + self.leaves.capacity() * std::mem::size_of::<Leaf>()
            + self.leaf_sums.capacity() * std::mem::size_of::<LeafSums>()
    }

    /// What the photons within `radius` of `p` may hold, from the leaves whose boxes come within `radius`
    /// (a superset of those photons): the largest RGB channel of their summed power, and a box holding
    /// their arrival directions (`lo > hi` when no leaf is in reach). The gather's roulette
    /// bounds an estimate with it (method.md §3.1).
    #[must_use]
    pub fn bound_within(&self, p: Vec3, radius: f32) -> LeavesNear {
        let (q, r2) = (Vec3A::from(p), radius * radius);
        let mut near = LeavesNear { power: 0.0, lo: Vec3::INFINITY, hi: Vec3::NEG_INFINITY };
        let _ = self.walk_leaves(
            |b| b.dist2(q) <= r2,
            |leaf| {
                let sums = &self.leaf_sums[leaf as usize];
                near.power += sums.power;
                (near.lo, near.hi) = (near.lo.min(sums.dirs.min()), near.hi.max(sums.dirs.max()));
                ControlFlow::Continue(())
            },
        );
        near
    }

    /// Visits, left to right, the leaves (by id) under every node whose box passes `near` (a test that a
    /// parent's box passes whenever a child's does: a distance or overlap test), until `visit` breaks.
    /// Depth-first over (node, height, first leaf id); a stack of one entry per level is enough, as a
    /// node's right child waits while its left subtree is walked.
    fn walk_leaves(&self, near: impl Fn(&NodeBox) -> bool, mut visit: impl FnMut(u32) -> ControlFlow<()>) -> ControlFlow<()> {
        if self.photons.is_empty() || !near(&NodeBox::new(self.root)) {
            return ControlFlow::Continue(());
        }
        let mut stack = [(0usize, 0u32, 0u32); 33];
        stack[0] = (0, self.depth, 0);
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (node, h, first) = stack[top];
            if h == 0 {
                visit(first)?;
                continue;
            }
            let [bl, br] = &self.nodes[node].children;
            // Right pushed first: leaves come out left to right.
            if near(br) {
                stack[top] = (node + (1usize << (h - 1)), h - 1, first + (1u32 << (h - 1)));
                top += 1;
            }
            if near(bl) {
                stack[top] = (node + 1, h - 1, first);
                top += 1;
            }
        }
        ControlFlow::Continue(())
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
        self.knn_by_index(p, k, max_radius, |i| accept(&self.photons[i]), out);
    }

    /// [`KdTree::knn`] with the acceptance test given the photon's index into [`KdTree::photons`] (and
    /// [`KdTree::decoded`]): the density estimate tests the pre-decoded direction without touching the
    /// photon record.
    pub fn knn_by_index<F: Fn(usize) -> bool>(&self, p: Vec3, k: usize, max_radius: f32, accept: F, out: &mut KnnResult) {
        self.knn_bounded(p, k, max_radius, None, SearchFrom::Root, &accept, out);
    }

    /// [`KdTree::knn_by_index`] warm-started from the recent queries `memory` holds with the same `k` and
    /// the same acceptance test, which the caller names by `key` (a key shared by two tests costs reruns,
    /// never exactness). A recent query that found k photons within `r` of `p₀` bounds this one's radius by
    /// `r + |p − p₀|`
    /// (the triangle inequality: those k photons lie within it), so the search starts with that limit
    /// instead of `max_radius`: it prunes from the first node, and photons beyond the bound never enter
    /// the heap. The result is the exact k-NN whatever the bound: if k accepted photons lie within it,
    /// the k nearest do too; if fewer do (rounding, or a `key` reused for another test), the search runs
    /// again from `max_radius`. Only the order of the neighbours in the heap (and which of equidistant
    /// photons at the k-th distance is kept) depends on the bound. The query is then remembered in `memory`.
    #[allow(clippy::too_many_arguments)]
    pub fn knn_warm<F: Fn(usize) -> bool + Copy>(&self, p: Vec3, k: usize, max_radius: f32, key: u64, accept: F, memory: &mut KnnMemory, out: &mut KnnResult) {
        self.knn_warm_from(p, k, max_radius, key, SearchFrom::Root, accept, memory, out);
    }

    /// The ids of the leaves whose boxes come within `reach` of the box `[min, max]` along every axis (a
    /// superset of the leaves holding a photon within `reach` of a point of the box), appended to `out` in
    /// left-to-right order; false, with `out` cut back to its length on entry, when there are more than
    /// `cap`.
    pub fn leaves_near_box(&self, min: Vec3, max: Vec3, reach: f32, cap: usize, out: &mut Vec<u32>) -> bool {
        let start = out.len();
        let (lo, hi) = (Vec3A::from(min) - Vec3A::splat(reach), Vec3A::from(max) + Vec3A::splat(reach));
        let walked = self.walk_leaves(
            |b| b.min.cmple(hi).all() && b.max.cmpge(lo).all(),
            |leaf| {
                if out.len() - start == cap {
                    return ControlFlow::Break(());
                }
                out.push(leaf);
                ControlFlow::Continue(())
            },
        );
        if walked.is_break() {
            out.truncate(start);
        }
        walked.is_continue()
    }

    /// [`KdTree::knn_warm`] searching `from` a list of leaves instead of the root when it is given: the
    /// list must hold every leaf with a photon within `max_radius` of `p` (as
    /// [`crate::photon::OccupancyGrid::near`] gives). The result is the same exact k-NN (ties aside);
    /// the leaves are scanned in the list's order, each skipped when its box lies beyond the current limit.
    #[allow(clippy::too_many_arguments)]
    pub fn knn_warm_from<F: Fn(usize) -> bool + Copy>(&self, p: Vec3, k: usize, max_radius: f32, key: u64, from: SearchFrom<'_>, accept: F, memory: &mut KnnMemory, out: &mut KnnResult) {
        let bound = memory.radius_bounds(p, k, key).1;
        // Rounding of r and of the distance could put one of the k photons just outside: a relative margin
        // of 2⁻¹⁶ (far above f32's error, far below what would matter for pruning) makes a rerun rare.
        let bound2 = bound * bound * (1.0 + 1.0 / 65536.0);
        let warm = (bound2 < max_radius * max_radius).then_some(bound2);
        self.knn_bounded(p, k, max_radius, warm, from, accept, out);
        if warm.is_some() && out.heap.len() < k {
            self.knn_bounded(p, k, max_radius, None, from, accept, out);
        }
        if k > 0 && p.is_finite() && max_radius.is_finite() {
            memory.remember(p, out.r2.sqrt(), k, key);
        }
    }

    /// The search of [`KdTree::knn_by_index`], starting with the inclusive limit `warm` on d² instead of
    /// `max_radius²` when given (`warm < max_radius²`; the result then holds the k nearest only if it holds k),
    /// from the root or from a list of leaves ([`KdTree::knn_warm_from`]).
    #[allow(clippy::too_many_arguments)]
    fn knn_bounded<F: Fn(usize) -> bool + Copy>(&self, p: Vec3, k: usize, max_radius: f32, warm: Option<f32>, from: SearchFrom<'_>, accept: F, out: &mut KnnResult) {
        out.heap.clear();
        out.r2 = 0.0;
        if k == 0 {
            return;
        }
        if max_radius.is_nan() || max_radius < 0.0 {
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
        let mut search = Search {
            positions: &self.positions,
            nodes: &self.nodes,
            q: p.to_array(),
            k,
            limit: warm.unwrap_or(max_r2),
            heap: &mut out.heap,
            accept,
        };
        match from {
            SearchFrom::Root => {
                if self.root.dist2(&search.q) <= search.limit {
                    search.descend(self.depth, self.photons.len());
                }
            }
            SearchFrom::Leaves(ids) => {
                let q = Vec3A::from_array(search.q);
                for &id in ids {
                    let leaf = &self.leaves[id as usize];
                    if leaf.bounds.dist2(q) <= search.limit {
                        search.scan_leaf(leaf.lo as usize, leaf.hi as usize);
                    }
                }
            }
        }
        if out.heap.len() == k {
            out.r2 = out.heap[0].dist2;
        }
    }
}

/// State of one k-NN search.
struct Search<'a, F> {
    positions: &'a Positions,
    nodes: &'a [Node],
    q: [f32; 3],
    k: usize,
    /// Inclusive bound on d²: `max_radius²` until k photons are held, then just below the heap's top.
    limit: f32,
    heap: &'a mut Vec<Neighbor>,
    accept: F,
}

impl<F: Fn(usize) -> bool + Copy> Search<'_, F> {
    /// Visits the tree of height `depth` over photons `[0, n)`: depth first, the nearer child first, a
    /// child skipped when its box is beyond the limit (the farther child's box distance is tested again
    /// when its turn comes, against the limit the nearer subtree left). A loop over an explicit stack
    /// (one entry per level at most), not recursion: no call per node.
    fn descend(&mut self, depth: u32, n: usize) {
        // (node, height, lo, hi, box distance) of the farther children still to visit.
        let mut stack = [(0usize, 0u32, 0usize, 0usize, 0.0f32); MAX_DEPTH];
        let mut top = 0;
        let (mut node, mut h, mut lo, mut hi) = (0usize, depth, 0usize, n);
        let q = Vec3A::from_array(self.q);
        loop {
            if h > 0 {
                let [bl, br] = &self.nodes[node].children;
                let (dl, dr) = (bl.dist2(q), br.dist2(q));
                let mid = lo + (hi - lo) / 2;
                let left = (node + 1, h - 1, lo, mid, dl);
                let right = (node + (1usize << (h - 1)), h - 1, mid, hi, dr);
                let (near, far) = if dl <= dr { (left, right) } else { (right, left) };
                if near.4 <= self.limit {
                    // The limit only shrinks: a farther child beyond it now stays beyond it.
                    if far.4 <= self.limit {
                        stack[top] = far;
                        top += 1;
                    }
                    (node, h, lo, hi) = (near.0, near.1, near.2, near.3);
                    continue;
                }
                // The farther child is no nearer than the nearer one: both are beyond the limit.
            } else {
                self.scan_leaf(lo, hi);
            }
            // Next: the most recently deferred child still within the limit.
            loop {
                if top == 0 {
                    return;
                }
                top -= 1;
                let e = stack[top];
                if e.4 <= self.limit {
                    (node, h, lo, hi) = (e.0, e.1, e.2, e.3);
                    break;
                }
            }
        }
    }

    /// Offers the leaf's photons within the limit, in groups of [`LEAF_GROUP`]: the distances of a group
    /// first, four photons per SIMD vector (`Vec4` over the x, y, z arrays: the same f32 operations in the
    /// same order per lane), with a bit mask of those within the limit of the group's start (`movmskps`);
    /// then only those are tested again against the current limit and `accept`.
    #[inline]
    fn scan_leaf(&mut self, lo: usize, hi: usize) {
        let [qx, qy, qz] = self.q.map(Vec4::splat);
        let Positions { x: xs, y: ys, z: zs } = self.positions;
        let mut start = lo;
        while start < hi {
            let len = (hi - start).min(LEAF_GROUP);
            let limit = Vec4::splat(self.limit);
            let mut d2 = [0.0f32; LEAF_GROUP];
            let mut inside = 0u32;
            // Whole vectors: the arrays are padded (`KdTree::positions`); lanes past the leaf are masked off.
            // The group's slices are cut once, so the loop's reads need no bounds checks.
            let end = start + len.div_ceil(4) * 4;
            let groups = xs[start..end].chunks_exact(4).zip(ys[start..end].chunks_exact(4)).zip(zs[start..end].chunks_exact(4));
            for (c, ((x, y), z)) in groups.enumerate() {
                let (dx, dy, dz) = (Vec4::from_slice(x) - qx, Vec4::from_slice(y) - qy, Vec4::from_slice(z) - qz);
                let d = (dx * dx + dy * dy) + dz * dz;
                d.write_to_slice(&mut d2[4 * c..4 * c + 4]);
                inside |= d.cmple(limit).bitmask() << (4 * c);
            }
            // The leaf's photons only (LEAF_GROUP < 32).
            inside &= (1u32 << len) - 1;
            while inside != 0 {
                let j = inside.trailing_zeros() as usize;
                inside &= inside - 1;
                if d2[j] <= self.limit && (self.accept)(start + j) {
                    self.offer(d2[j], (start + j) as u32);
                }
            }
            start += len;
        }
    }

    /// Inserts a photon already known to be closer than the current limit into the bounded max-heap.
    #[inline]
    fn offer(&mut self, dist2: f32, index: u32) {
        let item = Neighbor { dist2, index };
        if self.heap.len() < self.k {
            // Fill phase: append; heapify once when the k-th arrives (Floyd, O(k)).
            self.heap.push(item);
            if self.heap.len() == self.k {
                heapify(self.heap);
                self.limit = below(self.heap[0].dist2);
            }
        } else {
            replace_top(self.heap, item);
            self.limit = below(self.heap[0].dist2);
        }
    }
}

/// The tree's depth at most (photon counts fit u32, leaves hold at least one photon): the size of
/// [`Search::descend`]'s stack.
const MAX_DEPTH: usize = 33;

/// Photons whose distances [`Search::scan_leaf`] computes at once (a leaf of [`DEFAULT_LEAF_SIZE`] is one
/// group; a bit each in a `u32` mask).
const LEAF_GROUP: usize = 16;

/// Children per heap node. A 4-ary heap of k = 50 has 3 levels instead of 6 and the four children share a
/// cache line, so a replacement has half the dependent loads of a binary heap (LaMarca & Ladner 1996, "The
/// influence of caches on the performance of heaps"). Measured: ~5% faster queries at k = 50 than the
/// bottom-up binary heap, which was ~10% faster than the textbook sift-down; the heap is ~40% of the query.
const ARITY: usize = 4;

/// Index of the largest of the children `first .. first + ARITY` (clipped to `n`); `first < n`.
#[inline]
fn largest_child(heap: &[Neighbor], first: usize) -> usize {
    if let Some(g) = heap.get(first..first + 4) {
        // Full group: a branch-free tournament.
        let a = usize::from(g[1].dist2 > g[0].dist2);
        let b = 2 + usize::from(g[3].dist2 > g[2].dist2);
        return first + if g[b].dist2 > g[a].dist2 { b } else { a };
    }
    let end = (first + ARITY).min(heap.len());
    let mut c = first;
    for j in first + 1..end {
        if heap[j].dist2 > heap[c].dist2 {
            c = j;
        }
    }
    c
}

/// Floyd's O(n) construction of an `ARITY`-ary max-heap on `dist2`.
fn heapify(heap: &mut [Neighbor]) {
    if heap.len() < 2 {
        return;
    }
    for start in (0..=(heap.len() - 2) / ARITY).rev() {
        let item = heap[start];
        let mut i = start;
        loop {
            let first = ARITY * i + 1;
            if first >= heap.len() {
                break;
            }
            let c = largest_child(heap, first);
            if heap[c].dist2 <= item.dist2 {
                break;
            }
            heap[i] = heap[c];
            i = c;
        }
        heap[i] = item;
    }
}

/// Replaces the largest element of a non-empty max-heap by `item` (which is no larger), bottom-up: the hole
/// at the root moves down along the largest children to a leaf, then `item` rises from there (Wegener 1993,
/// "Bottom-up heapsort"). A replacing photon is usually near the query, so it rarely rises far.
#[inline]
fn replace_top(heap: &mut [Neighbor], item: Neighbor) {
    let mut i = 0;
    loop {
        let first = ARITY * i + 1;
        if first >= heap.len() {
            break;
        }
        let c = largest_child(heap, first);
        heap[i] = heap[c];
        i = c;
    }
    while i > 0 {
        let parent = (i - 1) / ARITY;
        if heap[parent].dist2 >= item.dist2 {
            break;
        }
        heap[i] = heap[parent];
        i = parent;
    }
    heap[i] = item;
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

    /// Every stored box is the tight box of its photons, and siblings are separated along some axis.
    fn validate(t: &KdTree) {
        fn tight(ps: &[Photon]) -> [f32; 6] {
            let b = ps.iter().fold(Bounds::EMPTY, |b, p| b.grow(p.position_array()));
            [b.min[0], b.min[1], b.min[2], b.max[0], b.max[1], b.max[2]]
        }
        fn flat(b: &Bounds) -> [f32; 6] {
            [b.min[0], b.min[1], b.min[2], b.max[0], b.max[1], b.max[2]]
        }
        fn flat_node(b: &NodeBox) -> [f32; 6] {
            flat(&Bounds { min: b.min.to_array(), max: b.max.to_array() })
        }
        fn rec(t: &KdTree, node: usize, h: u32, lo: usize, hi: usize) {
            if h == 0 {
                return;
            }
            let [bl, br] = &t.nodes[node].children;
            let mid = lo + (hi - lo) / 2;
            assert_eq!(flat_node(bl), tight(&t.photons[lo..mid]));
            assert_eq!(flat_node(br), tight(&t.photons[mid..hi]));
            if lo < mid && mid < hi {
                assert!((0..3).any(|a| bl.max[a] <= br.min[a]), "children not separated by any axis");
            }
            rec(t, node + 1, h - 1, lo, mid);
            rec(t, node + (1 << (h - 1)), h - 1, mid, hi);
        }
        assert_eq!(flat(&t.root), tight(&t.photons));
        rec(t, 0, t.depth, 0, t.len());
    }

    #[test]
    fn heap_operations_keep_the_k_smallest() {
        let mut s = crate::sampler::Sampler::for_key(5, 5, 5);
        for k in [1usize, 2, 3, 4, 5, 6, 7, 21, 50] {
            let all: Vec<f32> = (0..500).map(|_| (s.next_1d() * 20.0).floor()).collect();
            let mut heap: Vec<Neighbor> = all[..k]
                .iter()
                .enumerate()
                .map(|(i, &d)| Neighbor { dist2: d, index: i as u32 })
                .collect();
            heapify(&mut heap);
            for (i, &d) in all.iter().enumerate().skip(k) {
                assert!(
                    (1..heap.len()).all(|c| heap[(c - 1) / ARITY].dist2 >= heap[c].dist2),
                    "heap property"
                );
                if d < heap[0].dist2 {
                    replace_top(&mut heap, Neighbor { dist2: d, index: i as u32 });
                }
            }
            let mut got: Vec<f32> = heap.iter().map(|n| n.dist2).collect();
            got.sort_by(f32::total_cmp);
            let mut want = all.clone();
            want.sort_by(f32::total_cmp);
            assert_eq!(got, want[..k]);
        }
    }

    /// `knn_warm` over a coherent sequence of queries (a walk, as a pixel's samples) gives the k-NN
    /// distances of the cold search, also when one key names two different tests (reruns).
    #[test]
    fn warm_start_is_exact() {
        let mut s = crate::sampler::Sampler::for_key(6, 6, 6);
        let photons: Vec<Photon> = (0..20_000)
            .map(|_| {
                let p = Vec3::new(4.0 * s.next_1d() - 2.0, 0.0, 4.0 * s.next_1d() - 2.0);
                // Half the photons arrive from above, half from below.
                let w = if s.next_1d() < 0.5 { Vec3::Y } else { -Vec3::Y };
                Photon::new(p * (0.2 + p.length()), w, Vec3::ONE, 1.0)
            })
            .collect();
        let t = KdTree::build(photons).unwrap();
        let dirs = t.decoded();
        let (mut warm, mut cold, mut memory) = (KnnResult::default(), KnnResult::default(), KnnMemory::default());
        let mut q = Vec3::ZERO;
        for i in 0..3000 {
            q += Vec3::new(s.next_1d() - 0.5, 0.02 * (s.next_1d() - 0.5), s.next_1d() - 0.5) * 0.05;
            if i % 500 == 0 {
                q = Vec3::new(4.0 * s.next_1d() - 2.0, 0.0, 4.0 * s.next_1d() - 2.0);
            }
            let above = i % 3 != 0;
            let accept = move |j: usize| (dirs[j].wi.y > 0.0) == above;
            // Key 7 for both tests on purpose: the bound of one may hold too few photons of the other.
            let (k, r) = if i % 7 == 0 { (8, 0.05) } else { (50, 0.4) };
            t.knn_warm(q, k, r, 7, accept, &mut memory, &mut warm);
            t.knn_by_index(q, k, r, accept, &mut cold);
            let sorted = |o: &KnnResult| {
                let mut d: Vec<u32> = o.neighbors().iter().map(|n| n.dist2.to_bits()).collect();
                d.sort_unstable();
                d
            };
            assert_eq!(warm.r2().to_bits(), cold.r2().to_bits(), "query {i}");
            assert_eq!(sorted(&warm), sorted(&cold), "query {i}");
            assert!(warm.neighbors().iter().all(|n| accept(n.index as usize)));
        }
    }

    /// `leaves_near_box` lists every leaf holding a photon within `reach` of the box (brute force), in
    /// left-to-right order, and gives up past `cap`.
    #[test]
    fn leaves_near_a_box_hold_every_photon_in_reach() {
        let mut s = crate::sampler::Sampler::for_key(8, 8, 8);
        let photons: Vec<Photon> = (0..5000).map(|_| Photon::new(Vec3::new(s.next_1d(), 0.3 * s.next_1d(), s.next_1d()), Vec3::Z, Vec3::ONE, 1.0)).collect();
        let t = KdTree::build(photons).unwrap();
        let mut ids = Vec::new();
        for _ in 0..500 {
            let min = Vec3::new(s.next_1d(), 0.3 * s.next_1d(), s.next_1d());
            let max = min + Vec3::splat(0.05 * s.next_1d());
            let reach = 0.05 * s.next_1d();
            ids.clear();
            assert!(t.leaves_near_box(min, max, reach, usize::MAX, &mut ids));
            assert!(ids.windows(2).all(|w| w[0] < w[1]), "left to right");
            for (id, leaf) in t.leaves.iter().enumerate() {
                let near = (leaf.lo as usize..leaf.hi as usize).any(|i| {
                    let p = Vec3::from_array(t.positions.get(i));
                    p.cmpge(min - Vec3::splat(reach)).all() && p.cmple(max + Vec3::splat(reach)).all()
                });
                assert!(!near || ids.contains(&(id as u32)), "leaf {id} holds a photon in reach");
            }
            let n = ids.len();
            if n > 0 {
                ids.clear();
                ids.push(u32::MAX);
                assert!(!t.leaves_near_box(min, max, reach, n - 1, &mut ids), "more than the cap");
                assert_eq!(ids, [u32::MAX], "cut back to its length on entry");
            }
        }
    }

    #[test]
    fn node_layout_is_compact() {
        assert_eq!(std::mem::size_of::<Node>(), 64);
        assert_eq!(std::mem::align_of::<Node>(), 64);
    }

    #[test]
    fn box_distance_is_a_lower_bound() {
        let b = Bounds::EMPTY.grow(&[0.0, 1.0, 2.0]).grow(&[1.0, 1.0, 3.0]);
        assert_eq!(b.dist2(&[0.5, 1.0, 2.5]), 0.0);
        assert_eq!(b.dist2(&[2.0, 1.0, 4.0]), 2.0);
        assert_eq!(b.dist2(&[0.5, 0.0, 2.5]), 1.0);
        assert_eq!(Bounds::EMPTY.dist2(&[0.0; 3]), f32::INFINITY);
        assert_eq!(NodeBox::new(Bounds::EMPTY).dist2(Vec3A::ZERO), f32::INFINITY);
        // The node's SIMD distance is the scalar one, bit for bit.
        let mut s = crate::sampler::Sampler::for_key(4, 4, 4);
        for _ in 0..10_000 {
            let mut r = || 8.0 * s.next_1d() - 4.0;
            let bx = Bounds::EMPTY.grow(&[r(), r(), r()]).grow(&[r(), r(), r()]);
            let q = [r(), r(), r()];
            assert_eq!(bx.dist2(&q).to_bits(), NodeBox::new(bx).dist2(Vec3A::from_array(q)).to_bits());
        }
        assert_eq!(b.largest_axis(), 0);
        assert_eq!(Bounds::EMPTY.largest_axis(), 0);
    }

    #[test]
    fn depth_gives_small_leaves() {
        for n in [0usize, 1, 7, 8, 9, 100, 1000] {
            let photons: Vec<Photon> = (0..n)
                .map(|i| Photon::new(Vec3::new(i as f32, 0.0, 0.0), Vec3::Z, Vec3::ONE, 1.0))
                .collect();
            let t = KdTree::build_with_leaf_size(photons, 8).unwrap();
            assert_eq!(t.len(), n);
            assert!(n.div_ceil(1 << t.depth) <= 8);
            assert!(t.depth == 0 || n.div_ceil(1 << (t.depth - 1)) > 8);
            assert_eq!(t.nodes.len(), (1 << t.depth) - 1);
            validate(&t);
        }
        assert!(matches!(
            KdTree::build_with_leaf_size(Vec::new(), 0),
            Err(KdTreeError::ZeroLeafSize)
        ));
    }

    #[test]
    fn large_parallel_build_is_valid_and_drops_non_finite() {
        let mut s = crate::sampler::Sampler::for_key(9, 0, 0);
        let mut photons: Vec<Photon> = (0..100_000)
            .map(|_| {
                Photon::new(
                    Vec3::new(s.next_1d(), s.next_1d() * 0.1, (s.next_1d() * 8.0).floor()),
                    Vec3::Z,
                    Vec3::ONE,
                    1.0,
                )
            })
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

    /// Each photon's chain reaches [`KdTree::decoded`] beside it, non-finite photons dropped with theirs;
    /// and the tree order is the one a selection over the records themselves gives (the build sorts
    /// position-and-index keys instead, [`Keyed`]): the order of every estimate's sum, hence every image,
    /// is what it was before chains existed. Coordinates on a coarse grid make many ties; 40,000 photons
    /// take the parallel path of the build.
    #[test]
    fn chains_follow_their_photons_and_the_order_is_the_records() {
        let mut s = crate::sampler::Sampler::for_key(10, 0, 0);
        let mut list = PhotonList::default();
        for i in 0..40_000u32 {
            let chain = 1 + i % crate::photon::MAX_DELTA_CHAIN;
            let p = Vec3::new((s.next_1d() * 20.0).floor(), (s.next_1d() * 3.0).floor(), s.next_1d());
            // The power names the chain, so that the test can read it back from the record.
            list.push(Photon::new(p, Vec3::Z, Vec3::splat(chain as f32), 1.0), chain);
            if i % 10_000 == 0 {
                list.push(Photon::new(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Z, Vec3::splat(99.0), 1.0), 3);
            }
        }
        let t = KdTree::build(list.clone()).unwrap();
        assert_eq!((t.len(), t.dropped_non_finite()), (40_000, 4));
        for (p, d) in t.photons().iter().zip(t.decoded()) {
            assert_eq!(u32::from(d.chain), p.power().x as u32);
            assert_eq!(*d, p.decoded(d.chain));
        }
        // The build as it was: the records themselves selected at each node's median.
        fn select(photons: &mut [Photon], h: u32) {
            if h == 0 {
                return;
            }
            let axis = photons.iter().fold(Bounds::EMPTY, |b, p| b.grow(p.position_array())).largest_axis();
            let mid = photons.len() / 2;
            if mid < photons.len() {
                photons.select_nth_unstable_by(mid, |a, b| a.position_array()[axis].total_cmp(&b.position_array()[axis]));
            }
            let (left, right) = photons.split_at_mut(mid);
            select(left, h - 1);
            select(right, h - 1);
        }
        let mut records: Vec<Photon> = list.photons().iter().copied().filter(|p| p.position().is_finite()).collect();
        select(&mut records, t.depth);
        assert!(records == t.photons(), "the tree order differs from a selection over the records");
    }
}
